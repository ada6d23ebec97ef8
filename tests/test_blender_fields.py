"""The optional scene fields for Blender scenes (docs/scene-format.md, "Blender extensions") against hand-worked values:
an inverse-square light, a spot cone, emission, coloured lights, specular colour, two-sided faces, ray visibility,
holdouts and a transparent film, smooth meshes; and that leaving them out changes nothing."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from tests.random_scenes import extended_scene_document
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, default_scene_dict, scene_from_dict
from tracer.tracing.reference import render_reference, spot_attenuation
from tracer.tracing.wavefront import RayCounts, TracedScene, quiet
from tracer.workers.parallel import render


@pytest.fixture(autouse=True)
def _quiet():
    with quiet():  # as _trace_pixels traces (a ray along a light's direction divides 0 by 0 where no term is added)
        yield


ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "docs" / "scene.schema.json").read_text())
WHITE_MATTE = sc.Material(color=(1.0, 1.0, 1.0))


def floor_scene(lights: tuple[sc.Light, ...], material: sc.Material = WHITE_MATTE, **render: object) -> sc.Scene:
    """An infinite white floor at z = 0 under the given lights; rays are traced straight down by down_at()."""
    return sc.Scene(
        materials={"floor": material},
        objects=(sc.Plane(name="floor", material="floor"),),
        lights=lights,
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=4, height=3, **render),
    )


def down_at(scene: sc.Scene, points: list[tuple[float, float]], height: float = 10.0) -> np.ndarray:
    """The colours (n, 3) of rays straight down onto the floor at the points (x, y)."""
    prepared = TracedScene(scene)
    origins = np.array([[x, y, height] for x, y in points], dtype=np.float64).T
    directions = np.tile(np.array([[0.0], [0.0], [-1.0]]), (1, len(points)))
    return prepared.trace(directions, RayCounts(), origins=origins).T


def test_inverse_square_point_light_is_i_cos_over_d_squared() -> None:
    light = sc.PointLight(location=(0.0, 0.0, 2.0), intensity=3.0, falloff="inverse_square")
    points = [(0.0, 0.0), (1.0, 0.0), (1.5, -2.0), (-3.0, 4.0)]
    colours = down_at(floor_scene((light,)), points)
    for (x, y), colour in zip(points, colours, strict=True):
        d = math.sqrt(x * x + y * y + 4.0)
        np.testing.assert_allclose(colour, 3.0 * (2.0 / d) / (d * d), rtol=1e-12)
    # without falloff: the documented i cos
    plain = down_at(floor_scene((replace(light, falloff="none"),)), points)
    for (x, y), colour in zip(points, plain, strict=True):
        np.testing.assert_allclose(colour, 3.0 * 2.0 / math.sqrt(x * x + y * y + 4.0), rtol=1e-12)


@pytest.mark.parametrize("model", ["cycles4", "cycles3"])
@pytest.mark.parametrize("blend", [0.0, 0.15, 1.0])
def test_spot_light_follows_cycles_attenuation(model: str, blend: float) -> None:
    spot = sc.SpotLight(
        location=(0.0, 0.0, 2.0),
        direction=(0, 0, -5),
        intensity=1.0,
        spot_size=90.0,
        spot_blend=blend,
        spot_model=model,
    )
    xs = [0.0, 0.5, 1.0, 1.5, 1.99, 2.01, 3.0]  # the cone's edge (45 degrees) meets the floor at x = 2
    colours = down_at(floor_scene((spot,)), [(x, 0.0) for x in xs])
    cos_half = math.cos(math.radians(45.0))
    for x, colour in zip(xs, colours, strict=True):
        c = 2.0 / math.hypot(x, 2.0)  # the angle to the axis, and also N.L / |L| on the floor
        if c <= cos_half:
            expected = 0.0
        elif blend == 0.0:
            expected = 1.0
        else:
            f = min(1.0, (c - cos_half) / ((1.0 - cos_half) * blend))
            expected = f * f * (3.0 - 2.0 * f)
        if model == "cycles3":
            expected *= c
        np.testing.assert_allclose(colour, c * expected, rtol=1e-12, atol=1e-15)
    assert colours[0][0] == pytest.approx(1.0) and colours[-1][0] == 0.0


@pytest.mark.parametrize(("stretch", "turn"), [((1.6, 0.6), 0.0), ((0.5, 2.0), 30.0)])
def test_a_stretched_spots_cone_is_the_cone_of_the_scaled_ray(stretch: tuple[float, float], turn: float) -> None:
    """cone_scale (a, b) along x_axis and across it: a floor point at offset (x, y) in those axes, h below the light,
    is inside the cone where h / sqrt((x / a)^2 + (y / b)^2 + h^2) > cos(size / 2) (Cycles 4's spot of an object
    scaled a and b times its z): the lit ellipse's half axes a h tan(size / 2) and b h tan(size / 2)."""
    angle = math.radians(turn)
    axis_x, axis_y = (math.cos(angle), math.sin(angle)), (-math.sin(angle), math.cos(angle))
    spot = sc.SpotLight(
        location=(0.0, 0.0, 2.0),
        direction=(0, 0, -1),
        intensity=1.0,
        spot_size=70.0,
        spot_blend=0.0,
        x_axis=(axis_x[0], axis_x[1], 0.3),  # not perpendicular to the axis: its part across it counts
        cone_scale=stretch,
    )
    reach = 2.0 * math.tan(math.radians(35.0))
    offsets = [(0.97, 0.0), (1.03, 0.0), (0.0, 0.97), (0.0, 1.03), (0.6, 0.6), (0.75, 0.75)]  # in half axes
    points = []
    for u, v in offsets:
        x, y = u * stretch[0] * reach, v * stretch[1] * reach
        points.append((x * axis_x[0] + y * axis_y[0], x * axis_x[1] + y * axis_y[1]))
    colours = down_at(floor_scene((spot,)), points)
    for (u, v), (px, py), colour in zip(offsets, points, colours, strict=True):
        inside = u * u + v * v < 1.0
        expected = 2.0 / math.sqrt(px * px + py * py + 4.0) if inside else 0.0  # N.L / |L| where lit, blend 0
        np.testing.assert_allclose(colour, expected, rtol=1e-12, atol=1e-15)
    document = default_scene_dict()  # the file's fields say the same
    document["lights"] = [
        {"type": "spot", "location": [0.0, 0.0, 2.0], "direction": [0, 0, -1], "intensity": 1.0, "spot_size": 70.0,
         "spot_blend": 0.0, "x_axis": list(spot.x_axis), "cone_scale": list(stretch)}
    ]  # fmt: skip
    assert scene_from_dict(document).lights[0] == spot


@pytest.mark.parametrize("kind", ["point", "spot", "sun"])
def test_a_lights_ray_visibility_takes_its_diffuse_or_its_highlight_away(kind: str) -> None:
    """visible_diffuse false: the light adds its highlight alone; visible_glossy false: its diffuse term alone (a
    matte floor's colour); both: nothing. The three add up to the light's whole colour on a shiny floor."""
    shiny = replace(WHITE_MATTE, specular=8.0)
    light = {
        "point": sc.PointLight(location=(0.5, 0.0, 2.0), intensity=1.0),
        "spot": sc.SpotLight(location=(0.5, 0.0, 2.0), direction=(0, 0, -1), intensity=1.0, spot_size=120.0),
        "sun": sc.DirectionalLight(direction=(0.3, 0.1, 1.0), intensity=1.0),
    }[kind]
    points = [(0.0, 0.0), (0.4, 0.1), (1.0, -0.3)]
    whole = down_at(floor_scene((light,), shiny), points)
    diffuse = down_at(floor_scene((light,), WHITE_MATTE), points)
    highlight_only = down_at(floor_scene((replace(light, visible_diffuse=False),), shiny), points)
    diffuse_only = down_at(floor_scene((replace(light, visible_glossy=False),), shiny), points)
    nothing = down_at(floor_scene((replace(light, visible_diffuse=False, visible_glossy=False),), shiny), points)
    np.testing.assert_allclose(diffuse_only, diffuse, rtol=1e-12)
    np.testing.assert_allclose(highlight_only, whole - diffuse, rtol=1e-9, atol=1e-15)
    assert np.all(nothing == 0.0) and np.all(whole - diffuse > 1e-3)  # a highlight there to take away


def test_spot_models_differ_by_the_cosine() -> None:
    spot = sc.SpotLight(spot_size=120.0, spot_blend=0.5)
    for c in (0.55, 0.7, 0.9, 0.99, 1.0):
        new = spot_attenuation(c, spot)
        old = spot_attenuation(c, replace(spot, spot_model="cycles3"))
        assert old == pytest.approx(c * new, rel=1e-15)


def test_emission_is_added_unshadowed_and_unweighted() -> None:
    material = sc.Material(color=(0.5, 0.5, 0.5), reflective=0.5, emission=(0.2, 0.1, 0.0))
    scene = floor_scene((), material)
    np.testing.assert_array_equal(down_at(scene, [(0.0, 0.0)])[0], [0.2, 0.1, 0.0])


def test_light_colours_multiply_each_channel() -> None:
    ambient = sc.AmbientLight(intensity=0.4, color=(0.5, 1.0, 0.0))
    sun = sc.DirectionalLight(direction=(0.0, 0.0, 2.0), intensity=0.5, color=(1.0, 0.0, 2.0))
    colour = down_at(floor_scene((ambient, sun)), [(0.3, 0.2)])[0]
    np.testing.assert_allclose(colour, [0.2 + 0.5, 0.4, 1.0], rtol=1e-15)


def test_specular_color_keeps_highlights_white_on_a_red_surface() -> None:
    light = sc.PointLight(location=(0.0, 0.0, 5.0), intensity=1.0)
    red = sc.Material(color=(1.0, 0.0, 0.0), specular=10.0)
    documented = down_at(floor_scene((light,), red, model="phong"), [(0.0, 0.0)])[0]
    white = down_at(floor_scene((light,), replace(red, specular_color=(1.0, 1.0, 1.0)), model="phong"), [(0.0, 0.0)])
    # head on: diffuse 1 and highlight 1 (R.V = 1); documented: all of it red; with a specular colour: white highlight
    np.testing.assert_allclose(documented, [2.0, 0.0, 0.0], rtol=1e-15)
    np.testing.assert_allclose(white[0], [2.0, 1.0, 1.0], rtol=1e-15)


def test_two_sided_faces_are_lit_from_behind() -> None:
    light = sc.PointLight(location=(0.0, 0.0, -4.0), intensity=0.8)  # below the floor, seen from below
    for two_sided, expected in ((False, 0.1), (True, 0.9)):
        material = replace(WHITE_MATTE, two_sided=two_sided)
        scene = floor_scene((sc.AmbientLight(intensity=0.1), light), material)
        prepared = TracedScene(scene)
        origins = np.array([[0.0], [0.0], [-10.0]])
        colour = prepared.trace(np.array([[0.0], [0.0], [1.0]]), RayCounts(), origins=origins).T  # the back
        np.testing.assert_allclose(colour[0], expected, rtol=1e-15)


def _shadow_scene(**flags: bool) -> sc.Scene:
    """A floor under a light straight above, a ball between them, and a mirror ball beside."""
    return sc.Scene(
        materials={"white": WHITE_MATTE, "mirror": sc.Material(color=(0, 0, 0), reflective=1.0)},
        objects=(
            sc.Plane(name="floor", material="white"),
            sc.Sphere(name="ball", material="white", location=(0.0, 0.0, 2.0), radius=0.5, **flags),
        ),
        lights=(sc.PointLight(location=(0.0, 0.0, 5.0), intensity=1.0),),
        background=sc.Background(type="solid", color=(0.0, 0.0, 1.0)),
        render=sc.RenderSettings(width=4, height=3),
    )


def test_ray_visibility_flags() -> None:
    def floor_under_ball(scene: sc.Scene) -> float:  # a ray down onto the floor at (0, 0.8): beside the ball
        prepared = TracedScene(scene)
        return prepared.trace(np.array([[0.0], [0.0], [-1.0]]), RayCounts(), origins=np.array([[0.0], [0.0], [1.0]]))

    shadowed = floor_under_ball(_shadow_scene())
    assert shadowed[0, 0] == 0.0  # the ball shadows the floor below it
    assert floor_under_ball(_shadow_scene(visible_shadow=False))[0, 0] == pytest.approx(1.0)
    assert floor_under_ball(_shadow_scene(visible_camera=False))[0, 0] == 0.0  # still casts its shadow
    # seen from above: the camera ray meets the ball unless it is invisible to the camera
    above = np.array([[0.0], [0.0], [10.0]])
    down = np.array([[0.0], [0.0], [-1.0]])
    ball = TracedScene(_shadow_scene()).trace(down, RayCounts(), origins=above)
    assert ball[0, 0] > 0.5
    hidden = TracedScene(_shadow_scene(visible_camera=False)).trace(down, RayCounts(), origins=above)
    assert hidden[0, 0] == 0.0  # through to the floor, in the ball's shadow
    # a mirror floor sees the ball above it unless the ball is invisible to reflections
    mirror = replace(_shadow_scene(), objects=(replace(_shadow_scene().objects[0], material="mirror"),))
    up = TracedScene(replace(mirror, objects=(*mirror.objects, _shadow_scene().objects[1])))
    seen = up.trace(down, RayCounts(), origins=np.array([[0.0], [0.0], [1.0]]))
    assert seen[2, 0] < 1.0  # the ball's underside, not the blue sky
    flags = replace(_shadow_scene().objects[1], visible_reflection=False)
    unseen = TracedScene(replace(mirror, objects=(*mirror.objects, flags)))
    sky = unseen.trace(down, RayCounts(), origins=np.array([[0.0], [0.0], [1.0]]))
    np.testing.assert_array_equal(sky[:, 0], [0.0, 0.0, 1.0])


def _holdout_document(film_transparent: bool) -> dict:
    document = copy.deepcopy(default_scene_dict())
    document["render"].update(width=32, height=24, film_transparent=film_transparent)
    ball = next(obj for obj in document["objects"] if obj["type"] == "sphere")
    ball["holdout"] = True
    return document


@pytest.mark.parametrize("film_transparent", [False, True])
def test_holdouts_and_the_transparent_film_give_an_alpha(film_transparent: bool) -> None:
    scene = scene_from_dict(_holdout_document(film_transparent))
    result = render(scene, workers=1)
    assert result.alpha is not None and result.alpha.shape == (24, 32)
    expected = np.asarray(render_reference(scene))
    np.testing.assert_allclose(result.image, expected[..., :3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(result.alpha, expected[..., 3], rtol=0, atol=1e-12)
    holes = result.alpha == 0.0
    assert holes.any() and np.all(result.image[holes] == 0.0)
    assert (result.alpha == 1.0).any()
    plain = render(scene.with_render(film_transparent=False), workers=1)
    assert film_transparent == (plain.alpha is not None and (plain.alpha == 0).sum() < holes.sum())
    assert render(default_scene().with_render(width=8, height=6), workers=1).alpha is None


def test_empty_scene_is_the_background() -> None:
    document = copy.deepcopy(default_scene_dict())
    document["objects"] = []
    document.pop("vane", None)
    document.pop("motion", None)
    document.pop("wind", None)
    document["render"].update(width=8, height=6)
    document["background"] = {"type": "solid", "color": [0.1, 0.2, 0.3]}
    image = render(scene_from_dict(document), workers=1).image
    np.testing.assert_array_equal(image, np.broadcast_to([0.1, 0.2, 0.3], image.shape))


def test_absent_fields_and_their_defaults_render_the_same_bytes() -> None:
    document = copy.deepcopy(default_scene_dict())
    document["render"].update(width=40, height=30)
    plain = render(scene_from_dict(document), workers=1).image
    for material in document["materials"].values():
        material.update(emission=[0, 0, 0], two_sided=False)
    for light in document["lights"]:
        light["color"] = [1, 1, 1]
        if light["type"] == "point":
            light["falloff"] = "none"
    for obj in document["objects"]:
        obj.update(visible_camera=True, visible_shadow=True, visible_reflection=True, holdout=False)
    document["render"]["film_transparent"] = False
    explicit = scene_from_dict(document)
    result = render(explicit, workers=1)
    assert result.alpha is None
    assert result.image.tobytes() == plain.tobytes()


@pytest.mark.parametrize("seed", range(0, 60, 7))
def test_extended_scenes_follow_the_schema(seed: int) -> None:
    jsonschema.validate(extended_scene_document(seed), SCHEMA)


BAD = [
    ("lights", 2, "color", [1, -1, 0], "lights[2].color[1]: must be >= 0, got -1"),
    ("lights", 2, "color", [1, 1], "lights[2].color: must be a list of 3 numbers, got a list of 2"),
    ("lights", 1, "falloff", "linear", 'lights[1].falloff: must be one of "none", "inverse_square", got "linear"'),
    ("lights", 0, "falloff", "none", "lights[0].falloff: is not a known field"),
    ("objects", 0, "holdout", 1, "objects[0].holdout: must be true or false, got 1"),
    ("objects", 0, "visible_shadow", "no", 'objects[0].visible_shadow: must be true or false, got "no"'),
]


@pytest.mark.parametrize(("section", "index", "key", "value", "message"), BAD)
def test_bad_fields_are_named(section: str, index: int, key: str, value: object, message: str) -> None:
    document = copy.deepcopy(default_scene_dict())
    document[section][index][key] = value
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert message in caught.value.problems, caught.value.problems


def _mesh_document(**fields: object) -> dict:
    document = copy.deepcopy(default_scene_dict())
    mesh = {
        "type": "mesh",
        "name": "quad",
        "material": "stone",
        "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
        "triangles": [[0, 1, 2], [0, 2, 3]],
    }
    mesh.update(fields)
    document["objects"].append(mesh)
    return document


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"normals": [[[0, 0, 1]] * 3]}, "objects[14].normals: must be a list of 2 triangles' corner normals"),
        ({"normals": [[[0, 0, 1]] * 3, [[0, 0, 1], [0, 0, 0], [0, 0, 1]]]}, "objects[14].normals[1][1]: must not be"),
        ({"normals": [[[0, 0, 1]] * 3, [[0, 0, 1], [0, True, 1], [0, 0, 1]]]}, "objects[14].normals[1]: must be 3"),
        ({"materials": ["stone"]}, "objects[14].material_indices: is required with materials"),
        ({"materials": ["stone", "gold"], "material_indices": [0, 1]}, "objects[14].materials[1]: must name one of"),
        (
            {"materials": ["stone"], "material_indices": [0, 1]},
            "objects[14].material_indices[1]: must be an integer in",
        ),
        ({"materials": ["stone"], "material_indices": [0]}, "objects[14].material_indices: must be a list of 2"),
    ],
)
def test_bad_mesh_fields_are_named(fields: dict, message: str) -> None:
    document = _mesh_document(**fields)
    assert len(document["objects"]) == 15
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert any(problem.startswith(message) for problem in caught.value.problems), caught.value.problems


def test_bad_spot_and_material_fields_are_named() -> None:
    document = copy.deepcopy(default_scene_dict())
    document["lights"].append(
        {"type": "spot", "location": [0, 0, 3], "direction": [0, 0, 0], "intensity": 1, "spot_size": 200}
    )
    document["materials"]["stone"]["emission"] = [0, -1, 0]
    document["materials"]["stone"]["specular_color"] = "white"
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    problems = caught.value.problems
    assert "lights[3].direction: must not be the zero vector, got [0, 0, 0]" in problems
    assert "lights[3].spot_size: must be <= 180, got 200" in problems
    assert "materials.stone.emission[1]: must be >= 0, got -1" in problems
    assert any(p.startswith("materials.stone.specular_color: must be a list of 3 numbers") for p in problems)


def test_bad_border_is_named() -> None:
    document = copy.deepcopy(default_scene_dict())
    document["render"]["border"] = [0.3, 0.2, 0.4, 1.2]
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert caught.value.problems == ["render.border[3]: must be <= 1, got 1.2"]
    document["render"]["border"] = [0.5, 0.2, 0.4, 0.9]
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert caught.value.problems == ["render.border: min_x must be less than max_x, got 0.5 and 0.4"]


def test_cli_writes_rgba_png_and_four_channel_npy(tmp_path: Path) -> None:
    from PIL import Image

    path = tmp_path / "scene.json"
    path.write_text(json.dumps(_holdout_document(True)))
    for name in ("out.png", "out.npy"):
        subprocess.run(
            [
                sys.executable,
                "-m",
                "tracer",
                "render",
                str(path),
                "-o",
                str(tmp_path / name),
                "--quiet",
                "--workers",
                "1",
            ],
            check=True,
            cwd=ROOT,
        )
    with Image.open(tmp_path / "out.png") as png:
        assert png.mode == "RGBA" and png.size == (32, 24)
        assert np.asarray(png)[..., 3].min() == 0
    array = np.load(tmp_path / "out.npy")
    assert array.shape == (24, 32, 4)
    assert array[..., 3].min() == 0.0 and array[..., 3].max() == 1.0


@pytest.mark.parametrize("crop", [False, True])
def test_render_border_traces_only_its_pixels(crop: bool) -> None:
    from tracer.geometry.camera import border_window

    scene = default_scene().with_render(width=40, height=30, border=(0.25, 0.1, 0.75, 0.5), crop=crop)
    assert border_window(scene.render) == (10, 30, 15, 27)  # columns 10-29; rows 3-14 from the bottom
    whole = render(scene.with_render(border=None, crop=False), workers=1)
    one, two = render(scene, workers=1), render(scene, workers=2)
    np.testing.assert_array_equal(one.image, two.image)
    inside = whole.image[15:27, 10:30]
    if crop:
        assert one.image.shape == (12, 20, 3) and one.alpha is None
        np.testing.assert_array_equal(one.image, inside)
    else:
        assert one.image.shape == (30, 40, 3)
        np.testing.assert_array_equal(one.image[15:27, 10:30], inside)
        assert not one.image[:15].any() and not one.image[:, :10].any() and not one.image[27:].any()
        assert one.alpha[15:27, 10:30].min() == 1.0 and one.alpha.sum() == 12 * 20
        np.testing.assert_array_equal(one.alpha, two.alpha)
    assert one.rays.camera == 12 * 20


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("numerics", ["documented", "robust"])
def test_blender_fields_at_their_limits_render_finite_pixels(dtype: str, numerics: str) -> None:
    document = extended_scene_document(3, width=12, height=9)
    document["render"].update(dtype=dtype, numerics=numerics, samples=4)
    for material in document["materials"].values():
        material.update(emission=[1e6, 0, 1e6], specular_color=[1e6, 1e6, 0], two_sided=True)
    document["lights"] += [
        {"type": "spot", "location": [0, -3, 2], "direction": [0, 1, 0], "intensity": 1e6, "color": [1e6, 0, 1],
         "falloff": "inverse_square", "spot_size": 1e-3, "spot_blend": 1.0, "spot_model": "cycles3"},
        {"type": "spot", "location": [0, -3, 2], "direction": [1e-9, 0, 0], "intensity": 1, "spot_size": 180,
         "spot_blend": 0.0},
        {"type": "point", "location": [1e9, 0, 0], "intensity": 1e6, "falloff": "inverse_square", "color": [1e6] * 3},
    ]  # fmt: skip
    result = render(scene_from_dict(document), workers=1)
    assert np.all(np.isfinite(result.image)) and (result.alpha is None or np.all(np.isfinite(result.alpha)))


def test_render_border_with_a_clipped_orthographic_camera_and_samples() -> None:
    from tracer.geometry.camera import border_window

    scene = default_scene().with_render(width=48, height=36, samples=4)
    scene = replace(scene, camera=replace(scene.camera, type="ORTHO", ortho_scale=8.0, clip_start=1.0, clip_end=30.0))
    whole = render(scene, workers=1).image
    bordered = scene.with_render(border=(0.1, 0.2, 0.6, 0.9), crop=True)
    x0, x1, y0, y1 = border_window(bordered.render)
    np.testing.assert_array_equal(render(bordered, workers=2).image, whole[y0:y1, x0:x1])
