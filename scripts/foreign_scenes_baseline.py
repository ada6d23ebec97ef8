"""Runs the foreign-scene acceptance suite (tests/addon/test_foreign_scenes.py: geometry, frames and visibility;
materials, lights and world) in the bpy wheel and in Debian's Blender 3.4.1 and writes the measured numbers per
scene and per Blender as a Markdown table (docs/foreign-scenes-baseline.md was made by it):

    .venv/bin/python scripts/foreign_scenes_baseline.py --out docs/foreign-scenes-baseline-table.md
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SUITE = ROOT / "tests" / "addon" / "test_foreign_scenes.py"

# what each scene is held to (the asserts of tests/addon/test_foreign_scenes.py)
BOUNDS = {
    "keyed_cube": "IoU >= 0.99 each frame; centroid <= 1 px, F12 and -a, frames 1-5",
    "keyed_camera": "IoU >= 0.99 each frame; centroid <= 1 px, F12 and -a, frames 1-5",
    "parented_child": "IoU >= 0.99 each frame; centroid <= 1 px, F12 and -a, frames 1-5",
    "smooth_suzanne": "IoU >= 0.99; shading error <= 0.03 and <= half Cycles' flat-vs-smooth",
    "mirrored_object": "IoU >= 0.99; mirrored/original brightness = Cycles' within 5%",
    "per_face_materials": "IoU >= 0.99; slot colour agrees on >= 98% of pixels",
    "excluded_collection": "IoU >= 0.99; alpha differs on <= 0.5%; shading error <= 0.05, wrong pixels <= 1%",
    "shadow_ray_visibility_off": "shading error <= 0.05 and wrong pixels <= 1% (no shadow from the sphere)",
    "glossy_ray_visibility_off": "PSNR >= 35 dB (the red cube missing from the mirror)",
    "back_facing_plane": "back/front brightness = Cycles' within 5% (two-sided shading)",
    "red_principled_sphere": "mean colour per channel within 3% (or 0.002)",
    "point_light_100w": "near and far patch within 3%",
    "point_light_1000w": "near and far patch within 3%",
    "spot_light_100w": "near and far patch within 3%; lit-area IoU >= 0.97",
    "spot_light_1000w": "near and far patch within 3%; lit-area IoU >= 0.97",
    "emission_plane": "mean colour per channel within 2%",
    "world_colour": "background = world colour x strength (max diff 0.002)",
    "mirror_scene": "PSNR >= 35 dB",
    "factory_startup": "mean brightness within 10%",
}
VISIBILITY = {
    "excluded_collection",
    "collection_disabled_in_renders",
    "camera_ray_visibility_off",
    "holdout_object",
    "film_transparent",
}


def bound(name: str) -> str:
    if name in BOUNDS:
        return BOUNDS[name]
    if name in VISIBILITY:
        return "IoU >= 0.99; alpha differs on <= 0.5% of pixels"
    return "IoU >= 0.99" if name != "flat_suzanne" else "(Cycles reference of smooth_suzanne)"


def run(blender: str, report: Path) -> float:
    environment = {**os.environ, "WEATHERVANE_FOREIGN_SCENES": "1", "WEATHERVANE_FOREIGN_REPORT": str(report)}
    arguments = ["-q", "-p", "no:cacheprovider", str(SUITE)]
    if blender == "wheel":
        command = [sys.executable, "-m", "pytest", *arguments]
    else:
        command = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python"]
        command += [str(ROOT / "tests" / "addon" / "run_in_blender.py"), "--", *arguments]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True, timeout=900)
    return time.perf_counter() - started


def cell(numbers: dict) -> str:
    def show(value):
        if isinstance(value, float):
            return f"{value:.4g}"
        if isinstance(value, list):
            return "[" + ", ".join(show(item) for item in value) + "]"
        return str(value)

    parts = []
    for key, value in numbers.items():
        if key in ("cycles_s", "tracer_s"):
            continue
        if key == "errors":
            for where, error in value.items():
                first = " ".join(str(error).replace(f"{ROOT}/", "").split())[:160].replace("|", "/")
                parts.append(f"**{where} refused**: {first}")
            continue
        parts.append(f"{key} {show(value)}")
    return "; ".join(parts) or "-"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="the Markdown file (default: standard output)")
    parser.add_argument("--blender", default=shutil.which("blender"), help="Blender 3.4.1's executable")
    arguments = parser.parse_args()
    reports, seconds = {}, {}
    with tempfile.TemporaryDirectory() as folder:
        for label, blender in (("wheel", "wheel"), ("blender", arguments.blender)):
            if blender is None:
                continue
            path = Path(folder) / f"{label}.json"
            seconds[label] = run(blender, path)
            if path.exists():
                reports[label] = json.loads(path.read_text())
    versions = {label: report["summary"]["blender"] for label, report in reports.items()}
    lines = ["| scene | held to | " + " | ".join(f"Blender {versions[label]} today" for label in reports) + " |"]
    lines.append("|" + " --- |" * (2 + len(reports)))
    names = list(next(iter(reports.values()))["scenes"]) if reports else []
    for name in names:
        cells = [cell(report["scenes"].get(name, {})) for report in reports.values()]
        lines.append(f"| {name} | {bound(name)} | " + " | ".join(cells) + " |")
    lines.append("")
    for label, report in reports.items():
        lines.append(
            f"Blender {versions[label]}: suite {report['summary']['seconds']} s inside pytest, "
            f"{seconds[label]:.1f} s with start-up."
        )
    text = "\n".join(lines) + "\n"
    if arguments.out:
        arguments.out.write_text(text)
    else:
        print(text)


if __name__ == "__main__":
    main()
