"""The vane's response to a step in wind direction -> docs/motion-step-response.png (and a table on stdout).

Usage: python scripts/plot_step_response.py [--out docs/motion-step-response.png]
Simulates tracer.scene.motion at 240 fps for three damping ratios and three wind speeds, and draws the closed form
over the samples, so the page shows the model and the integrator's agreement with it at once.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tracer.scene.motion import Motion, frame_times, heading_into_wind, simulate
from tracer.scene.wind import Wind, WindKey
from tracer.tracing.images import atomic_path

WAVELENGTH = 7.0
STEP_FROM = 30.0  # the wind comes from 30 degrees: the vane at heading 0 is pulled to 60


def response(zeta: float, speed: float, fps: float, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    motion = Motion(
        wind=Wind(keys=(WindKey(0.0, STEP_FROM, speed),)), damping=zeta, wavelength=WAVELENGTH, threshold=0.1, fps=fps
    )
    frames = int(seconds * fps) + 1
    return frame_times(frames, fps), simulate(motion, frames, initial_heading=0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/motion-step-response.png"))
    args = parser.parse_args()
    target = heading_into_wind(STEP_FROM)
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4), dpi=110)
    print("zeta  U m/s  overshoot (model)  overshoot (closed form)  period s (model)  period s (closed form)")
    for zeta, color in ((0.3, "tab:red"), (0.5, "tab:blue"), (0.7, "tab:green")):
        times, headings = response(zeta, 5.0, 240.0, 4.0)
        left.plot(times, headings, color=color, label=f"zeta = {zeta}")
        omega = 2 * math.pi * 5.0 / WAVELENGTH
        damped = omega * math.sqrt(1 - zeta**2)
        closed = target - target * np.exp(-zeta * omega * times) * (
            np.cos(damped * times) + zeta * omega / damped * np.sin(damped * times)
        )
        left.plot(times[::24], closed[::24], "o", color=color, markersize=3)
        peaks = [k for k in range(1, headings.size - 1) if headings[k - 1] < headings[k] >= headings[k + 1]]
        period = (peaks[1] - peaks[0]) / 240.0 if len(peaks) > 1 else float("nan")
        print(
            f"{zeta:4}  {5.0:5}  {(headings.max() - target) / target:17.4f}  "
            f"{math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)):23.4f}  {period:16.3f}  "
            f"{2 * math.pi / damped:22.3f}"
        )
    left.axhline(target, color="grey", linewidth=0.8, linestyle="--")
    left.set(
        title=f"Step of 60 degrees, U = 5 m/s, wavelength {WAVELENGTH:g} m",
        xlabel="time (s)",
        ylabel="heading (degrees)",
    )
    left.legend(title="lines: model at 240 fps; dots: closed form", fontsize=8, title_fontsize=8)
    for speed, color in ((2.0, "tab:purple"), (5.0, "tab:blue"), (12.0, "tab:orange")):
        times, headings = response(0.5, speed, 24.0, 4.0)
        right.plot(times, headings, "-", color=color, drawstyle="steps-post", label=f"U = {speed:g} m/s")
    right.axhline(target, color="grey", linewidth=0.8, linestyle="--")
    right.set(title="zeta = 0.5 at 24 fps: stiffer in stronger wind", xlabel="time (s)", ylabel="heading (degrees)")
    right.legend(fontsize=8)
    figure.tight_layout()
    with atomic_path(args.out) as temporary:
        figure.savefig(temporary, format="png")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
