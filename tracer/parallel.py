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
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from . import scene as sc
from .wavefront import PreparedScene, RayCounts

RAYS_PER_BAND = 160000  # camera samples per band: bounds memory (tens of MB) and amortises NumPy's call cost
BLOCK_ROWS = 16

Progress = Callable[[int, int], None]


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def bands(settings: sc.RenderSettings) -> list[np.ndarray]:
    """The image's rows (arrays of row indices) dealt into bands of at most about RAYS_PER_BAND camera samples.

    Rows go in blocks of BLOCK_ROWS, dealt round-robin, so each band holds a like share of sky, ground and object
    (the workers finish together) while its rays stay coherent enough for the hierarchy (a fully interleaved deal
    was about 35% slower here). The number of bands is even, so that 1 or 2 workers get equal shares, and as small
    as the memory bound allows: each band costs about 13 ms of fixed NumPy overhead at 640x480 (1 band 123 ms, 2
    bands 138 ms, 4 bands 162 ms per frame on one worker here). It depends only on the image.
    """
    samples = settings.height * settings.width * settings.samples
    blocks = [
        np.arange(start, min(start + BLOCK_ROWS, settings.height)) for start in range(0, settings.height, BLOCK_ROWS)
    ]
    count = min(len(blocks), 2 * math.ceil(samples / RAYS_PER_BAND / 2))
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


_shared_output: mmap.mmap | None = None  # set before the pool forks: workers write their bands straight into it


def _render_band(
    task: tuple[bytes, np.ndarray, tuple[int, int, int], str],
) -> tuple[np.ndarray, np.ndarray | None, RayCounts]:
    scene_bytes, rows, shape, dtype = task
    band, counts = _prepared_for(scene_bytes).render_rows(rows)
    if _shared_output is None:  # a spawned worker shares no memory: the band travels back pickled
        return rows, band, counts
    np.ndarray(shape, dtype=dtype, buffer=_shared_output)[rows] = band
    return rows, None, counts


# ---- parent side -------------------------------------------------------------------------------------------------


class Renderer:
    """Renders scenes with a pool of worker processes kept alive between frames (use as a context manager).

    Where processes fork, the image lives in an anonymous shared mapping made before the pool starts, so bands
    come back without being copied through pipes; a larger image than the mapping holds restarts the pool once.
    """

    def __init__(self, workers: int = 0) -> None:
        self.workers = workers if workers > 0 else default_workers()
        self._pool = None
        self._buffer: mmap.mmap | None = None
        self._prepared: tuple[bytes, PreparedScene] | None = None
        self._forking = "fork" in multiprocessing.get_all_start_methods()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        global _shared_output
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None
        if self._buffer is not None:
            if _shared_output is self._buffer:
                _shared_output = None
            self._buffer.close()
            self._buffer = None

    def _start_pool(self, image_bytes: int) -> None:
        global _shared_output
        if self._pool is not None and (self._buffer is None or len(self._buffer) >= image_bytes):
            return
        self.close()
        if self._forking:
            self._buffer = mmap.mmap(-1, max(image_bytes, 1))
            _shared_output = self._buffer
            self._pool = multiprocessing.get_context("fork").Pool(self.workers)
            _shared_output = None  # only the forked workers write through it
        else:
            self._pool = multiprocessing.get_context("spawn").Pool(self.workers)

    def _results(
        self, scene: sc.Scene, shape: tuple[int, int, int]
    ) -> Iterator[tuple[np.ndarray, np.ndarray | None, RayCounts]]:
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
        dtype = np.dtype(scene.render.dtype)
        self._start_pool(math.prod(shape) * dtype.itemsize)
        scene_bytes = pickle.dumps(scene)
        tasks = [(scene_bytes, rows, shape, dtype.str) for rows in bands(scene.render)]
        yield from self._pool.imap_unordered(_render_band, tasks)

    def render(self, scene: sc.Scene, progress: Progress | None = None) -> RenderResult:
        """Trace the whole image; progress(bands_done, bands_total) is called as bands finish."""
        settings = scene.render
        started = time.perf_counter()
        shape = (settings.height, settings.width, 3)
        dtype = np.dtype(settings.dtype)
        image = np.empty(shape, dtype=dtype)
        counts = RayCounts()
        total = len(bands(settings))
        for done, (rows, band, band_counts) in enumerate(self._results(scene, shape), start=1):
            if band is not None:
                image[rows] = band
            counts.add(band_counts)
            if progress is not None:
                progress(done, total)
        if self._buffer is not None and self.workers > 1:
            image = np.ndarray(shape, dtype=dtype, buffer=self._buffer).copy()
        return RenderResult(image, counts, time.perf_counter() - started)


def render(scene: sc.Scene, workers: int | None = None, progress: Progress | None = None) -> RenderResult:
    """Render once; workers defaults to the scene's setting (0: all cores)."""
    with Renderer(scene.render.workers if workers is None else workers) as renderer:
        return renderer.render(scene, progress)
