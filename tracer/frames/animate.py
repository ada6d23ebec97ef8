"""A scene with a vane -> a numbered PNG sequence of the vane turning by the motion code, and a GIF preview; with
render passes asked for, each frame's passes too, as a multilayer EXR beside its PNG (frame_0001.exr).

Frames are rendered by one persistent worker pool. A frame whose files exist is complete (files are only ever
renamed into place, the EXR before the PNG), so a stopped run resumes where it left off unless overwrite is asked
for.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..scene import scene as sc
from ..scene.keyframes import DEFAULT_TOLERANCE, reduce_keys
from ..scene.motion import Motion, iter_headings
from ..tracing.images import FramePng, atomic_path, encode_frame, sweep_stale_temporaries, to_8bit, write_frame
from ..tracing.wavefront import RayCounts
from ..workers import shutter
from ..workers.parallel import Renderer, RenderResult
from .incremental import render_frames as incremental_frames

FrameProgress = Callable[[int, int], None]


def frame_path(folder: Path, frame: int) -> Path:
    return folder / f"frame_{frame:04d}.png"


def passes_path(folder: Path, frame: int) -> Path:
    """The frame's passes file (with render passes asked for): its image and passes, as `render -o X.exr` writes."""
    return folder / f"frame_{frame:04d}.exr"


def headings(scene: sc.Scene, last_frame: int, fps: float | None = None) -> np.ndarray:
    """The vane's heading (last_frame,) in degrees at frames 1..last_frame (index 0 is frame 1)."""
    return np.concatenate([np.empty(0), *_heading_pieces(scene, last_frame, fps)])


def _heading_pieces(scene: sc.Scene, last_frame: int, fps: float | None) -> Iterator[np.ndarray]:
    motion = scene.motion or Motion()
    if fps is not None:
        from dataclasses import replace

        motion = replace(motion, fps=fps)
    start = scene.vane.heading if scene.vane is not None else 0.0
    return iter_headings(motion, last_frame, start)


def frame_is_complete(path: Path, width: int, height: int) -> bool:
    """Whether a frame file left by an earlier run is a whole PNG of the right size (a file copied in, truncated or
    damaged outside this program is rendered again rather than trusted)."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            if image.format != "PNG" or image.size != (width, height):
                return False
            image.load()  # decodes every row: a truncated file fails here
    except (OSError, ValueError, SyntaxError):
        return False
    return True


@dataclass
class AnimationResult:
    rendered: list[int]
    skipped: list[int]
    seconds: float
    rays: RayCounts
    keys: int  # keyframes that the motion needs at the default tolerance over frames first..last
    frames: int
    swept: int = 0  # temporary files that killed writers had left in the folder, removed at the start


@dataclass
class FramePlan:
    """Which frames of first..last to render and which are already there, and the headings of those to render."""

    rendered: list[int]
    skipped: list[int]
    wanted: Iterator[tuple[int, float]]  # (frame, heading) of the frames to render, simulated as they are asked for
    count_keys: Callable[[], int]  # keyframes of frames first..last (call after wanted is used up)


def plan_frames(
    scene: sc.Scene, folder: Path, first: int, last: int, fps: float | None = None, overwrite: bool = False
) -> FramePlan:
    """What a run of frames first..last into folder has to do: a frame whose file is a whole PNG of the right size
    (and, with passes, whose passes file holds them) stays (unless overwrite), so a stopped run resumes."""
    if scene.vane is None:
        raise ValueError("the scene has no vane to turn (add a 'vane' section naming its parts)")
    if shutter.steps(scene) > 1:
        raise ValueError(
            "the scene has poses (motion blur over one frame's shutter): animate renders the vane's turn frame by "
            "frame, render renders the poses' frame"
        )
    rendered, skipped = [], []
    width, height = scene.render.width, scene.render.height
    for frame in range(first, last + 1):
        path = frame_path(folder, frame)
        keep = not overwrite and path.exists() and frame_is_complete(path, width, height)
        if keep and scene.render.passes:
            from ..tracing.pass_files import passes_file_is_complete

            keep = passes_file_is_complete(passes_path(folder, frame), scene)
        (skipped if keep else rendered).append(frame)
    span: list[np.ndarray] = []  # headings of frames first..last, for the keyframe count

    def frame_headings() -> Iterator[tuple[int, float]]:
        """(frame, heading) for frames 1..last, simulated a piece at a time as the renderer asks for them."""
        frame = 1
        for piece in _heading_pieces(scene, last, fps):
            span.append(piece[max(0, first - frame) : max(0, last + 1 - frame)])
            for heading in piece.tolist():
                yield frame, heading
                frame += 1

    to_render = set(rendered)
    stream = frame_headings()

    def count_keys() -> int:
        for _ in stream:
            pass  # the frames after the last rendered one
        return int(reduce_keys(np.concatenate(span)).size)

    wanted = ((frame, heading) for frame, heading in stream if frame in to_render)
    return FramePlan(rendered, skipped, wanted, count_keys)


def animate(
    scene: sc.Scene,
    folder: Path,
    first: int,
    last: int,
    *,
    fps: float | None = None,
    overwrite: bool = False,
    srgb: bool = False,
    progress: FrameProgress | None = None,
    incremental: bool = True,
) -> AnimationResult:
    """Render frames first..last (inclusive, 1-based) into folder; returns what was rendered and skipped.

    incremental: trace again only the pixels the vane can change (tracer/frames/incremental.py; the same bytes); False
    traces every frame whole."""
    swept = sweep_stale_temporaries(folder)
    plan = plan_frames(scene, folder, first, last, fps, overwrite)
    folder.mkdir(parents=True, exist_ok=True)
    rays = RayCounts()
    started = time.perf_counter()
    total = last - first + 1
    done = len(plan.skipped)
    if progress is not None and done:
        progress(done, total)
    # a frame is encoded and written on a thread while the pool traces the next one (about a fifth of a frame's
    # time at 640x480, which the pool would otherwise wait for); one write at a time keeps memory to two images
    with (
        Renderer(scene.render.workers) as renderer,
        ThreadPoolExecutor(1, "weathervane-writer") as writer,
        contextlib.closing(frame_results(renderer, scene, plan.wanted, incremental)) as results,
    ):  # the results are closed before the pool stops
        pending: Future | None = None
        converted: dict[str, np.ndarray] = {}  # the writer's: the base of the frames being re-traced, in 8 bits
        png = FramePng()  # the writer's: the last frame's compressed rows, reused where a frame's rows are the same
        for frame, result in results:
            if pending is not None:
                pending.result()  # raises here if that write failed
            target = frame_path(folder, frame)
            pending = writer.submit(_write_frame, result, target, srgb, converted, png, scene)
            rays.add(result.rays)
            done += 1
            if progress is not None:
                progress(done, total)
        if pending is not None:
            pending.result()
    keys = plan.count_keys()
    return AnimationResult(plan.rendered, plan.skipped, time.perf_counter() - started, rays, keys, total, swept)


def _write_frame(
    result: RenderResult, target: Path, srgb: bool, converted: dict[str, np.ndarray], png: FramePng, scene: sc.Scene
) -> None:
    """Write a frame's PNG (images.FramePng: the same bytes whether or not png holds the last frame's rows). A frame
    that is its run's base with some pixels traced again (RenderResult.retraced) is converted to 8 bits in those
    pixels only, over the base's 8 bits kept from the run's earlier frames: the same bytes (the conversion is per
    pixel), without converting the whole image each frame (at 640x480 with 7.5% of the pixels re-traced, measured
    alternating: 0.9 ms against 7.1 ms for the whole image). With passes the passes file goes first: a frame whose
    PNG is there is whole."""
    if result.passes:
        from ..tracing.pass_files import write_passes_exr

        write_passes_exr(target.with_suffix(".exr"), scene, result.image, result.alpha, result.passes)
    pixels8 = None
    if result.retraced is not None and result.alpha is None:
        base, pixels = result.retraced
        if base.shape == result.image.shape:
            if converted.get("base") is not base:
                converted.clear()
                converted["base"], converted["base8"] = base, to_8bit(base, srgb)
            pixels8 = converted["base8"].copy()
            flat = result.image.reshape(-1, result.image.shape[-1])  # take(): a row gather 5x faster than flat[pixels]
            pixels8.reshape(-1, pixels8.shape[-1])[pixels] = to_8bit(flat.take(pixels, axis=0)[None], srgb)[0]
    write_frame(target, encode_frame(result.image, srgb, result.alpha, pixels8, png))


def frame_results(
    renderer: Renderer, scene: sc.Scene, wanted: Iterator[tuple[int, float]], incremental: bool
) -> Iterator[tuple[int, RenderResult]]:
    """(frame, image) for the (frame, heading) pairs, in order."""
    if incremental:
        yield from incremental_frames(renderer, scene, wanted)
        return
    frames: deque[int] = deque()  # the frames whose scenes the renderer has taken, oldest first

    def scenes() -> Iterator[sc.Scene]:
        for frame, heading in wanted:
            frames.append(frame)
            yield scene.with_heading(heading)

    for result in renderer.render_frames(scenes()):
        yield frames.popleft(), result


def write_gif(folder: Path, first: int, last: int, fps: float, target: Path) -> Path:
    """Assemble frames first..last of folder into an endlessly looping GIF, written atomically."""
    from PIL import Image

    frames = [Image.open(frame_path(folder, frame)).convert("RGB") for frame in range(first, last + 1)]
    with atomic_path(target) as temporary:
        frames[0].save(
            temporary,
            format="GIF",
            save_all=True,
            append_images=frames[1:],
            duration=max(20, round(1000.0 / fps)),
            loop=0,
        )
    return target


__all__ = [
    "DEFAULT_TOLERANCE",
    "AnimationResult",
    "FramePlan",
    "animate",
    "frame_path",
    "frame_results",
    "headings",
    "passes_path",
    "plan_frames",
    "write_gif",
]
