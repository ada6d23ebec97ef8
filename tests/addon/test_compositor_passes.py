"""Blender's compositor on the engine's passes as on Cycles': a Defocus node fed by the Depth pass blurs the same
pixels for both engines (the cube in focus stays sharp, the plane behind it and the cube's outline blur)."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat

pytestmark = pytest.mark.skipif(
    compat.VERSION >= (4, 0, 0),
    reason="a Blender executable's compositor: in the bpy 4.x wheels a background render's compositor leaves the "
    "image as rendered (Defocus changed 0 pixels for Cycles too), and Blender 5 composites through node groups",
)


def scene_with_depth_of_field() -> bpy.types.Scene:
    """The camera 5 m above a large plane looking down, a 2 m cube below it (its top 3 m away, in focus), a point
    light of radius 0 (hard shadows in both engines), Standard view, no dither."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 96, 72, 100
    scene.view_settings.view_transform = "Standard"
    scene.render.dither_intensity = 0.0
    bpy.ops.mesh.primitive_plane_add(size=100.0)
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.6, 0.3, 1.0), rotation=(0.0, 0.0, 0.5))
    bpy.ops.object.camera_add(location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0))
    scene.camera = bpy.context.object
    scene.camera.data.dof.focus_distance = 3.0
    bpy.ops.object.light_add(type="POINT", location=(3.0, -2.0, 8.0))
    bpy.context.object.data.energy = 1000.0
    bpy.context.object.data.shadow_soft_size = 0.0
    scene.world = bpy.data.worlds.new("World")
    scene.view_layers[0].use_pass_z = True
    return scene


def defocus_by_depth(scene: bpy.types.Scene, on: bool) -> None:
    """Render Layers -> Defocus (Z from the Depth pass, the camera's focus, f/0.5) -> Composite, or no compositing."""
    scene.use_nodes = on
    if not on:
        return
    tree = scene.node_tree
    tree.nodes.clear()
    layers, composite = tree.nodes.new("CompositorNodeRLayers"), tree.nodes.new("CompositorNodeComposite")
    defocus = tree.nodes.new("CompositorNodeDefocus")
    defocus.scene = scene
    defocus.use_zbuffer = True
    defocus.f_stop = 0.5
    tree.links.new(layers.outputs["Image"], defocus.inputs["Image"])
    tree.links.new(layers.outputs["Depth"], defocus.inputs["Z"])
    tree.links.new(defocus.outputs["Image"], composite.inputs["Image"])


def rendered(scene: bpy.types.Scene, path: Path) -> np.ndarray:
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))  # Blender's own reader: 3.4's Python has no Pillow
    try:
        width, height = image.size
        return np.asarray(image.pixels[:], dtype=np.float64).reshape(height, width, 4)[..., :3]
    finally:
        bpy.data.images.remove(image)


def changed_by_defocus(scene: bpy.types.Scene, tmp_path: Path, engine: str) -> np.ndarray:
    """Which pixels the Defocus node changes, by more than a tenth of its largest change: the two engines' shadows
    differ in contrast (Cycles' bounce light lifts them), so each engine's blur is measured against its own."""
    scene.render.engine = engine
    # antialiased edges, as Cycles' filter gives them; 64: the world light's 16 directions in 4 turns (its noise
    # in the shadows halved, as Cycles' 256 samples keep theirs low: the noise changes under the blur too)
    scene.weathervane.samples = "64"
    if engine == "CYCLES":
        scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.seed = 256, False, 0
        scene.cycles.device = "CPU"
    defocus_by_depth(scene, False)
    sharp = rendered(scene, tmp_path / f"{engine}-sharp.png")
    defocus_by_depth(scene, True)
    blurred = rendered(scene, tmp_path / f"{engine}-defocus.png")
    change = np.abs(blurred - sharp).max(axis=2)
    return change > 0.1 * change.max()


def test_defocus_by_the_engines_depth_blurs_where_it_does_with_cycles_depth(tmp_path: Path) -> None:
    scene = scene_with_depth_of_field()
    tracer = changed_by_defocus(scene, tmp_path, "WEATHERVANE_TRACER")
    cycles = changed_by_defocus(scene, tmp_path, "CYCLES")
    iou = (tracer & cycles).sum() / max(1, (tracer | cycles).sum())
    print(f"Defocus changed {tracer.sum()} pixels (tracer) and {cycles.sum()} (Cycles); IoU {iou:.3f}")
    assert tracer.sum() > 0.05 * tracer.size  # the blur shows
    assert iou >= 0.9
