"""Glass and transparency from Blender's node trees (issue 36, item 2): Glass BSDF, Refraction BSDF, Principled
Transmission and IOR, Principled Alpha and Transparent BSDF -> the material's transmission t, ior and alpha a
(docs/scene-format.md), and F12 beside Cycles: a glass sphere's refracted checker, an Alpha 0 object that is not
there, an Alpha 0.5 one that is half there. Runs in the bpy wheel (5.0.1) and in Debian's 3.4.1 (run_in_blender.py)."""

from __future__ import annotations

import bpy
import numpy as np
import pytest

from addon import compat, conversion_report, material_convert

ENGINE = "WEATHERVANE_TRACER"


def shader_tree(*kinds: str) -> tuple[bpy.types.Material, bpy.types.NodeTree, bpy.types.Node, list]:
    """A material with only a Material Output and the given shader nodes (unlinked)."""
    material = bpy.data.materials.new("glassy")
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    return material, tree, output, [tree.nodes.new(kind) for kind in kinds]


def single(kind: str, **inputs) -> tuple[bpy.types.Material, bpy.types.Node]:
    """A material of one shader node of this kind, its inputs set, on the output's Surface."""
    material, tree, output, (node,) = shader_tree(kind)
    for name, value in inputs.items():
        node.inputs[name].default_value = value
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    return material, node


def mixed(first: str, second: str, factor: float) -> tuple[bpy.types.Material, list]:
    """Mix Shader (factor) of a first and a second shader node: (1 - factor) first + factor second."""
    material, tree, output, nodes = shader_tree(first, second, "ShaderNodeMixShader")
    mix = nodes[2]
    tree.links.new(nodes[0].outputs[0], mix.inputs[1])
    tree.links.new(nodes[1].outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], output.inputs["Surface"])
    mix.inputs[0].default_value = factor
    return material, nodes


def principled(**inputs) -> tuple[bpy.types.Material, bpy.types.Node]:
    """The default Principled material with inputs by role (transmission, specular) or socket name."""
    material = bpy.data.materials.new("principled")
    compat.enable_nodes(material)
    node = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    for name, value in inputs.items():
        socket = compat.principled_input(node, name) if name in ("transmission", "specular") else node.inputs[name]
        socket.default_value = value
    return material, node


def f32(value: float) -> float:
    """value as Blender's float32 socket keeps it."""
    return float(np.float32(value))


# --- the conversion ---------------------------------------------------------------------------------------------------


def test_a_glass_bsdf_is_all_transmission_of_its_ior_tinted_by_its_colour() -> None:
    material, node = single("ShaderNodeBsdfGlass", IOR=1.33, Color=(1.0, 1.0, 1.0, 1.0))
    document, notes = material_convert.convert_material(material)
    assert notes == []
    assert document["transmission"] == 1.0 and document["ior"] == 1.33 and "alpha" not in document
    assert document["color"] == [1.0, 1.0, 1.0] and document["reflective"] == 0.0
    node.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    node.inputs["Roughness"].default_value = 0.3
    document, notes = material_convert.convert_material(material)
    assert document["color"] == pytest.approx([0.9, 0.5, 0.2]) and document["transmission"] == 1.0
    assert notes == ["rough Glass BSDF: sharp", "Glass BSDF colour: tints the refraction only"]
    if "SHARP" in [item.identifier for item in node.bl_rna.properties["distribution"].enum_items]:
        node.distribution = "SHARP"  # 3.x: a sharp glass whatever its Roughness
        assert material_convert.convert_material(material)[1] == ["Glass BSDF colour: tints the refraction only"]


def test_a_refraction_bsdf_is_glass_with_its_reflection_named() -> None:
    material, _ = single("ShaderNodeBsdfRefraction", IOR=1.6)
    document, notes = material_convert.convert_material(material)
    assert document["transmission"] == 1.0 and document["ior"] == 1.6
    assert notes == ["Refraction BSDF: glass, its reflection added"]


@pytest.mark.parametrize("metallic", [0.0, 0.5])
def test_principled_transmission_is_the_glass_share_of_what_metallic_leaves(metallic: float) -> None:
    """Cycles layers Metallic m over Transmission t over the dielectric: glass (1 - m) t, opaque 1 - (1 - m) t; the
    format's t is the glass's share of the covered surface."""
    material, node = principled(transmission=0.6, Metallic=metallic, Roughness=0.0, IOR=1.45)
    node.inputs["Base Color"].default_value = (0.2, 0.8, 0.4, 1.0)
    document, notes = material_convert.convert_material(material)
    metal = ["tinted mirror: white at its mean reflectance", "glass tint: the opaque part's colour"]
    assert notes == ([] if metallic == 0.0 else metal)
    assert document["transmission"] == pytest.approx((1.0 - metallic) * f32(0.6), rel=1e-6)
    assert document["ior"] == 1.45 and "alpha" not in document
    if metallic == 0.0:
        assert document["color"] == pytest.approx([0.2, 0.8, 0.4], abs=0.05)  # the opaque part's diffuse: the tint
    opaque, _ = principled(Metallic=metallic, Roughness=0.0, IOR=1.45)
    opaque.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.2, 0.8, 0.4, 1.0)
    plain = material_convert.convert_material(opaque)[0]
    if metallic == 0.0:  # the opaque rest is the plain dielectric
        assert document["reflective"] == pytest.approx(plain["reflective"], rel=1e-6)
        assert document["color"] == pytest.approx(plain["color"], rel=1e-6)
    compat.principled_input(node, "transmission").default_value = 1.0
    document, notes = material_convert.convert_material(material)
    assert document["transmission"] == pytest.approx(1.0 - metallic)
    if metallic == 0.0:  # all glass: its colour is the tint, Base Color
        assert document["color"] == pytest.approx([0.2, 0.8, 0.4], rel=1e-6) and notes == []
    node.inputs["Roughness"].default_value = 0.5
    assert "rough transmission: sharp" in material_convert.convert_material(material)[1]


def test_principled_alpha_is_the_coverage_and_leaves_the_rest_as_it_was() -> None:
    material, node = principled(Alpha=0.3, Roughness=0.2)
    node.inputs["Base Color"].default_value = (0.7, 0.1, 0.1, 1.0)
    document, notes = material_convert.convert_material(material)
    assert document["alpha"] == pytest.approx(0.3) and "transmission" not in document
    opaque, other = principled(Roughness=0.2)
    other.inputs["Base Color"].default_value = (0.7, 0.1, 0.1, 1.0)
    plain, plain_notes = material_convert.convert_material(opaque)
    assert notes == plain_notes  # what the opaque material names (its highlight clipped), nothing more
    for key in ("color", "specular_color"):
        assert document[key] == pytest.approx(plain[key], rel=1e-6)
    assert document["specular"] == pytest.approx(plain["specular"]) and document["reflective"] == pytest.approx(
        plain["reflective"], rel=1e-6
    )
    node.inputs["Alpha"].default_value = 0.0
    assert material_convert.convert_material(material)[0]["alpha"] == 0.0
    node.inputs["Alpha"].default_value = 1.0
    assert "alpha" not in material_convert.convert_material(material)[0]


def test_a_transparent_bsdf_alone_is_alpha_0_and_mixed_the_mix_factor() -> None:
    material, _ = single("ShaderNodeBsdfTransparent")
    document, notes = material_convert.convert_material(material)
    assert document["alpha"] == 0.0 and notes == []
    material, (diffuse, _, _) = mixed("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfTransparent", 0.25)
    diffuse.inputs["Color"].default_value = (0.1, 0.6, 0.3, 1.0)
    document, notes = material_convert.convert_material(material)
    assert notes == [] and document["alpha"] == pytest.approx(0.75)
    assert document["color"] == pytest.approx([0.1, 0.6, 0.3], rel=1e-6)  # the covered part: the diffuse itself
    material, _ = mixed("ShaderNodeBsdfTransparent", "ShaderNodeBsdfDiffuse", 0.25)
    assert material_convert.convert_material(material)[0]["alpha"] == pytest.approx(0.25)


def test_a_tinted_transparent_bsdf_passes_its_mean_named() -> None:
    material, _ = single("ShaderNodeBsdfTransparent", Color=(1.0, 0.5, 0.0, 1.0))
    document, notes = material_convert.convert_material(material)
    assert document["alpha"] == pytest.approx(0.5) and document["color"] == [0.0, 0.0, 0.0]
    assert notes == ["tinted transparency: grey of its mean"]


def test_glass_mixed_with_diffuse_and_with_transparent() -> None:
    material, (diffuse, glass, _) = mixed("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlass", 0.3)
    diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    glass.inputs["IOR"].default_value = 1.5
    document, notes = material_convert.convert_material(material)
    assert document["transmission"] == pytest.approx(0.3) and document["ior"] == 1.5
    assert document["color"] == pytest.approx([0.5, 0.5, 0.5]) and "alpha" not in document
    assert notes == ["glass tint: the opaque part's colour"]  # white glass, grey diffuse: one colour for both
    material, (glass, _, _) = mixed("ShaderNodeBsdfGlass", "ShaderNodeBsdfTransparent", 0.5)
    glass.inputs["IOR"].default_value = 1.45
    document, notes = material_convert.convert_material(material)
    assert notes == [] and document["alpha"] == pytest.approx(0.5) and document["transmission"] == 1.0


def test_transparent_shadows_off_is_named() -> None:
    """Cycles' Transparent Shadows switch: 3.x in the material's Cycles settings, 4.2+ on the material."""
    material, _ = principled(Alpha=0.5)
    assert material_convert.convert_material(material)[1] == []
    if compat.VERSION >= (4, 2, 0):
        material.use_transparent_shadow = False
    else:
        material.cycles.use_transparent_shadow = False
    notes = material_convert.convert_material(material)[1]
    assert notes == ["Transparent Shadows off: its shadow lets 1 - alpha through"]


def test_the_conversion_panel_no_longer_names_glass_and_alpha_but_names_subsurface() -> None:
    scene = bpy.context.scene
    scene.render.engine = ENGINE
    names = []
    for name, material in (
        ("glass", single("ShaderNodeBsdfGlass")[0]),
        ("see-through", principled(Alpha=0.5, transmission=0.5, Roughness=0.0)[0]),
        ("skin", principled(**{compat.principled_input(principled()[1], "subsurface").name: 0.5})[0]),
    ):
        material.name = name
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
        mesh.materials.append(material)
        scene.collection.objects.link(bpy.data.objects.new(name, mesh))
        names.append(material.name)
    bpy.context.view_layer.update()
    rows = {name: notes for kind, name, notes in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert rows[names[0]] == [] and rows[names[1]] == []
    assert rows[names[2]] == ["subsurface: rendered as the opaque base"]
