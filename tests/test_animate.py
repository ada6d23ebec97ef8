"""`python -m tracer animate`: frames turned by the motion code, resumable, with a GIF preview."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tracer.frames.animate import headings
from tracer.scene.loader import default_scene, default_scene_dict
from tracer.tracing.images import to_8bit
from tracer.workers.parallel import render

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--width", "32", "--height", "24", "--quiet"]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "tracer", "animate", *args], capture_output=True, text=True, cwd=ROOT, timeout=300
    )


def test_frames_show_the_vane_at_the_simulated_headings(tmp_path: Path) -> None:
    out = tmp_path / "frames"
    gif = tmp_path / "preview.gif"
    # frames 20-25: the wind has started and the vane swings (still frames would merge in the GIF)
    result = run("-o", str(out), "--frames", "20-25", "--gif", str(gif), *SMALL[:-1])
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == [f"frame_{k:04d}.png" for k in range(20, 26)]
    assert "6 rendered, 0 already there" in result.stdout and "keyframes" in result.stdout
    with Image.open(gif) as preview:
        assert preview.n_frames == 6
    scene = default_scene().with_render(width=32, height=24)
    angle = headings(scene, 25)[22]  # frame 23
    expected = to_8bit(render(scene.with_heading(float(angle)), workers=1).image)
    assert np.array_equal(np.asarray(Image.open(out / "frame_0023.png")), expected)


def test_resumes_and_overwrites_on_request(tmp_path: Path) -> None:
    out = tmp_path / "frames"
    assert run("-o", str(out), "--frames", "2-4", *SMALL).returncode == 0
    kept = (out / "frame_0004.png").read_bytes()
    (out / "frame_0003.png").unlink()
    (out / "frame_0002.png").write_bytes(b"not a frame")  # damaged: rendered again, not trusted
    result = run("-o", str(out), "--frames", "2-4", "--width", "32", "--height", "24")
    assert "2 rendered, 1 already there" in result.stdout
    assert (out / "frame_0004.png").read_bytes() == kept and (out / "frame_0003.png").exists()
    assert (out / "frame_0002.png").read_bytes().startswith(b"\x89PNG")
    before = (out / "frame_0004.png").stat().st_mtime_ns
    assert run("-o", str(out), "--frames", "2-4", "--overwrite", *SMALL).returncode == 0
    assert (out / "frame_0004.png").stat().st_mtime_ns != before


def test_bad_frames_and_scenes_without_a_vane(tmp_path: Path) -> None:
    result = run("-o", str(tmp_path / "x"), "--frames", "5-2")
    assert result.returncode == 2 and "argument --frames: must be A-B with 1 <= A <= B" in result.stderr
    result = run("-o", str(tmp_path / "x"), "--frames", "a-b")
    assert result.returncode == 2 and "whole frame numbers" in result.stderr
    document = default_scene_dict()
    del document["vane"]
    scene = tmp_path / "still.json"
    scene.write_text(json.dumps(document))
    result = run(str(scene), "-o", str(tmp_path / "x"), "--frames", "1-2")
    assert result.returncode == 2 and "vane: is required to animate" in result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "x").exists()


def test_incremental_frames_convert_only_their_retraced_pixels_to_the_same_png_pixels(tmp_path: Path) -> None:
    """An incremental frame's 8 bits are its run's base's with the re-traced pixels converted again: the PNGs'
    pixels are those of whole frames, in linear and sRGB, with 1 and 2 workers."""
    from tracer.frames.animate import animate

    scene = default_scene().with_render(width=48, height=36)
    for workers in (1, 2):
        for srgb in (False, True):
            folders = {}
            for incremental in (True, False):
                folder = tmp_path / f"{workers}-{srgb}-{incremental}"
                animate(scene.with_render(workers=workers), folder, 20, 27, srgb=srgb, incremental=incremental)
                folders[incremental] = folder
            for frame in range(20, 28):
                name = f"frame_{frame:04d}.png"
                with Image.open(folders[True] / name) as fast, Image.open(folders[False] / name) as whole:
                    assert np.array_equal(np.asarray(fast), np.asarray(whole)), (workers, srgb, name)
                # the files too: FramePng's reused pieces are the bytes of compressing them again
                assert (folders[True] / name).read_bytes() == (folders[False] / name).read_bytes()


def test_frame_pngs_reuse_unchanged_rows_and_decode_to_their_pixels() -> None:
    """FramePng's files decode (Pillow) to the pixels given, RGB and RGBA, of any size, and a frame encoded after
    another (its unchanged pieces reused) is the same bytes as the frame encoded on its own."""
    import io

    from tracer.tracing.images import PNG_ROWS, FramePng

    rng = np.random.default_rng(7)
    for height, width, channels in [(1, 1, 3), (PNG_ROWS * 3, 17, 3), (PNG_ROWS * 2 + 5, 9, 4)]:
        frames = FramePng()
        pixels = rng.integers(0, 256, (height, width, channels), dtype=np.uint8)
        pixels[: height // 2] = 40  # flat rows: runs for the run-length strategy
        for _ in range(4):
            data = frames.encode(pixels)
            assert data == FramePng().encode(pixels)
            with Image.open(io.BytesIO(data)) as image:
                assert image.mode == ("RGBA" if channels == 4 else "RGB")
                assert np.array_equal(np.asarray(image), pixels)
            pixels = pixels.copy()
            pixels[rng.integers(0, height), rng.integers(0, width)] += 1  # one pixel of one piece changes


def test_passes_go_into_each_frames_exr_beside_its_png_and_a_stopped_run_resumes_them(tmp_path: Path) -> None:
    pytest.importorskip("OpenEXR", reason="the exr extra: make test installs the OpenEXR bindings")
    from tracer.tracing.exr import read_exr_channels
    from tracer.tracing.pass_files import exr_channels

    out, plain = tmp_path / "frames", tmp_path / "plain"
    asked = "depth,normal,object_index,diffuse,reflection,cryptomatte_object"
    result = run("-o", str(out), "--frames", "20-22", "--passes", asked, *SMALL)
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        f"frame_{k:04d}.{e}" for k in range(20, 23) for e in ("exr", "png")
    ]
    assert run("-o", str(plain), "--frames", "20-22", *SMALL).returncode == 0
    scene = default_scene().with_render(width=32, height=24, passes=tuple(asked.split(",")))
    angles = headings(scene, 22)
    for frame in range(20, 23):  # the passes asked for do not change the image
        assert (out / f"frame_{frame:04d}.png").read_bytes() == (plain / f"frame_{frame:04d}.png").read_bytes()
    # each file holds what a single render of the frame's heading gives (the same channels, bit for bit)
    single = render(scene.with_heading(float(angles[20])), workers=1)
    expected, _ = exr_channels(scene, single.image, single.alpha, single.passes)
    written, header = read_exr_channels(out / "frame_0021.exr")
    assert sorted(written) == sorted(expected)
    assert all(np.array_equal(written[name], expected[name]) for name in expected)
    assert any(key.endswith("/manifest") for key in header)

    (out / "frame_0021.exr").unlink()  # a run stopped between the two files of a frame
    (out / "frame_0022.exr").write_bytes((out / "frame_0022.exr").read_bytes()[:500])  # damaged: not trusted
    kept = (out / "frame_0020.exr").read_bytes()
    result = run("-o", str(out), "--frames", "20-22", "--passes", asked, "--width", "32", "--height", "24")
    assert "2 rendered, 1 already there" in result.stdout, result.stderr
    assert (out / "frame_0020.exr").read_bytes() == kept
    assert read_exr_channels(out / "frame_0022.exr")[0].keys() == expected.keys()
    more = run("-o", str(out), "--frames", "20-22", "--passes", f"{asked},mist", *SMALL)  # a pass the files lack
    assert more.returncode == 0 and "mist" in {
        n.split(".")[1].lower() for n in read_exr_channels(out / "frame_0020.exr")[0]
    }
