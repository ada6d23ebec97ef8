"""The command line: exit codes, messages without tracebacks, no partial files, worker-independent bytes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tracer.scene.loader import default_scene, default_scene_dict
from tracer.tracing.images import to_8bit
from tracer.workers.parallel import render

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "tracer", *args], capture_output=True, text=True, cwd=ROOT, timeout=120, **kwargs
    )


def test_renders_default_scene_to_png_and_prints_a_summary(tmp_path: Path) -> None:
    out = tmp_path / "default.png"
    result = run("render", "-o", str(out), "--width", "64", "--height", "48", "--workers", "1")
    assert result.returncode == 0, result.stderr
    assert Image.open(out).size == (64, 48)
    assert "64x48" in result.stdout and "Mrays/s" in result.stdout and "shadow" in result.stdout


def test_npy_holds_the_float32_linear_image(tmp_path: Path) -> None:
    out = tmp_path / "image.npy"
    assert run("render", "-o", str(out), "--width", "32", "--height", "24", "--quiet").returncode == 0
    image = np.load(out)
    assert image.shape == (24, 32, 3) and image.dtype == np.float32
    expected = render(default_scene().with_render(width=32, height=24), workers=1).image
    assert np.array_equal(image, expected.astype(np.float32))


def test_png_is_the_documented_clamp_of_the_linear_image(tmp_path: Path) -> None:
    png, npy = tmp_path / "a.png", tmp_path / "a.npy"
    for out in (png, npy):
        assert run("render", "-o", str(out), "--width", "24", "--height", "16", "--quiet").returncode == 0
    linear = np.load(npy).astype(np.float64)
    pixels = np.asarray(Image.open(png))
    expected = np.floor(np.clip(linear, 0, 1) * 255 + 0.5)
    # the .npy holds float32, the PNG was encoded from float64: values on a rounding edge (the sky's 0.9 * 255 =
    # 229.5) may differ by one
    assert np.abs(pixels - expected).max() <= 1
    srgb = tmp_path / "s.png"
    assert run("render", "-o", str(srgb), "--width", "24", "--height", "16", "--srgb", "--quiet").returncode == 0
    assert np.asarray(Image.open(srgb)).astype(int).sum() > pixels.astype(int).sum()  # sRGB lifts mid-tones


def test_8bit_encoding_clamps_and_rounds() -> None:
    linear = np.array([[[-0.5, 0.0, 0.5], [1.0, 1.7, np.nan]]])
    assert to_8bit(linear).tolist() == [[[0, 0, 128], [255, 255, 0]]]
    assert to_8bit(np.array([[[0.0031308, 0.5, 1.0]]]), srgb=True).tolist() == [[[10, 188, 255]]]


def test_bad_scene_file_exits_2_with_messages_and_no_output(tmp_path: Path) -> None:
    document = default_scene_dict()
    document["objects"][3]["radius"] = -1
    document["render"]["model"] = "lambert"
    scene = tmp_path / "bad.json"
    scene.write_text(json.dumps(document))
    out = tmp_path / "bad.png"
    result = run("render", str(scene), "-o", str(out))
    assert result.returncode == 2
    assert f"{scene}: objects[3].radius: must be > 0, got -1" in result.stderr
    assert "render.model: must be one of" in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == [scene]


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--width", "0"], "argument --width: must be an integer from 1 to 16384, got 0"),
        (["--samples", "5"], "argument --samples: must be a perfect square"),
        (["--coef", "-1"], "argument --coef: must be a finite number > 0, got -1"),
        (["--model", "lambert"], "argument --model: invalid choice: 'lambert'"),
        (["--dtype", "half"], "argument --dtype: invalid choice: 'half'"),
        (["--depth", "deep"], "argument --depth: must be an integer, got 'deep'"),
        (["--background", "stars"], "argument --background: invalid choice: 'stars'"),
    ],
)
def test_bad_flags_exit_2_and_name_the_flag(tmp_path: Path, flags: list[str], message: str) -> None:
    out = tmp_path / "x.png"
    result = run("render", "-o", str(out), *flags)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()


def test_bad_output_name_and_missing_scene_file(tmp_path: Path) -> None:
    result = run("render", "-o", str(tmp_path / "x.jpg"))
    assert result.returncode == 2 and "must end in .png, .npy or .exr" in result.stderr
    result = run("render", str(tmp_path / "nowhere.json"), "-o", str(tmp_path / "x.png"))
    assert result.returncode == 2 and "cannot read the file" in result.stderr and "Traceback" not in result.stderr


def test_existing_output_survives_a_failed_render(tmp_path: Path) -> None:
    out = tmp_path / "keep.png"
    out.write_bytes(b"precious")
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert run("render", str(bad), "-o", str(out)).returncode == 2
    assert out.read_bytes() == b"precious"


def test_interrupt_leaves_no_partial_file(tmp_path: Path) -> None:
    out = tmp_path / "big.png"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "tracer",
            "render",
            "-o",
            str(out),
            "--width",
            "1200",
            "--height",
            "900",
            "--samples",
            "16",
            "--workers",
            "1",
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(3.0)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130
    assert "interrupted" in stderr and "Traceback" not in stderr
    assert list(tmp_path.iterdir()) == []


def test_help_documents_every_render_flag() -> None:
    text = run("render", "--help").stdout
    for flag in (
        "--width",
        "--height",
        "--depth",
        "--model",
        "--coef",
        "--samples",
        "--workers",
        "--dtype",
        "--background",
        "--srgb",
        "--numerics",
    ):
        assert flag in text


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_image_bytes_do_not_depend_on_the_number_of_workers(dtype: str) -> None:
    scene = default_scene().with_render(width=96, height=200, samples=4, dtype=dtype)
    images = [render(scene, workers=workers).image for workers in (1, 2, 3)]
    assert images[0].tobytes() == images[1].tobytes() == images[2].tobytes()


def test_cli_output_is_identical_for_one_and_two_workers(tmp_path: Path) -> None:
    outputs = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}.npy"
        env = {**os.environ}
        assert (
            run(
                "render", "-o", str(out), "--width", "80", "--height", "60", "--workers", workers, "--quiet", env=env
            ).returncode
            == 0
        )
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1]


def test_shared_images_outlive_later_frames_and_leave_no_files() -> None:
    """Workers write into a shared-memory file that the returned image maps: the name goes, the image stays."""
    import glob
    import tempfile

    from tracer.workers.parallel import Renderer

    pattern = "weathervane-image-*"
    before = set(glob.glob(f"/dev/shm/{pattern}")) | set(glob.glob(f"{tempfile.gettempdir()}/{pattern}"))
    scene = default_scene().with_render(width=64, height=48)
    with Renderer(2) as renderer:
        first = renderer.render(scene).image
        kept = first.copy()
        second = renderer.render(scene.with_heading(90.0)).image
    assert np.array_equal(first, kept)  # the second frame went into a file of its own
    assert not np.array_equal(first, second)
    assert np.array_equal(first, render(scene, workers=1).image)
    after = set(glob.glob(f"/dev/shm/{pattern}")) | set(glob.glob(f"{tempfile.gettempdir()}/{pattern}"))
    assert after == before


def test_render_frames_gives_each_frame_in_order_and_cleans_up_when_stopped_early() -> None:
    import glob
    import tempfile

    from tracer.workers.parallel import Renderer

    def leftovers() -> set[str]:
        pattern = "weathervane-image-*"
        return set(glob.glob(f"/dev/shm/{pattern}")) | set(glob.glob(f"{tempfile.gettempdir()}/{pattern}"))

    before = leftovers()
    scenes = [default_scene().with_render(width=48, height=36).with_heading(angle) for angle in (0.0, 60.0, 120.0)]
    expected = [render(scene, workers=1).image for scene in scenes]
    with Renderer(2) as renderer:
        images = [result.image for result in renderer.render_frames(iter(scenes))]
        frames = renderer.render_frames(iter(scenes))
        first = next(frames)  # the second frame is queued by now
        frames.close()
    assert all(np.array_equal(image, want) for image, want in zip(images, expected, strict=True))
    assert np.array_equal(first.image, expected[0])
    assert leftovers() == before


def test_kept_image_files_are_used_again_only_when_free_and_closed_with_the_renderer() -> None:
    """A Renderer keeps small image files for later frames: a held result keeps its bytes, every frame equals the
    one-process image, and closing the Renderer leaves no image file open."""
    import os

    from tracer.workers.parallel import Renderer

    def open_images() -> int:
        """Image files this process has open (a mapping holds a descriptor of its own)."""
        files = set()
        for name in os.listdir("/proc/self/fd"):
            try:
                if "weathervane-image" in os.readlink(f"/proc/self/fd/{name}"):
                    files.add(os.stat(f"/proc/self/fd/{name}").st_ino)
            except OSError:  # the listing's own descriptor, closed by now
                pass
        return len(files)

    before = open_images()
    scenes = [default_scene().with_render(width=48, height=36).with_heading(angle) for angle in (0.0, 50.0, 100.0)]
    expected = [render(scene, workers=1).image for scene in scenes]
    with Renderer(2) as renderer:
        held = renderer.render(scenes[0]).image
        for _ in range(2):
            for scene, want in zip(scenes, expected, strict=True):
                assert np.array_equal(renderer.render(scene).image, want)
        assert np.array_equal(held, expected[0])
        assert open_images() - before <= 2
    assert open_images() - before == 1  # the held image's
    del held
    assert open_images() == before


def _address_space_limit() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def test_an_address_space_limit_refuses_a_huge_render_in_one_line(tmp_path: Path) -> None:
    """Under RLIMIT_AS 4 GiB a 16384x16384 float64 render (about 8 GB) is refused before tracing: one line that says
    what it needs and what the limit leaves, exit 1, no traceback, no file (it died of a NumPy MemoryError before)."""
    out = tmp_path / "huge.png"
    result = run(
        "render", "--width", "16384", "--height", "16384", "-o", str(out), "--quiet", preexec_fn=_address_space_limit
    )
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "memory" in lines[0] and "16384x16384" in lines[0] and "Traceback" not in result.stderr
    assert not out.exists() and not list(tmp_path.iterdir())


def test_running_out_of_memory_midway_is_one_line_and_writes_nothing(tmp_path: Path, monkeypatch, capsys) -> None:
    """A MemoryError the up-front check could not foresee (another process grew) ends in one line naming the render
    and what to change, exit 1, and leaves an existing output file as it was."""
    from tracer import cli
    from tracer.workers import parallel

    def exhausted(self, scene, progress=None):
        raise MemoryError("Unable to allocate 6.00 GiB for an array")

    monkeypatch.setattr(parallel.Renderer, "render", exhausted)
    out = tmp_path / "kept.png"
    out.write_bytes(b"the user's file")
    code = cli.main(["render", "--width", "64", "--height", "48", "--workers", "1", "-o", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith("error: out of memory during a 64x48 float64 render") and "no image written" in err[0]
    assert out.read_bytes() == b"the user's file"
