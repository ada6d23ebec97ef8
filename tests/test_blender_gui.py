"""Blender 3.4.1 in a real window under Xvfb: the add-on enabled, the Weathervane tab open beside the built vane, a
screenshot in out/, and no Python error from any draw or operator in Blender's log."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
BLENDER, XVFB = shutil.which("blender"), shutil.which("xvfb-run")
SCREENSHOT = ROOT / "out" / "weathervane-gui.png"


@pytest.mark.skipif(
    BLENDER is None or XVFB is None,
    reason="Debian's blender and xvfb are not installed: `make test` installs them with apt-get as root",
)
def test_panel_beside_the_built_vane_in_a_real_window(dist: Path, tmp_path: Path) -> None:
    (legacy,) = dist.glob("weathervane-*-blender-3.4.zip")
    config, scripts = tmp_path / "config", tmp_path / "scripts"
    config.mkdir()
    scripts.mkdir()
    environment = {**os.environ, "BLENDER_USER_CONFIG": str(config), "BLENDER_USER_SCRIPTS": str(scripts)}
    # preferences without the splash screen, so that nothing covers the view
    subprocess.run(
        [
            BLENDER,
            "-b",
            "--python-expr",
            "import bpy; bpy.context.preferences.view.show_splash = False; bpy.ops.wm.save_userpref()",
        ],
        env=environment,
        capture_output=True,
        timeout=120,
        check=True,
    )
    SCREENSHOT.parent.mkdir(exist_ok=True)
    SCREENSHOT.unlink(missing_ok=True)
    result = subprocess.run(
        [
            XVFB,
            "-a",
            "-s",
            "-screen 0 1600x900x24",
            BLENDER,
            "--python",
            str(ROOT / "tests" / "addon" / "gui_session.py"),
            "--",
            str(legacy),
            str(SCREENSHOT),
        ],
        env=environment,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    log = result.stdout + result.stderr
    assert result.returncode == 0, log[-4000:]
    assert "WEATHERVANE-GUI built" in log and "WEATHERVANE-GUI screenshot" in log, log[-4000:]
    assert "WEATHERVANE-GUI undo and redo" in log, log[-4000:]
    assert "WEATHERVANE-GUI export menu" in log, log[-4000:]
    # every number field's label and value fit the sidebar at its default width (measured with the UI font)
    print(*(line for line in log.splitlines() if line.startswith("WEATHERVANE-GUI")), sep="\n")
    assert "WEATHERVANE-GUI labels fit" in log, log[-4000:]
    assert "Traceback" not in log and "Error: Python" not in log, log[-4000:]
    with Image.open(SCREENSHOT) as image:
        assert image.size == (1600, 900)
        colors = image.convert("RGB").getcolors(maxcolors=1 << 20)
        assert colors is not None and len(colors) > 1000  # a drawn window, not a blank screen
