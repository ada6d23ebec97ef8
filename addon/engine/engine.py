"""The documented tracer as a Blender render engine: F12, animation renders, `blender -b -E WEATHERVANE_TRACER` and
the 3D View's Rendered shading (engine/viewport.py).

Each frame exports the evaluated scene to a tracer scene (convert/export.py), renders it on the tracer's worker
pool band by band with progress and cancel, and hands the linear float image to Blender's render result.
"""

from __future__ import annotations

import time

import bpy
import numpy as np

from .. import tracer_api as tracer
from ..convert import export, motion_blur, pass_map
from ..vane import camera
from . import messages, viewport
from .collector import collector_held
from .workers import spawn_with_blenders_python


def say(engine: bpy.types.RenderEngine, info: str) -> None:
    """What F12 is doing, in the render window's header and the status bar, as Cycles says "Synchronizing object" and
    "Sample 3/16": the export and the preparation before the first band (on a large scene, seconds in which the
    image is still empty), then the bands, then the time."""
    engine.update_stats("Weathervane Tracer", info)


def remaining(elapsed: float, done: int, total: int) -> str:
    """ ", about 3 min 20 s left" after done of total bands in elapsed seconds, at their pace so far (Cycles'
    "Remaining"; an adaptive F12's first bands are quicker than its second pass's, so it is rough): nothing once
    done, or while under 2 s are left."""
    if not 0 < done < total:
        return ""
    left = elapsed * (total - done) / done
    if left < 2.0:
        return ""
    if left < 60.0:
        return f", about {left:.0f} s left"
    minutes, seconds = divmod(round(left / 10.0) * 10, 60)
    return f", about {minutes} min {seconds} s left" if seconds else f", about {minutes} min left"


class RenderCancelledError(Exception):
    pass


_renderers: dict[int, object] = {}  # one worker pool per worker count, kept across frames of an animation
_turning: dict[
    int, object
] = {}  # per pool: the last scene's pixels that the vane can change (tracer/frames/incremental.py)


# the least time between two writes of F12's bands into Blender's result (each makes Blender redraw its display
# of the render; a full-HD frame's 36 bands finish 15-30 ms apart with 2 workers here)
WRITE_SECONDS = 0.25

_closing = [False]  # set while the add-on is disabled or Blender quits: no pool is started again


def _renderer(workers: int):
    """The pool for a worker count, kept across frames; none once the engine is closing (Blender quits during a
    render: its thread would otherwise start new worker processes after the pools were closed). A pool of another
    count is closed first: Processes set to 64 and back would otherwise keep 64 idle workers (8.5 GB) until Blender
    quits."""
    if _closing[0]:
        raise RenderCancelledError
    for count in [count for count in _renderers if count != workers]:
        _renderers.pop(count).close()
        _turning.pop(count, None)
    if workers not in _renderers:
        _renderers[workers] = tracer.Renderer(workers, start_method=spawn_with_blenders_python())
    return _renderers[workers]


def close_renderers() -> None:
    _closing[0] = True
    for renderer in _renderers.values():
        renderer.close(final=True)  # a render still running on it (Blender quitting) starts no worker again
    _renderers.clear()
    _turning.clear()


class WEATHERVANE_RE_tracer(bpy.types.RenderEngine):
    bl_idname = "WEATHERVANE_TRACER"
    bl_label = "Weathervane Tracer"
    bl_use_preview = False

    def __del__(self) -> None:
        try:
            session = self.__dict__.get("_viewport")
        except (AttributeError, ReferenceError):  # no dict, or Blender freed the engine's struct already
            return
        if session is not None:
            session.close()

    def _viewport_session(self, blender_scene) -> viewport.ViewportSession:
        """This view's tracing session, started again if the number of workers changed."""
        workers = blender_scene.weathervane.workers
        session = getattr(self, "_viewport", None)
        if session is None or session.workers != workers:
            if session is not None:
                session.close()
            session = self._viewport = viewport.ViewportSession(workers)
        return session

    def view_update(self, context, depsgraph) -> None:
        """The depsgraph changed: export the scene again and hand it over as this view sees it, so that it is traced
        while Blender gets to the draw (view_draw hands over the view's own changes: an orbit, a resize)."""
        try:
            # Blender calls this inside the evaluation, before the depsgraph handlers: what changed is told here
            export.observe(depsgraph, from_view_update=True)
            session = self._viewport_session(depsgraph.scene)
            session.update_scene(context, depsgraph)
            region, view = context.region, context.region_data
            if region is not None and region.type == "WINDOW" and isinstance(view, bpy.types.RegionView3D):
                session.show(region, view, _playing(context))
        except Exception:  # a viewport must never raise into Blender's draw loop
            import traceback

            traceback.print_exc()

    def view_draw(self, context, depsgraph) -> None:
        """Draw the newest traced level; trace again when the view (or the scene) changed."""
        try:
            blender_scene = depsgraph.scene
            session = self._viewport_session(blender_scene)
            if session.document is None and session.error is None:
                session.update_scene(context, depsgraph)
            session.show(context.region, context.region_data, _playing(context))
            session.draw_soon()
            status = session.draw(context.region)
        except Exception as failure:  # one line in the view; the console has the traceback
            import traceback

            traceback.print_exc()
            status = f"Weathervane Tracer: {failure}"
        shown = status
        try:  # the view draws the text line by line: a long one (a refusal) wrapped to the view
            shown = messages.view_text(status, context.region, context.area)
        except Exception:
            import traceback

            traceback.print_exc()
        messages.VIEW_TEXT.update(status=status, shown=shown)
        self.update_stats("", shown)

    def update_render_passes(self, scene=None, renderlayer=None) -> None:
        """The passes ticked in View Layer > Passes that the tracer makes, for Blender's result and compositor."""
        pass_map.register_passes(self, scene, renderlayer)

    def render(self, depsgraph) -> None:
        from ..convert.export import ExportCancelledError, ExportNotes, MemoryBudget, named_problems, scene_document

        blender_scene = depsgraph.scene
        messages.clear_render_window()  # a previous F12's refusal is not about this render
        say(self, "exporting the scene")
        notes = ExportNotes()
        budget = MemoryBudget(blender_scene, cancelled=lambda: cancelled(self))
        try:
            moves = motion_blur.sampled(blender_scene, depsgraph, self.frame_set)  # Render > Motion Blur's poses
            with collector_held():
                document = scene_document(
                    bpy.context, depsgraph, blender_scene, notes, budget, arrays=True, motion=moves
                )
                scene = tracer.scene_from_dict(export.as_json_types(document), "scene", kept=export.F12_LOADED)
        except tracer.SceneError as error:
            self._nothing_rendered(
                "Weathervane Tracer: " + "; ".join(named_problems(error.problems, document, blender_scene.world)[:4])
            )
            return
        except tracer.ResourceError as error:  # refused before its arrays were read: nothing started
            self._nothing_rendered(f"Weathervane Tracer: not started: {error}")
            return
        except ExportCancelledError:
            return
        view_layer = depsgraph.view_layer
        passes = pass_map.wanted(blender_scene, view_layer)
        if passes:  # View Layer > Passes: traced with the image (whole frames), written into the result at the end
            scene = scene.with_render(
                passes=passes, **pass_map.mist(blender_scene.world), **pass_map.cryptomatte(view_layer)
            )
        width, height = scene.render.width, scene.render.height
        left_out = camera.unsupported(blender_scene, exporting=False) + pass_map.not_made(view_layer)
        if left_out or notes.line():
            said = [f"does not render: {', '.join(left_out)}"] if left_out else []
            messages.report_whole(
                self, {"WARNING"}, f"Weathervane Tracer: {'; '.join([*said, notes.line()] if notes.line() else said)}"
            )
        objects, lights = len(scene.objects), len(scene.lights)
        say(self, f"preparing {objects:,} object{'s' * (objects != 1)} and {lights} light{'s' * (lights != 1)}")
        region = border_region(blender_scene.render, width, height)
        if region is not None:
            self._render_region(scene, region)
            return
        started = time.perf_counter()

        def progress(done: int, total: int) -> None:
            self.update_progress(done / total)
            say(self, f"band {done}/{total}" + remaining(time.perf_counter() - started, done, total))
            if cancelled(self):
                raise RenderCancelledError

        # the image as Blender shows it (rows bottom-up, RGBA): bands are drawn into it as they finish, so a
        # cancelled render keeps what was traced
        shown = np.zeros((height, width, 4), dtype=np.float32)
        shown[..., 3] = 1.0
        render_result = self.begin_result(0, 0, width, height)
        unwritten = np.zeros(height, dtype=bool)  # Blender's rows traced but not yet in the result
        last_write = [-np.inf]

        def write_bands() -> None:
            """The rows traced since the last write into Blender's result. Where a pass takes an array (Blender
            4+), the frame in one call; in Blender 3.4 each run of those rows (a band deals blocks of rows over the
            frame) as a result of its own, so every pixel goes in once (a whole frame for each band: 62 s at
            1920x1080 with lists)."""
            last_write[0] = time.perf_counter()
            if not unwritten.any():
                return
            if _fast_write(render_result):
                _write(render_result, shown)
                self.update_result(render_result)
                unwritten[:] = False
                return
            lines = np.flatnonzero(unwritten)
            unwritten[:] = False
            breaks = np.flatnonzero(np.diff(lines) != 1) + 1
            for run in np.split(lines, breaks):
                bottom, count = int(run[0]), len(run)
                band_result = self.begin_result(0, bottom, width, count)
                _write(band_result, shown[bottom : bottom + count])
                self.end_result(band_result)

        def band_done(image: np.ndarray, rows: np.ndarray) -> None:
            shown[height - 1 - rows, :, :3] = image[rows]
            unwritten[height - 1 - rows] = True
            # at most one write every WRITE_SECONDS (each write costs Blender a redraw of the render's display): the
            # first band at once, the others with the next write
            if time.perf_counter() - last_write[0] >= WRITE_SECONDS:
                write_bands()

        def stop_if_cancelled() -> None:  # while the workers prepare a large scene, before any band is done
            if cancelled(self):
                raise RenderCancelledError

        renderer = None
        try:
            workers = scene.render.workers
            renderer = _renderer(workers)
            renderer.heartbeat = stop_if_cancelled
            turning = _turning.setdefault(workers, tracer.TurningFrames())
            result = turning.render(renderer, scene, progress, band_done)
        except (RenderCancelledError, tracer.PoolClosedError):  # Esc, or Blender quitting (its pools closed)
            # the bands finished before the cancel: in the frame's result, or (Blender 3.4) in results of their own
            write_bands()
            self.end_result(render_result, cancel=not _fast_write(render_result))
            return
        except (tracer.ResourceError, tracer.WorkerLostError, tracer.TaskFailedError) as error:
            self.end_result(render_result, cancel=True)
            self._nothing_rendered(str(error))  # not enough memory, workers lost: the pool stays usable
            return
        finally:
            if renderer is not None:
                renderer.heartbeat = None  # the renderer outlives this engine
        final = np.flipud(result.image).astype(np.float32)  # Blender's rows go bottom-up
        alpha = getattr(result, "alpha", None)
        fast = _fast_write(render_result)
        if not fast:
            write_bands()  # the bands since the last write (Blender 4+ takes the whole frame below)
        if alpha is None and not fast and not result.passes and np.array_equal(shown[..., :3], final):
            # every pixel went in with its band already (Blender 3.4's lists): no second conversion of the frame
            self.end_result(render_result, cancel=True)
        else:
            shown[..., :3] = final
            if alpha is not None:
                shown[..., 3] = np.flipud(alpha)
            _write(render_result, shown, result.passes)
            self.end_result(render_result)
        if result.passes:  # the manifests go into the frame's own result, whose metadata Blender's files carry
            whole = self.get_result()
            for key, value in pass_map.cryptomatte_metadata(scene, view_layer.name).items():
                whole.stamp_data_add_field(key, value)
        say(self, f"{result.seconds * 1000:.0f} ms, {result.rays.total} rays")

    def _nothing_rendered(self, text: str) -> None:
        """F12 made no image: the whole text in the Info editor and over the render window's empty image, a short line
        in the status bar (engine/messages.py). Not RenderEngine.error_set: from 4.2 it adds its text as one more
        error report, and in 3.4 it only puts the text's start in the window's own line, above the whole text."""
        messages.report_whole(self, {"ERROR"}, text)
        messages.show_in_render_window(text)

    def _render_region(self, scene, region: tuple[int, int, int, int]) -> None:
        """Only the render border's pixels traced; Blender's result is the border's size (it places the region in
        the frame itself unless Crop to Render Region is on)."""
        x0, y0, x1, y1 = region
        width, height = scene.render.width, scene.render.height
        render_result = self.begin_result(0, 0, x1 - x0, y1 - y0)
        rows = np.arange(height - y1, height - y0)  # Blender counts rows from the bottom, the tracer from the top
        pixels = (rows[:, None] * width + np.arange(x0, x1)[None, :]).ravel()
        try:
            base = np.zeros((height, width, 4 if scene.has_alpha else 3), dtype=np.dtype(scene.render.dtype))
            result = _renderer(scene.render.workers).render_pixels(scene, pixels, base)
        except (RenderCancelledError, tracer.PoolClosedError):  # the engine is closing
            self.end_result(render_result, cancel=True)
            return
        except (tracer.ResourceError, tracer.WorkerLostError, tracer.TaskFailedError) as error:
            self.end_result(render_result, cancel=True)
            self._nothing_rendered(str(error))
            return
        shown = np.ones((y1 - y0, x1 - x0, 4), dtype=np.float32)
        shown[..., :3] = np.flipud(result.image[height - y1 : height - y0, x0:x1])
        alpha = getattr(result, "alpha", None)
        if alpha is not None:
            shown[..., 3] = np.flipud(alpha[height - y1 : height - y0, x0:x1])
        _write(render_result, shown)
        self.end_result(render_result)
        say(self, f"{result.seconds * 1000:.0f} ms, render border {x1 - x0}x{y1 - y0}")


def _playing(context) -> bool:
    """Whether an animation is playing in the context's window (the Rendered view then traces frames coarse)."""
    screen = context.screen
    return screen is not None and screen.is_animation_playing


def border_region(render, width: int, height: int) -> tuple[int, int, int, int] | None:
    """The render border as Blender's render pipeline cuts it: (x0, y0, x1, y1) in pixels, y up from the bottom,
    each border fraction times the size truncated to a whole pixel; None without a border (or a border over the
    whole frame)."""
    if not render.use_border:
        return None
    x0, x1 = int(render.border_min_x * width), int(render.border_max_x * width)
    y0, y1 = int(render.border_min_y * height), int(render.border_max_y * height)
    x0, x1, y0, y1 = max(0, x0), min(width, max(x1, x0 + 1)), max(0, y0), min(height, max(y1, y0 + 1))
    return None if (x0, y0, x1, y1) == (0, 0, width, height) else (x0, y0, x1, y1)


def cancelled(engine) -> bool:
    """Whether the user asked to stop the render (Esc)."""
    return engine.test_break()


_FAST_WRITE: list[bool] = []  # found by the first write: whether a pass takes an image through foreach_set


def _fast_write(render_result) -> bool:
    """Whether a pass takes an image in one call (foreach_set: Blender 4+; 3.4's rect has the method but refuses
    it, and takes only lists). Tried once, with a row of the result's own size, and remembered."""
    if not _FAST_WRITE:
        combined = render_result.layers[0].passes["Combined"]
        try:
            combined.rect.foreach_set(np.zeros(len(combined.rect) * 4, dtype=np.float32))
            _FAST_WRITE.append(True)
        except (AttributeError, TypeError):
            _FAST_WRITE.append(False)
    return _FAST_WRITE[0]


def _write(render_result, rgba: np.ndarray, passes: dict[str, np.ndarray] | None = None) -> None:
    """A (height, width, 4) float32 image, rows bottom-up, into the render result's Combined pass, and the traced
    passes ((H, W, C), rows top-down) into theirs: in one foreach_set a pass where a pass takes it (Blender 4+); in
    Blender 3.4 through a file that Blender reads itself (an uncompressed float OpenEXR: RenderLayer.load_from_file
    for the image alone, RenderResult.load_from_file for a multilayer file with the passes, the way external engines
    hand over their images), since a list costs Blender 3.4 about 0.7 us a value and the file about 0.1 us (most of an
    F12's time at full HD: docs/measurements.md); lists where the file cannot be read."""
    combined = render_result.layers[0].passes["Combined"]
    if _fast_write(render_result):
        combined.rect.foreach_set(rgba.ravel())
        if passes:
            pass_map.write_passes(render_result, passes, fast=True)
        return
    import contextlib
    import os
    import tempfile

    top_down = np.flipud(rgba)  # an EXR's lines go top-down, Blender's rows bottom-up
    if passes:
        layer = render_result.layers[0].name
        channels = {f"{layer}.Combined.{letter}": top_down[..., k] for k, letter in enumerate("RGBA")}
        channels.update(pass_map.exr_channels(passes, layer))
    else:
        channels = {letter: top_down[..., k] for k, letter in enumerate("RGBA")}
    handle, path = tempfile.mkstemp(suffix=".exr", prefix="weathervane-")
    try:
        with os.fdopen(handle, "wb") as file:
            write_exr(file, channels)
        if passes:
            render_result.load_from_file(path)
        else:
            render_result.layers[0].load_from_file(path)
    except (OSError, RuntimeError):  # no room for the file, or Blender could not read it
        _write_list(combined, rgba)
        if passes:
            pass_map.write_passes(render_result, passes, fast=False)
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)


def _write_list(combined, rgba: np.ndarray) -> None:
    """The pixels as a list, which every Blender takes (3.4's slow path: about 0.7 us a pixel)."""
    combined.rect = rgba.reshape(-1, 4).tolist()


def exr_bytes(channels: dict[str, np.ndarray] | np.ndarray) -> bytes:
    """The bytes write_exr writes for channels (a (height, width, 4) array: the channels R, G, B, A)."""
    import io

    stream = io.BytesIO()
    write_exr(stream, channels if isinstance(channels, dict) else {c: channels[..., k] for k, c in enumerate("RGBA")})
    return stream.getvalue()


def write_exr(file, channels: dict[str, np.ndarray]) -> None:
    """Named (height, width) float images, rows top-down, into file as a single-part scanline OpenEXR file: 32-bit
    float channels in the format's (alphabetical) order, no compression, one line per block, the data window (0,
    0)-(width - 1, height - 1). Dotted names ("ViewLayer.Depth.Z") make it a multilayer file as Blender writes them.
    The lines are made in one array and written as they are (a full-HD frame with every pass is 450 MB)."""
    names = sorted(channels, key=lambda name: name.encode())
    height, width = next(iter(channels.values())).shape[:2]

    def attribute(name: str, kind: str, value: bytes) -> bytes:
        return name.encode() + b"\0" + kind.encode() + b"\0" + np.int32(len(value)).tobytes() + value

    channel = np.array([2, 0, 1, 1], dtype="<i4").tobytes()  # FLOAT, pLinear 0 (and 3 reserved bytes), x/y sampling 1
    channel_list = b"".join(name.encode() + b"\0" + channel for name in names) + b"\0"
    window = np.array([0, 0, width - 1, height - 1], dtype="<i4").tobytes()
    header = b"".join(
        [
            np.array([20000630, 2], dtype="<i4").tobytes(),  # magic number; version 2, single-part scanline
            attribute("channels", "chlist", channel_list),
            attribute("compression", "compression", b"\0"),
            attribute("dataWindow", "box2i", window),
            attribute("displayWindow", "box2i", window),
            attribute("lineOrder", "lineOrder", b"\0"),  # increasing y
            attribute("pixelAspectRatio", "float", np.float32(1).tobytes()),
            attribute("screenWindowCenter", "v2f", np.zeros(2, dtype="<f4").tobytes()),
            attribute("screenWindowWidth", "float", np.float32(1).tobytes()),
            b"\0",
        ]
    )
    # each line: its y and its size in bytes (int32), then every pixel of the first channel, of the next, ...
    lines = np.empty((height, 2 + len(names) * width), dtype="<f4")
    lines.view("<i4")[:, 0] = np.arange(height)
    lines.view("<i4")[:, 1] = 4 * len(names) * width
    values = lines[:, 2:].reshape(height, len(names), width)
    for k, name in enumerate(names):
        values[:, k, :] = channels[name]
    start = len(header) + 8 * height  # after the table of each line's offset in the file
    offsets = (start + lines.shape[1] * 4 * np.arange(height, dtype="<u8")).astype("<u8")
    file.write(header)
    file.write(offsets.tobytes())
    file.write(memoryview(lines).cast("B"))


CLASSES = (WEATHERVANE_RE_tracer,)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register() -> None:
    _closing[0] = False
    _register_classes()
    export.register()  # the export's memory of geometry and materials, and the handlers that keep it true
    messages.register()  # the render window's text of an F12 that made no image


def unregister() -> None:
    messages.unregister()
    export.unregister()
    viewport.close_sessions()
    close_renderers()
    _unregister_classes()
