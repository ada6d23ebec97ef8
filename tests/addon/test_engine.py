"""The documented tracer as a Blender render engine: what Blender's render result holds is the tracer's image."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from tracer.scene.loader import default_scene
from tracer.workers.parallel import render


def engine_scene(workers: int | None = None):
    """The built vane, rendered by the tracer engine at 64x48 into 32-bit EXR files."""
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    if workers is not None:
        scene.weathervane.workers = workers
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    return scene


def read_exr(path: Path) -> np.ndarray:
    """A 64x48 image file Blender wrote -> (48, 64, 3) float32, rows from the top."""
    image = bpy.data.images.load(str(path))
    pixels = np.empty(64 * 48 * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return np.flipud(pixels.reshape(48, 64, 4))[..., :3]


def test_render_result_is_the_tracers_image(tmp_path: Path) -> None:
    scene = engine_scene()
    scene.render.filepath = str(tmp_path / "engine.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    rendered = read_exr(tmp_path / "engine.exr")
    expected = render(default_scene().with_render(width=64, height=48), workers=1).image
    # the scene went through Blender's float32 properties and back: rounding only
    assert np.abs(rendered - expected).max() < 1e-4
    assert rendered.std() > 0.05  # a real picture, not a flat fill


def test_engine_follows_the_baked_motion(tmp_path: Path) -> None:
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 40
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 36, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    images = []
    for frame in (1, 30):
        scene.frame_set(frame)
        scene.render.filepath = str(tmp_path / f"frame{frame}.exr")
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        image = bpy.data.images.load(str(tmp_path / f"frame{frame}.exr"))
        pixels = np.empty(48 * 36 * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        images.append(pixels)
    assert np.abs(images[0] - images[1]).max() > 0.1  # the vane turned between the frames


def test_a_render_too_large_for_memory_is_reported_in_one_line_not_raised(tmp_path: Path, monkeypatch) -> None:
    from addon import tracer_api

    monkeypatch.setattr(tracer_api, "available_memory", lambda: 10**6)  # 1 MB free, as the add-on reads it
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.filepath = str(tmp_path / "engine.png")
    with pytest.raises(RuntimeError, match=r"needs about .* of memory and 1\.0 MB is available; try"):
        bpy.ops.render.render(write_still=True)  # Blender turns the engine's ERROR report into the operator's
    assert not (tmp_path / "engine.png").exists()
    monkeypatch.undo()
    scene.render.filepath = str(tmp_path / "after.png")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}  # the engine still renders
    assert (tmp_path / "after.png").exists()


def test_engine_renders_blenders_orthographic_shifted_clipped_camera(
    tmp_path: Path, capfd: pytest.CaptureFixture
) -> None:
    import json
    from dataclasses import replace

    from tracer.scene.loader import scene_from_dict

    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    camera = scene.camera.data
    camera.type, camera.ortho_scale, camera.shift_x = "ORTHO", 7.0, 0.1
    camera.clip_start, camera.clip_end = 2.0, 9.0  # the far end of the ground is clipped away
    camera.dof.use_dof, camera.dof.aperture_blades = True, 5  # a thin lens, round where Blender's has 5 blades
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 48, 32, 100
    scene.render.pixel_aspect_x = 2.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(tmp_path / "engine.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    lines = [line for line in capfd.readouterr().out.splitlines() if "does not render" in line]
    assert len(lines) == 1 and "5 blades" in lines[0]
    image = bpy.data.images.load(str(tmp_path / "engine.exr"))
    pixels = np.empty(48 * 32 * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    rendered = np.flipud(pixels.reshape(32, 48, 4))[..., :3]
    assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
    exported = scene_from_dict(json.loads((tmp_path / "scene.json").read_text()))
    assert (exported.camera.type, exported.render.pixel_aspect) == ("ORTHO", (2.0, 1.0))
    expected = render(exported, workers=1).image
    assert np.abs(rendered - expected).max() < 1e-4
    # the clip planes and the orthographic view both changed the picture
    unclipped = replace(exported, camera=replace(exported.camera, clip_start=0.0, clip_end=None))
    assert (np.abs(render(unclipped, workers=1).image - expected).max(axis=2) > 0.05).mean() > 0.05
    perspective = render(default_scene().with_render(width=48, height=32), workers=1).image
    assert not np.allclose(rendered, perspective, atol=1e-3)


def test_f12_png_equals_the_tracers_srgb_png_and_the_properties_show_the_engine(tmp_path: Path) -> None:
    import json

    from tracer.scene.loader import scene_from_dict
    from tracer.tracing.images import to_8bit

    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    assert scene.view_settings.view_transform == "Standard"  # Build set it, and said so
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "8"
    scene.render.filepath = str(tmp_path / "f12.png")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    image = bpy.data.images.load(str(tmp_path / "f12.png"))
    pixels = np.empty(64 * 48 * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    f12 = np.round(np.flipud(pixels.reshape(48, 64, image.channels))[..., :3] * 255).astype(int)
    assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
    exported = scene_from_dict(json.loads((tmp_path / "scene.json").read_text()))
    tracer_png = to_8bit(render(exported, workers=1).image, srgb=True).astype(int)
    assert np.abs(f12 - tracer_png).max() <= 1
    # Render and World Properties show the engine's own panels; the stock Output and colour panels include it
    from addon.engine import render_panels

    for panel in render_panels.CLASSES:
        assert panel.poll(bpy.context)
    added = list(render_panels._added)
    names = {cls.__name__ for cls in added}
    assert {"RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output", "RENDER_PT_color_management"} <= names
    assert {"DATA_PT_lens", "DATA_PT_camera"} <= names and not any("_dof" in name for name in names)
    assert all("WEATHERVANE_TRACER" in cls.COMPAT_ENGINES for cls in added)
    # unregistering takes the engine out of exactly those panels, and leaves the others' engines alone
    import addon

    addon.unregister()
    try:
        assert not any("WEATHERVANE_TRACER" in cls.COMPAT_ENGINES for cls in added)
        assert all("CYCLES" in cls.COMPAT_ENGINES for cls in added if cls.__name__ == "RENDER_PT_format")
    finally:
        addon.register()


def test_numerics_and_precision_set_in_render_properties_reach_the_tracer(tmp_path: Path) -> None:
    import json

    from tracer.scene.loader import scene_from_dict

    assert bpy.ops.weathervane.build() == {"FINISHED"}
    settings = bpy.context.scene.weathervane
    assert (settings.numerics, settings.precision) == ("documented", "float64")  # the file's
    settings.numerics, settings.precision = "robust", "float32"
    assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
    exported = scene_from_dict(json.loads((tmp_path / "scene.json").read_text()))
    assert (exported.render.numerics, exported.render.dtype) == ("robust", "float32")


def test_a_cancelled_render_keeps_the_bands_finished_before_the_cancel(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from addon.engine import engine
    from tracer.workers.parallel import bands

    engine_scene(workers=1)  # bands one after another: the cancel comes after the first
    written, write = [], engine._write

    def counted_write(*args) -> None:
        written.append(1)
        write(*args)

    monkeypatch.setattr(engine, "_write", counted_write)
    monkeypatch.setattr(engine, "cancelled", lambda _engine: bool(written))  # Esc once a band is in the result
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(tmp_path / "cancelled.exr"))
    shown = read_exr(tmp_path / "cancelled.exr")
    expected = render(default_scene().with_render(width=64, height=48), workers=1).image
    first, *rest = bands(default_scene().with_render(width=64, height=48).render)
    assert rest, "the frame must have more than one band"
    assert np.abs(shown[first] - expected[first]).max() < 1e-4  # the band traced before the cancel is shown
    others = np.setdiff1d(np.arange(48), first)
    assert np.all(shown[others] == 0.0)  # the rest was never traced


def test_the_engines_workers_are_started_afresh_not_forked_from_blender(tmp_path: Path) -> None:
    from addon.engine import engine

    scene = engine_scene(workers=2)
    scene.render.filepath = str(tmp_path / "two.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    renderer = engine._renderers[2]
    pids = renderer._pool.pids()
    assert len(pids) == 2
    for pid in pids:  # a spawned worker runs multiprocessing's spawn_main, a forked one Blender's own command line
        command = Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace")
        assert "spawn_main" in command, command
    expected = render(default_scene().with_render(width=64, height=48), workers=1).image
    assert np.abs(read_exr(tmp_path / "two.exr") - expected).max() < 1e-4
    # another number of Processes: the pool of two is closed, its workers gone (not kept idle until Blender quits)
    scene.weathervane.workers = 1
    scene.render.filepath = str(tmp_path / "one.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert list(engine._renderers) == [1]
    assert not any(Path(f"/proc/{pid}").exists() for pid in pids)


@pytest.mark.parametrize("seconds", [0.0, 1e9], ids=["every-band", "first-and-last"])
def test_f12_writes_each_band_once_where_blender_takes_only_lists(tmp_path: Path, monkeypatch, seconds: float) -> None:
    """Where a pass takes only lists (Blender 3.4), F12 hands each band's rows over once, not the whole frame per
    band (62 s at 1920x1080 before), and the image is still the tracer's; where foreach_set works, the frame is
    written whole. Bands go into the result at most every WRITE_SECONDS: with 0 after every band, with a long time
    the first band at once and the rest at the end. Counted in numbers handed to the render results, not timed."""
    from addon.engine import engine
    from tracer.workers.parallel import bands

    scene = engine_scene(workers=1)
    scene.render.filepath = str(tmp_path / "engine.exr")
    written = []
    write = engine._write
    monkeypatch.setattr(
        engine, "_write", lambda result, rgba, passes=None: written.append(rgba.size) or write(result, rgba, passes)
    )
    monkeypatch.setattr(engine, "WRITE_SECONDS", seconds)
    lists = []  # Blender 3.4 reads the bands' files: no pixel goes over as a list
    monkeypatch.setattr(engine, "_write_list", lambda combined, rgba: lists.append(rgba.size))
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert not lists
    expected = render(default_scene().with_render(width=64, height=48), workers=1).image
    assert np.abs(read_exr(tmp_path / "engine.exr") - expected).max() < 1e-4
    count = len(bands(default_scene().with_render(width=64, height=48).render))
    assert count > 1
    frame = 64 * 48 * 4
    if engine._FAST_WRITE == [False]:
        assert sum(written) == frame  # every pixel once, in its band's results; no second frame
    else:
        assert written == [frame] * (count + 1 if seconds == 0 else 2)  # the frame after bands, and at the end


def test_f12_says_what_it_is_doing_from_the_export_to_the_last_band(monkeypatch) -> None:
    """The render window's header (update_stats) names each stage before the image has pixels: the export, then the
    preparation with the scene's counts (the tracer's scene: the vane's objects and its lights), then every band in
    order, then the time."""
    import re

    from addon.engine import engine
    from tracer.workers.parallel import bands

    said = []
    say = engine.say
    monkeypatch.setattr(engine, "say", lambda render_engine, info: said.append(info) or say(render_engine, info))
    engine_scene(workers=1)
    assert bpy.ops.render.render() == {"FINISHED"}
    tracer_scene = default_scene().with_render(width=64, height=48)
    objects, lights = len(tracer_scene.objects), len(tracer_scene.lights)
    count = len(bands(tracer_scene.render))
    assert said[:2] == ["exporting the scene", f"preparing {objects} objects and {lights} lights"], said
    bands_said = [re.sub(r", about \d+( min)?( \d+ s)?( s)? left$", "", text) for text in said[2:-1]]
    assert bands_said == [f"band {done}/{count}" for done in range(1, count + 1)], said
    assert re.fullmatch(r"\d+ ms, \d+ rays", said[-1]), said


@pytest.mark.parametrize(
    ("elapsed", "done", "total", "text"),
    [(1.0, 1, 2, ""), (4.0, 2, 4, ", about 4 s left"), (30.0, 4, 140, ", about 17 min left"),
     (25.0, 4, 140, ", about 14 min 10 s left"), (60.0, 1, 2, ", about 1 min left"), (59.4, 10, 11, ", about 6 s left"),
     (9.0, 3, 3, ""), (0.0, 0, 3, "")],
)  # fmt: skip
def test_f12_says_about_how_long_is_left_at_the_bands_pace(elapsed, done, total, text) -> None:
    """After done of total bands in elapsed seconds: elapsed (total - done) / done left (4 of 140 bands in 30 s:
    30 * 136 / 4 = 1,020 s, 17 min; in 25 s, 850 s), to the nearest 10 s from a minute; nothing under 2 s, or once
    done."""
    from addon.engine import engine

    assert engine.remaining(elapsed, done, total) == text


def test_an_image_handed_over_as_an_openexr_file_is_read_by_blender_exactly(tmp_path: Path) -> None:
    """Blender 3.4's F12 hands its bands over as float OpenEXR files (engine.exr_bytes): Blender's own reader gives
    back every float, the top row first in the file and last in Blender's bottom-up pixels."""
    from addon.engine import engine

    rgba = np.random.default_rng(5).normal(0.5, 2.0, (7, 11, 4)).astype(np.float32)  # negative and above 1 too
    (tmp_path / "band.exr").write_bytes(engine.exr_bytes(rgba))
    image = bpy.data.images.load(str(tmp_path / "band.exr"))
    assert tuple(image.size) == (11, 7) and image.is_float
    pixels = np.empty(7 * 11 * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    assert np.array_equal(np.flipud(pixels.reshape(7, 11, 4)), rgba)


@pytest.mark.parametrize("evaluated", [True, False], ids=["evaluated", "script-edit-then-f12"])
def test_a_vane_parts_colour_edited_in_the_material_tab_shows_in_f12(tmp_path: Path, evaluated: bool) -> None:
    """The vane material's Surface node (its Color input in the Material tab) is what F12 renders: the tracer's own
    render of the scene file with that colour, and what the sidebar's colour set the same way renders."""
    from tracer.scene.loader import default_scene_dict, scene_from_dict

    scene = engine_scene()
    new = (0.9, 0.1, 0.05)

    def f12(name: str) -> np.ndarray:
        scene.render.filepath = str(tmp_path / f"{name}.exr")
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        return read_exr(tmp_path / f"{name}.exr")

    before = f12("before")
    top = bpy.data.materials["WV verdigris"].node_tree.nodes["WV Surface"]
    top.inputs["Color"].default_value = (*new, 1.0)
    if evaluated:
        bpy.context.view_layer.update()  # as in the window, where the depsgraph evaluates before F12 is pressed
    edited = f12("edited")
    document = default_scene_dict()
    document["materials"]["verdigris"]["color"] = list(new)
    expected = render(scene_from_dict(document).with_render(width=64, height=48), workers=1).image
    assert np.abs(edited - expected).max() < 1e-4
    changed = np.abs(edited - before).max(axis=2) > 0.02
    assert changed.sum() >= 8  # the part covers pixels (11 at 64x48), and they changed
    red = edited[changed][:, 0] / np.maximum(edited[changed][:, 1], 1e-6)
    assert np.median(red) > 3.0  # to the new colour: red over green
    # the sidebar's colour set the same way renders the same pixels
    entry = next(entry for entry in scene.weathervane.materials if entry.name == "verdigris")
    entry.color = (0.2, 0.2, 0.2)
    entry.color = new
    assert np.array_equal(f12("sidebar"), edited)


def test_f12_and_the_rendered_view_export_and_load_with_the_garbage_collector_held(monkeypatch) -> None:
    """The export and the load of F12 and of the Rendered view run with Python's cyclic garbage collector off
    (collector_held: their containers would otherwise set off a full collection of Blender's Python heap, 0.10-0.15 s
    in most F12s of 3,000 separate cubes), and it is on again after, also where the export fails; a collector the
    user turned off stays off."""
    import gc

    from addon import tracer_api
    from addon.convert import export
    from addon.engine import viewport
    from addon.engine.collector import collector_held

    seen = []
    scene_document, scene_from_dict = export.scene_document, tracer_api.scene_from_dict

    def exported(*args, **kwargs):
        seen.append(("export", gc.isenabled()))
        return scene_document(*args, **kwargs)

    def loaded(*args, **kwargs):
        seen.append(("load", gc.isenabled()))
        return scene_from_dict(*args, **kwargs)

    monkeypatch.setattr(export, "scene_document", exported)
    monkeypatch.setattr(tracer_api, "scene_from_dict", loaded)
    engine_scene(workers=1)
    assert gc.isenabled()
    assert bpy.ops.render.render() == {"FINISHED"}
    assert seen == [("export", False), ("load", False)] and gc.isenabled(), seen
    session = viewport.ViewportSession(1)
    try:
        seen.clear()
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        assert seen == [("export", False)] and gc.isenabled(), seen
    finally:
        session.close()
    with pytest.raises(ValueError), collector_held():
        assert not gc.isenabled()
        raise ValueError("an export that fails")
    assert gc.isenabled()
    gc.disable()
    try:
        with collector_held():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
