"""Where the shadow rays of a light of a size go: stratified points on an area light, directions over a sun's disk,
and the equirectangular lookup of an image background. Plain Python floats, so that the vectorized tracer and the
per-pixel reference use the very same numbers (docs/scene-format.md, "Lights of a size").

A light of a size at n = render.shadow_samples > 1 is taken as n point (or directional) lights, each with 1 / n of
its intensity, at multi-jittered sample numbers (patterned_grid: one a cell of the sqrt(n) grid, and one a strip of
n along each axis) mapped onto the light's shape (a rectangle as it is, a disk or an ellipse by Shirley and Chiu's
concentric map, which keeps the cells' areas equal). From PATTERNS_FROM samples it is four such sets, 4n lights
with 1 / 4n each, and each pixel of a 2 x 2 block takes one set (pixel_pattern), 4 times. The same grid points at
every pixel made the penumbra a staircase as wide as the light, an edge along the light's axis sqrt(n) + 1 hard
copies of it; now a pixel sees n + 1 steps, a 2 x 2 block 4n + 1, and no noise. One sample is the centre: the
light's hard shadow.
"""

from __future__ import annotations

import math

import numpy as np

from ..scene import scene as sc
from . import transforms as tf


def grid(samples: int) -> list[tuple[float, float]]:
    """The stratified grid's cell centres in [-1, 1]^2, row by row: m x m of them for samples = m^2."""
    side = math.isqrt(samples)
    return [(2.0 * (a + 0.5) / side - 1.0, 2.0 * (b + 0.5) / side - 1.0) for b in range(side) for a in range(side)]


PATTERNS = 4  # a light of a size's sample patterns, one for each pixel of a 2 x 2 block
# where in its strip (of 4 parts) each pattern's samples sit along x and along y: every part once along each axis
PATTERN_X = (0, 2, 3, 1)
PATTERN_Y = (2, 0, 1, 3)
# shadow samples from which a light of a size takes its patterns: below, one set of 4 (the Rendered view's default)
# keeps the view's 4 shadow queries a light (16 made its glass edits finish 15-20% later)
PATTERNS_FROM = 9


def patterns(samples: int) -> int:
    """How many patterns a light of a size takes at render.shadow_samples = samples: PATTERNS from PATTERNS_FROM,
    else 1 (one multi-jittered set, or the centre alone)."""
    return PATTERNS if samples >= PATTERNS_FROM else 1


def patterned_grid(samples: int) -> list[tuple[float, float]]:
    """A light of a size's sample numbers in [-1, 1]^2: grid(samples) for one sample, else patterns(samples) x
    samples of them, entry j PATTERNS + r pattern r's sample in cell j = b m + a of the m x m grid (samples = m^2;
    one pattern: x in strip a m + b and y in strip b m + a, at their middles). Over
    [0, 1] its x is in strip a m + (b + sx) mod m of m^2 and its y in strip b m + (a + sy) mod m, at the quarter
    PATTERN_X[r] (PATTERN_Y[r]) of it, with sx = r m // 4 and sy = PATTERN_Y[r] m // 4: each pattern one sample a
    cell and one a strip along each axis (Chiu, Shirley and Wang's multi-jittered sampling), so that an edge along
    an axis, a box's beside a rectangular light, meets them one at a time (samples + 1 steps, where the grid's m
    columns gave m + 1); the four patterns' samples of a cell in strips and quarters of their own, so that a 2 x 2
    block's 4 m^2 samples are spread as finely."""
    side = math.isqrt(samples)
    if samples == 1:
        return grid(samples)
    cells, count = side * side, patterns(samples)
    along_x, along_y = (PATTERN_X, PATTERN_Y) if count == PATTERNS else ((0,), (0,))
    points = []
    for b in range(side):
        for a in range(side):
            for r in range(count):
                x_strip = a * side + (b + r * side // count) % side
                y_strip = b * side + (a + along_y[r] * side // count) % side
                x = (x_strip + (along_x[r] + 0.5) / count) / cells
                y = (y_strip + (along_y[r] + 0.5) / count) / cells
                points.append((2.0 * x - 1.0, 2.0 * y - 1.0))
    return points


def patterned(scene: sc.Scene) -> bool:
    """Whether some light of the scene is taken in patterns: render.shadow_samples from PATTERNS_FROM and a light of
    a size (an area light, a sun of an angle, a point or spot light of a radius)."""
    if patterns(scene.render.shadow_samples) == 1:
        return False
    return any(
        isinstance(light, sc.AreaLight)
        or (isinstance(light, sc.DirectionalLight) and light.angle > 0.0)
        or (isinstance(light, sc.PointLight | sc.SpotLight) and light.radius > 0.0)
        for light in scene.lights
    )


def pixel_pattern(width: int, pixel: int | np.ndarray) -> int | np.ndarray:
    """The pattern (patterned_grid) that the flat pixel (j width + i; an int or an int64 array) of an image width
    pixels wide takes: x + 2 y for its place (x, y) = (i mod 2, j mod 2) in its 2 x 2 block."""
    return (pixel % width) % 2 + 2 * ((pixel // width) % 2)


def concentric(a: float, b: float) -> tuple[float, float]:
    """Shirley and Chiu's concentric map of the square [-1, 1]^2 onto the unit disk (areas kept)."""
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        radius, angle = a, math.pi / 4.0 * (b / a)
    else:
        radius, angle = b, math.pi / 2.0 - math.pi / 4.0 * (a / b)
    return radius * math.cos(angle), radius * math.sin(angle)


def _unit(v: sc.Vec3) -> sc.Vec3:
    length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / length, v[1] / length, v[2] / length)


def _cross(a: sc.Vec3, b: sc.Vec3) -> sc.Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def area_frame(light: sc.AreaLight) -> tuple[sc.Vec3, sc.Vec3, sc.Vec3]:
    """The light's unit normal (the way it shines, Blender's local -Z) and its local X and Y axes in the world
    (X: x_axis made perpendicular to the normal; Y = X x normal, Blender's local Y)."""
    normal = _unit(light.direction)
    x = light.x_axis
    along = x[0] * normal[0] + x[1] * normal[1] + x[2] * normal[2]
    x_axis = _unit((x[0] - along * normal[0], x[1] - along * normal[1], x[2] - along * normal[2]))
    return normal, x_axis, _cross(x_axis, normal)


def area_points(light: sc.AreaLight, samples: int) -> list[sc.Vec3]:
    """The area light's sample points (patterned_grid: patterns(samples) x samples of them; 1: its centre)."""
    if samples == 1:
        return [tuple(float(c) for c in light.location)]
    _, x_axis, y_axis = area_frame(light)
    half_x, half_y = light.size[0] / 2.0, light.size[1] / 2.0
    points = []
    for a, b in patterned_grid(samples):
        if light.shape in ("disk", "ellipse"):
            a, b = concentric(a, b)
        x, y = a * half_x, b * half_y
        points.append(tuple(light.location[k] + x * x_axis[k] + y * y_axis[k] for k in range(3)))
    return points


def sun_directions(light: sc.DirectionalLight, samples: int) -> list[sc.Vec3]:
    """A sun's directions toward the light over its disk of angular diameter light.angle (patterned_grid:
    patterns(samples) x samples of them, each as long as light.direction; 1 sample or angle 0: the direction itself)."""
    if samples == 1 or light.angle == 0.0:
        return [tuple(float(c) for c in light.direction)]
    d = light.direction
    length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    axis = _unit(d)
    other = (1.0, 0.0, 0.0) if abs(axis[2]) > 0.9 else (0.0, 0.0, 1.0)
    e1 = _unit(_cross(axis, other))
    e2 = _cross(axis, e1)
    radius = math.tan(math.radians(light.angle) / 2.0)
    directions = []
    for a, b in patterned_grid(samples):
        x, y = concentric(a, b)
        toward = _unit(tuple(axis[k] + radius * (x * e1[k] + y * e2[k]) for k in range(3)))
        directions.append(tuple(length * c for c in toward))
    return directions


GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))  # radians: successive directions turn by it (a Fibonacci spiral)
GOLDEN_TURN = (3.0 - math.sqrt(5.0)) / 2.0  # the golden angle as a fraction of a turn


def hemisphere_directions(samples: int) -> list[sc.Vec3]:
    """The world light's directions in the frame of a point's normal (z along it): a Fibonacci spiral over the
    hemisphere, z = (i + 0.5) / samples (Archimedes: uniform in z is uniform over the hemisphere's area) turning by
    the golden angle, so that every direction has a height of its own (an occluder's edge is resolved to 1 / samples
    in z, where a grid of the same count resolves 1 / sqrt(samples)). 2 / samples times the sum of z f over them
    estimates the cosine-weighted mean of f (exactly, for f = 1: the midpoint rule on a linear function). Each
    pixel turns the spiral about the normal by an angle of its own (camera.world_turn), keeping the heights."""
    directions = []
    for i in range(samples):
        z = (i + 0.5) / samples
        r = math.sqrt(max(0.0, 1.0 - z * z))
        angle = i * GOLDEN_ANGLE
        directions.append((r * math.cos(angle), r * math.sin(angle), z))
    return directions


def world_share(settings: sc.RenderSettings, directions: int) -> int:
    """How many of a pixel's camera samples share out the world light's directions: g = gcd(strata, directions),
    strata the pixel's samples (times a motion blur's time slices). Camera sample s then takes the directions i with
    i = key mod g (sharing_key), each g times its weight: the pixel's mean holds every direction once per strata / g
    samples, as one sample holding them all would, at 1 / g of the shadow rays (16 samples: one direction each).
    1: every sample takes every direction (one sample a pixel, or counts with no common factor)."""
    slices = 1 if settings.time_slice is None else settings.time_slice[1]
    return math.gcd(settings.samples * slices, directions)


def shared_pairs(settings: sc.RenderSettings, count: int, sample: int) -> tuple[range, float]:
    """The glossy pairs camera sample `sample` of a pixel takes at a path's first glossy surface or diffuse bounce,
    and each one's share: shared out among the pixel's samples as the world light's directions are (world_share g),
    range(key mod g, count, g) at g / count each (16 samples, 16 pairs: one ray each, 16 a pixel, not 256)."""
    share = world_share(settings, count)
    return range(sharing_key(settings, sample) % share, count, share), share / count


def sharing_key(settings: sc.RenderSettings, sample: int | np.ndarray) -> int | np.ndarray:
    """A camera sample's place among the pixel's strata for world_share: sample s of the pixel (in a time slice k of
    T, s T + k: over the slices every key once)."""
    if settings.time_slice is None:
        return sample
    k, slices = settings.time_slice
    return sample * slices + k


def equirectangular(D: sc.Vec3, rotation: float) -> tuple[float, float]:
    """A direction -> Blender's equirectangular (u, v) in [0, 1] (Cycles' direction_to_equirectangular: u = 0.5 -
    atan2(y, x) / 2 pi, so +X is the picture's centre and +Y a quarter from its left; v = 0.5 + elevation / pi, 1 at
    the zenith), after the Mapping's rotation about Z (degrees): the direction looked up is Rz(rotation) D."""
    x, y, z = D
    if rotation != 0.0:
        c, s = math.cos(math.radians(rotation)), math.sin(math.radians(rotation))
        x, y = c * x - s * y, s * x + c * y
    return 0.5 - math.atan2(y, x) / (2.0 * math.pi), 0.5 + math.atan2(z, math.hypot(x, y)) / math.pi


def disk_offsets(samples: int) -> list[tuple[float, float]]:
    """A point or spot light's samples on the unit disk (the concentric map of patterned_grid; 1: the centre
    alone), scaled by its radius on the disk that faces each shaded point (facing_basis)."""
    if samples == 1:
        return [(0.0, 0.0)]
    return [concentric(a, b) for a, b in patterned_grid(samples)]


def facing_basis(w: sc.Vec3) -> tuple[sc.Vec3, sc.Vec3]:
    """Two unit vectors perpendicular to the unit vector w and to each other (Duff et al. 2017, "Building an
    orthonormal basis, revisited": continuous except where w.z changes sign): the disk of a light of a radius, seen
    from a point, lies along them."""
    x, y, z = w
    sign = math.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    return (1.0 + sign * x * x * a, sign * b, -sign * x), (b, sign + y * y * a, -y)


# a glossy lobe of the world alone (a dielectric's few percent) samples at most this many pairs: its untraced
# lookups of a smooth world need few, and 16 made the factory cube's frame 1.4x its time without the lobe. Under a
# picture, PICTURE_GLOSSY_PAIRS, each reading it blurred to its share of the lobe (picture_levels): from 4 the blur
# spreads a bright patch 35% over the lobe's integral at grazing angles, from 16 within 13%
WORLD_GLOSSY_PAIRS = 4
PICTURE_GLOSSY_PAIRS = 16


def world_glossy_pairs(scene: sc.Scene) -> int:
    """The pairs a glossy lobe of the world alone samples in the scene: WORLD_GLOSSY_PAIRS, or PICTURE_GLOSSY_PAIRS
    under a picture, at most render.glossy_samples."""
    most = PICTURE_GLOSSY_PAIRS if scene.background.type == "image" else WORLD_GLOSSY_PAIRS
    return min(most, scene.render.glossy_samples)


def glossy_pairs(samples: int) -> list[tuple[float, float]]:
    """A glossy lobe's sample numbers (u1, u2) in [0, 1)^2, the same at every hit: u1 = (i + 0.5) / samples (the
    radius of Heitz's disk of visible normals, stratified) and u2 = i times the golden angle's fraction of a turn,
    mod 1 (its angle, turning as hemisphere_directions' do). Rough glass turns them at each hit by a rotation of its
    own (camera.glass_rotation)."""
    return [((i + 0.5) / samples, (i * GOLDEN_TURN) % 1.0) for i in range(samples)]


def cone_axes(spot: sc.SpotLight) -> tuple[sc.Vec3, sc.Vec3]:
    """A stretched spot's unit axes across its axis (cone_scale's): x_axis made perpendicular to the axis, and the
    axis times that."""
    axis = tf.normalize(spot.direction)
    x = tf.normalize(tf.sub(spot.x_axis, tf.scale(axis, tf.dot(spot.x_axis, axis))))
    return x, tf.cross(axis, x)
