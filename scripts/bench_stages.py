"""Where the time goes: CPU milliseconds per stage of one frame of the default scene (or a mesh scene of
scripts/mesh_scenes.py), all bands in this process.

Usage: python scripts/bench_stages.py [--dtype float64|float32] [--repeats 7] [--width 640 --height 480 --depth 3]
                                      [--mesh sphere1k|sphere16k|sphere100k|suzanne2]
Each stage (the hierarchy's closest hits, the shadow rays, FindIntensity's arithmetic, normals, TraceRay's loop,
the camera rays and band assembly, a scene's preparation; for a mesh, its picture searches and walks within the
first two and the pictures' making in the first frame) is wrapped with a thread-CPU timer; the figures are
medians over the repeats. CPU time, not wall time: the machine is shared (docs/performance.md).
"""

from __future__ import annotations

import argparse
import collections
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import mesh_scenes

from tracer.geometry import bvh, meshbvh, meshpicture
from tracer.scene.loader import default_scene, scene_from_dict
from tracer.tracing import shading, shadows, wavefront
from tracer.workers import parallel

spent: collections.Counter = collections.Counter()
MESHES = {
    "sphere1k": lambda: mesh_scenes.uv_sphere(1000),
    "sphere16k": lambda: mesh_scenes.uv_sphere(16000),
    "sphere100k": lambda: mesh_scenes.uv_sphere(100000),
    "suzanne2": lambda: mesh_scenes.suzanne(2),
}


def timed(owner: object, name: str, label: str) -> None:
    original = getattr(owner, name)

    def wrapper(*args, **kwargs):
        started = time.thread_time()
        try:
            return original(*args, **kwargs)
        finally:
            spent[label] += time.thread_time() - started

    setattr(owner, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--depth", type=int, default=3)
    parser.add_argument("--mesh", choices=sorted(MESHES), help="a mesh in the vane's place instead of the vane")
    args = parser.parse_args()
    settings = {"width": args.width, "height": args.height, "depth": args.depth, "samples": 1, "dtype": args.dtype}
    if args.mesh:
        scene = scene_from_dict(mesh_scenes.mesh_scene(*MESHES[args.mesh](), **settings))
    else:
        scene = default_scene().with_render(**settings)
    timed(bvh.Hierarchy, "closest", "closest")
    timed(shadows, "reached", "shadow")
    timed(shading, "find_intensity", "intensity")
    timed(wavefront.TracedScene, "normals", "normals")
    timed(wavefront.TracedScene, "trace", "trace")
    timed(wavefront.TracedScene, "render_rows", "rows")
    timed(meshbvh.MeshKernel, "_search_cells", "pictures")
    timed(meshbvh.MeshKernel, "_search", "walk")
    timed(meshpicture.TrianglePicture, "build", "making pictures")
    parallel.tune_allocator()
    prepared = parallel.TracedScene(scene)
    bands = parallel.bands(scene.render)
    for rows in bands:  # warm-up: camera rays cached, allocator warmed, a mesh's pictures made
        prepared.render_rows(rows)
    making = 1000 * spent["making pictures"]
    samples = collections.defaultdict(list)
    for _ in range(args.repeats):
        spent.clear()
        started = time.thread_time()
        parallel.TracedScene(scene)
        preparation = time.thread_time() - started
        for rows in bands:
            prepared.render_rows(rows)
        ms = {key: 1000 * value for key, value in spent.items()}
        stages = {
            "closest hits (camera and mirror rays)": ms["closest"],
            "shadow rays (planes, coverage grids, any-hit)": ms["shadow"],
            "shading arithmetic (FindIntensity without its shadow rays)": ms["intensity"] - ms["shadow"],
            "normals": ms["normals"],
            "TraceRay's loop: gathers, sky, accumulation, materials": ms["trace"]
            - ms["closest"]
            - ms["intensity"]
            - ms["normals"],
            "camera rays, box filter, band assembly": ms["rows"] - ms["trace"],
            "one frame's tracing, all bands": ms["rows"],
            "preparing the scene (once per scene)": 1000 * preparation,
        }
        if args.mesh:
            stages["of the closest hits and shadow rays: the mesh's picture searches"] = ms["pictures"]
            stages["of the closest hits and shadow rays: the mesh's walks (mirror rays)"] = ms["walk"]
            stages["making the mesh's pictures (first frame only)"] = making
        for label, value in stages.items():
            samples[label].append(value)
    case = f"{args.mesh or 'default scene'}, {args.dtype}, {args.width}x{args.height}, depth {args.depth}"
    print(f"| stage ({case}) | CPU ms |")
    print("| --- | --- |")
    for label, values in samples.items():
        print(f"| {label} | {statistics.median(values):.1f} |")


if __name__ == "__main__":
    main()
