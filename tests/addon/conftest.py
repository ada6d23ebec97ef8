"""Add-on tests run in Blender 5.0 (the bpy wheel, under plain pytest) and in Blender 3.4 (run_in_blender.py).

Each test starts from factory settings with the add-on registered, and unregisters it after.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

bpy = pytest.importorskip("bpy", reason="Blender's Python module: make test installs the bpy wheel")


@pytest.fixture(autouse=True)
def blender():
    """A clean Blender with the add-on registered."""
    import addon

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    yield bpy
    addon.unregister()
    bpy.ops.wm.read_factory_settings(use_empty=True)
