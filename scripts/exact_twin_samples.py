"""The exact twin's agreement with the tracer and its time against Cycles' samples per pixel -> a chart and its
numbers (docs/exact-twin-samples.png, .json), beside the tracer's own time on the same frame.

Each sample count is one run of scripts/render_both.py (`--engines tracer,exact`) in a fresh process, so every
point is what a user gets from that command. Usage:
    python scripts/exact_twin_samples.py [--samples 4,16,64,256] [--width 320 --height 240] [--out docs]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def measure(samples: int, width: int, height: int, folder: Path) -> dict:
    """One render_both run at this many exact-twin samples: its PSNR, mean FLIP and both renderers' times."""
    subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "render_both.py"), "--engines", "tracer,exact", "--out", str(folder),
         "--width", str(width), "--height", str(height), "--cycles-samples", str(samples)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    metrics = json.loads((folder / "metrics.json").read_text())
    pair = metrics["pairs"]["exact_vs_tracer"]
    return {
        "samples": samples,
        "psnr_db": pair["psnr_db"],
        "mean_flip": pair["mean_flip"],
        "exact_seconds": metrics["timings_s"]["exact"],
        "tracer_seconds": metrics["timings_s"]["tracer"],
    }


def chart(points: list[dict], width: int, height: int, target: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    samples = [point["samples"] for point in points]
    figure, (agreement, time) = plt.subplots(1, 2, figsize=(9, 3.4))
    agreement.semilogx(samples, [point["psnr_db"] for point in points], "o-", base=2, label="PSNR")
    agreement.axhline(50, color="grey", linestyle=":", label="issue's bar (50 dB)")
    agreement.set(xlabel="exact twin: Cycles samples per pixel", ylabel="PSNR against the tracer (dB)")
    flip = agreement.twinx()
    flip.semilogx(samples, [point["mean_flip"] for point in points], "s--", color="tab:orange", base=2)
    flip.set_ylabel("mean FLIP", color="tab:orange")
    agreement.legend(loc="lower right", fontsize=8)
    time.loglog(samples, [point["exact_seconds"] for point in points], "o-", base=2, label="exact twin (Cycles)")
    tracer = sorted(point["tracer_seconds"] for point in points)[len(points) // 2]
    time.axhline(tracer, color="tab:green", linestyle="--", label=f"tracer, 16 samples ({tracer:.2f} s)")
    time.set(xlabel="exact twin: Cycles samples per pixel", ylabel="seconds per frame")
    time.legend(fontsize=8)
    figure.suptitle(f"Default scene, {width}x{height}, bpy 5.0.1 on this machine's 2 cores", fontsize=9)
    figure.tight_layout()
    figure.savefig(target, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", default="4,16,64,256", help="comma-separated Cycles samples per pixel")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    args = parser.parse_args()
    try:
        counts = [int(value) for value in args.samples.split(",")]
    except ValueError:
        parser.error(f"--samples: expected comma-separated whole numbers, got {args.samples!r}")
    if any(count < 1 for count in counts):
        parser.error(f"--samples: every count must be >= 1, got {args.samples!r}")
    points = []
    with tempfile.TemporaryDirectory() as work:
        for count in counts:
            points.append(measure(count, args.width, args.height, Path(work) / str(count)))
            print(json.dumps(points[-1]))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "exact-twin-samples.json").write_text(json.dumps(points, indent=2) + "\n")
    chart(points, args.width, args.height, args.out / "exact-twin-samples.png")
    print(f"wrote {args.out / 'exact-twin-samples.png'}")


if __name__ == "__main__":
    main()
