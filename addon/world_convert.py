"""scene.world -> the tracer's background and an ambient light (docs/scene-format.md), and what it approximates.

Cycles shows a uniform world of radiance W = Background Color x Strength to camera and mirror rays, and lights an
unoccluded white diffuse surface to exactly W (measured in Cycles 5.0.1 and 3.4.1: a world (0.3, 0.5, 0.7) gives
(0.3, 0.5, 0.7) on a white plane; tests/addon/test_shading_convert.py). So:

    background  {"type": "solid", "color": W}
    ambient     {"type": "ambient", "intensity": 1, "color": W}     the documented ambient term, coloured; named,
                because Cycles' world light is occluded (ambient occlusion) and the documented ambient is not
                (a W above 1 becomes intensity max(W) and colour W / max(W), the same light; the background clips)

An environment texture's colour is its image's mean (weighted by solid angle), named; a sky texture has no colour
to read without rendering it: a clear-sky blue (SKY_MEAN) times its strength, named. No world is black with no
ambient, as in Cycles. The add-on's own world (twin.py, "WV World") is the panel's background, lighting nothing.
"""

from __future__ import annotations

import math

import bpy

from . import compat, material_convert

OWN_WORLD = "WV World"  # twin.WORLD
SKY_MEAN = (0.2, 0.35, 0.6)  # a clear day's sky, mean radiance at strength 1 (an estimate, named where used)
BLACK = {"type": "solid", "color": [0.0, 0.0, 0.0]}

_means: dict[tuple, tuple[float, float, float]] = {}


def environment_mean(image) -> tuple[float, float, float] | None:
    """An equirectangular image's mean linear colour over the sphere (rows weighted by cos(latitude)), cached."""
    key = (image.name, tuple(image.size), image.filepath)
    if key not in _means:
        rgb = material_convert.linear_rgb(image)
        if rgb is None:
            return None
        height = rgb.shape[0]
        weights = [math.cos((row + 0.5) / height * math.pi - math.pi / 2.0) for row in range(height)]
        rows = rgb.mean(axis=1)  # (height, 3)
        _means[key] = tuple(float(c) for c in (rows * [[weight] for weight in weights]).sum(axis=0) / sum(weights))
    return _means[key]


def _own_background(blender_scene) -> dict:
    settings = blender_scene.weathervane
    return {
        "type": settings.background,
        "color": list(settings.background_color),
        "horizon": list(settings.horizon),
        "zenith": list(settings.zenith),
    }


def _color_of(socket, notes: list[str]) -> tuple[float, float, float]:
    """The Background node's Color: its own, an RGB node's, an environment image's mean or a sky's estimate."""
    own = tuple(float(c) for c in socket.default_value[:3])
    if not socket.is_linked:
        return own
    node = socket.links[0].from_node
    if node.bl_idname == "ShaderNodeRGB":
        return tuple(float(c) for c in node.outputs[0].default_value[:3])
    if node.bl_idname == "ShaderNodeTexEnvironment" and node.image is not None:
        mean = environment_mean(node.image)
        if mean is not None:
            notes.append("environment texture: its mean colour")
            return mean
    if node.bl_idname == "ShaderNodeTexSky":
        notes.append(f"sky texture: a clear-sky blue {SKY_MEAN}")
        return SKY_MEAN
    notes.append(f"{node.name} on the world's Color: the input's own value")
    return own


def convert_world(world, *, blender_scene=None) -> tuple[dict, dict | None, list[str]]:
    """scene.world (or None) -> (tracer background dict, ambient light dict or None, notes)."""
    blender_scene = blender_scene or bpy.context.scene
    notes: list[str] = []
    if world is None:
        return dict(BLACK), None, notes
    if world.name == OWN_WORLD and hasattr(blender_scene, "weathervane"):
        return _own_background(blender_scene), None, notes
    if not compat.uses_nodes(world):
        color = [float(c) for c in world.color[:3]]
    else:
        tree = world.node_tree
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.target in ("ALL", "CYCLES")]
        output = ([n for n in outputs if n.is_active_output] or outputs or [None])[0]
        if output is None or not output.inputs["Surface"].is_linked:
            return dict(BLACK), None, notes
        if output.inputs["Volume"].is_linked:
            notes.append("world volume: ignored")
        shader = output.inputs["Surface"].links[0].from_node
        if shader.bl_idname != "ShaderNodeBackground":
            notes.append(f"{shader.bl_label} as the world: black")
            return dict(BLACK), None, notes
        color = _color_of(shader.inputs["Color"], notes)
        strength = shader.inputs["Strength"]
        if strength.is_linked:
            notes.append(f"{strength.links[0].from_node.name} on the world's Strength: the input's own value")
        color = [c * float(strength.default_value) for c in color]
    background = {"type": "solid", "color": [min(1.0, c) for c in color]}
    if max(color) > 1.0:
        notes.append("world brighter than 1: background clipped at 1, as the display shows it")
    visibility = getattr(world, "cycles_visibility", None)
    if visibility is not None and not visibility.camera:
        background = dict(BLACK)  # Cycles' camera rays do not see it
    if not any(c > 0.0 for c in color) or (visibility is not None and not visibility.diffuse):
        return background, None, notes
    notes.append("world light: unshadowed ambient")
    # intensity 1 and colour W; a W above 1 (the format's colours lie in [0, 1]) puts its largest channel in the
    # intensity: the same light
    brightest = max(1.0, max(color))
    return background, {"type": "ambient", "intensity": brightest, "color": [c / brightest for c in color]}, notes
