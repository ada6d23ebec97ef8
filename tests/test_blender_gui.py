"""Blender 3.4.1 in a real window under Xvfb: the add-on enabled, the Weathervane tab open beside the built vane, the
tracer as the render engine (its Render and Output Properties, F12, the 3D View in Rendered shading), screenshots in
out/, and no Python error from any draw or operator in Blender's log."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
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
            str(tmp_path),
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
    # Output Properties hold Blender's own Format, Frame Range and Output panels for the tracer
    assert "WEATHERVANE-GUI output panels RENDER_PT_format RENDER_PT_frame_range RENDER_PT_output" in log
    assert SCREENSHOT.with_name("weathervane-gui-output.png").exists()
    # Material, Light, World and Object Data Properties hold Blender's own panels for the tracer, as for Cycles
    for tab in ("material-part", "data-light", "world-part", "data-part"):
        assert f"WEATHERVANE-GUI shading panels {tab.replace('-', ' ')}" in log, log[-4000:]
        assert SCREENSHOT.with_name(f"weathervane-gui-{tab}.png").exists(), tab
    assert "WEATHERVANE-GUI rendered view stopped with Solid shading" in log
    check_f12_is_the_command_lines_png(tmp_path)
    check_rendered_view_is_the_tracers_image(tmp_path, SCREENSHOT.with_name("weathervane-gui-rendered.png"))


def check_f12_is_the_command_lines_png(work: Path) -> None:
    """F12's image, saved by Blender as PNG, against `python -m tracer render --srgb` of the scene exported then."""
    cli = work / "cli.png"
    command = [sys.executable, "-m", "tracer", "render", str(work / "f12-scene.json"), "-o", str(cli), "--srgb"]
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True, timeout=300)
    with Image.open(work / "f12.png") as f12, Image.open(cli) as expected:
        difference = np.abs(np.asarray(f12.convert("RGB"), int) - np.asarray(expected.convert("RGB"), int))
    assert difference.shape == (48, 64, 3) and difference.max() <= 1, difference.max()


def check_rendered_view_is_the_tracers_image(work: Path, screenshot: Path) -> None:
    """The view's pixels on screen against the tracer's own render of the scene from that view at that size."""
    from skimage.metrics import peak_signal_noise_ratio

    from tracer.scene.loader import load_scene
    from tracer.tracing.images import to_8bit
    from tracer.workers.parallel import render

    place = json.loads((work / "rendered-region.json").read_text())
    top = place["window"] - place["y"] - place["height"]  # Blender counts window rows from the bottom
    with Image.open(screenshot) as image:
        shown = np.asarray(image.convert("RGB"))[top : top + place["height"], place["x"] : place["x"] + place["width"]]
    expected = to_8bit(render(load_scene(work / "rendered-scene.json"), workers=2).image, srgb=True)
    assert shown.shape == expected.shape
    # Blender draws the area's border and rounded corners (and the corners' split widgets) over the view's edge
    margin = 10
    shown, expected = shown[margin:-margin, margin:-margin], expected[margin:-margin, margin:-margin]
    psnr = peak_signal_noise_ratio(expected, shown, data_range=255)
    print(f"WEATHERVANE-GUI rendered view {place['width']}x{place['height']}: PSNR {psnr:.1f} dB against the tracer")
    assert psnr >= 30.0
