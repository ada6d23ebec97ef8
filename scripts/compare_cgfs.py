"""Gambetta's "Computer Graphics from Scratch" demo scene -> how much each of its conventions that differ from the
documented tracer changes its picture: docs/algorithm/cgfs-differences.png and .json.

Usage: python scripts/compare_cgfs.py [--size 200] [--out docs/algorithm]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from tests import cgfs_peer as peer  # noqa: E402
from tracer.tracing.images import atomic_path  # noqa: E402
from tracer.workers.parallel import render  # noqa: E402

CHANGES = {
    "weighted_last_bounce": "last bounce's local colour x (1 - r)",
    "reflection_epsilon": "mirror rays from t > 0.01 (not 0.001)",
    "unit_camera_rays": "unit camera rays from t > 0 (not D = V - O, t >= 1)",
    "pixel_centres": "pixel centres (not corners)",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=200)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "algorithm")
    args = parser.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    book = peer.render(args.size, peer.BOOK)
    documented = np.clip(render(peer.as_scene(args.size), workers=1).image, 0.0, 1.0)
    rows = {}
    panels = [("the book's conventions", book), ("the documented tracer", documented)]
    for name, label in CHANGES.items():
        changed = peer.render(args.size, replace(peer.BOOK, **{name: True}))
        difference = np.abs(changed - book).max(axis=2)
        rows[name] = {
            "change": label,
            "pixels_changed_over_1_of_255": float((difference > 1 / 255).mean()),
            "max_difference": float(difference.max()),
            "mean_difference": float(difference.mean()),
        }
        panels.append(
            (f"{label}\n{100 * rows[name]['pixels_changed_over_1_of_255']:.1f}% of pixels > 1/255", difference)
        )
    together = np.abs(documented - book).max(axis=2)
    rows["all"] = {
        "change": "all four (the documented tracer)",
        "pixels_changed_over_1_of_255": float((together > 1 / 255).mean()),
        "max_difference": float(together.max()),
        "mean_difference": float(together.mean()),
        "peer_with_all_four_vs_tracer_max": float(np.abs(peer.render(args.size, peer.DOCUMENTED) - documented).max()),
    }
    figure, axes = plt.subplots(2, 3, figsize=(9, 6.6), dpi=100)
    for axis, (title, picture) in zip(axes.ravel(), panels, strict=True):
        if picture.ndim == 3:
            axis.imshow(picture ** (1 / 2.2))
        else:
            axis.imshow(picture, cmap="magma", vmin=0.0, vmax=0.1)  # the largest channel difference, 0 to 0.1
        axis.set_title(title, fontsize=7)
        axis.axis("off")
    figure.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "cgfs-differences.png") as temporary:
        figure.savefig(temporary, format="png")
    with atomic_path(args.out / "cgfs-differences.json") as temporary:
        temporary.write_text(json.dumps({"size": args.size, "changes": rows}, indent=1) + "\n")
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
