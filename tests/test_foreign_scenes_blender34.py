"""The foreign-scene acceptance suite (tests/addon/test_foreign_scenes.py: geometry, frames and visibility;
materials, lights and world) inside Debian's Blender 3.4.1, run once through tests/addon/run_in_blender.py as the
other add-on tests are, reported here per scene: a failure names the scene and carries the inner failures' lines and
the numbers measured in 3.4.1."""

from __future__ import annotations

import atexit
import functools
import json
import os
import re
import shutil
import tempfile
from concurrent.futures import Future
from pathlib import Path

import pytest

from tests.addon.foreign_scenes import SCENES
from tests.conftest import in_background

ROOT = Path(__file__).resolve().parents[1]
BLENDER = shutil.which("blender")
CHECKED = [name for name in SCENES if name != "flat_suzanne"]  # flat_suzanne is smooth_suzanne's Cycles reference


@functools.cache
def report_folder() -> Path:
    """Where the run in 3.4.1 writes its numbers and its pytest's temporaries (removed when this process exits)."""
    folder = Path(tempfile.mkdtemp(prefix="weathervane-foreign34-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def background_runs() -> Future | None:
    """The suite in Blender 3.4.1, queued in the session's background runs (tests/conftest.py) -> the future of its
    subprocess.CompletedProcess; None without Debian's blender."""
    if BLENDER is None:
        return None
    environment = {
        **os.environ,
        "WEATHERVANE_FOREIGN_SCENES": "1",
        "WEATHERVANE_FOREIGN_REPORT": str(report_folder() / "measured.json"),
    }
    environment["COLUMNS"] = "400"  # the short summary keeps each failure's message
    command = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1"]
    command += ["--python", str(ROOT / "tests" / "addon" / "run_in_blender.py"), "--"]
    command += [
        "-q",
        "-rA",
        "--basetemp",
        str(report_folder() / "tmp"),
        str(ROOT / "tests" / "addon" / "test_foreign_scenes.py"),
    ]
    return in_background("foreign scenes 3.4.1", command, cwd=ROOT, env=environment, timeout=600)


@pytest.fixture(scope="module")
def inner() -> dict:
    """The suite's outcome in Blender 3.4.1: {"outcomes": {test id: (outcome, line)}, "measured": {...}, ...}."""
    running = background_runs()
    if running is None:
        pytest.skip("Debian's blender (3.4.1) is not installed: `make test` installs it with apt-get as root")
    run = running.result()
    assert "Blender 3.4" in run.stdout, run.stdout[-2000:] + run.stderr[-2000:]
    outcomes = {}
    for line in run.stdout.splitlines():
        found = re.match(r"^(PASSED|FAILED|ERROR|SKIPPED) \S*test_foreign_scenes\.py::(\S+)", line)
        if found:
            outcomes[found.group(2)] = (found.group(1), line)
    assert outcomes, run.stdout[-3000:] + run.stderr[-3000:]
    report = report_folder() / "measured.json"
    measured = json.loads(report.read_text()) if report.exists() else {}
    return {"outcomes": outcomes, "measured": measured, "tail": run.stdout[-1500:]}


@pytest.mark.parametrize("name", CHECKED)
def test_foreign_scene_in_blender_34(inner: dict, name: str) -> None:
    mine = {test: result for test, result in inner["outcomes"].items() if test.endswith(f"[{name}]")}
    assert mine, f"{name}: no test of the scene ran in Blender 3.4.1\n{inner['tail']}"
    failed = [line for outcome, line in mine.values() if outcome != "PASSED"]
    numbers = inner["measured"].get("scenes", {}).get(name, {})
    assert not failed, f"{name} in Blender 3.4.1: measured {numbers}\n" + "\n".join(failed)
