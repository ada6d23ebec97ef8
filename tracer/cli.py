"""Command line -> rendered image files: `python -m tracer render [SCENE.json] -o OUT.png|OUT.npy [flags]`."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from . import scene as sc
from .images import SUFFIXES, write_image
from .loader import SceneError, check_samples, default_scene, load_scene
from .parallel import Renderer
from .progress import ProgressBar

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_INTERRUPTED = 130


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


def _output(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in SUFFIXES:
        raise argparse.ArgumentTypeError(f"must end in .png or .npy, got {text!r}")
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"must be a file path, got the folder {text!r}")
    return path


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m tracer",
        description="The documented Whitted-style Phong / Blinn-Phong ray tracer, vectorized with NumPy.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    render = commands.add_parser(
        "render",
        help="render a scene file (or the built-in weathervane) to an image",
        description="Render SCENE (a JSON scene file; the built-in weathervane when omitted) to OUT. Flags override "
        "the scene's render settings. Exit codes: 0 done, 2 bad input (scene or flags), 1 failure, 130 interrupted.",
    )
    render.add_argument("scene", nargs="?", type=Path, help="JSON scene file (docs/scene-format.md)")
    render.add_argument(
        "-o",
        "--output",
        required=True,
        type=_output,
        metavar="OUT",
        help=".png: 8-bit, clamped to [0, 1] as the seed's canvas (linear values unless --srgb); "
        ".npy: float32 linear H x W x 3",
    )
    render.add_argument("--width", type=_integer(1, 16384), help="image width in pixels")
    render.add_argument("--height", type=_integer(1, 16384), help="image height in pixels")
    render.add_argument("--depth", type=_integer(0, 64), help="recursion depth: reflections per camera ray")
    render.add_argument("--model", choices=sc.MODELS, help="specular model of FindIntensity")
    render.add_argument(
        "--coef",
        type=_positive_number,
        help="Blinn-Phong exponent factor: the exponent is specular * coef (2-4 is typical)",
    )
    render.add_argument(
        "--samples",
        type=_integer(1, 1024, check_samples),
        help="samples per pixel, a perfect square: stratified n x n grid, box filter",
    )
    render.add_argument("--workers", type=_integer(0, 256), help="worker processes over bands of rows; 0: all cores")
    render.add_argument("--dtype", choices=sc.DTYPES, help="floating-point precision of the tracing")
    render.add_argument(
        "--background",
        choices=sc.BACKGROUNDS,
        help="solid color, sky gradient, the seed's single-color mode (documented), or none (black)",
    )
    render.add_argument("--srgb", action="store_true", help="encode the PNG as sRGB instead of linear values")
    render.add_argument("--quiet", action="store_true", help="no progress bar and no summary line")
    return parser


def _apply_flags(scene: sc.Scene, args: argparse.Namespace) -> sc.Scene:
    names = ("width", "height", "depth", "model", "coef", "samples", "workers", "dtype")
    changes = {name: getattr(args, name) for name in names if getattr(args, name) is not None}
    if changes:
        scene = scene.with_render(**changes)
    if args.background is not None:
        from dataclasses import replace

        scene = replace(scene, background=replace(scene.background, type=args.background))
    return scene


def _summary(output: Path, scene: sc.Scene, workers: int, result) -> str:
    settings, rays = scene.render, result.rays
    return (
        f"{output}: {settings.width}x{settings.height}, {settings.samples} spp, depth {settings.depth}, "
        f"{settings.model}, {settings.dtype}, {workers} workers: {result.seconds * 1000:.1f} ms, "
        f"rays {rays.camera} camera + {rays.shadow} shadow + {rays.reflection} reflection = {rays.total}, "
        f"{result.mrays_per_second:.2f} Mrays/s"
    )


def run_render(args: argparse.Namespace) -> int:
    try:
        scene = default_scene() if args.scene is None else load_scene(args.scene)
    except SceneError as error:
        for problem in error.problems:
            print(f"error: {error.source}: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    scene = _apply_flags(scene, args)
    progress = ProgressBar("render", enabled=None if not args.quiet else False)
    with Renderer(scene.render.workers) as renderer:
        result = renderer.render(scene, progress)
        workers = renderer.workers
    progress.close()
    try:
        write_image(result.image, args.output, srgb=args.srgb)
    except OSError as error:
        print(f"error: cannot write {args.output}: {error.strerror or error}", file=sys.stderr)
        return EXIT_FAILED
    if not args.quiet:
        print(_summary(args.output, scene, workers, result))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return run_render(args)
    except KeyboardInterrupt:
        print("interrupted: no image written", file=sys.stderr)
        return EXIT_INTERRUPTED
