"""The 3D View's Rendered shading with the tracer: the viewport's view -> a tracer camera, the scene traced coarse to
fine on a thread (tracer/frames/progressive.py), the newest image drawn with the gpu module over the whole view.

Blender calls view_update() when the depsgraph changes (an object moved, a material or light edited, the frame
changed) and view_draw() whenever the view is drawn (also when it is orbited or zoomed). Both only hand a new scene
to the tracing thread when what the tracer would render changed, and never wait for it; a timer on Blender's main
thread asks the Rendered views to redraw as levels finish.

The view has its own samples (Render Properties > Weathervane Tracer > Viewport; each at most F12's): its coarse
levels are one sample of everything, its full size is traced in passes up to them, and its status says how far it
is ("Sample 4/16"), as Cycles' viewport does. F12 reads only its own settings.
"""

from __future__ import annotations

import hashlib
import json
import threading
import time
import weakref

import bpy
import numpy as np

from .. import tracer_api as tracer
from .collector import collector_held
from .workers import spawn_with_blenders_python

SENSOR = 36.0  # millimetres: any width serves, the lens is derived from it
REDRAW_SECONDS = 0.02  # how often the main thread looks for finished levels while a view is tracing
# How long a draw waits for the newest scene's first level before it draws the previous image under "updating": none.
# Waiting would save a draw of the previous image (0.1-0.2 s of software OpenGL under Xvfb), but the draw right after
# a change comes before even the 1/8 level at one sample (0.03-0.05 s on the pool in the real-window test's 1321x759
# view), and the user must see at once that the change was taken (within 0.2 s). Kept as settings of the
# session's draw_soon for views whose draws are cheap.
FIRST_LEVEL_WAIT = 0.0
EDIT_WAIT = 0.0  # the same for a change answered from the kept ray trees (a slow one's 1/8 level comes first)
WORLD_VIEW_SAMPLES = 4  # the fewest world-light directions the view traces to (F12's: 16)
INTERMEDIATE_SECONDS = 1.0  # a level between the first drawn and the full one is drawn after this long without a draw
# The status's share of the level being traced is drawn again this often, unless the level is estimated to finish
# within it: its image is drawn then anyway, and each draw takes the trace's CPU (a 1321x759 view in software OpenGL:
# 0.13-0.2 s)
PROGRESS_SECONDS = 2.0
# the longest a closing view waits for its tracing thread's current piece (a piece of kept ray trees: well under 1 s)
CLOSE_WAIT = 2.0
PLAYBACK_DIVISOR = 4  # while an animation plays, each frame is traced at 1/4 of the view's width and height alone


def view_camera(view_matrix, window_matrix, width: int, height: int) -> dict:
    """A 3D View's view and projection (mathutils 4x4 matrices, region of width x height pixels) -> the scene file's
    camera section that traces exactly the pixels Blender draws there.

    Blender's projection maps camera space to clip space; a perspective view's x / -z is (ndc_x + P[0][2]) / P[0][0],
    so the tracer camera's lens is SENSOR * P[0][0] / 2 and its shift P[0][2] / 2 (likewise in y, in units of the
    width); an orthographic view's x is (ndc_x - P[0][3]) / P[0][0]. The near and far planes come from P[2]. An
    orthographic view's near plane can lie behind the view's centre (Blender centres its clip range there): the
    camera is then moved back along its axis so that it starts on that plane."""
    p = window_matrix
    # inverted in float64: mathutils works in float32, and the camera's location then misses the near plane's
    # pixels by 1e-3 px where the near plane is 1 cm away
    camera_to_world = np.linalg.inv(np.array(view_matrix, dtype=np.float64))
    location, axes = camera_to_world[:3, 3], camera_to_world[:3, :3]
    section = {
        "rotation": list(tracer.euler_xyz_from_matrix(axes.tolist())),
        "sensor_width": SENSOR,
        "sensor_height": SENSOR * height / width,
        "sensor_fit": "HORIZONTAL",
    }
    if p[3][3] == 0.0:  # perspective: w = -z
        near, far = p[2][3] / (p[2][2] - 1.0), p[2][3] / (p[2][2] + 1.0)
        lens = SENSOR * p[0][0] / 2.0
        section.update(
            type="PERSP",
            location=location.tolist(),
            lens=lens,
            shift_x=p[0][2] / 2.0,
            shift_y=p[1][2] * p[0][0] / (2.0 * p[1][1]),
            clip_start=near,
            clip_end=far,
        )
        return section
    near, far = (p[2][3] + 1.0) / p[2][2], (p[2][3] - 1.0) / p[2][2]
    back = max(0.0, -near)
    section.update(
        type="ORTHO",
        location=(location + axes[:, 2] * back).tolist(),
        ortho_scale=2.0 / p[0][0],
        shift_x=-p[0][3] / 2.0,
        shift_y=-p[1][3] * p[0][0] / (2.0 * p[1][1]),
        clip_start=near + back,
        clip_end=far + back,
    )
    return section


def texture_rgba(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) linear floats, rows from the top -> (H, W, 4) float32 with rows from the bottom, as a texture is
    laid out. The values stay scene-linear: Blender's viewport applies the scene's colour management (view
    transform, look, exposure, gamma) to what a render engine draws, as it does to F12's image."""
    rgba = np.empty((*image.shape[:2], 4), dtype=np.float32)
    rgba[..., 3] = 1.0
    rgb = rgba[..., :3]
    with np.errstate(over="ignore"):  # a value past float32's range becomes inf, then the largest float32
        rgb[...] = image[::-1]
    if not np.isfinite(rgb).all():  # a scan, cheaper than nan_to_num of the whole image (0.02 s, not 0.07-0.2 s)
        np.nan_to_num(rgb, copy=False)
    return rgba


class ViewportSession:
    """One Rendered view's state: the scene it shows, the tracing thread, the texture of the newest level."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        # each level's texture data made on the tracing thread as it is delivered (a full 1321x759 level's: 25-45 ms
        # that the main thread's draw would otherwise spend); the thread holds the tracer, not the session
        prepared = self._prepared = {}
        self.progressive = tracer.ProgressiveRender(
            workers, start_method=spawn_with_blenders_python(), on_level=lambda level: _prepare(prepared, level)
        )
        self.document: dict | None = None  # the scene without its camera (set by view_update)
        self.error: str | None = None  # why the scene cannot be traced (a bad scene), shown in the view
        self._scene_key = ""  # the document as JSON, made once per update: view_draw runs on every redraw
        self._loaded = tracer.LoadedParts()  # the last view's materials and objects as loaded, for the next's
        self._shown_key: str | None = None
        self._texture_level = None  # the level whose texture _textures holds for this session
        self._drawn_at = 0.0  # when a level was last drawn (time.perf_counter)
        self._status_at = 0.0  # when the status was last drawn
        self._drawn_tracing = None  # the progress of the level being traced that the status last showed
        self.status = ""  # the status line last drawn
        self._view_size: tuple[int, int] | None = None  # the region's (width, height) when last shown
        self._editable_samples, self._kept_bytes = tracer.EDITABLE_SAMPLES, tracer.KEPT_BYTES_PER_SAMPLE
        self.samples = tracer.Samples()  # what the view traces to (set by update_scene from the Viewport settings)
        _sessions.add(self)
        # a session let go without close() still ends its thread and its workers (the thread holds the tracer, not
        # the session)
        weakref.finalize(self, self.progressive.close)

    def close(self) -> None:
        # Blender frees the view's engine as the shading leaves Rendered: the tracing thread is let finish its piece
        # first (keeping a view's ray trees runs in Blender's own process), so that nothing of the view's runs on
        # once Blender has let it go
        self.progressive.close(wait=CLOSE_WAIT)
        self._texture_level = None
        _sessions.discard(self)
        if threading.current_thread() is threading.main_thread():
            _textures.pop(id(self), None)  # the GPU texture freed now; elsewhere by the main thread's next look

    def update_scene(self, context, depsgraph) -> None:
        from ..convert.export import MemoryBudget, scene_document

        self.samples = view_samples(depsgraph.scene.weathervane)
        # the memory check counts the view's image (the last size it was drawn at) and its kept ray trees (kept up
        # to EDITABLE_SAMPLES camera samples times shadow samples; whether the scene has a light of a size, which
        # makes them count, is known only after the export: counted as if it had)
        budget = True
        if self._view_size is not None:
            width, height = self._view_size
            settings = depsgraph.scene.weathervane
            shadows = min(self.samples.shadow, int(settings.shadow_samples))
            pixel = min(self.samples.pixel, int(settings.samples))
            samples = min(width * height * pixel * shadows, self._editable_samples)
            budget = MemoryBudget(depsgraph.scene, size=self._view_size, extra=samples * self._kept_bytes)
        try:
            # arrays as NumPy arrays (as F12's): a textured, subdivided scene's lists cost 0.3 s a change to make,
            # serialize for the key and read back, before the view could show "updating"
            with collector_held():  # an edit's answer without a collection of Blender's whole heap in it
                document = scene_document(context, depsgraph, depsgraph.scene, budget=budget, arrays=True)
        except tracer.ResourceError as refusal:  # too large for the free memory: not read
            self.error, self.document = f"Weathervane Tracer: not started: {refusal}", None  # as F12 says it
            return
        except Exception as failure:  # shown in the view as one line; the console has the rest
            import traceback

            traceback.print_exc()
            self.error, self.document = f"cannot export the scene: {failure}", None
            return
        document.pop("camera", None)
        self.document, self.error = document, None
        self._scene_key = json.dumps(document, sort_keys=True, default=_array_key)

    def show(self, region, view, playing: bool = False) -> None:
        """Hand the scene as seen from this view to the tracing thread, if it differs from the one shown. playing:
        an animation is playing, each frame is traced at PLAYBACK_DIVISOR of the view's size alone (the full levels
        come when it stops)."""
        self._view_size = (region.width, region.height)
        if self.document is None:
            return
        render = {**self.document["render"], "width": region.width, "height": region.height, "pixel_aspect": [1.0, 1.0]}
        camera = view_camera(view.view_matrix, view.window_matrix, region.width, region.height)
        # only the view's part is serialized on a redraw: the scene's (10,000 instances' matrices, a large mesh's
        # triangles) was once, when it changed
        view_part = json.dumps({"camera": camera, "render": render}, sort_keys=True)
        key = f"{playing}{self.samples}{view_part}{self._scene_key}"
        if key == self._shown_key:
            return
        document = {**self.document, **json.loads(view_part)}
        from ..convert.export import as_json_types

        try:
            with collector_held():
                scene = tracer.scene_from_dict(as_json_types(document), "viewport", kept=self._loaded)
        except tracer.SceneError as error:
            from ..convert.export import named_problems

            self.error = "; ".join(named_problems(error.problems, document, bpy.context.scene.world)[:2])
            return
        self._shown_key, self.error = key, None
        self.progressive.show(scene, (PLAYBACK_DIVISOR,) if playing else None, self.samples)
        _keep_redrawing()

    def draw_soon(self) -> None:
        """Before a draw: wait up to FIRST_LEVEL_WAIT for the newest scene's first level (its coarse image, or a small
        edit at full size), so that this draw would show the change rather than the previous image under
        "updating"."""
        self.progressive.wait_first(FIRST_LEVEL_WAIT, EDIT_WAIT)

    def draw(self, region) -> str:
        """Draw the newest level over the region; returns the status line to show."""
        level = self.progressive.latest()
        if level is None:
            self.status = self.error or self.progressive.error or "Weathervane Tracer: starting"
            return self.status
        texture = _textures.get(id(self))
        if texture is None or self._texture_level is not level:
            _free_textures()
            prepared = self._prepared.get("last")  # (level, its texture data): one item, set at once
            rgba = prepared[1] if prepared is not None and prepared[0] is level else texture_rgba(level.image)
            texture = _textures[id(self)] = _texture(rgba)
            self._texture_level = level
            self._drawn_at = time.perf_counter()
        from gpu_extras.presets import draw_texture_2d

        draw_texture_2d(texture, (0, 0), region.width, region.height)
        self.status = self._status(level)
        self._status_at, self._drawn_tracing = time.perf_counter(), getattr(self.progressive, "tracing", None)
        return self.status

    def news(self) -> bool:
        """Whether a redraw would show something new: a level or a failure not drawn yet. A level between a scene's
        first drawn one and its finished image only after INTERMEDIATE_SECONDS without a draw: each draw takes the
        tracer's CPU, and a full-HD view's full image follows its 1/8 within a second."""
        level, drawn = self.progressive.latest(), self._texture_level
        if self.progressive.error is not None and self.progressive.error != self.status:
            return True
        if level is None:
            return False
        if level is drawn:  # the status's share of the next level, every PROGRESS_SECONDS while it changes
            tracing, now = self.progressive.tracing, time.perf_counter()
            return (
                not level.final
                and tracing is not None
                and tracing != self._drawn_tracing
                and now - self._status_at >= PROGRESS_SECONDS
                and tracing.seconds_left(now) >= PROGRESS_SECONDS
            )
        return (
            level.final
            or drawn is None
            or drawn.generation != level.generation
            or time.perf_counter() - self._drawn_at >= INTERMEDIATE_SECONDS
        )

    def _status(self, level) -> str:
        """The view's status line for the level drawn: never a previous scene's figures as the new one's."""
        if self.error or self.progressive.error:
            return self.error or self.progressive.error
        if level.generation != self.progressive.generation:  # the previous scene's image, until the change is traced
            return "Weathervane Tracer: updating"
        whole = level.image.shape[0] * level.image.shape[1]
        if level.final and level.traced < whole:
            return f"Weathervane Tracer: edit, {level.traced} of {whole} pixels traced again in {level.seconds:.2f} s"
        # Cycles' "Sample 3/16": the most samples of any kind the scene has, of the most it is traced to
        sample = f"Sample {level.sample}/{level.samples}" if level.samples > 1 else ""
        if level.final:  # done, even while the ray trees for edits are kept in the background
            return f"Weathervane Tracer: done in {level.seconds:.2f} s" + (f" ({sample})" if sample else "")
        if level.divisor == 1:
            return f"Weathervane Tracer: {sample} ({level.seconds:.2f} s)" + self._next(level)
        where = f"{sample}, 1/{level.divisor} resolution" if sample else f"1/{level.divisor} resolution"
        return f"Weathervane Tracer: {where} ({level.seconds:.2f} s)" + self._next(level)

    def _next(self, level) -> str:
        """How far the level after the one drawn is (its share of bands done), where the scene's is being traced:
        "; next: Sample 4/4, 40%"; nothing otherwise."""
        tracing = getattr(self.progressive, "tracing", None)
        if tracing is None or tracing.generation != level.generation or not tracing.total or not self.progressive.busy:
            return ""
        if tracing.samples > 1 and tracing.divisor == 1:
            what = f"Sample {tracing.sample}/{tracing.samples}"
        else:
            what = "full size" if tracing.divisor == 1 else f"1/{tracing.divisor} resolution"
        return f"; next: {what}, {100 * tracing.done // tracing.total}%"


def _array_key(value) -> str | float | int:
    """json.dumps' default for a document with arrays: a NumPy number as itself, an array as its dtype, shape and a
    digest of its bits (kept for a large read-only array seen again, such as a World's picture)."""
    if isinstance(value, np.generic):
        return value.item()
    if not isinstance(value, np.ndarray):
        raise TypeError(f"not JSON: {type(value).__name__}")
    kept = _digests.get(id(value))
    if kept is not None and kept[0] is value:
        return kept[1]
    digest = hashlib.blake2b(np.ascontiguousarray(value).data, digest_size=16).hexdigest()
    key = f"{value.dtype.str}{value.shape}:{digest}"
    if value.nbytes >= DIGEST_KEPT_FROM and tracer.immutable(value):  # nothing can change its bits while kept
        while len(_digests) >= DIGESTS_KEPT:
            _digests.pop(next(iter(_digests)))
        _digests[id(value)] = (value, key)
    return key


# digests kept for read-only arrays of at least DIGEST_KEPT_FROM bytes (a World's picture, a large texture: 1-4 ms a
# MB to digest), at most DIGESTS_KEPT of them: each is kept alive here, so that its id stays its own
DIGEST_KEPT_FROM = 1 << 20
DIGESTS_KEPT = 4
_digests: dict[int, tuple[np.ndarray, str]] = {}  # id(array) -> (the array, its key)


def view_samples(settings) -> tracer.Samples:
    """The Viewport settings (Render Properties) -> the samples the view traces to; the tracer takes each at most
    as F12's (a view never traces more than F12, nor another look: 1 shadow sample is a hard shadow)."""
    shadows = int(settings.viewport_shadow_samples)
    return tracer.Samples(
        pixel=int(settings.viewport_samples),
        shadow=shadows,
        glossy=int(settings.viewport_glossy_samples),
        world=max(WORLD_VIEW_SAMPLES, shadows),
    )


def _prepare(prepared: dict, level) -> None:
    """On the tracing thread, as a level is delivered: its texture data, for the draw that shows it."""
    prepared["last"] = (level, texture_rgba(level.image))


def _texture(rgba: np.ndarray):
    import gpu

    height, width = rgba.shape[:2]
    buffer = gpu.types.Buffer("FLOAT", width * height * 4, np.ascontiguousarray(rgba).ravel())
    return gpu.types.GPUTexture((width, height), format="RGBA32F", data=buffer)


_sessions: weakref.WeakSet[ViewportSession] = weakref.WeakSet()
_redrawing = False
# Each session's GPU texture (by id(session)), held here rather than by the session, so that it is freed on Blender's
# main thread only, where the GPU context is: a session (or its engine) that Python's cycle collector frees on the
# tracing thread (a collection may start at any allocation there) would otherwise free its texture there
_textures: dict[int, object] = {}


def _free_textures() -> None:
    """On the main thread: free the textures of sessions that are closed or gone."""
    live = {id(session) for session in list(_sessions)}
    for key in [key for key in _textures if key not in live]:
        del _textures[key]


def _keep_redrawing() -> None:
    """Ask Blender to redraw the Rendered views every REDRAW_SECONDS while any of them is tracing."""
    global _redrawing
    if not _redrawing:
        _redrawing = True
        bpy.app.timers.register(_redraw_rendered_views, first_interval=REDRAW_SECONDS)


def _redraw_rendered_views() -> float | None:
    """Redraw the Rendered views when a level is ready that is not drawn yet (or a failure to show), else only look
    again: each redraw of a view costs the software OpenGL of a virtual display 0.1-0.3 s of the CPU the tracer
    needs (drawn ten times a second while tracing, a 1586x926 view's edit took 1.5 s instead of 0.8 s)."""
    global _redrawing
    _free_textures()
    sessions = list(_sessions)
    # until every image is done (the ray trees kept afterwards change nothing on screen); looked at before the news,
    # so that this tick's redraw shows the last level and its "done"
    tracing = any(not session.progressive.done and session.progressive.busy for session in sessions)
    if any(session.news() for session in sessions):
        for window in bpy.context.window_manager.windows:
            for area in window.screen.areas:
                if area.type == "VIEW_3D" and area.spaces.active.shading.type == "RENDERED":
                    area.tag_redraw()
    if tracing:
        return REDRAW_SECONDS
    _redrawing = False
    return None


def close_sessions() -> None:
    for session in list(_sessions):
        session.close()
    _textures.clear()
    if bpy.app.timers.is_registered(_redraw_rendered_views):
        bpy.app.timers.unregister(_redraw_rendered_views)
    global _redrawing
    _redrawing = False
