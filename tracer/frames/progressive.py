"""A scene -> its image coarse to fine, traced on a thread of its own: what an interactive view (Blender's Rendered
shading) shows while the user works.

Each scene is traced at LEVELS: 1/8 of the image's width and height first (1/64 of its pixels), then 1/4 and 1/2,
each with ONE sample of everything (one ray a pixel, one point on each light of a size, one glossy pair, one world
direction), then the full size in passes toward the samples asked for (`target`, the scene's own by default): every
kind of sample at min(target, 4^k) for k = 1, 2, ..., the last pass the target itself (Cycles' viewport reaches its
samples progressively the same way; its first image is one sample of everything). A newer scene supersedes the one
being traced at the next finished band, so an edit is answered by a coarse image within about one coarse level's
time, never after the rest of an old image. The caller's thread only hands scenes over and reads the latest image:
it never waits.

While nothing changes after the full level, the thread traces the scene once more in its own process keeping every
pixel's ray tree (edits.py; up to EDITABLE_SAMPLES). A next scene that differs by one edit (a material, a light's
intensity, an object moved) touching at most EDIT_SHARE of the pixels then skips the coarse levels: those pixels
are traced again over the kept image, the same bytes as a whole render. (Dragging a slider is one edit after
another.) An edit whose pixels are estimated above QUICK_EDIT_SECONDS to trace again, and any object moved (its
pixels are found by testing every kept segment), first gets the 1/8 level from the pool, so that its first image
comes as soon as any change's. Keeping the trees is skipped where the full level took longer than EDITABLE_SECONDS
per worker; while they are kept, done is already true (the image is finished) though busy is not yet false.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import astuple, dataclass, replace

import numpy as np

from ..scene import scene as sc
from ..workers.parallel import Renderer
from .edits import Edit, EditableImage, TransformEdit, edits_between

LEVELS = (8, 4, 2, 1)  # divisors of the image's width and height, coarse to fine
# Up to this many camera samples (width x height x samples, times the shadow samples where the scene has a light of a
# size: each adds a shadow segment to every hit) the full level's ray trees are kept afterwards (their size and the
# time to keep them: docs/measurements.md#the-tracers-constants), so that a later scene that differs by one small
# edit is answered at full size by tracing only the pixels it changes (a whole 1920x1080 view at one sample is under
# it; a 1321x759 view at 4 shadow samples, 820 MB kept in 3.9 s in the caller's process, is not).
EDITABLE_SAMPLES = 1 << 21
KEPT_BYTES_PER_SAMPLE = 234  # measured on the default scene (above): what the memory check counts for kept trees
# Nor when the full level took longer than this many seconds times the pool's workers: the ray trees are traced again
# in one process, and a scene of many triangles (a subdivided Suzanne) would keep them long after its image was
# done, its CPU taken from the next edit's coarse levels.
EDITABLE_SECONDS = 1.5
# An edit that changes more than this share of the pixels goes coarse to fine instead: its re-trace in one process
# would come later than the pool's first coarse level (the ground's material: 57% of the default scene's pixels).
EDIT_SHARE = 0.2
# An edit answered from the kept trees whose pixels' estimated time (their segments at the time a segment took to keep)
# is above this shows the 1/8 level first. The estimate is 3-4x short of the trace: a tail fin's colour 0.019 s
# (traced in 0.053 s), a glass sphere's IOR (19,000 pixels, many segments through a mesh) 0.12 s (traced in 0.51 s).
QUICK_EDIT_SECONDS = 0.05
KEEP_AFTER = 0.3  # seconds between the full image and the start of keeping its ray trees (a change meanwhile: none)
# The workers run this much nicer than the program that shows their levels: drawing a level (Blender's view in
# software OpenGL, whose rasterizer threads the workers of the next levels otherwise share the cores with) comes first
WORKER_NICENESS = 10


class _SupersededError(Exception):
    pass


@dataclass(frozen=True)
class Samples:
    """How many samples of each kind a pass traces: rays a pixel (render.samples: antialiasing, a lens), points on
    each light of a size (render.shadow_samples), glossy pairs (render.glossy_samples: glossy lobes, rough glass,
    diffuse bounces) and directions of each world light (its samples)."""

    pixel: int = 1
    shadow: int = 1
    glossy: int = 1
    world: int = 1

    @property
    def most(self) -> int:
        return max(astuple(self))


ONE = Samples()  # one sample of everything: every coarse level, every frame of a playing animation


def scene_samples(scene: sc.Scene) -> Samples:
    """The samples the scene itself asks for (F12's)."""
    render = scene.render
    worlds = [light.samples for light in scene.lights if isinstance(light, sc.WorldLight)]
    return Samples(render.samples, render.shadow_samples, render.glossy_samples, max(worlds, default=1))


def used_samples(scene: sc.Scene, samples: Samples) -> Samples:
    """samples with 1 for each kind the scene has nothing of (no light of a size, no glossy lobe, rough glass or
    bounce, no world light): a pass with more of those would trace the same image again."""
    sized = any(
        isinstance(light, sc.AreaLight)
        or getattr(light, "radius", 0.0) > 0.0
        or (isinstance(light, sc.DirectionalLight) and light.angle > 0.0)
        for light in scene.lights
    )
    glossy = scene.render.diffuse_bounces > 0 or any(
        material.is_glossy or material.transmission_roughness > 0.0 for material in scene.materials.values()
    )
    world = any(isinstance(light, sc.WorldLight) for light in scene.lights)
    return Samples(
        samples.pixel, samples.shadow if sized else 1, samples.glossy if glossy else 1, samples.world if world else 1
    )


def with_samples(scene: sc.Scene, samples: Samples) -> sc.Scene:
    """The scene traced with these samples (its world lights' directions included)."""
    if scene_samples(scene) == samples:
        return scene
    lights = tuple(
        replace(light, samples=samples.world) if isinstance(light, sc.WorldLight) else light for light in scene.lights
    )
    render = replace(scene.render, samples=samples.pixel, shadow_samples=samples.shadow, glossy_samples=samples.glossy)
    return replace(scene, lights=lights, render=render)


def passes(target: Samples) -> tuple[Samples, ...]:
    """The full-size passes toward target: each kind at min(target, 4^k) for k = 1, 2, ... up to the target (a square
    count stays a square: 1, 4, 16, ... and the target's own)."""
    found, k = [], 1
    while not found or found[-1] != target:
        found.append(Samples(*(min(count, 4**k) for count in astuple(target))))
        k += 1
    return tuple(found)


def level_scene(scene: sc.Scene, divisor: int) -> sc.Scene:
    """The scene at 1/divisor of its width and height (at least 1 pixel) with one sample of everything; divisor 1:
    the scene itself."""
    if divisor == 1:
        return scene
    settings = scene.render
    return with_samples(scene, ONE).with_render(
        width=max(1, round(settings.width / divisor)), height=max(1, round(settings.height / divisor))
    )


@dataclass(frozen=True)
class Tracing:
    """The level being traced: its scene's generation, divisor and samples (the most of any kind, of the most the
    scene is traced to), and how many of its bands are done, of how many."""

    generation: int
    divisor: int
    sample: int
    samples: int
    done: int = 0
    total: int = 0
    started: float = 0.0  # time.perf_counter() as the level began

    def seconds_left(self, now: float) -> float:
        """The level's seconds still to trace, estimated from its bands so far at their pace (inf before the first)."""
        return (now - self.started) * (self.total - self.done) / self.done if self.done else float("inf")


@dataclass(frozen=True)
class Level:
    """One finished level: image (height / divisor, width / divisor, 3) linear floats, rows from the top."""

    image: np.ndarray
    divisor: int
    generation: int  # which scene (counted from 1 as scenes are handed over)
    seconds: float  # from the scene's hand-over to this level's last band
    traced: int  # pixels traced for it: all of the level's, or those an edit could change
    sample: int = 1  # the most samples of any kind it was traced with (of the kinds the scene has)
    samples: int = 1  # ... and the most the scene is traced to in the end
    final: bool = True  # the scene's finished image (full size, at the target's samples)


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
        self._pending: tuple[sc.Scene, int, float, tuple[int, ...], Samples | None] | None = None
        self._generation = 0
        self._latest: Level | None = None
        self._busy = False
        self._editing = False  # the newest scene is being compared with the kept ray trees, or answered from them
        self._closed = False
        self.error: str | None = None  # the last scene's failure, one line (not enough memory, a worker lost)
        self.tracing: Tracing | None = None  # the level being traced, or the last one (set band by band)
        self._thread = threading.Thread(target=self._run, daemon=True, name="weathervane-progressive")
        self._thread.start()

    def show(self, scene: sc.Scene, levels: tuple[int, ...] | None = None, target: Samples | None = None) -> int:
        """Trace scene from its coarsest level, dropping the scene being traced; returns its generation. levels:
        the divisors to trace for this scene instead of the render's own (an animation playing: (4,) alone, at one
        sample of everything). target: the samples of the full level (a viewport's own), each at most the scene's;
        the scene's own by default."""
        with self._condition:
            self._generation += 1
            self._pending = (scene, self._generation, time.perf_counter(), levels or self._levels, target)
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
            return latest is not None and latest.generation == self._generation and latest.final

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
                    scene, generation, handed_over, levels, wanted = self._pending
                    self._pending = None

                def check(_done: int = 0, _total: int = 0, generation: int = generation) -> None:
                    if self._generation != generation:
                        raise _SupersededError

                asked = scene_samples(scene) if wanted is None else wanted
                target = used_samples(scene, Samples(*map(min, astuple(asked), astuple(scene_samples(scene)))))
                final = with_samples(scene, target)
                # "Sample k/n" counts the kinds the scene has; the coarse levels are one sample of each
                steps = [(d, ONE) for d in levels if d != 1] + ([(1, s) for s in passes(target)] if 1 in levels else [])
                job = (scene, generation, handed_over, target, check)

                def trace_step(divisor: int, samples: Samples, last: bool = False, job: tuple = job) -> None:
                    self._trace_level(renderer, job, divisor, samples, last)

                try:
                    with self._condition:
                        self._editing = editable is not None and self._generation == generation
                    answer = _small_edit(editable, final) if levels[-1] == 1 else None
                    first = 0  # the steps already traced
                    if answer is not None and answer[2] and steps[0][0] != 1:  # the pool's 1/8 before a slow edit
                        trace_step(*steps[0])
                        first = 1
                        answer = _small_edit(editable, final, answer)
                    with self._condition:
                        self._editing = answer is not None and self._generation == generation
                    if answer is not None:  # one material, light intensity or object place changed, a few pixels
                        edit, pixels, _ = answer
                        if edit is not None:
                            editable.apply(edit, pixels)
                        level = Level(editable.image.copy(), 1, generation, 0.0, len(pixels), target.most,
                                      target.most)  # fmt: skip
                        self._deliver(level, handed_over)
                    else:
                        editable = None
                        full_seconds = 0.0
                        for index in range(first, len(steps)):
                            started = time.perf_counter()
                            trace_step(*steps[index], last=index == len(steps) - 1 and steps[index][0] == 1)
                            full_seconds = time.perf_counter() - started
                        # the full image drawn first: keeping the trees holds the interpreter that Blender's
                        # drawing needs too (the full image came later on screen); a change meanwhile goes before
                        # them
                        render = final.render
                        shadows = target.shadow  # 1 where the scene has no light of a size
                        if (
                            levels[-1] == 1
                            and render.width * render.height * render.samples * shadows <= EDITABLE_SAMPLES
                            and full_seconds <= EDITABLE_SECONDS * renderer.workers
                        ):
                            with self._condition:
                                self._condition.wait_for(lambda: self._pending is not None or self._closed, KEEP_AFTER)
                            check()
                            editable = EditableImage(final, between_pieces=check)
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

    def _trace_level(self, renderer: Renderer, job: tuple, divisor: int, samples: Samples, last: bool) -> None:
        """One level of job (scene, generation, hand-over time, target samples, check) on the pool, delivered; last:
        the scene's finished image."""
        scene, generation, handed_over, target, check = job

        started = time.perf_counter()

        def progress(done: int = 0, total: int = 0) -> None:
            check()
            self.tracing = Tracing(generation, divisor, samples.most, target.most, done, total, started)

        progress()
        result = renderer.render(with_samples(level_scene(scene, divisor), samples), progress=progress)
        count = result.image.shape[0] * result.image.shape[1]
        level = Level(result.image, divisor, generation, 0.0, count, samples.most, target.most, last)
        self._deliver(level, handed_over)

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


def _small_edit(
    editable: EditableImage | None, scene: sc.Scene, found: tuple | None = None
) -> tuple[Edit | None, np.ndarray, bool] | None:
    """(the edit, the flat pixels it traces again, whether the pool's first level should come first) when scene is
    the kept scene with at most one edit that changes at most EDIT_SHARE of the pixels (no edit: None and no
    pixels); None otherwise. An object moved comes first with no pixels (finding them tests every kept segment),
    as does an edit whose pixels are estimated above QUICK_EDIT_SECONDS; found: that first answer, completed."""
    if editable is None:
        return None
    if found is not None:
        edit, pixels, _ = found
    else:
        edits = edits_between(editable.scene, scene)
        if edits is None or len(edits) > 1:
            return None
        if not edits:
            return None, np.empty(0, dtype=np.int64), False
        edit = edits[0]
        if isinstance(edit, TransformEdit):
            return edit, np.empty(0, dtype=np.int64), True
        pixels = editable.affected(edit)
    if isinstance(edit, TransformEdit) and found is not None:
        pixels = editable.affected(edit)
    if len(pixels) > EDIT_SHARE * editable.pixels:
        return None
    return edit, pixels, found is None and editable.seconds_for(pixels) > QUICK_EDIT_SECONDS
