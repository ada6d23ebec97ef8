"""A scene -> a linear float image, in bands of rows over a persistent pool of worker processes.

A band is every B-th block of rows of the image, so that every band holds a like share of sky, ground and object
and the workers finish together. The bands depend only on the image (never on the number of
workers) and each is traced by the same code, so the image is bit-identical for any number of workers. Memory stays
bounded by the band.
"""

from __future__ import annotations

import ctypes
import math
import mmap
import multiprocessing
import os
import pickle
import time
import uuid
import weakref
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from ..geometry.camera import border_window
from ..geometry.cull import GRID_BOXES
from ..geometry.footprint import Volume
from ..scene import scene as sc
from ..tracing.recorder import plane_dtype, plane_shape
from ..tracing.wavefront import RayCounts, TracedScene
from . import adaptive, shutter
from .pool import PoolClosedError, Task, WorkerPool
from .resources import band_samples, check_resources

BLOCK_ROWS = 16
Item = TypeVar("Item")
# An animation's frames whose pixels are traced again go to the workers this many at a time, traced together
# (TracedScene with headings): such a frame traces a few thousand pixels, and much of its own trace's time is fixed
# cost (preparing the scene, the NumPy calls of every bounce), which a batch pays once. 8 was the fastest of 1, 4, 8
# and 12 on the default animation; more frames make more boxes for every light's grid to tell apart
# (docs/measurements.md#the-tracers-constants).
FRAMES_PER_TASK = 8

Progress = Callable[[int, int], None]
BandDone = Callable[[np.ndarray, np.ndarray], None]  # (the frame's image so far, the rows just finished)


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def worker_count(requested: int) -> int:
    """The processes a render uses for a requested count (0: all cores)."""
    return requested if requested > 0 else default_workers()


def bands(settings: sc.RenderSettings) -> list[np.ndarray]:
    """The image's rows (arrays of row indices) dealt into bands of at most about band_samples() samples.

    Rows go in blocks of BLOCK_ROWS, dealt round-robin, so each band holds a like share of sky, ground and object
    (the workers finish together) while its rays stay coherent enough for the hierarchy (a fully interleaved deal
    was about 35% slower here). The number of bands is even, so that 1 or 2 workers get equal shares, and as small
    as the memory bound allows: each band costs fixed NumPy overhead (one worker, a float32 frame at 640x480 before
    later work: 1 band 123 ms, 2 bands 138 ms, 4 bands 162 ms). It depends only on the image and the dtype.
    """
    samples = settings.height * settings.width * settings.samples
    blocks = [
        np.arange(start, min(start + BLOCK_ROWS, settings.height)) for start in range(0, settings.height, BLOCK_ROWS)
    ]
    count = min(len(blocks), 2 * math.ceil(samples / band_samples(settings) / 2))
    return [np.concatenate(blocks[first::count]) for first in range(count)]


@dataclass
class RenderResult:
    image: np.ndarray  # (height, width, 3) linear RGB, unclamped, in the scene's dtype
    rays: RayCounts
    seconds: float
    touched: np.ndarray | None = None  # (height, width) bool: pixels whose ray trees met the volume asked about
    # (height, width): the share of each pixel's camera samples that met a visible object other than a holdout (0
    # outside a render border); None where the scene has no transparent film, no holdout and no uncropped border
    # (Scene.has_alpha). The colours are then premultiplied by it (a missing sample adds 0).
    alpha: np.ndarray | None = None
    # (base, flat pixels (P,)): the image is base (the array given to render_pixels) with those pixels traced again
    # and every other pixel base's; None for a whole frame. A writer can then convert only those pixels to 8 bits.
    retraced: tuple[np.ndarray, np.ndarray] | None = None
    # pass name -> (height, width, channels) for the settings' passes (tracer/scene/passes.py), in the scene's dtype
    # (Cryptomatte's in float32): views of planar arrays, each channel a contiguous (height, width) plane
    passes: dict[str, np.ndarray] | None = None
    adaptive: float | None = None  # adaptive sampling: the share of pixels traced at the full count (else None)

    @property
    def mrays_per_second(self) -> float:
        return self.rays.total / self.seconds / 1e6 if self.seconds > 0 else 0.0


_allocator_tuned = False


def tune_allocator() -> None:
    """Keep freed arrays' memory in the process (glibc only; elsewhere a no-op).

    Each bounce allocates and frees arrays of about a megabyte. By default glibc returns such blocks to the system
    and the next array of the same size page-faults its way back in, which cost about half of the frame time here
    (a 3 x 65536 slab test: 5.3 ms with the defaults, 0.65 ms with these settings). The memory stays bounded by
    the band size.
    """
    global _allocator_tuned
    if _allocator_tuned:
        return
    _allocator_tuned = True
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return
    m_trim_threshold, m_mmap_threshold = -1, -3
    libc.mallopt(m_mmap_threshold, 32 * 1024 * 1024)  # glibc's largest allowed value
    libc.mallopt(m_trim_threshold, 256 * 1024 * 1024)


# ---- worker side -------------------------------------------------------------------------------------------------

_worker_cache: dict[str, object] = {}


def _result(
    image: np.ndarray,
    counts: RayCounts,
    seconds: float,
    touched: np.ndarray | None = None,
    settings: sc.RenderSettings | None = None,
    planes: dict[str, np.ndarray] | None = None,
) -> RenderResult:
    """A RenderResult from an image of 3 channels, or of 4 (colour and alpha) where the scene has an alpha, and the
    passes' planar (channels, height, width) arrays; cut to the render border where the settings crop to it."""
    if settings is not None and settings.crop and settings.border is not None:
        x0, x1, y0, y1 = border_window(settings)
        image = image[y0:y1, x0:x1]
        touched = None if touched is None else touched[y0:y1, x0:x1]
        if image.shape[-1] == 3:
            image = np.ascontiguousarray(image)
        if planes is not None:
            planes = {name: plane[:, y0:y1, x0:x1] for name, plane in planes.items()}
    found = None if planes is None else {name: np.moveaxis(plane, 0, -1) for name, plane in planes.items()}
    if image.shape[-1] == 4:
        result = RenderResult(np.ascontiguousarray(image[..., :3]), counts, seconds, touched, image[..., 3].copy())
    else:
        result = RenderResult(np.ascontiguousarray(image), counts, seconds, touched)
    result.passes = found
    return result


def _colour(image: np.ndarray) -> np.ndarray:
    """The colour channels of an image being traced (what band_done shows)."""
    return image if image.shape[-1] == 3 else image[..., :3]


@dataclass(frozen=True)
class _SceneMessage:
    """A scene as a task carries it. key: what names it (the same key, the same scene: a worker keeps what it
    prepared for it). pickled: the whole pickle; or, with offsets (a scene with large arrays: a mesh), the pickle
    without its arrays, which are in a shared file (the task's first descriptor) at these offsets, so that a task
    carries no copy of them and every worker maps the same pages."""

    key: bytes
    pickled: bytes
    offsets: tuple[tuple[int, int], ...] | None = None  # (offset, bytes) of each out-of-band buffer in the file


def _prepared_for(
    scene: _SceneMessage, descriptors: tuple[int, ...], headings: tuple[float, ...] | None = None
) -> tuple[TracedScene, tuple[int, ...]]:
    """The prepared scene (with the vane's parts at headings, where given: TracedScene), rebuilt only when the
    scene or the headings changed since the last task (a few ms per build; seconds for a million-triangle mesh),
    and the descriptors the scene did not use. The scene itself is unpickled only when it changed: frames at other
    headings keep its objects, and with them what TracedScene keeps by object."""
    if scene.offsets is not None:
        file, descriptors = descriptors[0], descriptors[1:]
    if _worker_cache.get("scene") != (scene.key, headings):
        tune_allocator()
        _worker_cache.pop("prepared", None)  # the last scene's kernels go before the next one's are built
        loaded = _worker_cache.get("loaded")
        if loaded is None or loaded[0] != scene.key:
            _worker_cache.pop("loaded", None)
            if scene.offsets is None:
                loaded = (scene.key, pickle.loads(scene.pickled))
            else:
                # read-only arrays on the shared pages themselves: no copy in any worker
                mapping = memoryview(mmap.mmap(file, 0, access=mmap.ACCESS_READ))
                buffers = [mapping[start : start + size] for start, size in scene.offsets]
                loaded = (scene.key, pickle.loads(scene.pickled, buffers=buffers))
            _worker_cache["loaded"] = loaded
        _worker_cache["scene"] = (scene.key, headings)
        _worker_cache["prepared"] = TracedScene(loaded[1], headings)
    prepared = _worker_cache["prepared"]
    assert isinstance(prepared, TracedScene)
    return prepared, descriptors


def _render_band(
    scene: _SceneMessage,
    rows: np.ndarray,
    shape: tuple[int, int, int],
    dtype: str,
    volume: Volume | None = None,
    keep: bool = False,
    *descriptors: int,
) -> tuple[np.ndarray | None, RayCounts, np.ndarray | None]:
    """Trace rows (R,) of the scene; the band (R, W, 3) goes into the shared image (the descriptor after the
    scene's, if any) or comes back, with (R, W) touched where a volume is given (footprint.py). keep: the image's
    file is one the parent reuses. The scene's passes go straight into their planes in the shared file (_planes), or
    come back as the band's rows of them (each (channels, R, W)) after the band."""
    prepared, descriptors = _prepared_for(scene, descriptors)
    image = descriptors[0] if descriptors else None
    settings = prepared.scene.render
    touched = None if volume is None else np.zeros((len(rows), shape[1]), dtype=bool)
    if image is None:
        planes = None
        if settings.passes:
            planes = {
                name: np.empty(plane_shape(name, *shape[:2], settings.cryptomatte_levels), plane_dtype(name, dtype))
                for name in settings.passes
            }
        band, counts = prepared.render_rows(rows, band_samples(settings), volume, touched, planes)
        if planes is None:
            return band, counts, touched
        return (band, {name: plane[:, rows] for name, plane in planes.items()}), counts, touched
    mapping = _mapped(image, keep)
    planes = {name: np.ndarray(size, where, mapping, offset) for name, offset, size, where in _planes(settings, shape)}
    band, counts = prepared.render_rows(rows, band_samples(settings), volume, touched, planes or None)
    shared = np.ndarray(shape, dtype=dtype, buffer=mapping)
    shared[rows] = band
    del shared, planes  # the mapping closes only when no array uses it
    if not keep:
        mapping.close()
    return None, counts, touched


def _mapped(descriptor: int, keep: bool) -> mmap.mmap:
    """The shared image file as a mapping. keep: the parent reuses this file for later frames (a small image), so
    the mapping stays between bands: writing through a fresh mapping page-faults on every page (about 2.5 ms per
    band of the 640x480 float64 frame here), through a kept one it does not (0.1 ms). One such mapping is kept."""
    status = os.fstat(descriptor)
    key = (status.st_dev, status.st_ino, status.st_size)
    kept = _worker_cache.get("mapping")
    if keep and kept is not None and kept[0] == key:
        return kept[1]
    # not MAP_POPULATE: a large image goes in many bands, and each band would map all of the image's pages (slower
    # and larger at 1920x1080: docs/measurements.md#the-tracers-constants)
    mapping = mmap.mmap(descriptor, 0)
    if keep:
        if kept is not None:
            kept[1].close()
        _worker_cache["mapping"] = (key, mapping)
    return mapping


def _planes(settings: sc.RenderSettings, shape: tuple[int, int, int]) -> list[tuple[str, int, tuple, np.dtype]]:
    """Where the passes' planar arrays lie in a frame's shared file, after its image (shape, in the settings' dtype):
    (pass name, offset in bytes, plane shape, dtype) each, aligned as NumPy's own allocations."""
    end = math.prod(shape) * np.dtype(settings.dtype).itemsize
    out = []
    for name in settings.passes:
        end = -(-end // BUFFER_ALIGNMENT) * BUFFER_ALIGNMENT
        size = plane_shape(name, *shape[:2], settings.cryptomatte_levels)
        dtype = plane_dtype(name, settings.dtype)
        out.append((name, end, size, dtype))
        end += math.prod(size) * dtype.itemsize
    return out


def _render_pixels(scene: _SceneMessage, pixels: np.ndarray, *descriptors: int) -> tuple[np.ndarray, RayCounts]:
    """Trace the flat pixels (P,) of the scene: their colours (P, 3)."""
    prepared, _ = _prepared_for(scene, descriptors)
    return prepared.render_pixels(pixels, band_samples(prepared.scene.render))


def _render_frame_pixels(
    scene: _SceneMessage, headings: tuple[float, ...], frame_pixels: list[np.ndarray], *descriptors: int
) -> list[tuple[np.ndarray, RayCounts]]:
    """Trace each frame's flat pixels (P_k,) in the scene with its vane at headings[k]: their colours (P_k, 3) and
    ray counts, all frames in one trace (TracedScene.render_frame_pixels)."""
    prepared, _ = _prepared_for(scene, descriptors, headings)
    return prepared.render_frame_pixels(frame_pixels, band_samples(prepared.scene.render))


# ---- parent side -------------------------------------------------------------------------------------------------


class Renderer:
    """Renders scenes with a pool of worker processes kept alive between frames (use as a context manager).

    Where the system has anonymous shared memory (Linux's memfd), each frame's image is such a file that the
    workers map and write their bands into and that the returned array maps in turn: bands are not copied through
    pipes, the image is never copied at all (at 1920x1080 in float64 that is 50 MB less at the peak), and the file
    has no name, so nothing outlives the processes however they end. Elsewhere bands come back pickled.
    A worker that dies (killed, out of memory) has its bands traced again by a fresh one (tracer/workers/pool.py).
    """

    def __init__(self, workers: int = 0, start_method: str | None = None, niceness: int = 0) -> None:
        """start_method: how worker processes start ("fork", "spawn"); None: fork where the system has it (fast,
        and safe in a single-threaded program like the command line; a program with threads of its own, such as
        Blender, asks for "spawn"). niceness: the workers' priority below this process's (pool.WorkerPool)."""
        self.workers = worker_count(workers)
        self._niceness = niceness
        self._pool: WorkerPool | None = None
        self._prepared: tuple[bytes, tuple[float, ...] | None, TracedScene] | None = None
        default = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
        self._start_method = start_method or default
        self._images = _SharedImages() if hasattr(os, "memfd_create") else None
        self._scenes = _SharedScenes(hasattr(os, "memfd_create"))
        self._final = False  # closed for good: no pool is started again
        # called about every 0.1 s while a render waits on its workers with no band finished (a large scene's
        # preparation): raising there stops the render, as raising from progress does after a band
        self.heartbeat: Callable[[], None] | None = None

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self, final: bool = False) -> None:
        """Stop the workers (a later render starts them again, unless final: it then raises PoolClosedError, as
        does a render waiting on them in another thread)."""
        self._final = self._final or final
        if self._pool is not None:
            self._pool.close()
            self._pool = None
        if self._images is not None:
            self._images.close()
        self._scenes.close()

    def _start_pool(self) -> WorkerPool:
        if self._final:
            raise PoolClosedError("the renderer is closed")
        if self._pool is None:
            self._pool = WorkerPool(self.workers, self._start_method, self._private_descriptors, self._niceness)
            self._pool.heartbeat = self._beat
        return self._pool

    def _beat(self) -> None:
        if self.heartbeat is not None:
            self.heartbeat()

    def _private_descriptors(self) -> list[int]:
        """The files this Renderer keeps open (images used again, the current scene's arrays): a forked worker
        closes its copies."""
        return (self._images.descriptors() if self._images is not None else []) + self._scenes.descriptors()

    def render(
        self,
        scene: sc.Scene,
        progress: Progress | None = None,
        volume: Volume | None = None,
        band_done: BandDone | None = None,
    ) -> RenderResult:
        """Trace the whole image; progress(bands_done, bands_total) is called as bands finish, and band_done(image,
        rows) with the image so far (a display that draws bands as they come). volume: also tell which pixels' ray
        trees meet it (RenderResult.touched; footprint.py).

        An exception from progress (a cancelled render) stops the frame; the pool stays usable. With adaptive
        sampling (render.adaptive_threshold) the frame is adaptive.render's two passes (volume: not recorded); with
        objects or a camera that move over the shutter (their poses), shutter.render's time slices."""
        if shutter.steps(scene) > 1:
            return shutter.render(lambda part, told, _: self.render(part, told, volume), scene, progress, band_done)
        if any(obj.poses for obj in scene.objects) or scene.camera.poses:
            scene = shutter.still(scene)  # poses all alike: the same bytes as without them
        if adaptive.applies(scene.render) and volume is None:
            started = time.perf_counter()
            # one count over every pass: the first pass's bands (and its steady pass's), then the runs of the
            # pixels traced again; the steady pass is not shown
            pieces = self.pixel_pieces(scene.render)
            first_bands = len(bands(scene.with_render(samples=adaptive.base_samples(scene.render.samples)).render))
            total = first_bands * (2 if adaptive.steadied(scene) else 1) + pieces
            after = None
            if progress is not None:
                after = lambda done, count: progress(total - count + done, total)  # noqa: E731

            def whole(first: sc.Scene, index: int) -> RenderResult:
                told = None if progress is None else lambda done, _: progress(index * first_bands + done, total)
                return self.render(first, told, None, band_done if index == 0 else None)

            image, rays, share = adaptive.render(
                whole,
                lambda full, pixels, base: self.render_pixels(full, pixels, base, after, band_done, pieces),
                scene,
            )
            result = _result(image, rays, time.perf_counter() - started)
            result.adaptive = share
            return result
        check_resources(scene.render, self.workers)
        if self.workers > 1:
            self._start_pool()
            return self._submit(scene, volume).finish(progress, band_done)
        settings = scene.render
        started = time.perf_counter()
        prepared = self._prepared_here(scene)
        image = np.empty((settings.height, settings.width, prepared.channels), dtype=settings.dtype)
        planes = None
        if settings.passes:
            planes = {
                name: np.empty(
                    plane_shape(name, settings.height, settings.width, settings.cryptomatte_levels),
                    plane_dtype(name, settings.dtype),
                )
                for name in settings.passes
            }
        touched = None if volume is None else np.zeros((settings.height, settings.width), dtype=bool)
        counts = RayCounts()
        every = bands(settings)
        for done, rows in enumerate(every, 1):
            band_touched = None if touched is None else np.zeros((len(rows), settings.width), dtype=bool)
            image[rows], band_counts = prepared.render_rows(rows, band_samples(settings), volume, band_touched, planes)
            if touched is not None:
                touched[rows] = band_touched
            counts.add(band_counts)
            if band_done is not None:
                band_done(_colour(image), rows)
            if progress is not None:
                progress(done, len(every))
        return _result(image, counts, time.perf_counter() - started, touched, settings, planes)

    def _prepared_here(self, scene: sc.Scene, headings: tuple[float, ...] | None = None) -> TracedScene:
        """The scene prepared in this process (one worker), with the vane at headings where given, kept while both
        stay the same."""
        tune_allocator()
        scene_bytes = pickle.dumps(scene)
        if self._prepared is None or self._prepared[:2] != (scene_bytes, headings):
            self._prepared = None  # the last scene's kernels go before the next one's are built
            self._prepared = (scene_bytes, headings, TracedScene(scene, headings))
        return self._prepared[2]

    def render_pixels(
        self,
        scene: sc.Scene,
        pixels: np.ndarray,
        base: np.ndarray,
        progress: Progress | None = None,
        band_done: BandDone | None = None,
        pieces: int | None = None,
    ) -> RenderResult:
        """The image base (height, width, 3), or (height, width, 4) with alpha for a scene that has one, with the
        flat pixels (P,) traced again in scene: bit for bit the scene's whole image where no other pixel can differ
        from base (footprint.py). pieces: traced in that many runs of the pixels (at most one a pixel), each told to
        progress(done, runs) and band_done(image so far, its rows) as it finishes (an adaptive F12's second pass,
        which a display follows as it follows bands); None: a run per worker."""
        count = min(len(pixels), self.workers if pieces is None else pieces)
        runs = np.array_split(np.asarray(pixels), count) if count else []
        if self.workers > 1:
            self._start_pool()
            return self._submit_pixels(scene, runs, base, pixels).finish(progress, band_done)
        started = time.perf_counter()
        image = base.copy()
        flat = image.reshape(-1, image.shape[-1])
        counts = RayCounts()
        prepared = self._prepared_here(scene) if runs else None  # no pixels: the image is base, nothing to prepare
        for done, run in enumerate(runs, 1):
            colors, run_counts = prepared.render_pixels(run, band_samples(scene.render))
            flat[run] = colors[:, : image.shape[-1]]
            counts.add(run_counts)
            if band_done is not None:
                band_done(_colour(image), np.unique(run // image.shape[1]))
            if progress is not None:
                progress(done, len(runs))
        result = _result(image, counts, time.perf_counter() - started)
        result.retraced = (base, np.asarray(pixels))
        return result

    def pixel_pieces(self, settings: sc.RenderSettings) -> int:
        """The runs an adaptive frame's second pass is traced in: as many as its bands, at least one a worker."""
        return max(len(bands(settings)), self.workers)

    def render_frames(self, scenes: Iterable[sc.Scene]) -> Iterator[RenderResult]:
        """render() for each scene in turn, results in order. With workers the next frame's bands wait in the
        pool's queue while the current frame finishes, so no worker idles between frames (an animation)."""
        if self.workers <= 1:
            for scene in scenes:
                yield self.render(scene)
            return

        def submitted() -> Iterator[_Frame]:
            for scene in scenes:
                check_resources(scene.render, self.workers, frames=2)
                yield self._submit(scene)

        yield from self._pipelined(submitted(), 2)  # one frame traced, one queued: memory stays at two images

    def render_pixel_frames(
        self, scene: sc.Scene, frames: Iterable[tuple[float, np.ndarray]], base: np.ndarray
    ) -> Iterator[RenderResult]:
        """render_pixels(scene with its vane at heading, pixels, base) for each (heading, pixels) in turn, results in
        order. The frames go FRAMES_PER_TASK at a time, each batch in one trace (TracedScene with headings); with
        workers a batch is one task, and as many batches as workers (and one more, queued) are traced at once: such
        a frame is small, and most of its time is the fixed cost of a trace, which a batch pays once and splitting
        would pay again in every worker."""
        if self.workers <= 1:
            for batch in batches(frames, frames_per_task(scene)):
                started = time.perf_counter()
                prepared = self._prepared_here(scene, tuple(heading for heading, _ in batch))
                traced = prepared.render_frame_pixels([pixels for _, pixels in batch], band_samples(scene.render))
                yield from _pixel_results(base, batch, traced, time.perf_counter() - started)
            return
        pool = self._start_pool()
        pending: deque[_FrameBatch] = deque()
        try:
            for batch in batches(frames, frames_per_task(scene)):
                message, scene_file = self._scenes.message(scene)
                descriptors = () if scene_file is None else (scene_file.descriptor,)
                headings = tuple(heading for heading, _ in batch)
                task = pool.submit(_render_frame_pixels, (message, headings, [p for _, p in batch]), descriptors)
                pending.append(_FrameBatch(pool, task, batch, base, time.perf_counter(), scene_file))
                if len(pending) == self.workers + 1:
                    yield from pending.popleft().finish()
            while pending:
                yield from pending.popleft().finish()
        finally:
            for frame_batch in pending:  # stopped early
                frame_batch.abandon()

    def map(self, function: Callable, arguments: Iterable[tuple]) -> list:
        """function(*args) for each args, on the workers (in this process with one worker); the results in order.
        function must be importable by the workers (a module's top-level function)."""
        if self.workers <= 1:
            return [function(*args) for args in arguments]
        pool = self._start_pool()
        tasks = [pool.submit(function, args) for args in arguments]
        try:
            for _ in pool.as_completed(tasks):
                pass
        finally:
            pool.cancel(tasks)
        return [task.value() for task in tasks]

    def _pipelined(self, frames: Iterator[_Frame], depth: int) -> Iterator[RenderResult]:
        """The frames' results in order, with up to depth frames in the pool at once."""
        self._start_pool()
        pending: deque[_Frame] = deque()
        try:
            for frame in frames:
                pending.append(frame)
                if len(pending) == depth:
                    yield pending.popleft().finish()
            while pending:
                yield pending.popleft().finish()
        finally:
            for frame in pending:  # stopped early
                frame.abandon()

    def _submit(self, scene: sc.Scene, volume: Volume | None = None) -> _Frame:
        pool = self._start_pool()
        settings = scene.render
        shape = (settings.height, settings.width, 4 if scene.has_alpha else 3)
        dtype = np.dtype(settings.dtype)
        started = time.perf_counter()
        layout = _planes(settings, shape)
        image_size = math.prod(shape) * dtype.itemsize
        size = image_size if not layout else layout[-1][1] + math.prod(layout[-1][2]) * layout[-1][3].itemsize
        shared = self._images.take(size, image_size) if self._images is not None else None
        image = np.empty(shape, dtype) if shared is None else shared.array(shape, dtype)
        planes = None
        if layout:
            if shared is None:
                planes = {name: np.empty(size, where) for name, _, size, where in layout}
            else:
                planes = {name: shared.array(size, where, offset) for name, offset, size, where in layout}
        descriptor = None if shared is None else shared.descriptor
        keep = shared is not None and shared.kept
        message, scene_file = self._scenes.message(scene)
        descriptors = (() if scene_file is None else (scene_file.descriptor,)) + (
            () if descriptor is None else (descriptor,)
        )
        tasks = [
            (rows, pool.submit(_render_band, (message, rows, shape, dtype.str, volume, keep), descriptors))
            for rows in bands(settings)
        ]
        touched = None if volume is None else np.zeros(shape[:2], dtype=bool)
        frame = _Frame(pool, image, tasks, shared, started, touched, settings=settings, scene_file=scene_file)
        frame.planes = planes
        return frame

    def _submit_pixels(self, scene: sc.Scene, runs: list[np.ndarray], base: np.ndarray, pixels: np.ndarray) -> _Frame:
        """A frame of base with pixels traced again, a task for each run of them (none for no pixels)."""
        pool = self._start_pool()
        started = time.perf_counter()
        message, scene_file = self._scenes.message(scene)
        descriptors = () if scene_file is None else (scene_file.descriptor,)
        tasks = [(run, pool.submit(_render_pixels, (message, run), descriptors)) for run in runs]
        base_pixels = (base, np.asarray(pixels))
        return _Frame(pool, base.copy(), tasks, None, started, pixels=True, base=base_pixels, scene_file=scene_file)


def frames_per_task(scene: sc.Scene) -> int:
    """FRAMES_PER_TASK, or fewer where the parts' copies would take a scene's boxes past those a light's coverage
    grid tells apart (cull.GRID_BOXES: beyond, every shadow ray that meets any box would go to every kernel)."""
    parts = sum(obj.name in scene.vane.parts for obj in scene.objects) if scene.vane is not None else 0
    room = GRID_BOXES - (len(scene.objects) - parts)
    return max(1, min(FRAMES_PER_TASK, room // max(1, parts)))


def batches(items: Iterable[Item], size: int) -> Iterator[list[Item]]:
    """Items -> consecutive lists of size of them, in order (the last may be shorter), taken as they are asked for
    (itertools.batched from Python 3.12 on)."""
    batch: list[Item] = []
    for item in items:
        batch.append(item)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


def _pixel_results(
    base: np.ndarray, batch: list[tuple[float, np.ndarray]], traced: list[tuple[np.ndarray, RayCounts]], seconds: float
) -> Iterator[RenderResult]:
    """Each frame of a batch as base (height, width, channels) with its pixels' colours traced again; seconds: the
    batch's, shared among its frames."""
    for (_, pixels), (colors, counts) in zip(batch, traced, strict=True):
        image = base.copy()
        image.reshape(-1, image.shape[-1])[pixels] = colors[:, : image.shape[-1]]
        result = _result(image, counts, seconds / len(batch))
        result.retraced = (base, np.asarray(pixels))
        yield result


@dataclass
class _FrameBatch:
    """Frames whose pixels are traced again in one task of the pool (Renderer.render_pixel_frames)."""

    pool: WorkerPool
    task: Task
    batch: list[tuple[float, np.ndarray]]  # (heading, flat pixels) of each frame
    base: np.ndarray
    started: float
    scene_file: _SceneFile | None = None

    def finish(self) -> Iterator[RenderResult]:
        try:
            for _ in self.pool.as_completed([self.task]):
                pass
            traced = self.task.result
        finally:
            self.abandon()
        return _pixel_results(self.base, self.batch, traced, time.perf_counter() - self.started)

    def abandon(self) -> None:
        self.pool.cancel([self.task])
        if self.scene_file is not None:
            self.scene_file.release()
            self.scene_file = None


@dataclass
class _Frame:
    """A frame whose bands are in the pool: its image, the bands' tasks, the shared image's file."""

    pool: WorkerPool
    image: np.ndarray
    tasks: list[tuple[np.ndarray, Task]]  # (rows of a band, or flat pixels where pixels is set; its task)
    shared: _SharedImage | None
    started: float
    touched: np.ndarray | None = None
    pixels: bool = False
    settings: sc.RenderSettings | None = None  # a whole frame's: its render border may crop the image
    base: tuple[np.ndarray, np.ndarray] | None = None  # a pixel frame's base and pixels (RenderResult.retraced)
    scene_file: _SceneFile | None = None  # the shared file of the scene's arrays that the tasks carry
    planes: dict[str, np.ndarray] | None = None  # the passes' planar arrays (where the workers write them)

    def finish(self, progress: Progress | None = None, band_done: BandDone | None = None) -> RenderResult:
        counts = RayCounts()
        where = {id(task): rows for rows, task in self.tasks}
        try:
            for done, task in enumerate(self.pool.as_completed([task for _, task in self.tasks]), 1):
                if self.pixels:
                    colors, piece_counts = task.result
                    channels = self.image.shape[-1]  # 4 where base carries alpha
                    self.image.reshape(-1, channels)[where[id(task)]] = colors[:, :channels]
                    if band_done is not None:
                        band_done(_colour(self.image), np.unique(where[id(task)] // self.image.shape[1]))
                else:
                    band, piece_counts, band_touched = task.result
                    if isinstance(band, tuple):  # no shared file: the band's rows of the passes came back too
                        band, band_planes = band
                        for name, values in band_planes.items():
                            self.planes[name][:, where[id(task)]] = values
                    if band is not None:
                        self.image[where[id(task)]] = band
                    if self.touched is not None:
                        self.touched[where[id(task)]] = band_touched
                    if band_done is not None:
                        band_done(_colour(self.image), where[id(task)])
                counts.add(piece_counts)
                if progress is not None:
                    progress(done, len(self.tasks))
        finally:
            self.abandon()
        seconds = time.perf_counter() - self.started
        result = _result(self.image, counts, seconds, self.touched, self.settings, self.planes)
        result.retraced = self.base
        return result

    def abandon(self) -> None:
        """Forget the bands not yet finished (their workers may still write into the image: it is this frame's own
        file, which goes when the last process lets go of it)."""
        self.pool.cancel(task for _, task in self.tasks)
        if self.shared is not None:
            # a file may be used again only once no worker can write into it any more: every band done
            self.shared.release(finished=all(task.done for _, task in self.tasks))
            self.shared = None
        if self.scene_file is not None:  # no task of this frame is sent any more: its descriptor may close
            self.scene_file.release()
            self.scene_file = None


# Image files of at most this size are kept by a Renderer and used again for later frames once nothing uses the
# last frame's image (two kept: a caller holds one frame's result while the next is traced). A new file costs its
# allocation and zeroing, page faults in every process that maps it and its release (each a few ms at 640x480:
# docs/measurements.md#the-tracers-constants); a kept one none of these. Larger images get a file each, so that
# memory at 1920x1080 stays at one image. The size is the image's: a file with render passes beside the image is
# kept by its image's size, up to KEEP_FILE_BYTES in all (every pass of a 640x480 float64 frame fits)
KEEP_IMAGE_BYTES = 16 << 20
KEEP_FILE_BYTES = 128 << 20
KEEP_IMAGES = 2


class _SharedImage:
    """An anonymous shared-memory file (Linux's memfd) for a frame's image: a descriptor to hand to workers and the
    parent's mapping of it."""

    def __init__(self, size: int, kept: bool) -> None:
        self.size, self.kept = size, kept
        self.descriptor: int | None = os.memfd_create("weathervane-image", os.MFD_CLOEXEC)
        try:
            os.posix_fallocate(self.descriptor, 0, size)  # no memory fails here, not as a crash when a worker writes
            self.mapping = mmap.mmap(self.descriptor, size)
        except BaseException:
            os.close(self.descriptor)
            raise
        self.users: list[weakref.ref] = []  # the arrays of the frame that uses it last (its image and passes)
        self.busy = False  # a frame's bands may still write into it

    def free(self) -> bool:
        return not self.busy and all(user() is None for user in self.users)

    def array(self, shape: tuple[int, ...], dtype: np.dtype, offset: int = 0) -> np.ndarray:
        """An array on the file at offset; the file is in use (busy) until every such array of the frame is gone."""
        array = np.ndarray(shape, dtype, buffer=self.mapping, offset=offset)
        if offset == 0:
            self.users, self.busy = [], True
        self.users.append(weakref.ref(array))
        return array

    def release(self, finished: bool) -> None:
        """The frame is done with the file (finished: every band written, none still running)."""
        self.busy = not finished
        if not (self.kept and finished):
            self.kept = False
            self.close()

    def close(self) -> None:
        """Let the file go: it goes when the last process (and array) lets go of it."""
        if self.descriptor is not None:
            os.close(self.descriptor)
            self.descriptor = None
        self.mapping = None  # the frames' arrays keep their mapping alive


class _SharedImages:
    """A Renderer's image files: KEEP_IMAGES small ones used again, larger ones one per frame."""

    def __init__(self) -> None:
        self.kept: list[_SharedImage] = []

    def take(self, size: int, image_size: int | None = None) -> _SharedImage:
        """A file of size bytes, one kept where the frame's image (image_size bytes; None: size) is small."""
        self.kept = [image for image in self.kept if image.kept]  # those released unfinished are gone
        for image in self.kept:
            if image.size == size and image.free():
                return image
        keep = (size if image_size is None else image_size) <= KEEP_IMAGE_BYTES and size <= KEEP_FILE_BYTES
        if keep and len(self.kept) >= KEEP_IMAGES:  # the other size now: the oldest free one makes room
            free = [image for image in self.kept if image.free()]
            if free:
                free[0].kept = False
                free[0].close()
                self.kept.remove(free[0])
            else:
                keep = False
        image = _SharedImage(size, keep)
        if keep:
            self.kept.append(image)
        return image

    def descriptors(self) -> list[int]:
        return [image.descriptor for image in self.kept if image.descriptor is not None]

    def close(self) -> None:
        for image in self.kept:
            image.kept = False
            image.close()
        self.kept = []


# A scene whose arrays (a mesh's) are larger than this goes to the workers as a pickle without them and one shared file
# that holds them: a million-triangle mesh's 36 MB pickled into every task was copied through each worker's pipe and
# kept, unpickled, once more in each worker.
SHARED_SCENE_BYTES = 1 << 20
BUFFER_ALIGNMENT = 64  # each array's offset in the file: aligned as NumPy's own allocations


class _SceneFile:
    """A large scene's arrays in an anonymous shared file (memfd), each at an aligned offset. It stays open while
    it is the Renderer's current one or a frame's tasks may still carry its descriptor (users)."""

    def __init__(self, views: list[memoryview]) -> None:
        self.views = views  # the arrays' bytes (views of the scene's own read-only arrays)
        self.token = uuid.uuid4().bytes  # names the file's contents in the workers' keys
        offsets, end = [], 0
        for view in views:
            offsets.append((end, view.nbytes))
            end += -(-view.nbytes // BUFFER_ALIGNMENT) * BUFFER_ALIGNMENT
        self.offsets = tuple(offsets)
        self.users = 0
        self.current = True
        self.descriptor: int | None = os.memfd_create("weathervane-scene", os.MFD_CLOEXEC)
        try:
            os.ftruncate(self.descriptor, max(end, 1))
            for (start, _), view in zip(offsets, views, strict=True):
                written = 0
                while written < view.nbytes:
                    written += os.pwrite(self.descriptor, view[written:], start + written)
        except BaseException:
            self.current = False
            self._close_if_unused()
            raise

    def release(self) -> None:
        """A frame that used the file is done (its tasks finished or dropped: none will be sent)."""
        self.users -= 1
        self._close_if_unused()

    def retire(self) -> None:
        """No longer the current scene's file."""
        self.current = False
        self._close_if_unused()

    def _close_if_unused(self) -> None:
        if not self.current and self.users <= 0 and self.descriptor is not None:
            os.close(self.descriptor)  # the file itself goes once no worker maps it any more
            self.descriptor = None
            self.views = []


class _SharedScenes:
    """A Renderer's scenes as tasks carry them (_SceneMessage), and the shared file of the current one's arrays
    while they are large. A scene whose arrays are those of the last (an animation's frames: the same mesh, the
    vane turned) uses its file again: its arrays are written once."""

    def __init__(self, shared: bool) -> None:
        self.shared = shared  # anonymous shared files exist here (memfd)
        self.file: _SceneFile | None = None
        # the last scene and its message: a Scene is frozen, so the same object sent again (an F12 of an unchanged
        # scene, reuse.LoadedParts) has the same pickle, which costs 0.05-0.1 s for 3,000 objects
        self._last: tuple[sc.Scene, _SceneMessage] | None = None

    def message(self, scene: sc.Scene) -> tuple[_SceneMessage, _SceneFile | None]:
        """The scene's message, and the file its tasks carry (one user more: the frame releases it when done)."""
        last = self._last
        if last is not None and last[0] is scene:
            if last[1].offsets is None:
                return last[1], None
            assert self.file is not None  # the file of the last message: only close() drops it, and forgets that
            self.file.users += 1
            return last[1], self.file
        message, file = self._made(scene)
        self._last = (scene, message)
        return message, file

    def _made(self, scene: sc.Scene) -> tuple[_SceneMessage, _SceneFile | None]:
        buffers: list[pickle.PickleBuffer] = []
        pickled = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)  # arrays: views, not copies
        views = [buffer.raw() for buffer in buffers]
        if not self.shared or sum(view.nbytes for view in views) <= SHARED_SCENE_BYTES:
            whole = pickle.dumps(scene, protocol=5)
            return _SceneMessage(whole, whole), None
        if self.file is None or not _same_bytes(views, self.file.views):
            self.close()
            self.file = _SceneFile(views)
        self.file.users += 1
        return _SceneMessage(self.file.token + pickled, pickled, self.file.offsets), self.file

    def descriptors(self) -> list[int]:
        return [] if self.file is None or self.file.descriptor is None else [self.file.descriptor]

    def close(self) -> None:
        self._last = None
        if self.file is not None:
            self.file.retire()
            self.file = None


def _same_bytes(views: list[memoryview], others: list[memoryview]) -> bool:
    """Whether two scenes' arrays hold the same bytes (the same arrays, most often: a scene's arrays are
    read-only)."""
    if len(views) != len(others):
        return False
    for view, other in zip(views, others, strict=True):
        if view.obj is other.obj:
            continue
        if view.nbytes != other.nbytes or not np.array_equal(
            np.frombuffer(view, np.uint8), np.frombuffer(other, np.uint8)
        ):
            return False
    return True


def render(scene: sc.Scene, workers: int | None = None, progress: Progress | None = None) -> RenderResult:
    """Render once; workers defaults to the scene's setting (0: all cores)."""
    with Renderer(scene.render.workers if workers is None else workers) as renderer:
        return renderer.render(scene, progress)
