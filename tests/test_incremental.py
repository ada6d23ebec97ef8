"""Incremental frames (tracer/geometry/footprint.py, tracer/frames/incremental.py) are the whole frames, bit for bit."""

from __future__ import annotations

import random
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import random_scene_document
from tracer.frames import incremental
from tracer.frames.animate import headings
from tracer.geometry import bvh
from tracer.geometry.cull import GRID_BOXES
from tracer.geometry.footprint import swept_volume
from tracer.geometry.rayframes import RayFrames
from tracer.scene import scene as sc
from tracer.scene.loader import default_scene, scene_from_dict
from tracer.tracing.wavefront import TracedScene
from tracer.workers.parallel import FRAMES_PER_TASK, Renderer, frames_per_task


def turning_scene(seed: int, dtype: str, numerics: str) -> sc.Scene:
    """A random scene whose non-plane objects are split: about half turn as a vane about a random tilted axis
    through a point among them (so moving parts shadow and mirror static ones and each other), mirrors at depth 5,
    a point and a directional light beside the scene's own."""
    rng = random.Random(seed)
    document = random_scene_document(seed, width=40, height=30)
    document["render"].update(depth=5, dtype=dtype, numerics=numerics)
    document["materials"]["mirror"] = {"color": [0.9, 0.9, 0.95], "specular": 40, "reflective": 0.8}
    bounded = [obj for obj in document["objects"] if obj["type"] != "plane"]
    for obj in bounded[::3]:
        obj["material"] = "mirror"
    parts = [obj["name"] for obj in bounded if rng.random() < 0.5] or [bounded[0]["name"]]
    document["lights"] += [
        {"type": "point", "location": [rng.uniform(-3, 3), rng.uniform(-3, 1), rng.uniform(2, 4)], "intensity": 0.4},
        {"type": "directional", "direction": [rng.uniform(-1, 1), rng.uniform(-1, 1), 1.0], "intensity": 0.3},
    ]
    document["vane"] = {
        "parts": parts,
        "pivot": [rng.uniform(-1, 1), rng.uniform(-0.5, 1.5), rng.uniform(0, 1)],
        "axis": [rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 1.0],
    }
    return scene_from_dict(document)


def random_headings(seed: int, count: int) -> list[float]:
    """A walk of small and large steps: runs of close headings and jumps between them."""
    rng = random.Random(seed)
    heading, result = rng.uniform(0, 360), []
    for _ in range(count):
        heading += rng.choice([0.0, rng.uniform(-4, 4), rng.uniform(-40, 40)])
        result.append(heading)
    return result


def assert_frames_are_whole_frames(scene: sc.Scene, turns: list[float], workers: int) -> float:
    """Every incremental frame equals a whole trace of it; returns the share of camera rays the increments saved."""
    pairs = list(enumerate(turns, 1))
    with Renderer(workers) as renderer:
        traced = 0
        for frame, result in incremental.render_frames(renderer, scene, iter(pairs)):
            whole = renderer.render(scene.with_heading(turns[frame - 1]))
            assert result.image.dtype == whole.image.dtype
            assert np.array_equal(result.image, whole.image), f"frame {frame} differs"
            traced += result.rays.camera
    return 1.0 - traced / (len(turns) * scene.render.width * scene.render.height * scene.render.samples)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(("dtype", "numerics"), [("float64", "documented"), ("float32", "robust")])
def test_random_turning_scenes_are_bit_identical_frame_by_frame(seed: int, dtype: str, numerics: str) -> None:
    scene = turning_scene(seed, dtype, numerics)
    assert_frames_are_whole_frames(scene, random_headings(seed, 24), workers=1)


@pytest.mark.parametrize(("dtype", "numerics"), [("float32", "documented"), ("float64", "robust")])
def test_random_turning_scenes_with_two_workers(dtype: str, numerics: str) -> None:
    scene = turning_scene(11, dtype, numerics)
    assert_frames_are_whole_frames(scene, random_headings(11, 24), workers=2)


def test_runs_share_the_image_without_the_vane(monkeypatch: pytest.MonkeyPatch) -> None:
    """Frames in several runs (each its own marks) over the one image without the parts, and an animation shorter
    than MIN_FRAMES traced whole: the whole frames."""
    monkeypatch.setattr(incremental, "RUN_FRAMES", 5)
    scene = turning_scene(4, "float64", "robust")
    assert_frames_are_whole_frames(scene, random_headings(4, 17), workers=1)
    assert assert_frames_are_whole_frames(scene, random_headings(6, incremental.MIN_FRAMES - 1), workers=1) == 0.0


def test_the_default_animation_over_120_frames_and_what_it_saves() -> None:
    scene = default_scene().with_render(width=64, height=48, samples=4)
    saved = assert_frames_are_whole_frames(scene, headings(scene, 120).tolist(), workers=2)
    assert saved > 0.5  # most camera rays are not traced again


def test_a_frame_traces_only_the_pixels_its_heading_changes() -> None:
    """Frames start from the image without the vane's parts and trace the pixels whose trees meet a part at their
    heading (footprint.HeadingMarks): far fewer than the parts' boxes over every heading hold; a frame at the heading
    of the one before it traces nothing; the frames are the whole frames."""
    scene = default_scene().with_render(width=160, height=120)
    turns = headings(scene, 30).tolist()
    assert turns[1] == turns[0] != turns[-1]
    with Renderer(1) as renderer:
        results = dict(incremental.render_frames(renderer, scene, iter(list(enumerate(turns, 1)))))
        for frame in (1, 2, 20, 30):
            whole = renderer.render(scene.with_heading(turns[frame - 1]))
            assert np.array_equal(results[frame].image, whole.image)
        still = incremental.without_vane(scene)
        volume = swept_volume(scene, np.dtype(scene.render.dtype))
        held = int(renderer.render(still, volume=volume).touched.sum())
    for frame in range(2, 31):
        if turns[frame - 1] == turns[frame - 2]:
            assert results[frame].rays.camera == 0 and results[frame].image is results[frame - 1].image
        else:
            assert 0 < results[frame].rays.camera < held / 4


def test_turning_frames_in_any_order_are_whole_frames() -> None:
    scene = turning_scene(3, "float64", "documented")
    turning = incremental.TurningFrames()
    with Renderer(1) as renderer:
        for heading in random_headings(5, 12):
            result = turning.render(renderer, scene.with_heading(heading))
            assert np.array_equal(result.image, renderer.render(scene.with_heading(heading)).image)
        # another scene (a moved light) starts again from a whole frame
        moved = scene.with_render(depth=2)
        assert np.array_equal(turning.render(renderer, moved).image, renderer.render(moved).image)


def test_a_vane_that_fills_the_view_falls_back_to_whole_frames(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = turning_scene(2, "float64", "documented")
    turns = random_headings(2, 6)
    # the camera inside the box of the vane's first part: every camera ray starts in the volume
    first = next(obj for obj in scene.objects if obj.name == scene.vane.parts[0])
    inside = tuple(float(x) for x in first.location)
    scene = replace(scene, camera=replace(scene.camera, location=inside), vane=replace(scene.vane, pivot=inside))

    def not_incremental(*_args: object) -> None:
        raise AssertionError("pixels traced again where whole frames cost no more")

    monkeypatch.setattr(Renderer, "render_pixel_frames", not_incremental)
    with Renderer(1) as renderer:
        for frame, result in incremental.render_frames(renderer, scene, iter(list(enumerate(turns, 1)))):
            assert np.array_equal(result.image, renderer.render(scene.with_heading(turns[frame - 1])).image)


@pytest.mark.parametrize("seed", [1, 4, 8, 9])
def test_turning_scenes_with_blender_fields_are_whole_frames(seed: int) -> None:
    from tests.random_scenes import extended_scene_document

    document = extended_scene_document(seed, width=32, height=24)
    bounded = [obj["name"] for obj in document["objects"] if obj["type"] != "plane"]
    document["vane"] = {"parts": bounded[::2], "pivot": [0.2, 0.5, 0.3], "axis": [0.1, 0.0, 1.0]}
    document["render"]["depth"] = 3
    scene = scene_from_dict(document)
    turns = random_headings(seed, 8)
    with Renderer(1) as renderer:
        for frame, result in incremental.render_frames(renderer, scene, iter(list(enumerate(turns, 1)))):
            whole = renderer.render(scene.with_heading(turns[frame - 1]))
            assert np.array_equal(result.image, whole.image)
            assert (result.alpha is None) == (whole.alpha is None)
            assert result.alpha is None or np.array_equal(result.alpha, whole.alpha)
    # the pixel re-trace path itself, on the scene without what needs whole frames (alpha, border)
    document["render"].pop("border", None)
    document["render"]["film_transparent"] = False
    for obj in document["objects"]:
        obj["holdout"] = False
    assert_frames_are_whole_frames(scene_from_dict(document), turns, workers=1)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize(
    ("dtype", "numerics"),
    [("float64", "documented"), ("float32", "documented"), ("float64", "robust"), ("float32", "robust")],
)
def test_the_vanes_own_subtree_traces_the_same_bytes(
    seed: int, dtype: str, numerics: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The hierarchy with the vane's parts in a subtree of their own (the still objects' kept between frames) gives
    the images of the one surface-area tree over all objects, bit for bit, at any heading."""
    from tracer.geometry import bvh
    from tracer.tracing.wavefront import TracedScene
    from tracer.workers.resources import band_samples

    def image(scene: sc.Scene) -> np.ndarray:
        rows = np.arange(scene.render.height)
        return TracedScene(scene).render_rows(rows, band_samples(scene.render))[0]

    base = turning_scene(seed, dtype, numerics)
    turns = random_headings(seed, 3)
    split = [image(base.with_heading(turn)) for turn in turns]
    joined = bvh._split_build
    monkeypatch.setattr(bvh, "_split_build", lambda *args: joined(*args[:-1], None))
    for turn, expected in zip(turns, split, strict=True):
        assert np.array_equal(image(base.with_heading(turn)), expected), f"heading {turn}"


def assert_frames_together_are_frames_alone(scene: sc.Scene, turns: list[float], seed: int) -> None:
    """Each frame's pixels traced with the other frames' (TracedScene with headings: its parts' copies see only its
    rays) get the bytes and ray counts of a trace of that frame alone, whole or in pieces that split frames."""
    rng = np.random.default_rng(seed)
    size = scene.render.width * scene.render.height
    frame_pixels = [np.sort(rng.choice(size, size // 3, replace=False)) for _ in turns]
    together = TracedScene(scene, tuple(turns))
    for max_samples in (None, 97):
        traced = together.render_frame_pixels(frame_pixels, max_samples)
        for heading, pixels, (colors, counts) in zip(turns, frame_pixels, traced, strict=True):
            alone, alone_counts = TracedScene(scene.with_heading(heading)).render_pixels(pixels, max_samples)
            assert np.array_equal(colors, alone), f"heading {heading}"
            assert counts == alone_counts


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("numerics", ["documented", "robust"])
@pytest.mark.parametrize("brute_scale", [0.0, 1e9])  # every hierarchy brute force; none
def test_frames_traced_together_are_each_frame_alone(
    seed: int, dtype: str, numerics: str, brute_scale: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(bvh, "BRUTE_SCALE", brute_scale)
    scene = turning_scene(seed, dtype, numerics)
    assert_frames_together_are_frames_alone(scene, random_headings(seed, 5), seed)


@pytest.mark.parametrize("seed", [1, 4, 8, 9])
def test_frames_traced_together_with_blender_fields(seed: int) -> None:
    """Holdouts, ray visibility, two-sided materials, spot lights, several samples: as each frame alone."""
    from tests.random_scenes import extended_scene_document

    document = extended_scene_document(seed, width=32, height=24)
    bounded = [obj["name"] for obj in document["objects"] if obj["type"] != "plane"]
    document["vane"] = {"parts": bounded[::2], "pivot": [0.2, 0.5, 0.3], "axis": [0.1, 0.0, 1.0]}
    document["render"].update(depth=3, samples=4)
    assert_frames_together_are_frames_alone(scene_from_dict(document), random_headings(seed, 4), seed)


def test_batches_keep_their_boxes_within_what_a_light_grid_tells_apart() -> None:
    """Frames traced together hold each part once per frame: a batch is smaller where that would take the boxes
    past cull.GRID_BOXES (every shadow ray meeting any box would go to every kernel)."""
    scene = default_scene()
    assert frames_per_task(scene) == FRAMES_PER_TASK
    every = replace(scene, vane=replace(scene.vane, parts=tuple(obj.name for obj in scene.objects)))
    size = frames_per_task(every)
    assert 1 <= size < FRAMES_PER_TASK and size * len(every.objects) <= GRID_BOXES < (size + 1) * len(every.objects)


def test_ray_frames_select_each_frames_rays() -> None:
    """A query of runs (a shadow query's lights), each ordered by frame: select() gives a frame's rays of a set, as
    a mask over every ray's frame does."""
    rng = np.random.default_rng(5)
    frame_of_ray = np.concatenate([np.sort(rng.integers(0, 4, size)) for size in (37, 0, 23)])
    runs, start = [], 0
    for size in (37, 0, 23):
        runs.append(RayFrames.of(frame_of_ray[start : start + size], np.arange(5), start))
        start += size
    frames = RayFrames.joined(runs)
    assert frames.sizes.tolist() == np.bincount(frame_of_ray, minlength=4).tolist()
    subset = np.sort(rng.choice(frame_of_ray.size, 25, replace=False))
    for frame in range(4):
        assert frames.select(frame, None).tolist() == np.flatnonzero(frame_of_ray == frame).tolist()
        assert frames.select(frame, subset).tolist() == subset[frame_of_ray[subset] == frame].tolist()
