"""A scene -> its image coarse to fine, traced on a thread of its own: what an interactive view (Blender's Rendered
shading) shows while the user works.

Each scene is traced at LEVELS: 1/8 of the image's width and height first (1/64 of its pixels, one sample each),
then 1/4, 1/2 and the full size with the scene's own samples. A newer scene supersedes the one being traced at the
next finished band, so an edit is answered by a coarse image within about one coarse level's time, never after the
rest of an old image. The caller's thread only hands scenes over and reads the latest image: it never waits.

While nothing changes after the full level, the thread traces the scene once more in its own process keeping every
pixel's ray tree (edits.py; up to EDITABLE_SAMPLES). A next scene that differs by one edit (a material, a light's
intensity, an object moved) touching at most EDIT_SHARE of the pixels then skips the coarse levels: those pixels
are traced again over the kept image, the same bytes as a whole render. (Dragging a slider is one edit after
another.) Keeping the trees is skipped where the full level took longer than EDITABLE_SECONDS per worker; while they
are kept, done is already true (the image is finished) though busy is not yet false.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..scene import scene as sc
from ..workers.parallel import Renderer
from .edits import Edit, EditableImage, edits_between

LEVELS = (8, 4, 2, 1)  # divisors of the image's width and height, coarse to fine
# Up to this many camera samples (width x height x samples) the full level's ray trees are kept afterwards (their
# size and the time to keep them: docs/measurements.md#the-tracers-constants), so that a later scene that differs by
# one small edit is answered at full size by tracing only the pixels it changes (a whole 1920x1080 view at one
# sample is under it).
EDITABLE_SAMPLES = 1 << 21
KEPT_BYTES_PER_SAMPLE = 234  # measured on the default scene (above): what the memory check counts for kept trees
# Nor when the full level took longer than this many seconds times the pool's workers: the ray trees are traced again
# in one process, and a scene of many triangles (a subdivided Suzanne) would keep them long after its image was
# done, its CPU taken from the next edit's coarse levels.
EDITABLE_SECONDS = 1.5
# An edit that changes more than this share of the pixels goes coarse to fine instead: its re-trace in one process
# would come later than the pool's first coarse level (the ground's material: 57% of the default scene's pixels).
EDIT_SHARE = 0.2
KEEP_AFTER = 0.3  # seconds between the full image and the start of keeping its ray trees (a change meanwhile: none)
# The workers run this much nicer than the program that shows their levels: drawing a level (Blender's view in
# software OpenGL, whose rasterizer threads the workers of the next levels otherwise share the cores with) comes first
WORKER_NICENESS = 10


class _SupersededError(Exception):
    pass


@dataclass(frozen=True)
class Level:
    """One finished level: image (height / divisor, width / divisor, 3) linear floats, rows from the top."""

    image: np.ndarray
    divisor: int
    generation: int  # which scene (counted from 1 as scenes are handed over)
    seconds: float  # from the scene's hand-over to this level's last band
    traced: int  # pixels traced for it: all of the level's, or those an edit could change


def level_scene(scene: sc.Scene, divisor: int) -> sc.Scene:
    """The scene at 1/divisor of its width and height (at least 1 pixel), one sample per pixel but at full size."""
    if divisor == 1:
        return scene
    settings = scene.render
    return scene.with_render(
        width=max(1, round(settings.width / divisor)), height=max(1, round(settings.height / divisor)), samples=1
    )


class ProgressiveRender:
    """Traces the latest scene handed to show() at LEVELS on a background thread with a worker pool of its own.

    on_level(level) is called on that thread after each finished level (e.g. to ask the UI for a redraw); latest()
    returns the newest finished level of the newest scene, or of an older scene until the newer one has one."""

    def __init__(
        self,
        workers: int = 0,
        start_method: str | None = None,
        on_level: Callable[[Level], None] | None = None,
        levels: tuple[int, ...] = LEVELS,
    ) -> None:
        self._workers, self._start_method = workers, start_method
        self._on_level = on_level
        self._levels = levels
        self._condition = threading.Condition()
        self._pending: tuple[sc.Scene, int, float] | None = None
        self._generation = 0
        self._latest: Level | None = None
        self._busy = False
        self._editing = False  # the newest scene is being compared with the kept ray trees, or answered from them
        self._closed = False
        self.error: str | None = None  # the last scene's failure, one line (not enough memory, a worker lost)
        self._thread = threading.Thread(target=self._run, daemon=True, name="weathervane-progressive")
        self._thread.start()

    def show(self, scene: sc.Scene, levels: tuple[int, ...] | None = None) -> int:
        """Trace scene from its coarsest level, dropping the scene being traced; returns its generation. levels:
        the divisors to trace for this scene instead of the render's own (an animation playing: (4,) alone)."""
        with self._condition:
            self._generation += 1
            self._pending = (scene, self._generation, time.perf_counter(), levels or self._levels)
            self._busy = True
            self._condition.notify()
            return self._generation

    def wait_first(self, timeout: float, editing_timeout: float = 0.0) -> bool:
        """Block up to timeout seconds until the newest scene has a level (its coarsest, or its edit at full size);
        True if it has one. A view about to be drawn waits this short while so that it draws the change itself
        instead of the previous image (a draw of a full-HD window in software OpenGL costs 0.4-0.6 s)."""

        def ready() -> bool:
            return (
                self._closed
                or self._generation == 0
                or (self._latest is not None and self._latest.generation == self._generation)
                or (not self._busy)
            )

        with self._condition:
            if self._condition.wait_for(ready, timeout):
                return True
            # the newest scene is being answered from the kept ray trees (an object moved: its pixels found from
            # them): up to editing_timeout in all, still sooner than a draw of the old image and another
            return self._editing and self._condition.wait_for(ready, max(0.0, editing_timeout - timeout))

    def latest(self) -> Level | None:
        with self._condition:
            return self._latest

    @property
    def busy(self) -> bool:
        """Whether a scene is waiting or being traced."""
        with self._condition:
            return self._busy

    @property
    def generation(self) -> int:
        """The newest scene's generation (counted from 1 as scenes are handed over; 0 before any)."""
        with self._condition:
            return self._generation

    @property
    def done(self) -> bool:
        """Whether the newest scene's full-size image is the latest level (the thread may still be keeping its ray
        trees for edits: busy, but with nothing more to show)."""
        with self._condition:
            latest = self._latest
            return latest is not None and latest.generation == self._generation and latest.divisor == 1

    @property
    def closed(self) -> bool:
        with self._condition:
            return self._closed

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the newest scene is traced to full size (or failed); False on timeout (tests, benchmarks)."""
        with self._condition:
            return self._condition.wait_for(lambda: not self._busy, timeout)

    def close(self, wait: float = 0.0) -> None:
        """Stop tracing and stop the worker pool; the thread ends after its current band or piece. wait: block up to
        this many seconds for it to end (the caller frees what the thread's work shares its process with)."""
        with self._condition:
            self._closed = True
            self._generation += 1
            self._condition.notify_all()
        if wait > 0.0 and self._thread is not threading.current_thread():
            self._thread.join(wait)

    def _run(self) -> None:
        renderer = Renderer(self._workers, start_method=self._start_method, niceness=WORKER_NICENESS)
        editable: EditableImage | None = None  # the newest full-size scene with its ray trees, for edits
        try:
            while True:
                with self._condition:
                    self._condition.wait_for(lambda: self._pending is not None or self._closed)
                    if self._closed:
                        return
                    scene, generation, handed_over, levels = self._pending
                    self._pending = None

                def check(_done: int = 0, _total: int = 0, generation: int = generation) -> None:
                    if self._generation != generation:
                        raise _SupersededError

                try:
                    with self._condition:
                        self._editing = editable is not None and self._generation == generation
                    answer = _small_edit(editable, scene)
                    with self._condition:
                        self._editing = answer is not None and self._generation == generation
                    if answer is not None:  # one material, light intensity or object place changed, a few pixels
                        edit, pixels = answer
                        if edit is not None:
                            editable.apply(edit, pixels)
                        level = Level(editable.image.copy(), 1, generation, 0.0, len(pixels))
                        self._deliver(level, handed_over)
                    else:
                        editable = None
                        full_seconds = 0.0
                        for divisor in levels:
                            started = time.perf_counter()
                            result = renderer.render(level_scene(scene, divisor), progress=check)
                            full_seconds = time.perf_counter() - started
                            count = result.image.shape[0] * result.image.shape[1]
                            self._deliver(Level(result.image, divisor, generation, 0.0, count), handed_over)
                        # the full image drawn first: keeping the trees holds the interpreter that Blender's
                        # drawing needs too (the full image came later on screen); a change meanwhile goes before
                        # them
                        if (
                            levels[-1] == 1
                            and scene.render.width * scene.render.height * scene.render.samples <= EDITABLE_SAMPLES
                            and full_seconds <= EDITABLE_SECONDS * renderer.workers
                        ):
                            with self._condition:
                                self._condition.wait_for(lambda: self._pending is not None or self._closed, KEEP_AFTER)
                            check()
                            editable = EditableImage(scene, between_pieces=check)
                    error = None
                except _SupersededError:
                    continue
                except Exception as failure:  # shown to the user as one line, the thread goes on
                    error = f"{type(failure).__name__}: {failure}" if not str(failure) else str(failure)
                    editable = None  # an edit stopped half way leaves it unlike any scene
                with self._condition:
                    if self._generation == generation:
                        self.error = error
                        self._busy = False
                        self._condition.notify_all()
        finally:
            renderer.close()
            with self._condition:
                self._busy = False
                self._condition.notify_all()

    def _deliver(self, level: Level, handed_over: float) -> None:
        """Make level the latest (its seconds counted from the scene's hand-over), unless a newer scene came."""
        level = replace(level, seconds=time.perf_counter() - handed_over)
        with self._condition:
            if self._generation != level.generation:
                raise _SupersededError
            self._latest = level
            self._condition.notify_all()  # wait_first
        if self._on_level is not None:
            self._on_level(level)


def _small_edit(editable: EditableImage | None, scene: sc.Scene) -> tuple[Edit | None, np.ndarray] | None:
    """(the edit, the flat pixels it traces again) when scene is the kept scene with at most one edit that changes
    at most EDIT_SHARE of the pixels (no edit: None and no pixels); None otherwise."""
    if editable is None:
        return None
    edits = edits_between(editable.scene, scene)
    if edits is None or len(edits) > 1:
        return None
    if not edits:
        return None, np.empty(0, dtype=np.int64)
    pixels = editable.affected(edits[0])
    return None if len(pixels) > EDIT_SHARE * editable.pixels else (edits[0], pixels)
