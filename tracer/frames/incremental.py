"""Frames of a turning vane -> their images, tracing again only the pixels that the vane can change (footprint.py).

Frames go in runs whose headings stay within RUN_DEGREES of each other (at most RUN_FRAMES long). The run's first
frame is traced whole, noting which pixels' ray trees meet the boxes that hold the vane's parts at every heading of
the run; the workers then trace those pixels' trees again at the first frame's heading and find, for each heading of
the run, the pixels whose trees meet a part that moved, where it was or where it is (footprint.HeadingMarks: the
parts' oriented boxes). Each later frame of the run is the first image with its heading's pixels traced again (none
where its heading is the first's). Every frame is bit-identical to a whole trace of it. Where the boxes' pixels are
more than FULL_SHARE of the image (a camera inside the vane's reach, a huge vane), the run's frames are traced whole
instead, which costs nothing more than a plain animation.
"""

from __future__ import annotations

import pickle
from collections.abc import Iterable, Iterator
from dataclasses import replace

import numpy as np

from ..geometry.footprint import HeadingMarks, heading_marks, swept_volume
from ..scene import scene as sc
from ..tracing.raystore import RayStore
from ..tracing.wavefront import PreparedScene
from ..workers.parallel import BandDone, Progress, Renderer, RenderResult
from ..workers.resources import band_samples

# Runs: a frame's pixels (HeadingMarks) do not depend on the run's span, so a longer run means fewer whole frames;
# what grows with it is the pixels the run's boxes hold (the marks' trace) and the headings whose marks are found.
# Before the marks (every frame traced all of its run's pixels) runs of 90 degrees were best. With them, the default
# 120 frames (PNGs written, CPU seconds of the parent and both workers, two runs each): runs of 90 degrees (4 runs:
# whole frames with their footprint 1.5 s, marks 1.0 s) 9.4 / 10.0 s, of 180 (3 runs) 9.2 / 9.2 s, of a whole turn
# (1 run: 0.4 s and 0.6 s) 8.9 / 8.8 s. Over a whole turn the boxes hold no more.
RUN_DEGREES = 360.0
RUN_FRAMES = 120
FULL_SHARE = 0.5


def runs(frame_headings: Iterable[tuple[int, float]]) -> Iterator[list[tuple[int, float]]]:
    """(frame, heading) pairs -> consecutive runs whose headings span at most RUN_DEGREES, RUN_FRAMES long at most."""
    run: list[tuple[int, float]] = []
    low = high = 0.0
    for frame, heading in frame_headings:
        if run and (len(run) == RUN_FRAMES or max(high, heading) - min(low, heading) > RUN_DEGREES):
            yield run
            run = []
        low, high = (heading, heading) if not run else (min(low, heading), max(high, heading))
        run.append((frame, heading))
    if run:
        yield run


def render_frames(
    renderer: Renderer, scene: sc.Scene, frame_headings: Iterable[tuple[int, float]]
) -> Iterator[tuple[int, RenderResult]]:
    """(frame, image) for each (frame, heading), in order: scene with its vane turned to each heading."""
    for run in runs(frame_headings):
        headings = np.array([heading for _, heading in run])
        # a scene with an alpha (a transparent film, a holdout) or a border is traced in whole frames (see below)
        whole = scene.has_alpha or scene.render.border is not None
        volume = None if whole else swept_volume(scene, np.dtype(scene.render.dtype), headings)
        (first_frame, first_heading), rest = run[0], run[1:]
        if volume is None or not rest:
            for (frame, _), result in zip(
                run, renderer.render_frames(scene.with_heading(h) for _, h in run), strict=True
            ):
                yield frame, result
            continue
        base = scene.with_heading(first_heading)
        first = renderer.render(base, volume=volume)
        yield first_frame, first
        if first.touched.mean() > FULL_SHARE:
            results = renderer.render_frames(scene.with_heading(heading) for _, heading in rest)
        else:
            marks = run_marks(renderer, base, np.flatnonzero(first.touched), headings)
            frames = ((scene.with_heading(heading), marks.at(heading)) for _, heading in rest)
            results = renderer.render_pixel_frames(frames, first.image)
        for (frame, _), result in zip(rest, results, strict=True):
            yield frame, result


def run_marks(renderer: Renderer, base: sc.Scene, pixels: np.ndarray, headings: np.ndarray) -> HeadingMarks:
    """Which of the pixels (P,) each heading of a run changes (footprint.HeadingMarks), their trees traced again at
    the base's heading on the workers, a share of the pixels each."""
    pieces = np.array_split(pixels, max(1, min(renderer.workers, len(pixels))))
    return HeadingMarks.joined(renderer.map(_marks, [(base, piece, headings) for piece in pieces]))


def _marks(scene: sc.Scene, pixels: np.ndarray, headings: np.ndarray) -> HeadingMarks:
    """On a worker: the pixels' ray trees in scene (its vane at the run's base heading) -> their HeadingMarks."""
    store = RayStore()
    PreparedScene(scene).render_pixels(pixels, band_samples(scene.render), store)
    return heading_marks(store.segments(), scene, np.dtype(scene.render.dtype), headings)


class TurningFrames:
    """Frames of a scene that differ only in the vane's heading, asked for one at a time in any order (Blender's
    render engine renders an animation frame by frame): the first is traced whole, noting the pixels whose ray trees
    meet the vane's whole turn; each later one traces those pixels again over it. Any other change to the scene
    starts again with a whole frame."""

    def __init__(self) -> None:
        self._still: bytes | None = None  # the scene at heading 0 that the pixels and base belong to
        self._pixels: np.ndarray | None = None  # None: the vane's reach covers too much, trace whole frames
        self._base: np.ndarray | None = None

    def render(
        self, renderer: Renderer, scene: sc.Scene, progress: Progress | None = None, band_done: BandDone | None = None
    ) -> RenderResult:
        # an alpha or a render border: whole frames (pixel re-traces keep colour only, of the whole image)
        if scene.vane is None or scene.has_alpha or scene.render.border is not None:
            return renderer.render(scene, progress, band_done=band_done)
        still = pickle.dumps(replace(scene, vane=replace(scene.vane, heading=0.0)))
        if still == self._still:
            if self._pixels is None:
                return renderer.render(scene, progress, band_done=band_done)
            return renderer.render_pixels(scene, self._pixels, self._base)
        volume = swept_volume(scene, np.dtype(scene.render.dtype))
        result = renderer.render(scene, progress, volume, band_done)
        self._still, self._pixels, self._base = still, None, None
        if volume is not None and result.touched.mean() <= FULL_SHARE:
            self._pixels, self._base = np.flatnonzero(result.touched), result.image.copy()
        return result
