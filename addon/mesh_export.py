"""An evaluated Blender object (mesh, text, curve, surface, metaball, Geometry Nodes mesh) and a world matrix -> a
tracer mesh in world space: triangles, corner normals where faces are smooth, a material slot per triangle.

The triangles of one evaluated object are read once (`MeshArrays`, NumPy through `foreach_get`) and placed at each
instance's matrix: 1,000 instances of a mesh cost one read and 1,000 matrix products.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import compat


@dataclass(frozen=True)
class MeshArrays:
    """One evaluated object's triangles in its local frame."""

    vertices: np.ndarray  # (V, 3) float64
    triangles: np.ndarray  # (T, 3) int64, counter-clockwise seen from the face normal's side
    corner_normals: np.ndarray | None  # (T, 3, 3) float64, None when every face is flat
    slots: np.ndarray  # (T,) int64, the material slot of each triangle


def read(obj) -> MeshArrays | None:
    """The triangles of an evaluated object, or None when it has no faces (or yields no mesh at all)."""
    try:
        mesh = obj.to_mesh()
    except RuntimeError:  # an object type with no mesh form
        return None
    if mesh is None:
        return None
    try:
        compat.calc_split_normals(mesh)
        mesh.calc_loop_triangles()
        count = len(mesh.loop_triangles)
        if count == 0:
            return None
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", vertices)
        triangles = np.empty(count * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        normals = np.empty(count * 9, dtype=np.float32)
        mesh.loop_triangles.foreach_get("split_normals", normals)
        face_normals = np.empty(count * 3, dtype=np.float32)
        mesh.loop_triangles.foreach_get("normal", face_normals)
        slots = np.empty(count, dtype=np.int32)
        mesh.loop_triangles.foreach_get("material_index", slots)
        polygons = np.empty(count, dtype=np.int32)
        mesh.loop_triangles.foreach_get("polygon_index", polygons)
        smooth_faces = np.empty(len(mesh.polygons), dtype=bool)
        mesh.polygons.foreach_get("use_smooth", smooth_faces)
    finally:
        obj.to_mesh_clear()
    smooth = smooth_faces[polygons]
    corner_normals = normals.astype(np.float64).reshape(count, 3, 3)
    # a flat face shades with each triangle's own normal, as Cycles does (a non-planar quad's split normal is the
    # polygon's, which neither triangle has): only smooth faces carry corner normals
    corner_normals[~smooth] = face_normals.astype(np.float64).reshape(count, 1, 3)[~smooth]
    flat = not smooth.any()
    return MeshArrays(
        vertices=vertices.astype(np.float64).reshape(-1, 3),
        triangles=triangles.astype(np.int64).reshape(count, 3),
        corner_normals=None if flat else corner_normals,
        slots=slots.astype(np.int64),
    )


def in_world(arrays: MeshArrays, matrix) -> tuple[dict, np.ndarray, int]:
    """The mesh placed by a world matrix (4x4, mathutils or nested lists): scene-file fields (vertices, triangles,
    and normals where faces are smooth), the material slot of each kept triangle (T,), and how many triangles were
    dropped for spanning no area there (the tracer refuses them; Blender renders nothing of them)."""
    m = np.array(matrix, dtype=np.float64)
    vertices = arrays.vertices @ m[:3, :3].T + m[:3, 3]
    triangles = arrays.triangles
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    spans_area = np.any(np.cross(b - a, c - a) != 0.0, axis=1) & np.all(np.isfinite(vertices[triangles]), axis=(1, 2))
    mirrored = np.linalg.det(m[:3, :3]) < 0.0
    # a mirroring matrix turns counter-clockwise into clockwise: swap two corners so the normal points out again
    order = [0, 2, 1] if mirrored else [0, 1, 2]
    kept = triangles[spans_area][:, order]
    used, remapped = np.unique(kept, return_inverse=True)  # only the vertices the kept triangles use
    fields: dict = {"vertices": vertices[used].tolist(), "triangles": remapped.reshape(-1, 3).tolist()}
    if arrays.corner_normals is not None:
        normal_matrix = np.linalg.inv(m[:3, :3]).T  # normals transform by the inverse transpose
        normals = arrays.corner_normals[spans_area][:, order] @ normal_matrix.T
        lengths = np.linalg.norm(normals, axis=2, keepdims=True)
        a, b, c = (vertices[kept[:, k]] for k in range(3))
        flat = np.cross(b - a, c - a)
        flat = np.broadcast_to((flat / np.linalg.norm(flat, axis=1, keepdims=True))[:, None, :], normals.shape)
        fields["normals"] = np.where(lengths > 0, normals / np.where(lengths > 0, lengths, 1.0), flat).tolist()
    return fields, arrays.slots[spans_area], int(np.count_nonzero(~spans_area))
