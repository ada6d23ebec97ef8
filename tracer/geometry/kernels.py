"""World-space primitives -> vectorized ray kernels: closest hit, any hit and normals over arrays of rays.

Rays are (3, N) arrays of origins O and directions D (rows x, y, z). Each kernel performs the seed's formulas with
the same operations in the same order as reference.py, so a ray's result matches the per-pixel oracle bit for bit
or to the last unit; the array code only adds culling that cannot change which surfaces are hit.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from . import transforms as tf

# ---- small vector helpers on (3, N) arrays (explicit sums keep the reference's operation order) -------------------


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, N) . (3, N) or (3, 1) -> (N,)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit(vectors: np.ndarray) -> np.ndarray:
    """(3, N) -> the same divided by their lengths, as the reference normalises a normal."""
    return vectors / np.sqrt(dot(vectors, vectors))


def interpolated_corners(
    w: np.ndarray, e1: np.ndarray, e2: np.ndarray, n0: np.ndarray, n1: np.ndarray, n2: np.ndarray
) -> np.ndarray:
    """Corner normals n0, n1, n2 (3, n) weighted by the barycentric coordinates (1 - u - v, u, v) of points at w = P -
    v0 (3, n) in triangles of edges e1, e2 (3, n), not normalised: the reference's operations, in its order."""
    d00, d01, d11 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    d20, d21 = dot(w, e1), dot(w, e2)
    denominator = d00 * d11 - d01 * d01
    u = (d11 * d20 - d01 * d21) / denominator
    v = (d00 * d21 - d01 * d20) / denominator
    s = 1.0 - u - v
    return n0 * s + n1 * u + n2 * v


def unit_or(vectors: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """(3, n) vectors normalised, fallback (3, n) where one is zero (opposite corner normals can cancel)."""
    size = np.sqrt(dot(vectors, vectors))
    good = size > 0.0
    return np.where(good, vectors / np.where(good, size, 1.0), fallback)


def take(rays: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The columns keep (an index array) of a (3, N) ray array.

    A (3, 1) array stands for a vector shared by every ray (the camera's origin, a directional light's vector) and
    is returned as it is, to keep broadcasting; for a real single ray that is the same answer, and an empty keep
    gives (3, 0) either way. Index arrays and np.take throughout: here NumPy gathers by a boolean mask about ten
    times slower. The indices come from nonzero() or a take of such, so always in range: the wrap mode skips the
    default mode's bounds check and its error path (a 640x480 frame about 3% faster here, the same bytes)."""
    if rays.shape[1] == 1 and keep.size:
        return rays
    return rays.take(keep, axis=1, mode="wrap")


def spread(array: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """np.broadcast_to(array, shape), or the array itself where it has that shape already: broadcast_to costs about
    10 us a call here, and in most of a frame's calls it would change nothing."""
    return array if array.shape == shape else np.broadcast_to(array, shape)


def indices(mask: np.ndarray) -> np.ndarray:
    """The positions (n,) where a 1-D mask is true (np.flatnonzero without its wrapper's overhead)."""
    return mask.nonzero()[0]


# Rays that are parallel to a slab or a plane divide by zero and compare NaNs by design: the kernels run inside
# quiet() (entered once per query by the hierarchy, not around each NumPy call: it costs microseconds each time).
def quiet() -> np.errstate:
    return np.errstate(divide="ignore", invalid="ignore", over="ignore")


def ray_count(O: np.ndarray, D: np.ndarray) -> int:
    """How many rays (3, N) origins and directions describe when one of them may be a shared (3, 1) column."""
    return D.shape[1] if O.shape[1] == 1 else O.shape[1]


def column(v: tf.sc.Vec3, dtype: np.dtype) -> np.ndarray:
    """A 3-vector as a (3, 1) column that broadcasts against (3, N) rays."""
    return np.asarray(v, dtype=dtype).reshape(3, 1)


def padded_box(
    lower: np.ndarray, upper: np.ndarray, dtype: np.dtype, reach: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """A box grown by a margin far above the rounding of the slab test, as (3, 1) columns in dtype.

    reach: the largest coordinate magnitude the test subtracts (the box's own, or its frame's origin's)."""
    size = float(np.max(np.abs(np.concatenate((lower, upper)))) + np.max(upper - lower)) + reach
    pad = box_margin(size, dtype)
    return (lower - pad).astype(dtype).reshape(3, 1), (upper + pad).astype(dtype).reshape(3, 1)


def column_bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) -> their least and greatest coordinates (3,) each, a column at a time (a reduction along the
    points' axis of an (n, 3) array runs an inner loop of 3 per point: ten times slower at a million triangles)."""
    return (
        np.array([points[:, axis].min() for axis in range(3)]),
        np.array([points[:, axis].max() for axis in range(3)]),
    )


def _local_bounds(points: np.ndarray, rotation: np.ndarray, location: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) -> the least and greatest of R^T (p - location) (3,) each, one of the object's axes at a time
    (a million triangles' corners in one (3n, 3) product were 144 MB more at a worker's peak)."""
    lower, upper = np.empty(3), np.empty(3)
    for j in range(3):
        local = (points[:, 0] - location[0]) * rotation[0, j]
        local += (points[:, 1] - location[1]) * rotation[1, j]
        local += (points[:, 2] - location[2]) * rotation[2, j]
        lower[j], upper[j] = local.min(), local.max()
    return lower, upper


def box_margin(size, dtype: np.dtype):
    """padded_box's margin for a box of size (its largest coordinate magnitude plus its longest side): a number, or
    one per box (n,) where size is an array."""
    relative = 1e-6 if dtype == np.float64 else 1e-4
    return relative * size + 1e-9


BOX_PIECE = 1 << 16  # rays per piece of an oriented box test (Kernel.in_box)
# (triangle, ray) pairs per pass of a small mesh's test of all its triangles (TrianglesKernel._hit): a band's
# millions of shadow rays against a 12-triangle cube made each of the test's temporaries hundreds of MB (a glass
# cube under an area light at Shadows 16, 480x270: 3.9 GB peak, half the time in page faults)
TRIANGLE_PAIRS = 1 << 18


def slab(O: np.ndarray, inverse: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit t of rays (3, n) through a box; an axis giving NaN (0 * inf) is ignored, so nothing is lost."""
    a = (lower - O) * inverse
    b = (upper - O) * inverse
    low = np.fmin(a, b)
    high = np.fmax(a, b, out=a)
    near = np.fmax(low[0], low[1])
    np.fmax(near, low[2], out=near)
    far = np.fmin(high[0], high[1])
    np.fmin(far, high[2], out=far)
    return near, far


def origins_exponent(O: np.ndarray) -> int:
    """The least e with every origin (3, n) within 2**e of 0 in each coordinate, for grown_float32's bound (a few
    sizes serve all of a frame's rays, so the grown boxes can be kept)."""
    return math.frexp(float(np.abs(O).max()) if O.size else 0.0)[1]


GROWN_KEPT = 2  # grown box sets a kernel keeps (kept_grown): the camera's reach and the scene's


def kept_grown(kept: dict[int, tuple], O: np.ndarray, reach: float, make) -> tuple:
    """The float32 boxes make(bound) gives (grown_float32 of a kernel's boxes) for rays whose origins (3, n) lie within
    2**e of 0 (e = origins_exponent(O), bound = 2**e + reach, reach the boxes' own), made once per e and kept in kept,
    the last GROWN_KEPT of them (a frame's rays need one or two)."""
    exponent = origins_exponent(O)
    found = kept.get(exponent)
    if found is None:
        found = make(2.0**exponent + reach)
        if len(kept) >= GROWN_KEPT:
            kept.pop(next(iter(kept)))
        kept[exponent] = found
    return found


def grown_float32(lower: np.ndarray, upper: np.ndarray, bound: float) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (lower, upper, any shape) -> float32 boxes around them for a float32 slab test that meets every box
    the float64 test meets, for rays whose origins and the boxes lie within bound of 0 in each coordinate.

    Error bound: the float32 test computes t = fl(fl(l - o) inv) with o and inv rounded to float32, which is the
    exact t of a face moved by at most 2^-24 |o| + 3.01 2^-24 (|l| + |o|) < 2^-21 bound. Each box grown by 2^-21
    bound and rounded outward is therefore entered no later and left no earlier than the float64 test finds (itself
    within 2^-51 of exact), and an axis that a zero direction component makes NaN or infinite is at most as strict.
    A walk on them visits every node the float64 walk visits, maybe a few more; exact tests below find the same hits.
    """
    grow = bound * 2.0**-21
    return (
        np.nextafter((lower - grow).astype(np.float32), np.float32(-np.inf)),
        np.nextafter((upper + grow).astype(np.float32), np.float32(np.inf)),
    )


def _unlimited(t_max: float | np.ndarray) -> bool:
    """Whether t_max is the single number +inf (no upper limit)."""
    return np.ndim(t_max) == 0 and t_max == np.inf


def _nearest(best_t: np.ndarray, best_part: np.ndarray, t: np.ndarray, ok: np.ndarray, part: int) -> None:
    """Keep t where it is valid and strictly nearer (the reference's `t < closest_t`, first candidate on ties)."""
    closer = ok & (t < best_t)
    np.copyto(best_t, t, where=closer)
    np.copyto(best_part, part, where=closer)


class Kernel:
    """A primitive ready for tracing. hit() returns (t, part) with t = inf where the ray misses in (t_min, t_max).

    A kernel with a frame first drops the rays that miss its oriented box (the object's own axes, tighter than the
    world box of a rotated object) and runs its exact test on the rest only.
    """

    dtype: np.dtype
    cost = 8.0  # a hit test's cost in box tests, for the hierarchy's surface area heuristic
    frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None  # world->local, origin, lower, upper

    def set_frame(self, rotation: np.ndarray, origin: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        """rotation (3, 3) has the local axes as columns; lower, upper (3,) bound the object in that frame.

        Every such kernel keeps its frame, even where the oriented box is no smaller than the world box: rays that
        reach a kernel through the culls' sets (cull.py) have met no box test yet."""
        padded = padded_box(lower, upper, self.dtype, float(np.max(np.abs(origin))))
        self.frame = (rotation.T.astype(self.dtype), origin.astype(self.dtype).reshape(3, 1), *padded)

    def hit(
        self, O: np.ndarray, D: np.ndarray, t_min: float, t_max: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rays (3, N) -> (t (N,), part (N,)); t_max is one number or one per ray. Call inside quiet()."""
        if self.frame is None:
            return self._hit(O, D, t_min, t_max)
        count = ray_count(O, D)
        rays = self.in_box(O, D, t_min, t_max)
        if rays.size == count:
            return self._hit(O, D, t_min, t_max)
        t = np.full(count, np.inf, dtype=self.dtype)
        part = np.zeros(count, dtype=np.int32)
        if rays.size:
            limit = t_max.take(rays) if isinstance(t_max, np.ndarray) else t_max
            found_t, found_part = self._hit(take(O, rays), take(D, rays), t_min, limit)
            t[rays] = found_t
            part[rays] = found_part
        return t, part

    def in_box(self, O: np.ndarray, D: np.ndarray, t_min: float, t_max: float | np.ndarray) -> np.ndarray:
        """Indices (n,) of the rays (3, N) that meet the oriented box within (t_min, t_max); needs a frame. In pieces
        of BOX_PIECE rays: a few passes over arrays of a band's shadow rays (millions) outgrow the caches."""
        count = ray_count(O, D)
        if count > BOX_PIECE:
            found = []
            for start in range(0, count, BOX_PIECE):
                piece = slice(start, start + BOX_PIECE)
                O_p, D_p = (O if O.shape[1] == 1 else O[:, piece]), (D if D.shape[1] == 1 else D[:, piece])
                limit = t_max[piece] if np.ndim(t_max) else t_max
                found.append(start + self.in_box(O_p, D_p, t_min, limit))
            return np.concatenate(found)
        to_local, origin, lower, upper = self.frame
        near, far = slab(to_local @ (O - origin), 1.0 / (to_local @ D), lower, upper)
        return indices(spread((near <= far) & (far > t_min) & (near < t_max), (count,)))

    # Per-object parameters of a kernel class whose _hit works unchanged when each is given per ray ((3, N) for a
    # column, (N,) for a number): several objects of that class are then tested in one batch of NumPy calls.
    batch_attributes: tuple[str, ...] = ()

    def batched(self, members: list[Kernel], which: np.ndarray) -> Kernel:
        """A stand-in for members (kernels of this class) whose ray i takes the parameters of members[which[i]].

        Each ray then meets the same operations on the same numbers as in its own kernel, so the results are the
        same; only the NumPy calls are shared."""
        proxy = copy.copy(self)
        proxy.frame = None
        for name in self.batch_attributes:
            values = [getattr(member, name) for member in members]
            if np.ndim(values[0]) == 2:  # a (3, 1) column
                setattr(proxy, name, np.concatenate(values, axis=1).take(which, axis=1))
            else:
                setattr(proxy, name, np.asarray(values, dtype=self.dtype).take(which))
        return proxy

    def _hit(self, O: np.ndarray, D: np.ndarray, t_min: float, t_max: float) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def normal(self, P: np.ndarray, part: np.ndarray) -> np.ndarray:
        """Unnormalised normals (3, N) at hit points P (3, N) of the given parts."""
        raise NotImplementedError

    def unit_normal(self, P: np.ndarray, part: np.ndarray) -> np.ndarray:
        """Unit normals (3, N): normal() divided by its length (kernels with fixed normals divide them once)."""
        return unit(self.normal(P, part))

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """World axis-aligned box (lower (3,), upper (3,)) float64, or None for an unbounded surface."""
        return None


def shared_terms(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A sphere test's terms that depend on the rays' directions (3, N) alone: 4 k1 and 2 k1 (N,), k1 = D.D."""
    k1 = dot(D, D)
    return 4.0 * k1, 2.0 * k1


class SphereKernel(Kernel):
    cost = 6.0
    batch_attributes = ("center", "radius_squared")

    def __init__(self, sphere: tf.WorldSphere, dtype: np.dtype) -> None:
        self.center = column(sphere.center, dtype)
        self.radius_squared = dtype.type(sphere.radius) * dtype.type(sphere.radius)
        self.dtype = dtype
        self.lower = np.asarray(sphere.center) - sphere.radius
        self.upper = np.asarray(sphere.center) + sphere.radius

    def bounds(self):
        return self.lower, self.upper

    def _roots(self, O, D, shared):
        """The listing's roots (-k2 +- root) / (2 k1) as (-k2, root, 2 k1) (N,) each; a negative discriminant gives
        a NaN root, which no comparison accepts (the listing's "no real root")."""
        four_k1, twice_k1 = shared_terms(D) if shared is None else shared
        CO = O - self.center
        k2 = 2.0 * dot(CO, D)
        k3 = dot(CO, CO) - self.radius_squared
        discriminant = k2 * k2 - four_k1 * k3
        return -k2, np.sqrt(discriminant), twice_k1

    def _hit(self, O, D, t_min, t_max, shared=None):
        """shared: shared_terms(D), when several spheres test the same rays (the same numbers, computed once)."""
        # the roots as _nearest would keep them, in fewer passes: the first root fills the empty best (inf stays
        # inf), the second replaces it where strictly nearer; with no upper limit t < t_max is left out (an
        # infinite t is never nearer than best); the part is always 0
        minus_k2, root, twice_k1 = self._roots(O, D, shared)
        t = (minus_k2 + root) / twice_k1
        ok = t > t_min
        if not _unlimited(t_max):
            ok &= t < t_max
        best_t = np.where(ok, t, np.inf).astype(self.dtype, copy=False)
        t = (minus_k2 - root) / twice_k1
        ok = t > t_min
        if not _unlimited(t_max):
            ok &= t < t_max
        ok &= t < best_t
        np.copyto(best_t, t, where=ok)
        return best_t, np.zeros(best_t.shape, dtype=np.int8)

    def blocks(self, O, D, t_min, t_max, shared=None) -> np.ndarray:
        """Whether either root lies in (t_min, t_max), bool (N,): _hit's t < inf, without choosing the nearer
        root (an infinite root counts as none, as in _hit)."""
        minus_k2, root, twice_k1 = self._roots(O, D, shared)
        upper = np.inf if _unlimited(t_max) else t_max
        t = (minus_k2 + root) / twice_k1
        blocked = (t > t_min) & (t < upper)
        t = (minus_k2 - root) / twice_k1
        blocked |= (t > t_min) & (t < upper)
        return blocked

    def normal(self, P, part):
        return P - self.center


def sparse_terms(vector: np.ndarray) -> tuple[tuple[int, np.generic], ...]:
    """The nonzero components of a (3, 1) column as (axis, value) pairs, for sparse_dot."""
    return tuple((axis, vector[axis, 0]) for axis in range(3) if vector[axis, 0] != 0.0)


def sparse_dot(terms: tuple[tuple[int, np.generic], ...], X: np.ndarray) -> np.ndarray:
    """dot(vector, X) (3, N) -> (N,) over the vector's nonzero components only (an axis-aligned normal: one term).

    The same value as dot(), since x + 0 = x and 1 * x = x exactly for finite x, except that a zero result may
    differ in sign; where it is used that cannot show (t = -0 or +0 both fail t > t_min >= 0, and a zero
    denominator is a parallel ray either way)."""
    result = None
    for axis, value in terms:
        term = X[axis] if np.ndim(value) == 0 and value == 1.0 else X[axis] * value
        result = term if result is None else result + term
    return result


def sparse_dot_difference(terms: tuple[tuple[int, np.generic], ...], point: np.ndarray, O: np.ndarray) -> np.ndarray:
    """sparse_dot(terms, point - O) for a (3, 1) point and (3, N) or (3, 1) origins, subtracting only the components
    that it reads: the same values, without the other rows' passes."""
    result = None
    for axis, value in terms:
        difference = point[axis] - O[axis]
        term = difference if np.ndim(value) == 0 and value == 1.0 else difference * value
        result = term if result is None else result + term
    return result


def _plane_t(
    O: np.ndarray, D: np.ndarray, normal: tuple[tuple[int, np.generic], ...], point: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Seed 2.17 for every ray: (t, not parallel); t is junk where the ray is parallel to the plane.

    normal: the plane normal's sparse_terms."""
    denominator = sparse_dot(normal, D)
    t = sparse_dot_difference(normal, point, O) / denominator
    parallel = denominator != 0.0
    return t, parallel if parallel.shape == t.shape else np.broadcast_to(parallel, t.shape).copy()


class PlaneKernel(Kernel):
    def __init__(self, plane: tf.WorldPlane, dtype: np.dtype) -> None:
        self.point = column(plane.point, dtype)
        self.plane_normal = column(plane.normal, dtype)
        self.normal_terms = sparse_terms(self.plane_normal)
        self.unit = unit(self.plane_normal)  # the same operations per ray would give the same numbers
        self.u_axis = column(plane.u_axis, dtype)
        self.v_axis = column(plane.v_axis, dtype)
        self.u_terms, self.v_terms = sparse_terms(self.u_axis), sparse_terms(self.v_axis)
        self.half_size = plane.half_size
        self.dtype = dtype
        self.box = None
        if plane.half_size is not None:
            corners = [
                tf.add(
                    plane.point,
                    tf.add(
                        tf.scale(plane.u_axis, su * plane.half_size[0]), tf.scale(plane.v_axis, sv * plane.half_size[1])
                    ),
                )
                for su in (-1.0, 1.0)
                for sv in (-1.0, 1.0)
            ]
            self.box = (np.min(corners, axis=0), np.max(corners, axis=0))

    def bounds(self):
        return self.box

    def _hit(self, O, D, t_min, t_max):
        # as few passes over the rays as can be: every ray meets the ground plane's test. Only the components of
        # point - O that the normal uses are subtracted; and a parallel ray's t (a zero denominator: +-inf or NaN)
        # fails t > t_min >= 0 or t < t_max <= inf by itself, so it needs no test of its own
        t = sparse_dot_difference(self.normal_terms, self.point, O) / sparse_dot(self.normal_terms, D)
        ok = (t > t_min) & (t < t_max)
        if self.half_size is not None:
            rays = indices(ok)
            t_rays = t.take(rays)
            offset = {}  # (O + D t - point) along the axes that u and v use
            for axis in {axis for axis, _ in self.u_terms + self.v_terms}:
                origin = O[axis] if O.shape[1] == 1 else O[axis].take(rays)
                direction = D[axis] if D.shape[1] == 1 else D[axis].take(rays)
                offset[axis] = origin + direction * t_rays - self.point[axis]
            outside = (np.abs(sparse_dot(self.u_terms, offset)) > self.half_size[0]) | (
                np.abs(sparse_dot(self.v_terms, offset)) > self.half_size[1]
            )
            ok[rays.take(indices(outside))] = False
        return np.where(ok, t, self.dtype.type(np.inf)), np.zeros(ok.shape, dtype=np.int8)

    def normal(self, P, part):
        return np.broadcast_to(self.plane_normal, P.shape)

    def unit_normal(self, P, part):
        return np.broadcast_to(self.unit, P.shape)


class CylinderKernel(Kernel):
    """Parts: 0 side, 1 bottom cap (normal -V), 2 top cap (normal +V)."""

    cost = 10.0
    batch_attributes = ("base", "axis", "down", "top", "radius_squared", "height")

    def batched(self, members: list[Kernel], which: np.ndarray) -> Kernel:
        proxy = super().batched(members, which)
        # per-ray axes: every component is kept (for one kernel, zero components are skipped: the same values)
        dense = lambda column: tuple(enumerate(column))  # noqa: E731
        proxy.caps = ((1, dense(proxy.down), proxy.base), (2, dense(proxy.axis), proxy.top))
        return proxy

    def __init__(self, cylinder: tf.WorldCylinder, dtype: np.dtype) -> None:
        self.base = column(cylinder.base, dtype)
        self.axis = column(cylinder.axis, dtype)
        self.down = column(tuple(-x for x in cylinder.axis), dtype)
        self.top = column(tf.add(cylinder.base, tf.scale(cylinder.axis, cylinder.height)), dtype)
        self.caps = ((1, sparse_terms(self.down), self.base), (2, sparse_terms(self.axis), self.top))
        self.height = cylinder.height
        self.radius_squared = dtype.type(cylinder.radius) * dtype.type(cylinder.radius)
        self.dtype = dtype
        ends = np.asarray([cylinder.base, tf.add(cylinder.base, tf.scale(cylinder.axis, cylinder.height))])
        # a disc of radius r about unit axis a reaches r * sqrt(1 - a_i^2) along world axis i
        reach = cylinder.radius * np.sqrt(np.maximum(0.0, 1.0 - np.asarray(cylinder.axis) ** 2))
        self.lower, self.upper = ends.min(axis=0) - reach, ends.max(axis=0) + reach
        axis = np.asarray(cylinder.axis)
        helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
        u = np.cross(axis, helper)
        u /= np.linalg.norm(u)
        r = cylinder.radius
        self.set_frame(
            np.column_stack((u, np.cross(axis, u), axis)),
            np.asarray(cylinder.base),
            np.array([-r, -r, 0.0]),
            np.array([r, r, cylinder.height]),
        )

    def bounds(self):
        return self.lower, self.upper

    def _hit(self, O, D, t_min, t_max):
        CO = O - self.base
        DV = dot(D, self.axis)
        COV = dot(CO, self.axis)
        a = dot(D, D) - DV * DV
        b = 2.0 * (dot(CO, D) - COV * DV)
        k = dot(CO, CO) - COV * COV - self.radius_squared
        discriminant = b * b - 4.0 * a * k
        side = (a != 0.0) & (discriminant >= 0.0)
        root = np.sqrt(np.where(side, discriminant, 0.0))
        denominator = np.where(side, 2.0 * a, 1.0)
        best_t = np.full(ray_count(O, D), np.inf, dtype=self.dtype)
        best_part = np.zeros(best_t.shape, dtype=np.int8)
        in_range = lambda t: (t > t_min) & (t < t_max)  # noqa: E731
        for t in ((-b + root) / denominator, (-b - root) / denominator):
            h = COV + DV * t
            _nearest(best_t, best_part, t, side & (h >= 0.0) & (h <= self.height) & in_range(t), 0)
        for part, normal, centre in self.caps:
            t, ok = _plane_t(O, D, normal, centre)
            ok &= in_range(t)
            offset = O + D * np.where(ok, t, 0.0) - centre
            _nearest(best_t, best_part, t, ok & (dot(offset, offset) <= self.radius_squared), part)
        return best_t, best_part

    def normal(self, P, part):
        h = dot(P - self.base, self.axis)
        side = P - (self.base + self.axis * h)
        return np.where(part == 0, side, np.where(part == 1, self.down, self.axis))


def moller_trumbore(
    O: tuple[np.ndarray, ...], D: tuple[np.ndarray, ...], v0, e1, e2, t_min: float
) -> tuple[np.ndarray, np.ndarray]:
    """Seed 2.29 on components that broadcast together (rays' x, y, z against triangles' v0, e1 = v1 - v0 and
    e2 = v2 - v0): t, and whether the ray meets the triangle with t > t_min. cross() and dot() written out per
    component: the reference's operations in its order, without stacking temporaries into (3, ...) ones."""
    (ox, oy, oz), (dx, dy, dz), (ax, ay, az), (bx, by, bz), (cx, cy, cz) = O, D, v0, e1, e2
    tx, ty, tz = ox - ax, oy - ay, oz - az  # T = O - v0
    px, py, pz = dy * cz - dz * cy, dz * cx - dx * cz, dx * cy - dy * cx  # P = D x e2
    qx, qy, qz = ty * bz - tz * by, tz * bx - tx * bz, tx * by - ty * bx  # Q = T x e1
    determinant = px * bx + py * by + pz * bz
    t = (qx * cx + qy * cy + qz * cz) / determinant
    u = (px * tx + py * ty + pz * tz) / determinant
    v = (qx * dx + qy * dy + qz * dz) / determinant
    ok = determinant != 0.0
    ok &= u >= 0.0
    ok &= v >= 0.0
    ok &= u + v <= 1.0
    ok &= t > t_min
    return t, ok


class TrianglesKernel(Kernel):
    """Moller-Trumbore (seed 2.29) over all triangles of a mesh at once, first triangle on ties."""

    def __init__(self, mesh: tf.WorldTriangles, dtype: np.dtype) -> None:
        triangles = np.asarray(mesh.triangles, dtype=np.float64)  # (T, 3 vertices, 3)
        # edges in float64, as the reference subtracts them, then in the tracing dtype; (3, T, 1): broadcasts against
        # rays as (3, 1, N), so that NumPy's inner loops run along the rays
        self.v0 = np.ascontiguousarray(triangles[:, 0].T, dtype=dtype)[:, :, None]
        self.e1 = np.ascontiguousarray((triangles[:, 1] - triangles[:, 0]).T, dtype=dtype)[:, :, None]
        self.e2 = np.ascontiguousarray((triangles[:, 2] - triangles[:, 0]).T, dtype=dtype)[:, :, None]
        self.normals = np.asarray(mesh.normals, dtype=dtype).T  # (3, T)
        self.unit_normals = unit(self.normals)
        self.cost = 3.0 + len(mesh.triangles)
        self.lower, self.upper = column_bounds(triangles.reshape(-1, 3))
        self.dtype = dtype
        rotation, location = np.asarray(mesh.rotation), np.asarray(mesh.location)
        self.set_frame(rotation, location, *_local_bounds(triangles.reshape(-1, 3), rotation, location))

    def bounds(self):
        return self.lower, self.upper

    def _hit(self, O, D, t_min, t_max):
        count = ray_count(O, D)
        piece = max(1, TRIANGLE_PAIRS // self.v0.shape[1])
        if count > piece:  # each ray's answer is its own: the same numbers in pieces
            found = [
                self._hit(
                    O if O.shape[1] == 1 else O[:, start : start + piece],
                    D if D.shape[1] == 1 else D[:, start : start + piece],
                    t_min,
                    t_max[start : start + piece] if isinstance(t_max, np.ndarray) else t_max,
                )
                for start in range(0, count, piece)
            ]
            return np.concatenate([t for t, _ in found]), np.concatenate([part for _, part in found])
        # (T, N): (T, 1) triangles broadcast against (1, N) rays, so that NumPy's inner loops run along the rays
        t, ok = moller_trumbore(
            (O[0][None], O[1][None], O[2][None]), (D[0][None], D[1][None], D[2][None]), self.v0, self.e1, self.e2, t_min
        )
        ok &= t < (t_max[None, :] if isinstance(t_max, np.ndarray) else t_max)
        t = spread(np.where(ok, t, np.inf), (t.shape[0], ray_count(O, D)))
        nearest = np.argmin(t, axis=0)  # first triangle on ties, as the reference's loop
        return t.min(axis=0), nearest

    def pack(self, triangles: np.ndarray) -> np.ndarray:
        """Triangle indices (L, K) -> their v0, e1, e2 components (9, L, K) in the tracing dtype, for packed_t (a
        take along axis 1 then gives each component's (P, K) contiguous). Filled in place: no second copy at the
        peak of a large mesh's preparation."""
        packed = np.empty((9, *triangles.shape), dtype=self.dtype)
        components = [array[axis, :, 0] for array in (self.v0, self.e1, self.e2) for axis in range(3)]
        for row, component in zip(packed, components, strict=True):
            component.take(triangles, out=row)
        return packed

    def packed_t(self, O: np.ndarray, D: np.ndarray, packed: np.ndarray, t_min: float) -> np.ndarray:
        """Rays (3, P), each against its own triangles packed (9, P, K) -> t (P, K), inf where the test fails or
        t <= t_min: the operations of _hit, so the same t for the same ray and triangle."""
        rays = (O[0][:, None], O[1][:, None], O[2][:, None]), (D[0][:, None], D[1][:, None], D[2][:, None])  # (P, 1)
        t, ok = moller_trumbore(*rays, packed[0:3], packed[3:6], packed[6:9], t_min)
        return np.where(ok, t, np.inf)

    def normal(self, P, part):
        return self.normals[:, part]

    def unit_normal(self, P, part):
        return self.unit_normals.take(part, axis=1)


def make_kernel(primitive: tf.WorldPrimitive, dtype: np.dtype) -> Kernel:
    if isinstance(primitive, tf.WorldSphere):
        return SphereKernel(primitive, dtype)
    if isinstance(primitive, tf.WorldPlane):
        return PlaneKernel(primitive, dtype)
    if isinstance(primitive, tf.WorldCylinder):
        return CylinderKernel(primitive, dtype)
    return TrianglesKernel(primitive, dtype)
