"""A prepared scene's shadow rays -> which lights reach which points: one any-hit query for the rays of every light
(planes first, then each light's coverage grid, then the hierarchy), and where some material has alpha < 1 the share
of each light that passes the partly transparent surfaces on the way (listing 3.2's shadow test, Cycles' transparent
shadows)."""

from __future__ import annotations

import numpy as np

from ..geometry.cull import kernel_sets
from ..geometry.footprint import Footprint
from ..geometry.kernels import indices, take
from ..geometry.rayframes import RayFrames
from ..geometry.robust import offset_origins
from ..scene import scene as sc
from .lights import DirectedLight, LightTerm, directed
from .prepared import PreparedScene
from .rays import SHADOW_T_MIN, RayCounts, tally

# Shadow rays of one query of every light, at most (reached() takes the points in pieces beyond): each of its arrays
# then stays under glibc's largest mmap threshold (32 MB), which a fresh array above it page-faults in again: a glass
# cube under an area light at Shadows 16 (33 lights' rays at every point) spent a third of its CPU time in the kernel
SHADOW_RAYS_PIECE = 1 << 20


def reached(
    scene: PreparedScene,
    terms: list[LightTerm],
    P: np.ndarray,
    N: np.ndarray,
    surface: tuple[np.ndarray, np.ndarray] | None,
    counts: RayCounts,
    footprint: Footprint | None = None,
    samples: np.ndarray | None = None,
    frames: np.ndarray | None = None,
) -> list[np.ndarray]:
    """One any-hit query for the shadow rays of every light (terms: each light's, in order): which points (n,) of P
    each light reaches, the rays starting off the normals N (3, n) and the points' surface (robust numerics);
    footprint: records them as rays of the camera samples (n,); frames: where each frame's points start (K + 1,),
    as find_intensity() takes them. The reason for 9 parameters: the points' three, and the bookkeeping of
    counts, footprint and frames every query of the tracer carries.

    Robust numerics start each shadow ray just off the surface (offset_origins), on the light's side, and search
    t from 0; the documented ones start on the surface and search t from 0.001 (listing 3.2). In adaptive
    sampling's flagging pass (render.adaptive_flags) the world light reaches every point it faces, with no ray."""
    count = P.shape[1]
    rays = sum(term.needed.size for term in terms)
    if rays > SHADOW_RAYS_PIECE and frames is None and count > 1:  # each ray's answer is its own: points in pieces
        lit = [np.zeros(count, dtype=bool) for _ in terms]
        piece = max(1, count * SHADOW_RAYS_PIECE // rays)
        for start in range(0, count, piece):
            part = slice(start, min(count, start + piece))
            found = reached(
                scene,
                [_term_piece(term, part, count) for term in terms],
                P[:, part],
                N[:, part],
                None if surface is None else tuple(array[part] for array in surface),
                counts,
                footprint,
                None if samples is None else samples[part],
            )
            for whole, answer in zip(lit, found, strict=True):
                whole[part] = answer
        return lit
    lights = directed(scene.lights)
    unshadowed = scene.scene.render.adaptive_flags  # the world light's directions (its samples have no highlight)
    t_min = 0.0 if scene.robust else SHADOW_T_MIN
    shadows, origins, vectors, limits, bits, views, runs = [], [], [], [], [], [], []
    start = 0  # where the light's rays start in the query of all lights
    for light, term in zip(lights, terms, strict=True):
        L, needed = term.L, term.needed
        own = None if frames is None else RayFrames.of(needed, frames)  # the light's rays by frame
        if unshadowed and not light.highlight:  # reached wherever needed: no ray
            origin = vector = np.empty((3, 0), dtype=scene.dtype)
            blocked, rest, covering = np.zeros(needed.size, dtype=bool), needed[:0], None
        else:
            origin, vector = _shadow_rays(scene, light, L, needed, P, N, surface)
            if footprint is not None:  # the whole segment: a blocker that moves in could block it anywhere
                footprint.record(samples.take(needed), origin, vector, t_min, light.t_max, light=light.source)
            tally(counts, "shadow", needed.size, own)
            blocked, rest, covering = _outside_planes_and_grid(scene, light, origin, vector, t_min, own)
        bits.append(None if covering is None else (light.grid.kernels, covering))
        shadows.append((needed, blocked, rest))
        if own is not None:
            runs.append(RayFrames.of(rest, own.cuts[0], start))
        start += rest.size
        origins.append((origin, rest))
        vectors.append((vector, rest))
        limits.append(light.t_max)
        views.append(light.view)
    if not shadows:
        return []
    # where every light's grid told which boxes each ray may meet, the hierarchy is not walked
    hierarchy = scene.shadow_hierarchy
    sets = None if any(b is None for b in bits) else kernel_sets(bits)
    # which light's point or direction each ray shares, for the meshes' pictures
    sizes = [rest.size for *_, rest in shadows]
    which = np.repeat(np.arange(len(views)), sizes)
    # one limit for every ray where the lights share it (suns and the world: no limit, which spares the walk its
    # tests against each ray's limit); else each ray its light's
    shared_limit = len(set(limits)) == 1
    blocked_by_objects = (
        np.zeros(0, dtype=bool)
        if not start
        else hierarchy.occluded(
            _joined(origins, start, scene.dtype),
            _joined(vectors, start, scene.dtype),
            t_min,
            limits[0] if shared_limit else np.repeat(np.array(limits, dtype=scene.dtype), sizes),
            planes=False,
            sets=sets,
            views=(views, which),
            frames=RayFrames.joined(runs) if runs else None,
        )
    )
    lit, start = [], 0
    for needed, blocked, rest in shadows:
        blocked[rest] = blocked_by_objects[start : start + rest.size]
        start += rest.size
        reaching = np.zeros(P.shape[1], dtype=bool)
        reaching[needed] = ~blocked
        lit.append(reaching)
    return lit


def _joined(parts: list[tuple[np.ndarray, np.ndarray]], count: int, dtype: np.dtype) -> np.ndarray:
    """Each light's rays: its array (3, k) and the columns rest (r,) of it that go on (a shared column (3, 1)
    stands for every one of them) -> (3, count), one light after another. Gathered straight into the query's
    array: no copy per light to join (13 million shadow rays of 3,000 cubes at 1280x720)."""
    if len(parts) == 1:  # one light: its array as it is where it can be
        array, rest = parts[0]
        if array.shape[1] == rest.size:
            return array
        return np.broadcast_to(array, (3, rest.size)) if array.shape[1] == 1 else take(array, rest)
    joined = np.empty((3, count), dtype=dtype)
    start = 0
    for array, rest in parts:
        stop = start + rest.size
        for row in range(3):
            if array.shape[1] == 1 or array.shape[1] == rest.size:  # a shared column, or every ray
                joined[row, start:stop] = array[row]
            else:
                array[row].take(rest, out=joined[row, start:stop], mode="wrap")
        start = stop
    return joined


def _term_piece(term: LightTerm, part: slice, count: int) -> LightTerm:
    """A light's term at the points part of count: its per-point arrays sliced (a shared column kept), and the
    points that need a shadow ray among them, counted from the piece's start."""
    needed = term.needed
    first, last = np.searchsorted(needed, (part.start, part.stop))
    cut = {
        name: value[..., part] if isinstance(value, np.ndarray) and value.shape[-1] == count else value
        for name, value in term._asdict().items()
    }
    cut["needed"] = needed[first:last] - part.start
    return LightTerm(**cut)


def _outside_planes_and_grid(
    scene: PreparedScene,
    light: DirectedLight,
    origin: np.ndarray,
    vector: np.ndarray,
    t_min: float,
    own: RayFrames | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """A light's shadow rays (3, k) against the planes first (a shared direction keeps their test cheap), then its
    coverage grid: which are blocked by a plane (k,), the rays (r,) the grid cannot rule out, which go on to the
    hierarchy with every light's, and the grid's kernel bits for them (None without a grid)."""
    whole = [] if light.grid is None else light.grid.whole  # what the light's picture leaves out
    blocked = scene.shadow_hierarchy.blocked_by_planes(origin, vector, t_min, light.t_max, whole, own)
    if light.grid is None:
        return blocked, indices(~blocked), None
    rest, covering = light.covering(origin, vector)
    keep = indices(~blocked.take(rest))
    return blocked, rest.take(keep), None if covering is None else covering.take(keep)


def _shadow_rays(
    scene: PreparedScene,
    light: DirectedLight,
    L: np.ndarray,
    needed: np.ndarray,
    P: np.ndarray,
    N: np.ndarray,
    surface: tuple[np.ndarray, np.ndarray] | None,
) -> tuple[np.ndarray, np.ndarray]:
    """The shadow rays toward a light from the points needed (k,) of P (3, n): origins and vectors (3, k; a
    directional light's vector a shared column), the light at t = 1 for a point. Robust numerics start them just
    off the surface (offset_origins, by the normals N and the points' surface), on the light's side."""
    vector = take(L, needed)
    origin = take(P, needed)
    if scene.robust:
        target = take(P, needed) + vector if light.disk is not None else light.vector
        origin = offset_origins(origin, take(N, needed), vector, *(part.take(needed) for part in surface))
        if light.ends_at_point:
            vector = target - origin  # t = 1 is still exactly the light
    return origin, vector


def passing(
    scene: PreparedScene,
    terms: list[LightTerm],
    lit: list[np.ndarray],
    P: np.ndarray,
    N: np.ndarray,
    counts: RayCounts,
    surface: tuple[np.ndarray, np.ndarray] | None,
    frames: np.ndarray | None,
) -> list[np.ndarray]:
    """Where some material has alpha < 1: the share (n,) of each light (not ambient) that reaches the points,
    from reached()'s answer: 1 where nothing blocks, else the product of 1 - alpha over the surfaces the shadow ray
    meets, nearest first, each passed by a segment from its hit along the same vector (the rest of the range);
    0 at an opaque one (glass too: Cycles' caustics off) or past sc.TRANSPARENT_BOUNCES of them (the
    reference's shadow_through)."""
    lights = directed(scene.lights)
    t_min = 0.0 if scene.robust else SHADOW_T_MIN
    throughs = []
    for light, term, reached in zip(lights, terms, lit, strict=True):
        L, needed = term.L, term.needed
        through = reached.astype(scene.dtype)
        rows = needed.take(indices(~reached.take(needed)))
        if not rows.size:
            throughs.append(through)
            continue
        vector = np.array(np.broadcast_to(take(L, rows), (3, rows.size)))
        origin = np.array(np.broadcast_to(take(P, rows), (3, rows.size)))
        target = None
        if scene.robust:  # as reached() starts them
            target = origin + vector if light.disk is not None else light.vector
            origin = offset_origins(origin, take(N, rows), vector, *(part.take(rows) for part in surface))
            if light.ends_at_point:
                vector = target - origin
        limit = np.full(rows.size, light.t_max, dtype=scene.dtype)
        share = np.ones(rows.size, dtype=scene.dtype)
        live = np.arange(rows.size)
        if scene.opaque_shadows is not None:  # an object that blocks whole on the way: 0, whatever else is there
            query = None if frames is None else RayFrames.of(rows, frames)
            tally(counts, "shadow", rows.size, query)
            whole = scene.opaque_shadows.occluded(origin, vector, t_min, light.t_max, frames=query)
            share[whole] = 0.0
            live = indices(~whole)
        for layer in range(sc.TRANSPARENT_BOUNCES + 1):
            if not live.size:
                break
            query = None if frames is None else RayFrames.of(rows.take(live), frames)
            tally(counts, "shadow", live.size, query)
            O_, L_ = take(origin, live), take(vector, live)
            t, obj, part = scene.shadow_hierarchy.closest(O_, L_, t_min, None, None, query)
            found = indices((obj >= 0) & (t < limit.take(live)))
            a = scene.alpha.take(scene.material_of(obj.take(found), part.take(found)))
            opaque = (a >= 1.0) | (layer >= sc.TRANSPARENT_BOUNCES)
            share[live.take(found.take(indices(opaque)))] = 0.0
            on = indices(~opaque)
            passed, at = found.take(on), t.take(found.take(on))
            live = live.take(passed)
            share[live] *= 1.0 - a.take(on)
            Q = take(O_, passed) + take(L_, passed) * at
            if scene.robust:
                normals, rounding = scene.normals(Q, obj.take(passed), part.take(passed))
                origin[:, live] = offset_origins(Q, normals, take(L_, passed), *rounding)
                if light.ends_at_point:
                    ends = target if target.shape[1] == 1 else take(target, live)
                    vector[:, live] = ends - origin[:, live]
            else:
                origin[:, live] = Q
                limit[live] -= at
        through[rows] = share
        throughs.append(through)
    return throughs
