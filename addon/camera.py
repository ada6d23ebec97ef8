"""The tracer's camera -> a Blender camera object, and back: the models are the same (lens, sensor, fit)."""

from __future__ import annotations

import math

import bpy


def create(camera, collection, name: str = "WV Camera"):
    """A Blender camera object for a tracer Camera, linked into collection."""
    data = bpy.data.cameras.new(name)
    data.lens = camera.lens
    data.sensor_width = camera.sensor_width
    data.sensor_height = camera.sensor_height
    data.sensor_fit = camera.sensor_fit
    data.clip_start = 0.01
    data.clip_end = 1000.0
    obj = bpy.data.objects.new(name, data)
    obj.location = camera.location
    obj.rotation_euler = [math.radians(angle) for angle in camera.rotation]
    collection.objects.link(obj)
    return obj


def to_tracer(obj) -> dict:
    """A camera object -> the scene file's camera section (world transform, Euler XYZ degrees)."""
    location, rotation, _ = obj.matrix_world.decompose()
    euler = rotation.to_euler("XYZ")
    return {
        "location": list(location),
        "rotation": [math.degrees(angle) for angle in euler],
        "lens": obj.data.lens,
        "sensor_width": obj.data.sensor_width,
        "sensor_height": obj.data.sensor_height,
        "sensor_fit": obj.data.sensor_fit,
    }
