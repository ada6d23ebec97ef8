"""Blender's camera model -> primary rays, one pixel sample at a time or a band of rows at once.

Pixel (column i, row j) counts from the top-left corner, as images are stored; its centre is (i + 0.5, j + 0.5).
Image position (x, y) maps to the view plane point (cx, cy) = ((x / W - 0.5) * extent_x + shift_x * side,
(0.5 - y / H) * extent_y + shift_y * side), the extents fitted to the image as Blender's viewplane does
(sensor_fit AUTO, HORIZONTAL or VERTICAL, decided on the image's size times the pixel aspect; side: the fitted
extent). A perspective camera's plane is the sensor at distance lens (millimetres) and its rays leave the camera
through (cx, cy, -lens); an orthographic one's plane is ortho_scale metres across and its rays leave the plane's
points along -Z. Camera rays start on the clip_start plane and end on the clip_end plane, as in Cycles.
Samples per pixel form a stratified n x n grid, each jittered by a counter-based hash of (seed, pixel, sample),
so any band of any worker draws the same positions; one sample per pixel sits on the pixel centre.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from ..scene import scene as sc
from . import lightsamples
from . import transforms as tf

MASK64 = (1 << 64) - 1


def view_extent(camera: sc.Camera, settings: sc.RenderSettings) -> tuple[float, float, float]:
    """The view plane's (x extent, y extent, fitted side) as Blender's viewplane fits it to the image: millimetres
    at distance lens for a perspective camera, metres for an orthographic one."""
    return _fitted(camera, settings.width, settings.height, settings.pixel_aspect)


def _fitted(
    camera: sc.Camera, width: int, height: int, pixel_aspect: tuple[float, float] = (1.0, 1.0)
) -> tuple[float, float, float]:
    aspect_x, aspect_y = pixel_aspect
    ycor = aspect_y / aspect_x  # Blender's ycor: a pixel's height over its width
    fit = camera.sensor_fit
    if camera.type == "ORTHO":
        side = camera.ortho_scale
    elif fit == "VERTICAL":
        side = camera.sensor_height
    else:
        side = camera.sensor_width  # AUTO takes the width whichever way it fits, as Blender does
    if fit == "AUTO":
        fit = "HORIZONTAL" if aspect_x * width >= aspect_y * height else "VERTICAL"
    if fit == "HORIZONTAL":
        return side, side * ycor * height / width, side
    return side * width / (ycor * height), side, side


def sensor_size(
    camera: sc.Camera, width: int, height: int, pixel_aspect: tuple[float, float] = (1.0, 1.0)
) -> tuple[float, float]:
    """The view plane's (x, y) extent that maps onto the image, as Blender fits it."""
    extent_x, extent_y, _ = _fitted(camera, width, height, pixel_aspect)
    return extent_x, extent_y


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


SLICE_SEED = 0x736C6963  # each pixel's turn of the strata among a motion blur's time slices: its own sequence


def strata(settings: sc.RenderSettings) -> int:
    """The strata of a pixel's stratified grid: its samples, or in a time slice of motion blur samples * slices (the
    slice traces samples of them)."""
    return settings.samples if settings.time_slice is None else settings.samples * settings.time_slice[1]


def stratum(settings: sc.RenderSettings, pixel: int, s: int) -> int:
    """The stratum of the grid that sample s of the flat pixel traces: s itself; in time slice k of T, the stratum
    s * T + (k + shift) mod T, shift the pixel's own uniform turn in [0, T): over the T slices a pixel traces each
    stratum once, and which slice (time) meets which stratum differs from pixel to pixel (no pattern of time
    against position on the image)."""
    if settings.time_slice is None:
        return s
    k, slices = settings.time_slice
    shift = int(jitter(settings.seed + SLICE_SEED, pixel, 0) * slices)
    return s * slices + (k + shift) % slices


def _strata_array(settings: sc.RenderSettings, pixels: np.ndarray, s: np.ndarray) -> np.ndarray:
    """stratum() for arrays of flat pixels and samples (N,) each."""
    if settings.time_slice is None:
        return s
    k, slices = settings.time_slice
    shift = (jitter_array(settings.seed + SLICE_SEED, pixels, 0) * slices).astype(np.int64)
    return s * slices + (k + shift) % slices


GLASS_SEED = 0x676C6173  # rough glass's pair rotations: jitter(seed + GLASS_SEED, serial * BOUNCES + depth, 0 or 1)
BOUNCES = 128  # above the deepest path (render.depth <= 64): each depth of a camera sample's tree its own index


def glass_rotation(seed: int, serial: int, depth: int) -> tuple[float, float]:
    """The Cranley-Patterson rotation (in [0, 1)^2) of the glossy pairs at a rough glass hit of camera sample serial
    (sample_serial) with depth bounces left: its own for every camera sample and every depth of its
    tree (the glass's entry and exit differ), the same for any band or worker."""
    index = serial * BOUNCES + depth
    return jitter(seed + GLASS_SEED, index, 0), jitter(seed + GLASS_SEED, index, 1)


def glass_rotations(seed: int, serial: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """glass_rotation of arrays of camera samples and depths (k,) -> (2, k)."""
    index = np.asarray(serial, dtype=np.int64) * BOUNCES + np.asarray(depth, dtype=np.int64)
    return np.stack((jitter_array(seed + GLASS_SEED, index, 0), jitter_array(seed + GLASS_SEED, index, 1)))


WORLD_SEED = 0x776F726C  # each pixel's turn of the world light's directions: jitter(seed + WORLD_SEED, index, 0)
WORLD_TURNS = 1024  # the turns' steps (0.35 degrees): a table of Python floats, the same for tracer and reference
WORLD_TURN_TABLE = np.array(
    [
        [math.cos(2.0 * math.pi * k / WORLD_TURNS) for k in range(WORLD_TURNS)],
        [math.sin(2.0 * math.pi * k / WORLD_TURNS) for k in range(WORLD_TURNS)],
    ]
)


def _world_turn_index(settings: sc.RenderSettings, pixel, sample, share: int):
    """The row of WORLD_TURN_TABLE for sample `sample` of the flat pixel (ints or int64 arrays), the world light's
    directions shared out among share samples (lightsamples.world_share): one turn for each round of share
    strata through the directions, so that a pixel's samples hold the whole set once a round, each round turned
    its own way."""
    rounds = strata(settings) // share
    index = pixel * rounds + lightsamples.sharing_key(settings, sample) // share
    if isinstance(index, np.ndarray):
        return (jitter_array(settings.seed + WORLD_SEED, index, 0) * WORLD_TURNS).astype(np.int64)
    return int(jitter(settings.seed + WORLD_SEED, index, 0) * WORLD_TURNS)


def world_turn(settings: sc.RenderSettings, pixel: int, sample: int, share: int) -> tuple[float, float]:
    """The (cos, sin) by which sample `sample` of the flat pixel turns the world light's directions about the
    point's normal (lightsamples.hemisphere_directions): the same set for every point made every point's shadow
    edge a hard copy of the occluder, 16 stepped bands where Cycles' contact shadows are smooth; turned by a
    pixel's own angle they are noise that the pixel's samples average out. The heights stay: open ground is still
    lit exactly."""
    row = _world_turn_index(settings, pixel, sample, share)
    return float(WORLD_TURN_TABLE[0, row]), float(WORLD_TURN_TABLE[1, row])


def world_turns(settings: sc.RenderSettings, pixels: np.ndarray, samples: np.ndarray, share: int) -> np.ndarray:
    """world_turn of arrays of flat pixels and their samples (n,) -> (2, n): cos and sin."""
    rows = _world_turn_index(settings, np.asarray(pixels, dtype=np.int64), np.asarray(samples, np.int64), share)
    return WORLD_TURN_TABLE.take(rows, axis=1)


def sample_serial(settings: sc.RenderSettings, i: int, j: int, s: int) -> int:
    """The global index of sample s of pixel (i, j), as its jitter and lens sample count it: (j * width + i) *
    samples + s, or in a time slice of motion blur the pixel's strata times its own plus the stratum it traces."""
    pixel = j * settings.width + i
    return pixel * strata(settings) + stratum(settings, pixel, s)


def sample_serials(settings: sc.RenderSettings, pixels: np.ndarray) -> np.ndarray:
    """sample_serial of every sample of the flat pixels (P,), ordered pixel, sample (P * samples,)."""
    samples = settings.samples
    pixels = np.asarray(pixels, dtype=np.int64)
    shape = (pixels.size, samples)
    flat = np.broadcast_to(pixels[:, None], shape).ravel()
    s = np.broadcast_to(np.arange(samples, dtype=np.int64)[None, :], shape).ravel()
    return flat * strata(settings) + _strata_array(settings, flat, s)


def sample_position(settings: sc.RenderSettings, i: int, j: int, s: int) -> tuple[float, float]:
    """Image-plane position, in pixels from the top-left corner, of sample s of pixel (i, j)."""
    grid = strata(settings)
    n = math.isqrt(grid)
    if n == 1:
        return i + 0.5, j + 0.5
    pixel = j * settings.width + i
    cell = stratum(settings, pixel, s)
    index = pixel * grid + cell
    column, row = cell % n, cell // n
    x = i + (column + jitter(settings.seed, index, 0)) / n
    y = j + (row + jitter(settings.seed, index, 1)) / n
    return x, y


LENS_SEED = 0x6C656E73  # the lens samples' own sequence: jitter(seed + LENS_SEED, sample index, 0 or 1)


def lens_sample(settings: sc.RenderSettings, i: int, j: int, s: int) -> tuple[float, float]:
    """The lens position (u, v) in [0, 1)^2 of sample s of pixel (i, j): a uniform pair of its own for each camera
    sample (apart from its image position's jitter)."""
    pixel = j * settings.width + i
    index = pixel * strata(settings) + stratum(settings, pixel, s)
    seed = settings.seed + LENS_SEED
    return jitter(seed, index, 0), jitter(seed, index, 1)


def _lens_samples(settings: sc.RenderSettings, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """lens_sample of every sample of the flat pixels (P,), ordered pixel, sample (N,) each."""
    samples = settings.samples
    pixels = np.asarray(pixels, dtype=np.int64)
    if settings.time_slice is None:
        index = (pixels[:, None] * samples + np.arange(samples, dtype=np.int64)[None, :]).ravel()
    else:
        shape = (pixels.size, samples)
        flat = np.broadcast_to(pixels[:, None], shape).ravel()
        s = np.broadcast_to(np.arange(samples, dtype=np.int64)[None, :], shape).ravel()
        index = flat * strata(settings) + _strata_array(settings, flat, s)
    seed = settings.seed + LENS_SEED
    return jitter_array(seed, index, 0), jitter_array(seed, index, 1)


def _on_lens(camera: sc.Camera, u, v):
    """A lens position (u, v) in [0, 1)^2 (floats or arrays) -> its offset (a, b) in the camera's x and y, metres:
    Shirley and Chiu's concentric map of the square onto the disk of radius aperture (areas kept)."""
    a, b = 2.0 * u - 1.0, 2.0 * v - 1.0
    if isinstance(a, float):
        a, b = lightsamples.concentric(a, b)
        return camera.aperture * a, camera.aperture * b
    wide = np.abs(a) > np.abs(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(wide, a, b)
        angle = np.where(wide, math.pi / 4.0 * (b / a), math.pi / 2.0 - math.pi / 4.0 * (a / b))
    radius = np.where((a == 0.0) & (b == 0.0), 0.0, radius)
    angle = np.where((a == 0.0) & (b == 0.0), 0.0, angle)
    return camera.aperture * (radius * np.cos(angle)), camera.aperture * (radius * np.sin(angle))


def _view_point(camera: sc.Camera, settings: sc.RenderSettings, x, y):
    """Image positions x, y in pixels (floats or arrays) -> view plane coordinates cx, cy, lens shift included."""
    extent_x, extent_y, side = view_extent(camera, settings)
    cx = (x / settings.width - 0.5) * extent_x + camera.shift_x * side
    cy = (0.5 - y / settings.height) * extent_y + camera.shift_y * side
    return cx, cy


def panorama_outside(camera: sc.Camera, u, v):
    """Where an image position (u, v) (floats or (N,) arrays, as panorama_direction takes them) is outside a
    panoramic camera's lens: beyond a fisheye's circle or the mirror ball; never for the equirectangular."""
    kind = camera.panorama_type
    if kind == "EQUIRECTANGULAR":
        return np.zeros(np.shape(u), dtype=bool) if not isinstance(u, float) else False
    if kind == "MIRRORBALL":
        a, c = 2.0 * u - 1.0, 2.0 * v - 1.0
        return a * a + c * c > 1.0
    if kind == "FISHEYE_EQUIDISTANT":
        a, c = (u - 0.5) * 2.0, (v - 0.5) * 2.0
        return np.sqrt(a * a + c * c) > 1.0 if not isinstance(u, float) else math.sqrt(a * a + c * c) > 1.0
    a, c = (u - 0.5) * camera.sensor_width, (v - 0.5) * camera.sensor_height
    r = np.sqrt(a * a + c * c) if not isinstance(u, float) else math.sqrt(a * a + c * c)
    return r > 2.0 * camera.fisheye_lens * math.sin(math.radians(camera.fisheye_fov) * 0.25)


def panorama_direction(camera: sc.Camera, u, v):
    """Cycles' panoramic cameras (kernel/camera/projection.h): an image position (u, v) in [0, 1]^2, u from the
    left, v from the bottom (floats or (N,) arrays) -> the direction in the camera's own frame (x, y, z: Blender's
    local axes, looking along -Z) and where it is outside the lens (False, or an (N,) mask): the direction in Cycles'
    panorama space, turned as Cycles turns it into the camera's (blender/camera.cpp: the mirror ball's (x, z, y), the
    others' (-y, z, -x))."""
    array = not isinstance(u, float)
    sin, cos, sqrt = (np.sin, np.cos, np.sqrt) if array else (math.sin, math.cos, math.sqrt)
    kind = camera.panorama_type
    outside = panorama_outside(camera, u, v)
    if kind == "EQUIRECTANGULAR":
        lon_min, lon_max = math.radians(camera.longitude_min), math.radians(camera.longitude_max)
        lat_min, lat_max = math.radians(camera.latitude_min), math.radians(camera.latitude_max)
        phi = (lon_min - lon_max) * u - lon_min
        theta = (lat_min - lat_max) * v + (math.pi / 2.0 - lat_min)
        x, y, z = sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)
    elif kind == "MIRRORBALL":
        a, c = 2.0 * u - 1.0, 2.0 * v - 1.0
        b = -sqrt(np.maximum(1.0 - a * a - c * c, 0.0) if array else max(1.0 - a * a - c * c, 0.0))
        # the reflection of I = (0, -1, 0) about the ball's normal (a, b, c): 2 (n . I) n - I
        x, y, z = -2.0 * b * a, -2.0 * b * b + 1.0, -2.0 * b * c
        return (x, z, y), outside
    else:  # the fisheyes: an angle theta off the view axis, around it by phi
        if kind == "FISHEYE_EQUIDISTANT":
            a, c = (u - 0.5) * 2.0, (v - 0.5) * 2.0
        else:
            a, c = (u - 0.5) * camera.sensor_width, (v - 0.5) * camera.sensor_height
        r = sqrt(a * a + c * c)
        if kind == "FISHEYE_EQUIDISTANT":
            theta = r * math.radians(camera.fisheye_fov) * 0.5
        else:
            half = r / (2.0 * camera.fisheye_lens)
            theta = 2.0 * (np.arcsin(np.minimum(half, 1.0)) if array else math.asin(min(half, 1.0)))
        if array:
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(r != 0.0, a / r, 0.0)
            phi = np.arccos(np.clip(ratio, -1.0, 1.0))
            phi = np.where(c < 0.0, -phi, phi)
        else:
            phi = math.acos(min(max(a / r if r != 0.0 else 0.0, -1.0), 1.0))
            phi = -phi if c < 0.0 else phi
        x, y, z = cos(theta), -cos(phi) * sin(theta), sin(phi) * sin(theta)
    return (-y, z, -x), outside


def primary_direction(camera: sc.Camera, settings: sc.RenderSettings, x: float, y: float) -> sc.Vec3:
    """Unit world direction of the camera ray through image position (x, y) in pixels; Python floats. A panoramic
    camera's position outside its lens: (0, 0, 0)."""
    r = tf.euler_xyz_matrix(camera.rotation)
    if camera.type == "PANO":
        (cx, cy, cz), outside = panorama_direction(camera, x / settings.width, 1.0 - y / settings.height)
        if outside:
            return 0.0, 0.0, 0.0
    elif camera.type == "ORTHO":
        return -r[0][2], -r[1][2], -r[2][2]
    else:
        cx, cy = _view_point(camera, settings, x, y)
        cz = -camera.lens
    wx = r[0][0] * cx + r[0][1] * cy + r[0][2] * cz
    wy = r[1][0] * cx + r[1][1] * cy + r[1][2] * cz
    wz = r[2][0] * cx + r[2][1] * cy + r[2][2] * cz
    size = math.sqrt(wx * wx + wy * wy + wz * wz)
    return wx / size, wy / size, wz / size


def primary_ray(
    camera: sc.Camera, settings: sc.RenderSettings, x: float, y: float, lens: tuple[float, float] = (0.5, 0.5)
) -> tuple[sc.Vec3, sc.Vec3, float]:
    """The camera ray through image position (x, y): (origin, unit direction, t_max), Python floats.

    It starts on the clip_start plane and ends on the clip_end plane (t_max infinite without one); with neither
    and a perspective camera (the documented camera) the origin is the camera's location exactly. With an aperture,
    the ray leaves the lens at lens (u, v) (lens_sample; the centre by default) toward the point where the pinhole
    ray meets the focus plane (a thin lens)."""
    D = primary_direction(camera, settings, x, y)
    if camera.type == "PANO":  # clipped by distance along the ray, as Cycles clips panoramic rays
        if D == (0.0, 0.0, 0.0):  # outside the lens: a ray that sees nothing
            return camera.location, (0.0, 0.0, 1.0), 0.0
        start = tuple(camera.location[k] + D[k] * camera.clip_start for k in range(3))
        return start, D, math.inf if camera.clip_end is None else camera.clip_end - camera.clip_start
    r = tf.euler_xyz_matrix(camera.rotation)
    start = camera.location
    if camera.type == "ORTHO":
        depth_per_t = 1.0
        cx, cy = _view_point(camera, settings, x, y)
        start = tuple(camera.location[k] + r[k][0] * cx + r[k][1] * cy for k in range(3))
    if camera.aperture > 0.0:
        start, D = _through_lens(camera, r, start, D, *_on_lens(camera, *lens))
    if camera.type != "ORTHO" or camera.aperture > 0.0:  # how much deeper in front of the camera a unit step goes
        depth_per_t = -(r[0][2] * D[0] + r[1][2] * D[1] + r[2][2] * D[2])
    if camera.clip_start:
        start = tuple(start[k] + D[k] * (camera.clip_start / depth_per_t) for k in range(3))
    t_max = math.inf if camera.clip_end is None else (camera.clip_end - camera.clip_start) / depth_per_t
    return start, D, t_max


def _through_lens(camera: sc.Camera, r, start, D, a, b):
    """The thin lens: the pinhole ray (start, unit D; floats or (3, N) arrays) -> the ray from the lens point offset
    by (a, b) along the camera's x and y toward where the pinhole ray meets the focus plane, focus_distance in front
    of the camera: (origin, unit direction)."""
    along = 1.0 if camera.type == "ORTHO" else -(r[0][2] * D[0] + r[1][2] * D[1] + r[2][2] * D[2])
    t = camera.focus_distance / along
    origin = tuple(start[k] + r[k][0] * a + r[k][1] * b for k in range(3))
    toward = tuple(start[k] + D[k] * t - origin[k] for k in range(3))
    if isinstance(a, float):
        size = math.sqrt(toward[0] * toward[0] + toward[1] * toward[1] + toward[2] * toward[2])
        return origin, (toward[0] / size, toward[1] / size, toward[2] / size)
    size = np.sqrt(toward[0] * toward[0] + toward[1] * toward[1] + toward[2] * toward[2])
    return np.stack(origin), np.stack((toward[0] / size, toward[1] / size, toward[2] / size))


def band_pixels(settings: sc.RenderSettings, rows: np.ndarray, columns: np.ndarray | None = None) -> np.ndarray:
    """Flat pixel indices j * W + i (R * C,) of the given rows (R,) and columns (C,; every column when None), ordered
    row, column."""
    rows = np.asarray(rows, dtype=np.int64)
    columns = np.arange(settings.width, dtype=np.int64) if columns is None else np.asarray(columns, dtype=np.int64)
    return (rows[:, None] * settings.width + columns[None, :]).ravel()


def _sample_positions(settings: sc.RenderSettings, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image positions x, y (N,) of every sample of the given flat pixels (P,), ordered pixel, sample: the same
    operations as sample_position."""
    width, samples = settings.width, settings.samples
    grid = strata(settings)
    n = math.isqrt(grid)
    pixels = np.asarray(pixels, dtype=np.int64)
    shape = (pixels.size, samples)
    j = np.broadcast_to((pixels // width)[:, None], shape).ravel()
    i = np.broadcast_to((pixels % width)[:, None], shape).ravel()
    s = np.broadcast_to(np.arange(samples, dtype=np.int64)[None, :], shape).ravel()
    if n == 1:
        return i + 0.5, j + 0.5
    if settings.time_slice is not None:
        s = _strata_array(settings, j * width + i, s)
    index = (j * width + i) * grid + s
    x = i + ((s % n) + jitter_array(settings.seed, index, 0)) / n
    y = j + ((s // n) + jitter_array(settings.seed, index, 1)) / n
    return x, y


def pixel_directions(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray) -> np.ndarray:
    """Unit directions (3, N) float64 of every sample of the given flat pixels (P,), ordered pixel, sample.

    The same operations in the same order as primary_direction (and primary_ray's thin lens), so each ray is
    bit-identical to the scalar one (and to itself in any band or subset)."""
    if camera.type == "PANO":
        return _panorama_rays(camera, settings, pixels)[0]
    D = _pinhole_directions(camera, settings, pixels)
    return D if camera.aperture == 0.0 else _lens_rays(camera, settings, pixels, D)[1]


def _panorama_rays(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A panoramic camera's unit directions (3, N) of every sample of the pixels (P,), and which are outside its lens
    (N,) (their direction +Z, never traced): the same operations as primary_direction."""
    x, y = _sample_positions(settings, pixels)
    (cx, cy, cz), outside = panorama_direction(camera, x / settings.width, 1.0 - y / settings.height)
    r = tf.euler_xyz_matrix(camera.rotation)
    wx = r[0][0] * cx + r[0][1] * cy + r[0][2] * cz
    wy = r[1][0] * cx + r[1][1] * cy + r[1][2] * cz
    wz = r[2][0] * cx + r[2][1] * cy + r[2][2] * cz
    with np.errstate(divide="ignore", invalid="ignore"):
        size = np.sqrt(wx * wx + wy * wy + wz * wz)
        D = np.stack((wx / size, wy / size, wz / size))
    if np.any(outside):
        D[:, outside] = ((0.0,), (0.0,), (1.0,))
    return D, np.broadcast_to(outside, (x.size,))


def _lens_rays(
    camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray, D: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The thin lens's rays (origins, unit directions; (3, N) each) of every sample of the pixels (P,), from their
    pinhole directions D (3, N)."""
    r = tf.euler_xyz_matrix(camera.rotation)
    return _through_lens(
        camera, r, _pinhole_starts(camera, settings, pixels, r), D, *_lens_offsets(camera, settings, pixels)
    )


def _pinhole_starts(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray, r):
    """Where the pinhole rays of the pixels' samples start: the camera's location, or an orthographic camera's
    view-plane points (a list of 3 (N,) arrays)."""
    if camera.type != "ORTHO":
        return camera.location
    cx, cy = _view_point(camera, settings, *_sample_positions(settings, pixels))
    return [camera.location[k] + r[k][0] * cx + r[k][1] * cy for k in range(3)]


def _lens_offsets(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray):
    """Each sample's point on the lens (a, b) (N,) each, along the camera's x and y."""
    return _on_lens(camera, *_lens_samples(settings, pixels))


def _lens_origins(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray, r) -> np.ndarray:
    """The lens rays' origins (3, N): _through_lens's, without their directions."""
    start, (a, b) = _pinhole_starts(camera, settings, pixels, r), _lens_offsets(camera, settings, pixels)
    return np.stack(tuple(start[k] + r[k][0] * a + r[k][1] * b for k in range(3)))


def _pinhole_directions(camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray) -> np.ndarray:
    """pixel_directions without a lens: the rays through the pinhole (the camera's location)."""
    x, y = _sample_positions(settings, pixels)
    r = tf.euler_xyz_matrix(camera.rotation)
    if camera.type == "ORTHO":
        return np.repeat(np.asarray([[-r[0][2]], [-r[1][2]], [-r[2][2]]]), x.size, axis=1)
    cx, cy = _view_point(camera, settings, x, y)
    cz = -camera.lens
    wx = r[0][0] * cx + r[0][1] * cy + r[0][2] * cz
    wy = r[1][0] * cx + r[1][1] * cy + r[1][2] * cz
    wz = r[2][0] * cx + r[2][1] * cy + r[2][2] * cz
    size = np.sqrt(wx * wx + wy * wy + wz * wz)
    return np.stack((wx / size, wy / size, wz / size))


def band_directions(
    camera: sc.Camera, settings: sc.RenderSettings, rows: np.ndarray, columns: np.ndarray | None = None
) -> np.ndarray:
    """Unit directions (3, N) float64 of every sample of the given image rows (R,) and columns (C,; every column
    when None), ordered row, column, sample: pixel_directions of those pixels."""
    return pixel_directions(camera, settings, band_pixels(settings, rows, columns))


def border_window(settings: sc.RenderSettings) -> tuple[int, int, int, int] | None:
    """The render border's pixels as columns [x0, x1) and rows from the top [y0, y1), or None without a border.

    As Blender's render rectangle: each side at int(fraction * size) (truncated), y counted up from the bottom;
    at least one pixel wide and high."""
    if settings.border is None:
        return None
    width, height = settings.width, settings.height
    min_x, min_y, max_x, max_y = settings.border
    x0 = min(int(min_x * width), width - 1)
    x1 = min(max(int(max_x * width), x0 + 1), width)
    bottom = min(int(min_y * height), height - 1)
    top = min(max(int(max_y * height), bottom + 1), height)
    return x0, x1, height - top, height - bottom


def shares_origin(camera: sc.Camera) -> bool:
    """Whether every camera ray starts at the camera's location and has no far limit (the documented camera)."""
    return camera.type == "PERSP" and not camera.clip_start and camera.clip_end is None and camera.aperture == 0.0


def pixel_starts(
    camera: sc.Camera, settings: sc.RenderSettings, pixels: np.ndarray, directions: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None]:
    """Where the camera rays of pixel_directions(pixels) start and stop, as primary_ray computes them: origins
    (3, N) float64 and t_max (N,), or None where there is no far limit. directions: those rays (3, N)."""
    r = tf.euler_xyz_matrix(camera.rotation)
    D = np.asarray(directions, dtype=np.float64)
    if camera.type == "PANO":  # clipped by distance along the ray; outside the lens: nothing (t_max 0)
        x, y = _sample_positions(settings, pixels)
        outside = np.broadcast_to(panorama_outside(camera, x / settings.width, 1.0 - y / settings.height), (x.size,))
        start = np.asarray(camera.location, dtype=np.float64).reshape(3, 1) + D * camera.clip_start
        length = math.inf if camera.clip_end is None else camera.clip_end - camera.clip_start
        if camera.clip_end is None and not outside.any():
            return start, None
        return start, np.where(outside, 0.0, length)
    if camera.aperture > 0.0:  # the lens points; the directions (pixel_directions') are the lens rays already
        start = _lens_origins(camera, settings, pixels, r)
        depth_per_t = -(r[0][2] * D[0] + r[1][2] * D[1] + r[2][2] * D[2])
    elif camera.type == "ORTHO":
        depth_per_t = 1.0
        cx, cy = _view_point(camera, settings, *_sample_positions(settings, pixels))
        start = np.stack([camera.location[k] + r[k][0] * cx + r[k][1] * cy for k in range(3)])
    else:
        depth_per_t = -(r[0][2] * D[0] + r[1][2] * D[1] + r[2][2] * D[2])
        start = np.broadcast_to(np.asarray(camera.location, dtype=np.float64).reshape(3, 1), D.shape)
    if camera.clip_start:
        start = start + D * (camera.clip_start / depth_per_t)
    if camera.clip_end is None:
        return start, None
    return start, np.broadcast_to((camera.clip_end - camera.clip_start) / depth_per_t, (D.shape[1],))


def band_starts(
    camera: sc.Camera,
    settings: sc.RenderSettings,
    rows: np.ndarray,
    columns: np.ndarray | None,
    directions: np.ndarray,
) -> tuple[np.ndarray, np.ndarray | None]:
    """pixel_starts() of the rays of band_directions(rows, columns)."""
    return pixel_starts(camera, settings, band_pixels(settings, rows, columns), directions)


def to_pixels(
    camera: sc.Camera, settings: sc.RenderSettings, points: np.ndarray, location: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (..., 3) -> image position x, y (...) in pixels from the top-left corner and depth (...) in
    front of the camera: the camera rays' inverse. location (3,): the camera's position as the tracer holds it."""
    local = (points - location) @ np.asarray(tf.euler_xyz_matrix(camera.rotation))  # the camera's axes
    depth = -local[..., 2]
    extent_x, extent_y, side = view_extent(camera, settings)
    if camera.type == "ORTHO":
        cx, cy = local[..., 0], local[..., 1]
    else:
        cx, cy = camera.lens * local[..., 0] / depth, camera.lens * local[..., 1] / depth
    x = ((cx - camera.shift_x * side) / extent_x + 0.5) * settings.width
    y = (0.5 - (cy - camera.shift_y * side) / extent_y) * settings.height
    return x, y, depth


def pixel_footprint(camera: sc.Camera, settings: sc.RenderSettings, depth: float) -> float:
    """The world size of one pixel at a depth in front of the camera (the smaller side, for any sensor fit)."""
    extent_x, extent_y, _ = view_extent(camera, settings)
    across = min(extent_x / settings.width, extent_y / settings.height)
    return across if camera.type == "ORTHO" else depth * across / camera.lens


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
        settings.time_slice,  # a motion blur slice's strata (stratum)
        settings.pixel_aspect,
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
