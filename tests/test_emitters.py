"""Lights seen in mirrors (an area light's or a sun's seen_in_mirrors): the vectorized tracer against the per-pixel
reference, the radiance a mirror shows against the analytic pi intensity / area (a sun's: Cycles' disc), which rays
see them, and an edit of their intensity against the whole render."""

from __future__ import annotations

import math
import random
from dataclasses import replace

import numpy as np
import pytest

from tests.test_glossy import _glossy_document
from tests.test_lights_and_world import _passes_add_up_and_workers_agree, _soft_document
from tests.tracing import assert_matches_reference
from tracer.frames.edits import EditableImage, edits_between
from tracer.geometry import transforms as tf
from tracer.scene import scene as sc
from tracer.scene.loader import scene_from_dict
from tracer.workers.parallel import render


def _seen_document(seed: int) -> dict:
    """A random scene with area lights (soft lights' scenes, or glossy, glass and bouncing ones given some), each
    seen in mirrors or not."""
    rng = random.Random(50_000 + seed)
    document = _soft_document(seed) if seed % 2 else _glossy_document(seed)
    if not any(light["type"] == "area" for light in document["lights"]):
        document["lights"] += [light for light in _soft_document(seed)["lights"] if light["type"] == "area"]
    for light in document["lights"]:
        if light["type"] == "area":
            light["seen_in_mirrors"] = rng.random() < 0.8
    for material in document["materials"].values():
        material["reflective"] = rng.choice([material.get("reflective", 0.0), 0.5, 1.0])
    return document


@pytest.mark.parametrize("seed", range(8))
def test_scenes_with_lights_seen_in_mirrors_match_the_reference(seed: int) -> None:
    assert_matches_reference(scene_from_dict(_seen_document(seed)))


def test_lights_seen_in_mirrors_keep_the_passes_adding_up_and_workers_agree() -> None:
    document = _seen_document(3)
    document["render"].pop("border", None)
    _passes_add_up_and_workers_agree(scene_from_dict(document))


def _mirror_under_a_light(**light: object) -> float:
    """A perfect mirror floor seen straight down by an orthographic camera, a 2 x 0.5 m area light of intensity 3
    facing down between them: the camera's ray reflected straight up meets it."""
    document = {
        "materials": {"mirror": {"color": [0, 0, 0], "reflective": 0.75}},
        "objects": [{"name": "floor", "type": "plane", "material": "mirror"}],
        "lights": [{"type": "area", "location": [0, 0, 2], "direction": [0, 0, -1], "shape": "rectangle", **light}],
        "camera": {"location": [0.0, 0.0, 5.0], "rotation": [0.0, 0.0, 0.0], "type": "ORTHO", "ortho_scale": 0.01},
        "background": {"type": "solid", "color": [0.2, 0.2, 0.2]},
        "render": {"width": 1, "height": 1},
    }
    document["lights"][0] = {"size": [2.0, 0.5], "intensity": 3.0, **document["lights"][0]}
    return float(render(scene_from_dict(document), workers=1).image[0, 0, 0])


def test_a_mirror_shows_a_lights_radiance_pi_intensity_over_area_and_the_camera_does_not():
    """The camera looks down through the light (it does not see lights); its mirror ray meets the light's front:
    r pi I / A. Not seen in mirrors, the mirror shows the background behind it; facing away, its back: the same."""
    assert _mirror_under_a_light(seen_in_mirrors=True) == pytest.approx(0.75 * math.pi * 3.0 / 1.0, rel=1e-12)
    assert _mirror_under_a_light(seen_in_mirrors=False) == pytest.approx(0.75 * 0.2, rel=1e-12)
    away = _mirror_under_a_light(seen_in_mirrors=True, direction=[0, 0, 1])
    assert away == pytest.approx(0.75 * 0.2, rel=1e-12)
    image = np.asarray([_mirror_under_a_light(seen_in_mirrors=True, color=[0.5, 1, 1])])
    np.testing.assert_allclose(image, 0.75 * math.pi * 3.0 * 0.5, rtol=1e-12)


def _sun_document(seed: int, seen: bool = True) -> dict:
    """A random scene (soft lights' scenes, or glossy, glass and bouncing ones) with a wide sun posed where the
    camera's mirrors see it: its direction toward the light the camera's view reflected in a floor (z = 0) turned a
    little at random, its angle 20 to 60 degrees, either disc model, coloured; seen in mirrors (or not, seen False);
    the floor (added where the scene has none) a sharp mirror."""
    rng = random.Random(60_000 + seed)
    document = _soft_document(seed) if seed % 2 else _glossy_document(seed)
    camera = document["camera"]
    r = tf.euler_xyz_matrix(camera.get("rotation", (0.0, 0.0, 0.0)))
    view = [-r[0][2], -r[1][2], -r[2][2]]  # the camera's local -Z
    toward = [view[0] + rng.uniform(-0.3, 0.3), view[1] + rng.uniform(-0.3, 0.3), abs(view[2]) + 0.2]
    document["lights"].append(
        {
            "type": "directional",
            "direction": toward,
            "intensity": rng.uniform(0.5, 2.0),
            "color": [rng.uniform(0.3, 1.2) for _ in range(3)],
            "angle": rng.uniform(20.0, 60.0),
            "seen_in_mirrors": seen,
            "disc_model": rng.choice(sc.DISC_MODELS),
        }
    )
    for material in document["materials"].values():
        material["reflective"] = rng.choice([material.get("reflective", 0.0), 0.5, 1.0])
    # the floor a sharp mirror, whose rays see the disc (glossy lobes' and rough glass's rays do not: the sun comes
    # through their terms)
    document["materials"]["mirror"] = {"color": [0.8, 0.8, 0.8], "specular": 50, "reflective": 0.9}
    floors = [obj for obj in document["objects"] if obj["type"] == "plane"]
    if not floors:
        floors = [{"name": "floor", "type": "plane", "location": [0.0, 0.0, -1.0]}]
        document["objects"].append(floors[0])
    floors[0]["material"] = "mirror"
    document["render"].pop("border", None)  # the whole image: where the mirrors are
    return document


@pytest.mark.parametrize("seed", range(6))
def test_scenes_with_a_sun_seen_in_mirrors_match_the_reference_and_show_it(seed: int) -> None:
    """Both tracers agree to 1e-9, and the disc is there to agree on: the image differs from the same scene's with
    the sun not seen in mirrors."""
    scene = scene_from_dict(_sun_document(seed))
    assert_matches_reference(scene)
    unseen = render(scene_from_dict(_sun_document(seed, seen=False)), workers=1).image
    assert (np.abs(render(scene, workers=1).image - unseen) > 1e-6).any()


def test_a_sun_seen_in_mirrors_keeps_the_passes_adding_up_and_workers_agree() -> None:
    document = _sun_document(1)
    _passes_add_up_and_workers_agree(scene_from_dict(document))


def _mirror_under_a_sun(**sun: object) -> float:
    """A mirror floor of reflectivity 0.75 seen straight down by an orthographic camera (its mirror rays go straight
    up), a sun of intensity 2 and angle 10 degrees toward +Z, a grey background: the one pixel's red."""
    document = {
        "materials": {"mirror": {"color": [0, 0, 0], "reflective": 0.75}},
        "objects": [{"name": "floor", "type": "plane", "material": "mirror"}],
        "lights": [{"type": "directional", "direction": [0, 0, 1], "intensity": 2.0, "angle": 10.0, **sun}],
        "camera": {"location": [0.0, 0.0, 5.0], "rotation": [0.0, 0.0, 0.0], "type": "ORTHO", "ortho_scale": 0.01},
        "background": {"type": "solid", "color": [0.2, 0.2, 0.2]},
        "render": {"width": 1, "height": 1},
    }
    return float(render(scene_from_dict(document), workers=1).image[0, 0, 0])


def test_a_mirror_shows_the_suns_disc_at_cycles_radiance_over_the_background():
    """Cycles 4.0+: intensity / sin^2(angle / 2) all over the disc; Cycles 3.x: intensity / (tan^2(angle / 2)
    cos^3 theta), theta the angle from its centre (scene/light.cpp, kernel/light/*.h); either added to the
    background the mirror ray sees, times the mirror's r; nothing outside the disc, when not seen in mirrors, or at
    angle 0 (the documented sun)."""
    h, sky = math.radians(5.0), 0.75 * 0.2
    assert _mirror_under_a_sun(seen_in_mirrors=True) == pytest.approx(sky + 0.75 * 2.0 / math.sin(h) ** 2, rel=1e-12)
    tilt = math.radians(3.0)  # the mirror ray 3 degrees off the disc's centre, inside it
    off = [math.sin(tilt), 0.0, math.cos(tilt)]
    assert _mirror_under_a_sun(seen_in_mirrors=True, direction=off) == pytest.approx(
        sky + 0.75 * 2.0 / math.sin(h) ** 2, rel=1e-12
    )
    expected = sky + 0.75 * 2.0 / (math.tan(h) ** 2 * math.cos(tilt) ** 3)
    assert _mirror_under_a_sun(seen_in_mirrors=True, direction=off, disc_model="cycles3") == pytest.approx(
        expected, rel=1e-12
    )
    outside = [math.sin(math.radians(5.5)), 0.0, math.cos(math.radians(5.5))]
    assert _mirror_under_a_sun(seen_in_mirrors=True, direction=outside) == pytest.approx(sky, rel=1e-12)
    assert _mirror_under_a_sun(seen_in_mirrors=False) == pytest.approx(sky, rel=1e-12)
    assert _mirror_under_a_sun(seen_in_mirrors=True, angle=0.0) == pytest.approx(sky, rel=1e-12)
    coloured = _mirror_under_a_sun(seen_in_mirrors=True, color=[0.5, 1, 1], direction=[0, 0, 7])  # length kept
    assert coloured == pytest.approx(sky + 0.75 * 0.5 * 2.0 / math.sin(h) ** 2, rel=1e-12)


def test_the_camera_does_not_see_the_sun():
    """A camera looking into the disc sees the background (Cycles' lights are not visible to the camera unless their
    Camera ray visibility is turned on, which the add-on names)."""
    document = {
        "materials": {"grey": {"color": [0.5, 0.5, 0.5]}},
        "objects": [],
        "lights": [{"type": "directional", "direction": [0, 0, -1], "intensity": 2.0, "angle": 10.0,
                    "seen_in_mirrors": True}],
        "camera": {"location": [0.0, 0.0, 5.0], "rotation": [0.0, 0.0, 0.0]},
        "background": {"type": "solid", "color": [0.2, 0.2, 0.2]},
        "render": {"width": 4, "height": 3},
    }  # fmt: skip
    np.testing.assert_array_equal(render(scene_from_dict(document), workers=1).image, 0.2)


@pytest.mark.parametrize("kind", ["directional", "area"])
def test_an_edit_of_a_light_seen_only_through_glass_retraces_the_pixels_that_see_it(kind: str) -> None:
    """A glass ball before a camera looking into a sun's disc (or an area light behind the ball): its pixels see the
    light only by refracted rays, with no shadow segment toward it. Doubling the light's intensity in an editable
    image gives the whole render of the edited scene, bit for bit (before: the disc's pixels kept their old value)."""
    up = [0.0, math.cos(math.radians(30.0)), math.sin(math.radians(30.0))]
    if kind == "directional":
        light = {"type": "directional", "direction": up, "intensity": 1.0, "angle": 8.0, "seen_in_mirrors": True}
    else:
        light = {"type": "area", "location": [8.0 * c for c in up], "direction": [-c for c in up], "shape": "square",
                 "size": 1.0, "intensity": 1.0, "seen_in_mirrors": True}  # fmt: skip
    document = {
        "materials": {"glass": {"color": [1, 1, 1], "transmission": 1.0, "ior": 1.45}},
        "objects": [
            {"name": "ball", "type": "sphere", "location": [4.0 * c for c in up], "radius": 1.0, "material": "glass"}
        ],
        "lights": [light],
        "camera": {"location": [0.0, 0.0, 0.0], "rotation": [120.0, 0.0, 0.0]},
        "background": {"type": "solid", "color": [0.1, 0.1, 0.1]},
        "render": {"width": 32, "height": 24},
    }
    scene = scene_from_dict(document)
    brighter = replace(scene, lights=(replace(scene.lights[0], intensity=2.0),))
    whole = render(brighter, workers=1).image
    assert whole.max() > 2.0 * render(scene, workers=1).image.max() - 0.2  # the light is what the ball shows
    image = EditableImage(scene)
    for edit in edits_between(scene, brighter):
        image.apply(edit)
    np.testing.assert_array_equal(image.image, whole)
