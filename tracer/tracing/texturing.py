"""A texture and the UVs of hits -> the texture's linear colours there (Cycles' image lookup), vectorized and per ray.

Texel (i, j) of a W x H image covers u in [i / W, (i + 1) / W) and v in [j / H, (j + 1) / H), j counted from the
bottom (v = 0; the pixels' row H - 1 - j, as their row 0 is the top). As Cycles' `interp_closest` and
`interp_linear` (intern/cycles/kernel/device/cpu/image.h):

- closest: x = u W, i = floor(x) (the same in v), the texel (i, j);
- linear: x = u W - 0.5, i = floor(x), a = x - i (the same in v: j, b); the four texels (i, j), (i + 1, j),
  (i, j + 1), (i + 1, j + 1) weighted (1 - a)(1 - b), a (1 - b), (1 - a) b, a b, added in that order;
- repeat: i modulo W; extend: i clamped to 0..W - 1; clip: a texel outside the image is black (0).

A UV that is not finite is read as (0, 0). The vectorized sample() and the per-ray sample_one() do the same float64
operations in the same order, so the tracer and the per-pixel reference agree to the last bits but for the
rounding of the hit's UV itself.
"""

from __future__ import annotations

import math

import numpy as np

from ..scene import scene as sc


def sample(texture: sc.Texture, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The texture's colours (3, n) float64 at UVs u, v (n,)."""
    pixels = texture.pixels
    height, width = pixels.shape[0], pixels.shape[1]
    flat = pixels.reshape(-1, 3)
    u = np.where(np.isfinite(u), u, 0.0)
    v = np.where(np.isfinite(v), v, 0.0)
    if texture.interpolation == "closest":
        i, j = _cells(u * width), _cells(v * height)
        return _texels(texture, flat, width, height, i, j)
    x, y = u * width - 0.5, v * height - 0.5
    i, j = _cells(x), _cells(y)
    a, b = x - i, y - j
    i1, j1 = i + 1, j + 1
    total = _texels(texture, flat, width, height, i, j) * ((1.0 - b) * (1.0 - a))
    total = total + _texels(texture, flat, width, height, i1, j) * ((1.0 - b) * a)
    total = total + _texels(texture, flat, width, height, i, j1) * (b * (1.0 - a))
    return total + _texels(texture, flat, width, height, i1, j1) * (b * a)


def _cells(x: np.ndarray) -> np.ndarray:
    """floor(x) as float64 (exact integers), clamped to +-2^52 (a UV within the coordinate limit stays inside)."""
    return np.floor(np.clip(x, -(2.0**52), 2.0**52))


def _texels(texture: sc.Texture, flat: np.ndarray, width: int, height: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The texels (3, n) float64 at cells i, j (n,) (floats holding integers), by the texture's extension."""
    ii, jj = i.astype(np.int64), j.astype(np.int64)
    if texture.extension == "repeat":
        ii, jj = np.mod(ii, width), np.mod(jj, height)
        return flat.take((height - 1 - jj) * width + ii, axis=0).T.astype(np.float64)
    if texture.extension == "extend":
        ii, jj = np.clip(ii, 0, width - 1), np.clip(jj, 0, height - 1)
        return flat.take((height - 1 - jj) * width + ii, axis=0).T.astype(np.float64)
    inside = (ii >= 0) & (ii < width) & (jj >= 0) & (jj < height)
    ii, jj = np.clip(ii, 0, width - 1), np.clip(jj, 0, height - 1)
    values = flat.take((height - 1 - jj) * width + ii, axis=0).T.astype(np.float64)
    return np.where(inside, values, 0.0)


def sample_one(texture: sc.Texture, u: float, v: float) -> tuple[float, float, float]:
    """The texture's colour at one UV: sample()'s operations in plain Python floats (the per-pixel reference)."""
    pixels = texture.pixels
    height, width = pixels.shape[0], pixels.shape[1]
    u = u if math.isfinite(u) else 0.0
    v = v if math.isfinite(v) else 0.0
    if texture.interpolation == "closest":
        return _texel(texture, width, height, _cell(u * width), _cell(v * height))
    x, y = u * width - 0.5, v * height - 0.5
    i, j = _cell(x), _cell(y)
    a, b = x - i, y - j
    weights = ((1.0 - b) * (1.0 - a), (1.0 - b) * a, b * (1.0 - a), b * a)
    corners = ((i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1))
    first = _texel(texture, width, height, i, j)
    total = [c * weights[0] for c in first]
    for weight, (ci, cj) in zip(weights[1:], corners[1:], strict=True):
        texel = _texel(texture, width, height, ci, cj)
        total = [t + c * weight for t, c in zip(total, texel, strict=True)]
    return (total[0], total[1], total[2])


def _cell(x: float) -> float:
    return float(math.floor(min(max(x, -(2.0**52)), 2.0**52)))


def _texel(texture: sc.Texture, width: int, height: int, i: float, j: float) -> tuple[float, float, float]:
    ii, jj = int(i), int(j)
    if texture.extension == "repeat":
        ii, jj = ii % width, jj % height
    elif texture.extension == "extend":
        ii, jj = min(max(ii, 0), width - 1), min(max(jj, 0), height - 1)
    elif not (0 <= ii < width and 0 <= jj < height):
        return (0.0, 0.0, 0.0)
    r, g, b = texture.pixels[height - 1 - jj, ii].tolist()
    return (float(r), float(g), float(b))
