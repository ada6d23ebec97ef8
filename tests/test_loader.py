"""Scene files: the shipped ones load and match the JSON Schema; malformed ones get one clear message per problem."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest

from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, default_scene_dict, load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "docs" / "scene.schema.json").read_text())


def test_default_scene_loads_and_follows_the_schema() -> None:
    jsonschema.validate(default_scene_dict(), SCHEMA)
    scene = default_scene()
    assert scene.vane is not None and "arrow_head" in scene.vane.parts
    kinds = {type(obj) for obj in scene.objects}
    assert {sc.Plane, sc.Box, sc.Cylinder, sc.Sphere, sc.Pyramid} <= kinds
    assert {type(light) for light in scene.lights} == {sc.AmbientLight, sc.PointLight, sc.DirectionalLight}


@pytest.mark.parametrize("seed", range(0, 60, 7))
def test_random_test_scenes_follow_the_schema(seed: int) -> None:
    from tests.random_scenes import random_scene_document

    jsonschema.validate(random_scene_document(seed), SCHEMA)


def test_fov_sets_the_lens_as_blender_does() -> None:
    document = default_scene_dict()
    del document["camera"]["lens"]
    document["camera"]["fov"] = 90.0
    assert scene_from_dict(document).camera.lens == pytest.approx(18.0)  # 36 mm / 2 / tan(45 degrees)


def _set(document: dict[str, Any], path: str, value: Any) -> None:
    keys: list[Any] = [int(k) if k.isdigit() else k for k in path.split("/")]
    target = document
    for key in keys[:-1]:
        target = target[key]
    if value is DELETE:
        del target[keys[-1]]
    else:
        target[keys[-1]] = value


DELETE = object()

MALFORMED = [
    ("objects/2/radius", -1, "objects[2].radius: must be > 0, got -1"),
    ("objects/2/radius", 0, "objects[2].radius: must be > 0, got 0"),
    ("objects/2/radius", "thick", 'objects[2].radius: must be a number, got string "thick"'),
    ("objects/2/height", DELETE, "objects[2].height: is required"),
    ("objects/9/radius", True, "objects[9].radius: must be a number, got boolean true"),
    ("objects/1/size", [1, 2], "objects[1].size: must be a list of 3 numbers, got a list of 2"),
    ("objects/1/size", [1, -2, 3], "objects[1].size[1]: must be > 0, got -2"),
    ("objects/0/size", [40], "objects[0].size: must be a list of 2 numbers, got a list of 1"),
    ("objects/12/size", "big", 'objects[12].size: must be a list of 3 numbers, got string "big"'),
    (
        "objects/0/type",
        "torus",
        'objects[0].type: must be one of "sphere", "plane", "cylinder", "box", "pyramid", "mesh", "instance", '
        '"instances", got "torus"',
    ),
    (
        "objects/0/type",
        DELETE,
        "objects[0].type: is required (one of sphere, plane, cylinder, box, pyramid, mesh, instance, instances)",
    ),
    (
        "objects/0/material",
        "gold",
        "objects[0].material: must name one of the materials (brass, copper, iron, stone, "
        'tiles, verdigris), got "gold"',
    ),
    ("objects/0/material", DELETE, "objects[0].material: is required"),
    ("objects/0/location", [0, 0], "objects[0].location: must be a list of 3 numbers, got a list of 2"),
    ("objects/3/rotation", [90, "x", 0], 'objects[3].rotation[1]: must be a number, got string "x"'),
    ("objects/0/colour", [1, 0, 0], "objects[0].colour: is not a known field"),
    ("objects/1/name", "ground", 'objects[1].name: must be unique, got "ground" twice'),
    ("objects", {}, "objects: must be a list of objects, got an object"),
    ("objects", DELETE, "objects: is required"),
    ("objects/0", 7, "objects[0]: must be an object, got number 7"),
    ("materials", DELETE, "materials: is required"),
    ("materials/brass/color", [1.5, 0, 0], "materials.brass.color[0]: must be <= 1, got 1.5"),
    # all floats: the vectors' fast path, which must name the same problems
    ("materials/brass/color", [0.5, 1.0000001, 0.5], "materials.brass.color[1]: must be <= 1, got 1.0000001"),
    ("materials/brass/color", [0.5, -0.25, 0.5], "materials.brass.color[1]: must be >= 0, got -0.25"),
    ("materials/brass/color", [0.5, float("nan"), 0.5], "materials.brass.color[1]: must be a finite number, got nan"),
    ("materials/brass/color", [0.5, float("inf"), 0.5], "materials.brass.color[1]: must be a finite number, got inf"),
    ("objects/1/size", [1.0, 0.0, 3.0], "objects[1].size[1]: must be > 0, got 0"),
    ("objects/1/size", [1.0, 1e-12, 3.0], "objects[1].size[1]: must be at least"),
    ("objects/1/location", [0.0, 1e30, 0.0], "objects[1].location[1]: must be <= "),
    ("lights/2/direction", [0.0, 0.0, 0.0], "lights[2].direction: must not be the zero vector, got [0, 0, 0]"),
    ("materials/brass/color", DELETE, "materials.brass.color: is required"),
    ("materials/brass/reflective", 2, "materials.brass.reflective: must be <= 1, got 2"),
    ("materials/brass/specular", -5, "materials.brass.specular: must be >= 0, got -5"),
    (
        "lights/0/type",
        "lamp",
        'lights[0].type: must be one of "ambient", "point", "directional", "spot", "area", "world", got "lamp"',
    ),
    ("lights/1/intensity", -0.5, "lights[1].intensity: must be >= 0, got -0.5"),
    ("lights/1/location", DELETE, "lights[1].location: is required"),
    ("lights/2/direction", [0, 0, 0], "lights[2].direction: must not be the zero vector, got [0, 0, 0]"),
    ("lights", {"type": "ambient"}, "lights: must be a list of lights, got an object"),
    ("camera/lens", 0, "camera.lens: must be > 0, got 0"),
    ("camera/sensor_fit", "auto", 'camera.sensor_fit: must be one of "AUTO", "HORIZONTAL", "VERTICAL", got "auto"'),
    ("camera/fov", 60, "camera.fov: give either lens or fov, not both"),
    ("render/width", 0, "render.width: must be >= 1, got 0"),
    ("render/height", 2.5, "render.height: must be an integer, got 2.5"),
    ("render/depth", -1, "render.depth: must be >= 0, got -1"),
    ("render/model", "lambert", 'render.model: must be one of "phong", "blinn-phong", got "lambert"'),
    ("render/coef", 0, "render.coef: must be > 0, got 0"),
    ("render/samples", 3, "render.samples: must be a perfect square (1, 4, 9, 16, ...) for the stratified grid, got 3"),
    ("render/dtype", "float16", 'render.dtype: must be one of "float32", "float64", got "float16"'),
    ("render/workers", -2, "render.workers: must be >= 0, got -2"),
    ("render/gate_specular", "yes", 'render.gate_specular: must be true or false, got "yes"'),
    (
        "background/type",
        "gradient",
        'background.type: must be one of "solid", "sky", "documented", "none", "image", got "gradient"',
    ),
    ("background/zenith", [0, 0, -1], "background.zenith[2]: must be >= 0, got -1"),
    ("vane/parts", ["shaft", "propeller"], 'vane.parts[1]: must name an object of the scene, got "propeller"'),
    ("vane/axis", [0, 0, 0], "vane.axis: must not be the zero vector, got [0, 0, 0]"),
    ("vane/heading", None, "vane.heading: must be a number, got null"),
    ("extra", 1, "extra: is not a known field"),
    ("wind/keys/1/time", 0, "wind.keys[1].time: must be after the previous key's time (0), got 0"),
    ("wind/keys/0/speed", 70, "wind.keys[0].speed: must be <= 60, got 70"),
    ("wind/keys/0/direction", -5, "wind.keys[0].direction: must be >= 0, got -5"),
    ("wind/keys", [], "wind.keys: must be a non-empty list of {time, direction, speed}, got a list of 0"),
    ("wind/direction", 90, "wind.keys: give either keys or a constant direction and speed, not both"),
    ("wind/gusts/intensity", 2, "wind.gusts.intensity: must be <= 1, got 2"),
    ("wind/gusts/time_scale", 0, "wind.gusts.time_scale: must be > 0, got 0"),
    ("wind/stop", 0.1, "wind.stop: must be after start (0.25), got 0.1"),
    ("motion/damping", 0, "motion.damping: must be > 0, got 0"),
    ("motion/wavelength", -7, "motion.wavelength: must be > 0, got -7"),
    ("motion/mode", "gust", 'motion.mode: must be one of "wind", "spin", got "gust"'),
    ("motion/fps", 0, "motion.fps: must be > 0, got 0"),
    (
        "motion/spin/direction",
        "left",
        'motion.spin.direction: must be one of "clockwise", "counterclockwise", got "left"',
    ),
    ("motion/spin/smoothness", -1, "motion.spin.smoothness: must be >= 0, got -1"),
    ("render/numerics", "exact", 'render.numerics: must be one of "documented", "robust", got "exact"'),
]


@pytest.mark.parametrize(("path", "value", "message"), MALFORMED, ids=[f"{m[0]}={m[1]!r}" for m in MALFORMED])
def test_malformed_scene_names_the_field(path: str, value: Any, message: str) -> None:
    document = copy.deepcopy(default_scene_dict())
    _set(document, path, value)
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert any(problem.startswith(message) for problem in caught.value.problems), caught.value.problems


def test_every_problem_is_reported_at_once() -> None:
    document = copy.deepcopy(default_scene_dict())
    document["objects"][2]["radius"] = -1
    document["render"]["width"] = 0
    document["lights"][0]["type"] = "lamp"
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert len(caught.value.problems) == 3


def test_file_problems(tmp_path: Path) -> None:
    missing = tmp_path / "missing.json"
    with pytest.raises(SceneError, match="cannot read the file"):
        load_scene(missing)
    broken = tmp_path / "broken.json"
    broken.write_text('{"materials": {,}')
    with pytest.raises(SceneError, match=r"line 1 column 16: invalid JSON"):
        load_scene(broken)
    nan = tmp_path / "nan.json"
    nan.write_text('{"materials": {"m": {"color": [NaN, 0, 0]}}, "objects": []}')
    with pytest.raises(SceneError, match="NaN is not a number JSON allows"):
        load_scene(nan)
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(binary)
    top = tmp_path / "list.json"
    top.write_text("[1, 2]")
    with pytest.raises(SceneError, match=r"\(top level\): must be an object, got a list of 2"):
        load_scene(top)


def test_degenerate_triangles_are_refused() -> None:
    document = default_scene_dict()
    document["objects"].append(
        {
            "name": "sliver",
            "type": "mesh",
            "material": "stone",
            "vertices": [[0, 0, 0], [1, 1, 1], [2, 2, 2], [0, 1, 0]],
            "triangles": [[0, 1, 3], [0, 1, 2]],
        }
    )
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert caught.value.problems == [
        "objects[14].triangles[1]: must span an area (its vertices 0, 1, 2 are on one line)"
    ]


def test_a_valid_mesh_checked_as_arrays_loads_the_same_scene_as_the_per_entry_loop(monkeypatch) -> None:
    """The array check of a mesh's vertices and triangles (large meshes) gives the scene the loop gives, and leaves
    every invalid mesh to the loop, which names the entry."""
    from tracer.scene import loader as loader_module

    rng = np.random.default_rng(7)
    vertices = rng.uniform(-2, 2, (40, 3)).round(6).tolist()
    vertices[0] = [1, 2, 3]  # integers too
    triangles = [[int(a), int(b), int(c)] for a, b, c in rng.permuted(np.tile(np.arange(40), (60, 1)), axis=1)[:, :3]]
    document = default_scene_dict()
    document["objects"].append({"name": "m", "type": "mesh", "material": "iron", "vertices": vertices,
                                "triangles": triangles})  # fmt: skip
    fast = scene_from_dict(document)
    assert loader_module._mesh_arrays(vertices, triangles) is not None
    monkeypatch.setattr(loader_module, "_mesh_arrays", lambda *args: None)
    assert scene_from_dict(document) == fast
    monkeypatch.undo()
    for bad, field in (([[0, 1, True]], "triangles[0]"), ([[0, 1, 40]], "triangles[0]"), ([[0, 0, 1]], "triangles[0]")):
        assert loader_module._mesh_arrays(vertices, bad) is None
        broken = json.loads(json.dumps(document))
        broken["objects"][-1]["triangles"] = bad
        with pytest.raises(SceneError) as error:
            scene_from_dict(broken)
        assert any(field in problem for problem in error.value.problems), error.value.problems


def _meshes_document(count: int, seed: int) -> dict:
    """The default scene with count small meshes (lists, as an export writes separate objects), some with integer
    coordinates."""
    rng = np.random.default_rng(seed)
    document = default_scene_dict()
    for k in range(count):
        size = int(rng.integers(4, 9))
        vertices = rng.uniform(-3, 3, (size, 3)).round(5).tolist()
        if k % 3 == 0:
            vertices[0] = [int(v) for v in rng.integers(-3, 3, 3)]
        corners = rng.permuted(np.tile(np.arange(size), (2 * size, 1)), axis=1)[:, :3]
        document["objects"].append({"name": f"m{k}", "type": "mesh", "material": "iron", "vertices": vertices,
                                    "triangles": corners.tolist()})  # fmt: skip
    return document


def test_many_small_meshes_checked_in_bulk_load_the_scene_each_check_alone_loads(monkeypatch) -> None:
    """Separate objects' meshes checked together (_meshes_in_bulk) give the scene, to its pickled bytes (what the
    workers key their preparation on), that checking each mesh as arrays gives, and that the per-entry loop gives."""
    import pickle

    from tracer.scene import loader as loader_module

    document = _meshes_document(40, 3)
    bulk = scene_from_dict(document)
    checked = loader_module._meshes_in_bulk(document["objects"])
    assert len(checked) == 40
    assert not any(vertices.flags.writeable or triangles.flags.writeable for vertices, triangles in checked.values())
    monkeypatch.setattr(loader_module, "_meshes_in_bulk", lambda bodies: {})
    one_by_one = scene_from_dict(document)
    monkeypatch.setattr(loader_module, "_mesh_arrays", lambda *args: None)
    loop = scene_from_dict(document)
    assert bulk == one_by_one == loop
    assert pickle.dumps(bulk, protocol=5) == pickle.dumps(one_by_one, protocol=5)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        (
            "triangles",
            [[0, 1, 2], [0, 1, 8]],
            "objects[31].triangles[1]: must be 3 vertex indices in 0..7, got [0, 1, 8]",
        ),
        (
            "triangles",
            [[0, 1, 2], [0, 1, -1]],
            "objects[31].triangles[1]: must be 3 vertex indices in 0..7, got [0, 1, -1]",
        ),
        (
            "triangles",
            [[0, 1, 2], [0, 1, True]],
            "objects[31].triangles[1]: must be 3 vertex indices in 0..7, got [0, 1, true]",
        ),
        ("triangles", [[0, 1, 2], [3, 3, 4]], "objects[31].triangles[1]: must span an area"),
        ("vertices", "rows", "objects[31].vertices: must be a non-empty list of [x, y, z]"),
    ],
)
def test_a_bad_mesh_among_many_is_named_as_alone(field: str, value: Any, message: str) -> None:
    """One bad mesh among many (an index past its own vertices but within the meshes' joined ones, a boolean, a
    sliver) leaves the bulk check to the one-by-one checks, which name the entry."""
    document = _meshes_document(40, 5)
    target = document["objects"][31]
    target["vertices"] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0],
                          [0.5, 0.0, 1.0], [0.0, 0.5, 1.0], [1.0, 0.5, 0.0]]  # fmt: skip
    target["triangles"] = [[0, 1, 2], [2, 3, 5]]
    scene_from_dict(document)  # valid as it stands
    target[field] = value
    with pytest.raises(SceneError) as caught:
        scene_from_dict(document)
    assert any(problem.startswith(message) for problem in caught.value.problems), caught.value.problems
