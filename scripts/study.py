"""The seed's research study, and further: how the tracer's time grows -> charts and a table in docs/performance.md.

Usage: python scripts/study.py [--out docs] [--repeats 3]
Times (median of --repeats frames on one persistent pool, warm) the default scene against workers (1 to 4),
recursion depth (0 to 8), resolution, scene size (spheres; triangles), Phong against Blinn-Phong, float32 against
float64, the per-pixel reference against the vectorized tracer, and Cycles at a few sample counts for scale.
Writes <out>/study.png and <out>/study.json, and the table with the date it was taken between the STUDY markers of
<out>/performance.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from tracer.scene import scene as sc  # noqa: E402
from tracer.scene.loader import default_scene  # noqa: E402
from tracer.tracing.reference import render_reference  # noqa: E402
from tracer.workers.parallel import Renderer  # noqa: E402

MARK_START, MARK_END = "<!-- STUDY:START -->", "<!-- STUDY:END -->"


def timed(renderer: Renderer, scene: sc.Scene, repeats: int) -> tuple[float, int, np.ndarray]:
    """Median seconds per frame, rays per frame and the image."""
    result = renderer.render(scene)
    seconds = [renderer.render(scene).seconds for _ in range(repeats)]
    return statistics.median(seconds), result.rays.total, result.image


def spheres(count: int) -> sc.Scene:
    """count spheres on a grid above the default scene's ground, all in view."""
    base = default_scene()
    side = math.ceil(math.sqrt(count))
    objects = [base.objects[0]] + [
        sc.Sphere(
            name=f"ball{k}",
            material="brass",
            radius=0.45 / side,
            location=(-1.2 + 2.4 * (k % side + 0.5) / side, 0.0, 0.6 + 2.4 * (k // side + 0.5) / side),
        )
        for k in range(count)
    ]
    return replace(base, objects=tuple(objects), vane=None)


def triangles(count: int) -> sc.Scene:
    """A sphere-like mesh of about count triangles (a UV sphere) in the default scene's place of the vane."""
    base = default_scene()
    rings = max(2, int(math.sqrt(count / 2)))
    segments = max(3, count // (2 * rings))
    vertices = [(0.0, 0.0, 1.0)]
    for i in range(1, rings):
        theta = math.pi * i / rings
        vertices += [
            (
                math.sin(theta) * math.cos(2 * math.pi * j / segments),
                math.sin(theta) * math.sin(2 * math.pi * j / segments),
                math.cos(theta),
            )
            for j in range(segments)
        ]
    vertices.append((0.0, 0.0, -1.0))
    faces = []
    for j in range(segments):
        faces.append((0, 1 + j, 1 + (j + 1) % segments))
        last = 1 + (rings - 2) * segments
        faces.append((len(vertices) - 1, last + (j + 1) % segments, last + j))
    for i in range(rings - 2):
        for j in range(segments):
            a, b = 1 + i * segments + j, 1 + i * segments + (j + 1) % segments
            faces += [(a, a + segments, b), (b, a + segments, b + segments)]
    mesh = sc.TriangleMesh(
        name="mesh", material="copper", location=(0, 0, 2.0), vertices=tuple(vertices), triangles=tuple(faces)
    )
    return replace(base, objects=(base.objects[0], mesh), vane=None)


def run(repeats: int) -> dict:
    scene = default_scene().with_render(width=640, height=480)
    data: dict = {}
    for workers in (1, 2, 3, 4):
        with Renderer(workers) as renderer:
            data.setdefault("workers", []).append((workers, timed(renderer, scene, repeats)[0]))
    with Renderer(2) as renderer:
        for depth in range(9):
            data.setdefault("depth", []).append((depth, timed(renderer, scene.with_render(depth=depth), repeats)[0]))
        for width in (80, 160, 320, 640, 1280):
            sized = scene.with_render(width=width, height=width * 3 // 4)
            data.setdefault("resolution", []).append((width * width * 3 // 4, timed(renderer, sized, repeats)[0]))
        for count in (1, 4, 16, 64, 256):
            many = spheres(count).with_render(width=320, height=240)
            data.setdefault("spheres", []).append((count, timed(renderer, many, repeats)[0]))
        for count in (12, 100, 1000, 10_000, 100_000, 1_000_000):
            mesh = triangles(count).with_render(width=320, height=240)
            actual = len(mesh.objects[1].triangles)
            data.setdefault("triangles", []).append((actual, timed(renderer, mesh, repeats)[0]))
        models = {}
        for model in ("phong", "blinn-phong"):
            seconds, _, image = timed(renderer, scene.with_render(model=model), repeats)
            models[model] = (seconds, image)
        data["models"] = {model: seconds for model, (seconds, _) in models.items()}
        data["models_mean_difference"] = float(np.abs(models["phong"][1] - models["blinn-phong"][1]).mean())
        for dtype in ("float64", "float32"):
            data.setdefault("dtype", {})[dtype] = timed(renderer, scene.with_render(dtype=dtype), repeats)[0]
    small = scene.with_render(width=64, height=48)
    started = time.perf_counter()
    render_reference(small)
    data["reference_seconds_640x480"] = (time.perf_counter() - started) * 100
    data["vectorized_seconds_640x480"] = dict(data["workers"])[1]
    data["cycles"] = cycles(repeats)  # last: bpy is not imported while the pools above fork
    return data


CYCLES_SIZE = (320, 240)
CYCLES_SAMPLES = (1, 4, 16, 64, 256)


def cycles(repeats: int) -> dict | None:
    """Cycles (CPU) on the default scene's twin at a few sample counts, and the tracer at the same size for scale:
    {"samples": [(n, seconds)], "tracer": seconds}; None without the bpy wheel."""
    try:
        import bpy
    except ImportError:
        return None
    import argparse
    import tempfile

    sys.path.insert(0, str(ROOT / "scripts"))
    import render_both

    from addon.convert import twin

    width, height = CYCLES_SIZE
    render_both.prepare(argparse.Namespace(scene=None, width=width, height=height))
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        for samples in CYCLES_SAMPLES:
            twin.cycles(bpy.context.scene, samples)
            seconds = []
            for _ in range(max(1, repeats // 2)):
                started = time.perf_counter()
                render_both.render_blender(Path(folder), "study")
                seconds.append(time.perf_counter() - started)
            runs.append((samples, statistics.median(seconds)))
    with Renderer(2) as renderer:
        tracer_seconds = timed(renderer, default_scene().with_render(width=width, height=height), repeats)[0]
    return {"samples": runs, "tracer": tracer_seconds}


def chart(data: dict, target: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tracer.tracing.images import atomic_path

    figure, axes = plt.subplots(2, 4, figsize=(18, 8), dpi=100)
    panels = [
        ("workers", "worker processes", "ms per frame (640x480)", False),
        ("depth", "recursion depth", "ms per frame (640x480)", False),
        ("resolution", "pixels", "ms per frame", True),
        ("spheres", "spheres in the scene", "ms per frame (320x240)", True),
        ("triangles", "triangles in the scene", "ms per frame (320x240)", True),
    ]
    for axis, (key, xlabel, ylabel, logarithmic) in zip(axes.ravel(), panels, strict=False):
        x, y = zip(*data[key], strict=True)
        axis.plot(x, [1000 * value for value in y], "o-")
        if logarithmic:
            axis.set_xscale("log")
            axis.set_yscale("log")
            slope = np.polyfit(np.log(x[-3:]), np.log(y[-3:]), 1)[0]
            axis.set_title(f"{key}: cost grows as n^{slope:.2f}")
        else:
            axis.set_title(key)
        axis.set(xlabel=xlabel, ylabel=ylabel)
        axis.grid(True, which="both", alpha=0.3)
    bars = axes.ravel()[5]
    labels = ["Phong", "Blinn-Phong", "float64", "float32"]
    values = [
        data["models"]["phong"],
        data["models"]["blinn-phong"],
        data["dtype"]["float64"],
        data["dtype"]["float32"],
    ]
    bars.bar(labels, [1000 * value for value in values], color=["tab:blue", "tab:blue", "tab:orange", "tab:orange"])
    bars.set(ylabel="ms per frame (640x480, 2 workers)", title="models and precision")
    scale = axes.ravel()[6]
    if data.get("cycles"):
        samples, seconds = zip(*data["cycles"]["samples"], strict=True)
        scale.plot(samples, [1000 * value for value in seconds], "o-", color="tab:orange", label="Cycles (CPU)")
        scale.axhline(1000 * data["cycles"]["tracer"], color="tab:blue", label="tracer, 2 workers")
        scale.set_xscale("log")
        scale.set_yscale("log")
        scale.legend()
    scale.set(xlabel="Cycles samples per pixel", ylabel="ms per frame (320x240)", title="Cycles for scale")
    scale.grid(True, which="both", alpha=0.3)
    axes.ravel()[7].axis("off")
    figure.tight_layout()
    with atomic_path(target) as temporary:
        figure.savefig(temporary, format="png")


def table(data: dict) -> str:
    workers = dict(data["workers"])
    rows = [
        "| measure | figure |",
        "| --- | --- |",
        *(
            f"| {count} worker(s), 640x480 | {1000 * seconds:.1f} ms ({workers[1] / seconds:.2f}x of one) |"
            for count, seconds in data["workers"]
        ),
        f"| depth 0 / 3 / 8 | {1000 * data['depth'][0][1]:.1f} / {1000 * data['depth'][3][1]:.1f} / "
        f"{1000 * data['depth'][8][1]:.1f} ms |",
        f"| Phong / Blinn-Phong | {1000 * data['models']['phong']:.1f} / {1000 * data['models']['blinn-phong']:.1f} ms,"
        f" mean image difference {data['models_mean_difference']:.4f} |",
        f"| float64 / float32 | {1000 * data['dtype']['float64']:.1f} / {1000 * data['dtype']['float32']:.1f} ms |",
        f"| per-pixel reference / vectorized (1 worker) | {data['reference_seconds_640x480']:.1f} s / "
        f"{data['vectorized_seconds_640x480']:.3f} s "
        f"({data['reference_seconds_640x480'] / data['vectorized_seconds_640x480']:.0f}x) |",
        *(f"| {count} spheres (320x240) | {1000 * seconds:.1f} ms |" for count, seconds in data["spheres"]),
        *(f"| {count} triangles (320x240) | {1000 * seconds:.1f} ms |" for count, seconds in data["triangles"]),
    ]
    if data.get("cycles"):
        rows.append(f"| tracer, default scene (320x240, 2 workers) | {1000 * data['cycles']['tracer']:.1f} ms |")
        rows.extend(
            f"| Cycles CPU, {samples} samples (320x240) | {1000 * seconds:.0f} ms |"
            for samples, seconds in data["cycles"]["samples"]
        )
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    data = run(args.repeats)
    chart(data, args.out / "study.png")
    (args.out / "study.json").write_text(json.dumps(data, indent=1))
    page = args.out / "performance.md"
    if page.exists():
        text = page.read_text()
        taken = f"Taken {datetime.date.today().isoformat()} (`make study`, medians of {args.repeats} frames)."
        block = f"{MARK_START}\n{taken}\n\n{table(data)}\n{MARK_END}"
        if MARK_START in text:
            text = text[: text.index(MARK_START)] + block + text[text.index(MARK_END) + len(MARK_END) :]
        else:
            text += f"\n## The study\n\n![study](study.png)\n\n{block}\n"
        page.write_text(text)
    print(table(data))


if __name__ == "__main__":
    main()
