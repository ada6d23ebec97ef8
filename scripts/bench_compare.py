"""Same-run speed comparison: the working tree against a git commit (REF), and both against the peer rt3.py.

Usage: python scripts/bench_compare.py --ref <commit> [--rounds 7] [--frames 5] [--cases default64,default32,...]
(`make bench-compare REF=<commit>`).

REF is exported with `git archive` into a temporary folder (the repository and its worktrees are not touched). Each
round runs one fresh process per side (REF, the working tree, and for the peer's scene rt3.py), in alternating
order, so that both see the same load on a shared machine. A process renders one warm-up frame (pool start, scene
preparation) and then FRAMES frames with one persistent Renderer, timed around Renderer.render (rt3.py: around its
raytrace() call, as it times itself); the process reports the median of its frames. The figure of a side is the
median over rounds, and the ratio printed is the median of the per-round ratios (new / REF), with its range.

Cases:
  default64, default32  the built-in scene, 640x480, depth 3, 1 sample, 2 workers, float64 / float32
  peer64, peer32        rt3.py's scene (4 spheres, a point light, 2 bounces, 400x300) in the scene format,
                        1 worker (one process), float64 / float32; rt3.py itself is timed in the same rounds
The last line of the output is one JSON object with every figure.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PEER = Path("/work/shared/peers/rt3/rt3.py")

# rt3.py's scene in the scene format. rt3's (x, y, z) (y up, left-handed) is Blender's (x, z, y). Its eye at
# (0, 0.35, -1) looks along +z through the screen z = 0 spanning x in [-1, 1] (90 degrees across) and centred at
# y = 0.25 (shift_y = -0.1 / 2). Same ray counts as rt3.py: every hit casts one shadow ray, every hit before the
# last bounce a mirror ray (every material reflects). What the format does not say the same way: rt3's checkered
# floor (here plain), its screen points at linspace(-1, 1, w) (here pixel centres), its Lambert term with the
# shadow test from a nudged point (here the documented FindIntensity: shadow t in (0.001, 1), specular added where
# N.L <= 0), its local colour not weighted by 1 - r and mirror rays from a nudged point (here t > 0.01).
PEER_SCENE = {
    "materials": {
        "blue": {"color": [0, 0, 1], "specular": 50, "reflective": 0.5},
        "purple": {"color": [0.5, 0.223, 0.5], "specular": 50, "reflective": 0.5},
        "orange": {"color": [1, 0.572, 0.184], "specular": 50, "reflective": 0.5},
        "floor": {"color": [0.75, 0.75, 0.75], "specular": 50, "reflective": 0.25},
    },
    "objects": [
        {"name": "s1", "type": "sphere", "material": "blue", "location": [0.75, 1, 0.1], "radius": 0.6},
        {"name": "s2", "type": "sphere", "material": "purple", "location": [-0.75, 2.25, 0.1], "radius": 0.6},
        {"name": "s3", "type": "sphere", "material": "orange", "location": [-2.75, 3.5, 0.1], "radius": 0.6},
        {"name": "floor", "type": "sphere", "material": "floor", "location": [0, 0, -99999.5], "radius": 99999},
    ],
    "lights": [{"type": "ambient", "intensity": 0.05}, {"type": "point", "location": [5, -10, 5], "intensity": 1}],
    "camera": {
        "location": [0, -1, 0.35],
        "rotation": [90, 0, 0],
        "fov": 90,
        "sensor_fit": "HORIZONTAL",
        "shift_y": -0.05,
    },
    "background": {"type": "solid", "color": [0, 0, 0]},
    "render": {"width": 400, "height": 300, "depth": 2, "model": "blinn-phong", "coef": 1, "samples": 1},
}

CASES = {
    "default64": {"scene": None, "dtype": "float64", "workers": 2},
    "default32": {"scene": None, "dtype": "float32", "workers": 2},
    "peer64": {"scene": PEER_SCENE, "dtype": "float64", "workers": 1},
    "peer32": {"scene": PEER_SCENE, "dtype": "float32", "workers": 1},
}

TRACER_CHILD = """
import hashlib, json, statistics, sys, time
import tracer
case = json.loads(sys.argv[1])
if case["scene"] is None:
    scene = tracer.default_scene().with_render(width=640, height=480, depth=3, samples=1, dtype=case["dtype"])
else:
    scene = tracer.scene_from_dict(case["scene"]).with_render(dtype=case["dtype"])
with tracer.Renderer(case["workers"]) as renderer:
    result = renderer.render(scene)  # warm-up: pool start, imports, caches
    times = []
    for _ in range(case["frames"]):
        started = time.perf_counter()
        result = renderer.render(scene)
        times.append(time.perf_counter() - started)
rays = result.rays
print(json.dumps({"seconds": statistics.median(times), "md5": hashlib.md5(result.image.tobytes()).hexdigest(),
                  "rays": [rays.camera, rays.shadow, rays.reflection]}))
"""

PEER_CHILD = """
import json, statistics, sys, time
source = open(sys.argv[1]).read()
source = source.replace("from PIL import Image", "").split("t0 = time.time()")[0]
namespace = {"__name__": "rt3"}
exec(compile(source, sys.argv[1], "exec"), namespace)
vec3, raytrace, scene, E, x, y = (namespace[k] for k in ("vec3", "raytrace", "scene", "E", "x", "y"))
frames = int(sys.argv[2])
raytrace(E, (vec3(x, y, 0) - E).norm(), scene)  # warm-up
times = []
for _ in range(frames):
    started = time.perf_counter()
    Q = vec3(x, y, 0)
    raytrace(E, (Q - E).norm(), scene)
    times.append(time.perf_counter() - started)
print(json.dumps({"seconds": statistics.median(times)}))
"""


def export(ref: str, into: Path) -> Path:
    """The tree of commit ref, written into a folder (git archive: no worktree, no change to the repository)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def run_tracer(root: Path, case: dict, frames: int) -> dict:
    argument = json.dumps({**case, "frames": frames})
    done = subprocess.run(
        [sys.executable, "-c", TRACER_CHILD, argument], cwd=root, check=True, capture_output=True, text=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def run_peer(frames: int) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", PEER_CHILD, str(PEER), str(frames)], check=True, capture_output=True, text=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", required=True, help="the commit to compare the working tree with")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--frames", type=int, default=5, help="frames per process after its warm-up")
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    cases = [name.strip() for name in args.cases.split(",") if name.strip()]
    unknown = [name for name in cases if name not in CASES]
    if unknown:
        parser.error(f"--cases: unknown {', '.join(unknown)}; expected some of {', '.join(CASES)}")
    folder = Path(tempfile.mkdtemp(prefix="bench-compare-"))
    try:
        old_root = export(args.ref, folder)
        report = {"ref": args.ref, "rounds": args.rounds, "frames": args.frames, "cases": {}}
        for name in cases:
            case = CASES[name]
            sides = {"ref": [], "new": []}
            if case["scene"] is not None:
                sides["rt3"] = []
            md5s, rays = {}, {}
            for round_index in range(args.rounds):
                order = list(sides) if round_index % 2 == 0 else list(reversed(sides))
                for side in order:
                    if side == "rt3":
                        sides[side].append(run_peer(args.frames)["seconds"])
                        continue
                    measured = run_tracer(old_root if side == "ref" else ROOT, case, args.frames)
                    sides[side].append(measured["seconds"])
                    md5s[side], rays[side] = measured["md5"], measured["rays"]
            ratios = [new / old for new, old in zip(sides["new"], sides["ref"], strict=True)]
            entry = {
                "ms": {side: round(1000 * statistics.median(times), 2) for side, times in sides.items()},
                "new_over_ref": round(statistics.median(ratios), 3),
                "new_over_ref_range": [round(min(ratios), 3), round(max(ratios), 3)],
                "same_bytes": md5s["new"] == md5s["ref"],
                "rays_new": rays["new"],
                "rays_ref": rays["ref"],
            }
            if "rt3" in sides:
                for side in ("new", "ref"):
                    peer = [mine / theirs for mine, theirs in zip(sides[side], sides["rt3"], strict=True)]
                    entry[f"{side}_over_rt3"] = round(statistics.median(peer), 3)
            report["cases"][name] = entry
            ms = entry["ms"]
            line = f"{name:10s} ref {ms['ref']:8.2f} ms  new {ms['new']:8.2f} ms  new/ref {entry['new_over_ref']:.3f}"
            line += f" [{entry['new_over_ref_range'][0]:.3f}-{entry['new_over_ref_range'][1]:.3f}]"
            if "rt3" in sides:
                line += f"  rt3 {ms['rt3']:7.2f} ms  new/rt3 {entry['new_over_rt3']:.3f}"
                line += f"  ref/rt3 {entry['ref_over_rt3']:.3f}"
            line += "  bytes " + ("same" if entry["same_bytes"] else "DIFFER") + f"  rays {entry['rays_new']}"
            print(line, flush=True)
        print(json.dumps(report))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
