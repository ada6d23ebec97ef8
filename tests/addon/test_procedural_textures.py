"""Checker and Gradient textures, Color Ramp and Hue/Saturation on a texture, and Image Textures on Emission in
Blender: the conversion hands them to the tracer (docs/scene-format.md, Procedural textures), and
F12 renders a UV-mapped plane as Cycles does: the mean colour over the plane, the mask of Color1's pixels (IoU with
Cycles' >= 0.95), and an image through a Color Ramp (Constant) or Hue/Saturation within 3 dB (PSNR over the plane)
of the plain image's PSNR. Lit by a sun straight down (diffuse only), orthographic, 96 x 96, Cycles 16 samples at the
pixel centres."""

from __future__ import annotations

import math
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import material_convert, mesh_export
from tests.addon.f12_images import f12_exr
from tests.addon.node_groups import new_group

ENGINE = "WEATHERVANE_TRACER"
SIZE = 96
RED, BLUE = (0.8, 0.1, 0.1, 1.0), (0.1, 0.15, 0.7, 1.0)
PSNR_CAP = 100.0


def uv_plane() -> tuple[bpy.types.Material, bpy.types.Node]:
    """A 2 m plane (its default UV map: [0, 1]^2 across it) filling an orthographic camera's view from above, lit by
    a sun straight down; a Principled BSDF without specular, returned with its material. Again: a new material on
    the plane made before."""
    plane = bpy.data.objects.get("Plane")
    if plane is not None:
        return new_material(plane)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.world = None
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.0
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    scene.collection.objects.link(sun)
    return new_material(plane)


def new_material(plane) -> tuple[bpy.types.Material, bpy.types.Node]:
    material = bpy.data.materials.new("procedural")
    compat.enable_nodes(material)
    shader = next(node for node in material.node_tree.nodes if node.bl_idname == "ShaderNodeBsdfPrincipled")
    compat.principled_socket(shader, "specular").default_value = 0.0
    plane.data.materials.clear()
    plane.data.materials.append(material)
    return material, shader


def by_uv(material, node) -> None:
    """node's Vector from a Texture Coordinate's UV (procedural textures read Generated coordinates unlinked)."""
    coordinates = material.node_tree.nodes.new("ShaderNodeTexCoord")
    material.node_tree.links.new(coordinates.outputs["UV"], node.inputs["Vector"])


def checker(
    scale: float, output: str = "Color", mapping: str | None = None, turn: float = 0.0
) -> tuple[bpy.types.Material, bpy.types.Node]:
    """A Checker Texture of this scale by UV on Base Color (through a Mapping node of this type: scale (1.6, 0.7),
    location (0.13, -0.2); with turn degrees about Z, and for Texture a uniform scale 1.3)."""
    material, shader = uv_plane()
    node = material.node_tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Color1"].default_value, node.inputs["Color2"].default_value = RED, BLUE
    node.inputs["Scale"].default_value = scale
    if mapping is None:
        by_uv(material, node)
    else:
        moved = material.node_tree.nodes.new("ShaderNodeMapping")
        moved.vector_type = mapping
        moved.inputs["Scale"].default_value = (1.3, 1.3, 1.0) if turn and mapping == "TEXTURE" else (1.6, 0.7, 1.0)
        moved.inputs["Location"].default_value = (0.13, -0.2, 0.0)
        moved.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(turn))
        by_uv(material, moved)
        material.node_tree.links.new(moved.outputs["Vector"], node.inputs["Vector"])
    material.node_tree.links.new(node.outputs[output], shader.inputs["Base Color"])
    return material, node


def gradient(kind: str, ramp: str | None) -> bpy.types.Material:
    """A Gradient Texture of this type by UV on Base Color, through a Color Ramp (red at 0.3 to blue at 0.7) of this
    interpolation or straight (its grey)."""
    material, shader = uv_plane()
    tree = material.node_tree
    node = tree.nodes.new("ShaderNodeTexGradient")
    node.gradient_type = kind
    by_uv(material, node)
    if ramp is None:
        tree.links.new(node.outputs["Color"], shader.inputs["Base Color"])
        return material
    colors = tree.nodes.new("ShaderNodeValToRGB")
    colors.color_ramp.interpolation = ramp
    first, last = colors.color_ramp.elements
    first.position, first.color = 0.3, RED
    last.position, last.color = 0.7, BLUE
    tree.links.new(node.outputs["Fac"], colors.inputs["Fac"])
    tree.links.new(colors.outputs["Color"], shader.inputs["Base Color"])
    return material


def cells_texture(tree) -> bpy.types.Node:
    """A new Image Texture node (Closest) in tree, of a packed 8 x 8 image of random colours."""
    rng = np.random.default_rng(5)
    image = bpy.data.images.new("cells", 8, 8)
    image.pixels[:] = np.concatenate((rng.random((64, 3)), np.ones((64, 1))), axis=1).reshape(-1).tolist()
    image.pack()
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    return texture


def image_plane(between: str | None) -> bpy.types.Material:
    """A packed 8 x 8 image of random colours (Closest) by UV on Base Color, straight, through a Color Ramp
    (Constant: three stops) or through a Hue/Saturation/Value node."""
    material, shader = uv_plane()
    tree = material.node_tree
    output = cells_texture(tree).outputs["Color"]
    if between == "ramp":
        ramp = tree.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.interpolation = "CONSTANT"
        ramp.color_ramp.elements[0].color = (0.05, 0.3, 0.1, 1.0)
        ramp.color_ramp.elements[1].position, ramp.color_ramp.elements[1].color = 0.6, (0.9, 0.8, 0.2, 1.0)
        middle = ramp.color_ramp.elements.new(0.25)
        middle.color = (0.7, 0.2, 0.5, 1.0)
        tree.links.new(output, ramp.inputs["Fac"])
        output = ramp.outputs["Color"]
    elif between == "hsv":
        hsv = tree.nodes.new("ShaderNodeHueSaturation")
        hsv.inputs["Hue"].default_value, hsv.inputs["Saturation"].default_value = 0.3, 1.6
        hsv.inputs["Value"].default_value = 0.8
        tree.links.new(output, hsv.inputs["Color"])
        output = hsv.outputs["Color"]
    tree.links.new(output, shader.inputs["Base Color"])
    return material


def on_generated(material, node) -> None:
    """node's Vector left unlinked, as a new node comes: Generated coordinates."""
    for link in list(node.inputs["Vector"].links):
        material.node_tree.links.remove(link)


def generated_checker_on(obj, scale: float) -> bpy.types.Material:
    """A Checker Texture (red and blue, this scale) on Generated coordinates on Base Color of obj's only material."""
    material, shader = new_material(obj)
    node = material.node_tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Color1"].default_value, node.inputs["Color2"].default_value = RED, BLUE
    node.inputs["Scale"].default_value = scale
    material.node_tree.links.new(node.outputs["Color"], shader.inputs["Base Color"])
    return material


def cube_from_a_corner(kind: str = "cube") -> bpy.types.Object:
    """Blender's default cube (or a UV sphere) seen from a corner by a perspective camera (its three faces toward
    the camera each along an axis of the texture space), lit by a sun from the camera's side."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.world = None
    if kind == "cube":
        bpy.ops.mesh.primitive_cube_add(size=2.0)
    else:
        bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0)
    obj = bpy.context.active_object
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (5.0, -5.0, 4.2)
    camera.rotation_euler = (math.radians(60.0), 0.0, math.radians(45.0))
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (math.radians(50.0), 0.0, math.radians(30.0))
    scene.collection.objects.link(sun)
    return obj


def f12(engine: str, path: Path) -> np.ndarray:
    scene = bpy.context.scene
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.device, scene.cycles.samples = "CPU", 16
        scene.cycles.use_denoising = scene.cycles.use_adaptive_sampling = False
        scene.cycles.filter_width = 0.01  # each pixel sampled at its centre, as the tracer's one ray
    return f12_exr(path)


def both(tmp_path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(tracer, Cycles) F12 images of the scene."""
    return f12(ENGINE, tmp_path / "tracer.exr"), f12("CYCLES", tmp_path / "cycles.exr")


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max(1, (a | b).sum()))


def psnr(found: np.ndarray, expected: np.ndarray) -> float:
    """PSNR in dB, at most PSNR_CAP: beyond it the two differ by float rounding alone (in bpy 5.0.1 the plain image
    is 142 dB, Hue/Saturation 137 dB: errors of 1e-7), which says nothing about the conversion."""
    error = float(np.mean((found - expected) ** 2))
    return min(PSNR_CAP, 10.0 * np.log10(max(float(expected.max()), 1e-6) ** 2 / max(error, 1e-30)))


def compare_means(tracer: np.ndarray, cycles: np.ndarray) -> str:
    found, expected = tracer.reshape(-1, 3).mean(axis=0), cycles.reshape(-1, 3).mean(axis=0)
    message = f"tracer mean {found.round(4).tolist()}, Cycles mean {expected.round(4).tolist()}"
    assert np.all(np.abs(found - expected) <= 0.03 * expected + 0.005), message
    return message


# ---- the conversion -------------------------------------------------------------------------------------------------


def test_a_checker_by_uv_becomes_the_formats_checker() -> None:
    material, node = checker(3.7)
    document, notes = material_convert.convert_material(material)
    assert notes == []
    found = document["texture"]["checker"]
    k = compat.principled_diffuse_factor(0.5, 0.0)  # Principled's diffuse share, as for a plain colour
    assert found["scale"] == pytest.approx(3.7)
    assert found["color1"] == pytest.approx([min(1.0, c * k) for c in RED[:3]], abs=1e-6)
    assert found["color2"] == pytest.approx([min(1.0, c * k) for c in BLUE[:3]], abs=1e-6)
    assert document["color"] == pytest.approx(
        [(a + b) / 2 * k for a, b in zip(RED[:3], BLUE[:3], strict=True)], abs=1e-6
    )
    material.node_tree.links.remove(node.inputs["Vector"].links[0])  # Generated coordinates: the meshes' UVs made
    document, notes = material_convert.convert_material(material)  # from them (mesh_export.generated_uvs)
    assert notes == [] and document["texture"]["uv_map"] == mesh_export.GENERATED
    assert document["texture"]["checker"]["scale"] == pytest.approx(3.7)


def test_a_gradient_through_a_colour_ramp_becomes_the_ramps_stops() -> None:
    document, notes = material_convert.convert_material(gradient("RADIAL", "CONSTANT"))
    assert notes == []
    found = document["texture"]["gradient"]
    assert found["type"] == "radial" and found["interpolation"] == "constant"
    n = compat.cycles_ramp_table()  # Cycles' table: a Constant ramp steps at the first i / (n - 1) past a stop
    assert [p for p, _ in found["stops"]] == pytest.approx(
        [np.ceil(0.3 * (n - 1)) / (n - 1), 180 / 256 if n == 257 else 179 / 255]
    )
    assert found["stops"][0][1] == pytest.approx([c * compat.principled_diffuse_factor(0.5, 0.0) for c in RED[:3]])
    found = material_convert.convert_material(gradient("SPHERICAL", "LINEAR"))[0]["texture"]["gradient"]
    assert [p for p, _ in found["stops"]] == pytest.approx([0.3, 0.7]) and found["interpolation"] == "linear"
    document, notes = material_convert.convert_material(gradient("EASING", None))
    assert notes == [] and document["texture"]["gradient"]["type"] == "easing"
    assert [p for p, _ in document["texture"]["gradient"]["stops"]] == [0.0, 1.0]


def test_ramp_and_hue_saturation_are_applied_to_the_images_texels() -> None:
    plain = material_convert.convert_material(image_plane(None))[0]["texture"]["pixels"]
    material = image_plane("hsv")
    document, notes = material_convert.convert_material(material)
    assert notes == []
    k = compat.principled_diffuse_factor(0.5, 0.0)
    linear = material_convert.linear_rgb(bpy.data.images["cells"])[::-1]  # rows top first, as the format's
    expected = material_convert.hue_saturation(linear, 0.3, 1.6, 0.8, 1.0) * k
    assert document["texture"]["pixels"] == pytest.approx(np.clip(expected, 0, 1), abs=1e-5)
    assert np.abs(document["texture"]["pixels"] - plain).max() > 0.1
    texture = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    texture.interpolation = "Linear"  # the node maps the interpolated colour: on the texels it is near, named
    assert material_convert.convert_material(material)[1] == [
        "hue/saturation on a linear-interpolated image on Base Color: on its texels"
    ]


def test_hue_saturation_is_cycles_hsv_node() -> None:
    """Against Python's colorsys (the same hexcone model Cycles' rgb_to_hsv/hsv_to_rgb write out)."""
    import colorsys

    rng = np.random.default_rng(2)
    colors = rng.random((200, 3))
    colors[:5] = [[0, 0, 0], [0.5, 0.5, 0.5], [1, 0, 0], [0, 1, 1], [0.2, 0.2, 0.9]]
    for hue, saturation, value, fac in ((0.5, 1.0, 1.0, 1.0), (0.3, 1.6, 0.8, 1.0), (0.9, 0.4, 1.3, 0.7)):
        found = material_convert.hue_saturation(colors, hue, saturation, value, fac)
        for color, got in zip(colors, found, strict=True):
            h, s, v = colorsys.rgb_to_hsv(*color)
            rgb = colorsys.hsv_to_rgb((h + hue + 0.5) % 1.0, min(1.0, max(0.0, s * saturation)), v * value)
            expected = np.maximum(fac * np.asarray(rgb) + (1 - fac) * color, 0.0)
            assert got == pytest.approx(expected, abs=1e-12)


def test_an_image_on_emission_becomes_the_emission_texture_times_its_strength() -> None:
    material, shader = uv_plane()
    tree = material.node_tree
    image = bpy.data.images.new("glow", 2, 2, float_buffer=True)
    image.pixels[:] = [0.2, 0.4, 0.1, 1, 0.0, 0.1, 0.3, 1, 0.5, 0.5, 0.5, 1, 0.05, 0.0, 0.2, 1]
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    tree.links.new(texture.outputs["Color"], compat.principled_socket(shader, "emission"))
    shader.inputs["Emission Strength"].default_value = 1.5
    document, notes = material_convert.convert_material(material)
    assert notes == []
    expected = np.asarray(image.pixels[:]).reshape(2, 2, 4)[::-1, :, :3] * 1.5
    assert document["emission_texture"]["pixels"] == pytest.approx(expected, abs=1e-6)
    assert document["emission"] == pytest.approx(expected.reshape(-1, 3).mean(axis=0), abs=1e-6)
    shader.inputs["Emission Strength"].default_value = 3.0  # 0.5 x 3: radiance above 1, kept as Cycles keeps it
    document, notes = material_convert.convert_material(material)
    assert document["emission_texture"]["pixels"].max() == pytest.approx(1.5) and notes == []


def test_a_mapping_node_becomes_the_textures_uv_scale_and_offset() -> None:
    material, _ = checker(3.0, mapping="POINT")
    document, notes = material_convert.convert_material(material)
    assert notes == []
    assert document["texture"]["uv_scale"] == pytest.approx([1.6, 0.7])
    assert document["texture"]["uv_offset"] == pytest.approx([0.13, -0.2])
    moved = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeMapping")
    moved.vector_type = "TEXTURE"  # (u - L) / S
    texture = material_convert.convert_material(material)[0]["texture"]
    assert texture["uv_scale"] == pytest.approx([1 / 1.6, 1 / 0.7])
    assert texture["uv_offset"] == pytest.approx([-0.13 / 1.6, 0.2 / 0.7])
    for change in ("rotation", "z"):  # a rotation; a z offset (the checker reads z): the mean colour, named
        moved.inputs["Rotation"].default_value = (0.0, 0.0, 0.3 if change == "rotation" else 0.0)
        moved.inputs["Location"].default_value = (0.13, -0.2, 0.5 if change == "z" else 0.0)
        document, notes = material_convert.convert_material(material)
        assert "texture" not in document and notes == ["checker texture on Base Color: mean colour"], change


def test_what_is_not_converted_stays_named() -> None:
    material = gradient("LINEAR", "LINEAR")
    ramp = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "B_SPLINE"
    document, notes = material_convert.convert_material(material)
    assert "texture" not in document and notes and "Base Color" in notes[0]
    material = gradient("LINEAR", "LINEAR")
    shader = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    hsv = material.node_tree.nodes.new("ShaderNodeHueSaturation")  # HSV on a ramp's colours: not a ramp
    material.node_tree.links.new(shader.inputs["Base Color"].links[0].from_socket, hsv.inputs["Color"])
    material.node_tree.links.new(hsv.outputs["Color"], shader.inputs["Base Color"])
    document, notes = material_convert.convert_material(material)
    assert "texture" not in document and notes == [f"{hsv.name} on Base Color: the input's own value"]


def test_hue_saturation_on_a_gradients_grey_scales_it(tmp_path) -> None:
    """HSV of a grey keeps it grey and scales it by fac Value + 1 - fac: the gradient's white stop becomes that."""
    material = gradient("DIAGONAL", None)
    shader = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    hsv = material.node_tree.nodes.new("ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value, hsv.inputs["Saturation"].default_value = 0.2, 1.7
    hsv.inputs["Value"].default_value, hsv.inputs["Fac"].default_value = 0.6, 0.75
    material.node_tree.links.new(shader.inputs["Base Color"].links[0].from_socket, hsv.inputs["Color"])
    material.node_tree.links.new(hsv.outputs["Color"], shader.inputs["Base Color"])
    document, notes = material_convert.convert_material(material)
    assert notes == []
    stops = document["texture"]["gradient"]["stops"]
    k = compat.principled_diffuse_factor(0.5, 0.0)
    assert stops[0] == [0.0, [0.0, 0.0, 0.0]]
    assert stops[1][0] == 1.0 and stops[1][1] == pytest.approx([(0.75 * 0.6 + 0.25) * k] * 3, abs=1e-6)
    tracer, cycles = both(tmp_path)
    compare_means(tracer, cycles)
    score = psnr(tracer, cycles)
    print(f"HSV on a diagonal gradient: PSNR {score:.2f} dB over the plane")
    assert score >= 40.0


# ---- beside Cycles --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("scale", "mapping", "turn"),
    [(5.0, None, 0.0), (3.7, None, 0.0), (3.7, "POINT", 0.0), (2.5, "TEXTURE", 0.0), (3.7, "POINT", 15.0),
     (2.5, "TEXTURE", 20.0)],
)  # fmt: skip
def test_f12_shows_the_checker_as_cycles_does(tmp_path, scale: float, mapping: str | None, turn: float) -> None:
    material, _ = checker(scale, mapping=mapping, turn=turn)
    if mapping is not None:
        fields = {"checker", "uv_scale", "uv_offset"} | ({"uv_rotation"} if turn else set())
        assert set(material_convert.convert_material(material)[0]["texture"]) == fields
    tracer, cycles = both(tmp_path)
    message = compare_means(tracer, cycles)
    first, expected = tracer[..., 0] > tracer[..., 2], cycles[..., 0] > cycles[..., 2]  # Color1 is the red one
    overlap = iou(first, expected)
    print(f"checker {scale} {mapping} {turn}: {message}; Color1 IoU {overlap:.4f}, share {expected.mean():.3f}")
    assert 0.3 < expected.mean() < 0.7 and overlap >= 0.95, f"{message}; IoU {overlap:.4f}"


@pytest.mark.parametrize("scale", [5.0, 3.7])  # z's cell even at 5 (z is 1/2 on a flat plane), odd at 3.7
def test_f12_shows_a_checker_on_generated_coordinates_as_cycles_does_on_a_plane(tmp_path, scale: float) -> None:
    material, node = checker(scale)
    on_generated(material, node)
    tracer, cycles = both(tmp_path)
    message = compare_means(tracer, cycles)
    first, expected = tracer[..., 0] > tracer[..., 2], cycles[..., 0] > cycles[..., 2]
    overlap = iou(first, expected)
    print(f"checker {scale} on Generated, a plane: {message}; Color1 IoU {overlap:.4f}, share {expected.mean():.3f}")
    assert 0.3 < expected.mean() < 0.7 and overlap >= 0.95, f"{message}; IoU {overlap:.4f}"


@pytest.mark.parametrize("scale", [5.0, 3.7])  # the faces at 0 and 1 of each axis: cells 0 and 4, or 0 and 3
def test_f12_shows_a_checker_on_generated_coordinates_as_cycles_does_on_the_default_cube(tmp_path, scale) -> None:
    """Each face lies along an axis of the cube's texture space: the 3D checker is exact there, and nothing is
    named."""
    cube = cube_from_a_corner()
    generated_checker_on(cube, scale)
    from addon.convert import export

    notes = export.ExportNotes()
    document = export.scene_document(bpy.context, notes=notes)
    assert "Generated" not in notes.line(), notes.line()
    assert document is not None
    tracer, cycles = both(tmp_path)
    on = cycles.sum(axis=2) > 0.0  # the cube's pixels (no world: black around it)
    first, expected = (tracer[..., 0] > tracer[..., 2]) & on, (cycles[..., 0] > cycles[..., 2]) & on
    overlap = iou(first, expected)
    print(f"checker {scale} on Generated, the cube: Color1 IoU {overlap:.4f}, share {expected.sum() / on.sum():.3f}")
    assert 0.3 < expected.sum() / on.sum() < 0.7 and overlap >= 0.93, f"IoU {overlap:.4f}"


def test_f12_shows_a_checker_on_generated_coordinates_of_instances_as_cycles_does(tmp_path) -> None:
    """The plane in a collection instanced three times (the meshes table's path), one of them mirrored (its corners
    swapped) and one turned: each instance reads the plane's own Generated coordinates, as in Cycles."""
    material, node = checker(3.7)
    on_generated(material, node)
    plane = bpy.data.objects["Plane"]
    plane.scale = (0.45, 0.45, 1.0)
    collection = bpy.data.collections.new("Tiles")
    collection.objects.link(plane)
    bpy.context.scene.collection.objects.unlink(plane)
    for number, (x, y, mirrored, turn) in enumerate(((-0.5, 0.5, 1, 0), (0.5, 0.5, -1, 0), (0.0, -0.5, 1, 30))):
        tile = bpy.data.objects.new(f"Tile{number}", None)
        tile.instance_type, tile.instance_collection = "COLLECTION", collection
        tile.location, tile.scale = (x, y, 0.0), (mirrored, 1.0, 1.0)
        tile.rotation_euler = (0.0, 0.0, math.radians(turn))
        bpy.context.scene.collection.objects.link(tile)
    from addon.convert import export

    document = export.scene_document(bpy.context)
    assert [body["type"] for body in document["objects"]] == ["instances"] and len(document["meshes"]) == 1
    tracer, cycles = both(tmp_path)
    on = cycles.sum(axis=2) > 0.0
    first, expected = (tracer[..., 0] > tracer[..., 2]) & on, (cycles[..., 0] > cycles[..., 2]) & on
    overlap = iou(first, expected)
    print(f"checker 3.7 on Generated, 3 instances: Color1 IoU {overlap:.4f}, share {expected.sum() / on.sum():.3f}")
    assert 0.3 < expected.sum() / on.sum() < 0.7 and overlap >= 0.95, f"IoU {overlap:.4f}"


def test_f12_shows_an_image_on_generated_coordinates_as_cycles_does_on_the_default_cube(tmp_path) -> None:
    """Texture Coordinate > Generated into an image (flat projection: it reads x and y): the cube's faces show the
    image across x and y, where its UV map would show it whole on each face."""
    cube = cube_from_a_corner()
    material, shader = new_material(cube)
    tree = material.node_tree
    texture = cells_texture(tree)
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coordinates.outputs["Generated"], texture.inputs["Vector"])
    tree.links.new(texture.outputs["Color"], shader.inputs["Base Color"])
    assert material_convert.convert_material(material)[0]["texture"]["uv_map"] == mesh_export.GENERATED
    tracer, cycles = both(tmp_path)
    on = cycles.sum(axis=2) > 0.0
    generated = psnr(tracer[on], cycles[on])
    tree.links.new(coordinates.outputs["UV"], texture.inputs["Vector"])  # the same image by the cube's UV map
    by_uv, cycles_by_uv = both(tmp_path / "uv")
    wrong = psnr(by_uv[on], cycles[on])  # what showing the UV map where Cycles reads Generated would score
    plain = psnr(by_uv[on], cycles_by_uv[on])  # the two engines' agreement on the UV map: the bar

    def off_by(image: np.ndarray) -> float:  # the share of the cube's pixels of another texel than Cycles' (or an edge)
        return float((np.abs(image - cycles).max(axis=2)[on] > 0.2).mean())

    off, off_wrong = off_by(tracer), off_by(by_uv)
    print(
        f"an image on the cube, tracer against Cycles: on Generated {generated:.2f} dB ({off:.1%} of its pixels off "
        f"by over 0.2), by UV {plain:.2f} dB; the UV map's image against Cycles' on Generated {wrong:.2f} dB "
        f"({off_wrong:.1%} off)"
    )
    # the texels' edges (a pixel wide, across each side face from top to bottom) take the few dB below the UV map's
    assert off <= 0.05 and off_wrong >= 0.3 and generated >= wrong + 10.0, (off, off_wrong, generated, wrong)


def test_a_checker_on_generated_coordinates_of_a_sphere_is_named() -> None:
    sphere = cube_from_a_corner("sphere")
    generated_checker_on(sphere, 5.0)
    from addon.convert import export

    notes = export.ExportNotes()
    export.scene_document(bpy.context, notes=notes)
    assert "a checker on Generated coordinates, 2D on faces along no axis of its texture space (Sphere)" in notes.line()
    sphere.modifiers.new("Subdivision", "SUBSURF")
    notes = export.ExportNotes()
    export.scene_document(bpy.context, notes=notes)
    assert "Generated coordinates from the shape after modifiers (Sphere)" in notes.line()


def test_f12_shows_a_gradient_on_generated_coordinates_as_cycles_does_and_names_a_spheres(tmp_path) -> None:
    material = gradient("DIAGONAL", "LINEAR")
    node = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeTexGradient")
    on_generated(material, node)
    tracer, cycles = both(tmp_path)
    message = compare_means(tracer, cycles)
    overlap = iou(tracer[..., 0] > tracer[..., 2], cycles[..., 0] > cycles[..., 2])
    print(f"diagonal gradient on Generated: {message}; IoU {overlap:.4f}")
    assert overlap >= 0.95, f"{message}; IoU {overlap:.4f}"
    node.gradient_type = "SPHERICAL"  # reads z, which UVs do not carry: its mean, named
    document, notes = material_convert.convert_material(material)
    assert "texture" not in document and notes == ["colour ramp on Base Color: mean colour"]


@pytest.mark.parametrize(("kind", "ramp"), [("LINEAR", None), ("SPHERICAL", "LINEAR"), ("RADIAL", "CONSTANT")])
def test_f12_shows_the_gradient_as_cycles_does(tmp_path, kind: str, ramp: str | None) -> None:
    gradient(kind, ramp)
    tracer, cycles = both(tmp_path)
    message = compare_means(tracer, cycles)
    if ramp is None:  # grey: the bright half
        first, expected = tracer[..., 0] > cycles[..., 0].max() / 2, cycles[..., 0] > cycles[..., 0].max() / 2
    else:
        first, expected = tracer[..., 0] > tracer[..., 2], cycles[..., 0] > cycles[..., 2]
    overlap = iou(first, expected)
    print(f"gradient {kind} {ramp}: {message}; IoU {overlap:.4f}, share {expected.mean():.3f}")
    assert 0.1 < expected.mean() < 0.9 and overlap >= 0.95, f"{message}; IoU {overlap:.4f}"


def test_f12_shows_an_image_through_a_ramp_or_hue_saturation_as_cycles_does(tmp_path) -> None:
    scores = {}
    for between in (None, "ramp", "hsv"):
        image_plane(between)
        tracer, cycles = both(tmp_path)
        compare_means(tracer, cycles)
        scores[between] = psnr(tracer, cycles)
    print(f"PSNR over the plane, tracer vs Cycles: plain {scores[None]:.2f} dB, colour ramp {scores['ramp']:.2f} dB, "
          f"hue/saturation {scores['hsv']:.2f} dB")  # fmt: skip
    assert scores["ramp"] >= scores[None] - 3.0 and scores["hsv"] >= scores[None] - 3.0, scores


def test_f12_shows_an_emission_texture_as_cycles_does_and_the_export_carries_it(tmp_path) -> None:
    """A packed 8 x 8 image (Closest) on Principled's Emission Color, strength 0.8, over a black base with the sun
    off: the plane's pixels are the emission, as Cycles'; File > Export's document holds it as lists, with UVs."""
    from addon.convert import export

    material = image_plane(None)
    shader = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    link = shader.inputs["Base Color"].links[0]
    material.node_tree.links.new(link.from_socket, compat.principled_socket(shader, "emission"))
    material.node_tree.links.remove(shader.inputs["Base Color"].links[0])
    shader.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    shader.inputs["Emission Strength"].default_value = 0.8
    bpy.data.objects["Sun"].hide_render = True
    document = export.scene_document(bpy.context)
    converted = document["materials"]["blender:procedural"]
    assert isinstance(converted["emission_texture"]["pixels"], list) and "texture" not in converted
    assert next(body for body in document["objects"] if body["type"] == "mesh").get("uvs")
    tracer, cycles = both(tmp_path)
    compare_means(tracer, cycles)
    score = psnr(tracer, cycles)
    print(f"emission texture: PSNR {score:.2f} dB over the plane, std {tracer.reshape(-1, 3).std(axis=0).round(3)}")
    assert score >= 40.0 and tracer.reshape(-1, 3).std(axis=0).min() > 0.05


def mixed_by(source: str, grouped: bool = False) -> bpy.types.Material:
    """A Mix of red and blue (the Mix node) on Base Color whose factor is a checker's Fac (scale 3.7) or a linear
    gradient's Fac, by UV; grouped: the Mix inside a node group whose input is the factor, as artists wrap it."""
    material, shader = uv_plane()
    tree = material.node_tree
    texture = tree.nodes.new("ShaderNodeTexChecker" if source == "checker" else "ShaderNodeTexGradient")
    if source == "checker":
        texture.inputs["Scale"].default_value = 3.7
    by_uv(material, texture)
    if grouped:
        inner, given, taken = new_group(
            "two colours", "ShaderNodeTree", [("Fac", "NodeSocketFloat")], [("Color", "NodeSocketColor")]
        )
    else:
        inner = tree
    mix = inner.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    by_id = {socket.identifier: socket for socket in mix.inputs}
    by_id["A_Color"].default_value, by_id["B_Color"].default_value = RED, BLUE
    result = next(socket for socket in mix.outputs if socket.identifier == "Result_Color")  # 3.4 lists Float first
    if not grouped:
        tree.links.new(texture.outputs["Fac"], by_id["Factor_Float"])
        tree.links.new(result, shader.inputs["Base Color"])
        return material
    inner.links.new(given.outputs[0], by_id["Factor_Float"])
    inner.links.new(result, taken.inputs[0])
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = inner
    tree.links.new(texture.outputs["Fac"], group.inputs[0])
    tree.links.new(group.outputs[0], shader.inputs["Base Color"])
    return material


@pytest.mark.parametrize(("source", "grouped"), [("checker", False), ("checker", True), ("gradient", False)])
def test_f12_shows_a_texture_on_a_mix_factor_as_cycles_does(tmp_path, source: str, grouped: bool) -> None:
    """A texture's value mixing two colours (how artists colour a checker or a gradient): the texture with the mixed
    colours, exact, where the Mix had been its mean colour, named as 'the input's own value'."""
    material = mixed_by(source, grouped)
    document, notes = material_convert.convert_material(material)
    assert notes == [] and source in document["texture"], (notes, document.get("texture"))
    tracer, cycles = both(tmp_path)
    message = compare_means(tracer, cycles)
    reddish, expected = tracer[..., 0] > tracer[..., 2], cycles[..., 0] > cycles[..., 2]
    overlap = iou(reddish, expected)
    print(f"{source} on a Mix factor (grouped {grouped}): {message}; IoU {overlap:.4f}, share {expected.mean():.3f}")
    assert 0.1 < expected.mean() < 0.9 and overlap >= 0.95, f"{message}; IoU {overlap:.4f}"


def test_f12_shows_a_straight_alpha_images_transparent_texels_black_as_cycles_does(tmp_path) -> None:
    """An 8 x 8 RGBA image (Straight alpha, Blender's default), green everywhere but alpha 0 on a checker of its
    texels, on Base Color (Closest): Cycles' Color output is black there (it keeps the image premultiplied); with
    Linear the interpolation between them is named."""
    material, shader = uv_plane()
    image = bpy.data.images.new("leaf", 8, 8, alpha=True)
    alpha = (np.indices((8, 8)).sum(axis=0) % 2).reshape(-1, 1).astype(float)
    image.pixels[:] = np.concatenate((np.tile([0.1, 0.8, 0.2], (64, 1)), alpha), axis=1).reshape(-1).tolist()
    image.pack()
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    material.node_tree.links.new(texture.outputs["Color"], shader.inputs["Base Color"])
    assert material_convert.convert_material(material)[1] == []
    tracer, cycles = both(tmp_path)
    score = psnr(tracer, cycles)
    dark = cycles.max(axis=2) < 0.02
    print(f"straight alpha: PSNR {score:.2f} dB, Cycles' black share {dark.mean():.3f}")
    assert 0.3 < dark.mean() < 0.7 and score >= 30.0, score
    texture.interpolation = "Linear"
    notes = material_convert.convert_material(material)[1]
    assert notes == ["transparent texels of the image on Base Color: black, interpolated into a darker edge"], notes
