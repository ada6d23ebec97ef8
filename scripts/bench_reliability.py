"""The figures of docs/reliability.md: recovery from a killed worker, Ctrl-C, memory at high sample counts, loading
many objects, and how soon a long animation starts. Prints one line per figure and a JSON line last.

    .venv/bin/python scripts/bench_reliability.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tracer import default_scene  # noqa: E402
from tracer.scene.loader import default_scene_dict, scene_from_dict  # noqa: E402
from tracer.scene.motion import Motion, iter_headings, simulate  # noqa: E402
from tracer.workers.parallel import Renderer  # noqa: E402


def kill_recovery(repeats: int) -> dict[str, float]:
    """A 640x480 frame at 16 spp on 2 workers, as it is and with one worker killed after the first band."""
    scene = default_scene().with_render(samples=16)
    plain, killed = [], []
    with Renderer(2) as renderer:
        renderer.render(scene)  # the workers' first frame prepares their caches
        for _ in range(repeats):
            started = time.perf_counter()
            renderer.render(scene)
            plain.append(time.perf_counter() - started)

            def kill(done: int, _total: int) -> None:
                if done == 1:
                    os.kill(renderer._pool.pids()[0], signal.SIGKILL)

            started = time.perf_counter()
            renderer.render(scene, kill)
            killed.append(time.perf_counter() - started)
    return {"frame_s": statistics.median(plain), "frame_with_a_killed_worker_s": statistics.median(killed)}


def ctrl_c_exit(repeats: int) -> float:
    """Seconds from Ctrl-C (SIGINT to the process group) to the exit of a 2-worker render."""
    times = []
    for _ in range(repeats):
        process = subprocess.Popen(
            [sys.executable, "-m", "tracer", "render", "-o", "/tmp/weathervane-bench.png", "--samples", "64"],
            cwd=ROOT,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        time.sleep(2.0)
        sent = time.perf_counter()
        os.killpg(process.pid, signal.SIGINT)
        process.wait()
        times.append(time.perf_counter() - sent)
    return statistics.median(times)


def peak_memory_mb(samples: int) -> float:
    """Peak resident memory (MB) of a 1-worker render of 160x32 at this many samples per pixel."""
    code = (
        "import resource; from tracer import default_scene; from tracer.workers.parallel import render; "
        f"render(default_scene().with_render(width=160, height=32, samples={samples}), workers=1); "
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return int(done.stdout.strip()) / 1024


def load_seconds(count: int) -> float:
    document = default_scene_dict()
    template = document["objects"][0]
    document["objects"] = [dict(template, name=f"o{i}") for i in range(count)]
    del document["vane"]
    started = time.perf_counter()
    scene_from_dict(document)
    return time.perf_counter() - started


def first_headings_seconds(frames: int) -> tuple[float, float]:
    """Seconds to the first piece of headings of a long animation, and to all of them."""
    started = time.perf_counter()
    next(iter_headings(Motion(), frames, 0.0))
    first = time.perf_counter() - started
    started = time.perf_counter()
    simulate(Motion(), frames, 0.0)
    return first, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    figures: dict[str, object] = {}
    figures.update(kill_recovery(args.repeats))
    print(
        f"640x480 16 spp, 2 workers: {figures['frame_s'] * 1000:.0f} ms a frame; "
        f"{figures['frame_with_a_killed_worker_s'] * 1000:.0f} ms with a worker killed after the first band"
    )
    figures["ctrl_c_exit_s"] = ctrl_c_exit(args.repeats)
    print(f"Ctrl-C to exit, 2 workers mid-render: {figures['ctrl_c_exit_s']:.2f} s")
    figures["peak_mb_by_samples"] = {spp: peak_memory_mb(spp) for spp in (16, 64, 256, 1024)}
    print("160x32, 1 worker, peak resident MB by samples per pixel:", figures["peak_mb_by_samples"])
    figures["load_s_by_objects"] = {count: load_seconds(count) for count in (10_000, 20_000, 40_000)}
    print("loading N objects, seconds:", {k: round(v, 2) for k, v in figures["load_s_by_objects"].items()})
    first, whole = first_headings_seconds(100_000)
    figures["headings_100k_first_piece_s"], figures["headings_100k_all_s"] = first, whole
    print(f"100,000 frames of motion: first {2048} headings in {first * 1000:.0f} ms, all in {whole:.1f} s")
    figures["self_peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
