"""Scene objects -> world-space primitive parameters: plain Python floats, and a mesh's triangles as arrays.

Both the vectorized tracer and the per-pixel reference start from these numbers, so the two agree on geometry
and differ only in how they trace. Rotations follow Blender: Euler XYZ in degrees, R = Rz @ Ry @ Rx.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import scene as sc

Matrix3 = tuple[sc.Vec3, sc.Vec3, sc.Vec3]

IDENTITY: Matrix3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def euler_xyz_matrix(rotation_degrees: sc.Vec3) -> Matrix3:
    """Blender's XYZ Euler rotation as a row-major 3x3 matrix (applied to column vectors: R @ v)."""
    x, y, z = (math.radians(angle) for angle in rotation_degrees)
    cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), math.cos(z), math.sin(z)
    return (
        (cy * cz, sx * sy * cz - cx * sz, cx * sy * cz + sx * sz),
        (cy * sz, sx * sy * sz + cx * cz, cx * sy * sz - sx * cz),
        (-sy, sx * cy, cx * cy),
    )


def euler_xyz_from_matrix(matrix: Matrix3) -> sc.Vec3:
    """The XYZ Euler angles in degrees of a rotation matrix (row-major), the inverse of euler_xyz_matrix: the Y
    angle in [-90, 90]; at +-90 degrees (gimbal lock) the X angle takes the whole turn about the shared axis."""
    (r00, _, _), (r10, r11, r12), (r20, r21, r22) = matrix
    cos_y = math.hypot(r00, r10)
    y = math.atan2(-r20, cos_y)
    if cos_y > 1e-12:
        x, z = math.atan2(r21, r22), math.atan2(r10, r00)
    else:
        x, z = math.atan2(-r12, r11), 0.0
    return math.degrees(x), math.degrees(y), math.degrees(z)


def axis_angle_matrix(axis: sc.Vec3, angle_degrees: float) -> Matrix3:
    """Right-handed rotation by angle about a (not necessarily unit) axis (Rodrigues)."""
    length = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    x, y, z = axis[0] / length, axis[1] / length, axis[2] / length
    angle = math.radians(angle_degrees)
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return (
        (t * x * x + c, t * x * y - s * z, t * x * z + s * y),
        (t * x * y + s * z, t * y * y + c, t * y * z - s * x),
        (t * x * z - s * y, t * y * z + s * x, t * z * z + c),
    )


def apply(matrix: Matrix3, v: sc.Vec3) -> sc.Vec3:
    return (
        matrix[0][0] * v[0] + matrix[0][1] * v[1] + matrix[0][2] * v[2],
        matrix[1][0] * v[0] + matrix[1][1] * v[1] + matrix[1][2] * v[2],
        matrix[2][0] * v[0] + matrix[2][1] * v[1] + matrix[2][2] * v[2],
    )


def matmul(a: Matrix3, b: Matrix3) -> Matrix3:
    columns = [apply(a, (b[0][j], b[1][j], b[2][j])) for j in range(3)]
    return tuple(tuple(columns[j][i] for j in range(3)) for i in range(3))  # type: ignore[return-value]


def add(a: sc.Vec3, b: sc.Vec3) -> sc.Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: sc.Vec3, b: sc.Vec3) -> sc.Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(v: sc.Vec3, k: float) -> sc.Vec3:
    return (v[0] * k, v[1] * k, v[2] * k)


def dot(a: sc.Vec3, b: sc.Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: sc.Vec3, b: sc.Vec3) -> sc.Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def length(v: sc.Vec3) -> float:
    return math.sqrt(dot(v, v))


def normalize(v: sc.Vec3) -> sc.Vec3:
    size = length(v)
    return (v[0] / size, v[1] / size, v[2] / size)


# ---- world-space primitives --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WorldSphere:
    material: str
    center: sc.Vec3
    radius: float


@dataclass(frozen=True)
class WorldPlane:
    """normal is unit length; u_axis, v_axis and half_size bound a finite plane (half_size None: infinite)."""

    material: str
    point: sc.Vec3
    normal: sc.Vec3
    u_axis: sc.Vec3
    v_axis: sc.Vec3
    half_size: tuple[float, float] | None


@dataclass(frozen=True)
class WorldCylinder:
    """The seed's cylinder (2.18-2.23): base centre C, unit axis V, height H, radius r."""

    material: str
    base: sc.Vec3
    axis: sc.Vec3
    height: float
    radius: float


@dataclass(frozen=True, eq=False)
class WorldTriangles(sc.ArraysByBits):
    """Triangles (T, 3 vertices, 3) float64 with normals (T, 3) computed once before tracing (seed 2.6): unit (v1-v0)
    x (v2-v0), or 0 for a triangle of no area; read-only arrays (nested sequences are converted once, here).

    Kernels are kept between frames keyed by their primitive (tracing/wavefront.py), so equality compares the
    arrays' bits and the hash leaves them out (hashing a million triangles as tuples took 1.5 s a frame)."""

    material: str
    triangles: np.ndarray
    normals: np.ndarray
    rotation: Matrix3 = IDENTITY  # the object's frame: world = rotation @ local + location
    location: sc.Vec3 = (0.0, 0.0, 0.0)
    # what the triangles were made from, where that is a mesh's (vertices, faces): the kernel cache's key then holds
    # these (the scene's own arrays) instead of the world's triangles and normals (96 MB at a million triangles)
    source: tuple[np.ndarray, np.ndarray] | None = None

    ARRAYS = ("triangles", "normals")
    UNCOMPARED = ("source",)  # the triangles and normals are made from it

    def __post_init__(self) -> None:
        object.__setattr__(self, "triangles", sc.frozen_array(self.triangles, np.float64, (-1, 3, 3)))
        object.__setattr__(self, "normals", sc.frozen_array(self.normals, np.float64, (-1, 3)))

    @property
    def cache_key(self) -> object:
        """What names these triangles in a cache: equal keys, the same triangles and normals."""
        return self if self.source is None else MeshSource(self.material, self.rotation, self.location, *self.source)


@dataclass(frozen=True, eq=False)
class MeshSource(sc.ArraysByBits):
    """A mesh's local vertices (V, 3) and faces (T, 3) placed by a frame: the same ones (by their bits) give the same
    world triangles (_triangles is a function of them)."""

    material: str
    rotation: Matrix3
    location: sc.Vec3
    vertices: np.ndarray
    faces: np.ndarray

    ARRAYS = ("vertices", "faces")


@dataclass(frozen=True, eq=False)
class WorldInstances(sc.ArraysByBits):
    """A mesh placed K times: its triangles once, in its own space (a WorldTriangles at the identity, the kernel
    cache's key its (vertices, faces)), and per instance the maps both ways, float64.

    matrices (K, 3, 4): world = A @ local + b, the scene's matrices after the object's own frame. inverses (K, 3, 4):
    local = A^-1 @ world + (-A^-1 b): a ray goes into an instance's space as O' = A^-1 O + c, D' = A^-1 D (D' not
    normalised, so t is the same parameter on both sides). cofactors (K, 3, 3): |det(A)| A^-T, which takes a local
    normal to the normal of the placed triangle ((A e1) x (A e2) = det(A) A^-T (e1 x e2)), kept on the outer side
    for a mirroring A as Blender keeps a negatively scaled object's (and as the export of world triangles swaps two
    corners of each). A hit's part is k T + the triangle's index (T triangles), so instance k's hits come before
    instance k + 1's on ties."""

    material: str
    mesh: WorldTriangles
    matrices: np.ndarray
    inverses: np.ndarray
    cofactors: np.ndarray

    ARRAYS = ("matrices",)
    UNCOMPARED = ("mesh", "inverses", "cofactors")  # the mesh by its cache key below; the others from matrices

    def _plain(self) -> tuple:
        return (*super()._plain(), self.mesh.cache_key)

    @property
    def cache_key(self) -> object:
        return self

    @property
    def triangle_count(self) -> int:
        return len(self.mesh.triangles)


WorldPrimitive = WorldSphere | WorldPlane | WorldCylinder | WorldTriangles | WorldInstances

# meshes of at most this many triangles are placed in one pass (world_primitives): per-mesh NumPy calls dominate them,
# while a larger mesh's own pass is all arithmetic (and joining would copy it)
PLACED_TOGETHER_TRIANGLES = 4096
BOX_TRIANGLES = (
    # two counter-clockwise triangles per face, seen from outside; corners indexed by (x, y, z) bits
    (0, 1, 3), (0, 3, 2),  # -X
    (4, 6, 7), (4, 7, 5),  # +X
    (0, 4, 5), (0, 5, 1),  # -Y
    (2, 3, 7), (2, 7, 6),  # +Y
    (0, 2, 6), (0, 6, 4),  # -Z
    (1, 5, 7), (1, 7, 3),  # +Z
)  # fmt: skip

PYRAMID_TRIANGLES = (
    (0, 1, 3), (0, 3, 2),  # base, facing -Z
    (1, 0, 4), (3, 1, 4), (2, 3, 4), (0, 2, 4),  # sides up to the apex
)  # fmt: skip


def box_vertices(size: sc.Vec3) -> list[sc.Vec3]:
    hx, hy, hz = size[0] / 2.0, size[1] / 2.0, size[2] / 2.0
    return [(sx * hx, sy * hy, sz * hz) for sx in (-1.0, 1.0) for sy in (-1.0, 1.0) for sz in (-1.0, 1.0)]


def pyramid_vertices(size: sc.Vec3) -> list[sc.Vec3]:
    hx, hy, hz = size[0] / 2.0, size[1] / 2.0, size[2] / 2.0
    base = [(sx * hx, sy * hy, -hz) for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)]
    return [*base, (0.0, 0.0, hz)]


def object_frame(obj: sc.SceneObject, vane: sc.Vane | None) -> tuple[Matrix3, sc.Vec3]:
    """The object's world rotation and location, turned with the vane when it is one of its parts."""
    rotation = euler_xyz_matrix(obj.rotation)
    location = obj.location
    if vane is not None and obj.name in vane.parts and vane.heading != 0.0:
        turn = axis_angle_matrix(vane.axis, vane.heading)
        rotation = matmul(turn, rotation)
        location = add(vane.pivot, apply(turn, sub(location, vane.pivot)))
    # each -0.0 made 0.0: objects equal under == (one turned by -0.0 about Z, whose normal is then (0, -0.0, 1)) get
    # the same world primitive, bit for bit, so that a kernel kept between scenes under an equal primitive
    # (tracing/wavefront.py) is the one each would make, and a scene's bytes do not depend on what came before it
    (a, b, c), (d, e, f), (g, h, i) = rotation
    x, y, z = location
    rotation = ((a + 0.0, b + 0.0, c + 0.0), (d + 0.0, e + 0.0, f + 0.0), (g + 0.0, h + 0.0, i + 0.0))
    return rotation, (x + 0.0, y + 0.0, z + 0.0)


def _triangles(
    material: str,
    rotation: Matrix3,
    location: sc.Vec3,
    vertices: np.ndarray | list[sc.Vec3],
    faces: np.ndarray | tuple[tuple[int, int, int], ...],
    source: tuple[np.ndarray, np.ndarray] | None = None,
) -> WorldTriangles:
    """vertices (V, 3) and faces (T, 3) -> the world's triangles and unit normals, as arrays: the operations of
    add(location, apply(rotation, v)), cross, length and the division per component in their order, so the same
    float64 numbers as those functions give one vertex at a time (the reference's)."""
    local = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    x, y, z = local[:, 0], local[:, 1], local[:, 2]
    world = np.empty_like(local)
    for axis in range(3):
        row = rotation[axis]
        world[:, axis] = location[axis] + (row[0] * x + row[1] * y + row[2] * z)
    triangles, normals = _with_normals(world[np.asarray(faces, dtype=np.int64).reshape(-1, 3)])
    return WorldTriangles(material, triangles, normals, rotation, location, source)


def _with_normals(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World triangles (T, 3 vertices, 3) -> themselves and their unit normals (T, 3), both read-only: cross,
    length and the division per component in the reference's order ((0, 0, 0) where a triangle has no area)."""
    v0 = triangles[:, 0]
    ax, ay, az = (triangles[:, 1] - v0).T  # sub(v1, v0)
    bx, by, bz = (triangles[:, 2] - v0).T
    n = np.stack((ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx), axis=1)  # cross
    nx, ny, nz = n.T
    size = np.sqrt(nx * nx + ny * ny + nz * nz)  # length: math.sqrt(dot(n, n))
    area = size > 0.0
    normals = np.divide(n, size[:, None], out=np.zeros_like(n), where=area[:, None])  # (0, 0, 0) where no area
    for array in (triangles, normals):
        array.flags.writeable = False  # made here and owned: WorldTriangles keeps them (or views) without a copy
    return triangles, normals


def _placed_together(meshes: list[sc.TriangleMesh], vane: sc.Vane | None) -> list[WorldTriangles]:
    """Many meshes' world triangles in one pass over their joined vertices: each vertex placed by its own mesh's
    frame with _triangles' operations in its order (elementwise, so the same bits as one mesh at a time), each
    mesh's triangles and normals read-only views of the joined ones. Thousands of separate objects took 40 us each
    one at a time (a scene's preparation after one of 3,000 cubes moved: 0.12 of 0.22 s)."""
    frames = [object_frame(mesh, vane) for mesh in meshes]
    vertices = [np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3) for mesh in meshes]
    faces = [np.asarray(mesh.triangles, dtype=np.int64).reshape(-1, 3) for mesh in meshes]
    vertex_counts = np.array([len(array) for array in vertices])
    triangle_counts = np.array([len(array) for array in faces])
    local = np.concatenate(vertices)
    x, y, z = local[:, 0], local[:, 1], local[:, 2]
    rotations = np.repeat(np.array([rotation for rotation, _ in frames], dtype=np.float64), vertex_counts, axis=0)
    locations = np.repeat(np.array([location for _, location in frames], dtype=np.float64), vertex_counts, axis=0)
    world = np.empty_like(local)
    for axis in range(3):
        row = rotations[:, axis]
        world[:, axis] = locations[:, axis] + (row[:, 0] * x + row[:, 1] * y + row[:, 2] * z)
    offsets = np.repeat(np.cumsum(vertex_counts) - vertex_counts, triangle_counts)
    triangles, normals = _with_normals(world[np.concatenate(faces) + offsets[:, None]])
    placed, start = [], 0
    for mesh, (rotation, location), count in zip(meshes, frames, triangle_counts.tolist(), strict=True):
        piece = slice(start, start + count)
        source = (mesh.vertices, mesh.triangles)
        placed.append(WorldTriangles(mesh.material, triangles[piece], normals[piece], rotation, location, source))
        start += count
    return placed


def world_primitive(obj: sc.SceneObject, vane: sc.Vane | None) -> WorldPrimitive:
    """One scene object in world space, as the seed's intersection formulas want it."""
    rotation, location = object_frame(obj, vane)
    z_axis = (rotation[0][2], rotation[1][2], rotation[2][2])
    if isinstance(obj, sc.Sphere):
        return WorldSphere(obj.material, location, obj.radius)
    if isinstance(obj, sc.Plane):
        x_axis = (rotation[0][0], rotation[1][0], rotation[2][0])
        y_axis = (rotation[0][1], rotation[1][1], rotation[2][1])
        half = None if obj.size is None else (obj.size[0] / 2.0, obj.size[1] / 2.0)
        return WorldPlane(obj.material, location, z_axis, x_axis, y_axis, half)
    if isinstance(obj, sc.Cylinder):
        base = sub(location, scale(z_axis, obj.height / 2.0))
        return WorldCylinder(obj.material, base, z_axis, obj.height, obj.radius)
    if isinstance(obj, sc.Box):
        return _triangles(obj.material, rotation, location, box_vertices(obj.size), BOX_TRIANGLES)
    if isinstance(obj, sc.Pyramid):
        return _triangles(obj.material, rotation, location, pyramid_vertices(obj.size), PYRAMID_TRIANGLES)
    if isinstance(obj, sc.MeshInstances):
        return world_instances(obj, rotation, location)
    return _triangles(obj.material, rotation, location, obj.vertices, obj.triangles, (obj.vertices, obj.triangles))


def world_instances(obj: sc.MeshInstances, rotation: Matrix3, location: sc.Vec3) -> WorldInstances:
    """The instances' matrices after the object's frame (rotation, location; the identity unless a vane turns them),
    their inverses and cofactors, and the mesh's triangles in its own space."""
    mesh = obj.mesh
    local = _triangles(
        mesh.material, IDENTITY, (0.0, 0.0, 0.0), mesh.vertices, mesh.triangles, (mesh.vertices, mesh.triangles)
    )
    matrices = np.asarray(obj.matrices, dtype=np.float64)
    if rotation != IDENTITY or location != (0.0, 0.0, 0.0):
        turn = np.asarray(rotation, dtype=np.float64)
        matrices = np.concatenate(
            (turn @ matrices[:, :, :3], turn @ matrices[:, :, 3:] + np.reshape(location, (3, 1))), 2
        )
    cofactor, determinant = _cofactors(matrices[:, :, :3])
    inverse = np.transpose(cofactor, (0, 2, 1)) / determinant[:, None, None]
    offset = -(inverse @ matrices[:, :, 3:])
    inverses = np.concatenate((inverse, offset), axis=2)
    cofactors = cofactor * np.sign(determinant)[:, None, None]  # |det A| A^-T
    return WorldInstances(obj.material, local, _read_only(matrices), _read_only(inverses), _read_only(cofactors))


def _cofactors(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3x3 matrices (K, 3, 3) -> their cofactor matrices (K, 3, 3) (det(A) A^-T) and determinants (K,), written out:
    np.linalg.inv calls LAPACK once per matrix (1.2 s for 100,000 of them here, this a few milliseconds)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = (tuple(a[:, i, j] for j in range(3)) for i in range(3))
    rows = (
        (a11 * a22 - a12 * a21, a12 * a20 - a10 * a22, a10 * a21 - a11 * a20),
        (a02 * a21 - a01 * a22, a00 * a22 - a02 * a20, a01 * a20 - a00 * a21),
        (a01 * a12 - a02 * a11, a02 * a10 - a00 * a12, a00 * a11 - a01 * a10),
    )
    cofactor = np.stack([np.stack(row, axis=1) for row in rows], axis=1)
    determinant = a00 * rows[0][0] + a01 * rows[0][1] + a02 * rows[0][2]
    return cofactor, determinant


def _read_only(array: np.ndarray) -> np.ndarray:
    """A contiguous float64 copy (or the array itself, where it is one) that nobody can write to."""
    array = np.ascontiguousarray(array, dtype=np.float64)
    array.flags.writeable = False
    return array


def world_primitives(scene: sc.Scene) -> list[WorldPrimitive]:
    """world_primitive of every object; the meshes of at most PLACED_TOGETHER_TRIANGLES triangles placed in one pass
    (_placed_together: the same arrays, bit for bit)."""
    objects = scene.objects
    small = [
        index
        for index, obj in enumerate(objects)
        if type(obj) is sc.TriangleMesh and len(obj.triangles) <= PLACED_TOGETHER_TRIANGLES
    ]
    placed: dict[int, WorldPrimitive] = {}
    if len(small) > 1:
        placed = dict(zip(small, _placed_together([objects[index] for index in small], scene.vane), strict=True))
    return [placed[index] if index in placed else world_primitive(obj, scene.vane) for index, obj in enumerate(objects)]


def world_corner_normals(obj: sc.SceneObject, vane: sc.Vane | None) -> np.ndarray | None:
    """A mesh's corner normals (T, 3 corners, 3) rotated into the world with the object (None: a flat mesh). One
    array both tracers read, so that they interpolate the same numbers."""
    normals = getattr(obj, "normals", None)
    if normals is None or isinstance(obj, sc.MeshInstances):  # an instance's normals stay in its mesh's space
        return None
    rotation, _ = object_frame(obj, vane)
    local = np.asarray(normals, dtype=np.float64).reshape(-1, 3, 3)  # triples, or the loader's flat nines
    return local @ np.asarray(rotation, dtype=np.float64).T
