"""The add-on in real Blenders: the built zips install and work in Blender 5.0 and 3.4.1, and the add-on test suite
passes inside Debian's Blender 3.4.1 and the 4.x bpy wheels, one Blender at a time beside the other tests (it runs
under plain pytest on the bpy 5.0.1 wheel in tests/addon)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from concurrent.futures import Future
from pathlib import Path

import pytest

from tests.conftest import in_background

ROOT = Path(__file__).resolve().parents[1]
BLENDER = shutil.which("blender")
needs_blender_34 = pytest.mark.skipif(
    BLENDER is None, reason="Debian's blender (3.4.1) is not installed: `make test` installs it with apt-get as root"
)


def test_extension_zip_installs_and_builds_in_blender_5(dist: Path, tmp_path: Path) -> None:
    (extension,) = [path for path in dist.glob("weathervane-*.zip") if "3.4" not in path.name]
    script = textwrap.dedent(f"""
        import sys
        sys.modules["tracer"] = None  # the add-on must use its own copy of the tracer
        import bpy
        result = bpy.ops.extensions.package_install_files(filepath={str(extension)!r}, repo="user_default",
                                                          enable_on_install=True)
        assert result == {{"FINISHED"}}, result
        assert "bl_ext.user_default.weathervane" in bpy.context.preferences.addons
        assert bpy.ops.weathervane.build() == {{"FINISHED"}}
        print("OBJECTS", len(bpy.data.collections["Weathervane"].objects))
        # its own copy, as a top-level package from the extension's folder (worker processes import it by name)
        copy = sys.modules["weathervane_tracer.scene.loader"].__file__
        assert "extensions" in copy and "weathervane" in copy, copy
    """)
    environment = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path)}
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=tmp_path, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "OBJECTS 19" in result.stdout


@needs_blender_34
def test_legacy_zip_installs_and_builds_in_blender_34(dist: Path, tmp_path: Path) -> None:
    (legacy,) = dist.glob("weathervane-*-blender-3.4.zip")
    script = textwrap.dedent(f"""
        import sys
        sys.modules["tracer"] = None  # the add-on must use its own copy of the tracer
        import bpy
        assert bpy.app.version[:2] == (3, 4), bpy.app.version
        assert bpy.ops.preferences.addon_install(filepath={str(legacy)!r}, overwrite=True) == {{"FINISHED"}}
        assert bpy.ops.preferences.addon_enable(module="weathervane") == {{"FINISHED"}}
        assert bpy.ops.weathervane.build() == {{"FINISHED"}}
        print("OBJECTS", len(bpy.data.collections["Weathervane"].objects))
    """)
    environment = {**os.environ, "BLENDER_USER_SCRIPTS": str(tmp_path)}
    result = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", script],
        capture_output=True,
        text=True,
        env=environment,
        cwd=tmp_path,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "OBJECTS 19" in result.stdout


@needs_blender_34
def test_addon_suite_passes_inside_blender_34() -> None:
    result = background_runs()["3.4.1"].result()
    assert "Blender 3.4" in result.stdout
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
    assert " passed" in result.stdout and " failed" not in result.stdout


def wheel_versions() -> list[str]:
    """The bpy wheels besides 5.0.1 that `make test` gives their own virtual environments (tests/addon/wheels.txt)."""
    lines = (ROOT / "tests" / "addon" / "wheels.txt").read_text().splitlines()
    return [line.split("#")[0].strip() for line in lines if line.split("#")[0].strip()]


# The Blenders at the ends of the supported range, Debian's 3.4.1 and the main .venv's 5.0.1, run the whole add-on
# suite in `make test`. The wheels between them run SUITE_OF_A_MIDDLE_WHEEL, the files that go through compat.py's
# version branches and the export of a scene; `make test-blenders` (WEATHERVANE_FULL_SUITES=1) runs the whole suite in
# each of them.
SUITE_OF_A_MIDDLE_WHEEL = (
    "test_addon.py",  # install, Build, Bake: the keyframes through compat.fcurves_of (layered actions from 4.4)
    "test_engine.py",
    "test_scene_export.py",
    "test_shading_convert.py",  # Principled inputs by version
    "test_glass_transparency.py",  # Transparent Shadows: a Cycles setting up to 4.1, the material's from 4.2
    "test_motion_blur.py",
    "test_render_passes.py",  # pass names by version
    "test_messages.py",
    "test_build_settings.py",
)


def suite_files(version: str) -> list[str]:
    """The add-on test files that `make test` runs in a Blender -> paths (the folder: all of them)."""
    folder = ROOT / "tests" / "addon"
    if version == "3.4.1" or os.environ.get("WEATHERVANE_FULL_SUITES") == "1":
        return [str(folder)]
    return [str(folder / name) for name in SUITE_OF_A_MIDDLE_WHEEL]


def background_runs() -> dict[str, Future]:
    """The add-on suite in Debian's Blender 3.4.1 and in each bpy wheel that is installed, queued in the session's
    background runs (tests/conftest.py: one Blender at a time, started as the tests are collected) -> each Blender's
    future subprocess.CompletedProcess."""
    runs = {}
    if BLENDER is not None:
        runner = str(ROOT / "tests" / "addon" / "run_in_blender.py")
        command = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python", runner,
                   "--", "-q", *suite_files("3.4.1")]  # fmt: skip
        runs["3.4.1"] = in_background("suite 3.4.1", command, cwd=ROOT, timeout=1200)
    for version in wheel_versions():
        python = ROOT / f".venv-bpy-{version}" / "bin" / "python"
        if python.exists():
            script = textwrap.dedent(f"""
                import sys
                import bpy, numpy, pytest
                print("Blender", bpy.app.version_string, "NumPy", numpy.__version__)
                arguments = ["-q", "-p", "no:cacheprovider", "--rootdir", {str(ROOT)!r}, *{suite_files(version)!r}]
                sys.exit(int(pytest.main(arguments)))
            """)
            runs[version] = in_background(f"suite {version}", [str(python), "-c", script], cwd=ROOT, timeout=1200)
    return runs


@pytest.mark.parametrize("version", wheel_versions())
def test_addon_suite_passes_in_the_bpy_wheel(version: str) -> None:
    python = ROOT / f".venv-bpy-{version}" / "bin" / "python"
    if not python.exists():
        pytest.skip(
            f"no {python.parent.parent.name}: `make blender-wheels` (part of `make test`) installs bpy {version}"
        )
    result = background_runs()[version].result()
    assert f"Blender {version}" in result.stdout, result.stdout[-2000:] + result.stderr[-2000:]
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
    assert " passed" in result.stdout and " failed" not in result.stdout


@pytest.mark.parametrize("blender", ["bpy 5.0.1", "Debian 3.4.1"])
def test_two_hundred_f12_renders_in_a_row_with_the_pool_kept_do_not_crash_blender(blender: str) -> None:
    """scripts/stress_engine.py: 200 F12 renders alternating two scenes, each image equal to its scene's first."""
    script = str(ROOT / "scripts" / "stress_engine.py")
    if blender == "Debian 3.4.1":
        if BLENDER is None:
            pytest.skip("Debian's blender (3.4.1) is not installed: `make test` installs it with apt-get as root")
        command = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script, "--"]
    else:
        pytest.importorskip("bpy", reason="Blender's Python module: make test installs the bpy wheel")
        command = [sys.executable, script]
    result = subprocess.run([*command, "--renders", "200"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]  # a crash: killed by a signal
    assert "STRESS renders=200 crashes=0" in result.stdout and "start=spawn pool=kept" in result.stdout
    assert f"STRESS blender={blender.split()[1]}" in result.stdout


def vane_blend(dist: Path, tmp_path: Path, *, bake_to: int = 0) -> tuple[Path, dict]:
    """A .blend of the built vane at 64x48 (Standard view, no dither) saved by Blender 3.4.1 with the legacy zip
    installed in a user scripts folder of its own; bake_to: also bake the motion over frames 1..bake_to.
    Returns the file and the environment that finds the add-on."""
    (legacy,) = dist.glob("weathervane-*-blender-3.4.zip")
    blend = tmp_path / "vane.blend"
    environment = {**os.environ, "BLENDER_USER_SCRIPTS": str(tmp_path / "scripts")}
    make_file = textwrap.dedent(f"""
        import bpy
        assert bpy.ops.preferences.addon_install(filepath={str(legacy)!r}, overwrite=True) == {{"FINISHED"}}
        assert bpy.ops.preferences.addon_enable(module="weathervane") == {{"FINISHED"}}
        bpy.ops.wm.read_homefile(use_empty=True)
        assert bpy.ops.weathervane.build() == {{"FINISHED"}}
        scene = bpy.context.scene
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
        scene.view_settings.view_transform = "Standard"  # 3.4 defaults to Filmic
        scene.render.dither_intensity = 0.0
        if {bake_to}:
            scene.frame_start, scene.frame_end = 1, {bake_to}
            assert bpy.ops.weathervane.bake() == {{"FINISHED"}}
        bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
    """)
    result = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", make_file],
        capture_output=True,
        text=True,
        env=environment,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return blend, environment


@needs_blender_34
def test_a_render_farms_two_frame_ranges_make_the_same_frames_as_one_run(dist: Path, tmp_path: Path) -> None:
    """Blender's own farm path, as a farm manager (Flamenco) splits a job: `blender -b FILE --addons weathervane -E
    WEATHERVANE_TRACER -s A -e B -a` on two machines, frames 1-6 and 7-12, against one run of 1-12."""
    from PIL import Image

    blend, environment = vane_blend(dist, tmp_path, bake_to=12)

    def farm(first: int, last: int, folder: Path) -> None:
        command = [BLENDER, "-b", str(blend), "--addons", "weathervane", "-E", "WEATHERVANE_TRACER"]
        command += ["-o", str(folder / "frame_####"), "-F", "PNG", "-s", str(first), "-e", str(last), "-a"]
        result = subprocess.run(command, capture_output=True, text=True, env=environment, timeout=300)
        assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]

    farm(1, 6, tmp_path / "machines")
    farm(7, 12, tmp_path / "machines")
    farm(1, 12, tmp_path / "one")

    def pixels(path: Path):
        with Image.open(path) as image:
            return image.convert("RGB").tobytes()  # Blender's PNG metadata holds the render time: pixels only

    split = {path.name: pixels(path) for path in sorted((tmp_path / "machines").glob("frame_*.png"))}
    whole = {path.name: pixels(path) for path in sorted((tmp_path / "one").glob("frame_*.png"))}
    assert list(whole) == [f"frame_{frame:04d}.png" for frame in range(1, 13)]
    assert split == whole
    assert whole["frame_0001.png"] != whole["frame_0012.png"]  # the vane turned


@needs_blender_34
def test_command_line_render_with_the_tracer_engine_in_blender_34(dist: Path, tmp_path: Path) -> None:
    """`blender -b file.blend -E WEATHERVANE_TRACER -f 1`: the frame Blender writes is the tracer's image."""
    import numpy as np
    from PIL import Image

    from tracer.scene.loader import default_scene
    from tracer.tracing.images import to_8bit
    from tracer.workers.parallel import render

    blend, environment = vane_blend(dist, tmp_path)
    result = subprocess.run(
        [
            BLENDER,
            "-b",
            str(blend),
            "--addons",
            "weathervane",
            "-E",
            "WEATHERVANE_TRACER",
            "-o",
            str(tmp_path / "frame_####"),
            "-F",
            "PNG",
            "-f",
            "1",
        ],
        capture_output=True,
        text=True,
        env=environment,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    frame = np.asarray(Image.open(tmp_path / "frame_0001.png").convert("RGB")).astype(int)
    expected = to_8bit(render(default_scene().with_render(width=64, height=48), workers=1).image, srgb=True)
    assert np.abs(frame - expected.astype(int)).max() <= 1
