"""Same-run speed comparison: the working tree against a git commit (REF), and both against the peer rt3.py.

Usage: python scripts/bench_compare.py --ref <commit> [--rounds 7] [--frames 5] [--cases default64,default32,...]
(`make bench-compare REF=<commit>`).

REF is exported with `git archive` into a temporary folder (the repository and its worktrees are not touched). Each
round runs one fresh process per side (REF, the working tree, and for the peer's scene rt3.py), in alternating
order, so that both see the same load on a shared machine. A process renders one warm-up frame (pool start, scene
preparation) and then FRAMES frames with one persistent Renderer, timed around Renderer.render (rt3.py: around its
raytrace() call, as it times itself); the process reports the median of its frames. The figure of a side is the
median over rounds, and the ratio printed is the median of the per-round ratios (new / REF), with its range. The
CPU time per frame (user + system of the process and its workers, over the FRAMES frames) is reported beside the
wall time: on a shared machine the wall time follows the other processes' load, the CPU time much less. The span
is the CPU time per frame of the busiest process (the parent or one worker): what a frame would take on an idle
machine with a core for each process; it shows what the workers' overlap buys where the machine is too busy for
the wall time to show it.

Cases:
  default64, default32  the built-in scene, 640x480, depth 3, 1 sample, 2 workers, float64 / float32
  glass64               the built-in scene with a glass plinth and parts at alpha 0.6 (see-through wavefronts),
                        640x480, depth 3, 2 workers, float64
  roughglass64          the built-in scene with a rough glass plinth (roughness 0.4: sampled reflection and
                        refraction at the 16 glossy pairs, turned per camera sample), 320x240, depth 3, 2 workers
  roughglass16          the same at the F12 defaults of a scene from Blender (16 samples, adaptive 0.005): a pixel's
                        samples share out the 16 pairs
  peer64, peer32        rt3.py's scene (4 spheres, a point light, 2 bounces, 400x300) in the scene format,
                        1 worker (one process), float64 / float32; rt3.py itself is timed in the same rounds
  cubes                 make bench-scenes' 3,000 separate cubes as the add-on exports them (each its own mesh and
                        material, a ground, a sun and a world light of 16 shadow rays a point), 640x360, 2 workers;
                        only when named (a frame takes seconds)
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


def glass_scene() -> dict:
    """The built-in scene with its plinth stone glass (transmission 1, IOR 1.45), its brass and copper parts at
    alpha 0.6: every stage of a see-through wavefront (refracted, straight and mirror rays, shadows through
    transparency)."""
    document = json.loads((ROOT / "tracer" / "scene" / "default_scene.json").read_text())
    document["materials"]["stone"].update(transmission=1.0, ior=1.45)
    for name in ("brass", "copper"):
        document["materials"][name]["alpha"] = 0.6
    return document


def rough_glass_scene(samples: int = 1) -> dict:
    """The built-in scene at 320x240 with its plinth rough glass (transmission 1, IOR 1.45, roughness 0.4): the
    rough glass rays of glossy.glass_rays at every pair of its first hits, one pair at the hits after; samples > 1:
    that many a pixel, adaptive at 0.005 (the add-on's F12 defaults), the pairs shared out among them."""
    document = json.loads((ROOT / "tracer" / "scene" / "default_scene.json").read_text())
    document["materials"]["stone"].update(transmission=1.0, ior=1.45, transmission_roughness=0.4)
    document["render"].update(width=320, height=240)
    if samples > 1:
        document["render"].update(samples=samples, adaptive_threshold=0.005)
    return document


def cubes_scene() -> dict:
    """make bench-scenes' 3,000 separate cubes as the add-on exports them from Blender: a 60 x 50 grid of 0.8 m cubes
    1.2 m apart, each its own mesh and material (seeded colours, Principled at roughness 0.6), on a 100 m ground,
    under a sun of 0.53 degrees and a world colour (16 shadow rays a point), 640x360 at 1 sample."""
    import random

    colours = random.Random(34)
    principled = {"specular": 4.477, "reflective": 0.0, "glossy": [0.04] * 3, "roughness": 0.6,
                  "glossy_fresnel": "schlick", "glossy_source": "world", "specular_color": [0.0772] * 3,
                  "two_sided": True}  # fmt: skip
    corners = [[x, y, z] for z in (0.0, 0.8) for y in (0.0, 0.8) for x in (0.0, 0.8)]
    faces = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
             [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]  # fmt: skip
    materials = {"ground": {"color": [0.336, 0.288, 0.211], **principled}}
    ground = [[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [50.0, 50.0, 0.0], [-50.0, 50.0, 0.0]]
    objects = [{"name": "ground", "type": "mesh", "material": "ground", "vertices": ground,
                "triangles": [[0, 1, 2], [0, 2, 3]]}]  # fmt: skip
    for row in range(50):
        for column in range(60):
            name = f"cube{len(objects) - 1:04d}"
            x, y = (column - 29.5) * 1.2 - 0.4, (row - 24.5) * 1.2 - 0.4
            materials[name] = {"color": [colours.random() for _ in range(3)], **principled}
            vertices = [[x + a, y + b, c] for a, b, c in corners]
            objects.append({"name": name, "type": "mesh", "material": name, "vertices": vertices, "triangles": faces})
    return {
        "materials": materials,
        "objects": objects,
        "lights": [
            {"type": "directional", "direction": [0.599, -0.281, 0.750], "intensity": 0.955, "angle": 0.526},
            {"type": "world", "radiance": "color", "samples": 16, "intensity": 1.0, "color": [0.15, 0.2, 0.275]},
        ],
        "background": {"type": "solid", "color": [0.15, 0.2, 0.275]},
        "camera": {"location": [0.0, -72.08, 45.05], "rotation": [58.0, 0.0, 0.0], "lens": 50.0, "sensor_width": 36.0},
        "render": {"width": 640, "height": 360, "depth": 3, "model": "blinn-phong", "coef": 3.0, "samples": 1},
    }


CASES = {
    "default64": {"scene": None, "dtype": "float64", "workers": 2},
    "default32": {"scene": None, "dtype": "float32", "workers": 2},
    "peer64": {"scene": PEER_SCENE, "dtype": "float64", "workers": 1},
    "peer32": {"scene": PEER_SCENE, "dtype": "float32", "workers": 1},
    "glass64": {"scene": glass_scene(), "dtype": "float64", "workers": 2},
    "roughglass64": {"scene": rough_glass_scene(), "dtype": "float64", "workers": 2},
    "roughglass16": {"scene": rough_glass_scene(samples=16), "dtype": "float64", "workers": 2},
    "cubes": {"scene": "cubes", "dtype": "float64", "workers": 2},
}

# CPU seconds (user + system) of this process and its children (the workers), from /proc where there is one: on a
# shared machine the wall time follows the other processes' load, the CPU time much less
CPU_TIME = """
import os
def cpu_times():
    # CPU seconds (user + system) of this process and of each of its children (the workers), by process id
    times = {os.getpid(): sum(os.times()[:2])}
    tick = os.sysconf("SC_CLK_TCK")
    for name in os.listdir("/proc") if os.path.isdir("/proc") else []:
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat") as stat:
                    fields = stat.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == os.getpid():
                times[int(name)] = (int(fields[11]) + int(fields[12])) / tick
    return times
def cpu_spent(before, after, frames):
    # (all processes' CPU seconds per frame, the busiest process's CPU seconds per frame)
    spent = [after[pid] - before.get(pid, 0.0) for pid in after]
    return sum(spent) / frames, max(spent) / frames
"""

TRACER_CHILD = (
    CPU_TIME
    + """
import hashlib, json, statistics, sys, time
import tracer
case = json.loads(sys.argv[1])
if case["scene"] is None:
    scene = tracer.default_scene().with_render(width=640, height=480, depth=3, samples=1, dtype=case["dtype"])
elif isinstance(case["scene"], str):  # a scene too large for the command line: its file
    scene = tracer.scene_from_dict(json.loads(open(case["scene"]).read())).with_render(dtype=case["dtype"])
else:
    scene = tracer.scene_from_dict(case["scene"]).with_render(dtype=case["dtype"])
with tracer.Renderer(case["workers"]) as renderer:
    result = renderer.render(scene)  # warm-up: pool start, imports, caches
    times = []
    before = cpu_times()
    for _ in range(case["frames"]):
        started = time.perf_counter()
        result = renderer.render(scene)
        times.append(time.perf_counter() - started)
    cpu, span = cpu_spent(before, cpu_times(), case["frames"])
rays = result.rays
md5 = hashlib.md5(result.image.tobytes()).hexdigest()
print(json.dumps({"seconds": statistics.median(times), "cpu": cpu, "span": span, "md5": md5,
                  "rays": [rays.camera, rays.shadow, rays.reflection]}))
"""
)

PEER_CHILD = (
    CPU_TIME
    + """
import json, statistics, sys, time
source = open(sys.argv[1]).read()
source = source.replace("from PIL import Image", "").split("t0 = time.time()")[0]
namespace = {"__name__": "rt3"}
exec(compile(source, sys.argv[1], "exec"), namespace)
vec3, raytrace, scene, E, x, y = (namespace[k] for k in ("vec3", "raytrace", "scene", "E", "x", "y"))
frames = int(sys.argv[2])
raytrace(E, (vec3(x, y, 0) - E).norm(), scene)  # warm-up
times = []
before = cpu_times()
for _ in range(frames):
    started = time.perf_counter()
    Q = vec3(x, y, 0)
    raytrace(E, (Q - E).norm(), scene)
    times.append(time.perf_counter() - started)
cpu, span = cpu_spent(before, cpu_times(), frames)
print(json.dumps({"seconds": statistics.median(times), "cpu": cpu, "span": span}))
"""
)


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


def compare(case: dict, old_root: Path, new_root: Path, rounds: int, frames: int) -> dict:
    """One case: per side the median over rounds of the per-process median wall time and mean CPU time per frame
    (ms), and the medians of the per-round ratios."""
    sides = ["ref", "new"] + (["rt3"] if case["scene"] is PEER_SCENE else [])
    wall = {side: [] for side in sides}
    cpu = {side: [] for side in sides}
    span = {side: [] for side in sides}
    md5s, rays = {}, {}
    for round_index in range(rounds):
        for side in sides if round_index % 2 == 0 else list(reversed(sides)):
            if side == "rt3":
                measured = run_peer(frames)
            else:
                measured = run_tracer(old_root if side == "ref" else new_root, case, frames)
                md5s[side], rays[side] = measured["md5"], measured["rays"]
            wall[side].append(measured["seconds"])
            cpu[side].append(measured["cpu"])
            span[side].append(measured["span"])

    def ratio(times: dict, mine: str, theirs: str) -> float:
        return round(statistics.median(a / b for a, b in zip(times[mine], times[theirs], strict=True)), 3)

    entry = {
        "wall_ms": {side: round(1000 * statistics.median(times), 2) for side, times in wall.items()},
        "cpu_ms": {side: round(1000 * statistics.median(times), 2) for side, times in cpu.items()},
        "new_over_ref_wall": ratio(wall, "new", "ref"),
        "new_over_ref_wall_range": [
            round(min(a / b for a, b in zip(wall["new"], wall["ref"], strict=True)), 3),
            round(max(a / b for a, b in zip(wall["new"], wall["ref"], strict=True)), 3),
        ],
        "new_over_ref_cpu": ratio(cpu, "new", "ref"),
        "span_ms": {side: round(1000 * statistics.median(times), 2) for side, times in span.items()},
        "new_over_ref_span": ratio(span, "new", "ref"),
        "same_bytes": md5s["new"] == md5s["ref"],
        "rays_new": rays["new"],
        "rays_ref": rays["ref"],
    }
    if "rt3" in sides:
        for side in ("new", "ref"):
            entry[f"{side}_over_rt3_wall"] = ratio(wall, side, "rt3")
            entry[f"{side}_over_rt3_cpu"] = ratio(cpu, side, "rt3")
    return entry


def summary(name: str, entry: dict) -> str:
    wall, cpu = entry["wall_ms"], entry["cpu_ms"]
    low, high = entry["new_over_ref_wall_range"]
    line = f"{name:10s} wall ref {wall['ref']:7.1f} new {wall['new']:7.1f} ms new/ref {entry['new_over_ref_wall']:.3f}"
    line += f" [{low:.2f}-{high:.2f}] | cpu ref {cpu['ref']:7.1f} new {cpu['new']:7.1f} ms"
    line += f" new/ref {entry['new_over_ref_cpu']:.3f}"
    line += f" | span ref {entry['span_ms']['ref']:6.1f} new {entry['span_ms']['new']:6.1f} ms"
    line += f" new/ref {entry['new_over_ref_span']:.3f}"
    if "rt3" in wall:
        line += f" | rt3 wall {wall['rt3']:6.1f} cpu {cpu['rt3']:6.1f} ms; new/rt3 wall"
        line += f" {entry['new_over_rt3_wall']:.3f} cpu {entry['new_over_rt3_cpu']:.3f}"
        line += f"; ref/rt3 wall {entry['ref_over_rt3_wall']:.3f} cpu {entry['ref_over_rt3_cpu']:.3f}"
    return line + " | bytes " + ("same" if entry["same_bytes"] else "DIFFER") + f" rays {entry['rays_new']}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", required=True, help="the commit to compare the working tree with")
    parser.add_argument("--new", default=None, help="a commit to take as the new side instead of the working tree")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--frames", type=int, default=10, help="frames per process after its warm-up")
    parser.add_argument("--cases", default=",".join(name for name in CASES if name != "cubes"))
    args = parser.parse_args()
    cases = [name.strip() for name in args.cases.split(",") if name.strip()]
    unknown = [name for name in cases if name not in CASES]
    if unknown:
        parser.error(f"--cases: unknown {', '.join(unknown)}; expected some of {', '.join(CASES)}")
    folder = Path(tempfile.mkdtemp(prefix="bench-compare-"))
    try:
        (folder / "ref").mkdir()
        old_root = export(args.ref, folder / "ref")
        new_root = ROOT
        if args.new is not None:
            (folder / "new").mkdir()
            new_root = export(args.new, folder / "new")
        report = {
            "ref": args.ref,
            "new": args.new or "working tree",
            "rounds": args.rounds,
            "frames": args.frames,
            "cases": {},
        }
        for name in cases:
            case = CASES[name]
            if case["scene"] == "cubes":  # 3 MB of scene: handed to the processes as a file
                written = folder / "cubes.json"
                written.write_text(json.dumps(cubes_scene()))
                case = {**case, "scene": str(written)}
            report["cases"][name] = compare(case, old_root, new_root, args.rounds, args.frames)
            print(summary(name, report["cases"][name]), flush=True)
        print(json.dumps(report))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
