"""Build and the scene's own settings: what the user set stays, and the result line names every change.

Every scene-level setting is read before and after a Build (the scene's, Output's, Color Management's, units'): the
only ones that differ are those the result line names."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import bpy
import pytest

from addon.vane import build, operators
from tracer.scene.loader import default_scene, default_scene_dict

# RNA property -> the name the result line gives it
NAMES = {
    "resolution_x": "resolution",
    "resolution_y": "resolution",
    "resolution_percentage": "resolution scale",
    "fps": "frame rate",
    "fps_base": "frame rate",
    "view_transform": "view transform",
    "look": "view transform",
    "exposure": "view transform",
    "gamma": "view transform",
    "dither_intensity": "dither",
    "camera": "active camera",
}


def _values(struct, prefix: str) -> dict:
    """Every plain setting of an RNA struct (numbers, strings, enums, arrays) and its ID pointers, by path."""
    values = {}
    for prop in struct.bl_rna.properties:
        name = prop.identifier
        if name == "rna_type" or prop.type == "COLLECTION":
            continue
        if prop.type == "POINTER" and not isinstance(prop.fixed_type, bpy.types.ID):
            continue
        with warnings.catch_warnings():  # 5.0 warns of settings it will remove (Scene.use_nodes)
            warnings.simplefilter("ignore", DeprecationWarning)
            value = getattr(struct, name, None)
        if prop.type == "POINTER":
            value = value.name if value is not None else None
        elif getattr(prop, "is_array", False) or (hasattr(value, "__len__") and not isinstance(value, str)):
            value = tuple(value)
        values[f"{prefix}{name}"] = value
    return values


def scene_settings(blender_scene) -> dict:
    """The scene-level settings a user sets: the scene's own, Output's (render, image format), Color Management's
    (view, display, sequencer) and units; not the add-on's (scene.weathervane) nor Blender's undo-free internals."""
    values = _values(blender_scene, "scene.")
    for path in ("render", "render.image_settings", "view_settings", "display_settings", "unit_settings"):
        struct = blender_scene.path_resolve(path)
        values.update(_values(struct, f"scene.{path}."))
    values.update(_values(blender_scene.sequencer_colorspace_settings, "scene.sequencer_colorspace_settings."))
    return values


def changed_settings(before: dict, after: dict) -> set[str]:
    return {path.rsplit(".", 1)[1] for path in before if before[path] != after.get(path)}


def build_line(**options) -> str:
    assert bpy.ops.weathervane.build(**options) == {"FINISHED"}
    line, _ = operators.result_line()
    return line


def test_build_into_a_factory_scene_sets_the_files_resolution_and_names_each_change() -> None:
    """A factory scene (1920x1080, 24 fps, AgX or Filmic, dither 1): Build sets what the vane needs and its result
    line names each change; nothing else of the scene's settings moves (frame range included)."""
    blender_scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))  # the startup file's active camera
    blender_scene.collection.objects.link(camera)
    blender_scene.camera = camera
    factory_transform = blender_scene.view_settings.view_transform
    before = scene_settings(blender_scene)
    line = build_line()
    after = scene_settings(blender_scene)
    changed = changed_settings(before, after)
    assert {"resolution_x", "resolution_y", "view_transform", "dither_intensity", "camera"} <= changed
    assert changed <= set(NAMES), changed - set(NAMES)
    assert (after["scene.frame_start"], after["scene.frame_end"]) == (before["scene.frame_start"], 250)
    assert "changed resolution 1920x1080 -> 640x480" in line
    assert f"view transform {factory_transform} -> Standard" in line and "dither 1 -> 0" in line
    assert "active camera Camera -> WV Camera" in line
    changes = line.split("; changed ", 1)[1].split(";", 1)[0]
    phrases = changes.split(", ")  # one per setting changed, each starting with its name
    names = {NAMES[name] for name in changed}
    assert len(phrases) == len(names) and all(any(p.startswith(f"{n} ") for p in phrases) for n in names), phrases
    assert "kept your" not in line


def test_build_names_the_render_settings_it_takes_from_the_file() -> None:
    """A scene's engine settings at the defaults for scenes the add-on did not build (Samples 16, Threshold 0.005):
    Build takes the documented vane's (1 sample, no threshold) and its result line names both, as Render Properties
    names them; a second Build (a rebuild: the render settings kept) names none."""
    settings = bpy.context.scene.weathervane
    settings.samples, settings.noise_threshold = "16", 0.005
    line = build_line()
    assert (settings.samples, settings.noise_threshold) == ("1", 0.0)
    assert "; the file's render settings: Samples 16 -> 1, Threshold 0.005 -> 0" in line
    assert "the file's render settings" not in build_line()


def test_build_keeps_what_the_user_set_and_names_it() -> None:
    """The user's 1280x720 at 50%, 30 fps and Filmic with exposure 1 stay through Build; the line names each kept
    value beside the file's; the curved parts are segmented for the user's resolution, and the wind's start is at
    the file's time in the user's frame rate."""
    blender_scene = bpy.context.scene
    render, view = blender_scene.render, blender_scene.view_settings
    render.resolution_x, render.resolution_y, render.resolution_percentage = 3840, 2160, 50
    render.fps, render.fps_base = 30, 1.0
    view.view_transform, view.exposure = "Filmic", 1.0
    before = scene_settings(blender_scene)
    line = build_line()
    after = scene_settings(blender_scene)
    assert changed_settings(before, after) == {"dither_intensity", "camera"}
    assert "changed dither 1 -> 0" in line
    assert "kept your resolution 3840x2160 (the file's: 640x480), resolution scale 50% (the file's: 100%)" in line
    assert "view transform Filmic, exposure 1 (the tracer's: Standard), frame rate 30 fps (the file's: 24 fps)" in line
    assert line.endswith("(Reset sets these)")
    assert blender_scene.weathervane.start_frame == 1 + round(default_scene().motion.wind.start * 30)
    # the curved parts are as fine as 3840 pixels across need: more segments than the file's 640 give (Reset)
    fine = _segments_of_spheres()
    assert bpy.ops.weathervane.reset("EXEC_DEFAULT") == {"FINISHED"}
    coarse = _segments_of_spheres()
    assert coarse and all(fine[name] >= count for name, count in coarse.items())
    assert sum(fine.values()) > sum(coarse.values())


def _segments_of_spheres() -> dict[str, int]:
    """Each built sphere's vertex count, by part name."""
    return {
        obj.name: len(obj.data.vertices)
        for obj in bpy.data.collections[build.COLLECTION].objects
        if obj.type == "MESH" and json.loads(obj["weathervane_object"])["type"] == "sphere"
    }


def test_reset_and_a_build_from_another_file_change_what_build_set_but_not_the_users_own(tmp_path: Path) -> None:
    """Build's own values are Build's to change again (another file's resolution); a value the user set after it is
    kept by Build and set by Reset (asked first), each change named; a rebuild changes none of them."""
    blender_scene = bpy.context.scene
    build_line()
    document = default_scene_dict()
    document["render"]["width"], document["render"]["height"] = 320, 240
    other = tmp_path / "other.json"
    other.write_text(json.dumps(document), encoding="utf-8")
    assert "changed resolution 640x480 -> 320x240" in build_line(filepath=str(other))
    blender_scene.render.resolution_x, blender_scene.render.resolution_y = 800, 600
    blender_scene.view_settings.exposure = 0.5
    before = scene_settings(blender_scene)
    line = build_line()  # the default scene: another source, a new build
    assert changed_settings(before, scene_settings(blender_scene)) == set()  # its camera is made again, same name
    kept = "resolution 800x600 (the file's: 640x480), view transform Standard, exposure 0.5 (the tracer's: Standard)"
    assert f"kept your {kept}" in line
    rebuilt = build_line()  # the same source again: only the geometry
    assert rebuilt.startswith("Rebuilt")
    assert (blender_scene.render.resolution_x, blender_scene.render.resolution_y) == (800, 600)
    assert bpy.ops.weathervane.reset("EXEC_DEFAULT") == {"FINISHED"}
    line, _ = operators.result_line()
    assert "changed resolution 800x600 -> 640x480, view transform Standard, exposure 0.5 -> Standard" in line
    assert (blender_scene.render.resolution_x, blender_scene.render.resolution_y) == (640, 480)


def test_the_factory_values_are_the_startup_files_and_a_new_scenes_and_leave_no_scene_behind() -> None:
    scenes = len(bpy.data.scenes)
    factory = build.factory_settings()
    assert len(bpy.data.scenes) == scenes
    assert factory["resolution"] == [(1920, 1080)] * 2 and factory["resolution scale"] == [100] * 2
    assert factory["frame rate"] == pytest.approx([24.0] * 2) and factory["dither"] == pytest.approx([1.0] * 2)
    startup = "Filmic" if bpy.app.version < (4, 0, 0) else "AgX"
    assert factory["view transform"][0][0] == startup == bpy.context.scene.view_settings.view_transform
