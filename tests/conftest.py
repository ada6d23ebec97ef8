"""Shared fixtures: the built add-on zips."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """dist/ as `make addon` writes it (the extension zip and the Blender 3.4 zip), in a temporary folder."""
    pytest.importorskip("bpy", reason="the bpy wheel carries Blender's extension builder")
    folder = tmp_path_factory.mktemp("dist")
    result = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "build_addon.py"), "--dist", str(folder)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return folder
