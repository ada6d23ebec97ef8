"""Inputs artists' scenes hold, beside Cycles: an Attribute node of an empty or unknown name (Cycles reads 0), an image
whose file is missing (Cycles' magenta, and the file named), a missing world picture, a texture on a factor input
(its mean, named). Each is a plane under a sun seen straight on; the plane's mean colour is compared per channel.
Runs in every Blender the add-on suite runs in."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import material_convert
from addon.convert.export import ExportNotes, scene_document
from tests.addon.f12_images import f12_exr, looking_down
from tests.addon.node_groups import new_group

GEOMETRY = [("Geometry", "NodeSocketGeometry")]


def _plane_scene() -> tuple[bpy.types.Material, bpy.types.NodeTree, bpy.types.Node]:
    """A 2 m plane (with a UV map) of a Diffuse BSDF material under a 3 W/m^2 sun, an orthographic camera filling
    the view with it, no world. -> the material, its tree and the Diffuse node."""
    material_convert.clear_cache()  # the means of an earlier test's image or attribute of the same name
    scene = bpy.context.scene
    material = bpy.data.materials.new("surface")
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    output, diffuse = tree.nodes.new("ShaderNodeOutputMaterial"), tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    mesh = bpy.data.meshes.new("plane")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.uv_layers.new(name="UVMap")
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("plane", mesh))
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    scene.collection.objects.link(sun)
    looking_down(2.0, 1.5)
    scene.cycles.max_bounces = 0
    return material, tree, diffuse


def _missing_image(path: Path) -> bpy.types.Image:
    """An image as a .blend file holds one whose file was moved away: loaded from path, then the file gone."""
    image = bpy.data.images.new(path.name, 4, 2, float_buffer=path.suffix == ".exr")
    image.filepath_raw = str(path)
    image.file_format = "OPEN_EXR" if path.suffix == ".exr" else "PNG"
    image.save()
    loaded = bpy.data.images.load(str(path), check_existing=False)
    bpy.data.images.remove(image)
    path.unlink()
    loaded.reload()
    return loaded


def _both(tmp_path: Path) -> tuple[np.ndarray, np.ndarray]:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = f12_exr(tmp_path / "cycles.exr").reshape(-1, 3).mean(axis=0)
    scene.render.engine = "WEATHERVANE_TRACER"
    tracer = f12_exr(tmp_path / "tracer.exr").reshape(-1, 3).mean(axis=0)
    return cycles, tracer


@pytest.mark.parametrize("name", ["", "no_such_attribute"])
def test_an_attribute_no_mesh_has_is_black_as_in_cycles(tmp_path: Path, name: str) -> None:
    material, tree, diffuse = _plane_scene()
    mesh = bpy.data.meshes["plane"]
    colors = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")  # one the node does not name
    colors.data.foreach_set("color", [0.9, 0.5, 0.1, 1.0] * 4)
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = name
    tree.links.new(attribute.outputs["Color"], diffuse.inputs["Color"])
    document, notes = material_convert.convert_material(material)
    assert document["color"] == [0.0, 0.0, 0.0] and notes == []
    cycles, tracer = _both(tmp_path)
    print(f"attribute {name!r}: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    assert cycles.max() < 1e-6 and tracer.max() < 1e-6


def test_an_attribute_geometry_nodes_may_store_is_named_not_black() -> None:
    """An attribute that no mesh holds but that a Geometry Nodes modifier stores on the evaluated mesh (Store Named
    Attribute): Cycles reads its values; the conversion cannot, and names it rather than rendering black unnamed."""
    material, tree, diffuse = _plane_scene()
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "paint"
    tree.links.new(attribute.outputs["Color"], diffuse.inputs["Color"])
    assert material_convert.convert_material(material)[0]["color"] == [0.0, 0.0, 0.0]  # no modifier: Cycles' 0
    group, given, taken = new_group("paint", "GeometryNodeTree", GEOMETRY, GEOMETRY)
    store = group.nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type = "FLOAT_COLOR"
    store.inputs["Name"].default_value = "paint"
    group.links.new(given.outputs[0], store.inputs["Geometry"])
    group.links.new(store.outputs[0], taken.inputs[0])
    bpy.data.objects["plane"].modifiers.new("paint", "NODES").node_group = group
    material_convert.clear_cache()
    _document, notes = material_convert.convert_material(material)
    assert notes == ["Attribute on Diffuse BSDF Color: the input's own value"], notes


def test_an_image_sequence_whose_frames_exist_is_not_called_missing(tmp_path: Path) -> None:
    """An Image Texture of source Image Sequence: Cycles reads the frame's file; Blender's Python gets no pixels of a
    sequence, so the tracer cannot, and says so rather than 'not found ... as Cycles shows it'."""
    material, tree, diffuse = _plane_scene()
    frame = bpy.data.images.new("frame", 4, 4)
    frame.filepath_raw, frame.file_format = str(tmp_path / "seq_0001.png"), "PNG"
    frame.save()
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = bpy.data.images.load(str(tmp_path / "seq_0001.png"))
    texture.image.source = "SEQUENCE"
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    _document, notes = material_convert.convert_material(material)
    assert notes == ['image sequence "seq_0001.png" on Diffuse BSDF Color: its frames are not read (Python gets no '
                     'pixels): magenta'], notes  # fmt: skip


def test_a_missing_image_is_magenta_and_its_file_named(tmp_path: Path) -> None:
    material, tree, diffuse = _plane_scene()
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = _missing_image(tmp_path / "gone.png")
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    _document, notes = material_convert.convert_material(material)
    assert any("gone.png" in note and str(tmp_path) in note and "magenta" in note for note in notes), notes
    cycles, tracer = _both(tmp_path)
    print(f"missing image: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    assert cycles[0] > 0.1 and cycles[1] < 1e-6  # magenta in Cycles
    np.testing.assert_allclose(tracer, cycles, rtol=0.02, atol=1e-6)


def test_a_missing_world_picture_is_magenta_as_in_cycles(tmp_path: Path) -> None:
    _plane_scene()
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("sky")
    compat.enable_nodes(scene.world)
    tree = scene.world.node_tree
    environment = tree.nodes.new("ShaderNodeTexEnvironment")
    environment.image = _missing_image(tmp_path / "sky.exr")
    tree.links.new(environment.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    bpy.data.objects.remove(bpy.data.objects["plane"])
    from addon.convert import world_convert

    _background, _, notes = world_convert.convert_world(scene.world, blender_scene=scene)
    assert any("sky.exr" in note and "magenta" in note for note in notes), notes
    cycles, tracer = _both(tmp_path)
    print(f"missing world picture: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    np.testing.assert_allclose(tracer, cycles, atol=1e-3)
    np.testing.assert_allclose(cycles, [1.0, 0.0, 1.0], atol=1e-3)


def test_a_texture_on_a_factor_input_is_its_mean_named() -> None:
    _material, tree, _diffuse = _plane_scene()
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    tree.links.new(principled.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    image = bpy.data.images.new("rough", 2, 1, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set([0.2, 0.2, 0.2, 1.0, 0.6, 0.6, 0.6, 1.0])
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    tree.links.new(texture.outputs["Color"], principled.inputs["Roughness"])
    roughness = material_convert.value_input(principled.inputs["Roughness"], "Roughness", notes := [])
    assert roughness == pytest.approx(0.4) and notes == ["image texture on Roughness: its mean"]


def test_render_controls_the_tracer_does_not_express_are_named() -> None:
    """Shadow catcher and (4.0+) light and shadow linking: F12's line and Scene Conversion name each with the objects
    or light it concerns. A holdout and indirect-only collection are expressed (its objects' flags), not named."""
    from addon.convert import export, light_convert

    _plane_scene()
    scene = bpy.context.scene
    plane = bpy.data.objects["plane"]
    plane.is_shadow_catcher = True
    props = bpy.data.collections.new("Props")
    scene.collection.children.link(props)
    props.objects.link(bpy.data.objects.new("prop", bpy.data.meshes["plane"]))
    layer = bpy.context.view_layer.layer_collection.children["Props"]
    layer.holdout = layer.indirect_only = True
    notes = export.ExportNotes()
    document = export.scene_document(bpy.context, notes=notes)
    line = notes.line()
    assert line == "shadow catcher rendered as an ordinary object (plane)", line
    prop = next(body for body in document["objects"] if body["name"] == "prop")
    assert prop["holdout"] is True and prop["visible_camera"] is False
    sun = bpy.data.objects["sun"]
    if hasattr(sun, "light_linking"):
        sun.light_linking.receiver_collection = props
        sun.light_linking.blocker_collection = props
        _, light_notes = light_convert.convert_light(sun)
        assert 'light linking ("Props"): lights every object' in light_notes
        assert 'shadow linking ("Props"): every object casts its shadow' in light_notes


@pytest.mark.parametrize("interpolation", ["Closest", "Linear"])
def test_an_image_on_a_mesh_without_uvs_shows_the_texel_cycles_shows(tmp_path: Path, interpolation: str) -> None:
    """Cycles reads a missing UV map as (0, 0): the texel there (Closest: the bottom-left one; Linear: the four
    corners' mean, the lookup wrapping around)."""
    _material, tree, diffuse = _plane_scene()
    mesh = bpy.data.meshes["plane"]
    mesh.uv_layers.remove(mesh.uv_layers[0])
    image = bpy.data.images.new("corners", 2, 2, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set([0.9, 0.1, 0.1, 1, 0.1, 0.9, 0.1, 1, 0.1, 0.1, 0.9, 1, 0.9, 0.9, 0.1, 1])
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, interpolation
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    cycles, tracer = _both(tmp_path)
    print(f"no UV map, {interpolation}: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    np.testing.assert_allclose(tracer, cycles, rtol=0.02)


def test_a_packed_channel_of_a_texture_on_a_factor_input_is_its_mean_named() -> None:
    """glTF's metallic-roughness image: Separate Color's Green on Roughness, Blue on Metallic."""
    _material, tree, _diffuse = _plane_scene()
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    image = bpy.data.images.new("orm", 2, 1, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set([0.0, 0.2, 0.9, 1.0, 0.0, 0.6, 0.5, 1.0])
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    separate = tree.nodes.new("ShaderNodeSeparateColor")
    tree.links.new(texture.outputs["Color"], separate.inputs[0])
    tree.links.new(separate.outputs[1], principled.inputs["Roughness"])
    tree.links.new(separate.outputs[2], principled.inputs["Metallic"])
    notes: list[str] = []
    assert material_convert.value_input(principled.inputs["Roughness"], "Roughness", notes) == pytest.approx(0.4)
    assert material_convert.value_input(principled.inputs["Metallic"], "Metallic", notes) == pytest.approx(0.7)
    assert notes == ["a texture's channel on Roughness: its mean", "a texture's channel on Metallic: its mean"]


def test_a_udim_image_is_named() -> None:
    material, tree, diffuse = _plane_scene()
    image = bpy.data.images.new("tiles", 4, 4, tiled=True)
    image.tiles.new(tile_number=1002)
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    _, notes = material_convert.convert_material(material)
    assert "UDIM image on Diffuse BSDF Color: tile 1001 over the whole surface" in notes, notes


def test_scene_conversion_lists_materials_reached_through_instances_and_geometry_nodes() -> None:
    """A material on an object that only a collection instance places, and one a Geometry Nodes Set Material gives:
    both render, so both are in Render Properties > Scene Conversion."""
    from addon.convert import conversion_report

    _plane_scene()
    scene = bpy.context.scene
    props = bpy.data.collections.new("props")  # not linked to the scene: only the instance below shows it
    placed = bpy.data.meshes.new("placed")
    placed.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    placed.materials.append(bpy.data.materials.new("instanced"))
    props.objects.link(bpy.data.objects.new("placed", placed))
    holder = bpy.data.objects.new("holder", None)
    holder.instance_type, holder.instance_collection = "COLLECTION", props
    scene.collection.objects.link(holder)
    noded = bpy.data.objects.new("noded", bpy.data.meshes["plane"].copy())
    scene.collection.objects.link(noded)
    group, given, taken = new_group("set", "GeometryNodeTree", GEOMETRY, GEOMETRY)
    setter = group.nodes.new("GeometryNodeSetMaterial")
    setter.inputs["Material"].default_value = bpy.data.materials.new("from nodes")
    group.links.new(given.outputs[0], setter.inputs["Geometry"])
    group.links.new(setter.outputs[0], taken.inputs[0])
    noded.modifiers.new("set", "NODES").node_group = group
    bpy.context.view_layer.update()
    listed = {name for kind, name, _ in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert {"instanced", "from nodes", "surface"} <= listed, listed


def test_scene_conversion_lists_what_an_export_met_on_hidden_objects_that_geometry_nodes_place(tmp_path: Path) -> None:
    """A hidden object that Object Info brings into Instance on Points renders only as the instances, with its own
    material: F12 counts that material, and Scene Conversion lists it from then on with its notes."""
    from addon.convert import conversion_report

    _plane_scene()
    scene = bpy.context.scene
    source = bpy.data.objects.new("source", bpy.data.meshes["plane"].copy())
    source.data.materials.clear()
    glowing = bpy.data.materials.new("glowing")
    compat.enable_nodes(glowing)
    glowing.node_tree.nodes.clear()
    emission = glowing.node_tree.nodes.new("ShaderNodeEmission")
    output = glowing.node_tree.nodes.new("ShaderNodeOutputMaterial")
    glowing.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    source.data.materials.append(glowing)
    source.hide_render = True
    scene.collection.objects.link(source)
    placer = bpy.data.objects.new("placer", bpy.data.meshes["plane"].copy())
    scene.collection.objects.link(placer)
    group, given, taken = new_group("place", "GeometryNodeTree", GEOMETRY, GEOMETRY)
    info, points = group.nodes.new("GeometryNodeObjectInfo"), group.nodes.new("GeometryNodeInstanceOnPoints")
    info.inputs["Object"].default_value = source
    group.links.new(given.outputs[0], points.inputs["Points"])
    group.links.new(info.outputs["Geometry"], points.inputs["Instance"])
    group.links.new(points.outputs[0], taken.inputs[0])
    placer.modifiers.new("place", "NODES").node_group = group
    bpy.context.view_layer.update()
    scene.render.engine = "WEATHERVANE_TRACER"
    notes = ExportNotes()
    scene_document(bpy.context, notes=notes)
    assert notes.materials["glowing"] == [material_convert.UNLIT_EMISSION]  # Bounces 0: it lights nothing
    rows = {name: said for kind, name, said in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert rows["glowing"] == [material_convert.UNLIT_EMISSION], rows
    scene.weathervane.diffuse_bounces = 1  # its emission now lights the plane through the bounce
    notes = ExportNotes()
    scene_document(bpy.context, notes=notes)
    assert notes.materials["glowing"] == []
    rows = {name: said for kind, name, said in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert rows["glowing"] == []


def _both_images(tmp_path: Path) -> tuple[np.ndarray, np.ndarray]:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = f12_exr(tmp_path / "cycles.exr")
    scene.render.engine = "WEATHERVANE_TRACER"
    return cycles, f12_exr(tmp_path / "tracer.exr")


@pytest.mark.parametrize(("domain", "kind"), [("CORNER", "FLOAT_COLOR"), ("POINT", "BYTE_COLOR")])
def test_a_colour_attribute_is_interpolated_per_corner_as_in_cycles(tmp_path: Path, domain: str, kind: str) -> None:
    """The four corners of the plane in four colours, through a Multiply Mix with a constant colour (glTF's vertex
    colour times base colour factor) on Principled's Base Color: each pixel as Cycles shows it (before: the
    attribute's mean colour over the whole plane)."""
    material, tree, diffuse = _plane_scene()
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 24
    scene.cycles.filter_width = 0.01  # each pixel sampled at its centre, as the tracer samples it
    mesh = bpy.data.meshes["plane"]
    colors = mesh.color_attributes.new("Col", kind, domain)
    corners = [0.9, 0.1, 0.2, 1.0, 0.1, 0.8, 0.3, 1.0, 0.2, 0.3, 0.95, 1.0, 1.0, 1.0, 0.0, 1.0]
    colors.data.foreach_set("color", corners)
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    multiply = tree.nodes.new("ShaderNodeMixRGB")
    multiply.blend_type, multiply.inputs["Fac"].default_value = "MULTIPLY", 1.0
    multiply.inputs["Color2"].default_value = (0.8, 0.9, 1.0, 1.0)
    tree.links.new(attribute.outputs["Color"], multiply.inputs["Color1"])
    tree.links.new(multiply.outputs[0], diffuse.inputs["Color"])
    document, notes = material_convert.convert_material(material)
    assert "attribute" in document["texture"] and notes == [], (document, notes)
    cycles, tracer = _both_images(tmp_path)
    error = np.mean((np.clip(tracer, 0, 1) - np.clip(cycles, 0, 1)) ** 2)
    psnr = 10.0 * np.log10(1.0 / error)
    flat = np.full_like(cycles, cycles.reshape(-1, 3).mean(axis=0))  # the mean colour the conversion gave before
    before = 10.0 * np.log10(1.0 / np.mean((flat - np.clip(cycles, 0, 1)) ** 2))
    print(f"colour attribute ({domain}, {kind}): PSNR {psnr:.1f} dB against Cycles (its mean colour: {before:.1f} dB)")
    assert psnr >= 35.0 and psnr > before + 10.0


def test_a_mix_of_two_varying_colours_is_the_mix_of_their_means_named() -> None:
    """glTF's base colour: an image times a colour attribute (a product no texture of the format holds): the product
    of their means, named (was the input's own value, black)."""
    material, tree, diffuse = _plane_scene()
    mesh = bpy.data.meshes["plane"]
    colors = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    colors.data.foreach_set("color", [0.2, 0.4, 0.6, 1.0] * 2 + [0.6, 0.8, 1.0, 1.0] * 2)  # mean (0.4, 0.6, 0.8)
    image = bpy.data.images.new("two", 2, 1, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set([0.5, 0.5, 0.5, 1.0, 1.0, 0.5, 0.0, 1.0])  # mean (0.75, 0.5, 0.25)
    texture, attribute = tree.nodes.new("ShaderNodeTexImage"), tree.nodes.new("ShaderNodeVertexColor")
    texture.image = image
    multiply = tree.nodes.new("ShaderNodeMixRGB")
    multiply.blend_type, multiply.inputs["Fac"].default_value = "MULTIPLY", 1.0
    tree.links.new(texture.outputs["Color"], multiply.inputs["Color1"])
    tree.links.new(attribute.outputs["Color"], multiply.inputs["Color2"])
    tree.links.new(multiply.outputs[0], diffuse.inputs["Color"])
    document, notes = material_convert.convert_material(material)
    assert document["color"] == pytest.approx([0.3, 0.3, 0.2])
    assert notes == [f"{multiply.name} of varying colours on Diffuse BSDF Color: its inputs' means mixed"], notes


@pytest.mark.parametrize("kind", ["ShaderNodeBsdfPrincipled", "ShaderNodeBsdfGlass"])
def test_a_glass_cube_tints_what_is_seen_through_it_as_in_cycles(tmp_path: Path, kind: str) -> None:
    """A 1 m cube of clear glass (Principled Transmission 1, or Glass BSDF) of colour (0.2, 0.6, 0.9) before a white
    emitting wall, seen straight through: Cycles 4.0+ tints a ray through Principled's closed object by Base Color
    once (sqrt at each crossing), 3.x and Glass BSDF by the colour at each crossing (before: 0.1 of Principled's 5.0
    Cycles brightness came out 0.02 through the square)."""
    scene = bpy.context.scene
    wall = bpy.data.materials.new("wall")
    compat.enable_nodes(wall)
    tree = wall.node_tree
    tree.nodes.clear()
    emission, output = tree.nodes.new("ShaderNodeEmission"), tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    mesh = bpy.data.meshes.new("wall")
    mesh.from_pydata([(-5, -5, -2), (5, -5, -2), (5, 5, -2), (-5, 5, -2)], [], [(0, 1, 2, 3)])
    mesh.materials.append(wall)
    scene.collection.objects.link(bpy.data.objects.new("wall", mesh))
    glass = bpy.data.materials.new("glass")
    compat.enable_nodes(glass)
    tree = glass.node_tree
    tree.nodes.clear()
    shader, output = tree.nodes.new(kind), tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(shader.outputs[0], output.inputs["Surface"])
    shader.inputs["Roughness"].default_value = 0.0
    if kind == "ShaderNodeBsdfPrincipled":
        shader.inputs["Base Color"].default_value = (0.2, 0.6, 0.9, 1.0)
        compat.principled_input(shader, "transmission").default_value = 1.0
    else:
        shader.inputs["Color"].default_value = (0.2, 0.6, 0.9, 1.0)
    corners = [(x, y, z) for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    cube = bpy.data.meshes.new("cube")
    cube.from_pydata(corners, [], faces)
    cube.materials.append(glass)
    scene.collection.objects.link(bpy.data.objects.new("cube", cube))
    looking_down(3.0, 0.5)
    scene.cycles.caustics_refractive = False
    cycles, tracer = _both(tmp_path)
    print(f"{kind} cube: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    np.testing.assert_allclose(tracer, cycles, rtol=0.03)


def test_an_image_read_through_a_named_uv_map_is_looked_up_there_as_in_cycles(tmp_path: Path) -> None:
    """A plane with two UV maps, the default and one turned a quarter (u, v) -> (v, 1 - u); an image by a UV Map node
    naming the second: each pixel as Cycles shows it (before: the image's mean colour, named)."""
    material, tree, diffuse = _plane_scene()
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 24
    scene.cycles.filter_width = 0.01
    mesh = bpy.data.meshes["plane"]
    turned = mesh.uv_layers.new(name="Turned")
    default = np.empty(len(mesh.loops) * 2)
    mesh.uv_layers["UVMap"].data.foreach_get("uv", default)
    u, v = default[0::2], default[1::2]
    turned.data.foreach_set("uv", np.stack([v, 1.0 - u], axis=1).ravel())
    mesh.uv_layers.active = mesh.uv_layers["UVMap"]
    image = bpy.data.images.new("quarters", 2, 2, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set([0.9, 0.1, 0.1, 1, 0.1, 0.9, 0.1, 1, 0.1, 0.1, 0.9, 1, 0.9, 0.9, 0.1, 1])
    texture, uv_map = tree.nodes.new("ShaderNodeTexImage"), tree.nodes.new("ShaderNodeUVMap")
    texture.image, texture.interpolation, uv_map.uv_map = image, "Closest", "Turned"
    tree.links.new(uv_map.outputs["UV"], texture.inputs["Vector"])
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    document, notes = material_convert.convert_material(material)
    assert document["texture"]["uv_map"] == "Turned" and notes == []
    cycles, tracer = _both_images(tmp_path)
    error = np.mean((np.clip(tracer, 0, 1) - np.clip(cycles, 0, 1)) ** 2)
    psnr = 10.0 * np.log10(1.0 / error) if error > 0 else 99.0
    print(f"named UV map: PSNR {psnr:.1f} dB against Cycles")
    assert psnr >= 35.0


def test_emission_above_1_is_the_radiance_cycles_writes(tmp_path: Path) -> None:
    """An Emission shader of strength 5: the EXR holds 5 x its colour in both (was clipped at 1, named)."""
    material, tree, _diffuse = _plane_scene()
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    emission.inputs["Strength"].default_value = 5.0
    tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    bpy.data.objects.remove(bpy.data.objects["sun"])
    document, notes = material_convert.convert_material(material)
    assert document["emission"] == pytest.approx([5.0, 2.5, 1.0]) and notes == []
    cycles, tracer = _both(tmp_path)
    print(f"emission 5: Cycles {np.round(cycles, 4)}, tracer {np.round(tracer, 4)}")
    np.testing.assert_allclose(tracer, cycles, rtol=1e-3)
    np.testing.assert_allclose(cycles, [5.0, 2.5, 1.0], rtol=1e-3)


def test_the_view_layers_material_override_is_every_surfaces_material(tmp_path: Path) -> None:
    """View Layer > Override > Material: F12 is the render with every object's slots holding that material (as
    Cycles renders it), and Scene Conversion lists it alone; a World override (Blender 4.2+) is the background."""
    from addon.convert import conversion_report

    _, _, diffuse = _plane_scene()
    diffuse.inputs["Color"].default_value = (0.8, 0.1, 0.1, 1.0)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0.3, 0.2, 0.25))
    cube_material = bpy.data.materials.new("cube")
    cube_material.diffuse_color = (0.1, 0.8, 0.1, 1.0)
    bpy.context.object.data.materials.append(cube_material)
    clay = bpy.data.materials.new("clay")
    clay.diffuse_color = (0.5, 0.45, 0.4, 1.0)
    scene.render.engine = "WEATHERVANE_TRACER"
    own = f12_exr(tmp_path / "own.exr")
    bpy.context.view_layer.material_override = clay
    overridden = f12_exr(tmp_path / "overridden.exr")
    listed = {name for kind, name, _ in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert listed == {"clay"}
    bpy.context.view_layer.material_override = None
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.material_slots[0].material = clay
    assigned = f12_exr(tmp_path / "assigned.exr")
    assert np.array_equal(overridden, assigned) and np.abs(overridden - own).max() > 0.2
    if hasattr(bpy.context.view_layer, "world_override"):
        world = bpy.data.worlds.new("override")
        world.color = (0.2, 0.3, 0.9)
        if world.node_tree is not None:  # a new world has nodes from Blender 5.0 on
            world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.3, 0.9, 1.0)
        bpy.context.view_layer.world_override = world
        scene.camera.data.ortho_scale = 8.0  # the plane no longer fills the view: the corner is the background
        corner = f12_exr(tmp_path / "world.exr")[-1, 0]
        assert corner == pytest.approx([0.2, 0.3, 0.9], abs=1e-4)
