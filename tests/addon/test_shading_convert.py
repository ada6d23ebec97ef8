"""Blender's materials, lights and world -> the tracer's (addon/convert/material_convert.py, light_convert.py,
world_convert.py), the round trip of the add-on's own, Cycles' light units measured, and Blender's own property
panels shown for the engine. Runs in the bpy wheel (5.0.1) and in Debian's 3.4.1 (run_in_blender.py)."""

from __future__ import annotations

import copy
import math
import os
import tempfile

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import conversion_report, light_convert, material_convert, world_convert
from addon.vane import build
from tracer.scene.loader import default_scene_dict, scene_from_dict


def principled(name: str = "P", **inputs) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    compat.enable_nodes(material)
    node = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    for role, value in inputs.items():
        socket = compat.principled_socket(node, role) if role in ("specular", "emission") else node.inputs[role]
        socket.default_value = value
    return material


def shader_material(name: str, *kinds: str) -> tuple[bpy.types.Material, list]:
    """A material whose nodes are only an output and the given shader nodes (unlinked)."""
    material = bpy.data.materials.new(name)
    compat.enable_nodes(material)
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    return material, [output, *(tree.nodes.new(kind) for kind in kinds)]


def light_object(kind: str, energy: float, location=(0.0, 0.0, 3.0), rotation=(0.0, 0.0, 0.0), **settings):
    data = bpy.data.lights.new(kind.title(), kind)
    data.energy = energy
    for key, value in settings.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(kind.title(), data)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    return obj


# --- materials -------------------------------------------------------------------------------------------------------


def test_a_red_principled_is_a_red_diffuse_with_a_white_highlight() -> None:
    material = principled(**{"Base Color": (0.8, 0.05, 0.05, 1.0), "Roughness": 0.5})
    document, notes = material_convert.convert_material(material)
    f0 = 0.04  # IOR 1.5 (4.0+) and Specular 0.5 (3.4)
    k = compat.principled_diffuse_factor(0.5, f0)  # 1 - F0 in 4.0+; Disney diffuse's albedo in 3.x
    assert k == pytest.approx(1 - f0 if bpy.app.version >= (4, 0, 0) else 1.009)
    assert document["color"] == pytest.approx([0.8 * k, 0.05 * k, 0.05 * k], rel=1e-5)
    assert document["reflective"] == 0.0 and document["two_sided"] is True
    n = 2 / 0.5**4 - 2  # 30: the twin's exponent for roughness 0.5
    assert document["specular"] == pytest.approx(n / 3.0)
    assert document["specular_color"] == pytest.approx([f0 * (n + 2) / 8] * 3, rel=1e-5)  # white: a dielectric
    assert "emission" not in document and notes == []


def test_a_smooth_metal_is_a_mirror_named_where_tinted() -> None:
    document, notes = material_convert.convert_material(
        principled(**{"Base Color": (1.0, 1.0, 1.0, 1.0), "Metallic": 1.0, "Roughness": 0.0})
    )
    assert document["reflective"] == pytest.approx(1.0) and "specular_color" not in document
    assert document["specular"] == 0 and notes == []
    gold, notes = material_convert.convert_material(
        principled(**{"Base Color": (1.0, 0.8, 0.3, 1.0), "Metallic": 1.0, "Roughness": 0.05})
    )
    assert gold["reflective"] == pytest.approx(0.7, rel=1e-5) and gold["color"] == pytest.approx([0, 0, 0])
    assert "tinted mirror: white at its mean reflectance" in notes


@pytest.mark.parametrize(("metallic", "roughness", "named"), [(0.0, 0.0, False), (0.0, 0.05, True), (1.0, 0.08, True),
                                                       (0.0, 0.2, False), (1.0, 0.3, False)])  # fmt: skip
def test_a_specular_lobe_sharpened_to_a_mirror_names_the_highlight_it_loses(metallic, roughness, named) -> None:
    """At roughness 0 the lights are not seen in Cycles' mirror either; at up to 0.1 Cycles shows a small light's
    highlight, which the sharp mirror does not (a helper's sweep: a sun's peak 16.9 against 0.61 at 0.05); rougher,
    the highlight or the glossy lobe is kept."""
    material = principled(**{"Base Color": (0.1, 0.1, 0.6, 1.0), "Metallic": metallic, "Roughness": roughness})
    _document, notes = material_convert.convert_material(material)
    assert ("roughness up to 0.1: a sharp mirror, no highlight of the lights in it" in notes) == named, notes


@pytest.mark.parametrize("kind", ["metal", "glass", "glass bsdf"])
def test_a_roughness_typed_as_0_1_is_sharp_as_documented(kind) -> None:
    """Blender keeps a typed 0.1 as float32's 0.10000000149: still "up to 0.1", so a sharp mirror or sharp glass
    (named), not sampled microfacets (rough glass's rays took 16 times as long); 0.1001 is rough."""
    for roughness, is_sharp in ((0.1, True), (0.1001, False)):
        if kind == "glass bsdf":
            material, (output, glass) = shader_material("G", "ShaderNodeBsdfGlass")
            material.node_tree.links.new(glass.outputs[0], output.inputs["Surface"])
            glass.inputs["Roughness"].default_value = roughness
        else:
            material = principled(**{"Metallic": 1.0 if kind == "metal" else 0.0, "Roughness": roughness})
            if kind == "glass":
                node = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
                compat.principled_input(node, "transmission").default_value = 1.0
        stored = (
            material.node_tree.nodes["Glass BSDF" if kind == "glass bsdf" else "Principled BSDF"]
            .inputs["Roughness"].default_value
        )  # fmt: skip
        assert (stored > 0.1) == (roughness == 0.1 or not is_sharp)  # float32 keeps 0.1 above 0.1
        document, notes = material_convert.convert_material(material)
        rough_keys = {"glossy", "transmission_roughness"} & set(document)
        assert (not rough_keys) == is_sharp, (roughness, document, notes)
        if is_sharp:
            assert any("sharp" in note for note in notes), notes
    """Above the mirror's roughness a metal is the format's glossy lobe (GGX, Schlick's Fresnel from the base
    colour, Principled's distribution's energy): no mirror, no documented highlight, nothing to name."""
    document, notes = material_convert.convert_material(
        principled(**{"Base Color": (0.9, 0.6, 0.2, 1.0), "Metallic": 1.0, "Roughness": 0.3})
    )
    assert document["glossy"] == pytest.approx([0.9, 0.6, 0.2], rel=1e-6)
    assert document["roughness"] == pytest.approx(0.3, rel=1e-6)
    assert document["glossy_fresnel"] == "schlick"
    assert document["reflective"] == 0.0 and document["specular"] == 0 and "specular_color" not in document
    assert document["color"] == pytest.approx([0.0, 0.0, 0.0])
    assert notes == []


def test_emission_is_added_and_an_emission_only_plane_is_not_black() -> None:
    material, (output, emission) = shader_material("glow", "ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    emission.inputs["Strength"].default_value = 2.0
    material.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    document, notes = material_convert.convert_material(material)
    assert document["emission"] == pytest.approx([2.0, 1.0, 0.5]) and document["color"] == [0, 0, 0]
    assert notes == []  # radiance above 1 is kept, as Cycles keeps it (the display clips, an EXR does not)
    lamp, notes = material_convert.convert_material(
        principled(emission=(0.0, 1.0, 0.0, 1.0), **{"Emission Strength": 0.5})
    )
    assert lamp["emission"] == pytest.approx([0.0, 0.5, 0.0]) and notes == []


def test_mix_and_add_weigh_their_shaders() -> None:
    material, (output, diffuse, glossy, mix) = shader_material(
        "mix", "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlossy", "ShaderNodeMixShader"
    )
    links = material.node_tree.links
    diffuse.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1.0)
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.inputs["Roughness"].default_value = 0.0
    mix.inputs["Fac"].default_value = 0.25
    links.new(diffuse.outputs[0], mix.inputs[1])
    links.new(glossy.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], output.inputs["Surface"])
    document, notes = material_convert.convert_material(material)
    # local 0.75 x diffuse weighed by 1 - r = 0.75 in the tracer: the colour itself; mirror 0.25
    assert document["reflective"] == pytest.approx(0.25)
    assert document["color"] == pytest.approx([0.2, 0.4, 0.6], rel=1e-5) and notes == []
    add = material.node_tree.nodes.new("ShaderNodeAddShader")
    emission = material.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 0.5
    links.new(mix.outputs[0], add.inputs[0])
    links.new(emission.outputs[0], add.inputs[1])
    links.new(add.outputs[0], output.inputs["Surface"])
    document, _ = material_convert.convert_material(material)
    assert document["emission"] == pytest.approx([0.5, 0.5, 0.5]) and document["reflective"] == pytest.approx(0.25)


def test_an_image_texture_on_base_color_is_rendered_by_uv_its_mean_the_colour() -> None:
    """An Image Texture read by the mesh's UVs becomes the material's texture (not named); its mean is the
    colour (hits without UVs); with Object coordinates it is the mean colour, named."""
    image = bpy.data.images.new("checker", 4, 4, float_buffer=True)
    pixels = [0.0] * 64
    for index in range(16):
        pixels[index * 4 : index * 4 + 4] = (1.0, 0.5, 0.0, 1.0) if index % 2 else (0.0, 0.5, 1.0, 1.0)
    image.pixels[:] = pixels
    material = principled("textured")
    tree = material.node_tree
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    tree.links.new(texture.outputs["Color"], next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED").inputs[0])
    document, notes = material_convert.convert_material(material)
    k = compat.principled_diffuse_factor(0.5, 0.04)
    assert document["color"] == pytest.approx([0.5 * k, 0.5 * k, 0.5 * k], rel=1e-5)
    assert notes == [] and document["texture"]["pixels"].shape == (4, 4, 3)
    texels = np.clip(np.array([[1.0, 0.5, 0.0], [0.0, 0.5, 1.0]]) * k, 0.0, 1.0)  # each clipped (3.4's k > 1)
    assert document["texture"]["pixels"].reshape(-1, 3).mean(axis=0) == pytest.approx(texels.mean(axis=0), rel=1e-5)
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Object"], texture.inputs["Vector"])
    document, notes = material_convert.convert_material(material)
    assert document["color"] == pytest.approx([0.5 * k, 0.5 * k, 0.5 * k], rel=1e-5) and "texture" not in document
    assert notes == ["image texture on Base Color: mean colour"]


def test_what_the_model_cannot_say_is_named() -> None:
    material = principled(**{"Alpha": 0.5})
    for role in ("subsurface", "coat"):
        compat.principled_input(next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"),
                                role).default_value = 1.0  # fmt: skip
    _, notes = material_convert.convert_material(material)
    assert "subsurface: rendered as the opaque base" in notes and "coat: rendered as the opaque base" in notes
    plain = bpy.data.materials.new("plain")
    plain.diffuse_color = (0.1, 0.2, 0.3, 1.0)
    if compat.VERSION < (5, 0, 0):
        document, notes = material_convert.convert_material(plain)
        assert document["color"] == pytest.approx([0.1, 0.2, 0.3]) and notes
    document, notes = material_convert.convert_material(None)
    assert document["color"] == [0.8, 0.8, 0.8] and notes == ["no material: Cycles' grey"]


SCENE_VARIANTS = [
    ("blinn-phong", 3.0, {"odd": {"color": [0.123, 0.4567, 0.9], "specular": 1234.5, "reflective": 0.77}}),
    ("phong", 2.5, {"odd": {"color": [1.0, 0.0, 0.333], "specular": 7, "reflective": 1.0}}),
]


@pytest.mark.parametrize("model, coef, extra", SCENE_VARIANTS, ids=["blinn-phong", "phong"])
def test_the_addons_own_materials_and_lights_convert_back_exactly(model, coef, extra) -> None:
    document = copy.deepcopy(default_scene_dict())
    document["materials"].update(extra)
    document["objects"][0]["material"] = "odd"
    document["render"].update(model=model, coef=coef)
    document["lights"].append({"type": "point", "location": [0.1, -2.7, 9.3], "intensity": 0.33})
    document["lights"].append({"type": "directional", "direction": [0.3, -0.2, 0.7], "intensity": 0.05})
    build.build(bpy.context, scene_from_dict(document), source="round trip")
    bpy.context.view_layer.update()
    for name, expected in document["materials"].items():
        if not any(obj["material"] == name for obj in document["objects"]):
            continue
        converted, notes = material_convert.convert_material(bpy.data.materials[f"WV {name}"])
        assert converted == expected and notes == [], name
    settings = bpy.context.scene.weathervane
    converted = []
    for entry in settings.lights:
        if entry.object_name:
            light, notes = light_convert.convert_light(bpy.data.objects[entry.object_name])
            assert notes == []
            converted.append(light)
    expected = [light for light in document["lights"] if light["type"] != "ambient"]
    assert converted == expected


def test_a_material_edited_in_its_nodes_follows_the_nodes() -> None:
    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="edit")
    material = bpy.data.materials["WV brass"]
    top = material.node_tree.nodes["WV Surface"]  # the Surface's node in the Material tab
    top.inputs["Reflectivity"].default_value = 0.5
    top.inputs["Shininess"].default_value = 150.0
    top.inputs["Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    converted, notes = material_convert.convert_material(material)
    assert converted == {"color": [1.0, 0.0, 0.0], "specular": 150.0, "reflective": 0.5} and notes == []


def test_a_material_built_before_the_surface_group_still_converts_and_is_rebuilt_on_its_next_edit() -> None:
    """A .blend saved by an older add-on: its vane materials have the twin's nodes flat in the material."""
    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="edit")
    material = bpy.data.materials["WV brass"]
    tree = material.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    for name, kind in (("WV Diffuse", "ShaderNodeBsdfDiffuse"), ("WV Highlight", "ShaderNodeBsdfGlossy"),
                       ("WV Mix", "ShaderNodeMixShader")):  # fmt: skip
        tree.nodes.new(kind).name = name
    tree.nodes["WV Diffuse"].inputs["Color"].default_value = (0.78, 0.6, 0.22, 1.0)
    tree.nodes["WV Highlight"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    tree.nodes["WV Mix"].inputs["Fac"].default_value = 0.35
    tree.links.new(tree.nodes["WV Mix"].outputs[0], output.inputs["Surface"])
    converted, _ = material_convert.convert_material(material)
    assert converted["color"] == [0.78, 0.6, 0.22] and converted["reflective"] == 0.35
    entry = next(entry for entry in bpy.context.scene.weathervane.materials if entry.name == "brass")
    entry.reflective = 0.25
    assert material.node_tree.nodes["WV Surface"].inputs["Reflectivity"].default_value == 0.25


# --- lights ----------------------------------------------------------------------------------------------------------


def test_point_and_spot_lights_take_cycles_units_and_inverse_square() -> None:
    point, notes = light_convert.convert_light(light_object("POINT", 1000.0, shadow_soft_size=0.0))
    assert point == {
        "type": "point",
        "location": pytest.approx([0.0, 0.0, 3.0]),
        "intensity": pytest.approx(1000.0 / (4 * math.pi**2)),
        "falloff": "inverse_square",
        "color": pytest.approx([1.0, 1.0, 1.0]),
    }
    assert notes == []
    spot, notes = light_convert.convert_light(
        light_object(
            "SPOT", 100.0, rotation=(math.radians(90), 0.0, 0.0), spot_size=math.radians(40), spot_blend=0.25,
            shadow_soft_size=0.25, color=(1.0, 0.5, 0.2),
        )
    )  # fmt: skip
    assert spot["type"] == "spot" and spot["intensity"] == pytest.approx(100.0 / (4 * math.pi**2))
    assert spot["direction"] == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)  # -Z turned 90 degrees about X
    assert spot["spot_size"] == pytest.approx(40.0) and spot["spot_blend"] == pytest.approx(0.25)
    assert spot["color"] == pytest.approx([1.0, 0.5, 0.2]) and spot["falloff"] == "inverse_square"
    assert notes and notes[0].startswith("radius 0.25 m: hard shadow")


def test_a_coloured_sun_is_a_coloured_directional_light() -> None:
    sun, notes = light_convert.convert_light(
        light_object("SUN", 3.0, rotation=(0.0, math.radians(90), 0.0), color=(1.0, 0.2, 0.1), angle=0.0)
    )
    assert sun["type"] == "directional" and sun["intensity"] == pytest.approx(3.0 / math.pi)
    assert sun["direction"] == pytest.approx([1.0, 0.0, 0.0], abs=1e-6)  # +Z, toward the light
    assert sun["color"] == pytest.approx([1.0, 0.2, 0.1]) and notes == []
    sun, notes = light_convert.convert_light(light_object("SUN", 1.0, angle=math.radians(2.0)))
    assert sun["angle"] == pytest.approx(2.0) and notes == ["sun angle 2°: hard shadow"]
    bpy.context.scene.weathervane.shadow_samples = "16"
    try:  # soft shadows with more than one shadow sample: nothing to name
        assert light_convert.convert_light(light_object("SUN", 1.0, angle=math.radians(2.0)))[1] == []
    finally:
        bpy.context.scene.weathervane.shadow_samples = "1"


def test_an_area_light_is_an_area_light_of_cycles_intensity() -> None:
    obj = light_object("AREA", 200.0, location=(1.0, 2.0, 3.0), rotation=(0.0, 0.0, math.radians(90.0)), size=0.5)
    area, notes = light_convert.convert_light(obj)
    factor = math.pi / 4.0 if bpy.app.version < (4, 0, 0) else 1.0  # Cycles 3.4 emits pi / 4 as much
    assert area["type"] == "area" and area["location"] == pytest.approx([1.0, 2.0, 3.0])
    assert area["intensity"] == pytest.approx(200.0 / math.pi**2 * factor)
    assert area["direction"] == pytest.approx([0.0, 0.0, -1.0], abs=1e-6)
    assert area["x_axis"] == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)  # the local X, turned 90 degrees about Z
    assert area["shape"] == "square" and area["size"] == pytest.approx(0.5)
    assert notes == ["area light: hard shadow"]
    obj.scale = (2.0, 1.0, 1.0)  # a disk scaled unevenly is an ellipse, its size times the scale
    obj.data.shape, obj.data.spread = "DISK", math.radians(90.0)
    bpy.context.view_layer.update()
    area, notes = light_convert.convert_light(obj)
    assert area["shape"] == "ellipse" and area["size"] == pytest.approx([1.0, 0.5])
    assert "area light spread 90°: 180°" in notes
    scene_from_dict({**default_scene_dict(), "lights": [area]})  # the loader takes it


def test_a_light_whose_type_changed_in_blender_converts_as_its_new_type() -> None:
    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="retype")
    bpy.context.view_layer.update()
    entry = next(e for e in bpy.context.scene.weathervane.lights if e.kind == "DIRECTIONAL")
    bpy.data.objects[entry.object_name].data.type = "POINT"
    light, _ = light_convert.convert_light(bpy.data.objects[entry.object_name])
    assert light["type"] == "point" and light["falloff"] == "inverse_square"


# --- world -----------------------------------------------------------------------------------------------------------


def test_the_world_colour_is_the_background_and_a_shadowed_world_light() -> None:
    assert world_convert.convert_world(None) == ({"type": "solid", "color": [0.0, 0.0, 0.0]}, None, [])
    world = bpy.data.worlds.new("green")
    compat.enable_nodes(world)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.1, 0.6, 0.2, 1.0)
    background.inputs["Strength"].default_value = 2.0
    color, ambient, notes = world_convert.convert_world(world)
    assert color == {"type": "solid", "color": pytest.approx([0.2, 1.0, 0.4])}  # the display's clip
    assert ambient == {
        "type": "world",
        "radiance": "color",
        "intensity": pytest.approx(1.2),
        "samples": 16,
        "color": pytest.approx([0.2 / 1.2, 1, 0.4 / 1.2]),
    }
    assert notes == [
        "world brighter than 1: background clipped at 1, as the display shows it",
        "world light: shadowed, 16 directions per point, no bounces",
    ]
    background.inputs["Strength"].default_value = 1.0
    color, ambient, notes = world_convert.convert_world(world)
    assert color["color"] == ambient["color"] == pytest.approx([0.1, 0.6, 0.2]) and ambient["intensity"] == 1.0
    assert notes == ["world light: shadowed, 16 directions per point, no bounces"]
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    world.node_tree.links.new(sky.outputs["Color"], background.inputs["Color"])
    color, _, notes = world_convert.convert_world(world)
    assert color["color"] == pytest.approx(world_convert.SKY_MEAN) and notes[0].startswith("sky")


# --- Cycles' units, measured -----------------------------------------------------------------------------------------


def cycles_plane(light: tuple | None, world=(0.0, 0.0, 0.0), surface=None, view_degrees: float = 0.0) -> list[float]:
    """Cycles' linear colour at the centre of a plane (a white diffuse one, albedo 1, unless surface(material) builds
    the material's nodes) under one light of radius 0 straight above it ((kind, power, height[, colour])) and a
    uniform world, seen view_degrees from its normal."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 64 if light is None or surface is not None else 4
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 1
    scene.cycles.diffuse_bounces = 0
    scene.render.resolution_x = scene.render.resolution_y = 4
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    mesh = bpy.data.meshes.new("plane")
    mesh.from_pydata([(-50, -50, 0), (50, -50, 0), (50, 50, 0), (-50, 50, 0)], [], [(0, 1, 2, 3)])
    if surface is None:
        material, (output, diffuse) = shader_material("white", "ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        material.node_tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    else:
        material = surface()
    mesh.materials.append(material)
    scene.collection.objects.link(bpy.data.objects.new("plane", mesh))
    scene.world = bpy.data.worlds.new("world")
    compat.enable_nodes(scene.world)
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (*world, 1.0)
    if light is not None:
        kind, power, height, *color = light
        data = bpy.data.lights.new("light", kind)
        data.energy = power
        data.color = color[0] if color else (1.0, 1.0, 1.0)
        if kind == "SUN":
            data.angle = 0.0
        else:
            data.shadow_soft_size = 0.0
        if kind == "SPOT":
            data.spot_size = math.radians(60.0)
        obj = bpy.data.objects.new("light", data)
        obj.location = (0.0, 0.0, height)
        scene.collection.objects.link(obj)
    camera = bpy.data.cameras.new("camera")
    camera.type, camera.ortho_scale, camera.clip_start = "ORTHO", 0.01, 0.001
    scene.camera = bpy.data.objects.new("camera", camera)
    angle = math.radians(view_degrees)
    scene.camera.location = (0.5 * math.sin(angle), 0.0, 0.5 * math.cos(angle))
    scene.camera.rotation_euler = (0.0, angle, 0.0)
    scene.collection.objects.link(scene.camera)
    scene.render.filepath = os.path.join(tempfile.mkdtemp(), "plane.exr")
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene.render.filepath)
    pixels = list(image.pixels)
    return [sum(pixels[channel::4]) / (len(pixels) // 4) for channel in range(3)]


def cycles_white_plane(light: tuple | None, world=(0.0, 0.0, 0.0)) -> float:
    return cycles_plane(light, world)[0]


@pytest.mark.parametrize(
    "kind, power, height, measured",
    [
        ("POINT", 100.0, 2.0, 0.63324),
        ("POINT", 100.0, 5.0, 0.10132),
        ("POINT", 1000.0, 2.0, 6.33241),
        ("POINT", 1000.0, 5.0, 1.01321),
        ("SPOT", 100.0, 2.0, 0.63324),
        ("SPOT", 1000.0, 5.0, 1.01321),
        ("SUN", 1.0, 1.0, 0.31831),
        ("SUN", 3.0, 1.0, 0.95493),
    ],
)
def test_cycles_light_units_are_what_the_conversion_assumes(kind, power, height, measured) -> None:
    """The tracer's white diffuse surface facing a light returns i (falloff 1 / d^2 for point and spot)."""
    value = cycles_white_plane((kind, power, height))
    assert value == pytest.approx(measured, rel=0.03)  # the number recorded in light_convert.py, this Blender
    if kind == "SUN":
        predicted = power / light_convert.SUN_STRENGTH_PER_UNIT
    else:
        predicted = power / light_convert.POINT_WATTS_PER_UNIT / height**2
    assert value == pytest.approx(predicted, rel=0.03)


def test_cycles_world_lights_a_white_plane_to_its_colour() -> None:
    assert cycles_white_plane(None, world=(0.3, 0.5, 0.7)) == pytest.approx(0.3, rel=0.03)


# --- Blender's own panels, and the Scene Conversion panel ------------------------------------------------------------


def triangle(scene):
    """A one-triangle mesh object linked to the scene."""
    mesh = bpy.data.meshes.new("mesh")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new("mesh", mesh)
    scene.collection.objects.link(obj)
    return obj


def test_blenders_material_light_world_and_mesh_panels_show_for_the_engine() -> None:
    from addon.engine import render_panels

    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    obj = triangle(scene)
    mesh = obj.data
    material = principled("shown")
    mesh.materials.append(material)
    spot = light_object("SPOT", 10.0)
    scene.world = bpy.data.worlds.new("world")
    compat.enable_nodes(scene.world)
    names = {cls.__name__ for cls in render_panels._added}
    wanted = {
        "material": ["CYCLES_PT_context_material", "CYCLES_MATERIAL_PT_surface", "MATERIAL_PT_viewport"],
        "light": ["DATA_PT_context_light", "CYCLES_LIGHT_PT_light", "CYCLES_LIGHT_PT_beam_shape"],
        "world": ["WORLD_PT_context_world", "CYCLES_WORLD_PT_surface"],
        "mesh": ["DATA_PT_context_mesh", "DATA_PT_uv_texture", "DATA_PT_shape_keys", "DATA_PT_vertex_groups"]
        + (["DATA_PT_normals"] if compat.VERSION < (4, 1, 0) else []),
    }
    members = {
        "material": {"material": material, "object": obj},
        "light": {"light": spot.data, "object": spot},
        "world": {"world": scene.world},
        "mesh": {"mesh": mesh, "object": obj},
    }
    for tab, panels in wanted.items():
        with bpy.context.temp_override(**members[tab]):
            for name in panels:
                cls = getattr(bpy.types, name)
                assert name in names or name == "MATERIAL_PT_viewport", name  # Viewport Display shows for all engines
                assert cls.poll(bpy.context), name
    assert not any(word in name.lower() for name in names for word in ("preview", "volume", "mist"))
    assert "DATA_PT_light" not in names  # Cycles' Light panel replaces the type-only one
    added = list(render_panels._added)
    import addon

    addon.unregister()
    try:
        assert not any("WEATHERVANE_TRACER" in cls.COMPAT_ENGINES for cls in added)
        assert all("CYCLES" in cls.COMPAT_ENGINES for cls in added if cls.__name__.startswith("CYCLES_"))
    finally:
        addon.register()


class _DrawnProperties:
    """A panel layout that notes the properties drawn into it (every row, column and split is itself)."""

    def __init__(self) -> None:
        self.drawn: list[str] = []
        self.use_property_split = self.use_property_decorate = self.active = False

    def prop(self, _data, name: str, **_options) -> None:
        self.drawn.append(name)

    def row(self, **_options):
        return self

    column = split = row

    def separator(self, *_arguments, **_options) -> None:
        pass

    prop_decorator = label = separator


CYCLES_LIGHT_SETTINGS = {"max_bounces", "cast_shadow", "use_shadow", "use_multiple_importance_sampling",
                         "is_caustics_light", "is_portal"}  # fmt: skip


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_the_light_panel_shows_the_tracer_no_cycles_settings(kind: str) -> None:
    """Light Properties' Light panel with the tracer as the engine: the light's type, colour, power and size (what
    the conversion reads), none of Cycles' own settings (Max Bounces, Cast Shadow, Multiple Importance, Shadow
    Caustics, Portal), which Cycles' panel holds in Blender 3.4-4.4 and a Settings subpanel from 4.5; for Cycles the
    panel draws as Cycles has it."""
    from types import SimpleNamespace

    light = light_object(kind, 100.0).data
    panel = bpy.types.CYCLES_LIGHT_PT_light
    drawn = {}
    for engine in ("WEATHERVANE_TRACER", "CYCLES"):
        layout = _DrawnProperties()
        context = SimpleNamespace(
            engine=engine, light=light, scene=bpy.context.scene, preferences=bpy.context.preferences
        )
        panel.draw(SimpleNamespace(layout=layout, bl_space_type="PROPERTIES"), context)
        drawn[engine] = layout.drawn
    size = {"POINT": "shadow_soft_size", "SPOT": "shadow_soft_size", "SUN": "angle", "AREA": "size"}[kind]
    assert {"type", "color", "energy", size} <= set(drawn["WEATHERVANE_TRACER"]), drawn
    assert not CYCLES_LIGHT_SETTINGS & set(drawn["WEATHERVANE_TRACER"]), drawn
    assert set(drawn["WEATHERVANE_TRACER"]) <= set(drawn["CYCLES"]) | {"color"}, drawn  # Cycles 4.5+: "Tint"/"Color"
    if not hasattr(bpy.types, "CYCLES_LIGHT_PT_settings"):  # Cycles' own settings in its Light panel: still there
        assert "max_bounces" in drawn["CYCLES"], drawn


def test_the_scene_conversion_panel_converts_once_per_change(monkeypatch) -> None:

    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    obj = triangle(scene)
    mesh = obj.data
    material = principled("glass", **{"Alpha": 0.5})
    node = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    compat.principled_input(node, "sheen").default_value = 0.5
    mesh.materials.append(material)
    light_object("AREA", 100.0)
    bpy.context.view_layer.update()
    calls = []
    convert = material_convert.convert_material
    monkeypatch.setattr(
        material_convert, "convert_material", lambda *a, **k: calls.append(a[0].name) or convert(*a, **k)
    )
    rows = conversion_report.scene_conversion(scene)
    assert [(kind, name) for kind, name, _ in rows] == [
        ("MATERIAL", "glass"),
        ("LIGHT", "Area"),
        ("WORLD", "no world (black)"),
    ]
    assert rows[0][2] == ["sheen: rendered as the opaque base"] and rows[1][2][0].startswith("area light")
    assert rows[2][2] == []
    assert conversion_report.summary_line(rows) == "1 exact, 2 approximated (glass, Area)"
    for _ in range(50):  # redraws
        assert conversion_report.scene_conversion(scene) is rows
    assert calls == ["glass"]
    compat.principled_input(node, "sheen").default_value = 0.0
    material.node_tree.update_tag()
    bpy.context.view_layer.update()
    rows = conversion_report.scene_conversion(scene)
    assert calls == ["glass", "glass"] and rows[0][2] == []


def test_cycles_own_render_panels_stay_hidden_for_the_engine() -> None:
    """Cycles' panels share one COMPAT_ENGINES set through their base class: the engine goes into a copy."""
    for name in ("CYCLES_RENDER_PT_sampling", "CYCLES_MATERIAL_PT_preview", "CYCLES_WORLD_PT_volume"):
        cls = getattr(bpy.types, name, None)
        assert cls is None or "WEATHERVANE_TRACER" not in cls.COMPAT_ENGINES, name


def documented_plane(material: dict, sun_intensity: float, sun_color, view_degrees: float, coef: float = 3.0):
    """What the documented model (Blinn-Phong, with the optional fields) gives on a plane lit by a sun straight above
    it, seen view_degrees from its normal: i (color cos + specular_color (H.N)^(s coef)) (1 - r) + emission."""
    angle = math.radians(view_degrees)
    half = (math.sin(angle), 0.0, math.cos(angle) + 1.0)
    cosine = half[2] / math.sqrt(sum(c * c for c in half))
    highlight = material.get("specular_color", material["color"])
    exponent = material["specular"] * coef
    return [
        sun_intensity
        * light
        * (color + (spec * cosine**exponent if exponent > 0 else 0.0))
        * (1 - material["reflective"])
        + emitted
        for light, color, spec, emitted in zip(
            sun_color, material["color"], highlight, material.get("emission", [0.0] * 3), strict=True
        )
    ]


@pytest.mark.parametrize("view_degrees", [10.0, 30.0])
def test_a_red_principled_under_a_coloured_sun_matches_cycles_mean_colour(view_degrees) -> None:
    """Measured (mean colour, converted-and-documented against Cycles): 10 degrees: 5.0.1 -1.6%, 3.4.1 +1.3%;
    30 degrees: 5.0.1 -3.0%, 3.4.1 +0.4% (the highlight's shape and Fresnel are where the models differ)."""
    sun_color = (1.0, 0.9, 0.7)

    def surface():
        return principled("red", **{"Base Color": (0.8, 0.05, 0.05, 1.0), "Roughness": 0.5})

    cycles = cycles_plane(("SUN", 3.0, 1.0, sun_color), surface=surface, view_degrees=view_degrees)
    material, _ = material_convert.convert_material(bpy.data.materials["red"])
    documented = documented_plane(material, 3.0 / math.pi, sun_color, view_degrees)
    assert sum(documented) / 3 == pytest.approx(sum(cycles) / 3, rel=0.04)
    assert documented[0] == pytest.approx(cycles[0], rel=0.03)  # the diffuse red


def test_an_emission_plane_shows_its_emission_as_in_cycles() -> None:
    def surface():
        material, (output, emission) = shader_material("glow", "ShaderNodeEmission")
        emission.inputs["Color"].default_value = (0.9, 0.4, 0.1, 1.0)
        emission.inputs["Strength"].default_value = 0.8
        material.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
        return material

    cycles = cycles_plane(None, surface=surface)
    material, notes = material_convert.convert_material(bpy.data.materials["glow"])
    assert notes == [] and cycles == pytest.approx(material["emission"], rel=0.02)
    assert documented_plane(material, 0.0, (1.0, 1.0, 1.0), 0.0) == pytest.approx(cycles, rel=0.02)


def test_the_factory_startup_scene_converts_with_its_approximations_named() -> None:

    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    cube = bpy.data.objects["Cube"].active_material
    node = next(n for n in cube.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    material, notes = material_convert.convert_material(cube)
    f0 = compat.principled_f0(node, compat.principled_socket(node, "specular").default_value)  # IOR 1.45 in 4.x
    k = compat.principled_diffuse_factor(node.inputs["Roughness"].default_value, f0)
    expected = [k * c for c in node.inputs["Base Color"].default_value[:3]]
    assert material["color"] == pytest.approx(expected, rel=1e-5) and material["two_sided"] and notes == []
    light, notes = light_convert.convert_light(bpy.data.objects["Light"])
    assert light["intensity"] == pytest.approx(1000.0 / (4 * math.pi**2)) and light["falloff"] == "inverse_square"
    assert notes and notes[0].startswith("radius 0.1 m: hard shadow")
    background, ambient, notes = world_convert.convert_world(scene.world)
    assert background["color"] == pytest.approx([0.0508761] * 3, rel=1e-4) or background["color"] == pytest.approx(
        [0.05] * 3, rel=1e-4
    )
    assert ambient["color"] == background["color"]
    assert notes == ["world light: shadowed, 16 directions per point, no bounces"]
    rows = conversion_report.scene_conversion(scene)
    assert [kind for kind, _, _ in rows] == ["MATERIAL", "LIGHT", "WORLD"]
    assert conversion_report.summary_line(rows) == "1 exact, 2 approximated (Light, World)"


def test_vertex_colours_on_base_color_are_an_attribute_texture_of_their_corners() -> None:
    mesh = bpy.data.meshes.new("painted")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    if hasattr(mesh, "color_attributes"):
        layer = mesh.color_attributes.new("paint", "FLOAT_COLOR", "POINT")
    else:
        layer = mesh.vertex_colors.new(name="paint")
    for item, color in zip(layer.data, [(1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1)], strict=False):
        item.color = color
    material = principled("painted")
    mesh.materials.append(material)
    tree = material.node_tree
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "paint"
    tree.links.new(
        attribute.outputs["Color"], next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled").inputs[0]
    )
    material_convert.clear_cache()
    document, notes = material_convert.convert_material(material)
    mean = sum(document["color"]) / 3  # where a mesh lacks the attribute: its mean, as before
    assert document["color"] == pytest.approx([mean] * 3, rel=1e-3) and mean > 0.2
    texture = document["texture"]["attribute"]
    k = document["color"][0] / (1.0 / 3.0)  # Principled's diffuse factor of the mean grey
    assert texture["name"] == "paint" and texture["bias"] == pytest.approx([0.0] * 3, abs=1e-9)
    assert texture["gain"] == pytest.approx([k] * 3, rel=1e-6)
    assert notes == []


def test_an_addon_light_recoloured_in_blender_keeps_its_intensity_and_takes_the_colour() -> None:
    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="colour")
    bpy.context.view_layer.update()
    entry = next(e for e in bpy.context.scene.weathervane.lights if e.kind == "POINT")
    bpy.data.objects[entry.object_name].data.color = (1.0, 0.5, 0.25)
    light, notes = light_convert.convert_light(bpy.data.objects[entry.object_name])
    assert light == {"type": "point", "location": [4.0, -3.0, 6.0], "intensity": 0.6, "color": [1.0, 0.5, 0.25]}
    assert notes == []


def test_a_sharp_glossy_is_a_mirror_and_a_tinted_specular_is_named() -> None:
    material, (output, glossy) = shader_material("sharp", "ShaderNodeBsdfGlossy")
    glossy.distribution = "SHARP" if compat.VERSION < (4, 0, 0) else "GGX"
    glossy.inputs["Roughness"].default_value = 0.0 if compat.VERSION >= (4, 0, 0) else 0.7
    material.node_tree.links.new(glossy.outputs[0], output.inputs["Surface"])
    document, notes = material_convert.convert_material(material)
    assert document["reflective"] == pytest.approx(0.8) and notes == []
    tinted = principled("tinted")
    tint = next(n for n in tinted.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled").inputs["Specular Tint"]
    tint.default_value = (1.0, 0.0, 0.0, 1.0) if tint.type == "RGBA" else 0.5
    assert material_convert.convert_material(tinted)[1] == ["specular tint: white highlight"]


def test_an_environment_texture_is_its_mean_over_the_sphere() -> None:
    """Rows of an equirectangular image weigh by the cosine of their latitude: three rows at -60, 0 and 60 degrees
    weigh 1/2, 1, 1/2, so a bright equator row of 1 gives a mean of 1/2 (a plain mean would give 1/3)."""
    image = bpy.data.images.new("equator", 4, 3, float_buffer=True)
    image.pixels[:] = [value for row in (0.0, 1.0, 0.0) for _ in range(4) for value in (row, row, row, 1.0)]
    assert world_convert.environment_mean(image) == pytest.approx((0.5, 0.5, 0.5))


def test_the_world_tab_shows_the_vanes_background_only_where_the_vane_is_built() -> None:
    """Without the vane F12 renders the World's Surface: the World tab shows that, not the vane's background."""
    from addon.engine import render_panels

    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.world = bpy.data.worlds.new("world")
    compat.enable_nodes(scene.world)
    background = render_panels.WEATHERVANE_WORLD_PT_background
    with bpy.context.temp_override(world=scene.world):
        assert not background.poll(bpy.context)
        assert bpy.types.CYCLES_WORLD_PT_surface.poll(bpy.context)
    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="world")
    with bpy.context.temp_override(world=scene.world):
        assert background.poll(bpy.context)


def test_a_light_type_changed_in_the_light_tab_redraws_the_sidebars_lights_list(monkeypatch) -> None:
    from addon.convert import export
    from addon.vane import sync

    build.build(bpy.context, scene_from_dict(default_scene_dict()), source="lights")
    bpy.context.view_layer.update()
    entry = next(entry for entry in bpy.context.scene.weathervane.lights if entry.kind == "POINT")
    redraws = []
    monkeypatch.setattr(sync, "redraw", lambda: redraws.append(1))
    bpy.data.objects[entry.object_name].data.type = "SPOT"
    bpy.context.view_layer.update()
    assert redraws and export.entry_kind(entry) == "SPOT"  # the list's row reads the type it has now


@pytest.mark.parametrize("roughness", [0.0, 0.2, 0.5, 0.8])
def test_a_base_color_of_exactly_1_is_not_reported_clamped(roughness) -> None:
    """A note says clamped for a colour input above 1, not the conversion's rounding or 3.x Principled's diffuse."""
    converted, notes = material_convert.convert_material(principled(**{"Base Color": (1.0, 0.0, 0.0, 1.0),
                                                                       "Roughness": roughness}))  # fmt: skip
    assert not any("clamped" in note for note in notes), notes
    assert converted["color"][0] == pytest.approx(1.0, abs=0.05) and converted["color"][1:] == [0.0, 0.0]
    _, notes = material_convert.convert_material(principled(**{"Base Color": (1.5, 0.0, 0.0, 1.0)}))
    assert "diffuse colour above 1: clamped" in notes
    material, (output, diffuse) = shader_material("diffuse", "ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    material.node_tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    converted, notes = material_convert.convert_material(material)
    assert converted["color"] == [1.0, 1.0, 1.0] and notes == []


def test_the_scene_conversion_summary_fits_its_room() -> None:
    rows = [("MATERIAL", "Material.001", ["x"]), ("LIGHT", "Light", ["y"]), ("WORLD", "World", ["z"]),
            ("MATERIAL", "exact", [])]  # fmt: skip
    assert conversion_report.summary_line(rows) == "1 exact, 3 approximated (Material.001, Light, World)"
    assert conversion_report.summary_line(rows, 44) == "1 exact, 3 approximated (Material.001, ...)"
    assert conversion_report.summary_line(rows, 30) == "1 exact, 3 approximated"
    from addon.engine.messages import text_width
    from addon.vane.panels import panel_room

    for width in (200, 280, 400):  # the Properties editor's width: the line in the pixels it holds (Blender's font)
        room = panel_room(width)
        line = conversion_report.summary_line(rows, fits=lambda text, room=room: text_width(text) <= room)
        assert text_width(line) <= room and line.startswith("1 exact, 3 approximated")
    assert len(conversion_report.summary_line(rows, fits=lambda text: text_width(text) <= panel_room(400))) > 30
