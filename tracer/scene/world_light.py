"""An image background -> the two small pictures a world light under it is lit by: its radiance blurred to the
spacing of the light's directions, and its irradiance by normal (the cosine-weighted mean radiance about each
direction), both equirectangular and looked up as the background is.

Sixteen directions over a hemisphere sample a sharp picture badly: a forest picture's bright gaps made the open
ground's estimate 1.7 times its cosine-weighted mean with the same directions at every point, and noise of 150% of it
with the directions turned pixel by pixel. A point's world light is therefore its irradiance, exact in the open,
times the share of it that its open directions carry, each direction weighted by the blurred radiance along it
(tracing/lights.py): the ground in the open is lit exactly and smoothly, and what an object hides is still weighted
toward the bright side of the sky. Plain NumPy reductions, no BLAS: the same bits in every process.
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from dataclasses import replace

import numpy as np

from . import scene as sc

ROWS, COLUMNS = 32, 64  # the pictures' texels: 5.6 degrees each, finer than either changes
BLUR_DEGREES = 30.0  # the blur's radius: about the angle between the 16 directions' neighbours
CHUNK = 256  # output texels per pass (their weights over every texel: 256 x 2,048)
KEPT = 2  # backgrounds whose pictures a process keeps (a view's edits, a worker's frames: 90 ms each for 1024 x 512)
_KEPT: OrderedDict[sc.Background, tuple[sc.Background, sc.Background]] = OrderedDict()


def backgrounds(scene: sc.Scene) -> tuple[sc.Background, sc.Background] | None:
    """The scene's pictures as image backgrounds (blurred radiance, irradiance), with the background's rotation and
    strength, looked up linearly; None unless the background is an image and a world light takes its radiance."""
    background = scene.background
    lit = any(isinstance(light, sc.WorldLight) and light.radiance == "background" for light in scene.lights)
    if background.type != "image" or not lit:
        return None
    if background not in _KEPT:
        made = pictures(background.image)
        _KEPT[background] = tuple(replace(background, image=picture, interpolation="linear") for picture in made)
        while len(_KEPT) > KEPT:
            _KEPT.popitem(last=False)
    _KEPT.move_to_end(background)
    return _KEPT[background]


def pictures(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An equirectangular picture (H, W, 3) (row 0 the zenith) -> (blurred radiance, irradiance), (ROWS, COLUMNS,
    3) float32 each, same layout. Each is a normalized weighted mean over the picture's texels binned to ROWS x
    COLUMNS by solid angle: the blur with weights max(0, cos a - cos BLUR_DEGREES), the irradiance with max(0, cos a)
    (a the angle between the texel's direction and the output's): a uniform picture gives itself in both."""
    binned, solid = _binned(image)
    directions = _directions(ROWS, COLUMNS).reshape(-1, 3)
    values = binned.reshape(-1, 3)
    blur_floor = math.cos(math.radians(BLUR_DEGREES))
    blurred = np.empty_like(values)
    irradiance = np.empty_like(values)
    for first in range(0, directions.shape[0], CHUNK):
        cosine = _cosines(directions, first)
        for out, floor in ((blurred, blur_floor), (irradiance, 0.0)):
            weight = np.maximum(cosine - floor, 0.0) * solid[None, :]
            total = weight.sum(axis=1)
            for channel in range(3):
                out[first : first + CHUNK, channel] = (weight * values[None, :, channel]).sum(axis=1) / total
    shape = (ROWS, COLUMNS, 3)
    return blurred.reshape(shape).astype(np.float32), irradiance.reshape(shape).astype(np.float32)


def _cosines(directions: np.ndarray, first: int) -> np.ndarray:
    """cos of the angles (k, T) between CHUNK output directions from first and every texel's (T, 3): the dot
    products summed axis by axis (no BLAS: the same bits whatever the machine's threads)."""
    part = directions[first : first + CHUNK]
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
