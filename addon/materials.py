"""Tracer materials (color, specular exponent, reflectivity) -> Blender node materials named "WV <name>".

The graph follows the documented model as far as a physically based renderer allows: a Principled BSDF with the
color and a roughness from the Phong exponent (Walter et al. 2007: Beckmann alpha = sqrt(2 / (n + 2)), Blender
roughness = sqrt(alpha)), mixed with a sharp mirror by the reflectivity. The comparison issue tunes it further.
"""

from __future__ import annotations

import math

import bpy

from . import compat

PREFIX = "WV "


def roughness_from_exponent(exponent: float) -> float:
    """Blender roughness for a Phong exponent n; matte (n = 0) is fully rough."""
    if exponent <= 0.0:
        return 1.0
    return math.sqrt(math.sqrt(2.0 / (exponent + 2.0)))


def material_name(name: str) -> str:
    return f"{PREFIX}{name}"


def ensure_material(name: str, color: tuple[float, float, float], specular: float, reflective: float):
    """The add-on's material for a tracer material name, created or updated in place."""
    material = bpy.data.materials.get(material_name(name)) or bpy.data.materials.new(material_name(name))
    compat.enable_nodes(material)
    material["weathervane_material"] = name
    tree = material.node_tree
    nodes = tree.nodes
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    output.location = (600, 0)
    surface = nodes.new("ShaderNodeBsdfPrincipled")
    surface.name = "WV Surface"
    surface.location = (0, 100)
    mirror = nodes.new("ShaderNodeBsdfGlossy")
    mirror.name = "WV Mirror"
    mirror.location = (0, -300)
    mix = nodes.new("ShaderNodeMixShader")
    mix.name = "WV Mix"
    mix.location = (350, 0)
    tree.links.new(surface.outputs[0], mix.inputs[1])
    tree.links.new(mirror.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], output.inputs["Surface"])
    apply(material, color, specular, reflective)
    return material


def apply(material, color, specular: float, reflective: float) -> None:
    """Set an add-on material's parameters (live edits from the panel)."""
    nodes = material.node_tree.nodes
    surface, mirror, mix = nodes.get("WV Surface"), nodes.get("WV Mirror"), nodes.get("WV Mix")
    if surface is None or mirror is None or mix is None:
        return
    rgba = (*color, 1.0)
    surface.inputs["Base Color"].default_value = rgba
    surface.inputs["Roughness"].default_value = roughness_from_exponent(specular)
    compat.principled_socket(surface, "specular").default_value = 0.5 if specular > 0.0 else 0.0
    mirror.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    mirror.inputs["Roughness"].default_value = 0.0
    mix.inputs["Fac"].default_value = reflective
    material.diffuse_color = rgba  # the viewport's solid mode
