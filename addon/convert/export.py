"""A Blender scene, as its depsgraph evaluates it at a frame -> a tracer scene document (docs/scene-format.md), and
notes on what it could not say exactly (the one warning line of F12, the scene file's comment).

What becomes what:

- The add-on's own objects (made by `build`, marked "weathervane_object") map back exactly: the kind, sizes and
  material `build` recorded, at their evaluated world transforms; the vane's turning parts as modelled (heading 0),
  with the turn's angle as the vane's heading and the panel's wind and motion settings.
- Every other object instance the depsgraph renders (depsgraph.object_instances: plain objects, collection
  instances, vertex and face instancing, particles, Geometry Nodes instances; a text, curve, surface or metaball
  object as its evaluated mesh) is a geometry read once (mesh_export) and placed. A geometry placed once is a "mesh"
  object in world space, as Cycles bakes a geometry used once; one placed several times is one entry of the
  document's "meshes" table in its own space, placed by the matrices of an "instances" object per set of materials
  and visibility flags (a forest of 10,000 instances of one sphere is one sphere and 10,000 matrices). What the vane
  turns keeps the world-space form.
- Materials: each Blender material's node tree converted by material_convert; lights: the panel's Lights entries,
  and the scene's other lights in Cycles' units (always in a scene without the add-on's vane, else with Other Lights
  on); the world as background and ambient light where there is no vane; the scene camera; the render settings.

Nothing is read twice that did not change: geometry (mesh_export.CACHE) and material conversions are remembered
between exports (F12s, animation frames, the Rendered view's updates) and forgotten when a depsgraph update says their
data changed. `register` installs the depsgraph handlers that say so; the engine's view_update calls `observe` itself,
as Blender calls it inside the evaluation, before the handlers run.
"""

from __future__ import annotations

import heapq
import itertools
import json
import math
import re
from collections import OrderedDict
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Vector

from .. import compat
from .. import tracer_api as tracer
from ..vane import build
from ..vane import camera as camera_module
from ..vane import materials as vane_materials
from ..vane.animation import motion_for
from . import conversion_report, light_convert, material_convert, mesh_export, motion_blur, pass_map, world_convert


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
    lights_left_out: list[str] = field(default_factory=list)  # the scene's lights beside the vane's own, not rendered
    # Blender's controls of what an object is in the render that the tracer does not express -> the objects' names
    # (shadow catcher, an emissive object's light linking)
    controls: dict[str, list[str]] = field(default_factory=dict)

    def not_expressed(self, control: str, name: str) -> None:
        names = self.controls.setdefault(control, [])
        if name not in names:
            names.append(name)

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
        if self.lights_left_out:
            count, names = len(self.lights_left_out), ", ".join(self.lights_left_out[:3])
            more = f" and {count - 3} more" if count > 3 else ""
            parts.append(
                f"{count} light{'s' if count > 1 else ''} beside the vane's not rendered ({names}{more}; "
                "Lights > Other Lights renders them)"
            )
        for control, names in self.controls.items():
            shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
            parts.append(f"{control} ({shown})")
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


def named_problems(problems: list[str], document: dict, world=None) -> list[str]:
    """The loader's problems with `objects[3]` replaced by the Blender object's name (`object "Suzanne"`),
    `background` by the World's and its picture's (`World "Sky", image "forest.exr"`) and `render.width` by Output
    Properties' Resolution X, which is what the user can find in the Outliner, the Image editor and Properties."""
    names = [obj.get("name", "?") for obj in document.get("objects", [])]

    def name(match: re.Match) -> str:
        index = int(match.group(1))
        return f'object "{names[index]}"' if index < len(names) else match.group(0)

    named = [re.sub(r"objects\[(\d+)\]", name, problem) for problem in problems]
    # the image's size is Output Properties' Resolution times its %
    named = [re.sub(r"^render\.(width|height)(?=:)", _resolution_field, problem) for problem in named]
    if world is not None:
        image = world_convert.picture_name(world)
        where = f'World "{world.name}"' + (f', image "{image}"' if image else "")
        named = [re.sub(r"^background(\.(image|pixels))?(?=[.:])", where, problem) for problem in named]
    return named


def _resolution_field(match: re.Match) -> str:
    return f"Resolution {'X' if match.group(1) == 'width' else 'Y'} x % (Output Properties)"


def _render_hidden_objects() -> set[int]:
    """For a viewport depsgraph (Export, the Rendered view): the original objects left out of renders by a collection
    of theirs (disabled in renders), found in one pass over the collections; Object.users_collection searches every
    collection for each object: 2 s for 3,000 objects. A render depsgraph has already left them out."""
    return {
        obj.as_pointer() for collection in bpy.data.collections if collection.hide_render for obj in collection.objects
    }


# --- materials, converted once until they change ---------------------------------------------------------------------

MATERIALS_KEPT = 20_000  # conversions remembered, least recently used forgotten first
_ATTRIBUTE_NODES = ("ShaderNodeVertexColor", "ShaderNodeAttribute")  # material_convert averages them over meshes
_conversions: OrderedDict[tuple, tuple[dict, list[str], int, tuple[int, ...]]] = OrderedDict()
# the last F12's document as loaded: the next F12 loads again only the materials and objects that changed, and an
# unchanged scene is the same Scene, which the workers keep prepared (reuse.LoadedParts)
F12_LOADED = tracer.LoadedParts()


def _converted(material, export: _Export) -> tuple[dict, list[str]]:
    """A Blender material -> (scene-file material, what it approximates), converted from its node tree once and kept
    until a depsgraph update changes the material, its node tree, any node group or image, a mesh (where it averages
    a colour attribute) or, for the add-on's own materials (read against the panel's entries), the scene; the
    highlight model and coef that every conversion reads are in the key, so a change of another scene setting (an
    engine switch, a resolution) keeps them. One with animation is kept per frame. A conversion takes about 0.13 ms:
    3,000 materials would cost every F12 and moved object 0.4 s."""
    cache = mesh_export.CACHE
    original = material.original or material  # an evaluated object's slots hold evaluated copies
    tree = original.node_tree
    animated = original.animation_data is not None or (tree is not None and tree.animation_data is not None)
    key = (original.as_pointer(), original.name, export.conversion, export.frame if animated else None)
    found = _conversions.get(key) if cache.enabled else None
    if found is not None and cache.valid(found[3], found[2]):
        _conversions.move_to_end(key)
        document, said = found[0], found[1]
    else:
        document, said = material_convert.convert_material(material)
        if cache.enabled:
            watched = [original.as_pointer(), mesh_export.SHADING]
            if original.get("weathervane_material") is not None:  # read against the panel's entries: the scene's
                watched.append(mesh_export.SCENE)
            if tree is not None:
                watched.append(tree.as_pointer())
                if any(node.bl_idname in _ATTRIBUTE_NODES for node in tree.nodes):
                    watched.append(mesh_export.ATTRIBUTES)
            _conversions[key] = (document, list(said), export.stamp, tuple(watched))
            while len(_conversions) > MATERIALS_KEPT:
                _conversions.popitem(last=False)
    # copies: the document is the caller's to change
    copied = {name: list(value) if isinstance(value, list) else value for name, value in document.items()}
    if getattr(original, "pass_index", 0):  # Material > Settings > Pass Index, for the Material Index pass
        copied["pass_index"] = original.pass_index
    return copied, list(said)


def _material_name(material, materials: dict, notes: ExportNotes | None = None, export: _Export | None = None) -> str:
    """A Blender material (or None) -> the name of its scene-file material, converted once from its node tree (and
    remembered across exports where an export's state is given)."""
    name = f"blender:{material.name}" if material is not None else "blender:default"
    if name not in materials:
        if material is None or export is None:
            materials[name], said = material_convert.convert_material(material)
        else:
            materials[name], said = _converted(material, export)
            said += material_convert.scene_notes(materials[name], export.scene)
        if notes is not None and material is not None:
            notes.materials[material.name] = said
    return name


# --- object instances -> meshes, instances and the add-on's own objects ---------------------------------------------

SKIP, LIGHT, VANE, GEOMETRY = "skip", "light", "vane", "geometry"


def _flags(obj) -> dict:
    """An object's render visibility as scene-file fields (only those that differ from the defaults)."""
    flags = {}
    for flag in ("visible_camera", "visible_shadow"):
        if not getattr(obj, flag, True):
            flags[flag] = False
    if not getattr(obj, "visible_glossy", True):
        flags["visible_reflection"] = False
    if getattr(obj, "is_holdout", False):
        flags["holdout"] = True
    if getattr(obj, "pass_index", 0):  # Object > Relations > Pass Index, for the Object Index pass
        flags["pass_index"] = obj.pass_index
    return flags


@dataclass(eq=False)
class _Source:
    """What the instances of one (instancer, object, evaluated data) export as: found from the first of them, then
    each only adds its matrix."""

    action: str  # SKIP, LIGHT, VANE or GEOMETRY
    original: object = None
    owner: object = None  # the instancer's original object; None for an object placed by itself
    slot_materials: list = field(default_factory=list)
    flags: dict = field(default_factory=dict)
    turned: bool = False  # hangs below the vane's turn: each placement a world-space mesh, not an instance
    generated: bool = False  # made by its own object's evaluation (Geometry Nodes instances, a text's mesh)
    geometry: _Geometry | None = None
    done: bool = False  # a vane object's body is added once


@dataclass(eq=False)
class _Geometry:
    """One evaluated geometry of the export and every place it is put."""

    entry: object  # mesh_export's cache entry: the arrays and their placed forms
    stem: str  # the name of its meshes-table entry before it is made unique
    placements: list = field(default_factory=list)  # (order, source, matrix)


@dataclass
class _Item:
    """A body of the document's objects before its name is made unique (names follow Blender's order)."""

    order: int  # the depsgraph's order of its first instance
    body: dict
    stem: str = ""  # its name, before it is made unique; "" for the add-on's objects (named already)
    owner: str = ""  # a world-space instance's instancer: named "owner/object#n", n counted per owner
    dropped: int = 0  # zero-area triangles left out (or the triangles of instances that flatten)
    blender: str = ""  # the Blender object's name, as Cycles' Cryptomatte names it (an instance's: the instanced)


def _turned_by(obj, turn) -> bool:
    """Whether obj hangs below the vane's turning object."""
    parent = obj.parent if turn is not None else None
    while parent is not None:
        if parent == turn:
            return True
        parent = parent.parent
    return False


def _geometry_source(source: _Source, mode: str, index: int) -> mesh_export.Source:
    """Where a source's geometry comes from for the cache: its mesh data-block where that is all there is to it,
    else the index-th distinct geometry its object's evaluation yields in this depsgraph mode."""
    original = source.original
    mesh = original.data
    editing = bool(getattr(mesh, "is_editmode", False))
    pointer = original.as_pointer()
    if (
        not source.generated
        and original.type == "MESH"
        and mesh is not None
        and len(original.modifiers) == 0
        and getattr(mesh, "shape_keys", None) is None
        and mesh.animation_data is None
        and original.parent_type not in ("ARMATURE", "LATTICE")  # a deforming parent: a modifier in all but name
        and not editing
    ):
        key = ("mesh", mesh.as_pointer(), mesh.name)
        return mesh_export.Source(key, (mesh.as_pointer(), pointer), False, pointer, original.name)
    watched = (pointer, mesh.as_pointer()) if mesh is not None else (pointer,)
    key = ("object", mode, pointer, original.name, index)
    return mesh_export.Source(key, watched, True, pointer, original.name, cacheable=not editing)


class _Export:
    """One export's document materials and notes, the cache's stamp and the frame."""

    def __init__(self, depsgraph, materials: dict, notes: ExportNotes, arrays: bool = False) -> None:
        self.materials = materials
        self.notes = notes
        self.arrays = arrays
        self.stamp = mesh_export.CACHE.clock  # taken before anything is read: a later update makes it stale
        self.scene = depsgraph.scene  # its settings, as the original holds them
        scene = depsgraph.scene_eval
        self.frame = float(scene.frame_current) + float(scene.frame_subframe)
        self.min_determinant = tracer.MATRIX_MIN_DETERMINANT
        # what a conversion depends on besides the material: material_convert reads the context scene's settings
        settings = getattr(bpy.context.scene, "weathervane", None)
        model, coef = getattr(settings, "model", None), float(getattr(settings, "coef", 0.0))
        self.conversion = (bpy.context.scene.as_pointer(), model, coef)

    def material(self, material) -> str:
        return _material_name(material, self.materials, self.notes, self)


@dataclass
class _Collected:
    objects: list = field(default_factory=list)
    parts: list = field(default_factory=list)  # names of the vane's turning parts
    lights: list = field(default_factory=list)  # (original light object, evaluated object, world matrix)
    meshes: dict = field(default_factory=dict)  # the document's meshes table
    materials: dict = field(default_factory=dict)  # the document's materials (whether a mesh entry needs UVs)
    arrays: bool = False  # large meshes' fields as arrays (mesh_export.Placed.fields)
    blender_names: dict = field(default_factory=dict)  # object name in the document -> its Blender object's name
    motion: motion_blur.SampledMotion | None = None  # motion blur: the matrices over the shutter of what moves


class MemoryBudget:
    """The memory a scene's preparation and render will take, counted as the export finds the scene (distinct
    triangles, instances; tracer/workers/resources.py's figures) and checked against the memory free at the start
    before each geometry's arrays are read: a scene that cannot fit is refused with one line (ResourceError) before
    it takes the memory, not after. cancelled: a callable the export asks every CANCEL_EVERY instances (Esc)."""

    CANCEL_EVERY = 512
    LARGEST = 3

    def __init__(self, blender_scene, cancelled=None, size: tuple[int, int] | None = None, extra: int = 0) -> None:
        """size: the image's (width, height) where it is not the render's (a Rendered view's region); extra: bytes
        held beside the render (the view's kept ray trees)."""
        render, settings = blender_scene.render, blender_scene.weathervane
        scale = render.resolution_percentage / 100.0
        width, height = size or (max(1, round(render.resolution_x * scale)), max(1, round(render.resolution_y * scale)))
        self.settings = tracer.RenderSettings(
            width=width, height=height, samples=int(settings.samples), dtype=settings.precision
        )
        self.extra = extra
        self.workers = tracer.worker_count(settings.workers)
        self.available = tracer.available_memory()
        # what the scene may take before the check itself is asked (it decides near the bound, and words a refusal)
        self.room = -1.0
        if self.available is not None:
            self.room = tracer.scene_room(self.settings, self.workers, self.available, extra=extra) * (1 - 1e-9) - 1
        self.cancelled = cancelled
        self.triangles = self.instances = 0
        self.meshes: dict[str, int] = {}  # a geometry's name -> its triangles

    def geometry(self, name: str, data) -> None:
        """A geometry about to be read: its triangles counted (from Blender's counts, nothing read) and checked; a
        cancel asked for meanwhile stops the export before the read."""
        if self.cancelled is not None and self.cancelled():
            raise ExportCancelledError
        count = max(0, len(data.loops) - 2 * len(data.polygons)) if isinstance(data, bpy.types.Mesh) else 0
        self.triangles += count
        self.meshes[name] = self.meshes.get(name, 0) + count
        self.check()

    def placed(self, count: int) -> None:
        self.instances += count

    def tick(self, order: int) -> None:
        """Called for each instance the export walks: asks whether the user cancelled, now and then."""
        if self.cancelled is not None and order and order % self.CANCEL_EVERY == 0 and self.cancelled():
            raise ExportCancelledError

    def check(self) -> None:
        """Raises ResourceError (one line) when what is counted so far cannot fit in the memory free at the start."""
        if self.available is None or tracer.scene_bytes(self.triangles, self.instances) < self.room:
            return
        counted = {"triangles": self.triangles, "instances": self.instances, "available": self.available}
        try:
            tracer.check_resources(self.settings, self.workers, **counted, blender=True, extra=self.extra)
        except tracer.ResourceError:
            # the largest meshes only for the refusal's line: sorting them at every geometry was quadratic (0.85 of
            # the 1.18 s export of 3,000 separate cubes)
            largest = heapq.nlargest(self.LARGEST, self.meshes.items(), key=lambda item: item[1])
            named = tuple((name, count) for name, count in largest if count)
            tracer.check_resources(
                self.settings, self.workers, **counted, largest=named, blender=True, extra=self.extra
            )
            raise


class ExportCancelledError(Exception):
    """The user cancelled (Esc) while the export walked the scene."""


def _classify(
    obj, original, owner, turn, hidden: set[int] | None, notes: ExportNotes, override=None, view_layer=None
) -> _Source:
    """What the instances of one (instancer, object, data) export as, read from the first of them. override: the view
    layer's Material Override, which every surface takes, as in Cycles; view_layer: the one whose collections' Holdout
    and Indirect Only the object (or its instancer) takes."""
    if hidden is not None:  # a viewport depsgraph: Blender's render visibility of the original placed
        placed = owner if owner is not None else original
        if placed.hide_render or placed.as_pointer() in hidden:
            return _Source(SKIP)
    if obj.type == "LIGHT":
        return _Source(LIGHT, original)
    if obj.type in NOT_TRACED:
        notes.not_rendered(NOT_TRACED[obj.type], original.name)
        return _Source(SKIP)
    if obj.type != "MESH":
        # empties, cameras, armatures, lattices render nothing; a text, curve, surface or metaball object's mesh
        # comes as an instance of its own (a Mesh with the object as its parent), as Cycles reads it
        return _Source(SKIP)
    if owner is None and "weathervane_object" in original:
        return _Source(VANE, original)
    _name_controls(original, owner, notes)
    return _Source(
        GEOMETRY,
        original,
        owner,
        slot_materials=[override] if override is not None else [slot.material for slot in obj.material_slots] or [None],
        flags=_flags(obj) | _collection_flags(original, owner, view_layer),
        turned=_turned_by(original, turn) or (owner is not None and _turned_by(owner, turn)),
        generated=owner is not None and owner == original,
    )


CONTROLS = {  # an object's setting -> what the tracer renders instead, as the F12 line says it (a holdout: _flags)
    "is_shadow_catcher": "shadow catcher rendered as an ordinary object",
}


def _name_controls(original, owner, notes: ExportNotes) -> None:
    """Name the render controls the object (or the instancer placing it) has that the tracer does not express."""
    for placed in filter(None, (original, owner)):
        for setting, what in CONTROLS.items():
            if getattr(placed, setting, False):
                notes.not_expressed(what, placed.name)
        linking = getattr(placed, "light_linking", None)  # 4.0+: an emissive object's own light linking
        if linking is not None and (linking.receiver_collection or linking.blocker_collection):
            notes.not_expressed("light linking of an emissive object ignored", placed.name)


def _collection_flags(original, owner, view_layer) -> dict:
    """The view layer's Holdout and Indirect Only (Outliner, a collection's) as an object's scene-file flags: a holdout,
    or hidden from camera rays alone (Cycles' indirect only: seen in shadows and reflections). An instance takes its
    instancer's."""
    if view_layer is None:
        return {}
    flags = {}
    for placed in filter(None, (original, owner)):
        if placed.holdout_get(view_layer=view_layer):
            flags["holdout"] = True
        if placed.indirect_only_get(view_layer=view_layer):
            flags["visible_camera"] = False
    return flags


def _collect(
    depsgraph,
    turn,
    materials: dict,
    notes: ExportNotes,
    budget: MemoryBudget | None,
    arrays: bool = False,
    motion: motion_blur.SampledMotion | None = None,
) -> _Collected:
    """Every object instance Blender renders at the depsgraph's frame: the add-on's objects as their own kinds, and
    each other geometry read once (not at all where the cache holds it unchanged), then placed: once in world space
    as a "mesh", several times as a "meshes" entry and "instances" of it."""
    collected = _Collected(arrays=arrays, materials=materials, motion=motion)
    export = _Export(depsgraph, materials, notes, arrays)
    cache = mesh_export.CACHE
    hidden = _render_hidden_objects() if depsgraph.mode == "VIEWPORT" else None
    view_layer = depsgraph.view_layer
    override = view_layer.material_override
    sources: dict[tuple, _Source] = {}
    geometries: dict[int, _Geometry] = {}  # evaluated data pointer -> its geometry
    distinct: dict[int, int] = {}  # original object pointer -> the distinct geometries it yielded so far
    items: list[_Item] = []
    bulk: dict[int, np.ndarray | None] = {}  # instancer pointer -> its instances' world matrices, read at once
    for order, instance in enumerate(depsgraph.object_instances):
        if budget is not None:
            budget.tick(order)
        parent = instance.parent if instance.is_instance else None
        if parent is not None:
            parent_pointer = parent.as_pointer()
            if parent_pointer in bulk:
                if bulk[parent_pointer] is not None:
                    continue  # placed with the first of its kind, below
            else:
                bulk[parent_pointer] = _bulk_matrices(parent, instance, turn)
        obj = instance.object
        original = obj.original
        data = obj.data
        data_pointer = data.as_pointer() if data is not None else 0
        key = (parent.as_pointer() if parent is not None else 0, original.as_pointer(), data_pointer)
        source = sources.get(key)
        if source is None:
            owner = parent.original if parent is not None else None
            source = sources[key] = _classify(obj, original, owner, turn, hidden, notes, override, view_layer)
            if motion is not None and owner is not None and owner.name in motion.objects:
                notes.not_expressed("motion blur of instances (at the frame's time)", owner.name)
        if source.action == SKIP or not getattr(instance, "show_self", True):
            continue
        if source.action == LIGHT:
            collected.lights.append((original, obj, instance.matrix_world.copy()))
            continue
        if source.action == VANE:
            if not source.done:
                source.done = True
                if override is not None:  # the vane's parts are the documented model's, with its own materials
                    notes.not_expressed("Material Override not applied to the vane", original.name)
                body = json.loads(original["weathervane_object"])
                unturned = _unturned(original, turn)
                body.update(_transform(unturned))
                if motion is not None and original.name in motion.objects:
                    # the document turns the parts by the heading: each pose is the part's unturned at that time
                    untwist = (instance.matrix_world @ unturned.inverted_safe()).inverted_safe()
                    body["poses"] = [motion_blur.pose(untwist @ matrix) for matrix in motion.objects[original.name]]
                items.append(_Item(order, body, blender=original.name))
                if turn is not None and original.parent == turn:
                    collected.parts.append(body["name"])
            continue
        geometry = source.geometry
        if geometry is None:
            geometry = source.geometry = geometries.get(data_pointer)
        if geometry is None:
            index = distinct[key[1]] = distinct.get(key[1], -1) + 1
            if budget is not None:
                budget.geometry(original.name, data)
            # read now, while obj is the instance iterated (Geometry Nodes instances share one temporary object)
            entry = cache.arrays(_geometry_source(source, depsgraph.mode, index), obj, export.frame, export.stamp)
            stem = f"{original.name}/{data.name}" if source.generated else data.name
            geometry = source.geometry = geometries[data_pointer] = _Geometry(entry, stem)
        if geometry.entry.arrays is not None:
            matrices = bulk.get(key[0]) if parent is not None else None
            geometry.placements.append((order, source, instance.matrix_world.copy() if matrices is None else matrices))
            if budget is not None:
                budget.placed(1 if matrices is None else len(matrices))
    if budget is not None:
        budget.check()
    for geometry in geometries.values():
        items += _placed_items(geometry, export, collected)
    _name(items, collected, notes)
    cache.trim()
    return collected


def _placed_items(geometry: _Geometry, export: _Export, collected: _Collected) -> list[_Item]:
    """A geometry's placements -> document bodies: one placement (or one the vane turns) as a world-space "mesh", as
    Cycles bakes a geometry used once into world space; the rest as "instances" groups over one meshes entry."""
    placements = geometry.placements
    moving = collected.motion.objects if collected.motion is not None else {}
    # a geometry the vane turns, or an object of its own that moves over the shutter (its poses): a mesh alone
    apart = [placement[1].turned or (placement[1].owner is None and placement[1].original.name in moving)
             for placement in placements]  # fmt: skip
    alone = [placement for placement, single in zip(placements, apart, strict=True) if single]
    shared = [placement for placement, single in zip(placements, apart, strict=True) if not single]
    if len(shared) == 1 and not isinstance(shared[0][2], np.ndarray):  # an array: a block of bulk placements
        alone, shared = alone + shared, []
    items = []
    for order, source, matrix in alone:
        placed = mesh_export.CACHE.placed(geometry.entry, matrix)
        body = _mesh_object(placed, source, export) if len(placed.triangles) else None
        name = source.original.name
        if body is not None and source.owner is None and name in moving and not isinstance(matrix, np.ndarray):
            body["poses"], rigid = motion_blur.relative_poses(moving[name], matrix)
            if not rigid:
                export.notes.not_expressed("motion blur of a changing scale (its move blurred only)", name)
        if source.owner is None or source.generated:  # an object's own geometry, or a text's mesh: its name
            item = _Item(order, body, source.original.name, dropped=placed.dropped, blender=source.original.name)
        else:
            owner = source.owner.name
            item = _Item(order, body, source.original.name, owner, placed.dropped, blender=source.original.name)
        items.append(item)
    if shared:
        items += _instance_groups(geometry, shared, export, collected)
    return items


def _mesh_object(placed: mesh_export.Placed, source: _Source, export: _Export) -> dict:
    """One placement of a geometry in world space as a scene-file mesh, with its materials and visibility."""
    slot_materials = source.slot_materials
    slots, used = placed.slots_of(len(slot_materials))
    first = export.material(slot_materials[used[0]])
    names = [export.material(material) for material in slot_materials] if len(used) > 1 else [first]
    uvs = _textured(names, export.materials)
    fields = placed.fields(arrays=export.arrays, uvs=uvs, colors=_colored(names, export.materials))
    _note_generated(placed, uvs, source.original, export.notes)
    body = {"name": "", "type": "mesh", "material": first, **fields}
    if len(used) > 1:
        body["materials"] = names
        body["material_indices"] = slots.tolist()
    body.update(source.flags)
    return body


def _textured(names, materials: dict) -> bool | str | mesh_export.GeneratedUVs:
    """Which corner UVs the meshes of these scene-file materials carry: the UV map a texture of theirs reads (its
    "uv_map": a UV Map node's), True for the default one, their Generated coordinates for a checker's or a gradient's
    that reads them (mesh_export.GENERATED), False where none has a texture read by UV."""
    for name in names:
        for key in ("texture", "emission_texture"):
            texture = materials.get(name, {}).get(key)
            if texture is not None and "attribute" not in texture:
                if texture.get("uv_map") == mesh_export.GENERATED:
                    return mesh_export.GeneratedUVs(texture["checker"]["scale"] if "checker" in texture else None)
                return texture.get("uv_map") or True
    return False


def _note_generated(placed: mesh_export.Placed, uvs, obj, notes: ExportNotes) -> None:
    """Names what a mesh's UVs from Generated coordinates cannot say: a checker's 3D cells on triangles that lie
    along no axis of the texture space, and an object whose shape its modifiers (or a curve's or text's own
    texture space) make, where Cycles may read the coordinates from the shape before the modifiers."""
    if not isinstance(uvs, mesh_export.GeneratedUVs):
        return
    name = obj.name
    if placed.generated_uvs(uvs)[1]:
        notes.not_expressed("a checker on Generated coordinates, 2D on faces along no axis of its texture space", name)
    if obj.type != "MESH" or len(getattr(obj, "modifiers", ())):
        notes.not_expressed("Generated coordinates from the shape after modifiers", name)


def _colored(names, materials: dict) -> str | None:
    """The colour attribute ("" the render default) that an "attribute" texture of one of these scene-file materials
    reads (its meshes then carry those corner colours), or None."""
    for name in names:
        for key in ("texture", "emission_texture"):
            texture = materials.get(name, {}).get(key) or {}
            if "attribute" in texture:
                return texture["attribute"].get("name", "")
    return None


def _texture_lists(materials: dict) -> None:
    """The materials' texture pixels as nested lists (a document for JSON: File > Export, the Rendered view's key);
    each texture dict replaced, never changed (the conversions' cache shares them)."""
    for name, material in materials.items():
        for key in ("texture", "emission_texture"):
            texture = material.get(key)
            if texture is not None and isinstance(texture.get("pixels"), np.ndarray):
                material = {**material, key: {**texture, "pixels": texture["pixels"].tolist()}}
                materials[name] = material


def _instance_groups(geometry: _Geometry, placements: list, export: _Export, collected: _Collected) -> list[_Item]:
    """Placements of one geometry -> one "instances" body per (materials, visibility), over a meshes-table entry in
    the geometry's own space (one entry per set of materials where faces use several, else one with the group's
    material as an override)."""
    local = mesh_export.CACHE.placed(geometry.entry)
    triangles = len(geometry.entry.arrays.triangles)
    groups: dict[tuple, list] = {}
    # (materials key, per-triangle slots or None) and the group's key, once per source: 100,000 Geometry Nodes
    # instances come from one source, and working them out per placement was a fifth of a second's export
    kinds: dict[int, tuple] = {}
    for placement in placements:
        source = placement[1]
        kind = kinds.get(id(source))
        if kind is None:
            slots, used = local.slots_of(len(source.slot_materials))
            if len(used) == 1:
                materials, slots = ("one", export.material(source.slot_materials[used[0]])), None
            else:
                materials = ("many", tuple(export.material(m) for m in source.slot_materials))
            key = (materials, tuple(sorted(source.flags.items())))
            kind = kinds[id(source)] = (key, slots, groups.setdefault(key, []))
        kind[2].append((placement, kind[1]))
    items = []
    entries: dict[tuple, str] = {}  # materials key -> meshes-table name
    for (materials, flags), members in groups.items():
        order, first, _ = members[0][0]
        matrices = _stacked([matrix for (_, _, matrix), _ in members])
        usable = _invertible(matrices, export.min_determinant)
        # an instance that flattens its mesh (a scale of 0) renders nothing in Blender; the tracer refuses it
        dropped = local.dropped * int(np.count_nonzero(usable)) + triangles * int(np.count_nonzero(~usable))
        stem = first.original.name if first.owner is None else _group_stem(first, geometry)
        if not len(local.triangles) or not usable.any():
            items.append(_Item(order, None, stem, dropped=dropped))
            continue
        mesh_key = materials if materials[0] == "many" else ("one",)
        if mesh_key not in entries:
            entries[mesh_key] = _mesh_entry(geometry, local, materials, members[0][1], collected)
            _note_generated(local, _textured(_names(materials), collected.materials), first.original, export.notes)
        body = {"name": "", "type": "instances", "mesh": entries[mesh_key]}
        body["matrices"] = matrices[usable, :3, :].reshape(-1, 12).tolist()
        if materials[0] == "one":
            body["material"] = materials[1]
        body.update(dict(flags))
        items.append(_Item(order, body, stem, dropped=dropped, blender=first.original.name))
    return items


def _stacked(matrices: list) -> np.ndarray:
    """Placements (4x4 mathutils matrices, and (K, 4, 4) arrays of bulk ones) -> (N, 4, 4) float64."""
    singles = [matrix for matrix in matrices if not isinstance(matrix, np.ndarray)]
    # the matrices' numbers as one stream (a third faster than np.array over 100,000 Matrix objects)
    numbers = itertools.chain.from_iterable(itertools.chain.from_iterable(singles))
    parts = [np.fromiter(numbers, dtype=np.float64, count=16 * len(singles)).reshape(-1, 4, 4)]
    parts += [matrix for matrix in matrices if isinstance(matrix, np.ndarray)]
    return np.concatenate(parts)


BULK_INSTANCES = 256  # an object's Geometry Nodes instances from this many on are read at once (Blender 4.3+)


def _bulk_matrices(parent, first, turn) -> np.ndarray | None:
    """The world matrices (K, 4, 4) float64 of every instance an evaluated object's Geometry Nodes tree makes, read
    at once from its evaluated geometry (Blender 4.3+: `Object.evaluated_geometry()`, the instances' point cloud and
    its "instance_transform" attribute, 7 ms for 100,000 where the depsgraph's instances walked one by one in Python
    took 0.9 s), or None where that cannot stand for them: an older Blender, fewer than BULK_INSTANCES, more than one
    kind of geometry instanced (or instances of instances, of objects or collections), an instancer the vane turns,
    or a first instance whose matrix is not the first transform's. first: the object's first instance in the
    depsgraph, whose matrix is checked."""
    if not hasattr(parent, "evaluated_geometry") or (turn is not None and _turned_by(parent.original, turn)):
        return None
    try:
        geometry = parent.evaluated_geometry()
        cloud = geometry.instances_pointcloud()
        references = geometry.instance_references()
    except (RuntimeError, TypeError, AttributeError):
        return None
    if cloud is None or len(cloud.points) < BULK_INSTANCES or len(references) != 1:
        return None
    reference = references[0]
    if type(reference).__name__ != "GeometrySet" or reference.mesh is None or reference.instances_pointcloud():
        return None
    if any(getattr(reference, part, None) is not None for part in ("pointcloud", "curves", "volume", "grease_pencil")):
        return None
    transforms = cloud.attributes.get("instance_transform")
    if transforms is None:
        return None
    local = np.empty(len(cloud.points) * 16, dtype=np.float32)
    transforms.data.foreach_get("value", local)
    local = local.astype(np.float64).reshape(-1, 4, 4).transpose(0, 2, 1)  # stored by columns
    matrices = np.asarray(parent.matrix_world, dtype=np.float64) @ local
    expected = np.asarray(first.matrix_world, dtype=np.float64)
    if not np.allclose(matrices[0], expected, rtol=1e-5, atol=1e-5 * max(1.0, float(np.abs(expected).max()))):
        return None
    return matrices


def _group_stem(source: _Source, geometry: _Geometry) -> str:
    """A group's name: "instancer/object" (collection, vertex, particle instances), "object/mesh" (an object's own
    Geometry Nodes instances)."""
    if source.generated:
        return geometry.stem
    return f"{source.owner.name}/{source.original.name}"


def _mesh_entry(geometry: _Geometry, local: mesh_export.Placed, materials: tuple, slots, collected: _Collected) -> str:
    """A meshes-table entry for a geometry (with its per-triangle materials where it has several); its name."""
    name, count = geometry.stem, 1
    while name in collected.meshes:
        count += 1
        name = f"{geometry.stem}#{count}"
    names = _names(materials)
    entry = local.fields(
        arrays=collected.arrays, uvs=_textured(names, collected.materials), colors=_colored(names, collected.materials)
    )
    if materials[0] == "one":
        entry["material"] = materials[1]
    else:
        entry["material"] = materials[1][int(slots[0])]
        entry["materials"] = list(materials[1])
        entry["material_indices"] = slots.tolist()
    collected.meshes[name] = entry
    return name


def _names(materials: tuple) -> list[str]:
    """A group's materials key ("one", name) or ("many", names) -> the scene-file materials' names."""
    return [materials[1]] if materials[0] == "one" else list(materials[1])


def _invertible(matrices: np.ndarray, min_determinant: float) -> np.ndarray:
    """(K, 4, 4) world matrices -> (K,) whether each is finite and invertible by the loader's measure (its 3x3 part's
    determinant above min_determinant times its largest entry cubed)."""
    finite = np.all(np.isfinite(matrices[:, :3, :]), axis=(1, 2))
    linear = np.where(finite[:, None, None], matrices[:, :3, :3], 0.0)
    largest = np.abs(linear).max(axis=(1, 2))
    return finite & (np.abs(np.linalg.det(linear)) > min_determinant * largest**3)


def _name(items: list[_Item], collected: _Collected, notes: ExportNotes) -> None:
    """The items in Blender's order, named uniquely (a world-space instance "instancer/object#n", n counted per
    instancer; a repeated name gets "#2", "#3"), with their dropped triangles noted under those names."""
    names: set[str] = set()
    per_owner: dict[str, int] = {}
    repeats: dict[str, int] = {}
    for item in sorted(items, key=lambda item: item.order):
        if not item.stem:  # the add-on's own objects
            collected.objects.append(item.body)
            collected.blender_names[item.body["name"]] = item.blender
            continue
        name = item.stem
        if item.owner:
            per_owner[item.owner] = per_owner.get(item.owner, 0) + 1
            name = f"{item.owner}/{item.stem}#{per_owner[item.owner]}"
        stem = item.stem
        while name in names:
            repeats[stem] = repeats.get(stem, 1) + 1
            name = f"{stem}#{repeats[stem]}"
        names.add(name)
        if item.dropped:
            notes.dropped_triangles[name] = notes.dropped_triangles.get(name, 0) + item.dropped
        if item.body is not None:
            item.body["name"] = name
            collected.objects.append(item.body)
            collected.blender_names[name] = item.blender


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
    model = compat.cycles_spot_model()
    if document["type"] == "spot" and model != "cycles4":  # cycles4: the scene format's default
        document["spot_model"] = model
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
        if kind not in ("POINT", "DIRECTIONAL") or not light_convert.documented(evaluated.data):
            # a spot or area light made in the Light tab, or a radius, inverse square, a sun's angle: as Blender's
            documents.append(_blender_light(evaluated, notes))
            continue
        if kind == "POINT":
            light = {"type": "point", "location": list(matrix.translation), "intensity": entry.intensity}
        else:
            light = {"type": "directional", "direction": _direction_toward(obj, matrix), "intensity": entry.intensity}
        color = compat.light_color(evaluated.data)  # recoloured in the Light tab
        if any(c != 1.0 for c in color):
            light["color"] = [float(c) for c in color]
        documents.append(light)
    for original, evaluated, _ in collected.lights:
        if original.name in driven:
            continue
        if settings.other_lights or not own_vane:
            documents.append(_blender_light(evaluated, notes))
        else:
            notes.lights_left_out.append(original.name)
    return documents


def as_json_types(value):
    """A scene document as json.loads(json.dumps(value)) would give it to the loader (tuples as lists), without
    the round trip through text: a list of numbers, or of lists of numbers (a mesh's vertices, an instance group's
    matrices), is passed as it is, being JSON already. The round trip cost 1.4 s for 100,000 placements."""
    if isinstance(value, dict):
        return {key: as_json_types(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        first = value[0] if value else None
        if isinstance(value, list) and (
            isinstance(first, int | float) or (isinstance(first, list) and first and isinstance(first[0], int | float))
        ):
            return value
        return [as_json_types(item) for item in value]
    return value


def scene_document(
    context,
    depsgraph=None,
    blender_scene=None,
    notes: ExportNotes | None = None,
    budget: MemoryBudget | bool = True,
    arrays: bool = False,
    motion: motion_blur.SampledMotion | None = None,
) -> dict:
    """The Blender scene as Blender renders it at the depsgraph's frame (the current one for the context's
    depsgraph, the frame being rendered inside a render) as a tracer scene document. notes, when given, collects
    what is approximated or left out; the document's comment says the same in one line. budget: the memory check
    (True: one for the scene's render settings; False: none); raises ResourceError, one line, for a scene that
    cannot fit, before its arrays are read. arrays: a large mesh's vertices, triangles and normals as NumPy arrays
    rather than lists, for scene_from_dict in this process (F12), not for JSON."""
    blender_scene = blender_scene or context.scene
    settings = blender_scene.weathervane
    depsgraph = depsgraph or context.evaluated_depsgraph_get()
    notes = notes if notes is not None else ExportNotes()
    materials = {
        entry.name: {"color": list(entry.color), "specular": entry.specular, "reflective": entry.reflective}
        for entry in settings.materials
    }
    for name, document in materials.items():  # the vane material's Material > Settings > Pass Index
        blender_material = bpy.data.materials.get(vane_materials.material_name(name))
        if blender_material is not None and blender_material.pass_index:
            document["pass_index"] = blender_material.pass_index
    turn = bpy.data.objects.get(build.TURN)
    # the parts go out as modelled (heading 0) and the current turn becomes the vane's heading
    heading = math.degrees(turn.evaluated_get(depsgraph).matrix_basis.to_euler("XYZ")[2]) if turn is not None else 0.0
    if budget is True:
        budget = MemoryBudget(blender_scene)
    collected = _collect(depsgraph, turn, materials, notes, budget or None, arrays, motion)
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
        # the world as evaluated at the depsgraph's frame: its keyed colour or strength (an animation's frames are
        # evaluated in the render's depsgraph, never in the original data)
        world = world_convert.scene_world(blender_scene, depsgraph.view_layer)
        world = world.evaluated_get(depsgraph) if world is not None else None
        background, ambient, notes.world = world_convert.convert_world(world, blender_scene=blender_scene)
        light_list += [ambient] if ambient is not None else []
        if not arrays:  # an image background's pixels as a .npy file's path: the document stays JSON, and small
            background = world_convert.background_for_json(background)
    render = blender_scene.render
    scale = render.resolution_percentage / 100.0
    document = {
        "materials": materials,
        **({"meshes": collected.meshes} if collected.meshes else {}),
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
        if motion is not None and motion.camera is not None:
            document["camera"]["poses"] = [motion_blur.pose(matrix) for matrix in motion.camera]
    if motion is not None:
        _motion_notes(blender_scene, motion, notes)
    glass = any(material.get("transmission", 0.0) > 0.0 for material in materials.values())
    cycles = getattr(blender_scene, "cycles", None)
    if glass and getattr(cycles, "caustics_refractive", False):  # Cycles' default; the format's rule is caustics off
        notes.approximated.append("Refractive Caustics: glass's shadow opaque")
    if render.film_transparent:
        document["render"]["film_transparent"] = True
        if glass and getattr(cycles, "film_transparent_glass", False):
            notes.approximated.append("Film > Transparent Glass: glass opaque in the alpha")
    view_layer = depsgraph.view_layer
    if view_layer.use_pass_cryptomatte_object or view_layer.use_pass_cryptomatte_material:
        # Cryptomatte under the Blender names Cycles writes, at the view layer's levels (the passes are the engine's)
        names = pass_map.blender_names(materials, collected.blender_names, vane_materials.material_name)
        document["render"].update(pass_map.cryptomatte(view_layer), **({"cryptomatte_names": names} if names else {}))
    threshold = float(getattr(settings, "noise_threshold", 0.0))
    if int(settings.samples) > 1 and threshold > 0.0:  # adaptive sampling: the samples only where pixels differ
        document["render"]["adaptive_threshold"] = round(threshold, 6)  # the property's float32, as typed
    if int(settings.shadow_samples) > 1:  # lights of a size sampled over their surface (1: the default, not written)
        document["render"]["shadow_samples"] = int(settings.shadow_samples)
    bounces = int(getattr(settings, "diffuse_bounces", 0))
    if bounces:  # indirect light between surfaces (0: the documented model, not written)
        document["render"]["diffuse_bounces"] = bounces
    if bounces or any("glossy" in material or "transmission_roughness" in material for material in materials.values()):
        document["render"]["glossy_samples"] = int(getattr(settings, "glossy_samples", "16"))
    if notes.line():
        document["comment"] = notes.line()
    if not arrays:
        _texture_lists(materials)
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
    conversion_report.exported(blender_scene.name, notes.materials)  # those only instances of hidden objects show
    return document


def _motion_notes(blender_scene, motion: motion_blur.SampledMotion, notes: ExportNotes) -> None:
    """What the poses leave out of Blender's motion blur, named: shapes that change, moving lights, instances, the
    shutter's curve and rolling."""
    for name in motion.deforming:
        notes.not_expressed("motion blur of a changing shape (its move blurred only)", name)
    for name in motion.lights:
        notes.not_expressed("motion blur of a moving light (lit as at the frame)", name)
    for problem in motion_blur.unsupported(blender_scene):
        notes.approximated.append(f"motion blur: {problem}")


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


# --- what tells the caches that something changed -------------------------------------------------------------------


def observe(depsgraph, from_view_update: bool = False) -> None:
    """A viewport depsgraph's last evaluation -> the remembered geometry and material conversions it changed are
    forgotten (mesh_export.GeometryCache.observe)."""
    if mesh_export.CACHE.enabled:
        mesh_export.CACHE.observe(depsgraph, from_view_update)


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph) -> None:
    observe(depsgraph)


@bpy.app.handlers.persistent
def _on_frame_change(_scene, depsgraph=None) -> None:
    if depsgraph is not None:
        observe(depsgraph)


@bpy.app.handlers.persistent
def _forget_everything(*_arguments) -> None:
    """A file loaded, an undo or redo: data-blocks may be others at the same addresses."""
    mesh_export.CACHE.clear()
    _conversions.clear()
    F12_LOADED.clear()  # compared by value, never stale: let go for its memory
    conversion_report.exported_forget()


_HANDLERS = (
    ("depsgraph_update_post", _on_depsgraph_update),
    ("frame_change_post", _on_frame_change),
    ("load_post", _forget_everything),
    ("undo_post", _forget_everything),
    ("redo_post", _forget_everything),
)


def register() -> None:
    """Start remembering geometry and materials between exports: the handlers that say what changed."""
    for name, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler not in handlers:
            handlers.append(handler)
    _forget_everything()
    mesh_export.CACHE.enabled = True


def unregister() -> None:
    mesh_export.CACHE.enabled = False
    for name, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler in handlers:
            handlers.remove(handler)
    _forget_everything()
