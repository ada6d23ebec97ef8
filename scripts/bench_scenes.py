"""Scenes of real size, F12 with the Weathervane Tracer engine against Cycles on the CPU (4 samples), in bpy 5.0.1
(`make bench-scenes`).

    python scripts/bench_scenes.py [--instances 1000,10000,100000] [--sizes 320x240,1280x720] [--repeats 3]
                                   [--budget-seconds 300] [--scenes forest,cubes-separate,cubes-merged]
                                   [--quick] [--out docs/scenes-benchmark] [--images out/scenes-benchmark]

Scenes, each built with plain bpy in a fresh Blender (the bpy module):

- forest-N: a 100 m ground plane whose Geometry Nodes modifier scatters N instances of one UV sphere (16 segments,
  11 rings: 320 triangles) with Distribute Points on Faces (fixed seed, density a fifth above N per area, points
  past index N deleted, so exactly N) and Instance on Points (random rotation and scale); the instances are not
  realized. A separate small cube, the "mover", stands among them.
- cubes-separate: 3,000 cubes in a 60 x 50 grid, each its own mesh object with its own Principled material, on a
  ground plane; cubes-merged: the same 36,000 triangles as one mesh object with one material.

Every scene has a camera, a sun and a world colour. For each scene, size and engine, one measurement: the first F12
after the scene is built (for the tracer: starting its workers, exporting, preparing, tracing), a second F12 with
nothing changed, and an F12 after one object moved (forest: the mover, 1 m along x; cubes-separate: the first
cube, 1 m up; cubes-merged: the merged object, 1 m up). F12 is bpy.ops.render.render(write_still=False), timed
around the call. The tracer renders --tracer-samples a pixel (default 1, the documented model's: one ray through each
pixel centre; 4 is a stratified 2 x 2) with all cores as workers; Cycles renders 4 samples on the CPU with all
cores, no denoising and no adaptive sampling (a fixed amount of work, as the tracer's).

Each measurement runs in its own process (`--one`), started by this script, which alternates the engines (the
order swapped every repeat) and takes medians over the repeats. A render that takes longer than --budget-seconds
is abandoned (its process group killed) and recorded as exceeded; that engine then skips larger instance counts at
that size and larger (a budget of the build itself: BUILD_SECONDS). The tracer's F12 is split: `trace` is the
seconds the engine reports in its status line (result.seconds: handing the scene to the workers, their preparation
and the tracing); `export` (addon.convert.export.scene_document), `json` (the engine's JSON round trip of the
document) and `load` (the loader's scene_from_dict) are timed by wrappers this measuring process puts around those
functions (the add-on is not changed); `other` is the rest (Blender's render pipeline and depsgraph, the worker
pool's start, writing the result). Peak memory: the summed resident set size (RSS) of the measuring process and all its
descendants (the tracer's workers), sampled every 20 ms from /proc by this (parent) process, over each F12; shared
pages count once per process that maps them.

Writes OUT.json (every raw figure, medians, load averages at start and end, date, git commit) and OUT.png (seconds
per F12 against the forest's instance count, per size), prints a markdown table per scene, and saves each
measurement's last image (first repeat) under out/scenes-benchmark/ to look at.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import queue
import re
import signal
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MARK = "BENCH-SCENES "  # the prefix of the JSON lines a measuring process prints among Blender's own output
ENGINES = {"tracer": "WEATHERVANE_TRACER", "cycles": "CYCLES"}
ENGINE_NAMES = {"tracer": "Weathervane Tracer", "cycles": "Cycles CPU"}
PHASES = ("first", "second", "moved")
PHASE_NAMES = {"first": "first F12", "second": "second F12", "moved": "F12 after a move"}
CUBES = 3000
CUBE_GRID = (60, 50)
GROUND_SIZE = 100.0
SPHERE = {"segments": 16, "rings": 11, "radius": 0.4}  # 16 * 9 * 2 + 2 * 16 = 320 triangles
SPHERE_TRIANGLES = 320
SEED = 34
SAMPLE_SECONDS = 0.02
BUILD_SECONDS = 600.0  # the most a measuring process may take to start Blender and build its scene (about 5 s here)
MIB = 1024 * 1024


# ---- the measuring process (--one): runs inside bpy ------------------------------------------------------------------


def emit(event: str, **fields: Any) -> None:
    print(MARK + json.dumps({"event": event, **fields}), flush=True)


def _material(bpy: ModuleType, name: str, color: tuple[float, float, float]) -> Any:
    material = bpy.data.materials.new(name)
    if material.node_tree is None:  # before Blender 5.0 a new material has no nodes until asked
        material.use_nodes = True
    principled = next(node for node in material.node_tree.nodes if node.bl_idname == "ShaderNodeBsdfPrincipled")
    principled.inputs["Base Color"].default_value = (*color, 1.0)
    principled.inputs["Roughness"].default_value = 0.6
    material.diffuse_color = (*color, 1.0)
    return material


def _cube_mesh(bpy: ModuleType, name: str, centre: tuple[float, float, float], half: float) -> Any:
    x, y, z = centre
    corners = [(x + sx * half, y + sy * half, z + sz * half) for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], faces)
    mesh.update()
    return mesh


def _link(bpy: ModuleType, name: str, data: Any, location: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Any:
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _ground(bpy: ModuleType, size: float) -> Any:
    half = size / 2
    mesh = bpy.data.meshes.new("Ground")
    mesh.from_pydata([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], [], [(0, 1, 2, 3)])
    mesh.update()
    obj = _link(bpy, "Ground", mesh)
    obj.data.materials.append(_material(bpy, "Ground", (0.35, 0.3, 0.22)))
    return obj


def _surroundings(bpy: ModuleType, target: tuple[float, float, float], distance: float) -> None:
    """Camera, sun and world: what every scene shares."""
    from mathutils import Vector

    scene = bpy.context.scene
    camera = _link(bpy, "Camera", bpy.data.cameras.new("Camera"))
    camera.location = Vector(target) + Vector((0.0, -0.8, 0.5)).normalized() * distance
    camera.rotation_euler = (Vector(target) - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun_data.energy = 3.0
    sun = _link(bpy, "Sun", sun_data)
    sun.rotation_euler = (0.7, 0.2, 0.9)
    world = bpy.data.worlds.new("World")
    if world.node_tree is None:
        world.use_nodes = True
    background = next(node for node in world.node_tree.nodes if node.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (0.3, 0.4, 0.55, 1.0)
    background.inputs["Strength"].default_value = 0.5
    world.color = (0.3, 0.4, 0.55)
    scene.world = world


def _forest_nodes(bpy: ModuleType, count: int) -> Any:
    """Ground -> ground + exactly count sphere instances (not realized), seeded."""
    tree = bpy.data.node_groups.new("Forest", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    distribute = nodes.new("GeometryNodeDistributePointsOnFaces")
    distribute.distribute_method = "RANDOM"
    # a fifth more points than asked (a Poisson count falls short of its mean half the time), then the points past
    # index count deleted: exactly count instances, the same ones on every run
    distribute.inputs["Density"].default_value = 1.2 * count / GROUND_SIZE**2
    distribute.inputs["Seed"].default_value = SEED
    index = nodes.new("GeometryNodeInputIndex")
    compare = nodes.new("FunctionNodeCompare")
    compare.data_type, compare.operation = "INT", "GREATER_EQUAL"
    compare.inputs[3].default_value = count  # B of the INT inputs
    delete = nodes.new("GeometryNodeDeleteGeometry")
    delete.domain = "POINT"
    sphere = nodes.new("GeometryNodeMeshUVSphere")
    for name, value in SPHERE.items():
        sphere.inputs[name.capitalize()].default_value = value
    leaf = nodes.new("GeometryNodeSetMaterial")
    leaf.inputs["Material"].default_value = _material(bpy, "Leaf", (0.1, 0.45, 0.12))
    turn = nodes.new("FunctionNodeRandomValue")
    turn.data_type = "FLOAT_VECTOR"
    turn.inputs[1].default_value = (6.283185, 6.283185, 6.283185)  # Max of the vector inputs
    turn.inputs["Seed"].default_value = SEED
    euler = nodes.new("FunctionNodeEulerToRotation")
    size = nodes.new("FunctionNodeRandomValue")
    size.data_type = "FLOAT"
    size.inputs[2].default_value, size.inputs[3].default_value = 0.6, 1.4  # Min and Max of the float inputs
    size.inputs["Seed"].default_value = SEED + 1
    instance = nodes.new("GeometryNodeInstanceOnPoints")
    join = nodes.new("GeometryNodeJoinGeometry")
    links.new(group_in.outputs[0], distribute.inputs["Mesh"])
    links.new(distribute.outputs["Points"], delete.inputs["Geometry"])
    links.new(index.outputs[0], compare.inputs[2])
    links.new(compare.outputs[0], delete.inputs["Selection"])
    links.new(delete.outputs[0], instance.inputs["Points"])
    links.new(sphere.outputs["Mesh"], leaf.inputs["Geometry"])
    links.new(leaf.outputs[0], instance.inputs["Instance"])
    links.new(turn.outputs[0], euler.inputs[0])
    links.new(euler.outputs[0], instance.inputs["Rotation"])
    links.new(size.outputs[1], instance.inputs["Scale"])  # Value of the float outputs
    links.new(group_in.outputs[0], join.inputs[0])
    links.new(instance.outputs[0], join.inputs[0])
    links.new(join.outputs[0], group_out.inputs[0])
    return tree


def build_forest(bpy: ModuleType, count: int) -> dict[str, Any]:
    ground = _ground(bpy, GROUND_SIZE)
    modifier = ground.modifiers.new("Forest", "NODES")
    modifier.node_group = _forest_nodes(bpy, count)
    mover = _link(bpy, "Mover", _cube_mesh(bpy, "Mover", (0.0, 0.0, 0.0), 0.5), (2.0, -20.0, 0.5))
    mover.data.materials.append(_material(bpy, "Mover", (0.8, 0.15, 0.1)))
    _surroundings(bpy, (0.0, 5.0, 0.0), 95.0)
    return {
        "triangles": count * SPHERE_TRIANGLES + 2 + 12,
        "moved": "the mover (a separate 1 m cube among the instances), 1 m along x",
        "mover": mover.name,
        "offset": (1.0, 0.0, 0.0),
    }


def _grid_centres() -> list[tuple[float, float, float]]:
    columns, rows = CUBE_GRID
    spacing = 1.2
    return [
        ((column - (columns - 1) / 2) * spacing, (row - (rows - 1) / 2) * spacing, 0.4)
        for row in range(rows)
        for column in range(columns)
    ]


def build_cubes(bpy: ModuleType, merged: bool) -> dict[str, Any]:
    import random

    _ground(bpy, GROUND_SIZE)
    centres = _grid_centres()
    if merged:
        import numpy as np

        unit = _cube_mesh(bpy, "unit", (0.0, 0.0, 0.0), 0.4)
        corners = np.array([vertex.co for vertex in unit.vertices])
        faces = np.array([list(polygon.vertices) for polygon in unit.polygons])
        bpy.data.meshes.remove(unit)
        vertices = (np.array(centres)[:, None, :] + corners[None, :, :]).reshape(-1, 3)
        quads = (faces[None, :, :] + 8 * np.arange(len(centres))[:, None, None]).reshape(-1, 4)
        mesh = bpy.data.meshes.new("Cubes")
        mesh.from_pydata(vertices.tolist(), [], quads.tolist())
        mesh.update()
        obj = _link(bpy, "Cubes", mesh)
        obj.data.materials.append(_material(bpy, "Cubes", (0.6, 0.5, 0.4)))
        moved = "the merged object (all 36,000 cube triangles), 1 m up"
    else:
        colours = random.Random(SEED)
        for number, centre in enumerate(centres):
            name = f"Cube{number:04d}"
            obj = _link(bpy, name, _cube_mesh(bpy, name, (0.0, 0.0, 0.0), 0.4), centre)
            colour = (colours.random(), colours.random(), colours.random())
            obj.data.materials.append(_material(bpy, name, colour))
        obj = bpy.data.objects["Cube0000"]
        moved = "the first cube (Cube0000), 1 m up"
    _surroundings(bpy, (0.0, 0.0, 0.0), 85.0)
    return {"triangles": CUBES * 12 + 2, "moved": moved, "mover": obj.name, "offset": (0.0, 0.0, 1.0)}


def _settings(bpy: ModuleType, engine: str, width: int, height: int, tracer_samples: str) -> dict[str, Any]:
    scene = bpy.context.scene
    scene.render.engine = ENGINES[engine]
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    if engine == "tracer":
        settings = scene.weathervane
        settings.samples = tracer_samples
        settings.workers = 0  # all cores, as Cycles' threads
        return {
            "samples": int(settings.samples),
            "workers": os.cpu_count(),
            "depth": settings.depth,
            "precision": settings.precision,
            "numerics": settings.numerics,
        }
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = 4
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    return {"samples": cycles.samples, "threads": "auto", "denoising": False, "adaptive_sampling": False}


def _timed(function: Callable[..., Any], spans: dict[str, float], key: str) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        started = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            spans[key] = spans.get(key, 0.0) + time.perf_counter() - started

    return wrapper


def _time_engine_steps(spans: dict[str, float]) -> None:
    """The engine reports only its trace time: export, the document's JSON round trip and loading are timed around
    the functions it calls, which it looks up at each render (so these wrappers are what it runs)."""
    from addon import tracer_api
    from addon.convert import export
    from addon.engine import engine

    export.scene_document = _timed(export.scene_document, spans, "export")
    engine.json = SimpleNamespace(dumps=_timed(json.dumps, spans, "json"), loads=_timed(json.loads, spans, "json"))
    tracer_api.scene_from_dict = _timed(tracer_api.scene_from_dict, spans, "load")


def measure_one(spec: dict[str, Any]) -> int:
    """One scene at one size with one engine: build, three F12s, each reported as a JSON line on stdout."""
    sys.path.insert(0, str(ROOT))
    import bpy

    import addon

    started = time.perf_counter()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    spans: dict[str, float] = {}
    stats: list[str] = []
    if spec["engine"] == "tracer":
        _time_engine_steps(spans)

    def stats_seen(text: str, *_: Any) -> None:
        stats.append(str(text))

    bpy.app.handlers.render_stats.append(stats_seen)
    try:
        if spec["scene"] == "forest":
            built = build_forest(bpy, spec["instances"])
        else:
            built = build_cubes(bpy, merged=spec["scene"] == "cubes-merged")
        settings = _settings(bpy, spec["engine"], spec["width"], spec["height"], spec.get("tracer_samples", "1"))
        emit("built", seconds=time.perf_counter() - started, blender=bpy.app.version_string, settings=settings, **built)
        mover = bpy.data.objects[built["mover"]]
        for phase in PHASES:
            if phase == "moved":
                mover.location = [a + b for a, b in zip(mover.location, built["offset"], strict=True)]
            spans.clear()
            stats.clear()
            emit("start", phase=phase)
            began = time.monotonic()
            clock = time.perf_counter()
            try:
                answer, error = sorted(bpy.ops.render.render(write_still=False)), None
            except RuntimeError as failure:  # the engine reported an error: this F12 failed, the next ones still run
                answer, error = [], str(failure)
            seconds = time.perf_counter() - clock
            ended = time.monotonic()
            figures: dict[str, Any] = {"seconds": seconds, "began": began, "ended": ended, "answer": answer}
            if error is not None:
                figures["error"] = error
            figures["stats"] = stats[-1] if stats else None  # the engine's last status line (Cycles: its memory)
            if spec["engine"] == "tracer":
                said = [re.search(r"(\d+) ms, (\d+) rays", line) for line in stats]
                traced = next((match for match in reversed(said) if match), None)
                figures["export"] = spans.get("export")
                figures["load"] = spans.get("load")
                figures["trace"] = int(traced.group(1)) / 1000 if traced else None
                figures["rays"] = int(traced.group(2)) if traced else None
                figures["json"] = spans.get("json")
                known = [figures[key] for key in ("export", "json", "load", "trace")]
                if all(value is not None for value in known):
                    figures["other"] = seconds - sum(known)
            emit("render", phase=phase, **figures)
        if spec.get("image"):
            Path(spec["image"]).parent.mkdir(parents=True, exist_ok=True)
            bpy.data.images["Render Result"].save_render(spec["image"])
        # counted after the renders, so that no viewport evaluation runs before the first F12
        depsgraph = bpy.context.evaluated_depsgraph_get()
        instances = sum(1 for instance in depsgraph.object_instances if instance.is_instance)
        emit("done", instances_counted=instances, image=spec.get("image"))
    finally:
        addon.unregister()  # closes the tracer's worker pool
    return 0


# ---- the parent: runs the measuring processes, samples their memory, writes the report -------------------------------


def tree_rss(pid: int) -> int:
    """Summed RSS in bytes of pid and all its descendants (children listed per thread by /proc)."""
    total, pending, page = 0, [pid], os.sysconf("SC_PAGE_SIZE")
    while pending:
        current = pending.pop()
        try:
            with open(f"/proc/{current}/statm") as statm:
                total += int(statm.read().split()[1]) * page
            for task in os.listdir(f"/proc/{current}/task"):
                with open(f"/proc/{current}/task/{task}/children") as children:
                    pending.extend(int(child) for child in children.read().split())
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue  # gone between the listing and the read
    return total


class MemorySampler(threading.Thread):
    """(time.monotonic(), summed RSS) of a process tree every SAMPLE_SECONDS, in this process so that the sampling
    neither waits on the measured process's interpreter lock nor adds to its memory."""

    def __init__(self, pid: int) -> None:
        super().__init__(daemon=True)
        self.pid = pid
        self.samples: list[tuple[float, int]] = []
        self._halt = threading.Event()

    def run(self) -> None:
        while not self._halt.is_set():
            self.samples.append((time.monotonic(), tree_rss(self.pid)))
            self._halt.wait(SAMPLE_SECONDS)

    def stop(self) -> None:
        self._halt.set()
        self.join()

    def peak_mib(self, began: float, ended: float) -> float | None:
        # a render shorter than a sampling interval still gets the samples on either side of it
        inside = [rss for when, rss in self.samples if began - SAMPLE_SECONDS <= when <= ended + SAMPLE_SECONDS]
        return max(inside) / MIB if inside else None


def run_one(spec: dict[str, Any], budget: float) -> dict[str, Any]:
    """A measuring process for spec, abandoned (its process group killed) when a step exceeds budget seconds."""
    command = [sys.executable, str(Path(__file__).resolve()), "--one", json.dumps(spec)]
    child = subprocess.Popen(
        command,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        bufsize=1,
        start_new_session=True,  # its own process group: the tracer's workers are killed with it
    )
    sampler = MemorySampler(child.pid)
    sampler.start()
    lines: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        for line in child.stdout:
            lines.put(line.rstrip("\n"))
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    record: dict[str, Any] = {**spec, "renders": {}, "exceeded": None, "log": []}
    waiting_for, deadline = "built", time.monotonic() + BUILD_SECONDS
    try:
        while True:
            try:
                line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                if waiting_for == "exit":  # every figure is in: only a hang at exit, no render over budget
                    record["hung_at_exit"] = True
                else:
                    record["exceeded"] = waiting_for
                break
            if line is None:
                break
            if not line.startswith(MARK):
                record["log"].append(line)
                continue
            event = json.loads(line[len(MARK) :])
            kind = event.pop("event")
            if kind == "built":
                record.update(build_seconds=event.pop("seconds"), **event)
            elif kind == "start":
                waiting_for, deadline = event["phase"], time.monotonic() + budget
            elif kind == "render":
                phase = event.pop("phase")
                event["peak_mib"] = sampler.peak_mib(event["began"], event["ended"])
                record["renders"][phase] = event
                waiting_for, deadline = "done", time.monotonic() + budget
            elif kind == "done":
                record.update(event)
                waiting_for, deadline = "exit", time.monotonic() + 60
    finally:
        # abandoned, hung at exit, or this script stopped (Ctrl-C): the group was started apart and would outlive it
        if child.poll() is None and (record["exceeded"] or record.get("hung_at_exit") or sys.exc_info()[0]):
            os.killpg(child.pid, signal.SIGKILL)
        try:
            record["returncode"] = child.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            record["returncode"] = child.wait()
        sampler.stop()
    if record["exceeded"] is not None:
        record["peak_mib_until_abandoned"] = max((rss for _, rss in sampler.samples), default=0) / MIB
    # errors and warnings are kept whole (each warning once); the rest of the output only as a tail
    problems = [line for line in record["log"] if re.search(r"Traceback|Error|ERROR|Exception", line)]
    record["problems"] = problems[:40]
    record["warnings"] = list(dict.fromkeys(line for line in record["log"] if re.search(r"Warning|WARNING", line)))
    record["log"] = record["log"][-40:]
    return record


def git(*arguments: str) -> str:
    try:
        done = subprocess.run(["git", *arguments], cwd=ROOT, capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return ""
    return done.stdout.rstrip("\n")  # not strip(): a porcelain line starts with a space


def machine() -> dict[str, Any]:
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    model = next((line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")), "")
    return {"cpus": os.cpu_count(), "cpu": model, "platform": platform.platform(), "python": platform.python_version()}


def cases(options: argparse.Namespace) -> list[dict[str, Any]]:
    """The (scene, size) measurements of one repeat, the forest's instance counts rising."""
    scenes = [("forest", count) for count in options.instances] + [("cubes-separate", None), ("cubes-merged", None)]
    return [
        {"scene": scene, "instances": count, "width": width, "height": height}
        for scene, count in scenes
        for width, height in options.sizes
    ]


def label(spec: dict[str, Any]) -> str:
    scene = f"forest-{spec['instances']}" if spec["scene"] == "forest" else spec["scene"]
    return f"{scene} {spec['width']}x{spec['height']} {spec['engine']}"


def over_budget(spec: dict[str, Any], exceeded: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The exceeded measurement that rules spec out: the same engine and scene at no more instances and no larger
    image (a larger one would only take longer)."""
    for earlier in exceeded:
        if earlier["engine"] != spec["engine"] or earlier["scene"] != spec["scene"]:
            continue
        if (earlier["instances"] or 0) <= (spec["instances"] or 0) and (
            earlier["width"] * earlier["height"] <= spec["width"] * spec["height"]
        ):
            return earlier
    return None


def medians(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Per scene, size and engine: the median of each phase's figures over the repeats that finished it."""
    grouped: dict[str, list[dict[str, Any]]] = {}
    for record in records:
        grouped.setdefault(label(record), []).append(record)
    result: dict[str, Any] = {}
    for key, group in grouped.items():
        entry: dict[str, Any] = {
            "scene": group[0]["scene"],
            "instances": group[0]["instances"],
            "size": f"{group[0]['width']}x{group[0]['height']}",
            "engine": group[0]["engine"],
            "repeats": len(group),
            "exceeded": sorted({record["exceeded"] for record in group if record.get("exceeded")}),
            "skipped": sum(1 for record in group if record.get("skipped")),
            "errors": sorted({phase for record in group for phase, r in record["renders"].items() if "error" in r}),
        }
        for phase in PHASES:
            renders = [
                record["renders"][phase]
                for record in group
                if phase in record["renders"] and "error" not in record["renders"][phase]
            ]
            figures = {}
            for name in ("seconds", "peak_mib", "export", "json", "load", "trace", "other"):
                values = [render[name] for render in renders if render.get(name) is not None]
                if values:
                    figures[name] = statistics.median(values)
            figures["count"] = len(renders)
            entry[phase] = figures
        result[key] = entry
    return result


def _seconds(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2f} s" if value < 10 else f"{value:.1f} s"


def table(summary: dict[str, Any], budget: float) -> str:
    """A markdown table per scene: F12 times and peak memory per size and engine, then the tracer's breakdown."""
    blocks = []
    scenes: dict[str, list[dict[str, Any]]] = {}
    for entry in summary.values():
        name = f"forest, {entry['instances']:,} instances" if entry["scene"] == "forest" else entry["scene"]
        scenes.setdefault(name, []).append(entry)
    for name, entries in scenes.items():
        lines = [
            f"### {name}",
            "",
            "| size | engine | first F12 | second F12 | F12 after a move | peak MiB (all processes) |",
            "| --- | --- | ---: | ---: | ---: | ---: |",
        ]
        for entry in entries:
            cells = []
            for phase in PHASES:
                figures = entry[phase]
                if phase in entry["exceeded"]:
                    cells.append(f"over {budget:g} s")
                elif "built" in entry["exceeded"] and not figures["count"]:
                    cells.append("build took too long")
                elif phase in entry["errors"] and not figures["count"]:
                    cells.append("error")
                elif entry["skipped"] and not figures["count"]:
                    cells.append("skipped")
                else:
                    cells.append(_seconds(figures.get("seconds")))
            peaks = [entry[phase].get("peak_mib") for phase in PHASES if entry[phase].get("peak_mib") is not None]
            peak = f"{max(peaks):,.0f}" if peaks else "-"
            lines.append(f"| {entry['size']} | {ENGINE_NAMES[entry['engine']]} | {' | '.join(cells)} | {peak} |")
        breakdown = [entry for entry in entries if entry["engine"] == "tracer"]
        if any(entry[phase].get("trace") is not None for entry in breakdown for phase in PHASES):
            lines += [
                "",
                "| size | Weathervane Tracer | F12 | export | JSON round trip | load | trace (engine's own) | other |",
                "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
            ]
            for entry in breakdown:
                for phase in PHASES:
                    figures = entry[phase]
                    if not figures["count"]:
                        continue
                    keys = ("seconds", "export", "json", "load", "trace", "other")
                    cells = [_seconds(figures.get(key)) for key in keys]
                    lines.append(f"| {entry['size']} | {PHASE_NAMES[phase]} | {' | '.join(cells)} |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def chart(summary: dict[str, Any], sizes: list[tuple[int, int]], budget: float, path: Path) -> None:
    """Seconds per F12 (second and first) against the forest's instance count, log-log, one panel per size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    plain = matplotlib.ticker.FuncFormatter(lambda value, _: f"{value:,g}")
    figure, axes = plt.subplots(1, len(sizes), figsize=(5.5 * len(sizes), 4.2), squeeze=False, sharey=True)
    colours = {"tracer": "tab:blue", "cycles": "tab:orange"}
    for axis, (width, height) in zip(axes[0], sizes, strict=True):
        size = f"{width}x{height}"
        for engine in ENGINES:
            entries = sorted(
                (
                    entry
                    for entry in summary.values()
                    if entry["scene"] == "forest" and entry["size"] == size and entry["engine"] == engine
                ),
                key=lambda entry: entry["instances"],
            )
            for phase, style, marker, fill in (("second", "-", "o", colours[engine]), ("first", "--", "s", "none")):
                points = [(e["instances"], e[phase]["seconds"]) for e in entries if "seconds" in e[phase]]
                if points:
                    axis.plot(
                        *zip(*points, strict=True),
                        style,
                        marker=marker,
                        markerfacecolor=fill,
                        color=colours[engine],
                        label=f"{ENGINE_NAMES[engine]}, {PHASE_NAMES[phase]}",
                    )
            over = [entry["instances"] for entry in entries if entry["exceeded"]]
            if over:
                axis.plot(over, [budget] * len(over), "x", color=colours[engine], markersize=10, label=None)
                for count in over:
                    axis.annotate("over budget", (count, budget), textcoords="offset points", xytext=(4, -12))
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.yaxis.set_major_formatter(plain)
        axis.xaxis.set_major_formatter(plain)
        axis.set_title(f"forest of UV spheres, {size}")
        axis.set_xlabel("instances (320 triangles each)")
        axis.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("seconds per F12 (log)")
    low, high = axes[0][0].get_ylim()
    if high / low < 30:  # within about a decade and a half the 2, 3, ... ticks are the only ones: label them
        for axis in axes[0]:
            axis.yaxis.set_minor_formatter(plain)
    drawn = [axis for axis in axes[0] if axis.get_legend_handles_labels()[0]]
    if drawn:
        drawn[0].legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def progress_line(record: dict[str, Any]) -> str:
    """One measurement in a line, as it finishes (a full run takes hours)."""
    renders = record["renders"]
    times = " / ".join(_seconds(renders.get(phase, {}).get("seconds")) for phase in PHASES)
    peak = max((render.get("peak_mib") or 0 for render in renders.values()), default=0)
    line = f"{label(record)}: build {_seconds(record.get('build_seconds'))}, F12 first / second / moved {times}"
    line += f", peak {peak:,.0f} MiB"
    if record["exceeded"]:
        line += f", EXCEEDED the budget during {record['exceeded']}"
    line += "".join(
        f", {phase} F12 failed: {render['error']}" for phase, render in renders.items() if "error" in render
    )
    if record.get("returncode"):
        line += f", exit code {record['returncode']}"
    if record.get("problems"):
        line += f", {len(record['problems'])} error lines in its output"
    return line


def arguments(given: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", default="1000,10000,100000", help="the forest's instance counts")
    parser.add_argument("--sizes", default="320x240,1280x720", help="image sizes, WIDTHxHEIGHT, comma-separated")
    parser.add_argument("--repeats", type=int, default=3, help="measurements of each case (medians)")
    parser.add_argument("--budget-seconds", type=float, default=300.0, help="the most one render may take")
    parser.add_argument("--scenes", default="forest,cubes-separate,cubes-merged", help="which scenes")
    parser.add_argument(
        "--quick", action="store_true", help="a smoke run: 1,000 and 10,000 instances, 320x240, 1 repeat"
    )
    parser.add_argument(
        "--tracer-samples",
        default="1",
        choices=("1", "4", "9", "16", "64"),
        help="the tracer's samples a pixel (default 1, the documented model's one ray a pixel; F12's own default on a"
        " scene the add-on did not build is 16 at Threshold 0.005)",
    )
    parser.add_argument("--out", default="docs/scenes-benchmark", help="OUT.json and OUT.png are written")
    parser.add_argument("--images", default="out/scenes-benchmark", help="where each case's last image goes")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # a measuring process's spec (JSON), from the parent
    options = parser.parse_args(given)
    if options.quick:
        options.instances, options.sizes, options.repeats = "1000,10000", "320x240", 1
    options.instances = [int(count) for count in options.instances.replace("_", "").split(",") if count]
    options.sizes = [tuple(int(part) for part in size.split("x")) for size in options.sizes.split(",") if size]
    options.scenes = [scene for scene in options.scenes.split(",") if scene]
    return options


def main() -> int:
    options = arguments()
    if options.one:
        return measure_one(json.loads(options.one))
    # a stop by SIGTERM unwinds as Ctrl-C does, so that the measuring process (a group of its own) is killed too
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    load_start = os.getloadavg()
    # the tree may change during a long run (others at work): its state is recorded at both ends
    commit_start = git("rev-parse", "HEAD")
    changed_start = git("status", "--porcelain", "--untracked-files=no").splitlines()
    started = datetime.datetime.now(datetime.UTC)
    records: list[dict[str, Any]] = []
    exceeded: list[dict[str, Any]] = []
    plan = [case for case in cases(options) if case["scene"] in options.scenes]
    for repeat in range(options.repeats):
        engines = list(ENGINES) if repeat % 2 == 0 else list(reversed(ENGINES))
        for case in plan:
            for engine in engines:
                spec = {**case, "engine": engine, "repeat": repeat, "tracer_samples": options.tracer_samples}
                ruled_out = over_budget(spec, exceeded)
                if ruled_out is not None:
                    records.append({**spec, "skipped": f"{label(ruled_out)} exceeded the budget", "renders": {}})
                    print(f"{label(spec)}: skipped ({label(ruled_out)} exceeded the budget)", file=sys.stderr)
                    continue
                if repeat == 0:
                    spec["image"] = str(ROOT / options.images / f"{label(spec).replace(' ', '-')}.png")
                record = run_one(spec, options.budget_seconds)
                records.append(record)
                if record["exceeded"] is not None:
                    exceeded.append(record)
                print(progress_line(record), file=sys.stderr, flush=True)
    summary = medians(records)
    report = {
        "what": __doc__.split("\n\n")[0],
        "options": {
            "instances": options.instances,
            "sizes": [f"{width}x{height}" for width, height in options.sizes],
            "repeats": options.repeats,
            "budget_seconds": options.budget_seconds,
            "scenes": options.scenes,
            "quick": options.quick,
        },
        "date": started.isoformat(timespec="seconds"),
        "finished": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "git_commit": commit_start,
        "git_changed_files": changed_start,
        "git_commit_end": git("rev-parse", "HEAD"),
        "git_changed_files_end": git("status", "--porcelain", "--untracked-files=no").splitlines(),
        "machine": machine(),
        "load_average_start": load_start,
        "load_average_end": os.getloadavg(),
        "memory": "peak summed RSS (MiB) of the measuring process and its descendants over each F12, every 20 ms",
        "medians": summary,
        "measurements": records,
    }
    out = ROOT / options.out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(report, indent=1) + "\n")
    chart(summary, options.sizes, options.budget_seconds, out.with_suffix(".png"))
    print(
        f"Scenes in Blender (bpy) against Cycles CPU 4 samples; medians of {options.repeats} repeat(s); "
        f"{os.cpu_count()} CPUs, load {load_start[0]:.2f} at start, {report['load_average_end'][0]:.2f} at end; "
        f"commit {commit_start[:10]}{' (tree changed)' if changed_start else ''}"
        + (f" to {report['git_commit_end'][:10]}" if report["git_commit_end"] != commit_start else "")
        + "\n"
    )
    print(table(summary, options.budget_seconds))
    shown = out.relative_to(ROOT) if out.is_relative_to(ROOT) else out
    print(f"\nwrote {shown}.json and {shown}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
