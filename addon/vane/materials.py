"""Tracer materials (color, specular exponent, reflectivity) -> Blender node materials named "WV <name>".

Each material's Surface is one group node, "WV Surface", whose three inputs are the documented material: Color,
Shininess (the specular exponent s) and Reflectivity (r). The Material tab shows them as the Surface's inputs, and
they are the values: the sidebar's Materials panel and the group node's inputs always hold the same numbers (an edit
of either is copied to the other: `sync_from_nodes` below, run by sync.py's handlers before every depsgraph
evaluation and every render; the panel's update callback writes the node). Inside the group (one, shared by every
vane material) is the documented model written as closely as Cycles allows (the "Cycles twin"):

    surface = (1 - r) * local + r * mirror           Mix Shader, factor = reflectivity r
    local   = diffuse(color) + highlight + ambient    the listing's intensity times color
    ambient = emission of ambient x color, seen by camera and mirror rays only (Light Path), so it neither lights
              other surfaces nor is shadowed, as the documented ambient term
    highlight = glossy (Beckmann) of color x highlight_gain(n), roughness from the exponent n (Walter et al. 2007:
              Beckmann alpha = sqrt(2 / (n + 2)), Blender roughness = sqrt(alpha)); n is specular x coef for
              Blinn-Phong and 4 x specular for Phong (a Phong lobe is about four times narrower in its exponent)
    mirror  = sharp glossy, white

The group computes n, the roughness and the gain with Math nodes from Shininess and two values the scene sets (the
exponent factor, coef or 4, and the ambient intensity: refresh_all). Only camera rays and mirror (singular) rays see
a surface or the background, so the rough highlight reflects the lights and nothing else, as documented. Diffuse and
highlight take their strength from the lights (see lights.py for the conversions). Where the documented lobe and a
microfacet lobe differ (the highlight's shape and its energy), the comparison report shows it.
"""

from __future__ import annotations

import math

import bpy

from .. import compat

PREFIX = "WV "


def highlight_gain(exponent: float) -> float:
    """The glossy color's factor that makes a Beckmann lobe's peak the documented highlight's.

    Beckmann with Walter's alpha^2 = 2 / (n + 2) is about the normalised Blinn-Phong lobe (n + 2) / (2 pi) cos^n;
    lit by a sun of strength pi * i it returns about i (n + 2) / 8 cos^n(theta_h) / cos(theta_o), while the
    documented model adds i cos^n(theta_h): so the factor is 8 / (n + 2), taking cos(theta_o) as 1."""
    return 8.0 / (exponent + 2.0) if exponent > 0.0 else 0.0


def exponent_for(specular: float, model: str = "blinn-phong", coef: float = 3.0) -> float:
    """The Blinn-Phong exponent that the documented model raises the half-vector cosine to."""
    return specular * coef if model == "blinn-phong" else 4.0 * specular


def roughness_from_exponent(exponent: float) -> float:
    """Blender roughness for a Blinn-Phong exponent n; matte (n = 0) is fully rough."""
    if exponent <= 0.0:
        return 1.0
    return math.sqrt(math.sqrt(2.0 / (exponent + 2.0)))


def ambient_of(blender_scene) -> float:
    """The summed intensity of the panel's ambient lights."""
    return sum(entry.intensity for entry in blender_scene.weathervane.lights if entry.kind == "AMBIENT")


def refresh_all(blender_scene) -> None:
    """Re-apply every panel material (after a change of ambient light, model or coef)."""
    settings = blender_scene.weathervane
    for entry in settings.materials:
        material = bpy.data.materials.get(material_name(entry.name))
        if material is not None:
            apply(
                material,
                tuple(entry.color),
                entry.specular,
                entry.reflective,
                ambient=ambient_of(blender_scene),
                model=settings.model,
                coef=settings.coef,
            )


def material_name(name: str) -> str:
    return f"{PREFIX}{name}"


GROUP = "WV Surface"  # the shared node group, and the name of each material's group node
TOP = GROUP
GROUP_VERSION = 1
INPUTS = ("Color", "Shininess", "Reflectivity")
SPECULAR_MAX = 10000.0  # properties.WEATHERVANE_PG_material.specular's max


def _node(tree, kind: str, name: str, location: tuple[int, int]):
    node = tree.nodes.new(kind)
    node.name = node.label = name
    node.location = location
    return node


def _math(tree, operation: str, name: str, location: tuple[int, int], *constants):
    """A Math node; constants fill its first inputs where not None (the rest are linked)."""
    node = _node(tree, "ShaderNodeMath", name, location)
    node.operation = operation
    for index, value in enumerate(constants):
        if value is not None:
            node.inputs[index].default_value = value
    return node


def _interface_socket(group, name: str, in_out: str, socket_type: str, description: str, **values):
    """A group input or output: Blender 4+'s interface, 3.x's inputs/outputs (a factor is its own socket type
    there, a subtype from 4)."""
    factor = values.pop("factor", False)
    if hasattr(group, "interface"):
        socket = group.interface.new_socket(name=name, in_out=in_out, socket_type=socket_type)
        if factor:
            socket.subtype = "FACTOR"
    else:
        sockets = group.inputs if in_out == "INPUT" else group.outputs
        socket = sockets.new(socket_type + ("Factor" if factor else ""), name)
    socket.description = description
    for key, value in values.items():
        setattr(socket, key, value)
    return socket


def _build_group(group) -> None:
    """The twin's graph inside the shared group (see the module's docstring)."""
    tree = group
    tree.nodes.clear()
    if hasattr(tree, "interface"):
        tree.interface.clear()
    else:
        tree.inputs.clear()
        tree.outputs.clear()
    _interface_socket(tree, "Color", "INPUT", "NodeSocketColor", "The documented material's colour (linear RGB)",
                      default_value=(0.8, 0.8, 0.8, 1.0))  # fmt: skip
    _interface_socket(
        tree, "Shininess", "INPUT", "NodeSocketFloat",
        "The documented specular exponent s: larger is a smaller, sharper highlight; 0 is matte",
        default_value=0.0, min_value=0.0, max_value=SPECULAR_MAX,
    )  # fmt: skip
    _interface_socket(tree, "Reflectivity", "INPUT", "NodeSocketFloat", "The documented reflectivity r: the share "
                      "of the mirrored ray in the colour", factor=True, default_value=0.0, min_value=0.0,
                      max_value=1.0)  # fmt: skip
    _interface_socket(tree, "Surface", "OUTPUT", "NodeSocketShader", "The documented material as a shader")
    links = tree.links
    inputs = _node(tree, "NodeGroupInput", "WV Inputs", (-900, 0))
    outputs = _node(tree, "NodeGroupOutput", "WV Group Output", (1200, 0))
    color, shininess, reflectivity = (inputs.outputs[name] for name in INPUTS)
    # the exponent n = Shininess x factor (coef for Blinn-Phong, 4 for Phong), roughness (2 / (n + 2))^(1/4),
    # the highlight's gain 8 / (n + 2) where Shininess > 0
    factor = _node(tree, "ShaderNodeValue", "WV Exponent Factor", (-900, -300))
    exponent = _math(tree, "MULTIPLY", "WV Exponent", (-700, -200))
    links.new(shininess, exponent.inputs[0])
    links.new(factor.outputs[0], exponent.inputs[1])
    plus_two = _math(tree, "ADD", "WV Exponent + 2", (-550, -200), None, 2.0)
    links.new(exponent.outputs[0], plus_two.inputs[0])
    ratio = _math(tree, "DIVIDE", "WV 2 / (n + 2)", (-400, -100), 2.0)
    links.new(plus_two.outputs[0], ratio.inputs[1])
    roughness = _math(tree, "POWER", "WV Roughness", (-250, -100), None, 0.25)
    links.new(ratio.outputs[0], roughness.inputs[0])
    gain = _math(tree, "DIVIDE", "WV Gain", (-400, -250), 8.0)
    links.new(plus_two.outputs[0], gain.inputs[1])
    shiny = _math(tree, "GREATER_THAN", "WV Shiny", (-400, -400), None, 0.0)
    links.new(shininess, shiny.inputs[0])
    gain_on = _math(tree, "MULTIPLY", "WV Highlight Gain", (-250, -300))
    links.new(gain.outputs[0], gain_on.inputs[0])
    links.new(shiny.outputs[0], gain_on.inputs[1])
    highlight_color = _node(tree, "ShaderNodeVectorMath", "WV Highlight Color", (-100, 100))
    highlight_color.operation = "SCALE"
    links.new(color, highlight_color.inputs[0])
    links.new(gain_on.outputs[0], highlight_color.inputs["Scale"])

    diffuse = _node(tree, "ShaderNodeBsdfDiffuse", "WV Diffuse", (100, 300))
    links.new(color, diffuse.inputs["Color"])
    highlight = _node(tree, "ShaderNodeBsdfGlossy", "WV Highlight", (100, 100))
    highlight.distribution = "BECKMANN"
    links.new(highlight_color.outputs[0], highlight.inputs["Color"])
    links.new(roughness.outputs[0], highlight.inputs["Roughness"])
    # ambient: the colour times the ambient intensity, for camera and mirror rays only (not diffuse ones)
    emission = _node(tree, "ShaderNodeEmission", "WV Ambient", (100, -100))
    links.new(color, emission.inputs["Color"])
    light_path = _node(tree, "ShaderNodeLightPath", "WV Light Path", (-400, -600))
    hidden = _math(tree, "SUBTRACT", "WV Not Diffuse", (-200, -500), 1.0)
    links.new(light_path.outputs["Is Diffuse Ray"], hidden.inputs[1])
    level = _node(tree, "ShaderNodeValue", "WV Ambient Level", (-200, -700))
    strength = _math(tree, "MULTIPLY", "WV Ambient Strength", (-50, -550))
    links.new(hidden.outputs[0], strength.inputs[0])
    links.new(level.outputs[0], strength.inputs[1])
    links.new(strength.outputs[0], emission.inputs["Strength"])
    first_sum = _node(tree, "ShaderNodeAddShader", "WV Direct", (350, 200))
    local = _node(tree, "ShaderNodeAddShader", "WV Local", (550, 100))
    links.new(diffuse.outputs[0], first_sum.inputs[0])
    links.new(highlight.outputs[0], first_sum.inputs[1])
    links.new(first_sum.outputs[0], local.inputs[0])
    links.new(emission.outputs[0], local.inputs[1])
    mirror = _node(tree, "ShaderNodeBsdfGlossy", "WV Mirror", (550, -200))
    mirror.distribution = "SHARP" if compat.VERSION < (4, 0, 0) else "GGX"
    mirror.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    mirror.inputs["Roughness"].default_value = 0.0
    mix = _node(tree, "ShaderNodeMixShader", "WV Mix", (800, 0))
    links.new(reflectivity, mix.inputs["Fac"])
    links.new(local.outputs[0], mix.inputs[1])
    links.new(mirror.outputs[0], mix.inputs[2])
    # only camera and mirror rays see a surface: the documented highlight reflects lights, not the scene
    visible = _math(tree, "MAXIMUM", "WV Visible", (800, -250))
    links.new(light_path.outputs["Is Camera Ray"], visible.inputs[0])
    links.new(light_path.outputs["Is Singular Ray"], visible.inputs[1])
    seen = _node(tree, "ShaderNodeMixShader", "WV Seen", (1000, 0))
    links.new(visible.outputs[0], seen.inputs["Fac"])
    links.new(mix.outputs[0], seen.inputs[2])
    links.new(seen.outputs[0], outputs.inputs[0])
    group["weathervane_group"] = GROUP_VERSION


def ensure_group():
    """The shared "WV Surface" node group, made (or made again where its graph is not this version's)."""
    group = bpy.data.node_groups.get(GROUP)
    if group is None or group.bl_idname != "ShaderNodeTree":
        group = bpy.data.node_groups.new(GROUP, "ShaderNodeTree")
    if group.get("weathervane_group") != GROUP_VERSION:
        _build_group(group)
    return group


def top_node(material):
    """A vane material's "WV Surface" group node (the Surface the Material tab shows), or None."""
    tree = material.node_tree if material is not None else None
    node = tree.nodes.get(TOP) if tree is not None else None
    if node is None or node.bl_idname != "ShaderNodeGroup" or node.node_tree is None:
        return None
    if any(name not in node.inputs for name in INPUTS):
        return None
    return node


def _build_material(material) -> None:
    """A material's tree: the group node into the Material Output."""
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    output = _node(tree, "ShaderNodeOutputMaterial", "WV Output", (300, 0))
    top = _node(tree, "ShaderNodeGroup", TOP, (0, 0))
    top.node_tree = ensure_group()
    top.width = 240
    tree.links.new(top.outputs[0], output.inputs["Surface"])


def ensure_material(
    name: str,
    color,
    specular: float,
    reflective: float,
    *,
    ambient: float = 0.0,
    model: str = "blinn-phong",
    coef: float = 3.0,
):
    """The add-on's material for a tracer material name, created or rebuilt in place."""
    material = bpy.data.materials.get(material_name(name)) or bpy.data.materials.new(material_name(name))
    material["weathervane_material"] = name
    _build_material(material)
    apply(material, color, specular, reflective, ambient=ambient, model=model, coef=coef)
    return material


def _set(socket, value) -> None:
    """Write a socket's value only where it differs: every write tags the material for a depsgraph update."""
    current = socket.default_value
    if isinstance(value, tuple):
        if any(a != b for a, b in zip(current, value, strict=True)):
            socket.default_value = value
    elif current != value:
        socket.default_value = value


def set_scene_values(ambient: float, model: str, coef: float) -> None:
    """The group's two scene-wide values: the exponent factor (coef for Blinn-Phong, 4 for Phong) and ambient."""
    group = ensure_group()
    _set(group.nodes["WV Exponent Factor"].outputs[0], float(exponent_for(1.0, model, coef)))
    _set(group.nodes["WV Ambient Level"].outputs[0], float(ambient))


def apply(
    material,
    color,
    specular: float,
    reflective: float,
    *,
    ambient: float = 0.0,
    model: str = "blinn-phong",
    coef: float = 3.0,
) -> None:
    """Set an add-on material's parameters (live edits from the panel); one built before the group had its graph
    flat: it is built again."""
    if top_node(material) is None:
        _build_material(material)
    set_scene_values(ambient, model, coef)
    node = top_node(material)
    rgba = (*(float(c) for c in color), 1.0)
    _set(node.inputs["Color"], rgba)
    _set(node.inputs["Shininess"], float(specular))
    _set(node.inputs["Reflectivity"], float(reflective))
    if tuple(material.diffuse_color) != rgba:
        material.diffuse_color = rgba  # the viewport's solid mode
    if hasattr(material, "cycles"):
        compat.no_emission_sampling(material)


def node_values(node) -> tuple[tuple[float, float, float], float, float]:
    """A group node's (color, specular, reflectivity) as the panel holds them: clamped to the panel's ranges."""
    color = tuple(min(1.0, max(0.0, float(c))) for c in node.inputs["Color"].default_value[:3])
    specular = min(SPECULAR_MAX, max(0.0, float(node.inputs["Shininess"].default_value)))
    reflective = min(1.0, max(0.0, float(node.inputs["Reflectivity"].default_value)))
    return color, specular, reflective


_syncing = [False]


def syncing() -> bool:
    """Whether sync_from_nodes is writing the panel now (its update callback must not write the nodes back)."""
    return _syncing[0]


def sync_from_nodes(blender_scene) -> bool:
    """Copy each vane material's group node inputs (edited in the Material tab or by a script) to the panel's
    entries, where they differ; a value outside the panel's range is clamped on both. True where anything changed."""
    settings = getattr(blender_scene, "weathervane", None)
    if settings is None or not len(settings.materials):
        return False
    changed = False
    _syncing[0] = True
    try:
        for entry in settings.materials:
            material = bpy.data.materials.get(material_name(entry.name))
            node = top_node(material)
            if node is None:
                continue
            color, specular, reflective = node_values(node)
            _set(node.inputs["Color"], (*color, 1.0))  # a no-op unless clamped
            _set(node.inputs["Shininess"], specular)
            _set(node.inputs["Reflectivity"], reflective)
            if tuple(entry.color) != color:
                entry.color, changed = color, True
                if tuple(material.diffuse_color) != (*color, 1.0):
                    material.diffuse_color = (*color, 1.0)  # the viewport's solid mode
            if entry.specular != specular:
                entry.specular, changed = specular, True
            if entry.reflective != reflective:
                entry.reflective, changed = reflective, True
    finally:
        _syncing[0] = False
    return changed
