"""What an incremental animation frame costs: its pixels' trace in a worker, the run's start, the PNG in the parent.

Usage: python scripts/bench_incremental_frame.py
The default 120-frame animation at 640x480, its first run (incremental.py), thread CPU times in one process: the
image without the vane with its footprint, the run's marks (footprint.HeadingMarks: the marked pixels' trees traced
again and tested against the parts' oriented boxes at each heading), then for the run's headings TracedScene (the
still objects' hierarchy kept, bvh._still_subtree) and the trace of the frame's own pixels (medians), one frame at a
time (as Blender's engine asks for them) and FRAMES_PER_TASK frames in one trace (as animate's workers take them);
the trace of fewer pixels shows its fixed part; and the writer's PNG (images.FramePng) of a frame on its own and
after the frame before it. No assert: the machine is shared.
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
from tracer.geometry.footprint import heading_parts, swept_volume
from tracer.scene.loader import default_scene
from tracer.tracing.images import FramePng, to_8bit
from tracer.tracing.wavefront import TracedScene
from tracer.workers.parallel import FRAMES_PER_TASK
from tracer.workers.resources import band_samples


def cpu(call) -> float:
    start = time.thread_time()
    call()
    return (time.thread_time() - start) * 1e3


def main() -> None:
    scene = default_scene().with_render(width=640, height=480, workers=2)
    samples = band_samples(scene.render)
    run = [heading for _, heading in next(incremental.runs(enumerate(headings(scene, 120).tolist(), 1)))]
    volume = swept_volume(scene, np.dtype(scene.render.dtype))
    touched = np.zeros((scene.render.height, scene.render.width), dtype=bool)
    rows = np.arange(scene.render.height)
    still = incremental.without_vane(scene)
    whole = cpu(lambda: TracedScene(still).render_rows(rows, samples, volume, touched))
    candidates = np.flatnonzero(touched)
    print(f"run of {len(run)} frames; the boxes' pixels {candidates.size} ({candidates.size / touched.size:.1%})")
    print(f"the image without the vane with its footprint, one process: {whole:.0f} ms")
    parts = []
    spent = cpu(lambda: parts.append(heading_parts(scene, np.dtype(scene.render.dtype), np.array(run))))
    print(f"the vane's parts at the run's headings, one process: {spent:.0f} ms")
    marks = []
    spent = cpu(lambda: marks.append(incremental._marks(still, candidates, parts[0])))
    print(f"the run's marks, one process: {spent:.0f} ms")
    prepare, trace, counts = [], [], []
    for k, heading in enumerate(run):
        if k and heading == run[k - 1]:
            continue  # the frame before's image: nothing traced
        pixels = marks[0].at(heading)
        start = time.thread_time()
        prepared = TracedScene(scene.with_heading(heading))
        middle = time.thread_time()
        prepared.render_pixels(pixels, samples)
        prepare.append((middle - start) * 1e3)
        trace.append((time.thread_time() - middle) * 1e3)
        counts.append(pixels.size)
    print(
        f"per frame ({len(run) - len(counts)} at the heading before traced nothing): pixels "
        f"{statistics.mean(counts):.0f} ({statistics.mean(counts) / touched.size:.1%}), prepare "
        f"{statistics.median(prepare):.2f} ms, trace {statistics.median(trace):.1f} ms"
    )
    traced = [heading for k, heading in enumerate(run) if k == 0 or heading != run[k - 1]]
    batches = [tuple(traced[k : k + FRAMES_PER_TASK]) for k in range(0, len(traced), FRAMES_PER_TASK)]
    prepare, trace = [], []
    for batch in batches:
        start = time.thread_time()
        prepared = TracedScene(scene, batch)
        middle = time.thread_time()
        prepared.render_frame_pixels([marks[0].at(heading) for heading in batch], samples)
        prepare.append((middle - start) * 1e3 / len(batch))
        trace.append((time.thread_time() - middle) * 1e3 / len(batch))
    print(
        f"per frame, {FRAMES_PER_TASK} frames in one trace ({len(batches)} batches): prepare "
        f"{statistics.median(prepare):.2f} ms, trace {statistics.median(trace):.1f} ms"
    )
    prepared_scene = TracedScene(scene.with_heading(run[-1]))
    pixels = marks[0].at(run[-1])
    for count in (100, 1000, min(5000, pixels.size)):
        chosen = pixels[np.linspace(0, pixels.size - 1, count).astype(np.int64)]
        times = [cpu(lambda chosen=chosen: prepared_scene.render_pixels(chosen, samples)) for _ in range(7)]
        print(f"trace {count} of a frame's pixels: {statistics.median(times):.1f} ms")
    plain = [cpu(lambda: prepared_scene.render_rows(rows, samples)) for _ in range(3)]
    print(f"a whole frame, one process: {statistics.median(plain):.0f} ms")
    frames = [to_8bit(TracedScene(scene.with_heading(heading)).render_rows(rows, samples)[0]) for heading in run[-3:]]
    alone = [cpu(lambda: FramePng().encode(frames[-1])) for _ in range(5)]
    after = []
    for _ in range(5):
        png = FramePng()
        png.encode(frames[-2])
        after.append(cpu(lambda png=png: png.encode(frames[-1])))
    print(
        f"the PNG of one frame from its 8-bit pixels (images.FramePng): on its own {statistics.median(alone):.1f} "
        f"ms, after the frame before it {statistics.median(after):.1f} ms"
    )


if __name__ == "__main__":
    main()
