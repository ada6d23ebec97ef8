"""Every HDRI that ships with Blender (datafiles/studiolights/world: forest.exr, city.exr, ...) as the World, F12 with
the engine beside Cycles: it renders (each file holds a few slightly negative texels, which Blender keeps and the
engine now keeps too) and its background matches Cycles'. A float picture that holds a NaN is refused with a message
that names the World and the image. Runs in every Blender the add-on suite runs in."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from tests.addon.f12_images import f12_exr


def _hdris() -> list[Path]:
    folder = bpy.utils.system_resource("DATAFILES", path="studiolights/world")
    return sorted(Path(folder).glob("*.exr")) if folder else []


HDRIS = _hdris()


def _world_scene(image) -> bpy.types.Scene:
    """The image as the World's Environment Texture, seen by a 16 mm camera looking at the horizon, 64 x 32."""
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("sky")
    compat.enable_nodes(scene.world)
    tree = scene.world.node_tree
    environment = tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = image
    tree.links.new(environment.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    camera = bpy.data.cameras.new("camera")
    camera.lens = 16.0
    scene.camera = bpy.data.objects.new("camera", camera)
    scene.camera.rotation_euler = (math.radians(85.0), 0.0, math.radians(20.0))
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 32, 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 16, False
    scene.weathervane.samples = "16"  # both average 16 points of each pixel (Cycles' box filter of width 1)
    scene.cycles.filter_width = 1.0
    scene.cycles.pixel_filter_type = "BOX"
    return scene


@pytest.mark.skipif(not HDRIS, reason="this Blender has no datafiles/studiolights/world")
@pytest.mark.parametrize("path", HDRIS, ids=[path.stem for path in HDRIS])
def test_blenders_own_hdri_renders_as_cycles_shows_it(tmp_path: Path, path: Path) -> None:
    image = bpy.data.images.load(str(path), check_existing=True)
    width, height = image.size
    texels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(texels)
    scene = _world_scene(image)
    scene.render.engine = "CYCLES"
    cycles = f12_exr(tmp_path / "cycles.exr")
    scene.render.engine = "WEATHERVANE_TRACER"
    tracer = f12_exr(tmp_path / "tracer.exr")
    assert np.all(np.isfinite(tracer)) and tracer.max() > 0.0, "the tracer's F12 left the background black"
    # over the displayed range (the view clips at 1): a sun or moon in view, a few texels of hundreds, would make the
    # full range's peak and mean measure how 16 samples of a pixel happen to catch it (night.exr's moon: 443 in the
    # tracer's pixel, 593 in Cycles' at 256 samples), not the picture
    shown_tracer, shown_cycles = np.clip(tracer, 0.0, 1.0), np.clip(cycles, 0.0, 1.0)
    error = np.mean((shown_tracer - shown_cycles) ** 2)
    psnr = 10.0 * math.log10(1.0 / error) if error > 0.0 else math.inf
    level = 10.0 * math.log10(shown_tracer.mean() / shown_cycles.mean())
    print(f"{path.name}: {int((texels < 0).sum())} negative texels; PSNR {psnr:.1f} dB, mean level {level:+.3f} dB")
    assert abs(level) <= 0.1, f"{path.name}: the background's mean is {level:+.3f} dB from Cycles'"
    assert psnr >= 30.0, f"{path.name}: PSNR {psnr:.1f} dB against Cycles"


def test_a_picture_with_a_nan_is_refused_naming_the_world_and_the_image(tmp_path: Path) -> None:
    image = bpy.data.images.new("broken.exr", 8, 4, float_buffer=True)
    texels = np.full((4, 8, 4), 0.5, dtype=np.float32)
    texels[1, 2, 0] = np.nan
    image.pixels.foreach_set(texels.ravel())
    scene = _world_scene(image)
    scene.render.engine = "WEATHERVANE_TRACER"
    target = tmp_path / "scene.json"
    with pytest.raises(RuntimeError) as refusal:
        bpy.ops.weathervane.export(filepath=str(target))
    message = str(refusal.value)
    assert 'World "sky", image "broken.exr"' in message and "must be a finite number" in message, message
    assert not target.exists()


@pytest.mark.skipif(not HDRIS, reason="this Blender has no datafiles/studiolights/world")
def test_an_environment_read_by_other_coordinates_than_the_rays_direction_is_its_named_mean() -> None:
    """Texture Coordinate > Generated (or Object, no object) is the ray's direction, as the Vector unlinked; Window,
    Reflection or an object's space map the picture otherwise (Cycles shows it stretched over the screen, or turned):
    the picture's mean colour, named, never the plain panorama."""
    from addon.convert import world_convert

    scene = _world_scene(bpy.data.images.load(str(HDRIS[0]), check_existing=True))
    tree = scene.world.node_tree
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    environment = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeTexEnvironment")
    for output, expected in (("Generated", "image"), ("Object", "image"), ("Window", "solid"), ("Reflection", "solid")):
        tree.links.new(coordinates.outputs[output], environment.inputs["Vector"])
        background, _, notes = world_convert.convert_world(scene.world, blender_scene=scene)
        assert background["type"] == expected, (output, background["type"], notes)
        named = [note for note in notes if "Vector" in note]
        assert named == (
            []
            if expected == "image"
            else [f"Texture Coordinate {output} on the environment texture's Vector: its mean colour"]
        ), notes
    empty = bpy.data.objects.new("turned", None)
    coordinates.object = empty  # the object's space: the picture turned with it
    tree.links.new(coordinates.outputs["Object"], environment.inputs["Vector"])
    assert world_convert.convert_world(scene.world, blender_scene=scene)[0]["type"] == "solid"
