"""A scene (the default, a scene file or a .blend) -> the documented tracer's and Blender's images of it, compared.

    python scripts/render_both.py [SCENE.json|SCENE.blend] --out out/compare [--engines tracer,cycles,eevee,workbench]
        [--twin exact|physical]
    blender -b [SCENE.blend] --python scripts/render_both.py -- [SCENE.json] --out out/compare

Both paths render the same Blender scene: the add-on builds it (or the .blend is opened), the tracer renders what
the add-on exports from it, and Cycles renders its twins. The exact twin (`exact`, addon/convert/exact_twin.py: the
documented model itself in OSL) where this Blender's Cycles has OSL, beside the physically based twin (`cycles`,
addon/convert/twin.py); --twin physical, or a Blender without OSL, renders the physical one only. Writes <engine>.npy
(linear) and .png, a FLIP heat map per pair, metrics.json, timings.json and report.html into the output folder (one
folder per frame with --frames A-B), and prints the headline numbers. With --passes depth,normal,... the data passes
both the tracer and Cycles make are compared too: the tracer's as passes/tracer.<pass>.npy, Cycles' in
passes/cycles.exr (Blender's multilayer file), their agreement in metrics.json's "passes".
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

ENGINES = ("tracer", "exact", "cycles", "eevee", "workbench")
# The passes both engines make from the same definition (Blender's data passes); the tracer's shading passes split
# the documented model, which Cycles' light passes do not, so they are not compared.
COMPARABLE_PASSES = ("depth", "mist", "normal", "position", "object_index", "material_index")


def parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="render_both.py", description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", type=Path, help="a tracer scene (.json) or a .blend; default: built-in")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "compare", help="output folder")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--engines", default="tracer,cycles", help=f"comma-separated, from {', '.join(ENGINES)}")
    parser.add_argument(
        "--twin",
        choices=("exact", "physical"),
        help="exact (default where Cycles has OSL): the exact twin beside the physical one; physical: that one only",
    )
    parser.add_argument("--cycles-samples", type=int, default=256, help="samples of either Cycles twin")
    parser.add_argument(
        "--pixel-centres",
        action="store_true",
        help="the tracer at one sample per pixel and the exact twin's samples at the pixel centres (Cycles' narrowest "
        "filter): compares shading without the two renderers' different pixel samples",
    )
    parser.add_argument("--eevee-samples", type=int, default=64)
    parser.add_argument("--tracer-samples", type=int, default=16, help="a perfect square: 16 is 4 x 4")
    parser.add_argument("--frames", help="A-B: render every frame of the baked motion")
    parser.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="with --frames: render the frames on a Dask cluster whose workers have this project with bpy and the "
        "report extra; this machine writes the files, and frames already complete are kept",
    )
    parser.add_argument("--chunk", type=int, default=1, help="with --scheduler: frames per task (default 1)")
    parser.add_argument("--no-bake", action="store_true", help="render the file's keyed motion as it is")
    parser.add_argument(
        "--passes",
        metavar="LIST",
        help=f"compare data passes with Cycles' (needs tracer and cycles in --engines): 'all' or from "
        f"{', '.join(COMPARABLE_PASSES)}",
    )
    args = parser.parse_args(argv)
    if args.scheduler and not args.frames:
        parser.error("--scheduler: needs --frames A-B (the frames are what goes to the cluster)")
    if args.chunk < 1:
        parser.error(f"--chunk: must be at least 1, got {args.chunk}")
    engines = [name.strip() for name in args.engines.split(",") if name.strip()]
    unknown = [name for name in engines if name not in ENGINES]
    if unknown or not engines:
        parser.error(f"--engines: must name engines from {', '.join(ENGINES)}, got {args.engines!r}")
    if args.width < 1 or args.height < 1:
        parser.error("--width and --height must be >= 1")
    args.engines = engines
    args.passes = _passes(parser, args.passes, engines)
    if args.pixel_centres:
        args.tracer_samples = 1
    return args


def _passes(parser: argparse.ArgumentParser, text: str | None, engines: list[str]) -> tuple[str, ...]:
    """--passes -> the passes to compare, depth always among them (it gives both engines' coverage)."""
    if text is None:
        return ()
    names = COMPARABLE_PASSES if text.strip() == "all" else [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in COMPARABLE_PASSES]
    if unknown or not names:
        parser.error(f"--passes: must be 'all' or name passes from {', '.join(COMPARABLE_PASSES)}, got {text!r}")
    if "tracer" not in engines or "cycles" not in engines:
        parser.error("--passes: compares the tracer's passes with Cycles': --engines must hold tracer and cycles")
    return tuple(dict.fromkeys(("depth", *names)))


def choose_twin(args: argparse.Namespace) -> None:
    """Add the exact twin before the physical one (engine `cycles`) where this Blender can render it; else say in
    one line why not and render the physical twin only."""
    asked = "exact" in args.engines  # by name in --engines
    if not asked and (args.twin == "physical" or "cycles" not in args.engines):
        return
    from addon.convert import exact_twin

    reason = exact_twin.unavailable()
    if reason is not None:
        rest = "rendering the physical twin only (addon/convert/twin.py)" if "cycles" in args.engines else "left out"
        print(f"exact twin: not rendered, {reason}; {rest}", flush=True)
        if asked:
            args.engines.remove("exact")
        return
    if not asked:
        args.engines.insert(args.engines.index("cycles"), "exact")


def prepare(args: argparse.Namespace) -> None:
    """Register the add-on and build or open the scene."""
    import addon

    if not hasattr(bpy.types, "WEATHERVANE_OT_build"):
        addon.register()
    if args.scene is not None and args.scene.suffix == ".blend":
        bpy.ops.wm.open_mainfile(filepath=str(args.scene.resolve()))
        if not hasattr(bpy.types, "WEATHERVANE_OT_build"):
            addon.register()
    elif not (bpy.data.filepath and bpy.data.collections.get("Weathervane")):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if not hasattr(bpy.types, "WEATHERVANE_OT_build"):
            addon.register()
        result = bpy.ops.weathervane.build(filepath=str(args.scene.resolve()) if args.scene else "")
        if result != {"FINISHED"}:
            sys.exit("error: the scene could not be built")
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
    scene.render.resolution_percentage = 100


def render_tracer(samples: int, passes: tuple[str, ...] = (), folder: Path | None = None) -> np.ndarray:
    """The tracer's image of what the add-on exports; with passes, each saved as folder/passes/tracer.<pass>.npy."""
    from addon.convert.export import scene_document
    from tracer.scene.loader import scene_from_dict
    from tracer.workers.parallel import render

    document = scene_document(bpy.context)
    document["render"]["samples"] = samples
    if passes:
        document["render"]["passes"] = list(passes)
    scene = scene_from_dict(json.loads(json.dumps(document)), "export")
    result = render(scene)
    for name, values in (result.passes or {}).items():
        (folder / "passes").mkdir(exist_ok=True)
        np.save(folder / "passes" / f"tracer.{name}.npy", values.astype(np.float32))
    return result.image


def render_blender(folder: Path, name: str, passes: tuple[str, ...] = ()) -> np.ndarray:
    """Blender's image with the scene's engine; with passes, its View Layer passes of those names ticked for this
    render and saved as Blender's multilayer EXR, folder/passes/<name>.exr."""
    from addon.convert.pass_map import PASSES

    scene = bpy.context.scene
    view_layer = bpy.context.view_layer
    path = folder / f".{name}.exr"
    flags = [entry.flag for entry in PASSES if entry.tracer in passes]
    ticked = {flag: getattr(view_layer, flag) for flag in flags}
    for flag in flags:
        setattr(view_layer, flag, True)
    settings = scene.render.image_settings
    try:
        bpy.ops.render.render()
        result = bpy.data.images["Render Result"]
        settings.file_format = "OPEN_EXR"
        settings.color_depth = "32"
        result.save_render(filepath=str(path), scene=scene)
        if passes:
            (folder / "passes").mkdir(exist_ok=True)
            if hasattr(settings, "media_type"):  # Blender 5: the multilayer file is a media type of its own
                settings.media_type = "MULTI_LAYER_IMAGE"
            settings.file_format = "OPEN_EXR_MULTILAYER"
            result.save_render(filepath=str(folder / "passes" / f"{name}.exr"), scene=scene)
            if hasattr(settings, "media_type"):
                settings.media_type = "IMAGE"
            settings.file_format = "OPEN_EXR"
    finally:
        for flag, value in ticked.items():
            setattr(view_layer, flag, value)
    image = bpy.data.images.load(str(path), check_existing=False)
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    path.unlink()
    return np.flipud(pixels.reshape(height, width, 4))[..., :3].copy()


def render_frame(args: argparse.Namespace, folder: Path) -> dict:
    from addon.convert import twin

    folder.mkdir(parents=True, exist_ok=True)
    stale_passes = [*folder.glob("passes/tracer.*.npy"), folder / "passes" / "cycles.exr"]
    for stale in [*(folder / f"{name}.npy" for name in ENGINES), *folder.glob("diff_*_vs_*.png"), *stale_passes]:
        stale.unlink(missing_ok=True)  # this script's own outputs of an earlier run
    scene = bpy.context.scene
    engine_before = scene.render.engine
    timings = {}
    for name in args.engines:
        started = time.perf_counter()
        if name == "tracer":
            image = render_tracer(args.tracer_samples, args.passes, folder)
        elif name == "exact":
            from addon.convert import exact_twin

            state = exact_twin.apply(bpy.context, args.cycles_samples, pixel_centres=args.pixel_centres)
            if state.line():
                print(state.line(), flush=True)
            try:
                image = render_blender(folder, name)
            finally:
                state.restore()
        else:
            if name == "cycles":
                twin.cycles(scene, args.cycles_samples)
            elif name == "eevee":
                twin.eevee(scene, args.eevee_samples)
            else:
                twin.workbench(scene)
            image = render_blender(folder, name, args.passes if name == "cycles" else ())
        timings[name] = round(time.perf_counter() - started, 3)
        np.save(folder / f"{name}.npy", image.astype(np.float32))
        print(f"{name}: {timings[name]:.2f} s", flush=True)
    scene.render.engine = engine_before
    (folder / "timings.json").write_text(json.dumps(timings, indent=2))
    return timings


def compare(folder: Path) -> dict | None:
    """metrics.json and report.html: in this Python when it has the report libraries, else the project's."""
    try:
        import compare_images

        return compare_images.write_report(folder)
    except ImportError:
        python = ROOT / ".venv" / "bin" / "python"
        if not python.exists():
            print("warning: metrics skipped: no Python with the report extra (make demo installs it)", file=sys.stderr)
            return None
        environment = {key: value for key, value in os.environ.items() if not key.startswith("PYTHON")}
        subprocess.run(
            [str(python), str(ROOT / "scripts" / "compare_images.py"), str(folder)],
            check=True,
            env=environment,
            stdout=subprocess.DEVNULL,
        )
        return json.loads((folder / "metrics.json").read_text())


def frames_on_cluster(args: argparse.Namespace, frames: range) -> dict[int, dict | None]:
    """Each run of --chunk frames rendered by a Dask worker (this script in the worker's Python, from this .blend
    with its keys as baked here); the frames' files come back and are written here, metrics.json last, so a frame
    folder with metrics.json is complete and a run again keeps it."""
    import tempfile

    from tracer.frames.cluster import ClusterError, run_on_cluster
    from tracer.tracing.images import atomic_path

    results: dict[int, dict | None] = {}
    wanted = []
    for frame in frames:
        done = args.out / f"frame_{frame:04d}" / "metrics.json"
        if done.exists():
            results[frame] = json.loads(done.read_text())
        else:
            wanted.append(frame)
    with tempfile.TemporaryDirectory(prefix="weathervane-cluster-") as folder:
        blend = Path(folder) / "scene.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
        # the exact twin is the worker's own choice (its Blender's OSL), as here: only what differs from that goes
        engines = [name for name in args.engines if name != "exact" or args.twin == "exact"]
        options = ["--width", str(args.width), "--height", str(args.height), "--engines", ",".join(engines)]
        options += ["--cycles-samples", str(args.cycles_samples), "--eevee-samples", str(args.eevee_samples)]
        options += ["--tracer-samples", str(args.tracer_samples)]
        options += ["--twin", args.twin] if args.twin else []
        options += ["--pixel-centres"] if args.pixel_centres else []
        options += ["--passes", ",".join(args.passes)] if args.passes else []
        runs: list[list[int]] = []  # runs of consecutive frames, --chunk at most
        for frame in wanted:
            if runs and len(runs[-1]) < args.chunk and runs[-1][-1] == frame - 1:
                runs[-1].append(frame)
            else:
                runs.append([frame])

        def write(answer: dict[str, bytes]) -> None:
            names = sorted(answer, key=lambda name: name.endswith("metrics.json"))  # metrics.json last
            for name in names:
                with atomic_path(args.out / name) as temporary:
                    temporary.write_bytes(answer[name])
                if name.endswith("metrics.json"):
                    frame = int(Path(name).parent.name.removeprefix("frame_"))
                    results[frame] = json.loads(answer[name])
                    print(f"frame {frame}: written ({len(results)} of {len(frames)})", flush=True)

        def kept() -> str:
            return f"{len(results)} of {len(frames)} frames are written; run the same command again for the rest"

        try:
            run_on_cluster(args.scheduler, partial(render_frames_on_worker, options=options), blend.read_bytes(),
                           runs, write, kept)  # fmt: skip
        except ClusterError as error:
            print(f"error: {error}", file=sys.stderr)
            sys.exit(1)
    return dict(sorted(results.items()))


def render_frames_on_worker(blend: bytes, frames: list[int], options: list[str]) -> dict[str, bytes]:
    """Runs on a Dask worker: this script, in the worker's own Python, renders frames of blend into a folder of
    its own; returns every file it wrote (by path under the output folder). Only the standard library and the
    project's installed tracer are named here: the function travels to the worker by value."""
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    import tracer

    script = Path(tracer.__file__).resolve().parents[1] / "scripts" / "render_both.py"
    with tempfile.TemporaryDirectory(prefix="weathervane-frames-") as folder:
        (Path(folder) / "scene.blend").write_bytes(blend)
        out = Path(folder) / "out"
        command = [sys.executable, str(script), str(Path(folder) / "scene.blend"), "--no-bake", "--out", str(out)]
        command += ["--frames", f"{frames[0]}-{frames[-1]}", *options]
        finished = subprocess.run(command, capture_output=True, text=True)
        if finished.returncode != 0:
            raise RuntimeError(f"render_both.py failed on the worker: {finished.stderr.strip()[-500:]}")
        return {
            str(path.relative_to(out)): path.read_bytes()
            for frame in frames
            for path in sorted((out / f"frame_{frame:04d}").rglob("*"))
            if path.is_file()
        }


def main() -> None:
    from script_args import script_arguments

    args = parse(script_arguments())
    prepare(args)
    choose_twin(args)
    scene = bpy.context.scene
    if args.frames:
        first, _, last = args.frames.partition("-")
        frames = range(int(first), int(last or first) + 1)
        if not args.no_bake and scene.weathervane and bpy.data.objects.get("WV Turn") is not None:
            scene.frame_start, scene.frame_end = frames.start, frames.stop - 1
            bpy.ops.weathervane.bake()
        if args.scheduler:
            results = frames_on_cluster(args, frames)
        else:
            results = {}
            for frame in frames:
                scene.frame_set(frame)
                folder = args.out / f"frame_{frame:04d}"
                render_frame(args, folder)
                results[frame] = compare(folder)
        summary = {str(frame): (result or {}).get("pairs") for frame, result in results.items()}
        (args.out / "metrics.json").write_text(json.dumps(summary, indent=2))
        print(f"report: {args.out}/frame_*/report.html")
        return
    timings = render_frame(args, args.out)
    result = compare(args.out)
    print(f"report: {(args.out / 'report.html').resolve()}")
    if result:
        for key, metrics in result["pairs"].items():
            print(
                f"{key}: PSNR {metrics['psnr_db']:.2f} dB, SSIM {metrics['ssim']:.4f}, mean FLIP "
                f"{metrics['mean_flip']:.4f}, pixels over 0.016: {100 * metrics['share_over_0.016']:.1f}%"
            )
        for name, metrics in result.get("passes", {}).get("cycles_vs_tracer", {}).items():
            print(f"pass {name}: {metrics}")
    print("timings: " + ", ".join(f"{name} {seconds:.2f} s" for name, seconds in timings.items()))


if __name__ == "__main__":
    main()
    # Debian's Blender 3.4 segfaults in its normal shutdown after a --python script has imported multiprocessing
    # (the tracer's worker pool); leaving through SystemExit skips that path, in the wheel too it is harmless
    sys.exit(0)
