"""Frames of a turning vane -> their images, tracing again only the pixels that the vane can change (footprint.py).

All frames start from one image of the scene without its vane's parts, traced whole while noting which pixels' ray
trees meet the boxes that hold the parts at every heading (footprint.swept_volume). Frames then go in runs of at
most RUN_FRAMES: for a run's headings the workers trace those pixels' trees again (without the parts) and find, for
each heading, the pixels whose trees meet a part there (footprint.HeadingMarks: the parts' oriented boxes); each frame
is the image without the parts with its heading's pixels traced again in the whole scene (a frame at the heading of
the one before it is that frame's image). A tree that meets no part is the same with the parts there, so every frame
is bit-identical to a whole trace of it. Where the boxes' pixels are more than FULL_SHARE of the image (a camera
inside the vane's reach, a huge vane), or the animation is shorter than MIN_FRAMES, frames are traced whole instead,
which costs nothing more than a plain animation.
"""

from __future__ import annotations

import pickle
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from ..geometry.footprint import HeadingMarks, HeadingParts, heading_marks, heading_parts, swept_volume
from ..scene import scene as sc
from ..tracing.raystore import RayStore
from ..tracing.wavefront import RayCounts, TracedScene
from ..workers import shutter
from ..workers.parallel import BandDone, Progress, Renderer, RenderResult, batches
from ..workers.resources import band_samples

# The image without the parts, with its footprint, costs about two plain frames and the marks of 120 headings about
# three (docs/measurements.md#the-tracers-constants); a frame then traces its own pixels (a few percent of the
# image). Runs bound the marks kept at once (a list of pixels per heading) and the frames a run's marks keep waiting;
# the image without the parts serves every run.
RUN_FRAMES = 120
MIN_FRAMES = 4  # an animation of fewer frames is traced whole: the image without the parts would cost more
FULL_SHARE = 0.5


def runs(frame_headings: Iterable[tuple[int, float]]) -> Iterator[list[tuple[int, float]]]:
    """(frame, heading) pairs -> consecutive runs of RUN_FRAMES (the last may be shorter)."""
    return batches(frame_headings, RUN_FRAMES)


def render_frames(
    renderer: Renderer, scene: sc.Scene, frame_headings: Iterable[tuple[int, float]]
) -> Iterator[tuple[int, RenderResult]]:
    """(frame, image) for each (frame, heading), in order: scene with its vane turned to each heading."""
    dtype = np.dtype(scene.render.dtype)
    # a scene with an alpha (a transparent film, a holdout) or a border is traced in whole frames (see below)
    whole = scene.has_alpha or scene.render.border is not None or bool(scene.render.passes)
    volume = None if whole else swept_volume(scene, dtype)  # every heading: one image without the vane serves all
    still = None if volume is None else without_vane(scene)
    base: RenderResult | None = None
    for run in runs(frame_headings):
        headings = np.array([h for _, h in run])
        parts = None
        if base is None and still is not None and len(run) >= MIN_FRAMES:
            # the parts at the run's headings are made here while the workers trace the image without them
            with ThreadPoolExecutor(1, "weathervane-parts") as helper:
                made = helper.submit(heading_parts, scene, dtype, headings)
                base = renderer.render(still, volume=volume)
                parts = made.result()
            if base.touched.mean() > FULL_SHARE:
                still = None
        if base is None or still is None:
            scenes = (scene.with_heading(heading) for _, heading in run)
            for (frame, _), result in zip(run, renderer.render_frames(scenes), strict=True):
                yield frame, result
            continue
        parts = parts or heading_parts(scene, dtype, headings)
        marks = run_marks(renderer, still, np.flatnonzero(base.touched), parts)
        # a frame at the heading of the one before it is that frame's image (the vane at rest): nothing to trace
        traced = [k for k, (_, heading) in enumerate(run) if k == 0 or heading != run[k - 1][1]]
        frames = ((run[k][1], marks.at(run[k][1])) for k in traced)
        results = renderer.render_pixel_frames(scene, frames, base.image)
        last = None
        for k, (frame, heading) in enumerate(run):
            if k == 0 or heading != run[k - 1][1]:
                last = next(results)
                yield frame, last
            else:
                yield frame, RenderResult(last.image, RayCounts(), 0.0, retraced=last.retraced)


def without_vane(scene: sc.Scene) -> sc.Scene | None:
    """The scene without its vane's parts (None where nothing else is there)."""
    objects = tuple(obj for obj in scene.objects if obj.name not in scene.vane.parts)
    return replace(scene, objects=objects, vane=None) if objects else None


def run_marks(renderer: Renderer, still: sc.Scene, pixels: np.ndarray, parts: HeadingParts) -> HeadingMarks:
    """Which of the pixels (P,) each heading of a run changes (footprint.HeadingMarks), their trees traced again in
    still (the scene without its vane) on the workers, a share of the pixels each; parts: the vane's parts at the
    run's headings (footprint.heading_parts)."""
    pieces = np.array_split(pixels, max(1, min(renderer.workers, len(pixels))))
    return HeadingMarks.joined(renderer.map(_marks, [(still, piece, parts) for piece in pieces]))


def _marks(still: sc.Scene, pixels: np.ndarray, parts: HeadingParts) -> HeadingMarks:
    """On a worker: the pixels' ray trees in still (the scene without its vane) -> their HeadingMarks for the parts."""
    store = RayStore()
    TracedScene(still).render_pixels(pixels, band_samples(still.render), store)
    return heading_marks(store.segments(), parts)


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
        # an alpha, a render border or passes: whole frames (pixel re-traces keep colour only, of the whole image);
        # motion blur: whole frames of time slices (the pixels a turn reaches are one time's)
        settings = scene.render
        if (
            scene.vane is None
            or scene.has_alpha
            or settings.border is not None
            or settings.passes
            or shutter.steps(scene) > 1
        ):
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
