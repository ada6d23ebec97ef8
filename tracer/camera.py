"""Blender's camera model -> primary rays, one pixel sample at a time or a band of rows at once.

Pixel (column i, row j) counts from the top-left corner, as images are stored; its centre is (i + 0.5, j + 0.5).
A camera-space point on the sensor plane at distance lens is ((x / W - 0.5) * sensor_x, (0.5 - y / H) * sensor_y,
-lens), with the sensor sides fitted to the image as Blender does (sensor_fit AUTO, HORIZONTAL or VERTICAL).
Samples per pixel form a stratified n x n grid, each jittered by a counter-based hash of (seed, pixel, sample),
so any band of any worker draws the same positions; one sample per pixel sits on the pixel centre.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from . import scene as sc
from . import transforms as tf

MASK64 = (1 << 64) - 1


def sensor_size(camera: sc.Camera, width: int, height: int) -> tuple[float, float]:
    """The sensor's (x, y) extent in millimetres that maps onto the image, as Blender fits it."""
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
        side = camera.sensor_width
    else:
        side = camera.sensor_width if fit == "HORIZONTAL" else camera.sensor_height
    if fit == "HORIZONTAL":
        return side, side * height / width
    return side * width / height, side


def _mix64(key: int) -> int:
    """splitmix64's finaliser on a Python int (the scalar twin of _mix64_array)."""
    key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9 & MASK64
    key = (key ^ (key >> 27)) * 0x94D049BB133111EB & MASK64
    return key ^ (key >> 31)


def _mix64_array(key: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on uint64 arrays (wrapping multiplication)."""
    key = (key ^ (key >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    key = (key ^ (key >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return key ^ (key >> np.uint64(31))


def _hash_key(seed: int, sample_index: int, dimension: int) -> int:
    return (seed * 0x9E3779B97F4A7C15 + sample_index * 2 + dimension) & MASK64


def jitter(seed: int, sample_index: int, dimension: int) -> float:
    """A uniform number in [0, 1) for one global sample index and dimension (0: x, 1: y)."""
    return (_mix64(_hash_key(seed, sample_index, dimension)) >> 11) * 2.0**-53


def jitter_array(seed: int, sample_index: np.ndarray, dimension: int) -> np.ndarray:
    """jitter() for an array of int64 sample indices."""
    base = np.uint64(seed * 0x9E3779B97F4A7C15 & MASK64)
    with np.errstate(over="ignore"):
        key = base + sample_index.astype(np.uint64) * np.uint64(2) + np.uint64(dimension)
        return (_mix64_array(key) >> np.uint64(11)).astype(np.float64) * 2.0**-53


def sample_position(settings: sc.RenderSettings, i: int, j: int, s: int) -> tuple[float, float]:
    """Image-plane position, in pixels from the top-left corner, of sample s of pixel (i, j)."""
    n = math.isqrt(settings.samples)
    if n == 1:
        return i + 0.5, j + 0.5
    index = (j * settings.width + i) * settings.samples + s
    column, row = s % n, s // n
    x = i + (column + jitter(settings.seed, index, 0)) / n
    y = j + (row + jitter(settings.seed, index, 1)) / n
    return x, y


def primary_direction(camera: sc.Camera, settings: sc.RenderSettings, x: float, y: float) -> sc.Vec3:
    """Unit world direction of the camera ray through image position (x, y) in pixels; Python floats."""
    sensor_x, sensor_y = sensor_size(camera, settings.width, settings.height)
    cx = (x / settings.width - 0.5) * sensor_x
    cy = (0.5 - y / settings.height) * sensor_y
    cz = -camera.lens
    r = tf.euler_xyz_matrix(camera.rotation)
    wx = r[0][0] * cx + r[0][1] * cy + r[0][2] * cz
    wy = r[1][0] * cx + r[1][1] * cy + r[1][2] * cz
    wz = r[2][0] * cx + r[2][1] * cy + r[2][2] * cz
    size = math.sqrt(wx * wx + wy * wy + wz * wz)
    return wx / size, wy / size, wz / size


def band_directions(
    camera: sc.Camera, settings: sc.RenderSettings, rows: np.ndarray, columns: np.ndarray | None = None
) -> np.ndarray:
    """Unit directions (3, N) float64 of every sample of the given image rows (R,) and columns (C,; every column
    when None), ordered row, column, sample.

    The same operations in the same order as primary_direction, so each ray is bit-identical to the scalar one.
    """
    width, samples = settings.width, settings.samples
    n = math.isqrt(samples)
    rows = np.asarray(rows, dtype=np.int64)
    columns = np.arange(width, dtype=np.int64) if columns is None else np.asarray(columns, dtype=np.int64)
    sample = np.arange(samples, dtype=np.int64)
    shape = (rows.size, columns.size, samples)
    j = np.broadcast_to(rows[:, None, None], shape).ravel()
    i = np.broadcast_to(columns[None, :, None], shape).ravel()
    s = np.broadcast_to(sample[None, None, :], shape).ravel()
    if n == 1:
        x = i + 0.5
        y = j + 0.5
    else:
        index = (j * width + i) * samples + s
        x = i + ((s % n) + jitter_array(settings.seed, index, 0)) / n
        y = j + ((s // n) + jitter_array(settings.seed, index, 1)) / n
    sensor_x, sensor_y = sensor_size(camera, settings.width, settings.height)
    cx = (x / settings.width - 0.5) * sensor_x
    cy = (0.5 - y / settings.height) * sensor_y
    cz = -camera.lens
    r = tf.euler_xyz_matrix(camera.rotation)
    wx = r[0][0] * cx + r[0][1] * cy + r[0][2] * cz
    wy = r[1][0] * cx + r[1][1] * cy + r[1][2] * cz
    wz = r[2][0] * cx + r[2][1] * cy + r[2][2] * cz
    size = np.sqrt(wx * wx + wy * wy + wz * wz)
    return np.stack((wx / size, wy / size, wz / size))


def to_pixels(
    camera: sc.Camera, settings: sc.RenderSettings, points: np.ndarray, location: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (..., 3) -> image position x, y (...) in pixels from the top-left corner and depth (...) in
    front of the camera: primary_direction's inverse. location (3,): the camera's position as the tracer holds it."""
    local = (points - location) @ np.asarray(tf.euler_xyz_matrix(camera.rotation))  # the camera's axes
    depth = -local[..., 2]
    sensor_x, sensor_y = sensor_size(camera, settings.width, settings.height)
    x = (camera.lens * local[..., 0] / depth / sensor_x + 0.5) * settings.width
    y = (0.5 - camera.lens * local[..., 1] / depth / sensor_y) * settings.height
    return x, y, depth


def pixel_footprint(camera: sc.Camera, settings: sc.RenderSettings, depth: float) -> float:
    """The world size of one pixel at a depth in front of the camera (the smaller side, for any sensor fit)."""
    sensor_x, sensor_y = sensor_size(camera, settings.width, settings.height)
    return depth * min(sensor_x / settings.width, sensor_y / settings.height) / camera.lens


_BAND_CACHE: OrderedDict[tuple, np.ndarray] = OrderedDict()
BAND_CACHE_BYTES = 8 << 20  # holds every band of a 640x480 frame in either dtype; 1080p is computed each time


def cached_band_directions(
    camera: sc.Camera, settings: sc.RenderSettings, rows: np.ndarray, dtype: np.dtype
) -> np.ndarray:
    """band_directions() in dtype, kept (read-only) while the camera and the image settings stay the same.

    A still camera is the common case (an animation turns the vane, not the camera), and the rays of a band cost
    about 3 ms at 640x480 here. Only an image whose rays all fit in BAND_CACHE_BYTES is kept (a larger one would
    only churn the cache); least recently used bands go first."""
    rows = np.asarray(rows, dtype=np.int64)
    key = (
        camera,
        settings.width,
        settings.height,
        settings.samples,
        settings.seed,
        np.dtype(dtype).str,
        rows.tobytes(),
    )
    directions = _BAND_CACHE.get(key)
    if directions is not None:
        _BAND_CACHE.move_to_end(key)
        return directions
    directions = band_directions(camera, settings, rows).astype(dtype, copy=False)
    directions.flags.writeable = False
    if settings.width * settings.height * settings.samples * 3 * np.dtype(dtype).itemsize <= BAND_CACHE_BYTES:
        _BAND_CACHE[key] = directions
        while sum(kept.nbytes for kept in _BAND_CACHE.values()) > BAND_CACHE_BYTES:
            _BAND_CACHE.popitem(last=False)
    return directions


def documented_background_direction(camera: sc.Camera, settings: sc.RenderSettings) -> sc.Vec3:
    """The ray through pixel (W / 2, H / 2): the seed returns the background image's color there for every miss."""
    return primary_direction(camera, settings, settings.width // 2 + 0.5, settings.height // 2 + 0.5)
