"""The coarse-to-fine render behind Blender's Rendered shading: each level is the plain render of the scene at that
size, a newer scene supersedes an older one, failures come back as one line, and close() ends the thread."""

from __future__ import annotations

import itertools
import multiprocessing
import threading
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest

from tracer.frames import progressive as progressive_module
from tracer.frames.edits import edits_between
from tracer.frames.progressive import EDIT_SHARE, LEVELS, Level, ProgressiveRender, level_scene
from tracer.scene import scene as sc
from tracer.scene.loader import default_scene
from tracer.workers import resources
from tracer.workers.parallel import render


def small_scene(heading: float = 0.0, width: int = 96, height: int = 64):
    return default_scene().with_render(width=width, height=height, samples=4).with_heading(heading)


@pytest.mark.parametrize("workers", [1, 2])
def test_every_level_is_the_plain_render_of_the_scene_at_that_size(workers: int) -> None:
    levels: list[Level] = []
    progressive = ProgressiveRender(workers, on_level=levels.append)
    try:
        scene = small_scene()
        generation = progressive.show(scene)
        assert progressive.wait(120)
        assert [level.divisor for level in levels] == list(LEVELS)
        assert {level.generation for level in levels} == {generation}
        for level in levels:
            expected = render(level_scene(scene, level.divisor), workers=1).image
            assert level.image.shape == (round(64 / level.divisor), round(96 / level.divisor), 3)
            assert np.array_equal(level.image, expected)
        # the full level is the scene itself, with its samples
        assert np.array_equal(progressive.latest().image, render(scene, workers=1).image)
        assert progressive.latest().seconds >= levels[0].seconds
        assert progressive.error is None and not progressive.busy
    finally:
        progressive.close()


def test_the_level_being_traced_reports_its_bands_as_they_finish(monkeypatch) -> None:
    """ProgressiveRender.tracing: while a level is traced, its divisor and samples and how many of its bands are
    done (what the view's status shows of the level after the one drawn), set at its start and as each band ends.
    Every report the thread makes is recorded (no polling: a busy machine would miss some)."""
    reports: list = []

    def recorded(*args, **kwargs):
        report = progressive_module.Tracing.__wrapped__(*args, **kwargs)
        reports.append(report)
        return report

    recorded.__wrapped__ = progressive_module.Tracing
    monkeypatch.setattr(progressive_module, "Tracing", recorded)
    progressive = ProgressiveRender(2)
    try:
        generation = progressive.show(small_scene(0.0, 320, 240))
        assert progressive.wait(120)
    finally:
        progressive.close()
    assert reports and {report.generation for report in reports} == {generation}
    assert progressive.tracing is reports[-1]
    full = [report for report in reports if report.divisor == 1]
    assert full[-1].done == full[-1].total > 1 and full[-1].sample == full[-1].samples == 4
    assert any(0 < report.done < report.total for report in full)  # a share part of the way
    pairs = itertools.pairwise(full)
    assert all(a.done <= b.done for a, b in pairs if (a.divisor, a.sample) == (b.divisor, b.sample))
    # each level's reports carry its start, one time a level, later level by level
    starts = {(report.divisor, report.sample): report.started for report in reports}
    assert len(starts) == len({(report.divisor, report.sample, report.started) for report in reports})
    assert list(starts.values()) == sorted(starts.values()) and min(starts.values()) > 0


def test_a_newer_scene_supersedes_the_one_being_traced() -> None:
    levels: list[Level] = []
    progressive = ProgressiveRender(1, on_level=levels.append)
    try:
        progressive.show(small_scene(0.0, 320, 240))
        newest = progressive.show(small_scene(120.0))
        assert progressive.wait(120)
        # no level of the older scene is delivered after one of the newer, and the newest ends at full size
        generations = [level.generation for level in levels]
        assert generations == sorted(generations) and generations[-1] == newest
        assert [level.divisor for level in levels if level.generation == newest] == list(LEVELS)
        assert np.array_equal(progressive.latest().image, render(small_scene(120.0), workers=1).image)
    finally:
        progressive.close()


def test_a_scene_that_cannot_be_traced_leaves_one_line_and_the_next_scene_renders(monkeypatch) -> None:
    progressive = ProgressiveRender(1)
    try:
        monkeypatch.setattr(resources, "available_memory", lambda: 10**6)
        progressive.show(small_scene())
        assert progressive.wait(60)
        assert progressive.error is not None and "needs about" in progressive.error and "\n" not in progressive.error
        assert progressive.latest() is None
        monkeypatch.undo()
        progressive.show(small_scene())
        assert progressive.wait(120)
        assert progressive.error is None and progressive.latest().divisor == 1
    finally:
        progressive.close()


def test_close_ends_the_thread_and_its_workers() -> None:
    progressive = ProgressiveRender(2)
    progressive.show(small_scene(0.0, 320, 240))
    progressive.close()
    progressive._thread.join(30)
    assert not progressive._thread.is_alive()
    assert multiprocessing.active_children() == []
    # an earlier test's closed session may still be finishing its current piece on a loaded machine: it too ends
    for thread in threading.enumerate():
        if thread.name == "weathervane-progressive":
            thread.join(30)
    assert not any(thread.name == "weathervane-progressive" for thread in threading.enumerate())


def edits():
    """(change, scene -> the scene edited, whether the edit is small): a material of a few pixels (the tail fin's)
    and of most (the ground's), a light's intensity (it reaches most pixels), an object moved (the plinth)."""

    def material(name: str):
        return lambda scene: replace(
            scene, materials={**scene.materials, name: replace(scene.materials[name], color=(0.9, 0.1, 0.1))}
        )

    def dimmer(scene):
        lights = [replace(light, intensity=light.intensity * 0.3) if isinstance(light, sc.PointLight) else light
                  for light in scene.lights]  # fmt: skip
        return replace(scene, lights=tuple(lights))

    def moved(scene):
        objects = [replace(obj, location=(obj.location[0] + 0.1, *obj.location[1:])) if obj.name == "plinth" else obj
                   for obj in scene.objects]  # fmt: skip
        return replace(scene, objects=tuple(objects))

    return [("tail fin material", material("verdigris"), True), ("ground material", material("tiles"), False),
            ("point light", dimmer, False), ("plinth moved", moved, True)]  # fmt: skip


@contextmanager
def shown(scene):
    """A one-worker ProgressiveRender that has shown scene to the end (its ray trees kept), and the levels it
    delivers from then on; closed after."""
    levels: list[Level] = []
    progressive = ProgressiveRender(1, on_level=levels.append)
    try:
        progressive.show(scene)
        assert progressive.wait(120)
        levels.clear()
        yield progressive, levels
    finally:
        progressive.close()


def test_small_edits_after_the_full_level_trace_only_what_they_change_at_full_size() -> None:
    scene = small_scene()
    with shown(scene) as (progressive, levels):
        for change, edit, small in edits():
            edited = edit(scene)
            levels.clear()
            generation = progressive.show(edited)
            assert progressive.wait(120) and progressive.error is None
            if small:  # one level at full size, a few pixels traced (an object moved: the pool's 1/8 level first)
                first = [(8, generation)] if "moved" in change else []
                assert [(level.divisor, level.generation) for level in levels] == [*first, (1, generation)], change
                assert 0 < levels[-1].traced < EDIT_SHARE * 96 * 64, change
            else:  # the pool's coarse levels first, as for any other change
                assert [level.divisor for level in levels] == list(LEVELS), change
            # the same bytes as a whole render of the edited scene
            assert np.array_equal(levels[-1].image, render(edited, workers=1).image), change
            scene = edited
        # the vane turned (a frame changed) is not an edit: coarse to fine again
        levels.clear()
        progressive.show(scene.with_heading(150.0))
        assert progressive.wait(120)
        assert [level.divisor for level in levels] == list(LEVELS)
        assert np.array_equal(levels[-1].image, render(scene.with_heading(150.0), workers=1).image)


def test_scenes_over_the_kept_size_go_coarse_to_fine_after_an_edit(monkeypatch) -> None:
    monkeypatch.setattr(progressive_module, "EDITABLE_SAMPLES", 96 * 64 * 4 - 1)
    scene = small_scene()
    with shown(scene) as (progressive, levels):
        edited = edits()[0][1](scene)
        progressive.show(edited)
        assert progressive.wait(120)
        assert [level.divisor for level in levels] == list(LEVELS)
        assert np.array_equal(levels[-1].image, render(edited, workers=1).image)


def test_the_edits_between_two_scenes_are_found_or_refused() -> None:
    scene = small_scene()
    for change, edit, _ in edits():
        found = edits_between(scene, edit(scene))
        assert found is not None and len(found) == 1, change
    assert edits_between(scene, scene) == []
    # anything else is not an edit: the vane turned, the camera moved, a sphere grew, the render settings
    assert edits_between(scene, scene.with_heading(10.0)) is None
    assert edits_between(scene, replace(scene, camera=replace(scene.camera, lens=20.0))) is None
    assert edits_between(scene, scene.with_render(samples=9)) is None
    sphere = next(obj for obj in scene.objects if isinstance(obj, sc.Sphere))
    grown = tuple(replace(obj, radius=obj.radius * 2) if obj is sphere else obj for obj in scene.objects)
    assert edits_between(scene, replace(scene, objects=grown)) is None


def test_done_once_the_full_image_is_the_latest_even_while_its_ray_trees_are_kept() -> None:
    seen: list = []
    progressive = ProgressiveRender(1)
    progressive._on_level = lambda level: seen.append((level.divisor, progressive.done, progressive.busy))
    try:
        assert not progressive.done and progressive.generation == 0
        scene = small_scene()
        generation = progressive.show(scene)
        assert progressive.generation == generation
        assert progressive.wait(120)
        # coarse levels are not done; the full one is, while the thread goes on to keep its ray trees (busy)
        assert seen == [(8, False, True), (4, False, True), (2, False, True), (1, True, True)]
        assert progressive.done and not progressive.busy
        # a newer scene: the shown image is the previous scene's until the new one's first level
        progressive.show(scene.with_heading(40.0))
        assert not progressive.done or progressive.latest().generation == progressive.generation
        assert progressive.wait(120) and progressive.done
    finally:
        progressive.close()


def test_no_ray_trees_are_kept_for_a_scene_whose_full_level_took_long(monkeypatch) -> None:
    monkeypatch.setattr(progressive_module, "EDITABLE_SECONDS", 0.0)
    scene = small_scene()
    with shown(scene) as (progressive, levels):
        progressive.show(edits()[0][1](scene))  # a small edit, but nothing kept to apply it to
        assert progressive.wait(120)
        assert [level.divisor for level in levels] == list(LEVELS)


def test_passes_go_up_by_four_to_the_target_and_samples_count_only_what_the_scene_has() -> None:
    from tracer.frames.progressive import ONE, Samples, passes, scene_samples, used_samples, with_samples

    assert passes(ONE) == (ONE,)
    assert passes(Samples(1, 4, 4, 4)) == (Samples(1, 4, 4, 4),)
    assert passes(Samples(1, 16, 4, 16)) == (Samples(1, 4, 4, 4), Samples(1, 16, 4, 16))
    assert passes(Samples(9, 64, 1, 64)) == (Samples(4, 4, 1, 4), Samples(9, 16, 1, 16), Samples(9, 64, 1, 64))
    scene = small_scene()  # the default vane: point and directional lights, no glossy lobe, no world light
    assert scene_samples(scene) == Samples(4, 1, 16, 1)
    assert used_samples(scene, Samples(4, 16, 16, 16)) == Samples(4, 1, 1, 1)
    assert with_samples(scene, scene_samples(scene)) is scene
    soft = replace(scene, lights=(*scene.lights, sc.AreaLight(location=(0.0, -2.0, 4.0), direction=(0.0, 0.0, -1.0))))
    assert used_samples(soft, Samples(4, 16, 16, 16)) == Samples(4, 16, 1, 1)


def test_a_target_traces_one_sample_of_everything_first_then_passes_each_at_most_the_scenes() -> None:
    """An area light at 16 shadow samples, traced to 4: the coarse levels at one sample of everything, the full image
    at 4 (the scene's 16 never asked); a target above the scene's is the scene's."""
    from tracer.frames.progressive import Samples

    scene = small_scene().with_render(samples=1, shadow_samples=16)
    area = sc.AreaLight(location=(1.0, -3.0, 5.0), direction=(0.0, 0.0, -1.0), size=(2.0, 2.0), intensity=30.0)
    scene = replace(scene, lights=(*scene.lights, area))
    levels: list[Level] = []
    progressive = ProgressiveRender(1, on_level=levels.append)
    try:
        progressive.show(scene, target=Samples(1, 4, 4, 4))
        assert progressive.wait(120) and progressive.error is None
        assert [(lv.divisor, lv.sample, lv.samples, lv.final) for lv in levels] == [
            (8, 1, 4, False), (4, 1, 4, False), (2, 1, 4, False), (1, 4, 4, True)]  # fmt: skip
        assert np.array_equal(levels[0].image, render(level_scene(scene, 8), workers=1).image)
        assert np.array_equal(levels[0].image, render(level_scene(scene.with_render(shadow_samples=1), 8)).image)
        assert np.array_equal(levels[-1].image, render(scene.with_render(shadow_samples=4), workers=1).image)
        levels.clear()
        progressive.show(scene, target=Samples(64, 64, 64, 64))
        assert progressive.wait(120)
        assert [(lv.divisor, lv.sample, lv.samples) for lv in levels][3:] == [(1, 4, 16), (1, 16, 16)]
        assert np.array_equal(levels[-1].image, render(scene, workers=1).image)
    finally:
        progressive.close()


def test_an_edit_estimated_slow_shows_the_pools_first_level_then_its_pixels_from_the_kept_trees(monkeypatch) -> None:
    monkeypatch.setattr(progressive_module, "QUICK_EDIT_SECONDS", 0.0)  # every edit estimated slow
    scene = small_scene()
    with shown(scene) as (progressive, levels):
        edited = edits()[0][1](scene)  # the tail fin's material: a small edit
        generation = progressive.show(edited)
        assert progressive.wait(120) and progressive.error is None
        assert [(level.divisor, level.generation) for level in levels] == [(8, generation), (1, generation)]
        assert 0 < levels[-1].traced < EDIT_SHARE * 96 * 64 and levels[-1].final and not levels[0].final
        assert np.array_equal(levels[0].image, render(level_scene(edited, 8), workers=1).image)
        assert np.array_equal(levels[-1].image, render(edited, workers=1).image)
