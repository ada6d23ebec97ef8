"""Blender exits cleanly once the add-on ran in it: enabled from a script, after an F12, after an animation, and
after Ctrl+C during an animation, in Debian's Blender 3.4.1 and in every bpy wheel; no crash report is written.

Blender 3.4.1 used to exit with a segmentation fault (status 139) whenever the add-on was enabled from a script run
with --python: importing multiprocessing listed the script's module a second time as `__mp_main__`, and Blender
frees that module after the script (addon/tracer_api.py drops the second name)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from tests.test_blender import BLENDER, ROOT, needs_blender_34, wheel_versions

# What the script does after enabling the add-on; each runs in a Blender of its own.
SCENARIO = textwrap.dedent("""
    import sys
    import bpy

    scenario, output = sys.argv[-2], sys.argv[-1]
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.filepath = output + "/frame_"
    if scenario == "f12":
        bpy.ops.render.render(write_still=True)
    elif scenario == "animation":
        scene.frame_start, scene.frame_end = 1, 3
        bpy.ops.render.render(animation=True)
    elif scenario == "interrupted":
        scene.render.resolution_x, scene.render.resolution_y = 640, 480
        scene.frame_start, scene.frame_end = 1, 500
        print("WEATHERVANE-EXIT animating", flush=True)
        bpy.ops.render.render(animation=True)
    print("WEATHERVANE-EXIT done", scenario, flush=True)
""")

# Enabling as a pipeline's script does: Blender 3.4 from the legacy zip in a user scripts folder...
ENABLE_34 = textwrap.dedent("""
    import addon_utils
    import bpy

    assert bpy.ops.preferences.addon_install(filepath={zip!r}, overwrite=True) == {{"FINISHED"}}
    addon_utils.enable("weathervane", default_set=True)
    assert "weathervane" in bpy.context.preferences.addons
""")
# ...and a bpy wheel from the extension zip in a user resources folder.
ENABLE_WHEEL = textwrap.dedent("""
    import bpy

    result = bpy.ops.extensions.package_install_files(filepath={zip!r}, repo="user_default", enable_on_install=True)
    assert result == {{"FINISHED"}}, result
    assert "bl_ext.user_default.weathervane" in bpy.context.preferences.addons
""")


def blender_command(blender: str, script: Path) -> list[str]:
    """The command that runs script (a file: Blender runs a file's module differently from --python-expr)."""
    if blender == "Debian 3.4.1":
        return [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script)]
    version = blender.split()[1]
    python = Path(sys.executable) if version == "5.0.1" else ROOT / f".venv-bpy-{version}" / "bin" / "python"
    if not python.exists():
        pytest.skip(
            f"no {python.parent.parent.name}: `make blender-wheels` (part of `make test`) installs bpy {version}"
        )
    return [str(python), str(script)]


def run_scenario(blender: str, scenario: str, dist: Path, tmp_path: Path) -> subprocess.CompletedProcess:
    """Runs the scenario in a fresh Blender with its own user folders and temporary folder; returns the finished
    process (for "interrupted", Blender got SIGINT once the animation had written a frame)."""
    if blender == "Debian 3.4.1":
        (zip_path,) = dist.glob("weathervane-*-blender-3.4.zip")
        enable = ENABLE_34.format(zip=str(zip_path))
    else:
        (zip_path,) = [path for path in dist.glob("weathervane-*.zip") if "3.4" not in path.name]
        enable = ENABLE_WHEEL.format(zip=str(zip_path))
    script, output, temporary = tmp_path / "scenario.py", tmp_path / "frames", tmp_path / "tmp"
    output.mkdir()
    temporary.mkdir()
    script.write_text(enable + SCENARIO)
    environment = {
        **os.environ,
        "BLENDER_USER_SCRIPTS": str(tmp_path / "scripts"),
        "BLENDER_USER_RESOURCES": str(tmp_path / "resources"),
        "TMPDIR": str(temporary),  # where Blender writes its crash report
    }
    command = [*blender_command(blender, script), "--", scenario, str(output)]
    if scenario != "interrupted":
        result = subprocess.run(command, capture_output=True, text=True, env=environment, cwd=tmp_path, timeout=300)
    else:
        with subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=environment, cwd=tmp_path
        ) as process:
            deadline = time.monotonic() + 120
            while not list(output.glob("frame_*.png")) and time.monotonic() < deadline and process.poll() is None:
                time.sleep(0.05)
            process.send_signal(signal.SIGINT)  # Ctrl+C in the terminal Blender runs in
            stdout, _ = process.communicate(timeout=120)
        result = subprocess.CompletedProcess(command, process.returncode, stdout, "")
    assert not list(temporary.glob("*crash*")), (result.stdout + result.stderr)[-3000:]
    # no worker process outlives Blender
    leftover = subprocess.run(["pgrep", "-f", str(tmp_path)], capture_output=True, text=True)
    assert leftover.stdout.strip() == "", leftover.stdout
    return result


BLENDERS = [
    pytest.param("Debian 3.4.1", marks=needs_blender_34),
    "bpy 5.0.1",
    *(f"bpy {version}" for version in wheel_versions()),
]


@pytest.mark.parametrize("scenario", ["enabled", "f12", "animation"])
@pytest.mark.parametrize("blender", BLENDERS)
def test_blender_exits_with_status_0_after_the_addon_ran(blender: str, scenario: str, dist: Path, tmp_path) -> None:
    if blender != "Debian 3.4.1":
        pytest.importorskip("bpy", reason="the bpy wheel carries Blender's extension installer")
    result = run_scenario(blender, scenario, dist, tmp_path)
    log = result.stdout + result.stderr
    assert result.returncode == 0, log[-3000:]
    assert f"WEATHERVANE-EXIT done {scenario}" in log, log[-3000:]
    frames = sorted(path.name for path in (tmp_path / "frames").iterdir())
    expected = {
        "enabled": [],
        "f12": ["frame_.png"],
        "animation": ["frame_0001.png", "frame_0002.png", "frame_0003.png"],
    }
    assert frames == expected[scenario]


@needs_blender_34
def test_ctrl_c_during_an_animation_in_blender_34_exits_as_blender_does(dist: Path, tmp_path: Path) -> None:
    """Ctrl+C stops Blender's animation after the frame in hand; Blender then exits with its own status for an
    interrupted run, 1 (Cycles' run gives the same), never a crash, and no worker outlives it."""
    result = run_scenario("Debian 3.4.1", "interrupted", dist, tmp_path)
    assert result.returncode == 1, result.stdout[-3000:]
    assert "Blender quit" in result.stdout, result.stdout[-3000:]
    frames = list((tmp_path / "frames").glob("frame_*.png"))
    assert 1 <= len(frames) < 500
    assert not list((tmp_path / "frames").glob(".*")), "a temporary file was left"
