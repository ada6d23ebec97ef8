"""Area lights that mirror rays see (an area light's seen_in_mirrors, Blender's Glossy ray visibility of a light) ->
where a wavefront's mirror and refracted rays meet one before any surface: its radiance times the rays' weights added
into their samples, and those rays ended. Camera rays, glossy lobes' and diffuse bounces' rays do not see lights:
their lights are counted where they start (the light terms through the lobe, the shadow rays)."""

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


def prepare(scene: sc.Scene, dtype: np.dtype) -> list[SeenLight]:
    """The scene's area lights that mirror rays see."""
    seen = []
    for light in scene.lights:
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
            )
        )
    return seen


def meet(
    lights: list[SeenLight], origin: np.ndarray, direction: np.ndarray, t: np.ndarray, t_min: float, rays: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Which of the rays rows (k,) (origins (3, n) or (3, 1), directions (3, n), nearest surface t (n,), inf for
    none) meet a light's front before their surface, with t > t_min -> those rows (j,) and the radiance each
    brings (3, j) (the nearest light's, where several lie on a ray)."""
    if not rays.size:
        return rays, np.zeros((3, 0))
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
        return rays.take(met), np.zeros((3, 0))
    radiance = np.concatenate([light.radiance for light in lights], axis=1).take(found.take(met), axis=1)
    return rays.take(met), radiance
