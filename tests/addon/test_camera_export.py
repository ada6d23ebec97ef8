"""Every Blender camera the tracer expresses exports so that its rays land on Blender's own pixels; what it cannot
express is said in one line."""

from __future__ import annotations

import json
import math
import random
from pathlib import Path

import bpy
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

from addon import compat
from addon.vane.camera import unsupported
from tracer.geometry import camera as cam
from tracer.scene.loader import scene_from_dict

# (camera data settings, render resolution, pixel aspect)
CAMERAS = [
    ({"lens": 35.0}, (64, 48), (1.0, 1.0)),
    ({"lens": 35.0, "shift_x": 0.2, "shift_y": -0.15}, (64, 48), (1.0, 1.0)),
    ({"type": "ORTHO", "ortho_scale": 5.0}, (64, 48), (1.0, 1.0)),
    ({"type": "ORTHO", "ortho_scale": 4.0, "shift_x": -0.3, "sensor_fit": "VERTICAL"}, (30, 50), (1.0, 1.0)),
    ({"lens": 24.0, "clip_start": 0.5, "clip_end": 30.0}, (40, 30), (1.0, 2.0)),
    ({"lens": 50.0, "sensor_fit": "VERTICAL", "shift_y": 0.4}, (50, 40), (3.0, 1.0)),
    ({"type": "ORTHO", "ortho_scale": 9.0, "clip_start": 1.0, "clip_end": 12.0}, (40, 60), (2.0, 1.0)),
]


def camera_scene(settings: dict, resolution: tuple[int, int], aspect: tuple[float, float]):
    """The built scene, its camera changed by settings and moved."""
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    obj = scene.camera
    for name, value in settings.items():
        setattr(obj.data, name, value)
    obj.location = (1.0, -8.0, 2.0)
    obj.rotation_euler = (math.radians(85), math.radians(3), math.radians(-10))
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x, scene.render.pixel_aspect_y = aspect
    bpy.context.view_layer.update()
    return scene, obj


def exported(tmp_path: Path):
    path = tmp_path / "scene.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    return scene_from_dict(json.loads(path.read_text()))


@pytest.mark.parametrize(("settings", "resolution", "aspect"), CAMERAS)
def test_exported_camera_rays_land_on_blenders_pixels(tmp_path: Path, settings, resolution, aspect) -> None:
    scene, obj = camera_scene(settings, resolution, aspect)
    tracer_scene = exported(tmp_path)
    width, height = resolution
    rng = random.Random(width * height)
    for _ in range(40):
        i, j = rng.randrange(width), rng.randrange(height)
        origin, direction, t_max = cam.primary_ray(tracer_scene.camera, tracer_scene.render, i + 0.5, j + 0.5)
        reach = min(7.0, t_max / 2)
        point = Vector(origin) + Vector(direction) * reach
        x, y, _ = world_to_camera_view(scene, obj, point)
        assert x * width == pytest.approx(i + 0.5, abs=1e-4)
        assert (1 - y) * height == pytest.approx(j + 0.5, abs=1e-4)
        # the ray starts on Blender's near plane and stops on its far plane (mathutils works in float32)
        start_depth = world_to_camera_view(scene, obj, Vector(origin))[2]
        assert start_depth == pytest.approx(obj.data.clip_start, abs=1e-5)
        end_depth = world_to_camera_view(scene, obj, Vector(origin) + Vector(direction) * t_max)[2]
        assert end_depth == pytest.approx(obj.data.clip_end, rel=1e-5)


def test_export_names_what_the_tracer_does_not_render(tmp_path: Path, capfd: pytest.CaptureFixture) -> None:
    scene, obj = camera_scene({"lens": 35.0}, (64, 48), (1.0, 1.0))
    path = tmp_path / "scene.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    assert "does not render" not in capfd.readouterr().out
    obj.data.dof.use_dof, obj.data.dof.aperture_blades = True, 6
    scene.render.use_border = True
    obj.keyframe_insert("location", frame=1)
    assert unsupported(scene) == [
        "aperture of 6 blades (a round one)",
        f"moving camera (exported as at frame {scene.frame_current})",
        "render border (a scene file holds the whole frame; F12 renders only the border)",
    ]
    assert unsupported(scene, exporting=False) == ["aperture of 6 blades (a round one)"]
    path.unlink()
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    assert path.exists()
    # one report line (the status bar's), naming each thing
    lines = [line for line in capfd.readouterr().out.splitlines() if "does not render" in line]
    assert len(lines) == 1 and "6 blades" in lines[0] and "moving camera" in lines[0] and "border" in lines[0]
    obj.data.type = "PANO"
    compat.panorama_settings(obj.data).panorama_type = "FISHEYE_LENS_POLYNOMIAL"
    assert unsupported(scene)[0] == "panoramic camera, fisheye lens polynomial (rendered as perspective)"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    assert json.loads(path.read_text())["camera"]["type"] == "PERSP"
    compat.panorama_settings(obj.data).panorama_type = "EQUIRECTANGULAR"
    obj.data.update_tag()  # as an edit in the panel does (3.4 keeps the Cycles settings' old value evaluated)
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    camera = json.loads(path.read_text())["camera"]
    assert camera["type"] == "PANO" and camera["panorama_type"] == "EQUIRECTANGULAR"


def test_a_scene_files_camera_builds_and_exports_unchanged(tmp_path: Path) -> None:
    from tracer.scene.loader import default_scene_dict

    document = default_scene_dict()
    camera = {"type": "ORTHO", "ortho_scale": 8.5, "shift_x": 0.25, "shift_y": -0.1, "clip_start": 0.3, "clip_end": 60}
    document["camera"].update(camera)
    path = tmp_path / "ortho.json"
    path.write_text(json.dumps(document))
    assert bpy.ops.weathervane.build(filepath=str(path)) == {"FINISHED"}
    data = bpy.context.scene.camera.data
    assert (data.type, data.shift_x, data.shift_y) == ("ORTHO", pytest.approx(0.25), pytest.approx(-0.1))
    again = exported(tmp_path).camera
    for name, value in camera.items():
        assert getattr(again, name) == (value if isinstance(value, str) else pytest.approx(value, rel=1e-6))
