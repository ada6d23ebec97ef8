"""A large triangle mesh -> one kernel with a bounding-volume hierarchy over its triangles, traversed a level at a
time for all rays at once.

A hierarchy walked node by node costs NumPy calls per node, so its time grows with the number of nodes a frame
visits, not with the rays: that is what made a 10,000-triangle mesh grow as n^0.58. Here every query keeps (ray,
node) pairs and moves them down one level per step: one slab test over all pairs of a level, the leaves' triangles
tested over all (pair, triangle) at once, the inner nodes' children as the next level's pairs. Before that walk each
ray follows one path, always into the child it enters first, and tests that leaf: its hit (usually the nearest, or
for a shadow ray any) prunes every node beyond it. A query costs a few dozen NumPy calls per level, about
log2(n / LEAF_TRIANGLES) levels, and arithmetic in proportion to the pairs.
The exact test per triangle is the mesh kernel's own (Moller-Trumbore as the seed writes it, or the watertight
test of the robust numerics), with the same operations, so the hits are the ones the whole-mesh kernel finds:
nearest t, then the lowest triangle index on ties.
"""

from __future__ import annotations

import numpy as np

from . import transforms as tf
from .kernels import Kernel, box_margin, ray_count, slab

LEAF_TRIANGLES = 8
MESH_HIERARCHY_TRIANGLES = 32  # a mesh of more triangles gets its own hierarchy; below, one test over all of them
BIG = np.iinfo(np.int64).max


class MeshHierarchy:
    """Nodes (M) in arrays: boxes (3, M) padded in the tracing dtype, children (M,) (-1 at a leaf), and for each
    leaf its row of leaf_triangles (L, LEAF_TRIANGLES) (indices into the mesh; real marks the filled slots)."""

    def __init__(self, triangles: np.ndarray, dtype: np.dtype) -> None:
        """triangles (T, 3 vertices, 3) float64.

        Median splits on the centroids' longest axis, built a level at a time: every node of a level is a range of
        one order of the triangles, and one pass of segment reductions and one stable sort serve them all (a
        node-by-node build cost 0.9 s of Python per 100,000 triangles, most of a million-triangle scene's
        preparation). Nodes are numbered level by level; the splits depend on the mesh only."""
        count = len(triangles)
        centroids = triangles.mean(axis=1)
        low_all, high_all = triangles.min(axis=1), triangles.max(axis=1)
        order = np.arange(count)
        starts, stops = np.array([0]), np.array([count])
        first_node = 0
        lowers, uppers, lefts, leaf_rows, leaf_starts, leaf_stops = [], [], [], [], [], []
        leaves = 0
        while starts.size:
            lowers.append(_segments(np.minimum, low_all[order], starts, stops))  # (n, 3): each node's box
            uppers.append(_segments(np.maximum, high_all[order], starts, stops))
            sizes = stops - starts
            is_leaf = sizes <= LEAF_TRIANGLES
            inner = (~is_leaf).nonzero()[0]
            leaf = is_leaf.nonzero()[0]
            rows = np.full(starts.size, -1, dtype=np.int64)
            rows[leaf] = leaves + np.arange(leaf.size)
            leaves += leaf.size
            leaf_rows.append(rows)
            leaf_starts.append(starts[leaf])
            leaf_stops.append(stops[leaf])
            # children of the inner nodes: the next level's nodes, left then right for each parent in turn
            left = np.full(starts.size, -1, dtype=np.int64)
            left[inner] = first_node + starts.size + 2 * np.arange(inner.size)
            lefts.append(left)
            first_node += starts.size
            if not inner.size:
                break
            inner_starts, inner_stops = starts[inner], stops[inner]
            points = centroids[order]
            extent = _segments(np.maximum, points, inner_starts, inner_stops) - _segments(
                np.minimum, points, inner_starts, inner_stops
            )
            axis = np.argmax(extent, axis=1)
            # a stable order by the centroid along each node's axis, within each node's range
            lengths = inner_stops - inner_starts
            segment = np.repeat(np.arange(inner.size), lengths)
            positions = np.arange(segment.size) - np.repeat(np.cumsum(lengths) - lengths, lengths)
            positions += np.repeat(inner_starts, lengths)
            keys = points[positions, np.repeat(axis, lengths)]
            resorted = positions[np.lexsort((keys, segment))]
            order[positions] = order[resorted]
            middle = inner_starts + lengths // 2
            starts = np.stack((inner_starts, middle), axis=1).ravel()
            stops = np.stack((middle, inner_stops), axis=1).ravel()
        lower, upper = np.concatenate(lowers), np.concatenate(uppers)  # (M, 3)
        self.left = np.concatenate(lefts)
        self.right = np.where(self.left >= 0, self.left + 1, -1)
        self.leaf_row = np.concatenate(leaf_rows)
        # padded_box() for every node at once: the same margin, from the same numbers
        size = np.maximum(np.abs(lower).max(axis=1), np.abs(upper).max(axis=1)) + (upper - lower).max(axis=1)
        pad = box_margin(size, dtype)[:, None]
        self.lower = (lower - pad).astype(dtype).T.copy()  # (3, M)
        self.upper = (upper + pad).astype(dtype).T.copy()
        starts, stops = np.concatenate(leaf_starts), np.concatenate(leaf_stops)
        slots = starts[:, None] + np.arange(LEAF_TRIANGLES)[None, :]  # (L, K)
        self.real = slots < stops[:, None]
        # repeats pad a short leaf, as np.resize did: slot k holds member k mod the leaf's size
        wrapped = starts[:, None] + np.arange(LEAF_TRIANGLES)[None, :] % (stops - starts)[:, None]
        self.leaf_triangles = order[wrapped]


def _segments(ufunc: np.ufunc, values: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """ufunc's reduction (n, 3) of values (P, 3) over each non-empty range [starts, stops)."""
    padded = np.concatenate((values, values[-1:]))  # a stop may be P: one row more keeps reduceat in range
    return ufunc.reduceat(padded, np.stack((starts, stops), axis=1).ravel(), axis=0)[0::2]


class MeshKernel(Kernel):
    """A mesh's triangles behind their own hierarchy: hit() finds each ray's nearest triangle (part = its index in
    the mesh), as the whole-mesh kernel `inner` would; any_hit() only whether there is one."""

    def __init__(self, inner: Kernel, mesh: tf.WorldTriangles) -> None:
        self.inner = inner  # TrianglesKernel or WatertightTrianglesKernel: the test, the normals, the frame
        self.dtype = inner.dtype
        self.frame = inner.frame
        self.lower, self.upper = inner.lower, inner.upper
        self.hierarchy = MeshHierarchy(np.asarray(mesh.triangles, dtype=np.float64), inner.dtype)
        self.packed = inner.pack(self.hierarchy.leaf_triangles)  # (9, L, K): each leaf's triangles, gathered once
        self.cost = 3.0 + 4.0 * np.log2(max(2, len(mesh.triangles)))

    def bounds(self):
        return self.lower, self.upper

    def hit(self, O, D, t_min, t_max, any_hit: bool = False):
        """Kernel.hit (rays outside the mesh's oriented box skip the search); any_hit: stop at a ray's first hit,
        whose t is then any hit's, not the nearest."""
        count = ray_count(O, D)
        rays = self.in_box(O, D, t_min, t_max)
        t = np.full(count, np.inf, dtype=self.dtype)
        part = np.zeros(count, dtype=np.int64)
        if rays.size:
            limit = t_max.take(rays) if isinstance(t_max, np.ndarray) else t_max
            O_r = np.broadcast_to(O, (3, count)).take(rays, axis=1)
            D_r = np.broadcast_to(D, (3, count)).take(rays, axis=1)
            found_t, found_part = self._search(O_r, D_r, t_min, limit, any_hit)
            t.put(rays, found_t)
            part.put(rays, found_part)
        return t, part

    def _hit(self, O, D, t_min, t_max):
        count = ray_count(O, D)
        return self._search(np.broadcast_to(O, (3, count)), np.broadcast_to(D, (3, count)), t_min, t_max, False)

    def _search(self, O, D, t_min, t_max, any_hit):
        count = O.shape[1]
        inverse = 1.0 / D
        best_t = np.broadcast_to(np.asarray(t_max, dtype=self.dtype), (count,)).copy()
        best_part = np.full(count, BIG, dtype=np.int64)
        tree = self.hierarchy
        # first one path per ray, always into the child entered first: its leaf usually holds the nearest hit (or,
        # for a shadow ray, a hit at all), so that the full walk below can leave out every node beyond it
        rays = np.arange(count)
        nodes = np.zeros(count, dtype=np.int64)
        dived = np.full(count, -1, dtype=np.int64)  # the leaf each ray's path ended in
        while rays.size:
            inner = (tree.left.take(nodes) >= 0).nonzero()[0]
            leaf = (tree.left.take(nodes) < 0).nonzero()[0]
            if leaf.size:
                dived[rays.take(leaf)] = nodes.take(leaf)
                self._test_leaves(O, D, t_min, rays.take(leaf), nodes.take(leaf), best_t, best_part)
            rays, nodes = rays.take(inner), nodes.take(inner)
            O_n, inverse_n = O.take(rays, axis=1), inverse.take(rays, axis=1)
            left, right = tree.left.take(nodes), tree.right.take(nodes)
            near_left, far_left = slab(O_n, inverse_n, tree.lower[:, left], tree.upper[:, left])
            near_right, far_right = slab(O_n, inverse_n, tree.lower[:, right], tree.upper[:, right])
            meets_left = (near_left <= far_left) & (far_left > t_min) & (near_left <= best_t.take(rays))
            meets_right = (near_right <= far_right) & (far_right > t_min) & (near_right <= best_t.take(rays))
            go_right = meets_right & (~meets_left | (near_right < near_left))
            going = (meets_left | meets_right).nonzero()[0]
            rays, nodes = rays.take(going), np.where(go_right, right, left).take(going)
        # for any-hit queries only the rays that found nothing on their path go on
        rays = (best_part == BIG).nonzero()[0] if any_hit else np.arange(count)
        nodes = np.zeros(rays.size, dtype=np.int64)
        while rays.size:
            near, far = slab(
                O.take(rays, axis=1), inverse.take(rays, axis=1), tree.lower[:, nodes], tree.upper[:, nodes]
            )
            keep = ((near <= far) & (far > t_min) & (near <= best_t.take(rays))).nonzero()[0]
            rays, nodes = rays.take(keep), nodes.take(keep)
            leaf = tree.left.take(nodes) < 0
            at_leaf = (leaf & (nodes != dived.take(rays))).nonzero()[0]  # a path's own leaf is tested already
            if at_leaf.size:
                self._test_leaves(O, D, t_min, rays.take(at_leaf), nodes.take(at_leaf), best_t, best_part)
            inner = (~leaf).nonzero()[0]
            rays, nodes = rays.take(inner), nodes.take(inner)
            if any_hit:
                still = (best_part.take(rays) == BIG).nonzero()[0]
                rays, nodes = rays.take(still), nodes.take(still)
            rays = np.concatenate((rays, rays))
            nodes = np.concatenate((tree.left.take(nodes), tree.right.take(nodes)))
        found = best_part != BIG
        return np.where(found, best_t, np.inf).astype(self.dtype, copy=False), np.where(found, best_part, 0)

    def _test_leaves(self, O, D, t_min, rays, nodes, best_t, best_part) -> None:
        """The triangles of leaves (P,) met by rays (P,): the nearest hit nearer than each ray's best so far replaces
        it, the lowest triangle index on equal t."""
        row = self.hierarchy.leaf_row.take(nodes)
        triangles, real = self.hierarchy.leaf_triangles.take(row, axis=0), self.hierarchy.real.take(row, axis=0)
        t = self.inner.packed_t(O.take(rays, axis=1), D.take(rays, axis=1), self.packed.take(row, axis=1), t_min)
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
