"""Motion blur (objects' and the camera's poses over the shutter, tracer/workers/shutter.py): a moving box's coverage
against the count of time slices that cover each pixel (the analytic answer), a camera moving one way the same image
as the object moving the other, meshes and instances posed as boxes, the passes' sums, the same bytes for any
number of workers, poses that do not move rendering as the still scene, and the loader's and CLI's messages."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from tests.random_scenes import extended_scene_document
from tests.tracing import assert_matches_reference
from tracer.geometry.camera import sample_position
from tracer.scene.loader import SceneError, scene_from_dict
from tracer.scene.passes import WHITTED
from tracer.workers import shutter
from tracer.workers.parallel import render

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "docs" / "scene.schema.json").read_text())
WIDTH, HEIGHT, ORTHO_SCALE = 160, 40, 8.0  # 0.05 m a pixel
STEPS = 8


def _poses(start: float, end: float, z: float = 0.0, steps: int = STEPS, turn: float = 0.0) -> list[dict]:
    """steps poses moving along x from start to end (and turning by turn degrees about z), evenly over the shutter."""
    return [
        {"location": [start + (end - start) * k / (steps - 1), 0.0, z], "rotation": [0.0, 0.0, turn * k / (steps - 1)]}
        for k in range(steps)
    ]


def _document(box: dict | None = None, camera: dict | None = None, **render: object) -> dict:
    """A unit box seen from above by an orthographic camera, on a transparent film, lit by an ambient light."""
    return {
        "materials": {"m": {"color": [0.8, 0.5, 0.2]}},
        "objects": [{"type": "box", "name": "box", "material": "m", "size": [1, 1, 1], **(box or {})}],
        "lights": [
            {"type": "ambient", "intensity": 1.0},
            {"type": "directional", "direction": [0.3, 0.2, 1.0], "intensity": 0.5},
        ],
        "camera": {"type": "ORTHO", "ortho_scale": ORTHO_SCALE, "location": [0, 0, 10], "rotation": [0, 0, 0]}
        | (camera or {}),
        "background": {"type": "none"},
        "render": {"width": WIDTH, "height": HEIGHT, "film_transparent": True, "workers": 1} | render,
    }


def _pixel_centres() -> np.ndarray:
    return (np.arange(WIDTH) + 0.5) / WIDTH * ORTHO_SCALE - ORTHO_SCALE / 2.0


def test_a_moving_box_covers_each_pixel_for_the_share_of_slices_it_is_there() -> None:
    scene = scene_from_dict(_document({"poses": _poses(-0.5, 0.5)}))
    assert shutter.steps(scene) == STEPS
    result = render(scene)
    places = -0.5 + np.arange(STEPS) / (STEPS - 1)
    expected = (np.abs(_pixel_centres()[:, None] - places[None, :]) < 0.5).mean(axis=1)
    np.testing.assert_array_equal(result.alpha[HEIGHT // 2], expected)
    covered = _pixel_centres()[result.alpha[HEIGHT // 2] > 0]
    streak = covered[-1] - covered[0] + ORTHO_SCALE / WIDTH
    assert streak == pytest.approx(2.0, abs=ORTHO_SCALE / WIDTH)  # the box's 1 m and its 1 m move, to a pixel


def test_the_camera_moving_one_way_is_the_box_moving_the_other() -> None:
    moved = render(scene_from_dict(_document({"poses": _poses(-0.5, 0.5)})))
    camera = render(scene_from_dict(_document(camera={"poses": _poses(0.5, -0.5, z=10.0)})))
    np.testing.assert_allclose(camera.image, moved.image, atol=1e-12)
    np.testing.assert_allclose(camera.alpha, moved.alpha, atol=1e-12)


def test_a_mesh_and_an_instance_follow_their_poses_as_a_box_does() -> None:
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    box = scene_from_dict(_document({"poses": _poses(-0.5, 0.5, turn=40.0)}))
    faces = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4]]
    faces += [[2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]
    mesh = {"type": "mesh", "vertices": corners.tolist(), "triangles": faces, "poses": _poses(-0.5, 0.5, turn=40.0)}
    document = _document()
    document["objects"] = [{"name": "box", "material": "m", **mesh}]
    mesh_alpha = render(scene_from_dict(document)).alpha
    document["meshes"] = {"cube": {"vertices": corners.tolist(), "triangles": faces, "material": "m"}}
    document["objects"] = [
        {"type": "instances", "name": "box", "mesh": "cube", "matrices": [[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]],
         "poses": _poses(-0.5, 0.5, turn=40.0)}
    ]  # fmt: skip
    instance_alpha = render(scene_from_dict(document)).alpha
    box_alpha = render(box).alpha
    assert 0.0 < box_alpha.mean() < 1.0
    for alpha in (mesh_alpha, instance_alpha):
        differ = np.abs(alpha - box_alpha) > 1e-9
        assert differ.mean() < 0.002  # a sample on a shared edge may fall either side


def test_blurred_passes_still_add_up_to_the_image_and_depth_is_the_middle_slices() -> None:
    passes = [*WHITTED, "depth"]
    scene = scene_from_dict(_document({"poses": _poses(-0.5, 0.5)}, passes=passes, samples=4))
    result = render(scene)
    total = sum(result.passes[name] for name in WHITTED)
    np.testing.assert_allclose(total, result.image, atol=1e-12)
    middle = render(shutter.time_slice(scene, (STEPS - 1) // 2))
    np.testing.assert_array_equal(result.passes["depth"], middle.passes["depth"])


def test_the_same_bytes_for_any_number_of_workers() -> None:
    document = _document({"poses": _poses(-0.5, 0.5, turn=30.0)}, camera={"poses": _poses(0.0, 0.3, z=10.0)})
    one = render(scene_from_dict(document), workers=1)
    two = render(scene_from_dict(document), workers=2)
    assert one.image.tobytes() == two.image.tobytes() and one.alpha.tobytes() == two.alpha.tobytes()


def test_poses_that_do_not_move_render_the_still_scene_at_that_pose() -> None:
    at = {"location": [0.7, 0.0, 0.0], "rotation": [0.0, 0.0, 10.0]}
    posed = scene_from_dict(_document({"poses": [at] * 3}))
    assert shutter.steps(posed) == 1
    still = scene_from_dict(_document(at))
    assert render(posed).image.tobytes() == render(still).image.tobytes()


def test_posed_scenes_follow_the_schema_and_bad_poses_are_named() -> None:
    document = _document({"poses": _poses(-0.5, 0.5)}, camera={"poses": _poses(0.0, 0.3, z=10.0)})
    jsonschema.validate(document, SCHEMA)
    cases = {
        "objects[0].poses: must be a list of 2 to 256 poses": {"poses": _poses(0, 1)[:1]},
        "objects[0].poses[1].rotation: is required": {"poses": [{"location": [0, 0, 0], "rotation": [0, 0, 0]},
                                                                {"location": [1, 0, 0]}]},
    }  # fmt: skip
    for message, box in cases.items():
        with pytest.raises(SceneError) as raised:
            scene_from_dict(_document(box))
        assert any(problem.startswith(message) for problem in raised.value.problems), raised.value.problems
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(_document(box), SCHEMA)
    with pytest.raises(SceneError) as raised:
        scene_from_dict(_document({"poses": _poses(0, 1, steps=4)}, camera={"poses": _poses(0, 1, z=10, steps=3)}))
    assert raised.value.problems == [
        "camera.poses: 3 poses where objects[0].poses has 4: each moving object and the camera need one pose per time "
        "over the shutter, the same number"
    ]


def test_the_animate_command_refuses_poses_by_name(tmp_path: Path) -> None:
    document = _document({"poses": _poses(-0.5, 0.5)})
    document["vane"] = {"parts": ["box"]}
    path = tmp_path / "posed.json"
    path.write_text(json.dumps(document))
    done = subprocess.run(
        [sys.executable, "-m", "tracer", "animate", str(path), "-o", str(tmp_path / "frames"), "--frames", "2"],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2 and "poses: motion blur" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "frames").exists() or not any((tmp_path / "frames").iterdir())


def test_slices_share_out_the_samples_every_stratum_once_and_the_streak_is_the_swept_box() -> None:
    scene = scene_from_dict(_document({"poses": _poses(-0.5, 0.5, steps=16)}, samples=16))
    slices = [shutter.time_slice(scene, k).render for k in range(16)]
    assert all(settings.samples == 1 and settings.time_slice == (k, 16) for k, settings in enumerate(slices))
    for i, j in ((3, 5), (80, 20), (159, 39)):  # each pixel's 16 slices land in its 16 strata, one each
        cells = {(int((x - i) * 4), int((y - j) * 4)) for x, y in (sample_position(s, i, j, 0) for s in slices)}
        assert cells == {(a, b) for a in range(4) for b in range(4)}
    result = render(scene)
    assert result.rays.camera == WIDTH * HEIGHT * 16  # the still frame's samples, not 16 frames of them
    # the box's 1 m swept over 1 m: coverage along x is the trapezoid (box * move), here 2 m wide at its foot, flat 0
    # at its top (a triangle); each pixel's 16 samples meet 16 times (noise of about 1/16), averaged over the 16 rows
    # well inside the box's 1 m (20 rows) across the motion
    profile = result.alpha[12:28].mean(axis=0)
    triangle = np.clip(1.0 - np.abs(_pixel_centres()), 0.0, 1.0)
    assert np.abs(profile - triangle).max() < 0.07
    assert np.abs(profile - triangle).mean() < 0.01
    two = render(scene, workers=2)
    assert two.image.tobytes() == result.image.tobytes() and two.alpha.tobytes() == result.alpha.tobytes()


@pytest.mark.parametrize("seed", range(6))
def test_a_time_slices_share_of_the_samples_is_the_per_pixel_references(seed: int) -> None:
    """The strata a slice traces (image positions and lens points) are the same in both tracers."""
    scene = scene_from_dict(extended_scene_document(seed))
    if seed % 2:  # a thin lens: its points are the strata's too
        scene = replace(scene, camera=replace(scene.camera, aperture=0.05, focus_distance=6.0))
    assert_matches_reference(scene.with_render(samples=4, time_slice=(seed % 4, 4)))


def test_a_slices_camera_rays_are_not_taken_for_the_whole_frames() -> None:
    """The camera's rays are kept between renders of the same camera and image settings: a slice's share of the
    strata is not the whole frame's (they once were, when the kept rays' key left the slice out)."""
    scene = scene_from_dict(extended_scene_document(1)).with_render(samples=4)
    render(scene.with_render(time_slice=(1, 4)), workers=1)
    assert_matches_reference(scene)


def test_one_or_four_samples_over_16_poses_take_a_4_by_4_grid_and_8_poses_do_not_share() -> None:
    """16 poses (a perfect square) share out a grid of lcm(samples, 16) strata: at 1, 4 or 16 samples the same 4 x 4
    grid, one stratum a slice, the same bytes; 8 poses (not a square) trace every sample in every slice."""
    images = {}
    for samples in (1, 4, 16):
        scene = scene_from_dict(_document({"poses": _poses(-0.5, 0.5, steps=16)}, samples=samples))
        assert shutter.time_slice(scene, 3).render.time_slice == (3, 16)
        result = render(scene)
        assert result.rays.camera == WIDTH * HEIGHT * 16
        images[samples] = result.image.tobytes() + result.alpha.tobytes()
    assert images[1] == images[4] == images[16]
    eight = scene_from_dict(_document({"poses": _poses(-0.5, 0.5, steps=8)}, samples=4))
    assert shutter.time_slice(eight, 3).render.time_slice is None
    assert render(eight).rays.camera == WIDTH * HEIGHT * 4 * 8
