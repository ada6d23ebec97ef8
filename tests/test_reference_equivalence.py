"""The vectorized tracer equals the per-pixel reference (listings 3.1-3.2) to 1e-9 on every pixel."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tests import cgfs_peer
from tests.random_scenes import extended_scene_document, random_scene_document
from tracer.scene.loader import default_scene, scene_from_dict
from tracer.tracing.reference import ReferenceTracer, render_reference
from tracer.workers.parallel import render

SEEDS = range(60)


@pytest.mark.parametrize("seed", SEEDS)
def test_random_scene_matches_reference(seed: int) -> None:
    scene = scene_from_dict(random_scene_document(seed))
    expected = np.asarray(render_reference(scene))
    result = render(scene, workers=1)
    assert result.image.shape == expected.shape
    assert np.all(np.isfinite(result.image))
    np.testing.assert_allclose(result.image, expected, rtol=0, atol=1e-9)


def _with_alpha(result) -> np.ndarray:
    """The render as the reference gives it: (H, W, 3), or (H, W, 4) with the alpha where the scene has one."""
    if result.alpha is None:
        return result.image
    return np.concatenate((result.image, result.alpha[..., None]), axis=2)


@pytest.mark.parametrize("seed", SEEDS)
def test_random_scene_with_blender_fields_matches_reference(seed: int) -> None:
    scene = scene_from_dict(extended_scene_document(seed))
    expected = np.asarray(render_reference(scene))
    image = _with_alpha(render(scene, workers=1))
    assert image.shape == expected.shape
    assert np.all(np.isfinite(image))
    np.testing.assert_allclose(image, expected, rtol=0, atol=1e-9)


def test_random_scenes_with_blender_fields_cover_every_field() -> None:
    from tracer.scene import scene as sc

    scenes = [scene_from_dict(extended_scene_document(seed)) for seed in SEEDS]
    materials = [m for scene in scenes for m in scene.materials.values()]
    assert any(m.emission != sc.BLACK for m in materials) and any(m.two_sided for m in materials)
    assert any(m.specular_color is not None for m in materials)
    lights = [light for scene in scenes for light in scene.lights]
    assert any(light.color != sc.WHITE for light in lights)
    assert any(getattr(light, "falloff", "") == "inverse_square" for light in lights)
    spots = [light for light in lights if isinstance(light, sc.SpotLight)]
    assert {light.spot_model for light in spots} == {"cycles3", "cycles4"} and any(s.spot_blend == 0 for s in spots)
    objects = [obj for scene in scenes for obj in scene.objects]
    for flag in ("visible_camera", "visible_shadow", "visible_reflection"):
        assert any(not getattr(obj, flag) for obj in objects), flag
    assert any(obj.holdout for obj in objects)
    meshes = [obj for obj in objects if isinstance(obj, sc.TriangleMesh)]
    assert any(m.normals is not None for m in meshes) and any(m.material_indices is not None for m in meshes)
    assert any(scene.render.film_transparent for scene in scenes)
    assert {scene.render.crop for scene in scenes if scene.render.border is not None} == {False, True}


@pytest.mark.parametrize("seed", [0, 5, 13])
def test_blender_fields_in_two_workers_and_float32(seed: int) -> None:
    scene = scene_from_dict(extended_scene_document(seed, width=24, height=18))
    one = _with_alpha(render(scene, workers=1))
    np.testing.assert_array_equal(_with_alpha(render(scene, workers=2)), one)  # shared images carry the alpha
    single = _with_alpha(render(scene.with_render(dtype="float32"), workers=1))
    assert np.all(np.isfinite(single)) and (np.abs(single - one).max(axis=2) < 1e-3).mean() > 0.95
    robust = _with_alpha(render(scene.with_render(numerics="robust"), workers=1))
    assert np.all(np.isfinite(robust))


def test_large_smooth_mesh_with_triangle_materials_matches_reference() -> None:
    import math

    from tracer.geometry.meshbvh import MESH_HIERARCHY_TRIANGLES
    from tracer.scene import scene as sc

    # a UV sphere large enough for the mesh's own hierarchy, smooth (corner normals = the vertices' directions),
    # with two materials in bands, one of them two-sided
    rings, segments = 12, 16
    vertices = [
        (
            math.sin(math.pi * i / rings) * math.cos(2 * math.pi * j / segments),
            math.sin(math.pi * i / rings) * math.sin(2 * math.pi * j / segments),
            math.cos(math.pi * i / rings),
        )
        for i in range(rings + 1)
        for j in range(segments)
    ]
    faces = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            faces += [t for t in ((a, c, b), (b, c, d)) if len({vertices[k] for k in t}) == 3]
    faces = [f for f in faces if math.dist(vertices[f[0]], vertices[f[1]]) > 1e-9]
    base = default_scene()
    mesh = sc.TriangleMesh(
        name="mesh",
        material="copper",
        location=(0, 0, 2),
        rotation=(10, 20, 30),
        vertices=tuple(vertices),
        triangles=tuple(faces),
        normals=tuple(tuple(vertices[k] for k in face) for face in faces),
        materials=("copper", "verdigris"),
        material_indices=tuple((index // 40) % 2 for index in range(len(faces))),
    )
    materials = dict(base.materials)
    materials["verdigris"] = replace(materials["verdigris"], two_sided=True, emission=(0.05, 0.0, 0.1))
    scene = replace(base, materials=materials, objects=(base.objects[0], mesh), vane=None)
    scene = scene.with_render(width=40, height=30)
    assert len(faces) > MESH_HIERARCHY_TRIANGLES
    np.testing.assert_allclose(render(scene, workers=1).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


def test_random_scenes_cover_every_feature() -> None:
    scenes = [scene_from_dict(random_scene_document(seed)) for seed in SEEDS]
    kinds = {type(obj).__name__ for scene in scenes for obj in scene.objects}
    assert kinds == {"Sphere", "Cylinder", "Box", "Pyramid", "TriangleMesh", "Plane"}
    assert {type(light).__name__ for scene in scenes for light in scene.lights} == {
        "AmbientLight",
        "PointLight",
        "DirectionalLight",
    }
    assert {scene.render.model for scene in scenes} == {"phong", "blinn-phong"}
    assert {scene.render.depth for scene in scenes} == set(range(6))
    assert {scene.background.type for scene in scenes} == {"solid", "sky", "documented", "none"}
    assert {scene.render.samples for scene in scenes} == {1, 4}
    assert any(scene.render.gate_specular for scene in scenes)
    with_reflections = sum(render(scene, workers=1).rays.reflection > 0 for scene in scenes)
    assert with_reflections >= 30


def test_ray_counts_match_reference() -> None:
    scene = default_scene().with_render(width=40, height=30)
    tracer = ReferenceTracer(scene)
    for j in range(30):
        for i in range(40):
            tracer.pixel(i, j)
    rays = render(scene, workers=1).rays
    assert (rays.camera, rays.reflection) == (tracer.rays["camera"], tracer.rays["reflection"])
    # the tracer skips shadow rays toward lights that could add nothing at the point (N.L <= 0, no highlight)
    assert 0.9 * tracer.rays["shadow"] <= rays.shadow <= tracer.rays["shadow"]


def test_default_scene_matches_reference() -> None:
    scene = default_scene().with_render(width=48, height=36, samples=4)
    np.testing.assert_allclose(render(scene, workers=1).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


def test_float32_stays_close_to_reference() -> None:
    scene = default_scene().with_render(width=48, height=36)
    expected = np.asarray(render_reference(scene))
    image = render(scene.with_render(dtype="float32"), workers=1).image
    assert image.dtype == np.float32
    close = np.abs(image - expected).max(axis=2) < 1e-3
    assert close.mean() > 0.99  # a few pixels on silhouettes may flip in float32


@pytest.mark.parametrize(("width", "height"), [(1, 1), (1, 5), (4, 1)])
@pytest.mark.parametrize("seed", [3, 10, 21])
def test_single_ray_bands_match_reference(seed: int, width: int, height: int) -> None:
    # one-ray arrays look like the (3, 1) columns shared by all rays: they must still trace as single rays
    scene = scene_from_dict(random_scene_document(seed, width=width, height=height))
    np.testing.assert_allclose(render(scene, workers=1).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


def test_large_mesh_split_into_clusters_matches_reference() -> None:
    import math

    from tracer.scene import scene as sc

    # a UV sphere of 8 x 12 quads (192 triangles): its triangles go into the hierarchy in clusters
    rings, segments = 8, 12
    vertices = (
        [(0.0, 0.0, 1.0)]
        + [
            (
                math.sin(math.pi * i / rings) * math.cos(2 * math.pi * j / segments),
                math.sin(math.pi * i / rings) * math.sin(2 * math.pi * j / segments),
                math.cos(math.pi * i / rings),
            )
            for i in range(1, rings)
            for j in range(segments)
        ]
        + [(0.0, 0.0, -1.0)]
    )
    faces = []
    last = 1 + (rings - 2) * segments
    for j in range(segments):
        faces += [(0, 1 + j, 1 + (j + 1) % segments), (len(vertices) - 1, last + (j + 1) % segments, last + j)]
    for i in range(rings - 2):
        for j in range(segments):
            a, b = 1 + i * segments + j, 1 + i * segments + (j + 1) % segments
            faces += [(a, a + segments, b), (b, a + segments, b + segments)]
    base = default_scene()
    mesh = sc.TriangleMesh(
        name="mesh",
        material="copper",
        location=(0, 0, 2),
        rotation=(10, 20, 30),
        vertices=tuple(vertices),
        triangles=tuple(faces),
    )
    from dataclasses import replace

    scene = replace(base, objects=(base.objects[0], mesh), vane=None).with_render(width=40, height=30)
    assert len(faces) > 16 * 4
    np.testing.assert_allclose(render(scene, workers=1).image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)


def test_the_books_tracer_with_the_documented_conventions_is_the_tracer() -> None:
    # docs/algorithm.md: Gambetta's CGFS tracer, written from the book, with its four differing conventions switched
    size = 40
    tracer_image = np.clip(render(cgfs_peer.as_scene(size), workers=1).image, 0.0, 1.0)
    np.testing.assert_allclose(cgfs_peer.render(size, cgfs_peer.DOCUMENTED), tracer_image, rtol=0, atol=1e-9)
    book = cgfs_peer.render(size, cgfs_peer.BOOK)
    changed = {}
    for name in ("weighted_last_bounce", "reflection_epsilon", "unit_camera_rays", "pixel_centres"):
        one = cgfs_peer.render(size, replace(cgfs_peer.BOOK, **{name: True}))
        changed[name] = float((np.abs(one - book).max(axis=2) > 1 / 255).mean())
    # as the doc's table says: the weighting and the pixel centres change the picture, unit camera rays do not
    assert changed["weighted_last_bounce"] > 0.02 and changed["pixel_centres"] > 0.1
    assert changed["unit_camera_rays"] == 0.0
