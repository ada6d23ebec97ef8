"""The documented tracer as a Blender render engine: F12, animation renders and `blender -b -E WEATHERVANE_TRACER`.

Each frame exports the evaluated scene to a tracer scene (addon/export.py), renders it on the tracer's worker
pool band by band with progress and cancel, and hands the linear float image to Blender's render result.
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from . import camera
from ._tracer import module


class RenderCancelledError(Exception):
    pass


_renderers: dict[int, object] = {}  # one worker pool per worker count, kept across frames of an animation
_turning: dict[int, object] = {}  # per pool: the last scene's pixels that the vane can change (tracer/incremental.py)


def _renderer(workers: int):
    if workers not in _renderers:
        _renderers[workers] = module("parallel").Renderer(workers)
    return _renderers[workers]


def close_renderers() -> None:
    for renderer in _renderers.values():
        renderer.close()
    _renderers.clear()
    _turning.clear()


class WEATHERVANE_RE_tracer(bpy.types.RenderEngine):
    bl_idname = "WEATHERVANE_TRACER"
    bl_label = "Weathervane Tracer"
    bl_use_preview = False

    def render(self, depsgraph) -> None:
        from .export import scene_document

        blender_scene = depsgraph.scene
        loader = module("loader")
        try:
            document = scene_document(bpy.context, depsgraph, blender_scene)
            scene = loader.scene_from_dict(json.loads(json.dumps(document)), "scene")
        except loader.SceneError as error:
            self.report({"ERROR"}, "; ".join(error.problems[:4]))
            return
        width, height = scene.render.width, scene.render.height
        left_out = camera.unsupported(blender_scene, exporting=False)
        if left_out:
            self.report({"WARNING"}, f"Weathervane Tracer does not render: {', '.join(left_out)}")

        def progress(done: int, total: int) -> None:
            self.update_progress(done / total)
            self.update_stats("Weathervane Tracer", f"band {done}/{total}")
            if self.test_break():
                raise RenderCancelledError

        pool, resources = module("pool"), module("resources")
        try:
            workers = scene.render.workers
            turning = _turning.setdefault(workers, module("incremental").TurningFrames())
            result = turning.render(_renderer(workers), scene, progress)
        except RenderCancelledError:
            return
        except (resources.ResourceError, pool.WorkerLostError, pool.TaskFailedError) as error:
            self.report({"ERROR"}, str(error))  # not enough memory, workers lost: one line, the pool stays usable
            return
        image = np.flipud(result.image).astype(np.float32)  # Blender's rows go bottom-up
        rgba = np.concatenate((image, np.ones((height, width, 1), dtype=np.float32)), axis=2).reshape(-1, 4)
        render_result = self.begin_result(0, 0, width, height)
        combined = render_result.layers[0].passes["Combined"]
        try:
            combined.rect.foreach_set(rgba.ravel())
        except (AttributeError, TypeError):
            combined.rect = rgba.tolist()
        self.end_result(render_result)
        self.update_stats("Weathervane Tracer", f"{result.seconds * 1000:.0f} ms, {result.rays.total} rays")


CLASSES = (WEATHERVANE_RE_tracer,)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(CLASSES)


def register() -> None:
    _register_classes()


def unregister() -> None:
    close_renderers()
    _unregister_classes()
