"""An animation's frames -> PNG files, traced on a Dask cluster (`dask.distributed`, the optional `cluster` extra).

The client plans the run as `animate` does (frames already written stay, so a stopped run resumes), simulates the
vane's motion, and sends runs of up to CHUNK_FRAMES consecutive frames to the cluster as tasks: a worker traces a
run incrementally (its frames share what the vane cannot change; tracer/frames/incremental.py) and answers with the
frames' PNG bytes (and, with render passes, each frame's multilayer EXR bytes: workers then need the OpenEXR
bindings), which the client writes atomically itself, so workers need no shared disk. A frame is a pure
function of the scene and its heading, so a task run again elsewhere (its worker died) gives the same bytes, and
the client writes each frame once, from the first answer it receives.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TypeVar

from ..scene import scene as sc
from ..tracing.images import FramePng, atomic_path, encode_frame, sweep_stale_temporaries
from ..tracing.wavefront import RayCounts
from ..workers.parallel import Renderer
from .animate import (
    AnimationResult,
    FrameProgress,
    frame_path,
    frame_results,
    passes_path,
    plan_frames,
)

CHUNK_FRAMES = 8  # frames per task: long enough for the incremental renderer's reuse, short enough to spread
CONNECT_SECONDS = 10.0  # how long to try reaching the scheduler before saying so
T = TypeVar("T")
INSTALL_HINT = "pip install 'dask[distributed]' (or the project's extra: pip install -e '.[cluster]')"


class ClusterError(Exception):
    """The cluster cannot take or finish the work: one line for the user, saying what was kept."""


@dataclass(frozen=True)
class ChunkResult:
    frames: list[tuple[int, bytes]]  # (frame, PNG bytes)
    rays: RayCounts
    seconds: float  # tracing and encoding on the worker
    passes: dict[int, bytes] = field(default_factory=dict)  # frame -> its passes file's bytes, with render passes


def render_chunk(scene: sc.Scene, frames: list[tuple[int, float]], srgb: bool, incremental: bool) -> ChunkResult:
    """Runs on a Dask worker: (frame, heading) pairs traced in this process, in order, encoded as the frames'
    PNG files (the same bytes `animate` writes)."""
    started = time.perf_counter()
    rays = RayCounts()
    encoded, passes = [], {}
    png = FramePng()
    with Renderer(1) as renderer:
        for frame, result in frame_results(renderer, scene, iter(frames), incremental):
            encoded.append((frame, encode_frame(result.image, srgb, result.alpha, frames=png)))
            if result.passes:
                from ..tracing.pass_files import encode_passes_exr

                passes[frame] = encode_passes_exr(scene, result.image, result.alpha, result.passes)
            rays.add(result.rays)
    return ChunkResult(encoded, rays, time.perf_counter() - started, passes)


def chunks(wanted: Iterator[tuple[int, float]], size: int = CHUNK_FRAMES) -> Iterator[list[tuple[int, float]]]:
    """Runs of at most size frames, each of consecutive frame numbers (a gap starts a new run)."""
    run: list[tuple[int, float]] = []
    for frame, heading in wanted:
        if run and (len(run) == size or frame != run[-1][0] + 1):
            yield run
            run = []
        run.append((frame, heading))
    if run:
        yield run


def _distributed():
    try:
        import distributed
    except ImportError:
        raise ClusterError(
            f"--scheduler needs Dask's distributed scheduler, which is not installed: {INSTALL_HINT}"
        ) from None
    return distributed


def run_on_cluster(
    scheduler: str,
    task: Callable[..., T],
    shared: object,
    runs: Iterable[object],
    on_result: Callable[[T], None],
    kept: Callable[[], str],
) -> None:
    """task(shared, run) for each run on the Dask cluster at scheduler, on_result(answer) on this thread as
    each answer comes (in the order they finish). shared is sent to each worker once. A lost scheduler, an
    unreachable one or a task that kept killing workers raises ClusterError, ending with kept() (what stays)."""
    distributed = _distributed()
    try:
        client = distributed.Client(scheduler, timeout=CONNECT_SECONDS, set_as_default=False)
    except (OSError, TimeoutError) as error:
        raise ClusterError(f"cannot reach the Dask scheduler at {scheduler}: {_reason(error)}") from None
    try:
        sent = client.scatter(shared, broadcast=True, hash=False)
        futures = [client.submit(task, sent, run, pure=False, retries=0) for run in runs]
        for future in distributed.as_completed(futures, loop=client.loop):
            on_result(_result(future, scheduler, distributed, kept))
    finally:
        client.close(timeout=CONNECT_SECONDS)


def animate_on_cluster(
    scene: sc.Scene,
    folder: Path,
    first: int,
    last: int,
    scheduler: str,
    *,
    fps: float | None = None,
    overwrite: bool = False,
    srgb: bool = False,
    progress: FrameProgress | None = None,
    incremental: bool = True,
    chunk_frames: int = CHUNK_FRAMES,
) -> AnimationResult:
    """Render frames first..last of scene into folder on the Dask cluster at scheduler (e.g. tcp://host:8786);
    the same files as animate(). Raises ClusterError when the scheduler cannot be reached or goes away (the frames
    written so far stay; running again resumes)."""
    _distributed()  # before anything is planned or made: says how to install it
    swept = sweep_stale_temporaries(folder)
    plan = plan_frames(scene, folder, first, last, fps, overwrite)
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    total, written = last - first + 1, set(plan.skipped)
    rays = RayCounts()
    if progress is not None and written:
        progress(len(written), total)

    def write(result: ChunkResult) -> None:
        for frame, png in result.frames:
            if frame in written:
                continue
            if frame in result.passes:  # before the PNG: a frame whose PNG is there is whole
                with atomic_path(passes_path(folder, frame)) as temporary:
                    temporary.write_bytes(result.passes[frame])
            with atomic_path(frame_path(folder, frame)) as temporary:
                temporary.write_bytes(png)
            written.add(frame)
            if progress is not None:
                progress(len(written), total)
        rays.add(result.rays)

    def kept() -> str:
        return f"{len(written)} of {total} frames are written; run the same command again to render the rest"

    task = partial(render_chunk, srgb=srgb, incremental=incremental)
    run_on_cluster(scheduler, task, scene, chunks(plan.wanted, chunk_frames), write, kept)
    keys = plan.count_keys()
    return AnimationResult(plan.rendered, plan.skipped, time.perf_counter() - started, rays, keys, total, swept)


def _result(future, scheduler: str, distributed, kept: Callable[[], str]):
    """A finished task's answer; a lost scheduler or a task that kept killing workers becomes a ClusterError."""
    try:
        return future.result()
    except distributed.client.FutureCancelledError:
        raise ClusterError(f"lost the Dask scheduler at {scheduler}; {kept()}") from None
    except distributed.scheduler.KilledWorker as error:
        raise ClusterError(f"work kept killing the cluster's workers ({_reason(error)}); {kept()}") from None
    except (OSError, TimeoutError) as error:
        raise ClusterError(f"lost the Dask scheduler at {scheduler}: {_reason(error)}; {kept()}") from None
    except ImportError as error:  # a worker without an optional package the work needs (OpenEXR for passes)
        raise ClusterError(f"a worker of the cluster cannot do the work: {_reason(error)}; {kept()}") from None


def _reason(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return text[0] if text else type(error).__name__
