"""An image background -> what a world light under it is lit by: the irradiance by normal (the cosine-weighted mean
radiance about each direction), a small equirectangular picture looked up as the background is, and a smooth,
positive weight over directions (that irradiance to second order in spherical harmonics: a quadratic in the
direction) by which a point's directions share its irradiance out.

Sixteen directions over a hemisphere sample a sharp picture badly: a forest picture's bright gaps made the open
ground's estimate 1.77 times Cycles' with the same directions at every point, and noise of 150% of it with the
directions turned pixel by pixel. A point's world light is therefore its irradiance, exact in the open, times the
share of the weight its open directions carry (tracing/shading.py): the ground in the open is lit exactly and
without noise, and what an object hides is still weighted toward the bright side of the sky. Because the weight is
a quadratic, its sum over a point's directions is a few products with the directions' moments, not a lookup per
direction. Plain NumPy sums, no BLAS: the same bits in every process.
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np

from . import scene as sc

T = TypeVar("T")

ROWS, COLUMNS = 32, 64  # the irradiance picture's texels: 5.6 degrees each, finer than an irradiance changes
CHUNK = 256  # output texels per pass (their weights over every texel: 256 x 2,048)
KEPT = 2  # backgrounds whose lighting a process keeps (a view's edits, a worker's frames: 60 ms each for 1024 x 512)
WEIGHT_FLOOR = 0.02  # the weight's least value, of its mean: second order rings below 0 around a sun
# the real spherical harmonics of orders 0-2 as polynomials of the unit direction (x, y, z)
SH = (0.282095, 0.488603, 1.092548, 0.315392, 0.546274)


@dataclass(frozen=True, eq=False)
class WorldLighting:
    """irradiance: the picture of the cosine-weighted mean radiance by normal (ROWS, COLUMNS), as an image
    background with the background's rotation and strength; the weight of a direction d (world frame, rotation and
    strength in): constant (3,) + linear (3 channels, 3) . d + d^T quadratic (3 channels, 3, 3) d, per channel."""

    irradiance: sc.Background
    constant: np.ndarray
    linear: np.ndarray
    quadratic: np.ndarray

    def weight(self, d: sc.Vec3) -> sc.Color:
        """The weight of the unit direction d, per channel, in Python floats (the reference's; shading.py sums the
        same polynomial by moments)."""
        out = []
        for k in range(3):
            a, b = self.quadratic[k].tolist(), self.linear[k].tolist()
            value = float(self.constant[k])
            value += b[0] * d[0] + b[1] * d[1] + b[2] * d[2]
            value += sum(d[p] * (a[p][0] * d[0] + a[p][1] * d[1] + a[p][2] * d[2]) for p in range(3))
            out.append(value)
        return (out[0], out[1], out[2])


_KEPT: OrderedDict[object, tuple[sc.Background, WorldLighting]] = OrderedDict()


def lighting(scene: sc.Scene) -> WorldLighting | None:
    """The scene's WorldLighting; None unless the background is an image and a world light takes its radiance."""
    background = scene.background
    lit = any(isinstance(light, sc.WorldLight) and light.radiance == "background" for light in scene.lights)
    if background.type != "image" or not lit:
        return None
    return kept(_KEPT, background, _made)


def kept(cache: OrderedDict, background: sc.Background, make: Callable[[sc.Background], T]) -> T:
    """make(background), kept in cache under background_key for the last KEPT backgrounds (the background kept too:
    its image's id stays its own)."""
    key = background_key(background)
    if key not in cache:
        cache[key] = (background, make(background))
        while len(cache) > KEPT:
            cache.popitem(last=False)
    cache.move_to_end(key)
    return cache[key][1]


def background_key(background: sc.Background) -> object:
    """What finds a background's lighting again: a read-only picture that owns its memory (the loader's, given again
    on each edit of a view) by its identity, with what else the lighting depends on; else the background itself,
    by its picture's bits (a digest of an 8k picture's 400 MB costs about 0.5 s)."""
    if sc.immutable(background.image):
        return (id(background.image), background.rotation, background.strength)
    return background


def _made(background: sc.Background) -> WorldLighting:
    picture, solid = irradiance(background.image)
    constant, linear, quadratic = _second_order(picture, solid)
    # the lookups turn a direction d to Rz(rotation) d: the polynomial in the world's frame is Rz^T A Rz, Rz^T b
    angle = math.radians(background.rotation)
    turn = np.array([[math.cos(angle), -math.sin(angle), 0.0], [math.sin(angle), math.cos(angle), 0.0], [0, 0, 1.0]])
    linear = np.stack([_product(turn.T, b[:, None])[:, 0] for b in linear])
    quadratic = np.stack([_product(_product(turn.T, a), turn) for a in quadratic])
    strength = background.strength
    return WorldLighting(
        replace(background, image=picture, interpolation="linear"),
        constant * strength,
        linear * strength,
        quadratic * strength,
    )


def irradiance(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An equirectangular picture (H, W, 3) (row 0 the zenith) -> its irradiance picture (ROWS, COLUMNS, 3) float32,
    same layout, and the solid angle of each texel (ROWS * COLUMNS,): at each texel's direction the mean of the
    picture's texels binned to ROWS x COLUMNS weighted by max(0, cos a) and their solid angle (a the angle between
    the two directions): a uniform picture gives itself. The first and last rows hold the zenith's and the nadir's,
    which a lookup there reads (a lookup clamps at the rows' centres, 2.8 degrees off the poles: a floor under
    forest.exr read 3% above its irradiance)."""
    binned, solid = _binned(image)
    texels = _directions(ROWS, COLUMNS)
    toward = texels.copy()  # where each output is the irradiance: its texel's centre, but the poles on the end rows
    toward[0], toward[-1] = (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)
    directions, toward = texels.reshape(-1, 3), toward.reshape(-1, 3)
    values = binned.reshape(-1, 3)
    out = np.empty_like(values)
    for first in range(0, directions.shape[0], CHUNK):
        weight = np.maximum(_cosines(toward, directions, first), 0.0) * solid[None, :]
        total = weight.sum(axis=1)
        for channel in range(3):
            out[first : first + CHUNK, channel] = (weight * values[None, :, channel]).sum(axis=1) / total
    return out.reshape(ROWS, COLUMNS, 3).astype(np.float32), solid


def _second_order(picture: np.ndarray, solid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The irradiance picture (ROWS, COLUMNS, 3) projected on the spherical harmonics of orders 0-2 (each texel
    its solid angle), as the polynomial c + b . d + d^T A d per channel -> c (3,), b (3, 3), A (3, 3, 3), raised
    where needed so that it is at least WEIGHT_FLOOR of its mean over the sphere."""
    x, y, z = (_directions(ROWS, COLUMNS).reshape(-1, 3)[:, axis] for axis in range(3))
    y00, y1, y2, y20, y22 = SH
    basis = (y00 + 0 * x, y1 * y, y1 * z, y1 * x, y2 * x * y, y2 * y * z, y20 * (3 * z * z - 1), y2 * x * z)
    basis = (*basis, y22 * (x * x - y * y))
    values = picture.reshape(-1, 3).astype(np.float64)
    coefficients = np.array([[(f * values[:, k] * solid).sum() for f in basis] for k in range(3)])  # (3, 9)
    constant = np.empty(3)
    linear = np.empty((3, 3))
    quadratic = np.empty((3, 3, 3))
    for k, (l00, l1y, l1z, l1x, lxy, lyz, l20, lxz, l22) in enumerate(coefficients):
        constant[k] = y00 * l00 - y20 * l20
        linear[k] = (y1 * l1x, y1 * l1y, y1 * l1z)
        quadratic[k] = [
            [y22 * l22, y2 * lxy / 2, y2 * lxz / 2],
            [y2 * lxy / 2, -y22 * l22, y2 * lyz / 2],
            [y2 * lxz / 2, y2 * lyz / 2, 3 * y20 * l20],
        ]
        grid = np.stack((x, y, z))
        weights = constant[k] + (linear[k][:, None] * grid).sum(axis=0)
        weights = weights + (grid * _product(quadratic[k], grid)).sum(axis=0)
        floor = WEIGHT_FLOOR * max(float((weights * solid).sum() / solid.sum()), 0.0)
        constant[k] += max(0.0, floor - float(weights.min()))
    return constant, linear, quadratic


def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a (3, 3) times b (3, m), row by row as sums of products (no BLAS)."""
    return a[:, 0, None] * b[0] + a[:, 1, None] * b[1] + a[:, 2, None] * b[2]


def _cosines(toward: np.ndarray, directions: np.ndarray, first: int) -> np.ndarray:
    """cos of the angles (k, T) between CHUNK of the directions toward (from first) and every texel's (T, 3): the
    dot products summed axis by axis (no BLAS: the same bits whatever the machine's threads)."""
    part = toward[first : first + CHUNK]
    return (
        part[:, None, 0] * directions[None, :, 0]
        + part[:, None, 1] * directions[None, :, 1]
        + (part[:, None, 2] * directions[None, :, 2])
    )


def _binned(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The picture's mean radiance (ROWS, COLUMNS, 3) float64 over each bin of rows and columns, each texel weighted
    by its solid angle (the cosine of its latitude), and each bin's solid angle (ROWS * COLUMNS,). A bin of rows at
    a time in float64 (an 8k picture's whole would be 800 MB); a picture of fewer texels than the bins has each
    texel repeated first (as its closest lookup would show it)."""
    if image.shape[0] < ROWS:
        image = np.repeat(image, -(-ROWS // image.shape[0]), axis=0)
    if image.shape[1] < COLUMNS:
        image = np.repeat(image, -(-COLUMNS // image.shape[1]), axis=1)
    height, width = image.shape[:2]
    weight = np.cos(math.pi * (0.5 - (np.arange(height) + 0.5) / height))  # row 0 at the top: the zenith
    row_edges = np.linspace(0, height, ROWS + 1).round().astype(np.int64)
    column_edges = np.linspace(0, width, COLUMNS + 1).round().astype(np.int64)
    columns = np.diff(column_edges).astype(np.float64)
    binned = np.empty((ROWS, COLUMNS, 3))
    for row, (first, last) in enumerate(itertools.pairwise(row_edges.tolist())):
        rows = np.asarray(image[first:last], dtype=np.float64) * weight[first:last, None, None]
        sums = np.add.reduceat(rows.sum(axis=0), column_edges[:-1], axis=0)
        binned[row] = sums / (weight[first:last].sum() * columns)[:, None]
    top = math.pi * (0.5 - row_edges[:-1] / height)
    bottom = math.pi * (0.5 - row_edges[1:] / height)
    solid = (np.sin(top) - np.sin(bottom))[:, None] * (2.0 * math.pi * columns / width)[None, :]
    return binned, solid.reshape(-1)


def _directions(rows: int, columns: int) -> np.ndarray:
    """The unit directions (rows, columns, 3) of an equirectangular grid's texel centres, as Blender looks a
    picture up (lightsamples.equirectangular): u = 0.5 - atan2(y, x) / 2 pi, v = 0.5 + elevation / pi, row 0 at
    v = 1."""
    u = (np.arange(columns) + 0.5) / columns
    v = 1.0 - (np.arange(rows) + 0.5) / rows
    azimuth = (0.5 - u) * 2.0 * math.pi
    elevation = (v - 0.5) * math.pi
    cos_elevation = np.cos(elevation)[:, None]
    return np.stack(
        (
            cos_elevation * np.cos(azimuth)[None, :],
            cos_elevation * np.sin(azimuth)[None, :],
            np.broadcast_to(np.sin(elevation)[:, None], (rows, columns)),
        ),
        axis=-1,
    )
