"""What caps the exact twin's agreement with the tracer, measured: the same scene compared step by step with each
known difference taken away (docs/comparison.md).

    python scripts/exact_twin_caps.py [--scenes default,mirror] [--width 640 --height 480] [--out out/caps]

Steps: `+`-joined changes to the demo's comparison (default: box, centres, centres+robust, centres+robust+fine,
box+fine):
  box        the demo's comparison: the tracer at 4 x 4 stratified samples, the exact twin at --samples with the
             twin's box filter (width 1)
  centres    both at the pixel centres (the tracer's one sample, Cycles' narrowest filter, 4 samples): no sampling
             difference
  robust     the tracer's robust numerics: no light leaking through the shared edges of the documented triangles
  fine       spheres and cylinders tessellated to 1/50 pixel instead of 1/2 (the add-on's build.segments_for)

Each step runs scripts/render_both.py's functions in a fresh Python (a clean Blender); prints one table row per
scene and step and writes caps.json.
"""

from __future__ import annotations

import argparse
import copy
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

STEPS = ("box", "centres", "centres+robust", "centres+robust+fine", "box+fine")


def scene_document(name: str, step: str) -> dict:
    from make_templates import TEMPLATES

    document = copy.deepcopy(TEMPLATES["default_vane" if name == "default" else "mirror_studio"]())
    if "robust" in step.split("+"):
        document["render"]["numerics"] = "robust"
    return document


def run_step(name: str, step: str, width: int, height: int, samples: int, out: Path) -> dict:
    """In this (fresh) process: build the scene, render the tracer and the exact twin, compare."""
    import functools

    import render_both

    from addon.vane import build

    changes = step.split("+")
    if "fine" in changes:
        build.segments_for = functools.partial(build.segments_for, max_error_pixels=0.02)
        build.MAX_SEGMENTS = 4096
    out.mkdir(parents=True, exist_ok=True)
    scene_file = out / "scene.json"
    scene_file.write_text(json.dumps(scene_document(name, step)))
    arguments = [str(scene_file), "--out", str(out), "--width", str(width), "--height", str(height)]
    arguments += ["--engines", "tracer,exact", "--cycles-samples", str(4 if "centres" in changes else samples)]
    arguments += ["--pixel-centres"] if "centres" in changes else []
    args = render_both.parse(arguments)
    render_both.prepare(args)
    timings = render_both.render_frame(args, out)
    metrics = render_both.compare(out)["pairs"]["exact_vs_tracer"]
    return {**metrics, "timings_s": timings}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="default,mirror")
    parser.add_argument("--steps", default=",".join(STEPS))
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--samples", type=int, default=256, help="the exact twin's samples at the box step")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "caps")
    parser.add_argument("--one", nargs=2, metavar=("SCENE", "STEP"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        name, step = args.one
        result = run_step(name, step, args.width, args.height, args.samples, args.out / name / step)
        print("RESULT " + json.dumps(result), flush=True)
        sys.exit(0)
    results: dict[str, dict] = {}
    print("| scene | step | PSNR | mean FLIP | over 0.016 | tracer | exact twin |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in args.scenes.split(","):
        for step in args.steps.split(","):
            command = [sys.executable, __file__, "--one", name, step, "--out", str(args.out)]
            command += ["--width", str(args.width), "--height", str(args.height), "--samples", str(args.samples)]
            finished = subprocess.run(command, capture_output=True, text=True)
            lines = [line for line in finished.stdout.splitlines() if line.startswith("RESULT ")]
            if finished.returncode != 0 or not lines:
                print(f"| {name} | {step} | failed: {finished.stderr.strip()[-300:]} |", flush=True)
                continue
            result = results.setdefault(name, {})[step] = json.loads(lines[-1].removeprefix("RESULT "))
            timings = result["timings_s"]
            print(
                f"| {name} | {step} | {result['psnr_db']:.2f} dB | {result['mean_flip']:.4f} | "
                f"{100 * result['share_over_0.016']:.2f}% | {timings['tracer']:.1f} s | {timings['exact']:.1f} s |",
                flush=True,
            )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "caps.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
