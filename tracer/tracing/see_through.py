"""Hits on glass and partly transparent surfaces (a material's transmission > 0 or alpha < 1) -> the mirror, refracted
and straight-on rays they continue with, traced wave by wave. Only scenes with such materials run it
(docs/algorithm.md, "Glass and transparency"); the light that passes such surfaces is shadows.passing's."""

from __future__ import annotations

import numpy as np

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry.footprint import Footprint
from ..geometry.kernels import dot, indices, take
from ..geometry.rayframes import RayFrames
from ..geometry.robust import offset_origins
from ..scene import scene as sc
from . import glossy, shading, surfaces
from .batch import Hits, RayBatch
from .prepared import PreparedScene
from .rays import RayCounts, accumulate
from .raystore import RayStore
from .recorder import NoPasses, PassRecorder


def camera_batch(
    batch: RayBatch, dtype: np.dtype, glossy_surfaces: bool = False, bounces: bool = False, lamps: bool = False
) -> RayBatch:
    """The camera rays' batch with the fields a see-through wavefront carries: every ray a camera ray with no
    straight layer yet, tagged 0 (its own hit), clear (alpha not yet covered) and its data passes pending; with
    glossy_surfaces (or bounces), no glossy sample taken yet (-1); with bounces, no diffuse bounce yet; with lamps,
    none sees the lights seen in mirrors (camera rays do not)."""
    total = batch.size
    return batch.with_rays(
        sample=np.full(total, -1, dtype=np.int64) if glossy_surfaces or bounces else None,
        bounces=np.zeros(total, dtype=np.int64) if bounces else None,
        diffuse=np.zeros(total, dtype=bool) if bounces else None,
        lamps=np.zeros(total, dtype=bool) if lamps else None,
        left=np.full(total, batch.left),
        camera=np.ones(total, dtype=bool),
        layers=np.zeros(total, dtype=np.int64),
        tag=np.zeros(total, dtype=np.int8),
        clear=np.ones(total, dtype=dtype),
        pending=np.ones(total, dtype=bool),
    )


def closest_by_kind(
    scene: PreparedScene,
    batch: RayBatch,
    t_min: float,
    sets: list | None,
    query: RayFrames | None,
    frames: np.ndarray | None,
    views: tuple[list, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hierarchy.closest for a see-through wavefront: the camera rays (and their straight continuations) among the
    objects the camera sees, the others among those mirror rays see; sets: the camera rays' screen rectangles (the
    first wavefront, all camera rays); query: the whole batch's frames; views: the camera's point for the first
    wavefront (Hierarchy.closest)."""
    O, D, camera, pixel = batch.origin, batch.direction, batch.camera, batch.pixel
    if camera.all():
        return scene.camera_hierarchy.closest(O, D, t_min, sets, None, query, views)
    if scene.camera_hierarchy is scene.mirror_hierarchy or not camera.any():
        return scene.mirror_hierarchy.closest(O, D, t_min, None, None, query)
    count = pixel.size
    t = np.full(count, np.inf, dtype=scene.dtype)
    obj = np.full(count, -1, dtype=np.int32)
    part = np.zeros(count, dtype=np.int64)
    for hierarchy, rows in ((scene.camera_hierarchy, indices(camera)), (scene.mirror_hierarchy, indices(~camera))):
        own = None if frames is None else RayFrames.of(pixel.take(rows), frames)
        found_t, found_obj, found_part = hierarchy.closest(take(O, rows), take(D, rows), t_min, None, None, own)
        t[rows], obj[rows], part[rows] = found_t, found_obj, found_part
    return t, obj, part


def add_misses(
    scene: PreparedScene,
    color: np.ndarray,
    batch: RayBatch,
    obj: np.ndarray,
    first: bool,
    alpha: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
) -> None:
    """The background where the rays of a see-through wavefront miss, times their weights, into their samples and
    passes; under a transparent film a camera ray (or its straight continuation) that meets nothing adds nothing
    and takes its share of alpha away."""
    miss = indices(obj < 0)
    if not miss.size:
        return
    if batch.diffuse is not None:  # a diffuse bounce's miss: the world's light is the world light's
        miss = miss.take(indices(~batch.diffuse.take(miss)))
    seen = miss
    if scene.scene.render.film_transparent:
        film = batch.camera.take(miss)
        if alpha is not None and film.any():
            gone = miss.take(indices(film))
            np.subtract.at(alpha, batch.pixel.take(gone), batch.clear.take(gone))
        seen = miss.take(indices(~film))
    if seen.size:
        sky = surfaces.background(scene, batch.direction, seen)
        if batch.weight is not None:
            sky = take(batch.weight, seen) * sky
        pixel = batch.pixel.take(seen)
        add_at(color, pixel, sky, first)
        recorder.tagged("environment", batch.tag, seen, pixel, sky)


def hold_out(
    scene: PreparedScene,
    batch: RayBatch,
    obj: np.ndarray,
    first: bool,
    alpha: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
) -> np.ndarray:
    """The rays of a see-through wavefront that hit something other than a holdout (k,): a holdout adds nothing,
    and a camera ray (or its straight continuation) that meets it takes its share of alpha away."""
    hit = indices(obj >= 0)
    if not scene.any_holdout or not hit.size:
        return hit
    held = scene.holdout.take(obj.take(hit))
    if not held.any():
        return hit
    gone = hit.take(indices(held))
    mine = gone.take(indices(batch.camera.take(gone)))
    if alpha is not None and mine.size:
        np.subtract.at(alpha, batch.pixel.take(mine), batch.clear.take(mine))
    if first:
        recorder.holdout(batch.pixel.take(gone))
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
) -> None:
    """The shaded share a (1 - t) of a see-through wavefront's hits: listing 3.2 there and the local colour as a
    Whitted hit has it, times the share and the rays' weights, added to their camera samples; the passes: a camera
    ray's own hit term by term, the others' by their tag, and the data passes of the first surface of alpha at least
    the pass threshold met straight on. The reason for 9 parameters: the wavefront's colours, hits and rays, and
    the bookkeeping (counts, footprint, frames, passes) every stage of the loop carries."""
    a, transmission = scene.alpha.take(hits.material), scene.transmission.take(hits.material)
    recorder.first_seen(batch.pixel, batch.pending, a, hits.P, hits.S, hits.obj, hits.material)
    shaded = a * (1.0 - transmission)
    lit = indices(shaded > 0.0)
    if not lit.size:
        return
    every = lit.size == batch.size  # every hit is shaded: no gathers
    mine = hits if every else hits.take(lit)
    pixel = batch.pixel if every else batch.pixel.take(lit)
    split = {} if first and recorder.shading else None
    local, reflective = shading.local_colors(scene, mine, pixel, counts, footprint, frames, split)
    share = shaded if every else shaded.take(lit)
    local = local * share
    value = local if batch.weight is None else (batch.weight if every else take(batch.weight, lit)) * local
    add_at(color, pixel, value, first)
    if first:
        if split is not None:  # the terms times (1 - r) a (1 - t): a reflectivity of 1 - (1 - r) a (1 - t)
            glow = None if mine.emission is None else mine.emission * share
            if "glossy" in split:
                split["glossy"] = split["glossy"] * share
            paints = (mine.colors, mine.specular_colors, glow)
            recorder.terms(pixel, split, mine.material, 1.0 - (1.0 - reflective) * share, paints)
    else:
        recorder.tagged("reflection", batch.tag, lit, pixel, value)


def add_glass_light(
    scene: PreparedScene,
    color: np.ndarray,
    hits: Hits,
    batch: RayBatch,
    counts: RayCounts,
    footprint: Footprint | RayStore | None,
    frames: np.ndarray | None,
    recorder: PassRecorder | NoPasses,
    first: bool,
) -> tuple[np.ndarray, glossy.Glass] | None:
    """The glass share a t of a see-through wavefront's rough glass hits: what the lights add through the glass's
    microfacets (shading.glass_light; the refracted part tinted by the hit's colour), times the share and the rays'
    weights, added to their camera samples; the passes: at a camera ray's hit the reflected part into Reflection and
    the refracted into Transmission, else by the rays' tag (add_local's). At every such hit, as the local colour,
    whatever depth is left -> those hits (k,) and their glass (glossy.glass_at), for their rays (continuing); None
    where there are none. The reason for 9 parameters: add_local's."""
    glass = scene.alpha.take(hits.material) * scene.transmission.take(hits.material)
    rough = scene.transmission_roughness.take(hits.material) > 0.0
    rows = indices(rough & (glass > 0.0))
    if not rows.size:
        return None
    mine = hits.take(rows)
    pixel = batch.pixel.take(rows)
    rotation = cam.glass_rotations(scene.scene.render.seed, batch.serial.take(rows), batch.left.take(rows))
    made = glossy.glass_at(scene, hits, rows, take(batch.direction, rows), rotation)
    reflected, transmitted = shading.glass_light(scene, mine, made, pixel, counts, footprint, frames)
    share = glass.take(rows)
    weight = share if batch.weight is None else take(batch.weight, rows) * share
    reflected, transmitted = reflected * weight, transmitted * mine.colors * weight
    value = reflected + transmitted
    add_at(color, pixel, value)
    if first:
        recorder.add("reflection", pixel, reflected)
        recorder.add("transmission", pixel, transmitted)
    else:
        recorder.tagged("reflection", batch.tag, rows, pixel, value)
    return rows, made


def continuing(
    scene: PreparedScene, hits: Hits, batch: RayBatch, rough: tuple[np.ndarray, glossy.Glass] | None = None
) -> RayBatch | None:
    """The rays a see-through wavefront's hits send on, in one batch ordered by camera sample: mirror rays
    (a ((1 - t) r + t F)), refracted rays (a t (1 - F) colour; none in total internal reflection) and straight ones
    (1 - a, the same direction, not a bounce: at most sc.TRANSPARENT_BOUNCES on a path; a camera ray's straight
    continuation stays a camera ray); None where no hit sends any. rough: the rough glass hits and their glass
    (add_glass_light's; None: made here)."""
    material, D = hits.material, batch.direction
    a, transmission = scene.alpha.take(material), scene.transmission.take(material)
    go = batch.left > 0
    mirror = a * (1.0 - transmission) * scene.reflective.take(material)
    bent_rows, bent_D, bent_weight = _refract(scene, go, a, transmission, material, hits, D, mirror)
    mirror_rows = indices(go & (mirror > 0.0))
    straight_rows = indices((a < 1.0) & (batch.layers < sc.TRANSPARENT_BOUNCES))
    base = np.ones((3, batch.size), dtype=scene.dtype) if batch.weight is None else batch.weight
    children = []  # (rows, D, weight, left, straight, tag)
    if mirror_rows.size:
        k = 2.0 * dot(hits.S, hits.V)
        Sm, Vm = take(hits.S, mirror_rows), take(hits.V, mirror_rows)
        children.append(
            (mirror_rows, Sm * k.take(mirror_rows) - Vm, take(base, mirror_rows) * mirror.take(mirror_rows),
             batch.left.take(mirror_rows) - 1, False, 1)
        )  # fmt: skip
    if bent_rows.size:
        children.append(
            (bent_rows, bent_D, take(base, bent_rows) * bent_weight, batch.left.take(bent_rows) - 1, False, 2)
        )
    if straight_rows.size:
        through = 1.0 - a.take(straight_rows)
        children.append(
            (straight_rows, take(D, straight_rows), take(base, straight_rows) * through,
             batch.left.take(straight_rows), True, 2)
        )  # fmt: skip
    made = [_child(scene, hits, batch, a, *child) for child in children]
    if scene.traced_glossy:
        rays = _glossy_rays(scene, hits, batch, go, a * (1.0 - transmission), base)
        if rays is not None:
            made.append(rays)
    if scene.rough_glass:
        rays = _rough_glass_rays(scene, hits, batch, go, a * transmission, base, rough)
        if rays is not None:
            made.append(rays)
    if scene.diffuse_bounces:
        rays = _diffuse_rays(scene, hits, batch, go, a * (1.0 - transmission), base)
        if rays is not None:
            made.append(rays)
    if not made:
        return None
    return RayBatch.joined(made)


def _diffuse_rays(
    scene: PreparedScene, hits: Hits, batch: RayBatch, go: np.ndarray, shaded: np.ndarray, base: np.ndarray
) -> RayBatch | None:
    """The diffuse bounce rays (glossy.diffuse_rays) of the hits that go on (go (n,)) with bounces left on their
    path and a shaded share a (1 - t) (n,) > 0, weighted by the albedo colour (1 - r) and the share."""
    albedo = hits.colors * (1.0 - scene.reflective.take(hits.material)) * shaded
    rows = indices(go & (batch.bounces < scene.diffuse_bounces) & np.any(albedo > 0.0, axis=0))
    if not rows.size:
        return None
    hit, pair, D, share = glossy.diffuse_rays(scene, hits, rows, batch.sample.take(rows), _keys(scene, batch, rows))
    rows = rows.take(hit)
    weight = take(base, rows) * take(albedo, rows) * share.astype(scene.dtype, copy=False)
    rays = _child(scene, hits, batch, shaded, rows, D.astype(scene.dtype, copy=False), weight,
                  batch.left.take(rows) - 1, False, 1, pair)  # fmt: skip
    lamps = None if rays.lamps is None else np.zeros(rows.size, dtype=bool)  # the shadow rays had the lights
    return rays.with_rays(bounces=rays.bounces + 1, diffuse=np.ones(rows.size, dtype=bool), lamps=lamps)


def _rough_glass_rays(
    scene: PreparedScene,
    hits: Hits,
    batch: RayBatch,
    go: np.ndarray,
    glass: np.ndarray,
    base: np.ndarray,
    known: tuple[np.ndarray, glossy.Glass] | None,
) -> RayBatch | None:
    """The sampled reflected and refracted rays (glossy.glass_rays) of the rough glass hits that go on (go (n,))
    with a glass share a t (n,) > 0, weighted by it (the refracted ones also by the hit's colour); known: the rough
    glass hits (k,) and their glass already made (add_glass_light), or None."""
    rough = scene.transmission_roughness.take(hits.material) > 0.0
    rows = indices(go & rough & (glass > 0.0))
    if not rows.size:
        return None
    rotation = cam.glass_rotations(scene.scene.render.seed, batch.serial.take(rows), batch.left.take(rows))
    if known is None:
        made = glossy.glass_at(scene, hits, rows, take(batch.direction, rows), rotation)
    else:  # rows are among the known hits, both ascending
        every, made = known
        made = made.take(np.searchsorted(every, rows))
    hit, pair, D, weight, refracted = glossy.glass_rays(
        scene, made, batch.sample.take(rows), rotation, _keys(scene, batch, rows)
    )
    if not hit.size:
        return None
    rows = rows.take(hit)
    tint = np.where(refracted, take(hits.colors, rows), 1.0)
    weight = take(base, rows) * tint * (weight * glass.take(rows)).astype(scene.dtype, copy=False)
    D = D.astype(scene.dtype, copy=False)
    kind = np.where(refracted, 2, 1)  # the passes' tag: Transmission for the refracted, Reflection for the others
    made = [
        _child(scene, hits, batch, glass, rows.take(part), take(D, part), take(weight, part),
               batch.left.take(rows.take(part)) - 1, False, tag, pair.take(part))
        for tag in (1, 2) if (part := indices(kind == tag)).size
    ]  # fmt: skip
    rays = RayBatch.joined(made)
    if rays.lamps is None:
        return rays
    return rays.with_rays(lamps=np.zeros(rays.size, dtype=bool))  # the lights came through the glass (glass_light)


def _glossy_rays(
    scene: PreparedScene, hits: Hits, batch: RayBatch, go: np.ndarray, shaded: np.ndarray, base: np.ndarray
) -> RayBatch | None:
    """The reflection rays of the glossy hits that go on (go (n,)) with a shaded share a (1 - t) (n,) > 0: every
    sample pair at a path's first glossy surface, its pair after (glossy.sample_rays), weighted by the share."""
    lobes = glossy.lobes_at(scene, hits)
    if lobes is None:
        return None
    traced = scene.glossy_traced.take(hits.material.take(lobes.rows))
    lobes = lobes.take(indices(traced & go.take(lobes.rows) & (shaded.take(lobes.rows) > 0.0) & lobes.facing))
    if not lobes.rows.size:
        return None
    keys = _keys(scene, batch, lobes.rows)
    lobe, pair, D, weight = glossy.sample_rays(scene, lobes, batch.sample.take(lobes.rows), keys)
    if not lobe.size:
        return None
    rows = lobes.rows.take(lobe)
    weight = take(base, rows) * (weight * shaded.take(rows)).astype(scene.dtype, copy=False)
    D = D.astype(scene.dtype, copy=False)
    rays = _child(scene, hits, batch, shaded, rows, D, weight, batch.left.take(rows) - 1, False, 1, pair)
    return rays if rays.lamps is None else rays.with_rays(lamps=np.zeros(rows.size, dtype=bool))  # the lobe had them


def _keys(scene: PreparedScene, batch: RayBatch, rows: np.ndarray) -> np.ndarray:
    """The sharing keys (k,) of the camera samples the rays rows belong to (lightsamples.sharing_key): which of
    the glossy pairs a path's first glossy surface or bounce takes."""
    settings = scene.scene.render
    return np.asarray(lightsamples.sharing_key(settings, batch.pixel.take(rows) % settings.samples), dtype=np.int64)


def _child(
    scene: PreparedScene,
    hits: Hits,
    batch: RayBatch,
    a: np.ndarray,
    rows: np.ndarray,
    D: np.ndarray,
    weight: np.ndarray,
    left: np.ndarray,
    straight: bool,
    kind: int,
    sample: np.ndarray | None = None,
) -> RayBatch:
    """The rays (k,) that the hits rows (k,) send in directions D (3, k) with weights (3, k) and bounces left (k,):
    a straight continuation keeps its camera ray's kind, reach and pending passes and covers 1 - a more of its
    alpha; a mirror or refracted ray (kind 1 or 2 for the passes' tag) is a new path. sample: a glossy ray's pair
    (k,) (None: the rays keep their path's). The reason for 11 parameters: the five that vary by child come with
    the six every child shares."""
    P = hits.P.take(rows, axis=1, mode="wrap")  # not take(): a lone hit's rays are columns, not a shared (3, 1)
    O = P
    if scene.robust:
        O = offset_origins(P, take(hits.N, rows), D, *(part.take(rows) for part in hits.surface))
    tag = batch.tag.take(rows)
    tag = np.where(tag == 0, np.int8(kind), tag)
    if straight:
        camera = batch.camera.take(rows)
        layers = batch.layers.take(rows) + 1
        clear = batch.clear.take(rows) * (1.0 - a.take(rows))
        reach = None if batch.reach is None else batch.reach.take(rows)  # what is left of it beyond the hit
        pending = batch.pending.take(rows) & (a.take(rows) < sc.PASS_ALPHA_THRESHOLD)
    else:
        camera = np.zeros(rows.size, dtype=bool)
        layers = batch.layers.take(rows)
        clear = np.zeros(rows.size, dtype=scene.dtype)
        reach = None if batch.reach is None else np.full(rows.size, np.inf)
        pending = np.zeros(rows.size, dtype=bool)
    if sample is None and batch.sample is not None:
        sample = batch.sample.take(rows)
    bounces = None if batch.bounces is None else batch.bounces.take(rows)
    diffuse = lamps = None  # a straight continuation is still the ray it was (a diffuse one's miss adds nothing)
    if batch.diffuse is not None:
        diffuse = batch.diffuse.take(rows) if straight else np.zeros(rows.size, dtype=bool)
    if batch.lamps is not None:  # mirror and refracted rays see lights (glossy, rough glass, diffuse: not)
        lamps = batch.lamps.take(rows) if straight else np.ones(rows.size, dtype=bool)
    serial = None if batch.serial is None else batch.serial.take(rows)
    return RayBatch(
        batch.pixel.take(rows), O, D, weight, left, reach, camera, layers, tag, clear, pending, sample, bounces,
        diffuse, lamps, serial,
    )  # fmt: skip


def _refract(
    scene: PreparedScene,
    go: np.ndarray,
    a: np.ndarray,
    transmission: np.ndarray,
    material: np.ndarray,
    hits: Hits,
    D: np.ndarray,
    mirror: np.ndarray,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The glass share of the hits that go on (go (n,)): adds a t F to their mirror weights (n,) in place and
    gives the rows (k,) that refract, their unit directions (3, k) and weights a t (1 - F) colour (3, k) (the
    reference's glass_split: eta = ior entering by the geometric normal N, 1 / ior leaving; the shading normal S
    turned to face D bends the ray; Cycles' fresnel_dielectric_cos)."""
    sharp = transmission > 0.0
    if scene.rough_glass:  # rough glass sends its own sampled rays (_rough_glass_rays)
        sharp &= scene.transmission_roughness.take(material) <= 0.0
    rows = indices(go & sharp & (a > 0.0))
    if not rows.size:
        return rows, None, None
    N_, S_, D_ = take(hits.N, rows), take(hits.S, rows), take(D, rows)
    ior = scene.ior.take(material.take(rows))
    eta = np.where(dot(N_, D_) < 0.0, ior, 1.0 / ior)
    facing = np.where(dot(S_, D_) < 0.0, S_, -S_)
    d = D_ / np.sqrt(dot(D_, D_))
    c = -dot(d, facing)
    g2 = eta * eta - 1.0 + c * c
    inside = g2 > 0.0  # else total internal reflection: F = 1
    g = np.sqrt(np.where(inside, g2, 1.0))
    A = (g - c) / (g + c)
    B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    F = np.where(inside, 0.5 * A * A * (1.0 + B * B), 1.0)
    glass = a.take(rows) * transmission.take(rows)
    mirror[rows] += glass * F
    share = glass * (1.0 - F)
    keep = indices(inside & (share > 0.0))
    T = take((d + (c - g) * facing) / eta, keep)
    T = T / np.sqrt(dot(T, T))
    return rows.take(keep), T, take(hits.colors, rows.take(keep)) * share.take(keep)


def add_at(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, unique: bool = False) -> None:
    """color[:, pixel] += value where pixels may repeat (a see-through wavefront holds several rays of a camera
    sample): np.add.at, in the order of the rays; unique: they do not (the camera rays' own wavefront), the faster
    gather and scatter of _accumulate (the same sums)."""
    if unique:
        accumulate(color, pixel, value, False)
        return
    for row, add in zip(color, value, strict=True):
        np.add.at(row, pixel, add)
