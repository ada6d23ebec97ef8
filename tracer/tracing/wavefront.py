"""A scene -> the documented tracer over arrays: every ray of a bounce at once (listings 3.1 and 3.2, vectorized).

TraceRay's recursion becomes a loop over bounces: each bounce finds the closest hit of all live rays, adds the
background for misses and weight * local color for hits, and the rays that hit reflective surfaces continue with
their weight multiplied by r. FindIntensity runs per light over all hit points, shadow rays as any-hit tests.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from ..geometry import camera as cam
from ..geometry import transforms as tf
from ..geometry.bvh import Hierarchy
from ..geometry.cull import CoverageGrid, ScreenRectangles, kernel_sets
from ..geometry.footprint import Footprint, Volume
from ..geometry.kernels import Kernel, PlaneKernel, column, dot, indices, make_kernel, quiet, take
from ..geometry.meshbvh import MESH_HIERARCHY_TRIANGLES, MeshKernel
from ..geometry.robust import make_robust_kernel, offset_origins
from ..scene import scene as sc
from .raystore import RayStore

CAMERA_T_MIN = 0.0  # seed 2.10: t >= 0
SHADOW_T_MIN = 0.001  # listing 3.2
REFLECTION_T_MIN = 0.01  # listing 3.1


@dataclass
class RayCounts:
    camera: int = 0
    shadow: int = 0
    reflection: int = 0

    @property
    def total(self) -> int:
        return self.camera + self.shadow + self.reflection

    def add(self, other: RayCounts) -> None:
        self.camera += other.camera
        self.shadow += other.shadow
        self.reflection += other.reflection


@dataclass
class _Light:
    kind: str
    intensity: float
    vector: np.ndarray | None = None  # (3, 1): point location or direction toward the light
    t_max: float = math.inf
    grid: CoverageGrid | None = None  # which shadow rays can meet a bounded object


@dataclass
class PreparedScene:
    """What tracing needs, built once per scene: kernels, per-object materials, lights, background."""

    scene: sc.Scene
    dtype: np.dtype = field(init=False)
    kernels: list[Kernel] = field(init=False)

    def __post_init__(self) -> None:
        settings = self.scene.render
        self.dtype = np.dtype(settings.dtype)
        self.robust = settings.numerics == "robust"
        build = make_robust_kernel if self.robust else make_kernel
        primitives = tf.world_primitives(self.scene)
        self.kernels = [_kernel(build, primitive, self.dtype) for primitive in primitives]  # per object: normals
        # a large mesh enters the scene's hierarchy as one leaf with a hierarchy of its own over its triangles
        leaf_kernels = [
            _kernel(MeshKernel, kernel, primitive)
            if isinstance(primitive, tf.WorldTriangles) and len(primitive.triangles) > MESH_HIERARCHY_TRIANGLES
            else kernel
            for kernel, primitive in zip(self.kernels, primitives, strict=True)
        ]
        owners = list(range(len(leaf_kernels)))
        self.hierarchy = Hierarchy(leaf_kernels, self.dtype, owners)
        materials = [self.scene.materials[obj.material] for obj in self.scene.objects]
        self.colors = np.asarray([m.color for m in materials], dtype=self.dtype).T.reshape(3, -1)  # (3, objects)
        self.specular = np.asarray([m.specular for m in materials], dtype=self.dtype)
        self.reflective = np.asarray([m.reflective for m in materials], dtype=self.dtype)
        self.lights = []
        for light in self.scene.lights:
            if isinstance(light, sc.AmbientLight):
                self.lights.append(_Light("ambient", light.intensity))
            elif isinstance(light, sc.PointLight):
                self.lights.append(_Light("point", light.intensity, column(light.location, self.dtype), 1.0))
            else:
                self.lights.append(_Light("directional", light.intensity, column(light.direction, self.dtype)))
        background = self.scene.background
        self.documented_color = None
        if background.type == "documented":
            direction = cam.documented_background_direction(self.scene.camera, settings)
            self.documented_color = column(background.sky(direction[2]), self.dtype)
        self.origin = column(self.scene.camera.location, self.dtype)
        self.screen = None  # which camera rays each bounded kernel can meet
        if self.hierarchy.boxes is not None:
            self.screen = ScreenRectangles.build(
                self.scene.camera, settings, self.origin.ravel().astype(np.float64), self.hierarchy.boxes
            )
            boxes = self.hierarchy.boxes
            for light in self.lights:
                if light.kind == "point":
                    light.grid = CoverageGrid.from_point(light.vector.ravel().astype(np.float64), *boxes)
                elif light.kind == "directional":
                    light.grid = CoverageGrid.from_direction(light.vector.ravel().astype(np.float64), *boxes)

    # ---- intersection ------------------------------------------------------------------------------------------

    def normals(
        self, P: np.ndarray, obj: np.ndarray, part: np.ndarray
    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """Unit normals (3, N) at hit points P (3, N) on objects obj (N,), and in robust numerics what
        offset_origins() needs (else None): each point's signed distance (N,) from its surface along the normal, and
        its primitive's rounding magnitude (N,)."""
        N = np.empty_like(P)
        if self.robust:
            distance, scale = np.empty(P.shape[1], dtype=self.dtype), np.empty(P.shape[1], dtype=self.dtype)
        # a stable sort of 8- or 16-bit keys is NumPy's radix sort: about twice as fast as on int32 here
        key = np.uint8 if len(self.kernels) <= 256 else np.uint16 if len(self.kernels) <= 65536 else obj.dtype
        order = np.argsort(obj.astype(key), kind="stable")
        start = 0
        for index, size in enumerate(np.bincount(obj, minlength=len(self.kernels)).tolist()):
            if size:
                rows = order[start : start + size]
                kernel = self.kernels[index]
                if isinstance(kernel, PlaneKernel):  # one normal for every point: no need to gather them
                    unit = kernel.unit
                else:
                    unit = kernel.unit_normal(take(P, rows), part.take(rows))
                for axis in range(3):
                    N[axis].put(rows, unit[axis])
                if self.robust:
                    along, rounding = kernel.surface(take(P, rows), part.take(rows))
                    distance.put(rows, along)
                    scale.put(rows, rounding)
                start += size
        return N, ((distance, scale) if self.robust else None)

    # ---- shading -----------------------------------------------------------------------------------------------

    def find_intensity(
        self,
        P: np.ndarray,
        N: np.ndarray,
        V: np.ndarray,
        specular: np.ndarray,
        counts: RayCounts,
        surface: tuple[np.ndarray, np.ndarray] | None = None,
        footprint: Footprint | None = None,
        samples: np.ndarray | None = None,
    ) -> np.ndarray:
        """Listing 3.2 for every hit point at once: P, N, V (3, n), specular (n,) -> intensity (n,).

        surface: robust numerics' (distance, scale) (n,) of each point, as normals() gives them. footprint: records
        the shadow rays of the camera samples (n,) the points belong to.

        The shadow rays of all lights go through the hierarchy in one batch; the terms are then added light by
        light in the listing's order."""
        settings = self.scene.render
        count = P.shape[1]
        length_n = np.sqrt(dot(N, N))
        length_v = np.sqrt(dot(V, V))
        shiny = specular > 0.0
        exponent = specular * settings.coef if settings.model == "blinn-phong" else specular
        terms = []
        for light in self.lights:
            if light.kind == "ambient":
                terms.append(None)
                continue
            L = light.vector - P if light.kind == "point" else light.vector  # a directional L broadcasts
            NL = dot(N, L)
            length_l = np.sqrt(dot(L, L))
            gate = shiny.copy()
            if settings.gate_specular:
                gate &= NL > 0.0
            if settings.model == "phong":
                k = 2.0 * dot(N, L)
                R = N * k - L
                RV = dot(R, V)
                gate &= RV > 0.0
                cosine = RV / (np.sqrt(dot(R, R)) * length_v)
            else:
                H = L / length_l + V / length_v
                HN = dot(H, N)
                gate &= HN > 0.0
                cosine = HN / (np.sqrt(dot(H, H)) * length_n)
            # a shadow ray only where this light could add something: the result is the listing's, with fewer rays
            diffuse_gate = NL > 0.0
            needed = indices(diffuse_gate | gate)
            terms.append((L, NL, length_l, diffuse_gate, gate, cosine, needed))
        lit = self._lit([term for term in terms if term is not None], P, N, counts, surface, footprint, samples)
        intensity = np.zeros(count, dtype=self.dtype)
        shadow_rays = iter(lit)
        for light, term in zip(self.lights, terms, strict=True):
            if term is None:
                intensity = intensity + light.intensity
                continue
            L, NL, length_l, diffuse_gate, gate, cosine, needed = term
            light_lit = next(shadow_rays)
            diffuse = light.intensity * NL / (length_n * length_l)
            intensity = np.where(light_lit & diffuse_gate, intensity + diffuse, intensity)
            gate &= light_lit
            highlight = light.intensity * np.power(np.where(gate, cosine, 1.0), exponent)
            intensity = np.where(gate, intensity + highlight, intensity)
        return intensity

    def _lit(
        self,
        terms: list[tuple],
        P: np.ndarray,
        N: np.ndarray,
        counts: RayCounts,
        surface: tuple[np.ndarray, np.ndarray] | None,
        footprint: Footprint | None = None,
        samples: np.ndarray | None = None,
    ) -> list[np.ndarray]:
        """One any-hit query for the shadow rays of every light: which points (n,) each light reaches.

        Robust numerics start each shadow ray just off the surface (offset_origins), on the light's side, and search
        t from 0; the documented ones start on the surface and search t from 0.001 (listing 3.2)."""
        lights = [(index, light) for index, light in enumerate(self.lights) if light.kind != "ambient"]
        t_min = 0.0 if self.robust else SHADOW_T_MIN
        shadows, origins, vectors, limits, bits = [], [], [], [], []
        for (index, light), (L, *_, needed) in zip(lights, terms, strict=True):
            vector = take(L, needed)  # a directional light's vector stays a shared column
            origin = take(P, needed)
            if self.robust:
                origin = offset_origins(origin, take(N, needed), vector, *(part.take(needed) for part in surface))
                if light.kind == "point":
                    vector = light.vector - origin  # t = 1 is still exactly the light
            if footprint is not None:  # the whole segment: a blocker that moves in could block it anywhere
                footprint.record(samples.take(needed), origin, vector, t_min, light.t_max, light=index)
            counts.shadow += needed.size
            # planes first, light by light (a shared direction keeps their test cheap); then only the rays that
            # the light's coverage grid cannot rule out go on to the hierarchy, all lights in one batch
            blocked = self.hierarchy.blocked_by_planes(origin, vector, t_min, light.t_max)
            if light.grid is None:
                rest, covering = indices(~blocked), None
            else:
                rest, covering = light.grid.select(vector, True) if light.kind == "point" else light.grid.select(origin)
                keep = indices(~blocked.take(rest))
                rest = rest.take(keep)
                covering = None if covering is None else covering.take(keep)
            bits.append(covering)
            shadows.append((needed, blocked, rest))
            origins.append(take(origin, rest))
            vectors.append(np.broadcast_to(vector, (3, rest.size)) if vector.shape[1] == 1 else take(vector, rest))
            limits.append(np.full(rest.size, light.t_max, dtype=self.dtype))
        if not shadows:
            return []
        # where every light's grid told which boxes each ray may meet, the hierarchy is not walked
        sets = None if any(b is None for b in bits) else kernel_sets(self.hierarchy.boxes[0], np.concatenate(bits))
        blocked_by_objects = self.hierarchy.occluded(
            np.concatenate(origins, axis=1),
            np.concatenate(vectors, axis=1),
            t_min,
            np.concatenate(limits),
            planes=False,
            sets=sets,
        )
        lit, start = [], 0
        for needed, blocked, rest in shadows:
            blocked.put(rest, blocked_by_objects[start : start + rest.size])
            start += rest.size
            reached = np.zeros(P.shape[1], dtype=bool)
            reached.put(needed, ~blocked)
            lit.append(reached)
        return lit

    def background(self, D: np.ndarray) -> np.ndarray:
        """Colors (3, n) for rays (3, n) that hit nothing."""
        background = self.scene.background
        if background.type == "none":
            return np.zeros_like(D)
        if background.type == "solid":
            return np.broadcast_to(column(background.color, self.dtype), D.shape)
        if background.type == "documented":
            return np.broadcast_to(self.documented_color, D.shape)
        k = np.minimum(np.maximum(D[2], 0.0), 1.0)
        horizon = column(background.horizon, self.dtype)
        zenith = column(background.zenith, self.dtype)
        return horizon + (zenith - horizon) * k

    # ---- TraceRay as a wavefront -------------------------------------------------------------------------------

    def trace(
        self,
        D: np.ndarray,
        counts: RayCounts,
        rows: np.ndarray | None = None,
        origins: np.ndarray | None = None,
        far: np.ndarray | None = None,
        footprint: Footprint | RayStore | None = None,
    ) -> np.ndarray:
        """Camera rays (3, N) -> linear colors (3, N), unclamped.

        rows: the image rows (R,) that the rays are, ordered as camera.band_directions gives them, if they are.
        origins (3, N): where each ray starts (None: all at the camera); far (N,): where each stops (None: never),
        as camera.band_starts gives them for a clipped or orthographic camera. footprint: records which of the N
        camera rays' trees meet its volume."""
        depth = self.scene.render.depth
        total = D.shape[1]
        counts.camera += total
        color = np.zeros((3, total), dtype=self.dtype)
        weight = np.ones(total, dtype=self.dtype)
        pixel = np.arange(total)
        O = self.origin if origins is None else origins  # (3, 1): every camera ray starts at the camera
        t_min = CAMERA_T_MIN
        for bounce in range(depth + 1):
            sets = self.screen.rays(rows) if bounce == 0 and rows is not None and self.screen is not None else None
            t, obj, part = self.hierarchy.closest(O, D, t_min, sets)
            if bounce == 0 and far is not None:  # beyond the camera's clip_end: the nearest hit is, so all are
                obj[t >= far] = -1
            if footprint is not None:  # each ray up to its hit; a miss to its end
                end = np.where(obj >= 0, t, np.inf if bounce or far is None else far)
                footprint.record(pixel, O, D, t_min, end, hit=obj)
            miss = indices(obj < 0)
            if miss.size:
                sky = weight.take(miss) * self.background(take(D, miss))
                _accumulate(color, pixel.take(miss), sky, bounce == 0)
            if miss.size == obj.size:
                break
            hit = indices(obj >= 0)
            O, D, t, obj, part = take(O, hit), take(D, hit), t.take(hit), obj.take(hit), part.take(hit)
            weight, pixel = weight.take(hit), pixel.take(hit)
            P = O + D * t
            V = -D
            O = D = t = None  # memory: a band's peak comes in the shading below
            N, surface = self.normals(P, obj, part)
            intensity = self.find_intensity(P, N, V, self.specular.take(obj), counts, surface, footprint, pixel)
            reflective = self.reflective.take(obj)
            local = (intensity * (1.0 - reflective)) * self.colors.take(obj, axis=1)
            _accumulate(color, pixel, weight * local, bounce == 0)
            go_on = indices(reflective > 0.0)
            if bounce == depth or go_on.size == 0:
                break
            P, N, V = take(P, go_on), take(N, go_on), take(V, go_on)
            k = 2.0 * dot(N, V)
            O, D = P, N * k - V
            if self.robust:
                O = offset_origins(P, N, D, *(part.take(go_on) for part in surface))
            weight, pixel = weight.take(go_on) * reflective.take(go_on), pixel.take(go_on)
            counts.reflection += D.shape[1]
            t_min = 0.0 if self.robust else REFLECTION_T_MIN
        return color

    def render_rows(
        self,
        rows: np.ndarray,
        max_samples: int | None = None,
        volume: Volume | None = None,
        touched: np.ndarray | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """Image rows (R,) -> (R, width, 3) linear image in the scene's dtype, and the ray counts.

        max_samples: trace at most this many camera samples at once (memory); a larger band goes in pieces of whole
        rows, or of a row's columns where one row is too many. Every ray is traced by the same elementwise
        operations whatever else is in its piece, so the pixels are the same bytes either way. volume, touched
        (R, width) bool: marks each pixel some of whose rays' trees meet the volume (footprint.py)."""
        settings = self.scene.render
        per_row = settings.width * settings.samples
        rows = np.asarray(rows)
        if max_samples is None or len(rows) * per_row <= max_samples:
            return self._render_piece(rows, None, volume, touched)
        counts = RayCounts()
        image = np.empty((len(rows), settings.width, 3), dtype=self.dtype)
        rows_at_once = max_samples // per_row
        if rows_at_once >= 1:
            for first in range(0, len(rows), rows_at_once):
                part = slice(first, first + rows_at_once)
                piece_touched = None if touched is None else touched[part]
                image[part], piece_counts = self._render_piece(rows[part], None, volume, piece_touched)
                counts.add(piece_counts)
            return image, counts
        columns_at_once = max(1, max_samples // settings.samples)
        for index, row in enumerate(rows):
            for first in range(0, settings.width, columns_at_once):
                columns = np.arange(first, min(first + columns_at_once, settings.width))
                piece_touched = None if touched is None else touched[index : index + 1, first : first + len(columns)]
                piece, piece_counts = self._render_piece(np.asarray([row]), columns, volume, piece_touched)
                image[index, columns] = piece[0]
                counts.add(piece_counts)
        return image, counts

    def _render_piece(
        self, rows: np.ndarray, columns: np.ndarray | None, volume: Volume | None, touched: np.ndarray | None
    ) -> tuple[np.ndarray, RayCounts]:
        """Rows (R,) and columns (C,) of the image (every column when None) -> (R, C, 3) and the ray counts;
        touched (R, C) is filled where a volume is given."""
        settings = self.scene.render
        camera = self.scene.camera
        with quiet():  # the directions are not kept here: trace() lets them go after the first bounce
            if columns is None:
                directions = cam.cached_band_directions(camera, settings, rows, self.dtype)
            else:
                directions = cam.band_directions(camera, settings, rows, columns).astype(self.dtype)
        pixels = None if cam.shares_origin(camera) else cam.band_pixels(settings, rows, columns)
        # whole rows: the screen rectangles cull them
        colors, counts, hit = self._trace_pixels(directions, pixels, rows if columns is None else None, volume)
        width = settings.width if columns is None else len(columns)
        if touched is not None:
            touched[...] = hit.reshape(len(rows), width)
        return colors.reshape(len(rows), width, 3), counts

    def render_pixels(
        self, pixels: np.ndarray, max_samples: int | None = None, store: RayStore | None = None
    ) -> tuple[np.ndarray, RayCounts]:
        """Flat pixel indices j * W + i (P,) -> their linear colours (P, 3) in the scene's dtype, and the ray
        counts: the same bytes as those pixels of a whole image (the incremental frames' re-trace). store: keeps
        every segment of their ray trees (edits.py)."""
        settings = self.scene.render
        at_once = len(pixels) if max_samples is None else max(1, max_samples // settings.samples)
        colors = np.empty((len(pixels), 3), dtype=self.dtype)
        counts = RayCounts()
        for first in range(0, len(pixels), at_once):
            piece = np.asarray(pixels[first : first + at_once])
            with quiet():
                directions = cam.pixel_directions(self.scene.camera, settings, piece).astype(self.dtype)
            if store is not None:
                store.begin(piece, settings.samples)
            traced = self._trace_pixels(directions, piece, None, None, store)
            colors[first : first + at_once], piece_counts, _ = traced
            counts.add(piece_counts)
        return colors, counts

    def _trace_pixels(
        self,
        directions: np.ndarray,
        pixels: np.ndarray | None,
        rows: np.ndarray | None,
        volume: Volume | None,
        store: RayStore | None = None,
    ) -> tuple[np.ndarray, RayCounts, np.ndarray | None]:
        """Camera rays (3, P * samples) of the flat pixels (P,; needed only for a camera whose rays do not all
        start at its location) -> colours (P, 3) box-filtered over each pixel's samples, the ray counts, and where a
        volume is given which pixels' trees met it (P,)."""
        settings = self.scene.render
        camera = self.scene.camera
        counts = RayCounts()
        footprint = store if store is not None else None if volume is None else Footprint(volume, directions.shape[1])
        with quiet():
            origins = far = None
            if not cam.shares_origin(camera):
                origins, far = cam.pixel_starts(camera, settings, pixels, directions)
                origins = origins.astype(self.dtype)
            color = self.trace(directions, counts, rows, origins, far, footprint)
        samples = color.reshape(3, -1, settings.samples)
        image = samples.sum(axis=2) / settings.samples if settings.samples > 1 else samples[..., 0]
        hit = None if volume is None else footprint.touched.reshape(-1, settings.samples).any(axis=1)
        return np.ascontiguousarray(image.T), counts, hit


_KERNELS: OrderedDict[tuple, object] = OrderedDict()
KERNEL_CACHE_SIZE = 512


def _kernel(make, first: object, second: object):
    """make(first, second) (a primitive and a dtype, or a mesh's kernel and its primitive), kept for primitives that
    stay put between frames (in an animation all but the vane's parts); kernels never change once made."""
    key = (make, first, second.str if isinstance(second, np.dtype) else second)
    made = _KERNELS.get(key)
    if made is None:
        made = _KERNELS[key] = make(first, second)
        if len(_KERNELS) > KERNEL_CACHE_SIZE:
            _KERNELS.popitem(last=False)
    else:
        _KERNELS.move_to_end(key)
    return made


def _accumulate(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, fresh: bool) -> None:
    """color[:, pixel] += value for unique pixel indices, a row at a time (several times faster than fancy `+=`).

    fresh: the pixels still hold their initial zeros (the camera rays' bounce), so the value is stored as it is."""
    for row, add in zip(color, value, strict=True):
        row.put(pixel, add if fresh else row.take(pixel) + add)
