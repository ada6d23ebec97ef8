"""A scene -> a linear float image, in bands of rows over a persistent pool of worker processes.

A band is every B-th block of rows of the image, so that every band holds a like share of sky, ground and object
and the workers finish together. The bands depend only on the image (never on the number of
workers) and each is traced by the same code, so the image is bit-identical for any number of workers. Memory stays
bounded by the band.
"""

from __future__ import annotations

import ctypes
import math
import multiprocessing
import os
import pickle
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from . import scene as sc
from .wavefront import PreparedScene, RayCounts

RAYS_PER_BAND = 65536  # camera samples per band: bounds memory (tens of MB) and amortises NumPy's call cost
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
    was about 35% slower here). The number of bands is a multiple of four so that 1, 2 or 4 workers get equal
    shares; it depends only on the image.
    """
    samples = settings.height * settings.width * settings.samples
    blocks = [
        np.arange(start, min(start + BLOCK_ROWS, settings.height)) for start in range(0, settings.height, BLOCK_ROWS)
    ]
    count = min(len(blocks), 4 * math.ceil(samples / RAYS_PER_BAND / 4))
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


def _prepared_for(key: int, scene_bytes: bytes) -> PreparedScene:
    if _worker_cache.get("key") != key:
        tune_allocator()
        _worker_cache["key"] = key
        _worker_cache["prepared"] = PreparedScene(pickle.loads(scene_bytes))
    prepared = _worker_cache["prepared"]
    assert isinstance(prepared, PreparedScene)
    return prepared


def _render_band(task: tuple[int, bytes, np.ndarray]) -> tuple[np.ndarray, np.ndarray, RayCounts]:
    key, scene_bytes, rows = task
    image, counts = _prepared_for(key, scene_bytes).render_rows(rows)
    return rows, image, counts


# ---- parent side -------------------------------------------------------------------------------------------------


class Renderer:
    """Renders scenes with a pool of worker processes kept alive between frames (use as a context manager)."""

    def __init__(self, workers: int = 0) -> None:
        self.workers = workers if workers > 0 else default_workers()
        self._pool = None
        self._key = 0
        if self.workers > 1:
            method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
            self._pool = multiprocessing.get_context(method).Pool(self.workers)

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def _results(self, scene: sc.Scene) -> Iterator[tuple[np.ndarray, np.ndarray, RayCounts]]:
        if self._pool is None:
            tune_allocator()
            prepared = PreparedScene(scene)
            for rows in bands(scene.render):
                image, counts = prepared.render_rows(rows)
                yield rows, image, counts
            return
        self._key += 1
        scene_bytes = pickle.dumps(scene)
        tasks = [(self._key, scene_bytes, rows) for rows in bands(scene.render)]
        yield from self._pool.imap_unordered(_render_band, tasks)

    def render(self, scene: sc.Scene, progress: Progress | None = None) -> RenderResult:
        """Trace the whole image; progress(bands_done, bands_total) is called as bands finish."""
        settings = scene.render
        started = time.perf_counter()
        image = np.empty((settings.height, settings.width, 3), dtype=np.dtype(settings.dtype))
        counts = RayCounts()
        total = len(bands(settings))
        for done, (rows, band, band_counts) in enumerate(self._results(scene), start=1):
            image[rows] = band
            counts.add(band_counts)
            if progress is not None:
                progress(done, total)
        return RenderResult(image, counts, time.perf_counter() - started)


def render(scene: sc.Scene, workers: int | None = None, progress: Progress | None = None) -> RenderResult:
    """Render once; workers defaults to the scene's setting (0: all cores)."""
    with Renderer(scene.render.workers if workers is None else workers) as renderer:
        return renderer.render(scene, progress)
