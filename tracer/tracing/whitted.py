"""A Whitted wavefront's stages (a scene without glass or transparency: every ray of a wavefront its own camera
sample's only one) -> its misses' background, its holdouts, its hits' local colours added into their samples and
the mirror rays they send on (listing 3.1's TraceRay, one bounce of all rays at once). A scene with glass or
transparency has see_through.py's instead."""

from __future__ import annotations

import numpy as np

from ..geometry.footprint import Footprint
from ..geometry.kernels import dot, indices, take
from ..geometry.robust import offset_origins
from . import shading, surfaces
from .batch import Hits, RayBatch
from .prepared import PreparedScene
from .rays import RayCounts, accumulate
from .raystore import RayStore
from .recorder import NoPasses, PassRecorder


def add_misses(
    scene: PreparedScene,
    color: np.ndarray,
    batch: RayBatch,
    obj: np.ndarray,
    first: bool,
    alpha: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
) -> None:
    """The background where the rays of a Whitted wavefront miss (a camera ray's is there already; a
    transparent film leaves alpha 0 there), times the rays' weights, and the Environment pass."""
    if first:
        if scene.scene.render.film_transparent and alpha is not None:
            alpha[obj < 0] = 0.0  # the film shows nothing there
        recorder.camera_misses(obj, color)
        return
    miss = indices(obj < 0)
    if miss.size:
        sky = batch.weight.take(miss) * surfaces.background(scene, batch.direction, miss)
        pixel = batch.pixel.take(miss)
        accumulate(color, pixel, sky, False)
        recorder.environment(pixel, sky)


def hold_out(
    scene: PreparedScene,
    color: np.ndarray,
    batch: RayBatch,
    obj: np.ndarray,
    first: bool,
    alpha: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
) -> np.ndarray:
    """The rays of a Whitted wavefront that hit something other than a holdout (k,): a holdout adds nothing,
    and a camera ray that meets it first shows nothing, not even the background it started with (alpha 0)."""
    hit = indices(obj >= 0)
    if not scene.any_holdout or not hit.size:
        return hit
    held = scene.holdout.take(obj.take(hit))
    if not held.any():
        return hit
    if first:
        gone = hit.take(indices(held))
        color[:, gone] = 0.0
        if alpha is not None:
            alpha[gone] = 0.0
        recorder.holdout(gone)
    return hit.take(indices(~held))


def add_local(
    scene: PreparedScene,
    color: np.ndarray,
    hits: Hits,
    batch: RayBatch,
    counts: RayCounts,
    footprint: Footprint | RayStore | None,
    frames: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
    first: bool,
) -> np.ndarray:
    """A Whitted wavefront's local colours (listing 3.1's (1 - r) local colour, emission added) times the rays'
    weights into their samples (the camera rays' replace the background), and the passes; -> the hits'
    reflectivities r (n,). The reason for 9 parameters: the wavefront's colours, hits and rays, and the
    bookkeeping (counts, footprint, frames, passes) every stage of the loop carries."""
    split = {} if first and recorder.shading else None
    local, reflective = shading.local_colors(scene, hits, batch.pixel, counts, footprint, frames, split)
    if first:
        recorder.first_hit(batch.pixel, hits.P, hits.S, hits.obj, hits.material)
        if split is not None:
            paints = (hits.colors, hits.specular_colors, hits.emission)
            recorder.terms(batch.pixel, split, hits.material, reflective, paints)
        accumulate(color, batch.pixel, local, True)
    else:
        local = batch.weight * local
        accumulate(color, batch.pixel, local, False)
        recorder.reflection(batch.pixel, local)
    return reflective


def mirror_rays(scene: PreparedScene, hits: Hits, batch: RayBatch, reflective: np.ndarray) -> RayBatch | None:
    """The mirror rays of a Whitted wavefront's reflective hits (listing 3.1's R = 2 N (N . V) - V), their weights
    multiplied by r; None at the depth or where no hit reflects."""
    go_on = indices(reflective > 0.0)
    if batch.left == 0 or go_on.size == 0:
        return None
    P, N, V = take(hits.P, go_on), take(hits.N, go_on), take(hits.V, go_on)
    S = N if hits.S is hits.N else take(hits.S, go_on)
    k = 2.0 * dot(S, V)
    D = S * k - V
    O = P
    if scene.robust:
        O = offset_origins(P, N, D, *(part.take(go_on) for part in hits.surface))
    ratio = reflective.take(go_on)
    weight = ratio if batch.weight is None else batch.weight.take(go_on) * ratio
    return RayBatch(batch.pixel.take(go_on), O, D, weight, batch.left - 1)
