"""Node trees as Blender evaluates them (addon/node_tree.py): materials built from node groups (nested, with
reroutes and muted nodes in the way) convert as their flat equivalents do, and the constant arithmetic the walker
folds (Math, Vector Math, Map Range, Clamp, Invert, Mix, Separate / Combine, Color Ramp, RGB Curves, Gamma,
Bright/Contrast, Hue/Saturation/Value, RGB to BW, and products with a constant 0 whose other factor varies) gives the
values Cycles renders: each chain drives an Emission shader's Color on a plane of its own, and Cycles' pixel over the
plane is the truth. Geometry > Backfacing reads front faces, and a single-sided plane's back is named where Cycles
shows it otherwise from behind; flat normal maps and bumps are the surface's own normal where Cycles shades them as the
unperturbed plane. Runs in every Blender the add-on suite runs in."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import material_convert, node_tree
from tests.addon.f12_images import f12_exr


def _material(name: str) -> tuple[bpy.types.Material, bpy.types.NodeTree]:
    material = bpy.data.materials.new(name)
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    return material, tree


def _group(name: str, inputs: list[tuple[str, str]], outputs: list[tuple[str, str]]) -> bpy.types.NodeTree:
    """An empty shader node group with these (name, socket type) inputs and outputs, and its Group Input/Output."""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for sockets, direction in ((inputs, "INPUT"), (outputs, "OUTPUT")):
        for socket_name, kind in sockets:
            if hasattr(group, "interface"):  # 4.0+
                group.interface.new_socket(socket_name, in_out=direction, socket_type=kind)
            else:
                (group.inputs if direction == "INPUT" else group.outputs).new(kind, socket_name)
    group.nodes.new("NodeGroupInput")
    group.nodes.new("NodeGroupOutput")
    return group


def _flat_material() -> bpy.types.Material:
    material, tree = _material("flat")
    output, principled = tree.nodes.new("ShaderNodeOutputMaterial"), tree.nodes.new("ShaderNodeBsdfPrincipled")
    principled.inputs["Base Color"].default_value = (0.2, 0.5, 0.7, 1.0)
    principled.inputs["Roughness"].default_value = 0.3
    principled.inputs["Alpha"].default_value = 0.6
    tree.links.new(principled.outputs[0], output.inputs["Surface"])
    return material


def _grouped_material() -> bpy.types.Material:
    """The flat material's Principled BSDF two groups deep: Base Color from the outer group node's unlinked socket
    through a reroute and a muted Gamma, Roughness 0.15 x 2 by a Math node in the inner group, Alpha a Map Range of
    a Value node outside."""
    inner = _group(
        "inner", [("Color", "NodeSocketColor"), ("Alpha", "NodeSocketFloat")], [("Shader", "NodeSocketShader")]
    )
    principled = inner.nodes.new("ShaderNodeBsdfPrincipled")
    doubled = inner.nodes.new("ShaderNodeMath")
    doubled.operation, doubled.inputs[0].default_value, doubled.inputs[1].default_value = "MULTIPLY", 0.15, 2.0
    inner.links.new(doubled.outputs[0], principled.inputs["Roughness"])
    inner.links.new(inner.nodes["Group Input"].outputs["Color"], principled.inputs["Base Color"])
    inner.links.new(inner.nodes["Group Input"].outputs["Alpha"], principled.inputs["Alpha"])
    inner.links.new(principled.outputs[0], inner.nodes["Group Output"].inputs["Shader"])
    outer = _group("outer", [("Tint", "NodeSocketColor"), ("Alpha", "NodeSocketFloat")], [("BSDF", "NodeSocketShader")])
    holder = outer.nodes.new("ShaderNodeGroup")
    holder.node_tree = inner
    reroute = outer.nodes.new("NodeReroute")
    muted = outer.nodes.new("ShaderNodeGamma")
    muted.inputs["Gamma"].default_value = 3.0
    muted.mute = True
    outer.links.new(outer.nodes["Group Input"].outputs["Tint"], reroute.inputs[0])
    outer.links.new(reroute.outputs[0], muted.inputs["Color"])
    outer.links.new(muted.outputs[0], holder.inputs["Color"])
    outer.links.new(outer.nodes["Group Input"].outputs["Alpha"], holder.inputs["Alpha"])
    outer.links.new(holder.outputs[0], outer.nodes["Group Output"].inputs["BSDF"])
    material, tree = _material("grouped")
    output, top = tree.nodes.new("ShaderNodeOutputMaterial"), tree.nodes.new("ShaderNodeGroup")
    top.node_tree = outer
    top.inputs["Tint"].default_value = (0.2, 0.5, 0.7, 1.0)
    value, remap = tree.nodes.new("ShaderNodeValue"), tree.nodes.new("ShaderNodeMapRange")
    value.outputs[0].default_value = 3.0
    remap.inputs["From Min"].default_value, remap.inputs["From Max"].default_value = 0.0, 5.0
    tree.links.new(value.outputs[0], remap.inputs["Value"])
    tree.links.new(remap.outputs["Result"], top.inputs["Alpha"])
    tree.links.new(top.outputs[0], output.inputs["Surface"])
    return material


def test_a_material_of_nested_groups_converts_as_its_flat_equivalent() -> None:
    flat, flat_notes = material_convert.convert_material(_flat_material())
    grouped, grouped_notes = material_convert.convert_material(_grouped_material())
    assert grouped.keys() == flat.keys() and grouped["alpha"] == pytest.approx(0.6)
    for key, value in flat.items():
        if isinstance(value, str):  # a glossy lobe's kind
            assert grouped[key] == value, key
            continue
        assert np.asarray(grouped[key], dtype=float) == pytest.approx(np.asarray(value, dtype=float), rel=1e-6), key
    assert grouped_notes == flat_notes


def test_an_image_inside_a_group_is_the_materials_texture() -> None:
    image = bpy.data.images.new("checks", 4, 2, float_buffer=True)
    texels = np.random.default_rng(5).uniform(0.0, 1.0, size=(2, 4, 4)).astype(np.float32)
    image.pixels.foreach_set(texels.ravel())
    group = _group("textured", [], [("Color", "NodeSocketColor")])
    texture = group.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    group.links.new(texture.outputs["Color"], group.nodes["Group Output"].inputs["Color"])
    material, tree = _material("textured")
    output, diffuse = tree.nodes.new("ShaderNodeOutputMaterial"), tree.nodes.new("ShaderNodeBsdfDiffuse")
    holder = tree.nodes.new("ShaderNodeGroup")
    holder.node_tree = group
    tree.links.new(holder.outputs["Color"], diffuse.inputs["Color"])
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    document, notes = material_convert.convert_material(material)
    assert notes == []
    np.testing.assert_allclose(document["texture"]["pixels"], texels[::-1, :, :3], atol=1e-6)


def test_the_node_walker_sees_every_node_in_groups_and_names_their_path() -> None:
    material = _grouped_material()
    found = {node.bl_idname: node for node in node_tree.nodes(material.node_tree)}
    principled = found["ShaderNodeBsdfPrincipled"]
    assert [group.node_tree.name for group in principled.path] == ["outer", "inner"]
    assert principled.path_name.endswith("Principled BSDF") and principled.path_name.count(">") == 2
    assert "ShaderNodeGroup" not in found


# --- constant folding against Cycles ---------------------------------------------------------------------------------


MATH_OPERATIONS = bpy.types.ShaderNodeMath.bl_rna.properties["operation"].enum_items.keys()


def _math(tree, operation: str, a: float, b: float = 0.5, c: float = 0.0, clamp: bool = False):
    node = tree.nodes.new("ShaderNodeMath")
    node.operation, node.use_clamp = operation, clamp
    for socket, value in zip(node.inputs, (a, b, c), strict=True):
        socket.default_value = value
    return node.outputs[0]


def _mix(tree, data_type: str, blend: str, factor: float, a, b):
    node = tree.nodes.new("ShaderNodeMix")
    node.data_type, node.blend_type = data_type, blend
    by_id = {socket.identifier: socket for socket in node.inputs}
    suffix = {"FLOAT": "Float", "RGBA": "Color", "VECTOR": "Vector"}[data_type]
    by_id["Factor_Float"].default_value = factor
    by_id[f"A_{suffix}"].default_value, by_id[f"B_{suffix}"].default_value = a, b
    return next(socket for socket in node.outputs if socket.identifier == f"Result_{suffix}")


def _node(tree, kind: str, output: str | int = 0, **inputs):
    node = tree.nodes.new(kind)
    for name, value in inputs.items():
        node.inputs[name.replace("_", " ")].default_value = value
    return node.outputs[output]


def _chains(tree) -> dict:
    """Constant chains, each an output socket of `tree` whose value lies in 0..2 (an Emission colour Cycles shows)."""
    chains = {}
    for operation, a, b, c in [
        ("ADD", 0.25, 0.5, 0.0),
        ("SUBTRACT", 0.9, 0.25, 0.0),
        ("DIVIDE", 0.6, 0.8, 0.0),
        ("MULTIPLY_ADD", 0.3, 2.0, 0.1),
        ("POWER", 0.5, 2.2, 0.0),
        ("LOGARITHM", 8.0, 16.0, 0.0),
        ("SQRT", 0.3, 0.0, 0.0),
        ("INVERSE_SQRT", 2.0, 0.0, 0.0),
        ("ABSOLUTE", -0.4, 0.0, 0.0),
        ("EXPONENT", -1.0, 0.0, 0.0),
        ("MINIMUM", 0.7, 0.3, 0.0),
        ("SMOOTH_MIN", 0.4, 0.5, 0.3),
        ("SMOOTH_MAX", 0.4, 0.5, 0.3),
        ("LESS_THAN", 0.2, 0.5, 0.0),
        ("COMPARE", 0.5, 0.52, 0.05),
        ("FRACT", 2.35, 0.0, 0.0),
        ("MODULO", 1.3, 0.5, 0.0),
        ("FLOORED_MODULO", -1.3, 0.5, 0.0),
        ("WRAP", 1.7, 1.0, 0.2),
        ("SNAP", 0.77, 0.25, 0.0),
        ("PINGPONG", 1.3, 0.5, 0.0),
        ("SINE", 1.0, 0.0, 0.0),
        ("ARCTAN2", 0.5, 0.8, 0.0),
        ("ROUND", 0.5, 0.0, 0.0),
        ("TRUNC", 1.6, 0.0, 0.0),
    ]:
        if operation in MATH_OPERATIONS:  # Floored Modulo: 4.0 and later
            chains[f"math {operation}"] = _math(tree, operation, a, b, c)
    chains["math clamped"] = _math(tree, "ADD", 0.8, 0.9, clamp=True)
    nested = _math(tree, "MULTIPLY", 0.5, 0.5)
    outer = tree.nodes.new("ShaderNodeMath")
    outer.operation, outer.inputs[1].default_value = "ADD", 0.1
    tree.links.new(nested, outer.inputs[0])
    chains["math of math"] = outer.outputs[0]
    for kind, extra in (("LINEAR", {}), ("STEPPED", {"Steps": 3.0}), ("SMOOTHSTEP", {}), ("SMOOTHERSTEP", {})):
        node = tree.nodes.new("ShaderNodeMapRange")
        node.interpolation_type = kind
        values = {"Value": 0.35, "From Min": 0.1, "From Max": 0.9, "To Min": 0.2, "To Max": 1.2, **extra}
        for name, value in values.items():
            next(s for s in node.inputs if s.name == name and s.enabled).default_value = value
        chains[f"map range {kind}"] = node.outputs["Result"]
    chains["clamp"] = _node(tree, "ShaderNodeClamp", Value=1.7, Min=0.2, Max=0.6)
    chains["invert"] = _node(tree, "ShaderNodeInvert", Fac=0.7, Color=(0.2, 0.5, 0.9, 1.0))
    for blend in ("MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "DARKEN", "OVERLAY"):
        chains[f"mix {blend}"] = _mix(tree, "RGBA", blend, 0.4, (0.2, 0.6, 0.9, 1.0), (0.7, 0.3, 0.5, 1.0))
    chains["mix float"] = _mix(tree, "FLOAT", "MIX", 0.25, 0.2, 1.0)
    separate = tree.nodes.new("ShaderNodeSeparateColor")
    separate.inputs[0].default_value = (0.1, 0.6, 0.3, 1.0)
    chains["separate green"] = separate.outputs[1]
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    combine.inputs[0].default_value, combine.inputs[1].default_value = 0.3, 0.8
    tree.links.new(separate.outputs[0], combine.inputs[2])
    chains["combine xyz"] = combine.outputs[0]
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.9, 0.1, 0.2, 1.0)
    ramp.color_ramp.elements[1].color = (0.1, 0.3, 1.0, 1.0)
    ramp.inputs["Fac"].default_value = 0.3
    chains["color ramp"] = ramp.outputs["Color"]
    curves = tree.nodes.new("ShaderNodeRGBCurve")
    curves.mapping.curves[3].points.new(0.5, 0.8)
    curves.mapping.update()
    curves.inputs["Color"].default_value = (0.5, 0.25, 0.75, 1.0)
    chains["rgb curves"] = curves.outputs[0]
    chains["gamma"] = _node(tree, "ShaderNodeGamma", Color=(0.5, 0.2, 0.9, 1.0), Gamma=2.2)
    chains["bright contrast"] = _node(tree, "ShaderNodeBrightContrast", Color=(0.5, 0.2, 0.9, 1.0), Bright=0.1,
                                      Contrast=0.4)  # fmt: skip
    chains["hue saturation"] = _node(tree, "ShaderNodeHueSaturation", Color=(0.6, 0.3, 0.2, 1.0), Hue=0.3,
                                     Saturation=1.4, Value=1.2)  # fmt: skip
    vector = tree.nodes.new("ShaderNodeVectorMath")
    vector.operation = "CROSS_PRODUCT"
    vector.inputs[0].default_value, vector.inputs[1].default_value = (0.2, 0.1, 0.4), (0.5, 0.9, 0.3)
    absolute = tree.nodes.new("ShaderNodeVectorMath")
    absolute.operation = "ABSOLUTE"
    tree.links.new(vector.outputs["Vector"], absolute.inputs[0])
    chains["vector math"] = absolute.outputs["Vector"]
    length = tree.nodes.new("ShaderNodeVectorMath")
    length.operation = "LENGTH"
    length.inputs[0].default_value = (0.3, 0.4, 0.5)
    chains["vector length"] = length.outputs["Value"]
    chains["rgb to bw"] = _node(tree, "ShaderNodeRGBToBW", Color=(0.2, 0.6, 0.9, 1.0))
    return chains


def _absorbing_chains(tree) -> dict:
    """Products with a constant 0 whose other factor varies over the surface (a Fresnel, the plane's Generated
    coordinates): Cycles gives exactly 0 there, and the walker folds the chains after them."""
    chains = {}
    # glTF's old importer: Dielectric Fresnel x (1 - metallic) + Metal Fresnel x metallic, metallic 1, the metal's
    # Fresnel F0 + (1 - F0)(1 - N.I)^5 of F0 = RGB to BW (white) = 1: the factor is 1 at every point
    metallic = _node(tree, "ShaderNodeValue")
    metallic.default_value = 1.0
    fresnel = _node(tree, "ShaderNodeFresnel", IOR=1.5)
    one_minus = _math(tree, "SUBTRACT", 1.0)
    tree.links.new(metallic, one_minus.node.inputs[1])
    dielectric = _math(tree, "MULTIPLY", 0.0, 0.0)
    tree.links.new(fresnel, dielectric.node.inputs[0])
    tree.links.new(one_minus, dielectric.node.inputs[1])
    f0 = _node(tree, "ShaderNodeRGBToBW")
    white = _node(tree, "ShaderNodeRGB")
    white.default_value = (1.0, 1.0, 1.0, 1.0)
    tree.links.new(white, f0.node.inputs["Color"])
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    cosine = tree.nodes.new("ShaderNodeVectorMath")
    cosine.operation = "DOT_PRODUCT"
    tree.links.new(geometry.outputs["Normal"], cosine.inputs[0])
    tree.links.new(geometry.outputs["Incoming"], cosine.inputs[1])
    falloff, fifth, slope, weighted, metal_fresnel, metal, total = (
        _math(tree, operation, 1.0, 5.0) for operation in ("SUBTRACT", "POWER", "SUBTRACT", "MULTIPLY", "ADD",
                                                           "MULTIPLY", "ADD")
    )  # fmt: skip
    for source, target in [
        (cosine.outputs["Value"], falloff.node.inputs[1]),
        (falloff, fifth.node.inputs[0]),
        (f0, slope.node.inputs[1]),
        (slope, weighted.node.inputs[0]),
        (fifth, weighted.node.inputs[1]),
        (f0, metal_fresnel.node.inputs[0]),
        (weighted, metal_fresnel.node.inputs[1]),
        (metal_fresnel, metal.node.inputs[0]),
        (metallic, metal.node.inputs[1]),
        (dielectric, total.node.inputs[0]),
        (metal, total.node.inputs[1]),
    ]:
        tree.links.new(source, target)
    chains["fresnel x zero metallic"] = total
    generated = tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"]
    across = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(generated, across.inputs[0])
    multiply_add = _math(tree, "MULTIPLY_ADD", 0.5, 0.0, 0.3)
    tree.links.new(across.outputs[0], multiply_add.node.inputs[0])
    chains["multiply add by 0"] = multiply_add
    for operation in ("MULTIPLY", "SCALE", "DOT_PRODUCT", "CROSS_PRODUCT"):
        product = tree.nodes.new("ShaderNodeVectorMath")
        product.operation = operation
        product.inputs[1].default_value, product.inputs[3].default_value = (0.0, 0.0, 0.0), 0.0
        tree.links.new(generated, product.inputs[0])
        shifted = tree.nodes.new("ShaderNodeVectorMath")
        shifted.operation, shifted.inputs[1].default_value = "ADD", (0.2, 0.4, 0.6)
        tree.links.new(product.outputs["Value" if operation == "DOT_PRODUCT" else "Vector"], shifted.inputs[0])
        chains[f"vector {operation} by 0"] = shifted.outputs["Vector"]
    for name, factor, black in (
        ("mix multiply by black B", 1.0, "B_Color"),
        ("mix multiply of black A", 0.5, "A_Color"),
    ):
        mixed = _mix(tree, "RGBA", "MULTIPLY", factor, (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0))
        varying = next(s for s in mixed.node.inputs if s.identifier == ("A_Color" if black == "B_Color" else "B_Color"))
        tree.links.new(generated, varying)
        lifted = _mix(tree, "RGBA", "ADD", 1.0, (0.0, 0.0, 0.0, 1.0), (0.3, 0.2, 0.1, 1.0))
        tree.links.new(mixed, next(s for s in lifted.node.inputs if s.identifier == "A_Color"))
        chains[name] = lifted
    return chains


def test_folded_constants_are_what_cycles_renders(tmp_path: Path) -> None:
    scene = bpy.context.scene
    probe = bpy.data.node_groups.new("probe", "ShaderNodeTree")
    builders = {name: builder for builder in (_chains, _absorbing_chains) for name in builder(probe)}
    names = list(builders)  # each material holds every chain of its builder
    columns = 8
    rows = math.ceil(len(names) / columns)
    expected = {}
    for index, name in enumerate(names):
        material, tree = _material(name)
        chain = builders[name](tree)[name]
        emission, output = tree.nodes.new("ShaderNodeEmission"), tree.nodes.new("ShaderNodeOutputMaterial")
        tree.links.new(chain, emission.inputs["Color"])
        tree.links.new(emission.outputs[0], output.inputs["Surface"])
        expected[name] = node_tree.constant_color(emission.inputs["Color"])
        assert expected[name] is not None, f"{name}: not folded"
        mesh = bpy.data.meshes.new(name)
        x, y = index % columns, index // columns
        mesh.from_pydata([(x, y, 0), (x + 1, y, 0), (x + 1, y + 1, 0), (x, y + 1, 0)], [], [(0, 1, 2, 3)])
        mesh.materials.append(material)
        scene.collection.objects.link(bpy.data.objects.new(name, mesh))
    camera = bpy.data.cameras.new("camera")
    camera.type, camera.ortho_scale = "ORTHO", float(columns)
    scene.camera = bpy.data.objects.new("camera", camera)
    scene.camera.location = (columns / 2.0, rows / 2.0, 5.0)
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x, scene.render.resolution_y = columns * 4, rows * 4
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 1, False
    scene.cycles.filter_width = 0.01
    pixels = f12_exr(tmp_path / "cycles.exr")  # rows from the bottom, as the planes' y
    wrong = []
    for index, name in enumerate(names):
        x, y = index % columns, index // columns
        shown = pixels[y * 4 + 1 : y * 4 + 3, x * 4 + 1 : x * 4 + 3].reshape(-1, 3).mean(axis=0)
        if not np.allclose(shown, expected[name], atol=2e-3, rtol=2e-3):
            wrong.append(f"{name}: folded {np.round(expected[name], 4)}, Cycles {np.round(shown, 4)}")
    assert not wrong, "\n".join(wrong)


# --- front and back faces, flat normal maps, against Cycles ----------------------------------------------------------


def _planes(materials: list, size: float = 1.6, uv: bool = False) -> None:
    """One single-sided quad per material in a row along x (centres 2 apart from x = 1 - len), each size across."""
    scene = bpy.context.scene
    for index, material in enumerate(materials):
        x, h = 2.0 * index + 1.0 - len(materials), size / 2.0
        mesh = bpy.data.meshes.new(material.name)
        mesh.from_pydata([(x - h, -h, 0), (x + h, -h, 0), (x + h, h, 0), (x - h, h, 0)], [], [(0, 1, 2, 3)])
        if uv:  # a UV map gives the normal map its tangents
            mesh.uv_layers.new(name="UVMap").data.foreach_set("uv", [0, 0, 1, 0, 1, 1, 0, 1])
        mesh.materials.append(material)
        scene.collection.objects.link(bpy.data.objects.new(material.name, mesh))


def _row_camera(count: int, from_below: bool = False) -> None:
    """An orthographic camera 4 pixels per plane of _planes, from above (z = 5) or below (z = -5, x as above)."""
    scene = bpy.context.scene
    camera = bpy.data.cameras.new("camera")
    camera.type, camera.ortho_scale = "ORTHO", 2.0 * count
    scene.camera = bpy.data.objects.new("camera", camera)
    scene.camera.location = (0.0, 0.0, -5.0 if from_below else 5.0)
    scene.camera.rotation_euler = (math.pi if from_below else 0.0, 0.0, 0.0)
    scene.collection.objects.link(scene.camera)
    scene.render.resolution_x, scene.render.resolution_y = 4 * count, 4
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 1, False
    scene.cycles.filter_width, scene.cycles.max_bounces = 0.01, 0


def _plane_pixels(pixels: np.ndarray, count: int) -> list[np.ndarray]:
    """The mean of the 2 x 2 pixels at each plane's centre."""
    return [pixels[1:3, 4 * i + 1 : 4 * i + 3].reshape(-1, pixels.shape[2]).mean(axis=0) for i in range(count)]


def _double_sided_switch(name: str, double_sided: float) -> bpy.types.Material:
    """glTF's old importer's double-sidedness: Mix Shader (Transparent, the surface) by max(DoubleSided > 0.5,
    1 - Backfacing), the surface an Emission."""
    material, tree = _material(name)
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    flag, front, either = (
        _math(tree, "GREATER_THAN", double_sided),
        _math(tree, "SUBTRACT", 1.0),
        _math(tree, "MAXIMUM", 0),
    )
    tree.links.new(geometry.outputs["Backfacing"], front.node.inputs[1])
    tree.links.new(flag, either.node.inputs[0])
    tree.links.new(front, either.node.inputs[1])
    mix, output = tree.nodes.new("ShaderNodeMixShader"), tree.nodes.new("ShaderNodeOutputMaterial")
    emission, clear = tree.nodes.new("ShaderNodeEmission"), tree.nodes.new("ShaderNodeBsdfTransparent")
    emission.inputs["Color"].default_value = (0.8, 0.3, 0.1, 1.0)
    tree.links.new(either, mix.inputs[0])
    tree.links.new(clear.outputs[0], mix.inputs[1])
    tree.links.new(emission.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], output.inputs["Surface"])
    return material


def test_backfacing_reads_front_faces_and_names_back_faces_where_cycles_shows_them_otherwise(tmp_path: Path) -> None:
    materials = [_double_sided_switch("single-sided", 0.0), _double_sided_switch("double-sided", 1.0)]
    _planes(materials)
    scene = bpy.context.scene
    scene.world, scene.render.film_transparent = None, True
    seen = {}
    for side in ("front", "back"):
        _row_camera(len(materials), from_below=side == "back")
        seen[side] = _plane_pixels(f12_exr(tmp_path / f"{side}.exr", "RGBA"), len(materials))
    converted = {material.name: material_convert.convert_material(material) for material in materials}
    with node_tree.back_faces():
        behind = {material.name: material_convert.convert_material(material)[0] for material in materials}
    for index, material in enumerate(materials):
        document, notes = converted[material.name]
        assert not [note for note in notes if "own value" in note], notes
        for side, shown in (("front", document), ("back", behind[material.name])):
            pixel = seen[side][index]
            alpha = shown.get("alpha", 1.0)
            assert pixel[3] == pytest.approx(alpha, abs=1e-3), (material.name, side)
            if alpha > 0.0:
                assert pixel[:3] == pytest.approx(shown["emission"], abs=2e-3), (material.name, side)
    differs = not np.allclose(seen["front"][0], seen["back"][0], atol=1e-3)
    assert differs and np.allclose(seen["front"][1], seen["back"][1], atol=1e-3)  # Cycles: only the single-sided
    assert "Backfacing: back faces shaded as the front (Cycles: transparent)" in converted["single-sided"][1]
    assert not [note for note in converted["double-sided"][1] if "Backfacing" in note]


def _normal_group() -> bpy.types.NodeTree:
    """glTF's old importer's normal: Normal Map of the group's colour, X and Y times NormalScale, Z straight,
    normalised."""
    group = _group(
        "normal", [("Normal", "NodeSocketColor"), ("NormalScale", "NodeSocketFloat")], [("Normal", "NodeSocketVector")]
    )
    given = group.nodes["Group Input"].outputs
    mapped, split, join = (group.nodes.new(kind) for kind in ("ShaderNodeNormalMap", "ShaderNodeSeparateXYZ",
                                                              "ShaderNodeCombineXYZ"))  # fmt: skip
    unit = group.nodes.new("ShaderNodeVectorMath")
    unit.operation = "NORMALIZE"
    group.links.new(given["Normal"], mapped.inputs["Color"])
    group.links.new(mapped.outputs["Normal"], split.inputs[0])
    for axis in (0, 1):
        scaled = _math(group, "MULTIPLY", 0.0, 1.0)
        group.links.new(split.outputs[axis], scaled.node.inputs[0])
        group.links.new(given["NormalScale"], scaled.node.inputs[1])
        group.links.new(scaled, join.inputs[axis])
    group.links.new(split.outputs[2], join.inputs[2])
    group.links.new(join.outputs[0], unit.inputs[0])
    group.links.new(unit.outputs["Vector"], group.nodes["Group Output"].inputs["Normal"])
    return group


def _bumped(name: str, normal: str, **settings) -> bpy.types.Material:
    """A white Diffuse BSDF whose Normal is a Normal Map, a Bump (Height: the plane's Generated x where height is
    set), glTF's chain (_normal_group) or nothing."""
    material, tree = _material(name)
    diffuse, output = tree.nodes.new("ShaderNodeBsdfDiffuse"), tree.nodes.new("ShaderNodeOutputMaterial")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    if normal == "map":
        node = tree.nodes.new("ShaderNodeNormalMap")
        node.inputs["Color"].default_value, node.inputs["Strength"].default_value = (
            settings["color"],
            settings["strength"],
        )
    elif normal == "bump":
        node = tree.nodes.new("ShaderNodeBump")
        node.inputs["Strength"].default_value, node.inputs["Distance"].default_value = settings["strength"], 1.0
        if settings["height"]:
            across = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], across.inputs[0])
            tree.links.new(across.outputs[0], node.inputs["Height"])
    elif normal == "gltf":
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = bpy.data.node_groups.get("normal") or _normal_group()
        node.inputs["Normal"].default_value, node.inputs["NormalScale"].default_value = settings["color"], 1.0
    else:
        return material
    tree.links.new(node.outputs["Normal"], diffuse.inputs["Normal"])
    return material


def test_flat_normal_maps_are_the_surfaces_own_normal_where_cycles_shades_them_so(tmp_path: Path) -> None:
    flat, tilted = (0.5, 0.5, 1.0, 1.0), (0.8, 0.5, 0.9, 1.0)
    materials = [
        _bumped("plain", ""),
        _bumped("flat map", "map", color=flat, strength=0.7),
        _bumped("strength 0 map", "map", color=tilted, strength=0.0),
        _bumped("glTF flat map", "gltf", color=flat),
        _bumped("bump strength 0", "bump", strength=0.0, height=True),
        _bumped("bump without height", "bump", strength=1.0, height=False),
        _bumped("tilted map", "map", color=tilted, strength=1.0),
        _bumped("glTF tilted map", "gltf", color=tilted),
        _bumped("bump of a slope", "bump", strength=1.0, height=True),
    ]
    _planes(materials, uv=True)
    sun = bpy.data.lights.new("sun", "SUN")
    sun.angle, sun.energy = 0.0, 1.0
    lamp = bpy.data.objects.new("sun", sun)
    lamp.rotation_euler = (0.0, 0.7, 0.0)
    bpy.context.scene.collection.objects.link(lamp)
    bpy.context.scene.world = None
    _row_camera(len(materials))
    pixels = _plane_pixels(f12_exr(tmp_path / "normals.exr"), len(materials))
    assert pixels[0] == pytest.approx([math.cos(0.7) / math.pi] * 3, rel=1e-3)  # the sun, unperturbed
    for material, pixel in zip(materials, pixels, strict=True):
        diffuse = next(node for node in material.node_tree.nodes if node.bl_idname == "ShaderNodeBsdfDiffuse")
        unperturbed = bool(np.allclose(pixel, pixels[0], rtol=1e-3))
        assert node_tree.own_normal(diffuse.inputs["Normal"]) == unperturbed, (material.name, pixel, pixels[0])
        named = "normal or bump map: the surface's own normal" in material_convert.convert_material(material)[1]
        assert named != unperturbed, material.name
    assert [bool(np.allclose(p, pixels[0], rtol=1e-3)) for p in pixels] == [True] * 6 + [False] * 3
