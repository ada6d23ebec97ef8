"""A wavefront's rays that see the lights seen in mirrors (emitters.py: mirror and refracted rays; a
Whitted wavefront's all but the camera's) -> the radiance they bring, times their weights, into their samples and the
Reflection pass (Transmission under a refracted ray): an area light's where they meet its front before any surface
(those rays end there), a sun's disc where they meet nothing and point into it (they go on to see the background)."""

from __future__ import annotations

import numpy as np

from ..geometry.footprint import Footprint
from ..geometry.kernels import indices, take
from . import emitters, see_through
from .batch import RayBatch
from .prepared import PreparedScene
from .raystore import RayStore
from .recorder import NoPasses, PassRecorder


def meet_lights(
    scene: PreparedScene,
    color: np.ndarray,
    batch: RayBatch,
    t: np.ndarray,
    obj: np.ndarray,
    part: np.ndarray,
    t_min: float,
    recorder: PassRecorder | NoPasses,
    footprint: Footprint | RayStore | None,
) -> tuple[RayBatch, np.ndarray, np.ndarray, np.ndarray]:
    """The rays that see lights and meet an area light's front before their surface (t, obj, part: their hits;
    emitters.meet): its radiance into their samples and passes, their segments up to the light, naming it, into the
    footprint (an edit of its intensity retraces them, where no shadow segment may name it: through glass), and the
    wavefront without them -> (batch, t, obj, part). The reason for 9 parameters: the wavefront loop's state (its
    rays, their hits, colours, passes and footprint) that the rays ending at a light leave."""
    rays = np.arange(batch.size) if batch.lamps is None else indices(batch.lamps)
    surface = np.where(obj >= 0, t, np.inf)
    met, radiance, sources, reach = emitters.meet(
        scene.seen_lights, batch.origin, batch.direction, surface, t_min, rays
    )
    if not met.size:
        return batch, t, obj, part
    if footprint is not None:
        for source in np.unique(sources):
            mine = indices(sources == source)
            rows = met.take(mine)
            origin = batch.origin if batch.origin.shape[1] == 1 else take(batch.origin, rows)
            direction = take(batch.direction, rows)
            footprint.record(batch.pixel.take(rows), origin, direction, t_min, reach.take(mine), light=int(source))
    _add(scene, color, batch, met, radiance, recorder)
    keep = np.ones(batch.size, dtype=bool)
    keep[met] = False
    keep = indices(keep)
    return batch.take(keep), t.take(keep), obj.take(keep), part.take(keep)


def see_suns(
    scene: PreparedScene, color: np.ndarray, batch: RayBatch, obj: np.ndarray, recorder: PassRecorder | NoPasses
) -> None:
    """The rays that see lights, meet nothing (obj < 0) and point into a sun's disc (emitters.see_suns): its
    radiance into their samples and passes; they go on to see the background too (Cycles adds the sun's and the
    world's)."""
    missed = obj < 0
    rays = indices(missed if batch.lamps is None else missed & batch.lamps)
    seen, radiance = emitters.see_suns(scene.seen_suns, batch.direction, rays)
    if seen.size:
        _add(scene, color, batch, seen, radiance, recorder)


def _add(
    scene: PreparedScene,
    color: np.ndarray,
    batch: RayBatch,
    rows: np.ndarray,
    radiance: np.ndarray,
    recorder: PassRecorder | NoPasses,
) -> None:
    """The radiance (3, j) the batch's rays rows (j,) see, times their weights, into their samples and the
    Reflection pass (Transmission under a refracted ray)."""
    weight = batch.weight
    if weight is not None:  # (n,) on mirror paths, (3, n) where glass tints them
        radiance = (weight.take(rows) if weight.ndim == 1 else take(weight, rows)) * radiance
    value = radiance.astype(scene.dtype, copy=False)
    pixel = batch.pixel.take(rows)
    see_through.add_at(color, pixel, value, batch.camera is None)
    if batch.tag is None:
        recorder.reflection(pixel, value)
    else:
        recorder.tagged("reflection", batch.tag, rows, pixel, value)
