"""The stability cases -> pictures for docs/stability.md: acne and leaks per mode, the per-primitive size and position
sweep (chart and JSON), Phong's cut-off, faceting.

Usage: python scripts/stability_pictures.py [--out docs/stability]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from PIL import Image, ImageDraw  # noqa: E402

from tracer.scene import scene as sc  # noqa: E402
from tracer.tracing.images import atomic_path, to_8bit  # noqa: E402
from tracer.workers.parallel import render  # noqa: E402


def ball_on_floor(scale: float, numerics: str, dtype: str) -> np.ndarray:
    scene = sc.Scene(
        materials={"floor": sc.Material(color=(0.8, 0.8, 0.75)), "ball": sc.Material(color=(0.9, 0.5, 0.3))},
        objects=(
            sc.Plane(name="floor", material="floor"),
            sc.Sphere(name="ball", material="ball", location=(0, 0, scale), radius=scale),
        ),
        lights=(sc.AmbientLight(0.15), sc.DirectionalLight(direction=(0.3, -0.4, 1.0), intensity=0.85)),
        camera=sc.Camera(location=(0, -6 * scale, 2.5 * scale), rotation=(75, 0, 0), lens=30),
        background=sc.Background(type="solid", color=(0.1, 0.1, 0.12)),
        render=sc.RenderSettings(width=256, height=192, depth=0, numerics=numerics, dtype=dtype, samples=4),
    )
    return render(scene).image


def highlight(model: str) -> np.ndarray:
    scene = sc.Scene(
        materials={"m": sc.Material(color=(0.6, 0.6, 0.65), specular=2.0)},
        objects=(sc.Plane(name="floor", material="m"),),
        lights=(sc.AmbientLight(0.05), sc.PointLight(location=(0, 4, 0.6), intensity=0.5)),
        camera=sc.Camera(location=(0, -4, 2.0), rotation=(70, 0, 0), lens=28),
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=256, height=192, depth=0, model=model, coef=1.0, samples=4),
    )
    return render(scene).image


def labelled(image: np.ndarray, label: str) -> Image.Image:
    picture = Image.fromarray(to_8bit(image, srgb=True))
    ImageDraw.Draw(picture).text((6, 4), label, fill=(255, 255, 0))
    return picture


def grid(pictures: list[Image.Image], columns: int) -> Image.Image:
    width, height = pictures[0].size
    rows = math.ceil(len(pictures) / columns)
    sheet = Image.new("RGB", (columns * width, rows * height))
    for k, picture in enumerate(pictures):
        sheet.paste(picture, ((k % columns) * width, (k // columns) * height))
    return sheet


def save(picture: Image.Image, target: Path) -> None:
    with atomic_path(target) as temporary:
        picture.save(temporary, format="PNG")
    print(f"wrote {target}")


def faceting_chart(target: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sys.path.insert(0, str(ROOT))
    from tracer.scene.loader import default_scene

    scene = default_scene()
    width = scene.render.width
    focal = scene.camera.lens / scene.camera.sensor_width * width
    figure, axis = plt.subplots(figsize=(7, 4), dpi=110)
    segments = np.arange(6, 257)
    from addon.vane.build import segments_for  # the add-on's own choice (imports bpy: the wheel)

    for obj in scene.objects:
        kind = type(obj).__name__
        if kind not in ("Sphere", "Cylinder") or obj.name in ("mark_north", "mark_south", "mark_west"):
            continue
        centre = np.array(obj.location)
        reach = obj.radius if kind == "Sphere" else max(obj.radius, obj.height / 2.0)
        distance = float(np.linalg.norm(centre - np.array(scene.camera.location)) - reach)
        error = focal * obj.radius * (1 - np.cos(np.pi / segments)) / distance
        line = axis.plot(segments, error, label=f"{obj.name} (r = {obj.radius:g} m, {distance:.1f} m away)")
        chosen = segments_for(obj.radius, distance, focal)
        axis.plot(
            [chosen], [focal * obj.radius * (1 - math.cos(math.pi / chosen)) / distance], "o", color=line[0].get_color()
        )
    axis.axhline(0.5, color="grey", linestyle="--", linewidth=1)
    axis.set(
        xscale="log",
        yscale="log",
        xlabel="segments around the circle",
        ylabel="silhouette error (pixels at 640 wide)",
        title="Mesh faceting against the analytic surface (dots: the add-on's choice)",
    )
    axis.legend(fontsize=7)
    figure.tight_layout()
    with atomic_path(target) as temporary:
        figure.savefig(temporary, format="png")
    print(f"wrote {target}")


def sweep_chart(target: Path, table: Path) -> None:
    """tests/stability_sweep.py in both modes: wrong pixels against each primitive's size, one panel per primitive."""
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tests import stability_sweep as sweep

    rows = []
    for cell in sweep.cells():
        for numerics in ("documented", "robust"):
            acne, leaks, decided = sweep.wrong_pixels(cell, numerics)
            rows.append({**cell.__dict__, "numerics": numerics, "acne": acne, "leaks": leaks, "decided": decided})
    figure, axes = plt.subplots(1, len(sweep.KINDS), figsize=(12, 3.6), dpi=110, sharey=True)
    for axis, kind in zip(axes, sweep.KINDS, strict=True):
        for layout in sweep.LAYOUTS:
            for position in sweep.POSITIONS:
                for dtype in ("float64", "float32"):
                    line = [
                        (row["size"], 100.0 * (row["acne"] + row["leaks"]) / max(row["decided"], 1))
                        for row in rows
                        if (row["kind"], row["layout"], row["position"], row["dtype"], row["numerics"])
                        == (kind, layout, position, dtype, "documented")
                    ]
                    if line:
                        sizes, wrong = zip(*line, strict=True)
                        style = "-" if dtype == "float64" else "--"
                        marker = "o" if position == 0.0 else "s"
                        axis.plot(
                            sizes,
                            wrong,
                            style,
                            marker=marker,
                            markersize=3,
                            label=f"{layout}, at {position:g}, {dtype}",
                        )
        robust = sum(row["acne"] + row["leaks"] for row in rows if row["kind"] == kind and row["numerics"] == "robust")
        axis.set(xscale="log", xlabel="primitive size (m)", title=f"{kind} (robust: {robust} wrong)")
    axes[0].set_ylabel("documented mode: wrong pixels (%)")
    axes[0].legend(fontsize=6)
    figure.tight_layout()
    with atomic_path(target) as temporary:
        figure.savefig(temporary, format="png")
    print(f"wrote {target}")
    with atomic_path(table) as temporary:
        temporary.write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {table}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "stability")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    cases = [(1e-3, "float64"), (1.0, "float64"), (1e4, "float32")]
    pictures = [
        labelled(ball_on_floor(scale, numerics, dtype), f"{numerics}, scale {scale:g}, {dtype}")
        for scale, dtype in cases
        for numerics in ("documented", "robust")
    ]
    save(grid(pictures, 2), args.out / "acne-and-leaks.png")
    save(
        grid([labelled(highlight(model), f"{model}, exponent 2") for model in ("phong", "blinn-phong")], 2),
        args.out / "phong-cutoff.png",
    )
    faceting_chart(args.out / "faceting.png")
    sweep_chart(args.out / "primitive-sweep.png", args.out / "primitive-sweep.json")


if __name__ == "__main__":
    main()
