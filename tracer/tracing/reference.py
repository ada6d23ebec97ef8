"""The per-pixel oracle: the seed's listings 3.1 (TraceRay) and 3.2 (FindIntensity), one ray at a time.

Plain Python floats and tuples, no NumPy, written to be read beside the seed rather than to be fast (about 19 s for
a 640x480 frame). The vectorized tracer must equal it to 1e-9 on every pixel.

Its render passes, one camera sample at a time, are reference_passes.py's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.transforms import add, cross, dot, length, scale, sub
from ..scene import picture_levels, world_light
from ..scene import scene as sc
from . import reference_glossy

INF = math.inf
CAMERA_T_MIN = 0.0  # seed 2.10: t >= 0, hits behind the camera are dropped
SHADOW_T_MIN = 0.001  # listing 3.2
REFLECTION_T_MIN = 0.01  # listing 3.1
MIRROR, GLOSSY, DIFFUSE = 0, 1, 2  # what kind of ray a path's last one is (camera rays: trace_ray's camera)
NEW_PATH = (-1, 0, MIRROR)  # trace_ray's path: no glossy pair yet, no diffuse bounce


def normalize(v: sc.Vec3) -> sc.Vec3:
    size = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / size, v[1] / size, v[2] / size)


def reflect_ray(X: sc.Vec3, N: sc.Vec3) -> sc.Vec3:
    """Seed 2.9 for X pointing away from the surface: R = 2 N (N.X) - X."""
    k = 2.0 * dot(N, X)
    return (N[0] * k - X[0], N[1] * k - X[1], N[2] * k - X[2])


def fresnel(cosine: float, eta: float) -> float:
    """The unpolarized reflectance of a dielectric boundary (Cycles' fresnel_dielectric_cos): cosine = |D.N| of the
    incoming ray, eta the index behind the boundary over the index in front; 1 beyond the critical angle."""
    c = abs(cosine)
    g = eta * eta - 1.0 + c * c
    if not g > 0.0:
        return 1.0
    g = math.sqrt(g)
    A = (g - c) / (g + c)
    B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return 0.5 * A * A * (1.0 + B * B)


def refract(D: sc.Vec3, N: sc.Vec3, eta: float) -> tuple[float, sc.Vec3 | None]:
    """A ray along D meeting a boundary with unit normal N facing it (N.D <= 0), eta = n behind / n in front ->
    (F, the refracted unit direction), or (1, None) in total internal reflection. With d = D / |D|, c = -d.N and
    g = sqrt(eta^2 - 1 + c^2): T = (d + (c - g) N) / eta, normalised (Snell's law: sin t = sin i / eta)."""
    d = normalize(D)
    c = -dot(d, N)
    g = eta * eta - 1.0 + c * c
    if not g > 0.0:
        return 1.0, None
    g = math.sqrt(g)
    A = (g - c) / (g + c)
    B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    k = c - g
    T = ((d[0] + k * N[0]) / eta, (d[1] + k * N[1]) / eta, (d[2] + k * N[2]) / eta)
    return 0.5 * A * A * (1.0 + B * B), normalize(T)


# ---- intersections (seed 2.5): each returns [(t, part), ...] for t in (t_min, t_max) ------------------------------


def _sphere(O: sc.Vec3, D: sc.Vec3, s: tf.WorldSphere) -> list[tuple[float, int]]:
    CO = sub(O, s.center)
    k1 = dot(D, D)
    k2 = 2.0 * dot(CO, D)
    k3 = dot(CO, CO) - s.radius * s.radius
    discriminant = k2 * k2 - 4.0 * k1 * k3
    if discriminant < 0.0:
        return []
    root = math.sqrt(discriminant)
    return [((-k2 + root) / (2.0 * k1), 0), ((-k2 - root) / (2.0 * k1), 0)]


def _plane_t(O: sc.Vec3, D: sc.Vec3, normal: sc.Vec3, point: sc.Vec3) -> float | None:
    """Seed 2.17: t = (V, OC) / (V, D); None for a ray parallel to the plane."""
    denominator = dot(normal, D)
    if denominator == 0.0:
        return None
    return dot(normal, sub(point, O)) / denominator


def _plane(O: sc.Vec3, D: sc.Vec3, p: tf.WorldPlane) -> list[tuple[float, int]]:
    t = _plane_t(O, D, p.normal, p.point)
    if t is None:
        return []
    if p.half_size is not None:
        offset = sub(add(O, scale(D, t)), p.point)
        if abs(dot(offset, p.u_axis)) > p.half_size[0] or abs(dot(offset, p.v_axis)) > p.half_size[1]:
            return []
    return [(t, 0)]


def _cylinder(O: sc.Vec3, D: sc.Vec3, c: tf.WorldCylinder) -> list[tuple[float, int]]:
    """Side (2.23, part 0) with 0 <= h <= H, then the bottom (part 1) and top (part 2) caps."""
    hits: list[tuple[float, int]] = []
    CO = sub(O, c.base)
    DV = dot(D, c.axis)
    COV = dot(CO, c.axis)
    a = dot(D, D) - DV * DV
    b = 2.0 * (dot(CO, D) - COV * DV)
    k = dot(CO, CO) - COV * COV - c.radius * c.radius
    discriminant = b * b - 4.0 * a * k
    if a != 0.0 and discriminant >= 0.0:
        root = math.sqrt(discriminant)
        for t in ((-b + root) / (2.0 * a), (-b - root) / (2.0 * a)):
            h = COV + DV * t
            if 0.0 <= h <= c.height:
                hits.append((t, 0))
    top = add(c.base, scale(c.axis, c.height))
    down = (-c.axis[0], -c.axis[1], -c.axis[2])
    for part, normal, centre in ((1, down, c.base), (2, c.axis, top)):
        t = _plane_t(O, D, normal, centre)
        if t is None:
            continue
        offset = sub(add(O, scale(D, t)), centre)
        if dot(offset, offset) <= c.radius * c.radius:
            hits.append((t, part))
    return hits


@dataclass(frozen=True)
class PlainTriangles:
    """A mesh's world triangles and unit normals (tf.WorldTriangles' numbers) as tuples of Python floats: the oracle
    computes in plain floats, one triangle at a time."""

    triangles: tuple[tuple[sc.Vec3, sc.Vec3, sc.Vec3], ...]
    normals: tuple[sc.Vec3, ...]


@dataclass(frozen=True)
class PlainInstances:
    """A mesh placed K times (tf.WorldInstances' numbers as tuples of floats): the mesh's triangles in its own
    space, and per instance the rows of [A^-1 | c] (local = A^-1 world + c), of the placing matrix [A | b] and of the
    cofactor |det(A)| A^-T (a local normal -> the placed triangle's, outward for a mirroring A too)."""

    mesh: PlainTriangles
    inverses: tuple[tuple[tuple[float, ...], ...], ...]
    matrices: tuple[tuple[tuple[float, ...], ...], ...]
    cofactors: tuple[tuple[sc.Vec3, sc.Vec3, sc.Vec3], ...]


def _affine(rows: tuple[tuple[float, ...], ...], X: sc.Vec3, translate: bool) -> sc.Vec3:
    """rows (3 of 3 or 4 numbers) applied to X, summed left to right; translate: the fourth column added."""
    return tuple(
        row[0] * X[0] + row[1] * X[1] + row[2] * X[2] + row[3]
        if translate
        else row[0] * X[0] + row[1] * X[1] + row[2] * X[2]
        for row in rows
    )  # type: ignore[return-value]


def plain_primitive(primitive: tf.WorldPrimitive) -> tf.WorldPrimitive | PlainTriangles | PlainInstances:
    """The primitive with a mesh's arrays turned into tuples of floats (the same numbers); others as they are."""
    if isinstance(primitive, tf.WorldInstances):
        as_tuples = lambda array: tuple(tuple(map(tuple, matrix)) for matrix in array.tolist())  # noqa: E731
        return PlainInstances(
            plain_primitive(primitive.mesh),
            as_tuples(primitive.inverses),
            as_tuples(primitive.matrices),
            as_tuples(primitive.cofactors),
        )
    if not isinstance(primitive, tf.WorldTriangles):
        return primitive
    triangles = tuple(tuple(map(tuple, triangle)) for triangle in primitive.triangles.tolist())
    return PlainTriangles(triangles, tuple(map(tuple, primitive.normals.tolist())))


def _triangles(O: sc.Vec3, D: sc.Vec3, mesh: PlainTriangles) -> list[tuple[float, int]]:
    """Moller-Trumbore as the seed writes it (2.29), one triangle at a time; part = triangle index."""
    hits: list[tuple[float, int]] = []
    for index, (V0, V1, V2) in enumerate(mesh.triangles):
        E1 = sub(V1, V0)
        E2 = sub(V2, V0)
        T = sub(O, V0)
        P = cross(D, E2)
        Q = cross(T, E1)
        determinant = dot(P, E1)
        if determinant == 0.0:
            continue
        t = dot(Q, E2) / determinant
        u = dot(P, T) / determinant
        v = dot(Q, D) / determinant
        if u >= 0.0 and v >= 0.0 and u + v <= 1.0:
            hits.append((t, index))
    return hits


def _hits(O: sc.Vec3, D: sc.Vec3, primitive: tf.WorldPrimitive | PlainTriangles) -> list[tuple[float, int]]:
    if isinstance(primitive, tf.WorldSphere):
        return _sphere(O, D, primitive)
    if isinstance(primitive, tf.WorldPlane):
        return _plane(O, D, primitive)
    if isinstance(primitive, tf.WorldCylinder):
        return _cylinder(O, D, primitive)
    if isinstance(primitive, PlainInstances):
        return _instances(O, D, primitive)
    return _triangles(O, D, primitive)


def _instances(O: sc.Vec3, D: sc.Vec3, placed: PlainInstances) -> list[tuple[float, int]]:
    """Each instance in turn: the ray taken into its space (O' = A^-1 O + c, D' = A^-1 D, not normalised, so t is
    the world's parameter) and tested against the mesh's triangles there; part = instance * T + triangle."""
    hits: list[tuple[float, int]] = []
    count = len(placed.mesh.triangles)
    for instance, rows in enumerate(placed.inverses):
        local_O, local_D = _affine(rows, O, True), _affine(rows, D, False)
        hits.extend((t, instance * count + part) for t, part in _triangles(local_O, local_D, placed.mesh))
    return hits


def find_normal(primitive: tf.WorldPrimitive | PlainTriangles, part: int, P: sc.Vec3) -> sc.Vec3:
    """The surface normal at P (not yet normalised, as findNormal in listing 3.1)."""
    if isinstance(primitive, tf.WorldSphere):
        return sub(P, primitive.center)
    if isinstance(primitive, tf.WorldPlane):
        return primitive.normal
    if isinstance(primitive, tf.WorldCylinder):
        if part == 1:
            return (-primitive.axis[0], -primitive.axis[1], -primitive.axis[2])
        if part == 2:
            return primitive.axis
        h = dot(sub(P, primitive.base), primitive.axis)
        return sub(P, add(primitive.base, scale(primitive.axis, h)))
    if isinstance(primitive, PlainInstances):
        instance, triangle = divmod(part, len(primitive.mesh.triangles))
        return _affine(primitive.cofactors[instance], primitive.mesh.normals[triangle], False)
    return primitive.normals[part]


def instance_normal(placed: PlainInstances, part: int, corners: list, P: sc.Vec3) -> sc.Vec3 | None:
    """An instanced mesh's smooth normal at P: P taken into the instance's space, the corner normals corners
    (local, T x 3 x 3) interpolated at its barycentric coordinates there, placed by the cofactor, normalised (None
    where the interpolation is zero)."""
    instance, triangle = divmod(part, len(placed.mesh.triangles))
    local = _affine(placed.inverses[instance], P, True)
    n = _interpolated(placed.mesh.triangles[triangle], corners[triangle], local)
    return _unit_or_none(_affine(placed.cofactors[instance], n, False))


def world_light_sample(
    tracer: ReferenceTracer, light: sc.WorldLight, local: sc.Vec3, N: sc.Vec3
) -> tuple[sc.Vec3, sc.Color]:
    """A world light's direction local at the normal N of the sample being traced (world_direction), and its
    colour: the light's colour times, where it takes the background's radiance, that radiance along the direction;
    under an image background (world_light.lighting) the direction's weight times the irradiance at N over 2 / count
    times the sum of z weight over all the light's directions (what shading._world_radiance sums by moments)."""
    settings, pixel, sample = tracer.settings, tracer.image_pixel, tracer.camera_sample
    direction = world_direction(settings, light, local, N, pixel, sample)
    if light.radiance != "background":
        return direction, light.color
    lighting = tracer.world_lighting
    if lighting is None:
        radiance = tracer.background(direction)
    else:
        directions = lightsamples.hemisphere_directions(light.samples)
        mean = [0.0, 0.0, 0.0]
        for other in directions:
            seen = lighting.weight(world_direction(settings, light, other, N, pixel, sample))
            mean = [mean[c] + (2.0 / len(directions) * other[2]) * seen[c] for c in range(3)]
        at_normal, along = environment(lighting.irradiance, normalize(N)), lighting.weight(direction)
        radiance = tuple(along[c] * (at_normal[c] / mean[c] if mean[c] > 0.0 else 0.0) for c in range(3))
    return direction, tuple(radiance[c] * light.color[c] for c in range(3))


def world_direction(
    settings: sc.RenderSettings, light: sc.WorldLight, local: sc.Vec3, N: sc.Vec3, pixel: int, sample: int
) -> sc.Vec3:
    """A world light's direction local (x, y, z) in the frame of the normal N at sample `sample` of the flat pixel:
    x e1 + y e2 + z n, n = N / |N| and e1, e2 facing_basis(n) turned about n by the pixel's turn (camera.world_turn;
    not in adaptive sampling's flagging pass, render.adaptive_flags)."""
    n = normalize(N)
    e1, e2 = lightsamples.facing_basis(n)
    if not settings.adaptive_flags:
        cos, sin = cam.world_turn(settings, pixel, sample, lightsamples.world_share(settings, light.samples))
        e1, e2 = tuple(cos * e1[k] + sin * e2[k] for k in range(3)), tuple(cos * e2[k] - sin * e1[k] for k in range(3))
    return tuple(local[0] * e1[k] + local[1] * e2[k] + local[2] * n[k] for k in range(3))


def spot_cosine(spot: sc.SpotLight, light_vector: sc.Vec3) -> float:
    """The cosine at the spot between its axis and the point light_vector came from (L, toward the light): of the
    direction in the cone's unstretched frame where it has a cone_scale (Cycles 4's scaled ray)."""
    cosine = -dot(light_vector, normalize(spot.direction)) / length(light_vector)
    if spot.cone_scale != (1.0, 1.0):
        x, y = lightsamples.cone_axes(spot)
        u = -dot(light_vector, x) / (length(light_vector) * spot.cone_scale[0])
        v = -dot(light_vector, y) / (length(light_vector) * spot.cone_scale[1])
        cosine = cosine / math.sqrt(u * u + v * v + cosine * cosine)
    return cosine


def spot_attenuation(cosine: float, spot: sc.SpotLight) -> float:
    """Cycles' spot attenuation at a point seen from the light at this cosine to the axis (docs/scene-format.md).

    cycles4 (Blender 4.x and 5.0, intern/cycles/kernel/light/spot.h): smoothstep((c - cos_half) * spot_smooth), with
    spot_smooth = 1 / ((1 - cos_half) * blend) and smoothstep(f) = 0 below 0, 1 above 1, else 3 f^2 - 2 f^3.
    cycles3 (Blender 3.4 and before): 0 where c <= cos_half; else c times smoothstep(t / ((1 - cos_half) * blend)) while
    t = c - cos_half is below (1 - cos_half) * blend, and c beyond. Blend 0: a hard edge."""
    cos_half = math.cos(math.radians(spot.spot_size) / 2.0)
    width = (1.0 - cos_half) * spot.spot_blend
    if not cosine > cos_half:
        return 0.0
    if width == 0.0:
        step = 1.0
    else:
        f = min(max((cosine - cos_half) / width, 0.0), 1.0)
        ff = f * f
        step = 3.0 * ff - 2.0 * ff * f
    return cosine * step if spot.spot_model == "cycles3" else step


def barycentric_normal(triangle: tuple[sc.Vec3, sc.Vec3, sc.Vec3], corners: list, P: sc.Vec3) -> sc.Vec3 | None:
    """The normalised interpolation (1 - u - v, u, v) of a triangle's corner normals at P (None if it is zero)."""
    return _unit_or_none(_interpolated(triangle, corners, P))


def _interpolated(triangle: tuple[sc.Vec3, sc.Vec3, sc.Vec3], corners: list, P: sc.Vec3) -> sc.Vec3:
    """A triangle's corner normals weighted by P's barycentric coordinates (1 - u - v, u, v), not normalised."""
    v0, v1, v2 = triangle
    e1, e2, w = sub(v1, v0), sub(v2, v0), sub(P, v0)
    d00, d01, d11 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    d20, d21 = dot(w, e1), dot(w, e2)
    denominator = d00 * d11 - d01 * d01
    u = (d11 * d20 - d01 * d21) / denominator
    v = (d00 * d21 - d01 * d20) / denominator
    s = 1.0 - u - v
    n0, n1, n2 = corners
    return tuple(n0[i] * s + n1[i] * u + n2[i] * v for i in range(3))  # type: ignore[return-value]


def _unit_or_none(n: sc.Vec3) -> sc.Vec3 | None:
    """n normalised, or None where it is zero (opposite corner normals can cancel)."""
    size = math.sqrt(dot(n, n))
    if not size > 0.0:
        return None
    return (n[0] / size, n[1] / size, n[2] / size)


def _colored(scene: sc.Scene) -> bool:
    """Whether the scene needs colours rather than the documented one intensity per point: a coloured or glossy
    material, or a coloured, falling-off, spot, area or world light."""
    materials = scene.materials.values()
    return any(m.specular_color is not None or m.is_glossy for m in materials) or any(
        light.color != sc.WHITE
        or getattr(light, "falloff", "none") != "none"
        or isinstance(light, sc.SpotLight | sc.AreaLight | sc.WorldLight)
        for light in scene.lights
    )


def seen_in_mirrors(scene: sc.Scene) -> tuple[list[sc.AreaLight], list[sc.DirectionalLight]]:
    """The scene's area lights and suns (of an angle above 0) that mirror rays see (seen_in_mirrors)."""
    lights = [light for light in scene.lights if isinstance(light, sc.AreaLight) and light.seen_in_mirrors]
    suns = [
        light
        for light in scene.lights
        if isinstance(light, sc.DirectionalLight) and light.seen_in_mirrors and light.angle > 0.0
    ]
    return lights, suns


class ReferenceTracer:
    """Traces one ray at a time exactly as the listings do; counts rays by kind."""

    def __init__(self, scene: sc.Scene) -> None:
        self.scene = scene
        self.settings = scene.render
        self.primitives = [plain_primitive(primitive) for primitive in tf.world_primitives(scene)]
        self.rays = {"camera": 0, "shadow": 0, "reflection": 0}
        self.documented_direction = cam.documented_background_direction(scene.camera, scene.render)
        self.corners = [tf.world_corner_normals(obj, scene.vane) for obj in scene.objects]
        self.corners = [None if c is None else c.tolist() for c in self.corners]
        self.instance_corners = [  # an instanced mesh's corner normals, in its own space
            obj.normals.tolist() if isinstance(obj, sc.MeshInstances) and obj.normals is not None else None
            for obj in scene.objects
        ]
        self.colored = _colored(scene)
        self.lights = light_samples(scene)
        self.camera_sample = 0  # the pixel's sample being traced: which world directions it takes
        self.image_pixel = 0  # the flat pixel j * W + i being traced: its turn of the world directions
        self.glossy_pairs = lightsamples.glossy_pairs(scene.render.glossy_samples)
        self.sky = True  # a miss brings the background (False: nothing, for the passes' split of a tree)
        self.seen_lights, self.seen_suns = seen_in_mirrors(scene)
        self.world_pairs = lightsamples.glossy_pairs(lightsamples.world_glossy_pairs(scene))  # a lobe of the world
        self.world_lighting = world_light.lighting(scene)  # under a picture: what the world light is lit by
        # shadow rays pass partly transparent surfaces (shadow_through) where some material has alpha < 1
        self.shadow_alpha = any(m.alpha < 1.0 for m in scene.materials.values())
        self.serial = 0  # the camera sample being traced (camera.sample_serial): rough glass's rotations

    def material(self, index: int, part: int) -> sc.Material:
        """The material of object index's part (a mesh's triangle may have its own)."""
        return self.scene.materials[self.material_name(index, part)]

    def material_name(self, index: int, part: int) -> str:
        """The name of the material of object index's part."""
        obj = self.scene.objects[index]
        if getattr(obj, "material_indices", None) is not None:
            if isinstance(obj, sc.MeshInstances):
                part %= len(obj.mesh.triangles)  # instance * T + triangle
            return obj.materials[obj.material_indices[part]]
        return obj.material

    def closest_intersection(
        self, O: sc.Vec3, D: sc.Vec3, t_min: float, t_max: float, seen_by: str = ""
    ) -> tuple[int, int, float]:
        """(object index or -1, part, t): the nearest hit with t_min < t < t_max, first object on ties. seen_by:
        only the objects whose flag of that name is true (visible_camera, visible_shadow, visible_reflection)."""
        closest_t = INF
        closest_object = -1
        closest_part = 0
        for index, primitive in enumerate(self.primitives):
            if seen_by and not getattr(self.scene.objects[index], seen_by):
                continue
            for t, part in _hits(O, D, primitive):
                if t_min < t < t_max and t < closest_t:
                    closest_t, closest_object, closest_part = t, index, part
        return closest_object, closest_part, closest_t

    def background(self, D: sc.Vec3, solid_angle: float | None = None) -> sc.Color:
        background = self.scene.background
        if background.type == "none":
            return (0.0, 0.0, 0.0)
        if background.type == "solid":
            return background.color
        if background.type == "image":  # blurred to the solid angle a glossy sample stands for, where given
            return blurred_environment(background, D, solid_angle) if solid_angle else environment(background, D)
        direction = self.documented_direction if background.type == "documented" else D
        k = min(max(direction[2], 0.0), 1.0)
        h, z = background.horizon, background.zenith
        return (h[0] + (z[0] - h[0]) * k, h[1] + (z[1] - h[1]) * k, h[2] + (z[2] - h[2]) * k)

    def find_intensity(self, P: sc.Vec3, N: sc.Vec3, V: sc.Vec3, specular: float) -> float:
        """Listing 3.2 (white lights, no attenuation: the documented mode)."""
        return self.find_intensities(P, N, V, specular)[0][0]

    def find_intensities(
        self,
        P: sc.Vec3,
        N: sc.Vec3,
        V: sc.Vec3,
        specular: float,
        split: dict | None = None,
        lobe: reference_glossy.Lobe | None = None,
    ) -> tuple[list[float], list[float]]:
        """Listing 3.2 with each light's colour and attenuation. Documented mode (self.colored false): the whole
        intensity, summed in the listing's order, in every channel of the first list. Else the (ambient + diffuse,
        specular) sums per channel. The reason for its length: one function that reads beside the listing it is
        the oracle of, one light at a time.

        split: a dict to fill with the same terms apart, for the render passes: "ambient", "diffuse" and "specular"
        (each a list of 3: per channel where coloured, else the documented scalar sum in every channel) and "shadow",
        the share of the lights other than ambient that reach P: its shadow ray is not blocked, the light's factor
        is above 0 (a spot light's cone), and P faces the light (N.L > 0) or gets its highlight. 1 without such
        lights.

        lobe: a glossy surface's lobe at P, whose light (r, g, b) is set to what the lights (not ambient, not the
        world's directions) that reach P add through it."""
        total = 0.0
        diffuse = [0.0, 0.0, 0.0]
        highlight = [0.0, 0.0, 0.0]
        length_n = length(N)
        length_v = length(V)
        ambient_sum, diffuse_sum, highlight_sum = 0.0, 0.0, 0.0  # the documented mode's terms apart (split)
        ambient, lights_diffuse = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]  # the coloured mode's terms apart (split)
        lights, reached = 0, 0
        shine = [0.0, 0.0, 0.0]  # through the glossy lobe
        for light, where, intensity, weight, emitter, disk, index, count, patterns in self.lights:
            color = light.color
            if isinstance(light, sc.AmbientLight):
                total += light.intensity
                diffuse = [diffuse[c] + light.intensity * color[c] for c in range(3)]
                ambient_sum += light.intensity
                ambient = [ambient[c] + light.intensity * color[c] for c in range(3)]
                continue
            if index is not None:  # a light of a size's sample or a world direction: which, of how many
                boost = sample_boost(self.settings, self.image_pixel, self.camera_sample, index, count, patterns)
                if not boost:
                    continue
                intensity, weight = intensity * boost, weight * boost
            lights += weight
            factor = 1.0
            if isinstance(light, sc.PointLight | sc.SpotLight):
                light_vector = sub(light.location, P)
                if disk is not None:  # a sample on the disk of the light's radius that faces P
                    e1, e2 = lightsamples.facing_basis(normalize(light_vector))
                    offset = tuple(disk[0] * e1[k] + disk[1] * e2[k] for k in range(3))
                    light_vector = add(light_vector, offset)
                t_max = 1.0
                if isinstance(light, sc.SpotLight):
                    factor = spot_attenuation(spot_cosine(light, light_vector), light)
                if light.falloff == "inverse_square":
                    falloff = 1.0 / dot(light_vector, light_vector)
                    factor = falloff if not isinstance(light, sc.SpotLight) else factor * falloff
            elif isinstance(light, sc.WorldLight):  # a direction of P's hemisphere, the background's radiance along it
                light_vector, color = world_light_sample(self, light, where, N)
                t_max = INF
            elif emitter is not None:  # an area light's sample point: a one-sided cosine emitter, inverse square
                light_vector = sub(where, P)
                t_max = 1.0
                factor = max(-dot(light_vector, emitter) / length(light_vector), 0.0)
                factor = factor * (1.0 / dot(light_vector, light_vector))
            else:
                light_vector = where
                t_max = INF
            through = 1.0  # the share of the light that passes partly transparent surfaces (alpha < 1)
            if self.settings.adaptive_flags and isinstance(light, sc.WorldLight):
                pass  # adaptive sampling's flagging pass: the world light unshadowed
            elif self.shadow_alpha:
                through = shadow_through(self, P, light_vector, t_max)
                if through <= 0.0:
                    continue
                intensity = intensity * through  # every term of this light
            else:
                self.rays["shadow"] += 1
                shadow_object, _, _ = self.closest_intersection(P, light_vector, SHADOW_T_MIN, t_max, "visible_shadow")
                if shadow_object >= 0:
                    continue
            adds_diffuse, adds_glossy = getattr(light, "visible_diffuse", True), getattr(light, "visible_glossy", True)
            through_lobe = reference_glossy.through_lobe(lobe, light, light_vector)
            if through_lobe is not None:
                shine = [shine[c] + (intensity * through_lobe[c]) * factor * color[c] for c in range(3)]
            NL = dot(N, light_vector)
            if NL > 0.0 and adds_diffuse:
                term = intensity * NL / (length_n * length(light_vector))
                total += term
                diffuse = [diffuse[c] + (term * factor) * color[c] for c in range(3)]
                diffuse_sum += term
                lights_diffuse = [lights_diffuse[c] + (term * factor) * color[c] for c in range(3)]
            term = None
            if adds_glossy and not (
                specular <= 0.0 or (self.settings.gate_specular and NL <= 0.0) or isinstance(light, sc.WorldLight)
            ):
                if self.settings.model == "phong":
                    R = reflect_ray(light_vector, N)
                    RV = dot(R, V)
                    if RV > 0.0:
                        term = intensity * (RV / (length(R) * length_v)) ** specular
                else:
                    H = add(normalize(light_vector), normalize(V))
                    HN = dot(H, N)
                    if HN > 0.0:
                        term = intensity * (HN / (length(H) * length_n)) ** (specular * self.settings.coef)
            if term is not None:
                total += term
                highlight = [highlight[c] + (term * factor) * color[c] for c in range(3)]
                highlight_sum += term
            if ((NL > 0.0 and adds_diffuse) or term is not None) and factor > 0.0:
                reached += weight * through
        if lobe is not None:
            lobe.shine = tuple(shine)
        if split is not None:
            split["shadow"] = reached / lights if lights else 1.0
            if self.colored:
                split.update(ambient=ambient, diffuse=lights_diffuse, specular=highlight)
            else:
                split.update(ambient=[ambient_sum] * 3, diffuse=[diffuse_sum] * 3, specular=[highlight_sum] * 3)
        if not self.colored:
            return [total, total, total], [0.0, 0.0, 0.0]
        return diffuse, highlight

    def shading_normal(self, index: int, part: int, P: sc.Vec3, V: sc.Vec3, material: sc.Material) -> sc.Vec3:
        """The unit normal a hit at P on object index's part is shaded with: the surface's own, or the corner
        normals interpolated (smooth meshes and instances), flipped on the back of a two-sided material."""
        N = normalize(find_normal(self.primitives[index], part, P))
        S = N
        corners = self.corners[index]
        if corners is not None:
            S = barycentric_normal(self.primitives[index].triangles[part], corners[part], P) or N
        instance_corners = self.instance_corners[index]
        if instance_corners is not None:
            S = instance_normal(self.primitives[index], part, instance_corners, P) or N
        if material.two_sided and dot(N, V) < 0.0:
            S = (-S[0], -S[1], -S[2])
        return S

    def textured(self, material: sc.Material, index: int, part: int, P: sc.Vec3) -> sc.Material:
        """The material as a hit at P on object index's part sees it: where the material has a texture (an emission
        texture) and the object corner UVs, its colour (emission) replaced by the texture's sample at P's UV, the
        corner UVs weighted by P's barycentric coordinates (as smooth normals'; an instance's in its own space)."""
        if material.texture is None and material.emission_texture is None:
            return material
        obj = self.scene.objects[index]
        if getattr(obj, "uvs", None) is None and getattr(obj, "colors", None) is None:
            return material
        from dataclasses import replace

        changes = {}
        for field, texture in (("color", material.texture), ("emission", material.emission_texture)):
            value = texture_value(self, texture, index, part, P)
            if value is not None:
                changes[field] = value
        return replace(material, **changes)

    def trace_ray(
        self,
        O: sc.Vec3,
        D: sc.Vec3,
        t_min: float,
        t_max: float,
        depth: int,
        camera: bool = False,
        layers: int = 0,
        path: tuple[int, int, int] = NEW_PATH,
    ) -> sc.Color:
        """Listing 3.1. camera: the camera ray (it sees the visible_camera objects, and nothing through a
        transparent film), or its straight continuation through partly transparent surfaces; the others are mirror
        (and refracted) rays. layers: the straight continuations on the path so far (sc.TRANSPARENT_BOUNCES).
        path: the pair the path took at its first glossy surface or diffuse bounce (-1: none yet), its diffuse
        bounces so far, and the kind of ray this one is: MIRROR (mirror, refracted, rough glass: it sees the area
        lights seen in mirrors), GLOSSY (a glossy lobe's), DIFFUSE (a bounce: its miss adds nothing, the world's
        light is the world light's). The reason for 8 parameters: the ray and its path's whole state."""
        seen_by = "visible_camera" if camera else "visible_reflection"
        closest_object, part, closest_t = self.closest_intersection(O, D, t_min, t_max, seen_by)
        if not camera and path[2] == MIRROR and self.seen_lights:
            lamp = seen_light(self.seen_lights, O, D, t_min, closest_t if closest_object >= 0 else INF)
            if lamp is not None:
                return lamp
        if closest_object < 0:  # a mirror ray's suns are not the sky's (the passes' split counts them as lights)
            if path[2] == DIFFUSE:
                return (0.0, 0.0, 0.0)
            sun = seen_sun(self.seen_suns, D) if not camera and path[2] == MIRROR else (0.0, 0.0, 0.0)
            shown = self.sky and not (camera and self.settings.film_transparent)
            return add(sun, self.background(D)) if shown else sun
        if self.scene.objects[closest_object].holdout:
            return (0.0, 0.0, 0.0)
        P = add(O, scale(D, closest_t))
        material = self.material(closest_object, part)
        material = self.textured(material, closest_object, part, P)
        V = (-D[0], -D[1], -D[2])
        S = self.shading_normal(closest_object, part, P, V, material)
        if material.transmission > 0.0 or material.alpha < 1.0:
            hit = (closest_object, part)
            return self.see_through(P, D, S, hit, t_max - closest_t, depth, camera, layers, material, path)
        return self.today(P, V, S, material, depth, layers, path)

    def see_through(
        self,
        P: sc.Vec3,
        D: sc.Vec3,
        S: sc.Vec3,
        hit: tuple[int, int],
        t_max: float,
        depth: int,
        camera: bool,
        layers: int,
        material: sc.Material,
        path: tuple[int, int, int] = NEW_PATH,
    ) -> sc.Color:
        """A hit on a surface with transmission t or alpha a (docs/algorithm.md, "Glass and transparency"):
        (1 - a) straight on + a ((1 - t) today's colour + t (F mirror + (1 - F) colour refracted)), with F the
        dielectric Fresnel reflectance (1 beyond the critical angle) and the mirror ray traced once for both shares.
        t_max: what is left of a camera ray's range beyond P (its clip_end); a glossy lobe's rays weighted by the
        shaded share a (1 - t). The reason for 10 parameters: the ray's whole state, as TraceRay's recursion
        carries it from call to call."""
        a = material.alpha
        out = [0.0, 0.0, 0.0]
        V = (-D[0], -D[1], -D[2])
        if a < 1.0 and layers < sc.TRANSPARENT_BOUNCES:
            beyond = self.trace_ray(P, D, REFLECTION_T_MIN, t_max, depth, camera, layers + 1, path)
            out = [(1.0 - a) * beyond[c] for c in range(3)]
        if a <= 0.0:
            return tuple(out)
        shaded, mirror, refracted, weight = glass_split(find_normal(self.primitives[hit[0]], hit[1], P), D, S, material)
        if shaded > 0.0:  # today's local colour (its own mirror ray below, shared with the glass's)
            local = self.today(P, V, S, material, -1)
            out = [out[c] + shaded * local[c] for c in range(3)]
        child = (path[0], path[1], MIRROR)
        if refracted is not None and depth > 0:
            self.rays["reflection"] += 1
            seen = self.trace_ray(P, refracted, REFLECTION_T_MIN, INF, depth - 1, False, layers, child)
            out = [out[c] + weight[c] * seen[c] for c in range(3)]
        if depth > 0 and mirror > 0.0:
            self.rays["reflection"] += 1
            seen = self.trace_ray(P, reflect_ray(V, S), REFLECTION_T_MIN, INF, depth - 1, False, layers, child)
            out = [out[c] + mirror * seen[c] for c in range(3)]
        if material.transmission > 0.0 and material.transmission_roughness > 0.0:  # its lights, and its rays
            normal = find_normal(self.primitives[hit[0]], hit[1], P)
            seen = reference_glossy.glass(self, P, D, normal, S, material, depth, layers, path)
            out = [out[c] + a * material.transmission * seen[c] for c in range(3)]
        if depth > 0 and shaded > 0.0 and material.traces_glossy:
            seen = reference_glossy.rays(self, P, V, S, material, depth, layers, path)
            out = [out[c] + shaded * seen[c] for c in range(3)]
        if depth > 0 and shaded > 0.0 and path[1] < self.settings.diffuse_bounces:
            albedo = tuple(shaded * c * (1.0 - material.reflective) for c in material.color)
            seen = reference_glossy.diffuse(self, P, V, S, albedo, depth, layers, path)
            out = [out[c] + seen[c] for c in range(3)]
        return tuple(out)

    def today(
        self,
        P: sc.Vec3,
        V: sc.Vec3,
        S: sc.Vec3,
        material: sc.Material,
        depth: int,
        layers: int = 0,
        path: tuple[int, int, int] = NEW_PATH,
    ) -> sc.Color:
        """Listing 3.1's colour of an opaque hit at P: local = intensity * colour * (1 - r) (+ emission) (+ the
        lights through a glossy lobe), plus r times the mirror ray's and the glossy rays' while depth lasts (depth <
        0: the local colour alone)."""
        lobe = None
        if material.is_glossy:
            pairs = self.glossy_pairs if material.traces_glossy else self.world_pairs
            lobe = reference_glossy.lobe_at(material, S, V, pairs)
            lobe.traced = material.traces_glossy
        diffuse, highlight = self.find_intensities(P, S, V, material.specular, None, lobe)
        color = material.color
        if self.colored:
            tint = color if material.specular_color is None else material.specular_color
            local = tuple(
                (diffuse[c] * color[c] + highlight[c] * tint[c]) * (1.0 - material.reflective) for c in range(3)
            )
        else:
            weight = diffuse[0] * (1.0 - material.reflective)
            local = (weight * color[0], weight * color[1], weight * color[2])
        if material.emission != sc.BLACK:
            local = tuple(local[c] + material.emission[c] for c in range(3))
        if lobe is not None:
            if not lobe.traced:  # the background along its samples, untraced
                lobe.shine = reference_glossy.environment(lobe, self.world_pairs, self)
            local = tuple(local[c] + lobe.shine[c] for c in range(3))
        if depth <= 0:
            return local
        if material.reflective > 0.0:
            self.rays["reflection"] += 1
            child = (path[0], path[1], MIRROR)
            reflected = self.trace_ray(P, reflect_ray(V, S), REFLECTION_T_MIN, INF, depth - 1, False, layers, child)
            r = material.reflective
            local = (local[0] + reflected[0] * r, local[1] + reflected[1] * r, local[2] + reflected[2] * r)
        if lobe is not None and lobe.traced:
            seen = reference_glossy.rays(self, P, V, S, material, depth, layers, path, lobe)
            local = (local[0] + seen[0], local[1] + seen[1], local[2] + seen[2])
        if path[1] < self.settings.diffuse_bounces:
            albedo = tuple(c * (1.0 - material.reflective) for c in color)
            seen = reference_glossy.diffuse(self, P, V, S, albedo, depth, layers, path)
            local = (local[0] + seen[0], local[1] + seen[1], local[2] + seen[2])
        return local

    def pixel(self, i: int, j: int) -> sc.Color:
        """The box-filtered mean of the pixel's samples (r, g, b), and alpha where the scene has one."""
        total = [0.0, 0.0, 0.0, 0.0]
        self.image_pixel = j * self.settings.width + i
        for s in range(self.settings.samples):
            self.camera_sample = s  # the world light's share of directions (lightsamples.world_share)
            x, y = cam.sample_position(self.settings, i, j, s)
            lens = cam.lens_sample(self.settings, i, j, s)
            O, D, t_max = cam.primary_ray(self.scene.camera, self.settings, x, y, lens)
            self.serial = cam.sample_serial(self.settings, i, j, s)
            self.rays["camera"] += 1
            if t_max == 0.0:  # a panoramic camera's ray outside its lens: nothing, not even the background
                continue
            color = self.trace_ray(O, D, CAMERA_T_MIN, t_max, self.settings.depth, camera=True)
            covered = coverage(self, O, D, CAMERA_T_MIN, t_max)
            total = [total[0] + color[0], total[1] + color[1], total[2] + color[2], total[3] + covered]
        n = self.settings.samples
        if self.scene.has_alpha:
            return (total[0] / n, total[1] / n, total[2] / n, total[3] / n)
        return (total[0] / n, total[1] / n, total[2] / n)


def shadow_through(tracer: ReferenceTracer, P: sc.Vec3, L: sc.Vec3, t_max: float) -> float:
    """The share of a light that reaches P along L (t in (0.001, t_max)): the product of 1 - alpha over the
    surfaces the shadow ray meets, each met by the nearest hit and passed by a new segment from it along the same
    L (what is left of t_max); 0 at an opaque surface (alpha 1, glass included: Cycles' caustics off) or at the
    (TRANSPARENT_BOUNCES + 1)-th partly transparent one. Each segment counts as a shadow ray."""
    through, layers = 1.0, 0
    while True:
        tracer.rays["shadow"] += 1
        index, part, t = tracer.closest_intersection(P, L, SHADOW_T_MIN, t_max, "visible_shadow")
        if index < 0:
            return through
        alpha = tracer.material(index, part).alpha
        if alpha >= 1.0 or layers >= sc.TRANSPARENT_BOUNCES:
            return 0.0
        through *= 1.0 - alpha
        P, t_max, layers = add(P, scale(L, t)), t_max - t, layers + 1


def coverage(tracer: ReferenceTracer, O: sc.Vec3, D: sc.Vec3, t_min: float, t_max: float, layers: int = 0) -> float:
    """A camera ray's share of the film's alpha in the tracer's scene: 0 for nothing met under a transparent film
    or a holdout, 1 for nothing met otherwise or an opaque surface; alpha + (1 - alpha) * the straight
    continuation's for a partly transparent one (1 beyond TRANSPARENT_BOUNCES: the path ends there, black and
    opaque)."""
    first, part, t = tracer.closest_intersection(O, D, t_min, t_max, "visible_camera")
    if first < 0:
        return 0.0 if tracer.settings.film_transparent else 1.0
    if tracer.scene.objects[first].holdout:
        return 0.0
    alpha = tracer.material(first, part).alpha
    if alpha >= 1.0 or layers >= sc.TRANSPARENT_BOUNCES:
        return 1.0
    beyond = coverage(tracer, add(O, scale(D, t)), D, REFLECTION_T_MIN, t_max - t, layers + 1)
    return alpha + (1.0 - alpha) * beyond


def texture_value(
    tracer: ReferenceTracer, texture: sc.Texture | None, index: int, part: int, P: sc.Vec3
) -> tuple[float, float, float] | None:
    """A texture's colour at a hit on the tracer's object index's part: an "attribute" texture's from the corner
    colours, the others' from the corner UVs, weighted by P's barycentric coordinates (as smooth normals'; an
    instance's in its own space); None where the object has not what the texture reads."""
    from .texturing import attribute_one, sample_one

    if texture is None:
        return None
    key = "colors" if texture.kind == "attribute" else "uvs"
    obj = tracer.scene.objects[index]
    if getattr(obj, key, None) is None:
        return None
    kept = tracer.__dict__.setdefault(f"_{key}_corners", {})
    if index not in kept:  # each corner's (u, v, 0) or (r, g, b): _interpolated's three components
        values = getattr(obj, key).tolist()
        kept[index] = values if key == "colors" else [[(u, v, 0.0) for u, v in c] for c in values]
    corners = kept[index]
    primitive = tracer.primitives[index]
    if isinstance(obj, sc.MeshInstances):
        instance, triangle = divmod(part, len(primitive.mesh.triangles))
        local = _affine(primitive.inverses[instance], P, True)
        found = _interpolated(primitive.mesh.triangles[triangle], corners[triangle], local)
    else:
        found = _interpolated(primitive.triangles[part], corners[part], P)
    if texture.kind == "attribute":
        return attribute_one(texture, found)
    return sample_one(texture, found[0], found[1])


def seen_light(lights: list[sc.AreaLight], O: sc.Vec3, D: sc.Vec3, t_min: float, t_max: float) -> sc.Color | None:
    """The radiance (pi intensity / area times the colour) of the nearest of the area lights whose front the ray
    meets with t_min < t < t_max, None where it meets none (emitters.meet, one ray at a time)."""
    found, nearest = None, t_max
    for light in lights:
        normal, x_axis, y_axis = lightsamples.area_frame(light)
        facing = dot(D, normal)
        if not facing < 0.0:
            continue
        t = dot(sub(light.location, O), normal) / facing
        if not t_min < t < nearest:
            continue
        offset = sub(add(O, scale(D, t)), light.location)
        x, y = dot(offset, x_axis) / (light.size[0] / 2.0), dot(offset, y_axis) / (light.size[1] / 2.0)
        round_shape = light.shape in ("disk", "ellipse")
        if (x * x + y * y <= 1.0) if round_shape else (abs(x) <= 1.0 and abs(y) <= 1.0):
            area = light.size[0] * light.size[1] * (math.pi / 4.0 if round_shape else 1.0)
            found, nearest = tuple(math.pi * light.intensity / area * c for c in light.color), t
    return found


def seen_sun(suns: list[sc.DirectionalLight], D: sc.Vec3) -> sc.Color:
    """The radiance a ray along D that meets nothing sees of the suns (emitters.see_suns, one ray at a time): each
    sun's whose disc it points into (the angle to the sun at most half its angle), added."""
    out = [0.0, 0.0, 0.0]
    size = length(D)
    for sun in suns:
        radius = math.radians(sun.angle) / 2.0
        cosine = dot(D, normalize(sun.direction)) / size
        if not cosine >= math.cos(radius):
            continue
        if sun.disc_model == "cycles3":  # a disc of radius tan h a unit away: 1 / cos^3 toward its rim
            radiance = sun.intensity / math.tan(radius) ** 2 / cosine**3
        else:  # Cycles 4.0+: uniform over the disc, its strength over pi sin^2 h
            radiance = sun.intensity / math.sin(radius) ** 2
        out = [out[c] + radiance * sun.color[c] for c in range(3)]
    return tuple(out)


def glass_split(
    normal: sc.Vec3, D: sc.Vec3, S: sc.Vec3, material: sc.Material
) -> tuple[float, float, sc.Vec3 | None, sc.Color]:
    """The alpha share a of a see-through hit split: (a (1 - t), the share shaded as today; a ((1 - t) r + t F), the
    mirror ray's weight; the refracted direction, None in total internal reflection, where t = 0 or where its
    weight is 0; its weight a t (1 - F) colour). Inside or outside by the geometric normal (unnormalized) against
    D: eta = ior entering (N.D < 0), 1 / ior leaving; the shading normal S turned to face D bends the ray."""
    a, t = material.alpha, material.transmission
    shaded = a * (1.0 - t)
    mirror = shaded * material.reflective
    if not t > 0.0 or material.transmission_roughness > 0.0:  # rough glass: its own rays (reference_glossy.glass)
        return shaded, mirror, None, (0.0, 0.0, 0.0)
    N = normalize(normal)
    eta = material.ior if dot(N, D) < 0.0 else 1.0 / material.ior
    facing = S if dot(S, D) < 0.0 else (-S[0], -S[1], -S[2])
    F, refracted = refract(D, facing, eta)
    mirror += a * t * F
    share = a * t * (1.0 - F)
    if refracted is None or not share > 0.0:
        return shaded, mirror, None, (0.0, 0.0, 0.0)
    return shaded, mirror, refracted, tuple(share * material.color[c] for c in range(3))


def sample_boost(settings: sc.RenderSettings, pixel: int, sample: int, index: int, count: int, patterns: int) -> int:
    """Whether camera sample `sample` of the flat pixel takes sample index of a light of a size (count of them in
    patterns patterns) or of a world light's directions, and how many times: 0 where it does not. The pixel takes
    its pattern's samples alone (lightsamples.pixel_pattern: the index mod patterns), patterns times, shared out among
    its camera samples (lightsamples.world_share g of the pattern's count: the index within the pattern mod g is the
    sample's sharing key mod g), g times."""
    boost = 1
    if patterns > 1:
        if index % patterns != lightsamples.pixel_pattern(settings.width, pixel):
            return 0
        boost = patterns
    share = lightsamples.world_share(settings, count // patterns)
    if share > 1:
        if (index // patterns) % share != lightsamples.sharing_key(settings, sample) % share:
            return 0
        boost *= share
    return boost


def light_samples(scene: sc.Scene) -> list[tuple]:
    """Each light as find_intensities visits it: (light, where: a point light's location or a directional
    light's direction, intensity, weight, emitter, disk, index, count, patterns), a light of a size once per sample
    (lightsamples.py) with 1 / samples of its intensity and of its weight in the Shadow pass; emitter: an area
    light's unit normal; disk: a point or spot light's sample offset (radius * (a, b)) on the disk facing each point;
    index, count: which of the light's samples (a world light's: its directions), of how many
    (lightsamples.world_share gives it to some of a pixel's samples), None for a light of no size; patterns: a light
    of a size's (a pixel takes the samples of one, lightsamples.pixel_pattern), 1 for the others."""
    samples = scene.render.shadow_samples
    made = []
    for light in scene.lights:
        if isinstance(light, sc.AreaLight):
            points = lightsamples.area_points(light, samples)
            normal = lightsamples.area_frame(light)[0]
            share = light.intensity / len(points) if len(points) > 1 else light.intensity
            patterns = lightsamples.patterns(samples) if len(points) > 1 else 1
            made.extend(
                (light, point, share, 1.0 / len(points), normal, None, i, len(points), patterns)
                for i, point in enumerate(points)
            )
        elif isinstance(light, sc.DirectionalLight):
            directions = lightsamples.sun_directions(light, samples)
            share = light.intensity / len(directions) if len(directions) > 1 else light.intensity
            patterns = lightsamples.patterns(samples) if len(directions) > 1 else 1
            made.extend(
                (light, direction, share, 1.0 / len(directions), None, None, i, len(directions), patterns)
                for i, direction in enumerate(directions)
            )
        elif isinstance(light, sc.WorldLight):  # directions in each point's normal frame
            directions = lightsamples.hemisphere_directions(light.samples)
            share = 2.0 * light.intensity / len(directions)
            made.extend(
                (light, local, share, 1.0 / len(directions), None, None, i, len(directions), 1)
                for i, local in enumerate(directions)
            )
        elif isinstance(light, sc.PointLight | sc.SpotLight) and light.radius > 0.0 and samples > 1:
            offsets = lightsamples.disk_offsets(samples)
            share, patterns = light.intensity / len(offsets), lightsamples.patterns(samples)
            for i, (a, b) in enumerate(offsets):
                disk = (light.radius * a, light.radius * b)
                made.append((light, light.location, share, 1.0 / len(offsets), None, disk, i, len(offsets), patterns))
        else:
            made.append((light, getattr(light, "location", None), light.intensity, 1.0, None, None, None, 1, 1))
    return made


def environment(background: sc.Background, D: sc.Vec3) -> sc.Color:
    """An image background's colour for direction D: the equirectangular (u, v) (lightsamples.equirectangular),
    then the texel by Cycles' rules (linear: bilinear between the texel centres around (u W - 0.5, v H - 0.5), v
    from the bottom, wrapping in u, clamped at the poles; closest: the texel (floor(u W), floor(v H))), times the
    strength; the same operations as surfaces.environment."""
    image = background.image
    height, width = image.shape[:2]
    u, v = lightsamples.equirectangular(D, background.rotation)

    def texel(row: int, column: int) -> tuple[float, float, float]:
        value = image[height - 1 - min(max(row, 0), height - 1), column % width]  # rows from the top
        return (float(value[0]), float(value[1]), float(value[2]))

    if background.interpolation == "closest":
        color = texel(math.floor(v * height), math.floor(u * width))
    else:
        px, py = u * width - 0.5, v * height - 0.5
        fx, fy = math.floor(px), math.floor(py)
        tx, ty = px - fx, py - fy
        a, b, c, d = texel(fy, fx), texel(fy, fx + 1), texel(fy + 1, fx), texel(fy + 1, fx + 1)
        color = tuple(
            (1.0 - ty) * ((1.0 - tx) * a[k] + tx * b[k]) + ty * ((1.0 - tx) * c[k] + tx * d[k]) for k in range(3)
        )
    if background.strength != 1.0:
        color = tuple(k * background.strength for k in color)
    return color


def blurred_environment(background: sc.Background, D: sc.Vec3, solid_angle: float) -> sc.Color:
    """An image background's colour along D blurred to solid_angle (picture_levels): environment() at the two levels
    around picture_levels.level's, a + (b - a) t between them (a alone where t is 0); surfaces.blurred_environment's
    operations."""
    chain = picture_levels.levels(background)
    level = min(picture_levels.level(solid_angle, background), len(chain) - 1)
    low = math.floor(level)
    a = environment(chain[low], D)
    if level - low <= 0.0:
        return a
    b = environment(chain[low + 1], D)
    return tuple(a[k] + (b[k] - a[k]) * (level - low) for k in range(3))


def render_reference(scene: sc.Scene) -> list[list[sc.Color]]:
    """The whole image as rows of (r, g, b) linear floats, unclamped, (r, g, b, alpha) where the scene has an
    alpha; rows from the top."""
    tracer = ReferenceTracer(scene)
    settings = scene.render
    window = cam.border_window(settings)
    if window is None:
        return [[tracer.pixel(i, j) for i in range(settings.width)] for j in range(settings.height)]
    x0, x1, y0, y1 = window  # a render border: only its pixels are traced, the others are 0 (alpha 0)
    blank = (0.0,) * (4 if scene.has_alpha else 3)
    image = [
        [tracer.pixel(i, j) if x0 <= i < x1 and y0 <= j < y1 else blank for i in range(settings.width)]
        for j in range(settings.height)
    ]
    return [row[x0:x1] for row in image[y0:y1]] if settings.crop else image
