"""Each primitive against analytic answers: hit, miss, tangent, from inside, behind, rotated, scaled."""

from __future__ import annotations

import pytest

from tests.primitive_cases import CASES, INF
from tests.tracing import first_hit, one_object_scene
from tracer.scene import scene as sc


@pytest.mark.parametrize(("label", "obj", "origin", "direction", "expected"), CASES, ids=[c[0] for c in CASES])
def test_primitive_against_analytic_answer(label, obj, origin, direction, expected) -> None:
    vectorized, reference = first_hit(one_object_scene(obj), origin, direction)
    if expected == INF:
        assert vectorized == INF and reference == INF
    else:
        assert vectorized == pytest.approx(expected, abs=1e-12)
        assert reference == pytest.approx(expected, abs=1e-12)


def test_pyramid_side_height_matches_its_slope() -> None:
    # the face from the base edge x = 1 up to the apex: z = -1 + 2 (1 - x) for a 2 x 2 x 2 pyramid
    pyramid = sc.Pyramid(name="y", material="m", size=(2, 2, 2))
    for x in (0.1, 0.4, 0.75):
        vectorized, reference = first_hit(one_object_scene(pyramid), (x, 0, 10), (0, 0, -1))
        assert vectorized == reference == pytest.approx(10 - (-1 + 2 * (1 - x)), abs=1e-12)


def test_box_and_pyramid_normals_point_outward() -> None:
    from tracer.geometry import transforms as tf

    for obj in (
        sc.Box(name="b", material="m", rotation=(10, 20, 30), size=(1, 2, 3)),
        sc.Pyramid(name="y", material="m", rotation=(-40, 5, 70), size=(1, 2, 3)),
    ):
        mesh = tf.world_primitive(obj, None)
        for (v0, v1, v2), normal in zip(mesh.triangles, mesh.normals, strict=True):
            centroid = tuple((v0[i] + v1[i] + v2[i]) / 3 for i in range(3))
            assert tf.dot(normal, centroid) > 0  # the object is centred on the origin
            assert tf.length(normal) == pytest.approx(1.0)


def test_vane_heading_turns_parts_about_the_pivot() -> None:
    arm = sc.Box(name="arm", material="m", location=(1, 0, 3), size=(0.2, 0.2, 0.2))
    still = sc.Sphere(name="ball", material="m", location=(1, 0, 3), radius=0.05)
    vane = sc.Vane(parts=("arm",), pivot=(0, 0, 3), axis=(0, 0, 1), heading=90)
    scene = sc.Scene(materials={"m": sc.Material()}, objects=(arm, still), lights=(), vane=vane)
    from tracer.geometry import transforms as tf

    box = tf.world_primitive(arm, vane)
    centre = [sum(v[i] for tri in box.triangles for v in tri) / (3 * len(box.triangles)) for i in range(3)]
    assert centre == pytest.approx([0, 1, 3], abs=1e-12)
    assert tf.world_primitive(still, vane).center == (1, 0, 3)
    assert scene.with_heading(45).vane.heading == 45


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_spheres_any_hit_answer_is_whether_its_closest_hit_finds_a_root(dtype: str) -> None:
    """SphereKernel.blocks (shadow rays) against _hit's t < inf on the same rays: rays from near and absurdly far,
    from the surface itself, grazing, parallel to nothing, zero and overflowing directions, with an upper limit of
    a number, one per ray or none."""
    import numpy as np

    from tracer.geometry import transforms as tf
    from tracer.geometry.kernels import SphereKernel, shared_terms

    rng = np.random.default_rng(7)
    kernel = SphereKernel(tf.WorldSphere("m", (0.5, -1.0, 2.0), 1.5), np.dtype(dtype))
    count = 4000
    O = rng.normal(size=(3, count)) * rng.choice([0.5, 3.0, 1e4, 1e19], size=count)
    D = rng.normal(size=(3, count)) * rng.choice([1e-3, 1.0, 50.0, 1e20], size=count)
    surface = rng.normal(size=(3, count // 4))
    O[:, : count // 4] = surface / np.linalg.norm(surface, axis=0) * 1.5 + np.array([[0.5], [-1.0], [2.0]])
    D[:, 1] = 0.0
    O, D = O.astype(dtype), D.astype(dtype)
    with np.errstate(all="ignore"):
        for t_max in (1.0, np.inf, rng.uniform(0.0, 5.0, count).astype(dtype)):
            for shared in (None, shared_terms(D)):
                closest, _ = kernel._hit(O, D, 0.001, t_max, shared)
                blocks = kernel.blocks(O, D, 0.001, t_max, shared)
                assert np.array_equal(blocks, closest < np.inf)
                assert 0 < blocks.sum() < count  # both answers occur
