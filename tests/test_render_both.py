"""scripts/render_both.py under both invocations: the tracer and its Cycles twin agree, with the report written."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.scripts_run import BLENDER, in_blender, in_python
from tracer.scene.loader import default_scene_dict

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--width", "96", "--height", "72", "--cycles-samples", "64"]

pytest.importorskip("bpy", reason="render_both.py runs on the bpy wheel")
pytest.importorskip("flip_evaluator", reason="the report extra (flip-evaluator, scikit-image) computes the metrics")


def run_python(*args: str) -> subprocess.CompletedProcess:
    return in_python("render_both.py", *args)


def test_default_scene_twin_agrees_and_the_report_is_written(tmp_path: Path) -> None:
    result = run_python("--out", str(tmp_path), *SMALL)
    assert result.returncode == 0, result.stdout + result.stderr
    metrics = json.loads((tmp_path / "metrics.json").read_text())["pairs"]["cycles_vs_tracer"]
    # measured 39.7 dB and FLIP 0.041 at this size; 40.3 dB and 0.036 at 640x480 and 256 samples (docs)
    assert metrics["psnr_db"] > 37.0 and metrics["mean_flip"] < 0.05
    for name in ("tracer.png", "cycles.png", "diff_cycles_vs_tracer.png", "report.html", "timings.json"):
        assert (tmp_path / name).exists()
    report = (tmp_path / "report.html").read_text()
    assert "cycles against tracer" in report and "data-other='tracer.png'" in report
    # where Cycles has OSL (the wheel), the exact twin is rendered too: against the tracer, and the physical twin
    # against it (how far the documented model is from a physically based renderer)
    pairs = json.loads((tmp_path / "metrics.json").read_text())["pairs"]
    assert pairs["exact_vs_tracer"]["psnr_db"] > 45.0  # measured 48.5 dB at this size (64 samples, box filter)
    assert "cycles_vs_exact" in pairs and (tmp_path / "diff_cycles_vs_exact.png").exists()
    assert "exact against tracer" in report and "cycles against exact" in report
    assert "PSNR" in result.stdout and "report:" in result.stdout


def test_matte_scene_twin_agrees_to_40_db(tmp_path: Path) -> None:
    document = default_scene_dict()
    for material in document["materials"].values():
        material["specular"] = 0
    scene = tmp_path / "matte.json"
    scene.write_text(json.dumps(document))
    result = run_python(str(scene), "--out", str(tmp_path / "out"), *SMALL)
    assert result.returncode == 0, result.stdout + result.stderr
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())["pairs"]["cycles_vs_tracer"]
    assert metrics["psnr_db"] >= 40.0  # measured 46.7 dB here, 50.8 dB at 640x480 and 256 samples


def test_data_passes_agree_with_cycles_where_both_engines_see_a_surface(tmp_path: Path) -> None:
    pytest.importorskip("OpenEXR", reason="the exr extra reads Cycles' multilayer file")
    document = default_scene_dict()
    indices = {}
    for number, obj in enumerate(document["objects"], start=1):
        obj["pass_index"] = indices[obj["name"]] = number  # every object its own index
    for number, material in enumerate(document["materials"].values(), start=20):
        material["pass_index"] = number
    scene = tmp_path / "indexed.json"
    scene.write_text(json.dumps(document))
    out = tmp_path / "out"
    # the tracer at the pixel centres: Cycles writes depth, position and the indices from its first sample, which
    # lands there (the 4 x 4 grid's first sample is a quarter pixel off it: depth 1.1% off on the ground)
    result = run_python(str(scene), "--out", str(out), *SMALL, "--twin", "physical", "--passes", "all",
                        "--tracer-samples", "1")  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    passes = json.loads((out / "metrics.json").read_text())["passes"]["cycles_vs_tracer"]
    # measured at 96x72: coverage 0.9998, depth 1.4e-5 (median) / 3.0e-5 (p95), position 0.16 / 0.73 mm
    assert passes["coverage_iou"] > 0.99 and passes["pixels_compared"] > 0.5 * 96 * 72
    assert passes["depth"]["median_relative_error"] < 1e-4 and passes["depth"]["p95_relative_error"] < 1e-3
    assert passes["position"]["p95_distance"] < 0.01
    assert passes["normal"]["p95_angle_degrees"] < 1.0
    assert passes["mist"]["median_relative_error"] < 0.01  # Cycles averages its 64 samples, the tracer has one
    # measured 0.9997 and 1.0: one pixel on the line where two objects meet, hit at slightly different points
    assert passes["object_index"]["share_equal"] > 0.995 and passes["material_index"]["share_equal"] > 0.995
    tracer_indices = np.load(out / "passes" / "tracer.object_index.npy")
    assert len(np.unique(tracer_indices)) >= 4  # several objects in view, each with its own index
    assert "pass depth:" in result.stdout and "Data passes" in (out / "report.html").read_text()


def test_with_supersampling_depth_comes_from_the_sample_nearest_the_pixel_centre_as_cycles_does(tmp_path: Path) -> None:
    pytest.importorskip("OpenEXR", reason="the exr extra reads Cycles' multilayer file")
    result = run_python("--out", str(tmp_path), *SMALL, "--twin", "physical", "--passes", "depth,position")
    assert result.returncode == 0, result.stdout + result.stderr
    passes = json.loads((tmp_path / "metrics.json").read_text())["passes"]["cycles_vs_tracer"]
    # 4 x 4 samples, measured: depth 0.37% (median) off Cycles' on the sloping ground, position 4 cm; the grid's
    # first (corner) sample instead: 1.1% and 13 cm
    assert passes["depth"]["median_relative_error"] < 0.006 and passes["position"]["median_distance"] < 0.08


def test_passes_other_than_the_data_passes_are_refused(tmp_path: Path) -> None:
    result = run_python("--out", str(tmp_path), "--passes", "depth,diffuse")
    assert result.returncode == 2 and "--passes: must be 'all' or name passes from depth" in result.stderr
    assert not any(tmp_path.iterdir())


def test_bad_engine_name_is_refused(tmp_path: Path) -> None:
    result = run_python("--out", str(tmp_path), "--engines", "tracer,povray")
    assert result.returncode == 2 and "--engines: must name engines from" in result.stderr
    assert not any(tmp_path.iterdir())


@pytest.mark.skipif(BLENDER is None, reason="Debian's blender (3.4.1) is not installed: `make test` installs it")
def test_runs_inside_blender_34_too(tmp_path: Path) -> None:
    result = in_blender("render_both.py", "--out", str(tmp_path), *SMALL)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "Blender 3.4" in result.stdout
    # no OSL in Debian's 3.4.1: one line says so, and the physical twin is rendered alone
    fallback = [line for line in result.stdout.splitlines() if line.startswith("exact twin:")]
    assert fallback == [
        "exact twin: not rendered, Blender 3.4.1's Cycles is built without OSL; rendering the physical twin only "
        "(addon/convert/twin.py)"
    ], result.stdout[-2000:]
    assert not (tmp_path / "exact.npy").exists()
    metrics = json.loads((tmp_path / "metrics.json").read_text())["pairs"]["cycles_vs_tracer"]
    assert metrics["psnr_db"] > 37.0 and metrics["mean_flip"] < 0.05


def test_frames_render_both_paths_over_the_baked_motion(tmp_path: Path) -> None:
    template = ROOT / "blend_templates" / "gusty_day.blend"
    result = run_python(
        str(template),
        "--frames",
        "20-21",
        "--out",
        str(tmp_path),
        "--width",
        "48",
        "--height",
        "36",
        "--cycles-samples",
        "8",
    )
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((tmp_path / "metrics.json").read_text())
    assert sorted(summary) == ["20", "21"]
    assert (tmp_path / "frame_0020" / "report.html").exists() and (tmp_path / "frame_0021" / "cycles.png").exists()
    # the vane turns between the frames in both paths
    import numpy as np

    for engine in ("tracer", "cycles"):
        first = np.load(tmp_path / "frame_0020" / f"{engine}.npy")
        second = np.load(tmp_path / "frame_0021" / f"{engine}.npy")
        assert np.abs(first - second).max() > 0.01


def test_frames_on_a_dask_cluster_are_the_local_runs_and_a_second_run_keeps_them(tmp_path: Path) -> None:
    pytest.importorskip("distributed", reason="the cluster extra: make test installs dask[distributed]")
    import numpy as np

    from tests.dask_cluster import LocalCluster

    template = str(ROOT / "blend_templates" / "gusty_day.blend")
    # the physical twin alone: this test is about the cluster (and a worker may lack OSL)
    small = ["--frames", "20-22", "--width", "48", "--height", "36", "--cycles-samples", "8", "--twin", "physical"]
    local = run_python(template, *small, "--out", str(tmp_path / "local"))
    assert local.returncode == 0, local.stdout + local.stderr
    with LocalCluster(workers=2) as dask:
        cluster = run_python(template, *small, "--out", str(tmp_path / "cluster"), "--scheduler", dask.address)
        assert cluster.returncode == 0, cluster.stdout + cluster.stderr
        assert cluster.stdout.count("written (") == 3
        again = run_python(template, *small, "--out", str(tmp_path / "cluster"), "--scheduler", dask.address)
        assert again.returncode == 0 and "written (" not in again.stdout  # every frame was complete: kept
    for frame in (20, 21, 22):
        for engine in ("tracer", "cycles"):
            on_cluster = np.load(tmp_path / "cluster" / f"frame_{frame:04d}" / f"{engine}.npy")
            assert np.array_equal(on_cluster, np.load(tmp_path / "local" / f"frame_{frame:04d}" / f"{engine}.npy"))
    summary = json.loads((tmp_path / "cluster" / "metrics.json").read_text())
    assert summary == json.loads((tmp_path / "local" / "metrics.json").read_text())
    assert not list((tmp_path / "cluster").rglob(".*.partial"))


def test_scheduler_without_frames_is_refused(tmp_path: Path) -> None:
    result = run_python("--out", str(tmp_path), "--scheduler", "tcp://127.0.0.1:9")
    assert result.returncode == 2 and "--scheduler: needs --frames A-B" in result.stderr
    assert not any(tmp_path.iterdir())
