"""Rendered shading: the tracer camera made from a 3D View's matrices traces Blender's own pixels, the view's image
is the tracer's render of the scene from that view, and only a change to what the tracer renders traces again."""

from __future__ import annotations

import json
import math
import random
import time
from pathlib import Path
from types import SimpleNamespace

import bpy
import numpy as np
import pytest
from mathutils import Matrix

from addon import compat
from addon.engine import viewport
from tracer.frames.progressive import Tracing
from tracer.geometry import camera as cam
from tracer.scene import scene as sc
from tracer.scene.loader import scene_from_dict
from tracer.workers.parallel import render

VIEWS = [
    ({"lens": 35.0}, (64, 48), 0.0),
    ({"lens": 24.0, "shift_x": 0.2, "shift_y": -0.15, "clip_start": 0.5, "clip_end": 30.0}, (50, 40), 0.0),
    ({"type": "ORTHO", "ortho_scale": 5.0, "shift_y": 0.1}, (64, 48), 0.0),
    # an orthographic view whose clip range starts behind the view's centre, as the 3D View's ortho views do
    ({"type": "ORTHO", "ortho_scale": 9.0, "clip_start": 1.0, "clip_end": 12.0}, (40, 60), 3.0),
]


def difference(image: np.ndarray, other: np.ndarray) -> str:
    """Where two images (H, W, C) differ: how many pixels, the first few (row, column), the largest difference."""
    pixels = np.argwhere((image != other).any(axis=-1))  # a NaN differs from itself: counted apart below
    if not pixels.size:
        return "the same bytes"
    largest = float(np.nanmax(np.abs(image - other)))
    nans = ""
    if np.isnan(image - other).any():
        nans = f" (NaN in {np.isnan(image).sum()} and {np.isnan(other).sum()} values)"
    return f"{len(pixels)} pixels differ, first {pixels[:5].tolist()}, by up to {largest:.3g}{nans}"


def view_of(settings: dict, size: tuple[int, int], ahead: float):
    """A 3D View's (view matrix, projection) seen through the built scene's camera, changed by settings: Blender's
    own projection for that camera and size; `ahead` moves the view's centre forward that far, keeping its pixels."""
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    obj = bpy.context.scene.camera
    for name, value in settings.items():
        setattr(obj.data, name, value)
    obj.location = (1.0, -8.0, 2.0)
    obj.rotation_euler = (math.radians(85), math.radians(3), math.radians(-10))
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    window = obj.calc_matrix_camera(depsgraph, x=size[0], y=size[1])
    view = obj.matrix_world.inverted()
    return Matrix.Translation((0.0, 0.0, ahead)) @ view, window @ Matrix.Translation((0.0, 0.0, -ahead)), obj


@pytest.mark.parametrize(("settings", "size", "ahead"), VIEWS)
def test_the_views_camera_traces_blenders_pixels_between_its_clip_planes(settings, size, ahead) -> None:
    view, window, _ = view_of(settings, size, ahead)
    width, height = size
    section = viewport.view_camera(view, window, width, height)
    camera = sc.Camera(**{name: tuple(value) if isinstance(value, list) else value for name, value in section.items()})
    settings = sc.RenderSettings(width=width, height=height)
    # Blender's projection of a world point, worked in float64; the matrices themselves are float32, whose axes are
    # orthogonal to about 1e-8 radians: 2e-4 px at the far plane 1 km away
    projection = np.array(window, dtype=np.float64) @ np.array(view, dtype=np.float64)
    rng = random.Random(width)
    for _ in range(40):
        i, j = rng.randrange(width), rng.randrange(height)
        origin, direction, t_max = cam.primary_ray(camera, settings, i + 0.5, j + 0.5)
        for t, ndc_depth in ((0.0, -1.0), (t_max / 3, None), (t_max, 1.0)):
            clip = projection @ np.append(np.array(origin) + np.array(direction) * t, 1.0)
            ndc = clip[:3] / clip[3]
            # the region's pixels: x from the left, y from the bottom (an image's rows from the top)
            assert (ndc[0] + 1) / 2 * width == pytest.approx(i + 0.5, abs=1e-3)
            assert (1 - ndc[1]) / 2 * height == pytest.approx(j + 0.5, abs=1e-3)
            if ndc_depth is not None:  # on Blender's near plane, then its far plane
                assert ndc[2] == pytest.approx(ndc_depth, abs=1e-6)


class View:
    """What view_draw reads of a 3D View: its region's size and its matrices."""

    def __init__(self, view_matrix, window_matrix, width: int, height: int) -> None:
        self.region = SimpleNamespace(width=width, height=height)
        self.data = SimpleNamespace(view_matrix=view_matrix, window_matrix=window_matrix)


def test_the_views_image_is_the_tracers_render_from_that_view_and_edits_trace_again(tmp_path: Path) -> None:
    view_matrix, window_matrix, _ = view_of({"lens": 30.0}, (48, 36), 0.0)
    scene = bpy.context.scene
    scene.weathervane.workers = 1
    view = View(view_matrix, window_matrix, 48, 36)
    session = viewport.ViewportSession(workers=1)
    try:
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(view.region, view.data)
        assert session.progressive.wait(120) and session.progressive.error is None
        shown = session.progressive.latest()
        assert shown.divisor == 1 and shown.final
        # the exported scene, rendered from the camera the view's matrices describe
        assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
        document = json.loads((tmp_path / "scene.json").read_text())
        document["camera"] = viewport.view_camera(view_matrix, window_matrix, 48, 36)
        document["render"].update(width=48, height=36)
        expected = render(scene_from_dict(document), workers=1).image
        assert np.abs(shown.image - expected).max() < 1e-4  # Blender's float32 properties and back
        assert shown.image.std() > 0.05
        first = shown.generation

        # nothing the tracer renders changed (a selection, a redraw): nothing is traced again
        bpy.data.collections["Weathervane"].objects[0].select_set(True)
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(view.region, view.data)
        assert not session.progressive.busy and session.progressive.latest().generation == first

        # a material edited, a light edited, an object moved, the view orbited, the frame changed: each traces
        # again, to the full image
        for change in ("material", "light", "object", "view", "frame"):
            if change == "material":
                scene.weathervane.materials[0].color = (0.9, 0.1, 0.1)
            elif change == "light":
                scene.weathervane.lights[-1].intensity *= 0.3
            elif change == "object":
                bpy.data.objects["WV ball"].location.z += 0.5
            elif change == "view":
                view.data.view_matrix = Matrix.Rotation(0.2, 4, "Z") @ view.data.view_matrix
            else:
                scene.frame_start, scene.frame_end = 1, 40
                assert bpy.ops.weathervane.bake() == {"FINISHED"}
                scene.frame_set(30)
            session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
            session.show(view.region, view.data)
            assert session.progressive.wait(120)
            latest = session.progressive.latest()
            assert latest.generation > first and latest.divisor == 1, change
            assert np.abs(latest.image - shown.image).max() > 0.05, change
            first, shown = latest.generation, latest
    finally:
        session.close()


def test_a_scene_the_tracer_cannot_render_shows_one_line_in_the_view() -> None:
    view_matrix, window_matrix, _ = view_of({"lens": 30.0}, (48, 36), 0.0)
    session = viewport.ViewportSession(workers=1)
    try:
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.document["render"]["samples"] = 3  # not a square: the loader names the field
        session.show(SimpleNamespace(width=48, height=36), View(view_matrix, window_matrix, 48, 36).data)
        assert session.error is not None and "samples" in session.error and "\n" not in session.error
        assert session.progressive.latest() is None and not session.progressive.busy
    finally:
        session.close()


def test_the_status_line_never_shows_a_previous_scenes_figures_and_says_done_with_the_full_image() -> None:
    """After an edit the view first shows the previous image: its status says the change is being traced, not the
    previous scene's "1/1 resolution (time)"; a full image is "done" even while its ray trees are kept for edits;
    a scene traced to more than one sample says how far it is, as Cycles' "Sample 3/16"."""
    session = viewport.ViewportSession.__new__(viewport.ViewportSession)
    session.error = None

    def level(divisor: int, generation: int, seconds: float, traced: int, sample=1, samples=1, final=None):
        size = (4, 6, 3) if divisor == 1 else (1, 1, 3)
        final = divisor == 1 if final is None else final
        return SimpleNamespace(image=np.zeros(size), divisor=divisor, generation=generation, seconds=seconds,
                               traced=traced, sample=sample, samples=samples, final=final)  # fmt: skip

    full = level(1, 1, 0.5, 24)
    session.progressive = SimpleNamespace(error=None, generation=1, busy=True)  # keeping the ray trees
    assert session._status(full) == "Weathervane Tracer: done in 0.50 s"
    session.progressive.generation = 2  # an edit handed over, nothing of it traced yet
    assert session._status(full) == "Weathervane Tracer: updating"
    assert session._status(level(8, 2, 0.1, 1)) == "Weathervane Tracer: 1/8 resolution (0.10 s)"
    edited = level(1, 2, 0.05, 3)
    assert session._status(edited) == "Weathervane Tracer: edit, 3 of 24 pixels traced again in 0.05 s"
    # traced to 16 samples of some kind: one sample of everything at the coarse levels, then 4, then 16
    assert session._status(level(8, 2, 0.03, 1, 1, 16)) == "Weathervane Tracer: Sample 1/16, 1/8 resolution (0.03 s)"
    assert session._status(level(1, 2, 1.2, 24, 4, 16, False)) == "Weathervane Tracer: Sample 4/16 (1.20 s)"
    assert session._status(level(1, 2, 3.5, 24, 16, 16)) == "Weathervane Tracer: done in 3.50 s (Sample 16/16)"
    # the level after the one drawn, as its bands finish: its share (the view redraws for it every few seconds)
    session.progressive.tracing = Tracing(2, 1, 16, 16, done=3, total=8)
    assert session._status(level(1, 2, 1.2, 24, 4, 16, False)) == (
        "Weathervane Tracer: Sample 4/16 (1.20 s); next: Sample 16/16, 37%"
    )
    session.progressive.tracing = Tracing(2, 2, 1, 16, done=1, total=4)
    assert session._status(level(8, 2, 0.03, 1, 1, 16)) == (
        "Weathervane Tracer: Sample 1/16, 1/8 resolution (0.03 s); next: 1/2 resolution, 25%"
    )
    session.progressive.busy = False  # nothing traced: no share
    assert session._status(level(1, 2, 1.2, 24, 4, 16, False)) == "Weathervane Tracer: Sample 4/16 (1.20 s)"


def test_the_share_of_the_next_level_is_drawn_again_only_while_that_level_is_far_from_done() -> None:
    """A drawn level's status is drawn again for the next level's share every PROGRESS_SECONDS, but not when that
    level is estimated (its bands so far at their pace) to finish sooner: its image is drawn then anyway, and each
    draw of the window takes the trace's CPU."""
    now = time.perf_counter()
    drawn = SimpleNamespace(final=False, generation=2)
    session = viewport.ViewportSession.__new__(viewport.ViewportSession)
    session.status, session._texture_level, session._drawn_tracing = "", drawn, None
    session._status_at = now - viewport.PROGRESS_SECONDS - 0.5  # the status drawn 2.5 s ago
    session.progressive = SimpleNamespace(error=None, latest=lambda: drawn, tracing=None)
    # 1 of 8 bands in 1 s: about 7 s left
    session.progressive.tracing = Tracing(2, 1, 4, 4, done=1, total=8, started=now - 1.0)
    assert session.news()
    # 7 of 8 bands in 3 s: about 0.4 s left
    session.progressive.tracing = Tracing(2, 1, 4, 4, done=7, total=8, started=now - 3.0)
    assert not session.news()
    # no band yet: as long as anything
    session.progressive.tracing = Tracing(2, 1, 4, 4, done=0, total=8, started=now - 3.0)
    assert session.news()
    session._status_at = now - 0.5  # drawn half a second ago: not yet
    assert not session.news()


def test_the_view_traces_to_its_own_samples_from_one_sample_of_everything_and_f12_keeps_its_own(
    tmp_path: Path,
) -> None:
    """An area light and a glass sphere at F12's Shadows 16: the view's coarse levels are one sample of everything,
    its full image the scene at the Viewport's samples (4 shadow samples, each kind at most F12's), "Sample 4/4"; a
    playing animation's frame is one sample of everything; F12's export keeps Shadows 16 and knows nothing of the
    Viewport settings."""
    view_matrix, window_matrix, _ = view_of({"lens": 30.0}, (48, 36), 0.0)
    scene = bpy.context.scene
    settings = scene.weathervane
    settings.workers, settings.shadow_samples, settings.other_lights = 1, "16", True
    light = bpy.data.lights.new("Area", "AREA")
    light.energy, light.size = 300.0, 1.5
    area = bpy.data.objects.new("Area", light)
    area.location = (1.0, -3.0, 4.0)
    scene.collection.objects.link(area)
    mesh = bpy.data.meshes.new("Glass ball")
    import bmesh

    shape = bmesh.new()
    bmesh.ops.create_uvsphere(shape, u_segments=16, v_segments=8, radius=0.8)
    shape.to_mesh(mesh)
    shape.free()
    glass = bpy.data.materials.new("Glass")
    compat.enable_nodes(glass)
    nodes = glass.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfGlass")
    glass.node_tree.links.new(bsdf.outputs[0], nodes["Material Output"].inputs[0])
    mesh.materials.append(glass)
    ball = bpy.data.objects.new("Glass ball", mesh)
    ball.location = (0.5, -3.5, 1.0)
    scene.collection.objects.link(ball)
    view = View(view_matrix, window_matrix, 48, 36)
    session = viewport.ViewportSession(workers=1)
    levels: list = []
    session.progressive._on_level = levels.append
    try:
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert session.document["render"]["shadow_samples"] == 16  # F12's document, untouched
        session.show(view.region, view.data)
        assert session.progressive.wait(120) and session.progressive.error is None
        assert [(lv.divisor, lv.sample, lv.samples, lv.final) for lv in levels] == [
            (8, 1, 4, False), (4, 1, 4, False), (2, 1, 4, False), (1, 4, 4, True)]  # fmt: skip
        assert session._status(levels[-1]).endswith("(Sample 4/4)")
        document = {**session.document, "camera": viewport.view_camera(view_matrix, window_matrix, 48, 36)}
        document["render"] = {**document["render"], "width": 48, "height": 36, "pixel_aspect": [1.0, 1.0]}
        at = {}  # the view's image at 1, 4 and 16 shadow samples, by the tracer
        for samples in (1, 4, 16):
            settings_at = {**document["render"], "shadow_samples": samples}
            at[samples] = render(scene_from_dict({**document, "render": settings_at}), workers=1).image
        if not np.array_equal(levels[-1].image, at[4]):  # where, and whether a fresh render repeats itself
            settings_at = {**document["render"], "shadow_samples": 4}
            again = render(scene_from_dict({**document, "render": settings_at}), workers=1).image
            shown = levels[-1].image
            pytest.fail(
                f"the view's finished image is not the render at 4 shadow samples: {difference(shown, at[4])}; "
                f"that render again: {difference(again, at[4])} from it, {difference(again, shown)} from the view's"
            )
        assert not np.array_equal(at[4], at[16])
        coarse = scene_from_dict({**document, "render": {**document["render"], "width": 6, "height": 4,
                                                           "shadow_samples": 1}})  # fmt: skip
        assert np.array_equal(levels[0].image, render(coarse, workers=1).image)
        # the Viewport's Shadows at 16: passes of 4, then 16 (F12's), the status counting them
        levels.clear()
        settings.viewport_shadow_samples = "16"
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(view.region, view.data)
        assert session.progressive.wait(120)
        assert [(lv.divisor, lv.sample, lv.samples) for lv in levels] == [(8, 1, 16), (4, 1, 16), (2, 1, 16),
                                                                           (1, 4, 16), (1, 16, 16)]  # fmt: skip
        assert np.array_equal(levels[-1].image, at[16])
        # playing: each frame at 1/4, one sample of everything
        levels.clear()
        session.show(view.region, view.data, playing=True)
        assert session.progressive.wait(120)
        assert [(lv.divisor, lv.sample, lv.final) for lv in levels] == [(4, 1, False)]
        # F12 exports its own Shadows whatever the Viewport's
        assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
        assert json.loads((tmp_path / "scene.json").read_text())["render"]["shadow_samples"] == 16
    finally:
        session.close()
        settings.shadow_samples, settings.viewport_shadow_samples, settings.other_lights = "1", "4", False


def test_selecting_hovering_or_redrawing_starts_no_trace_and_leaves_the_image_and_status() -> None:
    """What Blender calls on a selection (a depsgraph update: view_update exports and hands over the view) and on a
    redraw (hovering, a panel opened: view_draw) leaves the tracer idle, the drawn level and the status as they were;
    a playing animation traces each frame at 1/4 of the view alone."""
    view_matrix, window_matrix, _ = view_of({"lens": 30.0}, (48, 36), 0.0)
    bpy.context.scene.weathervane.workers = 1
    view = View(view_matrix, window_matrix, 48, 36)
    session = viewport.ViewportSession(workers=1)
    try:
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(view.region, view.data)
        assert session.progressive.wait(120) and session.progressive.error is None
        shown, generation = session.progressive.latest(), session.progressive.generation
        session._texture_level, session.status = shown, session._status(shown)  # as a draw leaves them
        status = session.status
        ball = bpy.data.objects["WV ball"]
        for change in ("select", "activate", "deselect", "redraw"):
            if change == "select":
                ball.select_set(True)
            elif change == "activate":
                bpy.context.view_layer.objects.active = ball
            elif change == "deselect":
                ball.select_set(False)
                bpy.context.view_layer.objects.active = None
            bpy.context.view_layer.update()
            session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())  # view_update
            session.show(view.region, view.data)
            session.draw_soon()  # view_draw, returning at once
            assert session.progressive.generation == generation and not session.progressive.busy, change
            assert session.progressive.latest() is shown and not session.news(), change
            assert session._status(session.progressive.latest()) == status, change

        # an animation playing: a frame (here a change over most pixels, as a turning vane's frame is not a small
        # edit) is traced at 1/4 of the view's size only; stopped, the full levels follow
        materials = {entry.name: entry for entry in bpy.context.scene.weathervane.materials}
        materials["tiles"].color = (0.1, 0.7, 0.2)
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(view.region, view.data, playing=True)
        assert session.progressive.wait(120)
        assert session.progressive.latest().image.shape[:2] == (9, 12)
        session.show(view.region, view.data)
        assert session.progressive.wait(120) and session.progressive.latest().divisor == 1
    finally:
        session.close()


def test_a_views_gpu_texture_is_freed_on_the_main_thread_only_wherever_its_session_goes() -> None:
    """A session closed, or dropped, on another thread (its engine collected there by Python's cycle collector) lets
    go of its texture only when the main thread next looks; closed on the main thread, at once."""
    import gc
    import threading

    freed_on: list[str] = []

    class Texture:  # stands for a gpu.types.GPUTexture: records the thread that frees it
        def __del__(self) -> None:
            freed_on.append(threading.current_thread().name)

    for ending in ("closed elsewhere", "dropped elsewhere", "closed here"):
        session = viewport.ViewportSession(workers=1)
        progressive = session.progressive
        viewport._textures[id(session)] = Texture()
        if ending == "closed here":
            session.close()
        else:
            holder = [session]
            del session

            def end(holder: list = holder, ending: str = ending) -> None:
                if ending == "closed elsewhere":
                    holder[0].close()
                holder.clear()  # the last reference goes on this thread
                gc.collect()

            other = threading.Thread(target=end, name="tracing")
            other.start()
            other.join()
            assert freed_on == [], ending  # not on the other thread
            viewport._free_textures()  # the main thread's next draw or timer
            assert progressive.closed, ending  # a session dropped without close() ends its thread all the same
        assert freed_on == ["MainThread"], ending
        freed_on.clear()
    assert not viewport._textures


def test_the_views_scene_key_tells_arrays_apart_by_their_bits() -> None:
    """The view's document carries NumPy arrays (a texture's pixels, a mesh's vertices, a World's picture); its key
    names each by dtype, shape and a digest of its bits, so that equal arrays give the same key (no new trace) and
    any changed bit another; a read-only array's digest is kept, a writeable one's (or a view of one) made again."""
    key = lambda document: json.dumps(document, sort_keys=True, default=viewport._array_key)  # noqa: E731
    pixels = np.linspace(0.0, 1.0, 48, dtype=np.float32).reshape(4, 4, 3).copy()
    same = pixels.copy()
    assert key({"pixels": pixels}) == key({"pixels": same})
    assert key({"pixels": pixels}) != key({"pixels": pixels.astype(np.float64)})
    assert key({"pixels": pixels}) != key({"pixels": pixels.reshape(16, 3)})
    signed = pixels.copy()
    signed[0, 0, 0] = -0.0  # 0.0 there before: equal as numbers, another bit
    assert key({"pixels": signed}) != key({"pixels": pixels})
    before = key({"pixels": same})
    same[1, 1, 1] += 0.5  # writeable: changed in place, its key follows
    assert key({"pixels": same}) != before and id(same) not in viewport._digests
    view = same[:2]
    view.flags.writeable = False  # its memory is still same's, which can change: not kept
    key({"pixels": view})
    assert id(view) not in viewport._digests
    pixels.flags.writeable = False
    key({"pixels": pixels})
    assert id(pixels) not in viewport._digests  # small: digested each time
    picture = np.linspace(0.0, 1.0, 3 << 18, dtype=np.float32).reshape(512, 512, 3)  # a World's picture: 3 MB
    picture.flags.writeable = False  # a view of linspace's array: read-only, but its base is writeable
    key({"pixels": picture})
    assert id(picture) not in viewport._digests
    picture = picture.copy()
    picture.flags.writeable = False
    picture_key = key({"pixels": picture})
    assert viewport._digests[id(picture)][0] is picture and key({"pixels": picture}) == picture_key
    assert key({"n": np.float32(0.5), "k": np.int64(3)}) == key({"n": 0.5, "k": 3})
