"""A large triangle mesh -> one kernel with a bounding-volume hierarchy over its triangles, traversed a level at a
time for all rays at once, and pictures of it for the rays that share a point or a direction (meshpicture.py).

A hierarchy walked node by node costs NumPy calls per node, so its time grows with the number of nodes a frame
visits, not with the rays: that is what made a 10,000-triangle mesh grow as n^0.58. Here every query keeps (ray,
node) pairs and moves them down one level per step: one slab test over all pairs of a level, the leaves' triangles
tested over all (pair, triangle) at once, the inner nodes' children as the next level's pairs. Before that walk each
ray follows one path, always into the child it enters first (a shadow ray: the one it enters later, away from the
surface it starts on), and tests that leaf: its hit (usually the nearest, or for a shadow ray any) prunes every node
beyond it, and the walk starts from the children that path passed by, so no box is tested twice. Many small objects
merged into one kernel get a leaf each (object_hierarchy). A query costs a few dozen NumPy calls per level, about
log2(n / leaf size) levels, and arithmetic in proportion to the pairs. Camera rays and shadow rays skip all of it
where the mesh has a picture from their shared point or direction: a few triangle tests per ray and no box.
The exact test per triangle is the mesh kernel's own (Moller-Trumbore as the seed writes it, or the watertight
test of the robust numerics), with the same operations, so the hits are the ones the whole-mesh kernel finds:
nearest t, then the lowest triangle index on ties.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from . import transforms as tf
from .kernels import Kernel, box_margin, grown_float32, kept_grown, ray_count, slab, take
from .meshpicture import TrianglePicture, View

# triangles per leaf: 4 rather than 8 costs one more level of box tests and halves the triangle tests of each leaf
# a ray reaches, which is faster from 1,000 to 100,000 triangles. Beyond SMALL_LEAVES_UP_TO triangles 8: a
# million-triangle mesh's first frame is mostly its preparation, which the deeper tree makes slower and larger
# (both measured in docs/measurements.md#the-tracers-constants). The same hits either way (only which leaves hold
# them differs)
LEAF_TRIANGLES = 8
SMALL_LEAF_TRIANGLES = 4
SMALL_LEAVES_UP_TO = 1 << 17
# merged objects of at most this many triangles each get a leaf per object (leaves_per_object, object_hierarchy), and
# so do the connected parts of a mesh of at least SMALL_PARTS_FROM of them (small_parts: its labels settle within
# PART_ROUNDS)
OBJECT_LEAF_TRIANGLES = 16
SMALL_PARTS_FROM = 64
PART_ROUNDS = 4
MESH_HIERARCHY_TRIANGLES = 32  # a mesh of more triangles gets its own hierarchy; below, one test over all of them
BIG = np.iinfo(np.int64).max
# views per mesh kernel whose pictures are kept whatever their size (the camera's and the lights'), and more while
# all of them take at most PICTURE_BYTES: a light of a size at Shadows 16 is 16 views, one per sample point, and
# keeping 8 rebuilt every picture for every band (a glass ball and a Suzanne under an area light: 799 pictures made
# in one 160x90 render, 3.6 of its 12 s)
PICTURES_KEPT = 8
PICTURE_BYTES = 64 << 20
VIEWS_COUNTED = 1024  # views whose asking rays are counted; beyond, the count starts again (a moving view's names)
PICTURE_PAYOFF = 0.5  # rays per triangle that a view's queries bring before its picture is made
# (ray, leaf) pairs times the triangles per leaf, per pass of a walk's leaf tests: a pass's temporaries (256 KB
# each in float64) stay in a core's cache, where 8 times more cost 64 rather than 43 ns a triangle test (3,000
# cubes' leaves of 12 triangles)
LEAF_SLOTS = 1 << 15
PAIRS = 1 << 17  # (ray, triangle) pairs per pass of a picture search: its temporaries stay a few MB
# rays per walk of a hierarchy: a walk gathers its rays' numbers at random from arrays of all of them, which for a
# band's 17 shadow rays a point (a million and more) no longer fit the caches (a forest's 640x480 frame 9.9 -> 3.7 s)
RAY_PIECE = 1 << 16


class MeshHierarchy:
    """Nodes (M) in arrays: boxes (3, M) padded in the tracing dtype, children (M,) (-1 at a leaf), and for each
    leaf its row of leaf_triangles (L, K) (indices into the mesh; real marks the filled slots), K = leaf_size."""

    def __init__(
        self,
        triangles: np.ndarray | None,
        dtype: np.dtype,
        boxes: tuple[np.ndarray, np.ndarray] | None = None,
        leaf_size: int | None = None,
    ) -> None:
        """triangles (T, 3 vertices, 3) float64; or None and boxes (lower, upper) (T, 3) float64 each: a hierarchy
        over boxes (the instances of a mesh), split by their centres.

        Median splits on the centroids' longest axis, built a level at a time: every node of a level is a range of
        three orders of the triangles, one by each axis (each sorted once, ties by index). A node's extent along an
        axis is its range's last centroid less its first in that axis's order, its median split the middle of that
        range, and one stable partition of the three orders by side keeps every child's range sorted in all three:
        a level costs a few passes over the triangles and no sort (a stable sort per level cost 4 s of a
        million-triangle mesh's 8 s in each worker). Boxes are made bottom-up once the leaves are known. Nodes are
        numbered level by level; the splits depend on the mesh only."""
        if boxes is None:
            count = len(triangles)
            first, second, third = triangles[:, 0], triangles[:, 1], triangles[:, 2]
            # the centroids a column at a time: contiguous for take() (which copies a strided array first), and no
            # (T, 3) temporaries at the peak of a million-triangle preparation
            columns = [(first[:, axis] + second[:, axis] + third[:, axis]) / 3.0 for axis in range(3)]
        else:
            count = len(boxes[0])
            columns = [np.ascontiguousarray(boxes[0][:, axis] + boxes[1][:, axis]) / 2.0 for axis in range(3)]
        if leaf_size is None:
            leaf_size = SMALL_LEAF_TRIANGLES if count <= SMALL_LEAVES_UP_TO else LEAF_TRIANGLES
        self.leaf_size = leaf_size
        # int32 positions and indices: the partitions below are a few passes over them per level
        index = np.int32 if count < 2**31 else np.int64
        orders = [np.argsort(column, kind="stable").astype(index) for column in columns]
        starts, stops = np.array([0]), np.array([count])
        first_node = 0
        lefts, leaf_rows, leaf_starts, leaf_stops, leaf_nodes, levels = [], [], [], [], [], []
        leaves = 0
        right_side = np.zeros(count, dtype=bool)
        while starts.size:
            sizes = stops - starts
            is_leaf = sizes <= leaf_size
            inner = (~is_leaf).nonzero()[0]
            leaf = is_leaf.nonzero()[0]
            rows = np.full(starts.size, -1, dtype=np.int64)
            rows[leaf] = leaves + np.arange(leaf.size)
            leaves += leaf.size
            leaf_rows.append(rows)
            leaf_starts.append(starts[leaf])
            leaf_stops.append(stops[leaf])
            leaf_nodes.append(first_node + leaf)
            # children of the inner nodes: the next level's nodes, left then right for each parent in turn
            left = np.full(starts.size, -1, dtype=np.int64)
            left[inner] = first_node + starts.size + 2 * np.arange(inner.size)
            lefts.append(left)
            levels.append((first_node + inner, left[inner]))
            first_node += starts.size
            if not inner.size:
                break
            inner_starts, inner_stops = starts[inner], stops[inner]
            extent = np.stack(
                [
                    columns[along].take(orders[along].take(inner_stops - 1))
                    - columns[along].take(orders[along].take(inner_starts))
                    for along in range(3)
                ],
                axis=1,
            )
            axis = np.argmax(extent, axis=1)  # (n,): the first of equal extents
            lengths = inner_stops - inner_starts
            middle = inner_starts + lengths // 2
            # the triangles of each node's upper half along its axis go right
            right_side[:] = False
            halves = _ranges(middle, inner_stops)
            for along in range(3):
                chosen = np.repeat(axis == along, inner_stops - middle)
                right_side[orders[along].take(halves[chosen])] = True
            for along in range(3):  # the other axes' orders of each node, partitioned stably by side
                moved = (axis != along).nonzero()[0]
                moved_starts, moved_lengths = inner_starts.take(moved), lengths.take(moved)
                positions = _ranges(moved_starts, moved_starts + moved_lengths).astype(index)
                range_first = np.repeat((np.cumsum(moved_lengths) - moved_lengths).astype(index), moved_lengths)
                members = orders[along].take(positions)
                goes_right = right_side.take(members)
                right_before = np.cumsum(goes_right, dtype=index)
                right_before -= goes_right  # right members before each, over all ranges
                right_before -= right_before.take(range_first)  # within its own range
                # a left member moves back by the right members before it in its range; a right one to the
                # middle, after the right members before it
                target = positions - right_before
                right = goes_right.nonzero()[0]
                target[right] = np.repeat(middle.take(moved).astype(index), moved_lengths).take(
                    right
                ) + right_before.take(right)
                orders[along][target] = members
            starts = np.stack((inner_starts, middle), axis=1).ravel()
            stops = np.stack((middle, inner_stops), axis=1).ravel()
        order = orders[0]
        self.left = np.concatenate(lefts)
        self.leaf_row = np.concatenate(leaf_rows)
        # boxes: each leaf's over its triangles, then each inner node's over its children's, deepest level first
        del columns
        lower, upper = np.empty((self.left.size, 3)), np.empty((self.left.size, 3))
        starts, stops, nodes = np.concatenate(leaf_starts), np.concatenate(leaf_stops), np.concatenate(leaf_nodes)
        for axis in range(3):  # the triangles' (or boxes') bounds in the order, a column at a time
            if boxes is None:
                corners = (first[:, axis], second[:, axis], third[:, axis])
                low = np.minimum(np.minimum(*corners[:2]), corners[2]).take(order)
            else:
                low = boxes[0][:, axis].take(order)
            lower[nodes, axis] = _segments(np.minimum, low, starts, stops)
            del low
            if boxes is None:
                high = np.maximum(np.maximum(*corners[:2]), corners[2]).take(order)
            else:
                high = boxes[1][:, axis].take(order)
            upper[nodes, axis] = _segments(np.maximum, high, starts, stops)
        for parents, children in reversed(levels):
            lower[parents] = np.minimum(lower.take(children, axis=0), lower.take(children + 1, axis=0))
            upper[parents] = np.maximum(upper.take(children, axis=0), upper.take(children + 1, axis=0))
        # padded_box() for every node at once: the same margin, from the same numbers
        size = np.maximum(np.abs(lower).max(axis=1), np.abs(upper).max(axis=1)) + (upper - lower).max(axis=1)
        pad = box_margin(size, dtype)[:, None]
        self.lower = (lower - pad).astype(dtype).T.copy()  # (3, M)
        self.upper = (upper + pad).astype(dtype).T.copy()
        starts, stops = np.concatenate(leaf_starts), np.concatenate(leaf_stops)
        slots = starts[:, None] + np.arange(leaf_size)[None, :]  # (L, K)
        self.real = slots < stops[:, None]
        # repeats pad a short leaf, as np.resize did: slot k holds member k mod the leaf's size
        wrapped = starts[:, None] + np.arange(leaf_size)[None, :] % (stops - starts)[:, None]
        self.leaf_triangles = order[wrapped]


def object_hierarchy(
    triangles: np.ndarray, starts: np.ndarray, sizes: np.ndarray, dtype: np.dtype, order: np.ndarray | None = None
) -> MeshHierarchy:
    """A hierarchy over objects' triangles (T, 3 vertices, 3), each object's a range [starts, starts + sizes) (k,)
    of them (of order (T,), the triangles object by object, where given), with a leaf per object: its boxes are the
    objects' (median splits of their centres), a leaf's row its object's triangles (repeats pad it to the largest
    object's count). A small closed object is one leaf test for a ray that reaches it, where median splits of its
    triangles make a few levels of boxes that all cover it."""
    corners = (triangles if order is None else triangles.take(order, axis=0)).reshape(-1, 3)
    lower = np.minimum.reduceat(corners, starts * 3, axis=0)
    upper = np.maximum.reduceat(corners, starts * 3, axis=0)
    hierarchy = MeshHierarchy(None, dtype, boxes=(lower, upper), leaf_size=1)
    objects = hierarchy.leaf_triangles[:, 0]  # (L,): each leaf's object
    width = int(sizes.max())
    counts = sizes.take(objects)[:, None]
    positions = starts.take(objects)[:, None] + np.arange(width)[None, :] % counts
    hierarchy.leaf_triangles = positions if order is None else order.take(positions)
    hierarchy.real = np.arange(width)[None, :] < counts
    hierarchy.leaf_size = width
    return hierarchy


def leaves_per_object(sizes: np.ndarray) -> bool:
    """Whether objects of these triangle counts (k,) are traced faster with a leaf each (object_hierarchy): at most
    OBJECT_LEAF_TRIANGLES triangles each, more than a leaf of the median splits holds on average (smaller ones it keeps
    whole already), and alike enough that padding every leaf to the largest at most doubles the triangle tests (and
    the packed leaves' memory)."""
    largest = int(sizes.max())
    return (
        largest <= OBJECT_LEAF_TRIANGLES
        and sizes.mean() > SMALL_LEAF_TRIANGLES
        and largest * sizes.size <= 2 * sizes.sum()
    )


def small_parts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """A mesh's faces (T, 3) vertex indices -> its connected parts (triangles sharing vertices) as (order (T,): the
    triangles part by part, starts (k,), sizes (k,)) where it has at least SMALL_PARTS_FROM parts that are traced
    faster with a leaf each (leaves_per_object: 3,000 cubes joined into one mesh); None otherwise, where PART_ROUNDS
    rounds of passing each vertex the lowest label of its triangles do not settle (a large connected mesh), and for
    meshes of more than SMALL_LEAVES_UP_TO triangles (a million triangles' rounds would cost a quarter of a
    second)."""
    count = len(faces)
    if not SMALL_PARTS_FROM <= count <= SMALL_LEAVES_UP_TO:
        return None
    labels = np.arange(int(faces.max()) + 1)
    for _ in range(PART_ROUNDS):
        lowest = labels.take(faces).min(axis=1)  # (T,): each triangle's lowest label
        settled = labels.copy()
        for corner in range(3):
            np.minimum.at(settled, faces[:, corner], lowest)
        settled = settled.take(settled)  # a label is a vertex of the same part: its label is as low or lower
        if np.array_equal(settled, labels):
            break
        labels = settled
    else:
        return None
    part = labels.take(faces[:, 0])
    names, part, sizes = np.unique(part, return_inverse=True, return_counts=True)
    if names.size < SMALL_PARTS_FROM or not leaves_per_object(sizes):
        return None
    order = np.argsort(part, kind="stable")
    return order, np.cumsum(sizes) - sizes, sizes


def _ranges(starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """Every integer of the ranges [starts, stops) (n,), range after range."""
    lengths = stops - starts
    return np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths - starts, lengths)


def _segments(ufunc: np.ufunc, values: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """ufunc's reduction (n, ...) of values (P, ...) over each non-empty range [starts, stops)."""
    padded = np.concatenate((values, values[-1:]))  # a stop may be P: one row more keeps reduceat in range
    return ufunc.reduceat(padded, np.stack((starts, stops), axis=1).ravel(), axis=0)[0::2]


def _view_groups(listed: list[View | None], which: np.ndarray) -> list[tuple[View | None, np.ndarray | None]]:
    """Rays (n,) by the view each shares, which (n,) indexing listed (k,) -> (view, the rays' positions) per view
    the rays name; the rays of every None view (a world light's directions) one group, and None for the positions
    where that group is all of them. A count per view, not np.unique: its sort of millions of shadow rays' indices
    was 3% of 3,000 cubes' frame under a world light."""
    present = np.bincount(which, minlength=len(listed)).nonzero()[0].tolist()
    named = [k for k in present if listed[k] is not None]
    if not named:
        return [(None, None)]
    groups: list[tuple[View | None, np.ndarray | None]] = [(listed[k], (which == k).nonzero()[0]) for k in named]
    if len(named) < len(present):
        is_named = np.zeros(len(listed), dtype=bool)
        is_named[named] = True
        groups.append((None, (~is_named.take(which)).nonzero()[0]))
    return groups


def _columns(rays: np.ndarray, positions: np.ndarray | None) -> np.ndarray:
    """The columns positions (k,, ascending; None: all) of rays (3, N) (a shared (3, 1) column as it is): a view of
    them where they are one run (a query's rays of one view usually are: one light after another), else a gather."""
    if positions is None or rays.shape[1] == 1:
        return rays
    if positions.size and int(positions[-1]) - int(positions[0]) + 1 == positions.size:
        return rays[:, int(positions[0]) : int(positions[-1]) + 1]
    return take(rays, positions)


def _picture_bytes(picture: TrianglePicture | None) -> int:
    return 0 if picture is None else picture.starts.nbytes + picture.entries.nbytes


class BoxRays(NamedTuple):
    """A walk's rays and boxes as its slab tests take them (MeshKernel._box_rays)."""

    origins: np.ndarray  # (3, n)
    inverses: np.ndarray  # (3, n): 1 / direction
    lower: np.ndarray  # (3, M): the nodes' boxes
    upper: np.ndarray


class MeshKernel(Kernel):
    """A mesh's triangles behind their own hierarchy: hit() finds each ray's nearest triangle (part = its index in
    the mesh), as the whole-mesh kernel `inner` would; any_hit() only whether there is one."""

    def __init__(self, inner: Kernel, mesh: tf.WorldTriangles, hierarchy: MeshHierarchy | None = None) -> None:
        """hierarchy: one over these triangles already made (by MergedMeshKernel); None: the median splits'."""
        self.inner = inner  # TrianglesKernel or WatertightTrianglesKernel: the test, the normals, the frame
        self.dtype = inner.dtype
        self.frame = inner.frame
        # a mesh placed in world space (merged objects): its oriented box is its world box, whose test the scene's
        # walk has made on the rays it hands over and the hierarchy's first level repeats on any other
        rotation, origin = self.frame[:2]
        self.world_placed = bool(np.array_equal(rotation, np.eye(3)) and not origin.any())
        self.lower, self.upper = inner.lower, inner.upper
        self.count = len(mesh.triangles)
        if hierarchy is None:
            triangles = np.asarray(mesh.triangles, dtype=np.float64)
            parts = None if mesh.source is None else small_parts(np.asarray(mesh.source[1], dtype=np.int64))
            if parts is None:
                hierarchy = MeshHierarchy(triangles, inner.dtype)
            else:  # many small parts (objects joined into one mesh): a leaf per part
                order, starts, sizes = parts
                hierarchy = object_hierarchy(triangles, starts, sizes, inner.dtype, order)
        self.hierarchy = hierarchy
        self.packed = inner.pack(self.hierarchy.leaf_triangles)  # (9, L, K): each leaf's triangles, gathered once
        self.flat_packed = self.packed.reshape(9, -1, 1)  # (9, L K, 1): by slot, as packed_t takes them
        self.cost = 3.0 + 4.0 * np.log2(max(2, len(mesh.triangles)))
        # a picture's entries are slots of the packed leaves (each triangle's one real slot), so that its search
        # gathers the same packed numbers as the walk and keeps no copy of its own
        self.slot_triangle = self.hierarchy.leaf_triangles.ravel()  # (L K,): the triangle in each slot
        filled = self.hierarchy.real.ravel().nonzero()[0]
        self.slots = np.empty(self.count, dtype=np.int64)
        self.slots[self.slot_triangle.take(filled)] = filled
        self.grown: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # _box_rays' float32 boxes by the origins' reach
        self.pictures: OrderedDict[View, TrianglePicture | None] = OrderedDict()
        self.asked: dict[View, int] = {}  # rays that asked for a view's picture before it was made
        self.picture_bytes = 0  # what the kept pictures take

    def bounds(self):
        return self.lower, self.upper

    def hit(
        self,
        O,
        D,
        t_min,
        t_max,
        any_hit: bool = False,
        views: tuple[list[View], np.ndarray] | None = None,
        columns: np.ndarray | None = None,
    ):
        """Kernel.hit (rays outside the mesh's oriented box skip the search); any_hit: stop at a ray's first hit,
        whose t is then any hit's, not the nearest.

        Rays that share a point or a direction are searched in the mesh's picture from there (meshpicture.py): a
        shared (3, 1) origin is a point, a shared direction a direction, and views (the views (k,) and each ray's
        index (N,) among them) name them for rays that do not show it (shadow rays). The others walk the
        hierarchy. Either way the same hits.

        columns: the rays are these columns (n,, ascending) of O and D (the caller's subset; t_max and views name
        each of them): gathered here once for each view's rays, and not at all where those are one run of columns."""
        if columns is not None and not self.world_placed:  # the oriented box test takes the rays themselves
            O, D, columns = _columns(O, columns), _columns(D, columns), None
        count = ray_count(O, D) if columns is None else columns.size
        rays = np.arange(count) if self.world_placed else self.in_box(O, D, t_min, t_max)
        t = np.full(count, np.inf, dtype=self.dtype)
        part = np.zeros(count, dtype=np.int64)
        if not rays.size:
            return t, part
        limit = t_max.take(rays) if isinstance(t_max, np.ndarray) else t_max
        # every ray in the box (most, where the scene's walk chose them): no gather of the arrays again
        if columns is None and rays.size < count:
            O, D = take(O, rays), take(D, rays)
        if views is not None:
            groups = _view_groups(views[0], views[1].take(rays))
        elif O.shape[1] == 1:  # camera rays
            groups = [(View("point", tuple(O[:, 0].astype(np.float64).tolist())), None)]
        elif D.shape[1] == 1:  # an orthographic camera's rays
            groups = [(View("direction", tuple(D[:, 0].astype(np.float64).tolist())), None)]
        else:
            groups = [(None, None)]
        for view, members in groups:
            if members is None:
                positions, limit_g, chosen = columns, limit, rays
            else:
                positions = members if columns is None else columns.take(members)
                chosen = rays.take(members)
                limit_g = limit.take(members) if isinstance(limit, np.ndarray) else limit
            O_g, D_g = _columns(O, positions), _columns(D, positions)
            found_t, found_part = self._find(O_g, D_g, t_min, limit_g, any_hit, view)
            t[chosen] = found_t
            part[chosen] = found_part
        return t, part

    def picture(self, view: View, rays: int) -> TrianglePicture | None:
        """The mesh seen in view, or None: made (for about as many rays as this query brings) once the rays that
        asked for it add up to PICTURE_PAYOFF times the triangles over the view's share, and kept (PICTURES_KEPT
        views, and more within PICTURE_BYTES: the camera and the lights' sample points). Making one costs about a
        microsecond per triangle and saves about two per ray, so a million-triangle mesh walks its first frame's
        rays and an animation's later frames use the pictures."""
        if view in self.pictures:
            self.pictures.move_to_end(view)
            return self.pictures[view]
        if len(self.asked) > VIEWS_COUNTED:  # a moving view (the viewport's camera) asks under ever new names
            self.asked.clear()
        self.asked[view] = self.asked.get(view, 0) + rays
        if self.asked[view] * view.share < PICTURE_PAYOFF * self.count:
            return None
        # the corners as the test sees them: its v0, v0 + e1, v0 + e2 (3 corners, 3 axes, T), made for the picture
        v0, e1, e2 = (
            np.asarray(array[:, :, 0], dtype=np.float64) for array in (self.inner.v0, self.inner.e1, self.inner.e2)
        )
        corners = np.stack((v0, v0 + e1, v0 + e2))
        made = self.pictures[view] = TrianglePicture.build(
            corners, self.lower, self.upper, self.slots, view, self.dtype, rays
        )
        del corners
        self.picture_bytes += _picture_bytes(made)
        while len(self.pictures) > PICTURES_KEPT and self.picture_bytes > PICTURE_BYTES:
            dropped, picture = self.pictures.popitem(last=False)
            self.picture_bytes -= _picture_bytes(picture)
            # earned again before it is made again: views taken in turn beyond the budget are not all rebuilt each query
            self.asked.pop(dropped, None)
        return made

    def _find(self, O, D, t_min, t_max, any_hit, view: View | None):
        """Rays (3, n) (either may be a shared column) -> (t, part) (n,), through the view's picture where it has
        one and resolves these rays, else the walk."""
        count = ray_count(O, D)
        picture = None if view is None else self.picture(view, count)
        found = None
        if picture is not None:
            found = picture.cells(D if view.perspective else np.broadcast_to(O, (3, count)))
        if found is None:
            return self._search(np.broadcast_to(O, (3, count)), np.broadcast_to(D, (3, count)), t_min, t_max, any_hit)
        return self._search_cells(O, np.broadcast_to(D, (3, count)), t_min, t_max, any_hit, picture, *found)

    def _search_cells(self, O, D, t_min, t_max, any_hit, picture: TrianglePicture, rays, cells):
        """Rays (n,) of O, D (3, N) in picture cells (n,) -> (t, part) (N,): each ray's nearest hit among its
        cell's triangles (the lowest triangle index on ties), in chunks of about PAIRS (ray, triangle) pairs."""
        count = D.shape[1]
        best_t = np.full(count, np.inf, dtype=self.dtype)
        best_part = np.zeros(count, dtype=np.int64)
        first = picture.starts.take(cells)
        counts = picture.starts.take(cells + 1) - first
        ends = np.cumsum(counts)
        start = 0
        while start < rays.size:
            stop = max(start + 1, int(np.searchsorted(ends, ends[start] - counts[start] + PAIRS, side="right")))
            sizes = counts[start:stop]
            segments = np.cumsum(sizes) - sizes
            pairs = int(sizes.sum())
            local = np.repeat(np.arange(sizes.size), sizes)
            entry = np.arange(pairs) - np.repeat(segments - first[start:stop], sizes)
            # the pairs' gathers in wrap mode: in range by construction, so no bounds check (a third faster here)
            slot = picture.entries.take(entry, mode="wrap")
            members = rays[start:stop].take(local, mode="wrap")
            O_p = O if O.shape[1] == 1 else O.take(members, axis=1, mode="wrap")
            t = self.inner.packed_t(
                O_p, D.take(members, axis=1, mode="wrap"), self.flat_packed.take(slot, axis=1, mode="wrap"), t_min
            )[:, 0]
            if isinstance(t_max, np.ndarray):
                t[t >= t_max.take(members)] = np.inf
            elif t_max != np.inf:
                t[t >= t_max] = np.inf
            nearest = np.minimum.reduceat(t, segments)
            hit = (nearest < np.inf).nonzero()[0]
            chosen = rays[start:stop].take(hit)
            best_t[chosen] = nearest.take(hit)
            if not any_hit:
                candidates = np.where(t == nearest.take(local), self.slot_triangle.take(slot, mode="wrap"), BIG)
                best_part[chosen] = np.minimum.reduceat(candidates, segments).take(hit)
            start = stop
        return best_t, best_part

    def _hit(self, O, D, t_min, t_max):
        count = ray_count(O, D)
        return self._search(np.broadcast_to(O, (3, count)), np.broadcast_to(D, (3, count)), t_min, t_max, False)

    def _search(self, O, D, t_min, t_max, any_hit):
        """Rays (3, N) -> (t, part) (N,) through the hierarchy: first one path per ray, always into the child it
        enters first, whose leaf usually holds its nearest hit (any_hit: the child it enters later, whose leaf more
        often holds a hit at all than the one around the ray's start); each child
        the path passed by (its box met too) is kept with its entry t, and afterwards these are walked a level at
        a time, each node's children tested as it is reached, leaving out every node that begins beyond the ray's
        best hit so far. Every node is box-tested once, by its parent. Rays go in pieces of RAY_PIECE (each ray's hit
        is its own)."""
        count = O.shape[1]
        if count > RAY_PIECE:
            found = [
                self._search(O[:, piece], D[:, piece], t_min, t_max[piece] if np.ndim(t_max) else t_max, any_hit)
                for piece in (slice(start, start + RAY_PIECE) for start in range(0, count, RAY_PIECE))
            ]
            return np.concatenate([t for t, _ in found]), np.concatenate([part for _, part in found])
        boxes = self._box_rays(O, D)
        best_t = np.broadcast_to(np.asarray(t_max, dtype=self.dtype), (count,)).copy()
        best_part = np.full(count, BIG, dtype=np.int64)
        # a shadow ray toward the world: no limit, and a ray leaves the walk at its first hit, so every ray still
        # walking has none yet and no box begins beyond it (its tests left out: 5% of a level's passes)
        unlimited = any_hit and np.ndim(t_max) == 0 and t_max == np.inf
        passed_rays, passed_nodes, passed_near = [], [], []
        rays = np.arange(count)
        nodes = np.zeros(count, dtype=np.int64)
        while rays.size:
            rays, left, (near_left, near_right, meets_left, meets_right) = self._step(
                O, D, boxes, t_min, rays, nodes, best_t, best_part, any_hit, unlimited
            )
            if not rays.size:
                break
            # the child entered first; for a shadow ray that starts inside it the one entered later: the ray starts
            # on a surface, and the child around its start usually holds that surface, which cannot block it (3,000
            # separate cubes under a world light: a third more shadow rays blocked by their first path, a third fewer
            # pairs walked after; a ray from the ground between them, outside both children, 4% fewer pairs)
            if any_hit:
                starts_in = np.minimum(near_left, near_right) <= t_min
                later = np.where(starts_in, near_right > near_left, near_right < near_left)
            else:
                later = near_right < near_left
            go_right = meets_right & (~meets_left | later)
            both = (meets_left & meets_right).nonzero()[0]
            if both.size:  # the right child is the left one's next node
                passed_rays.append(rays.take(both))
                passed_nodes.append(left.take(both) + ~go_right.take(both))
                passed_near.append(np.where(go_right, near_left, near_right).take(both))
            going = (meets_left | meets_right).nonzero()[0]
            rays, nodes = rays.take(going), left.take(going) + go_right.take(going)
        if not passed_rays:
            return self._found(best_t, best_part)
        rays, nodes, near = np.concatenate(passed_rays), np.concatenate(passed_nodes), np.concatenate(passed_near)
        while rays.size:
            if unlimited:  # only the rays that found nothing yet go on
                keep = best_part.take(rays) == BIG
            else:
                keep = near <= best_t.take(rays)
                if any_hit:
                    keep &= best_part.take(rays) == BIG
            keep = keep.nonzero()[0]
            rays, left, (near_left, near_right, meets_left, meets_right) = self._step(
                O, D, boxes, t_min, rays.take(keep), nodes.take(keep), best_t, best_part, any_hit, unlimited
            )
            if not rays.size:
                break
            on_left, on_right = meets_left.nonzero()[0], meets_right.nonzero()[0]
            rays = np.concatenate((rays.take(on_left), rays.take(on_right)))
            nodes = np.concatenate((left.take(on_left), left.take(on_right) + 1))
            near = np.concatenate((near_left.take(on_left), near_right.take(on_right)))
        return self._found(best_t, best_part)

    def _box_rays(self, O: np.ndarray, D: np.ndarray) -> BoxRays:
        """The rays (3, n) and the nodes' boxes as the walk's slab tests take them: in float32 where the tracing is
        float64 (half the bytes each test gathers and computes: 12% off 3,000 cubes' frame), the boxes grown so that
        every box the float64 test meets is met (kernels.grown_float32); the tracing dtype's own otherwise."""
        tree = self.hierarchy
        if self.dtype != np.float64 or not O.size:
            return BoxRays(O, 1.0 / D, tree.lower, tree.upper)
        reach = max(float(np.abs(tree.lower[:, 0]).max()), float(np.abs(tree.upper[:, 0]).max()))
        lower, upper = kept_grown(self.grown, O, reach, lambda bound: grown_float32(tree.lower, tree.upper, bound))
        return BoxRays(O.astype(np.float32), (1.0 / D).astype(np.float32), lower, upper)

    def _step(self, O, D, boxes, t_min, rays, nodes, best_t, best_part, any_hit=False, unlimited=False):
        """One level of a walk: the leaves among nodes (P,) tested with their rays (P,), and the inner nodes' rays
        and left children with their children's tests (_children; empty arrays where no inner node is left).
        unlimited: no ray has a hit or a limit yet, so its children are not tested against its best t. The reason for
        10 parameters: the walk's state, passed down rather than kept on the kernel, which every query shares."""
        left = self.hierarchy.left.take(nodes)
        is_leaf = left < 0
        leaf = is_leaf.nonzero()[0]
        if leaf.size:
            self._test_leaves(O, D, t_min, rays.take(leaf), nodes.take(leaf), best_t, best_part, any_hit)
            inner = (~is_leaf).nonzero()[0]
            rays, left = rays.take(inner), left.take(inner)
        if not rays.size:
            return rays, left, (None,) * 4
        return rays, left, self._children(boxes, rays, left, t_min, None if unlimited else best_t)

    def _children(self, boxes: BoxRays, rays, left, t_min, best_t):
        """The entry t (P,) of inner nodes' children, left (P,) and right (left + 1), for rays (P,), and whether
        each child's box meets its ray within (t_min, the ray's best t] (best_t None: within (t_min, inf))."""
        O_n = boxes.origins.take(rays, axis=1, mode="wrap")  # in range: no bounds check
        inverse_n = boxes.inverses.take(rays, axis=1, mode="wrap")
        right = left + 1
        lower, upper = boxes.lower, boxes.upper
        near_left, far_left = slab(O_n, inverse_n, lower.take(left, 1, mode="wrap"), upper.take(left, 1, mode="wrap"))
        near_right, far_right = slab(
            O_n, inverse_n, lower.take(right, 1, mode="wrap"), upper.take(right, 1, mode="wrap")
        )
        meets_left = (near_left <= far_left) & (far_left > t_min)
        meets_right = (near_right <= far_right) & (far_right > t_min)
        if best_t is not None:
            best = best_t.take(rays)
            meets_left &= near_left <= best
            meets_right &= near_right <= best
        return near_left, near_right, meets_left, meets_right

    def _found(self, best_t, best_part):
        found = best_part != BIG
        return np.where(found, best_t, np.inf).astype(self.dtype, copy=False), np.where(found, best_part, 0)

    def _test_leaves(self, O, D, t_min, rays, nodes, best_t, best_part, any_hit: bool = False) -> None:
        """The triangles of leaves (P,) met by rays (P,): the nearest hit nearer than each ray's best so far replaces
        it, the lowest triangle index on equal t. In pieces of LEAF_SLOTS (pair, triangle) slots: the test's
        temporaries of a whole band's rays were the largest part of a million-triangle frame's memory; a ray whose
        pairs fall in two pieces keeps the same nearest hit and lowest index, which do not depend on the order."""
        pairs = LEAF_SLOTS // self.hierarchy.leaf_size
        test = self._block_leaf_piece if any_hit else self._test_leaf_piece
        for start in range(0, rays.size, pairs):
            piece = slice(start, start + pairs)
            test(O, D, t_min, rays[piece], nodes[piece], best_t, best_part)

    def _block_leaf_piece(self, O, D, t_min, rays, nodes, best_t, best_part) -> None:
        """_test_leaf_piece for an any-hit walk: only whether a ray meets a triangle of its leaf before its limit
        (best_t); a blocked ray's t is then one such hit's and its part 0. A slot past a leaf's triangles repeats
        one of them, so every slot's hit is a hit of the leaf: no mask, no triangle indices."""
        row = self.hierarchy.leaf_row.take(nodes)
        O_r, D_r = O.take(rays, axis=1, mode="wrap"), D.take(rays, axis=1, mode="wrap")  # in range: no bounds check
        t = self.inner.packed_t(O_r, D_r, self.packed.take(row, axis=1, mode="wrap"), t_min).min(axis=1)
        blocked = (t < best_t.take(rays)).nonzero()[0]
        chosen = rays.take(blocked)
        best_t[chosen] = t.take(blocked)
        best_part[chosen] = 0

    def _test_leaf_piece(self, O, D, t_min, rays, nodes, best_t, best_part) -> None:
        row = self.hierarchy.leaf_row.take(nodes)
        triangles, real = self.hierarchy.leaf_triangles.take(row, axis=0), self.hierarchy.real.take(row, axis=0)
        O_r, D_r = O.take(rays, axis=1, mode="wrap"), D.take(rays, axis=1, mode="wrap")  # in range: no bounds check
        t = self.inner.packed_t(O_r, D_r, self.packed.take(row, axis=1, mode="wrap"), t_min)
        O_r = D_r = None  # memory: the pieces' largest arrays are below
        best, found = best_t.take(rays)[:, None], (best_part.take(rays) != BIG)[:, None]
        # nearer than the best so far, or as near (a tie: the lower index wins below); best_t starts at t_max
        t = np.where(real & ((t < best) | ((t == best) & found)), t, np.inf)
        nearest = t.min(axis=1)
        lowest = np.where(t == nearest[:, None], triangles, BIG).min(axis=1)
        hit = (nearest < np.inf).nonzero()[0]
        rays, nearest, lowest = rays.take(hit), nearest.take(hit), lowest.take(hit)
        before = best_t.take(rays)
        np.minimum.at(best_t, rays, nearest)
        improved = best_t.take(rays) < before
        best_part[rays.take(improved.nonzero()[0])] = BIG  # a nearer t: an earlier tie no longer counts
        tied = (nearest == best_t.take(rays)).nonzero()[0]
        np.minimum.at(best_part, rays.take(tied), lowest.take(tied))

    def normal(self, P, part):
        return self.inner.normal(P, part)

    def unit_normal(self, P, part):
        return self.inner.unit_normal(P, part)


class MergedMeshKernel(MeshKernel):
    """Many objects' triangles behind one hierarchy (a scene of thousands of small meshes: a leaf per object would
    walk the scene's hierarchy node by node in Python). The members' world triangles are concatenated in object
    order, so the hierarchy's tie rule (the lowest triangle index) is the scene's (the lower object, then its lower
    triangle); a hit's part is the concatenation's index, which owners() turns back into the object and its own
    triangle. The same numbers as each member's own kernel: the same triangles, the same test."""

    def __init__(self, make, dtype: np.dtype, members: tuple[int, ...], *meshes: tf.WorldTriangles) -> None:
        """make: make_kernel or make_robust_kernel; members (k,): the objects' indices, ascending; meshes: theirs."""
        sizes = np.array([len(mesh.triangles) for mesh in meshes], dtype=np.int64)
        triangles = np.concatenate([mesh.triangles for mesh in meshes])
        normals = np.concatenate([mesh.normals for mesh in meshes])
        merged = tf.WorldTriangles("", triangles, normals)
        starts = np.cumsum(sizes) - sizes  # (k,): each member's first triangle in the concatenation
        hierarchy = None
        if leaves_per_object(sizes):
            hierarchy = object_hierarchy(triangles, starts, sizes, dtype)
        super().__init__(make(merged, dtype), merged, hierarchy)
        self.members = np.asarray(members, dtype=np.int64)
        self.starts = starts
        self.member_of = np.repeat(np.arange(len(members)), sizes)  # (T,)

    def owners(self, part: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parts (n,) of this kernel -> the objects (n,) they belong to and their triangles' own indices (n,)."""
        member = self.member_of.take(part)
        return self.members.take(member), part - self.starts.take(member)

    def member(self, position: int) -> MergedMember:
        return MergedMember(self, position)


class MergedMember(Kernel):
    """One object of a MergedMeshKernel as a kernel of its own: its normals and surface, from the merged arrays
    (the scene's per-object kernels, for shading); it is never traced alone."""

    def __init__(self, merged: MergedMeshKernel, position: int) -> None:
        self.merged = merged
        self.start = int(merged.starts[position])
        self.dtype = merged.dtype

    def normal(self, P, part):
        return self.merged.inner.normal(P, part + self.start)

    def unit_normal(self, P, part):
        return self.merged.inner.unit_normal(P, part + self.start)

    def surface(self, P, part):
        return self.merged.inner.surface(P, part + self.start)
