"""The add-on's operators: build the vane, bake its motion, export the tracer scene, add and remove lights."""

from __future__ import annotations

import functools
import json
import sys
import traceback
from pathlib import Path

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from .. import tracer_api as tracer
from ..convert.export import other_lights
from ..engine import messages
from . import animation, build, camera, lights

_RESULT: list[str] = ["", "INFO"]  # the last operator's result line and its kind, shown in the sidebar


def result_line() -> tuple[str, str]:
    """The last result line of the add-on's operators and its kind (INFO, WARNING, ERROR): the sidebar shows it
    until the next one, since Blender's status bar shows a report only for a while, and not at all for an operator
    run from a script or a menu search in some versions."""
    return _RESULT[0], _RESULT[1]


def clear_result(*_args) -> None:
    _RESULT[:] = ["", "INFO"]


def report(operator, kinds: set[str], message: str) -> None:
    """operator.report (a long message whole, and a short line for the status bar: engine/messages.py), and the
    sidebar's result line: the last report of the run (an error wins over the lines before it). (A report method on
    the operator class would not be called: Blender's own comes first.)"""
    messages.report_whole(operator, kinds, message)
    kind = next(iter(kinds), "INFO")
    if not _RESULT[0] or _RESULT[1] != "ERROR" or kind == "ERROR":
        _RESULT[:] = [message, kind]


def reports_errors(execute):
    """An operator's execute that never lets an exception reach the user: an unexpected one becomes one report line
    naming the operator and the error (the traceback goes to the system console, for a bug report)."""

    @functools.wraps(execute)
    def guarded(self, context):
        clear_result()
        try:
            return execute(self, context)
        except Exception as error:  # the last line of defence: one line for the user, the details for a report
            traceback.print_exc(file=sys.stderr)
            report(self, {"ERROR"}, f"{self.bl_label} failed: {type(error).__name__}: {error}")
            return {"CANCELLED"}

    return guarded


def _load_scene(path: str):
    if not path:
        return tracer.default_scene()
    return tracer.load_scene(bpy.path.abspath(path))


class WEATHERVANE_OT_build(bpy.types.Operator):
    # one line: Blender shows a docstring's line breaks and indentation in the tooltip, and cuts at 239 bytes
    bl_description = (
        "Build the weathervane (default, or the scene file) in its own collection. Again from the same file: "
        "new geometry, your materials, wind, lights, camera and render settings kept (Reset starts over)"
    )
    bl_idname = "weathervane.build"
    bl_label = "Build Weathervane"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(
        name="Scene File",
        subtype="FILE_PATH",
        description="Tracer scene (.json); empty uses the panel's scene file or the default",
    )

    @reports_errors
    def execute(self, context):
        return _build_from(self, context, self.filepath or context.scene.weathervane.scene_file)


def _build_from(operator: bpy.types.Operator, context, path: str, reset: bool = False) -> set[str]:
    """Build from a scene file (empty: the default scene), reporting through operator; a rebuild from the same file
    keeps the user's settings unless reset."""
    try:
        scene = _load_scene(path)
    except tracer.SceneError as error:
        for problem in error.problems[:8]:
            report(operator, {"ERROR"}, f"{error.source}: {problem}")
        return {"CANCELLED"}
    problems = build.name_problems(scene)
    if problems:
        for problem in problems[:8]:
            report(operator, {"ERROR"}, f"{path or 'default scene'}: {problem}")
        return {"CANCELLED"}
    keep = not reset and build.kept_for_rebuild(context, path)
    result = build.build(context, scene, path, keep, overwrite=reset)
    built = f"Built {len(scene.objects)} parts in the '{build.COLLECTION}' collection"
    if scene.motion is not None and len(scene.motion.wind.keys) > 1:
        built += f"; the wind follows the file's {len(scene.motion.wind.keys)} keys (Wind panel)"
    built += _scene_settings_line(result)
    if keep:
        built = (
            f"Rebuilt the {len(scene.objects)} parts; kept your materials, wind, motion, lights, camera and render "
            "settings (Reset Weathervane starts over)"
        )
    warnings = []
    if any(isinstance(light, tracer.WorldLight) for light in scene.lights):
        warnings.append("the file's world light is not built: the vane is lit by its Lights panel's lights")
    others = [obj.name for obj in other_lights(context.scene)]
    if others and not context.scene.weathervane.other_lights:
        warnings.append(f"not rendered by the tracer: {_names(others)} (Lights > Other Lights renders them)")
    beside = _other_renderables(context.scene)
    if beside:
        warnings.append(f"also rendered with the vane: {_names(beside)} (hide them in renders to leave them out)")
    report(operator, {"WARNING"} if warnings else {"INFO"}, "; ".join([built, *warnings]))
    return {"FINISHED"}


def _names(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _other_renderables(blender_scene) -> list[str]:
    """Objects outside the add-on's collection that a render shows beside the vane (the startup file's Cube)."""
    own = bpy.data.collections.get(build.COLLECTION)
    ours = set(own.all_objects) if own is not None else set()
    shapes = {"MESH", "CURVE", "SURFACE", "META", "FONT"}
    return [
        obj.name
        for obj in blender_scene.objects
        if obj.type in shapes and obj not in ours and not obj.hide_render and obj.visible_get()
    ]


class WEATHERVANE_OT_reset(bpy.types.Operator):
    bl_description = (
        "Build the weathervane afresh from its scene file: its materials, wind, motion, lights, camera and render "
        "settings, and the scene's resolution, frame rate and colour management, go back to the file's (asks first)"
    )
    bl_idname = "weathervane.reset"
    bl_label = "Reset Weathervane"
    bl_options = {"REGISTER", "UNDO"}

    def invoke(self, context, _event):
        return context.window_manager.invoke_props_dialog(self, width=260)

    def draw(self, context):
        column = self.layout.column(align=True)
        source = context.scene.weathervane.scene_file or context.scene.weathervane.built_from or "the default vane"
        column.label(text="Build again from " + bpy.path.basename(source), icon="LOOP_BACK")
        column.label(text="and discard your edits to its")
        column.label(text="materials, wind, motion, lights,")
        column.label(text="camera, render settings and the")
        column.label(text="scene's resolution and colours?")

    @reports_errors
    def execute(self, context):
        settings = context.scene.weathervane
        through_camera = _views_through_camera(context)
        result = _build_from(self, context, settings.scene_file or settings.built_from, reset=True)
        for region in through_camera:  # the camera was made again: look through the new one, as before
            region.view_perspective = "CAMERA"
        return result


def _views_through_camera(context) -> list:
    """The 3D Views' regions that look through the scene camera now (none without a window)."""
    screen = getattr(context, "screen", None)
    if screen is None:
        return []
    return [
        area.spaces.active.region_3d
        for area in screen.areas
        if area.type == "VIEW_3D" and area.spaces.active.region_3d.view_perspective == "CAMERA"
    ]


class JsonFileBrowser(ImportHelper):
    """A file browser that shows tracer scene files (.json) only."""

    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})


class WEATHERVANE_OT_scene_file_browse(bpy.types.Operator, JsonFileBrowser):
    """Choose the tracer scene file (.json) that Build uses"""

    bl_idname = "weathervane.scene_file_browse"
    bl_label = "Choose Scene File"

    @reports_errors
    def execute(self, context):
        context.scene.weathervane.scene_file = bpy.path.relpath(self.filepath) if bpy.data.filepath else self.filepath
        return {"FINISHED"}


def _scene_settings_line(result) -> str:
    """The scene settings a Build changed and those it kept (the user's own), and the engine settings it took from
    the file, for its result line."""
    line = ""
    if result.changed:
        line += "; changed " + ", ".join(result.changed)
    if result.engine:
        line += "; the file's render settings: " + ", ".join(result.engine)
    if result.kept:
        line += "; kept your " + ", ".join(result.kept) + " (Reset sets these)"
    return line


class WEATHERVANE_OT_import(bpy.types.Operator, JsonFileBrowser):
    """Build the weathervane from a tracer scene file (.json) in its own collection"""

    bl_idname = "weathervane.import_scene"
    bl_label = "Import Weathervane"

    @reports_errors
    def execute(self, context):
        return _build_from(self, context, self.filepath)


class WEATHERVANE_OT_bake(bpy.types.Operator):
    """Simulate the vane in the wind over the frame range and key its rotation with the fewest keys"""

    bl_idname = "weathervane.bake"
    bl_label = "Bake Motion"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if bpy.data.objects.get(build.TURN) is None:
            cls.poll_message_set("Build the weathervane first: there is no vane to turn")
            return False
        return True

    @reports_errors
    def execute(self, context):
        window_manager = context.window_manager
        window_manager.progress_begin(0, 100)
        try:
            keys, frames = animation.bake(context, lambda share: window_manager.progress_update(int(share * 100)))
        except (LookupError, ValueError) as error:
            report(self, {"ERROR"}, str(error))
            return {"CANCELLED"}
        finally:
            window_manager.progress_end()
        report(
            self,
            {"INFO"},
            f"Baked {frames} frames into {keys} keys (within {context.scene.weathervane.tolerance:g} degrees)",
        )
        return {"FINISHED"}


class WEATHERVANE_OT_export(bpy.types.Operator, ExportHelper):
    """Write the scene as a tracer scene file (.json)"""

    bl_idname = "weathervane.export"
    bl_label = "Export Weathervane"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    @reports_errors
    def execute(self, context):
        from ..convert import motion_blur
        from ..convert.export import named_problems, scene_document

        try:
            scene = context.scene
            moves = motion_blur.sampled(
                scene,
                context.evaluated_depsgraph_get(),
                lambda frame, subframe: scene.frame_set(frame, subframe=subframe),
            )
            document = scene_document(context, motion=moves)
        except tracer.ResourceError as error:  # refused before the scene's arrays were read
            report(self, {"ERROR"}, f"cannot export: {error}")
            return {"CANCELLED"}
        try:
            tracer.scene_from_dict(json.loads(json.dumps(document)), "export")
        except tracer.SceneError as error:
            for problem in named_problems(error.problems, document, context.scene.world)[:8]:
                report(self, {"ERROR"}, f"cannot export: {problem}")
            return {"CANCELLED"}
        target = Path(bpy.path.abspath(self.filepath))
        swept = tracer.sweep_stale_temporaries(target.parent)
        beside = None
        try:
            picture = document.get("background", {}).get("image")
            if picture:  # a World's picture (world_convert.background_for_json): a .npy beside the scene file
                import shutil

                beside = target.with_name(f"{target.stem}.world.npy")
                with tracer.atomic_path(beside) as temporary:
                    shutil.copyfile(picture, temporary)
                document["background"] = {**document["background"], "image": beside.name}
            with tracer.atomic_path(target) as temporary:  # nothing is left behind if it fails
                temporary.write_text(json.dumps(document, indent=2), encoding="utf-8")
        except OSError as error:
            report(self, {"ERROR"}, f"cannot write {target}: {error.strerror or error}")
            return {"CANCELLED"}
        wrote = f"Wrote {target}" + (f" and the World's picture beside it, {beside.name}" if beside else "")
        wrote += f"; removed {swept} temporary file(s) a killed export had left" if swept else ""
        left_out = camera.unsupported(context.scene)
        said = [f"the tracer does not render: {', '.join(left_out)}"] if left_out else []
        if document.get("comment"):  # what the conversion approximated, as F12's warning says it
            said.append(document["comment"])
        if said:
            report(self, {"WARNING"}, f"{wrote}; {'; '.join(said)}")
        else:
            report(self, {"INFO"}, wrote)
        return {"FINISHED"}


class WEATHERVANE_OT_light_add(bpy.types.Operator):
    """Add a light of the documented model"""

    bl_idname = "weathervane.light_add"
    bl_label = "Add Light"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(
        name="Type",
        items=[
            ("POINT", "Point", "A light at a position", "LIGHT_POINT", 0),
            ("DIRECTIONAL", "Directional", "A light at infinity", "LIGHT_SUN", 1),
            ("AMBIENT", "Ambient", "Light everywhere", "WORLD", 2),
        ],
        default="POINT",
    )

    @reports_errors
    def execute(self, context):
        settings = context.scene.weathervane
        entry = settings.lights.add()
        entry.kind, entry.intensity = self.kind, 0.3
        if self.kind != "AMBIENT":
            collection = build.own_collection(context)
            vector = (3.0, -3.0, 5.0) if self.kind == "POINT" else (1.0, -1.0, 2.0)
            name = lights.object_name(self.kind, len(settings.lights) - 1)
            obj = lights.create(self.kind, entry.intensity, name, collection, vector)
            entry.object_name = obj.name
        settings.light_index = len(settings.lights) - 1
        report(self, {"INFO"}, f"Added a {self.kind.title()} light")
        return {"FINISHED"}


class WEATHERVANE_OT_light_remove(bpy.types.Operator):
    """Remove the selected light (and its Blender light object)"""

    bl_idname = "weathervane.light_remove"
    bl_label = "Remove Light"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        settings = context.scene.weathervane
        return 0 <= settings.light_index < len(settings.lights)

    @reports_errors
    def execute(self, context):
        settings = context.scene.weathervane
        entry = settings.lights[settings.light_index]
        obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
        removed = f" and its object {obj.name!r}" if obj is not None else ""
        collection = build.own_collection(context, create=False)
        if obj is not None and collection is not None and obj.name in collection.objects:
            data = obj.data
            bpy.data.objects.remove(obj, do_unlink=True)
            if data is not None and data.users == 0:
                bpy.data.lights.remove(data)
        kind = entry.kind.title()
        settings.lights.remove(settings.light_index)
        settings.light_index = min(settings.light_index, len(settings.lights) - 1)
        report(self, {"INFO"}, f"Removed the {kind} light{removed}")
        return {"FINISHED"}


CLASSES = (
    WEATHERVANE_OT_build,
    WEATHERVANE_OT_import,
    WEATHERVANE_OT_reset,
    WEATHERVANE_OT_scene_file_browse,
    WEATHERVANE_OT_bake,
    WEATHERVANE_OT_export,
    WEATHERVANE_OT_light_add,
    WEATHERVANE_OT_light_remove,
)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def menu_import(self, context) -> None:
    self.layout.operator(WEATHERVANE_OT_import.bl_idname, text="Weathervane Scene (.json)")


def menu_export(self, context) -> None:
    self.layout.operator(WEATHERVANE_OT_export.bl_idname, text="Weathervane Scene (.json)")


def menu_add(self, context) -> None:
    self.layout.operator(WEATHERVANE_OT_build.bl_idname, text="Weathervane", icon="FORCE_WIND")


class WEATHERVANE_MT_object(bpy.types.Menu):
    """Object > Weathervane: every operator of the add-on, so that menu search (F3) finds each by name."""

    bl_idname = "WEATHERVANE_MT_object"
    bl_label = "Weathervane"
    OPERATORS = (
        WEATHERVANE_OT_build,
        WEATHERVANE_OT_reset,
        WEATHERVANE_OT_bake,
        WEATHERVANE_OT_import,
        WEATHERVANE_OT_export,
        WEATHERVANE_OT_light_add,
        WEATHERVANE_OT_light_remove,
    )

    def draw(self, context):
        for operator in self.OPERATORS:
            if operator is WEATHERVANE_OT_light_add:
                self.layout.operator_menu_enum(operator.bl_idname, "kind", text=operator.bl_label)
            else:
                self.layout.operator(operator.bl_idname)


def menu_object(self, context) -> None:
    self.layout.menu(WEATHERVANE_MT_object.bl_idname, icon="FORCE_WIND")


MENUS = (
    ("TOPBAR_MT_file_import", menu_import),
    ("TOPBAR_MT_file_export", menu_export),
    ("VIEW3D_MT_add", menu_add),
    ("VIEW3D_MT_object", menu_object),
)


def register() -> None:
    _register_classes()
    bpy.app.handlers.load_post.append(clear_result)  # another file: the last file's result line is not about it
    bpy.utils.register_class(WEATHERVANE_MT_object)
    for menu, entry in MENUS:
        getattr(bpy.types, menu).append(entry)


def unregister() -> None:
    for menu, entry in MENUS:
        getattr(bpy.types, menu).remove(entry)
    bpy.utils.unregister_class(WEATHERVANE_MT_object)
    if clear_result in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(clear_result)
    _unregister_classes()
