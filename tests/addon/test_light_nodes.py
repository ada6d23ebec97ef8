"""A light's node tree as Cycles reads it: the Emission's Color and Strength (through constant arithmetic and
groups), an output with no shader as no light, and what varies (a Blackbody, a texture) named. Each case is a white
floor under a 100 W point light, rendered by Cycles and by the engine; the floor under the light is compared per
channel. Runs in every Blender the add-on suite runs in."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import light_convert
from tests.addon.f12_images import f12_exr, looking_down


def _scene() -> bpy.types.Object:
    scene = bpy.context.scene
    material = bpy.data.materials.new("white")
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    output, diffuse = tree.nodes.new("ShaderNodeOutputMaterial"), tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    mesh = bpy.data.meshes.new("floor")
    mesh.from_pydata([(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("floor", mesh))
    data = bpy.data.lights.new("lamp", "POINT")
    data.energy, data.shadow_soft_size = 100.0, 0.0
    if data.node_tree is None:
        data.use_nodes = True
    lamp = bpy.data.objects.new("lamp", data)
    lamp.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(lamp)
    looking_down(1.0, 1.0)
    scene.cycles.max_bounces = 0
    scene.cycles.filter_width = 0.01
    return lamp


def _emission(lamp):
    tree = lamp.data.node_tree
    return next(node for node in tree.nodes if node.bl_idname == "ShaderNodeEmission"), tree


def _colour_by_math(lamp) -> None:
    emission, tree = _emission(lamp)
    emission.inputs["Color"].default_value = (0.2, 0.6, 1.0, 1.0)
    half = tree.nodes.new("ShaderNodeMath")
    half.operation, half.inputs[0].default_value, half.inputs[1].default_value = "MULTIPLY", 0.25, 2.0
    tree.links.new(half.outputs[0], emission.inputs["Strength"])


def _unlinked(lamp) -> None:
    _, tree = _emission(lamp)
    output = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeOutputLight")
    for link in list(output.inputs["Surface"].links):
        tree.links.remove(link)


CASES = {"plain": None, "colour and strength by math": _colour_by_math, "unlinked output": _unlinked}


@pytest.mark.parametrize("case", list(CASES))
def test_a_lights_node_tree_lights_the_floor_as_in_cycles(tmp_path: Path, case: str) -> None:
    lamp = _scene()
    if CASES[case] is not None:
        CASES[case](lamp)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = f12_exr(tmp_path / "cycles.exr").reshape(-1, 3).mean(axis=0)
    scene.render.engine = "WEATHERVANE_TRACER"
    tracer = f12_exr(tmp_path / "tracer.exr").reshape(-1, 3).mean(axis=0)
    print(f"{case}: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    if case == "unlinked output":
        assert cycles.max() == 0.0 and tracer.max() == 0.0
    else:
        np.testing.assert_allclose(tracer, cycles, rtol=0.03)


def test_a_blackbody_on_the_lights_colour_is_named() -> None:
    lamp = _scene()
    emission, tree = _emission(lamp)
    blackbody = tree.nodes.new("ShaderNodeBlackbody")
    tree.links.new(blackbody.outputs[0], emission.inputs["Color"])
    document, notes = light_convert.convert_light(lamp)
    assert "Blackbody on the light's Emission Color: white" in notes
    assert document["color"] == [1.0, 1.0, 1.0]


def test_a_lights_ray_visibility_and_a_spot_scaled_unevenly_export_as_the_light_does() -> None:
    """Diffuse or Glossy ray visibility off: the light's visible_diffuse or visible_glossy false. A spot scaled
    unevenly is stretched where Cycles stretches it (4.0+; Blender 3.4's Cycles keeps it round, measured: 32 x 32
    pixels against 62 x 20 in 4.2 and 5.0 for a scale of 2 x 0.6)."""
    lamp = _scene()
    document, notes = light_convert.convert_light(lamp)
    assert notes == [] and "visible_diffuse" not in document and "visible_glossy" not in document
    lamp.visible_diffuse, lamp.visible_glossy = False, False
    document, notes = light_convert.convert_light(lamp)
    split = compat.glass_closure_splits_light_visibility()  # 4+: Cycles reflects it in rough glass while either is on
    assert notes == (
        [] if split else ["Glossy ray visibility off: not reflected in rough glass (Cycles reflects it there too)"]
    )
    assert document["visible_diffuse"] is False and document["visible_glossy"] is False
    assert "visible_transmission" not in document  # Transmission on: the light through rough glass
    lamp.visible_transmission = False
    assert light_convert.convert_light(lamp)[0]["visible_transmission"] is False
    lamp.visible_glossy = True  # 4+: rough glass shows it while Glossy is on; 3.x: off it only
    assert light_convert.convert_light(lamp)[0].get("visible_transmission", True) is not split
    lamp.visible_glossy = lamp.visible_transmission = True
    spot = bpy.data.objects.new("spot", bpy.data.lights.new("spot", "SPOT"))
    bpy.context.scene.collection.objects.link(spot)
    spot.data.shadow_soft_size = 0.0
    spot.scale = (1.5, 1.5, 1.5)
    bpy.context.view_layer.update()
    assert light_convert.convert_light(spot)[1] == []
    spot.scale = (2.0, 0.6, 1.0)
    bpy.context.view_layer.update()
    document, notes = light_convert.convert_light(spot)
    assert notes == []
    if compat.cycles_spot_model() == "cycles4":
        assert document["x_axis"] == pytest.approx([1.0, 0.0, 0.0])
        assert document["cone_scale"] == pytest.approx([2.0, 0.6])
    else:
        assert "cone_scale" not in document
