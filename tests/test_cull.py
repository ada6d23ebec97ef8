"""The culls (screen rectangles for camera rays, coverage grids for shadow rays) drop rays, never change a pixel."""

from __future__ import annotations

import numpy as np
import pytest

from tests.random_scenes import extended_scene_document, random_scene_document
from tracer.geometry.cull import CoverageGrid, ScreenRectangles
from tracer.scene.loader import default_scene, scene_from_dict
from tracer.tracing.lights import PointSample, directed
from tracer.tracing.wavefront import TracedScene

SEEDS = range(30)
MODES = [("float64", "documented"), ("float32", "documented"), ("float64", "robust"), ("float32", "robust")]


def _render(scene, culled: bool) -> tuple[np.ndarray, object]:
    prepared = TracedScene(scene)
    if not culled:
        prepared.screen = None
        prepared.mirrors = {}
        for light in directed(prepared.lights):
            light.grid = None
    return prepared.render_rows(np.arange(scene.render.height))


@pytest.mark.parametrize("dtype, numerics", MODES)
def test_culling_changes_no_pixel_of_random_scenes(dtype: str, numerics: str) -> None:
    culled_somewhere = mirrored = 0
    for seed in SEEDS:
        scene = scene_from_dict(random_scene_document(seed, 96, 72)).with_render(dtype=dtype, numerics=numerics)
        image, counts = _render(scene, culled=True)
        plain, plain_counts = _render(scene, culled=False)
        assert np.array_equal(image, plain), f"seed {seed}"
        assert counts == plain_counts
        prepared = TracedScene(scene)
        if prepared.screen is not None and any(light.grid is not None for light in directed(prepared.lights)):
            culled_somewhere += 1
        mirrored += bool(prepared.mirrors)
    assert culled_somewhere >= len(SEEDS) // 2  # the comparison above exercised the culls
    assert mirrored >= len(SEEDS) // 4  # and the mirror rays' rectangles


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_culling_changes_no_pixel_of_scenes_with_holdouts_two_sided_mirrors_and_ray_visibility(dtype: str) -> None:
    """The optional fields change which rays continue off a mirror and what they may meet."""
    mirrored = 0
    for seed in range(20):
        scene = scene_from_dict(extended_scene_document(seed, 64, 48)).with_render(dtype=dtype)
        image, counts = _render(scene, culled=True)
        plain, plain_counts = _render(scene, culled=False)
        assert np.array_equal(image, plain), f"seed {seed}"
        assert counts == plain_counts
        mirrored += bool(TracedScene(scene).mirrors)
    assert mirrored >= 3  # the comparison above exercised the mirror rays' rectangles


def test_culling_changes_no_pixel_of_the_default_scene() -> None:
    scene = default_scene().with_render(width=320, height=240)
    image, _ = _render(scene, culled=True)
    plain, _ = _render(scene, culled=False)
    assert np.array_equal(image, plain)
    prepared = TracedScene(scene)
    assert prepared.screen is not None
    assert all(light.grid is not None for light in directed(prepared.lights))


def _with_floor_sphere(seed: int) -> dict:
    """A random scene standing on a sphere of radius 99999 (rt3.py's floor): its box reaches behind the camera
    and spreads under the lights, so no picture can hold it."""
    document = random_scene_document(seed, 64, 48)
    floor = {"name": "floor", "type": "sphere", "material": "m0", "location": [0, 0, -99999 - 4.5], "radius": 99999}
    document["objects"].insert(seed % 2, floor)
    return document


@pytest.mark.parametrize("dtype, numerics", MODES)
def test_a_floor_sphere_is_left_out_of_the_pictures_and_changes_no_pixel(dtype: str, numerics: str) -> None:
    """The camera's rectangles and the lights' grids leave the floor's kernel out (it sees every ray, as brute
    force has it) and cull the rest: the same bytes as with no culls, whether the hierarchy walks or not."""
    left_out = 0
    for seed in range(16):
        scene = scene_from_dict(_with_floor_sphere(seed)).with_render(dtype=dtype, numerics=numerics)
        for brute in (False, True):
            images = []
            for culled in (True, False):
                prepared = TracedScene(scene)
                for hierarchy in _hierarchies(prepared):
                    hierarchy.brute = brute and hierarchy.root is not None
                if not culled:
                    prepared.screen = None
                    for light in directed(prepared.lights):
                        light.grid = None
                images.append(prepared.render_rows(np.arange(scene.render.height)))
            (image, counts), (plain, plain_counts) = images
            assert np.array_equal(image, plain), f"seed {seed}, brute {brute}"
            assert counts == plain_counts
        prepared = TracedScene(scene)
        floor = seed % 2
        if prepared.screen is not None and prepared.screen.whole == [floor]:
            grids = [light.grid for light in prepared.lights if isinstance(light, PointSample)]
            assert all(grid is None or floor in grid.whole for grid in grids)
            left_out += 1
    assert left_out >= 12  # the comparison above exercised the left-out kernels


def test_a_box_behind_the_camera_is_left_out_of_the_screen_and_sees_every_ray() -> None:
    from tracer.scene import scene as sc

    camera = sc.Camera(location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0), lens=50.0)  # looks down -z
    settings = sc.RenderSettings(width=64, height=48)
    lower = np.array([[-0.2, -0.2, -0.2], [-50.0, -50.0, -60.0]])
    upper = np.array([[0.2, 0.2, 0.2], [50.0, 50.0, -2.0]])
    screen = ScreenRectangles.build(camera, settings, np.array([0.0, 0.0, 5.0]), ([4, 7], lower, upper))
    assert screen.kernels == [4, 7] and screen.whole == []  # the second box is in front too
    upper[1, 2] = 6.0  # now it reaches behind the camera
    screen = ScreenRectangles.build(camera, settings, np.array([0.0, 0.0, 5.0]), ([4, 7], lower, upper))
    assert screen.kernels == [4] and screen.whole == [7]
    sets = screen.rays(np.arange(48))
    assert [kernel for kernel, _ in sets] == [4, 7] and sets[1][1] is None
    assert 0.0 < screen.shares[0] < 0.5  # the small box's rectangle, a part of the picture


def test_a_light_just_above_a_huge_box_leaves_it_out_of_its_grid() -> None:
    lower = np.array([[-1.0, -1.0, 0.0], [-1e5, -1e5, -2e5]])
    upper = np.array([[1.0, 1.0, 2.0], [1e5, 1e5, -0.5]])
    grid = CoverageGrid.from_point(np.array([0.0, 0.0, 10.0]), [2, 3], lower, upper)
    assert grid is not None and grid.kernels == [2] and grid.whole == [3]
    assert CoverageGrid.from_point(np.array([0.0, 0.0, 1.0]), [2, 3], lower, upper) is None  # inside the small one


def test_screen_rectangles_hold_every_pixel_that_sees_a_sphere() -> None:
    """Independent truth: a pixel centre's ray meets a sphere where its distance from the centre is <= radius."""
    document = random_scene_document(0, 160, 120)
    document["objects"] = [
        {
            "name": "ball",
            "type": "sphere",
            "material": "m0",
            "location": [0.7, 1.0, 1.5],
            "radius": 0.6,
            "rotation": [0, 0, 0],
        }
    ]
    document["render"]["samples"] = 1
    scene = scene_from_dict(document)
    prepared = TracedScene(scene)
    from tracer.geometry.camera import band_directions

    rows = np.arange(120)
    D = band_directions(scene.camera, scene.render, rows)
    O = np.asarray(scene.camera.location)[:, None]
    C = np.array([[0.7], [1.0], [1.5]])
    along = ((C - O) * D).sum(axis=0)
    distance = np.linalg.norm(O + D * along - C, axis=0)
    seen = np.flatnonzero((distance <= 0.6) & (along > 0))
    assert seen.size > 100
    origin = np.asarray(scene.camera.location, dtype=np.float64)
    screen = ScreenRectangles.build(scene.camera, scene.render, origin, prepared.hierarchy.boxes)
    ((kernel, rays),) = screen.rays(rows)
    assert kernel == 0
    assert np.isin(seen, rays).all()
    assert rays.size < 0.5 * D.shape[1]  # and it culls: the ball covers a small part of the picture


def test_mirror_rectangles_hold_every_pixel_whose_mirror_ray_meets_a_sphere() -> None:
    """Independent truth: each pixel centre's ray is reflected off a tilted plane by hand, in float64, and meets
    the sphere where the reflected line passes within the radius of its centre, ahead of the plane."""
    from tracer.geometry.camera import band_directions

    document = random_scene_document(0, 160, 120)
    document["objects"] = [
        {"name": "floor", "type": "plane", "material": "m0", "location": [0, 0, -1], "rotation": [12, -8, 30]},
        {"name": "ball", "type": "sphere", "material": "m1", "location": [0.7, 1.0, 0.2], "radius": 0.6},
    ]
    document["materials"]["m0"]["reflective"] = 0.5
    document["render"]["samples"] = 1
    scene = scene_from_dict(document)
    prepared = TracedScene(scene)
    plane = prepared.kernels[0]
    point, normal = plane.point.ravel().astype(np.float64), plane.unit.ravel().astype(np.float64)
    location = np.asarray(scene.camera.location, dtype=np.float64)
    boxes = prepared.hierarchy.boxes
    mirror = ScreenRectangles.mirrored(scene.camera, scene.render, location, boxes, point, normal)
    rows = np.arange(120)
    D = band_directions(scene.camera, scene.render, rows)
    O = np.asarray(scene.camera.location)[:, None]
    t = ((point[:, None] - O) * normal[:, None]).sum(axis=0) / (D * normal[:, None]).sum(axis=0)
    on_plane = np.flatnonzero(t > 0)
    P = O + D[:, on_plane] * t[on_plane]
    R = D[:, on_plane] - 2.0 * (D[:, on_plane] * normal[:, None]).sum(axis=0) * normal[:, None]
    C = np.array([[0.7], [1.0], [0.2]])
    along = ((C - P) * R).sum(axis=0)
    distance = np.linalg.norm(P + R * along - C, axis=0)
    seen = on_plane[(distance <= 0.6) & (along > 0)]
    assert seen.size > 100
    ((kernel, rays),) = mirror.rays(rows)
    assert kernel == 1
    assert np.isin(seen, rays).all()
    assert rays.size < 0.5 * D.shape[1]  # and it culls: the ball's mirror image covers a small part


def test_pixel_rays_give_a_list_of_pixels_the_rays_its_rows_would_have() -> None:
    """An animation's re-traced pixels are culled as whole rows are: the same pixels for each kernel."""
    scene = default_scene().with_render(width=160, height=120, samples=2)
    screen = TracedScene(scene).screen
    rows = np.arange(30, 100)
    pixels = (rows[:, None] * 160 + np.arange(160)[None, :]).ravel()
    by_rows = screen.rays(rows)
    assert [(k, r.tolist()) for k, r in by_rows] == [(k, r.tolist()) for k, r in screen.pixel_rays(pixels)]
    some = pixels[np.random.default_rng(0).random(pixels.size) < 0.1]
    by_list = dict(screen.pixel_rays(some))
    for kernel, rays in by_rows:
        expected = np.intersect1d(pixels[rays // 2], some)
        assert np.array_equal(np.unique(some[by_list.get(kernel, np.zeros(0, int)) // 2]), expected), kernel


def test_pixel_rays_of_ascending_runs_are_those_of_any_order() -> None:
    """Pixels in ascending runs (frames traced together) found by binary searches: each kernel gets the rays the
    masks over every pixel give it, or with frame_of those of its own run only."""
    scene = default_scene().with_render(width=160, height=120, samples=4)
    screen = TracedScene(scene).screen
    rng = np.random.default_rng(3)
    frames = [np.sort(rng.choice(160 * 120, size, replace=False)) for size in (900, 0, 2500, 40)]
    pixels = np.concatenate(frames)
    runs = np.concatenate(([0], np.cumsum([frame.size for frame in frames]))).tolist()
    anywhere = [(k, r.tolist()) for k, r in screen.pixel_rays(pixels)]
    assert anywhere == [(k, r.tolist()) for k, r in screen.pixel_rays(pixels, runs)]
    frame_of = [-1] * (max(screen.kernels) + 1)
    frame_of[screen.kernels[0]], frame_of[screen.kernels[1]] = 2, 3
    own = dict(screen.pixel_rays(pixels, runs, frame_of))
    for kernel, rays in anywhere:
        if frame_of[kernel] < 0:
            assert own[kernel].tolist() == rays
            continue
        start, end = runs[frame_of[kernel]] * 4, runs[frame_of[kernel] + 1] * 4  # four samples a pixel
        expected = [ray for ray in rays if start <= ray < end]
        assert own.get(kernel, np.zeros(0, int)).tolist() == expected


def test_a_camera_among_the_objects_gets_no_screen_rectangles() -> None:
    from tracer.scene import scene as sc

    boxes = ([0], np.array([[-1.0, -1.0, -1.0]]), np.array([[1.0, 1.0, 1.0]]))
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0), lens=50.0)  # looks down -z
    settings = sc.RenderSettings(width=64, height=48)
    assert ScreenRectangles.build(camera, settings, np.zeros(3), boxes) is None
    assert ScreenRectangles.build(camera, settings, np.array([0.0, 0.0, 5.0]), boxes) is not None


def test_a_light_among_the_objects_gets_no_grid() -> None:
    lower, upper = np.array([[-1.0, -1.0, -1.0]]), np.array([[1.0, 1.0, 1.0]])
    assert CoverageGrid.from_point(np.zeros(3), [0], lower, upper) is None
    grid = CoverageGrid.from_point(np.array([0.0, 0.0, 5.0]), [0], lower, upper)
    assert grid is not None and 0.0 < grid.coverage <= 1.0


def test_a_grid_keeps_rays_it_cannot_resolve() -> None:
    """Shadow rays from absurdly far points: float32 cannot place them within a cell, so none is culled."""
    lower, upper = np.array([[-1.0, -1.0, -1.0]]), np.array([[1.0, 1.0, 1.0]])
    grid = CoverageGrid.from_direction(np.array([0.0, 0.0, 1.0]), [0], lower, upper)
    near = np.array([[5.0, 0.0], [5.0, 0.0], [0.0, -3.0]], dtype=np.float32)  # beside the box; under it
    rays, bits = grid.select(near)
    assert rays.tolist() == [1] and bits.tolist() == [1]
    far = near.copy()
    far[0, 0] = 3e7
    rays, bits = grid.select(far)
    assert rays.tolist() == [0, 1] and bits is None


def _hierarchies(prepared: TracedScene) -> list:
    return [prepared.camera_hierarchy, prepared.shadow_hierarchy, prepared.mirror_hierarchy]


@pytest.mark.parametrize("dtype, numerics", MODES)
def test_brute_force_and_the_walk_give_the_same_bytes(dtype: str, numerics: str) -> None:
    """Every kernel on every ray (no boxes, no culls) or the hierarchy's walk: the same pixels and ray counts."""
    for seed in range(40):
        scene = scene_from_dict(random_scene_document(seed, 64, 48)).with_render(dtype=dtype, numerics=numerics)
        results = []
        for brute in (True, False):
            prepared = TracedScene(scene)
            for hierarchy in _hierarchies(prepared):
                hierarchy.brute = brute and hierarchy.root is not None
            results.append(prepared.render_rows(np.arange(scene.render.height)))
        (brute_image, brute_counts), (walked_image, walked_counts) = results
        assert np.array_equal(brute_image, walked_image), f"seed {seed}"
        assert brute_counts == walked_counts


def test_brute_force_is_chosen_for_a_few_spheres_and_the_walk_for_the_vane() -> None:
    """The cost estimate (Hierarchy.choose_brute): rt3.py's scene (4 spheres, one of them the floor) is tested by
    brute force, the default weathervane (13 bounded objects) walks its hierarchy and keeps its culls."""
    spheres = [([0.75, 1, 0.1], 0.6), ([-0.75, 2.25, 0.1], 0.6), ([-2.75, 3.5, 0.1], 0.6), ([0, 0, -99999.5], 99999)]
    document = {
        "materials": {"m": {"color": [0.5, 0.5, 0.5], "specular": 50, "reflective": 0.5}},
        "objects": [{"type": "sphere", "material": "m", "location": c, "radius": r} for c, r in spheres],
        "lights": [{"type": "ambient", "intensity": 0.05}, {"type": "point", "location": [5, -10, 5], "intensity": 1}],
        "camera": {"location": [0, -1, 0.35], "rotation": [90, 0, 0], "fov": 90, "shift_y": -0.05},
        "render": {"width": 400, "height": 300, "depth": 2},
    }
    for dtype in ("float64", "float32"):
        peer = TracedScene(scene_from_dict(document).with_render(dtype=dtype))
        assert all(hierarchy.brute for hierarchy in _hierarchies(peer))
        # the camera's rays still go to the small spheres through their rectangles, the floor sees them all; the
        # light's grid would give the spheres too many rays (their own surfaces' and their shadows') to pay
        assert peer.screen is not None and peer.screen.kernels == [0, 1, 2] and peer.screen.whole == [3]
        assert peer.lights[1].grid is None
        vane = TracedScene(default_scene().with_render(dtype=dtype))
        assert not any(hierarchy.brute for hierarchy in _hierarchies(vane))
        assert vane.screen is not None


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_sphere_whose_hits_lie_inside_its_padding_skips_no_hit_the_box_check_would_drop(dtype: str) -> None:
    """Hierarchy._inside_padding (brute force skips the padded-box check of a sphere's hits where it holds) against
    the box check itself, on rt3.py's floor and a small ball: rays from near and far, from the surfaces, and
    grazing ones a hair inside and outside the silhouette, where rounding makes spurious roots."""
    from tracer.geometry import transforms as tf
    from tracer.geometry.bvh import Hierarchy
    from tracer.geometry.kernels import SphereKernel, indices, quiet, shared_terms

    rng = np.random.default_rng(3)
    spheres = [((0.0, 0.0, -99999.5), 99999.0), ((0.75, 1.0, 0.1), 0.6)]
    kernels = [SphereKernel(tf.WorldSphere("m", center, radius), np.dtype(dtype)) for center, radius in spheres]
    hierarchy = Hierarchy(kernels, np.dtype(dtype), [0, 1], None)
    skipped = 0
    for index, (center, radius) in enumerate(spheres):
        for spread in (1.0, 400.0, 1e7):
            count = 20000
            O = rng.uniform(-spread, spread, size=(3, count))
            O[2] = np.abs(O[2])  # above the floor
            # grazing rays: toward a point of the silhouette seen from O, pushed a hair inside or outside
            toward = rng.normal(size=(3, count))
            toward /= np.linalg.norm(toward, axis=0)
            edge = np.asarray(center)[:, None] + toward * radius * (1.0 + rng.choice([-1e-9, 0.0, 1e-9], count))
            D = edge - O
            D[:, ::3] = rng.normal(size=(3, D[:, ::3].shape[1]))  # and some rays in any direction
            O, D = O.astype(dtype), D.astype(dtype)
            with quiet():
                shared = shared_terms(D)
                t, _ = kernels[index]._hit(O, D, 0.01, np.inf, shared)
                hits = indices(t < np.inf)
                dropped = hierarchy._off_box(index, O, D, hits, 0.01, np.inf)
                if hierarchy._inside_padding(index, O, shared[0], None):
                    skipped += 1
                    assert dropped.size == 0, f"sphere {index}, spread {spread}"
    if dtype == "float64":
        assert skipped >= 2  # the floor from near (and 400 units away) qualifies
    else:
        assert skipped == 0  # float32's rounding is never far enough below the padding
    nan_origins = np.full((3, 4), np.nan, dtype=dtype)
    assert not hierarchy._inside_padding(0, nan_origins, np.ones(4, dtype=dtype), None)
