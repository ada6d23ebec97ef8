"""Benchmark: the default scene at 640x480, depth 3, over workers and dtypes; the last line is one JSON object.

Usage: python scripts/bench_tracer.py [--repeats N] [--width W --height H]
Each figure is the median of N frames rendered by one persistent pool after a warm-up frame; the per-pixel
reference is timed on a small frame and scaled by the pixel count.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tracer.scene.loader import default_scene
from tracer.tracing.reference import render_reference
from tracer.workers.parallel import Renderer


def bench(scene, workers: int, repeats: int) -> dict:
    with Renderer(workers) as renderer:
        renderer.render(scene)  # warm-up: pool start, imports, caches
        results = [renderer.render(scene) for _ in range(repeats)]
    seconds = statistics.median(result.seconds for result in results)
    rays = results[0].rays
    return {
        "ms": round(seconds * 1000, 1),
        "rays": rays.total,
        "camera_rays": rays.camera,
        "shadow_rays": rays.shadow,
        "reflection_rays": rays.reflection,
        "mrays_per_s": round(rays.total / seconds / 1e6, 2),
    }


HD_SCRIPT = """
import json, os, sys, threading, time
sys.path.insert(0, {root!r})
from tracer.scene.loader import default_scene
from tracer.workers.parallel import Renderer

def field_mb(path, name):
    try:
        with open(path) as lines:
            return next(int(line.split()[1]) for line in lines if line.startswith(name)) / 1024
    except (OSError, StopIteration):
        return 0.0

# proportional set size of the parent and its workers together, and each one's resident set, every 2 ms
# (not getrusage: a child's ru_maxrss keeps the peak of the process it was forked from, across exec)
peak, sampling = {{"total": 0.0, "parent": 0.0, "worker": 0.0}}, [True]
def sample(pids):
    while sampling[0]:
        parent, *workers = pids()
        total = sum(field_mb(f"/proc/{{pid}}/smaps_rollup", "Pss:") for pid in [parent, *workers])
        peak["total"] = max(peak["total"], total)
        peak["parent"] = max(peak["parent"], field_mb(f"/proc/{{parent}}/status", "VmRSS:"))
        peak["worker"] = max([peak["worker"]] + [field_mb(f"/proc/{{pid}}/status", "VmRSS:") for pid in workers])
        time.sleep(0.002)

scene = default_scene().with_render(width=1920, height=1080, depth=3, samples=1, dtype={dtype!r})
with Renderer(2) as renderer:
    renderer.render(scene)
    pids = lambda: [os.getpid()] + renderer._pool.pids()
    sampler = threading.Thread(target=sample, args=(pids,), daemon=True)
    sampler.start()
    times = []
    for _ in range(3):
        result = renderer.render(scene)
        times.append(result.seconds)
        result.image.sum()  # read the image, as writing it would
        del result
    sampling[0] = False
    sampler.join()
times.sort()
print(json.dumps({{"ms": round(times[1] * 1000, 1), "peak_mb_total_pss": peak["total"],
                  "peak_mb_parent": peak["parent"], "peak_mb_worker": peak["worker"]}}))
"""


MESH_SCRIPT = (
    HD_SCRIPT.replace(
        "from tracer.scene.loader import default_scene\n",
        "sys.path.insert(0, {scripts!r})\nfrom study import triangles\n",
    )
    .replace(
        "scene = default_scene().with_render(width=1920, height=1080, depth=3, samples=1, dtype={dtype!r})",
        "scene = triangles({count}).with_render(width=640, height=480, depth=3, samples=1, dtype={dtype!r})",
    )
    .replace(
        "    renderer.render(scene)\n    pids",
        "    started = time.perf_counter()\n    renderer.render(scene)\n"
        "    first = time.perf_counter() - started\n    pids",
    )
    .replace('"ms": round(times[1] * 1000, 1),', '"ms": round(times[1] * 1000, 1), "first_ms": round(first * 1000, 1),')
)


def mesh(count: int) -> dict:
    """A UV-sphere mesh of about count triangles in place of the vane, 640x480, 2 workers, in a fresh process:
    the median of 3 frames after the first (which builds the mesh's hierarchy in each worker), and peak memory."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    script = MESH_SCRIPT.format(root=str(root), scripts=str(root / "scripts"), dtype="float64", count=count)
    output = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    figures = json.loads(output.strip().splitlines()[-1])
    return {"triangles": count, **{key: round(value, 1) for key, value in figures.items()}}


def full_hd(dtype: str) -> dict:
    """1920x1080 in a fresh process, so that its peak resident memory is this render's alone."""
    import subprocess

    script = HD_SCRIPT.format(root=str(Path(__file__).resolve().parents[1]), dtype=dtype)
    output = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    figures = json.loads(output.strip().splitlines()[-1])
    return {key: round(value, 1) for key, value in figures.items()}


def animation(repeats: int) -> dict:
    """`animate` on the default scene: 120 frames at 640x480, 2 workers, PNG files written; whole frames against
    incremental ones (the same bytes), alternating in the same run, wall and CPU seconds (the process and its
    workers); and what share of pixels each frame traces."""
    import resource
    import statistics
    import tempfile

    from tracer.frames import incremental
    from tracer.frames.animate import animate, headings
    from tracer.workers.parallel import Renderer

    def cpu() -> float:
        # this process and its finished children (the pool's workers, stopped when animate returns): on a shared
        # machine the wall time follows the other processes' load, the CPU time much less
        own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    scene = default_scene().with_render(width=640, height=480, workers=2)
    seconds: dict[str, list[float]] = {"whole": [], "incremental": []}
    cpu_seconds: dict[str, list[float]] = {"whole": [], "incremental": []}
    for _ in range(repeats):
        for name in seconds:
            with tempfile.TemporaryDirectory() as folder:
                before = cpu()
                result = animate(scene, Path(folder), 1, 120, incremental=name == "incremental")
                cpu_seconds[name].append(cpu() - before)
            seconds[name].append(result.seconds)
    pixels = scene.render.width * scene.render.height
    shares, whole_frames = [], 0
    with Renderer(2) as renderer:
        turns = headings(scene, 120).tolist()
        for _, result in incremental.render_frames(renderer, scene, iter(list(enumerate(turns, 1)))):
            share = result.rays.camera / pixels
            whole_frames += share == 1.0
            shares.append(share)
    retraced = [share for share in shares if share < 1.0]
    whole, fast = statistics.median(seconds["whole"]), statistics.median(seconds["incremental"])
    return {
        "repeats": repeats,
        "whole_seconds": [round(x, 2) for x in seconds["whole"]],
        "incremental_seconds": [round(x, 2) for x in seconds["incremental"]],
        "seconds": round(fast, 2),
        "whole_median_seconds": round(whole, 2),
        "speedup": round(whole / fast, 2),
        "whole_cpu_seconds": [round(x, 2) for x in cpu_seconds["whole"]],
        "incremental_cpu_seconds": [round(x, 2) for x in cpu_seconds["incremental"]],
        "cpu_speedup": round(
            statistics.median(cpu_seconds["whole"]) / statistics.median(cpu_seconds["incremental"]), 2
        ),
        "ms_per_frame": round(fast / 120 * 1000, 1),
        "whole_frames": whole_frames,
        "retraced_share_mean": round(statistics.mean(retraced), 4) if retraced else None,
        "retraced_share_max": round(max(retraced), 4) if retraced else None,
        "traced_share_overall": round(statistics.mean(shares), 4),
    }


def edits(repeats: int = 5) -> dict:
    """tracer/frames/edits.py on the default scene at 640x480 in one process: the editable image against a plain render,
    and four edits (medians of repeats): the share of pixels each traces again and its time."""
    from tracer.frames import edits as editing
    from tracer.scene import scene as sc

    scene = default_scene().with_render(width=640, height=480)
    with Renderer(1) as renderer:
        renderer.render(scene)
        plain = statistics.median(renderer.render(scene).seconds for _ in range(repeats))
    started = time.perf_counter()
    image = editing.EditableImage(scene)
    editable = time.perf_counter() - started
    segments = image.segments
    fin = next(obj for obj in scene.objects if obj.name == "tail_fin")
    sun = next(k for k, light in enumerate(scene.lights) if isinstance(light, sc.DirectionalLight))
    cases = {
        "tail fin's material": editing.MaterialEdit(fin.material, sc.Material((0.9, 0.1, 0.1), 20.0, 0.2)),
        "ball moved": editing.TransformEdit("ball", (0.3, 0.0, 3.3), (0.0, 0.0, 0.0)),
        "sun's intensity": editing.LightEdit(sun, 0.3),
        "ground's material": editing.MaterialEdit("tiles", sc.Material((0.5, 0.5, 0.5), 0.0, 0.3)),
    }
    rows = {}
    for label, edit in cases.items():
        times = []
        for _ in range(repeats):
            started = time.perf_counter()
            image.apply(edit)
            times.append(time.perf_counter() - started)
        rows[label] = {
            "traced_share": round(image.last_traced / (640 * 480), 4),
            "ms": round(1000 * statistics.median(times), 1),
        }
    return {
        "plain_ms": round(plain * 1000, 1),
        "editable_ms": round(editable * 1000, 1),
        "segments": int(segments.pixel.size),
        "segments_mb": round(sum(column.nbytes for column in segments.columns) / 1e6, 1),
        "edits": rows,
    }


def meshes() -> dict:
    rows = [mesh(count) for count in (1_000, 10_000, 100_000, 1_000_000)]
    by_count = {row["triangles"]: row for row in rows}
    return {"rows": rows, "ratio_100k_to_1k": round(by_count[100_000]["ms"] / by_count[1_000]["ms"], 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument(
        "--animation-only", action="store_true", help="only the 120-frame animation (whole against incremental)"
    )
    parser.add_argument("--animation-repeats", type=int, default=3)
    parser.add_argument(
        "--meshes-only", action="store_true", help="only the mesh scaling (1,000 to 1,000,000 triangles)"
    )
    parser.add_argument("--edits-only", action="store_true", help="only the edits (tracer/frames/edits.py)")
    args = parser.parse_args()
    if args.animation_only:
        print(json.dumps(animation(args.animation_repeats)))
        return
    if args.meshes_only:
        print(json.dumps(meshes()))
        return
    if args.edits_only:
        print(json.dumps(edits()))
        return
    scene = default_scene().with_render(width=args.width, height=args.height, depth=3, samples=1)
    report: dict = {
        "scene": "default",
        "width": args.width,
        "height": args.height,
        "depth": 3,
        "machine": f"{platform.machine()} {platform.python_version()}",
        "repeats": args.repeats,
    }
    for dtype in ("float64", "float32"):
        for workers in (1, 2):
            figures = bench(scene.with_render(dtype=dtype), workers, args.repeats)
            report[f"{dtype}_w{workers}"] = figures
            print(
                f"{dtype} {workers} worker(s): {figures['ms']:7.1f} ms/frame, {figures['rays']} rays "
                f"({figures['camera_rays']} camera, {figures['shadow_rays']} shadow, "
                f"{figures['reflection_rays']} reflection), {figures['mrays_per_s']:.2f} Mrays/s"
            )
        report[f"{dtype}_scaling_1_to_2"] = round(report[f"{dtype}_w1"]["ms"] / report[f"{dtype}_w2"]["ms"], 2)
    for dtype in ("float64", "float32"):
        hd = report[f"hd_1920x1080_{dtype}_w2"] = full_hd(dtype)
        print(
            f"1920x1080 {dtype} 2 workers: {hd['ms']:.1f} ms, peak memory {hd['peak_mb_total_pss']:.0f} MB for the "
            f"parent and its workers together (proportional set size); largest resident sets "
            f"{hd['peak_mb_parent']:.0f} MB (parent), {hd['peak_mb_worker']:.0f} MB (a worker)"
        )
    report["animation_120_frames_640x480"] = motion = animation(args.animation_repeats)
    print(
        f"animation, 120 frames at 640x480 (PNG files included): whole frames {motion['whole_median_seconds']:.2f} s, "
        f"incremental {motion['seconds']:.2f} s ({motion['speedup']:.2f}x, medians of {motion['repeats']}); "
        f"{motion['whole_frames']} frames traced whole, the others {100 * motion['retraced_share_mean']:.1f}% of "
        f"their pixels on average"
    )
    report["meshes_640x480_w2"] = scaling = meshes()
    print(
        "meshes at 640x480, 2 workers: "
        + ", ".join(
            f"{row['triangles']:,} triangles {row['ms']:.0f} ms ({row['peak_mb_total_pss']:.0f} MB)"
            for row in scaling["rows"]
        )
        + f"; 100,000 against 1,000: {scaling['ratio_100k_to_1k']:.2f}x"
    )
    report["edits_640x480"] = editing = edits()
    print(
        f"edits at 640x480: editable image {editing['editable_ms']:.0f} ms (plain {editing['plain_ms']:.0f} ms); "
        + ", ".join(f"{label} {row['ms']:.0f} ms" for label, row in editing["edits"].items())
    )
    small = scene.with_render(width=64, height=48)
    started = time.perf_counter()
    render_reference(small)
    reference_seconds = (time.perf_counter() - started) * (args.width * args.height) / (64 * 48)
    report["reference_ms_scaled"] = round(reference_seconds * 1000, 1)
    report["speedup_vs_reference_2_workers"] = round(reference_seconds * 1000 / report["float64_w2"]["ms"], 1)
    print(
        f"per-pixel reference: {reference_seconds:.1f} s per frame (64x48 timed, scaled to {args.width}x{args.height})"
    )
    print(json.dumps(report))


if __name__ == "__main__":
    main()
