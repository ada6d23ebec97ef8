"""Kernels -> a small bounding-volume hierarchy of padded boxes, and vectorized closest-hit and any-hit over it.

Boxes only decide which rays an object's own test sees; the object tests are the exact kernels, so culling never
changes a result. Planes skip the hierarchy (their test costs no more than a box's). Ties between objects go to
the lower object index, as the reference's loop over objects does.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from . import meshbvh
from .kernels import (
    Kernel,
    PlaneKernel,
    SphereKernel,
    indices,
    padded_box,
    quiet,
    ray_count,
    shared_terms,
    slab,
    spread,
    take,
)
from .meshbvh import MergedMeshKernel, MeshKernel
from .meshpicture import View
from .rayframes import RayFrames

# (kernel index, the indices (n,) of the rays it may meet, or None: every ray) for each kernel a cull gives rays to
Sets = list[tuple[int, np.ndarray | None]]


@dataclass
class Node:
    lower: np.ndarray  # (3, 1) in the tracing dtype
    upper: np.ndarray
    objects: list[int]  # leaf: object indices; inner: empty
    children: list[Node]


def _areas(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Surface areas of boxes (k, 3) -> (k,)."""
    d = np.maximum(upper - lower, 1e-12)
    return 2.0 * (d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 2] * d[:, 0])


def _build(indices: np.ndarray, lower: np.ndarray, upper: np.ndarray, costs: np.ndarray, dtype: np.dtype) -> Node:
    """Split by the surface area heuristic, sweeping every axis: a ray that meets a box meets a child with
    probability (child area / box area), and each object's test costs about costs[i] box tests.

    indices (n,) name the objects; lower, upper (n, 3) are their boxes and costs (n,) their test costs."""
    box_lower, box_upper = lower.min(axis=0), upper.max(axis=0)
    padded = padded_box(box_lower, box_upper, dtype)
    area = _areas(box_lower[None], box_upper[None])[0]
    best_cost, best_split = float(costs.sum()), None
    for axis in range(3):
        order = np.lexsort((indices, lower[:, axis] + upper[:, axis]))
        lo, hi, cost = lower[order], upper[order], costs[order]
        # left side: the first k objects; right side: the rest, for k = 1 .. n - 1
        left = _areas(np.minimum.accumulate(lo)[:-1], np.maximum.accumulate(hi)[:-1]) * np.cumsum(cost)[:-1]
        right_lower = np.minimum.accumulate(lo[::-1])[::-1][1:]
        right_upper = np.maximum.accumulate(hi[::-1])[::-1][1:]
        right = _areas(right_lower, right_upper) * np.cumsum(cost[::-1])[::-1][1:]
        split_costs = 2.0 + (left + right) / area
        if split_costs.size and split_costs.min() < best_cost:
            k = int(np.argmin(split_costs)) + 1
            best_cost, best_split = float(split_costs.min()), (order[:k], order[k:])
    if best_split is None:
        return Node(*padded, objects=sorted(indices.tolist()), children=[])
    return Node(
        *padded,
        objects=[],
        children=[_build(indices[side], lower[side], upper[side], costs[side], dtype) for side in best_split],
    )


_STILL: OrderedDict[tuple, Node] = OrderedDict()
STILL_CACHE_SIZE = 8


def _still_subtree(
    indices: np.ndarray, lower: np.ndarray, upper: np.ndarray, costs: np.ndarray, dtype: np.dtype
) -> Node:
    """_build() of kernels that stay put between frames, kept under its exact inputs (nodes never change once
    built): an animation's frames share the still part of their hierarchies."""
    key = (dtype.str, indices.tobytes(), lower.tobytes(), upper.tobytes(), costs.tobytes())
    node = _STILL.get(key)
    if node is None:
        node = _STILL[key] = _build(indices, lower, upper, costs, dtype)
        if len(_STILL) > STILL_CACHE_SIZE:
            _STILL.popitem(last=False)
    else:
        _STILL.move_to_end(key)
    return node


def _split_build(
    indices: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    costs: np.ndarray,
    dtype: np.dtype,
    owners: list[int],
    moving: frozenset[int] | None,
) -> Node:
    """The root over the bounded kernels indices (n,): the surface-area split of them all, or, where moving names
    some of their owners and not all, a node over the still kernels' kept subtree and the moving ones' own."""
    if moving:
        moves = np.array([owners[i] in moving for i in indices.tolist()], dtype=bool)
        if moves.any() and not moves.all():
            still, turned = ~moves, moves
            children = [
                _still_subtree(indices[still], lower[still], upper[still], costs[still], dtype),
                _build(indices[turned], lower[turned], upper[turned], costs[turned], dtype),
            ]
            return Node(*padded_box(lower.min(axis=0), upper.max(axis=0), dtype), objects=[], children=children)
    return _build(indices, lower, upper, costs, dtype)


# The cost model of the choice between walking the hierarchy and brute force (choose_brute), in the units of
# Kernel.cost (one box test over a ray): walking gathers each ray's origin and direction at every node and leaf
# kernel it reaches (GATHER_COST each); brute force tests every kernel on every ray in place and offers each result
# (BRUTE_OFFER_COST), which per ray costs about BRUTE_SCALE of what the same tests cost on gathered rays. Calibrated
# on the peer rt3.py's 4 spheres (brute force the faster) and the default vane's 13 bounded objects (the walk the
# faster; both measured in docs/measurements.md#the-tracers-constants): any BRUTE_SCALE in (0.05, 0.8) chooses right
# for both; 0.25 is about their geometric middle.
GATHER_COST = 2.0
BRUTE_OFFER_COST = 1.0
BRUTE_SCALE = 0.25
# Up to this many (ray, bounded kernel) pairs a query tests every kernel's own padded box at once instead of walking
# the tree (_flat_walk): the last bounces' few hundred rays cost the walk ~20 NumPy calls per node reached, and the
# flat test ~20 calls in all
FLAT_WALK_PAIRS = 1 << 16
# Up to this many bounded kernels a query tests their boxes at once however many rays it has, in pieces of
# FLAT_WALK_PAIRS pairs: a ground and 3,000 cubes merged (a tree of 3 nodes) walked a band's millions of shadow rays
# in 0.80 s, tested flat in 0.54 s (1280x720, one worker)
FLAT_WALK_KERNELS = 4


class Hierarchy:
    """Closest-hit and any-hit queries over all kernels of a scene."""

    def __init__(
        self,
        kernels: list[Kernel],
        dtype: np.dtype,
        owners: list[int] | None = None,
        moving: frozenset[int] | None = None,
        frame_of: list[int] | None = None,
    ) -> None:
        """kernels are the hierarchy's leaves; owners[i] is the scene object kernel i belongs to (default: i).

        frame_of: for several frames traced at once (prepared.PreparedScene with headings), the frame whose rays
        kernel i sees (-1: every frame's); a query then names each ray's frame (rayframes.RayFrames).

        moving: the owners that move between the frames of an animation (the vane's parts). Where some bounded
        kernels move and some do not, the root has two children, the still kernels' subtree (kept between frames,
        _still_subtree) and the moving kernels' subtree (built each time): a frame then builds only the latter.
        Boxes only decide which rays a kernel sees, so the images are the same bytes with either tree."""
        self.kernels = kernels
        # a hit's part: int32, unless a kernel has more parts than it holds (instances times their triangles)
        parts = max((getattr(kernel, "count", 0) for kernel in kernels), default=0)
        self.part_dtype = np.int64 if parts >= 2**31 else np.int32
        self.owners = owners if owners is not None else list(range(len(kernels)))
        self.frame_of = None if frame_of is None or max(frame_of, default=-1) < 0 else frame_of
        self.dtype = dtype
        boxes = {}
        self.unbounded: list[int] = []
        for index, kernel in enumerate(kernels):
            box = kernel.bounds()
            if box is None or isinstance(kernel, PlaneKernel):
                if self.frame_of is not None and self.frame_of[index] >= 0:
                    raise ValueError("a part that differs by frame must be bounded")
                self.unbounded.append(index)
            else:
                boxes[index] = box
        bounded = np.array(sorted(boxes), dtype=np.int64)
        self.root = None
        self.boxes: tuple[list[int], np.ndarray, np.ndarray] | None = None  # bounded kernels, lower, upper (k, 3)
        # brute force: every bounded kernel tests every ray, no boxes, no gathers (the peer's way), where the cost
        # estimate says that is cheaper than walking the hierarchy (a few objects, or boxes that every ray meets)
        self.brute = False
        self.walk_cost = self.brute_cost = 0.0
        # each bounded kernel's own padded box, as a leaf of it alone would have (brute force's check of its hits),
        # made when brute force first needs it, once per prepared scene
        self._padded: dict[int, tuple[np.ndarray, np.ndarray]] | None = None
        self._stacked: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # _flat_walk's boxes, made when needed
        if bounded.size:
            lower = np.array([boxes[i][0] for i in bounded.tolist()], dtype=np.float64)
            upper = np.array([boxes[i][1] for i in bounded.tolist()], dtype=np.float64)
            self.boxes = (bounded.tolist(), lower, upper)
            costs = np.array([kernels[i].cost for i in bounded.tolist()], dtype=np.float64)
            self.root = _split_build(bounded, lower, upper, costs, dtype, self.owners, moving)
            self.brute_cost = float(costs.sum()) + BRUTE_OFFER_COST * len(bounded)

    def choose_brute(self, O: np.ndarray, D: np.ndarray) -> bool:
        """Decide between the walk and brute force on sample rays (3, n) (a coarse grid of the camera's): the walk's
        cost per ray is counted on them (box tests and gathers at each node reached, kernel tests and gathers at
        each leaf), brute force's is the sum of the kernels' costs. A mesh with a hierarchy of its own is always
        walked to. Sets self.brute and returns it; the images are the same bytes either way."""
        self.brute = False
        if self.root is None or any(isinstance(kernel, MeshKernel) for kernel in self.kernels):
            return False
        with quiet():
            count = ray_count(O, D)
            cost, stack = 0.0, [(self.root, take(O, np.arange(count)), D, 1.0 / D)]
            while stack:
                node, O_n, D_n, inverse_n = stack.pop()
                cost += D_n.shape[1] * (1.0 + GATHER_COST)
                near, far = slab(O_n, inverse_n, node.lower, node.upper)
                keep = indices((near <= far) & (far > 0.0))
                if keep.size == 0:
                    continue
                O_n, D_n, inverse_n = take(O_n, keep), take(D_n, keep), take(inverse_n, keep)
                cost += keep.size * sum(self.kernels[index].cost + GATHER_COST for index in node.objects)
                stack.extend((child, O_n, D_n, inverse_n) for child in node.children)
        self.walk_cost = cost / max(1, count)
        self.brute = BRUTE_SCALE * self.brute_cost <= self.walk_cost
        return self.brute

    def culls_well(self, kernels: list[int], shares: np.ndarray) -> bool:
        """Whether a cull (cull.py) that gives kernels (k,) the shares (k,) of the rays costs less than what this
        hierarchy does without it: always where it walks; under brute force, where the culled kernels' rays,
        gathered, cost less than brute force's tests of them (the kernels it leaves out cost the same either way)."""
        if not self.brute:
            return True
        cost = {index: self.kernels[index].cost for index in self.boxes[0]}
        culled = sum(share * (cost[k] + GATHER_COST) for k, share in zip(kernels, shares.tolist(), strict=True))
        return culled < BRUTE_SCALE * sum(cost[k] + BRUTE_OFFER_COST for k in kernels)

    def _shared_terms(self, D: np.ndarray) -> tuple | None:
        """The spheres' direction terms, computed once where brute force tests several spheres on the same rays."""
        spheres = sum(type(self.kernels[index]) is SphereKernel for index in self.boxes[0])
        return shared_terms(D) if spheres > 1 else None

    def _brute_hit(
        self,
        index: int,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        limit: float | np.ndarray,
        shared: tuple | None = None,
        reach: float | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Kernel index's test on every ray, keeping only the hits of rays that meet the kernel's padded box within
        (t_min, limit] (limit: one number, or one per ray of all), the walk's test at a leaf of that kernel alone.
        A true hit's ray always meets the box; a test in the documented numerics may report a hit where its ray
        passes far from the object (float32's quadratic for a ray from thousands of units away): the walk's boxes
        drop such a hit, and so does this, unless a bound shows that none can be dropped (_inside_padding).
        shared: shared_terms(D); reach: the origins' largest coordinate magnitude (each computed here if None)."""
        kernel = self.kernels[index]
        if type(kernel) is SphereKernel:  # the documented test (not the robust one)
            shared = shared_terms(D) if shared is None else shared
            t, part = kernel._hit(O, D, t_min, t_max, shared)
            if self._inside_padding(index, O, shared[0], reach):
                return t, part
        else:
            t, part = kernel.hit(O, D, t_min, t_max)
        t[self._off_box(index, O, D, indices(t < np.inf), t_min, limit)] = np.inf
        return t, part

    def _padded_box(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """Bounded kernel index's own padded box (3, 1) each, as a leaf of it alone would have."""
        if self._padded is None:
            rows, lower, upper = self.boxes
            self._padded = {i: padded_box(lower[k], upper[k], self.dtype) for k, i in enumerate(rows)}
        return self._padded[index]

    def _inside_padding(self, index: int, O: np.ndarray, four_k1: np.ndarray, reach: float | None) -> bool:
        """Whether every hit that documented sphere index reports on rays from O (3, N) with 4 D.D four_k1 (N,)
        lies inside its padded box by more than the slab test's rounding, so that _off_box could drop none.

        Rounding moves the discriminant k2^2 - 4 k1 k3 by at most 4 k1 * 15 eps (R^2 + r^2), R the origins' largest
        distance from the centre: a reported root's point then lies within r + 2 sqrt(15 eps (R^2 + r^2)) of the
        centre (a spurious root of a ray that passes just outside included), and the slab test's own rounding
        moves a face by less than 4 eps (|box| + |O|). Both, doubled, must fit in half the padding: in practice a
        large sphere in float64 (rt3.py's floor), never float32. Directions whose 4 D.D leaves [1e-200, 1e200]
        (where a product could underflow or overflow) keep the box check."""
        if four_k1.size == 0:
            return True
        kernel = self.kernels[index]
        radius_squared = float(kernel.radius_squared)
        lower, upper = (bound.ravel().astype(np.float64) for bound in self._padded_box(index))
        room = float(min((kernel.lower - lower).min(), (upper - kernel.upper).min()))  # the padding
        reach = float(np.maximum(O.max(), -O.min())) if reach is None else reach  # NaN stays NaN: refused below
        if not (float(four_k1.min()) >= 1e-200 and float(four_k1.max()) <= 1e200 and radius_squared >= 1e-80):
            return False
        eps = float(np.finfo(self.dtype).eps)
        center = kernel.center.ravel().astype(np.float64)
        drift = float(np.abs(center - (kernel.lower + kernel.upper) / 2.0).max())  # the centre's own rounding
        distance = math.sqrt(3.0) * (reach + float(np.abs(center).max()))
        box_reach = float(max(np.abs(lower).max(), np.abs(upper).max()))
        slack = 4.0 * math.sqrt(15.0 * eps * (distance**2 + radius_squared)) + 8.0 * eps * (box_reach + reach)
        return slack + drift <= room / 2.0  # False for NaN or infinite origins

    def _brute_blocks(
        self, index: int, O: np.ndarray, L: np.ndarray, t_min: float, t_max: float | np.ndarray, shared: tuple | None
    ) -> np.ndarray:
        """Whether kernel index blocks each shadow ray (3, N) within (t_min, t_max): bool (N,), _brute_hit's hits
        (a documented sphere need not find which root is nearer)."""
        kernel = self.kernels[index]
        if shared is not None and type(kernel) is SphereKernel:
            blocks = kernel.blocks(O, L, t_min, t_max, shared)
        else:
            blocks = kernel.hit(O, L, t_min, t_max)[0] < np.inf
        blocks[self._off_box(index, O, L, indices(blocks), t_min, t_max)] = False
        return blocks

    def _off_box(
        self, index: int, O: np.ndarray, D: np.ndarray, hits: np.ndarray, t_min: float, limit: float | np.ndarray
    ) -> np.ndarray:
        """The rays among hits (n,) of rays (3, N) that miss kernel index's padded box within (t_min, limit]."""
        if hits.size == 0:
            return hits
        lower, upper = self._padded_box(index)
        D_h = take(D, hits)
        near, far = slab(take(O, hits), 1.0 / D_h, lower, upper)
        limit_h = limit.take(hits) if isinstance(limit, np.ndarray) else limit
        return hits.take(indices(~((near <= far) & (far > t_min) & (near <= limit_h))))

    def closest(
        self,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        sets: Sets | None = None,
        walk: np.ndarray | None = None,
        frames: RayFrames | None = None,
        views: tuple[list[View], np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rays (3, N) -> nearest t > t_min (N,), object index (N,) or -1, part (N,).

        O or D may be a (3, 1) column shared by all rays (see kernels.take). sets, when given, name for every
        bounded kernel that any ray can meet the rays (n,) that can, or None for all (cull.ScreenRectangles); the
        hierarchy is then neither walked nor replaced by brute force, except for the rays walk (m,), which the
        sets leave out (the mirror rays of what is not a culled plane) and which go through the hierarchy as
        without sets (walked only: a hierarchy that brute force serves is not given sets). frames: each ray's frame,
        where kernels differ by frame (frame_of); without it every kernel sees every ray. views as for occluded():
        the points the rays lie on lines through (a clipped camera's rays start off its location), for the meshes'
        pictures."""
        with quiet():
            return self._closest(O, D, t_min, sets, walk, frames if self.frame_of is not None else None, views)

    def _closest(
        self,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        sets: Sets | None,
        walk: np.ndarray | None = None,
        frames: RayFrames | None = None,
        views: tuple[list[View], np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        count = ray_count(O, D)
        best_t = np.full(count, np.inf, dtype=self.dtype)
        best_object = np.full(count, -1, dtype=np.int32)
        best_part = np.zeros(count, dtype=self.part_dtype)
        empty = True  # no hit offered yet

        def offer(index: int, rays: np.ndarray | None, t: np.ndarray, part: np.ndarray) -> None:
            """Hits t, part (n,) of kernel index on rays (n,) (None: all) replace nearer-or-tied earlier ones."""
            nonlocal empty
            owner = self.owners[index]
            kernel = self.kernels[index]
            if isinstance(kernel, MergedMeshKernel):  # many objects in one kernel: each hit's own object
                owner, part = kernel.owners(part)
            if empty and rays is None:  # every ray's hit is better than none: no comparisons (a plane's, mostly)
                empty = False
                found = t < np.inf
                np.copyto(best_t, t, where=found)
                np.copyto(best_object, owner, where=found)
                np.copyto(best_part, part, where=found)
                return
            empty = False
            if rays is None:
                current_t, current_object, current_part = best_t, best_object, best_part
            else:
                current_t, current_object = best_t.take(rays), best_object.take(rays)
                current_part = best_part.take(rays)
            # ties go to the lower object, then the lower part: the reference's loop order
            tie = (t == current_t) & (t < np.inf)
            earlier = (owner < current_object) | ((owner == current_object) & (part < current_part))
            better = indices((t < current_t) | (tie & earlier))
            chosen = better if rays is None else rays.take(better)
            best_t[chosen] = t.take(better)
            best_object[chosen] = owner if np.ndim(owner) == 0 else owner.take(better)
            best_part[chosen] = part.take(better)

        for index in self.unbounded:
            offer(index, None, *self.kernels[index].hit(O, D, t_min, math.inf))
        if self.brute and sets is None:
            limit = best_t.copy() if self.unbounded else math.inf  # the walk's limit: the planes' hits
            shared = self._shared_terms(D)
            reach = float(np.maximum(O.max(), -O.min())) if count else 0.0  # for _inside_padding, once a query
            by_frame = []  # kernels that see one frame's rays: tested on those only (_evaluate)
            for index in self.boxes[0] if self.boxes is not None else []:
                if frames is not None and self.frame_of[index] >= 0:
                    by_frame.append((index, None))
                    continue
                offer(index, None, *self._brute_hit(index, O, D, t_min, math.inf, limit, shared, reach))
            for index, rays, t, part in self._evaluate(O, D, t_min, math.inf, by_frame, frames=frames):
                offer(index, rays, t, part)
            return best_t, best_object, best_part
        if sets is None:  # the planes' hits bound the walk
            sets = self._walk(O, D, np.arange(count), t_min, best_t)
        elif walk is not None:
            sets = sets + self._walk(O, D, walk, t_min, best_t)
        for index, rays, t, part in self._evaluate(O, D, t_min, math.inf, sets, views=views, frames=frames):
            offer(index, rays, t, part)
        return best_t, best_object, best_part

    def _walk(
        self, O: np.ndarray, D: np.ndarray, rays: np.ndarray, t_min: float, limit: float | np.ndarray
    ) -> list[tuple[int, np.ndarray]]:
        """The leaves' rays: rays (n,) -> (kernel index, rays (m,)) for each leaf whose box the rays meet within
        (t_min, limit]; limit is one number or one per ray of all N. The leaves are tested afterwards, so that
        kernels of one class share a batch (_evaluate)."""
        if self.root is None or rays.size == 0:
            return []
        if rays.size * len(self.boxes[0]) <= FLAT_WALK_PAIRS:
            return self._flat_walk(O, D, rays, t_min, limit)
        piece = meshbvh.RAY_PIECE
        if len(self.boxes[0]) <= FLAT_WALK_KERNELS:  # a few kernels: their boxes at once, in pieces of rays
            walk, piece = self._flat_walk, max(1, FLAT_WALK_PAIRS // len(self.boxes[0]))
        else:
            walk = self._walk_piece
        if rays.size <= piece:
            return walk(O, D, rays, t_min, limit)
        # in pieces: a band's shadow rays of every light (millions) made each box test a few passes over arrays
        # far larger than the caches (0.74 s of 3,000 cubes' 640x360 frame for a tree of 3 nodes)
        joined: dict[int, list[np.ndarray]] = {}
        for start in range(0, rays.size, piece):
            for index, found in walk(O, D, rays[start : start + piece], t_min, limit):
                joined.setdefault(index, []).append(found)
        return [(index, found[0] if len(found) == 1 else np.concatenate(found)) for index, found in joined.items()]

    def _walk_piece(
        self, O: np.ndarray, D: np.ndarray, rays: np.ndarray, t_min: float, limit: float | np.ndarray
    ) -> list[tuple[int, np.ndarray]]:
        """_walk over rays (n,) at once: a depth-first walk of the tree, each node's box tested on its rays."""
        sets: list[tuple[int, np.ndarray]] = []
        O_n, D_n = (O, D) if rays.size == ray_count(O, D) else (take(O, rays), take(D, rays))
        limit_n = limit.take(rays) if isinstance(limit, np.ndarray) else limit
        # each entry carries its rays compacted, so deeper nodes gather from ever smaller arrays
        stack = [(self.root, rays, O_n, D_n, 1.0 / D_n, limit_n)]
        while stack:
            node, rays, O_n, D_n, inverse_n, limit_n = stack.pop()
            near, far = slab(O_n, inverse_n, node.lower, node.upper)
            keep = indices((near <= far) & (far > t_min) & (near <= limit_n))
            if keep.size == 0:
                continue
            if keep.size < rays.size:
                rays, O_n, D_n, inverse_n = rays.take(keep), take(O_n, keep), take(D_n, keep), take(inverse_n, keep)
                if isinstance(limit_n, np.ndarray):
                    limit_n = limit_n.take(keep)
            sets.extend((index, rays) for index in node.objects)
            stack.extend((child, rays, O_n, D_n, inverse_n, limit_n) for child in node.children)
        return sets

    def _flat_walk(
        self, O: np.ndarray, D: np.ndarray, rays: np.ndarray, t_min: float, limit: float | np.ndarray
    ) -> list[tuple[int, np.ndarray]]:
        """_walk's sets from every bounded kernel's own padded box, all tested at once in one (3, K, n) slab test.

        A kernel gets the rays that meet its own padded box within (t_min, limit], a subset of the rays the walk
        gives it (its box lies inside its ancestors'); what only the walk's rays could add is a hit off that box,
        which brute force drops too (_brute_hit): the same images either way."""
        if self._stacked is None:
            padded = [self._padded_box(index) for index in self.boxes[0]]
            lower = np.stack([box[0] for box in padded], axis=1)  # (3, K, 1)
            upper = np.stack([box[1] for box in padded], axis=1)
            self._stacked = (np.asarray(self.boxes[0]), lower, upper)
        kernels, lower, upper = self._stacked
        O_n, D_n = (O, D) if rays.size == ray_count(O, D) else (take(O, rays), take(D, rays))
        limit_n = limit.take(rays) if isinstance(limit, np.ndarray) else limit
        near, far = slab(O_n[:, None, :], 1.0 / D_n[:, None, :], lower, upper)  # (K, n) each
        box, ray = ((near <= far) & (far > t_min) & (near <= limit_n)).nonzero()  # by kernel, then ray, ascending
        ends = np.cumsum(np.bincount(box, minlength=len(kernels))).tolist()
        chosen = rays.take(ray)
        return [
            (index, chosen[start:end])
            for index, start, end in zip(kernels.tolist(), [0, *ends[:-1]], ends, strict=True)
            if end > start
        ]

    def occluded(
        self,
        O: np.ndarray,
        L: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        planes: bool = True,
        sets: Sets | None = None,
        views: tuple[list[View], np.ndarray] | None = None,
        frames: RayFrames | None = None,
    ) -> np.ndarray:
        """Whether anything lies on each ray (3, N) with t_min < t < t_max: bool (N,), stopping at the first.

        t_max is one number or one per ray (N,); planes=False leaves out the unbounded surfaces (for rays already
        tested with blocked_by_planes()); sets as for closest(); views: the views (k,) that the rays share a point
        or a direction of (a light's), and each ray's index (N,) among them, for the meshes' pictures; frames as for
        closest()."""
        frames = frames if self.frame_of is not None else None
        with quiet():
            blocked = self._blocked_by_planes(O, L, t_min, t_max) if planes else np.zeros(ray_count(O, L), bool)
            if self.brute and sets is None:
                shared = self._shared_terms(L)
                by_frame = []  # kernels that see one frame's rays: tested on those only (_evaluate)
                for index in self.boxes[0] if self.boxes is not None else []:
                    if frames is not None and self.frame_of[index] >= 0:
                        by_frame.append((index, None))
                        continue
                    blocked |= self._brute_blocks(index, O, L, t_min, t_max, shared)
                return self._occluded_in_sets(O, L, t_min, t_max, blocked, by_frame, views, frames)
            if sets is None:
                sets = self._walk(O, L, indices(~blocked), t_min, t_max)  # rays the planes block go no further
            return self._occluded_in_sets(O, L, t_min, t_max, blocked, sets, views, frames)

    def blocked_by_planes(
        self,
        O: np.ndarray,
        L: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        whole: list[int] = (),
        frames: RayFrames | None = None,
    ) -> np.ndarray:
        """occluded() over the unbounded surfaces and the bounded kernels whole (those a light's picture leaves
        out, each tested on every ray as brute force tests it, or on its frame's rays): bool (N,)."""
        frames = frames if self.frame_of is not None else None
        with quiet():
            blocked = self._blocked_by_planes(O, L, t_min, t_max)
            by_frame = []
            for index in whole:
                if frames is not None and self.frame_of[index] >= 0:
                    by_frame.append((index, None))
                    continue
                blocked |= self._brute_blocks(index, O, L, t_min, t_max, None)
            return self._occluded_in_sets(O, L, t_min, t_max, blocked, by_frame, frames=frames)

    def _blocked_by_planes(self, O: np.ndarray, L: np.ndarray, t_min: float, t_max: float | np.ndarray) -> np.ndarray:
        blocked = np.zeros(ray_count(O, L), dtype=bool)
        for index in self.unbounded:
            t, _ = self.kernels[index].hit(O, L, t_min, t_max)
            blocked |= t < np.inf
        return blocked

    def _occluded_in_sets(
        self,
        O: np.ndarray,
        L: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        blocked: np.ndarray,
        sets: Sets,
        views: tuple[list[View], np.ndarray] | None = None,
        frames: RayFrames | None = None,
    ) -> np.ndarray:
        """blocked (N,) with the rays that a kernel of sets blocks marked. The kernels without a hierarchy go first
        (together, in their batches), then the hierarchies, cheapest first, each walked only by the rays still open:
        a shadow ray that the ground blocks does not walk 3,000 cubes' hierarchy (a third of those rays, there)."""
        walked = sorted(
            (pair for pair in sets if isinstance(self.kernels[pair[0]], MeshKernel)),
            key=lambda pair: self.kernels[pair[0]].cost,
        )
        groups = [[pair for pair in sets if not isinstance(self.kernels[pair[0]], MeshKernel)]] + [[p] for p in walked]
        for position, group in enumerate(groups):
            if position:  # a hierarchy: only the rays nothing blocked yet
                index, rays = group[0]
                rays = indices(~blocked) if rays is None else rays.take(indices(~blocked.take(rays)))
                if not rays.size:
                    continue
                group = [(index, rays)]
            for _, rays, t, _ in self._evaluate(O, L, t_min, t_max, group, any_hit=True, views=views, frames=frames):
                hits = indices(t < np.inf)
                blocked[hits if rays is None else rays.take(hits)] = True
        return blocked

    def _evaluate(
        self,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        sets: Sets,
        any_hit: bool = False,
        views: tuple[list[View], np.ndarray] | None = None,
        frames: RayFrames | None = None,
    ) -> list[tuple[int, np.ndarray | None, np.ndarray, np.ndarray]]:
        """(kernel index, rays (n,)) sets -> (kernel index, rays (m,), t (m,), part (m,)) for the rays that pass its
        oriented box (rays None: every ray, and the kernel's padded box drops hits as brute force's does); kernels
        of one class that allow it are tested together in one batch (Kernel.batched), since here each NumPy call
        costs more than the arithmetic on a few hundred rays. any_hit: only whether a ray hits
        matters (shadow rays), which lets a mesh's own hierarchy stop at its first hit; views as for occluded().
        frames: each ray's frame; a kernel of one frame (frame_of) is given only that frame's rays of its set."""
        results, batches = [], {}
        for index, rays in sets:
            kernel = self.kernels[index]
            if frames is not None and self.frame_of[index] >= 0:
                every = rays is None
                rays = frames.select(self.frame_of[index], rays)
                if rays.size == 0:
                    continue
                if every and not isinstance(kernel, MeshKernel):  # brute force's test, on the frame's rays
                    limit = t_max.take(rays) if isinstance(t_max, np.ndarray) else t_max
                    found = self._brute_hit(index, take(O, rays), take(D, rays), t_min, limit, limit)
                    results.append((index, rays, *found))
                    continue
            if rays is None and not isinstance(kernel, MeshKernel):  # every ray, in place: brute force's test
                results.append((index, None, *self._brute_hit(index, O, D, t_min, t_max, t_max)))
                continue
            columns = rays  # a mesh's subset of the rays (None: all of them)
            if rays is None:
                rays, O_r, D_r = np.arange(ray_count(O, D)), O, D
            elif not isinstance(kernel, MeshKernel) and (not kernel.batch_attributes or kernel.frame is not None):
                O_r, D_r = take(O, rays), take(D, rays)
            limit = t_max.take(rays) if isinstance(t_max, np.ndarray) else t_max
            if isinstance(kernel, MeshKernel):  # it gathers its rays itself, once for each view's
                chosen = None if views is None else (views[0], views[1].take(rays))
                found = kernel.hit(O, D, t_min, limit, any_hit=any_hit, views=chosen, columns=columns)
                results.append((index, rays, *found))
                continue
            if not kernel.batch_attributes:
                results.append((index, rays, *kernel.hit(O_r, D_r, t_min, limit)))
                continue
            if kernel.frame is not None:
                keep = kernel.in_box(O_r, D_r, t_min, limit)
                if keep.size < rays.size:
                    rays = rays.take(keep)
                    limit = limit.take(keep) if isinstance(limit, np.ndarray) else limit
            if rays.size:  # a batch gathers its members' rays once, all together
                batches.setdefault(type(kernel), []).append((index, rays, limit))
        for members in batches.values():
            sizes = [rays.size for _, rays, _ in members]
            kernels = [self.kernels[index] for index, *_ in members]
            which = np.repeat(np.arange(len(members)), sizes)
            chosen = members[0][1] if len(members) == 1 else np.concatenate([rays for _, rays, _ in members])
            O_b, D_b = take(O, chosen), take(D, chosen)
            limit_b = _join([limit for *_, limit in members], sizes)
            if O_b.shape[1] == 1 and D_b.shape[1] == 1 and which.size > 1:  # one ray, met by several kernels
                D_b = np.repeat(D_b, which.size, axis=1)
            t, part = kernels[0].batched(kernels, which)._hit(O_b, D_b, t_min, limit_b)
            start = 0
            for (index, rays, *_), size in zip(members, sizes, strict=True):
                results.append((index, rays, t[start : start + size], part[start : start + size]))
                start += size
        return results


def _join(limits: list, sizes: list[int]) -> float | np.ndarray:
    """Per-member limits ((n,) arrays or numbers) -> one batch's: the number itself where every member shares it."""
    first = limits[0]
    if np.ndim(first) == 0 and all(limit is first for limit in limits):
        return first
    return np.concatenate([spread(np.asarray(limit), (size,)) for limit, size in zip(limits, sizes, strict=True)])
