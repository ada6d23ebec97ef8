"""How long the 3D View's Rendered shading takes to answer an edit: from the change to the first (1/8) image and to
the full image, at a typical viewport size, in the bpy wheel (no window: the view's matrices are Blender's own
projection of the scene camera at that size, the path view_update / view_draw take).

    python scripts/bench_viewport.py [--width 1280 --height 720 --repeats 5 --workers 2]

Each repeat edits the tail fin's colour (a small edit: its pixels traced again at full size over the kept ray trees),
the ground's (most pixels: coarse to fine) (the depsgraph changes: view_update exports the scene again) and orbits the
view (view_draw sees new matrices); the time counts the export, the hand-over and the tracing, not Blender's redraw
(drawn within addon/viewport.py's REDRAW_SECONDS after a level is ready). Medians of the repeats.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
from mathutils import Matrix  # noqa: E402


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    return parser.parse_args()


def timed_levels(session, view, started: float) -> dict[int, float]:
    """Seconds from started to each level of the newest scene, polled every millisecond."""
    seen: dict[int, float] = {}
    generation = session.progressive._generation
    while session.progressive.busy or 1 not in seen:
        level = session.progressive.latest()
        if level is not None and level.generation == generation and level.divisor not in seen:
            seen[level.divisor] = time.perf_counter() - started
        time.sleep(0.001)
    return seen


def main() -> int:
    options = arguments()
    import addon
    from addon import viewport

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    scene.weathervane.workers = options.workers
    obj = scene.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    region = SimpleNamespace(width=options.width, height=options.height)
    view = SimpleNamespace(
        view_matrix=obj.matrix_world.inverted(),
        window_matrix=obj.calc_matrix_camera(depsgraph, x=options.width, y=options.height),
    )
    session = viewport.ViewportSession(options.workers)
    session.update_scene(bpy.context, depsgraph)
    session.show(region, view)
    session.progressive.wait(600)  # the workers started and the first scene traced: not counted
    materials = {entry.name: entry for entry in scene.weathervane.materials}
    edits = {"tail fin colour": materials["verdigris"], "ground colour": materials["tiles"]}
    results: dict[str, list[dict[int, float]]] = {**{name: [] for name in edits}, "view orbited": []}
    for repeat in range(options.repeats):
        for name, material in edits.items():
            started = time.perf_counter()
            material.color = (0.2 + 0.1 * repeat, 0.3, 0.6)
            session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
            session.show(region, view)
            results[name].append(timed_levels(session, view, started))
            session.progressive.wait(600)  # the kept ray trees rebuilt after a coarse-to-fine answer
        started = time.perf_counter()
        view.view_matrix = Matrix.Rotation(0.05, 4, "Z") @ view.view_matrix
        session.show(region, view)
        results["view orbited"].append(timed_levels(session, view, started))
    session.close()
    print(
        f"Rendered view {options.width}x{options.height}, {options.workers} workers, "
        f"samples {scene.weathervane.samples}, Blender {bpy.app.version_string}; medians of {options.repeats}:"
    )
    for change, runs in results.items():
        levels = "  ".join(
            f"1/{divisor}: {1000 * statistics.median(run[divisor] for run in runs):.0f} ms"
            for divisor in sorted(runs[0], reverse=True)
        )
        print(f"  {change:16} {levels}")
    addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
