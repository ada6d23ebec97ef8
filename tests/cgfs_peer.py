"""The raytracer of Gambetta's "Computer Graphics from Scratch" (CGFS), per pixel, with each of its conventions that
differ from the documented tracer switchable to the documented one: for docs/algorithm.md's comparison figure and
for the test that, with every switch set, it gives the documented tracer's image.

Written from the book's chapters 2-5 (TraceRay, ClosestIntersection, ComputeLighting, ReflectRay), in its own
coordinates: camera at the origin looking along +z with +y up, a 1 x 1 viewport at distance 1. Colours are 0-255
floats, clamped only when the image is made.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracer.scene import scene as sc


@dataclass(frozen=True)
class Conventions:
    """Each True takes the documented tracer's way instead of the book's."""

    weighted_last_bounce: bool = False  # local colour times (1 - r) even when no reflection follows
    reflection_epsilon: bool = False  # mirror rays from t > 0.01 (book: 0.001)
    unit_camera_rays: bool = False  # camera rays of unit length from t > 0 (book: D = V - O, t >= 1)
    pixel_centres: bool = False  # through pixel centres (book: the pixel's corner)


BOOK = Conventions()
DOCUMENTED = Conventions(True, True, True, True)

# the book's demo scene (chapter 4, reflections): (centre, radius, colour, specular (-1: none), reflective)
SPHERES = (
    ((0.0, -1.0, 3.0), 1.0, (255.0, 0.0, 0.0), 500.0, 0.2),
    ((2.0, 0.0, 4.0), 1.0, (0.0, 0.0, 255.0), 500.0, 0.3),
    ((-2.0, 0.0, 4.0), 1.0, (0.0, 255.0, 0.0), 10.0, 0.4),
    ((0.0, -5001.0, 0.0), 5000.0, (255.0, 255.0, 0.0), 1000.0, 0.5),
)
AMBIENT, POINT, DIRECTIONAL = 0.2, ((2.0, 1.0, 0.0), 0.6), ((1.0, 4.0, 4.0), 0.2)
DEPTH = 3


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _along(O, D, t):
    return (O[0] + D[0] * t, O[1] + D[1] * t, O[2] + D[2] * t)


def _scale(v, k):
    return (v[0] * k, v[1] * k, v[2] * k)


def _length(v) -> float:
    return math.sqrt(_dot(v, v))


def _reflect(X, N):
    """The book's ReflectRay: 2 N (N . X) - X."""
    k = 2.0 * _dot(N, X)
    return (N[0] * k - X[0], N[1] * k - X[1], N[2] * k - X[2])


def _closest(O, D, t_min, t_max):
    best_t, best = math.inf, None
    for sphere in SPHERES:
        centre, radius = sphere[0], sphere[1]
        CO = _sub(O, centre)
        a, b, c = _dot(D, D), 2.0 * _dot(CO, D), _dot(CO, CO) - radius * radius
        discriminant = b * b - 4.0 * a * c
        if discriminant < 0.0:
            continue
        root = math.sqrt(discriminant)
        for t in ((-b + root) / (2.0 * a), (-b - root) / (2.0 * a)):
            if t_min < t < t_max and t < best_t:
                best_t, best = t, sphere
    return best, best_t


def _lighting(P, N, V, specular) -> float:
    intensity = AMBIENT
    for (vector, light), kind in ((POINT, "point"), (DIRECTIONAL, "directional")):
        L = _sub(vector, P) if kind == "point" else vector
        t_max = 1.0 if kind == "point" else math.inf
        if _closest(P, L, 0.001, t_max)[0] is not None:
            continue
        NL = _dot(N, L)
        if NL > 0.0:
            intensity += light * NL / (_length(N) * _length(L))
        if specular != -1:
            R = _reflect(L, N)
            RV = _dot(R, V)
            if RV > 0.0:
                intensity += light * (RV / (_length(R) * _length(V))) ** specular
    return intensity


def _trace(O, D, t_min, t_max, depth, conventions: Conventions):
    sphere, t = _closest(O, D, t_min, t_max)
    if sphere is None:
        return (0.0, 0.0, 0.0)
    P = _along(O, D, t)
    N = _sub(P, sphere[0])
    N = _scale(N, 1.0 / _length(N))
    V = _scale(D, -1.0)
    local = _scale(sphere[2], _lighting(P, N, V, sphere[3]))
    r = sphere[4]
    if conventions.weighted_last_bounce:
        local = _scale(local, 1.0 - r)
    if depth <= 0 or r <= 0:
        return local
    reflected = _trace(
        P, _reflect(V, N), 0.01 if conventions.reflection_epsilon else 0.001, math.inf, depth - 1, conventions
    )
    if not conventions.weighted_last_bounce:
        local = _scale(local, 1.0 - r)
    return (local[0] + reflected[0] * r, local[1] + reflected[1] * r, local[2] + reflected[2] * r)


def render(size: int, conventions: Conventions) -> np.ndarray:
    """The demo scene on a size x size canvas -> (size, size, 3) colours in [0, 1], rows from the top."""
    image = np.zeros((size, size, 3))
    for row in range(size):
        for column in range(size):
            # the book's canvas point (x, y) for this pixel, y up: its corner, or its centre
            x, y = column - size / 2, size / 2 - row - 1
            if conventions.pixel_centres:
                x, y = x + 0.5, y + 0.5
            D = (x / size, y / size, 1.0)
            if conventions.unit_camera_rays:
                color = _trace((0.0, 0.0, 0.0), _scale(D, 1.0 / _length(D)), 0.0, math.inf, DEPTH, conventions)
            else:
                color = _trace((0.0, 0.0, 0.0), D, 1.0, math.inf, DEPTH, conventions)
            image[row, column] = color
    return np.clip(image / 255.0, 0.0, 1.0)


def as_scene(size: int) -> sc.Scene:
    """The demo scene for the documented tracer: the book's (x, y, z) is the tracer's (x, z, y) (forward becomes +Y,
    up +Z; an isometry, so the picture is the same), its 1 x 1 viewport at distance 1 a 36 mm sensor at 36 mm."""

    def swap(v):
        return (v[0], v[2], v[1])

    materials, objects = {}, []
    for index, (centre, radius, color, specular, reflective) in enumerate(SPHERES):
        name = f"sphere{index}"
        materials[name] = sc.Material(
            color=tuple(c / 255.0 for c in color), specular=max(specular, 0.0), reflective=reflective
        )
        objects.append(sc.Sphere(name=name, material=name, location=swap(centre), radius=radius))
    return sc.Scene(
        materials=materials,
        objects=tuple(objects),
        lights=(
            sc.AmbientLight(AMBIENT),
            sc.PointLight(location=swap(POINT[0]), intensity=POINT[1]),
            sc.DirectionalLight(direction=swap(DIRECTIONAL[0]), intensity=DIRECTIONAL[1]),
        ),
        camera=sc.Camera(location=(0.0, 0.0, 0.0), rotation=(90.0, 0.0, 0.0), lens=36.0, sensor_width=36.0),
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=size, height=size, depth=DEPTH, model="phong"),
    )
