"""A prepared scene's hit points -> what their surfaces are there: the shading normals (smooth meshes' interpolated
corner normals, two-sided materials turned to face the ray), the material, specular and emission colours (a texture's
or a colour attribute's value at the hit), and the background the rays that miss see (a colour, a sky, a picture)."""

from __future__ import annotations

import math

import numpy as np

from ..geometry.kernels import column, dot, indices, interpolated_corners, spread, take, unit_or
from ..scene import picture_levels
from ..scene import scene as sc
from .batch import Hits
from .prepared import PreparedScene
from .texturing import attribute
from .texturing import sample as sample_texture


def hits(scene: PreparedScene, P: np.ndarray, V: np.ndarray, obj: np.ndarray, part: np.ndarray) -> Hits:
    """The points P (3, n) where rays from V's side (3, n) met the primitives part (n,) of the objects obj (n,) ->
    the hits with their normals, material rows, shading normals and colours."""
    N, surface = scene.normals(P, obj, part)
    material = scene.material_of(obj, part)
    S = shading_normals(scene, N, V, P, obj, part, material)
    colors, specular_colors, emission = surface_colors(scene, material, P, obj, part)
    return Hits(P, V, N, S, obj, part, material, surface, colors, specular_colors, emission)


def surface_colors(
    scene, material: np.ndarray, P: np.ndarray, obj: np.ndarray, part: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The hits' material colours (3, n), specular colours (3, n; None unless scene.colored) and emission (3, n;
    None unless scene.emissive): the material rows' own, and on a textured mesh the texture's sample at the hit's
    UV (the barycentric interpolation of its triangle's corner UVs, as smooth normals'): a texture replaces the
    colour (and the specular colour of a material without one), an emission texture the emission."""
    colors = scene.colors.take(material, axis=1)
    specular = scene.specular_colors.take(material, axis=1) if scene.colored else None
    emission = scene.emission.take(material, axis=1) if scene.emissive else None
    if not scene.textured:
        return colors, specular, emission
    for index in dict.fromkeys((*scene.uv_meshes, *scene.uv_instances, *scene.color_meshes, *scene.color_instances)):
        rows = indices(obj == index)
        if rows.size:
            rows = rows.take(indices(scene.has_texture.take(material.take(rows))))
        if not rows.size:
            continue
        triangle = part.take(rows)
        uv = _corner_values(scene, index, rows, triangle, P, scene.uv_meshes, scene.uv_instances)
        tint = _corner_values(scene, index, rows, triangle, P, scene.color_meshes, scene.color_instances)
        rows_material = material.take(rows)
        for row in np.unique(rows_material).tolist():
            mine = indices(rows_material == row)
            where = rows.take(mine)
            texture, glow = scene.row_textures[row], scene.row_emission_textures[row]
            value = _texture_value(scene, texture, uv, tint, mine)
            if value is not None:
                colors[:, where] = value
                if specular is not None and scene.scene.materials[scene.material_names[row]].specular_color is None:
                    specular[:, where] = value
            glowing = _texture_value(scene, glow, uv, tint, mine)
            if glowing is not None:
                emission[:, where] = glowing
    return colors, specular, emission


def _corner_values(
    scene, index: int, rows: np.ndarray, triangle: np.ndarray, P: np.ndarray, meshes: dict, instances: dict
) -> np.ndarray | None:
    """Object index's corner values (UVs or colours) interpolated at its hits rows (k, n), or None where it has
    none."""
    if index in meshes:
        v0, e1, e2, c0, c1, c2 = meshes[index]
        w = take(P, rows).astype(np.float64) - v0.take(triangle, axis=1)
        corners = (c.take(triangle, axis=1) for c in (c0, c1, c2))
        return interpolated_corners(w, e1.take(triangle, axis=1), e2.take(triangle, axis=1), *corners)
    if index in instances:
        return scene.kernels[index].corner_values(take(P, rows), triangle, instances[index])[0]
    return None


def _texture_value(
    scene, texture: sc.Texture | None, uv: np.ndarray | None, tint: np.ndarray | None, mine: np.ndarray
) -> np.ndarray | None:
    """A texture's colours (3, m) at the hits mine of the interpolated uv (2, n) or corner colours tint (3, n):
    an "attribute" texture by the colours, the others by the UVs; None where the mesh has not what it reads."""
    if texture is None:
        return None
    if texture.kind == "attribute":
        return None if tint is None else attribute(texture, tint.take(mine, axis=1)).astype(scene.dtype)
    if uv is None:
        return None
    return sample_texture(texture, uv[0].take(mine), uv[1].take(mine)).astype(scene.dtype)


def shading_normals(
    scene, N: np.ndarray, V: np.ndarray, P: np.ndarray, obj: np.ndarray, part: np.ndarray, material: np.ndarray
) -> np.ndarray:
    """The normals (3, n) that lighting and the mirror direction use: N (the geometric unit normals) where
    nothing changes them; a smooth mesh's interpolated corner normals; flipped where a two-sided material is
    hit from behind (N.V < 0, that is N.D > 0)."""
    S = N
    if scene.smooth_instances:
        S = np.array(N, copy=True)
        for index, corners in scene.smooth_instances.items():
            rows = indices(obj == index)
            if rows.size:
                unit = scene.kernels[index].smooth_normals(take(P, rows), part.take(rows), corners, take(N, rows))
                for axis in range(3):
                    S[axis][rows] = unit[axis]
    if scene.smooth:
        S = np.array(S, copy=True)
        for index, (v0, e1, e2, n0, n1, n2) in scene.smooth.items():
            rows = indices(obj == index)
            if not rows.size:
                continue
            triangle = part.take(rows)
            w = take(P, rows).astype(np.float64) - v0.take(triangle, axis=1)
            corners = (n.take(triangle, axis=1) for n in (n0, n1, n2))
            n = interpolated_corners(w, e1.take(triangle, axis=1), e2.take(triangle, axis=1), *corners)
            unit = unit_or(n, take(N, rows))  # the flat normal where the corners cancel
            for axis in range(3):
                S[axis][rows] = unit[axis]
    if scene.any_two_sided:
        flip = scene.two_sided.take(material) & (dot(N, V) < 0.0)
        if flip.any():
            S = np.where(flip, -S, S)
    return S


def background(scene: PreparedScene, D: np.ndarray, miss: np.ndarray | None) -> np.ndarray:
    """Colors (3, n) for the rays miss (n,) of rays D (3, N), which hit nothing (a sky reads only their z);
    miss None: for every ray (3, N)."""
    background = scene.scene.background
    count = D.shape[1] if miss is None else miss.size
    if background.type == "none":
        return np.zeros((3, count), dtype=scene.dtype)
    if background.type == "solid":
        return np.broadcast_to(column(background.color, scene.dtype), (3, count))
    if background.type == "documented":
        return np.broadcast_to(scene.documented_color, (3, count))
    if background.type == "image":
        seen = D if miss is None or D.shape[1] == 1 else take(D, miss)
        return spread(environment(background, seen).astype(scene.dtype, copy=False), (3, count))
    z = D[2] if D.shape[1] == 1 or miss is None else D[2].take(miss)  # one direction for all, or each ray's own
    k = np.minimum(np.maximum(z, 0.0), 1.0)
    horizon = column(background.horizon, scene.dtype)
    zenith = column(background.zenith, scene.dtype)
    return spread(horizon + (zenith - horizon) * k, (3, count))


def blurred_environment(background: sc.Background, D: np.ndarray, solid_angles: np.ndarray) -> np.ndarray:
    """An image background's colours (3, n) float64 along directions D (3, n), each blurred to the solid angle (n,) its
    sample stands for (picture_levels): environment() at the two levels around picture_levels.level's, a + (b - a) t
    between them (a alone where t is 0), the same operations as reference.blurred_environment."""
    chain = picture_levels.levels(background)
    level = np.minimum(picture_levels.levels_of(solid_angles, background), len(chain) - 1)
    low = np.floor(level).astype(np.int64)
    between = level - low
    u, v = _equirectangular(background, D)  # the same at every level
    colors = np.empty((3, D.shape[1]), dtype=np.float64)
    for k in np.unique(low).tolist():
        rows = indices(low == k)
        colors[:, rows] = _texels(chain[k], u.take(rows), v.take(rows))
        mixed = rows.take(indices(between.take(rows) > 0.0))
        if mixed.size:
            a = colors[:, mixed]
            colors[:, mixed] = a + (_texels(chain[k + 1], u.take(mixed), v.take(mixed)) - a) * between.take(mixed)
    return colors


def environment(background: sc.Background, D: np.ndarray) -> np.ndarray:
    """An image background's colours (3, n) float64 for directions D (3, n): Blender's equirectangular (u, v)
    (lightsamples.equirectangular, the same operations on arrays), then the texel by Cycles' rules: linear, bilinear
    between the texel centres around (u W - 0.5, v H - 0.5), v counted from the picture's bottom, wrapping around in
    u and clamped at the poles; closest, the texel (floor(u W), floor(v H)); times the strength."""
    return _texels(background, *_equirectangular(background, D))


def _equirectangular(background: sc.Background, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directions D (3, n) -> Blender's equirectangular (u, v) (n,) each, turned by the background's rotation."""
    x, y, z = (np.asarray(axis, dtype=np.float64) for axis in D)
    if background.rotation != 0.0:
        c, s = math.cos(math.radians(background.rotation)), math.sin(math.radians(background.rotation))
        x, y = c * x - s * y, s * x + c * y
    return 0.5 - np.arctan2(y, x) / (2.0 * math.pi), 0.5 + np.arctan2(z, np.hypot(x, y)) / math.pi


def _texels(background: sc.Background, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The background's picture at (u, v) (n,) each by Cycles' rules (environment()), times its strength: (3, n)."""
    image = background.image
    height, width = image.shape[:2]
    if background.interpolation == "closest":
        column_ = np.floor(u * width).astype(np.int64) % width
        row = height - 1 - np.clip(np.floor(v * height).astype(np.int64), 0, height - 1)
        color = image[row, column_].T.astype(np.float64)
    else:
        px, py = u * width - 0.5, v * height - 0.5
        fx, fy = np.floor(px), np.floor(py)
        tx, ty = px - fx, py - fy
        x0 = fx.astype(np.int64) % width
        x1 = (x0 + 1) % width
        y0 = height - 1 - np.clip(fy.astype(np.int64), 0, height - 1)  # rows from the top
        y1 = height - 1 - np.clip(fy.astype(np.int64) + 1, 0, height - 1)
        # rows of a (H W, 3) view gathered by one index each: a third of the time of image[r, c] (a copy where the
        # picture is not contiguous)
        rows = image.reshape(height * width, image.shape[2])
        texel = lambda r, c: rows.take(r * width + c, axis=0).T.astype(np.float64)  # noqa: E731
        color = (1.0 - ty) * ((1.0 - tx) * texel(y0, x0) + tx * texel(y0, x1)) + ty * (
            (1.0 - tx) * texel(y1, x0) + tx * texel(y1, x1)
        )
    return color * background.strength if background.strength != 1.0 else color
