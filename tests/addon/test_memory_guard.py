"""A scene too large for the memory free now is refused before the engine reads it (one line naming the figures
and the largest objects), and Esc while a large scene is being prepared stops the render at once. The truth: the
memory Blender's process really grows by (its peak, VmHWM), and the bands written into Blender's result."""

from __future__ import annotations

import time
from pathlib import Path

import bpy
import pytest

from addon import tracer_api
from addon.convert import mesh_export
from addon.engine import engine, messages
from tracer.workers import resources


def subdivided_cube(levels: int) -> int:
    """The factory scene's cube with a Subdivision Surface modifier at levels for render; its triangle count."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.weathervane.workers = 2
    modifier = bpy.data.objects["Cube"].modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = 1
    modifier.render_levels = levels
    return 6 * 4**levels * 2


def peak_rss_reset() -> None:
    Path("/proc/self/clear_refs").write_text("5")  # VmHWM starts again from the current size


def peak_rss() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM")


def test_a_scene_larger_than_the_free_memory_is_refused_before_it_is_read(monkeypatch: pytest.MonkeyPatch) -> None:
    triangles = subdivided_cube(7)  # 196,608 triangles: about 400 MB to prepare and trace
    monkeypatch.setattr(tracer_api, "available_memory", lambda: 250_000_000)  # a machine with 250 MB free
    reads = []
    monkeypatch.setattr(mesh_export.CACHE, "arrays", lambda *args: reads.append(args))
    peak_rss_reset()
    before = peak_rss()
    started = time.perf_counter()
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.render.render()
    seconds = time.perf_counter() - started
    grown = peak_rss() - before
    message = str(raised.value)
    print(f"refused in {seconds:.2f} s, Blender's peak grew by {grown / 1e6:.0f} MB: {message}")
    assert reads == []  # nothing of the scene was read: the count came from Blender's own mesh sizes
    assert len(message.strip().splitlines()) == 1, message
    assert "Weathervane Tracer: not started: a 64x48 float64 render with 2 workers" in message
    assert f"of {triangles:,} triangles needs about" in message
    assert "250.0 MB is available; the largest: Cube (196,608 triangles); try fewer triangles" in message
    assert "Precision 32-bit" in message and "Traceback" not in message
    # the render window's text over its empty image is the whole line (engine/messages.py draws it in a window)
    assert messages.render_window_text() == message.strip().removeprefix("Error: ")
    assert grown < 200_000_000  # Blender's own evaluation of the modifier only
    image = bpy.data.images.get("Render Result")
    assert image is None or not image.has_data or max(image.pixels[:]) == 0.0  # nothing was written


def test_the_estimate_lets_a_scene_that_fits_render(monkeypatch: pytest.MonkeyPatch) -> None:
    """The same scene with 2 GB free renders; its real growth stays below the estimate (which errs large)."""
    triangles = subdivided_cube(7)
    monkeypatch.setattr(tracer_api, "available_memory", lambda: 2_000_000_000)
    settings = resources.sc.RenderSettings(width=64, height=48)
    estimate = resources.memory_needed(settings, 2) + resources.scene_bytes(triangles, 1)
    engine.close_renderers()  # workers started afresh, as in a new Blender
    engine._closing[0] = False
    peak_rss_reset()
    before = peak_rss()
    bpy.ops.render.render()
    grown = peak_rss() - before
    print(f"estimated {estimate / 1e6:.0f} MB; Blender's process grew by {grown / 1e6:.0f} MB (workers not counted)")
    assert grown < estimate


def test_esc_while_the_workers_prepare_a_large_scene_stops_the_render_before_any_band(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    subdivided_cube(8)  # 786,432 triangles: seconds of preparation in each worker before their first band
    asked: list[float] = []
    written: list[int] = []
    write = engine._write

    def counted_write(*args) -> None:
        written.append(1)
        write(*args)

    def esc_after_the_export(_engine) -> bool:
        """The first look is the export's, before it reads the cube; the next ones come while the workers prepare
        the scene: the user presses Esc half a second into that."""
        asked.append(time.perf_counter())
        return len(asked) > 1 and asked[-1] >= asked[1] + 0.5

    monkeypatch.setattr(engine, "_write", counted_write)
    monkeypatch.setattr(engine, "cancelled", esc_after_the_export)
    bpy.ops.render.render()
    returned = time.perf_counter()
    pressed = asked[1] + 0.5
    print(f"Esc to the render's return: {returned - pressed:.3f} s; {len(asked)} looks at Esc")
    assert written == []  # stopped during the preparation: no band was traced
    assert len(asked) >= 3  # asked while waiting (every 0.1 s), not only when a band finished


def test_the_rendered_views_check_counts_the_views_size_and_its_kept_ray_trees(monkeypatch: pytest.MonkeyPatch) -> None:
    """Once a view was shown, the check is made for its size, with the ray trees it keeps (2^21 samples at most,
    about 0.5 GB at full HD): the factory cube alone is refused in a 1920x1005 view with 400 MB free, its line naming
    the view's size, and traced with 2 GB."""
    from addon.engine import viewport
    from tracer.frames.progressive import EDITABLE_SAMPLES, KEPT_BYTES_PER_SAMPLE

    bpy.ops.wm.read_factory_settings(use_empty=False)
    bpy.context.scene.render.engine = "WEATHERVANE_TRACER"
    bpy.context.scene.weathervane.workers = 1
    session = viewport.ViewportSession(workers=1)
    try:
        session._view_size = (1920, 1005)  # as show() leaves it for a full-HD window's view
        kept = EDITABLE_SAMPLES * KEPT_BYTES_PER_SAMPLE
        monkeypatch.setattr(tracer_api, "available_memory", lambda: 400_000_000)
        assert kept > 400_000_000 / resources.HEADROOM  # the trees alone would not fit
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert session.document is None
        assert session.error.startswith("Weathervane Tracer: not started: a 1920x1005 float64 render with 1 workers")
        monkeypatch.setattr(tracer_api, "available_memory", lambda: 2_000_000_000)
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert session.error is None and session.document is not None
    finally:
        session.close()


def test_the_budgets_bound_refuses_exactly_where_the_check_itself_refuses(monkeypatch: pytest.MonkeyPatch) -> None:
    """MemoryBudget asks check_resources only near its precomputed room (the export counts every geometry): around
    the bound, in steps of one triangle, it refuses exactly the counts the check itself refuses."""
    from addon.convert.export import MemoryBudget

    subdivided_cube(1)
    available = 300_000_000
    monkeypatch.setattr(tracer_api, "available_memory", lambda: available)
    budget = MemoryBudget(bpy.context.scene)
    settings, workers = budget.settings, budget.workers
    limit = int(resources.scene_room(settings, workers, available) / resources.BYTES_PER_TRIANGLE)
    outcomes = set()
    for triangles in range(limit - 3, limit + 4):
        budget.triangles, budget.instances = triangles, 1
        try:
            resources.check_resources(settings, workers, triangles=triangles, instances=1, available=available)
            refused = False
        except resources.ResourceError:
            refused = True
        outcomes.add(refused)
        if refused:
            with pytest.raises(resources.ResourceError):
                budget.check()
        else:
            budget.check()
    assert outcomes == {True, False}
