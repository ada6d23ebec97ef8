"""A scene -> a linear float image, in bands of rows over a persistent pool of worker processes.

A band is every B-th block of rows of the image, so that every band holds a like share of sky, ground and object
and the workers finish together. The bands depend only on the image (never on the number of
workers) and each is traced by the same code, so the image is bit-identical for any number of workers. Memory stays
bounded by the band.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import mmap
import multiprocessing
import os
import pickle
import tempfile
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from . import scene as sc
from .wavefront import PreparedScene, RayCounts

# One coordinate of every camera sample of a band, in bytes. A band's arrays peak at about 35 such coordinates per
# sample. Small frames go in few large bands (each band costs fixed NumPy overhead: at 640x480 in float64, 2 bands
# were 9% faster than 4); a large image leaves less room beside it, so its bands are smaller: 1920x1080 in float64
# took 197-211 MB for the parent and two workers together with bands of 148,000 samples, 155-165 MB with 80,000.
BAND_BYTES = 1_280_000  # 160,000 samples in float64, 320,000 in float32
LARGE_IMAGE_BYTES = 16 << 20
LARGE_IMAGE_BAND_BYTES = 480_000  # 60,000 samples in float64, 120,000 in float32
BLOCK_ROWS = 16

Progress = Callable[[int, int], None]


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def bands(settings: sc.RenderSettings) -> list[np.ndarray]:
    """The image's rows (arrays of row indices) dealt into bands of at most about BAND_BYTES / itemsize samples
    (LARGE_IMAGE_BAND_BYTES for an image of more than LARGE_IMAGE_BYTES).

    Rows go in blocks of BLOCK_ROWS, dealt round-robin, so each band holds a like share of sky, ground and object
    (the workers finish together) while its rays stay coherent enough for the hierarchy (a fully interleaved deal
    was about 35% slower here). The number of bands is even, so that 1 or 2 workers get equal shares, and as small
    as the memory bound allows: each band costs fixed NumPy overhead (one worker, a float32 frame at 640x480 before
    later work: 1 band 123 ms, 2 bands 138 ms, 4 bands 162 ms). It depends only on the image and the dtype.
    """
    samples = settings.height * settings.width * settings.samples
    itemsize = np.dtype(settings.dtype).itemsize
    large = settings.height * settings.width * 3 * itemsize > LARGE_IMAGE_BYTES
    per_band = (LARGE_IMAGE_BAND_BYTES if large else BAND_BYTES) // itemsize
    blocks = [
        np.arange(start, min(start + BLOCK_ROWS, settings.height)) for start in range(0, settings.height, BLOCK_ROWS)
    ]
    count = min(len(blocks), 2 * math.ceil(samples / per_band / 2))
    return [np.concatenate(blocks[first::count]) for first in range(count)]


@dataclass
class RenderResult:
    image: np.ndarray  # (height, width, 3) linear RGB, unclamped, in the scene's dtype
    rays: RayCounts
    seconds: float

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


def _prepared_for(scene_bytes: bytes) -> PreparedScene:
    """The prepared scene, rebuilt only when the scene changed since the last band (a few ms per build)."""
    if _worker_cache.get("scene") != scene_bytes:
        tune_allocator()
        _worker_cache["scene"] = scene_bytes
        _worker_cache["prepared"] = PreparedScene(pickle.loads(scene_bytes))
    prepared = _worker_cache["prepared"]
    assert isinstance(prepared, PreparedScene)
    return prepared


def _render_band(
    task: tuple[bytes, np.ndarray, tuple[int, int, int], str, str | None],
) -> tuple[np.ndarray, np.ndarray | None, RayCounts]:
    scene_bytes, rows, shape, dtype, image_file = task
    band, counts = _prepared_for(scene_bytes).render_rows(rows)
    if image_file is None:  # a spawned worker: the band travels back pickled
        return rows, band, counts
    with open(image_file, "r+b") as handle, mmap.mmap(handle.fileno(), 0) as mapping:
        image = np.ndarray(shape, dtype=dtype, buffer=mapping)
        image[rows] = band
        del image  # the mapping closes only when no array uses it
    return rows, None, counts


# ---- parent side -------------------------------------------------------------------------------------------------


class Renderer:
    """Renders scenes with a pool of worker processes kept alive between frames (use as a context manager).

    Where processes fork, each frame's image is a file in shared memory (/dev/shm) that the workers map and write
    their bands into and that the returned array maps in turn: bands are not copied through pipes, and the image
    is never copied at all (at 1920x1080 in float64 that is 50 MB less at the peak). Elsewhere bands come back
    pickled.
    """

    def __init__(self, workers: int = 0) -> None:
        self.workers = workers if workers > 0 else default_workers()
        self._pool = None
        self._prepared: tuple[bytes, PreparedScene] | None = None
        self._forking = "fork" in multiprocessing.get_all_start_methods()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def _start_pool(self) -> None:
        if self._pool is None:
            self._pool = multiprocessing.get_context("fork" if self._forking else "spawn").Pool(self.workers)

    def _bands(self, scene: sc.Scene) -> Iterator[tuple[np.ndarray, np.ndarray, RayCounts]]:
        """(rows, band, counts) as bands finish, traced here (one worker) or by spawned workers (bands pickled)."""
        if self.workers <= 1:
            tune_allocator()
            scene_bytes = pickle.dumps(scene)
            if self._prepared is None or self._prepared[0] != scene_bytes:
                self._prepared = (scene_bytes, PreparedScene(scene))
            prepared = self._prepared[1]
            for rows in bands(scene.render):
                image, counts = prepared.render_rows(rows)
                yield rows, image, counts
            return
        self._start_pool()
        scene_bytes = pickle.dumps(scene)
        shape = (scene.render.height, scene.render.width, 3)
        tasks = [(scene_bytes, rows, shape, np.dtype(scene.render.dtype).str, None) for rows in bands(scene.render)]
        yield from self._pool.imap_unordered(_render_band, tasks)

    def render(self, scene: sc.Scene, progress: Progress | None = None) -> RenderResult:
        """Trace the whole image; progress(bands_done, bands_total) is called as bands finish."""
        if self.workers > 1 and self._forking:
            self._start_pool()
            return self._submit(scene).finish(progress)
        settings = scene.render
        started = time.perf_counter()
        image = np.empty((settings.height, settings.width, 3), dtype=settings.dtype)
        counts = RayCounts()
        total = len(bands(settings))
        for done, (rows, band, band_counts) in enumerate(self._bands(scene), 1):
            image[rows] = band
            counts.add(band_counts)
            if progress is not None:
                progress(done, total)
        return RenderResult(image, counts, time.perf_counter() - started)

    def render_frames(self, scenes: Iterable[sc.Scene]) -> Iterator[RenderResult]:
        """render() for each scene in turn, results in order. With forked workers the next frame's bands wait in
        the pool's queue while the current frame finishes, so no worker idles between frames (an animation)."""
        if self.workers <= 1 or not self._forking:
            for scene in scenes:
                yield self.render(scene)
            return
        self._start_pool()
        pending: deque[_Frame] = deque()
        try:
            for scene in scenes:
                pending.append(self._submit(scene))
                if len(pending) == 2:  # one frame traced, one queued: memory stays at two images
                    yield pending.popleft().finish()
            while pending:
                yield pending.popleft().finish()
        finally:
            for frame in pending:  # stopped early: let the workers finish with the files before they go
                frame.abandon()

    def _submit(self, scene: sc.Scene) -> _Frame:
        settings = scene.render
        shape = (settings.height, settings.width, 3)
        dtype = np.dtype(settings.dtype)
        started = time.perf_counter()
        file = _image_file(math.prod(shape) * dtype.itemsize)
        name, mapping = file.__enter__()
        scene_bytes = pickle.dumps(scene)
        tasks = [
            self._pool.apply_async(_render_band, ((scene_bytes, rows, shape, dtype.str, name),))
            for rows in bands(settings)
        ]
        return _Frame(np.ndarray(shape, dtype, buffer=mapping), tasks, file, started)


@dataclass
class _Frame:
    """A frame whose bands are in the pool: its image (mapping the shared file), the bands' tasks, the file."""

    image: np.ndarray
    tasks: list
    file: contextlib.AbstractContextManager
    started: float

    def finish(self, progress: Progress | None = None) -> RenderResult:
        counts = RayCounts()
        try:
            for done, task in enumerate(self.tasks, 1):
                counts.add(task.get()[2])
                if progress is not None:
                    progress(done, len(self.tasks))
        finally:
            self.abandon()
        return RenderResult(self.image, counts, time.perf_counter() - self.started)

    def abandon(self) -> None:
        for task in self.tasks:
            task.wait(60.0)  # a band takes well under a second; never hang on a pool that is gone
        self.file.__exit__(None, None, None)


@contextlib.contextmanager
def _image_file(size: int) -> Iterator[tuple[str, mmap.mmap]]:
    """A file of size bytes in shared memory and the parent's mapping of it; the name is gone after the block (the
    mapping lives on with the array made from it)."""
    try:  # shared memory where it has room (a container's is often 64 MB); else the temporary folder
        roomy = os.statvfs("/dev/shm").f_bavail * os.statvfs("/dev/shm").f_frsize > 2 * size
    except OSError:
        roomy = False
    handle, name = tempfile.mkstemp(prefix="weathervane-image-", dir="/dev/shm" if roomy else None)
    try:
        if hasattr(os, "posix_fallocate"):
            os.posix_fallocate(handle, 0, size)  # no room fails here, not as a crash when a worker writes
        else:
            os.ftruncate(handle, size)
        mapping = mmap.mmap(handle, size)
        yield name, mapping
    finally:
        os.close(handle)
        os.unlink(name)


def render(scene: sc.Scene, workers: int | None = None, progress: Progress | None = None) -> RenderResult:
    """Render once; workers defaults to the scene's setting (0: all cores)."""
    with Renderer(scene.render.workers if workers is None else workers) as renderer:
        return renderer.render(scene, progress)
