"""Hits on glass and partly transparent surfaces (a material's transmission > 0 or alpha < 1) -> the mirror, refracted
and straight-on rays they continue with, traced wave by wave. Only scenes with such materials run it
(docs/algorithm.md, "Glass and transparency"); the light that passes such surfaces is shadows.passing's."""

from __future__ import annotations

import numpy as np

from ..geometry.footprint import Footprint
from ..geometry.kernels import dot, indices, take
from ..geometry.rayframes import RayFrames
from ..geometry.robust import offset_origins
from ..scene import scene as sc
from . import shading, surfaces
from .prepared import PreparedScene
from .rays import CAMERA_T_MIN, REFLECTION_T_MIN, RayCounts, accumulate, tally
from .raystore import RayStore
from .recorder import PassRecorder


def trace(
    scene: PreparedScene,
    D: np.ndarray,
    counts: RayCounts,
    rows: np.ndarray | None = None,
    origins: np.ndarray | None = None,
    far: np.ndarray | None = None,
    footprint: Footprint | RayStore | None = None,
    alpha: np.ndarray | None = None,
    pixels: np.ndarray | None = None,
    frames: np.ndarray | None = None,
    recorder: PassRecorder | None = None,
) -> np.ndarray:
    """trace() for a scene with a material of transmission t > 0 or alpha a < 1 (docs/algorithm.md, "Glass and
    transparency"); the same arguments and result. A hit adds a (1 - t) times the documented local colour and
    sends on, each with its weight (3 channels: a refracted ray is tinted), a mirror ray (a ((1 - t) r + t F),
    F the dielectric Fresnel reflectance), a refracted ray (a t (1 - F) colour; none in total internal
    reflection) and a straight one (1 - a, the same direction, not a bounce: at most sc.TRANSPARENT_BOUNCES on
    a path; a camera ray's straight continuation stays a camera ray). A camera sample's rays may then be several
    in one wavefront: the wavefront is kept in order of camera sample and adds with np.add.at."""
    settings = scene.scene.render
    total = D.shape[1]
    query = None if frames is None else RayFrames(frames[None])
    tally(counts, "camera", total, query)
    color = np.zeros((3, total), dtype=scene.dtype)
    runs = None if frames is None else (frames // settings.samples).tolist()  # each frame's pixels
    pixel = np.arange(total)  # each ray's camera sample, ascending
    O = scene.origin if origins is None else origins
    weight = None  # (3, n); None: 1 (the camera rays)
    left = np.full(total, settings.depth)  # bounces left
    layers = np.zeros(total, dtype=np.int64)  # straight continuations on the path so far
    camera = np.ones(total, dtype=bool)  # camera rays and their straight continuations
    reach = far  # a camera ray's clip_end left beyond its origin (n,), inf for others; None: none
    tag = np.zeros(total, dtype=np.int8)  # the passes: 0 the camera ray's hit, 1 under a mirror ray, 2 under a
    # refracted or straight one (the Transmission pass)
    clear = np.ones(total, dtype=scene.dtype)  # camera rays' product of 1 - alpha so far (the film's alpha)
    pending = np.ones(total, dtype=bool)  # camera rays whose data passes are not written yet
    first = True
    while pixel.size:
        t_min = CAMERA_T_MIN if first else 0.0 if scene.robust else REFLECTION_T_MIN
        sets = None
        if first and scene.screen is not None and (rows is not None or pixels is not None):
            if rows is not None:
                sets = scene.screen.rays(rows)
            else:
                sets = scene.screen.pixel_rays(pixels, runs, scene.camera_hierarchy.frame_of)
        t, obj, part = _closest_by_kind(scene, O, D, t_min, camera, pixel, sets, frames)
        if reach is not None:
            obj[t >= reach] = -1
        if footprint is not None:
            end = np.where(obj >= 0, t, np.inf if reach is None else reach)
            footprint.record(pixel, O, D, t_min, end, hit=obj)
        miss = indices(obj < 0)
        if miss.size:
            seen = miss
            if settings.film_transparent:  # a camera ray that meets nothing adds nothing, and its share of alpha
                film = camera.take(miss)
                if alpha is not None and film.any():
                    gone = miss.take(indices(film))
                    np.subtract.at(alpha, pixel.take(gone), clear.take(gone))
                seen = miss.take(indices(~film))
            if seen.size:
                sky = surfaces.background(scene, D, seen)
                if weight is not None:
                    sky = take(weight, seen) * sky
                add_at(color, pixel.take(seen), sky, first)
                if recorder is not None:
                    record_tagged(recorder, "environment", tag.take(seen), pixel.take(seen), sky)
        hit = indices(obj >= 0)
        if scene.any_holdout and hit.size:  # a holdout adds nothing; a camera ray's share of alpha goes
            held = scene.holdout.take(obj.take(hit))
            if held.any():
                gone = hit.take(indices(held))
                mine = gone.take(indices(camera.take(gone)))
                if alpha is not None and mine.size:
                    np.subtract.at(alpha, pixel.take(mine), clear.take(mine))
                if recorder is not None and first:
                    recorder.holdout(pixel.take(gone))
                hit = hit.take(indices(~held))
        if not hit.size:
            break
        O, D, t, obj, part = take(O, hit), take(D, hit), t.take(hit), obj.take(hit), part.take(hit)
        pixel, left, layers = pixel.take(hit), left.take(hit), layers.take(hit)
        camera, tag, clear, pending = camera.take(hit), tag.take(hit), clear.take(hit), pending.take(hit)
        weight = None if weight is None else take(weight, hit)
        reach = None if reach is None else reach.take(hit)
        P = O + D * t
        V = -D
        O = None
        N, surface = scene.normals(P, obj, part)
        material = scene.material_of(obj, part)
        S = surfaces.shading_normals(scene, N, V, P, obj, part, material)
        colors, specular_colors, emission = surfaces.surface_colors(scene, material, P, obj, part)
        a, transmission = scene.alpha.take(material), scene.transmission.take(material)
        if recorder is not None:  # the data passes: the first surface of alpha >= the threshold met straight on
            shown = pending & (a >= sc.PASS_ALPHA_THRESHOLD)
            if shown.all():
                recorder.first_hit(pixel, P, S, obj, material)
            elif shown.any():
                rows_ = indices(shown)
                recorder.first_hit(
                    pixel.take(rows_), take(P, rows_), take(S, rows_), obj.take(rows_), material.take(rows_)
                )
        shaded = a * (1.0 - transmission)
        reflective = scene.reflective.take(material)
        lit = indices(shaded > 0.0)
        if lit.size:
            _local(scene,
                color, lit, P, N, S, V, material, surface, (colors, specular_colors, emission), shaded, weight,
                pixel, tag, counts, footprint, frames, recorder, first,
            )  # fmt: skip
        # what goes on: mirror rays, refracted rays, straight continuations
        go = left > 0
        mirror = shaded * reflective
        bent_rows, bent_D, bent_weight = _refract(scene, go, a, transmission, material, N, S, D, mirror, colors)
        mirror_rows = indices(go & (mirror > 0.0))
        straight_rows = indices((a < 1.0) & (layers < sc.TRANSPARENT_BOUNCES))
        ones = None
        if weight is None:
            ones = np.ones((3, pixel.size), dtype=scene.dtype)
        base = ones if weight is None else weight
        k = 2.0 * dot(S, V)
        children = []  # (rows, O, D, weight, left, layers, camera, tag, clear, reach)
        if mirror_rows.size:
            Sm, Vm = take(S, mirror_rows), take(V, mirror_rows)
            children.append(
                (mirror_rows, Sm * k.take(mirror_rows) - Vm, take(base, mirror_rows) * mirror.take(mirror_rows),
                 left.take(mirror_rows) - 1, False, 1)
            )  # fmt: skip
        if bent_rows.size:
            children.append(
                (bent_rows, bent_D, take(base, bent_rows) * bent_weight, left.take(bent_rows) - 1, False, 2)
            )
        if straight_rows.size:
            through = 1.0 - a.take(straight_rows)
            children.append(
                (straight_rows, take(D, straight_rows), take(base, straight_rows) * through,
                 left.take(straight_rows), True, 2)
            )  # fmt: skip
        if not children:
            break
        parts = []
        for rows_, D_, weight_, left_, straight, kind in children:
            P_ = take(P, rows_)
            O_ = P_
            if scene.robust:
                O_ = offset_origins(P_, take(N, rows_), D_, *(part_.take(rows_) for part_ in surface))
            tag_ = tag.take(rows_)
            tag_ = np.where(tag_ == 0, np.int8(kind), tag_)
            if straight:
                camera_ = camera.take(rows_)
                layers_ = layers.take(rows_) + 1
                clear_ = clear.take(rows_) * (1.0 - a.take(rows_))
                reach_ = None if reach is None else np.where(camera_, reach.take(rows_) - t.take(rows_), np.inf)
                pending_ = pending.take(rows_) & (a.take(rows_) < sc.PASS_ALPHA_THRESHOLD)
            else:
                camera_ = np.zeros(rows_.size, dtype=bool)
                layers_ = layers.take(rows_)
                clear_ = np.zeros(rows_.size, dtype=scene.dtype)
                reach_ = None if reach is None else np.full(rows_.size, np.inf)
                pending_ = np.zeros(rows_.size, dtype=bool)
            parts.append((pixel.take(rows_), O_, D_, weight_, left_, layers_, camera_, tag_, clear_, reach_, pending_))
        joined = [None if parts[0][k_] is None else np.concatenate([p[k_] for p in parts], axis=-1) for k_ in range(11)]
        order = np.argsort(joined[0], kind="stable")
        pixel, O, D, weight, left, layers, camera, tag, clear, reach, pending = (
            None if value is None else value.take(order, axis=-1) for value in joined
        )
        first = False
        query = None if frames is None else RayFrames.of(pixel, frames)
        tally(counts, "reflection", pixel.size, query)
    return color


def _closest_by_kind(
    scene: PreparedScene,
    O: np.ndarray,
    D: np.ndarray,
    t_min: float,
    camera: np.ndarray,
    pixel: np.ndarray,
    sets: list | None,
    frames: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hierarchy.closest for a see-through wavefront: the camera rays (camera, and their straight continuations)
    among the objects the camera sees, the others among those mirror rays see; sets: the camera rays' screen
    rectangles (the first wavefront, all camera rays)."""

    def of(rows: np.ndarray | None) -> RayFrames | None:
        return None if frames is None else RayFrames.of(pixel if rows is None else pixel.take(rows), frames)

    if camera.all():
        return scene.camera_hierarchy.closest(O, D, t_min, sets, None, of(None))
    if scene.camera_hierarchy is scene.mirror_hierarchy or not camera.any():
        return scene.mirror_hierarchy.closest(O, D, t_min, None, None, of(None))
    count = pixel.size
    t = np.full(count, np.inf, dtype=scene.dtype)
    obj = np.full(count, -1, dtype=np.int32)
    part = np.zeros(count, dtype=np.int64)
    for hierarchy, rows in ((scene.camera_hierarchy, indices(camera)), (scene.mirror_hierarchy, indices(~camera))):
        found_t, found_obj, found_part = hierarchy.closest(take(O, rows), take(D, rows), t_min, None, None, of(rows))
        t[rows], obj[rows], part[rows] = found_t, found_obj, found_part
    return t, obj, part


def _local(
    scene: PreparedScene,
    color: np.ndarray,
    lit: np.ndarray,
    P: np.ndarray,
    N: np.ndarray,
    S: np.ndarray,
    V: np.ndarray,
    material: np.ndarray,
    surface: tuple[np.ndarray, np.ndarray] | None,
    paints: tuple[np.ndarray, np.ndarray | None, np.ndarray | None],
    shaded: np.ndarray,
    weight: np.ndarray | None,
    pixel: np.ndarray,
    tag: np.ndarray,
    counts: RayCounts,
    footprint: Footprint | RayStore | None,
    frames: np.ndarray | None,
    recorder: PassRecorder | None,
    first: bool,
) -> None:
    """The shaded share a (1 - t) of the hits lit (k,) of a see-through wavefront: listing 3.2 there and the
    local colour as trace() makes it (emission included), times the share and the rays' weights, added to their
    camera samples; the passes: a camera ray's own hit term by term, the others' by their tag."""
    every = lit.size == pixel.size  # every hit is shaded: no gathers
    pick = (lambda array: array) if every else (lambda array: take(array, lit))
    P_, S_, V_ = pick(P), pick(S), pick(V)
    geometric = None if S is N else pick(N)
    surface_ = None if surface is None else tuple(part if every else part.take(lit) for part in surface)
    material_ = material if every else material.take(lit)
    pixel_ = pixel if every else pixel.take(lit)
    points = None if frames is None else np.searchsorted(pixel_, frames)
    split = {} if recorder is not None and first and recorder.shading else None
    specular = scene.specular.take(material_)
    intensity = shading.find_intensity(
        scene, P_, S_, V_, specular, counts, surface_, footprint, pixel_, geometric, points, split
    )
    reflective = scene.reflective.take(material_)
    share = shaded if every else shaded.take(lit)
    colors, specular_colors, emission = (None if paint is None else pick(paint) for paint in paints)
    if scene.colored:
        diffuse, highlight = intensity
        local = (diffuse * colors + highlight * specular_colors) * (1.0 - reflective)
    else:
        local = (intensity * (1.0 - reflective)) * colors
    if scene.emissive:
        local = local + emission
    local = local * share
    value = local if weight is None else pick(weight) * local
    add_at(color, pixel_, value, first)
    if recorder is None:
        return
    if first:
        if split is not None:  # the terms times (1 - r) a (1 - t): a reflectivity of 1 - (1 - r) a (1 - t)
            glow = None if emission is None else emission * share
            recorder.terms(pixel_, split, material_, 1.0 - (1.0 - reflective) * share, (colors, specular_colors, glow))
    else:
        record_tagged(recorder, "reflection", tag.take(lit), pixel_, value)


def _refract(
    scene: PreparedScene,
    go: np.ndarray,
    a: np.ndarray,
    transmission: np.ndarray,
    material: np.ndarray,
    N: np.ndarray,
    S: np.ndarray,
    D: np.ndarray,
    mirror: np.ndarray,
    colors: np.ndarray,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The glass share of the hits that go on (go (n,)): adds a t F to their mirror weights (n,) in place and
    gives the rows (k,) that refract, their unit directions (3, k) and weights a t (1 - F) colour (3, k) (the
    reference's glass_split: eta = ior entering by the geometric normal N, 1 / ior leaving; the shading normal S
    turned to face D bends the ray; Cycles' fresnel_dielectric_cos)."""
    rows = indices(go & (transmission > 0.0) & (a > 0.0))
    if not rows.size:
        return rows, None, None
    N_, S_, D_ = take(N, rows), take(S, rows), take(D, rows)
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
    return rows.take(keep), T, take(colors, rows.take(keep)) * share.take(keep)


def add_at(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, unique: bool = False) -> None:
    """color[:, pixel] += value where pixels may repeat (a see-through wavefront holds several rays of a camera
    sample): np.add.at, in the order of the rays; unique: they do not (the camera rays' own wavefront), the faster
    gather and scatter of _accumulate (the same sums)."""
    if unique:
        accumulate(color, pixel, value, False)
        return
    for row, add in zip(color, value, strict=True):
        np.add.at(row, pixel, add)


def record_tagged(recorder: PassRecorder, name: str, tag: np.ndarray, pixel: np.ndarray, value: np.ndarray) -> None:
    """What rays of a see-through wavefront add (3, n) into their passes: under a refracted or straight ray (tag 2)
    the Transmission pass, else name (reflection for surfaces, environment for misses)."""
    mine = tag == 2
    if mine.any():
        recorder.add("transmission", pixel[mine], value[:, mine])
    if not mine.all():
        recorder.add(name, pixel[~mine], value[:, ~mine])
