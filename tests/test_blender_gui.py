"""Blender 3.4.1 in a real window under Xvfb: the add-on enabled, the Weathervane tab open beside the built vane, the
tracer as the render engine (its Render and Output Properties, F12, the 3D View in Rendered shading), a foreign scene
added with Blender's own operators (Suzanne with subdivision, a text, a collection instance) in F12 and the Rendered
view, screenshots in out/, and no Python error from any draw or operator in Blender's log."""

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
FOREIGN_F12 = SCREENSHOT.with_name("weathervane-gui-foreign-f12.png")
FOREIGN_VIEW = SCREENSHOT.with_name("weathervane-gui-foreign-rendered.png")


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
    for stale in (SCREENSHOT, FOREIGN_F12, FOREIGN_VIEW):
        stale.unlink(missing_ok=True)
    result = subprocess.run(
        [
            XVFB,
            "-a",
            "-s",
            "-screen 0 1600x900x24",
            BLENDER,
            "--enable-event-simulate",  # the session's keys (numpad orbit, Space, N) sent with Window.event_simulate
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
        timeout=420,  # 1.5-4 minutes on the 2-core machine, with others' work beside it
        cwd=tmp_path,
    )
    log = result.stdout + result.stderr
    assert result.returncode == 0, log[-4000:]
    # Blender was quit during an F12: nothing of Blender's memory leaked, and no worker process outlives it
    assert "WEATHERVANE-GUI quitting during F12" in log, log[-4000:]
    assert "Not freed memory blocks" not in log, log[-4000:]
    check_no_worker_left(config)
    assert "WEATHERVANE-GUI built" in log and "WEATHERVANE-GUI screenshot" in log, log[-4000:]
    assert "WEATHERVANE-GUI undo and redo" in log, log[-4000:]
    assert "WEATHERVANE-GUI export menu" in log, log[-4000:]
    # every number field's label and value fit the sidebar at its default width (measured with the UI font)
    print(*(line for line in log.splitlines() if line.startswith("WEATHERVANE-GUI")), sep="\n")
    # every text of every panel (open) in every state fits its room at the sidebar's and Properties' default widths,
    # and every tooltip is one whole line (tests/addon/gui_measure.py)
    assert "WEATHERVANE-GUI labels fit" in log, log[-4000:]
    assert "WEATHERVANE-GUI tooltips one line" in log, log[-4000:]
    # Scene Conversion with the longest note (a missing world picture's, with its path) at the Properties editor's
    # width: every line fits, and each line's tooltip is its whole note
    assert "WEATHERVANE-GUI scene conversion notes fit" in log, log[-4000:]
    assert "WEATHERVANE-GUI scene conversion notes whole" in log, log[-4000:]
    assert SCREENSHOT.with_name("weathervane-gui-conversion.png").exists()
    for page in (1, 2, 3):
        assert SCREENSHOT.with_name(f"weathervane-gui-sidebar-{page}.png").exists()
    # no Python error anywhere before the quit; at the quit, only Blender 3.4's readonly state (below)
    before, _, at_quit = log.partition("WEATHERVANE-GUI quitting during F12")
    assert "Traceback" not in before and "Error: Python" not in before, before[-4000:]
    check_quit_errors(at_quit)
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
    # a light's type changed in Blender's Light tab is what Export writes and what the sidebar shows
    assert "WEATHERVANE-GUI light type changed in the Light tab: exported" in log, log[-4000:]
    # a small edit in the Rendered view: only the new scene's status lines were drawn, up to the edited image
    assert "WEATHERVANE-GUI small edit in the Rendered view" in log, log[-4000:]
    assert "WEATHERVANE-GUI rendered view stopped with Solid shading" in log
    check_f12_is_the_command_lines_png(tmp_path)
    check_rendered_view_is_the_tracers_image(tmp_path, SCREENSHOT.with_name("weathervane-gui-rendered.png"))
    assert "WEATHERVANE-GUI foreign scene added" in log and "foreign rendered screenshot" in log, log[-4000:]
    check_foreign_scene(tmp_path)
    check_latencies(log)
    check_material_tab_colour_in_f12(tmp_path)
    check_memory_refusal(log)


LATENCIES = (
    "f12-factory-cube-1920x1080",  # F12 of the factory scene at Blender's default size, key to the job's end
    # the artist's scene (the vane, a glass sphere and an area light at F12's Shadows 16), the view at its default
    # Viewport samples: from the change to ...
    "glass-ior-drawn",  # ... the engine's first draw after it ("updating", or the change's first level)
    "glass-ior-taken",  # ... the status text's first change on screen (the edit seen to be taken)
    "glass-ior-first-image",  # ... the first image on screen (the glass's IOR set as its Material tab sets it)
    "glass-ior",  # ... its finished image
    "glass-moved-drawn",  # the glass sphere moved 0.3 m, likewise
    "glass-moved-taken",
    "glass-moved-first-image",
    "glass-moved",
    "orbit-drawn",  # numpad 4 over the view, likewise
    "orbit-taken",
    "orbit-first-image",
    "orbit",
    "playback",  # Space over 10 keyed frames: seconds a frame, new images on screen
    "load",  # the 1-minute load average during the measurements (the highest of three)
    "f12-material-tab-colour",  # F12 at 320x240 after a colour edit in the Material tab
)
# The live view's bars at load < 2 (seconds; playback: seconds a frame, 4 images a second), reported by the test beside
# what it measured (docs/blender.md quotes the figures). They are not asserted as they are: the machines that run
# `make test` are shared, and one CI run at load 2.7 finished a move in 4.2 s. What the test asserts is the live view
# itself: each change answered within GUARD times its bar (times load / 2 above a load of 2), so that a view that
# traces a change at F12's samples again (8-9 s a change before the view had samples of its own, its first image after
# 2.5-5.7 s) fails it.
BARS = {"drawn": 0.2, "first-image": 0.5, "finished": 3.0, "playback": 0.25}
GUARD = 2.0
# From a draw to the screen: Blender's draw of the window in software OpenGL after the engine's part (0.13-0.2 s
# measured at load 1.5-2), which no engine shortens: "updating" on screen is measured against the bar plus this
DRAW_TO_SCREEN = 0.15


def check_latencies(log: str) -> None:
    """What the user sees, from the session (tests/addon/gui_session.py reads the view's pixels and its status text
    from the X server): every change reached the screen (the session asserts it), playback showed new images, and on
    the artist's scene each change was answered within GUARD times the issue's bars (the engine's draw of "updating"
    0.2 s, the screen showing it DRAW_TO_SCREEN later, the first image 0.5 s, the finished one 3 s, playback 4 images
    a second; medians of 3, times load / 2 above a load of 2). Prints each figure against its bar."""
    import re

    found = dict(re.findall(r"^WEATHERVANE-GUI latency (\S+) ([0-9.]+|inf)", log, flags=re.MULTILINE))
    assert sorted(found) == sorted(LATENCIES), (found, log[-4000:])
    assert all(float(value) > 0 for value in found.values()), found
    assert found["playback"] != "inf", "no new image on screen while the animation played"
    scale = max(1.0, float(found["load"]) / 2.0)
    bars = {}
    for change in ("glass-ior", "glass-moved", "orbit"):
        bars[f"{change}-drawn"] = BARS["drawn"]
        bars[f"{change}-taken"] = BARS["drawn"] + DRAW_TO_SCREEN
        bars[f"{change}-first-image"] = BARS["first-image"]
        bars[change] = BARS["finished"]
    bars["playback"] = BARS["playback"]
    for name, bar in bars.items():
        seconds = float(found[name])
        within = "within" if seconds <= bar else "over"
        print(f"WEATHERVANE-GUI bar {name} {seconds:.3f} s, {within} the bar {bar:.2f} s (load {found['load']})")
    for name, bar in bars.items():
        assert float(found[name]) <= GUARD * scale * bar, (name, found)


def check_material_tab_colour_in_f12(work: Path) -> None:
    """The tail fin's Color set in the Material tab (its "WV Surface" node) to (0.05, 0.1, 0.9): F12's pixels of the
    fin moved toward blue (its previous colour was red-orange), and the sidebar shows the same colour."""
    figures = json.loads((work / "material-tab.json").read_text())
    assert figures["changed"] >= 20, figures  # a 320x240 F12: the fin spans dozens of pixels
    before, after = np.array(figures["before"]), np.array(figures["after"])
    assert after[2] - before[2] >= 30 and before[0] - after[0] >= 30, figures
    assert np.allclose(figures["sidebar"], figures["colour"], atol=1e-6), figures


def check_memory_refusal(log: str) -> None:
    """A level-7 subdivided cube with 300 MB free (faked in the add-on's tracer): the Rendered view showed the one
    refusal line naming the figures (wrapped to the view) and traced nothing, the window answered a key, and F12 was
    refused with that line and wrote nothing; F12 with the render window showed the whole line over its empty image,
    and the Info editor held it (tests/addon/gui_session.py measures each line with Blender's font and reads the
    render window's pixels back)."""
    lines = [line for line in log.splitlines() if line.startswith("WEATHERVANE-GUI memory refusal")]
    assert len(lines) == 3, (lines, log[-4000:])
    view, answered, f12 = lines
    assert "1 line, traced nothing: Weathervane Tracer: not started: a " in view, view
    assert "196,608 triangles needs about" in view and "300.0 MB is available" in view, view
    assert "Subdivision" in view and "Cube (" in view, view
    assert "the window answered N over the view in" in answered, answered
    assert "nothing written: " in f12 and "Weathervane Tracer: not started: a " in f12, f12
    assert "196,608 triangles needs about" in f12 and "300.0 MB is available" in f12, f12
    # the whole refusal where the user looks: the Rendered view's text, the render window over its empty image, the
    # Info editor; the status bar's line (the last report) short enough for the bar
    (view_text,) = [line for line in log.splitlines() if "refusal in the Rendered view's text" in line]
    assert "lines, the whole refusal, the widest" in view_text, view_text
    (window,) = [line for line in log.splitlines() if line.startswith("WEATHERVANE-GUI refusal in the render window")]
    assert "lines, the whole refusal, the widest" in window, window
    (info,) = [line for line in log.splitlines() if line.startswith("WEATHERVANE-GUI refusal in the Info editor")]
    assert "Info editor: whole; the last report (the status bar's) is the short line" in info, info
    assert "not enough memory: needs about" in info, info
    for name in ("refusal-view", "render-window"):
        assert SCREENSHOT.with_name(f"weathervane-gui-{name}.png").exists(), name


def check_quit_errors(at_quit: str) -> None:
    """Blender 3.4 keeps one process-wide "Python may not write" flag, saved and restored around every Python
    callback: a render engine's render() on the F12 job's thread that starts while a panel draws on the main thread
    restores it to "readonly" when it ends, and Blender's quit then cannot unregister any add-on ("can't run in readonly
    state": seen in one of six quits here, a run with the base code's pools; the mechanism is inferred, not traced).
    That, and nothing else, may be in the log after the quit; the worker processes are checked separately (none may
    be left either way)."""
    blocks = at_quit.split("Traceback (most recent call last):")[1:]
    for block in blocks:
        assert "addon_utils.py" in block and "can't run in readonly state" in block, block[:2000]
    print(f"WEATHERVANE-GUI add-ons that could not unregister at the quit (Blender's readonly state): {len(blocks)}")


def check_no_worker_left(config: Path) -> None:
    """No process with this Blender's environment (its worker processes inherit BLENDER_USER_CONFIG) is left once
    Blender has exited: none started while it quit, none lingering (given a second for the last ones to be reaped)."""
    import time

    marker = f"BLENDER_USER_CONFIG={config}".encode()

    def left() -> list[int]:
        pids = []
        for entry in Path("/proc").iterdir():
            if entry.name.isdigit():
                try:
                    environment = (entry / "environ").read_bytes().split(b"\0")
                except OSError:
                    continue
                if marker in environment:
                    pids.append(int(entry.name))
        return pids

    started = time.perf_counter()
    while left() and time.perf_counter() - started < 1.0:
        time.sleep(0.1)
    pids = left()
    commands = [Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")[:200] for pid in pids]
    print(f"WEATHERVANE-GUI processes left after Blender quit during F12: {len(pids)} {commands}")
    assert not pids, commands


def covered(empty: np.ndarray, shown: np.ndarray, box: list, name: str, where: str) -> None:
    """The pixels inside an object's projected bounding box that differ from the image without the new objects
    (shadows and reflections differ too, but only on the ground): enough of them, spanning the box's width and
    height, so that the object is drawn where Blender projects it and at its size."""
    changed = np.abs(shown.astype(int) - empty.astype(int)).max(axis=2) > 3
    left, top = max(0, int(np.floor(box[0]))), max(0, int(np.floor(box[1])))
    right, bottom = min(changed.shape[1], int(np.ceil(box[2]))), min(changed.shape[0], int(np.ceil(box[3])))
    assert right - left >= 20 and bottom - top >= 20, (name, where, box)  # inside the image, and big enough
    inside = changed[top:bottom, left:right]
    rows, columns = np.nonzero(inside)
    fill = inside.mean()
    spans = (
        (columns.max() + 1 - columns.min()) / inside.shape[1] if fill else 0.0,
        (rows.max() + 1 - rows.min()) / inside.shape[0] if fill else 0.0,
    )
    print(
        f"WEATHERVANE-GUI foreign {where} {name}: box {inside.shape[1]}x{inside.shape[0]} px, {100 * fill:.0f}% "
        f"drawn, spanning {100 * spans[0]:.0f}% of its width and {100 * spans[1]:.0f}% of its height"
    )
    assert fill >= 0.2 and min(spans) >= 0.7, (name, where, fill, spans)


def check_foreign_scene(work: Path) -> None:
    """Suzanne with a Subdivision Surface modifier, a text and a collection instance of a cone, added with Blender's
    own operators: in F12 (against F12 of the vane alone) and in the Rendered view (against its first screenshot),
    each drawn over its bounding box as Blender's camera and view projections place it."""
    places = json.loads((work / "foreign.json").read_text())
    with Image.open(work / "foreign-f12-empty.png") as empty, Image.open(FOREIGN_F12) as shown:
        empty_f12, shown_f12 = np.asarray(empty.convert("RGB")), np.asarray(shown.convert("RGB"))
    assert shown_f12.shape == empty_f12.shape == (places["f12"]["size"][1], places["f12"]["size"][0], 3)
    for name, box in places["f12"]["boxes"].items():
        covered(empty_f12, shown_f12, box, name, "f12")
    # the view is laid out as for the first Rendered screenshot: the same region, only the new objects differ
    first = json.loads((work / "rendered-region.json").read_text())
    first.pop("hud", None)
    assert places["view"]["region"] == first, (places["view"]["region"], first)
    with Image.open(SCREENSHOT.with_name("weathervane-gui-rendered.png")) as empty, Image.open(FOREIGN_VIEW) as shown:
        empty_view, shown_view = np.asarray(empty.convert("RGB")), np.asarray(shown.convert("RGB"))
    for name, box in places["view"]["boxes"].items():
        covered(empty_view, shown_view, box, name, "rendered view")


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
    shown = shown.copy()
    for x, y, width, height in place.get("hud", []):  # the last operator's panel over the view: not compared
        left, hud_top = x - place["x"], place["window"] - y - height - top
        shown[max(0, hud_top) : hud_top + height, max(0, left) : left + width] = 0
        expected[max(0, hud_top) : hud_top + height, max(0, left) : left + width] = 0
    # Blender draws the area's border and rounded corners (and the corners' split widgets) over the view's edge
    margin = 10
    shown, expected = shown[margin:-margin, margin:-margin], expected[margin:-margin, margin:-margin]
    psnr = peak_signal_noise_ratio(expected, shown, data_range=255)
    print(f"WEATHERVANE-GUI rendered view {place['width']}x{place['height']}: PSNR {psnr:.1f} dB against the tracer")
    assert psnr >= 30.0
