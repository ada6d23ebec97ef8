"""What an incremental animation frame costs in a worker: preparing the turned scene and tracing the marked pixels.

Usage: python scripts/bench_incremental_frame.py
The default 120-frame animation at 640x480: the first run's marked pixels (incremental.py), then for the run's later
headings the thread CPU time of PreparedScene (the still objects' hierarchy kept, bvh._still_subtree) and of tracing
the marked pixels in one process (medians); the trace of fewer pixels shows its fixed part; and the PNG writer's
Pillow encode of one frame from its 8-bit pixels. No assert: the machine is shared.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tracer.frames import incremental
from tracer.frames.animate import headings
from tracer.geometry.footprint import swept_volume
from tracer.scene.loader import default_scene
from tracer.tracing.images import encode_png, to_8bit
from tracer.tracing.wavefront import PreparedScene
from tracer.workers.resources import band_samples


def cpu(call) -> float:
    start = time.thread_time()
    call()
    return (time.thread_time() - start) * 1e3


def main() -> None:
    scene = default_scene().with_render(width=640, height=480, workers=2)
    samples = band_samples(scene.render)
    run = [heading for _, heading in next(incremental.runs(enumerate(headings(scene, 120).tolist(), 1)))]
    volume = swept_volume(scene, np.dtype(scene.render.dtype), np.array(run))
    touched = np.zeros((scene.render.height, scene.render.width), dtype=bool)
    rows = np.arange(scene.render.height)
    whole = cpu(lambda: PreparedScene(scene.with_heading(run[0])).render_rows(rows, samples, volume, touched))
    pixels = np.flatnonzero(touched)
    print(f"run of {len(run)} frames; marked pixels {pixels.size} ({pixels.size / touched.size:.1%})")
    print(f"first frame with its footprint, one process: {whole:.0f} ms")
    prepare, trace = [], []
    for heading in run[1:]:
        start = time.thread_time()
        prepared = PreparedScene(scene.with_heading(heading))
        middle = time.thread_time()
        prepared.render_pixels(pixels, samples)
        prepare.append((middle - start) * 1e3)
        trace.append((time.thread_time() - middle) * 1e3)
    print(f"per later frame: prepare {statistics.median(prepare):.2f} ms, trace {statistics.median(trace):.1f} ms")
    prepared_scene = PreparedScene(scene.with_heading(run[1]))
    for count in (100, 1000, 5000):
        chosen = pixels[np.linspace(0, pixels.size - 1, count).astype(np.int64)]
        times = [cpu(lambda chosen=chosen: prepared_scene.render_pixels(chosen, samples)) for _ in range(7)]
        print(f"trace {count} of the marked pixels: {statistics.median(times):.1f} ms")
    plain = [cpu(lambda: prepared_scene.render_rows(rows, samples)) for _ in range(3)]
    print(f"a whole frame, one process: {statistics.median(plain):.0f} ms")
    colours, _ = prepared_scene.render_rows(rows, samples)
    converted = to_8bit(colours)
    png = [cpu(lambda: encode_png(colours, converted=converted)) for _ in range(5)]
    print(f"the PNG of one frame from its 8-bit pixels (Pillow, zlib level 6): {statistics.median(png):.1f} ms")


if __name__ == "__main__":
    main()
