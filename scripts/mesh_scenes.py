"""Mesh benchmark scenes -> scene documents: a UV sphere of about n triangles, or Blender's Suzanne subdivided, in
the default scene's place of the vane (above its ground, under its lights and camera).

Suzanne comes from Blender itself (the bpy module of the project's .venv, or any Python that imports bpy): its
evaluated triangles with a Subdivision Surface modifier, cached as out/suzanne-level<N>.npz so that the benchmark
needs Blender only once.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tracer.scene.loader import default_scene_dict  # noqa: E402

SUZANNE_SCRIPT = """
import sys
import bpy
import numpy as np
level, out = int(sys.argv[1]), sys.argv[2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_monkey_add(size=2.0)
monkey = bpy.context.active_object
modifier = monkey.modifiers.new("Subdivision", "SUBSURF")
modifier.levels = modifier.render_levels = level
evaluated = monkey.evaluated_get(bpy.context.evaluated_depsgraph_get())
mesh = evaluated.to_mesh()
mesh.calc_loop_triangles()
vertices = np.empty(len(mesh.vertices) * 3)
mesh.vertices.foreach_get("co", vertices)
triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
mesh.loop_triangles.foreach_get("vertices", triangles)
np.savez(out, vertices=vertices.reshape(-1, 3), triangles=triangles.reshape(-1, 3))
"""


def uv_sphere(count: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit UV sphere of about count triangles: vertices (V, 3) float64, triangles (T, 3) int64."""
    rings = max(2, int(np.sqrt(count / 2)))
    segments = max(3, count // (2 * rings))
    theta = np.pi * np.arange(1, rings) / rings
    phi = 2 * np.pi * np.arange(segments) / segments
    ring_points = np.stack(
        [
            np.outer(np.sin(theta), np.cos(phi)),
            np.outer(np.sin(theta), np.sin(phi)),
            np.repeat(np.cos(theta), segments).reshape(rings - 1, segments),
        ],
        axis=-1,
    ).reshape(-1, 3)
    vertices = np.concatenate([[(0.0, 0.0, 1.0)], ring_points, [(0.0, 0.0, -1.0)]])
    south = len(vertices) - 1
    j = np.arange(segments)
    nxt = (j + 1) % segments
    last = 1 + (rings - 2) * segments
    caps = [
        np.stack([np.zeros(segments, int), 1 + j, 1 + nxt], 1),
        np.stack([np.full(segments, south), last + nxt, last + j], 1),
    ]
    i = np.arange(rings - 2)[:, None]
    a, b = 1 + i * segments + j, 1 + i * segments + nxt
    bands = np.stack([np.stack([a, a + segments, b], -1), np.stack([b, a + segments, b + segments], -1)], 2)
    triangles = np.concatenate([*caps, bands.reshape(-1, 3)]).astype(np.int64)
    return vertices, triangles


def suzanne(level: int = 2, cache: Path = ROOT / "out") -> tuple[np.ndarray, np.ndarray]:
    """Blender's Suzanne (size 2) with a Subdivision Surface modifier at level, evaluated: (V, 3), (T, 3)."""
    path = cache / f"suzanne-level{level}.npz"
    if not path.exists():
        cache.mkdir(parents=True, exist_ok=True)
        python = ROOT / ".venv" / "bin" / "python"
        subprocess.run(
            [str(python if python.exists() else sys.executable), "-c", SUZANNE_SCRIPT, str(level), str(path)],
            check=True,
            capture_output=True,
        )
    data = np.load(path)
    return data["vertices"], data["triangles"]


def mesh_scene(vertices: np.ndarray, triangles: np.ndarray, **render) -> dict:
    """The default scene's document with the mesh (copper, 1 unit across its largest half-extent, centred 2 above
    the ground) in the vane's place, and render settings replaced by the given ones."""
    document = default_scene_dict()
    centre = (vertices.max(axis=0) + vertices.min(axis=0)) / 2
    vertices = (vertices - centre) / np.abs(vertices - centre).max()
    mesh = {
        "name": "mesh",
        "type": "mesh",
        "material": "copper",
        "location": [0.0, 0.0, 2.0],
        "vertices": vertices.round(9).tolist(),
        "triangles": triangles.tolist(),
    }
    document["objects"] = [document["objects"][0], mesh]
    document.pop("vane", None)
    document.pop("motion", None)
    document.pop("wind", None)
    document["render"].update(render)
    return document
