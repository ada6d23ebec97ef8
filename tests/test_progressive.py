"""The coarse-to-fine render behind Blender's Rendered shading: each level is the plain render of the scene at that
size, a newer scene supersedes an older one, failures come back as one line, and close() ends the thread."""

from __future__ import annotations

import multiprocessing
import threading

import numpy as np
import pytest

from tracer import resources
from tracer.loader import default_scene
from tracer.parallel import render
from tracer.progressive import LEVELS, Level, ProgressiveRender, level_scene


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
    assert not any(thread.name == "weathervane-progressive" for thread in threading.enumerate())
