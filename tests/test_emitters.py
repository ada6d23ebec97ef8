"""Area lights seen in mirrors (an area light's seen_in_mirrors): the vectorized tracer against the per-pixel
reference, the radiance a mirror shows against the analytic pi intensity / area, and which rays see them."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from tests.test_glossy import _glossy_document
from tests.test_lights_and_world import _passes_add_up_and_workers_agree, _soft_document
from tests.tracing import assert_matches_reference
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
