"""What triangle meshes cost against the default frame -> ms per frame, ratios, and a million triangles' first frame
and peak memory (`make bench-meshes`).

Usage: python scripts/bench_meshes.py [--rounds 5] [--frames 5] [--big 1000000] [--skip-big] [--dtype float64]

Frames part: one process with one persistent 2-worker Renderer; each round renders, for each case in turn
(alternating the order between rounds), a warm-up frame and then FRAMES frames: the default scene, a UV sphere of
1,000, 16,000 and 100,000 triangles and Suzanne at subdivision level 2 (about 15,700 triangles) in the vane's
place, 640x480, depth 3. A case's figure is the median over rounds of its frames' median; its ratio to the default
frame is the median of the per-round ratios (both measured in the same round, so they see the same load).
Big part: a scene file with a UV sphere of BIG triangles is rendered by `python -m tracer render` in a fresh
process (2 workers, 640x480): the wall time from the command's start to its PNG written, and the peak of the sum of
the proportional set sizes (Pss) of the command and its workers, sampled every 10 ms.
The last line of the output is one JSON object with every figure.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import mesh_scenes  # noqa: E402

import tracer  # noqa: E402


def frame_cases(dtype: str) -> dict:
    settings = {"width": 640, "height": 480, "depth": 3, "samples": 1, "dtype": dtype}
    cases = {"default": tracer.default_scene().with_render(**settings)}
    for count in (1_000, 16_000, 100_000):
        document = mesh_scenes.mesh_scene(*mesh_scenes.uv_sphere(count), **settings)
        cases[f"sphere{count // 1000}k"] = tracer.scene_from_dict(document)
    cases["suzanne2"] = tracer.scene_from_dict(mesh_scenes.mesh_scene(*mesh_scenes.suzanne(2), **settings))
    return cases


def run_frames(rounds: int, frames: int, dtype: str) -> dict:
    cases = frame_cases(dtype)
    times: dict[str, list[float]] = {name: [] for name in cases}
    with tracer.Renderer(2) as renderer:
        for round_index in range(rounds):
            order = list(cases) if round_index % 2 == 0 else list(reversed(cases))
            for name in order:
                renderer.render(cases[name])
                seconds = [renderer.render(cases[name]).seconds for _ in range(frames)]
                times[name].append(statistics.median(seconds))
    triangles = {name: len(scene.objects[1].triangles) for name, scene in cases.items() if name != "default"}
    report = {"dtype": dtype, "rounds": rounds, "frames": frames, "cases": {}}
    for name, values in times.items():
        ratio = statistics.median(a / b for a, b in zip(values, times["default"], strict=True))
        report["cases"][name] = {
            "ms": round(1000 * statistics.median(values), 1),
            "over_default": round(ratio, 2),
            "triangles": triangles.get(name),
        }
    if "sphere1k" in times and "sphere100k" in times:
        report["sphere100k_over_sphere1k"] = round(
            statistics.median(a / b for a, b in zip(times["sphere100k"], times["sphere1k"], strict=True)), 2
        )
    return report


def process_tree_pss(root: int) -> int:
    """The sum of Pss (bytes) of process root and its descendants."""
    children: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat") as stat:
                    parent = int(stat.read().rsplit(")", 1)[1].split()[1])
            except OSError:
                continue
            children.setdefault(parent, []).append(int(name))
    total, stack = 0, [root]
    while stack:
        pid = stack.pop()
        stack.extend(children.get(pid, []))
        try:
            with open(f"/proc/{pid}/smaps_rollup") as rollup:
                for line in rollup:
                    if line.startswith("Pss:"):
                        total += int(line.split()[1]) * 1024
                        break
        except OSError:
            continue
    return total


def run_big(count: int, dtype: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench-meshes-") as folder:
        scene_path, image_path = Path(folder) / "big.json", Path(folder) / "big.png"
        document = mesh_scenes.mesh_scene(*mesh_scenes.uv_sphere(count), width=640, height=480, dtype=dtype)
        scene_path.write_text(json.dumps(document))
        started = time.perf_counter()
        command = [sys.executable, "-m", "tracer", "render", str(scene_path), "-o", str(image_path)]
        process = subprocess.Popen([*command, "--workers", "2", "--quiet"], cwd=ROOT)
        peak = 0
        done = threading.Event()

        def sample() -> None:
            nonlocal peak
            while not done.is_set():
                peak = max(peak, process_tree_pss(process.pid))
                time.sleep(0.01)

        sampler = threading.Thread(target=sample)
        sampler.start()
        code = process.wait()
        seconds = time.perf_counter() - started
        done.set()
        sampler.join()
        return {
            "triangles": len(document["objects"][1]["triangles"]),
            "scene_file_mb": round(scene_path.stat().st_size / 2**20, 1),
            "first_frame_s": round(seconds, 2),
            "peak_pss_mb": round(peak / 2**20, 1),
            "exit": code,
        }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--dtype", default="float64", choices=("float64", "float32"))
    parser.add_argument("--big", type=int, default=1_000_000, help="triangles of the big scene")
    parser.add_argument("--skip-big", action="store_true")
    parser.add_argument("--skip-frames", action="store_true")
    args = parser.parse_args()
    report: dict = {}
    if not args.skip_frames:
        report["frames"] = run_frames(args.rounds, args.frames, args.dtype)
        for name, entry in report["frames"]["cases"].items():
            print(f"{name:12s} {entry['ms']:8.1f} ms  {entry['over_default']:5.2f}x default", flush=True)
    if not args.skip_big:
        report["big"] = run_big(args.big, args.dtype)
        print(f"big: {report['big']}", flush=True)
    print(json.dumps(report))


if __name__ == "__main__":
    main()
