"""Depth of field beside Cycles: three glowing bars at 3, 5 and 8 m in front of a 100 mm camera at f/0.5 focused on
the middle one. Each bar's left edge, averaged over the image's rows, rises over a width (10% to 90% of the bar's
level) that is the lens's blur there: the bars out of focus within 10% of Cycles' widths, the one in focus sharp in
both. Both with a one-pixel box filter (the tracer's) and no lamp, world or bounce (the bars' emission only)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.vane.camera import depth_of_field
from tests.addon.f12_images import AT_THE_ENDS, f12_exr, glowing_material

WIDTH, HEIGHT = 320, 64
BARS = ((-0.35, 3.0, 0.15), (0.0, 5.0, 0.15), (0.9, 8.0, 0.25))  # (x, distance, width) metres
FOCUS = 5.0


def _bars_scene() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    material = glowing_material()
    for x, distance, width in BARS:
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=(x, distance, 0.0))
        bar = bpy.context.object
        bar.scale = (width, 0.01, 2.0)
        bar.data.materials.append(material)
    data = bpy.data.cameras.new("camera")
    data.lens, data.sensor_width, data.sensor_fit = 100.0, 36.0, "HORIZONTAL"
    data.dof.use_dof, data.dof.aperture_fstop, data.dof.focus_distance = True, 0.5, FOCUS
    scene.camera = bpy.data.objects.new("camera", data)
    scene.camera.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # looking along +Y
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = WIDTH, HEIGHT, 100
    scene.view_settings.view_transform = "Standard"
    scene.world = None
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 256, False
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.weathervane.samples = "64"


def _left_edge_widths(image: np.ndarray) -> list[float]:
    """Each bar's left edge's rise (pixels, 10% to 90% of the bar's top level, interpolated) in the row mean."""
    profile = image.mean(axis=0)
    widths = []
    for x, distance, width in BARS:
        centre = WIDTH / 2.0 + x / distance * 100.0 / 36.0 * WIDTH
        half = width / distance * 100.0 / 36.0 * WIDTH / 2.0
        low, high = int(centre - half - 40), int(centre)
        part = profile[max(low, 0) : high]
        level = part.max()
        crossing = [np.interp(fraction * level, part, np.arange(part.size)) for fraction in (0.1, 0.9)]
        widths.append(float(crossing[1] - crossing[0]))
    return widths


@AT_THE_ENDS
def test_the_blur_of_bars_out_of_focus_is_cycles(tmp_path: Path) -> None:
    _bars_scene()
    scene = bpy.context.scene
    lens = depth_of_field(scene.camera)
    assert lens == {"aperture": pytest.approx(0.1), "focus_distance": pytest.approx(FOCUS)}
    widths, seconds = {}, {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        started = time.perf_counter()
        widths[engine] = _left_edge_widths(f12_exr(tmp_path / f"{engine}.exr")[..., 0])
        seconds[engine] = time.perf_counter() - started
    for (_, distance, _), cycles, tracer in zip(BARS, widths["CYCLES"], widths["WEATHERVANE_TRACER"], strict=True):
        print(f"bar at {distance} m: edge width tracer {tracer:.2f} px, Cycles {cycles:.2f} px")
    print(f"seconds at {WIDTH}x{HEIGHT}: " + ", ".join(f"{engine} {value:.2f}" for engine, value in seconds.items()))
    (near_c, focus_c, far_c), (near_t, focus_t, far_t) = widths["CYCLES"], widths["WEATHERVANE_TRACER"]
    assert near_t == pytest.approx(near_c, rel=0.10) and far_t == pytest.approx(far_c, rel=0.10)
    assert focus_t < 2.0 and focus_c < 2.0  # in focus: the edge within two pixels (a pixel box, interpolated)
    assert near_t > 8.0 and far_t > 4.0  # out of focus: blurred over many pixels


def test_the_focus_object_sets_the_focus_distance_along_the_view_axis() -> None:
    _bars_scene()
    camera = bpy.context.scene.camera
    target = bpy.data.objects.new("target", None)
    target.location = (2.0, 7.0, 1.0)  # 7 m along the view axis (+Y), off it sideways and up
    bpy.context.scene.collection.objects.link(target)
    camera.data.dof.focus_object = target
    bpy.context.view_layer.update()
    assert depth_of_field(camera)["focus_distance"] == pytest.approx(7.0)
    camera.data.type = "ORTHO"
    assert depth_of_field(camera)["aperture"] == pytest.approx(1.0)  # Cycles: 1 / (2 f-stop) for orthographic
