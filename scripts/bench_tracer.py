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

from tracer.loader import default_scene
from tracer.parallel import Renderer
from tracer.reference import render_reference


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args()
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
