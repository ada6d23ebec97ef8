"""Running the headless scripts both ways, for tests: on this Python (the bpy wheel) and inside Blender 3.4."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLENDER = shutil.which("blender")


def in_python(script: str, *args: str) -> subprocess.CompletedProcess:
    """python scripts/<script> ARGS."""
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / script), *args], capture_output=True, text=True, timeout=600, cwd=ROOT
    )


def in_blender(script: str, *args: str, blend: Path | None = None) -> subprocess.CompletedProcess:
    """blender -b [FILE.blend | --factory-startup] --python scripts/<script> -- ARGS (Debian's Blender 3.4.1)."""
    assert BLENDER is not None
    # this process's Python settings (a venv's) must not leak into Blender's own Python
    environment = {key: value for key, value in os.environ.items() if not key.startswith("PYTHON")}
    opening = [str(blend)] if blend is not None else ["--factory-startup"]
    return subprocess.run(
        [BLENDER, "-b", *opening, "--python-exit-code", "1", "--python", str(ROOT / "scripts" / script), "--", *args],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        env=environment,
    )
