"""Shared fixtures (the built add-on zips) and the session's order: the runs of whole suites in other Blenders (the
add-on suite in each Blender, the foreign scenes in Debian's 3.4.1) start in the background as the tests are collected,
one at a time, the tests that wait for them come after every other test, and the real-window test comes last, alone on
the machine (it measures the Rendered view's latencies)."""

from __future__ import annotations

import subprocess
import sys
from concurrent.futures import Future, ThreadPoolExecutor
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


# the tests that wait for a background run (a module's background_runs()), then the real-window test
RUN_LAST = (
    (
        "tests/test_blender.py::test_addon_suite_passes",
        "tests/test_foreign_scenes_blender34.py::",
    ),
    ("tests/test_blender_gui.py::",),
)
_background = ThreadPoolExecutor(max_workers=1)  # one Blender at a time, on the core pytest's own tests leave idle
_started: dict[str, Future] = {}


def in_background(name: str, command: list[str], **options) -> Future:
    """A subprocess run (subprocess.run's keywords) started once by name in the session's background queue ->
    the future of its CompletedProcess."""
    if name not in _started:
        _started[name] = _background.submit(subprocess.run, command, capture_output=True, text=True, **options)
    return _started[name]


@pytest.hookimpl(trylast=True)  # after -k and -m have deselected theirs
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The waiting tests and then the real-window test moved to the end (a stable sort keeps the rest in order),
    and the background runs of each module with a waiting test collected started, in the order of their tests."""

    def rank(item: pytest.Item) -> int:
        return next((place + 1 for place, group in enumerate(RUN_LAST) if item.nodeid.startswith(group)), 0)

    items.sort(key=rank)
    if config.option.collectonly:
        return
    modules = dict.fromkeys(item.module for item in items if rank(item) == 1)
    for module in modules:
        module.background_runs()


def pytest_sessionfinish(session: pytest.Session) -> None:
    _background.shutdown(wait=False, cancel_futures=True)
