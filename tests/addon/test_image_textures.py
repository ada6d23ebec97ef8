"""Image textures by UV in Blender: a UV-mapped plane with an Image Texture (a small generated
image, packed) on Principled's Base Color renders the texture in F12, as Cycles does: the mean colour over the plane
within 4% (+0.01) of Cycles' per channel, and its pixels the texels Cycles shows there (the grid's cells, not one
mean colour). The conversion hands the texture and the plane's corner UVs to the tracer and no longer names it."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon import compat
from addon.convert import export, material_convert, mesh_export
from tests.addon.f12_images import f12_exr

ENGINE = "WEATHERVANE_TRACER"
SIZE = 64
GRID = [  # 4 x 4 cells, bottom row first (Blender's order), sRGB byte values / 255
    [(0.9, 0.2, 0.2), (0.2, 0.8, 0.3), (0.2, 0.3, 0.9), (0.9, 0.9, 0.2)],
    [(0.2, 0.9, 0.9), (0.8, 0.2, 0.8), (0.5, 0.5, 0.5), (1.0, 0.6, 0.2)],
    [(0.1, 0.1, 0.1), (1.0, 1.0, 1.0), (0.4, 0.7, 0.2), (0.6, 0.3, 0.8)],
    [(0.7, 0.4, 0.3), (0.3, 0.4, 0.7), (0.95, 0.75, 0.8), (0.25, 0.5, 0.45)],
]


def textured_plane(interpolation: str = "Closest") -> tuple[bpy.types.Object, bpy.types.Material]:
    """A 2 m plane (its default UV map: the image once across it) seen from above by an orthographic camera that it
    fills, lit by a sun straight down; Principled (no specular) with a packed 4 x 4 colour grid on Base Color."""
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
    image = bpy.data.images.new("grid", 4, 4)
    image.pixels[:] = [c for row in GRID for rgb in row for c in (*rgb, 1.0)]
    image.pack()
    material = bpy.data.materials.new("textured")
    compat.enable_nodes(material)
    tree = material.node_tree
    shader = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeBsdfPrincipled")
    compat.principled_socket(shader, "specular").default_value = 0.0
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, interpolation
    tree.links.new(texture.outputs["Color"], shader.inputs["Base Color"])
    plane.data.materials.append(material)
    return plane, material


def f12(engine: str, path: Path) -> np.ndarray:
    scene = bpy.context.scene
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.device, scene.cycles.samples = "CPU", 16
        scene.cycles.use_denoising = scene.cycles.use_adaptive_sampling = False
        scene.cycles.filter_width = 0.01  # each pixel sampled at its centre, as the tracer's one ray
    return f12_exr(path)


def test_the_conversion_hands_the_texture_and_the_planes_uvs_over() -> None:
    _, material = textured_plane("Linear")
    document, notes = material_convert.convert_material(material)
    assert notes == []  # rendered, so not named
    texture = document["texture"]
    assert texture["interpolation"] == "linear" and texture["extension"] == "repeat"
    assert texture["pixels"].shape == (4, 4, 3)  # top row first: Blender's last row
    srgb = np.asarray(GRID[3][0])
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    k = compat.principled_diffuse_factor(0.5, 0.0)
    assert texture["pixels"][0, 0] == pytest.approx(np.clip(linear * k, 0, 1), abs=5e-3)  # 8-bit storage
    scene = export.scene_document(bpy.context, arrays=True)
    body = next(body for body in scene["objects"] if body["type"] == "mesh")
    assert body["uvs"].shape == (2, 3, 2) and body["uvs"].min() == 0.0 and body["uvs"].max() == 1.0
    assert isinstance(export.scene_document(bpy.context)["materials"]["blender:textured"]["texture"]["pixels"], list)


def test_a_material_without_a_texture_sends_no_uvs() -> None:
    _, material = textured_plane()
    material.node_tree.nodes.remove(next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage"))
    body = next(body for body in export.scene_document(bpy.context)["objects"] if body["type"] == "mesh")
    assert "uvs" not in body


def test_non_uv_coordinates_keep_the_mean_colour_named() -> None:
    _, material = textured_plane()
    tree = material.node_tree
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    texture = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    tree.links.new(coordinates.outputs["Object"], texture.inputs["Vector"])
    document, notes = material_convert.convert_material(material)
    assert "texture" not in document and notes == ["image texture on Base Color: mean colour"]
    tree.links.new(coordinates.outputs["Generated"], texture.inputs["Vector"])  # flat projection reads their x, y
    document, notes = material_convert.convert_material(material)
    assert document["texture"]["uv_map"] == mesh_export.GENERATED and notes == []


def test_a_multiply_mix_on_the_texture_is_evaluated_on_its_pixels() -> None:
    _, material = textured_plane()
    tree = material.node_tree
    texture = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    shader = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    plain = material_convert.convert_material(material)[0]["texture"]["pixels"]
    mix = tree.nodes.new("ShaderNodeMixRGB")
    mix.blend_type = "MULTIPLY"
    mix.inputs["Fac"].default_value = 1.0
    mix.inputs["Color2"].default_value = (0.5, 1.0, 0.25, 1.0)
    tree.links.new(texture.outputs["Color"], mix.inputs["Color1"])
    tree.links.new(mix.outputs["Color"], shader.inputs["Base Color"])
    material_convert.clear_cache()
    document, notes = material_convert.convert_material(material)
    assert notes == []
    # 3.4's Principled diffuse is 0.9% brighter than its colour at roughness 0.5: the plain white texel was clipped at 1
    tolerance = 1e-6 if bpy.app.version >= (4, 0, 0) else 5e-3
    assert document["texture"]["pixels"] == pytest.approx(plain * np.float32([0.5, 1.0, 0.25]), abs=tolerance)


def test_f12_shows_the_texture_as_cycles_does(tmp_path) -> None:
    """Measured (64 x 64, Closest, sun straight down, Cycles 16 samples): bpy 5.0.1 and Blender 3.4.1 in the commit
    message. Cycles' mean and the engine's within 4% + 0.01 per channel; the pixels as Cycles' but for
    those on a cell's edge (a pixel centre on a texel boundary may go either way): at least 99% of them within 0.01 of
    Cycles' (5.0.1: all but one, whose 16 Cycles samples lost one: 15/16 of the tracer's)."""
    textured_plane()
    cycles = f12("CYCLES", tmp_path / "cycles.exr")
    tracer = f12(ENGINE, tmp_path / "tracer.exr")
    found, expected = tracer.reshape(-1, 3).mean(axis=0), cycles.reshape(-1, 3).mean(axis=0)
    message = f"tracer mean {found.round(4).tolist()}, Cycles mean {expected.round(4).tolist()}"
    print(message)
    assert np.all(np.abs(found - expected) <= 0.04 * expected + 0.01), message
    assert tracer.reshape(-1, 3).std(axis=0).min() > 0.05, message  # the grid's colours, not one mean
    cell = SIZE // 4
    inner = np.ones((SIZE, SIZE), dtype=bool)
    for edge in range(0, SIZE + 1, cell):  # a pixel on either side of each cell boundary left out
        inner[max(0, edge - 1) : edge + 1, :] = False
        inner[:, max(0, edge - 1) : edge + 1] = False
    close = (np.abs(tracer - cycles).max(axis=2) <= 0.01)[inner].mean()
    assert close >= 0.99, f"{message}; share of the cells' pixels within 0.01 of Cycles' {close:.4f}"


def textured_cube_and_sphere(width: int, height: int) -> None:
    """A cube and a smooth UV sphere (64 x 32), each with its default UV map and the packed 4 x 4 grid on a Diffuse
    BSDF's Color (Lambert in every Blender: 3.4's Principled diffuse is Disney's, brighter at grazing angles), seen
    in perspective, lit by a sun from the side: diffuse light only, no world."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.render.film_transparent = True
    scene.world = None
    image = bpy.data.images.new("grid", 4, 4)
    image.pixels[:] = [c for row in GRID for rgb in row for c in (*rgb, 1.0)]
    image.pack()
    material = bpy.data.materials.new("textured")
    compat.enable_nodes(material)
    tree = material.node_tree
    output = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeOutputMaterial")
    shader = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(shader.outputs["BSDF"], output.inputs["Surface"])
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image, texture.interpolation = image, "Closest"
    tree.links.new(texture.outputs["Color"], shader.inputs["Color"])
    bpy.ops.mesh.primitive_cube_add(size=1.6, location=(-1.2, 0.0, 0.0), rotation=(0.5, 0.3, 0.4))
    bpy.context.object.data.materials.append(material)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(1.2, 0.0, 0.0), segments=64, ring_count=32)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(material)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0.0, -7.0, 2.5), (1.2566, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.6981, 0.0, 0.5236)
    scene.collection.objects.link(sun)


def rgba_f12(engine: str, samples: int, path: Path, seed: int = 0) -> np.ndarray:
    """(H, W, 4) linear RGBA of an F12: Cycles with a box filter one pixel wide (as the tracer's), no denoising."""
    scene = bpy.context.scene
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.device, scene.cycles.samples, scene.cycles.seed = "CPU", samples, seed
        scene.cycles.use_denoising = scene.cycles.use_adaptive_sampling = False
        scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    else:
        scene.weathervane.samples = str(samples)
    return f12_exr(path, "RGBA")


def test_a_textured_cube_and_sphere_are_as_close_to_cycles_as_cycles_at_64_samples(tmp_path) -> None:
    """The bar: the objects' pixels (those Cycles covers wholly) within 3 dB of Cycles' own at 64 samples,
    both against Cycles at 1024 samples. Measured at 96 x 72, the engine at 64 samples against Cycles at 64: 53.20
    against 56.10 dB (bpy 5.0.1), 53.31 / 55.89 (4.5.15, 4.2.23), 53.02 / 54.81 (Debian 3.4.1); the cube alone 58 dB,
    the sphere 51 (the pixels along its terminator); the mean colour within 0.2% of Cycles'; 0.3% of the pixels more
    than 0.02 apart (on the grid's lines: where Cycles has them)."""
    width, height = 96, 72
    textured_cube_and_sphere(width, height)
    reference = rgba_f12("CYCLES", 1024, tmp_path / "reference.exr")
    cycles = rgba_f12("CYCLES", 64, tmp_path / "cycles.exr", seed=7)
    tracer = rgba_f12(ENGINE, 64, tmp_path / "tracer.exr")
    covered = reference[..., 3] > 0.999
    assert covered.sum() > 0.25 * width * height

    def psnr(image: np.ndarray) -> float:
        difference = np.clip(image[..., :3], 0.0, 1.0)[covered] - np.clip(reference[..., :3], 0.0, 1.0)[covered]
        return float(10.0 * np.log10(1.0 / np.mean(difference * difference)))

    ours, theirs = psnr(tracer), psnr(cycles)
    message = f"PSNR over the objects: the engine {ours:.2f} dB, Cycles at 64 samples {theirs:.2f} dB"
    print(message)
    assert ours >= theirs - 3.0 and ours > 45.0, message
    mean, expected = tracer[covered][:, :3].mean(axis=0), reference[covered][:, :3].mean(axis=0)
    assert np.all(np.abs(mean / expected - 1.0) < 0.01), (mean, expected)
    apart = np.abs(np.clip(tracer[..., :3], 0, 1) - np.clip(reference[..., :3], 0, 1)).max(axis=2)[covered] > 0.02
    assert apart.mean() < 0.01, f"{message}; {apart.mean():.4f} of the pixels more than 0.02 from Cycles'"
