"""Every renderer at several settings -> error against time on log-log axes, with the Pareto front marked.

    python scripts/speed_accuracy.py [--width 160 --height 120] [--out docs]

Renders the default scene with the tracer (samples 1, 4, 16, 64; depth 1, 3, 5; float32 and float64), Cycles
(1 to 1024 samples), EEVEE (a few sample counts) and Workbench, and measures each image's RMSE and mean FLIP (on
the displayed, sRGB-encoded image) against two references: the documented model converged (the tracer at 8 x 8
samples, depth 8) and Cycles converged (4096 samples). Writes <out>/speed-accuracy.png and speed-accuracy.json.
Needs the bpy wheel and the report extra.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402
import render_both  # noqa: E402
from compare_images import display  # noqa: E402


def errors(image: np.ndarray, reference: np.ndarray) -> dict:
    import flip_evaluator

    a, b = display(reference), display(image)
    _, mean_flip, _ = flip_evaluator.evaluate(a.astype(np.float32), b.astype(np.float32), "LDR")
    return {"rmse": float(np.sqrt(np.mean((a - b) ** 2))), "flip": float(mean_flip)}


def tracer_image(samples: int, depth: int, dtype: str, renderer, seed: int = 0) -> tuple[np.ndarray, float]:
    from addon.convert.export import scene_document
    from tracer.scene.loader import scene_from_dict

    document = scene_document(bpy.context)
    document["render"].update(samples=samples, depth=depth, dtype=dtype, seed=seed)
    scene = scene_from_dict(json.loads(json.dumps(document)))
    renderer.render(scene)  # warm: the pool and the prepared scene
    result = renderer.render(scene)
    return result.image.astype(np.float64), result.seconds


def blender_image(setup, folder: Path) -> tuple[np.ndarray, float]:
    setup()
    started = time.perf_counter()
    image = render_both.render_blender(folder, "speed")
    return image.astype(np.float64), time.perf_counter() - started


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both time and error."""
    order = sorted(range(len(points)), key=lambda k: (points[k][0], points[k][1]))
    front, best = [], float("inf")
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


def main() -> None:
    from script_args import script_arguments

    parser = argparse.ArgumentParser(prog="speed_accuracy.py", description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--height", type=int, default=120)
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--cycles-reference", type=int, default=4096)
    args = parser.parse_args(script_arguments())
    render_both.prepare(argparse.Namespace(scene=None, width=args.width, height=args.height))
    from addon.convert import twin
    from tracer.workers.parallel import Renderer

    scene = bpy.context.scene
    folder = args.out / ".speed-accuracy"
    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    with Renderer(0) as renderer:
        # another seed than the measured settings', so that 64 spp is not compared with its own samples
        documented_reference, _ = tracer_image(64, 8, "float64", renderer, seed=1)
        for samples in (1, 4, 16, 64):
            for depth in (1, 3, 5):
                for dtype in ("float32", "float64"):
                    image, seconds = tracer_image(samples, depth, dtype, renderer)
                    runs.append(
                        {
                            "renderer": "tracer",
                            "setting": f"{samples} spp, depth {depth}, {dtype}",
                            "seconds": seconds,
                            "image": image,
                        }
                    )
    cycles_reference, _ = blender_image(lambda: twin.cycles(scene, args.cycles_reference), folder)
    for samples in (1, 4, 16, 64, 256, 1024):
        image, seconds = blender_image(lambda samples=samples: twin.cycles(scene, samples), folder)
        runs.append({"renderer": "cycles", "setting": f"{samples} samples", "seconds": seconds, "image": image})
    for samples in (1, 16):
        image, seconds = blender_image(lambda samples=samples: twin.eevee(scene, samples), folder)
        runs.append({"renderer": "eevee", "setting": f"{samples} samples", "seconds": seconds, "image": image})
    image, seconds = blender_image(lambda: twin.workbench(scene), folder)
    runs.append({"renderer": "workbench", "setting": "studio", "seconds": seconds, "image": image})
    folder.rmdir()
    for run in runs:
        run["against_documented"] = errors(run["image"], documented_reference)
        run["against_cycles"] = errors(run["image"], cycles_reference)
        del run["image"]
    chart(runs, args.out / "speed-accuracy.png")
    (args.out / "speed-accuracy.json").write_text(
        json.dumps(
            {
                "width": args.width,
                "height": args.height,
                "cycles_reference_samples": args.cycles_reference,
                "runs": runs,
            },
            indent=1,
        )
    )
    for run in runs:
        print(
            f"{run['renderer']:9} {run['setting']:28} {run['seconds']:8.3f} s  "
            f"vs documented: RMSE {run['against_documented']['rmse']:.4f} FLIP {run['against_documented']['flip']:.4f}"
            f"  vs Cycles: RMSE {run['against_cycles']['rmse']:.4f} FLIP {run['against_cycles']['flip']:.4f}"
        )


def chart(runs: list[dict], target: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tracer.tracing.images import atomic_path

    colors = {"tracer": "tab:blue", "cycles": "tab:orange", "eevee": "tab:green", "workbench": "tab:red"}
    figure, axes = plt.subplots(2, 2, figsize=(12, 9), dpi=100)
    for row, metric in enumerate(("flip", "rmse")):
        for column, reference in enumerate(("against_documented", "against_cycles")):
            axis = axes[row][column]
            points = [(max(run["seconds"], 1e-4), max(run[reference][metric], 1e-6)) for run in runs]
            for run, (x, y) in zip(runs, points, strict=True):
                marker = "s" if "float32" in run["setting"] else "o"
                axis.scatter(x, y, color=colors[run["renderer"]], marker=marker, s=22)
            front = pareto(points)
            axis.plot([points[k][0] for k in front], [points[k][1] for k in front], "k--", linewidth=1)
            axis.set_xscale("log")
            axis.set_yscale("log")
            title = "documented model converged" if column == 0 else "Cycles converged"
            axis.set(
                xlabel="time per frame (s)",
                ylabel=f"{'mean FLIP' if metric == 'flip' else 'RMSE'}",
                title=f"{metric.upper()} against the {title}",
            )
            axis.grid(True, which="both", alpha=0.3)
    handles = [plt.Line2D([], [], color=c, marker="o", linestyle="", label=name) for name, c in colors.items()]
    handles.append(plt.Line2D([], [], color="k", linestyle="--", label="Pareto front"))
    axes[0][0].legend(handles=handles, fontsize=8)
    figure.tight_layout()
    with atomic_path(target) as temporary:
        figure.savefig(temporary, format="png")


if __name__ == "__main__":
    main()
    sys.exit(0)  # see render_both.py
