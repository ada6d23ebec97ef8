"""A scene file's render, the working tree against a git commit: `python -m tracer render` of each in turn.

Usage: python scripts/bench_scene_commits.py SCENE --ref <commit> [--rounds 2] [--width W --height H]

REF is exported with `git archive` into a temporary folder (bench_compare.export: the repository is not touched).
Each round renders the scene once with REF's tracer and once with the working tree's, alternating which goes first,
each a fresh process (its workers started and the scene prepared inside the time, as a user's command runs), timed
from start to exit. Printed: each render's seconds, each side's median, whether the two images have the same bytes
(the PNGs are written to a temporary folder), and one JSON line with every figure.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_compare import ROOT, export


def render(root: Path, scene: Path, out: Path, flags: list[str]) -> float:
    """Seconds for `python -m tracer render scene -o out` run from root (its tracer), start to exit."""
    started = time.perf_counter()
    command = [sys.executable, "-m", "tracer", "render", str(scene), "-o", str(out), "--quiet", *flags]
    subprocess.run(command, cwd=root, check=True)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path, help="the scene file (docs/scene-format.md)")
    parser.add_argument("--ref", required=True, help="the commit to compare the working tree with")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--width", type=int, help="image width (the scene's by default)")
    parser.add_argument("--height", type=int, help="image height (the scene's by default)")
    args = parser.parse_args()
    flags = [
        flag for name in ("width", "height") if getattr(args, name) for flag in (f"--{name}", str(getattr(args, name)))
    ]
    scene = args.scene.resolve()
    seconds: dict[str, list[float]] = {"ref": [], "new": []}
    with tempfile.TemporaryDirectory() as folder:
        old_root = Path(folder) / "ref"
        old_root.mkdir()
        export(args.ref, old_root)
        images = {side: Path(folder) / f"{side}.png" for side in seconds}
        for round_ in range(args.rounds):
            for side in ("ref", "new") if round_ % 2 == 0 else ("new", "ref"):
                taken = render(old_root if side == "ref" else ROOT, scene, images[side], flags)
                seconds[side].append(taken)
                print(f"round {round_ + 1} {side}: {taken:.2f} s", flush=True)
        same = images["ref"].read_bytes() == images["new"].read_bytes()
    medians = {side: statistics.median(values) for side, values in seconds.items()}
    print(
        f"median ref {medians['ref']:.2f} s, new {medians['new']:.2f} s, new/ref {medians['new'] / medians['ref']:.3f}"
    )
    print("images: " + ("the same bytes" if same else "different bytes"))
    print(json.dumps({"ref": args.ref, "scene": str(args.scene), "seconds": seconds, "same_bytes": same}))


if __name__ == "__main__":
    main()
