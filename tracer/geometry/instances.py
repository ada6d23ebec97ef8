"""A mesh placed many times -> one kernel: the mesh's own hierarchy built once in its own space, the instances as
boxes in a hierarchy above it (a two-level hierarchy, as Cycles, Embree and pbrt instance geometry).

A query walks the instances' hierarchy a level at a time for all rays at once (as meshbvh walks a mesh's) and
gathers every (ray, instance) pair whose instance box the ray meets. Each ray first searches its nearest box's
instance; the pairs whose boxes begin no further than that hit (all of a ray's pairs where it found none) are then
searched together. A pair's ray goes into its instance's space (O' = A^-1 O + c, D' = A^-1 D: t keeps its meaning)
and walks the shared mesh's hierarchy there, every pair of every instance in the same NumPy calls. The hit kept is
the nearest t, then the lowest instance, then the lowest triangle: what testing the instances one after another
and each one's triangles in order gives (tracing/reference.py does exactly that). An instance costs its matrices
and its box, not its triangles.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import meshbvh
from . import transforms as tf
from .kernels import (
    Kernel,
    box_margin,
    dot,
    grown_float32,
    indices,
    interpolated_corners,
    kept_grown,
    make_kernel,
    ray_count,
    slab,
    take,
    unit,
    unit_or,
)
from .meshbvh import MeshHierarchy, MeshKernel

INSTANCES_PER_LEAF = 4


class InstanceBoxRays(NamedTuple):
    """A walk's rays and boxes as its slab tests take them (InstancesKernel._box_rays)."""

    origins: np.ndarray  # (3, n)
    inverses: np.ndarray  # (3, n): 1 / direction
    child_boxes: np.ndarray  # (12, M): each node's children's boxes, as InstancesKernel.child_boxes
    box_lower: np.ndarray  # (3, K): each instance's box
    box_upper: np.ndarray


class InstancesKernel(MeshKernel):
    """hit() returns (t, part) with part = instance * T + triangle (T triangles in the mesh); normals are the placed
    triangles' (cofactor @ local normal)."""

    def __init__(self, local: MeshKernel, instances: tf.WorldInstances, dtype: np.dtype) -> None:
        self.local = local  # the mesh's kernel in its own space, shared by every scene that places it
        self.inner = local.inner
        self.dtype = dtype
        self.frame = None
        self.pictures = {}
        self.grown: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # _box_rays' float32 boxes
        self.triangles = local.count
        self.count = len(instances.matrices) * local.count
        self.instance_count = len(instances.matrices)
        # per instance, each entry of the maps as its own (K,) row: a pair's 12 numbers gathered row by row
        self.inverse = np.ascontiguousarray(instances.inverses.reshape(-1, 12).T, dtype=dtype)  # (12, K)
        self.cofactor = np.ascontiguousarray(instances.cofactors.reshape(-1, 9).T, dtype=dtype)  # (9, K)
        self.matrices = instances.matrices  # (K, 3, 4) float64
        self.source_triangles = instances.mesh.triangles  # (T, 3, 3) float64: the mesh in its own space
        self.inverse64 = instances.inverses  # (K, 3, 4) float64, for smooth normals (the reference's numbers)
        self.cofactor64 = instances.cofactors
        local_lower, local_upper = (np.asarray(bound, dtype=np.float64) for bound in local.bounds())
        corners = np.array(
            [[(local_lower, local_upper)[(c >> axis) & 1][axis] for axis in range(3)] for c in range(8)]
        )  # (8, 3)
        linear, offset = self.matrices[:, :, :3], self.matrices[:, :, 3]
        placed = np.einsum("kij,cj->kci", linear, corners) + offset[:, None, :]
        lower, upper = placed.min(axis=1), placed.max(axis=1)  # (K, 3) each: the placed box's corners
        # and the placed bounding sphere's (an ellipsoid: half-width r |row i of A| along axis i); a turned round
        # mesh's box from its corners is up to sqrt(3) times as wide, and every ray through the difference walks it
        vertices = np.asarray(instances.mesh.triangles, dtype=np.float64).reshape(-1, 3)
        centre = (local_lower + local_upper) / 2.0
        radius = float(np.sqrt(((vertices - centre) ** 2).sum(axis=1).max()))
        self.sphere = (centre, radius)  # the mesh's bounding sphere in its own space (float64)
        middle = np.einsum("kij,j->ki", linear, centre) + offset
        half = radius * np.sqrt((linear * linear).sum(axis=2))
        lower, upper = np.maximum(lower, middle - half), np.minimum(upper, middle + half)
        self.lower, self.upper = lower.min(axis=0), upper.max(axis=0)
        size = np.maximum(np.abs(lower).max(axis=1), np.abs(upper).max(axis=1)) + (upper - lower).max(axis=1)
        pad = box_margin(size, dtype)[:, None]
        self.box_lower = np.ascontiguousarray((lower - pad).T, dtype=dtype)  # (3, K)
        self.box_upper = np.ascontiguousarray((upper + pad).T, dtype=dtype)
        self.top = tree = MeshHierarchy(None, dtype, boxes=(lower, upper), leaf_size=INSTANCES_PER_LEAF)
        # each node's children's boxes, rows (lower, upper) x (x, y, z) x (left, right): one gather a level
        left = np.maximum(tree.left, 0)
        self.child_boxes = np.concatenate(
            [
                np.stack((bound[axis].take(left), bound[axis].take(left + 1, mode="clip")))
                for bound in (tree.lower, tree.upper)
                for axis in range(3)
            ]
        )  # (12, M)
        self.cost = 3.0 + 4.0 * np.log2(max(2, self.count))

    def bounds(self):
        return self.lower, self.upper

    def picture(self, view, rays):
        return None  # each instance sees a shared point from a place of its own: no picture serves them all

    # ---- the query ---------------------------------------------------------------------------------------------

    def hit(self, O, D, t_min, t_max, any_hit: bool = False, views=None, columns=None):
        """Rays (3, N) (either may be a shared column) -> (t, part) (N,); any_hit: any hit's t, not the nearest.
        views: unused (MeshKernel.hit's signature); columns: the rays are these columns (n,) of O and D.

        Front to back, all rays at once: each round every ray takes the nearest of the nodes it has met but not
        entered (no further than its best hit so far), follows the nearer child down to a leaf (keeping the other
        child it meets for a later round), and searches the leaf's instances; a round's leaves are searched in one
        batch. A ray stops once nothing it has met begins before its hit: in a dense forest, after the first leaf
        or two, however many boxes lie behind. Rays go in pieces of RAY_PIECE (each ray's hit is its own)."""
        if columns is not None:
            O, D = take(O, columns), take(D, columns)
        count = ray_count(O, D)
        O, D = np.broadcast_to(O, (3, count)), np.broadcast_to(D, (3, count))
        size = meshbvh.RAY_PIECE
        if count <= size:
            return self._hit_piece(O, D, t_min, t_max, any_hit)
        found = [
            self._hit_piece(O[:, piece], D[:, piece], t_min, t_max[piece] if np.ndim(t_max) else t_max, any_hit)
            for piece in (slice(start, start + size) for start in range(0, count, size))
        ]
        return np.concatenate([t for t, _ in found]), np.concatenate([part for _, part in found])

    def _hit_piece(self, O, D, t_min, t_max, any_hit):
        count = O.shape[1]
        best = np.array(np.broadcast_to(np.asarray(t_max, dtype=self.dtype), (count,)))  # the limit until a hit
        found = np.zeros(count, dtype=bool)
        instance = np.zeros(count, dtype=np.int64)
        triangle = np.zeros(count, dtype=np.int64)
        boxes = self._box_rays(O, D)
        tree = self.top
        near, far = slab(O, 1.0 / D, tree.lower[:, :1], tree.upper[:, :1])
        pool_rays = indices((near <= far) & (far > t_min) & (near < best))
        rays_data = np.concatenate((boxes.origins, boxes.inverses))
        pool_nodes = np.zeros(pool_rays.size, dtype=np.int64)
        pool_near = near.take(pool_rays)
        while pool_rays.size:
            keep = pool_near <= best.take(pool_rays)
            if any_hit:
                keep &= ~found.take(pool_rays)
            keep = indices(keep)
            pool_rays, pool_nodes, pool_near = pool_rays.take(keep), pool_nodes.take(keep), pool_near.take(keep)
            if not pool_rays.size:
                break
            # each ray's nearest entry (entries as near as it too: a tie costs a little more work, not a sort)
            nearest = np.full(count, np.inf, dtype=self.dtype)
            np.minimum.at(nearest, pool_rays, pool_near)
            chosen = pool_near == nearest.take(pool_rays)
            taken, left_over = indices(chosen), indices(~chosen)
            rays, nodes = pool_rays.take(taken), pool_nodes.take(taken)
            pool_rays, pool_nodes, pool_near = (
                pool_rays.take(left_over),
                pool_nodes.take(left_over),
                pool_near.take(left_over),
            )
            rays, leaves, passed = self._descend(rays_data, boxes.child_boxes, t_min, best, rays, nodes)
            if passed[0].size:
                pool_rays = np.concatenate((pool_rays, passed[0]))
                pool_nodes = np.concatenate((pool_nodes, passed[1]))
                pool_near = np.concatenate((pool_near, passed[2]))
            if rays.size:
                self._search_leaves(O, D, boxes, t_min, rays, leaves, best, found, instance, triangle, any_hit)
        t = np.where(found, best, self.dtype.type(np.inf))
        part = np.where(found, instance * self.triangles + triangle, 0)
        return t, part

    def _box_rays(self, O: np.ndarray, D: np.ndarray) -> InstanceBoxRays:
        """The rays (3, n) and the boxes as the walk's slab tests take them: in float32 where the tracing is
        float64, the boxes grown so that every box the float64 test meets is met (kernels.grown_float32: half the
        bytes gathered; the same hits); the tracing dtype's own otherwise."""
        if self.dtype != np.float64:
            return InstanceBoxRays(O, 1.0 / D, self.child_boxes, self.box_lower, self.box_upper)
        reach = max(float(np.abs(self.lower).max()), float(np.abs(self.upper).max()))
        found = kept_grown(self.grown, O, reach, self._grown)
        return InstanceBoxRays(O.astype(np.float32), (1.0 / D).astype(np.float32), *found)

    def _grown(self, bound: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The children's boxes (12, M) and the instances' (3, K) each, grown for _box_rays (grown_float32)."""
        children = grown_float32(self.child_boxes[:6], self.child_boxes[6:], bound)
        return (np.concatenate(children), *grown_float32(self.box_lower, self.box_upper, bound))

    def _descend(self, rays_data, child_boxes, t_min, best, rays, nodes):
        """Rays (n,) from nodes (n,) down to a leaf each, always into the nearer child met (within (t_min, the ray's
        best]); -> the rays that reached a leaf, their leaves, and (rays, nodes, near) of the other children met.
        rays_data (6, N): every ray's origin and 1 / direction, gathered once a level; both children's boxes too
        (child_boxes (12, M), as self.child_boxes)."""
        tree = self.top
        passed_rays, passed_nodes, passed_near = [], [], []
        leaf_rays, leaf_nodes = [], []
        while rays.size:
            left = tree.left.take(nodes)
            is_leaf = left < 0
            if is_leaf.any():
                at_leaf = indices(is_leaf)
                leaf_rays.append(rays.take(at_leaf))
                leaf_nodes.append(nodes.take(at_leaf))
                inner = indices(~is_leaf)
                rays, nodes, left = rays.take(inner), nodes.take(inner), left.take(inner)
                if not rays.size:
                    break
            count = rays.size
            ray = rays_data.take(rays, axis=1)  # (6, n)
            boxes = child_boxes.take(nodes, axis=1).reshape(2, 3, 2, count)  # lower/upper, axis, child, ray
            near, far = slab(ray[:3, None, :], ray[3:, None, :], boxes[0], boxes[1])  # (2 children, n)
            meets = (near <= far) & (far > t_min) & (near <= best.take(rays))
            meets_left, meets_right = meets[0], meets[1]
            go_right = meets_right & (~meets_left | (near[1] < near[0]))
            both = indices(meets_left & meets_right)
            if both.size:
                passed_rays.append(rays.take(both))
                passed_nodes.append((left + ~go_right).take(both))  # the child not taken (right = left + 1)
                passed_near.append(np.where(go_right, near[0], near[1]).take(both))
            going = indices(meets_left | meets_right)
            rays, nodes = rays.take(going), (left + go_right).take(going)
        passed = (_join(passed_rays, np.int64), _join(passed_nodes, np.int64), _join(passed_near, self.dtype))
        return _join(leaf_rays, np.int64), _join(leaf_nodes, np.int64), passed

    def _search_leaves(self, O, D, boxes, t_min, rays, leaves, best, found, instance, triangle, any_hit) -> None:
        """The instances of leaves (n,) met by rays (n,): each pair whose instance box the ray meets (boxes: as
        _box_rays gives them) searched in the mesh, and each ray's least (t, instance, triangle) kept in best, found,
        instance, triangle."""
        tree = self.top
        row = tree.leaf_row.take(leaves)
        slots = indices(tree.real.take(row, axis=0).ravel())
        pair_rays = np.repeat(rays, tree.leaf_size).take(slots)
        members = tree.leaf_triangles.take(row, axis=0).ravel().take(slots)
        limit = best.take(pair_rays)
        near, far = slab(
            boxes.origins.take(pair_rays, axis=1),
            boxes.inverses.take(pair_rays, axis=1),
            boxes.box_lower.take(members, axis=1),
            boxes.box_upper.take(members, axis=1),
        )
        meets = indices((near <= far) & (far > t_min) & (near <= limit))
        if not meets.size:
            return
        pair_rays, members, limit = pair_rays.take(meets), members.take(meets), limit.take(meets)
        # as near as a hit found already counts too: a lower instance wins the tie in _keep_least
        limit = np.where(found.take(pair_rays), np.nextafter(limit, self.dtype.type(np.inf)), limit)
        t, hit_triangle = self._search_pairs(O, D, pair_rays, members, t_min, limit, any_hit)
        hit = indices(t < np.inf)
        if hit.size:
            self._keep_least(
                best,
                found,
                instance,
                triangle,
                (pair_rays.take(hit), t.take(hit), members.take(hit), hit_triangle.take(hit)),
            )

    @staticmethod
    def _keep_least(best, found, instance, triangle, candidates) -> None:
        """For each ray of candidates (rays, t, instances, triangles) (n,) each, the least (t, instance, triangle)
        of its current hit and its candidates, kept in best, found, instance and triangle (N,)."""
        rays, more_t, more_instance, more_triangle = candidates
        kept = np.unique(rays)
        kept = kept.take(indices(found.take(kept)))
        all_rays = np.concatenate((rays, kept))
        all_t = np.concatenate((more_t, best.take(kept)))
        all_instance = np.concatenate((more_instance, instance.take(kept)))
        all_triangle = np.concatenate((more_triangle, triangle.take(kept)))
        order = np.lexsort((all_triangle, all_instance, all_t, all_rays))
        sorted_rays = all_rays.take(order)
        first = np.ones(order.size, dtype=bool)
        np.not_equal(sorted_rays[1:], sorted_rays[:-1], out=first[1:])
        winner = order.take(indices(first))
        rays = all_rays.take(winner)
        best[rays] = all_t.take(winner)
        found[rays] = True
        instance[rays] = all_instance.take(winner)
        triangle[rays] = all_triangle.take(winner)

    def _search_pairs(self, O, D, rays, members, t_min, limit, any_hit):
        """Rays (P,) in the spaces of instances members (P,) -> their nearest (or any) hit (t, triangle) (P,) in the
        shared mesh, below limit (P,). Only the pairs whose ray meets the mesh's bounding sphere within (t_min,
        limit) walk its hierarchy: a third of a forest's shadow rays met a tree's box but not its sphere."""
        origin, direction = self.to_local(O.take(rays, axis=1), D.take(rays, axis=1), members)
        inside = indices(self._meets_sphere(origin, direction, t_min, limit))
        t = np.full(rays.size, np.inf, dtype=self.dtype)
        triangle = np.zeros(rays.size, dtype=np.int64)
        if inside.size:
            found_t, found_triangle = self.local._search(
                origin.take(inside, axis=1), direction.take(inside, axis=1), t_min, limit.take(inside), any_hit
            )
            t[inside] = found_t
            triangle[inside] = found_triangle
        return t, triangle

    def _meets_sphere(self, origin: np.ndarray, direction: np.ndarray, t_min: float, limit: np.ndarray) -> np.ndarray:
        """Whether rays (3, P) in the mesh's space meet its bounding sphere, grown by more than any rounding of the
        walk's hits (a relative 1e-6 in float64, 1e-4 in float32, of the sphere's and the origins' reach), between
        t_min and limit (P,): bool (P,), in float64. Every triangle lies inside the sphere, so a ray that does not
        meet it within its t range has no hit to find there."""
        centre, radius = self.sphere
        relative = 1e-6 if self.dtype == np.float64 else 1e-4
        offset = origin.astype(np.float64) - centre[:, None]
        along = direction.astype(np.float64)
        reach = np.sqrt((offset * offset).sum(axis=0))
        grown = radius + relative * (radius + float(np.abs(centre).max()) + reach) + 1e-9
        a = (along * along).sum(axis=0)
        b = (along * offset).sum(axis=0)
        c = (reach - grown) * (reach + grown)  # |offset|^2 - grown^2
        discriminant = b * b - a * c
        root = np.sqrt(np.maximum(discriminant, 0.0))
        # the sphere's exit -(b - root) / a and entry -(b + root) / a along the ray
        return (discriminant >= 0.0) & (root - b > t_min * a) & (-(b + root) <= limit * a)

    def to_local(self, O: np.ndarray, D: np.ndarray, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rays (3, P) -> the same rays in the spaces of instances members (P,): A^-1 O + c and A^-1 D, summed
        left to right as the reference does."""
        m = self.inverse.take(members, axis=1)  # (12, P): rows of [A^-1 | c]
        origin = np.empty_like(m[:3])
        direction = np.empty_like(m[:3])
        for i in range(3):
            a, b, c, d = m[4 * i], m[4 * i + 1], m[4 * i + 2], m[4 * i + 3]
            origin[i] = a * O[0] + b * O[1] + c * O[2] + d
            direction[i] = a * D[0] + b * D[1] + c * D[2]
        return origin, direction

    # ---- normals -----------------------------------------------------------------------------------------------

    def split(self, part: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parts (n,) -> (instance, triangle) (n,) each."""
        instance = part // self.triangles
        return instance, part - instance * self.triangles

    def normal(self, P, part):
        instance, triangle = self.split(part)
        n = self.inner.normals.take(triangle, axis=1)  # the local unit normals (3, n)
        c = self.cofactor.take(instance, axis=1)
        return np.stack([c[3 * i] * n[0] + c[3 * i + 1] * n[1] + c[3 * i + 2] * n[2] for i in range(3)])

    def unit_normal(self, P, part):
        return unit(self.normal(P, part))

    def surface(self, P, part):
        """Robust numerics: each point's signed distance (n,) from its placed triangle along the unit normal, and
        the placed triangle's largest coordinate magnitude (n,)."""
        instance, triangle = self.split(part)
        local = np.asarray(self.local_triangles(), dtype=np.float64).take(triangle, axis=0)  # (n, 3, 3)
        placed = np.einsum("nij,nvj->nvi", self.matrices[:, :, :3].take(instance, axis=0), local)
        placed += self.matrices[:, None, :, 3].take(instance, axis=0)
        corner = placed[:, 0].T.astype(self.dtype)
        return dot(self.unit_normal(P, part), P - corner), np.abs(placed).max(axis=(1, 2)).astype(self.dtype)

    def local_triangles(self) -> np.ndarray:
        """The mesh's triangles in its own space (T, 3 vertices, 3) float64, as its kernel was made from them."""
        return self.source_triangles

    def corner_values(self, P: np.ndarray, part: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-corner values of the mesh's triangles, corners (T, 3, k) (normals, UVs), interpolated (k, n) at hit
        points P (3, n) by their barycentric coordinates in their instance's space; and each hit's instance (n,).
        float64 throughout, as the reference."""
        instance, triangle = self.split(part)
        m = self.inverse64.take(instance, axis=0)  # (n, 3, 4)
        point = P.astype(np.float64)
        local = np.stack(
            [m[:, i, 0] * point[0] + m[:, i, 1] * point[1] + m[:, i, 2] * point[2] + m[:, i, 3] for i in range(3)]
        )
        triangles = self.local_triangles().take(triangle, axis=0)  # (n, 3, 3)
        a = triangles[:, 0].T
        corner = (corners[:, k].take(triangle, axis=0).T for k in range(3))
        values = interpolated_corners(
            local - a, (triangles[:, 1] - triangles[:, 0]).T, (triangles[:, 2] - triangles[:, 0]).T, *corner
        )
        return values, instance

    def smooth_normals(self, P: np.ndarray, part: np.ndarray, corners: np.ndarray, flat: np.ndarray) -> np.ndarray:
        """Interpolated corner normals (3, n) at hit points P (3, n): the barycentric coordinates of P taken into its
        instance's space, the mesh's corner normals corners (T, 3, 3) interpolated there, placed by the cofactor and
        normalised; flat (3, n) where they cancel. float64 throughout, as the reference."""
        n, instance = self.corner_values(P, part, corners)
        cof = self.cofactor64.take(instance, axis=0)  # (n, 3, 3)
        placed = np.stack([cof[:, i, 0] * n[0] + cof[:, i, 1] * n[1] + cof[:, i, 2] * n[2] for i in range(3)])
        return unit_or(placed, flat)


def _join(parts: list[np.ndarray], dtype: type | np.dtype) -> np.ndarray:
    """The arrays of parts end to end, or an empty array of dtype."""
    return np.concatenate(parts) if parts else np.zeros(0, dtype=dtype)


def local_mesh_kernel(make, mesh: tf.WorldTriangles, dtype: np.dtype) -> MeshKernel:
    """The kernel of a mesh in its own space, with its own hierarchy however few its triangles (the instances' walk
    goes through it); make: make_kernel or make_robust_kernel."""
    return MeshKernel(make(mesh, dtype), mesh)


def instances_kernel(make, primitive: tf.WorldInstances, dtype: np.dtype) -> InstancesKernel:
    """An InstancesKernel made without a cache (bounds for footprints and edits, tests)."""
    return InstancesKernel(local_mesh_kernel(make, primitive.mesh, dtype), primitive, dtype)


def placed_kernel(primitive: tf.WorldPrimitive, dtype: np.dtype) -> Kernel:
    """make_kernel for any world primitive, instances included (their bounds for footprints and edits)."""
    if isinstance(primitive, tf.WorldInstances):
        return instances_kernel(make_kernel, primitive, dtype)
    return make_kernel(primitive, dtype)
