"""Shared fixtures (the built add-on zips) and the session's order: the add-on suites in the other Blenders start in the
background as the tests are collected, the tests that wait for them come after every other test, and the real-window
test comes last, alone on the machine (it measures the Rendered view's latencies)."""

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


RUN_LAST = ("tests/test_blender.py::test_addon_suite_passes", "tests/test_blender_gui.py::")


@pytest.hookimpl(trylast=True)  # after -k and -m have deselected theirs
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The suites' waiting tests and then the real-window test moved to the end (a stable sort keeps the rest in
    order), and the suites started if any of their tests was collected."""

    def rank(item: pytest.Item) -> int:
        return next((place + 1 for place, start in enumerate(RUN_LAST) if item.nodeid.startswith(start)), 0)

    items.sort(key=rank)
    waiting = [item for item in items if rank(item) == 1]
    if waiting and not config.option.collectonly:
        waiting[0].module._suites()
