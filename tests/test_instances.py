"""Instances: a mesh placed many times is traced through a two-level hierarchy, and it gives what the per-pixel
reference gives (each instance tested in turn, the ray taken into its space), what a brute-force test of every
instance gives, and what the same scene flattened into world triangles gives except on silhouette edges."""

from __future__ import annotations

import math
import random
from typing import Any

import numpy as np
import pytest

from tracer.geometry import meshbvh
from tracer.geometry import transforms as tf
from tracer.geometry.instances import InstancesKernel, instances_kernel
from tracer.geometry.kernels import make_kernel, quiet
from tracer.geometry.robust import make_robust_kernel
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, scene_from_dict
from tracer.tracing import prepared as preparation
from tracer.tracing import wavefront
from tracer.tracing.reference import render_reference
from tracer.workers.parallel import render


def _octahedron(rng: random.Random, smooth: bool, slots: bool) -> dict[str, Any]:
    """A lumpy octahedron (8 triangles, counter-clockwise from outside), with corner normals and two material slots
    where asked."""
    radii = [rng.uniform(0.5, 1.0) for _ in range(6)]
    axes = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    vertices = [[r * a for a in axis] for r, axis in zip(radii, axes, strict=True)]
    triangles = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    mesh: dict[str, Any] = {"vertices": vertices, "triangles": triangles, "material": "m0"}
    if smooth:
        mesh["normals"] = [[[v / math.hypot(*vertices[k]) for v in vertices[k]] for k in tri] for tri in triangles]
    if slots:
        mesh["materials"] = ["m1", "m2"]
        mesh["material_indices"] = [rng.randrange(2) for _ in triangles]
    return mesh


def _matrix(rng: random.Random, mirror: bool) -> list[float]:
    """A random placement (12 numbers, row-major 3x4): rotated, scaled unevenly, mirrored where asked."""
    scale = [rng.uniform(0.2, 0.7) for _ in range(3)]
    if mirror:
        scale[rng.randrange(3)] *= -1.0
    placed = sc.matrix_from_transform(
        (rng.uniform(-2.5, 2.5), rng.uniform(-1.5, 2.5), rng.uniform(-0.3, 1.5)),
        tuple(rng.uniform(-180, 180) for _ in range(3)),
        tuple(scale),
    )
    return placed.ravel().tolist()


def instanced_scene_document(seed: int, width: int = 20, height: int = 15) -> dict[str, Any]:
    """A random scene of instances: one or two meshes, each placed by one to three groups of 1 to 12 instances
    (rotated, unevenly scaled, some mirrored, some with a material override or ray visibility off), over a plane,
    lit by point and directional lights, mirrors at depth 3."""
    rng = random.Random(seed)
    meshes = {f"mesh{k}": _octahedron(rng, smooth=rng.random() < 0.5, slots=rng.random() < 0.5) for k in range(2)}
    objects: list[dict[str, Any]] = []
    for group in range(rng.randrange(2, 5)):
        body: dict[str, Any] = {
            "type": "instances",
            "name": f"group{group}",
            "mesh": f"mesh{rng.randrange(2)}",
            "matrices": [_matrix(rng, mirror=rng.random() < 0.3) for _ in range(rng.randrange(1, 13))],
        }
        if rng.random() < 0.3:
            body["material"] = f"m{rng.randrange(3)}"
        if rng.random() < 0.2:
            body[rng.choice(("visible_camera", "visible_shadow", "visible_reflection"))] = False
        objects.append(body)
    objects.append(
        {"type": "instance", "name": "single", "mesh": "mesh0", "location": [0.3, 0.2, 1.8], "scale": [0.4, 0.4, -0.3]}
    )
    objects.append({"type": "sphere", "name": "ball", "material": "m1", "location": [-1.5, 1.5, 0.4], "radius": 0.4})
    objects.append({"type": "plane", "name": "floor", "material": "m0", "location": [0, 0, -0.6]})
    materials = {
        f"m{k}": {
            "color": [rng.random() for _ in range(3)],
            "specular": rng.choice([0, 10, 100]),
            "reflective": rng.choice([0.0, 0.3, 0.6]),
        }
        for k in range(3)
    }
    lights = [
        {"type": "ambient", "intensity": 0.2},
        {"type": "point", "location": [rng.uniform(-4, 4), rng.uniform(-4, 1), 5.0], "intensity": 0.6},
        {"type": "directional", "direction": [0.3, -0.4, 1.0], "intensity": 0.3},
    ]
    return {
        "materials": materials,
        "meshes": meshes,
        "objects": objects,
        "lights": lights,
        "camera": {"location": [6.5, -6.0, 4.5], "rotation": [62.0, 0.0, 47.0], "lens": 35},
        "render": {"width": width, "height": height, "depth": 3, "workers": 1},
    }


def flattened(scene: sc.Scene) -> sc.Scene:
    """The same scene with every instance written out as a mesh of world triangles (two corners swapped where the
    placement mirrors, as the export of world triangles does; corner normals by the inverse transpose)."""
    objects = []
    for obj in scene.objects:
        if not isinstance(obj, sc.MeshInstances):
            objects.append(obj)
            continue
        mesh = obj.mesh
        for k, matrix in enumerate(np.asarray(obj.matrices)):
            linear, offset = matrix[:, :3], matrix[:, 3]
            mirrored = np.linalg.det(linear) < 0.0
            order = [0, 2, 1] if mirrored else [0, 1, 2]
            normals = None
            if mesh.normals is not None:
                placed = np.asarray(mesh.normals) @ np.linalg.inv(linear)  # n @ A^-1 = (A^-T n)^T
                normals = placed[:, order]
            objects.append(
                sc.TriangleMesh(
                    name=f"{obj.name}#{k}",
                    material=obj.material,
                    vertices=np.asarray(mesh.vertices) @ linear.T + offset,
                    triangles=np.asarray(mesh.triangles)[:, order],
                    normals=normals,
                    materials=obj.materials,
                    material_indices=obj.material_indices,
                    visible_camera=obj.visible_camera,
                    visible_shadow=obj.visible_shadow,
                    visible_reflection=obj.visible_reflection,
                    holdout=obj.holdout,
                )
            )
    return sc.Scene(scene.materials, tuple(objects), scene.lights, scene.camera, scene.background, scene.render)


SEEDS = range(16)


@pytest.mark.parametrize("seed", SEEDS)
def test_random_instanced_scenes_match_the_per_pixel_reference(seed: int) -> None:
    scene = scene_from_dict(instanced_scene_document(seed))
    expected = np.asarray(render_reference(scene))
    image = render(scene, workers=1).image
    assert np.all(np.isfinite(image))
    np.testing.assert_allclose(image, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(("dtype", "tolerance"), [("float64", 1e-9), ("float32", 1e-4)])
def test_an_instanced_scene_and_the_same_scene_flattened_differ_only_on_silhouette_edges(
    seed: int, dtype: str, tolerance: float
) -> None:
    """The two trace the same surfaces; t in an instance's space rounds differently from t on world triangles, so
    a ray that grazes a silhouette edge, or meets two surfaces at nearly the same t, may go either way. Such pixels
    are few (at most 2% here, 40 by 30 pixels); every other pixel agrees to 1e-9 in float64, and to 1e-4 in float32
    (whose shading rounds at about 1e-7 of the hit's coordinates, differently on each side)."""
    scene = scene_from_dict(instanced_scene_document(seed, 40, 30)).with_render(dtype=dtype)
    instanced = render(scene, workers=1).image
    flat = render(flattened(scene), workers=1).image
    differs = np.abs(instanced.astype(np.float64) - flat).max(axis=2) > tolerance
    assert differs.mean() <= 0.02, differs.mean()


def _random_rays(rng: np.random.Generator, count: int, dtype: np.dtype) -> tuple[np.ndarray, np.ndarray]:
    O = rng.uniform(-4, 4, (3, count))
    target = rng.uniform(-2.5, 2.5, (3, count))
    return O.astype(dtype), (target - O).astype(dtype)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("robust", [False, True])
@pytest.mark.parametrize("any_hit", [False, True])
def test_the_two_level_walk_finds_what_testing_every_instance_finds(dtype: str, robust: bool, any_hit: bool) -> None:
    """Against brute force on the same numbers: every instance's rays taken into its space and tested against
    every triangle of the mesh; the nearest t, then the lowest instance, then the lowest triangle."""
    dtype = np.dtype(dtype)
    rng = np.random.default_rng(3)
    doc = instanced_scene_document(5)
    doc["objects"] = [
        {"type": "instances", "mesh": "mesh0", "matrices": [_matrix(random.Random(k), k % 3 == 0) for k in range(300)]}
    ]
    scene = scene_from_dict(doc)
    primitive = tf.world_primitive(scene.objects[0], None)
    make = make_robust_kernel if robust else make_kernel
    kernel = instances_kernel(make, primitive, dtype)
    whole = make(primitive.mesh, dtype)  # the whole mesh in its own space, every triangle on every ray
    O, D = _random_rays(rng, 3000, dtype)
    limit = np.where(rng.random(3000) < 0.5, np.inf, rng.uniform(0.3, 1.5, 3000)).astype(dtype)
    with quiet():
        t, part = kernel.hit(O, D, 0.001, limit, any_hit=any_hit)
        best_t = np.full(3000, np.inf, dtype=dtype)
        best_part = np.zeros(3000, dtype=np.int64)
        for k in range(kernel.instance_count):  # in order, strictly nearer: the first instance on ties
            origin, direction = kernel.to_local(O, D, np.full(3000, k))
            found_t, found_triangle = whole._hit(origin, direction, 0.001, limit)
            nearer = found_t < best_t
            best_t[nearer] = found_t[nearer]
            best_part[nearer] = k * kernel.triangles + np.asarray(found_triangle)[nearer]
    assert (best_t < np.inf).sum() > 300  # the rays meet instances
    np.testing.assert_array_equal(t < np.inf, best_t < np.inf)
    if not any_hit:
        np.testing.assert_array_equal(t, best_t)
        np.testing.assert_array_equal(part, best_part)


def test_the_float32_box_tests_of_instances_meet_every_box_the_float64_tests_meet() -> None:
    """The instances' walk tests its nodes' and instances' boxes in float32 on boxes grown by the test's error bound
    (InstancesKernel._box_rays, kernels.grown_float32). Rays from 30,000 away through the boxes' corners: every box
    the float64 test meets is met; and those rays and rays between the instances find brute force's hits."""
    from tracer.geometry.kernels import slab

    rng = np.random.default_rng(8)
    doc = instanced_scene_document(5)
    doc["objects"] = [
        {"type": "instances", "mesh": "mesh0", "matrices": [_matrix(random.Random(k), k % 3 == 0) for k in range(300)]}
    ]
    primitive = tf.world_primitive(scene_from_dict(doc).objects[0], None)
    kernel = instances_kernel(make_kernel, primitive, np.dtype(np.float64))
    lower64 = np.concatenate((kernel.child_boxes[:6].reshape(3, -1), kernel.box_lower), axis=1)
    upper64 = np.concatenate((kernel.child_boxes[6:].reshape(3, -1), kernel.box_upper), axis=1)
    corner = np.where(rng.integers(0, 2, lower64.shape) == 1, lower64, upper64)
    away = rng.normal(size=corner.shape)
    O = corner + 30000.123456789 * away / np.linalg.norm(away, axis=0)
    D = corner - O
    with quiet():
        boxes = kernel._box_rays(O, D)
        lower32 = np.concatenate((boxes.child_boxes[:6].reshape(3, -1), boxes.box_lower), axis=1)
        upper32 = np.concatenate((boxes.child_boxes[6:].reshape(3, -1), boxes.box_upper), axis=1)
        assert lower32.dtype == np.float32 and np.all(lower32 <= lower64) and np.all(upper32 >= upper64)
        near, far = slab(O, 1.0 / D, lower64, upper64)
        near32, far32 = slab(boxes.origins, boxes.inverses, lower32, upper32)
        assert (near <= far).sum() > corner.shape[1] // 2 and not np.any((near <= far) & ~(near32 <= far32))
        whole = make_kernel(primitive.mesh, np.dtype(np.float64))
        O_between, D_between = _random_rays(rng, 2000, np.dtype(np.float64))
        for origins, directions in ((O, D), (O_between, D_between)):
            count = origins.shape[1]
            t, part = kernel.hit(origins, directions, 0.001, np.inf)
            best_t = np.full(count, np.inf)
            best_part = np.zeros(count, dtype=np.int64)
            for k in range(kernel.instance_count):
                origin, direction = kernel.to_local(origins, directions, np.full(count, k))
                found_t, found_triangle = whole._hit(origin, direction, 0.001, np.inf)
                nearer = found_t < best_t
                best_t[nearer] = found_t[nearer]
                best_part[nearer] = k * kernel.triangles + np.asarray(found_triangle)[nearer]
            np.testing.assert_array_equal(t, best_t)
            np.testing.assert_array_equal(part, best_part)
            assert (best_t < np.inf).sum() > count // 10


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_the_bounding_sphere_test_keeps_every_pair_with_a_hit_and_drops_others(dtype: str) -> None:
    """InstancesKernel._meets_sphere against the whole mesh's test in each instance's space: every (ray, instance)
    pair with a hit in (t_min, limit) is kept, among them rays that graze the mesh and rays that start on it."""
    dtype = np.dtype(dtype)
    rng = np.random.default_rng(8)
    doc = instanced_scene_document(2)
    doc["objects"] = [
        {"type": "instances", "mesh": "mesh0", "matrices": [_matrix(random.Random(k), k % 2 == 0) for k in range(40)]}
    ]
    primitive = tf.world_primitive(scene_from_dict(doc).objects[0], None)
    kernel = instances_kernel(make_kernel, primitive, dtype)
    whole = make_kernel(primitive.mesh, dtype)
    O, D = _random_rays(rng, 4000, dtype)
    surface = rng.integers(0, len(primitive.mesh.triangles), 1000)  # rays from points on the mesh itself
    weights = rng.dirichlet((1.0, 1.0, 1.0), 1000)
    on_mesh = np.einsum("nv,nvi->in", weights, primitive.mesh.triangles[surface])
    # rays aimed just inside a triangle's corner farthest from the sphere's centre: the hits nearest the sphere
    centre, _ = kernel.sphere
    corners = primitive.mesh.triangles[rng.integers(0, len(primitive.mesh.triangles), 1000)]  # (n, 3, 3)
    far = np.argmax(((corners - centre) ** 2).sum(axis=2), axis=1)
    grazing = np.where(np.arange(3)[None, :] == far[:, None], 0.9998, 0.0001)
    aimed = np.einsum("nv,nvi->in", grazing, corners)
    limit = np.where(rng.random(4000) < 0.5, np.inf, rng.uniform(0.3, 1.5, 4000)).astype(dtype)
    limit[1000:2000] = np.inf
    kept_hits = dropped = 0
    with quiet():
        for k in range(kernel.instance_count):
            origin, direction = kernel.to_local(O, D, np.full(4000, k))
            origin[:, :1000] = on_mesh.astype(dtype)
            direction[:, 1000:2000] = (aimed - origin[:, 1000:2000]).astype(dtype)
            found_t, _ = whole._hit(origin, direction, 0.001, limit)
            meets = kernel._meets_sphere(origin, direction, 0.001, limit)
            assert meets[found_t < np.inf].all()
            kept_hits += int((found_t < np.inf).sum())
            dropped += int((~meets).sum())
    assert kept_hits > 1000 and dropped > 1000  # both cases are there


@pytest.mark.parametrize("any_hit", [False, True])
def test_instances_queried_in_pieces_of_rays_give_what_one_query_of_them_all_gives(any_hit: bool, monkeypatch) -> None:
    doc = instanced_scene_document(4)
    doc["objects"] = [
        {"type": "instances", "mesh": "mesh0", "matrices": [_matrix(random.Random(k), k % 3 == 0) for k in range(200)]}
    ]
    kernel = instances_kernel(
        make_kernel, tf.world_primitive(scene_from_dict(doc).objects[0], None), np.dtype("float64")
    )
    O, D = _random_rays(np.random.default_rng(6), 3000, np.dtype("float64"))
    limit = np.where(np.arange(3000) % 2 == 0, np.inf, 0.3 + np.arange(3000) % 5 * 0.3)
    with quiet():
        whole_t, whole_part = kernel.hit(O, D, 0.001, limit, any_hit=any_hit)
        monkeypatch.setattr(meshbvh, "RAY_PIECE", 257)  # 12 pieces, the last one short
        t, part = kernel.hit(O, D, 0.001, limit, any_hit=any_hit)
    assert np.array_equal(t, whole_t) and np.array_equal(part, whole_part)
    assert 0.1 < (t < np.inf).mean() < 0.95


def test_instances_render_the_same_bytes_with_one_worker_or_two_and_in_every_mode() -> None:
    scene = scene_from_dict(instanced_scene_document(7, 64, 48))
    for settings in ({}, {"dtype": "float32"}, {"numerics": "robust"}, {"numerics": "robust", "dtype": "float32"}):
        changed = scene.with_render(**settings)
        one, two = render(changed, workers=1).image, render(changed, workers=2).image
        assert np.all(np.isfinite(one))
        assert one.tobytes() == two.tobytes(), settings


def test_twenty_thousand_instances_of_one_mesh_are_prepared_without_comparing_meshes() -> None:
    """The kernel cache finds a mesh by its digest: 20,000 instances placed as one group, or as world meshes of one
    shape (the old export), compare arrays only where a digest matches, not each against every other."""
    rng = random.Random(1)
    mesh = _octahedron(rng, smooth=False, slots=False)
    doc = {
        "materials": {"m0": {"color": [0.5, 0.5, 0.5]}},
        "meshes": {"tree": mesh},
        "objects": [{"type": "instances", "mesh": "tree", "matrices": [_matrix(rng, False) for _ in range(20000)]}],
        "render": {"width": 8, "height": 6, "workers": 1},
    }
    scene = scene_from_dict(doc)
    preparation._KERNELS.clear()
    before = sc.ARRAY_COMPARISONS[0]
    wavefront.TracedScene(scene)
    wavefront.TracedScene(scene)  # the second finds the kernels kept by the first
    assert sc.ARRAY_COMPARISONS[0] - before <= 4
    # 2,000 separate meshes of one shape (each its own vertices): no comparison between different meshes
    separate = flattened(
        scene_from_dict({**doc, "objects": [{**doc["objects"][0], "matrices": doc["objects"][0]["matrices"][:2000]}]})
    )
    before = sc.ARRAY_COMPARISONS[0]
    wavefront.TracedScene(separate)
    assert sc.ARRAY_COMPARISONS[0] - before <= 10


def test_an_instance_costs_its_matrix_not_its_triangles() -> None:
    rng = random.Random(2)
    mesh = _octahedron(rng, smooth=True, slots=False)
    doc = {
        "materials": {"m0": {"color": [0.5, 0.5, 0.5]}},
        "meshes": {"tree": mesh},
        "objects": [{"type": "instances", "mesh": "tree", "matrices": [_matrix(rng, False) for _ in range(5000)]}],
    }
    scene = scene_from_dict(doc)
    kernel = wavefront.TracedScene(scene).kernels[0]
    assert isinstance(kernel, InstancesKernel)
    per_instance = (
        sum(
            array.nbytes
            for array in (kernel.inverse, kernel.cofactor, kernel.box_lower, kernel.box_upper, kernel.top.lower)
        )
        / kernel.instance_count
    )
    assert per_instance < 400  # bytes: 12 + 9 numbers, a box, a share of the top hierarchy; no triangle
    assert kernel.local.count == 8  # the mesh's triangles, once


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"mesh": "nope"}, "objects[0].mesh: must name a mesh of the scene's meshes (tree)"),
        ({"matrices": []}, "objects[0].matrices: must be a non-empty list of placements"),
        ({"matrices": [[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0]]}, "objects[0].matrices[0]: must be invertible"),
        ({"matrices": [[1, 0, 0]]}, "objects[0].matrices[0]: must be a 3x4 or 4x4 matrix"),
        (
            {"matrices": [[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]]},
            "objects[0].matrices[0]: must have a last row",
        ),
        ({"location": [1, 2, 3]}, 'objects[0].location: is not a field of "instances"'),
        ({"material": "nope"}, "objects[0].material: must name one of the materials"),
    ],
)
def test_bad_instances_are_named_by_field(change: dict, message: str) -> None:
    rng = random.Random(0)
    doc = {
        "materials": {"m0": {"color": [0.5, 0.5, 0.5]}, "m1": {"color": [1, 0, 0]}, "m2": {"color": [0, 1, 0]}},
        "meshes": {"tree": _octahedron(rng, smooth=False, slots=False)},
        "objects": [{"type": "instances", "mesh": "tree", "matrices": [_matrix(rng, False)], **change}],
    }
    with pytest.raises(SceneError) as caught:
        scene_from_dict(doc)
    assert any(problem.startswith(message) for problem in caught.value.problems), caught.value.problems


def test_one_instance_by_location_rotation_and_scale_is_blenders_matrix() -> None:
    matrix = sc.matrix_from_transform((1.0, 2.0, 3.0), (10.0, -20.0, 30.0), (1.0, -2.0, 0.5))
    rotation = np.asarray(tf.euler_xyz_matrix((10.0, -20.0, 30.0)))
    np.testing.assert_allclose(matrix[:, :3], rotation * [1.0, -2.0, 0.5], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(matrix[:, 3], [1.0, 2.0, 3.0])


def many_small_meshes_document(seed: int, count: int = 90, width: int = 24, height: int = 18) -> dict[str, Any]:
    """count boxes, pyramids and small meshes, each its own object and material, some with ray visibility off or a
    smooth mesh's normals, over a plane: enough of them to be merged into one kernel."""
    rng = random.Random(seed)
    objects: list[dict[str, Any]] = []
    for k in range(count):
        kind = rng.choice(("box", "pyramid", "mesh"))
        body: dict[str, Any] = {
            "type": kind,
            "name": f"{kind}{k}",
            "material": f"m{k % 5}",
            "location": [rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5), rng.uniform(0.0, 1.0)],
            "rotation": [rng.uniform(-180, 180) for _ in range(3)],
        }
        if kind == "mesh":
            mesh = _octahedron(rng, smooth=rng.random() < 0.5, slots=False)
            body["vertices"] = [[0.3 * x for x in v] for v in mesh["vertices"]]
            body["triangles"] = mesh["triangles"]
            if "normals" in mesh:
                body["normals"] = mesh["normals"]
        else:
            body["size"] = [rng.uniform(0.1, 0.5) for _ in range(3)]
        if rng.random() < 0.1:
            body[rng.choice(("visible_camera", "visible_shadow", "visible_reflection"))] = False
        objects.append(body)
    objects.append({"type": "plane", "name": "floor", "material": "m0", "location": [0, 0, -0.3]})
    document = instanced_scene_document(seed, width, height)
    document.pop("meshes")
    document["materials"].update(
        {f"m{k}": {"color": [rng.random() for _ in range(3)], "specular": 20, "reflective": 0.3} for k in range(3, 5)}
    )
    return {**document, "objects": objects}


@pytest.mark.parametrize("seed", range(3))
def test_many_small_meshes_merged_into_one_kernel_match_the_per_pixel_reference(seed: int) -> None:
    scene = scene_from_dict(many_small_meshes_document(seed))
    prepared = wavefront.TracedScene(scene)
    assert len(prepared.merged_starts) >= 1  # merged: the case under test
    expected = np.asarray(render_reference(scene))
    np.testing.assert_allclose(render(scene, workers=1).image, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("leaves", ["objects", "triangles"])
@pytest.mark.parametrize("settings", [{}, {"dtype": "float32"}, {"numerics": "robust"}])
def test_merged_meshes_trace_the_same_bytes_as_a_leaf_per_object(settings: dict, leaves: str, monkeypatch) -> None:
    """Merged into one kernel, with a leaf per object (these are all small) or the median splits of their triangles,
    the same bytes as a kernel per object."""
    if leaves == "triangles":
        monkeypatch.setattr(meshbvh, "OBJECT_LEAF_TRIANGLES", 0)
    preparation._KERNELS.clear()
    scene = scene_from_dict(many_small_meshes_document(7, 120, 48, 36)).with_render(**settings)
    kernel = wavefront.TracedScene(scene).merged_starts[0][0]
    assert (kernel.hierarchy.leaf_size == 12) == (leaves == "objects")  # the largest member: a box's 12 triangles
    merged = render(scene, workers=1)
    monkeypatch.setattr(preparation, "MERGE_MESHES_FROM", 10**9)
    preparation._KERNELS.clear()
    separate = render(scene, workers=1)
    assert merged.image.tobytes() == separate.image.tobytes()
    assert merged.rays == separate.rays


def test_an_object_hierarchy_has_a_leaf_holding_each_object_whole_inside_its_box() -> None:
    rng = np.random.default_rng(5)
    sizes = rng.integers(1, 13, size=200)
    starts = np.cumsum(sizes) - sizes
    centres = rng.uniform(-20.0, 20.0, size=(sizes.size, 1, 1, 3))
    triangles = np.repeat(centres, sizes, axis=0)[:, 0] + rng.uniform(-0.5, 0.5, size=(int(sizes.sum()), 3, 3))
    tree = meshbvh.object_hierarchy(triangles, starts, sizes, np.dtype(np.float64))
    assert tree.leaf_size == sizes.max()
    leaves = (tree.left < 0).nonzero()[0]
    held = [tree.leaf_triangles[tree.leaf_row[leaf]][tree.real[tree.leaf_row[leaf]]] for leaf in leaves]
    assert sorted(tuple(row.tolist()) for row in held) == [
        tuple(range(start, start + size)) for start, size in zip(starts.tolist(), sizes.tolist(), strict=True)
    ]
    for leaf, row in zip(leaves, held, strict=True):
        corners = triangles[row].reshape(-1, 3)
        assert np.all(tree.lower[:, leaf] < corners.min(axis=0)) and np.all(corners.max(axis=0) < tree.upper[:, leaf])


def test_instanced_scenes_follow_the_schema_and_the_schema_refuses_what_the_loader_refuses() -> None:
    import json
    from pathlib import Path

    import jsonschema

    schema = json.loads((Path(__file__).resolve().parents[1] / "docs" / "scene.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    for seed in range(8):
        document = instanced_scene_document(seed)
        assert not list(validator.iter_errors(document)), seed
        scene_from_dict(document)
    document = instanced_scene_document(0)
    document["objects"][0]["location"] = [1, 2, 3]  # a group of placements has no location of its own
    assert list(validator.iter_errors(document))
    with pytest.raises(SceneError):
        scene_from_dict(document)


def test_turning_instances_and_still_ones_give_whole_frames_incrementally_and_in_batches() -> None:
    """A vane of instances (one group turns, the others stand): incremental frames equal whole frames, and frames
    traced together equal each frame alone (tests/test_incremental.py's checks)."""
    from tests.test_incremental import assert_frames_are_whole_frames, assert_frames_together_are_frames_alone

    for dtype, numerics in (("float64", "documented"), ("float32", "robust")):
        document = instanced_scene_document(3, 40, 30)
        document["render"].update(depth=4, dtype=dtype, numerics=numerics)
        document["vane"] = {"parts": ["group0", "single"], "pivot": [0.2, 0.4, 0.0], "axis": [0.1, 0.0, 1.0]}
        scene = scene_from_dict(document)
        turns = [0.0, 3.0, 40.0, 41.5, 200.0]
        assert_frames_are_whole_frames(scene, turns, workers=1)
        assert_frames_together_are_frames_alone(scene, turns, 3)


def test_an_edit_of_an_instanced_scene_traces_again_only_what_it_touches() -> None:
    """A material edit and a moved group, through EditableImage (the Rendered view's path): the same bytes as a
    whole render of the edited scene; a re-export of the same scene (new objects, same
    meshes and placements) is no edit at all."""
    from dataclasses import replace

    from tracer.frames.edits import EditableImage, edits_between

    document = instanced_scene_document(4, 48, 36)
    scene = scene_from_dict(document)
    assert edits_between(scene, scene_from_dict(document)) == []
    image = EditableImage(scene)
    recoloured = replace(scene.materials["m2"], color=(0.9, 0.1, 0.4))
    edited = replace(scene, materials={**scene.materials, "m2": recoloured})
    moved_objects = tuple(
        replace(obj, location=(0.3, -0.2, 0.1)) if obj.name == "group1" else obj for obj in edited.objects
    )
    for new in (edited, replace(edited, objects=moved_objects)):
        edits = edits_between(image.scene, new)
        assert edits, "an edit, not a new scene"
        for edit in edits:
            shown = image.apply(edit)
        assert np.array_equal(shown, render(new, workers=1).image)


def test_parts_beyond_int32_are_kept_in_int64() -> None:
    """A hit's part is instance * T + triangle: a group whose instances times triangles pass 2^31 gets int64 parts
    from the hierarchy (counted, not built: the same kernel with its count raised)."""
    from tracer.geometry.bvh import Hierarchy

    scene = scene_from_dict(instanced_scene_document(2))
    primitive = tf.world_primitive(scene.objects[0], None)
    kernel = instances_kernel(make_kernel, primitive, np.dtype(np.float64))
    rng = np.random.default_rng(0)
    O, D = _random_rays(rng, 500, np.dtype(np.float64))
    small = Hierarchy([kernel], np.dtype(np.float64)).closest(O, D, 0.0)
    kernel.count = 2**31
    large = Hierarchy([kernel], np.dtype(np.float64)).closest(O, D, 0.0)
    assert small[2].dtype == np.int32 and large[2].dtype == np.int64
    assert (small[1] >= 0).any()
    np.testing.assert_array_equal(small[2], large[2])
