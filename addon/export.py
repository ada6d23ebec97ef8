"""A Blender scene -> a tracer scene document (the JSON of docs/scene-format.md).

The add-on's own objects map back exactly from what `build` recorded on them (kind, sizes, material) and their
world transforms at the current frame; any other visible mesh object exports as world-space triangles with a matte
material of its viewport color; the panel's lights and the scene camera convert, and the scene's other lights only
where the Lights panel's Other Lights is on.
"""

from __future__ import annotations

import json
import math

import bpy
from mathutils import Vector

from . import build, lights
from . import camera as camera_module
from .animation import motion_for


def _transform(matrix) -> dict:
    location, rotation, _ = matrix.decompose()
    return {"location": list(location), "rotation": [math.degrees(angle) for angle in rotation.to_euler("XYZ")]}


def _unturned(obj, turn):
    """obj's world matrix with the vane at heading 0: the turn's parent (the pivot) in place of the turn itself.

    Computed from the stored matrices, so export never writes to Blender data (it runs inside renders too)."""
    if turn is None or obj.parent != turn:
        return obj.matrix_world
    base = turn.parent.matrix_world if turn.parent is not None else turn.matrix_world @ turn.matrix_basis.inverted()
    return base @ obj.matrix_parent_inverse @ obj.matrix_basis


def _foreign_mesh(obj, depsgraph, materials: dict) -> dict | None:
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        if not mesh.loop_triangles:
            return None
        matrix = obj.matrix_world
        vertices = [list(matrix @ vertex.co) for vertex in mesh.vertices]
        triangles = [list(triangle.vertices) for triangle in mesh.loop_triangles]
    finally:
        evaluated.to_mesh_clear()
    material = obj.active_material
    name = f"blender:{material.name}" if material else "blender:default"
    color = list(material.diffuse_color[:3]) if material else [0.8, 0.8, 0.8]
    materials.setdefault(name, {"color": [min(1.0, max(0.0, c)) for c in color], "specular": 0, "reflective": 0})
    return {"name": obj.name, "type": "mesh", "material": name, "vertices": vertices, "triangles": triangles}


def _collect(blender_scene, depsgraph, turn, materials: dict, objects: list, parts: list) -> None:
    for obj in blender_scene.objects:
        if obj.type != "MESH" or obj.hide_render:
            continue
        if "weathervane_object" in obj:
            body = json.loads(obj["weathervane_object"])
            body.update(_transform(_unturned(obj, turn)))
            objects.append(body)
            if turn is not None and obj.parent == turn:
                parts.append(body["name"])
        else:
            body = _foreign_mesh(obj, depsgraph, materials)
            if body is not None:
                objects.append(body)


def other_lights(blender_scene) -> list:
    """The scene's rendered Blender lights that no entry of the panel's Lights list drives."""
    driven = {entry.object_name for entry in blender_scene.weathervane.lights if entry.object_name}
    return [
        obj for obj in blender_scene.objects if obj.type == "LIGHT" and obj.name not in driven and not obj.hide_render
    ]


def scene_document(context, depsgraph=None, blender_scene=None) -> dict:
    """The current Blender scene (or the depsgraph's, inside a render) as a tracer scene document."""
    blender_scene = blender_scene or context.scene
    settings = blender_scene.weathervane
    depsgraph = depsgraph or context.evaluated_depsgraph_get()
    materials = {
        entry.name: {"color": list(entry.color), "specular": entry.specular, "reflective": entry.reflective}
        for entry in settings.materials
    }
    objects, parts = [], []
    turn = bpy.data.objects.get(build.TURN)
    # the parts go out as modelled (heading 0) and the current turn becomes the vane's heading
    heading = math.degrees(turn.evaluated_get(depsgraph).matrix_basis.to_euler("XYZ")[2]) if turn is not None else 0.0
    _collect(blender_scene, depsgraph, turn, materials, objects, parts)
    light_list = []
    for entry in settings.lights:
        obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
        if entry.kind == "AMBIENT":
            light_list.append({"type": "ambient", "intensity": entry.intensity})
        elif obj is not None and entry.kind == "POINT":
            light_list.append(
                {"type": "point", "location": list(obj.matrix_world.translation), "intensity": entry.intensity}
            )
        elif obj is not None:
            light_list.append(
                {"type": "directional", "direction": list(lights.direction_toward(obj)), "intensity": entry.intensity}
            )
    for obj in other_lights(blender_scene) if settings.other_lights else ():
        if obj.data.type == "SUN":
            intensity = obj.data.energy / lights.SUN_STRENGTH_PER_UNIT
            light_list.append(
                {"type": "directional", "direction": list(lights.direction_toward(obj)), "intensity": intensity}
            )
        else:
            intensity = obj.data.energy / lights.POINT_WATTS_PER_UNIT
            light_list.append({"type": "point", "location": list(obj.matrix_world.translation), "intensity": intensity})
    render = blender_scene.render
    scale = render.resolution_percentage / 100.0
    document = {
        "materials": materials,
        "objects": objects,
        "lights": light_list,
        "background": {
            "type": settings.background,
            "color": list(settings.background_color),
            "horizon": list(settings.horizon),
            "zenith": list(settings.zenith),
        },
        "render": {
            "width": max(1, round(render.resolution_x * scale)),
            "height": max(1, round(render.resolution_y * scale)),
            "depth": settings.depth,
            "model": settings.model,
            "coef": settings.coef,
            "samples": int(settings.samples),
            "workers": settings.workers,
            "numerics": settings.numerics,
            "dtype": settings.precision,
            "pixel_aspect": [render.pixel_aspect_x, render.pixel_aspect_y],
        },
    }
    if blender_scene.camera is not None:
        document["camera"] = camera_module.to_tracer(blender_scene.camera)
    pivot = bpy.data.objects.get(build.PIVOT)
    if parts and pivot is not None:
        axis = pivot.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
        document["vane"] = {
            "parts": parts,
            "pivot": list(pivot.matrix_world.translation),
            "axis": list(axis.normalized()),
            "heading": heading,
        }
        motion = motion_for(blender_scene, max(1, blender_scene.frame_end))
        document["wind"] = _wind_document(motion.wind)
        document["motion"] = {
            "mode": motion.mode,
            "damping": motion.damping,
            "wavelength": motion.wavelength,
            "threshold": motion.threshold,
            "friction_time": motion.friction_time,
            "fps": motion.fps,
            "initial_heading": float(turn.get("weathervane_initial_heading", heading)) if turn else heading,
            "spin": {
                "direction": motion.spin.direction,
                "speed": motion.spin.speed,
                "smoothness": motion.spin.smoothness,
                "start": motion.spin.start,
                "stop": motion.spin.stop,
            },
        }
    return document


def _wind_document(wind) -> dict:
    keys = list(wind.keys)
    # consecutive equal keys add nothing: keep the ends of each run
    kept = [
        key
        for index, key in enumerate(keys)
        if index in (0, len(keys) - 1)
        or (key.direction, key.speed) != (keys[index - 1].direction, keys[index - 1].speed)
        or (key.direction, key.speed) != (keys[index + 1].direction, keys[index + 1].speed)
    ]
    document = {
        "keys": [{"time": key.time, "direction": key.direction, "speed": key.speed} for key in kept],
        "start": wind.start,
        "stop": wind.stop,
    }
    if len(kept) == 1:
        document = {"direction": kept[0].direction, "speed": kept[0].speed, "start": wind.start, "stop": wind.stop}
    if wind.gusts is not None:
        document["gusts"] = {
            "intensity": wind.gusts.intensity,
            "time_scale": wind.gusts.time_scale,
            "seed": wind.gusts.seed,
        }
    return document
