"""The world as a light that objects shadow, beside Cycles with no diffuse bounces: a cube on a ground under a
uniform white world, no lamp, seen straight down. The ground in the open, beside the cube's faces (where the cube
hides part of the sky) and the cube's top, each within 10% of Cycles' mean there; the same under Blender's own
forest.exr; and the world light's note."""

from __future__ import annotations

import json
import time
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from tests.addon.f12_images import AT_THE_ENDS, f12_exr, looking_down

SIZE = 8.0  # metres across the orthographic view
PIXELS = 64


def _world_scene(strength: float = 1.0) -> None:
    """A 2 m cube (Diffuse BSDF 0.8) on a 20 m ground (Diffuse BSDF 0.8) under a white world of strength, no lamp."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    looking_down(10.0, SIZE, PIXELS)
    scene = bpy.context.scene
    material = bpy.data.materials.new("white")
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 1.0))
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.data.materials.append(material)
    world = bpy.data.worlds.new("white")
    compat.enable_nodes(world)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = strength
    scene.world = world
    scene.cycles.samples = 256
    scene.cycles.diffuse_bounces = 0


def _regions() -> dict[str, np.ndarray]:
    """Masks (PIXELS, PIXELS) by where a pixel's centre falls on the ground: the open (over 3 m from the cube's
    axis), beside the cube (0.1-0.5 m from a face, off its corners' diagonal strips) and the cube's top."""
    centre = (np.arange(PIXELS) + 0.5) / PIXELS * SIZE - SIZE / 2.0
    x, y = np.meshgrid(centre, -centre)
    reach = np.maximum(np.abs(x), np.abs(y))  # the cube's faces at 1 m
    beside = (reach > 1.1) & (reach < 1.5) & (np.minimum(np.abs(x), np.abs(y)) < 0.8)
    return {"open": np.hypot(x, y) > 3.0, "beside the cube": beside, "the cube's top": reach < 0.9}


def _regions_against_cycles(tmp_path: Path, what: str) -> dict[str, np.ndarray]:
    """F12 of the open scene by Cycles and by the engine -> their red channels; each region's mean within 10% of
    Cycles' (printed with the engines' seconds). The masks are symmetric: rows from the bottom do."""
    scene = bpy.context.scene
    images, seconds = {}, {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        started = time.perf_counter()
        images[engine] = f12_exr(tmp_path / f"{engine}.exr")[..., 0]
        seconds[engine] = time.perf_counter() - started
    for name, mask in _regions().items():
        cycles, tracer = images["CYCLES"][mask].mean(), images["WEATHERVANE_TRACER"][mask].mean()
        print(f"{what}, {name}: tracer {tracer:.4f}, Cycles {cycles:.4f}, ratio {tracer / cycles:.4f}")
        assert tracer == pytest.approx(cycles, rel=0.10), name
    print(f"seconds at {PIXELS}x{PIXELS}: " + ", ".join(f"{engine} {value:.2f}" for engine, value in seconds.items()))
    return images


@AT_THE_ENDS
@pytest.mark.parametrize("strength", [1.0])
def test_a_cube_shadows_the_world_light_as_in_cycles(tmp_path: Path, strength: float) -> None:
    _world_scene(strength)
    scene = bpy.context.scene
    from addon.convert import world_convert

    _, light, notes = world_convert.convert_world(scene.world, blender_scene=scene)
    assert light["type"] == "world" and light["samples"] == world_convert.WORLD_SAMPLES
    assert notes == [f"world light: shadowed, {world_convert.WORLD_SAMPLES} directions per point, no bounces"]
    images = _regions_against_cycles(tmp_path, "world light")
    beside = images["WEATHERVANE_TRACER"][_regions()["beside the cube"]].mean()
    assert beside < 0.85 * images["WEATHERVANE_TRACER"][_regions()["open"]].mean()  # the cube's shadow is there


@AT_THE_ENDS
def test_with_a_diffuse_bounce_the_ground_beside_the_cube_gets_its_light_as_in_cycles(tmp_path: Path) -> None:
    """Render Properties > Bounces 1 beside Cycles' Light Paths > Diffuse 1: each region within 10% of
    Cycles' mean, and the ground beside the cube brighter than without the bounce (the cube's lit faces light it)."""
    _world_scene()
    scene = bpy.context.scene
    scene.cycles.diffuse_bounces = 1
    scene.weathervane.diffuse_bounces = 1
    from addon.convert import world_convert

    _, _, notes = world_convert.convert_world(scene.world, blender_scene=scene)
    assert notes == [f"world light: shadowed, {world_convert.WORLD_SAMPLES} directions per point, 1 diffuse bounce"]
    images = _regions_against_cycles(tmp_path, "1 diffuse bounce")
    scene.weathervane.diffuse_bounces = 0
    direct = f12_exr(tmp_path / "direct.exr")[..., 0]
    beside = _regions()["beside the cube"]
    assert images["WEATHERVANE_TRACER"][beside].mean() > 1.02 * direct[beside].mean()


def test_build_from_a_file_with_a_world_light_leaves_it_out_and_says_so(tmp_path: Path) -> None:
    from addon.vane import build, operators
    from tracer.scene.loader import default_scene_dict

    bpy.ops.wm.read_factory_settings(use_empty=True)
    document = default_scene_dict()
    document["lights"].append({"type": "world", "intensity": 1.0})
    path = tmp_path / "world.json"
    path.write_text(json.dumps(document))
    assert bpy.ops.weathervane.build(filepath=str(path)) == {"FINISHED"}
    line, kind = operators.result_line()
    assert kind == "WARNING" and "the file's world light is not built" in line
    assert len(bpy.context.scene.weathervane.lights) == len(document["lights"]) - 1
    assert bpy.data.collections.get(build.COLLECTION) is not None


def test_the_ambient_world_light_is_the_users_pick_for_speed(tmp_path: Path) -> None:
    """Render Properties > World Light: Ambient gives the world's light everywhere, unshadowed (named): the ground
    beside the cube as bright as in the open."""
    _world_scene()
    scene = bpy.context.scene
    scene.weathervane.world_light = "AMBIENT"
    from addon.convert import world_convert

    _, light, notes = world_convert.convert_world(scene.world, blender_scene=scene)
    assert light == {"type": "ambient", "intensity": 1.0, "color": [1.0, 1.0, 1.0]}
    assert notes == ["world light: unshadowed ambient (Render Properties > World Light)"]
    scene.render.engine = "WEATHERVANE_TRACER"
    image = f12_exr(tmp_path / "ambient.exr")[..., 0]
    regions = _regions()
    assert image[regions["beside the cube"]].mean() == pytest.approx(image[regions["open"]].mean(), rel=1e-6)


def _blenders_picture(name: str) -> Path | None:
    folder = bpy.utils.system_resource("DATAFILES", path="studiolights/world")
    path = Path(folder) / name if folder else None
    return path if path is not None and path.is_file() else None


FOREST = _blenders_picture("forest.exr")


@AT_THE_ENDS
@pytest.mark.skipif(FOREST is None, reason="this Blender has no datafiles/studiolights/world/forest.exr")
def test_the_cube_under_blenders_forest_picture_is_lit_as_in_cycles(tmp_path: Path) -> None:
    """The World's Environment Texture: Blender's own forest.exr, whose bright gaps between the trees a few fixed
    directions sample badly (the open ground came out 1.77x Cycles' with the same 16 at every point). Each region
    within 10% of Cycles' mean: the irradiance in the open, the cube's shadow beside it."""
    _world_scene()
    world = bpy.context.scene.world
    texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(str(FOREST), check_existing=True)
    world.node_tree.links.new(texture.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    _regions_against_cycles(tmp_path, "forest.exr")


def test_a_keyed_world_renders_at_each_frame_of_an_animation(tmp_path: Path) -> None:
    """Render Animation evaluates each frame in the render's own depsgraph: the world's keyed colour and strength are
    its values at that frame there (the original World keeps the current frame's), as Blender evaluates them."""
    _world_scene()
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    background = scene.world.node_tree.nodes["Background"]
    for frame, green, strength in ((1, 0.1, 1.0), (3, 0.4, 2.0)):
        background.inputs["Color"].default_value = (0.1, green, 0.1, 1.0)
        background.inputs["Strength"].default_value = strength
        background.inputs["Color"].keyframe_insert("default_value", frame=frame)
        background.inputs["Strength"].keyframe_insert("default_value", frame=frame)
    expected = {}
    for frame in (1, 2, 3):  # what Blender evaluates at each frame
        scene.frame_set(frame)
        color, strength = background.inputs["Color"].default_value[:3], background.inputs["Strength"].default_value
        expected[frame] = np.array(color) * strength
    scene.frame_set(1)
    scene.frame_start, scene.frame_end = 1, 3
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGB"
    scene.render.filepath = str(tmp_path / "frame_")
    bpy.ops.mesh.primitive_plane_add(size=20.0)  # the ground lit by the world: the corner pixels see only the sky
    scene.camera.location.z, scene.camera.data.ortho_scale = 10.0, 60.0
    assert bpy.ops.render.render(animation=True) == {"FINISHED"}
    assert not np.allclose(expected[1], expected[2]) and not np.allclose(expected[2], expected[3])
    for frame in (1, 2, 3):
        image = bpy.data.images.load(str(tmp_path / f"frame_{frame:04d}.exr"), check_existing=False)
        pixels = np.empty(PIXELS * PIXELS * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        corner = pixels.reshape(PIXELS, PIXELS, 4)[0, 0, :3]
        assert corner == pytest.approx(np.minimum(expected[frame], 1.0), abs=1e-4), frame
