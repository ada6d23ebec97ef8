"""Rendered images (linear float .npy) -> metrics.json, a difference heat map per pair and report.html.

Usage: python scripts/compare_images.py FOLDER [--reference tracer]
FOLDER holds `<engine>.npy` (H x W x 3 linear) and `timings.json` from render_both.py (and, from its --passes, the
tracer's data passes as passes/tracer.<pass>.npy beside Cycles' passes/cycles.exr). Every pair is compared in
the same color space, the display's: linear values clamped to [0, 1] and sRGB-encoded, as a viewer sees them (and
as FLIP's LDR mode expects). Metrics: PSNR and SSIM (scikit-image), mean FLIP (flip-evaluator), the largest
per-channel error, and the share of pixels whose error exceeds 0.016 in any channel, the threshold of Blender's
own render tests. Passes are compared where both engines see a surface, away from silhouettes (a pixel whose
3 x 3 neighbours all hit in both): coverage IoU, depth and mist relative error, position distance, normal angle,
share of equal indices. Needs the `report` extra (and `exr` for passes); render_both.py calls it with the project's
Python when Blender's lacks it.
"""

from __future__ import annotations

import argparse
import html
import itertools
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BLENDER_THRESHOLD = 0.016
# Cycles' channels of each tracer pass in its multilayer file: Blender 3.4/4.x names first, then Blender 5's
CYCLES_CHANNELS = {
    "depth": (["Depth.Z"],),
    "mist": (["Mist.Z"],),
    "normal": (["Normal.X", "Normal.Y", "Normal.Z"],),
    "position": (["Position.X", "Position.Y", "Position.Z"],),
    "object_index": (["IndexOB.X"], ["Object Index.X"]),
    "material_index": (["IndexMA.X"], ["Material Index.X"]),
}
BACKGROUND_DEPTH = 1.0e9  # both engines write 1e10 where a camera ray meets nothing


def display(linear: np.ndarray) -> np.ndarray:
    """Linear RGB -> clamped, sRGB-encoded floats in [0, 1]."""
    x = np.clip(np.nan_to_num(linear.astype(np.float64)), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def compare(reference: np.ndarray, test: np.ndarray) -> tuple[dict, np.ndarray]:
    """Metrics of test against reference (both linear H x W x 3) and the FLIP heat map (H x W x 3, magma)."""
    import flip_evaluator
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity

    a, b = display(reference), display(test)
    error = np.abs(a - b)
    flip_map, mean_flip, _ = flip_evaluator.evaluate(a.astype(np.float32), b.astype(np.float32), "LDR")
    metrics = {
        "psnr_db": round(float(peak_signal_noise_ratio(a, b, data_range=1.0)), 3),
        "ssim": round(float(structural_similarity(a, b, data_range=1.0, channel_axis=2)), 5),
        "mean_flip": round(float(mean_flip), 5),
        "max_error": round(float(error.max()), 5),
        "share_over_0.016": round(float((error.max(axis=2) > BLENDER_THRESHOLD).mean()), 5),
    }
    return metrics, np.asarray(flip_map)


def compare_passes(folder: Path) -> dict | None:
    """The tracer's passes (folder/passes/tracer.<pass>.npy, (H, W, C)) against Cycles' (folder/passes/cycles.exr)
    -> {pass: metrics}, or None where render_both.py compared no passes."""
    from tracer.tracing.exr import read_exr_channels

    tracer = {path.name.split(".")[1]: np.load(path) for path in sorted(folder.glob("passes/tracer.*.npy"))}
    if "depth" not in tracer or not (folder / "passes" / "cycles.exr").exists():
        return None
    channels, _ = read_exr_channels(folder / "passes" / "cycles.exr")
    cycles = {name: _cycles_pass(channels, name) for name in tracer}
    hit_tracer = tracer["depth"][..., 0] < BACKGROUND_DEPTH
    hit_cycles = cycles["depth"][..., 0] < BACKGROUND_DEPTH
    both = hit_tracer & hit_cycles
    inside = both.copy()  # away from silhouettes: every 3 x 3 neighbour hits in both engines
    padded = np.pad(both, 1)
    for dy in range(3):
        for dx in range(3):
            inside &= padded[dy : dy + both.shape[0], dx : dx + both.shape[1]]
    result = {"coverage_iou": round(float(both.sum() / max(1, (hit_tracer | hit_cycles).sum())), 5)}
    result["pixels_compared"] = int(inside.sum())
    for name, ours in tracer.items():
        a, b = ours[inside].astype(np.float64), cycles[name][inside].astype(np.float64)
        if name in ("depth", "mist"):
            error = np.abs(a - b)[:, 0] / np.maximum(np.abs(b[:, 0]), 1e-6)
            label = "relative_error"
        elif name == "position":
            error, label = np.linalg.norm(a - b, axis=1), "distance"
        elif name == "normal":
            cosine = (a * b).sum(axis=1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-12)
            error, label = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))), "angle_degrees"
        else:
            result[name] = {"share_equal": round(float((np.rint(a) == np.rint(b)).mean()) if a.size else 1.0, 5)}
            continue
        quantiles = np.quantile(error, [0.5, 0.95]) if error.size else (0.0, 0.0)
        result[name] = {f"median_{label}": float(f"{quantiles[0]:.4g}"), f"p95_{label}": float(f"{quantiles[1]:.4g}")}
    return result


def _cycles_pass(channels: dict[str, np.ndarray], name: str) -> np.ndarray:
    """A pass of Cycles' multilayer file as (H, W, C), by the channel names of any supported Blender."""
    for names in CYCLES_CHANNELS[name]:
        found = [next((v for key, v in channels.items() if key.endswith(f".{wanted}")), None) for wanted in names]
        if all(values is not None for values in found):
            return np.stack(found, axis=-1)
    raise ValueError(f"Cycles' passes file has no {name} pass (channels: {', '.join(sorted(channels))})")


def _save_png(pixels: np.ndarray, path: Path) -> None:
    from PIL import Image

    from tracer.tracing.images import atomic_path

    with atomic_path(path) as temporary:
        Image.fromarray(np.clip(pixels * 255.0 + 0.5, 0, 255).astype(np.uint8)).save(temporary, format="PNG")


def write_report(folder: Path, reference: str = "tracer") -> dict:
    """Compare every pair of `<engine>.npy` in folder; write heat maps, metrics.json and report.html."""
    from tracer.tracing.images import atomic_path

    images = {path.stem: np.load(path) for path in sorted(folder.glob("*.npy"))}
    # the reference first, then the exact twin (the physical twin is compared with it: how far the documented
    # model is from a physically based renderer)
    order = sorted(images, key=lambda name: (name != reference, name != "exact"))
    timings_path = folder / "timings.json"
    timings = json.loads(timings_path.read_text()) if timings_path.exists() else {}
    pairs = {}
    for first, second in itertools.combinations(order, 2):
        metrics, heat = compare(images[first], images[second])
        key = f"{second}_vs_{first}"
        _save_png(heat, folder / f"diff_{key}.png")
        pairs[key] = metrics
    for name in order:
        _save_png(display(images[name]), folder / f"{name}.png")
    result = {
        "reference": order[0] if order else None,
        "pairs": pairs,
        "timings_s": timings,
        "color_space": "display sRGB, clamped to [0, 1]",
    }
    passes = compare_passes(folder)
    if passes is not None:
        result["passes"] = {"cycles_vs_tracer": passes}
    with atomic_path(folder / "metrics.json") as temporary:
        temporary.write_text(json.dumps(result, indent=2))
    with atomic_path(folder / "report.html") as temporary:
        temporary.write_text(_html(order, pairs, timings, passes), encoding="utf-8")
    return result


def _html(order: list[str], pairs: dict, timings: dict, passes: dict | None = None) -> str:
    rows = []
    if passes:
        cells = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(str(v))}</td></tr>" for k, v in passes.items())
        rows.append(f"<h2>Data passes: Cycles against the tracer</h2><table>{cells}</table>")
    for key, metrics in pairs.items():
        test, reference = key.split("_vs_")
        cells = "".join(f"<td>{html.escape(str(value))}</td>" for value in metrics.values())
        rows.append(
            f"<h2>{html.escape(test)} against {html.escape(reference)}</h2>"
            f"<table><tr>{''.join(f'<th>{html.escape(k)}</th>' for k in metrics)}</tr><tr>{cells}</tr></table>"
            f"<div class='row'><figure><img src='{test}.png' data-other='{reference}.png' class='swap'>"
            f"<figcaption>{html.escape(test)} (hover: {html.escape(reference)})</figcaption></figure>"
            f"<figure><img src='{reference}.png'><figcaption>{html.escape(reference)}</figcaption></figure>"
            f"<figure><img src='diff_{key}.png'><figcaption>FLIP error (magma: dark = equal)</figcaption></figure>"
            "</div>"
        )
    timing_rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v:.2f} s</td></tr>" for k, v in timings.items())
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Weathervane: tracer and Blender compared</title>
<style>
body {{ font-family: sans-serif; margin: 2em; background: #1d1d1d; color: #ddd; }}
table {{ border-collapse: collapse; margin: 0.5em 0; }} td, th {{ border: 1px solid #555; padding: 0.3em 0.6em; }}
.row {{ display: flex; gap: 1em; flex-wrap: wrap; }} figure {{ margin: 0; }} img {{ max-width: 480px; }}
</style></head><body>
<h1>The documented tracer and Blender, rendered from the same scene</h1>
<p>Images are compared as displayed: linear values clamped to [0, 1] and sRGB-encoded. Hover over the first image of
a row to see the reference in its place, as Blender's render test reports do.</p>
<h2>Render times</h2><table>{timing_rows}</table>
{"".join(rows)}
<script>
for (const img of document.querySelectorAll('img.swap')) {{
  const own = img.src, other = img.dataset.other;
  img.addEventListener('mouseenter', () => {{ img.src = other; }});
  img.addEventListener('mouseleave', () => {{ img.src = own; }});
}}
</script></body></html>
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--reference", default="tracer")
    args = parser.parse_args()
    result = write_report(args.folder, args.reference)
    print(json.dumps(result["pairs"]))


if __name__ == "__main__":
    main()
