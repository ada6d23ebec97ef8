"""Loading with the last load's parts kept (reuse.LoadedParts, F12 after F12) gives what a fresh load gives: the same
scene, the same problems, the same image; parts are used again only where their documents are the same."""

from __future__ import annotations

import copy
import pickle
import random
from typing import Any

import numpy as np
import pytest
from PIL import Image

from tests.random_scenes import extended_scene_document, random_scene_document
from tracer.scene.loader import SceneError, scene_from_dict
from tracer.scene.reuse import LoadedParts, same
from tracer.workers import parallel


def _loaded(document: dict, kept: LoadedParts | None = None) -> Any:
    """The scene's pickle, or the problems' list where it does not load."""
    try:
        return pickle.dumps(scene_from_dict(document, "scene", kept=kept))
    except SceneError as error:
        return error.problems


def _changed(document: dict, rng: random.Random) -> dict:
    """document with one change an artist's edit makes (or a mistake the loader must still name)."""
    changed = copy.deepcopy(document)
    objects, materials = changed["objects"], changed["materials"]
    names = sorted(materials)
    change = rng.randrange(8)
    if (change in (2, 3) and len(objects) < 3) or (change in (1, 4) and len(names) < 2):
        change = 0
    if change == 0:  # an object moved
        rng.choice(objects)["location"][rng.randrange(3)] += rng.uniform(-0.5, 0.5)
    elif change == 1:  # a colour edited
        materials[rng.choice(names)]["color"][rng.randrange(3)] = rng.random()
    elif change == 2:  # an object deleted: the ones after it move up a place
        del objects[rng.randrange(len(objects))]
    elif change == 3:  # two objects in the other order
        i, j = rng.sample(range(len(objects)), 2)
        objects[i], objects[j] = objects[j], objects[i]
    elif change == 4:  # a material removed while objects still name it: the problem named as a fresh load names it
        del materials[rng.choice(names)]
    elif change == 5:  # a bad value
        rng.choice(objects)["rotation"] = [0.0, "tilted", 0.0]
    elif change == 6:  # a number that reads the same written as an integer
        rng.choice(objects)["location"][0] = 1
    else:  # the lights or the camera
        changed["lights"][0]["intensity"] = rng.uniform(0.1, 1.0)
    return changed


@pytest.mark.parametrize("seed", range(24))
def test_a_load_with_the_last_ones_parts_is_a_fresh_load(seed: int) -> None:
    make = extended_scene_document if seed % 2 else random_scene_document
    first = make(seed)
    rng = random.Random(seed)
    kept = LoadedParts()
    scene = scene_from_dict(first, kept=kept)
    reused = 0
    for _ in range(4):
        second = _changed(first, rng)
        assert _loaded(second, kept) == _loaded(second)
        reused += kept.reused
        if isinstance(_loaded(second), list):  # refused: the kept parts are still the last good load's
            assert scene_from_dict(copy.deepcopy(first), kept=kept) is scene
        else:
            first, scene = second, scene_from_dict(second, kept=kept)
    assert reused > 0  # the loads above did use parts of the ones before


def test_an_unchanged_document_is_the_same_scene_and_a_move_builds_one_object_again() -> None:
    document = random_scene_document(3)
    kept = LoadedParts()
    scene = scene_from_dict(document, kept=kept)
    assert scene_from_dict(copy.deepcopy(document), kept=kept) is scene
    assert kept.reused == len(scene.materials) + len(scene.objects)
    moved = copy.deepcopy(document)
    moved["objects"][1]["location"][2] += 0.25
    again = scene_from_dict(moved, kept=kept)
    assert again is not scene and pickle.dumps(again) == pickle.dumps(scene_from_dict(moved))
    assert [a is b for a, b in zip(again.objects, scene.objects, strict=True)] == [
        k != 1 for k in range(len(scene.objects))
    ]
    assert all(again.materials[name] is material for name, material in scene.materials.items())


def _mesh_document(vertices: np.ndarray) -> dict:
    return {
        "materials": {"m": {"color": [0.8, 0.4, 0.2]}},
        "objects": [
            {"name": "mesh", "type": "mesh", "material": "m", "vertices": vertices, "triangles": np.array([[0, 1, 2]])},
        ],
        "lights": [{"type": "ambient", "intensity": 1.0}],
        "camera": {"location": [0.0, -3.0, 0.3], "rotation": [90, 0, 0]},
        "render": {"width": 8, "height": 6},
    }


def test_arrays_are_compared_by_their_values() -> None:
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    kept = LoadedParts()
    scene = scene_from_dict(_mesh_document(vertices), kept=kept)
    assert scene_from_dict(_mesh_document(vertices.copy()), kept=kept) is scene  # other arrays, the same values
    moved = vertices + np.array([0.0, 0.0, 0.5])
    again = scene_from_dict(_mesh_document(moved), kept=kept)
    assert again.objects[0] is not scene.objects[0]
    assert pickle.dumps(again) == pickle.dumps(scene_from_dict(_mesh_document(moved)))
    assert not same(vertices, vertices.astype(np.float32)) and not same(vertices, vertices[:2])


def test_same_is_strict_about_types_and_nan() -> None:
    assert same({"a": [1.0, [2.0, 3.0]], "b": "x"}, {"a": [1.0, [2.0, 3.0]], "b": "x"})
    assert not same({"a": 1}, {"a": 1.0}) and not same({"a": True}, {"a": 1})
    assert not same([float("nan")], [float("nan")]) and not same({"a": 1}, {"a": 1, "b": 2})
    assert not same([{"p": np.zeros(3)}], [{"p": np.ones(3)}]) and same([{"p": np.zeros(3)}], [{"p": np.zeros(3)}])


def test_a_texture_read_from_a_file_is_read_again(tmp_path) -> None:
    path = tmp_path / "texture.png"
    Image.new("RGB", (2, 2), (255, 0, 0)).save(path)
    document = random_scene_document(5)
    for body in document["materials"].values():
        body["texture"] = {"image": str(path), "colorspace": "linear"}
    for body in document["objects"]:
        if body["type"] == "mesh":
            body["uvs"] = [[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]] * len(body["triangles"])
    kept = LoadedParts()
    scene = scene_from_dict(document, kept=kept)
    Image.new("RGB", (2, 2), (0, 0, 255)).save(path)  # the same name, another picture
    again = scene_from_dict(copy.deepcopy(document), kept=kept)
    assert again is not scene and kept.reused == len(scene.objects)  # the objects, not the materials
    assert pickle.dumps(again) == pickle.dumps(scene_from_dict(document)) != pickle.dumps(scene)


def test_the_same_scene_goes_to_the_workers_as_the_same_message() -> None:
    scene = scene_from_dict(random_scene_document(7, width=24, height=18))
    with parallel.Renderer(2) as renderer:
        first = renderer.render(scene).image
        message, _ = renderer._scenes.message(scene)
        again, _ = renderer._scenes.message(scene)
        assert again is message
        assert np.array_equal(renderer.render(scene).image, first)
        other = scene.with_render(width=24, height=18)  # an equal scene, another object: pickled again
        assert renderer._scenes.message(other)[0] is not message
        assert renderer._scenes.message(other)[0].key == message.key
