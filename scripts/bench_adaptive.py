"""Adaptive sampling against uniform sampling on the default frame -> error against a many-sample render, against time.

Usage: python scripts/bench_adaptive.py [--width 640 --height 480] [--rounds 5] [--truth 256]
                                        [--out docs/adaptive-sampling]

Renders the default scene at --truth samples (the reference), then, alternating in the same run, uniform 1, 4 and
16 samples and adaptive 16 samples at several thresholds, each --rounds times (wall time of Renderer.render, workers
0: all cores; the median is quoted). Error: RMSE and the worst pixel against the reference, linear RGB. Writes
OUT.json (every figure) and OUT.png (error against median seconds, matplotlib).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tracer.scene.loader import default_scene  # noqa: E402
from tracer.workers.parallel import Renderer  # noqa: E402

THRESHOLDS = (0.002, 0.005, 0.01, 0.02, 0.05)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--truth", type=int, default=256)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "adaptive-sampling")
    args = parser.parse_args()
    scene = default_scene().with_render(width=args.width, height=args.height)
    cases = {f"uniform {n}": scene.with_render(samples=n) for n in (1, 4, 16)}
    cases.update({f"adaptive 16, {t:g}": scene.with_render(samples=16, adaptive_threshold=t) for t in THRESHOLDS})
    records: dict[str, dict] = {name: {"seconds": []} for name in cases}
    with Renderer(0) as renderer:
        truth = renderer.render(scene.with_render(samples=args.truth)).image
        for name, case in cases.items():  # warm: each case's first render, and its error
            result = renderer.render(case)
            difference = result.image - truth
            records[name].update(
                rmse=float(np.sqrt(np.mean(difference**2))),
                worst=float(np.abs(difference).max()),
                rays=result.rays.total,
                camera_rays=result.rays.camera,
                traced_again=result.adaptive,
            )
        for _ in range(args.rounds):
            for name, case in cases.items():
                started = time.perf_counter()
                renderer.render(case)
                records[name]["seconds"].append(time.perf_counter() - started)
    uniform = records["uniform 16"]
    for record in records.values():
        record["median_seconds"] = statistics.median(record["seconds"])
        record["time_over_uniform_16"] = record["median_seconds"] / statistics.median(uniform["seconds"])
        record["rmse_over_uniform_16"] = record["rmse"] / uniform["rmse"]
    for name, record in records.items():
        again = "" if record["traced_again"] is None else f", {record['traced_again']:.1%} of pixels at 16"
        print(
            f"{name:22s} median {record['median_seconds'] * 1000:7.1f} ms ({record['time_over_uniform_16']:.2f} of "
            f"uniform 16), RMSE {record['rmse']:.6f} ({record['rmse_over_uniform_16']:.3f}), worst "
            f"{record['worst']:.4f}{again}"
        )
    summary = {"width": args.width, "height": args.height, "truth_samples": args.truth, "rounds": args.rounds}
    args.out.with_suffix(".json").write_text(json.dumps({**summary, "cases": records}, indent=1) + "\n")
    _chart(records, args.out.with_suffix(".png"), summary)


def _chart(records: dict[str, dict], path: Path, summary: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4.2), dpi=110)
    for kind, marker in (("uniform", "o"), ("adaptive", "s")):
        names = [name for name in records if name.startswith(kind)]
        x = [records[name]["median_seconds"] for name in names]
        y = [records[name]["rmse"] for name in names]
        axes.plot(x, y, marker=marker, linestyle="-" if kind == "uniform" else "none", label=kind)
        if kind == "uniform":
            for name, xi, yi in zip(names, x, y, strict=True):
                axes.annotate(name, (xi, yi), fontsize=7, xytext=(4, 3), textcoords="offset points")
        else:  # the thresholds lie on one another: one label
            label = f"adaptive 16, threshold {min(THRESHOLDS):g} to {max(THRESHOLDS):g}"
            axes.annotate(label, (min(x), max(y)), fontsize=7, xytext=(4, 8), textcoords="offset points")
    axes.set_xlabel("median seconds per frame (same run)")
    axes.set_ylabel(f"RMSE against {summary['truth_samples']} samples")
    axes.set_yscale("log")
    axes.set_title(f"Default frame {summary['width']}x{summary['height']}: adaptive 16 samples against uniform")
    axes.grid(True, alpha=0.3)
    axes.legend()
    figure.tight_layout()
    figure.savefig(path)


if __name__ == "__main__":
    main()
