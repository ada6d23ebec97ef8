"""Tracer materials (color, specular exponent, reflectivity) -> Blender node materials named "WV <name>".

The graph is the documented model written as closely as Cycles allows (the "Cycles twin"), all in this module:

    surface = (1 - r) * local + r * mirror           Mix Shader, factor = reflectivity r
    local   = diffuse(color) + highlight + ambient    the listing's intensity times color
    ambient = emission of ambient x color, seen by camera and mirror rays only (Light Path), so it neither lights
              other surfaces nor is shadowed, as the documented ambient term
    highlight = glossy (Beckmann) of color x highlight_gain(n), roughness from the exponent n (Walter et al. 2007:
              Beckmann alpha = sqrt(2 / (n + 2)), Blender roughness = sqrt(alpha)); n is specular x coef for
              Blinn-Phong and 4 x specular for Phong (a Phong lobe is about four times narrower in its exponent)
    mirror  = sharp glossy, white

Only camera rays and mirror (singular) rays see a surface or the background, so the rough highlight reflects the
lights and nothing else, as documented. Diffuse and highlight take their strength from the lights (see lights.py
for the conversions). Where the documented lobe and a microfacet lobe differ (the highlight's shape and its
energy), the comparison report shows it.
"""

from __future__ import annotations

import math

import bpy

from . import compat

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


def _node(tree, kind: str, name: str, location: tuple[int, int]):
    node = tree.nodes.new(kind)
    node.name = node.label = name
    node.location = location
    return node


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
    compat.enable_nodes(material)
    material["weathervane_material"] = name
    tree = material.node_tree
    tree.nodes.clear()
    links = tree.links
    output = _node(tree, "ShaderNodeOutputMaterial", "WV Output", (1000, 0))
    diffuse = _node(tree, "ShaderNodeBsdfDiffuse", "WV Diffuse", (0, 300))
    highlight = _node(tree, "ShaderNodeBsdfGlossy", "WV Highlight", (0, 100))
    emission = _node(tree, "ShaderNodeEmission", "WV Ambient", (0, -100))
    light_path = _node(tree, "ShaderNodeLightPath", "WV Light Path", (-400, -200))
    hidden = _node(tree, "ShaderNodeMath", "WV Not Diffuse", (-200, -200))
    hidden.operation = "SUBTRACT"
    hidden.inputs[0].default_value = 1.0
    links.new(light_path.outputs["Is Diffuse Ray"], hidden.inputs[1])
    links.new(hidden.outputs[0], emission.inputs["Strength"])
    first_sum = _node(tree, "ShaderNodeAddShader", "WV Direct", (250, 200))
    local = _node(tree, "ShaderNodeAddShader", "WV Local", (450, 100))
    links.new(diffuse.outputs[0], first_sum.inputs[0])
    links.new(highlight.outputs[0], first_sum.inputs[1])
    links.new(first_sum.outputs[0], local.inputs[0])
    links.new(emission.outputs[0], local.inputs[1])
    mirror = _node(tree, "ShaderNodeBsdfGlossy", "WV Mirror", (450, -200))
    mix = _node(tree, "ShaderNodeMixShader", "WV Mix", (750, 0))
    links.new(local.outputs[0], mix.inputs[1])
    links.new(mirror.outputs[0], mix.inputs[2])
    # only camera and mirror rays see a surface: the documented highlight reflects lights, not the scene
    visible = _node(tree, "ShaderNodeMath", "WV Visible", (750, -250))
    visible.operation = "MAXIMUM"
    links.new(light_path.outputs["Is Camera Ray"], visible.inputs[0])
    links.new(light_path.outputs["Is Singular Ray"], visible.inputs[1])
    seen = _node(tree, "ShaderNodeMixShader", "WV Seen", (900, 0))
    links.new(visible.outputs[0], seen.inputs["Fac"])
    links.new(mix.outputs[0], seen.inputs[2])
    output.location = (1100, 0)
    links.new(seen.outputs[0], output.inputs["Surface"])
    apply(material, color, specular, reflective, ambient=ambient, model=model, coef=coef)
    return material


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
    """Set an add-on material's parameters (live edits from the panel)."""
    nodes = material.node_tree.nodes
    needed = ("WV Diffuse", "WV Highlight", "WV Ambient", "WV Mirror", "WV Mix")
    if any(nodes.get(name) is None for name in needed):
        return
    rgba = (*color, 1.0)
    nodes["WV Diffuse"].inputs["Color"].default_value = rgba
    highlight = nodes["WV Highlight"]
    highlight.distribution = "BECKMANN"
    exponent = exponent_for(specular, model, coef)
    gain = highlight_gain(exponent)
    highlight.inputs["Color"].default_value = (
        (*(channel * gain for channel in color), 1.0) if specular > 0.0 else (0.0, 0.0, 0.0, 1.0)
    )
    highlight.inputs["Roughness"].default_value = roughness_from_exponent(exponent)
    nodes["WV Ambient"].inputs["Color"].default_value = (*(channel * ambient for channel in color), 1.0)
    mirror = nodes["WV Mirror"]
    mirror.distribution = "SHARP" if compat.VERSION < (4, 0, 0) else "GGX"
    mirror.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    mirror.inputs["Roughness"].default_value = 0.0
    nodes["WV Mix"].inputs["Fac"].default_value = reflective
    material.diffuse_color = rgba  # the viewport's solid mode
    if hasattr(material, "cycles"):
        compat.no_emission_sampling(material)
