"""Glass and transparency from Blender's node trees: Glass BSDF, Refraction BSDF, Principled
Transmission and IOR, Principled Alpha and Transparent BSDF -> the material's transmission t, ior and alpha a
(docs/scene-format.md), and F12 beside Cycles: a glass sphere's refracted checker, an Alpha 0 object that is not
there, an Alpha 0.5 one that is half there. Runs in the bpy wheel (5.0.1) and in Debian's 3.4.1 (run_in_blender.py)."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import conversion_report, export, material_convert
from tests.addon.f12_images import f12_exr

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
    assert document["transmission_roughness"] == pytest.approx(0.3)  # rough glass, sampled
    beckmann = getattr(node, "distribution", "") == "BECKMANN"  # 3.x's default: the format's Beckmann, single
    assert document.get("glossy_energy", "multiscatter") == ("single" if beckmann else "multiscatter")
    assert document.get("transmission_distribution", "ggx") == ("beckmann" if beckmann else "ggx")
    assert notes == ["Glass BSDF colour: tints the refraction only"]
    if hasattr(node, "distribution"):  # Beckmann, GGX (single scattering) and Multiscatter GGX, as Cycles draws them
        for distribution, energy, drawn in (
            ("BECKMANN", "single", "beckmann"),
            ("GGX", "single", "ggx"),
            ("MULTI_GGX", "multiscatter", "ggx"),
        ):
            node.distribution = distribution
            converted = material_convert.convert_material(material)[0]
            assert converted.get("glossy_energy", "multiscatter") == energy
            assert converted.get("transmission_distribution", "ggx") == drawn
        node.distribution = "BECKMANN" if beckmann else "MULTI_GGX"
    node.inputs["Roughness"].default_value = 0.05  # a near-mirror stays sharp, named
    document, notes = material_convert.convert_material(material)
    assert "transmission_roughness" not in document and notes[0] == "rough Glass BSDF: sharp"
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
    # 4.0+ tints each crossing by sqrt(Base Color) (compat.principled_transmission_tint), which the format's one
    # colour cannot hold beside the opaque part's Base Color: named
    dielectric = ["glass tint: the opaque part's colour"] if bpy.app.version >= (4, 0, 0) else []
    assert notes == (dielectric if metallic == 0.0 else metal)
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
    if metallic == 0.0:  # all glass: its colour is the tint of each crossing (compat.principled_transmission_tint)
        tint = compat.principled_transmission_tint((0.2, 0.8, 0.4))
        assert document["color"] == pytest.approx(tint, rel=1e-6) and notes == []
    node.inputs["Roughness"].default_value = 0.5
    assert material_convert.convert_material(material)[0]["transmission_roughness"] == pytest.approx(0.5)
    node.inputs["Roughness"].default_value = 0.05
    assert "rough transmission: sharp" in material_convert.convert_material(material)[1]
    if "Specular IOR Level" in node.inputs:  # 4.0+: the level scales the glass's reflection too
        node.inputs["Specular IOR Level"].default_value = 0.8
        assert (
            "Specular IOR Level on transmission: the IOR's own reflection"
            in material_convert.convert_material(material)[1]
        )


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


@pytest.mark.parametrize("switch", ["Is Shadow Ray", "Is Camera Ray"])
def test_a_light_path_switch_on_a_mix_is_what_camera_rays_see_named(switch: str) -> None:
    """Mix (glass, transparent) by Is Shadow Ray: glass whose shadow Cycles lets through; camera rays see glass (the
    factor 0). By Is Camera Ray: camera rays see the second shader (the factor 1)."""
    material, (glass, _, mix) = mixed("ShaderNodeBsdfGlass", "ShaderNodeBsdfTransparent", 0.5)
    glass.inputs["IOR"].default_value = 1.5
    path = material.node_tree.nodes.new("ShaderNodeLightPath")
    material.node_tree.links.new(path.outputs[switch], mix.inputs[0])
    document, notes = material_convert.convert_material(material)
    if switch == "Is Shadow Ray":
        assert document["transmission"] == 1.0 and "alpha" not in document
    else:
        assert document["alpha"] == 0.0
    assert notes == [f"Light Path {switch} on {mix.name}: the shader camera rays see, for every ray"]


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


def test_the_conversion_panel_names_glass_only_for_its_shadow_and_names_subsurface() -> None:
    """Glass and alpha convert as Cycles renders them; what differs is glass's shadow while Cycles' Refractive
    Caustics (on by default) lets light through it, which the panel names as F12's line does."""
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
    scene.cycles.caustics_refractive = False
    bpy.context.view_layer.update()
    rows = {name: notes for kind, name, notes in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    tinted = ["glass tint: the opaque part's colour"] if bpy.app.version >= (4, 0, 0) else []  # sqrt(0.8) vs 0.8
    assert rows[names[0]] == [] and rows[names[1]] == tinted
    assert rows[names[2]] == ["subsurface: rendered as the opaque base"]
    scene.cycles.caustics_refractive = True  # Cycles' default
    bpy.context.view_layer.update()
    rows = {name: notes for kind, name, notes in conversion_report.scene_conversion(scene) if kind == "MATERIAL"}
    assert rows[names[0]] == [conversion_report.GLASS_SHADOW] and rows[names[1]] == [*tinted, rows[names[0]][0]]
    assert rows[names[2]] == ["subsurface: rendered as the opaque base"]


# --- beside Cycles ----------------------------------------------------------------------------------------------------

WIDTH, HEIGHT = 128, 96
LENS, SENSOR = 50.0, 36.0  # mm: Blender's default camera (sensor fit Auto: the width)
DARK, BRIGHT = 0.05, 1.0  # the checker's emission
CYCLES_SAMPLES = 64


def emission_material(name: str, value: float) -> bpy.types.Material:
    material, tree, output, (emission,) = shader_tree("ShaderNodeEmission")
    material.name = name
    emission.inputs["Color"].default_value = (value, value, value, 1.0)
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return material


def checker_wall(y: float = 3.0, squares: int = 24, size: float = 0.5) -> bpy.types.Object:
    """A wall at this y facing -y: squares x squares quads of size metres (x and z centred on 0), alternately a dark
    and a bright emission (material slots 0 and 1): a checker made of geometry, the same in both renderers."""
    half = squares * size / 2.0
    vertices, faces, indices = [], [], []
    for row in range(squares):
        for column in range(squares):
            x0, z0 = -half + column * size, -half + row * size
            base = len(vertices)
            vertices += [(x0, y, z0), (x0, y, z0 + size), (x0 + size, y, z0 + size), (x0 + size, y, z0)]
            faces.append((base, base + 1, base + 2, base + 3))
            indices.append((row + column) % 2)
    mesh = bpy.data.meshes.new("checker")
    mesh.from_pydata(vertices, [], faces)
    mesh.materials.append(emission_material("dark", DARK))
    mesh.materials.append(emission_material("bright", BRIGHT))
    mesh.polygons.foreach_set("material_index", indices)
    mesh.update()
    wall = bpy.data.objects.new("checker", mesh)
    bpy.context.scene.collection.objects.link(wall)
    return wall


def camera_and_settings(location=(0.0, -4.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0)) -> bpy.types.Scene:
    """A 50 mm camera (looking along +y by default), a black world, WIDTH x HEIGHT, Standard view; Cycles at
    CYCLES_SAMPLES per pixel all at the pixel's centre (filter width 0.01, as the tracer's one ray), no denoising,
    caustics off (the format's rule for glass's shadow) and no glossy filter."""
    scene = bpy.context.scene
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.lens, camera.data.sensor_width = LENS, SENSOR
    camera.location, camera.rotation_euler = location, rotation
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("black")
    compat.enable_nodes(scene.world)
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = WIDTH, HEIGHT, 100
    scene.view_settings.view_transform = "Standard"
    cycles = scene.cycles
    cycles.device, cycles.samples, cycles.use_denoising = "CPU", CYCLES_SAMPLES, False
    cycles.use_adaptive_sampling = False
    cycles.filter_width = 0.01
    cycles.caustics_reflective = cycles.caustics_refractive = False
    cycles.blur_glossy = 0.0
    scene.weathervane.samples = "1"  # the tracer's one ray at each pixel's centre too (its F12 default antialiases)
    return scene


def glass_sphere(ior: float = 1.45, radius: float = 1.0, shader: str = "glass", location=(0.0, 0.0, 0.0)):
    """A smooth UV sphere (64 x 32) with a clear Glass BSDF of this IOR (shader "glass"), or a white Principled BSDF
    of Transmission 1, Roughness 0 and this IOR ("principled")."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=radius, location=location)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    if shader == "glass":
        material, _ = single("ShaderNodeBsdfGlass", IOR=ior, Color=(1.0, 1.0, 1.0, 1.0))
    else:
        material, node = principled(transmission=1.0, Roughness=0.0, IOR=ior)
        node.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    sphere.data.materials.append(material)
    return sphere


def f12(engine: str, path: Path) -> np.ndarray:
    """The scene rendered by engine -> (HEIGHT, WIDTH, 3) linear RGB, rows from the top."""
    bpy.context.scene.render.engine = engine
    return np.flipud(f12_exr(path))


def silhouette(radius: float, distance: float, inset: float) -> np.ndarray:
    """The pixels whose centres lie inside a sphere's silhouette (a sphere of this radius on the camera's axis at
    this distance), shrunk to inset of its radius: the circle of tan(asin(r / d)) over the half field of view."""
    half_width = math.tan(math.asin(radius / distance)) / (SENSOR / 2.0 / LENS) * WIDTH / 2.0
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    return np.hypot(x + 0.5 - WIDTH / 2.0, y + 0.5 - HEIGHT / 2.0) < inset * half_width


def alpha_stage(sun_angles=(30.0, -25.0)) -> bpy.types.Scene:
    """A white diffuse floor, a sharp mirror wall behind the origin facing the camera, a sun (angle 0) turned by
    sun_angles (degrees about x and y from straight down), a camera looking down at the origin from the front: camera
    rays, mirror rays and shadow rays meet whatever stands at the origin. Cycles without indirect light (no diffuse
    bounces, one glossy bounce for the mirror), as the tracer."""
    scene = camera_and_settings(location=(0.0, -7.0, 4.0), rotation=(math.radians(62.0), 0.0, 0.0))
    floor, tree, output, (diffuse,) = shader_tree("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    mirror, tree, output, (glossy,) = shader_tree("ShaderNodeBsdfGlossy")
    glossy.inputs["Roughness"].default_value = 0.0
    glossy.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    tree.links.new(glossy.outputs[0], output.inputs["Surface"])
    for name, vertices, material in (
        ("floor", [(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)], floor),
        ("mirror", [(-6, 5, 0), (6, 5, 0), (6, 5, 6), (-6, 5, 6)], mirror),
    ):
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(vertices, [], [(0, 1, 2, 3)])
        mesh.materials.append(material)
        scene.collection.objects.link(bpy.data.objects.new(name, mesh))
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (math.radians(sun_angles[0]), math.radians(sun_angles[1]), 0.0)
    scene.collection.objects.link(sun)
    cycles = scene.cycles
    cycles.max_bounces, cycles.diffuse_bounces, cycles.glossy_bounces, cycles.transmission_bounces = 2, 0, 1, 0
    cycles.transparent_max_bounces = 8
    return scene


def red_box(alpha: float, size: float = 1.2) -> bpy.types.Object:
    """A red Principled cube (no specular) of this Alpha floating 0.3 m above the floor at the origin."""
    bpy.ops.mesh.primitive_cube_add(size=size, location=(0.0, 0.0, size / 2.0 + 0.3))
    box = bpy.context.active_object
    material, node = principled(Alpha=alpha, Roughness=0.5, specular=0.0)
    node.inputs["Base Color"].default_value = (0.8, 0.1, 0.05, 1.0)
    box.data.materials.append(material)
    return box


def red_card(alpha: float) -> bpy.types.Object:
    """A red Principled square (no specular) of this Alpha, 1.6 m, level 1.5 m above the origin: with the sun
    straight down its shadow is the floor below it, which the camera sees directly; what the camera sees through it
    is the lit floor 2.9 m and more behind it, or the mirror (5 m behind), whose rays come down on the floor 4.5 m and
    more behind it, so no ray of a pixel crosses the card twice (the mirror at 3 m sent one row back into its
    shadow)."""
    mesh = bpy.data.meshes.new("card")
    mesh.from_pydata([(-0.8, -0.8, 1.5), (0.8, -0.8, 1.5), (0.8, 0.8, 1.5), (-0.8, 0.8, 1.5)], [], [(0, 1, 2, 3)])
    material, node = principled(Alpha=alpha, Roughness=0.5, specular=0.0)
    node.inputs["Base Color"].default_value = (0.8, 0.1, 0.05, 1.0)
    mesh.materials.append(material)
    card = bpy.data.objects.new("card", mesh)
    bpy.context.scene.collection.objects.link(card)
    return card


def dark_squares(image: np.ndarray) -> np.ndarray:
    """The checker's dark squares: pixels below the midpoint of its two emissions (the image is grey)."""
    return image.mean(axis=2) < 0.5 * (DARK + BRIGHT)


@pytest.mark.parametrize("shader", ["glass", "principled"])
def test_a_glass_sphere_refracts_the_checker_as_cycles_does(tmp_path: Path, shader: str) -> None:
    """A clear glass sphere (Glass BSDF, or Principled Transmission 1; IOR 1.45, radius 1 m, 4 m from the camera)
    before a checker wall of emission 6 m behind it, a black world. The rule: inside the sphere's silhouette shrunk
    to 0.9 of its radius (the rim, where the refracted checker is squeezed into stripes a pixel wide, left out), a
    pixel is a dark square where its grey is below the midpoint of the checker's two emissions; the tracer's dark
    squares and Cycles' (64 samples at each pixel's centre, caustics off, no glossy filter, default bounces) have an
    IoU of at least 0.9. The refracted checker is not
    the wall seen straight: Cycles' dark squares with the sphere and without it have an IoU well below that."""
    checker_wall(y=6.0, squares=40)
    glass_sphere(ior=1.45, shader=shader)
    camera_and_settings()
    cycles = f12("CYCLES", tmp_path / "cycles.exr")
    tracer = f12(ENGINE, tmp_path / "tracer.exr")
    inside = silhouette(1.0, 4.0, inset=0.9)
    found, expected = dark_squares(tracer) & inside, dark_squares(cycles) & inside
    iou = np.count_nonzero(found & expected) / np.count_nonzero(found | expected)
    bpy.data.objects.remove(bpy.data.objects["Sphere"])
    straight = dark_squares(f12("CYCLES", tmp_path / "straight.exr")) & inside
    unrefracted = np.count_nonzero(straight & expected) / np.count_nonzero(straight | expected)
    print(
        f"dark squares inside the silhouette: IoU tracer/Cycles {iou:.3f}; Cycles without the sphere {unrefracted:.3f}"
    )
    assert unrefracted < 0.6  # the scene tests refraction
    assert iou >= 0.9
    bright = ~dark_squares(tracer) & ~dark_squares(cycles) & inside
    ratio = tracer[bright].mean() / cycles[bright].mean()  # the bright squares through two surfaces' Fresnel
    print(f"bright squares inside the silhouette: tracer / Cycles = {ratio:.4f}")
    assert ratio == pytest.approx(1.0, abs=0.05)


def test_glass_casts_the_shadow_cycles_casts_with_caustics_off(tmp_path: Path) -> None:
    """The format's rule: glass's shadow is opaque, as Cycles' with refractive caustics off (its shadow rays stop at
    glass). A glass sphere 1 m above the alpha stage's floor, the sun straight down: the floor under its middle (a
    disc of 0.6 m, the camera's view of it not through the sphere) is as dark in the tracer as in Cycles (both under 2%
    of the lit floor), and the sphere's own pixels show the refracted floor and mirror within 10% of Cycles' mean
    (Cycles with 4 glossy and 4 transmission bounces, no diffuse ones; the tracer's 3 Reflections)."""
    scene = alpha_stage((0.0, 0.0))
    scene.cycles.max_bounces, scene.cycles.glossy_bounces, scene.cycles.transmission_bounces = 8, 4, 4
    camera = scene.camera
    camera.location, camera.rotation_euler = (0.0, -6.0, 1.5), (math.radians(80.0), 0.0, 0.0)
    images = {}
    for engine in ("CYCLES", ENGINE):
        images[engine, "none"] = f12(engine, tmp_path / f"{engine}-none.exr")
    sphere = glass_sphere(radius=0.5, location=(0.0, 0.0, 1.5))
    for engine in ("CYCLES", ENGINE):
        images[engine, "glass"] = f12(engine, tmp_path / f"{engine}-glass.exr")
    sphere.data.materials[0] = emission_material("white", 1.0)  # an emission of 1: its pixels (the mirror's are 0.9)
    covered = np.abs(f12(ENGINE, tmp_path / "opaque.exr") - 1.0).max(axis=2) < 1e-6
    lit = images["CYCLES", "none"].mean()
    changed = np.abs(images["CYCLES", "glass"] - images["CYCLES", "none"]).max(axis=2) > 0.1
    shadow = changed & ~covered  # the floor the sphere darkens, seen directly
    print(f"glass shadow ({np.count_nonzero(shadow)} pixels): tracer {images[ENGINE, 'glass'][shadow].mean():.4f}, "
          f"Cycles {images['CYCLES', 'glass'][shadow].mean():.4f}, lit floor {lit:.4f}")  # fmt: skip
    assert np.count_nonzero(shadow) > 30
    assert images["CYCLES", "glass"][shadow].mean() < 0.02 * lit
    assert images[ENGINE, "glass"][shadow].mean() < 0.02 * lit
    ratio = images[ENGINE, "glass"][covered].mean() / images["CYCLES", "glass"][covered].mean()
    print(f"the glass sphere's pixels: tracer / Cycles = {ratio:.4f}")
    assert ratio == pytest.approx(1.0, rel=0.1)


def render_set(tmp_path: Path, engine: str, build, alphas, sun_angles) -> dict:
    """The alpha stage rendered by engine without the object and with it at each alpha: {alpha or None: image}."""
    images = {}
    for alpha in (None, *alphas):
        bpy.ops.wm.read_factory_settings(use_empty=True)  # the add-on stays registered
        alpha_stage(sun_angles)
        if alpha is not None:
            build(alpha)
        images[alpha] = f12(engine, tmp_path / f"{engine}-{alpha}.exr")
    return images


def test_a_principled_alpha_0_object_is_not_there(tmp_path: Path) -> None:
    """A red box of Alpha 0 floating over the floor, before a mirror, lit by a slanted sun: camera rays, the mirror's
    rays and the sun's shadow rays all pass it. The tracer's pixels equal those of the scene without it (to 1e-6); at
    Alpha 1 the box, its reflection and its shadow are there. Cycles (64 samples) shows the same: Alpha 0 within 0.01
    of the scene without the box on every pixel."""
    tracer = render_set(tmp_path, ENGINE, red_box, (0.0, 1.0), (30.0, -25.0))
    cycles = render_set(tmp_path, "CYCLES", red_box, (0.0,), (30.0, -25.0))
    shown = np.abs(tracer[1.0] - tracer[None]).max(axis=2) > 0.1
    print(f"Alpha 0: tracer {np.abs(tracer[0.0] - tracer[None]).max():.2e}, Cycles "
          f"{np.abs(cycles[0.0] - cycles[None]).max():.2e} from the scene without it; Alpha 1 changes "
          f"{np.count_nonzero(shown)} pixels")  # fmt: skip
    assert np.count_nonzero(shown) > 200  # box, reflection and shadow
    assert np.abs(cycles[0.0] - cycles[None]).max() <= 0.01
    assert np.abs(tracer[0.0] - tracer[None]).max() <= 1e-6


def volume_box(density: float) -> bpy.types.Object:
    """red_box's cube with a material of a Volume Absorption alone (density), on the output's Volume: no Surface."""
    bpy.ops.mesh.primitive_cube_add(size=1.2, location=(0.0, 0.0, 0.9))
    box = bpy.context.active_object
    material, tree, output, (absorption,) = shader_tree("ShaderNodeVolumeAbsorption")
    absorption.inputs["Density"].default_value = density
    tree.links.new(absorption.outputs[0], output.inputs["Volume"])
    box.data.materials.append(material)
    return box


def test_a_volume_alone_lets_every_ray_through_named(tmp_path: Path) -> None:
    """A material of a volume and no Surface (a fog box): Cycles renders no surface there, only the volume. The
    tracer renders no volume, so it lets camera, mirror and shadow rays through, and names it; it was black before.
    At density 0 Cycles shows the scene without the box (within its noise, 0.01), and the tracer equals its own
    scene without the box to 1e-6."""
    material, tree, output, (absorption,) = shader_tree("ShaderNodeVolumeAbsorption")
    tree.links.new(absorption.outputs[0], output.inputs["Volume"])
    document, notes = material_convert.convert_material(material)
    assert document["alpha"] == 0.0 and "no surface shader: black" not in notes
    assert any(note.startswith("a volume alone, no Surface: not rendered, every ray passes") for note in notes), notes
    tracer = render_set(tmp_path, ENGINE, volume_box, (0.0,), (30.0, -25.0))
    cycles = render_set(tmp_path, "CYCLES", volume_box, (0.0,), (30.0, -25.0))
    print(f"a volume alone: tracer {np.abs(tracer[0.0] - tracer[None]).max():.2e}, Cycles "
          f"{np.abs(cycles[0.0] - cycles[None]).max():.2e} from the scene without it")  # fmt: skip
    assert np.abs(cycles[0.0] - cycles[None]).max() <= 0.01
    assert np.abs(tracer[0.0] - tracer[None]).max() <= 1e-6


def test_a_principled_alpha_half_card_is_half_there(tmp_path: Path) -> None:
    """A red card of Alpha 0.5 level over the floor, the sun straight down: its pixels (seen directly, in the mirror,
    and its shadow) are the mean of the scene with it opaque and without it, as Cycles' are. No ray of a pixel crosses
    the card twice (red_card), so the mean is exact for the format's model (1 - a of each ray passes) and for Cycles'
    (a Transparent BSDF mixed in by 1 - a) but for Cycles' noise. Measured, Cycles at 64 samples over the 1196 pixels
    the card changes: 95% within 0.0048 of the mean, all within 0.008 (5.0.1) and all but one within 0.01 (3.4.1:
    0.0118), the deviations' mean 4e-5. The bounds: within 0.01 on 99% of them, 0.002 on their mean; the tracer
    must meet them as Cycles does (its own rule gives the mean to rounding), and its card within 10% of Cycles'."""
    tolerance, share, mean_tolerance = 0.01, 0.99, 0.002
    results = {}
    for engine in ("CYCLES", ENGINE):
        images = render_set(tmp_path, engine, red_card, (0.5, 1.0), (0.0, 0.0))
        changed = np.abs(images[1.0] - images[None]).max(axis=2) > 0.02
        deviation = (images[0.5] - 0.5 * (images[1.0] + images[None]))[changed]
        within = float((np.abs(deviation).max(axis=1) <= tolerance).mean())
        results[engine] = (within, float(np.abs(deviation.mean())), images[0.5][changed].mean(), changed.sum())
        print(f"{engine}: {results[engine][3]} pixels changed by the card; within {tolerance} of the mean: "
              f"{within:.4f}; mean deviation {results[engine][1]:.5f}")  # fmt: skip
    for engine in ("CYCLES", ENGINE):
        within, mean_deviation, _, changed = results[engine]
        assert changed > 200 and within >= share and mean_deviation <= mean_tolerance, engine
    print(f"the card's pixels at Alpha 0.5: tracer / Cycles = {results[ENGINE][2] / results['CYCLES'][2]:.4f}")
    assert results[ENGINE][2] == pytest.approx(results["CYCLES"][2], rel=0.1)


def test_the_scene_document_carries_the_fields_the_tracer_loads() -> None:
    """F12's document: the glass and alpha materials' fields load into the tracer's materials as they were given,
    and its warning line names none of them (a rough glass is named again); the checker's emissions are named, as
    lighting nothing around them."""
    from tracer.scene.loader import scene_from_dict

    def named(notes: export.ExportNotes) -> dict[str, list[str]]:
        return {name: said for name, said in notes.materials.items() if said}

    emissions = {name: [material_convert.UNLIT_EMISSION] for name in ("dark", "bright")}
    checker_wall(y=6.0, squares=4)
    sphere = glass_sphere(ior=1.45)
    camera_and_settings()
    red_card(0.25)
    notes = export.ExportNotes()
    scene = scene_from_dict(export.scene_document(bpy.context, notes=notes))
    assert named(notes) == emissions
    sphere.data.materials[0].node_tree.nodes["Glass BSDF"].inputs["Roughness"].default_value = 0.05  # sharp, named
    notes = export.ExportNotes()
    export.scene_document(bpy.context, notes=notes)
    assert named(notes).keys() == {*emissions, "glassy"}
    assert notes.line() == "approximated: 3 materials (Render Properties > Scene Conversion says how)"
    bpy.context.scene.render.film_transparent = True  # glass is opaque in the alpha, as Cycles' by default
    bpy.context.scene.cycles.film_transparent_glass = True  # Cycles' Film > Transparent Glass: not so
    notes = export.ExportNotes()
    export.scene_document(bpy.context, notes=notes)
    assert notes.line().startswith("Film > Transparent Glass: glass opaque in the alpha; approximated: 3 materials")
    bpy.context.scene.cycles.caustics_refractive = True  # Cycles' default: light through glass into its shadow
    notes = export.ExportNotes()
    export.scene_document(bpy.context, notes=notes)
    assert notes.line().startswith("Refractive Caustics: glass's shadow opaque; Film > Transparent Glass")
    by_name = {name.split(":", 1)[-1]: material for name, material in scene.materials.items()}
    assert by_name["glassy"].transmission == 1.0 and by_name["glassy"].ior == 1.45 and by_name["glassy"].alpha == 1.0
    assert by_name["principled"].alpha == 0.25 and by_name["principled"].transmission == 0.0
    assert by_name["dark"].transmission == 0.0 and by_name["dark"].alpha == 1.0
