"""An evaluated Blender object's mesh (mesh, text, curve, surface, metaball, Geometry Nodes geometry) -> NumPy
triangles in its own space, read once and kept until Blender changes that geometry; placed by a matrix -> the scene
file's triangles, corner normals and material slots.

- `read` turns an evaluated object into `MeshArrays` (NumPy through `foreach_get`): its triangles in local space.
- `place` turns MeshArrays and a matrix (or none: local space) into `Placed`: the triangles that span an area there,
  the vertices they use, unit corner normals; `Placed.fields` gives the scene file's lists.
- `GeometryCache` keeps MeshArrays (and their placed forms) between exports, keyed by where the geometry comes from
  (an original mesh data-block, or an original object's evaluation), and forgets them when the depsgraph reports a
  geometry update of what they were read from (`observe`, fed by the depsgraph handlers and the engine's
  view_update). A geometry that can change with the frame (modifiers, shape keys, animated data) is trusted at another
  frame only where a viewport depsgraph evaluated that frame without updating it, or where a fingerprint of its
  evaluated mesh (positions, corners, faces' materials and smoothing) is unchanged.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from .. import compat

# A texture's "uv_map" where it reads Blender's Generated coordinates (a Checker or Gradient Texture's Vector unlinked,
# or from Texture Coordinate > Generated): its meshes' corner "uvs" are then made from their positions in their
# texture space (generated_uvs). A UV map of this very name is read as Generated coordinates.
GENERATED = "<Generated>"


@dataclass(frozen=True)
class GeneratedUVs:
    """A request for corner UVs from Generated coordinates (Placed.fields): a checker's scale, whose 3D cells each
    triangle's third axis folds into u; None for a gradient, which reads x and y alone."""

    checker_scale: float | None = None


@dataclass(frozen=True)
class MeshArrays:
    """One evaluated object's triangles in its local frame."""

    vertices: np.ndarray  # (V, 3) float64
    triangles: np.ndarray  # (T, 3) int64, counter-clockwise seen from the face normal's side
    corner_normals: np.ndarray | None  # (T, 3, 3) float64, None when every face is flat
    slots: np.ndarray  # (T,) int64, the material slot of each triangle
    uvs: np.ndarray | None = None  # (T, 3, 2) float64 the active render UV map's per corner, None without one
    uv_maps: dict = field(default_factory=dict)  # every UV map's, (T, 3, 2) float64 each, by name
    # the colour attributes (point or corner domain) per corner, linear RGB (T, 3, 3) float64 each, by name; "" names
    # the render default (what a Color Attribute node of no name reads)
    colors: dict = field(default_factory=dict)
    memo: dict = field(default_factory=dict, compare=False, repr=False)
    # the texture space (location (3,), size (3,)) Generated coordinates span, Blender's; None where unknown
    texspace: tuple | None = None

    def generated(self) -> np.ndarray | None:
        """Each triangle corner's Generated coordinates (T, 3, 3) float64, as Cycles makes them: (p - location) /
        (2 size) + 1/2, an axis of size 0 at 1/2; None without a texture space. Made once, when first asked."""
        if self.texspace is None:
            return None
        found = self.memo.get("generated")
        if found is None:
            location, size = (np.asarray(part, dtype=np.float64) for part in self.texspace)
            factor = np.divide(0.5, size, out=np.zeros(3), where=size != 0.0)
            found = self.memo["generated"] = self.vertices[self.triangles] * factor - (location * factor - 0.5)
        return found

    @property
    def all_used(self) -> bool:
        """Whether the triangles use every vertex (then, with every triangle kept, no index changes)."""
        found = self.memo.get("all_used")
        if found is None:
            used = np.zeros(len(self.vertices), dtype=bool)
            used[self.triangles.ravel()] = True
            found = self.memo["all_used"] = bool(used.all())
        return found

    @property
    def nbytes(self) -> int:
        maps = [array for array in self.uv_maps.values() if array is not self.uvs]
        arrays = (self.vertices, self.triangles, self.corner_normals, self.slots, self.uvs, *maps)
        return sum(array.nbytes for array in (*arrays, *self.colors.values()) if array is not None)


def _corner_uvs(mesh, loop_triangles, count: int) -> tuple[np.ndarray | None, dict[str, np.ndarray]]:
    """The mesh's UV maps at each triangle corner (T, 3, 2) float64, through foreach_get: the one Cycles' image
    textures read by default (the active render one, else the active one; None where the mesh has no UV map), and
    every one by name (for a UV Map node that names one)."""
    layers = getattr(mesh, "uv_layers", None)
    if not layers:
        return None, {}
    default = next((uv for uv in layers if uv.active_render), None) or layers.active or layers[0]
    loops = np.empty(count * 3, dtype=np.int32)
    loop_triangles.foreach_get("loops", loops)
    found = {}
    for layer in layers:
        uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.data.foreach_get("uv", uvs)
        found[layer.name] = uvs.reshape(-1, 2).astype(np.float64)[loops].reshape(count, 3, 2)
    return found[default.name], found


def _corner_colors(mesh, loop_triangles, count: int, triangles: np.ndarray) -> dict[str, np.ndarray]:
    """The mesh's colour attributes of the point or corner domain at each triangle corner (T, 3, 3) float64 linear
    RGB, by name, the render default also under "" (Cycles' Color Attribute node of no name); {} without any."""
    attributes = getattr(mesh, "color_attributes", None)
    if not attributes:
        return {}
    loops = None
    found = {}
    for attribute in attributes:
        if attribute.domain == "CORNER":
            if loops is None:
                loops = np.empty(count * 3, dtype=np.int32)
                loop_triangles.foreach_get("loops", loops)
            size, corner = len(mesh.loops), loops
        elif attribute.domain == "POINT":
            size, corner = len(mesh.vertices), triangles
        else:
            continue
        values = np.empty(size * 4, dtype=np.float32)
        attribute.data.foreach_get("color", values)  # scene linear, byte colours too
        found[attribute.name] = values.reshape(-1, 4)[:, :3].astype(np.float64)[corner].reshape(count, 3, 3)
    index = getattr(attributes, "render_color_index", -1)
    default = attributes[index].name if 0 <= index < len(attributes) else next(iter(found), None)
    if default in found:
        found[""] = found[default]
    return found


def read(obj) -> MeshArrays | None:
    """The triangles of an evaluated object, or None when it has no faces (or yields no mesh at all)."""
    try:
        mesh = obj.to_mesh()
    except RuntimeError:  # an object type with no mesh form
        return None
    if mesh is None:
        return None
    try:
        mesh.calc_loop_triangles()
        loop_triangles = mesh.loop_triangles
        count = len(loop_triangles)
        if count == 0:
            return None
        polygons = mesh.polygons
        smooth_faces = np.empty(len(polygons), dtype=bool)
        polygons.foreach_get("use_smooth", smooth_faces)
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", vertices)
        triangles = np.empty(count * 3, dtype=np.int32)
        loop_triangles.foreach_get("vertices", triangles)
        slots = np.empty(count, dtype=np.int32)
        loop_triangles.foreach_get("material_index", slots)
        corner_normals = None
        if smooth_faces.any():  # flat meshes need no normals at all (most of a small mesh's reading time)
            compat.calc_split_normals(mesh)
            normals = np.empty(count * 9, dtype=np.float32)
            loop_triangles.foreach_get("split_normals", normals)
            face_normals = np.empty(count * 3, dtype=np.float32)
            loop_triangles.foreach_get("normal", face_normals)
            polygon_of = np.empty(count, dtype=np.int32)
            loop_triangles.foreach_get("polygon_index", polygon_of)
            flat = ~smooth_faces[polygon_of]
            corner_normals = normals.astype(np.float64).reshape(count, 3, 3)
            # a flat face shades with each triangle's own normal, as Cycles does (a non-planar quad's split normal is
            # the polygon's, which neither triangle has): only smooth faces carry corner normals
            corner_normals[flat] = face_normals.astype(np.float64).reshape(count, 1, 3)[flat]
        uvs, uv_maps = _corner_uvs(mesh, loop_triangles, count)
        colors = _corner_colors(mesh, loop_triangles, count, triangles)
        texspace = (tuple(mesh.texspace_location), tuple(mesh.texspace_size))
    finally:
        obj.to_mesh_clear()
    return MeshArrays(
        vertices=vertices.astype(np.float64).reshape(-1, 3),
        triangles=triangles.astype(np.int64).reshape(count, 3),
        corner_normals=corner_normals,
        slots=slots.astype(np.int64),
        uvs=uvs,
        uv_maps=uv_maps,
        colors=colors,
        texspace=texspace,
    )


SMALL_MESH = 4096  # triangles: a placed mesh up to this size keeps its lists too (conversion dominates small meshes)


@dataclass(frozen=True)
class Placed:
    """A mesh's triangles placed by one matrix (or in its own space): what the scene file holds of it."""

    vertices: np.ndarray  # (V, 3) float64, only those the kept triangles use
    triangles: np.ndarray  # (T, 3) int64 into vertices
    normals: np.ndarray | None  # (T, 3, 3) float64 unit corner normals, None when every face is flat
    slots: np.ndarray  # (T,) int64, the material slot of each kept triangle
    dropped: int  # triangles left out for spanning no area (the tracer refuses them; Blender renders nothing of them)
    uvs: np.ndarray | None = None  # (T, 3, 2) float64 corner UVs of the kept triangles, None without a UV map
    uv_maps: dict = field(default_factory=dict)  # name -> (T, 3, 2) float64 each UV map's of the kept triangles
    colors: dict = field(default_factory=dict)  # name -> (T, 3, 3) float64 corner colours of the kept triangles
    memo: dict = field(default_factory=dict, compare=False, repr=False)  # what fields() and slots_of() made
    # the mesh in its own space, which triangles were kept (None: all) and their corners' order: for generated_uvs
    source: MeshArrays | None = field(default=None, compare=False, repr=False)
    kept_rows: np.ndarray | None = field(default=None, compare=False, repr=False)
    corner_order: tuple = (0, 1, 2)

    @property
    def nbytes(self) -> int:
        """Its arrays' bytes; a small mesh's counted 8 times, for the lists it keeps (a row of 3 floats is a list of
        float objects: about 150 bytes against 24)."""
        maps = [array for array in self.uv_maps.values() if array is not self.uvs]
        arrays = (self.vertices, self.triangles, self.normals, self.slots, self.uvs, *maps, *self.colors.values())
        size = sum(array.nbytes for array in arrays if array is not None)
        return size * 8 if len(self.triangles) <= SMALL_MESH else size

    def fields(self, arrays: bool = False, uvs: bool | str = False, colors: str | None = None) -> dict:
        """fields_without_uvs(arrays), with the corner "uvs" where asked (a textured material: True the default UV map,
        a name that UV map) and the corner "colors"
        of the colour attribute named colors ("" the render default) where the mesh has it: arrays where arrays are
        asked (a render in this process), else lists made once. A mesh with no UV map gets (0, 0) at every
        corner: Cycles reads a missing UV map as zero, so its textures show the texel found at (0, 0)."""
        found = self.fields_without_uvs(arrays)
        corner_colors = self.colors.get(colors) if colors is not None else None
        if corner_colors is not None:  # the colour attribute an "attribute" texture of its material reads
            found["colors"] = self._corners(corner_colors, ("color lists", colors), arrays)
        if not uvs:
            return found
        if isinstance(uvs, GeneratedUVs):
            found["uvs"] = self._corners(self.generated_uvs(uvs)[0], ("uv lists", uvs), arrays)
            return found
        # a UV map by name (a UV Map node's): one the mesh lacks reads (0, 0) below, as Cycles reads a missing one
        corners = self.uv_maps.get(uvs) if isinstance(uvs, str) else self.uvs
        if corners is None:
            corners = self.memo.get("zero uvs")
            if corners is None:
                corners = self.memo["zero uvs"] = np.zeros((len(self.triangles), 3, 2))
        found["uvs"] = self._corners(corners, ("uv lists", uvs), arrays)
        return found

    def generated_uvs(self, request: GeneratedUVs) -> tuple[np.ndarray, int]:
        """Corner UVs (T, 3, 2) from Blender's Generated coordinates (the mesh's own positions across its texture
        space, [0, 1] on each axis, as Cycles makes them), and how many triangles they are not exact on.

        A gradient reads x and y alone: (x, y), exact everywhere. Cycles' checker is 3D: a cell's colour follows the
        parity of its x, y and z cells alike, so a triangle with one axis constant (every face of a plane or a box
        in its texture space) reads the other two as (u, v), the constant axis's parity folded into u as one cell
        more (the same cells to a millionth of one). A triangle that no axis is constant on takes its thinnest axis
        at its corners' mean: it is counted, for the note that names it."""
        found = self.memo.get(request)
        if found is not None:
            return found
        generated = self.source.generated() if self.source is not None else None
        if generated is None:  # no texture space known (a mesh read() gives has one): (0, 0), every triangle counted
            generated = np.zeros((len(self.triangles), 3, 3))
            off = len(self.triangles)
            found = self.memo[request] = (generated[:, :, :2], off)
            return found
        if self.kept_rows is not None:
            generated = generated[self.kept_rows]
        generated = generated[:, list(self.corner_order)]
        if request.checker_scale is None:
            found = self.memo[request] = (np.ascontiguousarray(generated[:, :, :2]), 0)
            return found
        extent = generated.max(axis=1) - generated.min(axis=1)  # (T, 3)
        flat = extent == 0.0
        axis = np.where(flat.any(axis=1), flat.argmax(axis=1), extent.argmin(axis=1))  # (T,) the axis folded in
        off = int(np.count_nonzero(~flat.any(axis=1)))
        rows = np.arange(len(axis))
        depth = generated[rows, :, axis].mean(axis=1)  # (T,) the folded axis's value (a flat one's exactly)
        scale = request.checker_scale
        parity = np.abs(np.floor((depth * scale + 1e-6) * 0.999999)) % 2  # Cycles' svm_checker cell of that axis
        others = np.array([[1, 2], [0, 2], [0, 1]])[axis]  # (T, 2) the two axes read, in order
        uvs = np.take_along_axis(generated, others[:, None, :], axis=2)
        if scale != 0.0:
            uvs[:, :, 0] += (parity / scale)[:, None]
        found = self.memo[request] = (uvs, off)
        return found

    def _corners(self, corners: np.ndarray, key: tuple, arrays: bool):
        """Per-corner values (T, 3, k) as the scene file takes them: a read-only view where arrays are asked, else
        lists made once (kept in memo under key), in new outer lists."""
        if arrays:
            view = corners.view()
            view.flags.writeable = False
            return view
        listed = self.memo.get(key)
        if listed is None:
            listed = self.memo[key] = corners.tolist()
        return list(listed)

    def fields_without_uvs(self, arrays: bool = False) -> dict:
        """The scene file's "vertices", "triangles" and, where faces are smooth, "normals" (lists). A small mesh's are
        made once: each call gets new outer lists whose rows it shares with the other calls' (read them only).
        arrays: a large mesh's as read-only views of its arrays instead, for the loader in the same process (a
        render): lists cost about 6 times the memory and the time to make and to check again."""
        if arrays and len(self.triangles) > SMALL_MESH:
            views = {"vertices": self.vertices.view(), "triangles": self.triangles.view()}
            if self.normals is not None:
                views["normals"] = self.normals.view()
            for view in views.values():
                view.flags.writeable = False
            return views
        lists = self.memo.get("lists")
        if lists is None:
            lists = {"vertices": self.vertices.tolist(), "triangles": self.triangles.tolist()}
            if self.normals is not None:
                lists["normals"] = self.normals.tolist()
            if len(self.triangles) > SMALL_MESH:
                return lists
            self.memo["lists"] = lists
        return {name: list(rows) for name, rows in lists.items()}

    def slots_of(self, count: int) -> tuple[np.ndarray, list[int]]:
        """Each triangle's material slot for an object with count slots (a slot index past the last takes the last,
        as Blender's render does), and the slots used, ascending."""
        found = self.memo.get(count)
        if found is None:
            slots = np.minimum(self.slots, count - 1)
            found = self.memo[count] = (slots, sorted(set(slots.tolist())) or [0])
        return found


_NEXT, _LAST = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise cross products of (N, 3) arrays: np.cross's very operations (u1 v2 - u2 v1, ...: the same bits) in
    seven NumPy calls instead of its dozens, whose per-call cost dominates the many small meshes of a scene."""
    return u.take(_NEXT, axis=1) * v.take(_LAST, axis=1) - u.take(_LAST, axis=1) * v.take(_NEXT, axis=1)


def _mirrors(linear: np.ndarray) -> bool:
    """Whether a 3x3 matrix mirrors (its determinant is negative), as np.linalg.det says, which costs 20 us a call: the
    triple product decides where it is clear of rounding, LAPACK where it is not."""
    a, b, c = linear.tolist()
    triple = (
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
    )
    scale = max(abs(x) for row in (a, b, c) for x in row)
    if abs(triple) > 1e-9 * scale**3:
        return triple < 0.0
    return bool(np.linalg.det(linear) < 0.0)


def place(arrays: MeshArrays, matrix=None) -> Placed:
    """The mesh placed by a matrix (4x4: mathutils, NumPy or nested lists), or in its own space when matrix is None:
    the triangles that span an area there (a mirroring matrix's with two corners swapped, so that they face out
    again), the vertices they use, and unit corner normals where faces are smooth (transformed by the inverse
    transpose; a zero normal becomes the triangle's own)."""
    vertices = arrays.vertices
    linear = None
    if matrix is not None:
        m = np.asarray(matrix, dtype=np.float64)
        linear = m[:3, :3]
        vertices = vertices @ linear.T + m[:3, 3]
    triangles = arrays.triangles
    corners = vertices[triangles]
    edges = corners[:, 1:] - corners[:, :1]  # b - a and c - a
    normal = _cross(edges[:, 0], edges[:, 1])
    spans_area = normal.any(axis=1)  # a normal with a component other than 0 (or NaN)
    if not np.isfinite(vertices).all():
        spans_area &= np.all(np.isfinite(corners), axis=(1, 2))
    everything = bool(spans_area.all())
    mirrored = linear is not None and _mirrors(linear)
    # a mirroring matrix turns counter-clockwise into clockwise: swap two corners so the normal points out again
    order = [0, 2, 1] if mirrored else [0, 1, 2]
    kept = triangles if everything else triangles[spans_area]
    if mirrored:
        kept = kept[:, order]
    if everything and arrays.all_used:  # the indices stay (what np.unique would give, without its sort)
        placed_vertices, remapped = vertices, kept
    else:
        indices, inverse = np.unique(kept, return_inverse=True)
        placed_vertices, remapped = vertices[indices], inverse.reshape(-1, 3)
    normals = None
    if arrays.corner_normals is not None:
        normals = arrays.corner_normals if everything else arrays.corner_normals[spans_area]
        if mirrored:
            normals = normals[:, order]
        if linear is not None:
            normals = normals @ np.linalg.inv(linear)  # normals transform by the inverse transpose
        lengths = np.linalg.norm(normals, axis=2, keepdims=True)
        kept_corners = vertices[kept]
        first = kept_corners[:, 0]
        flat = _cross(kept_corners[:, 1] - first, kept_corners[:, 2] - first)
        flat = np.broadcast_to((flat / np.linalg.norm(flat, axis=1, keepdims=True))[:, None, :], normals.shape)
        normals = np.where(lengths > 0, normals / np.where(lengths > 0, lengths, 1.0), flat)
    slots = arrays.slots if everything else arrays.slots[spans_area]
    dropped = 0 if everything else int(len(triangles) - np.count_nonzero(spans_area))
    uvs = None
    if arrays.uvs is not None:  # the corners as kept, in the order kept (a mirroring placement swaps two)
        uvs = arrays.uvs if everything else arrays.uvs[spans_area]
        if mirrored:
            uvs = uvs[:, order]
    done: dict[int, np.ndarray] = {id(arrays.uvs): uvs} if uvs is not None else {}

    def kept(corners: np.ndarray) -> np.ndarray:  # the same, each UV map and colour attribute (shared ones once)
        if id(corners) not in done:
            some = corners if everything else corners[spans_area]
            done[id(corners)] = some[:, order] if mirrored else some
        return done[id(corners)]

    uv_maps = {name: kept(corners) for name, corners in arrays.uv_maps.items()}
    colors = {name: kept(corners) for name, corners in arrays.colors.items()}
    rows = None if everything else spans_area
    return Placed(
        placed_vertices, remapped, normals, slots, dropped, uvs, uv_maps, colors,
        source=arrays, kept_rows=rows, corner_order=tuple(order),
    )  # fmt: skip


def in_world(arrays: MeshArrays, matrix) -> tuple[dict, np.ndarray, int]:
    """The mesh placed by a world matrix: scene-file fields (vertices, triangles, and normals where faces are smooth),
    the material slot of each kept triangle (T,), and how many triangles were dropped for spanning no area."""
    placed = place(arrays, matrix)
    return placed.fields(), placed.slots, placed.dropped


def fingerprint(obj) -> bytes | None:
    """A digest of an evaluated mesh object's geometry as the export reads it (positions, faces' corners, materials
    and smoothing), without its triangulation or normals; None where it has no mesh data to read."""
    mesh = getattr(obj, "data", None)
    if mesh is None or not hasattr(mesh, "loops") or getattr(mesh, "is_editmode", False):
        return None
    digest = hashlib.blake2b(digest_size=20)
    counts = np.array([len(mesh.vertices), len(mesh.loops), len(mesh.polygons)], dtype=np.int64)
    digest.update(counts.tobytes())
    for collection, name, dtype, size in (
        (mesh.vertices, "co", np.float32, 3 * counts[0]),
        (mesh.loops, "vertex_index", np.int32, counts[1]),
        (mesh.polygons, "loop_start", np.int32, counts[2]),
        (mesh.polygons, "material_index", np.int32, counts[2]),
        (mesh.polygons, "use_smooth", bool, counts[2]),
    ):
        values = np.empty(int(size), dtype=dtype)
        collection.foreach_get(name, values)
        digest.update(values.tobytes())
    return digest.digest()


# --- remembering geometry between exports ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Source:
    """Where an evaluated geometry comes from, as the cache identifies it across depsgraphs.

    key: ("mesh", pointer, name) for a mesh data-block that is all of its objects' geometry (no modifiers, shape keys,
    animation or edit mode: the same in every depsgraph and at every frame), else ("object", depsgraph mode, object
    pointer, object name, k) for the k-th distinct geometry the object's evaluation yields (its own mesh, or the
    Geometry Nodes instances it makes). watched: the original IDs whose geometry updates make it stale.
    frame_bound: whether it may change with the frame. object_name: the original object, for frame changes."""

    key: tuple
    watched: tuple[int, ...]
    frame_bound: bool
    object_pointer: int
    object_name: str
    cacheable: bool = True  # False in edit mode: read every time


@dataclass
class _Entry:
    arrays: MeshArrays | None
    stamp: int  # the update clock when the export that read it began
    watched: tuple[int, ...]
    frames: set[float] | None  # the frames where it is known to hold (None: every frame)
    fingerprint: bytes | None
    object_name: str
    object_pointer: int
    placed: OrderedDict = field(default_factory=OrderedDict)  # None (local) or a matrix's bytes -> Placed
    kept: bool = False  # in the cache (its bytes counted)

    @property
    def nbytes(self) -> int:
        return (self.arrays.nbytes if self.arrays is not None else 0) + sum(p.nbytes for p in self.placed.values())


SHADING = -1  # a pseudo-ID: any shader node group, image or texture changed (every material's conversion)
ATTRIBUTES = -2  # a pseudo-ID: some mesh's geometry changed (the conversions that average colour attributes)
SCENE = -3  # a pseudo-ID: a scene changed (the add-on's own materials are read against the panel's settings)


class GeometryCache:
    """MeshArrays between exports, forgotten when a depsgraph update says their geometry changed.

    Changes are counted on a clock: observing an update of an ID sets changed[ID] to the next tick; an export takes
    the clock when it begins (`stamp`) and an entry it stores is valid while none of its watched IDs changed after
    that. An update observed while an export runs (a render thread) therefore makes what that export read stale."""

    MEMORY_BUDGET = 512 * 2**20  # bytes of arrays kept; least recently used entries go first beyond it
    PLACED_PER_ENTRY = 3  # placed forms kept per geometry (its local one and the last world matrices)
    FRAMES_PER_ENTRY = 4096
    CHANGED_LIMIT = 200_000  # IDs whose last change is remembered; beyond it everything is forgotten

    def __init__(self) -> None:
        self.enabled = False  # only while the depsgraph handlers run: without them nothing would say what changed
        self.entries: OrderedDict[tuple, _Entry] = OrderedDict()
        self.clock = 0
        self.changed: dict[int, int] = {}
        self.frames_seen: dict[int, float] = {}  # viewport depsgraph -> the frame it last evaluated
        self.observed: tuple | None = None  # what view_update observed, for the handler of the same evaluation
        self.reads = 0  # calls of read() (for tests and measurements)
        self.nbytes = 0  # of the arrays the entries hold

    def clear(self) -> None:
        self.entries.clear()
        self.nbytes = 0
        self.changed.clear()
        self.frames_seen.clear()
        self.observed = None
        self.clock += 1

    def valid(self, watched: tuple[int, ...], stamp: int) -> bool:
        """Whether none of the watched IDs changed after the export that began at stamp."""
        changed = self.changed
        for pointer in watched:  # noqa: SIM110 (a generator per call costs more than the loop: 2 calls an object)
            if changed.get(pointer, -1) > stamp:
                return False
        return True

    def observe(self, depsgraph, from_view_update: bool = False) -> None:
        """A viewport depsgraph's updates of its last evaluation: the geometries, materials, node trees and images it
        changed. A frame change that left an object's geometry alone extends that geometry's entries to the new
        frame. A render depsgraph is new on every render and reports everything: it says nothing."""
        if depsgraph.mode != "VIEWPORT":
            return
        changed: set[int] = set()
        for update in depsgraph.updates:
            identity = update.id.original if update.id.original is not None else update.id
            pointer = identity.as_pointer()
            kind = type(identity).__name__
            if kind in ("Material", "Image", "Texture") or kind.endswith("NodeTree"):
                changed.add(pointer)
                if kind in ("Image", "Texture") or (
                    kind == "ShaderNodeTree" and not getattr(identity, "is_embedded_data", False)
                ):
                    changed.add(SHADING)  # a node group or image: any material may use it
            elif kind == "Scene":
                changed.add(SCENE)
            elif update.is_updated_geometry:
                changed.add(pointer)
                if kind == "Mesh":
                    changed.add(ATTRIBUTES)
        scene = depsgraph.scene_eval
        frame = float(scene.frame_current) + float(scene.frame_subframe)
        evaluation = (depsgraph.as_pointer(), frozenset(changed), frame)
        if from_view_update or evaluation != self.observed:  # view_update runs inside the evaluation, before handlers
            self.clock += 1
            for pointer in changed:
                self.changed[pointer] = self.clock
        self.observed = evaluation if from_view_update else None
        last = self.frames_seen.get(evaluation[0])
        self.frames_seen[evaluation[0]] = frame
        if last is not None and last != frame:
            self._extend(depsgraph, last, frame, changed)
        if len(self.changed) > self.CHANGED_LIMIT:
            self.clear()

    def _extend(self, depsgraph, last: float, frame: float, changed: set[int]) -> None:
        """The entries that held at the last frame hold at this one too, where the depsgraph evaluated their object at
        this frame without updating its geometry (it updates every object whose geometry depends on the time)."""
        import bpy

        for entry in list(self.entries.values()):  # a copy: a render thread's export may add entries meanwhile
            if entry.frames is None or last not in entry.frames or entry.object_pointer in changed:
                continue
            obj = bpy.data.objects.get(entry.object_name)
            if obj is None or obj.as_pointer() != entry.object_pointer:
                continue
            if not getattr(depsgraph.id_eval_get(obj), "is_evaluated", False):  # not in this depsgraph (hidden)
                continue
            if len(entry.frames) >= self.FRAMES_PER_ENTRY:
                entry.frames.clear()
                entry.frames.add(last)
            entry.frames.add(frame)

    def arrays(self, source: Source, obj, frame: float, stamp: int) -> _Entry:
        """The entry of an evaluated object's geometry: remembered where nothing changed it, else read now."""
        entry = self.entries.get(source.key) if self.enabled and source.cacheable else None
        if entry is not None and self.valid(entry.watched, entry.stamp):
            if entry.frames is None or frame in entry.frames:
                self.entries.move_to_end(source.key)
                return entry
            if entry.fingerprint is not None and fingerprint(obj) == entry.fingerprint:
                entry.frames.add(frame)
                self.entries.move_to_end(source.key)
                return entry
        self.reads += 1
        entry = _Entry(
            arrays=read(obj),
            stamp=stamp,
            watched=source.watched,
            frames={frame} if source.frame_bound else None,
            fingerprint=fingerprint(obj) if source.frame_bound and source.cacheable else None,
            object_name=source.object_name,
            object_pointer=source.object_pointer,
        )
        if self.enabled and source.cacheable:
            replaced = self.entries.pop(source.key, None)
            self.nbytes += entry.nbytes - (replaced.nbytes if replaced is not None else 0)
            self.entries[source.key] = entry
            entry.kept = True
        return entry

    def placed(self, entry: _Entry, matrix=None) -> Placed:
        """entry's mesh placed by a matrix (None: its own space), kept with the entry for the next export."""
        if matrix is not None:
            matrix = np.array(matrix, dtype=np.float64)
        key = None if matrix is None else matrix.tobytes()
        found = entry.placed.get(key)
        if found is None:
            found = entry.placed[key] = place(entry.arrays, matrix)
            added = found.nbytes
            while len(entry.placed) > self.PLACED_PER_ENTRY:
                added -= entry.placed.popitem(last=False)[1].nbytes
            if entry.kept:
                self.nbytes += added
        entry.placed.move_to_end(key)
        return found

    def trim(self) -> None:
        """Forget the least recently used entries beyond the memory budget."""
        while self.nbytes > self.MEMORY_BUDGET and self.entries:
            _, entry = self.entries.popitem(last=False)
            self.nbytes -= entry.nbytes


CACHE = GeometryCache()
