"""Tracer lights -> Blender light objects, and the panel's light entries -> their energies.

The documented lights are white scalars without falloff. A point light becomes a POINT light of radius 0 whose
power is the intensity times 4 pi (W, so its radiant intensity is the scalar); a directional light becomes a SUN of
angle 0 and strength equal to the intensity, turned so that its local +Z (toward the light) is the documented
direction. Ambient light has no Blender object; the comparison issue renders it as emission.
"""

from __future__ import annotations

import math

import bpy
from mathutils import Vector

POINT_WATTS_PER_UNIT = 4.0 * math.pi


def point_power(intensity: float) -> float:
    return intensity * POINT_WATTS_PER_UNIT


def create(kind: str, intensity: float, name: str, collection, vector=(0.0, 0.0, 1.0)):
    """A Blender light object for a point (vector: location) or directional (vector: toward the light) light."""
    if kind == "POINT":
        data = bpy.data.lights.new(name, type="POINT")
        data.shadow_soft_size = 0.0
        data.energy = point_power(intensity)
        obj = bpy.data.objects.new(name, data)
        obj.location = vector
    else:
        data = bpy.data.lights.new(name, type="SUN")
        data.angle = 0.0
        data.energy = intensity
        obj = bpy.data.objects.new(name, data)
        obj.rotation_euler = Vector(vector).to_track_quat("Z", "Y").to_euler("XYZ")
        obj["weathervane_direction_length"] = Vector(vector).length  # the documented L keeps its length
    collection.objects.link(obj)
    return obj


def apply(entry) -> None:
    """Push a panel light entry's intensity to its Blender light."""
    obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
    if obj is None or obj.type != "LIGHT":
        return
    if entry.kind == "POINT" and obj.data.type == "POINT":
        obj.data.energy = point_power(entry.intensity)
    elif entry.kind == "DIRECTIONAL" and obj.data.type == "SUN":
        obj.data.energy = entry.intensity


def direction_toward(obj) -> tuple[float, float, float]:
    """A sun's direction toward the light: its local +Z in world space, as long as the documented vector was."""
    axis = obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
    return tuple(axis.normalized() * float(obj.get("weathervane_direction_length", 1.0)))
