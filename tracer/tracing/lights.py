"""A scene's lights -> the lights the shading traces: one PreparedLight per light, or per sample of a light of a size
(an area light's points, a sun's directions, the disk of a point light's radius), each knowing its vector toward a
point, its attenuation there, where its shadow rays end and which objects they can meet (its coverage grid).

Three kinds, one class each: AmbientLight (no direction, no shadow), PointSample (a point, a spot or one sample of an
area light or of a radius: shadow rays end at it) and DirectionalSample (a sun or one of its directions: shadow rays
run to infinity). The shading adds their terms in the scene's order (listing 3.2)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.cull import CoverageGrid
from ..geometry.kernels import column, dot
from ..geometry.meshpicture import View
from ..scene import scene as sc


@dataclass
class PreparedLight:
    """What every traced light has: its intensity, colour (3, 1) in the tracing dtype, the scene light it is (or is
    a sample of: its index in scene.lights), its share of that light (1 / samples for a light of a size, the
    Shadow pass's weight), and which of that light's samples it is, of how many (lightsamples.world_share gives a
    sample of a light of a size, or a world direction, to some of a pixel's camera samples; a pixel takes the samples
    of one of a light of a size's patterns, lightsamples.pixel_pattern)."""

    intensity: float
    color: np.ndarray
    source: int = 0
    weight: float = 1.0
    index: int = 0
    count: int = 1
    patterns: int = 1  # a light of a size's sample patterns (lightsamples.patterned_grid): its own is index mod this
    adds_diffuse: bool = True  # the scene light's visible_diffuse: its diffuse term is added
    adds_glossy: bool = True  # its visible_glossy: its highlight, its light through glossy lobes and off rough glass
    adds_transmission: bool = True  # its visible_transmission: its light through rough glass

    ambient: ClassVar[bool] = False  # no direction: its term is its intensity, it casts no shadow
    highlight: ClassVar[bool] = True  # a Phong / Blinn-Phong highlight besides the diffuse term
    world: ClassVar[bool] = False  # its colour at a point is the background's radiance along its vector there


@dataclass
class AmbientLight(PreparedLight):
    """Listing 3.2's ambient term: added to every point whatever its normal, never blocked."""

    ambient: ClassVar[bool] = True


@dataclass
class DirectedLight(PreparedLight):
    """A light with a direction at each point: its shadow rays run from the point along vector() up to t_max, and
    its grid (None: none) tells which of the scene's bounded objects each of them can meet."""

    vector: np.ndarray | None = None  # (3, 1): a point's location, or the direction toward a directional light
    # a light of a size's samples at this one's place in each of its patterns (3, patterns), or None: one pattern
    places: np.ndarray | None = None
    grid: CoverageGrid | None = None
    t_max: ClassVar[float] = math.inf
    ends_at_point: ClassVar[bool] = False  # shadow rays end at the light (their vectors point at one place)
    disk: ClassVar[tuple[float, float] | None] = None

    def toward(self, P: np.ndarray) -> np.ndarray:
        """L (3, n) from the points P (3, n) toward the light (unnormalized; a shared column for a direction)."""
        raise NotImplementedError

    def vector_at(self, P: np.ndarray, N: np.ndarray, shared: dict[int, tuple]) -> np.ndarray:
        """L (3, n) toward this light or sample from the points P with normals N (3, n); shared: what the samples of
        one scene light share at the points (by source), made by the first of them."""
        return self.toward(P)

    def attenuation(self, L: np.ndarray, length_l: np.ndarray) -> np.ndarray | None:
        """The factor (n,) on its terms at the points L came from (None: 1 everywhere)."""
        return None

    @property
    def attenuated(self) -> bool:
        """Whether attenuation() can give 0 (a spot's cone, an emitter's back): no shadow ray goes where it does."""
        return False

    @property
    def view(self) -> View | None:
        """What the light's shadow rays share, for the meshes' pictures."""
        raise NotImplementedError

    def make_grid(self, kernels: list[int], lower: np.ndarray, upper: np.ndarray) -> CoverageGrid | None:
        """The coverage grid of the bounded kernels' boxes (lower, upper) (k, 3) seen from the light (None:
        none)."""
        raise NotImplementedError

    def covering(self, origin: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """grid.select for the shadow rays origin + t vector (3, n): the rays (k,) it cannot rule out and the boxes
        each may meet."""
        raise NotImplementedError

    def grid_shares(self, P: np.ndarray) -> np.ndarray:
        """The share (k,) of the shadow rays from the points P (3, n) that the grid gives each kernel."""
        raise NotImplementedError


@dataclass
class PointSample(DirectedLight):
    """A point or spot light, or one sample point of an area light or of a point light's radius."""

    inverse_square: bool = False  # terms divided by |L|^2
    spot: sc.SpotLight | None = None  # terms times spot_attenuation()
    axis: np.ndarray | None = None  # a spot's unit axis (3, 1)
    # a stretched cone (cone_scale): the unit axes across the spot's axis (3, 1) each with its factor (cone_axes)
    cone: tuple[np.ndarray, float, np.ndarray, float] | None = None
    # one sample point of an area light: the unit normal it shines along (3, 1), its terms multiplied by the cosine
    # there (a one-sided Lambertian emitter)
    emitter: np.ndarray | None = None
    # one sample of a point or spot light of a radius: its offset (radius * (a, b)) on the disk facing each point
    # (lightsamples.facing_basis of the direction toward the light's centre)
    disk: tuple[float, float] | None = None
    t_max: ClassVar[float] = 1.0
    ends_at_point: ClassVar[bool] = True

    def toward(self, P: np.ndarray) -> np.ndarray:
        return self.vector - P

    def vector_at(self, P: np.ndarray, N: np.ndarray, shared: dict[int, tuple]) -> np.ndarray:
        """toward(P), or for a sample on the disk of the light's radius its point on the disk that faces each point
        (the disk's axes shared by the light's samples)."""
        L = self.vector - P
        if self.disk is None:
            return L
        if self.source not in shared:
            shared[self.source] = facing_basis(L)
        e1, e2 = shared[self.source]
        return L + (self.disk[0] * e1 + self.disk[1] * e2).astype(L.dtype, copy=False)

    def attenuation(self, L: np.ndarray, length_l: np.ndarray) -> np.ndarray | None:
        """1 / |L|^2 for inverse_square falloff, times a spot light's spot_attenuation() or an area sample's
        emitter cosine (the same operations as the reference's)."""
        factor = None
        if self.spot is not None:
            cosine = -dot(L, self.axis) / length_l  # the angle at the light between its axis and the point
            if self.cone is not None:  # the direction in the cone's unstretched frame (Cycles 4's scaled ray)
                x, a, y, b = self.cone
                u, v = -dot(L, x) / (length_l * a), -dot(L, y) / (length_l * b)
                cosine = cosine / np.sqrt(u * u + v * v + cosine * cosine)
            factor = spot_attenuation(cosine, self.spot)
        if self.emitter is not None:  # an area light's sample: a one-sided cosine emitter
            factor = np.maximum(-dot(L, self.emitter) / length_l, 0.0)
        if self.inverse_square:
            falloff = 1.0 / dot(L, L)
            factor = falloff if factor is None else factor * falloff
        return factor

    @property
    def attenuated(self) -> bool:
        return self.spot is not None or self.emitter is not None

    @property
    def view(self) -> View | None:
        """Shadow rays that end at the light (their vectors point toward it); nothing for a sample on a disk that
        faces each point (its rays end at different points: the meshes' hierarchies are walked)."""
        if self.disk is not None:
            return None
        return View("point", tuple(self.vector.ravel().astype(np.float64).tolist()), True, self.patterns)

    def make_grid(self, kernels: list[int], lower: np.ndarray, upper: np.ndarray) -> CoverageGrid | None:
        if self.disk is not None:
            return None  # its rays end on a disk that faces each point: no grid from one point
        return CoverageGrid.from_point(self.vector.ravel().astype(np.float64), kernels, lower, upper)

    def covering(self, origin: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        return self.grid.select(vector, True)

    def grid_shares(self, P: np.ndarray) -> np.ndarray:
        return self.grid.shares(self.vector - P, reverse=True)


@dataclass
class DirectionalSample(DirectedLight):
    """A sun, or one of the directions over a sun's disk of an angle."""

    def toward(self, P: np.ndarray) -> np.ndarray:
        return self.vector  # one column for every point: it broadcasts

    @property
    def view(self) -> View | None:
        return View("direction", tuple(self.vector.ravel().astype(np.float64).tolist()), share=self.patterns)

    def make_grid(self, kernels: list[int], lower: np.ndarray, upper: np.ndarray) -> CoverageGrid | None:
        return CoverageGrid.from_direction(self.vector.ravel().astype(np.float64), kernels, lower, upper)

    def covering(self, origin: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        return self.grid.select(origin)

    def grid_shares(self, P: np.ndarray) -> np.ndarray:
        return self.grid.shares(P)


class LightTerm(NamedTuple):
    """One light's share of listing 3.2 at n points, before its shadow rays: the vector L (3, n) toward it (a shared
    column for a direction), N.L and |L| (n,), where its diffuse term (N.L > 0) and its highlight (the gates) may
    count (n,) bool, the highlight's cosine (n,), the points (k,) that need a shadow ray, its attenuation (n,;
    None: 1) and its colour there."""

    L: np.ndarray
    NL: np.ndarray
    length_l: np.ndarray
    diffuse_gate: np.ndarray
    gate: np.ndarray
    cosine: np.ndarray
    needed: np.ndarray
    factor: np.ndarray | None
    color: np.ndarray  # (3, 1) the light's colour, or (3, n) the world's radiance along L at each point


@dataclass
class WorldSample(DirectedLight):
    """One of the world light's directions over each point's hemisphere (lightsamples.hemisphere_directions):
    local (x, y, z) in the frame of the point's normal, z along it. Its intensity is 2 / samples of the light's (the
    uniform hemisphere's estimate of the cosine-weighted mean); its colour there is the background's radiance along
    it; no highlight."""

    local: tuple[float, float, float] = (0.0, 0.0, 1.0)
    world: bool = True  # the background's radiance along it times its colour; False: its colour alone
    highlight: ClassVar[bool] = False

    def toward(self, P: np.ndarray) -> np.ndarray:
        raise ValueError("a world sample's direction depends on each point's normal: vector_at()")

    def basis(self, N: np.ndarray, turn: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frame (e1, e2, n) (3, n each, float64) of the points of normals N that the light's directions are
        in: n = N / |N|, and facing_basis(n) turned about n by each point's turn (2, n): cos and sin
        (camera.world_turns; the reference's operations); None: not turned."""
        n = np.asarray(N, dtype=np.float64)
        n = n / np.sqrt(x_y_z_squared(n))
        e1, e2 = facing_basis(n)
        if turn is None:
            return e1, e2, n
        cos, sin = turn
        return cos * e1 + sin * e2, cos * e2 - sin * e1, n

    def vector_at(self, P: np.ndarray, N: np.ndarray, shared: dict[int, tuple]) -> np.ndarray:
        """The unit direction (3, n) at each point of the normals N: x e1 + y e2 + z n in the frame basis() made,
        shared[source] (the caller's: it knows each point's pixel)."""
        e1, e2, n = shared[self.source]
        x, y, z = self.local
        return (x * e1 + y * e2 + z * n).astype(P.dtype, copy=False)

    @property
    def view(self) -> View | None:
        return None  # each point's own directions: the meshes' hierarchies are walked

    def make_grid(self, kernels: list[int], lower: np.ndarray, upper: np.ndarray) -> CoverageGrid | None:
        return None


def prepare_lights(scene: sc.Scene, dtype: np.dtype) -> list[PreparedLight]:
    """The scene's lights in its order, each light of a size as its samples (lightsamples.py: render.shadow_samples
    times its patterns), each sample with 1 / samples of the intensity."""
    samples = scene.render.shadow_samples
    lights: list[PreparedLight] = []
    for source, light in enumerate(scene.lights):
        color = column(light.color, dtype)
        if isinstance(light, sc.AmbientLight):
            made: list[PreparedLight] = [AmbientLight(light.intensity, color)]
        elif isinstance(light, sc.PointLight | sc.SpotLight):
            made = _point_samples(light, color, samples, dtype)
        elif isinstance(light, sc.AreaLight):
            made = _area_samples(light, color, samples, dtype)
        elif isinstance(light, sc.WorldLight):
            directions = lightsamples.hemisphere_directions(light.samples)
            share, weight = 2.0 * light.intensity / len(directions), 1.0 / len(directions)
            world = light.radiance == "background"
            made = [WorldSample(share, color, weight=weight, local=local, world=world) for local in directions]
        else:  # a sun of an angle: its samples' directions (one: the direction itself)
            directions = lightsamples.sun_directions(light, samples)
            share = light.intensity / len(directions) if len(directions) > 1 else light.intensity
            weight = 1.0 / len(directions)
            made = [DirectionalSample(share, color, weight=weight, vector=column(d, dtype)) for d in directions]
        patterns = 1 if isinstance(light, sc.WorldLight) or len(made) == 1 else lightsamples.patterns(samples)
        for index, sample in enumerate(made):
            sample.source, sample.index, sample.count, sample.patterns = source, index, len(made), patterns
            if patterns > 1:  # entries j patterns + r: the place j's vectors in each pattern r, shared
                if index % patterns == 0:
                    places = np.concatenate([one.vector for one in made[index : index + patterns]], axis=1)
                sample.places = places
            sample.adds_diffuse = getattr(light, "visible_diffuse", True)
            sample.adds_glossy = getattr(light, "visible_glossy", True)
            sample.adds_transmission = getattr(light, "visible_transmission", True)
        lights.extend(made)
    return lights


def _point_samples(
    light: sc.PointLight | sc.SpotLight, color: np.ndarray, samples: int, dtype: np.dtype
) -> list[PreparedLight]:
    """A point or spot light: itself, or with a radius its samples over the disk that faces each point."""
    offsets = lightsamples.disk_offsets(samples) if light.radius > 0.0 else [None]
    share = light.intensity / len(offsets) if len(offsets) > 1 else light.intensity
    made: list[PreparedLight] = []
    for offset in offsets:
        sample = PointSample(share, color, vector=column(light.location, dtype))
        sample.inverse_square = light.falloff == "inverse_square"
        if isinstance(light, sc.SpotLight):
            sample.spot, sample.axis = light, column(tf.normalize(light.direction), dtype)
            if light.cone_scale != (1.0, 1.0):
                x, y = lightsamples.cone_axes(light)
                sample.cone = (column(x, dtype), light.cone_scale[0], column(y, dtype), light.cone_scale[1])
        if len(offsets) > 1:
            sample.disk, sample.weight = (light.radius * offset[0], light.radius * offset[1]), 1.0 / len(offsets)
        made.append(sample)
    return made


def _area_samples(light: sc.AreaLight, color: np.ndarray, samples: int, dtype: np.dtype) -> list[PreparedLight]:
    """An area light as point lights at its sample points (lightsamples.area_points), each with 1 / samples of its
    intensity, shining as a one-sided cosine emitter with inverse-square falloff."""
    points = lightsamples.area_points(light, samples)
    normal = column(lightsamples.area_frame(light)[0], dtype)
    share = light.intensity / len(points) if len(points) > 1 else light.intensity
    return [
        PointSample(
            share, color, weight=1.0 / len(points), vector=column(point, dtype), inverse_square=True, emitter=normal
        )
        for point in points
    ]


def directed(lights: list[PreparedLight]) -> list[DirectedLight]:
    """The lights that cast shadows (all but the ambient ones), in order."""
    return [light for light in lights if not light.ambient]


def spot_attenuation(cosine: np.ndarray, spot: sc.SpotLight) -> np.ndarray:
    """Cycles' spot light attenuation (n,) for the cosines (n,) of the angle at the light between its axis and the
    points; the same operations as reference.spot_attenuation. cycles4 (Blender 4.x, 5.0: kernel/light/spot.h):
    smoothstep((c - cos_half) / ((1 - cos_half) * blend)); cycles3 (Blender 3.4): 0 inside cos_half, else c times
    smoothstep((c - cos_half) / ((1 - cos_half) * blend)) while that is below 1, and c beyond. Blend 0: a hard edge."""
    cos_half = math.cos(math.radians(spot.spot_size) / 2.0)
    width = (1.0 - cos_half) * spot.spot_blend
    inside = cosine > cos_half
    if width == 0.0:
        step = np.where(inside, 1.0, 0.0)
    else:
        f = np.clip((cosine - cos_half) / width, 0.0, 1.0)
        ff = f * f
        step = 3.0 * ff - 2.0 * ff * f
    attenuation = np.where(inside, cosine * step if spot.spot_model == "cycles3" else step, 0.0)
    return attenuation.astype(cosine.dtype, copy=False)


def facing_basis(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """lightsamples.facing_basis of each column's direction (3, n) -> its two axes (3, n) each, float64 (the same
    operations)."""
    L = np.asarray(L, dtype=np.float64)
    x, y, z = L / np.sqrt(x_y_z_squared(L))
    sign = np.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    return np.stack((1.0 + sign * x * x * a, sign * b, -sign * x)), np.stack((b, sign + y * y * a, -y))


def x_y_z_squared(L: np.ndarray) -> np.ndarray:
    return L[0] * L[0] + L[1] * L[1] + L[2] * L[2]
