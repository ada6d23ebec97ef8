"""Same-run comparison of the 120-frame animation, whole and incremental, between commits and the working tree.

Usage: python scripts/bench_animation_commits.py --ref <commit> [--ref <commit> ...] [--rounds 3]
Each REF is exported with `git archive` into a temporary folder (bench_compare.export). Each round runs, for every
side in turn (the REFs, then the working tree) and each mode (whole, incremental), one fresh process that calls
`animate` on the default scene (120 frames, 640x480, 2 workers, PNG files written) and reports its wall seconds and
the CPU seconds of the process and its workers (getrusage; the pool's workers have stopped when animate returns):
on a shared machine the wall time follows the other processes' load, the CPU time much less. Per side: the medians
over rounds and the whole / incremental ratios of each round. The last line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_compare import ROOT, export

CHILD = """
import json, resource, sys, tempfile, time
from pathlib import Path
sys.path.insert(0, ".")
from tracer.frames.animate import animate
from tracer.scene.loader import default_scene
def cpu():
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
scene = default_scene().with_render(width=640, height=480, workers=2)
with tempfile.TemporaryDirectory() as folder:
    before, started = cpu(), time.perf_counter()
    animate(scene, Path(folder), 1, 120, incremental=sys.argv[1] == "incremental")
    print(json.dumps({"wall": time.perf_counter() - started, "cpu": cpu() - before}))
"""


def run(root: Path, mode: str) -> dict:
    output = subprocess.run(
        [sys.executable, "-c", CHILD, mode], cwd=root, check=True, capture_output=True, text=True
    ).stdout
    return json.loads(output.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", action="append", required=True, help="a commit to compare (repeatable)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        sides = {}
        for ref in args.ref:
            folder = Path(temporary) / ref.replace("/", "_")
            folder.mkdir()
            sides[ref] = export(ref, folder)
        sides["working tree"] = ROOT
        figures = {side: {"whole": [], "incremental": []} for side in sides}
        for round_number in range(1, args.rounds + 1):
            for side, root in sides.items():
                for mode in ("whole", "incremental"):
                    figures[side][mode].append(run(root, mode))
                    print(f"round {round_number} {side} {mode}: {figures[side][mode][-1]}", flush=True)
    report = {}
    for side, modes in figures.items():
        whole, fast = modes["whole"], modes["incremental"]
        report[side] = {
            "whole_cpu": round(statistics.median(x["cpu"] for x in whole), 2),
            "incremental_cpu": round(statistics.median(x["cpu"] for x in fast), 2),
            "whole_wall": round(statistics.median(x["wall"] for x in whole), 2),
            "incremental_wall": round(statistics.median(x["wall"] for x in fast), 2),
            "cpu_ratios": [round(a["cpu"] / b["cpu"], 2) for a, b in zip(whole, fast, strict=True)],
            "wall_ratios": [round(a["wall"] / b["wall"], 2) for a, b in zip(whole, fast, strict=True)],
        }
        print(f"{side}: {report[side]}")
    print(json.dumps(report))


if __name__ == "__main__":
    main()
