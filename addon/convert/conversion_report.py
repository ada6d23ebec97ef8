"""What the conversion of a scene's materials, lights and world approximates: per data-block, the notes of
material_convert, light_convert and world_convert, kept until a depsgraph update changes that data-block.

Render Properties > Scene Conversion draws `scene_conversion`; F12, `-a` and Export can print `summary_line` of it (one
line with the counts). Converting is done once per changed data-block, never on a redraw.
"""

from __future__ import annotations

import bpy

from ..vane import build
from . import light_convert, material_convert, world_convert

_updates = [0]  # depsgraph updates seen
_converted: dict[tuple[str, str], list[str]] = {}  # (kind, name) -> notes, until that data-block changes
_listing: dict[str, object] = {"update": -1, "scene": None, "rows": []}
_glass: dict[str, bool] = {}  # material name -> whether it lets light through (transmission), as last converted
_emits: dict[str, bool] = {}  # material name -> whether it emits light, as last converted
# scene name -> the materials its last export (F12, the Rendered view) met: those of objects hidden from the render
# that Geometry Nodes place (Object Info), which no object's slots hold
_exported: dict[str, frozenset[str]] = {}
# a glass material's note while Cycles' Light Paths > Caustics > Refractive is on (its default): the tracer's glass
# casts the shadow Cycles casts with it off (F12's line says the same)
GLASS_SHADOW = "shadow opaque: as Refractive Caustics off"


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph) -> None:
    """Count the update and forget the conversions of the materials, lights and worlds it changed."""
    _updates[0] += 1
    for update in depsgraph.updates:
        identifier = update.id.original if update.id.original is not None else update.id
        kind = type(identifier).__name__
        if isinstance(identifier, bpy.types.Material):
            _converted.pop(("material", identifier.name), None)
        elif isinstance(identifier, bpy.types.Light):
            for key in [key for key in _converted if key[0] == "light"]:
                _converted.pop(key)
        elif isinstance(identifier, bpy.types.Object) and identifier.type == "LIGHT":
            _converted.pop(("light", identifier.name), None)  # its light data may be another one now
        elif isinstance(identifier, bpy.types.World):
            _converted.pop(("world", identifier.name), None)
        elif kind in ("ShaderNodeTree", "Image", "Mesh"):
            if kind != "ShaderNodeTree":
                material_convert.clear_cache()
            _converted.clear()


def exported(scene_name: str, materials) -> None:
    """The export of this scene met these materials (names): the listing holds them from its next redraw."""
    names = frozenset(materials)
    if _exported.get(scene_name) != names:
        _exported[scene_name] = names
        _updates[0] += 1


def exported_forget() -> None:
    """Another file, an undo: what the last exports met is not known."""
    _exported.clear()
    _updates[0] += 1


def _notes(kind: str, name: str, convert) -> list[str]:
    key = (kind, name)
    if key not in _converted:
        try:
            _converted[key] = list(convert())
        except Exception as error:  # a panel must draw: the conversion's failure is what it shows
            _converted[key] = [f"not converted: {error}"]
    return _converted[key]


def scene_conversion(blender_scene) -> list[tuple[str, str, list[str]]]:
    """(kind, name, notes) for each material, light and the world the scene renders; empty notes: exact.

    Converted once per data-block and kept until a depsgraph update changes it; the listing itself is made again only
    after an update, never on a redraw."""
    # Cycles' default lets light through glass into its shadow; the tracer's glass casts Cycles' shadow with it off
    caustics = bool(getattr(getattr(blender_scene, "cycles", None), "caustics_refractive", False))
    bounces = int(getattr(getattr(blender_scene, "weathervane", None), "diffuse_bounces", 0))
    shown = (blender_scene.name, caustics, bounces, bpy.context.view_layer.name)
    if _listing["update"] == _updates[0] and _listing["scene"] == shown:
        return _listing["rows"]
    rows, materials, lights = [], {}, {}
    view_layer = bpy.context.view_layer if bpy.context.scene == blender_scene else blender_scene.view_layers[0]
    override = view_layer.material_override  # every surface's material, as Cycles renders it
    for obj in _rendered_objects(blender_scene):
        if obj.type == "LIGHT":
            lights[obj.name] = obj
        elif obj.type in ("MESH", "CURVE", "SURFACE", "META", "FONT") and override is None:
            for material in _materials_of(obj):
                materials.setdefault(material.name, material)
    for name in _exported.get(blender_scene.name, ()) if override is None else (override.name,):
        material = bpy.data.materials.get(name)
        if material is not None:
            materials.setdefault(name, material)
    for name in sorted(materials):
        material = materials[name]
        notes = _notes("material", name, lambda m=material: _material_notes(m, blender_scene))
        if caustics and _glass.get(name):
            notes = [*notes, GLASS_SHADOW]
        if bounces == 0 and _emits.get(name):
            notes = [*notes, material_convert.UNLIT_EMISSION]
        rows.append(("MATERIAL", name, notes))
    # beside the add-on's vane the Lights panel's lights and the vane's Background render, not the scene's own
    settings = getattr(blender_scene, "weathervane", None)
    vane = build.has_vane()
    driven = {entry.object_name for entry in settings.lights} if vane and settings is not None else set()
    for name in sorted(lights):
        obj = lights[name]
        if vane and name not in driven and not settings.other_lights:
            rows.append(("LIGHT", name, ["off (see Other Lights)"]))
            continue
        notes = _notes("light", name, lambda o=obj: light_convert.convert_light(o, blender_scene=blender_scene)[1])
        rows.append(("LIGHT", name, notes))
    world = world_convert.scene_world(blender_scene, view_layer)
    if vane:
        if world is not None:
            rows.append(("WORLD", world.name, ["vane's Background used"]))
    else:
        notes = _notes(
            "world",
            world.name if world else "",
            lambda: world_convert.convert_world(world, blender_scene=blender_scene)[2],
        )
        rows.append(("WORLD", world.name if world else "no world (black)", notes))
    _listing.update(update=_updates[0], scene=shown, rows=rows)
    return rows


def _rendered_objects(blender_scene):
    """The scene's objects that render, and those its collection instances place (nested, linked libraries' too),
    each once."""
    seen: set[int] = set()
    stack = [obj for obj in blender_scene.objects if not obj.hide_render]
    while stack:
        obj = stack.pop()
        if obj.as_pointer() in seen:
            continue
        seen.add(obj.as_pointer())
        yield obj
        collection = obj.instance_collection if obj.instance_type == "COLLECTION" else None
        if collection is not None:
            stack.extend(inner for inner in collection.all_objects if not inner.hide_render)


def _materials_of(obj):
    """An object's materials: its slots', and where Geometry Nodes may set others, its evaluated geometry's."""
    found = [slot.material for slot in obj.material_slots or () if slot.material is not None]
    if any(modifier.type == "NODES" for modifier in obj.modifiers):
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        data = getattr(evaluated, "data", None)
        found += [material for material in getattr(data, "materials", ()) if material is not None]
    return found


def _material_notes(material, blender_scene) -> list[str]:
    converted, notes = material_convert.convert_material(material, blender_scene=blender_scene)
    _glass[material.name] = converted.get("transmission", 0.0) > 0.0
    _emits[material.name] = material_convert.emits(converted)
    return notes


def summary_line(rows, characters: int | None = None, fits=None) -> str:
    """One line: how many materials, lights and worlds convert exactly and how many are approximated, with the first
    approximated names (up to three) that fit in characters, or that fits(line) accepts (a panel measures the line
    with Blender's font; all three where neither is given; none where even one does not fit)."""
    approximated = [name for _, name, notes in rows if notes]
    line = f"{len(rows) - len(approximated)} exact, {len(approximated)} approximated"
    for shown in range(min(3, len(approximated)), 0, -1):
        more = ", ..." if shown < len(approximated) else ""
        named = f"{line} ({', '.join(approximated[:shown])}{more})"
        if (characters is None or len(named) <= characters) and (fits is None or fits(named)):
            return named
    return line


def register() -> None:
    if _on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)


def unregister() -> None:
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    _converted.clear()
    _exported.clear()
    _listing.update(update=-1, scene=None, rows=[])
