"""Tracer lights -> Blender light objects, and the panel's light entries -> their energies.

The documented lights are white scalars that add i cos(theta) to a surface's intensity, with no falloff. A white
diffuse surface in Cycles returns E / pi of the irradiance E, so:

- a directional light becomes a SUN of angle 0 (hard shadows) and strength pi * i, turned so that its local +Z
  (toward the light) is the documented direction;
- a point light becomes a POINT light of radius 0 with a Light Falloff node's Constant output as its strength (no
  inverse square), which makes E = P / (4 pi), so P = 4 pi^2 * i. (Both measured on a white plane in Cycles 5.0:
  sun strength 1 gives 0.3183 = 1 / pi; a point of 1 W with constant falloff 0.02533 = 1 / (4 pi^2) at 1.5 m and
  at 3 m.)

Ambient light has no Blender object: it is the materials' emission (materials.py).
"""

from __future__ import annotations

import math

import bpy
from mathutils import Matrix, Vector

from .. import compat

POINT_WATTS_PER_UNIT = 4.0 * math.pi**2
SUN_STRENGTH_PER_UNIT = math.pi


# a light object's property: its Glossy ray visibility was set by Build from a scene file's seen_in_mirrors
MIRRORS_ONLY = "weathervane_glossy_is_seen_in_mirrors"


def point_power(intensity: float) -> float:
    return intensity * POINT_WATTS_PER_UNIT


def sun_strength(intensity: float) -> float:
    return intensity * SUN_STRENGTH_PER_UNIT


def _constant_falloff(light_data) -> None:
    """Cycles: drive the light's emission by a Light Falloff node's Constant output (no inverse square)."""
    light_data.use_nodes = True
    tree = light_data.node_tree
    emission = next(node for node in tree.nodes if node.type == "EMISSION")
    falloff = tree.nodes.new("ShaderNodeLightFalloff")
    falloff.inputs["Strength"].default_value = 1.0
    tree.links.new(falloff.outputs["Constant"], emission.inputs["Strength"])


def object_name(kind: str, index: int) -> str:
    """The Blender name of the panel's light number index of a kind (POINT, DIRECTIONAL, SPOT or AREA), however it
    was made."""
    return f"WV {({'POINT': 'Point', 'SPOT': 'Spot', 'AREA': 'Area'}).get(kind, 'Sun')} {index}"


def create(kind: str, intensity: float, name: str, collection, vector=(0.0, 0.0, 1.0)):
    """A Blender light object for a point (vector: location) or directional (vector: toward the light) light."""
    if kind == "POINT":
        data = bpy.data.lights.new(name, type="POINT")
        data.shadow_soft_size = 0.0
        data.energy = point_power(intensity)
        _constant_falloff(data)
        obj = bpy.data.objects.new(name, data)
        obj.location = vector
    else:
        data = bpy.data.lights.new(name, type="SUN")
        data.angle = 0.0
        data.energy = sun_strength(intensity)
        obj = bpy.data.objects.new(name, data)
        # rounded to a millionth of a radian: the conversion leaves float noise that the panel shows as 0.000003°
        obj.rotation_euler = [round(angle, 6) + 0.0 for angle in Vector(vector).to_track_quat("Z", "Y").to_euler("XYZ")]
        obj["weathervane_direction_length"] = Vector(vector).length  # the documented L keeps its length
        obj["weathervane_direction"] = [float(c) for c in vector]  # exactly, while the light still points along it
    collection.objects.link(obj)
    return obj


def create_from_scene(light, name: str, collection):
    """A Blender light object for a scene file's point, directional, spot or area light that the documented panel
    entry cannot hold (a colour, inverse-square falloff, a radius, a sun's angle, a cone or a surface): made so that
    the add-on's conversion (convert/light_convert.py) gives the same light back. None for a documented point or
    directional light (create() makes those)."""
    kind = type(light).__name__
    if kind == "AmbientLight":
        return None
    plain = tuple(light.color) == (1.0, 1.0, 1.0)
    if kind == "PointLight" and plain and light.falloff == "none" and light.radius == 0.0:
        return None
    if kind == "DirectionalLight" and plain and light.angle == 0.0:
        return None
    if kind == "DirectionalLight":
        obj = create("DIRECTIONAL", light.intensity, name, collection, light.direction)
        obj.data.angle = math.radians(light.angle)
        if light.angle > 0.0 and hasattr(obj, "visible_glossy"):  # the file's disc is seen in mirrors, or not
            _seen_in_mirrors(obj, light.seen_in_mirrors)
    else:
        blender_type = {"PointLight": "POINT", "SpotLight": "SPOT", "AreaLight": "AREA"}[kind]
        data = bpy.data.lights.new(name, type=blender_type)
        obj = bpy.data.objects.new(name, data)
        obj.location = light.location
        collection.objects.link(obj)
        if blender_type == "AREA":
            _shape_area(obj, light)
        else:
            data.energy = point_power(light.intensity)
            data.shadow_soft_size = light.radius
            if hasattr(data, "use_soft_falloff"):  # 4.0+: the tracer's radius light keeps a point's inverse square
                data.use_soft_falloff = False
            if light.falloff == "none":
                _constant_falloff(data)
        if blender_type == "SPOT":
            data.spot_size, data.spot_blend = math.radians(light.spot_size), light.spot_blend
            obj.rotation_euler = (-Vector(light.direction)).to_track_quat("Z", "Y").to_euler("XYZ")
    obj.data.color = light.color
    return obj


def _shape_area(obj, light) -> None:
    """An area light's shape, size, power and orientation (local -Z along the light's direction, local X along its
    x_axis) as the tracer's area light has them."""
    data = obj.data
    data.shape = light.shape.upper()
    data.size = light.size[0]
    if light.shape in ("rectangle", "ellipse"):
        data.size_y = light.size[1]
    factor = compat.area_light_share()  # Cycles 3.4 emits pi / 4 of 4.0+'s
    data.energy = light.intensity * math.pi**2 / factor
    z = -Vector(light.direction).normalized()
    x = Vector(light.x_axis)
    x = (x - z * x.dot(z)).normalized()
    obj.matrix_world = Matrix.Translation(light.location) @ Matrix((x, z.cross(x), z)).transposed().to_4x4()
    if hasattr(obj, "visible_glossy"):  # the file's light is seen in mirrors, or not, in Cycles too
        _seen_in_mirrors(obj, light.seen_in_mirrors)


def _seen_in_mirrors(obj, seen: bool) -> None:
    """A scene file's light seen in mirrors, or not, as Cycles can say it: its Glossy ray visibility (which takes
    its highlight away in Cycles too). Marked, so that the export reads it back as seen_in_mirrors alone and the
    tracer keeps the file's highlight."""
    obj.visible_glossy = seen
    obj[MIRRORS_ONLY] = seen


def apply(entry) -> None:
    """Push a panel light entry's intensity to its Blender light."""
    obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
    if obj is None or obj.type != "LIGHT":
        return
    if entry.kind == "POINT" and obj.data.type == "POINT":
        obj.data.energy = point_power(entry.intensity)
    elif entry.kind == "DIRECTIONAL" and obj.data.type == "SUN":
        obj.data.energy = sun_strength(entry.intensity)


def direction_toward(obj) -> tuple[float, float, float]:
    """A sun's direction toward the light: its local +Z in world space, as long as the documented vector was."""
    axis = obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
    return tuple(axis.normalized() * float(obj.get("weathervane_direction_length", 1.0)))
