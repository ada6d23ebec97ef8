"""A texture and the UVs of hits -> the texture's linear colours there (Cycles' image lookup), vectorized and per ray.

Texel (i, j) of a W x H image covers u in [i / W, (i + 1) / W) and v in [j / H, (j + 1) / H), j counted from the
bottom (v = 0; the pixels' row H - 1 - j, as their row 0 is the top). As Cycles' `interp_closest` and
`interp_linear` (intern/cycles/kernel/device/cpu/image.h):

- closest: x = u W, i = floor(x) (the same in v), the texel (i, j);
- linear: x = u W - 0.5, i = floor(x), a = x - i (the same in v: j, b); the four texels (i, j), (i + 1, j),
  (i, j + 1), (i + 1, j + 1) weighted (1 - a)(1 - b), a (1 - b), (1 - a) b, a b, added in that order;
- repeat: i modulo W; extend: i clamped to 0..W - 1; clip: a texel outside the image is black (0).

An "attribute" texture is not looked up by UV: a mesh's corner colours interpolated at the hit (barycentric, as
smooth normals) go through gain * colour + bias, clamped to [0, 1] (attribute(), attribute_one()).

A UV that is not finite is read as (0, 0); a texture's uv_scale, uv_rotation and uv_offset (a Mapping node of
type Point) then make it R (u su, v sv) + (ou, ov), R the rotation by uv_rotation degrees counter-clockwise. The
vectorized sample() and the per-ray sample_one() do the same float64 operations in the same order, so the tracer and
the per-pixel reference agree to the last bits but for the rounding of the hit's UV itself.

Procedural textures read the UV as Cycles' texture coordinate (u, v, 0):

- checker (Cycles' svm_checker): p = (u, v, 0) scale, each component (p + 1e-6) 0.999999, xi, yi, zi = |floor|;
  color1 where (xi mod 2 == yi mod 2) == (zi mod 2), else color2; with z = 0: color1 where xi and yi differ in
  parity (the cell at the origin is color2);
- gradient (Cycles' svm_gradient) of x = u, y = v, z = 0: linear x; quadratic max(x, 0)^2; easing r = clamp(x, 0, 1),
  t = r^2, 3 t - 2 t r; diagonal (x + y) / 2; radial atan2(y, x) / (2 pi) + 1/2; quadratic_sphere and spherical
  r = max(0.999999 - |p|, 0) squared and as it is; then f clamped to [0, 1] and looked up in the colour ramp:
  Blender's colour band (before the first stop its colour, after the last the last's; constant: the colour of the
  last stop at or below f; linear: the two stops around f mixed by where f lies between them).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from ..scene import scene as sc


def _turn(degrees: float) -> tuple[float, float]:
    """cos and sin of a Mapping node's Z rotation (degrees), the same floats for sample() and sample_one()."""
    angle = math.radians(degrees)
    return math.cos(angle), math.sin(angle)


def _mapped(texture: sc.Texture, u, v):
    """The UV a texture reads through its Mapping (uv_scale, uv_rotation, uv_offset): the same operations in the same
    order on arrays (sample()) and on floats (sample_one())."""
    if texture.uv_rotation != 0.0:
        cosine, sine = _turn(texture.uv_rotation)
        x, y = u * texture.uv_scale[0], v * texture.uv_scale[1]
        return x * cosine - y * sine + texture.uv_offset[0], x * sine + y * cosine + texture.uv_offset[1]
    if texture.uv_scale != (1.0, 1.0) or texture.uv_offset != (0.0, 0.0):
        return u * texture.uv_scale[0] + texture.uv_offset[0], v * texture.uv_scale[1] + texture.uv_offset[1]
    return u, v


def sample(texture: sc.Texture, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The texture's colours (3, n) float64 at UVs u, v (n,)."""
    u, v = _mapped(texture, np.where(np.isfinite(u), u, 0.0), np.where(np.isfinite(v), v, 0.0))
    if texture.kind == "checker":
        return _checker(texture, u, v)
    if texture.kind == "gradient":
        return _ramp(texture, _gradient(texture.gradient, u, v))
    pixels = texture.pixels
    height, width = pixels.shape[0], pixels.shape[1]
    flat = pixels.reshape(-1, 3)
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


def _checker(texture: sc.Texture, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Cycles' svm_checker on (u, v, 0) scale: color1 where the cells' parities differ, else color2 (3, n)."""
    x = _cells((u * texture.scale + 1e-6) * 0.999999)
    y = _cells((v * texture.scale + 1e-6) * 0.999999)
    first = np.mod(x, 2.0) != np.mod(y, 2.0)
    one, two = (np.asarray(c, dtype=np.float64)[:, None] for c in texture.colors)
    return np.where(first, one, two)


def _gradient(kind: str, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cycles' svm_gradient of (x, y, 0), clamped to [0, 1] (n,)."""
    if kind == "linear":
        f = x
    elif kind == "quadratic":
        r = np.maximum(x, 0.0)
        f = r * r
    elif kind == "easing":
        r = np.minimum(np.maximum(x, 0.0), 1.0)
        t = r * r
        f = 3.0 * t - 2.0 * t * r
    elif kind == "diagonal":
        f = (x + y) * 0.5
    elif kind == "radial":
        f = np.arctan2(y, x) / (2.0 * math.pi) + 0.5
    else:
        r = np.maximum(0.999999 - np.sqrt(x * x + y * y), 0.0)
        f = r * r if kind == "quadratic_sphere" else r
    return np.minimum(np.maximum(f, 0.0), 1.0)


def _ramp(texture: sc.Texture, f: np.ndarray) -> np.ndarray:
    """The colour ramp's colours (3, n) at f (n,) in [0, 1] (Blender's colour band, RGB mode)."""
    positions = np.asarray(texture.positions, dtype=np.float64)
    colors = np.asarray(texture.colors, dtype=np.float64)  # (K, 3)
    last = len(positions) - 1
    above = np.searchsorted(positions, f, side="right")  # the first stop above f
    left, right = np.clip(above - 1, 0, last), np.clip(above, 0, last)
    if texture.ramp == "constant":
        return colors.take(left, axis=0).T
    low, high = positions.take(left), positions.take(right)
    span = low - high
    fac = np.where(span != 0.0, (f - high) / np.where(span != 0.0, span, 1.0), 0.0)  # the left stop's share
    return colors.take(right, axis=0).T * (1.0 - fac) + colors.take(left, axis=0).T * fac


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


def attribute(texture: sc.Texture, colors: np.ndarray) -> np.ndarray:
    """An "attribute" texture's colours (3, n) float64 from the hits' interpolated corner colours (3, n): gain *
    colour + bias per channel, clamped to [0, 1]; a colour that is not finite is read as 0."""
    colors = np.where(np.isfinite(colors), colors, 0.0)
    gain = np.asarray(texture.gain, dtype=np.float64)[:, None]
    bias = np.asarray(texture.bias, dtype=np.float64)[:, None]
    return np.minimum(np.maximum(colors * gain + bias, 0.0), 1.0)


def attribute_one(texture: sc.Texture, color: tuple[float, float, float]) -> tuple[float, float, float]:
    """attribute()'s operations on one colour in plain Python floats (the per-pixel reference)."""
    found = []
    for c, gain, bias in zip(color, texture.gain, texture.bias, strict=True):
        c = c if math.isfinite(c) else 0.0
        found.append(min(max(c * gain + bias, 0.0), 1.0))
    return found[0], found[1], found[2]


def sample_one(texture: sc.Texture, u: float, v: float) -> tuple[float, float, float]:
    """The texture's colour at one UV: sample()'s operations in plain Python floats (the per-pixel reference)."""
    u, v = _mapped(texture, u if math.isfinite(u) else 0.0, v if math.isfinite(v) else 0.0)
    if texture.kind == "checker":
        x = _cell((u * texture.scale + 1e-6) * 0.999999)
        y = _cell((v * texture.scale + 1e-6) * 0.999999)
        one, two = texture.colors
        color = one if x % 2.0 != y % 2.0 else two
        return (float(color[0]), float(color[1]), float(color[2]))
    if texture.kind == "gradient":
        return _ramp_one(texture, _gradient_one(texture.gradient, u, v))
    pixels = texture.pixels
    height, width = pixels.shape[0], pixels.shape[1]
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


def _gradient_one(kind: str, x: float, y: float) -> float:
    """_gradient for one point."""
    if kind == "linear":
        f = x
    elif kind == "quadratic":
        r = max(x, 0.0)
        f = r * r
    elif kind == "easing":
        r = min(max(x, 0.0), 1.0)
        t = r * r
        f = 3.0 * t - 2.0 * t * r
    elif kind == "diagonal":
        f = (x + y) * 0.5
    elif kind == "radial":
        f = math.atan2(y, x) / (2.0 * math.pi) + 0.5
    else:
        r = max(0.999999 - math.sqrt(x * x + y * y), 0.0)
        f = r * r if kind == "quadratic_sphere" else r
    return min(max(f, 0.0), 1.0)


def _ramp_one(texture: sc.Texture, f: float) -> tuple[float, float, float]:
    """_ramp for one f."""
    positions, colors = texture.positions, texture.colors
    last = len(positions) - 1
    above = bisect.bisect_right(positions, f)
    left, right = min(max(above - 1, 0), last), min(max(above, 0), last)
    if texture.ramp == "constant":
        return tuple(float(c) for c in colors[left])
    span = positions[left] - positions[right]
    fac = (f - positions[right]) / span if span != 0.0 else 0.0
    one, two = colors[right], colors[left]
    return tuple(float(a) * (1.0 - fac) + float(b) * fac for a, b in zip(one, two, strict=True))


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
