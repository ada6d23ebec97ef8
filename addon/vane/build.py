"""A tracer scene -> Blender objects inside the add-on's own collection; outside it, only the scene settings that
apply_scene_settings sets (where the user has not changed them) and the active camera, each named in the result line.

Analytic primitives become meshes with the fewest segments that keep the silhouette within half a pixel at the
resolution the Blender scene has after the Build (the file's, or the user's own that it keeps) and the camera's
distance: an n-gon of radius r misses the circle by r (1 - cos(pi / n)), which the camera shows as
f_px r (1 - cos(pi / n)) / d pixels at distance d. Boxes and pyramids use exactly the tracer's triangles. The vane's
parts hang under a pivot (aligned with the vane's axis) and a turning empty whose local Z rotation is the heading.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, replace

import bmesh
import bpy
from mathutils import Matrix, Vector

from .. import compat
from .. import tracer_api as tracer
from . import camera as camera_module
from . import lights, materials

COLLECTION = "Weathervane"
PIVOT = "WV Pivot"
TURN = "WV Turn"
MIN_SEGMENTS, MAX_SEGMENTS = 8, 256
INFINITE_PLANE_SIZE = 2000.0  # metres: a plane without size reaches the horizon in any reasonable view


def has_vane() -> bool:
    """Whether the file holds the add-on's vane (an object `build` made, marked "weathervane_object"): the export
    then renders the panel's background and Lights list, not the World (export.scene_document asks the same)."""
    return bpy.data.objects.get(TURN) is not None or any("weathervane_object" in obj for obj in bpy.data.objects)


def segments_for(radius: float, distance: float, focal_pixels: float, max_error_pixels: float = 0.5) -> int:
    """The fewest segments of a circle of radius at distance whose silhouette error stays under max_error_pixels."""
    if radius <= 0.0 or focal_pixels <= 0.0:
        return MIN_SEGMENTS
    allowed = max_error_pixels * max(distance, radius * 1e-3) / (focal_pixels * radius)
    if allowed >= 1.0:
        return MIN_SEGMENTS
    needed = math.ceil(math.pi / math.acos(1.0 - allowed))
    return int(min(MAX_SEGMENTS, max(MIN_SEGMENTS, needed + needed % 2)))


def focal_pixels(scene) -> float:
    """The camera's focal length in pixels of the scene's render width (tracer's sensor fit)."""
    width, height = scene.render.width, scene.render.height
    sensor_x, _ = tracer.sensor_size(scene.camera, width, height)
    return scene.camera.lens / sensor_x * width


def _distance(scene, centre) -> float:
    return (Vector(centre) - Vector(scene.camera.location)).length


def _mesh_from(name: str, vertices, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in vertices], [], [tuple(f) for f in faces])
    mesh.validate()
    mesh.update()
    return mesh


def _bmesh_to_mesh(name: str, bm, smooth_faces) -> bpy.types.Mesh:
    mesh = bpy.data.meshes.new(name)
    for face in bm.faces:
        face.smooth = smooth_faces(face)
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def sphere_mesh(name: str, radius: float, segments: int):
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=max(4, segments // 2), radius=radius)
    return _bmesh_to_mesh(name, bm, lambda face: True)


def cylinder_mesh(name: str, radius: float, height: float, segments: int):
    bm = bmesh.new()
    bmesh.ops.create_cone(
        bm, cap_ends=True, cap_tris=False, segments=segments, radius1=radius, radius2=radius, depth=height
    )
    # separate the caps from the side so that smooth sides do not bend the flat caps' shading
    rims = [
        edge
        for edge in bm.edges
        if len(edge.link_faces) == 2 and any(len(face.verts) == segments for face in edge.link_faces)
    ]
    bmesh.ops.split_edges(bm, edges=rims)
    return _bmesh_to_mesh(name, bm, lambda face: len(face.verts) == 4)


def primitive_mesh(scene, obj, world):
    """The mesh of one tracer object, in its local frame."""
    name = f"WV {obj.name}"
    if isinstance(obj, tracer.Sphere):
        segments = segments_for(obj.radius, _distance(scene, world.center) - obj.radius, focal_pixels(scene))
        return sphere_mesh(name, obj.radius, segments)
    if isinstance(obj, tracer.Cylinder):
        centre = Vector(world.base) + Vector(world.axis) * (obj.height / 2.0)
        distance = _distance(scene, centre) - max(obj.radius, obj.height / 2.0)
        return cylinder_mesh(name, obj.radius, obj.height, segments_for(obj.radius, distance, focal_pixels(scene)))
    if isinstance(obj, tracer.Plane):
        hx, hy = (s / 2.0 for s in obj.size) if obj.size else (INFINITE_PLANE_SIZE / 2.0,) * 2
        return _mesh_from(name, [(-hx, -hy, 0.0), (hx, -hy, 0.0), (hx, hy, 0.0), (-hx, hy, 0.0)], [(0, 1, 2, 3)])
    if isinstance(obj, tracer.Box):
        return _mesh_from(name, tracer.box_vertices(obj.size), tracer.BOX_TRIANGLES)
    if isinstance(obj, tracer.Pyramid):
        return _mesh_from(name, tracer.pyramid_vertices(obj.size), tracer.PYRAMID_TRIANGLES)
    return _mesh_from(name, obj.vertices.tolist(), obj.triangles.tolist())  # arrays -> Python numbers for bpy


def _record(blender_object, obj) -> None:
    """Keep the tracer description on the object, so that export maps it back exactly."""
    # a mesh's arrays as nested lists (the scene file's form; asdict would copy them and json cannot write them)
    fields = {
        field.name: value.tolist() if hasattr(value, "tolist") else value
        for field in dataclasses.fields(obj)
        if field.name not in ("location", "rotation", "poses")  # its place is the Blender object's, at any time
        for value in (getattr(obj, field.name),)
    }
    fields["type"] = {
        "Sphere": "sphere",
        "Plane": "plane",
        "Cylinder": "cylinder",
        "Box": "box",
        "Pyramid": "pyramid",
        "TriangleMesh": "mesh",
    }[type(obj).__name__]
    blender_object["weathervane_object"] = json.dumps(fields)


def own_collection(context, create: bool = True):
    collection = bpy.data.collections.get(COLLECTION)
    if collection is None and create:
        collection = bpy.data.collections.new(COLLECTION)
        collection["weathervane"] = True
    if collection is not None and create and collection.name not in context.scene.collection.children:
        context.scene.collection.children.link(collection)
    return collection


def clear(context, keep: frozenset[str] = frozenset()) -> None:
    """Remove the add-on's collection with its objects and their data; nothing else. keep: objects (by name) to
    take out of it first and keep (a rebuild's lights and camera), linked to the scene's own collection meanwhile."""
    collection = own_collection(context, create=False)
    if collection is None:
        return
    for obj in list(collection.all_objects):
        if obj.name in keep:
            context.scene.collection.objects.link(obj)
            collection.objects.unlink(obj)
            continue
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        if data is not None and data.users == 0:
            if isinstance(data, bpy.types.Mesh):
                bpy.data.meshes.remove(data)
            elif isinstance(data, bpy.types.Light):
                bpy.data.lights.remove(data)
            elif isinstance(data, bpy.types.Camera):
                bpy.data.cameras.remove(data)
    for child in list(collection.children):
        bpy.data.collections.remove(child)
    bpy.data.collections.remove(collection)


def name_problems(scene) -> list[str]:
    """One line per material or object whose Blender name (with the add-on's prefix) is longer than this Blender
    keeps; empty when every name fits. Checked before anything is built, so a refused Build changes nothing."""
    problems = []
    named = [(f"materials.{name}", materials.material_name(name)) for name in scene.materials]
    named += [(f"objects[{i}].name", f"WV {obj.name}") for i, obj in enumerate(scene.objects)]
    for field, blender_name in named:
        size = len(blender_name.encode("utf-8"))
        if size > compat.MAX_NAME_BYTES:
            problems.append(
                f"{field}: the name is {size} bytes in Blender (with its 'WV ' prefix), Blender "
                f"{'.'.join(map(str, compat.VERSION[:2]))} keeps at most {compat.MAX_NAME_BYTES}: shorten it"
            )
    return problems


def kept_for_rebuild(context, source: str) -> bool:
    """Whether Build would keep the user's settings: the vane is built, from this same source."""
    settings = context.scene.weathervane
    return own_collection(context, create=False) is not None and settings.built_from == source


@dataclass
class Built:
    """What a Build did to the scene's own settings (not the add-on's), one phrase each for its result line."""

    changed: list[str] = dataclasses.field(default_factory=list)  # "resolution 1920x1080 -> 640x480"
    kept: list[str] = dataclasses.field(default_factory=list)  # "resolution 1280x720 (the file's: 640x480)"
    engine: list[str] = dataclasses.field(default_factory=list)  # the file's render settings: "Samples 16 -> 1"


# The engine's settings (Render Properties > Weathervane Tracer) that a Build takes from the scene file, which its
# result line names where they change
ENGINE_SETTINGS = ("depth", "samples", "noise_threshold", "shadow_samples", "model", "numerics", "precision", "workers")


def _engine_values(settings) -> dict:
    return {key: getattr(settings, key) for key in ENGINE_SETTINGS}


def _engine_changes(settings, before: dict) -> list[str]:
    """Each engine setting that differs from before, as Render Properties names it and shows its values."""
    changes = []
    for key, old in before.items():
        new = getattr(settings, key)
        if _same(old, new):
            continue
        prop = settings.bl_rna.properties[key]
        if prop.type == "ENUM":
            shown = [prop.enum_items[value].name for value in (old, new)]
        else:
            shown = [f"{value:.4g}" if isinstance(value, float) else str(value) for value in (old, new)]
        changes.append(f"{prop.name} {shown[0]} -> {shown[1]}")
    return changes


# The scene's own settings (Output and Color Management, not the add-on's) that a Build sets: each one's name in the
# result line, how it reads and writes, and how it shows. The colour settings are one: a user who changed any of
# them chose a look, and keeps all of it.
def _resolution(blender_scene) -> tuple[int, int]:
    return blender_scene.render.resolution_x, blender_scene.render.resolution_y


def _set_resolution(blender_scene, value) -> None:
    blender_scene.render.resolution_x, blender_scene.render.resolution_y = value


def _percentage(blender_scene) -> int:
    return blender_scene.render.resolution_percentage


def _set_percentage(blender_scene, value) -> None:
    blender_scene.render.resolution_percentage = value


def _frame_rate(blender_scene) -> float:
    return blender_scene.render.fps / blender_scene.render.fps_base


def _set_frame_rate(blender_scene, fps: float) -> None:
    blender_scene.render.fps = max(1, round(fps))
    blender_scene.render.fps_base = blender_scene.render.fps / fps


def _colour(blender_scene) -> tuple[str, str, float, float]:
    view = blender_scene.view_settings
    return view.view_transform, view.look, view.exposure, view.gamma


def _set_colour(blender_scene, value) -> None:
    view = blender_scene.view_settings
    view.view_transform, view.look, view.exposure, view.gamma = value


def _dither(blender_scene) -> float:
    return blender_scene.render.dither_intensity


def _set_dither(blender_scene, value) -> None:
    blender_scene.render.dither_intensity = value


def _show_colour(value) -> str:
    transform, look, exposure, gamma = value
    extras = [f"look {look}"] if look != "None" else []
    extras += [f"exposure {exposure:.4g}"] if not _same(exposure, 0.0) else []
    extras += [f"gamma {gamma:.4g}"] if not _same(gamma, 1.0) else []
    return ", ".join([transform, *extras])


SCENE_SETTINGS = {  # name: (read, write, show)
    "resolution": (_resolution, _set_resolution, lambda value: f"{value[0]}x{value[1]}"),
    "resolution scale": (_percentage, _set_percentage, lambda value: f"{value}%"),
    "frame rate": (_frame_rate, _set_frame_rate, lambda value: f"{value:.4g} fps"),
    "view transform": (_colour, _set_colour, _show_colour),
    "dither": (_dither, _set_dither, lambda value: f"{value:.4g}"),
}
DISPLAY_AS_THE_TRACER = ("Standard", "None", 0.0, 1.0)  # the tracer's values as they are (`render --srgb`)
THE_TRACERS = ("view transform", "dither")  # what the tracer asks, not the file


def _same(a, b) -> bool:
    """Whether two settings' values are equal (floats as Blender keeps them, in single precision)."""
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)
    return a == b


def file_settings(scene) -> dict:
    """What a tracer scene asks of the Blender scene's settings: its resolution at 100%, its motion's frame rate,
    and Standard colour management without dither, so that Blender shows the tracer's values as they are."""
    wanted = {
        "resolution": (scene.render.width, scene.render.height),
        "resolution scale": 100,
        "view transform": DISPLAY_AS_THE_TRACER,
        "dither": 0.0,
    }
    if scene.motion is not None:
        wanted["frame rate"] = scene.motion.fps
    return wanted


def factory_settings() -> dict[str, list]:
    """Each setting's values in a scene nobody changed: the factory startup file's (1920x1080 at 100%, 24 fps, AgX
    in 4+ and Filmic in 3.x, no look, exposure 0, gamma 1, dither 1, in every Blender the add-on supports) and a new
    scene's in this Blender (read from one made and removed at once: 4.2 gives a new scene Filmic)."""
    startup = {
        "resolution": (1920, 1080),
        "resolution scale": 100,
        "frame rate": 24.0,
        "view transform": ("AgX" if compat.VERSION >= (4, 0, 0) else "Filmic", "None", 0.0, 1.0),
        "dither": 1.0,
    }
    probe = bpy.data.scenes.new("WV factory settings")
    try:
        return {name: [startup[name], read(probe)] for name, (read, _, _) in SCENE_SETTINGS.items()}
    finally:
        bpy.data.scenes.remove(probe)


def apply_scene_settings(blender_scene, scene, overwrite: bool = False) -> Built:
    """Set the scene's settings to what the tracer scene asks (file_settings), each only where the user has not
    changed it: where it holds this Blender's factory value or the value the last Build set (overwrite: everywhere,
    as Reset). What changed and what was kept, one phrase each; the values set are remembered on the scene."""
    result = Built()
    factory = factory_settings()
    settings = blender_scene.weathervane
    try:
        set_before = json.loads(settings.scene_settings_set or "{}")
    except ValueError:
        set_before = {}
    set_now = {}
    for name, wanted in file_settings(scene).items():
        read, write, show = SCENE_SETTINGS[name]
        value = read(blender_scene)
        if _same(value, wanted):
            set_now[name] = wanted
            continue
        untouched = any(_same(value, known) for known in factory[name]) or (
            name in set_before and _same(value, set_before[name])
        )
        if overwrite or untouched:
            write(blender_scene, wanted)
            set_now[name] = wanted
            result.changed.append(f"{name} {show(value)} -> {show(wanted)}")
        else:
            whose = "the tracer's" if name in THE_TRACERS else "the file's"
            result.kept.append(f"{name} {show(value)} ({whose}: {show(wanted)})")
    settings.scene_settings_set = json.dumps(set_now)
    return result


def _users_camera(context) -> str | None:
    """The name of the scene's active camera where it is not the vane's own (which a Build makes again)."""
    camera = context.scene.camera
    collection = own_collection(context, create=False)
    if camera is None or (collection is not None and camera.name in collection.all_objects):
        return None
    return camera.name


def build(context, scene, source: str = "", keep: bool = False, overwrite: bool = False) -> Built:
    """Build a tracer Scene into the add-on's collection (replacing only it) and fill the panel's settings.

    keep (a rebuild): the geometry is made again from the scene; the panel's settings (materials, wind and its keys,
    motion, the tracer's settings), the scene's settings, the lights, the camera and the baked motion stay as the user
    left them. Otherwise the scene's own settings that the vane needs (file_settings) become the file's where the
    user had not changed them, or everywhere with overwrite (Reset); the result says what changed and what was kept.
    Curved parts are segmented for the resolution the scene renders at after it."""
    settings = context.scene.weathervane
    result = Built()
    if not keep:
        result = apply_scene_settings(context.scene, scene, overwrite)
    users_camera = _users_camera(context)
    render = context.scene.render
    sized = replace(scene, render=replace(scene.render, width=render.resolution_x, height=render.resolution_y))
    kept_objects = frozenset()
    baked = None
    if keep:
        kept_objects = frozenset(entry.object_name for entry in settings.lights if entry.object_name)
        if context.scene.camera is not None:
            kept_objects |= {context.scene.camera.name}
        old_turn = bpy.data.objects.get(TURN)
        baked = compat.keyframes_of(old_turn, "rotation_euler", 2) if old_turn is not None else None
        kept_colors = {
            entry.name: (tuple(entry.color), entry.specular, entry.reflective) for entry in settings.materials
        }
    clear(context, kept_objects)
    collection = own_collection(context)
    for name in kept_objects:
        obj = bpy.data.objects.get(name)
        if obj is not None:
            collection.objects.link(obj)
            context.scene.collection.objects.unlink(obj)
    settings.built_from = source
    if keep:
        scene = _with_kept_materials(scene, kept_colors)
    ambient = sum(light.intensity for light in scene.lights if type(light).__name__ == "AmbientLight")
    made_materials = {}
    for name, material in scene.materials.items():
        made_materials[name] = materials.ensure_material(
            name,
            material.color,
            material.specular,
            material.reflective,
            ambient=ambient,
            model=scene.render.model,
            coef=scene.render.coef,
        )
        made_materials[name].pass_index = material.pass_index  # Material > Settings > Pass Index
    pivot = turn = None
    if scene.vane is not None:
        pivot = bpy.data.objects.new(PIVOT, None)
        axis = Vector(scene.vane.axis).normalized()
        pivot.matrix_world = Matrix.Translation(scene.vane.pivot) @ axis.to_track_quat("Z", "Y").to_matrix().to_4x4()
        pivot.empty_display_type = "SINGLE_ARROW"
        turn = bpy.data.objects.new(TURN, None)
        turn.empty_display_type = "CIRCLE"
        turn.empty_display_size = 0.3
        collection.objects.link(pivot)
        collection.objects.link(turn)
        turn.parent = pivot
        turn.rotation_euler = (0.0, 0.0, math.radians(scene.vane.heading))
        turn["weathervane_initial_heading"] = scene.vane.heading
        if baked:
            compat.replace_fcurve(turn, "rotation_euler", 2, *baked)
    still = scene.with_heading(0.0)
    context.view_layer.update()
    for obj in scene.objects:
        world = tracer.world_primitive(obj, None)
        mesh = primitive_mesh(sized, obj, world)
        blender_object = bpy.data.objects.new(f"WV {obj.name}", mesh)
        blender_object.data.materials.append(made_materials[obj.material])
        blender_object.pass_index = obj.pass_index  # Object > Relations > Pass Index
        collection.objects.link(blender_object)
        rotation, location = tracer.object_frame(obj, still.vane)
        blender_object.matrix_world = Matrix.Translation(location) @ Matrix(rotation).to_4x4()
        _record(blender_object, obj)
        blender_object["weathervane_material"] = obj.material
        blender_object["weathervane_name"] = obj.name
        if turn is not None and obj.name in scene.vane.parts:
            # modelled at heading 0 relative to the turning empty, so its Z rotation is the heading
            heading_zero = blender_object.matrix_world.copy()
            blender_object.parent = turn
            blender_object.matrix_parent_inverse = pivot.matrix_world.inverted()
            blender_object.matrix_basis = heading_zero
    if keep:
        return result
    camera = camera_module.create(scene.camera, collection)
    context.scene.camera = camera
    if users_camera is not None:  # the vane is seen through its file's camera; the user's stays in the file
        result.changed.append(f"active camera {users_camera} -> {camera.name}")
    settings.lights.clear()
    for index, light in enumerate(scene.lights):
        kind = type(light).__name__
        if kind == "WorldLight":  # the vane's world is the panel's background, lighting nothing (Build says so)
            continue
        entry = settings.lights.add()
        blender_kind = {"SpotLight": "SPOT", "AreaLight": "AREA"}.get(kind, _entry_kind(kind))
        made = lights.create_from_scene(light, lights.object_name(blender_kind, index), collection)
        if kind == "AmbientLight":
            entry.kind, entry.intensity = "AMBIENT", light.intensity
        elif made is not None:  # converted back as Blender's light of its type (entry_kind: the light's type)
            entry.kind, entry.intensity, entry.object_name = _entry_kind(kind), light.intensity, made.name
        elif kind == "PointLight":
            obj = lights.create(
                "POINT", light.intensity, lights.object_name("POINT", index), collection, light.location
            )
            entry.kind, entry.intensity, entry.object_name = "POINT", light.intensity, obj.name
        else:
            name = lights.object_name("DIRECTIONAL", index)
            obj = lights.create("DIRECTIONAL", light.intensity, name, collection, light.direction)
            entry.kind, entry.intensity, entry.object_name = "DIRECTIONAL", light.intensity, obj.name
    before = _engine_values(settings)
    _fill_settings(context, scene)
    result.engine = _engine_changes(settings, before)
    return result


def _entry_kind(kind: str) -> str:
    """The Lights panel entry's kind for a scene file light's class: a sun is DIRECTIONAL, the rest POINT (an entry
    of a spot or area light shows and converts as its Blender light's type)."""
    return "DIRECTIONAL" if kind == "DirectionalLight" else "POINT"


def _nearest_count(samples: int) -> str:
    """A scene file's sample count (a perfect square up to 1024) as the nearest the panel offers (1, 4, 9, 16, 64)."""
    return str(min((1, 4, 9, 16, 64), key=lambda offered: (abs(offered - samples), offered)))


def _with_kept_materials(scene, kept: dict):
    """The scene with its materials' colour, specular and reflectivity as the panel has them."""
    from dataclasses import replace

    materials_now = {
        name: replace(material, color=kept[name][0], specular=kept[name][1], reflective=kept[name][2])
        if name in kept
        else material
        for name, material in scene.materials.items()
    }
    return replace(scene, materials=materials_now)


def _fill_settings(context, scene) -> None:
    settings = context.scene.weathervane
    settings.depth, settings.model, settings.coef = scene.render.depth, scene.render.model, scene.render.coef
    settings.background, settings.workers = scene.background.type, scene.render.workers
    settings.numerics, settings.precision = scene.render.numerics, scene.render.dtype
    settings.background_color = scene.background.color
    settings.horizon, settings.zenith = scene.background.horizon, scene.background.zenith
    settings.samples = _nearest_count(scene.render.samples)
    settings.noise_threshold = scene.render.adaptive_threshold
    settings.shadow_samples = _nearest_count(scene.render.shadow_samples)
    settings.materials.clear()
    for name, material in scene.materials.items():
        entry = settings.materials.add()
        entry.name = name
        entry.color, entry.specular, entry.reflective = material.color, material.specular, material.reflective
        entry.parts = ", ".join(obj.name for obj in scene.objects if obj.material == name)
    motion = scene.motion
    if motion is not None:
        wind = motion.wind
        first = sorted(wind.keys, key=lambda key: key.time)[0]
        # the file's times in seconds, at the frame rate the scene keeps (the file's, or the user's own)
        fps = motion.fps if _same(_frame_rate(context.scene), motion.fps) else _frame_rate(context.scene)
        settings.mode = motion.mode.upper()
        settings.damping, settings.wavelength = motion.damping, motion.wavelength
        settings.threshold, settings.friction_time = motion.threshold, motion.friction_time
        settings.wind_direction, settings.wind_speed = math.radians(first.direction % 360.0), first.speed
        if wind.gusts is not None:
            settings.gust_intensity = wind.gusts.intensity
            settings.gust_time_scale = wind.gusts.time_scale
            settings.gust_seed = wind.gusts.seed
        settings.start_frame = 1 + round(wind.start * fps)
        settings.use_stop = wind.stop is not None
        if wind.stop is not None:
            settings.stop_frame = 1 + round(wind.stop * fps)
        settings.spin_direction, settings.spin_speed = motion.spin.direction, motion.spin.speed
        settings.spin_smoothness = motion.spin.smoothness
        if len(wind.keys) > 1:
            _key_wind(context.scene, wind, fps)


def _key_wind(blender_scene, wind, fps: float) -> None:
    """Keyed winds from a file become keyframes on the wind properties, as an artist would set them."""
    keys = sorted(wind.keys, key=lambda key: key.time)
    frames = [1.0 + key.time * fps for key in keys]
    unwrapped = [keys[0].direction]
    for key in keys[1:]:
        step = (key.direction - unwrapped[-1] + 180.0) % 360.0 - 180.0
        unwrapped.append(unwrapped[-1] + step)
    settings_path = "weathervane."
    compat.replace_fcurve(
        blender_scene, settings_path + "wind_direction", 0, frames, [math.radians(direction) for direction in unwrapped]
    )
    compat.replace_fcurve(blender_scene, settings_path + "wind_speed", 0, frames, [key.speed for key in keys])
