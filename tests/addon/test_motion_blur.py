"""Motion blur beside Cycles: a glowing 0.5 m cube that moves 1 m along x while the shutter is open (keyframed at 2 m
a frame, shutter 0.5, Center on Frame), seen straight down by an orthographic camera on a transparent film. Its
coverage along the motion is a trapezoid: the box's width convolved with the move. The streak's length (the box's
width plus the move, taken from the profile's second moment, robust to Cycles' noise) within 5% of Cycles', its
centre in the same place, and the same within 5% when the camera moves instead. Also: the poses the export writes
(times, Position, a changing scale named), File > Export's file, and a still scene unchanged by the switch."""

from __future__ import annotations

import json
import math
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.convert import motion_blur
from addon.convert.export import ExportNotes, scene_document
from tests.addon.f12_images import AT_THE_ENDS, f12_cycles_and_engine, glowing_material

WIDTH, HEIGHT, ORTHO_SCALE = 200, 40, 4.0  # 0.02 m a pixel
SIZE, MOVE, SPEED = 0.5, 1.0, 2.0  # the cube's side, its move over the shutter, metres a frame (shutter 0.5)


def _moving_cube_scene(camera_moves: bool = False) -> bpy.types.Object:
    """The cube (or the camera, the other way) keyframed from frame 1 to 3 at SPEED, linearly, rendered at frame 2
    where the cube is at the origin."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add(size=SIZE, location=(0.0, 0.0, 0.0))
    cube = bpy.context.object
    cube.data.materials.append(glowing_material())
    data = bpy.data.cameras.new("camera")
    data.type, data.ortho_scale = "ORTHO", ORTHO_SCALE
    scene.camera = bpy.data.objects.new("camera", data)
    scene.camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(scene.camera)
    moving, sign, z = (scene.camera, -1.0, 5.0) if camera_moves else (cube, 1.0, 0.0)
    for frame, x in ((1, -SPEED), (3, SPEED)):
        moving.location = (sign * x, 0.0, z)
        moving.keyframe_insert("location", index=0, frame=frame)
    for fcurve in _fcurves(moving):
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"
    scene.frame_set(2)
    render = scene.render
    render.resolution_x, render.resolution_y, render.resolution_percentage = WIDTH, HEIGHT, 100
    render.film_transparent = True
    render.use_motion_blur, render.motion_blur_shutter = True, MOVE / SPEED
    scene.view_settings.view_transform = "Standard"
    scene.world = None
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 256, False
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    return moving


def _fcurves(obj) -> list:
    from addon import compat

    return compat.fcurves_of(obj)


def _streak(alpha: np.ndarray) -> tuple[float, float]:
    """The coverage profile along x (rows averaged) -> (the streak's length in metres: the box's width plus the move
    that the profile's variance gives, var = (width^2 + move^2) / 12 for a box swept uniformly; its centre in
    metres)."""
    profile = alpha.mean(axis=0)
    x = (np.arange(WIDTH) + 0.5) / WIDTH * ORTHO_SCALE - ORTHO_SCALE / 2.0
    mass = profile.sum()
    centre = float((profile * x).sum() / mass)
    variance = float((profile * (x - centre) ** 2).sum() / mass)
    return SIZE + math.sqrt(max(0.0, 12.0 * variance - SIZE**2)), centre


@AT_THE_ENDS
@pytest.mark.parametrize("camera_moves", [False, True], ids=["object", "camera"])
def test_the_streak_of_a_cube_moving_1_m_over_the_shutter_is_cycles(tmp_path: Path, camera_moves: bool) -> None:
    _moving_cube_scene(camera_moves)
    images, seconds = f12_cycles_and_engine(tmp_path, "RGBA")
    (cycles, cycles_centre), (tracer, tracer_centre) = (
        _streak(images[e][..., 3]) for e in ("CYCLES", "WEATHERVANE_TRACER")
    )
    print(
        f"streak ({'camera' if camera_moves else 'object'} moving): tracer {tracer:.3f} m, Cycles {cycles:.3f} m "
        f"(centre {tracer_centre:+.3f} / {cycles_centre:+.3f}); seconds "
        + ", ".join(f"{engine} {value:.2f}" for engine, value in seconds.items())
    )
    assert cycles == pytest.approx(SIZE + MOVE, rel=0.03)  # the scene is what it says: Cycles' streak is 1.5 m
    assert tracer == pytest.approx(cycles, rel=0.05)
    assert abs(tracer_centre - cycles_centre) < 0.02  # within a pixel


def test_poses_are_written_at_the_middles_of_the_shutters_parts() -> None:
    cube = _moving_cube_scene()
    scene = bpy.context.scene
    scene.weathervane.motion_blur_steps = 4
    depsgraph = bpy.context.evaluated_depsgraph_get()
    moves = motion_blur.sampled(scene, depsgraph, lambda frame, subframe: scene.frame_set(frame, subframe=subframe))
    assert scene.frame_current == 2 and scene.frame_subframe == 0.0  # the frame put back
    document = scene_document(bpy.context, motion=moves)
    (body,) = [body for body in document["objects"] if body["name"] == cube.name]
    # at frame 2 +- 0.25, in four parts: the middles at 1.8125, 1.9375, 2.0625, 2.1875 -> x = 2 (t - 2)
    expected = [SPEED * (-0.25 + 0.5 * (k + 0.5) / 4) for k in range(4)]
    assert [pose["location"][0] for pose in body["poses"]] == pytest.approx(expected, abs=1e-6)
    assert "poses" not in document["camera"]
    compat_position = motion_blur.compat.motion_blur_position(scene)
    assert compat_position == "CENTER"
    owner = scene.render if hasattr(scene.render, "motion_blur_position") else scene.cycles
    owner.motion_blur_position = "START"
    times = motion_blur.step_times(scene, 4)
    assert times == pytest.approx([2.0 + 0.5 * (k + 0.5) / 4 for k in range(4)])


def test_a_changing_scale_and_a_still_scene(tmp_path: Path) -> None:
    cube = _moving_cube_scene()
    scene = bpy.context.scene
    for frame, scale in ((1, 1.0), (3, 2.0)):
        cube.scale = (scale, scale, scale)
        cube.keyframe_insert("scale", frame=frame)
    scene.frame_set(2)
    notes = ExportNotes()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    moves = motion_blur.sampled(scene, depsgraph, lambda frame, subframe: scene.frame_set(frame, subframe=subframe))
    scene_document(bpy.context, notes=notes, motion=moves)
    assert "motion blur of a changing scale (its move blurred only) (Cube)" in notes.line()
    # nothing moves: Motion Blur on or off, the same document and no poses
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add()
    scene = bpy.context.scene
    scene.render.use_motion_blur = True
    depsgraph = bpy.context.evaluated_depsgraph_get()
    moves = motion_blur.sampled(scene, depsgraph, lambda frame, subframe: scene.frame_set(frame, subframe=subframe))
    assert moves is not None and not moves.objects and moves.camera is None
    assert "poses" not in json.dumps(scene_document(bpy.context, motion=moves))


def test_file_export_writes_the_poses_and_the_tracer_reads_them(tmp_path: Path) -> None:
    from addon import tracer_api as tracer

    _moving_cube_scene()
    target = tmp_path / "blurred.json"
    assert bpy.ops.weathervane.export(filepath=str(target)) == {"FINISHED"}
    document = json.loads(target.read_text())
    (body,) = [body for body in document["objects"] if "poses" in body]
    assert len(body["poses"]) == bpy.context.scene.weathervane.motion_blur_steps
    scene = tracer.load_scene(target)
    first = next(obj.poses for obj in scene.objects if obj.poses)[0]
    assert first[0][0] == pytest.approx(body["poses"][0]["location"][0])
