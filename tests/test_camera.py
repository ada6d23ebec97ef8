"""Camera rays agree with Blender's camera to the pixel: points projected with Blender's formula land where traced."""

from __future__ import annotations

import math
import random
from dataclasses import replace

import numpy as np
import pytest

from tests.tracing import assert_matches_reference
from tracer.geometry import camera as cam
from tracer.geometry import transforms as tf
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, scene_from_dict
from tracer.tracing.reference import render_reference
from tracer.workers.parallel import render


def blender_world_to_camera_view(
    camera: sc.Camera, width: int, height: int, point: sc.Vec3, pixel_aspect: tuple[float, float] = (1.0, 1.0)
) -> tuple[float, float]:
    """bpy_extras.object_utils.world_to_camera_view, written out: normalised (x, y) with (0, 0) bottom-left.

    Blender's view frame (BKE_camera_params_compute_viewplane): the sensor side chosen by sensor_fit (AUTO: the
    wider side of the image times the pixel aspect takes sensor_width; HORIZONTAL: sensor_width across; VERTICAL:
    sensor_height up), or ortho_scale for an orthographic camera, spans the image at distance lens (at any depth
    for ORTHO); the frame is moved by shift times that side. The same check against Blender itself is in
    tests/addon/test_addon.py.
    """
    rx, ry, rz = (math.radians(a) for a in camera.rotation)

    # camera matrix_world rotation = Rz Ry Rx; its inverse is the transpose
    def rot_x(a):
        return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])

    def rot_y(a):
        return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])

    def rot_z(a):
        return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])

    rotation = rot_z(rz) @ rot_y(ry) @ rot_x(rx)
    local = rotation.T @ (np.asarray(point) - np.asarray(camera.location))
    z = -local[2]
    ycor = pixel_aspect[1] / pixel_aspect[0]
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if pixel_aspect[0] * width >= pixel_aspect[1] * height else "VERTICAL"
        sensor = camera.sensor_width
    else:
        sensor = camera.sensor_width if fit == "HORIZONTAL" else camera.sensor_height
    # the frame at unit depth (perspective) or in metres (orthographic)
    side = camera.ortho_scale if camera.type == "ORTHO" else sensor / camera.lens
    if fit == "HORIZONTAL":
        half_x = side / 2
        half_y = half_x * ycor * height / width
    else:
        half_y = side / 2
        half_x = half_y * width / (ycor * height)
    centre_x, centre_y = camera.shift_x * side, camera.shift_y * side
    u, v = (local[0], local[1]) if camera.type == "ORTHO" else (local[0] / z, local[1] / z)
    x = (u - centre_x + half_x) / (2 * half_x)
    y = (v - centre_y + half_y) / (2 * half_y)
    return x, y


CAMERAS = [
    (sc.Camera(location=(7.36, -6.93, 4.96), rotation=(63.6, 0, 46.7)), 64, 48),
    (sc.Camera(location=(1, -8, 2), rotation=(85, 3, -10), lens=35, sensor_fit="HORIZONTAL"), 40, 60),
    (sc.Camera(location=(-3, 4, 6), rotation=(30, -20, 200), lens=80, sensor_fit="VERTICAL", sensor_height=20), 50, 30),
    (sc.Camera(location=(0, -5, 1), rotation=(95, 0, 0), lens=24, sensor_fit="AUTO"), 30, 50),
]


# shift, orthographic, pixel aspect and clipping: (camera, width, height, pixel aspect)
MORE_CAMERAS = [
    (sc.Camera(location=(1, -8, 2), rotation=(85, 3, -10), lens=35, shift_x=0.2, shift_y=-0.15), 64, 48, (1, 1)),
    (sc.Camera(location=(2, -6, 3), rotation=(70, 0, 20), type="ORTHO", ortho_scale=5.0), 64, 48, (1, 1)),
    (sc.Camera(location=(2, -6, 3), rotation=(70, 0, 20), type="ORTHO", ortho_scale=4, shift_x=-0.3), 30, 50, (1, 1)),
    (sc.Camera(location=(0, -5, 1), rotation=(95, 0, 0), lens=24, clip_start=0.5, clip_end=30.0), 40, 30, (1, 2)),
    (sc.Camera(rotation=(63.6, 0, 46.7), sensor_fit="VERTICAL", shift_y=0.4), 50, 40, (3, 1)),
    (sc.Camera(type="ORTHO", ortho_scale=9, clip_start=1.0, clip_end=12.0, sensor_fit="HORIZONTAL"), 40, 60, (2, 1)),
]
ALL_CAMERAS = [(camera, width, height, (1, 1)) for camera, width, height in CAMERAS] + MORE_CAMERAS


@pytest.mark.parametrize(("camera", "width", "height", "aspect"), ALL_CAMERAS)
def test_pixel_centre_rays_project_back_onto_their_pixels(camera: sc.Camera, width: int, height: int, aspect) -> None:
    settings = sc.RenderSettings(width=width, height=height, pixel_aspect=aspect)
    rng = random.Random(width)
    for _ in range(50):
        i, j = rng.randrange(width), rng.randrange(height)
        origin, direction, _ = cam.primary_ray(camera, settings, i + 0.5, j + 0.5)
        point = tuple(origin[k] + 7.0 * direction[k] for k in range(3))
        x, y = blender_world_to_camera_view(camera, width, height, point, aspect)
        # Blender's normalised coordinates: pixel column x * width, row from the top (1 - y) * height
        assert x * width == pytest.approx(i + 0.5, abs=1e-9)
        assert (1 - y) * height == pytest.approx(j + 0.5, abs=1e-9)


@pytest.mark.parametrize(("camera", "width", "height", "aspect"), MORE_CAMERAS)
def test_camera_rays_start_and_stop_on_the_clip_planes(camera: sc.Camera, width: int, height: int, aspect) -> None:
    settings = sc.RenderSettings(width=width, height=height, pixel_aspect=aspect)
    forward = -np.asarray(tf.euler_xyz_matrix(camera.rotation))[:, 2]
    for i, j in ((0, 0), (width - 1, height - 1), (width // 2, height // 3)):
        origin, direction, t_max = cam.primary_ray(camera, settings, i + 0.5, j + 0.5)
        depth = float(np.dot(np.subtract(origin, camera.location), forward))
        assert depth == pytest.approx(camera.clip_start, abs=1e-12)
        if camera.clip_end is None:
            assert t_max == math.inf
        else:
            end = np.add(origin, np.multiply(direction, t_max))
            assert float(np.dot(end - camera.location, forward)) == pytest.approx(camera.clip_end, rel=1e-12)
    # the band's rays are the scalar ones, bit for bit
    rows = np.arange(height)
    directions = cam.band_directions(camera, settings, rows)
    origins, far = cam.band_starts(camera, settings, rows, None, directions)
    for k in (0, directions.shape[1] // 2, directions.shape[1] - 1):
        origin, direction, t_max = cam.primary_ray(camera, settings, k % width + 0.5, k // width + 0.5)
        assert tuple(directions[:, k]) == direction and tuple(origins[:, k]) == origin
        assert (far is None and t_max == math.inf) or far[k] == t_max


def test_clipping_hides_what_lies_before_clip_start_and_beyond_clip_end() -> None:
    # a small sphere 2 m ahead and a wall 20 m ahead, seen by a camera clipped to (3, 15), (1, 30) and (3, 30)
    def rendered(clip_start: float, clip_end: float | None) -> set[str]:
        scene = sc.Scene(
            materials={"near": sc.Material(color=(1, 0, 0)), "far": sc.Material(color=(0, 0, 1))},
            objects=(
                sc.Sphere(name="near", material="near", location=(0, 2, 0), radius=0.3),
                sc.Plane(name="far", material="far", location=(0, 20, 0), rotation=(90, 0, 0)),
            ),
            lights=(sc.AmbientLight(1.0),),
            camera=sc.Camera(location=(0, 0, 0), rotation=(90, 0, 0), clip_start=clip_start, clip_end=clip_end),
            background=sc.Background(type="solid", color=(0, 1, 0)),
            render=sc.RenderSettings(width=16, height=12, depth=0),
        )
        centre = render(scene, workers=1).image[6, 8]
        corner = render(scene, workers=1).image[0, 0]
        names = {(1, 0, 0): "near", (0, 0, 1): "far", (0, 1, 0): "sky"}
        return {names[tuple(int(c) for c in centre)], names[tuple(int(c) for c in corner)]}

    assert rendered(0.0, None) == {"near", "far"}
    assert rendered(3.0, None) == {"far"}
    assert rendered(1.0, 15.0) == {"near", "sky"}
    assert rendered(3.0, 15.0) == {"sky"}


@pytest.mark.parametrize(("camera", "width", "height", "aspect"), MORE_CAMERAS)
@pytest.mark.parametrize("samples", [1, 4])
def test_more_cameras_match_the_per_pixel_reference(
    camera: sc.Camera, width: int, height: int, aspect, samples
) -> None:
    scene = replace(default_scene(), camera=replace(camera, location=(4.6, -5.4, 3.3), rotation=(79.92, 0, 39.81)))
    scene = scene.with_render(width=width // 2, height=height // 2, pixel_aspect=aspect, samples=samples)
    expected = np.asarray(render_reference(scene))
    np.testing.assert_allclose(render(scene, workers=1).image, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize(("camera", "width", "height"), CAMERAS)
def test_small_spheres_appear_on_the_projected_pixels(camera: sc.Camera, width: int, height: int) -> None:
    rng = random.Random(height)
    # a sphere about 3 pixels across at 6 m
    radius = 6.0 * 1.5 * cam.sensor_size(camera, width, height)[0] / width / camera.lens
    for _ in range(4):
        # a point somewhere in view, about 6 m ahead
        settings = sc.RenderSettings(width=width, height=height, depth=0)
        x, y = rng.uniform(0.2, 0.8) * width, rng.uniform(0.2, 0.8) * height
        d = cam.primary_direction(camera, settings, x, y)
        centre = tuple(camera.location[k] + 6.0 * d[k] for k in range(3))
        u, v = blender_world_to_camera_view(camera, width, height, centre)
        expected = (u * width, (1 - v) * height)
        scene = sc.Scene(
            materials={"white": sc.Material(color=(1, 1, 1))},
            objects=(sc.Sphere(name="dot", material="white", location=centre, radius=radius),),
            lights=(sc.AmbientLight(1.0),),
            camera=camera,
            background=sc.Background(type="none"),
            render=settings,
        )
        covered = render(scene, workers=1).image[..., 0] > 0.5
        rows, columns = np.nonzero(covered)
        assert rows.size >= 3
        assert columns.mean() + 0.5 == pytest.approx(expected[0], abs=0.5)
        assert rows.mean() + 0.5 == pytest.approx(expected[1], abs=0.5)


def test_sensor_fit_auto_uses_the_wider_side() -> None:
    camera = sc.Camera(sensor_width=36, sensor_height=24)
    assert cam.sensor_size(camera, 200, 100) == (36, 18)
    assert cam.sensor_size(camera, 100, 200) == (18, 36)
    assert cam.sensor_size(sc.Camera(sensor_fit="VERTICAL", sensor_height=24), 200, 100) == (48, 24)
    assert cam.sensor_size(sc.Camera(sensor_fit="HORIZONTAL", sensor_width=36), 100, 200) == (36, 72)


def test_stratified_samples_stay_in_their_strata_and_band_rays_match_scalar_rays() -> None:
    camera = CAMERAS[0][0]
    settings = sc.RenderSettings(width=8, height=6, samples=9, seed=3)
    directions = cam.band_directions(camera, settings, np.arange(2, 4))
    k = 0
    for j in range(2, 4):
        for i in range(8):
            for s in range(9):
                x, y = cam.sample_position(settings, i, j, s)
                assert i + (s % 3) / 3 <= x < i + (s % 3 + 1) / 3
                assert j + (s // 3) / 3 <= y < j + (s // 3 + 1) / 3
                assert tuple(directions[:, k]) == cam.primary_direction(camera, settings, x, y)
                k += 1


def test_cached_band_directions_are_the_computed_ones_and_stay_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cam, "_BAND_CACHE", type(cam._BAND_CACHE)())
    settings = sc.RenderSettings(width=64, height=48, samples=4)
    camera = sc.Camera()
    rows = np.arange(16, 32)
    first = cam.cached_band_directions(camera, settings, rows, np.dtype(np.float32))
    np.testing.assert_array_equal(first, cam.band_directions(camera, settings, rows).astype(np.float32))
    assert not first.flags.writeable  # shared between frames: nobody may change it
    assert cam.cached_band_directions(camera, settings, rows, np.dtype(np.float32)) is first
    moved = sc.Camera(location=(1.0, 2.0, 3.0))
    np.testing.assert_array_equal(
        cam.cached_band_directions(moved, settings, rows, np.dtype(np.float32)),
        cam.band_directions(moved, settings, rows).astype(np.float32),
    )
    whole = 64 * 48 * 4 * 3 * 8  # every ray of the image in float64
    monkeypatch.setattr(cam, "BAND_CACHE_BYTES", whole)
    for start in range(0, 48, 4):
        cam.cached_band_directions(camera, settings, np.arange(start, start + 4), np.dtype(np.float64))
    assert sum(kept.nbytes for kept in cam._BAND_CACHE.values()) <= whole
    monkeypatch.setattr(cam, "_BAND_CACHE", type(cam._BAND_CACHE)())
    monkeypatch.setattr(cam, "BAND_CACHE_BYTES", whole - 1)  # the image no longer fits: nothing is kept
    cam.cached_band_directions(camera, settings, rows, np.dtype(np.float64))
    assert not cam._BAND_CACHE


@pytest.mark.parametrize("fit", ["AUTO", "HORIZONTAL", "VERTICAL"])
def test_to_pixels_inverts_primary_direction(fit: str) -> None:
    camera = sc.Camera(location=(1.0, -6.0, 2.0), rotation=(80.0, 5.0, 20.0), lens=35.0, sensor_fit=fit)
    settings = sc.RenderSettings(width=64, height=48)
    rng = random.Random(7)
    positions = [(rng.uniform(0, 64), rng.uniform(0, 48)) for _ in range(20)]
    points = np.array(
        [
            np.asarray(camera.location) + 3.5 * np.asarray(cam.primary_direction(camera, settings, x, y))
            for x, y in positions
        ]
    )
    x, y, depth = cam.to_pixels(camera, settings, points, np.asarray(camera.location))
    np.testing.assert_allclose(np.column_stack((x, y)), positions, atol=1e-9)
    assert (depth > 0).all()


@pytest.mark.parametrize(
    "rotation", [(63.6, 0.0, 46.7), (-170.0, 45.0, 179.0), (10.0, 90.0, 0.0), (0.0, -90.0, 30.0), (5.0, 0.0, -120.0)]
)
def test_euler_angles_read_back_from_a_rotation_give_the_same_rotation(rotation) -> None:
    angles = tf.euler_xyz_from_matrix(tf.euler_xyz_matrix(rotation))
    assert np.allclose(tf.euler_xyz_matrix(angles), tf.euler_xyz_matrix(rotation), atol=1e-12)
    if abs(rotation[1]) < 90.0:  # away from gimbal lock the angles themselves come back
        assert np.allclose(angles, rotation, atol=1e-9)


# ---- depth of field: a thin lens ------------------------------------------------------------------------------------


def _lens_document(seed: int) -> dict:
    """A random scene seen through a thin lens: perspective or orthographic, clipped or not, 1 to 9 samples."""
    from tests.random_scenes import extended_scene_document

    rng = random.Random(40_000 + seed)
    document = extended_scene_document(seed, width=14, height=10)
    camera = document.setdefault("camera", {})
    camera.update(aperture=rng.choice([0.05, 0.3]), focus_distance=rng.uniform(2.0, 9.0))
    if seed % 3 == 1:
        camera.update(type="ORTHO", ortho_scale=7.0)
    if seed % 3 == 2:
        camera.update(clip_start=0.5, clip_end=30.0)
    document.setdefault("render", {})["samples"] = rng.choice([1, 4, 9])
    return document


@pytest.mark.parametrize("seed", range(9))
def test_a_thin_lens_matches_the_reference(seed: int) -> None:
    scene = scene_from_dict(_lens_document(seed))
    assert_matches_reference(scene)


def test_a_thin_lens_focuses_on_its_plane_and_blurs_off_it() -> None:
    """Every lens ray of a pixel meets the pinhole ray on the focus plane; a lens of radius a spreads the rays of a
    pixel over a disk of radius a at the lens, their origins within a of the camera."""
    document = _lens_document(0)
    document["camera"].update(aperture=0.25, focus_distance=4.0, type="PERSP")
    for field in ("clip_start", "clip_end"):
        document["camera"].pop(field, None)
    document["render"]["samples"] = 16
    scene = scene_from_dict(document)
    settings, camera = scene.render, scene.camera
    pixels = np.arange(settings.width * settings.height)
    D = cam.pixel_directions(camera, settings, pixels)
    O, far = cam.pixel_starts(camera, settings, pixels, D)
    pinhole = cam.pixel_directions(replace(camera, aperture=0.0), settings, pixels)
    axis = -np.asarray(tf.euler_xyz_matrix(camera.rotation))[:, 2]
    location = np.asarray(camera.location)[:, None]
    on_plane = O + D * ((4.0 - axis @ (O - location)) / (axis @ D))
    through_pinhole = location + pinhole * (4.0 / (axis @ pinhole))
    np.testing.assert_allclose(on_plane, through_pinhole, atol=1e-9)
    offsets = np.linalg.norm(O - location, axis=0)
    assert far is None and offsets.max() <= 0.25 + 1e-12 and offsets.max() > 0.2  # the whole lens is used


def test_lens_fields_are_checked_with_clear_messages() -> None:
    base = {"materials": {"m": {"color": [1, 1, 1]}}, "objects": [{"type": "sphere", "material": "m"}]}
    for camera, field in (({"aperture": -0.1}, "camera.aperture"), ({"focus_distance": 0}, "camera.focus_distance")):
        with pytest.raises(SceneError, match=field.replace(".", r"\.")):
            scene_from_dict({**base, "camera": camera})


# ---- panoramic cameras ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", sc.PANORAMA_TYPES)
@pytest.mark.parametrize("seed", range(2))
def test_panoramic_cameras_match_the_reference(kind: str, seed: int) -> None:
    from tests.random_scenes import extended_scene_document

    document = extended_scene_document(seed, width=16, height=12)
    document["camera"].update(type="PANO", panorama_type=kind, fisheye_fov=200.0 if seed else 180.0)
    if seed:
        document["camera"].update(clip_start=0.3, clip_end=12.0, latitude_min=-60.0, longitude_max=120.0)
    document["render"].update(samples=4, film_transparent=True)
    scene = scene_from_dict(document)
    assert_matches_reference(scene)


def test_a_panoramic_cameras_centre_looks_ahead_and_outside_its_lens_is_nothing() -> None:
    """The image's centre looks along the camera's -Z for every panorama type; a fisheye's corners are outside its
    circle: black, transparent, and no pass holds anything there but the background's depth and mist."""
    base = {"location": [0.0, 0.0, 0.0], "rotation": [90.0, 0.0, 30.0], "type": "PANO"}
    forward = -np.asarray(tf.euler_xyz_matrix((90.0, 0.0, 30.0)))[:, 2]
    minimal = {"materials": {"m": {"color": [1, 1, 1]}}, "objects": [{"type": "sphere", "material": "m", "radius": 1}]}
    for kind in sc.PANORAMA_TYPES:
        camera = scene_from_dict({**minimal, "camera": {**base, "panorama_type": kind}}).camera
        settings = sc.RenderSettings(width=8, height=8)
        np.testing.assert_allclose(cam.primary_direction(camera, settings, 4.0, 4.0), forward, atol=1e-12)
    document = {
        "materials": {"m": {"color": [1.0, 1.0, 1.0]}},
        "objects": [{"type": "sphere", "material": "m", "location": [0.0, 30.0, 0.0], "radius": 100.0}],
        "lights": [{"type": "ambient", "intensity": 1.0}],
        "camera": {**base, "panorama_type": "FISHEYE_EQUIDISTANT"},
        "background": {"type": "solid", "color": [0.2, 0.4, 0.6]},
        "render": {"width": 8, "height": 8, "film_transparent": True, "passes": ["environment", "normal"]},
    }
    result = render(scene_from_dict(document), workers=1)
    assert np.all(result.image[0, 0] == 0.0) and result.alpha[0, 0] == 0.0  # a corner: outside the circle
    assert result.passes["environment"][0, 0].tolist() == [0.0, 0.0, 0.0]
    assert result.image[4, 4].sum() > 0.0 and result.alpha[4, 4] == 1.0


def test_panorama_fields_are_checked_with_clear_messages() -> None:
    base = {"materials": {"m": {"color": [1, 1, 1]}}, "objects": [{"type": "sphere", "material": "m"}]}
    for camera, field in (
        ({"type": "PANO", "panorama_type": "CUBEMAP"}, "camera.panorama_type"),
        ({"type": "PANO", "latitude_min": -95}, "camera.latitude_min"),
        ({"type": "PANO", "fisheye_fov": 0}, "camera.fisheye_fov"),
    ):
        with pytest.raises(SceneError, match=field.replace(".", r"\.")):
            scene_from_dict({**base, "camera": camera})
