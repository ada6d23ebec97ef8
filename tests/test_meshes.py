"""Large meshes (tracer/geometry/meshbvh.py): their own hierarchy finds exactly the hits of the whole-mesh test."""

from __future__ import annotations

import pickle
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tracer.frames import edits
from tracer.geometry import lightsamples, meshbvh, meshpicture
from tracer.geometry import transforms as tf
from tracer.geometry.kernels import make_kernel, quiet
from tracer.geometry.kernels import slab as kernels_slab
from tracer.geometry.meshbvh import MESH_HIERARCHY_TRIANGLES, MeshKernel
from tracer.geometry.meshpicture import View
from tracer.geometry.robust import make_robust_kernel
from tracer.scene import scene as sc
from tracer.scene.loader import scene_from_dict
from tracer.tracing import wavefront
from tracer.tracing.reference import render_reference
from tracer.workers import parallel
from tracer.workers.parallel import render

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import mesh_scenes
from study import triangles as uv_sphere


def soup(count: int, seed: int) -> tf.WorldTriangles:
    """Random triangles crossing each other, some repeated exactly (ties: the lower index must win) and some
    sharing edges."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-2, 2, (count, 1, 3))
    triangles = centres + rng.normal(0, 0.4, (count, 3, 3))
    triangles[count // 2 :: 7] = triangles[: len(triangles[count // 2 :: 7])]  # exact repeats of earlier ones
    triangles[1::5, 0] = triangles[0::5, 1][: len(triangles[1::5])]  # shared vertices
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    as_tuples = tuple(tuple(tuple(float(x) for x in vertex) for vertex in triangle) for triangle in triangles)
    return tf.WorldTriangles("m", as_tuples, tuple(tuple(float(x) for x in normal) for normal in normals))


def rays(mesh: tf.WorldTriangles, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays from around the mesh toward points near its triangles' centres (most hit, some graze or miss)."""
    rng = np.random.default_rng(seed)
    O = rng.uniform(-4, 4, (3, count))
    centres = np.asarray(mesh.triangles).mean(axis=1)
    D = centres[rng.integers(0, len(centres), count)].T + rng.normal(0, 0.2, (3, count)) - O
    return O, D / np.linalg.norm(D, axis=0)


@pytest.mark.parametrize("build", [make_kernel, make_robust_kernel])
@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize(("count", "seed"), [(40, 1), (300, 2), pytest.param(1500, 3, marks=pytest.mark.slow)])
def test_the_mesh_hierarchy_finds_the_whole_mesh_tests_hits(build, dtype, count, seed) -> None:
    mesh = soup(count, seed)
    whole = build(mesh, np.dtype(dtype))
    kernel = MeshKernel(whole, mesh)
    assert kernel.world_placed  # no oriented box test of its own: rays from around the mesh, missing its box too
    O, D = (array.astype(dtype) for array in rays(mesh, 4000, seed))
    with quiet():
        for t_min, t_max in ((0.5, 3.0), (0.0, np.inf)):
            expected_t, expected_part = whole.hit(O, D, t_min, t_max)
            t, part = kernel.hit(O, D, t_min, t_max)
            assert np.array_equal(t, expected_t)
            hit = expected_t < np.inf
            assert np.array_equal(part[hit], expected_part[hit])  # the lowest index on ties, as the whole test
            occluded, _ = kernel.hit(O, D, t_min, t_max, any_hit=True)
            assert np.array_equal(occluded < np.inf, hit)
    assert (expected_t < np.inf).mean() > 0.5  # of the unbounded queries


@pytest.mark.parametrize("build", [make_kernel, make_robust_kernel])
def test_a_walk_in_pieces_of_rays_finds_what_one_walk_of_them_all_finds(build, monkeypatch) -> None:
    mesh = soup(300, 2)
    kernel = MeshKernel(build(mesh, np.dtype("float64")), mesh)
    O, D = rays(mesh, 4000, 2)
    limit = np.where(np.arange(4000) % 3 == 0, np.inf, 1.5 + np.arange(4000) % 7 * 0.2)  # one per ray
    with quiet():
        whole = [kernel._search(O, D, 0.25, limit, any_hit) for any_hit in (False, True)]
        monkeypatch.setattr(meshbvh, "RAY_PIECE", 333)  # 12 pieces, the last one short
        pieces = [kernel._search(O, D, 0.25, limit, any_hit) for any_hit in (False, True)]
    (t, part), (piece_t, piece_part) = whole[0], pieces[0]
    assert np.array_equal(t, piece_t) and np.array_equal(part, piece_part)
    # any-hit: whether a ray is blocked (its t is whichever hit its leaf tests found first, by the docstring)
    assert np.array_equal(whole[1][0] < np.inf, pieces[1][0] < np.inf)
    assert np.array_equal(whole[1][0] < np.inf, t < np.inf)
    assert 0.2 < (whole[0][0] < np.inf).mean() < 0.95  # hits and misses both


def test_the_scene_walk_and_the_box_tests_in_pieces_of_rays_give_what_all_rays_at_once_give(monkeypatch) -> None:
    """The scene hierarchy's walk (Hierarchy._walk) and a kernel's oriented box test (Kernel.in_box) take a band's
    rays in pieces: each kernel gets the same rays, in the same order, as from one walk of them all."""
    from tracer.geometry import bvh
    from tracer.geometry import kernels as kernels_module
    from tracer.geometry.bvh import Hierarchy

    monkeypatch.setattr(bvh, "FLAT_WALK_PAIRS", 0)  # the tree's walk, not the flat test of few rays
    meshes = [soup(60, seed) for seed in range(5)]
    meshes = [tf.WorldTriangles(f"m{k}", np.asarray(mesh.triangles) + 3.0 * k, mesh.normals)
              for k, mesh in enumerate(meshes)]  # fmt: skip
    scene_kernels = [MeshKernel(make_kernel(mesh, np.dtype("float64")), mesh) for mesh in meshes]
    hierarchy = Hierarchy(scene_kernels, np.dtype("float64"))
    rng = np.random.default_rng(5)
    O = rng.uniform(-3, 15, (3, 5000))
    D = rng.normal(size=(3, 5000))
    limit = rng.uniform(1.0, 20.0, 5000)
    rays = np.sort(rng.choice(5000, 4000, replace=False))
    with quiet():
        whole = hierarchy._walk(O, D, rays, 0.0, limit)
        boxes = [kernel.in_box(O, D, 0.0, limit) for kernel in scene_kernels]
        monkeypatch.setattr(meshbvh, "RAY_PIECE", 333)
        monkeypatch.setattr(kernels_module, "BOX_PIECE", 333)
        pieces = hierarchy._walk(O, D, rays, 0.0, limit)
        box_pieces = [kernel.in_box(O, D, 0.0, limit) for kernel in scene_kernels]
    assert sorted(index for index, _ in whole) == sorted(index for index, _ in pieces) == list(range(5))
    expected = dict(whole)
    for index, found in pieces:
        assert np.array_equal(found, expected[index])
    for found, expected_rays in zip(box_pieces, boxes, strict=True):
        assert np.array_equal(found, expected_rays) and 100 < found.size < 5000


def test_a_few_kernels_boxes_tested_at_once_in_pieces_give_each_kernel_its_boxs_rays(monkeypatch) -> None:
    """A scene of at most FLAT_WALK_KERNELS bounded kernels tests their own padded boxes on every ray at once, in
    pieces of FLAT_WALK_PAIRS pairs: each kernel gets the rays that meet its box, in order, as from one test of them
    all, and the any-hit answers are the tree walk's."""
    from tracer.geometry import bvh
    from tracer.geometry.bvh import Hierarchy

    meshes = [soup(60, seed) for seed in range(3)]
    meshes = [tf.WorldTriangles(f"m{k}", np.asarray(mesh.triangles) + 3.0 * k, mesh.normals)
              for k, mesh in enumerate(meshes)]  # fmt: skip
    hierarchy = Hierarchy([MeshKernel(make_kernel(mesh, np.dtype("float64")), mesh) for mesh in meshes], np.float64)
    assert len(hierarchy.boxes[0]) <= bvh.FLAT_WALK_KERNELS
    rng = np.random.default_rng(8)
    O, D = rng.uniform(-3, 12, (3, 5000)), rng.normal(size=(3, 5000))
    limit = rng.uniform(1.0, 20.0, 5000)
    rays = np.sort(rng.choice(5000, 4000, replace=False))
    with quiet():
        whole = dict(hierarchy._flat_walk(O, D, rays, 0.0, limit))
        monkeypatch.setattr(bvh, "FLAT_WALK_PAIRS", 3 * 333)
        pieces = hierarchy._walk(O, D, rays, 0.0, limit)
        flat = hierarchy.occluded(O, D, 0.0, limit)
        monkeypatch.setattr(bvh, "FLAT_WALK_KERNELS", 0)
        walked = hierarchy.occluded(O, D, 0.0, limit)
    assert sorted(index for index, _ in pieces) == sorted(whole) == [0, 1, 2]
    for index, found in pieces:
        assert np.array_equal(found, whole[index]) and 100 < found.size < 4000
    assert np.array_equal(flat, walked) and 0.05 < flat.mean() < 0.95


def test_a_shadow_ray_blocked_by_a_small_kernel_does_not_walk_a_hierarchy(monkeypatch) -> None:
    """Hierarchy.occluded tests the kernels without a hierarchy first (a ground of two triangles), then the meshes'
    hierarchies only with the rays still open: each ray's answer is the OR of every kernel's own test, and no ray
    that the ground blocks walks the grid of cubes."""
    from tracer.geometry.bvh import Hierarchy

    ground = tf.WorldTriangles(
        "ground",
        np.array([[[-20, -20, 0], [20, -20, 0], [20, 20, 0]], [[-20, -20, 0], [20, 20, 0], [-20, 20, 0]]], float),
        np.array([[0.0, 0.0, 1.0]] * 2),
    )
    cubes = grid_of_cubes(8, 0.0)
    cubes = tf.WorldTriangles("grid", np.asarray(cubes.triangles) + np.array([0.0, 0.0, 0.5]), cubes.normals)
    flat = make_kernel(ground, np.dtype("float64"))
    grid = MeshKernel(make_kernel(cubes, np.dtype("float64")), cubes)
    hierarchy = Hierarchy([grid, flat], np.dtype("float64"))
    rng = np.random.default_rng(21)
    O = np.vstack((rng.uniform(-2, 14, (2, 6000)), rng.uniform(0.1, 2.5, (1, 6000))))
    D = rng.normal(size=(3, 6000))
    walked = []
    search = MeshKernel.hit

    def recorded(kernel, O_r, D_r, *args, columns=None, **kwargs):
        walked.append((O_r if columns is None else O_r[:, columns]).copy())
        return search(kernel, O_r, D_r, *args, columns=columns, **kwargs)

    monkeypatch.setattr(MeshKernel, "hit", recorded)
    with quiet():
        blocked = hierarchy.occluded(O, D, 1e-6, np.inf)
        on_ground = flat.hit(O, D, 1e-6, np.inf)[0] < np.inf
        on_cubes = search(grid, O, D, 1e-6, np.inf, any_hit=True)[0] < np.inf
    assert np.array_equal(blocked, on_ground | on_cubes)
    assert 0.2 < on_ground.mean() < 0.8 and np.count_nonzero(on_cubes & ~on_ground) > 100
    seen = {tuple(column) for column in np.hstack(walked).T.tolist()}
    assert seen and not seen & {tuple(column) for column in O[:, on_ground].T.tolist()}


def test_a_small_meshs_test_of_all_its_triangles_in_pieces_gives_the_same_bits(monkeypatch) -> None:
    """TrianglesKernel._hit takes a band's millions of rays in pieces of TRIANGLE_PAIRS (triangle, ray) pairs: the
    same t and parts, bit for bit, as all the rays at once, with one limit or one per ray and a shared origin."""
    from tracer.geometry import kernels as kernels_module

    kernel = make_kernel(soup(12, 3), np.dtype("float64"))
    rng = np.random.default_rng(7)
    O, D = rng.uniform(-2, 2, (3, 3000)), rng.normal(size=(3, 3000))
    limits = rng.uniform(0.5, 5.0, 3000)
    with quiet():
        whole = [kernel._hit(O, D, 0.0, limit) for limit in (np.inf, limits)] + [kernel._hit(O[:, :1], D, 0.0, 4.0)]
        monkeypatch.setattr(kernels_module, "TRIANGLE_PAIRS", 12 * 250 + 5)
        pieces = [kernel._hit(O, D, 0.0, limit) for limit in (np.inf, limits)] + [kernel._hit(O[:, :1], D, 0.0, 4.0)]
    for (t, part), (t_pieces, part_pieces) in zip(whole, pieces, strict=True):
        assert np.array_equal(t, t_pieces) and np.array_equal(part, part_pieces)
        assert 100 < np.count_nonzero(t < np.inf) < 3000


def test_small_meshes_placed_in_one_pass_have_the_bits_of_one_at_a_time() -> None:
    """tf.world_primitives places the small meshes together (_placed_together): each mesh's world triangles,
    normals, frame and source equal world_primitive's for it alone, bit for bit, whatever its rotation and location
    (some -0.0, some turned with the vane) and whatever meshes come before it; a large mesh and the primitives are
    placed alone."""
    from tracer.scene.loader import default_scene_dict

    rng = np.random.default_rng(12)
    document = default_scene_dict()
    for k in range(60):
        size = int(rng.integers(4, 9))
        corners = rng.permuted(np.tile(np.arange(size), (2 * size, 1)), axis=1)[:, :3]
        body = {"name": f"m{k}", "type": "mesh", "material": "iron",
                "vertices": rng.uniform(-3, 3, (size, 3)).round(4).tolist(), "triangles": corners.tolist()}  # fmt: skip
        if k % 3:
            body["location"] = rng.uniform(-5, 5, 3).tolist()
            body["rotation"] = [-0.0, float(rng.uniform(-180, 180)), 0.0] if k % 2 else rng.uniform(-90, 90, 3).tolist()
        document["objects"].append(body)
    big = next(obj for obj in uv_sphere(5000).objects if isinstance(obj, sc.TriangleMesh))
    assert len(big.triangles) > tf.PLACED_TOGETHER_TRIANGLES
    document["objects"].append({"name": "big", "type": "mesh", "material": "iron",
                                "vertices": np.asarray(big.vertices).tolist(),
                                "triangles": np.asarray(big.triangles).tolist()})  # fmt: skip
    document["vane"]["parts"] = [*document["vane"]["parts"], "m4", "m5"]
    document["vane"]["heading"] = 37.5
    scene = scene_from_dict(document)
    together = tf.world_primitives(scene)
    for obj, placed in zip(scene.objects, together, strict=True):
        alone = tf.world_primitive(obj, scene.vane)
        assert type(placed) is type(alone) and placed == alone
        if isinstance(alone, tf.WorldTriangles):
            assert placed.triangles.tobytes() == alone.triangles.tobytes()
            assert placed.normals.tobytes() == alone.normals.tobytes()
            assert not placed.triangles.flags.writeable and not placed.normals.flags.writeable
            assert (placed.rotation, placed.location) == (alone.rotation, alone.location)
            assert placed.cache_key == alone.cache_key


def joined_boxes(count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """count boxes (8 vertices, 12 triangles each) joined into one mesh, their triangles and vertices shuffled: the
    vertices (8 count, 3) and faces (12 count, 3); the boxes overlap here and there."""
    rng = np.random.default_rng(seed)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    box = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    vertices = (corners[None] * rng.uniform(0.1, 0.4, (count, 1, 3)) + rng.uniform(-3, 3, (count, 1, 3))).reshape(-1, 3)
    faces = (box[None] + 8 * np.arange(count)[:, None, None]).reshape(-1, 3)
    shuffle = rng.permutation(len(vertices))
    faces = np.argsort(shuffle)[faces][rng.permutation(len(faces))]
    return vertices[shuffle], faces


def test_a_mesh_of_many_small_parts_gets_a_leaf_per_part_and_finds_the_same_hits() -> None:
    vertices, faces = joined_boxes(100, 4)
    order, starts, sizes = meshbvh.small_parts(faces)
    assert sizes.tolist() == [12] * 100
    for start in starts.tolist():  # a part's triangles share their 8 vertices and no other
        assert len(np.unique(faces[order[start : start + 12]])) == 8
    triangles = vertices[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    mesh = tf.WorldTriangles("m", triangles, normals, source=(vertices, faces))
    whole = make_kernel(mesh, np.dtype("float64"))
    kernel = MeshKernel(whole, mesh)
    assert kernel.hierarchy.leaf_size == 12
    O, D = rays(mesh, 4000, 4)
    with quiet():
        expected_t, expected_part = whole.hit(O, D, 0.0, np.inf)
        t, part = kernel.hit(O, D, 0.0, np.inf)
        occluded, _ = kernel.hit(O, D, 0.0, np.inf, any_hit=True)
    hit = expected_t < np.inf
    assert np.array_equal(t, expected_t) and np.array_equal(part[hit], expected_part[hit])
    assert np.array_equal(occluded < np.inf, hit) and 0.3 < hit.mean() < 0.95


def test_a_mesh_given_columns_of_the_rays_finds_what_it_finds_for_those_rays_gathered() -> None:
    """MeshKernel.hit with columns (the scene's subset of a query's rays, gathered by each view's rays or sliced
    where they are one run) gives the same hits, bit for bit, as the same rays gathered first: a mesh in world
    space and a turned one (its oriented box test), rays of two lights' views and of none."""
    rng = np.random.default_rng(5)
    cubes = grid_of_cubes(6, 0.0)
    turned = tf.WorldTriangles(
        "turned", cubes.triangles, cubes.normals, rotation=((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    )
    O = np.vstack((rng.uniform(-1, 10, (2, 4000)), rng.uniform(0.1, 3.0, (1, 4000))))
    D = rng.normal(size=(3, 4000))
    views = [View("direction", (0.0, 0.0, 1.0)), None]
    which = (np.arange(4000) >= 1500).astype(np.int64)  # the first 1,500 rays share a view, the rest one run of none
    for mesh in (cubes, turned):
        kernel = MeshKernel(make_kernel(mesh, np.dtype("float64")), mesh)
        for columns in (np.sort(rng.choice(4000, 2500, replace=False)), np.arange(700, 3900)):
            with quiet():
                given = kernel.hit(
                    O, D, 1e-6, np.inf, any_hit=True, views=(views, which.take(columns)), columns=columns
                )
                gathered = kernel.hit(
                    O[:, columns], D[:, columns], 1e-6, np.inf, any_hit=True, views=(views, which.take(columns))
                )
                nearest = kernel.hit(O, D, 1e-6, 30.0, views=(views, which.take(columns)), columns=columns)
                nearest_gathered = kernel.hit(
                    O[:, columns], D[:, columns], 1e-6, 30.0, views=(views, which.take(columns))
                )
            assert (given[0] < np.inf).any() and (given[0] == np.inf).any()
            for found, expected in ((given, gathered), (nearest, nearest_gathered)):
                assert np.array_equal(found[0], expected[0]) and np.array_equal(found[1], expected[1])


def grid_of_cubes(side: int, offset: float) -> tf.WorldTriangles:
    """side x side unit cubes 1.5 apart at integer-and-a-half coordinates plus offset (far from the origin, large
    offsets), joined: every box face lies on a plane that rays along the axes can graze."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    box = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    places = np.array([[1.5 * i, 1.5 * j, 0.0] for i in range(side) for j in range(side)]) + offset
    vertices = (corners[None] + places[:, None]).reshape(-1, 3)
    faces = (box[None] + 8 * np.arange(len(places))[:, None, None]).reshape(-1, 3)
    triangles = vertices[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return tf.WorldTriangles("grid", triangles, normals, source=(vertices, faces))


@pytest.mark.parametrize("offset", [0.0, 1000.25, -40000.5])
def test_the_float32_box_tests_meet_every_box_the_float64_tests_meet(offset: float) -> None:
    """The walk's slab tests run in float32 on boxes grown by its error bound (MeshKernel._grown_boxes). On rays
    that graze the boxes' faces (origins on a face's plane, direction components exactly 0, far origins), every
    (ray, node) the float64 test meets is met, and the walk finds the whole-mesh test's hits."""
    mesh = grid_of_cubes(8, offset)
    whole = make_kernel(mesh, np.dtype("float64"))
    kernel = MeshKernel(whole, mesh)
    tree = kernel.hierarchy
    rng = np.random.default_rng(11)
    count = 6000
    # origins on the boxes' face planes (and far beyond the grid), directions along the axes or between them
    faces = np.asarray(mesh.triangles).reshape(-1, 3)[rng.integers(0, len(mesh.triangles) * 3, count)]
    O = faces.T + rng.integers(-1, 2, (3, count)) * rng.choice([0.5, 20.0, 3000.0], (3, count))
    D = rng.integers(-1, 2, (3, count)).astype(np.float64) * rng.choice([1.0, 1e-9, 0.5], (3, count))
    D[:, np.all(D == 0, axis=0)] = np.array([[1.0], [0.0], [0.0]])
    with quiet():
        boxes = kernel._box_rays(O, D)
    assert boxes.lower.dtype == np.float32
    reach = float(np.abs(O).max()) + float(np.abs(tree.upper).max())
    assert np.all(boxes.lower <= tree.lower) and np.all(boxes.upper >= tree.upper)
    assert np.all(tree.lower - boxes.lower <= reach * 2.0**-19)  # grown by the bound, not more
    # and rays from 30,000 away through each node's box corners: float32 origins alone are 1e-3 off there
    nodes = np.arange(tree.left.size)
    corner = np.where(rng.integers(0, 2, (3, nodes.size)) == 1, tree.lower, tree.upper)
    away = rng.normal(size=(3, nodes.size))
    far_O = corner + 30000.123456789 * away / np.linalg.norm(away, axis=0)
    with quiet():
        far_boxes = kernel._box_rays(far_O, corner - far_O)
        near, far = kernels_slab(far_O, 1.0 / (corner - far_O), tree.lower, tree.upper)
        near32, far32 = kernels_slab(far_boxes.origins, far_boxes.inverses, far_boxes.lower, far_boxes.upper)
        meets64, meets32 = near <= far, near32 <= far32
        assert meets64.sum() > nodes.size // 2 and not np.any(meets64 & ~meets32)
        for node in range(0, tree.left.size, 7):
            near, far = kernels_slab(O, 1.0 / D, tree.lower[:, node : node + 1], tree.upper[:, node : node + 1])
            near32, far32 = kernels_slab(
                boxes.origins, boxes.inverses, boxes.lower[:, node : node + 1], boxes.upper[:, node : node + 1]
            )
            for t_min in (0.0, 1e-3):
                meets64 = (near <= far) & (far > t_min) & (near <= 50.0)
                meets32 = (near32 <= far32) & (far32 > t_min) & (near32 <= 50.0)
                assert not np.any(meets64 & ~meets32), node
        for t_min in (0.0, 1e-3):
            expected_t, expected_part = whole.hit(O, D, t_min, np.inf)
            t, part = kernel.hit(O, D, t_min, np.inf)
            hit = expected_t < np.inf
            assert np.array_equal(t, expected_t) and np.array_equal(part[hit], expected_part[hit])
            occluded, _ = kernel.hit(O, D, t_min, np.inf, any_hit=True)
            assert np.array_equal(occluded < np.inf, hit)
    assert 0.05 < hit.mean() < 0.9


def test_objects_get_a_leaf_each_only_where_that_makes_fewer_tests() -> None:
    assert meshbvh.leaves_per_object(np.full(3000, 12))  # cubes
    assert meshbvh.leaves_per_object(np.array([12, 6, 8] * 30))  # padded to 12: 1.4x the triangles' tests
    assert not meshbvh.leaves_per_object(np.array([16] + [6] * 99))  # padding to 16 would be 2.6x the tests
    assert not meshbvh.leaves_per_object(np.full(500, 3))  # a median leaf of 4 holds them already
    assert not meshbvh.leaves_per_object(np.full(500, 17))  # too many for one leaf test


def test_connected_meshes_and_few_or_tiny_parts_keep_the_median_splits() -> None:
    sphere = uv_sphere(2000)
    faces = np.asarray(sphere.objects[1].triangles)
    assert meshbvh.small_parts(faces) is None  # one part
    assert meshbvh.small_parts(joined_boxes(40, 5)[1]) is None  # fewer than SMALL_PARTS_FROM parts
    single = np.arange(3 * 200).reshape(-1, 3)  # 200 parts of one triangle: a leaf of 4 holds them already
    assert meshbvh.small_parts(single) is None


def mesh_scene(count: int, width: int, height: int) -> sc.Scene:
    return uv_sphere(count).with_render(width=width, height=height, depth=3)


def test_a_mesh_scene_matches_the_per_pixel_reference() -> None:
    scene = mesh_scene(200, 40, 30)
    assert len(scene.objects[1].triangles) > MESH_HIERARCHY_TRIANGLES
    np.testing.assert_allclose(render(scene, workers=1).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


@pytest.mark.slow
def test_a_large_mesh_scene_matches_the_per_pixel_reference() -> None:
    scene = mesh_scene(10_000, 24, 18)
    np.testing.assert_allclose(render(scene, workers=2).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


def test_a_mesh_renders_the_same_bytes_with_one_worker_or_two_and_in_robust_mode_too() -> None:
    scene = mesh_scene(2000, 80, 60)
    for numerics in ("documented", "robust"):
        one = render(scene.with_render(numerics=numerics), workers=1).image
        two = render(scene.with_render(numerics=numerics), workers=2).image
        assert np.array_equal(one, two)


def picture_rays(mesh: tf.WorldTriangles, kind: str, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays that share a point or a direction, as a mesh's pictures see them (meshpicture.py): a camera's (one
    origin (3, 1) outside the mesh), a point light's shadow rays (each from a point before, among or beyond the
    triangles, toward the light: t in (0, 1) ends there) or a directional light's (one direction (3, 1))."""
    rng = np.random.default_rng(seed)
    centres = np.asarray(mesh.triangles).mean(axis=1)
    targets = centres[rng.integers(0, len(centres), count)].T + rng.normal(0, 0.2, (3, count))
    if kind == "camera":
        O = np.array([[9.0], [-7.0], [5.0]])
        return O, targets - O
    if kind == "light":
        light = np.array([[6.0], [5.0], [8.0]])
        O = light + (targets - light) * rng.uniform(0.3, 2.0, count)
        return O, light - O
    direction = np.array([[0.3], [-0.5], [0.8]])
    return targets - 12.0 * direction + rng.normal(0, 0.05, (3, count)), direction


@pytest.mark.parametrize("build", [make_kernel, make_robust_kernel])
@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("kind", ["camera", "light", "sun"])
@pytest.mark.parametrize(("count", "seed"), [(300, 4), pytest.param(1500, 5, marks=pytest.mark.slow)])
def test_the_mesh_pictures_find_the_whole_mesh_tests_hits(build, dtype, kind, count, seed, monkeypatch) -> None:
    monkeypatch.setattr(meshpicture, "MAX_DEPTH", np.inf)  # a soup is deep: pictured here all the same
    mesh = soup(count, seed)
    whole = build(mesh, np.dtype(dtype))
    kernel = MeshKernel(whole, mesh)
    O, D = (array.astype(dtype) for array in picture_rays(mesh, kind, 4000, seed))
    views = None
    if kind == "light":  # shadow rays show nothing shared: the light is named, as the tracer's shadow query does
        views = ([View("point", (6.0, 5.0, 8.0), reverse=True)], np.zeros(D.shape[1], dtype=np.int64))
    limits = ((0.001, 1.0),) if kind == "light" else ((0.5, 9.0), (0.0, np.inf))
    with quiet():
        for t_min, t_max in limits:
            shape = (3, max(O.shape[1], D.shape[1]))
            expected_t, expected_part = whole.hit(O, np.broadcast_to(D, shape), t_min, t_max)
            t, part = kernel.hit(O, D, t_min, t_max, views=views)
            assert np.array_equal(t, expected_t)
            hit = expected_t < np.inf
            assert np.array_equal(part[hit], expected_part[hit])  # the lowest index on ties, as the whole test
            occluded, _ = kernel.hit(O, D, t_min, t_max, any_hit=True, views=views)
            assert np.array_equal(occluded < np.inf, hit)
    assert 0.2 < hit.mean() < 1.0
    # the picture answered (not the walk): it exists and the walk was never needed
    assert [picture is not None for picture in kernel.pictures.values()] == [True]


def test_a_point_among_the_triangles_has_no_picture_and_the_walk_answers() -> None:
    mesh = soup(300, 6)
    whole = make_kernel(mesh, np.dtype("float64"))
    kernel = MeshKernel(whole, mesh)
    O = np.zeros((3, 1))  # the middle of the soup
    D = np.random.default_rng(6).normal(size=(3, 3000))
    with quiet():
        expected_t, expected_part = whole.hit(O, D, 0.0, np.inf)
        t, part = kernel.hit(O, D, 0.0, np.inf)
    assert list(kernel.pictures.values()) == [None]
    assert np.array_equal(t, expected_t)
    assert np.array_equal(part[t < np.inf], expected_part[t < np.inf])


def test_a_deep_stack_of_triangles_is_walked_not_pictured() -> None:
    """100 squares one behind another, seen face-on: every ray's cell would hold all 200 triangles, so the picture
    declines (meshpicture.MAX_DEPTH) and the walk, nearest first, finds the same hits."""
    square = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)
    triangles = np.concatenate([square + np.array([0.0, 0.0, depth]) for depth in range(100)])
    normals = tuple((0.0, 0.0, 1.0) for _ in triangles)
    mesh = tf.WorldTriangles("m", tuple(tuple(map(tuple, triangle)) for triangle in triangles), normals)
    whole = make_kernel(mesh, np.dtype("float64"))
    kernel = MeshKernel(whole, mesh)
    rng = np.random.default_rng(7)
    O = np.array([[0.0], [0.0], [-10.0]])
    D = np.vstack((rng.uniform(-0.08, 0.08, (2, 2000)), np.ones((1, 2000))))
    with quiet():
        expected_t, expected_part = whole.hit(O, D, 0.0, np.inf)
        t, part = kernel.hit(O, D, 0.0, np.inf)
    assert list(kernel.pictures.values()) == [None]
    assert np.array_equal(t, expected_t) and np.array_equal(part, expected_part)
    assert (t < np.inf).all()


def pictures_made(monkeypatch) -> list[View]:
    """The views whose pictures the renders after this call make, in order (TrianglePicture.build counted)."""
    made: list[View] = []
    build = meshpicture.TrianglePicture.build.__func__

    def counted(cls, corners, lower, upper, slots, view, *rest):
        made.append(view)
        return build(cls, corners, lower, upper, slots, view, *rest)

    monkeypatch.setattr(meshpicture.TrianglePicture, "build", classmethod(counted))
    return made


def test_an_area_light_at_shadows_16_gets_each_of_its_views_pictured_once(monkeypatch) -> None:
    """A mesh under an area light at Shadows 16 is seen from 65 views (the camera and the light's 64 points, 16 in
    each of the four patterns that a 2 x 2 block's pixels take): each view's picture is made once in a render and
    kept (meshbvh.PICTURE_BYTES), not made again band after band once more than PICTURES_KEPT views take turns."""
    light = sc.AreaLight(location=(2.0, -2.0, 5.0), direction=(-0.3, 0.3, -1.0), size=(2.0, 2.0), intensity=8.0)
    scene = replace(uv_sphere(400), lights=(light,)).with_render(width=160, height=120, shadow_samples=16)
    made = pictures_made(monkeypatch)
    render(scene, workers=1)
    views = 1 + lightsamples.PATTERNS * 16
    assert len(set(made)) == views and len(made) == views


@pytest.mark.parametrize(("dtype", "numerics"), [("float64", "documented"), ("float32", "robust")])
def test_a_clipped_cameras_rays_search_the_meshs_picture_from_its_location_with_the_walks_bytes(
    dtype: str, numerics: str, monkeypatch
) -> None:
    """A camera with a near clip plane (every Blender camera has one) starts its rays on that plane, not at its
    location, yet each lies on a line through the location: the mesh's picture from there serves them, and the
    image is the walk's, bit for bit."""
    scene = uv_sphere(4000)
    scene = replace(scene, camera=replace(scene.camera, clip_start=0.1, clip_end=50.0))
    scene = scene.with_render(width=96, height=72, samples=4, dtype=dtype, numerics=numerics)
    made = pictures_made(monkeypatch)
    pictured = render(scene, workers=1).image
    camera_view = View("point", tuple(float(x) for x in scene.camera.location))
    assert camera_view in made
    monkeypatch.setattr(wavefront.TracedScene, "_camera_views", lambda self, batch: None)  # the walk alone
    walked = render(scene, workers=1).image
    assert np.array_equal(pictured, walked) and pictured.std() > 0.05


# ---- meshes as arrays: vertices, triangles and corner fields as NumPy arrays -----------------------------------------


def as_tuples(value: object) -> object:
    """Nested lists -> nested tuples (a mesh as a scene made in code gives it)."""
    return tuple(as_tuples(item) for item in value) if isinstance(value, list) else value


def smooth_mesh(count: int, as_arrays: bool) -> sc.TriangleMesh:
    """A turned, moved UV sphere with corner normals and two materials, given as tuples or as arrays."""
    mesh = uv_sphere(count).objects[1]
    vertices, faces = mesh.vertices, mesh.triangles
    corners = vertices[faces] * 1.01  # (T, 3, 3): not unit, as a file may give them
    indices = np.arange(len(faces)) // 17 % 2
    fields = {"vertices": vertices, "triangles": faces, "normals": corners, "material_indices": indices}
    if not as_arrays:
        fields = {name: as_tuples(value.tolist()) for name, value in fields.items()}
    return sc.TriangleMesh(
        name="mesh",
        material="copper",
        location=(0.1, -0.2, 2.0),
        rotation=(10.0, 20.0, 30.0),
        materials=("copper", "brass"),
        **fields,
    )


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_mesh_given_as_tuples_or_as_arrays_renders_the_same_bytes(dtype: str) -> None:
    base = uv_sphere(600).with_render(width=48, height=36, depth=3, dtype=dtype)
    images = []
    for as_arrays in (False, True):
        scene = replace(base, objects=(base.objects[0], smooth_mesh(600, as_arrays)))
        images.append(render(scene, workers=1).image)
    assert np.array_equal(images[0], images[1])
    assert images[0].std() > 0.0


def test_a_meshs_arrays_are_read_only_and_its_own() -> None:
    vertices = np.array([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
    mesh = sc.TriangleMesh(name="t", material="m", vertices=vertices, triangles=[(0, 1, 2)], normals=[[0, 0, 1] * 3])
    vertices[1, 0] = 5.0  # the caller's array: the mesh has a copy
    assert mesh.vertices[1, 0] == 1.0
    assert (mesh.vertices.dtype, mesh.triangles.dtype, mesh.normals.shape) == (np.float64, np.int64, (1, 3, 3))
    for array in (mesh.vertices, mesh.triangles, mesh.normals, pickle.loads(pickle.dumps(mesh)).vertices):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0
    assert replace(mesh, location=(1.0, 2.0, 3.0)).vertices is mesh.vertices  # nothing copied again
    loaded = scene_from_dict(mesh_scenes.mesh_scene(*mesh_scenes.uv_sphere(100))).objects[1]
    assert not loaded.vertices.flags.writeable and not loaded.triangles.flags.writeable


def test_meshes_are_equal_by_their_arrays_bits() -> None:
    one, two = smooth_mesh(300, True), smooth_mesh(300, False)
    assert one == two and hash(one) == hash(two) and one.vertices is not two.vertices
    assert pickle.loads(pickle.dumps(one)) == one
    moved = replace(one, vertices=np.where(one.vertices == 0.0, -0.0, one.vertices))  # -0.0 where 0.0 was
    assert moved != one
    # the hash and digest are kept per object and never pickled (a str's hash differs between processes); a field
    # that is not an array (the name), or an array moved to another field, still makes another mesh
    assert hash(one) == hash(one) and "_hash" in one.__dict__
    state = one.__getstate__()
    assert "_hash" not in state and "_contents_digest" not in state
    assert replace(one, name="other") != one and hash(replace(one, name="other")) != hash(one)
    assert replace(one, normals=None) != one and replace(one, normals=None) == replace(two, normals=None)
    coloured = replace(one, normals=None, colors=one.normals.astype(np.float32))
    assert coloured != replace(one, normals=None) and coloured.contents_digest() != one.contents_digest()
    old = uv_sphere(300)
    new = replace(old, objects=(old.objects[0], replace(old.objects[1], location=(0.0, 0.0, 2.5))))
    assert edits.edits_between(old, new) == [edits.TransformEdit("mesh", (0.0, 0.0, 2.5), (0.0, 0.0, 0.0))]


def test_the_world_transform_on_arrays_gives_the_per_vertex_functions_numbers() -> None:
    mesh = smooth_mesh(400, True)
    vane = sc.Vane(parts=("mesh",), pivot=(0.3, 0.0, 0.1), axis=(0.1, 0.2, 1.0), heading=37.0)
    world = tf.world_primitive(mesh, vane)
    rotation, location = tf.object_frame(mesh, vane)
    points = [tf.add(location, tf.apply(rotation, vertex)) for vertex in mesh.vertices.tolist()]  # the old loop
    expected = np.array([[points[k] for k in face] for face in mesh.triangles.tolist()])
    normals = []
    for v0, v1, v2 in expected.tolist():
        n = tf.cross(tf.sub(v1, v0), tf.sub(v2, v0))
        size = tf.length(n)
        normals.append((n[0] / size, n[1] / size, n[2] / size) if size > 0.0 else (0.0, 0.0, 0.0))
    assert world.triangles.tobytes() == expected.tobytes()
    assert world.normals.tobytes() == np.array(normals).tobytes()
    assert world == tf.world_primitive(mesh, vane) and hash(world) == hash(tf.world_primitive(mesh, vane))
    # the kernel cache's key: the scene's own arrays, not the world's (equal for a mesh of the same bits)
    key, other = world.cache_key, tf.world_primitive(smooth_mesh(400, False), vane).cache_key
    assert key.vertices is mesh.vertices and key == other and hash(key) == hash(other)


def test_a_large_meshs_arrays_go_to_the_workers_once_in_a_shared_file(monkeypatch) -> None:
    monkeypatch.setattr(parallel, "SHARED_SCENE_BYTES", 0)  # the shared path for a small mesh
    base = replace(uv_sphere(600), objects=(uv_sphere(600).objects[0], smooth_mesh(600, True)))
    vane = sc.Vane(parts=("mesh",), pivot=(0.2, 0.0, 0.0), axis=(0.0, 0.0, 1.0))
    scenes = [
        replace(base, vane=replace(vane, heading=heading)).with_render(width=40, height=30) for heading in (0, 90)
    ]
    expected = [render(scene, workers=1).image for scene in scenes]
    with parallel.Renderer(2) as renderer:
        first, file = renderer._scenes.message(scenes[0])
        second, same_file = renderer._scenes.message(scenes[1])
        assert first.offsets is not None and same_file is file and first.key != second.key  # arrays written once
        file.users -= 2
        frames = list(renderer.render_frames(scenes * 2))  # pipelined: one frame's tasks wait while one is traced
        pixels = renderer.render_pixels(scenes[1], np.arange(0, 1200, 7), frames[0].image).image
    assert all(np.array_equal(frame.image, expected[k % 2]) for k, frame in enumerate(frames))
    assert np.array_equal(pixels.reshape(-1, 3)[::7], expected[1].reshape(-1, 3)[::7])
    assert file.descriptor is None  # closed with the renderer, once no frame used it
