"""Image textures by UV (docs/scene-format.md, Textures): the loader's checks and messages, a textured quad whose
pixels are the texels their UVs fall on (closest) or their bilinear mix (linear), repeat/extend/clip outside [0, 1],
sRGB images linearised, PNG and .npy files, instanced meshes, emission textures, and the Whitted passes still adding
up to the image."""

from __future__ import annotations

import random
import struct
import zlib
from typing import Any

import numpy as np
import pytest

from tests.random_scenes import extended_scene_document
from tests.test_reference_passes import check_against_reference, with_passes
from tracer.scene import passes as ps
from tracer.scene import textures as tx
from tracer.scene.loader import SceneError, scene_from_dict
from tracer.tracing.reference import render_reference
from tracer.workers.parallel import render

SIZE = 48  # the quad's image is SIZE x SIZE pixels, one world unit across
TEXELS = [  # 3 rows (top first) of 4 texels: every texel a different colour
    [[0.9, 0.1, 0.1], [0.1, 0.9, 0.1], [0.1, 0.1, 0.9], [0.9, 0.9, 0.1]],
    [[0.1, 0.9, 0.9], [0.9, 0.1, 0.9], [0.5, 0.5, 0.5], [0.2, 0.4, 0.6]],
    [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.3, 0.7, 0.2], [0.6, 0.3, 0.8]],
]


def quad_document(texture: dict[str, Any], uv_scale: float = 1.0, uv_offset: float = 0.0) -> dict[str, Any]:
    """A unit quad [0, 1]^2 at z = 0 seen straight down by an orthographic camera that fills the image with it, lit
    by an ambient light of 1 alone (so a pixel's colour is its material colour); its UVs (x, y) * scale + offset."""
    corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    triangles = [[0, 1, 2], [0, 2, 3]]
    uv = [[c * uv_scale + uv_offset for c in corner] for corner in corners]
    return {
        "materials": {"tex": {"color": [0.5, 0.5, 0.5], "texture": texture}},
        "objects": [
            {
                "type": "mesh",
                "name": "quad",
                "material": "tex",
                "vertices": [[x, y, 0.0] for x, y in corners],
                "triangles": triangles,
                "uvs": [[uv[k] for k in triangle] for triangle in triangles],
            }
        ],
        "lights": [{"type": "ambient", "intensity": 1.0}],
        "camera": {"type": "ORTHO", "location": [0.5, 0.5, 5.0], "rotation": [0, 0, 0], "ortho_scale": 1.0},
        "background": {"type": "none"},
        "render": {"width": SIZE, "height": SIZE, "depth": 0},
    }


def pixel_uvs(uv_scale: float = 1.0, uv_offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel centre's UV on the quad (SIZE, SIZE) each: pixel (i, j) from the top-left sees x = (i + 0.5) / SIZE,
    y = 1 - (j + 0.5) / SIZE."""
    centre = (np.arange(SIZE) + 0.5) / SIZE
    x, y = np.meshgrid(centre, 1.0 - centre)
    return x * uv_scale + uv_offset, y * uv_scale + uv_offset


def expected_texels(pixels: np.ndarray, u: np.ndarray, v: np.ndarray, interpolation: str, extension: str):
    """Cycles' lookup written out here on its own (intern/cycles/kernel/device/cpu/image.h), row 0 the top."""
    height, width = pixels.shape[:2]

    def texel(i, j):
        if extension == "repeat":
            i, j = i % width, j % height
        elif extension == "extend":
            i, j = np.clip(i, 0, width - 1), np.clip(j, 0, height - 1)
        inside = (i >= 0) & (i < width) & (j >= 0) & (j < height)
        value = pixels[height - 1 - np.clip(j, 0, height - 1), np.clip(i, 0, width - 1)].astype(np.float64)
        return np.where(inside[..., None], value, 0.0)

    if interpolation == "closest":
        return texel(np.floor(u * width).astype(int), np.floor(v * height).astype(int))
    x, y = u * width - 0.5, v * height - 0.5
    i, j = np.floor(x).astype(int), np.floor(y).astype(int)
    a, b = (x - i)[..., None], (y - j)[..., None]
    return (
        texel(i, j) * (1 - a) * (1 - b)
        + texel(i + 1, j) * a * (1 - b)
        + texel(i, j + 1) * (1 - a) * b
        + texel(i + 1, j + 1) * a * b
    )


@pytest.mark.parametrize("interpolation", ["closest", "linear"])
@pytest.mark.parametrize("extension", ["repeat", "extend", "clip"])
def test_each_pixel_is_the_texel_its_uv_falls_on_or_their_bilinear_mix(interpolation: str, extension: str) -> None:
    # UVs from -0.8 to 1.9: the image once, then outside it on every side
    texture = {"pixels": TEXELS, "colorspace": "linear", "interpolation": interpolation, "extension": extension}
    image = render(scene_from_dict(quad_document(texture, 2.7, -0.8)), workers=1).image
    u, v = pixel_uvs(2.7, -0.8)
    expected = expected_texels(np.asarray(TEXELS, dtype=np.float32), u, v, interpolation, extension)
    assert np.abs(image - expected).max() <= 1e-9
    if interpolation == "closest":  # every texel shows, each as its exact value
        assert {tuple(c) for c in np.float32(TEXELS).reshape(-1, 3).tolist()} <= {
            tuple(c) for c in image.astype(np.float32).reshape(-1, 3).tolist()
        }
    if extension == "clip":
        outside = (u < 0) | (u >= 1) | (v < 0) | (v >= 1)
        assert np.all(image[outside & ((u < -0.5) | (v < -0.5))] == 0.0)


def test_an_srgb_image_is_linearised_and_a_linear_one_kept() -> None:
    grey = [[[0.5, 0.5, 0.5]]]
    srgb = render(scene_from_dict(quad_document({"pixels": grey})), workers=1).image  # sRGB is the default
    linear = render(scene_from_dict(quad_document({"pixels": grey, "colorspace": "linear"})), workers=1).image
    # one texel, linear interpolation: its four weights add up to 1 within a few ulps
    assert np.allclose(srgb, np.float32(((0.5 + 0.055) / 1.055) ** 2.4), atol=1e-15, rtol=0)
    assert np.allclose(linear, 0.5, atol=1e-15, rtol=0)


def _png(image: np.ndarray, filters: list[int]) -> bytes:
    """A PNG (8-bit RGB) of image (H, W, 3) uint8 with each row's filter as given (0-4), written out here."""
    height, width, _ = image.shape
    data, above = b"", np.zeros(width * 3, dtype=np.int64)
    for y in range(height):
        row = image[y].reshape(-1).astype(np.int64)
        left = np.concatenate(([0, 0, 0], row[:-3]))
        corner = np.concatenate(([0, 0, 0], above[:-3]))
        kind = filters[y % len(filters)]
        if kind == 0:
            predicted = np.zeros_like(row)
        elif kind == 1:
            predicted = left
        elif kind == 2:
            predicted = above
        elif kind == 3:
            predicted = (left + above) // 2
        else:
            p = left + above - corner
            pa, pb, pc = np.abs(p - left), np.abs(p - above), np.abs(p - corner)
            predicted = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, above, corner))
        data += bytes([kind]) + ((row - predicted) % 256).astype(np.uint8).tobytes()
        above = row

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return tx.PNG_SIGNATURE + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(data)) + chunk(b"IEND", b"")


def test_png_and_npy_files_by_path_relative_to_the_scene_file(tmp_path) -> None:
    rng = np.random.default_rng(3)
    picture = rng.integers(0, 256, size=(7, 9, 3), dtype=np.uint8)
    (tmp_path / "pictures").mkdir()
    (tmp_path / "pictures" / "grid.png").write_bytes(_png(picture, [0, 1, 2, 3, 4]))
    np.save(tmp_path / "pictures" / "grid.npy", picture)
    for name in ("grid.png", "grid.npy"):
        document = quad_document({"image": f"pictures/{name}", "interpolation": "closest"})
        (tmp_path / "scene.json").write_text(__import__("json").dumps(document))
        from tracer.scene.loader import load_scene

        texture = load_scene(tmp_path / "scene.json").materials["tex"].texture
        assert np.array_equal(texture.pixels, tx.linear_pixels(picture, "sRGB")), name
        assert texture.source.endswith(name)


def test_instances_of_a_textured_mesh_show_the_texture_and_emission_textures_glow() -> None:
    texture = {"pixels": TEXELS, "colorspace": "linear", "interpolation": "closest"}
    document = quad_document(texture)
    quad = document["objects"].pop()
    document["meshes"] = {"quad": {k: quad[k] for k in ("vertices", "triangles", "uvs", "material")}}
    document["objects"] = [{"type": "instances", "name": "quads", "mesh": "quad", "matrices": [[1, 0, 0, 0] * 3]}]
    document["objects"][0]["matrices"] = [[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]]
    image = render(scene_from_dict(document), workers=1).image
    expected = expected_texels(np.asarray(TEXELS, dtype=np.float32), *pixel_uvs(), "closest", "repeat")
    assert np.array_equal(image, expected)
    # an emission texture: lit by nothing, the quad shows its emission's texels
    document["lights"] = []
    document["materials"]["tex"] = {"color": [0.5, 0.5, 0.5], "emission_texture": texture}
    assert np.array_equal(render(scene_from_dict(document), workers=1).image, expected)


def test_hits_without_uvs_keep_the_materials_colour() -> None:
    document = quad_document({"pixels": TEXELS})
    del document["objects"][0]["uvs"]
    assert np.all(render(scene_from_dict(document), workers=1).image == 0.5)


@pytest.mark.parametrize(
    ("texture", "message"),
    [
        ({}, 'materials.tex.texture: must give its pixels either inline ("pixels") or by a file\'s path ("image")'),
        ({"pixels": TEXELS, "image": "a.png"}, "materials.tex.texture: must give its pixels either inline"),
        ({"pixels": [[[1, 0, 0]], [[1, 0, 0], [0, 1, 0]]]}, "materials.tex.texture.pixels: must be a non-empty list"),
        ({"pixels": [[[1, 0, "red"]]]}, "materials.tex.texture.pixels[0]: must hold numbers only"),
        ({"pixels": [[[1, 0]]]}, "materials.tex.texture.pixels: must be an image of (height, width[, 1, 3 or 4])"),
        (
            {"pixels": [[[0.5, 0, 0], [0, float("nan"), 0]]], "colorspace": "linear"},
            "materials.tex.texture.pixels: texel (row 0, column 1) must be a finite number within +-1000000, got nan",
        ),
        (
            {"pixels": [[[0, 0, 2e6]]], "colorspace": "linear"},
            "materials.tex.texture.pixels: texel (row 0, column 0) must be a finite number within +-1000000, got "
            "2000000",
        ),
        ({"pixels": TEXELS, "extension": "MIRROR"}, 'materials.tex.texture.extension: must be one of "repeat"'),
        ({"pixels": TEXELS, "interpolation": "cubic"}, 'materials.tex.texture.interpolation: must be one of "linear"'),
        ({"pixels": TEXELS, "colorspace": "Non-Color"}, 'materials.tex.texture.colorspace: must be one of "sRGB"'),
        ({"pixels": TEXELS, "size": 3}, "materials.tex.texture.size: is not a known field"),
        ({"image": "missing.png"}, 'materials.tex.texture.image: "missing.png" cannot be read'),
        ({"image": 7}, "materials.tex.texture.image: must be a file's path (a non-empty string), got number 7"),
    ],
)
def test_the_loader_names_each_problem_of_a_texture(texture: dict, message: str) -> None:
    with pytest.raises(SceneError) as raised:
        scene_from_dict(quad_document(texture))
    assert any(line.startswith(message) for line in raised.value.problems), raised.value.problems


def test_the_loader_names_bad_uvs_and_bad_files(tmp_path) -> None:
    document = quad_document({"pixels": TEXELS})
    document["objects"][0]["uvs"] = document["objects"][0]["uvs"][:1]
    with pytest.raises(SceneError, match=r"objects\[0\]\.uvs: must be a list of 2 triangles' corner UVs"):
        scene_from_dict(document)
    document = quad_document({"pixels": TEXELS})
    document["objects"][0]["uvs"][1][2] = [0.5, None]
    with pytest.raises(SceneError, match=r"objects\[0\]\.uvs\[1\]: must be 3 corner UVs \[u, v\]"):
        scene_from_dict(document)
    (tmp_path / "not.png").write_bytes(b"hello, world")
    with pytest.raises(SceneError, match=r"must be a PNG or \.npy image file"):
        scene_from_dict(quad_document({"image": str(tmp_path / "not.png")}))
    (tmp_path / "cut.png").write_bytes(_png(np.zeros((4, 4, 3), dtype=np.uint8), [0])[:40])
    with pytest.raises(SceneError, match=r"not a complete PNG file|damaged PNG data"):
        scene_from_dict(quad_document({"image": str(tmp_path / "cut.png")}))


def textured_scene_document(seed: int, width: int = 16, height: int = 12) -> dict[str, Any]:
    """extended_scene_document(seed) with corner UVs on its meshes (some of them in a meshes table, placed twice)
    and textures and emission textures of random pixels, interpolations, extensions and colour spaces."""
    document = extended_scene_document(seed, width, height)
    rng = random.Random(20_000 + seed)

    def random_texture() -> dict[str, Any]:
        rows, columns = rng.randrange(1, 6), rng.randrange(1, 6)
        return {
            "pixels": [[[rng.random() for _ in range(3)] for _ in range(columns)] for _ in range(rows)],
            "interpolation": rng.choice(["linear", "closest"]),
            "extension": rng.choice(["repeat", "extend", "clip"]),
            "colorspace": rng.choice(["sRGB", "linear"]),
        }

    for name, material in document["materials"].items():
        if name == "m0" or rng.random() < 0.7:  # m0 always: the wall below wears it
            material["texture"] = random_texture()
        if rng.random() < 0.25:
            material["emission_texture"] = random_texture()
    wall = [[-2.0, 2.0, -1.0], [2.0, 2.0, -1.0], [2.0, 2.0, 2.0], [-2.0, 2.0, 2.0], [0.0, 1.5, 0.5]]
    document["objects"].append(  # a wall behind the random objects, facing the camera: textures fill the picture
        {
            "type": "mesh",
            "name": "wall",
            "material": "m0",
            "vertices": wall,
            "triangles": [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
            "rotation": [0.0, 0.0, rng.uniform(-20, 20)],
        }
    )
    meshes = [body for body in document["objects"] if body["type"] == "mesh"]
    for body in meshes:
        body["uvs"] = [[[rng.uniform(-1.5, 2.5), rng.uniform(-1.5, 2.5)] for _ in range(3)] for _ in body["triangles"]]
    if meshes and rng.random() < 0.6:
        body = meshes[0]
        keys = ("vertices", "triangles", "normals", "uvs", "material", "materials", "material_indices")
        document["meshes"] = {"shared": {k: body[k] for k in keys if k in body}}
        document["objects"].append(
            {
                "type": "instances",
                "name": "placed",
                "mesh": "shared",
                "matrices": [
                    [[0.8, 0.1, 0, rng.uniform(-1, 1)], [0, 0.9, 0.2, rng.uniform(-1, 1)], [0, 0, 1.1, 0.3]],
                    [[-1, 0, 0, rng.uniform(-1, 1)], [0, 1, 0, 0], [0, 0, 1, rng.uniform(0, 1)]],
                ],
            }
        )
    return document


@pytest.mark.parametrize("seed", range(8))
def test_textured_scenes_render_the_same_in_workers_and_bands_and_their_passes_add_up(seed: int) -> None:
    document = textured_scene_document(seed, width=24, height=18)
    document["render"]["samples"] = [1, 4][seed % 2]
    document["render"]["dtype"] = ["float64", "float64", "float32"][seed % 3]
    plain = scene_from_dict(document)
    names = tuple(name for name in ps.PASSES if not name.startswith("cryptomatte"))
    expected, result = render(plain, workers=1), render(plain.with_render(passes=names), workers=2)
    assert np.array_equal(result.image, expected.image)
    total = sum(result.passes[name].astype(np.float64) for name in ps.WHITTED)
    tolerance = 8 * np.finfo(result.image.dtype).eps * np.maximum(1.0, np.abs(result.image))
    assert np.all(np.abs(total - result.image) <= tolerance)


def test_random_textured_scenes_use_textures() -> None:
    """The random scenes above do show textures: without their textures most of them render differently."""
    differs = 0
    for seed in range(8):
        document = textured_scene_document(seed)
        plain = {**document, "materials": {k: {f: x for f, x in m.items() if "texture" not in f} for k, m in
                                           document["materials"].items()}}  # fmt: skip
        document["render"].pop("border", None)
        differs += not np.array_equal(
            render(scene_from_dict(document), workers=1).image, render(scene_from_dict(plain), workers=1).image
        )
    assert differs == 8


def _with_alpha(result) -> np.ndarray:
    if result.alpha is None:
        return result.image
    return np.concatenate((result.image, result.alpha[..., None]), axis=2)


@pytest.mark.parametrize("seed", range(30))
def test_random_textured_scenes_match_the_reference(seed: int) -> None:
    """The vectorized tracer and the per-pixel reference (texturing.sample and sample_one) agree to 1e-9."""
    scene = scene_from_dict(textured_scene_document(seed))
    expected = np.asarray(render_reference(scene))
    image = _with_alpha(render(scene, workers=1))
    assert image.shape == expected.shape and np.all(np.isfinite(image))
    np.testing.assert_allclose(image, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_random_textured_scene_passes_match_the_reference(seed: int) -> None:
    check_against_reference(scene_from_dict(with_passes(textured_scene_document(seed), seed, samples=(1, 4)[seed % 2])))


# ---- procedural textures: Checker and Gradient (with a colour ramp) ------------------------------------------------


def checker_expected(u: np.ndarray, v: np.ndarray, scale: float, one, two) -> np.ndarray:
    """Cycles' svm_checker written out on its own: p = (u, v, 0) scale nudged by (p + 1e-6) 0.999999, |floor| of
    each, color1 where (xi % 2 == yi % 2) == (zi % 2)."""
    xi, yi, zi = (np.abs(np.floor((c * scale + 1e-6) * 0.999999)).astype(np.int64) for c in (u, v, np.zeros_like(u)))
    first = (xi % 2 == yi % 2) == (zi % 2 == 1)
    return np.where(first[..., None], np.asarray(one, dtype=np.float64), np.asarray(two, dtype=np.float64))


@pytest.mark.parametrize(("scale", "uv_scale", "uv_offset"), [(5.0, 1.0, 0.0), (3.7, 2.7, -0.8), (-2.5, 1.0, 0.1)])
def test_a_checker_is_cycles_svm_checker_on_the_uv(scale: float, uv_scale: float, uv_offset: float) -> None:
    one, two = [0.9, 0.2, 0.1], [0.1, 0.3, 0.8]
    texture = {"checker": {"color1": one, "color2": two, "scale": scale}}
    image = render(scene_from_dict(quad_document(texture, uv_scale, uv_offset)), workers=1).image
    u, v = pixel_uvs(uv_scale, uv_offset)
    expected = checker_expected(u, v, scale, one, two)
    assert np.array_equal(image, expected)
    share = np.mean(np.all(image == np.float64(one), axis=2))
    assert 0.3 < share < 0.7  # both colours show


def test_a_checker_of_scale_5_has_5_cells_a_side_and_color2_at_the_origin() -> None:
    texture = {"checker": {"color1": [1, 1, 1], "color2": [0, 0, 0]}}  # Blender's default scale, 5
    image = render(scene_from_dict(quad_document(texture)), workers=1).image[..., 0]
    cell = SIZE // 6  # 48 pixels, 5 cells: the pixel centres at 4.8 k + 2.4 are well inside cell k
    centres = (np.arange(5) * SIZE / 5 + SIZE / 10).astype(int)
    assert cell > 0
    rows = image[SIZE - 1 - centres][:, centres]  # rows from the bottom (v = 0) up, columns from u = 0
    assert np.array_equal(rows, (np.add.outer(np.arange(5), np.arange(5)) % 2).astype(float))


def gradient_expected(kind: str, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cycles' svm_gradient of (x, y, 0), saturated, written out on its own."""
    formulas = {
        "linear": lambda: x,
        "quadratic": lambda: np.clip(x, 0, None) ** 2,
        "easing": lambda: 3 * np.clip(x, 0, 1) ** 2 - 2 * np.clip(x, 0, 1) ** 3,
        "diagonal": lambda: (x + y) / 2,
        "radial": lambda: np.arctan2(y, x) / (2 * np.pi) + 0.5,
        "quadratic_sphere": lambda: np.clip(0.999999 - np.hypot(x, y), 0, None) ** 2,
        "spherical": lambda: np.clip(0.999999 - np.hypot(x, y), 0, None),
    }
    return np.clip(formulas[kind](), 0.0, 1.0)


@pytest.mark.parametrize(
    "kind", ["linear", "quadratic", "easing", "diagonal", "radial", "quadratic_sphere", "spherical"]
)
def test_a_gradient_is_cycles_svm_gradient_on_the_uv_grey_by_default(kind: str) -> None:
    image = render(scene_from_dict(quad_document({"gradient": {"type": kind}}, 2.4, -1.2)), workers=1).image
    expected = gradient_expected(kind, *pixel_uvs(2.4, -1.2))
    assert np.abs(image - expected[..., None]).max() <= 1e-12
    assert expected.max() - expected.min() > 0.5  # the gradient shows


def test_a_gradient_through_a_colour_ramp_linear_and_constant() -> None:
    positions, colors = [0.2, 0.5, 0.5, 0.9], np.asarray([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    stops = [[p, c] for p, c in zip(positions, colors.tolist(), strict=True)]
    f = gradient_expected("diagonal", *pixel_uvs(1.2, -0.1))
    for interpolation in ("linear", "constant"):
        texture = {"gradient": {"type": "diagonal", "stops": stops, "interpolation": interpolation}}
        image = render(scene_from_dict(quad_document(texture, 1.2, -0.1)), workers=1).image
        if interpolation == "linear":  # piecewise linear between the stops, the end colours beyond them
            below = f < 0.5
            expected = np.stack(
                [np.where(below, np.interp(f, positions[:2], colors[:2, k]), np.interp(f, positions[2:], colors[2:, k]))
                 for k in range(3)], axis=-1)  # fmt: skip
        else:  # the last stop at or below f; before the first, the first
            expected = colors[np.maximum(np.searchsorted(positions, f, side="right") - 1, 0)]
        away = np.min(np.abs(f[..., None] - np.asarray(positions)), axis=-1) > 1e-9  # the hit's UV is rounded
        assert np.abs(image - expected)[away].max() <= 1e-12, interpolation
        shown = len({tuple(c) for c in image.reshape(-1, 3).round(6).tolist()})
        assert shown >= (3 if interpolation == "constant" else 50)  # constant: green (at 0.5 with blue) never shows


PROCEDURAL = "materials.tex.texture"  # the path the messages below start with
STOPS = "must be a non-empty list of colour ramp stops"


@pytest.mark.parametrize(
    ("texture", "message"),
    [
        ({"checker": {"color1": [2, 0, 0]}}, ".checker.color1[0]: must be <= 1, got 2"),
        ({"checker": {"scale": "big"}}, ".checker.scale: must be a number"),
        ({"checker": {"colour": [1, 0, 0]}}, ".checker.colour: is not a known field"),
        ({"checker": 5}, ".checker: must be an object, got number 5"),
        ({"checker": {}, "pixels": TEXELS}, ': must give "checker" alone: a procedural texture has no "pixels"'),
        ({"gradient": {"type": "ease"}}, '.gradient.type: must be one of "linear"'),
        ({"gradient": {"interpolation": "ease"}}, '.gradient.interpolation: must be one of "linear", "constant"'),
        ({"gradient": {"stops": []}}, f".gradient.stops: {STOPS}"),
        ({"gradient": {"stops": [[0.5, [1, 1, 1]], [0.2, [0, 0, 0]]]}}, f".gradient.stops[1]: {STOPS} [position, [r, "),
        ({"gradient": {"stops": [[1.5, [1, 1, 1]]]}}, ".gradient.stops[0]: must be <= 1, got 1.5"),
        (
            {"gradient": {"stops": [[0.5, [1, 1]]]}},
            ".gradient.stops[0][1]: must be a colour [r, g, b], got a list of 2",
        ),
        ({"gradient": {"stops": [0.5]}}, f".gradient.stops[0]: {STOPS}"),
        ({"checker": {}, "uv_scale": [1, 2, 3]}, ".uv_scale: must be a list of 2 numbers, got a list of 3"),
        ({"pixels": TEXELS, "uv_offset": [0, "a"]}, ".uv_offset[1]: must be a number"),
    ],
)
def test_the_loader_names_each_problem_of_a_procedural_texture(texture: dict, message: str) -> None:
    with pytest.raises(SceneError) as raised:
        scene_from_dict(quad_document(texture))
    assert any(line.startswith(PROCEDURAL + message) for line in raised.value.problems), raised.value.problems


def procedural_scene_document(seed: int, width: int = 16, height: int = 12) -> dict[str, Any]:
    """textured_scene_document(seed) with some of its textures (and emission textures) replaced by checkers and
    gradients of random colours, scales, types and ramps (their own random stream)."""
    document = textured_scene_document(seed, width, height)
    rng = random.Random(30_000 + seed)

    def colour() -> list[float]:
        return [rng.random() for _ in range(3)]

    def procedural() -> dict[str, Any]:
        if rng.random() < 0.5:
            return {"checker": {"color1": colour(), "color2": colour(), "scale": rng.choice([5.0, rng.uniform(-9, 9)])}}
        positions = sorted(rng.choice([0.0, 0.5, 1.0, rng.random()]) for _ in range(rng.randrange(1, 5)))
        gradient: dict[str, Any] = {"type": rng.choice(["linear", "quadratic", "easing", "diagonal", "radial",
                                                        "quadratic_sphere", "spherical"])}  # fmt: skip
        if rng.random() < 0.8:
            gradient["stops"] = [[p, colour()] for p in positions]
            gradient["interpolation"] = rng.choice(["linear", "constant"])
        return {"gradient": gradient}

    for name, material in document["materials"].items():
        for field in ("texture", "emission_texture"):
            if field in material and (name == "m0" or rng.random() < 0.7):
                material[field] = procedural()
            if field in material and rng.random() < 0.4:  # a Mapping node before it
                material[field]["uv_scale"] = [rng.uniform(-3, 3), rng.uniform(-3, 3)]
                material[field]["uv_offset"] = [rng.uniform(-2, 2), rng.uniform(-2, 2)]
    return document


@pytest.mark.parametrize("interpolation", ["closest", "linear"])
def test_a_mapping_reads_the_uv_scaled_and_offset(interpolation: str) -> None:
    """uv_scale and uv_offset on the texture equal the same scale and offset on the quad's UVs (Cycles' lookup
    written out in expected_texels), for an image, and for a checker and a gradient (their formulas above)."""
    image = {"pixels": TEXELS, "colorspace": "linear", "interpolation": interpolation}
    mapping = {"uv_scale": [2.7, 2.7], "uv_offset": [-0.8, -0.8]}
    found = render(scene_from_dict(quad_document({**image, **mapping})), workers=1).image
    u, v = pixel_uvs(2.7, -0.8)
    expected = expected_texels(np.asarray(TEXELS, dtype=np.float32), u, v, interpolation, "repeat")
    assert np.abs(found - expected).max() <= 1e-9
    mapping = {"uv_scale": [1.5, -2.0], "uv_offset": [0.25, 1.5]}
    u, v = pixel_uvs()
    u, v = u * 1.5 + 0.25, v * -2.0 + 1.5
    checker = {"checker": {"color1": [1, 0, 0], "color2": [0, 0, 1], "scale": 3.0}, **mapping}
    found = render(scene_from_dict(quad_document(checker)), workers=1).image
    edges = np.minimum(np.abs(u * 3 - np.round(u * 3)), np.abs(v * 3 - np.round(v * 3))) > 1e-6
    assert np.array_equal(found[edges], checker_expected(u, v, 3.0, [1, 0, 0], [0, 0, 1])[edges])
    gradient = {"gradient": {"type": "diagonal"}, **mapping}
    found = render(scene_from_dict(quad_document(gradient)), workers=1).image
    assert np.abs(found - gradient_expected("diagonal", u, v)[..., None]).max() <= 1e-9


@pytest.mark.parametrize("seed", range(16))
def test_random_procedural_scenes_match_the_reference(seed: int) -> None:
    """The vectorized tracer and the per-pixel reference agree to 1e-9 on checkers and gradients."""
    document = procedural_scene_document(seed)
    scene = scene_from_dict(document)
    assert any(m.texture is not None and m.texture.kind != "image" for m in scene.materials.values())
    expected = np.asarray(render_reference(scene))
    image = _with_alpha(render(scene, workers=1))
    assert image.shape == expected.shape and np.all(np.isfinite(image))
    np.testing.assert_allclose(image, expected, rtol=0, atol=1e-9)
    plain = dict(document, materials={k: {f: x for f, x in m.items() if "texture" not in f}
                                      for k, m in document["materials"].items()})  # fmt: skip
    plain["render"].pop("border", None)
    document["render"].pop("border", None)
    differs = not np.array_equal(render(scene_from_dict(document), workers=1).image,
                                 render(scene_from_dict(plain), workers=1).image)  # fmt: skip
    assert differs or seed not in range(4)  # the first scenes show their textures


@pytest.mark.parametrize("seed", range(4))
def test_random_procedural_scenes_in_workers_and_their_passes(seed: int) -> None:
    document = procedural_scene_document(seed, width=24, height=18)
    document["render"]["samples"] = [1, 4][seed % 2]
    plain = scene_from_dict(document)
    names = tuple(name for name in ps.PASSES if not name.startswith("cryptomatte"))
    expected, result = render(plain, workers=1), render(plain.with_render(passes=names), workers=2)
    assert np.array_equal(result.image, expected.image)
    check_against_reference(
        scene_from_dict(with_passes(procedural_scene_document(seed), seed, samples=(1, 4)[seed % 2]))
    )


def test_procedural_scenes_follow_the_schema_and_it_refuses_a_checker_beside_pixels() -> None:
    import json
    from pathlib import Path

    import jsonschema

    schema = json.loads((Path(__file__).resolve().parents[1] / "docs" / "scene.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    for seed in range(6):
        validator.validate(procedural_scene_document(seed))
    for texture in (
        {"checker": {}, "pixels": TEXELS},
        {"gradient": {"stops": [[2, [1, 1, 1]]]}},
        {"checker": {"x": 1}},
    ):
        assert not validator.is_valid(quad_document(texture)), texture
        with pytest.raises(SceneError):
            scene_from_dict(quad_document(texture))


# --- corner colours (Blender's colour attributes) ---------------------------------------------------------------------

CORNER_COLORS = [[0.9, 0.1, 0.2], [0.1, 0.8, 0.3], [0.2, 0.3, 0.95], [1.0, 1.0, 0.0]]  # the quad's four vertices'


def corner_document(gain=(0.8, 1.2, 1.0), bias=(0.1, -0.05, 0.0)) -> dict[str, Any]:
    """quad_document with the four vertices' colours per triangle corner and an "attribute" texture."""
    document = quad_document({"attribute": {"gain": list(gain), "bias": list(bias)}})
    quad = document["objects"][0]
    quad["colors"] = [[CORNER_COLORS[k] for k in triangle] for triangle in quad["triangles"]]
    del quad["uvs"]
    return document


def expected_corner_colors(gain, bias) -> np.ndarray:
    """Each pixel's colour written out here: the corner colours weighted by the pixel centre's barycentric
    coordinates in its triangle ((0, 1, 2) below the diagonal x = y, (0, 2, 3) above), then gain c + bias clamped."""
    x, y = pixel_uvs()
    c = np.asarray(CORNER_COLORS)
    lower = x >= y
    first = (1 - x)[..., None] * c[0] + (x - y)[..., None] * c[1] + y[..., None] * c[2]
    second = (1 - y)[..., None] * c[0] + x[..., None] * c[2] + (y - x)[..., None] * c[3]
    colors = np.where(lower[..., None], first, second)
    return np.clip(colors * np.asarray(gain) + np.asarray(bias), 0.0, 1.0)


def test_corner_colours_are_interpolated_over_each_triangle_and_mapped_by_gain_and_bias() -> None:
    gain, bias = (0.8, 1.2, 1.0), (0.1, -0.05, 0.0)
    scene = scene_from_dict(corner_document(gain, bias))
    image = render(scene, workers=1).image
    assert np.abs(image - expected_corner_colors(gain, bias)).max() <= 1e-9
    assert np.abs(np.asarray(render_reference(scene)) - image).max() <= 1e-9


def test_instances_of_a_mesh_with_corner_colours_show_them() -> None:
    document = corner_document()
    quad = document["objects"].pop()
    document["meshes"] = {"quad": {k: quad[k] for k in ("vertices", "triangles", "colors", "material")}}
    document["objects"] = [
        {"type": "instances", "name": "quads", "mesh": "quad", "matrices": [[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]]}
    ]
    scene = scene_from_dict(document)
    image = render(scene, workers=1).image
    assert np.abs(image - expected_corner_colors((0.8, 1.2, 1.0), (0.1, -0.05, 0.0))).max() <= 1e-9
    assert np.abs(np.asarray(render_reference(scene)) - image).max() <= 1e-9


def test_an_attribute_texture_on_a_mesh_without_colours_keeps_the_materials_colour_and_uvs_are_not_colours() -> None:
    document = corner_document()
    del document["objects"][0]["colors"]
    image = render(scene_from_dict(document), workers=1).image
    assert np.allclose(image, 0.5)
    document = quad_document({"pixels": TEXELS, "colorspace": "linear"})  # an image texture ignores corner colours
    document["objects"][0]["colors"] = corner_document()["objects"][0]["colors"]
    with_colors = render(scene_from_dict(document), workers=1).image
    del document["objects"][0]["colors"]
    assert np.array_equal(with_colors, render(scene_from_dict(document), workers=1).image)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"texture": {"attribute": {"gain": [1, 1]}}}, "materials.tex.texture.attribute.gain: must be"),
        ({"texture": {"attribute": {}, "uv_scale": [2, 2]}}, 'must give "attribute" alone'),
        ({"colors": [[[1, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]]}, "objects[0].colors[0]: must be 3"),
        ({"texture": {"attribute": {"name": 7}}}, "materials.tex.texture.attribute.name: must be a colour attribute's"),
        ({"texture": {"pixels": TEXELS, "uv_map": ["UV"]}}, "materials.tex.texture.uv_map: must be a UV map's name"),
        ({"texture": {"pixels": TEXELS, "uv_rotation": "15"}}, "materials.tex.texture.uv_rotation: must be a number"),
    ],
)
def test_the_loader_names_bad_corner_colours_and_attribute_textures(change: dict, message: str) -> None:
    document = corner_document()
    if "texture" in change:
        document["materials"]["tex"]["texture"] = change["texture"]
    else:
        document["objects"][0].update(change)
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert any(message in problem for problem in caught.value.problems), caught.value.problems


def test_corner_colour_scenes_follow_the_schema() -> None:
    import json
    from pathlib import Path

    import jsonschema

    schema = json.loads((Path(__file__).resolve().parents[1] / "docs" / "scene.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    validator.validate(corner_document())
    assert not validator.is_valid(quad_document({"attribute": {}, "pixels": TEXELS}))


@pytest.mark.parametrize("interpolation", ["closest", "linear"])
def test_a_rotated_mapping_turns_the_scaled_uv_before_the_offset(interpolation: str) -> None:
    """uv_rotation (degrees): the texture reads R (u su, v sv) + (ou, ov), written out here on its own, for an
    image and a checker; the per-pixel reference agrees."""
    image = {"pixels": TEXELS, "colorspace": "linear", "interpolation": interpolation}
    mapping = {"uv_scale": [0.4, 0.8], "uv_offset": [0.5, 0.4], "uv_rotation": 15.0}
    scene = scene_from_dict(quad_document({**image, **mapping}))
    found = render(scene, workers=1).image
    u, v = pixel_uvs()
    angle = np.radians(15.0)
    x, y = u * 0.4, v * 0.8
    turned_u, turned_v = x * np.cos(angle) - y * np.sin(angle) + 0.5, x * np.sin(angle) + y * np.cos(angle) + 0.4
    expected = expected_texels(np.asarray(TEXELS, dtype=np.float32), turned_u, turned_v, interpolation, "repeat")
    assert np.abs(found - expected).max() <= 1e-9
    assert np.abs(np.asarray(render_reference(scene)) - found).max() <= 1e-9
    checker = {"checker": {"color1": [1, 0, 0], "color2": [0, 0, 1], "scale": 3.0}, **mapping}
    found = render(scene_from_dict(quad_document(checker)), workers=1).image
    a, b = turned_u * 3, turned_v * 3
    edges = np.minimum(np.abs(a - np.round(a)), np.abs(b - np.round(b))) > 1e-6
    assert np.array_equal(found[edges], checker_expected(turned_u, turned_v, 3.0, [1, 0, 0], [0, 0, 1])[edges])


def test_a_large_read_only_inline_texture_is_converted_once_and_a_changed_one_again() -> None:
    """A document's texture given as a read-only array of 1 MB or more (the Rendered view hands the same one over on
    every change) is converted and checked once: the next load takes the same linear texels; a writeable array, or
    another array with other bits, is converted again, and a bad texel is refused every time."""
    from tracer.scene import loader

    pixels = np.full((512, 512, 3), 0.5, dtype=np.float32)  # 3 MB
    pixels[0, 0] = [0.25, 0.5, 1.0]
    writeable = pixels.copy()
    pixels.flags.writeable = False

    def texels(values: np.ndarray, colorspace: str = "sRGB") -> np.ndarray:
        document = quad_document({"pixels": values, "colorspace": colorspace})
        return scene_from_dict(document).materials["tex"].texture.pixels

    first = texels(pixels)
    assert texels(pixels) is first and np.array_equal(first, tx.linear_pixels(pixels, "sRGB"))
    assert np.array_equal(texels(pixels, "linear"), pixels) and texels(pixels, "linear") is not first
    assert texels(writeable) is not texels(writeable) and np.array_equal(texels(writeable), first)
    other = pixels.copy()
    other[1, 1] = [1.0, 0.0, 0.0]
    other.flags.writeable = False
    assert not np.array_equal(texels(other), first)
    bad = pixels.copy()
    bad[2, 3, 1] = np.nan
    bad.flags.writeable = False
    for _ in range(2):
        with pytest.raises(SceneError, match=r"texel \(row 2, column 3\)"):
            texels(bad)
    assert len(loader._checked_texels) <= loader.TEXELS_KEPT
