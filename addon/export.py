"""A Blender scene -> a tracer scene document (the JSON of docs/scene-format.md).

The add-on's own objects map back exactly from what `build` recorded on them (kind, sizes, material) and their
world transforms at the current frame; any other visible mesh object exports as world-space triangles with a matte
material of its viewport color; the panel's lights and the scene camera convert, and the scene's other lights only
where the Lights panel's Other Lights is on.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Vector

from . import build, light_convert, material_convert, mesh_export, world_convert
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


# Object types Blender renders that the tracer cannot: named and counted in the warning line
NOT_TRACED = {
    "POINTCLOUD": "point cloud",
    "VOLUME": "volume",
    "GPENCIL": "grease pencil",
    "GREASEPENCIL": "grease pencil",
    "CURVES": "hair curves",
}


@dataclass
class ExportNotes:
    """What the export could not say exactly: the one warning line of F12 and `-a`, the scene file's comment."""

    not_traced: dict[str, list[str]] = field(default_factory=dict)  # kind -> object names
    dropped_triangles: dict[str, int] = field(default_factory=dict)  # object -> zero-area triangles left out
    approximated: list[str] = field(default_factory=list)
    materials: dict[str, list[str]] = field(default_factory=dict)  # Blender material -> what its mapping approximates
    lights: dict[str, list[str]] = field(default_factory=dict)  # Blender light -> the same
    world: list[str] = field(default_factory=list)

    def not_rendered(self, kind: str, name: str) -> None:
        names = self.not_traced.setdefault(kind, [])
        if name not in names:
            names.append(name)

    def line(self) -> str:
        """One line for the user, empty when the export is exact."""
        parts = []
        for kind, names in self.not_traced.items():
            shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
            parts.append(f"{len(names)} {kind} object{'s' if len(names) > 1 else ''} not rendered ({shown})")
        if self.dropped_triangles:
            total = sum(self.dropped_triangles.values())
            names = ", ".join(list(self.dropped_triangles)[:3])
            parts.append(f"{total} zero-area triangle{'s' if total > 1 else ''} left out ({names})")
        parts += self.approximated
        counted = [
            f"{len(names)} {kind}{'s' if len(names) > 1 else ''}"
            for kind, names in (("material", self._noted(self.materials)), ("light", self._noted(self.lights)))
            if names
        ] + (["the world"] if self.world else [])
        if counted:
            parts.append(f"approximated: {', '.join(counted)} (Render Properties > Scene Conversion says how)")
        return "; ".join(parts)

    @staticmethod
    def _noted(mapping: dict[str, list[str]]) -> list[str]:
        return [name for name, said in mapping.items() if said]


def named_problems(problems: list[str], document: dict) -> list[str]:
    """The loader's problems with `objects[3]` replaced by the Blender object's name (`object "Suzanne"`), which is
    what the user can find in the Outliner."""
    names = [obj.get("name", "?") for obj in document.get("objects", [])]

    def name(match: re.Match) -> str:
        index = int(match.group(1))
        return f'object "{names[index]}"' if index < len(names) else match.group(0)

    return [re.sub(r"objects\[(\d+)\]", name, problem) for problem in problems]


def _visible_in_render(obj) -> bool:
    """For a viewport depsgraph (Export, the Rendered view), Blender's render visibility of an original object:
    a render depsgraph has already left out what is disabled in renders."""
    if obj.hide_render:
        return False
    return not any(collection.hide_render for collection in obj.users_collection)


def _material_name(material, materials: dict, notes: ExportNotes | None = None) -> str:
    """A Blender material (or None) -> the name of its scene-file material, converted once from its node tree."""
    name = f"blender:{material.name}" if material is not None else "blender:default"
    if name not in materials:
        materials[name], said = material_convert.convert_material(material)
        if notes is not None and material is not None:
            notes.materials[material.name] = said
    return name


def _mesh_object(name: str, obj, arrays, matrix, materials: dict, notes: ExportNotes) -> dict | None:
    """One instance of an evaluated object's mesh as a scene-file mesh, with its materials and visibility."""
    fields, slots, dropped = mesh_export.in_world(arrays, matrix)
    if dropped:
        notes.dropped_triangles[name] = notes.dropped_triangles.get(name, 0) + dropped
    if not fields["triangles"]:
        return None
    slot_materials = [slot.material for slot in obj.material_slots] or [None]
    # a face whose slot index is past the object's slots takes the last slot, as Blender's render does
    slots = np.minimum(slots, len(slot_materials) - 1)
    used = sorted(set(slots.tolist()))
    first = _material_name(slot_materials[used[0]], materials, notes)
    body = {"name": name, "type": "mesh", "material": first, **fields}
    if len(used) > 1:
        body["materials"] = [_material_name(material, materials, notes) for material in slot_materials]
        body["material_indices"] = slots.tolist()
    for flag, field_name in (("visible_camera", "visible_camera"), ("visible_shadow", "visible_shadow")):
        if not getattr(obj, flag, True):
            body[field_name] = False
    if not getattr(obj, "visible_glossy", True):
        body["visible_reflection"] = False
    if getattr(obj, "is_holdout", False):
        body["holdout"] = True
    return body


@dataclass
class _Collected:
    objects: list = field(default_factory=list)
    parts: list = field(default_factory=list)  # names of the vane's turning parts
    lights: list = field(default_factory=list)  # (original light object, evaluated object, world matrix)


def _collect(depsgraph, turn, materials: dict, notes: ExportNotes) -> _Collected:
    """Every object instance Blender renders at the depsgraph's frame, with its evaluated world matrix."""
    collected = _Collected()
    viewport = depsgraph.mode == "VIEWPORT"
    meshes: dict[tuple, object] = {}  # one read per evaluated object, however many instances
    instance_count: dict[str, int] = {}
    names: set[str] = set()  # scene-file names are unique
    for instance in depsgraph.object_instances:
        obj = instance.object
        original = obj.original
        parent = instance.parent.original if instance.is_instance and instance.parent is not None else None
        if viewport and not _visible_in_render(parent if parent is not None else original):
            continue
        if not getattr(instance, "show_self", True):
            continue
        matrix = instance.matrix_world.copy()
        if obj.type == "LIGHT":
            collected.lights.append((original, obj, matrix))
            continue
        if obj.type in NOT_TRACED:
            notes.not_rendered(NOT_TRACED[obj.type], original.name)
            continue
        if obj.type != "MESH":
            # empties, cameras, armatures, lattices render nothing; a text, curve, surface or metaball object's mesh
            # comes as an instance of its own (a Mesh with the object as its parent), as Cycles reads it
            continue
        if not instance.is_instance and "weathervane_object" in original:
            body = json.loads(original["weathervane_object"])
            body.update(_transform(_unturned(original, turn)))
            collected.objects.append(body)
            if turn is not None and original.parent == turn:
                collected.parts.append(body["name"])
            continue
        key = (obj.name, obj.data.as_pointer() if obj.data is not None else 0)
        if key not in meshes:
            meshes[key] = mesh_export.read(obj)
        if meshes[key] is None:
            continue
        if instance.is_instance and parent is not original:  # not the mesh of a text, curve or metaball itself
            owner = parent.name if parent is not None else "instance"
            count = instance_count[owner] = instance_count.get(owner, 0) + 1
            name = f"{owner}/{original.name}#{count}"
        else:
            name = original.name
        while name in names:  # Geometry Nodes instances of an object's own geometry share its name
            instance_count[name] = instance_count.get(name, 0) + 1
            name = f"{original.name}#{instance_count[name]}"
        names.add(name)
        body = _mesh_object(name, obj, meshes[key], matrix, materials, notes)
        if body is not None:
            collected.objects.append(body)
    return collected


def other_lights(blender_scene) -> list:
    """The scene's rendered Blender lights that no entry of the panel's Lights list drives."""
    driven = {entry.object_name for entry in blender_scene.weathervane.lights if entry.object_name}
    return [
        obj for obj in blender_scene.objects if obj.type == "LIGHT" and obj.name not in driven and not obj.hide_render
    ]


def entry_kind(entry) -> str:
    """What a Lights panel entry is now: AMBIENT, or its Blender light's type as the tracer names it (POINT,
    DIRECTIONAL for a sun, SPOT, AREA), which the Light tab may have changed since the entry was added."""
    obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
    if entry.kind == "AMBIENT" or obj is None or obj.type != "LIGHT":
        return entry.kind
    return {"SUN": "DIRECTIONAL"}.get(obj.data.type, obj.data.type)


def _direction_toward(obj, matrix) -> list[float]:
    """A sun's direction toward the light at this world matrix: its local +Z, as long as the documented vector."""
    axis = matrix.to_3x3() @ Vector((0.0, 0.0, 1.0))
    return list(axis.normalized() * float(obj.get("weathervane_direction_length", 1.0)))


def _blender_light(light, notes: ExportNotes) -> dict:
    """A light the panel does not drive (an evaluated light object) -> a scene-file light in Cycles' units."""
    document, said = light_convert.convert_light(light)
    notes.lights[light.name] = said
    if document["type"] == "spot" and bpy.app.version < (4, 0, 0):
        document["spot_model"] = "cycles3"  # Cycles before 4.0 also weights a spot by the angle's cosine
    return document


def _light_documents(settings, collected: _Collected, own_vane: bool, notes: ExportNotes) -> list[dict]:
    """The panel's lights (at their evaluated places), then the scene's other rendered lights: always when the
    scene has no vane of the add-on's, else only with Other Lights on."""
    placed = {original.name: (evaluated, matrix) for original, evaluated, matrix in collected.lights}
    documents = []
    driven = set()
    for entry in settings.lights:
        kind = entry_kind(entry)
        if kind == "AMBIENT":
            documents.append({"type": "ambient", "intensity": entry.intensity})
            continue
        obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
        if obj is None:
            continue
        driven.add(obj.name)
        if obj.name not in placed:
            continue  # not rendered (an excluded collection, Disable in Renders)
        evaluated, matrix = placed[obj.name]
        if kind == "POINT":
            documents.append({"type": "point", "location": list(matrix.translation), "intensity": entry.intensity})
        elif kind == "DIRECTIONAL":
            documents.append(
                {"type": "directional", "direction": _direction_toward(obj, matrix), "intensity": entry.intensity}
            )
        else:  # made a spot or area light in Blender's Light tab: it renders as Blender's light of that type
            documents.append(_blender_light(evaluated, notes))
    if settings.other_lights or not own_vane:
        for original, evaluated, _ in collected.lights:
            if original.name not in driven:
                documents.append(_blender_light(evaluated, notes))
    return documents


def scene_document(context, depsgraph=None, blender_scene=None, notes: ExportNotes | None = None) -> dict:
    """The Blender scene as Blender renders it at the depsgraph's frame (the current one for the context's
    depsgraph, the frame being rendered inside a render) as a tracer scene document. notes, when given, collects
    what is approximated or left out; the document's comment says the same in one line."""
    blender_scene = blender_scene or context.scene
    settings = blender_scene.weathervane
    depsgraph = depsgraph or context.evaluated_depsgraph_get()
    notes = notes if notes is not None else ExportNotes()
    materials = {
        entry.name: {"color": list(entry.color), "specular": entry.specular, "reflective": entry.reflective}
        for entry in settings.materials
    }
    turn = bpy.data.objects.get(build.TURN)
    # the parts go out as modelled (heading 0) and the current turn becomes the vane's heading
    heading = math.degrees(turn.evaluated_get(depsgraph).matrix_basis.to_euler("XYZ")[2]) if turn is not None else 0.0
    collected = _collect(depsgraph, turn, materials, notes)
    objects, parts = collected.objects, collected.parts
    own_vane = any("weathervane_object" in obj for obj in bpy.data.objects)
    light_list = _light_documents(settings, collected, own_vane, notes)
    if not materials:  # a scene with nothing to render still needs one material in the file
        _material_name(None, materials)
    background = {
        "type": settings.background,
        "color": list(settings.background_color),
        "horizon": list(settings.horizon),
        "zenith": list(settings.zenith),
    }
    if not own_vane:  # the scene's world is its background and, as Cycles lights with it, an ambient light
        background, ambient, notes.world = world_convert.convert_world(blender_scene.world, blender_scene=blender_scene)
        light_list += [ambient] if ambient is not None else []
    render = blender_scene.render
    scale = render.resolution_percentage / 100.0
    document = {
        "materials": materials,
        "objects": objects,
        "lights": light_list,
        "background": background,
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
        document["camera"] = camera_module.to_tracer(blender_scene.camera.evaluated_get(depsgraph))
    if render.film_transparent:
        document["render"]["film_transparent"] = True
    if notes.line():
        document["comment"] = notes.line()
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
