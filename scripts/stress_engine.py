"""F12 many times in a row in one Blender, the engine's worker pool kept between renders: does Blender survive?

    blender -b --factory-startup --python scripts/stress_engine.py -- [--renders 200] [--start-method spawn|fork]
    python scripts/stress_engine.py [...]      (inside a bpy wheel's environment)

Two scenes alternate; each render's EXR must equal the first of its scene (the same scene, the same bytes). Prints a
line per 50 renders and `STRESS renders=N crashes=0 seconds=S` at the end; a crash of Blender ends the process before
that line, which is how a caller counts it. --start-method fork starts the engine's workers by forking
Blender (as they were started before the engine spawned them), to record how often that crashes; --fresh-pool starts
new workers for every render (as each add-on test did, which is where the crash was seen), where the engine keeps its
pool.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
import numpy as np  # noqa: E402


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--renders", type=int, default=200, help="F12 renders in a row (default 200)")
    parser.add_argument("--start-method", choices=("spawn", "fork"), default="spawn", help="how workers start")
    parser.add_argument("--fresh-pool", action="store_true", help="new worker processes for every render")
    parser.add_argument("--workers", type=int, default=2, help="the engine's worker processes (default 2)")
    given = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    if bpy.app.background and "--" not in sys.argv and any(arg.endswith(".py") for arg in given[:1]):
        given = given[1:]
    return parser.parse_args(given)


def main() -> int:
    options = arguments()
    import addon
    from addon.engine import engine

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    if options.start_method == "fork":
        from tracer.workers.parallel import Renderer

        def forked(workers: int):
            if workers not in engine._renderers:
                engine._renderers[workers] = Renderer(workers, start_method="fork")
            return engine._renderers[workers]

        engine._renderer = forked
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    scene.weathervane.workers = options.workers
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    folder = Path(tempfile.mkdtemp(prefix="weathervane-stress-"))
    scene.render.filepath = str(folder / "frame.exr")
    first: dict[int, np.ndarray] = {}
    material = scene.weathervane.materials[0]
    colors = (tuple(material.color), (0.9, 0.2, 0.1))
    started = time.perf_counter()
    for number in range(1, options.renders + 1):
        # two scenes in turn, so that every render traces the whole frame on the workers (the same scene twice
        # would be answered from the previous frame)
        material.color = colors[number % 2]
        if options.fresh_pool:
            engine.close_renderers()
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        image = bpy.data.images.load(str(folder / "frame.exr"))  # the render result as Blender saves it, float32
        pixels = np.empty(64 * 48 * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        bpy.data.images.remove(image)
        expected = first.setdefault(number % 2, pixels)
        assert np.array_equal(pixels, expected) and pixels.std() > 0.05, f"render {number} differs from its twin"
        if number % 50 == 0:
            print(f"STRESS {number} renders, {time.perf_counter() - started:.1f} s", flush=True)
    seconds = time.perf_counter() - started
    pool = "fresh" if options.fresh_pool else "kept"
    print(f"STRESS renders={options.renders} crashes=0 seconds={seconds:.1f} start={options.start_method} pool={pool}")
    print(f"STRESS blender={bpy.app.version_string}", flush=True)
    addon.unregister()
    shutil.rmtree(folder)
    return 0


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    import os

    os._exit(code)  # Blender 3.4's normal shutdown can crash after multiprocessing was imported (render_both.py)
