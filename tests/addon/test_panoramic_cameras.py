"""Cycles' panoramic cameras beside Cycles: glowing cubes all around a camera (ahead, to the sides, above, below,
behind), each panorama type rendered by both; the pixels the cubes cover (coverage masks) agree to IoU >= 0.97 (the
pixels outside a fisheye's or the mirror ball's circle black in both)."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import pytest

from addon import compat
from tests.addon.f12_images import AT_THE_ENDS, f12_cycles_and_engine, glowing_material

CUBES = ((0.0, 4.0, 0.0), (3.0, 3.0, 1.0), (-4.0, 1.0, -1.0), (0.5, 1.0, 4.0), (1.0, -4.0, 0.5), (-1.5, 2.0, -3.0))
# a pixel counts as covered where a cube shows over 70% of it: the mirror ball's rim is a circle of pixels half
# inside its lens (everything behind the camera maps there), which at 50% the two engines' samples split by noise
COVERED = 0.7
CASES = {  # panorama type: (settings, width, height)
    "EQUIRECTANGULAR": ({"latitude_min": -1.4, "longitude_max": 2.8}, 192, 96),
    "FISHEYE_EQUIDISTANT": ({"fisheye_fov": math.radians(200.0)}, 128, 128),
    "FISHEYE_EQUISOLID": ({"fisheye_fov": math.radians(180.0), "fisheye_lens": 10.5}, 144, 96),
    "MIRRORBALL": ({}, 192, 192),
}


def _scene(kind: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    material = glowing_material()
    for location in CUBES:
        bpy.ops.mesh.primitive_cube_add(size=1.2, location=location, rotation=(0.3, 0.2, 0.1))
        bpy.context.object.data.materials.append(material)
    settings, width, height = CASES[kind]
    data = bpy.data.cameras.new("camera")
    data.type = "PANO"
    panorama = compat.panorama_settings(data)
    panorama.panorama_type = kind
    for name, value in settings.items():
        setattr(panorama, name, value)
    scene.camera = bpy.data.objects.new("camera", data)
    scene.camera.rotation_euler = (math.radians(80.0), 0.0, math.radians(10.0))
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.view_settings.view_transform = "Standard"
    scene.world = None
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 64, False
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    scene.weathervane.samples = "16"


@AT_THE_ENDS
@pytest.mark.parametrize("kind", sorted(CASES))
def test_each_panoramic_camera_covers_the_pixels_cycles_covers(tmp_path: Path, kind: str) -> None:
    _scene(kind)
    images, seconds = f12_cycles_and_engine(tmp_path)
    cycles, tracer = (images[engine][..., 0] > COVERED for engine in ("CYCLES", "WEATHERVANE_TRACER"))
    iou = (cycles & tracer).sum() / (cycles | tracer).sum()
    print(f"{kind}: coverage IoU {iou:.4f}, {cycles.sum()} pixels in Cycles; seconds {seconds}")
    assert cycles.sum() > 40 and iou >= 0.97
