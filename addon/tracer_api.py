"""The tracer as the add-on uses it: every name the add-on takes from the tracer, imported here and nowhere else.

Where the tracer is: the built add-on (`make addon`, scripts/build_addon.py) carries its own copy as a top-level
package, `weathervane_tracer`, in the add-on's folder; from the repository (tests, development) it is the package
`tracer`. The two branches below import the same names from the same modules, and `__all__` lists them
(tests/test_layers.py holds the three equal): a name the add-on starts to use is added to all three. The add-on's
modules import this module (`from .. import tracer_api as tracer`) and no other way into the tracer.

The copy is a package of its own, not a submodule of the add-on: the render engine's worker processes are started
afresh (not forked from Blender), and they import the tracer's functions by module name; a submodule would make them
import the add-on, which needs bpy.
"""

from __future__ import annotations

import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
BUILT = (_HERE / "weathervane_tracer").is_dir()  # the copy `make addon` puts inside the add-on

if BUILT:
    if str(_HERE) not in sys.path:
        sys.path.append(str(_HERE))
    from weathervane_tracer.frames.incremental import TurningFrames
    from weathervane_tracer.frames.progressive import (
        EDITABLE_SAMPLES,
        KEPT_BYTES_PER_SAMPLE,
        ProgressiveRender,
        Samples,
    )
    from weathervane_tracer.geometry.camera import documented_background_direction, sensor_size
    from weathervane_tracer.geometry.transforms import (
        BOX_TRIANGLES,
        PYRAMID_TRIANGLES,
        box_vertices,
        euler_xyz_from_matrix,
        object_frame,
        pyramid_vertices,
        world_primitive,
    )
    from weathervane_tracer.scene.keyframes import reduce_keys
    from weathervane_tracer.scene.loader import (
        MATRIX_MIN_DETERMINANT,
        SceneError,
        default_scene,
        load_scene,
        scene_from_dict,
    )
    from weathervane_tracer.scene.motion import Motion, Spin, simulate
    from weathervane_tracer.scene.passes import CRYPTOMATTE_LEVELS, PASSES, cryptomatte_layers
    from weathervane_tracer.scene.reuse import LoadedParts
    from weathervane_tracer.scene.scene import (
        AmbientLight,
        AreaLight,
        Background,
        Box,
        Camera,
        Cylinder,
        DirectionalLight,
        Plane,
        Pyramid,
        RenderSettings,
        Sphere,
        SpotLight,
        Texture,
        WorldLight,
        immutable,
    )
    from weathervane_tracer.scene.wind import Gusts, Wind, WindKey
    from weathervane_tracer.tracing.cryptomatte import layer_header as cryptomatte_layer_header
    from weathervane_tracer.tracing.cryptomatte import matte_names as cryptomatte_matte_names
    from weathervane_tracer.tracing.images import atomic_path, sweep_stale_temporaries
    from weathervane_tracer.tracing.texturing import sample as sample_texture
    from weathervane_tracer.workers.parallel import Renderer, worker_count
    from weathervane_tracer.workers.pool import PoolClosedError, TaskFailedError, WorkerLostError
    from weathervane_tracer.workers.resources import (
        ResourceError,
        available_memory,
        check_resources,
        scene_bytes,
        scene_room,
    )
else:  # the repository's package
    from tracer.frames.incremental import TurningFrames
    from tracer.frames.progressive import EDITABLE_SAMPLES, KEPT_BYTES_PER_SAMPLE, ProgressiveRender, Samples
    from tracer.geometry.camera import documented_background_direction, sensor_size
    from tracer.geometry.transforms import (
        BOX_TRIANGLES,
        PYRAMID_TRIANGLES,
        box_vertices,
        euler_xyz_from_matrix,
        object_frame,
        pyramid_vertices,
        world_primitive,
    )
    from tracer.scene.keyframes import reduce_keys
    from tracer.scene.loader import MATRIX_MIN_DETERMINANT, SceneError, default_scene, load_scene, scene_from_dict
    from tracer.scene.motion import Motion, Spin, simulate
    from tracer.scene.passes import CRYPTOMATTE_LEVELS, PASSES, cryptomatte_layers
    from tracer.scene.reuse import LoadedParts
    from tracer.scene.scene import (
        AmbientLight,
        AreaLight,
        Background,
        Box,
        Camera,
        Cylinder,
        DirectionalLight,
        Plane,
        Pyramid,
        RenderSettings,
        Sphere,
        SpotLight,
        Texture,
        WorldLight,
        immutable,
    )
    from tracer.scene.wind import Gusts, Wind, WindKey
    from tracer.tracing.cryptomatte import layer_header as cryptomatte_layer_header
    from tracer.tracing.cryptomatte import matte_names as cryptomatte_matte_names
    from tracer.tracing.images import atomic_path, sweep_stale_temporaries
    from tracer.tracing.texturing import sample as sample_texture
    from tracer.workers.parallel import Renderer, worker_count
    from tracer.workers.pool import PoolClosedError, TaskFailedError, WorkerLostError
    from tracer.workers.resources import ResourceError, available_memory, check_resources, scene_bytes, scene_room

# Importing multiprocessing (the tracer's workers do) lists the __main__ module of the moment again as
# `__mp_main__`. Where that is the module of a script Blender runs (`blender --python script.py`, an add-on enabled
# from such a script), Blender 3.4 frees the module after the script while the second name still holds it, and its
# exit crashes (segmentation fault) in addon_utils.disable_all's walk over sys.modules. Only a started child reads
# the name (it sets its own), so the parent drops it.
if sys.modules.get("__mp_main__") is sys.modules.get("__main__"):
    sys.modules.pop("__mp_main__", None)

__all__ = [
    "BOX_TRIANGLES",
    "CRYPTOMATTE_LEVELS",
    "EDITABLE_SAMPLES",
    "KEPT_BYTES_PER_SAMPLE",
    "MATRIX_MIN_DETERMINANT",
    "PASSES",
    "PYRAMID_TRIANGLES",
    "AmbientLight",
    "AreaLight",
    "Background",
    "Box",
    "Camera",
    "Cylinder",
    "DirectionalLight",
    "Gusts",
    "LoadedParts",
    "Motion",
    "Plane",
    "PoolClosedError",
    "ProgressiveRender",
    "Pyramid",
    "RenderSettings",
    "Renderer",
    "ResourceError",
    "Samples",
    "SceneError",
    "Sphere",
    "Spin",
    "SpotLight",
    "TaskFailedError",
    "Texture",
    "TurningFrames",
    "Wind",
    "WindKey",
    "WorkerLostError",
    "WorldLight",
    "atomic_path",
    "available_memory",
    "box_vertices",
    "check_resources",
    "cryptomatte_layer_header",
    "cryptomatte_layers",
    "cryptomatte_matte_names",
    "default_scene",
    "documented_background_direction",
    "euler_xyz_from_matrix",
    "immutable",
    "load_scene",
    "object_frame",
    "pyramid_vertices",
    "reduce_keys",
    "sample_texture",
    "scene_bytes",
    "scene_from_dict",
    "scene_room",
    "sensor_size",
    "simulate",
    "sweep_stale_temporaries",
    "worker_count",
    "world_primitive",
]
