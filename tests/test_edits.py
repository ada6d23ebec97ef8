"""Edits (tracer/frames/edits.py) re-trace what they touch, and the image is the whole render of the edited scene, bit
for bit."""

from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import random_scene_document
from tracer.frames import edits
from tracer.scene import scene as sc
from tracer.scene.loader import default_scene, scene_from_dict
from tracer.workers.parallel import render


def random_edit(scene: sc.Scene, rng: random.Random) -> edits.Edit:
    kind = rng.choice(["material", "light", "transform"])
    if kind == "material":
        name = rng.choice(sorted(scene.materials))
        material = sc.Material(
            color=tuple(rng.random() for _ in range(3)),
            specular=rng.choice([0.0, 10.0, 300.0]),
            reflective=rng.choice([0.0, 0.4, 0.9]),
        )
        return edits.MaterialEdit(name, material)
    if kind == "light" and scene.lights:
        return edits.LightEdit(rng.randrange(len(scene.lights)), rng.uniform(0.0, 1.0))
    bounded = [obj for obj in scene.objects if not isinstance(obj, sc.Plane)]
    obj = rng.choice(bounded)
    moved = tuple(x + rng.uniform(-0.8, 0.8) for x in obj.location)
    turned = tuple(a + rng.uniform(-40, 40) for a in obj.rotation)
    return edits.TransformEdit(obj.name, moved, turned)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize(("dtype", "numerics"), [("float64", "documented"), ("float32", "robust")])
def test_random_edits_give_the_whole_render_of_the_edited_scene(seed: int, dtype: str, numerics: str) -> None:
    document = random_scene_document(seed, width=32, height=24)
    document["render"].update(dtype=dtype, numerics=numerics, depth=max(document["render"]["depth"], 3))
    scene = scene_from_dict(document)
    image = edits.EditableImage(scene)
    assert np.array_equal(image.image, render(scene, workers=1).image)
    rng = random.Random(seed)
    kinds = set()
    for _ in range(8):
        edit = random_edit(image.scene, rng)
        kinds.add(type(edit).__name__)
        edited = image.apply(edit)
        assert np.array_equal(edited, render(image.scene, workers=1).image), edit
    assert len(kinds) >= 2


def test_edits_trace_only_what_they_touch_on_the_default_scene() -> None:
    scene = default_scene().with_render(width=160, height=120)
    image = edits.EditableImage(scene)
    pixels = 160 * 120
    vane_part = next(obj for obj in scene.objects if obj.name == "tail_fin")
    steps = [
        edits.MaterialEdit(vane_part.material, sc.Material(color=(0.9, 0.1, 0.1), specular=20, reflective=0.2)),
        edits.TransformEdit("ball", (0.3, 0.0, 3.3), (0.0, 0.0, 0.0)),
        next(edits.LightEdit(k, 0.2) for k, light in enumerate(scene.lights) if isinstance(light, sc.DirectionalLight)),
    ]
    for edit in steps:
        edited = image.apply(edit)
        assert np.array_equal(edited, render(image.scene, workers=1).image)
        assert 0 < image.last_traced < pixels, edit
    # a small part's material and a small part's move touch few pixels
    image = edits.EditableImage(scene)
    image.apply(steps[0])
    assert image.last_traced < 0.1 * pixels


def test_moving_an_unbounded_plane_traces_everything_again() -> None:
    scene = default_scene().with_render(width=40, height=30)
    scene = replace(scene, objects=(sc.Plane(name="floor", material="tiles"), *scene.objects[1:]))
    image = edits.EditableImage(scene)
    edited = image.apply(edits.TransformEdit("floor", (0.0, 0.0, -0.2), (0.0, 0.0, 0.0)))
    assert image.last_traced == 40 * 30
    assert np.array_equal(edited, render(image.scene, workers=1).image)


def test_an_editable_image_built_in_pieces_is_the_whole_render_and_can_be_stopped_between_them() -> None:
    scene = default_scene().with_render(width=320, height=240, samples=4)
    calls = []
    editable = edits.EditableImage(scene, between_pieces=lambda: calls.append(1))
    assert len(calls) == 320 * 240 * 4 // edits.BUILD_PIECE_SAMPLES == 4
    assert np.array_equal(editable.image, render(scene, workers=1).image)

    class StopError(Exception):
        pass

    def stop() -> None:
        raise StopError

    with pytest.raises(StopError):
        edits.EditableImage(scene, between_pieces=stop)  # after its first piece


@pytest.mark.parametrize("seed", range(0, 40, 5))
def test_edits_of_scenes_with_blender_fields_give_the_whole_render(seed: int) -> None:
    from tests.random_scenes import extended_scene_document

    document = extended_scene_document(seed, width=32, height=24)
    document["render"].pop("border", None)  # the editable image is the whole image's colours
    document["render"]["depth"] = max(document["render"]["depth"], 3)
    scene = scene_from_dict(document)
    image = edits.EditableImage(scene)
    whole = render(scene, workers=1)
    assert np.array_equal(image.image, whole.image)
    assert (image.alpha is None) == (whole.alpha is None)
    rng = random.Random(seed)
    for _ in range(6):
        edit = random_edit(image.scene, rng)
        edited = image.apply(edit)
        whole = render(image.scene, workers=1)
        assert np.array_equal(edited, whole.image), edit
        assert whole.alpha is None or np.array_equal(image.alpha, whole.alpha), edit
