"""Frames of a turning vane -> their images, tracing again only the pixels that the vane can change (footprint.py).

Frames go in runs whose headings stay within RUN_DEGREES of each other (at most RUN_FRAMES long). The run's first
frame is traced whole, noting which pixels' ray trees meet the boxes that hold the vane's parts at every heading of
the run; each later frame of the run is that image with those pixels traced again. Every frame is bit-identical to a
whole trace of it. Where the boxes' pixels are more than FULL_SHARE of the image (a camera inside the vane's reach, a
huge vane), the run's frames are traced whole instead, which costs nothing more than a plain animation.
"""

from __future__ import annotations

import pickle
from collections.abc import Iterable, Iterator
from dataclasses import replace

import numpy as np

from ..geometry.footprint import swept_volume
from ..scene import scene as sc
from ..workers.parallel import BandDone, Progress, Renderer, RenderResult

# Runs: tighter boxes mean fewer pixels to trace again, a longer run fewer whole frames. On the default scene the
# parts' boxes hold the ray trees of 3.6% of the pixels for one heading, 5% over 15 degrees, 6.2% over 30 and 7.9%
# over 60; a whole frame with its footprint costs about 1.6 plain frames. The default 120 frames (no PNG): 6.9 s with
# runs of 30 degrees, 5.8 s of 60, 5.5 s of 90, 5.3 s of 180, 5.9 s of a whole turn (one noisy run each).
RUN_DEGREES = 90.0
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
        first = renderer.render(scene.with_heading(first_heading), volume=volume)
        yield first_frame, first
        if first.touched.mean() > FULL_SHARE:
            results = renderer.render_frames(scene.with_heading(heading) for _, heading in rest)
        else:
            pixels = np.flatnonzero(first.touched)
            results = renderer.render_pixel_frames((scene.with_heading(h) for _, h in rest), pixels, first.image)
        for (frame, _), result in zip(rest, results, strict=True):
            yield frame, result


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
