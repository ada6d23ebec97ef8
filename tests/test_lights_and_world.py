"""Area lights, a sun's angle and soft shadows (render.shadow_samples), and the image background (an
equirectangular world): loader messages, analytic checks, the per-pixel reference to 1e-9, the passes, and nothing
changed for scenes without them."""

from __future__ import annotations

import math
import random
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import extended_scene_document, see_through_scene_document
from tests.tracing import assert_matches_reference
from tracer.geometry import camera as cam
from tracer.geometry import lightsamples
from tracer.scene import passes as ps
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, default_scene_dict, scene_from_dict
from tracer.tracing.surfaces import environment
from tracer.workers.parallel import render


def _problems(document: dict) -> list[str]:
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    return caught.value.problems


# ---- the loader -------------------------------------------------------------------------------------------------


def test_area_lights_sun_angles_and_shadow_samples_are_checked_with_clear_messages() -> None:
    document = default_scene_dict()
    document["lights"] += [
        {
            "type": "area",
            "location": [0, 0, 3],
            "direction": [0, 0, -1],
            "x_axis": [0, 0, 2],
            "size": 1,
            "intensity": 1,
        },
        {
            "type": "area",
            "location": [0, 0, 3],
            "direction": [0, 0, -1],
            "shape": "disk",
            "size": [1, 2],
            "intensity": 1,
        },
        {"type": "area", "location": [0, 0, 3], "direction": [0, 0, -1], "shape": "hexagon", "size": 1, "intensity": 1},
        {"type": "area", "location": [0, 0, 3], "direction": [0, 0, 0], "size": 0, "intensity": 1},
        {"type": "directional", "direction": [0, 0, 1], "intensity": 1, "angle": 200},
        {"type": "point", "location": [0, 0, 3], "intensity": 1, "radius": -1},
    ]
    document["render"]["shadow_samples"] = 8
    problems = _problems(document)
    assert "lights[3].x_axis: must not lie along direction (0, 0, -1), got [0, 0, 2]" in problems
    assert "lights[4].size: must be one length for a disk ([x, y] is for a rectangle or an ellipse)" in problems
    assert any(
        p.startswith('lights[5].shape: must be one of "square", "rectangle", "disk", "ellipse"') for p in problems
    )
    assert "lights[6].direction: must not be the zero vector, got [0, 0, 0]" in problems
    assert "lights[6].size: must be > 0, got 0" in problems
    assert "lights[7].angle: must be <= 180, got 200" in problems
    assert "lights[8].radius: must be >= 0, got -1" in problems
    assert any(p.startswith("render.shadow_samples: must be a perfect square") for p in problems)
    document = default_scene_dict()
    document["lights"].append({"type": "lamp", "intensity": 1})
    assert _problems(document) == [
        'lights[3].type: must be one of "ambient", "point", "directional", "spot", "area", "world", got "lamp"'
    ]


def test_an_image_background_is_checked_with_clear_messages(tmp_path) -> None:
    def problems(background: dict) -> list[str]:
        document = default_scene_dict()
        document["background"] = background
        return _problems(document)

    assert problems({"type": "image"}) == [
        'background.image: give the picture either by a file\'s path ("image") or inline ("pixels"): one of them is '
        "required"
    ]
    both = problems({"type": "image", "image": "a.npy", "pixels": [[[0, 0, 0]]]})
    assert both == [
        'background.pixels: give the picture either by a file\'s path ("image") or inline ("pixels"), not both'
    ]
    assert problems({"type": "sky", "pixels": [[[0, 0, 0]]]}) == [
        'background.pixels: is a field of the "image" background only, got type "sky"'
    ]
    missing = problems({"type": "image", "image": str(tmp_path / "nowhere.npy")})
    assert len(missing) == 1 and missing[0].startswith("background.image: ") and "cannot be read" in missing[0]
    assert problems({"type": "image", "pixels": [[[0, 0]]]}) == [
        "background.pixels: must be (height, width, 3 or 4) numbers, got shape [1, 1, 2]"
    ]
    assert problems({"type": "image", "pixels": [[[0, 0, 0]], [[0, 0, 0], [1, 1, 1]]]}) == [
        "background.pixels: must be rows of texels, each [r, g, b] numbers, every row as long (top row first)"
    ]
    assert problems({"type": "image", "pixels": [[[0, 0, 0], [0, float("inf"), 0]]], "colorspace": "linear"}) == [
        "background.pixels: texel (row 0, column 1) must be a finite number within +-1000000, got inf"
    ]
    # float pictures keep their slightly negative texels, as Blender holds them (its own HDRIs have a few)
    document = default_scene_dict()
    document["background"] = {"type": "image", "pixels": [[[0, 0, 0], [0, -4.47e-06, 0]]], "colorspace": "linear"}
    assert scene_from_dict(document).background.image[0, 1, 1] == np.float32(-4.47e-06)
    assert problems({"type": "image", "pixels": [[[0, 0, 0]]], "interpolation": "cubic"}) == [
        'background.interpolation: must be one of "linear", "closest", got "cubic"'
    ]
    np.save(tmp_path / "sky.npy", np.full((2, 4, 3), 0.5, dtype=np.float32))
    document = default_scene_dict()
    document["background"] = {"type": "image", "image": "sky.npy", "colorspace": "linear"}
    scene = scene_from_dict(document, "scene", tmp_path)  # relative to the scene file's folder
    assert scene.background.image.shape == (2, 4, 3) and np.all(scene.background.image == 0.5)


# ---- the image background ---------------------------------------------------------------------------------------


def _direction(u: float, v: float) -> np.ndarray:
    """The unit direction at equirectangular (u, v), Blender's convention (lightsamples.equirectangular)."""
    longitude, latitude = (0.5 - u) * 2.0 * math.pi, (v - 0.5) * math.pi
    return np.array(
        [math.cos(latitude) * math.cos(longitude), math.cos(latitude) * math.sin(longitude), math.sin(latitude)]
    )


def test_equirectangular_directions_as_blender_maps_them() -> None:
    # +X is the picture's centre, +Y a quarter from its left, -Y three quarters, the zenith its top row
    for D, (u, v) in [
        ((1, 0, 0), (0.5, 0.5)),
        ((0, 1, 0), (0.25, 0.5)),
        ((0, -1, 0), (0.75, 0.5)),
        ((0, 0, 1), (0.5, 1.0)),
        ((0, 0, -1), (0.5, 0.0)),
    ]:
        assert np.allclose(lightsamples.equirectangular(D, 0.0), (u, v), atol=1e-12)
    # a Mapping's Z rotation: the direction is turned by it before the lookup
    assert np.allclose(lightsamples.equirectangular((1, 0, 0), 90.0), (0.25, 0.5), atol=1e-12)


@pytest.mark.parametrize("interpolation", ["closest", "linear"])
def test_one_bright_texel_appears_where_its_direction_says(interpolation: str) -> None:
    height, width, row, column = 16, 32, 5, 9
    image = np.zeros((height, width, 3), dtype=np.float32)
    image[row, column] = (1.0, 2.0, 3.0)
    background = sc.Background(type="image", image=image, interpolation=interpolation)
    centre = _direction((column + 0.5) / width, (height - 1 - row + 0.5) / height)  # row 0 is the top
    assert np.allclose(environment(background, centre[:, None])[:, 0], (1.0, 2.0, 3.0), atol=1e-9)
    # a camera aimed at that direction sees it at the image's centre, and nowhere else far from it
    elevation, heading = math.degrees(math.asin(centre[2])), math.degrees(math.atan2(centre[1], centre[0]))
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(90.0 + elevation, 0.0, heading - 90.0), lens=50.0)
    settings = sc.RenderSettings(width=41, height=31)
    scene = sc.Scene({"m": sc.Material()}, (), (), camera, background, settings)
    picture = render(scene, workers=1).image
    bright = np.argwhere(picture[..., 0] > 0.5)
    assert bright.size and np.allclose(bright.mean(axis=0), (15.0, 20.0), atol=1.5)
    assert picture[15, 20, 2] == pytest.approx(3.0 * picture[15, 20, 0], rel=1e-6)
    pixels = np.arange(41 * 31)
    directions = cam.pixel_directions(camera, settings, pixels)
    assert np.argmax(centre @ directions) == 15 * 41 + 20


def _random_image(rng: random.Random, height: int, width: int) -> list:
    return [[[rng.uniform(0.0, 2.0) for _ in range(3)] for _ in range(width)] for _ in range(height)]


def _world_document(seed: int) -> dict:
    document = extended_scene_document(seed, width=20, height=15)
    rng = random.Random(20_000 + seed)
    document["background"] = {
        "type": "image",
        "pixels": _random_image(rng, rng.randrange(1, 9), rng.randrange(1, 17)),
        "colorspace": rng.choice(["linear", "sRGB"]),
        "rotation": rng.choice([0.0, 30.0, -145.0]),
        "strength": rng.choice([1.0, 0.6]),
        "interpolation": rng.choice(["linear", "closest"]),
    }
    document["render"]["depth"] = max(2, document["render"]["depth"])
    return document


@pytest.mark.parametrize("seed", range(16))
def test_image_backgrounds_match_the_reference(seed: int) -> None:
    assert_matches_reference(scene_from_dict(_world_document(seed)))


def test_an_image_background_is_seen_in_mirrors_and_travels_to_workers_once() -> None:
    document = _world_document(3)
    document["materials"] = {name: {**body, "reflective": 0.9} for name, body in document["materials"].items()}
    document["render"].pop("border", None)
    scene = scene_from_dict(document)
    one = render(scene, workers=1)
    assert np.array_equal(render(scene, workers=2).image, one.image)
    flat = scene_from_dict({**document, "background": {"type": "solid", "color": [0, 0, 0]}})
    assert not np.array_equal(render(flat, workers=1).image, one.image)


def test_the_environment_pass_holds_the_image_background_and_the_passes_add_up() -> None:
    scene = scene_from_dict(_world_document(1)).with_render(passes=ps.WHITTED)
    result = render(scene, workers=1)
    total = sum(result.passes[name].astype(np.float64) for name in ps.WHITTED)
    assert np.all(np.abs(total - result.image) <= 8 * np.finfo(np.float64).eps * np.maximum(1.0, result.image))


# ---- area lights and soft shadows --------------------------------------------------------------------------------


def _plane_under(light: sc.Light, shadow_samples: int = 1, width: int = 64, box: float | None = None) -> sc.Scene:
    """A white plane z = 0 (matte), optionally a box of side `box` standing on it, seen from straight above."""
    objects: tuple = (sc.Plane(name="floor", material="white", size=(40.0, 40.0)),)
    if box is not None:
        objects += (sc.Box(name="box", material="white", location=(0.0, 0.0, box / 2.0), size=(box, box, box)),)
    camera = sc.Camera(location=(0.0, 0.0, 10.0), rotation=(0.0, 0.0, 0.0), type="ORTHO", ortho_scale=8.0)
    settings = sc.RenderSettings(width=width, height=width, shadow_samples=shadow_samples)
    materials = {"white": sc.Material(color=(1.0, 1.0, 1.0))}
    return sc.Scene(materials, objects, (light,), camera, sc.Background(type="none"), settings)


def test_a_small_area_light_is_a_cosine_emitter_with_inverse_square_falloff() -> None:
    # a tiny square light 3 m above the origin, facing down: i cos(theta_e) cos(theta_s) / d^2 = i cos^2 / d^2
    light = sc.AreaLight(location=(0.0, 0.0, 3.0), direction=(0.0, 0.0, -1.0), size=(1e-3, 1e-3), intensity=2.0)
    scene = _plane_under(light, shadow_samples=16, width=65)
    image = render(scene, workers=1).image[..., 0]
    x = (np.arange(65) + 0.5) / 65 * 8.0 - 4.0  # the ortho pixels' centres
    X, Y = np.meshgrid(x, -x)
    d2 = X**2 + Y**2 + 9.0
    expected = 2.0 * (3.0 / np.sqrt(d2)) ** 2 / d2
    # a pixel's pattern of 16 points sits a quarter of a cell (of 4) off the light's centre: a first-order error at
    # each pixel (6e-5 here), which its 2 x 2 block's four patterns (64 points around the centre) cancel to the
    # difference between its pixels' slopes (3e-6)
    assert np.allclose(image, expected, rtol=1e-4)
    blocks = [array[:64, :64].reshape(32, 2, 32, 2).mean(axis=(1, 3)) for array in (image, expected)]
    assert np.allclose(*blocks, rtol=1e-5)
    # 4x the point light of the same power straight under it (P/pi along its normal against P/(4 pi) every way)
    point = sc.PointLight(location=(0.0, 0.0, 3.0), intensity=0.5, falloff="inverse_square")
    assert np.allclose(
        render(_plane_under(point, width=65), workers=1).image[32, 32, 0], image[32, 32] / 4.0, rtol=1e-5
    )


def test_a_square_area_lights_irradiance_converges_to_the_analytic_one() -> None:
    # on the axis of a square of side a at height h the form factor is known in closed form (Howell's catalogue,
    # C-11 differential area to a parallel square): F = (2/pi) (x/sqrt(1+x^2) atan(x/sqrt(1+x^2))) with x = a/(2h),
    # times 2; the rendered diffuse value of a white plane is i pi F / A (i the intensity along the normal over pi^0)
    a, h, intensity = 2.0, 1.5, 1.0
    light = sc.AreaLight(location=(0.0, 0.0, h), direction=(0.0, 0.0, -1.0), size=(a, a), intensity=intensity)
    value = render(_plane_under(light, shadow_samples=1024, width=3), workers=1).image[1, 1, 0]
    x = a / (2.0 * h)
    form_factor = (2.0 / math.pi) * 2.0 * (x / math.sqrt(1 + x * x)) * math.atan(x / math.sqrt(1 + x * x))
    assert value == pytest.approx(intensity * math.pi * form_factor / (a * a), rel=2e-3)


def _penumbra(light: sc.Light) -> int:
    """Pixels on the row through the box's centre that are neither fully lit nor fully shadowed: the floor's
    brightness with the box over that without it, between 2% and 98% (the box's top, nearer the light, is above)."""
    shadowed = render(_plane_under(light, shadow_samples=16, width=200, box=1.0), workers=1).image
    open_floor = render(_plane_under(light, shadow_samples=16, width=200), workers=1).image
    ratio = shadowed[100, :, 0] / open_floor[100, :, 0]
    return int(np.count_nonzero((ratio > 0.02) & (ratio < 0.98)))


def _edge_penumbra(shadow_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The Shadow pass along a 512-pixel row of a floor under a 2 m square light at height 4, half of it shaded by a
    sheet at height 2 over x < 0 (its edge along the light's y axis), and the share of the light each pixel's point
    sees: from floor point x the sheet hides the light where x_light < x (1 - 4 / 2) = -x, a ramp over x in [-1, 1]."""
    light = sc.AreaLight(location=(0.0, 0.0, 4.0), direction=(0.0, 0.0, -1.0), size=(2.0, 2.0), intensity=10.0)
    objects = (
        sc.Plane(name="floor", material="white", size=(40.0, 40.0)),
        sc.Box(name="sheet", material="white", location=(-10.0, 0.0, 2.0005), size=(20.0, 40.0, 0.001)),
    )
    camera = sc.Camera(location=(0.0, 0.0, 1.0), rotation=(0.0, 0.0, 0.0), type="ORTHO", ortho_scale=3.0)
    settings = sc.RenderSettings(width=512, height=4, shadow_samples=shadow_samples, passes=("shadow",))
    materials = {"white": sc.Material(color=(1.0, 1.0, 1.0))}
    scene = sc.Scene(materials, objects, (light,), camera, sc.Background(type="none"), settings)
    shadow = render(scene, workers=1).passes["shadow"][..., 0]
    x = (np.arange(512) + 0.5) / 512 * 3.0 - 1.5  # the ortho pixels' centres
    return shadow, np.clip((1.0 + x) / 2.0, 0.0, 1.0)


def test_a_penumbra_has_a_step_for_every_sample_and_its_2x2_blocks_four_times_as_many() -> None:
    # each pixel's 16 points have an x of their own each (multi-jittered): the share it sees is within 1/16 of the
    # light's, where the 4 x 4 grid's 4 columns were within 1/8 (5 steps, 16 hard copies of the edge that differ in
    # y only); a 2 x 2 block's four patterns, 64 x's, step in 64ths
    shadow, seen = _edge_penumbra(16)
    assert np.all(np.abs(shadow - seen) <= 1.0 / 16.0 + 1e-9)
    assert len(np.unique(shadow[:2].round(9))) == 16 + 1  # every step, both rows of a block together
    blocks = shadow[:2].reshape(2, 256, 2).mean(axis=(0, 2))
    assert np.all(np.abs(blocks - seen.reshape(256, 2).mean(axis=1)) <= 1.5 / 64.0)
    # in the pass's ramp, blocks take a new value at least every 3 of them (the grid's: every 16)
    ramp = (blocks > 0.0) & (blocks < 1.0)
    assert len(np.unique(blocks[ramp].round(9))) >= ramp.sum() / 3
    # below PATTERNS_FROM (the Rendered view's 4) one multi-jittered set: 4 x's, within 1/8 (the 2 x 2 grid: 1/4)
    four, _ = _edge_penumbra(4)
    assert np.all(np.abs(four - seen) <= 1.0 / 8.0 + 1e-9) and len(np.unique(four.round(9))) == 4 + 1
    # one sample: the centre's hard edge at x = 0
    hard, _ = _edge_penumbra(1)
    assert set(np.unique(hard)) == {0.0, 1.0}


def test_soft_shadows_grow_with_the_lights_size() -> None:
    widths = []
    for size in (1e-3, 0.5, 1.0, 2.0):
        light = sc.AreaLight(location=(0.0, 0.0, 4.0), direction=(0.0, 0.0, -1.0), size=(size, size), intensity=10.0)
        widths.append(_penumbra(light))
    assert widths[0] == 0 and widths[0] < widths[1] < widths[2] < widths[3], widths
    # the floor is fully lit from where the box's top edge (height 1, half-width 0.5) hides no part of the light
    # (height 4, half-size 1): x = (0.5 * 4 + 1 * 1) / 3 = 1 m; the box hides the floor inside 0.5 m; both sides
    pixels_per_metre = 200 / 8.0
    assert widths[3] == pytest.approx(2 * (1.0 - 0.5) * pixels_per_metre, rel=0.2)
    points = []
    for radius in (0.0, 0.25, 1.0):
        points.append(_penumbra(sc.PointLight(location=(0.0, 0.0, 4.0), intensity=10.0, radius=radius)))
    assert points[0] == 0 < points[1] < points[2], points
    # the disk of radius 1 m facing the floor beside the box as the 2 m square does, nearly
    assert points[2] == pytest.approx(widths[3], rel=0.25)
    suns = []
    for angle in (0.0, 15.0, 40.0):
        suns.append(_penumbra(sc.DirectionalLight(direction=(0.0, 0.0, 1.0), intensity=1.0, angle=angle)))
    assert suns[0] == 0 < suns[1] < suns[2], suns


@pytest.mark.parametrize("shape", ["square", "rectangle", "disk", "ellipse"])
def test_the_sample_points_cover_the_lights_shape(shape: str) -> None:
    light = sc.AreaLight(
        location=(1.0, 2.0, 3.0),
        direction=(0.0, 0.0, -1.0),
        x_axis=(1.0, 1.0, 0.0),
        shape=shape,
        size=(2.0, 2.0) if shape in ("square", "disk") else (2.0, 1.0),
    )
    points = np.asarray(lightsamples.area_points(light, 256)) - (1.0, 2.0, 3.0)
    assert len(points) == lightsamples.PATTERNS * 256
    # centred: exactly on a rectangle (the strips are symmetric), within 0.2 mm on a disk of 1 m (the concentric
    # map of strips that are not)
    assert np.allclose(points.mean(axis=0), 0.0, atol=1e-9 if shape in ("square", "rectangle") else 2e-4)
    assert np.allclose(points[:, 2], 0.0)
    x_axis, y_axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), np.array([-1.0, 1.0, 0.0]) / math.sqrt(2.0)
    along_x, along_y = points @ x_axis / (light.size[0] / 2), points @ y_axis / (light.size[1] / 2)
    if shape in ("disk", "ellipse"):
        assert np.all(along_x**2 + along_y**2 <= 1.0 + 1e-12) and (along_x**2 + along_y**2).max() > 0.85
    else:
        assert np.all(np.abs(along_x) <= 1.0) and np.all(np.abs(along_y) <= 1.0) and np.abs(along_x).max() > 0.9
    assert lightsamples.area_points(light, 1) == [(1.0, 2.0, 3.0)]


def test_one_shadow_sample_is_todays_hard_shadow_to_the_byte() -> None:
    scene = default_scene().with_render(width=160, height=120, workers=1)
    today = render(scene, workers=1).image
    assert np.array_equal(render(scene.with_render(shadow_samples=1), workers=1).image, today)
    # the default scene's sun with an angle but one shadow sample: the same bytes; with 16 a softer picture
    lights = tuple(
        replace(light, angle=3.0) if isinstance(light, sc.DirectionalLight) else light for light in scene.lights
    )
    assert any(isinstance(light, sc.DirectionalLight) for light in lights)
    assert np.array_equal(render(replace(scene, lights=lights), workers=1).image, today)
    soft = render(replace(scene, lights=lights).with_render(shadow_samples=16), workers=1).image
    assert not np.array_equal(soft, today) and np.abs(soft - today).mean() < 0.01


def _soft_document(seed: int) -> dict:
    document = extended_scene_document(seed, width=20, height=15)
    rng = random.Random(30_000 + seed)
    for _ in range(rng.randrange(1, 3)):
        location = [rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(2, 5)]
        target = [rng.uniform(-1, 1), rng.uniform(-0.5, 1.5), rng.uniform(-0.5, 0.5)]
        shape = rng.choice(["square", "rectangle", "disk", "ellipse"])
        size = rng.uniform(0.2, 2.0) if shape in ("square", "disk") else [rng.uniform(0.2, 2.0), rng.uniform(0.2, 2.0)]
        document["lights"].append(
            {
                "type": "area",
                "location": location,
                "direction": [t - p for t, p in zip(target, location, strict=True)],
                "x_axis": _unit_random(rng),
                "shape": shape,
                "size": size,
                "intensity": rng.uniform(2.0, 10.0),
                "color": [rng.uniform(0.3, 1.2) for _ in range(3)],
            }
        )
    for light in document["lights"]:
        if light["type"] == "directional":
            light["angle"] = rng.choice([0.0, 2.0, 15.0])
        if light["type"] in ("point", "spot"):
            light["radius"] = rng.choice([0.0, 0.1, 0.5, 1.5])
    document["render"]["shadow_samples"] = rng.choice([1, 4, 9])
    return document


def _unit_random(rng: random.Random) -> list[float]:
    return [rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.3, 1)]


@pytest.mark.parametrize("seed", range(20))
def test_area_lights_sun_angles_and_light_radii_match_the_reference(seed: int) -> None:
    assert_matches_reference(scene_from_dict(_soft_document(seed)))


def _passes_add_up_and_workers_agree(scene: sc.Scene):
    """The scene rendered with the Whitted passes and Shadow by 2 workers: the same image as 1 worker's, and the
    passes adding up to it (to a few ULPs); -> that render."""
    result = render(scene.with_render(passes=(*ps.WHITTED, "shadow")), workers=2)
    assert np.array_equal(result.image, render(scene, workers=1).image)
    total = sum(result.passes[name].astype(np.float64) for name in ps.WHITTED)
    assert np.all(np.abs(total - result.image) <= 8 * np.finfo(np.float64).eps * np.maximum(1.0, np.abs(result.image)))
    return result


@pytest.mark.parametrize("seed", range(6))
def test_soft_lights_keep_the_passes_adding_up_and_workers_and_robust_numerics_agree(seed: int) -> None:
    document = _soft_document(seed)
    document["render"].pop("border", None)
    plain = scene_from_dict(document)
    result = _passes_add_up_and_workers_agree(plain)
    shadow = result.passes["shadow"]
    assert np.all((shadow >= 0.0) & (shadow <= 1.0 + 1e-12))
    robust = render(plain.with_render(numerics="robust"), workers=1).image
    assert np.all(np.isfinite(robust))


def test_a_large_background_picture_travels_to_the_workers_in_the_shared_file_not_in_each_task() -> None:
    from tracer.workers.parallel import SHARED_SCENE_BYTES, _SharedScenes

    picture = np.random.default_rng(1).uniform(0.0, 1.0, size=(512, 1024, 3)).astype(np.float32)
    assert picture.nbytes > SHARED_SCENE_BYTES
    scene = default_scene().with_render(width=32, height=24)
    scene = replace(scene, background=sc.Background(type="image", image=picture))
    shared = _SharedScenes(True)
    try:
        message, file = shared.message(scene)
        assert file is not None and message.offsets is not None
        assert len(message.pickled) < picture.nbytes / 100  # the task carries the scene without the picture
        _, same = shared.message(replace(scene, camera=replace(scene.camera, lens=35.0)))
        assert same is file  # the next frame's scene, the same picture: the file is used again
    finally:
        shared.close()
    assert np.array_equal(render(scene, workers=2).image, render(scene, workers=1).image)


# ---- the world as a light that objects shadow ------------------------------------------------------------------------


def _world_lit_document(seed: int) -> dict:
    """A random scene lit by a world light (its radiance the background's, or a colour of its own), with or without
    its other lights, under any kind of background, glass and transparency included."""
    rng = random.Random(30_000 + seed)
    document = (see_through_scene_document if seed % 3 == 2 else extended_scene_document)(seed, width=16, height=12)
    if seed % 2:
        document["background"] = _world_document(seed)["background"]
    elif seed % 4 == 0:
        document["background"] = {"type": "sky", "horizon": [0.9, 0.8, 0.7], "zenith": [0.2, 0.4, 0.8]}
    light = {"type": "world", "intensity": rng.choice([1.0, 0.7]), "samples": rng.choice([1, 7, 16])}
    if seed % 5 == 1:
        light.update(radiance="color", color=[0.9, 0.6, 0.3])
    document["lights"] = [light] + (document["lights"] if seed % 3 else [])
    return document


@pytest.mark.parametrize("seed", range(12))
def test_world_lit_scenes_match_the_reference(seed: int) -> None:
    assert_matches_reference(scene_from_dict(_world_lit_document(seed)))


@pytest.mark.parametrize("seed", range(4))
def test_adaptive_samplings_flagging_pass_matches_the_reference(seed: int) -> None:
    """render.adaptive_flags: the world light unshadowed and not turned, in both tracers."""
    assert_matches_reference(scene_from_dict(_world_lit_document(seed)).with_render(adaptive_flags=True))


def _white_ground(
    objects: list[dict], samples: int = 16, at: tuple[float, float] = (0.0, 0.0), across: float = 0.01, **light: object
) -> dict:
    """A white ground and objects under a white world light only, seen straight down by an orthographic camera
    across metres wide over the point at, one pixel."""
    return {
        "materials": {"white": {"color": [1.0, 1.0, 1.0], "specular": 0}},
        "objects": [{"name": "ground", "type": "plane", "material": "white"}, *objects],
        "lights": [{"type": "world", "intensity": 1.0, "samples": samples, **light}],
        "camera": {"location": [*at, 50.0], "rotation": [0.0, 0.0, 0.0], "type": "ORTHO", "ortho_scale": across},
        "background": {"type": "solid", "color": [1.0, 1.0, 1.0]},
        "render": {"width": 1, "height": 1, "depth": 0},
    }


def _open_ground(objects: list[dict], samples: int = 64, **light: object) -> float:
    """The ground's colour straight under a camera looking down at the origin, lit by a white world light only."""
    document = _white_ground(objects, samples, **light)
    return float(render(scene_from_dict(document), workers=1).image[0, 0, 0])


def test_the_world_light_on_open_ground_is_its_radiance_and_a_sphere_above_hides_its_cap() -> None:
    """Open ground: the cosine-weighted mean of a uniform radiance 1 is 1 exactly (the directions' heights are the
    midpoint rule). Under a sphere of radius 1 centred 1.2 above: the sky within its angular radius asin(1 / 1.2) of
    the zenith is hidden, leaving 1 - (1 / 1.2)^2 of the light; the estimate is off by under one direction's
    height step (2 / samples)."""
    assert _open_ground([]) == pytest.approx(1.0, abs=1e-12)
    assert _open_ground([], radiance="color", color=[0.5, 0.5, 0.5]) == pytest.approx(0.5, abs=1e-12)
    sphere = {"name": "ball", "type": "sphere", "material": "white", "location": [0.0, 0.0, 1.2], "radius": 1.0}
    sphere["visible_camera"] = False  # the camera sees the ground under it
    for samples in (16, 64, 256):
        under = _open_ground([sphere], samples)
        assert under == pytest.approx(1.0 - (1.0 / 1.2) ** 2, abs=2.0 / samples), samples


def test_open_ground_under_a_picture_with_a_hot_spot_gets_its_irradiance() -> None:
    """A dim sky with a small spot 250 times brighter (a sun in an HDRI): the open ground's light is the picture's
    cosine-weighted mean over the upper hemisphere, summed here texel by texel (each its solid angle), within 1%,
    the same in every pixel (no noise in the open); 16 directions alone sample such a spot badly (on this picture,
    the same 16 at every point gave 0.20 against 0.37: none met the spot)."""
    height, width = 64, 128
    picture = np.full((height, width, 3), 0.2, dtype=np.float32)
    picture[height // 2 :] = 0.05  # below the horizon
    picture[12:15, 40:43] = 50.0  # the spot, 30 degrees above the horizon
    latitude = np.pi * (0.5 - (np.arange(height) + 0.5) / height)
    weight = np.maximum(np.sin(latitude), 0.0) * np.cos(latitude)  # cos to the zenith times the solid angle
    truth = float((picture[..., 0] * weight[:, None]).sum() / (weight.sum() * width))
    document = {
        "materials": {"white": {"color": [1.0, 1.0, 1.0], "specular": 0}},
        "objects": [{"name": "ground", "type": "plane", "material": "white"}],
        "lights": [{"type": "world", "intensity": 1.0, "samples": 16}],
        "camera": {"location": [0.0, 0.0, 50.0], "rotation": [0.0, 0.0, 0.0], "type": "ORTHO", "ortho_scale": 4.0},
        "background": {"type": "image", "pixels": picture, "colorspace": "linear"},
        "render": {"width": 8, "height": 6, "depth": 0},
    }
    image = render(scene_from_dict(document), workers=1).image
    assert image[..., 0].mean() == pytest.approx(truth, rel=0.01)
    assert np.ptp(image[..., 0]) < 1e-9


def test_the_world_lights_contact_shadow_beside_a_wall_is_the_view_factor_not_bands() -> None:
    """Open ground beside an endless wall of height 1, under a white world: at distance d the wall hides
    (1 - d / sqrt(d^2 + 1)) / 2 of the cosine-weighted sky (the 2D view factor), so the ground's light is 1 less that.
    Each pixel turns the 16 directions its own way (camera.world_turns): a column of 500 pixels at one d averages to
    the view factor within 0.02 (measured 0.008). The same 16 directions at every point missed it by up to 0.079, a
    step wherever one direction's shadow edge fell."""
    wall = {"name": "wall", "type": "box", "material": "white", "location": [-5.0, 0.0, 0.5]}
    wall.update(size=[10.0, 2000.0, 1.0], visible_camera=False)
    document = _white_ground([wall], at=(1.0, 0.0), across=20.0)
    document["render"].update(width=50, height=500)
    image = render(scene_from_dict(document), workers=1).image[..., 0]
    d = (np.arange(50) + 0.5) * 0.04  # each column's distance from the wall (pixels of 4 cm)
    view_factor = (1.0 - d / np.sqrt(d * d + 1.0)) / 2.0
    assert np.abs(image.mean(axis=0) - (1.0 - view_factor)).max() < 0.02
    assert image.std(axis=0).max() > 0.02  # the pixels of a column differ: noise, where the bands were one value


def test_world_light_samples_are_checked_with_clear_messages() -> None:
    base = {"materials": {"m": {"color": [1, 1, 1]}}, "objects": [{"type": "sphere", "material": "m"}]}
    for light, message in (
        ({"type": "world", "intensity": 1, "samples": 0}, "lights[0].samples"),
        ({"type": "world", "intensity": 1, "radiance": "sky"}, "lights[0].radiance"),
        ({"type": "world", "intensity": -1}, "lights[0].intensity"),
    ):
        with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
            scene_from_dict({**base, "lights": [light]})


@pytest.mark.parametrize("seed", range(3))
def test_a_world_light_keeps_the_passes_adding_up_and_workers_agree(seed: int) -> None:
    document = _world_lit_document(seed)
    document["render"].pop("border", None)
    _passes_add_up_and_workers_agree(scene_from_dict(document))


@pytest.mark.parametrize("seed", range(6))
def test_world_directions_shared_out_among_a_pixels_samples_match_the_reference(seed: int) -> None:
    """lightsamples.world_share: 4 or 16 camera samples a pixel (or a motion blur slice's share) take the world
    light's directions in turn; the per-pixel reference does the same."""
    scene = scene_from_dict(_world_lit_document(seed))
    settings = {"samples": 16} if seed % 3 == 0 else {"samples": 4}
    if seed % 3 == 2:
        settings["time_slice"] = (seed % 4, 4)
    assert_matches_reference(scene.with_render(**settings))


@pytest.mark.parametrize("seed", range(6))
def test_samples_of_lights_of_a_size_shared_out_among_a_pixels_samples_match_the_reference(seed: int) -> None:
    """lightsamples.world_share for area lights, suns of an angle and point lights of a radius: 4 or 16 camera
    samples a pixel (or a motion blur slice's share) take the light's samples in turn, each g times; the per-pixel
    reference does the same."""
    document = _soft_document(seed)
    document["render"].update(width=10, height=8, shadow_samples=16 if seed % 2 == 0 else 4)
    document["render"].pop("border", None)
    settings = {"samples": 16} if seed % 3 == 0 else {"samples": 4}
    if seed % 3 == 2:
        settings["time_slice"] = (seed % 4, 4)
    assert_matches_reference(scene_from_dict(document).with_render(**settings))


def test_an_area_lights_shared_samples_cost_one_ray_each_a_pixel_and_give_the_one_sample_value() -> None:
    """16 camera samples over a pixel of open ground under a 1 m area light at Shadows 16: each of its points traced
    once for the pixel (16 shadow rays, not 256), and the pixel's value the one sample's but for the light's change
    over the pixel (points up to 3.5 mm apart). Shadows 9 has no factor in common with 16: every sample takes all."""
    light = {"type": "area", "location": [0.5, 0.0, 2.0], "direction": [0.0, 0.0, -1.0], "shape": "square"}
    light.update(size=1.0, intensity=5.0)
    document = _white_ground([])
    document["lights"] = [light]
    document["render"]["shadow_samples"] = 16
    one = render(scene_from_dict(document), workers=1)
    document["render"]["samples"] = 16
    shared = render(scene_from_dict(document), workers=1)
    assert one.rays.shadow == 16 and shared.rays.shadow == 16 and shared.rays.camera == 16
    assert shared.image[0, 0, 0] == pytest.approx(one.image[0, 0, 0], rel=2e-3)
    document["render"]["shadow_samples"] = 9
    assert render(scene_from_dict(document), workers=1).rays.shadow == 16 * 9


def test_shared_world_directions_cost_one_ray_each_a_pixel_and_give_the_one_sample_value() -> None:
    """16 samples over a pixel of open ground under a sphere: each direction traced once for the pixel (16 shadow
    rays, not 256), and the pixel's value the one sample's (the same directions from points 2.5 mm apart)."""
    sphere = {"name": "ball", "type": "sphere", "material": "white", "location": [0.0, 0.0, 1.2], "radius": 1.0}
    sphere["visible_camera"] = False
    document = _white_ground([sphere])
    one = render(scene_from_dict(document), workers=1)
    document["render"]["samples"] = 16
    shared = render(scene_from_dict(document), workers=1)
    assert one.rays.shadow == 16 and shared.rays.shadow == 16 and shared.rays.camera == 16
    assert shared.image[0, 0, 0] == pytest.approx(one.image[0, 0, 0], abs=1e-12)
    assert 0.0 < one.image[0, 0, 0] < 1.0  # the sphere hides some of the directions


@pytest.mark.parametrize("seed", range(3))
def test_shadow_rays_in_pieces_of_points_give_the_same_image_and_passes(seed: int, monkeypatch) -> None:
    """shadows.reached takes the points in pieces where one query of every light's shadow rays would pass
    SHADOW_RAYS_PIECE (a band of millions): the same image and passes, bit for bit, as one query (the built-in scene
    under a world light of 16 directions beside its own lights, a random one's world-lit scene with glass and
    transparency; 4 samples)."""
    from tracer.tracing import shadows

    document = default_scene_dict() if seed == 0 else _world_lit_document(seed)
    if seed == 0:
        world = {"type": "world", "radiance": "color", "samples": 16, "intensity": 0.5, "color": [0.3, 0.4, 0.6]}
        document["lights"].append(world)
    document["render"].pop("border", None)
    document["render"].update(width=40, height=30)
    scene = scene_from_dict(document).with_render(samples=4, shadow_samples=4, passes=(*ps.WHITTED, "shadow"))
    whole = render(scene, workers=1)
    monkeypatch.setattr(shadows, "SHADOW_RAYS_PIECE", 97)
    pieces = render(scene, workers=1)
    assert whole.rays.shadow > 10 * 97 and whole.rays == pieces.rays
    assert np.array_equal(whole.image, pieces.image)
    for name, layer in whole.passes.items():
        assert np.array_equal(layer, pieces.passes[name]), name
