"""What render passes cost: the default frame (640x480) with no pass, with the data passes, with the Whitted passes
and with every pass, alternating in one process, each with a kept worker pool of its own; medians of the rounds.
Beside the wall time, the CPU time per frame (user + system of this process and the case's workers, over the rounds):
on a shared machine the wall time follows the other processes' load, the CPU time much less.

    .venv/bin/python scripts/bench_passes.py --rounds 7
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tracer.scene import passes as ps
from tracer.scene.loader import default_scene
from tracer.workers.parallel import Renderer

CASES = {
    "none": (),
    "data": ("depth", "mist", "normal", "position", "object_index", "material_index"),
    "whitted": (*ps.WHITTED, "shadow"),
    "all": tuple(ps.PASSES),
}


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--samples", type=int, default=1)
    args = parser.parse_args()
    base = default_scene().with_render(width=args.width, height=args.height, samples=args.samples)
    seconds: dict[str, list[float]] = {case: [] for case in CASES}
    cpu: dict[str, float] = dict.fromkeys(CASES, 0.0)
    # a pool per case, kept: a worker keeps the scene it prepared last, and the four cases are four scenes
    renderers = {case: Renderer(2) for case in CASES}
    try:
        for case, passes in CASES.items():  # warm: workers started, each scene prepared once
            renderers[case].render(base.with_render(passes=passes))
        for _ in range(args.rounds):
            for case, passes in CASES.items():
                scene = base.with_render(passes=passes)
                workers = renderers[case]._pool.pids()
                used = time.process_time() + sum(cpu_seconds(pid) for pid in workers)
                started = time.perf_counter()
                renderers[case].render(scene)
                seconds[case].append(time.perf_counter() - started)
                cpu[case] += time.process_time() + sum(cpu_seconds(pid) for pid in workers) - used
    finally:
        for renderer in renderers.values():
            renderer.close()
    medians = {case: statistics.median(values) * 1000 for case, values in seconds.items()}
    report = {
        "size": f"{args.width}x{args.height}",
        "samples": args.samples,
        "rounds": args.rounds,
        "median_ms": {case: round(value, 1) for case, value in medians.items()},
        "over_none": {case: round(value / medians["none"], 3) for case, value in medians.items()},
        "cpu_ms_per_frame": {case: round(value / args.rounds * 1000, 1) for case, value in cpu.items()},
        "cpu_over_none": {case: round(value / cpu["none"], 3) for case, value in cpu.items()},
    }
    print(json.dumps(report))


if __name__ == "__main__":
    main()
