"""A sun of angle 8 degrees seen in a mirror floor beside Cycles: the disc where Cycles shows it (coverage IoU) and as
bright (Cycles 4.0+: strength / (pi sin^2 4 degrees) all over it; 3.x: / (pi tan^2 4 degrees cos^3) toward the
rim); with the sun's Glossy ray visibility off, neither shows it. Seen through a glass sphere (refracted rays): the
same. The conversion (every Blender): seen_in_mirrors from the Glossy visibility and Multiple Importance, the disc
model of this Blender's Cycles, the camera's visibility named."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Vector

from addon import compat
from addon.convert import light_convert
from tests.addon.f12_images import AT_THE_ENDS, f12_exr, looking_into_the_mirror, mirror_floor

WIDTH, HEIGHT = 64, 48
ANGLE = 8.0  # degrees: the disc about 13 pixels across at the default 50 mm lens
STRENGTH, COLOR = 3.0, (1.0, 0.8, 0.6)


def _sun_over_a_mirror() -> bpy.types.Object:
    """A 40 m mirror floor (Principled Metallic 1, Roughness 0, white), a sun 30 degrees above the horizon toward +Y,
    a camera 2.5 m up looking 30 degrees down toward +Y (its view's reflection goes to the sun), no world, Standard
    view; Cycles at 4 samples, each at its pixel's centre (a perfect mirror and the sun's disc converge at once) ->
    the sun."""
    scene = bpy.context.scene
    mirror_floor(40.0)
    light = bpy.data.lights.new("sun", type="SUN")
    light.energy, light.angle, light.color = STRENGTH, math.radians(ANGLE), COLOR
    sun = bpy.data.objects.new("sun", light)
    sun.rotation_euler = (math.radians(-60.0), 0.0, 0.0)  # its +Z (toward the light) 30 degrees up toward +Y
    scene.collection.objects.link(sun)
    looking_into_the_mirror(WIDTH, HEIGHT, 4)
    return sun


def _compare(tmp_path: Path, what: str) -> tuple[np.ndarray, np.ndarray]:
    """F12 of the open scene by Cycles and by the engine: where Cycles shows the disc (above half its brightest) the
    engine's coverage IoU >= 0.97 and its mean there within rtol of Cycles' in each channel (printed) -> the images."""
    scene = bpy.context.scene
    images = {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        images[engine] = f12_exr(tmp_path / f"{engine}.exr")
    cycles, tracer = images["CYCLES"], images["WEATHERVANE_TRACER"]
    shown_c, shown_t = cycles[..., 0] > 0.5 * cycles[..., 0].max(), tracer[..., 0] > 0.5 * cycles[..., 0].max()
    iou = (shown_c & shown_t).sum() / (shown_c | shown_t).sum()
    both = shown_c & shown_t
    mean_c, mean_t = cycles[both].mean(axis=0), tracer[both].mean(axis=0)
    print(
        f"the sun {what} ({compat.version_name()}): {shown_c.sum()} pixels, IoU {iou:.3f}, "
        f"tracer {np.round(mean_t, 4)}, Cycles {np.round(mean_c, 4)}, ratio {np.round(mean_t / mean_c, 6)}"
    )
    assert shown_c.sum() > 40 and iou >= 0.97
    return mean_t, mean_c


def test_a_suns_disc_is_seen_in_mirrors_as_this_blenders_cycles_shows_it() -> None:
    sun = _sun_over_a_mirror()
    document, notes = light_convert.convert_light(sun)
    assert document["angle"] == pytest.approx(ANGLE) and document["seen_in_mirrors"] is True
    assert document.get("disc_model", "cycles4") == ("cycles3" if bpy.app.version < (4, 0, 0) else "cycles4")
    assert notes == [f"sun angle {ANGLE:.3g}°: hard shadow"]
    sun.visible_camera = True  # Cycles' camera then shows the disc; the tracer's does not, and says so
    assert "disc not shown to the camera" in light_convert.convert_light(sun)[1][0]
    sun.visible_glossy = False
    assert "seen_in_mirrors" not in light_convert.convert_light(sun)[0]
    sun.visible_glossy = True
    sun.data.cycles.use_multiple_importance_sampling = False  # Cycles' rays never meet a sun without it
    assert "seen_in_mirrors" not in light_convert.convert_light(sun)[0]


@AT_THE_ENDS
def test_a_mirror_shows_the_suns_disc_where_and_as_bright_as_cycles_does(tmp_path: Path) -> None:
    """The disc in the mirror on 120 pixels: IoU >= 0.97, the mean within 1% of Cycles' in each channel (the bar:
    5%); with the sun's Glossy visibility off, neither shows it."""
    sun = _sun_over_a_mirror()
    scene = bpy.context.scene
    mean_t, mean_c = _compare(tmp_path, "in the mirror")
    np.testing.assert_allclose(mean_t, mean_c, rtol=0.01)  # the bar is 5%; measured: the same to 1e-5
    brightest = mean_c[0]
    sun.visible_glossy = False
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        assert f12_exr(tmp_path / f"{engine}-hidden.exr")[..., 0].max() < 0.5 * brightest, engine


@AT_THE_ENDS
def test_a_glass_sphere_shows_the_suns_disc_as_cycles_does(tmp_path: Path) -> None:
    """A Glass BSDF sphere (IOR 1.45, radius 1) 4 m before a camera looking 30 degrees up into the sun: its refracted
    rays see the disc (16 Cycles samples: their Fresnel choices are noise) with IoU >= 0.97 and the mean within 5%.
    Cycles clamps light seen after two bounces or more at Light Paths > Clamping > Indirect Light (10 by default: the
    disc through the sphere is then 9.3 in 5.0.1, 8.6 in 3.4.1, where unclamped it is 183); the engine does not clamp,
    so Cycles' clamp is off here."""
    _sun_over_a_mirror()
    scene = bpy.context.scene
    bpy.data.objects.remove(bpy.data.objects["Plane"])
    glass = bpy.data.materials.new("glass")
    compat.enable_nodes(glass)
    tree = glass.node_tree
    tree.nodes.clear()
    shader = tree.nodes.new("ShaderNodeBsdfGlass")
    shader.inputs["IOR"].default_value = 1.45
    shader.inputs["Roughness"].default_value = 0.0
    tree.links.new(shader.outputs["BSDF"], tree.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    toward = Vector((0.0, math.cos(math.radians(30.0)), math.sin(math.radians(30.0))))  # the sun's +Z
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0, location=toward * 4.0)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(glass)
    scene.camera.location = (0.0, 0.0, 0.0)
    scene.camera.rotation_euler = (math.radians(120.0), 0.0, 0.0)  # its view 30 degrees up toward +Y
    scene.cycles.samples, scene.cycles.sample_clamp_indirect = 16, 0.0
    mean_t, mean_c = _compare(tmp_path, "through glass")
    np.testing.assert_allclose(mean_t, mean_c, rtol=0.05)
