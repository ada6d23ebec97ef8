"""The Blender API points that differ between 3.4 and 5.0, in one place.

F-curves: 5.0 keeps them in layered actions (channelbags through action slots), 3.4 only in action.fcurves.
Principled BSDF sockets were renamed in 4.0. EEVEE's engine id is BLENDER_EEVEE in 3.4 and 5.0 and
BLENDER_EEVEE_NEXT in 4.2-4.5. The default view transform is Filmic in 3.4 and AgX from 4.0.
"""

from __future__ import annotations

import math
import struct

import bpy

VERSION = bpy.app.version
# The longest data-block name in bytes (UTF-8): 63 until Blender 5.0 raised it to 255. A longer name is cut
# silently, so a name looked up again after creation would not be found.
MAX_NAME_BYTES = 255 if VERSION >= (5, 0, 0) else 63


def version_name() -> str:
    """This Blender's version as its splash screen writes it ("3.4.1", "5.0.1")."""
    return ".".join(map(str, VERSION))


def area_light_share() -> float:
    """What Cycles' area light emits for a given power, as a share of what Blender 4.0+ emits: pi / 4 in 3.x."""
    return math.pi / 4.0 if VERSION < (4, 0, 0) else 1.0


def microfacet_shadowing() -> str:
    """The scene format's glossy_shadowing of this Blender's Cycles microfacets: Smith's separable G1 G1 before 4.0
    (a white Glossy BSDF of roughness 1 under a uniform world: 0.403 in 3.4.1 where 5.0.1 shows 0.442), the
    height-correlated G2 since."""
    return "separable" if VERSION < (4, 0, 0) else "correlated"


def cycles_spot_model() -> str:
    """The scene format's spot_model of this Blender's Cycles: "cycles3" before 4.0 (it also weights a spot by the
    cosine to its axis), "cycles4" from 4.0 (smoothstep only)."""
    return "cycles3" if VERSION < (4, 0, 0) else "cycles4"


def cycles_sun_disc_model() -> str:
    """The scene format's disc_model of this Blender's Cycles: "cycles3" before 4.0 (a sun's disc in a mirror is
    brighter toward its rim by 1 / cos^3 of the angle from its centre, and intensity / tan^2 of half its angle at
    the centre), "cycles4" from 4.0 (intensity / sin^2 of half its angle all over it)."""
    return "cycles3" if VERSION < (4, 0, 0) else "cycles4"


def passes_named_in_words() -> bool:
    """Blender 5.0 names passes in words ("Object Index", "Diffuse Direct"); earlier releases in codes ("IndexOB",
    "DiffDir")."""
    return VERSION >= (5, 0, 0)


def fcurves_of(owner: bpy.types.ID) -> list:
    """The F-curves animating owner (an object or a scene), empty when it has no action."""
    animation = owner.animation_data
    if animation is None or animation.action is None:
        return []
    action = animation.action
    if VERSION >= (4, 4, 0):
        from bpy_extras import anim_utils

        channelbag = anim_utils.action_get_channelbag_for_slot(action, animation.action_slot)
        return list(channelbag.fcurves) if channelbag is not None else []
    return list(action.fcurves)


def find_fcurve(owner: bpy.types.ID, data_path: str, index: int = 0):
    """owner's F-curve for data_path[index], or None."""
    for fcurve in fcurves_of(owner):
        if fcurve.data_path == data_path and fcurve.array_index == index:
            return fcurve
    return None


def keyframes_of(owner: bpy.types.ID, data_path: str, index: int = 0) -> tuple[list[float], list[float]] | None:
    """owner's keys on data_path[index] as (frames, values), or None where it has none."""
    fcurve = find_fcurve(owner, data_path, index)
    if fcurve is None or not fcurve.keyframe_points:
        return None
    return [point.co[0] for point in fcurve.keyframe_points], [point.co[1] for point in fcurve.keyframe_points]


def replace_fcurve(owner: bpy.types.ID, data_path: str, index: int, frames: list[float], values: list[float]):
    """Key data_path[index] of owner at frames with values, LINEAR, replacing any keys it had; returns the F-curve."""
    old = find_fcurve(owner, data_path, index)
    if old is not None:
        if VERSION >= (4, 4, 0):
            from bpy_extras import anim_utils

            animation = owner.animation_data
            anim_utils.action_get_channelbag_for_slot(animation.action, animation.action_slot).fcurves.remove(old)
        else:
            owner.animation_data.action.fcurves.remove(old)
    # keyframe_insert makes the action (and in 5.0 its slot and channelbag) the way Blender's UI does
    is_array = hasattr(owner.path_resolve(data_path), "__len__")
    owner.keyframe_insert(data_path, index=index if is_array else -1, frame=frames[0])
    fcurve = find_fcurve(owner, data_path, index)
    points = fcurve.keyframe_points
    points.add(len(frames) - 1)
    coordinates = [value for pair in zip(frames, values, strict=True) for value in pair]
    points.foreach_set("co", coordinates)
    for point in points:
        point.interpolation = "LINEAR"
    fcurve.update()
    return fcurve


def calc_split_normals(mesh: bpy.types.Mesh) -> None:
    """Make loop_triangles' split_normals valid: 3.4-4.0 compute them on request (calc_normals_split), 4.1 and
    later keep corner normals up to date themselves and have no such call."""
    if hasattr(mesh, "calc_normals_split"):
        mesh.calc_normals_split()


def principled_diffuse_factor(roughness: float, f0: float) -> float:
    """The share of Base Color that the Principled BSDF's diffuse lobe returns, as a Lambert surface of the same
    albedo. 4.0 and later (Principled v2): Lambert under the dielectric layer, 1 - F0. 3.x (Principled v1): Burley's
    Disney diffuse, not darkened by the specular layer, whose retro-reflection at grazing angles gives it a
    hemispherical albedo of 0.953 + 0.112 roughness times Lambert's (fd integrated over cosine-weighted light and
    view directions: 0.953, 0.980, 1.008, 1.036, 1.065 at roughness 0, 1/4, 1/2, 3/4, 1; the line fits to 0.001)."""
    if VERSION >= (4, 0, 0):
        return 1.0 - f0
    return 0.953 + 0.112 * roughness


def principled_transmission_tint(base_color) -> list[float]:
    """The tint a Principled BSDF's transmission gives each refraction (the scene format tints every crossing of a
    surface): 4.0 and later, sqrt(Base Color), so that a ray through a closed object is tinted by Base Color once
    (a 1 m glass cube of Base Color 0.5 in Cycles: 0.4608 = 0.5 x 0.96^2 in 5.0.1 and 4.2); 3.x, Base Color at each
    crossing (0.233 = 0.5^2 x 0.96^2 in 3.4.1), as Glass BSDF's Color in every version."""
    if VERSION >= (4, 0, 0):
        return [max(0.0, float(c)) ** 0.5 for c in base_color]
    return [float(c) for c in base_color]


def principled_socket(node: bpy.types.Node, role: str) -> bpy.types.NodeSocket:
    """A Principled BSDF input by role: 'specular' and 'emission' were renamed in 4.0."""
    names = {
        "specular": ("Specular IOR Level", "Specular"),
        "emission": ("Emission Color", "Emission"),
    }.get(role, (role,))
    for name in names:
        if name in node.inputs:
            return node.inputs[name]
    raise KeyError(f"Principled BSDF has no {role!r} input in Blender {bpy.app.version_string}")


def enable_nodes(material: bpy.types.Material) -> None:
    """Give a material its node tree (always there from 5.0, where use_nodes is deprecated)."""
    if VERSION < (5, 0, 0):
        material.use_nodes = True


def no_emission_sampling(material: bpy.types.Material) -> None:
    """Cycles must not treat the ambient emission as a light (3.x: sample_as_light, 4.0+: emission_sampling)."""
    settings = material.cycles
    if hasattr(settings, "emission_sampling"):
        settings.emission_sampling = "NONE"
    elif hasattr(settings, "sample_as_light"):
        settings.sample_as_light = False


def no_world_sampling(world: bpy.types.World) -> None:
    """Cycles must not light the scene from the world (3.x: sample_as_light, 4.0+: sampling_method)."""
    settings = world.cycles
    if hasattr(settings, "sampling_method"):
        settings.sampling_method = "NONE"
    elif hasattr(settings, "sample_as_light"):
        settings.sample_as_light = False


def eevee_engine() -> str:
    return "BLENDER_EEVEE_NEXT" if (4, 2, 0) <= VERSION < (5, 0, 0) else "BLENDER_EEVEE"


def principled_input(node: bpy.types.Node, role: str):
    """A Principled BSDF input by the role it plays, or None where this Blender has none: 4.0 renamed 'Subsurface',
    'Transmission', 'Clearcoat' and 'Sheen' to their '... Weight' names (3.4's are factors with the same meaning)."""
    names = {
        "subsurface": ("Subsurface Weight", "Subsurface"),
        "transmission": ("Transmission Weight", "Transmission"),
        "coat": ("Coat Weight", "Clearcoat"),
        "sheen": ("Sheen Weight", "Sheen"),
        "specular": ("Specular IOR Level", "Specular"),
        "emission": ("Emission Color", "Emission"),
    }.get(role, (role,))
    return next((node.inputs[name] for name in names if name in node.inputs), None)


def principled_transmission_roughness(node: bpy.types.Node, roughness: float) -> float:
    """The roughness of a Principled BSDF's transmission: 4.0+ its Roughness; 3.x also has Transmission Roughness,
    which Cycles combines as 1 - (1 - Roughness)(1 - Transmission Roughness)."""
    extra = node.inputs.get("Transmission Roughness")
    if extra is None:
        return roughness
    return 1.0 - (1.0 - roughness) * (1.0 - min(1.0, max(0.0, float(extra.default_value))))


def transparent_shadow(material: bpy.types.Material) -> bool:
    """Whether Cycles lets shadow rays through the material's transparency: 3.x keeps the switch in its Cycles
    settings (material.cycles.use_transparent_shadow), 4.2+ on the material (Settings > Transparent Shadows)."""
    if VERSION >= (4, 2, 0) and hasattr(material, "use_transparent_shadow"):
        return bool(material.use_transparent_shadow)
    return bool(getattr(getattr(material, "cycles", None), "use_transparent_shadow", True))


def principled_f0(node: bpy.types.Node, level: float) -> float:
    """A dielectric Principled BSDF's reflectance at normal incidence for its specular level.

    3.4: F0 = 0.08 * Specular (0.5 is F0 = 0.04). 4.0+: F0 = ((IOR - 1) / (IOR + 1))^2 scaled by 2 * IOR Level (0.5
    keeps the IOR's own F0; IOR 1.5 is 0.04)."""
    if "IOR" in node.inputs and "Specular IOR Level" in node.inputs:
        ior = float(node.inputs["IOR"].default_value)
        return min(1.0, ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * level)
    return min(1.0, 0.08 * level)


def light_color(light: bpy.types.Light) -> tuple[float, float, float]:
    """The light's colour as Cycles emits it: 4.x+ multiplies it by the blackbody colour when use_temperature is on."""
    color = tuple(light.color)
    if getattr(light, "use_temperature", False):
        tint = tuple(light.temperature_color)
        color = tuple(c * t for c, t in zip(color, tint, strict=True))
    return color


def light_power(light: bpy.types.Light) -> float:
    """Watts (point, spot, area) or W/m^2 (sun) as Cycles emits them: 4.x+ scales energy by 2 ** exposure."""
    return float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))


def light_normalized(light: bpy.types.Light) -> bool:
    """4.5+: Normalize (on by default) keeps a light's power whatever its size; off, the power is per unit of the
    emitter's area. Before 4.5 every light is normalized."""
    return bool(getattr(light, "normalize", True))


def glass_closure_splits_light_visibility() -> bool:
    """Whether a lamp's light off rough glass follows its Glossy ray visibility and its light through it its
    Transmission visibility, one each (3.x); from 4.0 Cycles' glass is one closure that shows both while either is
    on. Measured on a rough glass ball lit from behind (sphere mean, both on / Glossy off / Transmission off / both
    off): 3.4.1 0.446 / 0.435 / 0.235 / 0.224; 4.2.23 0.425 / 0.425 / 0.425 / 0.219; 5.0.1 0.445 / 0.445 / 0.445 /
    0.220."""
    return VERSION < (4, 0, 0)


def light_casts_shadow(light: bpy.types.Light) -> bool:
    """3.x keeps the switch in Cycles' settings (cast_shadow), 4.0+ on the light (use_shadow)."""
    if hasattr(light, "use_shadow") and VERSION >= (4, 0, 0):
        return bool(light.use_shadow)
    return bool(getattr(getattr(light, "cycles", None), "cast_shadow", True))


def light_soft_falloff(light: bpy.types.Light) -> bool:
    """4.0+: a point or spot light of non-zero radius softens the inverse square near itself (Soft Falloff)."""
    return bool(getattr(light, "use_soft_falloff", False))


def uses_nodes(data) -> bool:
    """A material's or world's node tree is what Cycles renders (always from 5.0, where use_nodes is deprecated)."""
    return data.node_tree is not None and (VERSION >= (5, 0, 0) or bool(data.use_nodes))


def float32_decimal(value: float) -> float:
    """The shortest decimal that Blender's float32 storage of value came from (0.800000011920929 -> 0.8)."""
    if not abs(value) < 3.0e38:  # inf, nan and what float32 cannot hold stay as they are
        return float(value)
    stored = struct.unpack("f", struct.pack("f", value))[0]
    for digits in range(1, 10):
        text = f"{stored:.{digits}g}"
        if struct.unpack("f", struct.pack("f", float(text)))[0] == stored:
            return float(text)
    return float(stored)


def cycles_ramp_table() -> int:
    """The entries n of the table Cycles looks a Color Ramp up in: table[i] = the band at i / (n - 1), the lookup
    table[int(f (n - 1))] (mixed with the next entry for Linear), so a Constant ramp steps at the first i / (n - 1)
    at or past a stop. Measured with a grey float image swept across a Constant stop: 3.4.1 steps at 64/255 for a
    stop at 0.25 (n = 256); 4.2.23, 4.4.0, 4.5.15 and 5.0.1 at 0.25 for 0.25 and at 180/256 for 0.7 (n = 257), taken
    here for every 4.x (3.5-4.1 unmeasured)."""
    return 256 if VERSION < (4, 0, 0) else 257


def panorama_settings(camera_data):
    """Where a camera's panoramic settings (panorama_type, fisheye_fov, fisheye_lens, latitude_min...) live: on the
    camera data from Blender 4.0, on its Cycles settings (camera.cycles) before."""
    return camera_data if hasattr(camera_data, "panorama_type") else camera_data.cycles


def motion_blur_position(blender_scene) -> str:
    """Render > Motion Blur > Position (START, CENTER or END): the render settings' from 4.2 (shared by Cycles and
    EEVEE), Cycles' own before; CENTER where neither is there (Cycles' default)."""
    render = blender_scene.render
    if hasattr(render, "motion_blur_position"):
        return render.motion_blur_position
    cycles = getattr(blender_scene, "cycles", None)
    return getattr(cycles, "motion_blur_position", "CENTER")
