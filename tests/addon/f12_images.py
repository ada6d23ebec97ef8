"""F12 of the open scene -> its pixels, through a 32-bit OpenEXR file that Blender writes and reads back (the
engine's result as F12 saves it, for the tests that compare it with Cycles')."""

from __future__ import annotations

import math
import time
from pathlib import Path

import bpy
import numpy as np
import pytest

# A comparison with Cycles that the bars ask for in bpy 5.0.1 and Debian's 3.4.1 (the two ends of the supported
# range): skipped in the 4.x wheels, whose conversion tests still run (the suite's time stays within make test's)
AT_THE_ENDS = pytest.mark.skipif(
    (4, 0, 0) <= bpy.app.version < (5, 0, 0), reason="beside Cycles in bpy 5.0.1 and Debian's 3.4.1"
)


def f12_exr(path: Path, color_mode: str = "RGB") -> np.ndarray:
    """Render the scene with its engine and settings into a 32-bit EXR at path (color_mode "RGB" or "RGBA") ->
    (height, width, channels) linear float64, rows from the bottom as Blender keeps them."""
    scene = bpy.context.scene
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", color_mode
    scene.render.filepath = str(path)
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        width, height = image.size
        pixels = np.empty(width * height * image.channels, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        return pixels.reshape(height, width, image.channels)[..., : len(color_mode)].astype(np.float64)
    finally:
        bpy.data.images.remove(image)


def f12_cycles_and_engine(folder: Path, color_mode: str = "RGB") -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """F12 of the open scene by Cycles and then by the engine (f12_exr into folder) -> each one's image and seconds
    around its F12, by engine name."""
    images, seconds = {}, {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        bpy.context.scene.render.engine = engine
        started = time.perf_counter()
        images[engine] = f12_exr(folder / f"{engine}.exr", color_mode)
        seconds[engine] = time.perf_counter() - started
    return images, seconds


def looking_down(height: float, ortho_scale: float, pixels: int = 8) -> None:
    """The open scene seen straight down by an orthographic camera at (0, 0, height) ortho_scale across, pixels x
    pixels, Standard view, no world, Cycles on the CPU at 16 samples without denoising (the tests beside Cycles)."""
    scene = bpy.context.scene
    camera = bpy.data.cameras.new("camera")
    camera.type, camera.ortho_scale = "ORTHO", ortho_scale
    scene.camera = bpy.data.objects.new("camera", camera)
    scene.camera.location = (0.0, 0.0, height)
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x = scene.render.resolution_y = pixels
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.world = None
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 16, False


def glowing_material(name: str = "glow") -> bpy.types.Material:
    """A material whose surface is an Emission shader of strength 1, white: seen alike by every engine, with no
    lamp, world or bounce (the tests that compare where things are)."""
    from addon import compat

    material = bpy.data.materials.new(name)
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def mirror_floor(size: float) -> None:
    """A plane of size metres at the origin with a perfect mirror: a white Principled BSDF, Metallic 1, Roughness 0."""
    from addon import compat

    mirror = bpy.data.materials.new("mirror")
    compat.enable_nodes(mirror)
    principled = mirror.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    principled.inputs["Metallic"].default_value = 1.0
    principled.inputs["Roughness"].default_value = 0.0
    bpy.ops.mesh.primitive_plane_add(size=size)
    bpy.context.object.data.materials.append(mirror)


def looking_into_the_mirror(width: int, height: int, cycles_samples: int) -> None:
    """The open scene's camera 2.5 m up and 4 m back, looking 30 degrees down toward +Y (at a mirror floor), width x
    height, no world, Standard view; Cycles on the CPU at cycles_samples each on its pixel's centre (filter 0.01) and
    the engine at its one sample on the centre (its F12 default antialiases): sharp edges in both."""
    scene = bpy.context.scene
    camera = bpy.data.cameras.new("camera")
    scene.camera = bpy.data.objects.new("camera", camera)
    scene.collection.objects.link(scene.camera)
    scene.camera.location = (0.0, -4.0, 2.5)
    scene.camera.rotation_euler = (math.radians(60.0), 0.0, 0.0)
    scene.world = None
    render = scene.render
    render.resolution_x, render.resolution_y, render.resolution_percentage = width, height, 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", cycles_samples, False
    scene.cycles.filter_width = 0.01
    scene.weathervane.samples = "1"
