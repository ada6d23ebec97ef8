"""Command line -> rendered image files: `python -m tracer render [SCENE.json] -o OUT.png|OUT.npy [flags]`."""

from __future__ import annotations

import argparse
import contextlib
import errno
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from .frames.animate import DEFAULT_TOLERANCE, animate, write_gif
from .frames.cluster import ClusterError
from .progress import ProgressBar
from .scene import scene as sc
from .scene.loader import SceneError, check_samples, default_scene, load_scene
from .scene.passes import parse as parse_passes
from .tracing.images import SUFFIXES, sweep_stale_temporaries, write_image
from .workers import adaptive, shutter
from .workers.parallel import Renderer, worker_count
from .workers.pool import TaskFailedError, WorkerLostError
from .workers.resources import (
    ResourceError,
    check_disk,
    check_resources,
    out_of_memory_message,
    output_bytes,
    scene_counts,
)

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports a process ended by it


class TerminatedError(Exception):
    """SIGTERM arrived: stop as Ctrl-C does (workers stopped, temporary files gone), and say so."""


def _raise_terminated(_signum: int, _frame: object) -> None:
    raise TerminatedError


def _write_problem(path: Path, error: OSError) -> str:
    """One line for a failed write: the user's path (never a temporary one) and the reason."""
    if error.errno == errno.ENOSPC:
        return f"error: no space left on the device for {path}"
    if error.errno == errno.ENAMETOOLONG:
        return f"error: cannot write {path}: the file name is too long for its file system"
    return f"error: cannot write {path}: {error.strerror or error}"


def _integer(low: int, high: int, extra: Callable[[int], str | None] | None = None) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be an integer from {low} to {high}, got {value}")
        problem = extra(value) if extra else None
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return value

    return parse


def _positive_number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not value > 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _threshold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a number from 0 to 1, got {text}")
    return value


def _output(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in (*SUFFIXES, ".exr"):
        raise argparse.ArgumentTypeError(f"must end in .png, .npy or .exr, got {text!r}")
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"must be a file path, got the folder {text!r}")
    return path


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m tracer",
        description="The documented Whitted-style Phong / Blinn-Phong ray tracer, vectorized with NumPy.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    settings = _settings_parser()
    render = commands.add_parser(
        "render",
        parents=[settings],
        help="render a scene file (or the built-in weathervane) to an image",
        description="Render SCENE (a JSON scene file; the built-in weathervane when omitted) to OUT. Flags override "
        "the scene's render settings. Exit codes: 0 done, 2 bad input (scene or flags), 1 failure, 130 interrupted.",
    )
    render.add_argument(
        "-o",
        "--output",
        required=True,
        type=_output,
        metavar="OUT",
        help=".png: 8-bit, clamped to [0, 1] as the seed's canvas (linear values unless --srgb); "
        ".npy: float32 linear H x W x 3 (RGBA and H x W x 4 where the scene has an alpha: film_transparent, holdouts); "
        ".exr: a multilayer OpenEXR with the passes (needs the OpenEXR package)",
    )
    _add_passes_flag(render, "written into OUT when it is .exr, else into OUT's name with .exr")
    animate = commands.add_parser(
        "animate",
        parents=[settings],
        help="render the vane turning in the wind as a numbered PNG sequence (and a GIF)",
        description="Render frames A-B of SCENE's vane turning by its motion (docs/motion.md) into DIR as "
        "frame_0001.png, ... Frame 1 is time 0. Frames already in DIR are kept unless --overwrite, so a stopped run "
        "resumes. Exit codes: 0 done, 2 bad input, 1 failure, 130 interrupted (finished frames stay).",
    )
    animate.add_argument("-o", "--output", required=True, type=_folder, metavar="DIR", help="folder for the frames")
    animate.add_argument(
        "--frames", required=True, type=_frames, metavar="A-B", help="first and last frame, e.g. 1-120"
    )
    animate.add_argument("--fps", type=_positive_number, help="frames per second (default: the scene's motion.fps)")
    animate.add_argument("--overwrite", action="store_true", help="render frames again even where files exist")
    animate.add_argument("--gif", type=_gif, metavar="OUT.gif", help="also assemble the frames into a looping GIF")
    _add_passes_flag(animate, "each frame's into DIR/frame_0001.exr, ... beside its PNG")
    animate.add_argument(
        "--scheduler",
        type=_scheduler,
        metavar="tcp://HOST:PORT",
        help="trace the frames on a Dask cluster (needs dask[distributed]); this machine writes the files",
    )
    animate.add_argument(
        "--chunk",
        type=_integer(1, 10000),
        default=None,
        metavar="N",
        help="with --scheduler: consecutive frames per task (default 8; more reuses more between frames)",
    )
    return parser


def _add_passes_flag(parser: argparse.ArgumentParser, where: str) -> None:
    parser.add_argument(
        "--passes",
        type=_passes,
        metavar="LIST",
        help="render passes, 'all' or names separated by commas (depth, mist, normal, position, object_index, "
        "material_index, ambient, diffuse, specular, emission, reflection, environment, shadow, cryptomatte_object, "
        f"cryptomatte_material; docs/passes.md) in a multilayer EXR (needs the OpenEXR package): {where}",
    )


def _settings_parser() -> argparse.ArgumentParser:
    """The render-setting flags shared by every command."""
    settings = argparse.ArgumentParser(add_help=False)
    settings.add_argument("scene", nargs="?", type=Path, help="JSON scene file (docs/scene-format.md)")
    settings.add_argument("--width", type=_integer(1, 16384), help="image width in pixels")
    settings.add_argument("--height", type=_integer(1, 16384), help="image height in pixels")
    settings.add_argument("--depth", type=_integer(0, 64), help="recursion depth: reflections per camera ray")
    settings.add_argument("--model", choices=sc.MODELS, help="specular model of FindIntensity")
    settings.add_argument(
        "--coef",
        type=_positive_number,
        help="Blinn-Phong exponent factor: the exponent is specular * coef (2-4 is typical)",
    )
    settings.add_argument(
        "--samples",
        type=_integer(1, 1024, check_samples),
        help="samples per pixel, a perfect square: stratified n x n grid, box filter",
    )
    settings.add_argument(
        "--adaptive",
        type=_threshold,
        metavar="THRESHOLD",
        help="adaptive sampling: every pixel at a few samples first, --samples only where a pixel differs by more "
        "than THRESHOLD from the midpoint of two opposite neighbours (linear; edges, not smooth gradients; 0.005 keeps "
        "the default frame's error; 0: off)",
    )
    settings.add_argument("--workers", type=_integer(0, 256), help="worker processes over bands of rows; 0: all cores")
    settings.add_argument("--dtype", choices=sc.DTYPES, help="floating-point precision of the tracing")
    settings.add_argument(
        "--numerics",
        choices=sc.NUMERICS,
        help="documented: the seed's epsilons and formulas; robust: stable quadratics, watertight triangles, "
        "normal-offset ray origins (docs/stability.md)",
    )
    settings.add_argument(
        "--background",
        choices=tuple(kind for kind in sc.BACKGROUNDS if kind != "image"),  # a picture comes with its scene file
        help="solid color, sky gradient, the seed's single-color mode (documented), or none (black)",
    )
    settings.add_argument("--srgb", action="store_true", help="encode PNGs as sRGB instead of linear values")
    settings.add_argument("--quiet", action="store_true", help="no progress bar and no summary line")
    return settings


def _passes(text: str) -> tuple[str, ...]:
    try:
        return parse_passes(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _folder(text: str) -> Path:
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"must be a folder, got the file {text!r}")
    return path


def _gif(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() != ".gif":
        raise argparse.ArgumentTypeError(f"must end in .gif, got {text!r}")
    return path


def _scheduler(text: str) -> str:
    """A Dask scheduler's address: tcp://HOST:PORT (or tls://, ws://, wss://); HOST:PORT means tcp://."""
    address = text if "://" in text else f"tcp://{text}"
    scheme, _, rest = address.partition("://")
    host, colon, port = rest.rpartition(":")
    if scheme not in ("tcp", "tls", "ws", "wss") or not colon or not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"must be a Dask scheduler's address like tcp://HOST:PORT, got {text!r}")
    return address


def _frames(text: str) -> tuple[int, int]:
    first, dash, last = text.partition("-")
    try:
        start, stop = int(first), int(last if dash else first)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be A-B with whole frame numbers, e.g. 1-120, got {text!r}") from None
    if not 1 <= start <= stop <= 100000:
        raise argparse.ArgumentTypeError(f"must be A-B with 1 <= A <= B <= 100000, got {text!r}")
    return start, stop


def _apply_flags(scene: sc.Scene, args: argparse.Namespace) -> sc.Scene:
    names = ("width", "height", "depth", "model", "coef", "samples", "workers", "dtype", "numerics")
    changes = {name: getattr(args, name) for name in names if getattr(args, name) is not None}
    if changes:
        scene = scene.with_render(**changes)
    if getattr(args, "adaptive", None) is not None:
        scene = scene.with_render(adaptive_threshold=args.adaptive)
    if getattr(args, "passes", None):
        scene = scene.with_render(passes=args.passes)
    if args.background is not None:
        from dataclasses import replace

        scene = replace(scene, background=replace(scene.background, type=args.background))
    return scene


def _summary(output: Path, scene: sc.Scene, workers: int, result, swept: int) -> str:
    settings, rays = scene.render, result.rays
    spp = f"{settings.samples} spp"
    if getattr(result, "adaptive", None) is not None:
        spp = f"{settings.samples} spp where neighbours differ by > {settings.adaptive_threshold:g} "
        spp += f"({result.adaptive:.1%} of pixels), {adaptive.base_samples(settings.samples)} elsewhere"
    if shutter.steps(scene) > 1:
        spp += f", motion blur over {shutter.steps(scene)} time slices"
    return (
        f"{output}: {settings.width}x{settings.height}, {spp}, depth {settings.depth}, "
        f"{settings.model}, {settings.dtype}, {workers} workers: {result.seconds * 1000:.1f} ms, "
        f"rays {rays.camera} camera + {rays.shadow} shadow + {rays.reflection} reflection = {rays.total}, "
        f"{result.mrays_per_second:.2f} Mrays/s" + _swept(swept)
    )


def _swept(count: int) -> str:
    """The summary's note of the temporary files that killed runs had left, removed at the start."""
    if count == 0:
        return ""
    return f"; removed {count} temporary file{'s' if count > 1 else ''} a killed run had left"


def _load(args: argparse.Namespace) -> sc.Scene | None:
    """The scene with the flags applied, or None after printing every problem."""
    try:
        scene = default_scene() if args.scene is None else load_scene(args.scene)
    except SceneError as error:
        for problem in error.problems:
            print(f"error: {error.source}: {problem}", file=sys.stderr)
        return None
    return _apply_flags(scene, args)


def run_render(args: argparse.Namespace) -> int:
    scene = _load(args)
    if scene is None:
        return EXIT_BAD_INPUT
    if (scene.render.passes or args.output.suffix.lower() == ".exr") and not _exr_bindings(args.output):
        return EXIT_FAILED
    swept = sweep_stale_temporaries(args.output.parent)
    progress = ProgressBar("render", enabled=None if not args.quiet else False)
    workers = scene.render.workers
    try:
        with Renderer(scene.render.workers) as renderer:
            workers = renderer.workers
            suffix = args.output.suffix.lower()
            check_resources(scene.render, renderer.workers, output=suffix, **scene_counts(scene))
            check_disk(args.output, output_bytes(scene.render, suffix, 4 if scene.has_alpha else 3))
            if scene.render.passes and suffix != ".exr":
                check_disk(args.output.with_suffix(".exr"), output_bytes(scene.render, ".exr", scene.channels + 1))
            result = renderer.render(scene, progress)
        progress.close()
        exr = args.output if suffix == ".exr" else args.output.with_suffix(".exr") if scene.render.passes else None
        written = [] if suffix == ".exr" else [args.output]
        try:
            if suffix != ".exr":
                write_image(result.image, args.output, srgb=args.srgb, alpha=result.alpha)
            if exr is not None:
                from .tracing.pass_files import write_passes_exr

                write_passes_exr(exr, scene, result.image, result.alpha, result.passes)
                written.append(exr)
        except OSError as error:
            print(_write_problem(exr if written else args.output, error), file=sys.stderr)
            return EXIT_FAILED
        except ImportError as error:  # the OpenEXR bindings, an optional extra
            print(f"error: {exr}: {error}", file=sys.stderr)
            return EXIT_FAILED
    except MemoryError:  # a limit the check could not see (address space, a cgroup, other processes' growth)
        progress.close()
        print(f"error: {out_of_memory_message(scene.render, workers)}; no image written", file=sys.stderr)
        return EXIT_FAILED
    if not args.quiet:
        print(_summary(args.output, scene, workers, result, swept))
        if exr is not None and scene.render.passes:
            print(f"{exr}: passes {', '.join(scene.render.passes)}")
    return 0


def _exr_bindings(output: Path) -> bool:
    """Whether the OpenEXR bindings (an optional extra) are there for the passes file; says so before any work."""
    from .tracing.exr import openexr_module

    try:
        openexr_module()
    except ImportError as error:
        print(f"error: {output}: {error}", file=sys.stderr)
        return False
    return True


def run_animate(args: argparse.Namespace) -> int:
    scene = _load(args)
    if scene is None:
        return EXIT_BAD_INPUT
    if scene.vane is None:
        print(
            f"error: {args.scene or 'default scene'}: vane: is required to animate (name the turning parts)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    if shutter.steps(scene) > 1:
        print(
            f"error: {args.scene or 'default scene'}: poses: motion blur over one frame's shutter; animate renders the "
            "vane's turn frame by frame (render renders the poses' frame)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    if args.chunk is not None and args.scheduler is None:
        print("error: --chunk: only with --scheduler (it sets how many frames go to a cluster's task)", file=sys.stderr)
        return EXIT_BAD_INPUT
    if scene.render.passes and not _exr_bindings(args.output):
        return EXIT_FAILED
    first, last = args.frames
    fps = args.fps or (scene.motion.fps if scene.motion else 24.0)
    progress = ProgressBar("frames", enabled=None if not args.quiet else False)
    try:
        if args.scheduler is not None:
            result = _animate_on_cluster(scene, args, fps, progress)
        else:
            workers = worker_count(scene.render.workers)
            check_resources(scene.render, workers, frames=3, output=".png", **scene_counts(scene))
            result = animate(
                scene, args.output, first, last, fps=fps, overwrite=args.overwrite, srgb=args.srgb, progress=progress
            )
    except ClusterError as error:
        progress.close()
        print(f"error: {error}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as error:
        progress.close()
        where = Path(error.filename) if error.filename else args.output
        if where.name.startswith(".") and where.name.endswith(".partial"):  # the temporary beside a frame
            where = args.output
        print(_write_problem(where, error), file=sys.stderr)
        return EXIT_FAILED
    progress.close()
    swept = result.swept
    if args.gif is not None:
        if args.gif.parent.resolve() != args.output.resolve():
            swept += sweep_stale_temporaries(args.gif.parent)
        try:
            write_gif(args.output, first, last, fps, args.gif)
        except OSError as error:
            print(_write_problem(args.gif, error), file=sys.stderr)
            return EXIT_FAILED
    if not args.quiet:
        rendered = len(result.rendered)
        per_frame = result.seconds / rendered * 1000 if rendered else 0.0
        mrays = result.rays.total / result.seconds / 1e6 if result.seconds > 0 else 0.0
        print(
            f"{args.output}: frames {first}-{last} at {fps:g} fps: {rendered} rendered, {len(result.skipped)} "
            f"already there; {result.seconds:.2f} s, {per_frame:.1f} ms per rendered frame, {mrays:.2f} Mrays/s; "
            f"the motion needs {result.keys} keyframes of {result.frames} frames at {DEFAULT_TOLERANCE} degrees"
            + (f"; passes {', '.join(scene.render.passes)} in each frame's .exr" if scene.render.passes else "")
            + (f"; traced on the Dask cluster at {args.scheduler}" if args.scheduler else "")
            + (f"; preview {args.gif}" if args.gif else "")
            + _swept(swept)
        )
    return 0


def _animate_on_cluster(scene: sc.Scene, args: argparse.Namespace, fps: float, progress: ProgressBar):
    """animate's frames on the Dask cluster at args.scheduler, with Dask's own log lines (connection retries and
    their tracebacks) held back: what the user needs comes as one line of ClusterError."""
    import logging

    from .frames.cluster import CHUNK_FRAMES, animate_on_cluster

    dask_log = logging.getLogger("distributed")
    level = dask_log.level
    dask_log.setLevel(logging.CRITICAL + 1)
    try:
        first, last = args.frames
        return animate_on_cluster(
            scene,
            args.output,
            first,
            last,
            args.scheduler,
            fps=fps,
            overwrite=args.overwrite,
            srgb=args.srgb,
            progress=progress,
            chunk_frames=args.chunk or CHUNK_FRAMES,
        )
    finally:
        dask_log.setLevel(level)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with contextlib.suppress(ValueError):  # only the main thread may set handlers (not so when embedded)
        signal.signal(signal.SIGTERM, _raise_terminated)
    written = "finished frames stay" if args.command == "animate" else "no image written"
    try:
        return run_animate(args) if args.command == "animate" else run_render(args)
    except KeyboardInterrupt:
        print(f"\ninterrupted: {written}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except TerminatedError:
        print(f"terminated: {written}", file=sys.stderr)
        return EXIT_TERMINATED
    except MemoryError:
        print(f"error: out of memory: {written}; try a smaller --width/--height or --dtype float32", file=sys.stderr)
        return EXIT_FAILED
    except (ResourceError, WorkerLostError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_FAILED
    except TaskFailedError as error:  # a bug: the worker's traceback helps a report, the user sees one line
        print(f"error: {error} (please report this, with the scene file)", file=sys.stderr)
        return EXIT_FAILED
