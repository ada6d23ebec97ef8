"""Lights that mirror rays see (a light's seen_in_mirrors, Blender's Glossy ray visibility of a light) -> where a
wavefront's mirror and refracted rays meet an area light before any surface: its radiance times the rays' weights
added into their samples, and those rays ended; where they meet nothing and point into a sun's disc (a directional
light with an angle): its radiance, added to the background they see. Camera rays, glossy lobes', rough glass's and
diffuse bounces' rays do not see lights: their lights are counted where they start (the light terms through the lobe
or the glass, the shadow rays), and Cycles' camera does not show a light either."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import lightsamples
from ..geometry.kernels import column, indices, take
from ..scene import scene as sc


@dataclass(frozen=True)
class SeenLight:
    """An area light as mirror rays meet it: its centre, unit normal (the way it shines) and in-plane axes (3, 1),
    half sizes, whether round (disk, ellipse), and its radiance (3, 1): pi intensity / area times its colour (the
    tracer's intensity is the irradiance / pi that the diffuse term reads, so the emitter's own radiance is pi
    times it over its area)."""

    location: np.ndarray
    normal: np.ndarray
    x_axis: np.ndarray
    y_axis: np.ndarray
    half: tuple[float, float]
    round: bool
    radiance: np.ndarray
    source: int = -1  # its index in the scene's lights (the ray stores' segments name it, for edits)


def prepare(scene: sc.Scene, dtype: np.dtype) -> list[SeenLight]:
    """The scene's area lights that mirror rays see."""
    seen = []
    for source, light in enumerate(scene.lights):
        if not (isinstance(light, sc.AreaLight) and light.seen_in_mirrors):
            continue
        normal, x_axis, y_axis = lightsamples.area_frame(light)
        round_shape = light.shape in ("disk", "ellipse")
        area = light.size[0] * light.size[1] * (math.pi / 4.0 if round_shape else 1.0)
        radiance = [math.pi * light.intensity / area * c for c in light.color]
        seen.append(
            SeenLight(
                column(light.location, np.float64),
                column(normal, np.float64),
                column(x_axis, np.float64),
                column(y_axis, np.float64),
                (light.size[0] / 2.0, light.size[1] / 2.0),
                round_shape,
                column(radiance, dtype),
                source,
            )
        )
    return seen


def meet(
    lights: list[SeenLight], origin: np.ndarray, direction: np.ndarray, t: np.ndarray, t_min: float, rays: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which of the rays rows (k,) (origins (3, n) or (3, 1), directions (3, n), nearest surface t (n,), inf for
    none) meet a light's front before their surface, with t > t_min -> those rows (j,), the radiance each brings
    (3, j) (the nearest light's, where several lie on a ray), that light's index in the scene's lights (j,) and
    where the ray meets it (j,)."""
    if not rays.size:
        return rays, np.zeros((3, 0)), np.zeros(0, dtype=np.int64), np.zeros(0)
    O = np.asarray(take(origin, rays) if origin.shape[1] > 1 else origin, dtype=np.float64)
    D = np.asarray(take(direction, rays), dtype=np.float64)
    nearest = np.asarray(t.take(rays), dtype=np.float64).copy()
    found = np.full(rays.size, -1)
    for index, light in enumerate(lights):
        facing = (D * light.normal).sum(axis=0)  # the front faces the rays: they travel against the normal
        with np.errstate(divide="ignore", invalid="ignore"):
            along = ((light.location - O) * light.normal).sum(axis=0) / facing
        Q = O + D * np.where(np.isfinite(along), along, 0.0)
        x = ((Q - light.location) * light.x_axis).sum(axis=0) / light.half[0]
        y = ((Q - light.location) * light.y_axis).sum(axis=0) / light.half[1]
        inside = x * x + y * y <= 1.0 if light.round else (np.abs(x) <= 1.0) & (np.abs(y) <= 1.0)
        hit = (facing < 0.0) & (along > t_min) & (along < nearest) & inside
        nearest = np.where(hit, along, nearest)
        found = np.where(hit, index, found)
    met = indices(found >= 0)
    if not met.size:
        return rays.take(met), np.zeros((3, 0)), np.zeros(0, dtype=np.int64), np.zeros(0)
    which = found.take(met)
    radiance = np.concatenate([light.radiance for light in lights], axis=1).take(which, axis=1)
    sources = np.asarray([light.source for light in lights], dtype=np.int64).take(which)
    return rays.take(met), radiance, sources, nearest.take(met)


@dataclass(frozen=True)
class SeenSun:
    """A sun (a directional light with an angle) as mirror rays see it: the unit direction toward it (3, 1), the
    cosine of its angular radius h (half its angle), and its radiance (3, 1) at the disc's centre: intensity /
    sin^2 h times its colour (cycles4), or intensity / tan^2 h (cycles3, which divides it by cos^3 of the angle from
    the centre). The tracer's intensity is Blender's strength S / pi, and Cycles 4.0+ spreads S over the disc's
    solid angle's projection pi sin^2 h (scene/light.cpp, Light::area); Cycles 3.x took the disc as one of radius
    tan h a unit away (kernel/light/light.h, light_sample_from_distant_ray: invarea / cos^3 theta)."""

    direction: np.ndarray
    cos_radius: float
    radiance: np.ndarray
    cycles3: bool


def prepare_suns(scene: sc.Scene) -> list[SeenSun]:
    """The scene's suns that mirror rays see: those with seen_in_mirrors and an angle (Cycles shows no disc of a
    sun of angle 0)."""
    seen = []
    for light in scene.lights:
        if not (isinstance(light, sc.DirectionalLight) and light.seen_in_mirrors and light.angle > 0.0):
            continue
        radius = math.radians(light.angle) / 2.0
        cycles3 = light.disc_model == "cycles3"
        spread = math.tan(radius) ** 2 if cycles3 else math.sin(radius) ** 2
        length = math.sqrt(sum(c * c for c in light.direction))
        seen.append(
            SeenSun(
                column([c / length for c in light.direction], np.float64),
                math.cos(radius),
                column([light.intensity / spread * c for c in light.color], np.float64),
                cycles3,
            )
        )
    return seen


def see_suns(suns: list[SeenSun], direction: np.ndarray, rays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which of the rays rows (k,) (directions (3, n), all of them rays that meet nothing) point into a sun's disc
    (the angle to its centre at most its angular radius, as Cycles' distant_light_intersect) -> those rows (j,) and
    the radiance they see (3, j) float64: every disc they point into, added (Cycles adds each sun's)."""
    if not rays.size or not suns:
        return rays[:0], np.zeros((3, 0))
    D = np.asarray(take(direction, rays), dtype=np.float64)
    length = np.sqrt((D * D).sum(axis=0))
    total = np.zeros((3, rays.size))
    any_inside = np.zeros(rays.size, dtype=bool)
    for sun in suns:
        cosine = (D * sun.direction).sum(axis=0) / length
        inside = cosine >= sun.cos_radius
        any_inside |= inside
        if sun.cycles3:
            total += np.where(inside, sun.radiance / np.where(inside, cosine, 1.0) ** 3, 0.0)
        else:
            total += np.where(inside, sun.radiance, 0.0)
    seen = indices(any_inside)
    return rays.take(seen), total.take(seen, axis=1)
