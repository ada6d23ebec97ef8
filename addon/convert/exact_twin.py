"""A Blender scene -> Cycles computing the documented model itself through OSL: the "exact twin" of the tracer.

Where Cycles has OSL (the bpy wheels, any Blender built with it), every material of the scene is swapped for an OSL
script node that evaluates listing 3.2's FindIntensity at the shading point, with the scene's lights written into
the script as constants (ambient; point lights with L = position - P unnormalised and their shadow ray over
t in (0.001, 1) through OSL's trace(); directional lights with t in (0.001, inf); diffuse N.L / (|N||L|) without
falloff; Phong or Blinn-Phong highlights, added where N.L <= 0 too, as the listing does). The script returns

    local * emission() + r * reflection(N),      local = intensity x color x (1 - r)

so a camera path is listing 3.1's TraceRay: Cycles follows the perfect mirror closure for depth mirror rays (its
glossy bounces = depth - 1, as Cycles counts them), with no diffuse bounces and no Russian roulette; the emission is
the local term of each hit, and a miss sees the documented background (a world that lights nothing). No scene light
is sampled: the lights are hidden for the render (their values live in the script) and nothing else emits. The
parameters come from what the tracer renders: the add-on's export of the same scene, so both paths read one
document.

What stays different from the tracer: Blender's meshes for the analytic sphere and cylinder (the add-on's adaptive
tessellation) and their smooth normals, Cycles' pixel samples against the tracer's stratified ones, float32, and
where a mirror ray starts (listing 3.1 skips t < 0.01; Cycles' mirror closure starts at the surface, leaving out only
the surface itself). docs/comparison.md measures what the first three cost.

apply() changes the scene for the render and returns an ExactTwin whose restore() puts every material, light, the
world and the shading system back; the render settings stay the twin's (Cycles, samples, bounces, filter, the
Standard view), as twin.cycles() leaves them for the physical twin.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
from dataclasses import dataclass, field

import bpy

from .. import compat
from .. import tracer_api as tracer
from . import material_convert, twin

SCRIPT = "WV Exact Twin.osl"
WORLD = "WV Exact World"
PREFIX = "WV Exact "


def unavailable() -> str | None:
    """None where this Blender's Cycles runs OSL; else why not, in one short phrase."""
    version = compat.version_name()
    if not getattr(bpy.app.build_options, "cycles", False):
        return f"Blender {version} is built without Cycles"
    if not getattr(bpy.app.build_options, "cycles_osl", False):
        return f"Blender {version}'s Cycles is built without OSL"
    try:
        _oslquery()
    except ImportError:
        import _cycles

        if not hasattr(_cycles, "osl_update_node"):  # before 4.3 Cycles read the compiled shader itself
            return f"Blender {version} has no oslquery module to read compiled OSL shaders"
    return None


def _oslquery():
    """Cycles' update_script_node imports oslquery (from 4.3), which the bpy wheel keeps in its own site-packages."""
    try:
        import oslquery
    except ImportError:
        local = bpy.utils.resource_path("LOCAL")
        python = f"python{sys.version_info.major}.{sys.version_info.minor}"
        for folder in (os.path.join(local, "python", "lib", python, "site-packages"), os.path.join(local, "python")):
            if os.path.isdir(folder) and folder not in sys.path:
                sys.path.append(folder)
        import oslquery
    return oslquery


# ---- the shader ----------------------------------------------------------------------------------------------------


def _vector(v) -> str:
    return f"vector({float(v[0])!r}, {float(v[1])!r}, {float(v[2])!r})"


def _color(c) -> str:
    return f"color({float(c[0])!r}, {float(c[1])!r}, {float(c[2])!r})"


def _highlight(settings) -> str:
    """The listing's specular term for light_vector L (length dist), added to highlight with the light's weight."""
    if settings.model == "phong":
        return (
            "vector R = 2.0 * S * dot(S, L) - L;\n"
            "            float RV = dot(R, V);\n"
            "            if (RV > 0.0) highlight += weight * pow(RV / (length(R) * length(V)), Specular);"
        )
    return (
        "vector H = L / dist + V / length(V);\n"
        "            float HN = dot(H, S);\n"
        f"            if (HN > 0.0) highlight += weight * pow(HN / length(H), Specular * {float(settings.coef)!r});"
    )


def _spot(light) -> str:
    """Cycles' spot attenuation (reference.spot_attenuation) for the spot's constants, into `factor`."""
    cos_half = math.cos(math.radians(light.spot_size) / 2.0)
    width = (1.0 - cos_half) * light.spot_blend
    axis = _vector([c / math.sqrt(sum(a * a for a in light.direction)) for c in light.direction])
    step = "1.0" if width == 0.0 else f"smoothstep(0.0, 1.0, (cosine - {cos_half!r}) / {width!r})"
    if light.spot_model == "cycles3":
        step = f"cosine * {step}"
    return f"float cosine = -dot(L, {axis}) / dist;\n        factor = (cosine > {cos_half!r}) ? {step} : 0.0;\n        "


def shader_source(scene) -> str:
    """The OSL source of the exact twin for a tracer Scene (its lights, model, coef and gating as constants)."""
    settings = scene.render
    ambient = [0.0, 0.0, 0.0]
    blocks = []
    for light in scene.lights:
        if isinstance(light, tracer.AmbientLight):
            ambient = [ambient[c] + light.intensity * light.color[c] for c in range(3)]
            continue
        if isinstance(light, tracer.DirectionalLight):
            header = (
                f"vector L = {_vector(light.direction)};\n"
                "        float dist = length(L);\n"
                '        int shadowed = trace(P, L / dist, "mindist", 0.001 * dist);\n        '
            )
            factor = ""
        else:
            header = (
                f"vector L = {_vector(light.location)} - P;\n"
                "        float dist = length(L);\n"
                '        int shadowed = trace(P, L / dist, "mindist", 0.001 * dist, "maxdist", dist);\n        '
            )
            factor = _spot(light) if isinstance(light, tracer.SpotLight) else ""
            if getattr(light, "falloff", "inverse_square") == "inverse_square":  # an area light: its centre's
                factor += "factor *= 1.0 / dot(L, L);\n        "
        gate = "NL > 0.0 && " if settings.gate_specular else ""
        blocks.append(
            "    {\n        float factor = 1.0;\n        "
            + header
            + factor
            + f"color weight = {float(light.intensity)!r} * factor * {_color(light.color)};\n"
            "        if (!shadowed) {\n"
            "            float NL = dot(S, L);\n"
            "            if (NL > 0.0) lit += weight * NL / dist;\n"
            f"            if ({gate}Specular > 0.0) {{\n"
            f"            {_highlight(settings)}\n"
            "            }\n"
            "        }\n"
            "    }\n"
        )
    mirror = "    if (Reflective > 0.0) BSDF += Reflective * reflection(N);\n" if settings.depth > 0 else ""
    return (
        "// Weathervane's exact twin: listing 3.2's FindIntensity as emission, listing 3.1's mirror as a closure.\n"
        "// Generated by addon/convert/exact_twin.py from the scene's lights; the materials are the parameters.\n"
        "shader weathervane_exact(\n"
        "    color Color = 0.8,\n"
        "    float Specular = 0.0,\n"
        "    float Reflective = 0.0,\n"
        "    int TwoSided = 0,\n"
        "    int OwnSpecularColor = 0,\n"
        "    color SpecularColor = 0.0,\n"
        "    color Emission = 0.0,\n"
        "    output closure color BSDF = 0)\n"
        "{\n"
        "    vector V = I;  // Cycles: I points from the shading point toward where the ray came from\n"
        "    // the documented normal is the surface's own, not the one Cycles turns toward the viewer\n"
        "    normal S = backfacing() ? -N : N;\n"
        "    normal G = backfacing() ? -Ng : Ng;\n"
        "    if (TwoSided && dot(G, V) < 0.0) S = -S;\n"
        f"    color lit = {_color(ambient)};\n"
        "    color highlight = 0.0;\n"
        + "".join(blocks)
        + "    color tint = OwnSpecularColor ? SpecularColor : Color;\n"
        "    color local = (lit * Color + highlight * tint) * (1.0 - Reflective) + Emission;\n"
        "    BSDF = local * emission();\n" + mirror + "}\n"
    )


def background_source(scene) -> str:
    """The OSL world: what any miss returns (listing 3.1), from the tracer's background."""
    background = scene.background
    if background.type == "sky":
        h, z = background.horizon, background.zenith
        body = (
            "    vector D = -normalize(I);  // Cycles: I points back along the ray\n"
            "    float k = clamp(D[2], 0.0, 1.0);\n"
            f"    color sky = {_color(h)} + ({_color(z)} - {_color(h)}) * k;\n"
        )
    else:
        if background.type in ("none", "image"):  # an image background: black (approximated() names it)
            flat = (0.0, 0.0, 0.0)
        elif background.type == "solid":
            flat = background.color
        else:
            direction = tracer.documented_background_direction(scene.camera, scene.render)
            flat = background.sky(direction[2])
        body = f"    color sky = {_color(flat)};\n"
    return (
        "// Weathervane's exact twin: the documented background, seen by camera and mirror rays only.\n"
        "shader weathervane_background(output closure color Background = 0)\n{\n"
        + body
        + "    Background = sky * emission();  // Cycles renders background() black from an OSL world\n}\n"
    )


# ---- the scene -----------------------------------------------------------------------------------------------------


def _script(name: str, source: str):
    text = bpy.data.texts.get(name) or bpy.data.texts.new(name)
    text.clear()
    text.write(source)
    return text


def _script_node(tree, text):
    from cycles import osl  # Blender's own Cycles add-on

    with contextlib.suppress(ImportError):  # Cycles before 4.3 does without it (unavailable() has checked)
        _oslquery()
    node = tree.nodes.new("ShaderNodeScript")
    node.mode = "INTERNAL"
    node.script = text
    problems = []
    if not osl.update_script_node(node, lambda kind, message: problems.append(message) if "ERROR" in kind else None):
        raise RuntimeError(f"the exact twin's OSL script did not compile: {'; '.join(problems)}")
    return node


def _scripted(owner, text, output_type: str, closure: str):
    """owner's (a material's or the world's) node tree made anew: the OSL script node's closure into its output."""
    compat.enable_nodes(owner)
    tree = owner.node_tree
    tree.nodes.clear()
    node = _script_node(tree, text)
    output = tree.nodes.new(output_type)
    tree.links.new(node.outputs[closure], output.inputs["Surface"])
    return node


def _exact_material(name: str, values: dict, text):
    material = bpy.data.materials.get(PREFIX + name) or bpy.data.materials.new(PREFIX + name)
    inputs = _scripted(material, text, "ShaderNodeOutputMaterial", "BSDF").inputs
    inputs["Color"].default_value = (*values.get("color", (0.8, 0.8, 0.8)), 1.0)
    inputs["Specular"].default_value = float(values.get("specular", 0.0))
    inputs["Reflective"].default_value = float(values.get("reflective", 0.0))
    inputs["TwoSided"].default_value = int(bool(values.get("two_sided", False)))
    specular_color = values.get("specular_color")
    inputs["OwnSpecularColor"].default_value = int(specular_color is not None)
    inputs["SpecularColor"].default_value = (*(specular_color or (0.0, 0.0, 0.0)), 1.0)
    inputs["Emission"].default_value = (*values.get("emission", (0.0, 0.0, 0.0)), 1.0)
    compat.no_emission_sampling(material)
    material["weathervane_exact_twin"] = True
    return material


def _world(text):
    world = bpy.data.worlds.get(WORLD) or bpy.data.worlds.new(WORLD)
    _scripted(world, text, "ShaderNodeOutputWorld", "Background")
    compat.no_world_sampling(world)
    return world


@dataclass
class ExactTwin:
    """What apply() changed, to put back."""

    scene: object
    slots: list = field(default_factory=list)  # (slot, original material)
    added: list = field(default_factory=list)  # (mesh data, count of materials before)
    hidden: list = field(default_factory=list)  # light objects hidden for the render
    world: object = None
    shading_system: bool = False
    source: str = ""
    approximated: list = field(default_factory=list)  # what of the tracer's scene the twin does not render as it

    def line(self) -> str:
        """One line naming what the exact twin renders differently from the tracer's scene; empty when nothing."""
        return f"exact twin: approximates {'; '.join(self.approximated)}" if self.approximated else ""

    def restore(self) -> None:
        for slot, material in self.slots:
            slot.material = material
        for data, count in self.added:
            while len(data.materials) > count:
                data.materials.pop()
        for obj in self.hidden:
            obj.hide_render = False
        self.scene.world = self.world
        self.scene.cycles.shading_system = self.shading_system


def _tracer_material(material, document: dict, blender_scene) -> dict:
    """A Blender material (or None) -> the tracer material the export gives it (the same the tracer renders)."""
    materials = document["materials"]
    if material is not None and material.get("weathervane_material") in materials:
        return materials[material["weathervane_material"]]
    key = f"blender:{material.name}" if material is not None else "blender:default"
    if key in materials:
        return materials[key]
    return material_convert.convert_material(material, blender_scene=blender_scene)[0]


def apply(
    context, samples: int = 64, seed: int = 0, document: dict | None = None, pixel_centres: bool = False
) -> ExactTwin:
    """Set the context's scene up as the exact twin (Cycles with OSL); returns what restores it.

    pixel_centres: Cycles' pixel samples as near the pixel centre as it allows (a Gaussian filter of the smallest
    width, 0.01 pixel), to compare with the tracer's one sample per pixel, which sits on the centre; else the
    twin's box filter of width 1. (An OSL camera could put them on the centre exactly, but Cycles 5.0 crashes when
    a surface shader calls trace() under an OSL camera.)"""
    reason = unavailable()
    if reason is not None:
        raise RuntimeError(f"no exact twin: {reason}")
    from . import export

    blender_scene = context.scene
    if document is None:
        document = export.scene_document(context)
    scene = tracer.scene_from_dict(json.loads(json.dumps(document)), "export")
    if any(isinstance(light, tracer.WorldLight) for light in scene.lights):  # the twin's OSL traces point lights
        raise RuntimeError("no exact twin: the world lights the scene (shadowed), which the twin's shader cannot trace")
    world = blender_scene.world
    twin.cycles(blender_scene, samples, seed)
    state = ExactTwin(scene=blender_scene, world=world, shading_system=blender_scene.cycles.shading_system)
    options = blender_scene.cycles
    options.shading_system = True
    # Cycles' max bounces N still follows an (N + 1)-th scattering to the next surface and adds its emission (that
    # is how direct light is "0 bounces"); here the emission is the whole local term, so the listing's depth D
    # (D mirror rays after the camera ray) is N = D - 1. Depth 0 has no mirror closure at all (shader_source).
    bounces = max(scene.render.depth - 1, 0)
    options.max_bounces = options.glossy_bounces = bounces
    options.diffuse_bounces = options.transmission_bounces = options.volume_bounces = 0
    options.min_light_bounces = bounces + 1  # no Russian roulette: every mirror path runs to its depth
    if hasattr(options, "min_transparent_bounces"):
        options.min_transparent_bounces = 0
    state.source = shader_source(scene)
    text = _script(SCRIPT, state.source)
    made: dict[str, object] = {}

    def exact(material):
        key = material.name if material is not None else ""
        if key not in made:
            values = _tracer_material(material, document, blender_scene)
            made[key] = _exact_material(key or "default", values, text)
        return made[key]

    for obj in blender_scene.objects:
        if obj.type == "LIGHT":
            if not obj.hide_render:
                obj.hide_render = True
                state.hidden.append(obj)
            continue
        if obj.type not in {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES"} or obj.data is None:
            continue
        if not obj.material_slots and hasattr(obj.data, "materials"):
            state.added.append((obj.data, len(obj.data.materials)))
            obj.data.materials.append(exact(None))
            continue
        for slot in obj.material_slots:
            if slot.material is not None and slot.material.get("weathervane_exact_twin"):
                continue
            state.slots.append((slot, slot.material))
            slot.material = exact(slot.material)
    blender_scene.world = _world(_script(SCRIPT.replace("Twin", "World"), background_source(scene)))
    if pixel_centres:
        options.pixel_filter_type = "GAUSSIAN"
        options.filter_width = 0.01
    state.approximated = approximated(scene)
    return state


def approximated(scene) -> list[str]:
    """What the exact twin renders differently from the tracer's Scene, one short phrase each. Camera and mirror
    visibility and holdouts stay Blender's own object settings, which Cycles honours; but OSL's trace() sees every
    object, so one that casts no shadow still does. The twin's film is never transparent (twin.cycles)."""
    notes = []
    names = [obj.name for obj in scene.objects if not getattr(obj, "visible_shadow", True)]
    if names:
        notes.append(f"{len(names)} object{'s' if len(names) > 1 else ''} casting no shadow (they cast one here)")
    if scene.render.film_transparent:
        notes.append("a transparent film (the background is rendered)")
    if any(isinstance(light, tracer.AreaLight) for light in scene.lights):
        notes.append("area lights (point lights at their centres here)")
    if scene.render.shadow_samples > 1 and any(
        getattr(light, "radius", 0.0) > 0.0 or getattr(light, "angle", 0.0) > 0.0 for light in scene.lights
    ):
        notes.append("soft shadows (hard here)")
    if scene.background.type == "image":
        notes.append("an image background (black here)")
    glass = sorted(name for name, material in scene.materials.items() if getattr(material, "transmission", 0.0) > 0.0)
    if glass:
        notes.append(f"glass ({', '.join(glass)}: transmission, opaque here)")
    clear = sorted(name for name, material in scene.materials.items() if getattr(material, "alpha", 1.0) < 1.0)
    if clear:
        notes.append(f"partly transparent materials ({', '.join(clear)}: alpha, opaque here)")
    return notes
