"""Frames per second of an animation traced on a Dask cluster on this machine (1 and 2 workers) against the local
worker pool, and what a frame costs in transfer.

    python scripts/bench_cluster.py [--frames 48 --width 640 --height 480 --chunk 8 --repeats 3]

Each configuration renders the same frames into a fresh folder; medians of the repeats, run in turn (local, 1
worker, 2 workers) so that the machine's noise falls on all alike. Transfer: the scene sent once to each worker
(pickled) and each frame's PNG bytes sent back.
"""

from __future__ import annotations

import argparse
import pickle
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.dask_cluster import LocalCluster  # noqa: E402
from tracer.frames.animate import animate, frame_path  # noqa: E402
from tracer.frames.cluster import animate_on_cluster  # noqa: E402
from tracer.scene.loader import default_scene  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=48)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--chunk", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    options = parser.parse_args()
    scene = default_scene().with_render(width=options.width, height=options.height, workers=2)
    seconds: dict[str, list[float]] = {"local pool, 2 processes": [], "Dask, 1 worker": [], "Dask, 2 workers": []}
    png_bytes = 0
    with LocalCluster(workers=1) as one, LocalCluster(workers=2) as two:
        for _ in range(options.repeats):
            for name in seconds:
                folder = Path(tempfile.mkdtemp(prefix="weathervane-bench-"))
                started = time.perf_counter()
                if name.startswith("local"):
                    animate(scene, folder, 1, options.frames)
                else:
                    address = one.address if "1 worker" in name else two.address
                    animate_on_cluster(scene, folder, 1, options.frames, address, chunk_frames=options.chunk)
                seconds[name].append(time.perf_counter() - started)
                png_bytes = sum(frame_path(folder, f).stat().st_size for f in range(1, options.frames + 1))
                shutil.rmtree(folder)
    print(
        f"{options.frames} frames at {options.width}x{options.height}, runs of {options.chunk} frames per task, "
        f"medians of {options.repeats}:"
    )
    for name, runs in seconds.items():
        median = statistics.median(runs)
        print(f"  {name:24} {median:6.2f} s  {options.frames / median:5.1f} frames/s")
    print(
        f"transfer: scene {len(pickle.dumps(scene)) / 1024:.1f} KB once per worker, "
        f"{png_bytes / options.frames / 1024:.1f} KB of PNG back per frame"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
