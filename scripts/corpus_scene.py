"""One .blend file nobody on the team wrote, rendered by Cycles and by the engine -> one JSON record of what was
measured (run in Blender's Python: the bpy wheel's `python corpus_scene.py FILE OUT`, or `blender -b --python
corpus_scene.py -- FILE OUT`; scripts/corpus.py runs it once per file, each in a process of its own).

The file is opened as it is. Only what a comparison needs is set: a small resolution of the file's aspect, Film >
Transparent (the coverage mask is alpha > 0.5), and Cycles on the CPU at 64 samples, no denoising, a 0.01 px pixel
filter (each pixel sampled at its centre, as the tracer's one ray is) and no diffuse bounces (the documented model
has no indirect diffuse light; mirrors and glass keep theirs). A file with no camera gets one that frames its
renderable objects (recorded). The engine renders with its own defaults for a scene it did not build.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

ROOT = Path(__file__).resolve().parents[1]
WIDTH = 96  # pixels across; the height keeps the file's aspect
CYCLES_SAMPLES = 64


def _read(path: Path) -> np.ndarray:
    """An RGBA EXR -> (H, W, 4) float64, rows from the top."""
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        width, height = image.size
        pixels = np.empty(width * height * image.channels, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        channels = image.channels
    finally:
        bpy.data.images.remove(image)
    pixels = np.flipud(pixels.reshape(height, width, channels)).astype(np.float64)
    if channels == 3:
        pixels = np.concatenate([pixels, np.ones((height, width, 1))], axis=2)
    return pixels


def _render(scene, engine: str, path: Path) -> tuple[np.ndarray | None, str, float]:
    """The scene by engine -> (pixels or None, the operator's error or "", seconds)."""
    scene.render.engine = engine
    settings = scene.render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGBA"
    scene.render.filepath = str(path)
    started = time.perf_counter()
    try:
        result = bpy.ops.render.render(write_still=True)
    except RuntimeError as error:
        return None, str(error).strip(), time.perf_counter() - started
    seconds = time.perf_counter() - started
    if result != {"FINISHED"} or not path.exists():
        return None, f"render returned {sorted(result)}", seconds
    return _read(path), "", seconds


def _frame_camera(scene) -> bool:
    """Give a scene without a camera one that frames its mesh objects (looking from +X -Y above); False where it has
    nothing to frame."""
    corners = [
        obj.matrix_world @ Vector(corner)
        for obj in scene.objects
        if obj.type == "MESH" and not obj.hide_render
        for corner in obj.bound_box
    ]
    if not corners:
        return False
    low = Vector([min(c[i] for c in corners) for i in range(3)])
    high = Vector([max(c[i] for c in corners) for i in range(3)])
    centre, radius = (low + high) / 2.0, max((high - low).length / 2.0, 1e-3)
    data = bpy.data.cameras.new("corpus camera")
    data.lens = 50.0
    data.clip_start, data.clip_end = radius * 1e-3, radius * 100.0
    camera = bpy.data.objects.new("corpus camera", data)
    scene.collection.objects.link(camera)
    direction = Vector((1.0, -1.0, 0.7)).normalized()
    distance = radius / math.sin(math.atan(18.0 / 50.0)) * 1.1  # the sphere around it fits the narrower view
    camera.location = centre + direction * distance
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    return True


def _notes(scene, record: dict) -> None:
    """What F12 says it approximates or leaves out: the export's line and the camera's unsupported settings
    ("notes"), and what Scene Conversion says of each material, light and the world ("said"); "lamps": the
    scene's lights rendered (0: the world is its only light)."""
    from addon.convert import export
    from addon.vane import camera

    notes = export.ExportNotes()
    try:
        document = export.scene_document(bpy.context, notes=notes, budget=False)
    except Exception as error:  # a refusal is recorded as the engine's note, not raised here
        record["notes"] = f"export: {error}"
        return
    said = camera.unsupported(scene, exporting=False)
    record["notes"] = "; ".join(filter(None, [notes.line(), *(f"does not render: {part}" for part in said)]))
    record["said"] = {
        "materials": {name: found for name, found in notes.materials.items() if found},
        "lights": {name: found for name, found in notes.lights.items() if found},
        "world": notes.world,
        "scene": [part for part in notes.line().split("; ") if not part.startswith("approximated: ")] + said,
    }
    record["lamps"] = sum(light.get("type") not in ("ambient", "world") for light in document.get("lights", []))


def measure(path: Path, folder: Path, out: Path) -> dict:
    """Open path, render it both ways into folder, and measure (see the module's docstring). The record is written
    to out before each render too, its "stage" saying which was running should the process die in it."""
    record: dict = {"file": str(path), "blender": bpy.app.version_string}
    out.write_text(json.dumps({**record, "stage": "open"}))
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    except RuntimeError as error:
        record["skipped"] = f"does not open: {str(error).strip()[:200]}"
        return record
    sys.path.insert(0, str(ROOT))
    import addon

    addon.register()
    scene = bpy.context.scene
    if scene.camera is None:
        if not _frame_camera(scene):
            record["skipped"] = "no camera and no mesh to frame"
            return record
        record["camera_added"] = True
    render = scene.render
    aspect = (render.resolution_y * render.pixel_aspect_y) / max(1e-6, render.resolution_x * render.pixel_aspect_x)
    render.resolution_x, render.resolution_y = WIDTH, max(1, round(WIDTH * aspect))
    render.resolution_percentage, render.pixel_aspect_x, render.pixel_aspect_y = 100, 1.0, 1.0
    render.use_border = False
    render.film_transparent = True
    cycles = scene.cycles
    cycles.device, cycles.samples, cycles.use_denoising, cycles.use_adaptive_sampling = (
        "CPU",
        CYCLES_SAMPLES,
        False,
        False,
    )
    cycles.filter_width, cycles.seed, cycles.diffuse_bounces = 0.01, 0, 0
    render.threads_mode, render.threads = "FIXED", 2
    out.write_text(json.dumps({**record, "stage": "cycles"}))
    reference, record["cycles_error"], record["cycles_seconds"] = _render(scene, "CYCLES", folder / "cycles.exr")
    out.write_text(json.dumps({**record, "stage": "engine"}))
    traced, record["engine_error"], record["engine_seconds"] = _render(
        scene, "WEATHERVANE_TRACER", folder / "engine.exr"
    )
    _notes(scene, record)
    if reference is None:
        record["skipped"] = f"Cycles did not render: {record['cycles_error']}"
        return record
    covered = reference[..., 3] > 0.5
    if not covered.any():
        record["skipped"] = "Cycles shows nothing at this camera"
        return record
    if traced is None:
        return record
    seen = traced[..., 3] > 0.5
    both = covered & seen
    record["iou"] = float(both.sum() / (covered | seen).sum())
    shown_c, shown_t = np.clip(reference[..., :3], 0.0, 1.0), np.clip(traced[..., :3], 0.0, 1.0)
    if both.any():
        mean_c, mean_t = shown_c[both].mean(axis=0), shown_t[both].mean(axis=0)
        record["mean_cycles"], record["mean_engine"] = mean_c.round(4).tolist(), mean_t.round(4).tolist()
        record["mean_error"] = float(np.max(np.abs(mean_t - mean_c) / np.maximum(mean_c, 0.02)))
        error = float(np.mean((shown_t[both] - shown_c[both]) ** 2))
        record["psnr"] = 10.0 * math.log10(1.0 / error) if error > 0.0 else 99.0
    return record


if __name__ == "__main__":
    arguments = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    blend, out = Path(arguments[0]), Path(arguments[1])
    out.write_text(json.dumps(measure(blend, out.parent, out)))
