"""The per-pixel oracle's render passes: one camera sample at a time, the first hit's data (depth, mist, normal,
position, indices, Cryptomatte's names), listing 3.2's terms apart (find_intensities' split), and listing 3.1's
recursion unrolled into what mirror rays' surfaces and skies add (docs/passes.md). The vectorized tracer's passes
(recorder.py) must equal them to 1e-9 (tests/test_reference_passes.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.transforms import add, dot, length, scale, sub
from ..scene import scene as sc
from ..scene.passes import centre_sample
from . import reference_glossy
from .cryptomatte import matte_names
from .reference import (
    CAMERA_T_MIN,
    INF,
    NEW_PATH,
    REFLECTION_T_MIN,
    ReferenceTracer,
    find_normal,
    glass_split,
    normalize,
    reflect_ray,
)

# ---- render passes: what the reference gives for each (docs/passes.md) -------------------------------------------
BACKGROUND_DEPTH = 1.0e10  # Cycles' depth where a camera ray meets nothing
PASS_NAMES = (
    "depth",
    "mist",
    "normal",
    "position",
    "object_index",
    "material_index",
    "ambient",
    "diffuse",
    "specular",
    "emission",
    "reflection",
    "environment",
    "transmission",
    "shadow",
)
CENTRE_SAMPLE = ("depth", "position", "object_index", "material_index")  # the centre sample's; the others: the mean
# they add up to the image
WHITTED = ("ambient", "diffuse", "specular", "emission", "reflection", "environment", "transmission")


@dataclass
class SamplePasses:
    """One camera sample's passes. As for a camera ray that meets nothing: depth far, mist 1, the environment the
    background it sees; a holdout met first (held) leaves them so, but with no environment. object, material:
    the names of what the ray met first (Cryptomatte), None for nothing or a holdout."""

    depth: float = BACKGROUND_DEPTH
    mist: float = 1.0
    normal: sc.Vec3 = (0.0, 0.0, 0.0)
    position: sc.Vec3 = (0.0, 0.0, 0.0)
    object_index: float = 0.0
    material_index: float = 0.0
    ambient: sc.Color = (0.0, 0.0, 0.0)
    diffuse: sc.Color = (0.0, 0.0, 0.0)
    specular: sc.Color = (0.0, 0.0, 0.0)
    emission: sc.Color = (0.0, 0.0, 0.0)
    reflection: sc.Color = (0.0, 0.0, 0.0)
    environment: sc.Color = (0.0, 0.0, 0.0)
    transmission: sc.Color = (0.0, 0.0, 0.0)
    shadow: float = 0.0
    object: str | None = None
    material: str | None = None
    held: bool = False


class PassTracer(ReferenceTracer):
    """The reference tracer with its render passes, one camera sample at a time."""

    # ---- render passes, one camera sample at a time (docs/passes.md) ------------------------------------------

    def sample_passes(self, x: float, y: float, lens: tuple[float, float] = (0.5, 0.5)) -> SamplePasses:
        """The passes of the camera sample through image position (x, y) (and lens position, cam.lens_sample): what
        its ray meets first (data passes, ids), the first hit's terms of listing 3.2 apart, and what its mirror rays'
        tree adds (reflection, environment). The ray counts stay those of the image."""
        counted = dict(self.rays)
        camera = self.scene.camera
        O, D, t_max = cam.primary_ray(camera, self.settings, x, y, lens)
        out = SamplePasses()
        if t_max == 0.0:  # outside a panoramic camera's lens: nothing in any pass
            return out
        first, part, t = self.closest_intersection(O, D, CAMERA_T_MIN, t_max, "visible_camera")
        if first < 0:  # the background: far in depth, full mist, and the camera's view of the world
            if not self.settings.film_transparent:
                out.environment = self.background(D)
            return out
        if self.scene.objects[first].holdout:  # nothing of it shows; depth and mist as the background's
            out.held = True
            return out
        P = add(O, scale(D, t))
        material = self.material(first, part)
        material = self.textured(material, first, part, P)
        V = (-D[0], -D[1], -D[2])
        S = self.shading_normal(first, part, P, V, material)
        if material.alpha >= sc.PASS_ALPHA_THRESHOLD:
            self.data_passes(out, first, part, P, S, material)
        else:  # the data passes show what lies beyond (sc.PASS_ALPHA_THRESHOLD)
            beyond = self.data_hit(P, D, t_max - t)
            if beyond is not None:
                self.data_passes(out, *beyond)
        if material.see_through:
            self.see_through_passes(out, P, D, S, (first, part), t_max - t, material)
            self.rays = counted
            return out
        terms = self.local_terms(P, S, V, material)
        out.ambient, out.diffuse, out.specular = terms["ambient"], terms["diffuse"], terms["specular"]
        out.emission = material.emission
        out.shadow = terms["shadow"]
        reflection, environment = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        if self.settings.depth > 0 and material.reflective > 0.0:
            self.mirror_passes(
                P, reflect_ray(V, S), self.settings.depth - 1, material.reflective, reflection, environment
            )
        self.sampled_passes(P, V, S, material, 1.0, reflection, environment)
        out.reflection, out.environment = tuple(reflection), tuple(environment)
        self.rays = counted
        return out

    def sampled_passes(
        self, P: sc.Vec3, V: sc.Vec3, S: sc.Vec3, material: sc.Material, shaded: float, reflection, environment
    ) -> None:
        """A camera ray's first hit's glossy lobe rays and diffuse bounce rays, times its shaded share: what their
        trees meet into reflection, the sky they see into environment (split_ray)."""
        depth = self.settings.depth
        if depth <= 0 or shaded <= 0.0:
            return
        rays = []
        first = lightsamples.shared_pairs(self.settings, len(self.glossy_pairs), self.camera_sample)
        if material.traces_glossy:
            lobe = reference_glossy.lobe_at(material, S, V, self.glossy_pairs)
            rays += reference_glossy.lobe_rays(lobe, self.glossy_pairs, NEW_PATH, first)
        if self.settings.diffuse_bounces > 0:
            albedo = tuple(c * (1.0 - material.reflective) for c in material.color)
            rays += reference_glossy.bounce_rays(self.glossy_pairs, V, S, albedo, NEW_PATH, first)
        for direction, weight, path in rays:
            surface, sky = self.split_ray(P, direction, depth - 1, 0, path)
            for c in range(3):
                reflection[c] += shaded * weight[c] * surface[c]
                environment[c] += shaded * weight[c] * sky[c]

    def split_ray(
        self, O: sc.Vec3, D: sc.Vec3, depth: int, layers: int, path: tuple[int, int, int]
    ) -> tuple[sc.Color, sc.Color]:
        """What a reflection ray's tree brings back, split into what its surfaces add (its colour with every miss
        bringing nothing) and what the sky adds (the rest): the Reflection and Environment passes' shares."""
        whole = self.trace_ray(O, D, REFLECTION_T_MIN, INF, depth, False, layers, path)
        self.sky = False
        try:
            surface = self.trace_ray(O, D, REFLECTION_T_MIN, INF, depth, False, layers, path)
        finally:
            self.sky = True
        return surface, tuple(whole[c] - surface[c] for c in range(3))

    def data_passes(
        self, out: SamplePasses, index: int, part: int, P: sc.Vec3, S: sc.Vec3, material: sc.Material
    ) -> None:
        """A camera sample's data passes and Cryptomatte names from the surface at P on object index's part."""
        camera = self.scene.camera
        offset = sub(P, camera.location)
        r = tf.euler_xyz_matrix(camera.rotation)
        out.depth = dot(offset, (-r[0][2], -r[1][2], -r[2][2]))  # along the view axis, the camera's local -Z
        # Cycles' camera distance: the view axis's for an orthographic camera, the straight line's for a perspective
        out.mist = mist(abs(out.depth) if camera.type == "ORTHO" else length(offset), self.settings)
        out.normal = normalize(S)
        out.position = P
        out.object_index = float(self.scene.objects[index].pass_index)
        out.material_index = float(material.pass_index)
        render = self.scene.render  # the names Cryptomatte gives them (render.cryptomatte_names)
        out.object = matte_names([self.scene.objects[index].name], render, "object")[0]
        out.material = matte_names([self.material_name(index, part)], render, "material")[0]

    def data_hit(self, O: sc.Vec3, D: sc.Vec3, t_max: float) -> tuple | None:
        """Beyond a surface of alpha below sc.PASS_ALPHA_THRESHOLD at O: the surface the camera ray's straight
        continuations meet next with alpha at least that, as (index, part, P, S, material) for data_passes; None
        where they meet nothing, a holdout, or only such surfaces up to sc.TRANSPARENT_BOUNCES."""
        layers = 1
        while layers <= sc.TRANSPARENT_BOUNCES:
            index, part, t = self.closest_intersection(O, D, REFLECTION_T_MIN, t_max, "visible_camera")
            if index < 0 or self.scene.objects[index].holdout:
                return None
            P = add(O, scale(D, t))
            material = self.textured(self.material(index, part), index, part, P)
            if material.alpha >= sc.PASS_ALPHA_THRESHOLD:
                return index, part, P, self.shading_normal(index, part, P, (-D[0], -D[1], -D[2]), material), material
            O, t_max, layers = P, t_max - t, layers + 1
        return None

    def see_through_passes(
        self,
        out: SamplePasses,
        P: sc.Vec3,
        D: sc.Vec3,
        S: sc.Vec3,
        hit: tuple[int, int],
        t_max: float,
        material: sc.Material,
    ) -> None:
        """A camera ray's first hit on a see-through surface (see_through): its local terms (and the Shadow pass)
        times its shaded share a (1 - t) where that is above 0; its mirror ray's tree into reflection and
        environment, weighted by the mirror share; what its straight continuation and refracted ray bring back
        (trace_ray's colours, weighted) into transmission."""
        depth = self.settings.depth
        V = (-D[0], -D[1], -D[2])
        a = material.alpha
        transmission = [0.0, 0.0, 0.0]
        if a < 1.0:
            beyond = self.trace_ray(P, D, REFLECTION_T_MIN, t_max, depth, camera=True, layers=1)
            transmission = [(1.0 - a) * beyond[c] for c in range(3)]
        if a > 0.0:
            shaded, mirror, refracted, weight = glass_split(
                find_normal(self.primitives[hit[0]], hit[1], P), D, S, material
            )
            if shaded > 0.0:
                terms = self.local_terms(P, S, V, material)
                for name in ("ambient", "diffuse", "specular"):
                    setattr(out, name, tuple(shaded * value for value in terms[name]))
                out.emission = tuple(shaded * value for value in material.emission)
                out.shadow = terms["shadow"]
            if refracted is not None and depth > 0:
                seen = self.trace_ray(P, refracted, REFLECTION_T_MIN, INF, depth - 1, False, 0)
                transmission = [transmission[c] + weight[c] * seen[c] for c in range(3)]
            reflection, environment = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            if depth > 0 and mirror > 0.0:
                self.mirror_passes(P, reflect_ray(V, S), depth - 1, mirror, reflection, environment)
            if material.transmission > 0.0 and material.transmission_roughness > 0.0:  # the lights through it
                normal = find_normal(self.primitives[hit[0]], hit[1], P)
                glass = a * material.transmission
                shine = reference_glossy.glass_light(self, P, D, normal, S, material, depth, "reflected")
                bent = reference_glossy.glass_light(self, P, D, normal, S, material, depth, "refracted")
                reflection = [reflection[c] + glass * shine[c] for c in range(3)]
                transmission = [transmission[c] + glass * bent[c] for c in range(3)]
            if depth > 0 and material.transmission > 0.0 and material.transmission_roughness > 0.0:
                normal = find_normal(self.primitives[hit[0]], hit[1], P)
                glass = a * material.transmission
                rotation = cam.glass_rotation(self.settings.seed, self.serial, depth)
                first = lightsamples.shared_pairs(self.settings, len(self.glossy_pairs), self.camera_sample)
                for direction, weight, path, bent in reference_glossy.glass_rays(
                    self.glossy_pairs, D, normal, S, material, NEW_PATH, rotation, first
                ):
                    if bent:  # a refracted ray's tree, surfaces and sky alike: Transmission
                        seen = self.trace_ray(P, direction, REFLECTION_T_MIN, INF, depth - 1, False, 0, path)
                        transmission = [transmission[c] + glass * weight[c] * seen[c] for c in range(3)]
                        continue
                    surface, sky = self.split_ray(P, direction, depth - 1, 0, path)
                    for c in range(3):
                        reflection[c] += glass * weight[c] * surface[c]
                        environment[c] += glass * weight[c] * sky[c]
            self.sampled_passes(P, V, S, material, shaded, reflection, environment)
            out.reflection, out.environment = tuple(reflection), tuple(environment)
        out.transmission = tuple(transmission)

    def local_terms(self, P: sc.Vec3, S: sc.Vec3, V: sc.Vec3, material: sc.Material) -> dict:
        """A hit's local colour term by term: "ambient", "diffuse", "specular" (r, g, b) each times the material's
        colour (its specular colour for the highlight, where lights or materials are coloured) and (1 -
        reflectivity), as listing 3.1 weighs the local colour; and "shadow" (find_intensities' split)."""
        split: dict = {}
        lobe = None
        if material.is_glossy:  # the lights (or the world) through a glossy lobe: a highlight, as the image has it
            pairs = self.glossy_pairs if material.traces_glossy else self.world_pairs
            lobe = reference_glossy.lobe_at(material, S, V, pairs)
            lobe.traced = material.traces_glossy
        self.find_intensities(P, S, V, material.specular, split, lobe)
        if lobe is not None and not lobe.traced:
            lobe.shine = reference_glossy.environment(lobe, self.world_pairs, self)
        keep = 1.0 - material.reflective
        color = material.color
        tint = color if material.specular_color is None or not self.colored else material.specular_color
        terms = {}
        for name, paint in (("ambient", color), ("diffuse", color), ("specular", tint)):
            value = split[name]
            if self.colored:
                terms[name] = tuple(value[c] * paint[c] * keep for c in range(3))
            else:
                terms[name] = tuple((value[c] * keep) * paint[c] for c in range(3))
        if lobe is not None:
            terms["specular"] = tuple(terms["specular"][c] + lobe.shine[c] for c in range(3))
        terms["shadow"] = split["shadow"]
        return terms

    def mirror_passes(
        self,
        O: sc.Vec3,
        D: sc.Vec3,
        depth: int,
        weight: float | sc.Color,
        reflection: list,
        environment: list,
        layers: int = 0,
    ) -> None:
        """A mirror ray from O along D, its reflectivities' product weight (per channel where a refracted ray on its
        way tinted it): what its tree's surfaces add (their local terms and emission, the lights seen in mirrors,
        weighted) into reflection, the sky it sees into environment (split_ray: listing 3.1's recursion, once with
        the sky and once without)."""
        w = (weight, weight, weight) if isinstance(weight, float | int) else weight
        surface, sky = self.split_ray(O, D, depth, layers, NEW_PATH)
        for c in range(3):
            reflection[c] += w[c] * surface[c]
            environment[c] += w[c] * sky[c]

    def pixel_passes(self, i: int, j: int) -> tuple[dict[str, tuple[float, ...]], list[SamplePasses]]:
        """Pixel (i, j)'s passes (name -> its channels) from its samples: the mean of the samples', except depth,
        position and the indices, which are the sample's nearest the pixel's centre (passes.centre_sample: Cycles
        writes them from its first sample, on the centre); and the samples' own SamplePasses (their Cryptomatte
        names)."""
        samples = []
        self.image_pixel = j * self.settings.width + i  # its turn of the world light's directions
        for s in range(self.settings.samples):
            self.camera_sample = s  # the world light's share of directions (lightsamples.world_share)
            self.serial = cam.sample_serial(self.settings, i, j, s)  # rough glass's rotations
            position, lens = cam.sample_position(self.settings, i, j, s), cam.lens_sample(self.settings, i, j, s)
            samples.append(self.sample_passes(*position, lens))
        values = {}
        for name in PASS_NAMES:
            if name in CENTRE_SAMPLE:
                values[name] = _channels(getattr(samples[centre_sample(len(samples))], name))
                continue
            per_sample = [_channels(getattr(sample, name)) for sample in samples]
            values[name] = tuple(sum(column) / len(samples) for column in zip(*per_sample, strict=True))
        return values, samples


@dataclass
class ReferencePasses:
    """The reference's passes of a whole image: values (pass name -> rows from the top of each pixel's channels),
    and per pixel its samples' first object and material names (None: nothing, or a holdout) and whether one of
    its samples met a holdout first. Pixels outside a render border (not cropped): every pass 0, no samples."""

    values: dict[str, list[list[tuple[float, ...]]]]
    objects: list[list[list[str | None]]]
    materials: list[list[list[str | None]]]
    held: list[list[bool]]


def render_reference_passes(scene: sc.Scene) -> ReferencePasses:
    """Every pass of PASS_NAMES for every pixel, one sample at a time, where the image has its pixels (the render
    border, cropped or not, as render_reference)."""
    tracer = PassTracer(scene)
    settings = scene.render
    window = cam.border_window(settings)
    x0, x1, y0, y1 = (0, settings.width, 0, settings.height) if window is None else window
    blank = {name: (0.0,) * len(_channels(getattr(SamplePasses(), name))) for name in PASS_NAMES}
    result = ReferencePasses({name: [] for name in PASS_NAMES}, [], [], [])
    rows = range(y0, y1) if settings.crop else range(settings.height)
    columns = range(x0, x1) if settings.crop else range(settings.width)
    for j in rows:
        for store in (*result.values.values(), result.objects, result.materials, result.held):
            store.append([])
        for i in columns:
            if x0 <= i < x1 and y0 <= j < y1:
                values, samples = tracer.pixel_passes(i, j)
            else:
                values, samples = blank, []
            for name in PASS_NAMES:
                result.values[name][-1].append(values[name])
            result.objects[-1].append([sample.object for sample in samples])
            result.materials[-1].append([sample.material for sample in samples])
            result.held[-1].append(any(sample.held for sample in samples))
    return result


def mist(distance: float, settings: sc.RenderSettings) -> float:
    """Blender's mist at a distance from the camera: 0 at mist_start to 1 at mist_start + mist_depth (clamped),
    then the falloff: QUADRATIC m^2, LINEAR m, INVERSE_QUADRATIC sqrt(m) (Cycles' falloff exponents 2, 1, 1/2)."""
    depth = settings.mist_depth if settings.mist_depth > 0.0 else 1e-9
    m = min(max((distance - settings.mist_start) / depth, 0.0), 1.0)
    if settings.mist_falloff == "QUADRATIC":
        return m * m
    if settings.mist_falloff == "INVERSE_QUADRATIC":
        return math.sqrt(m)
    return m


def _channels(value: float | tuple[float, ...]) -> tuple[float, ...]:
    return tuple(value) if isinstance(value, tuple) else (value,)
