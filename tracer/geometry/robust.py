"""The robust numerics beside the documented ones: stable quadratics, watertight triangles, normal-offset origins.

`render.numerics = "robust"` swaps these in; the documented mode stays exactly the seed's (fixed t epsilons, the
textbook quadratic, Moller-Trumbore). Each fixes one way the documented numerics fail:

- spheres and cylinder sides (Haines et al., Ray Tracing Gems ch. 7): the discriminant from the perpendicular
  distance of the centre to the ray, a (r^2 - |f_perp|^2), instead of b^2 - 4ac, which cancels catastrophically for a
  small sphere far away; the roots as q / a and c / q with q = b' + sign(b') sqrt(discriminant), so the smaller root
  is not the difference of two nearly equal numbers. A ray along a cylinder's axis meets no side, by an explicit test.
- triangles (Woop, Benthin and Wald 2013): the watertight test, which shears the triangle into the ray's space and
  decides each edge by a sign that neighbouring triangles share, so a ray through a shared edge or vertex hits one of
  them; Moller-Trumbore's independent u, v tests can let it through both.
- secondary rays (after Pharr, Jakob and Humphreys, Physically Based Rendering, "Managing Rounding Error"): each
  hit point is first put back onto its primitive's surface along the normal (the primitive's own signed distance),
  then pushed off it, to the side the ray leaves from, by a bound on the rounding of that primitive's own test:
  OFFSET_EPSILONS units of the dtype's epsilon times the largest magnitude the test subtracts (a sphere's radius,
  a cylinder's radius + height, a plane's or triangle's coordinates) or the point's own. From there the
  primitive's test decides the origin's side correctly, so a ray leaving a surface cannot meet it again at t near
  0, at any size or distance from the world origin; t is then searched from 0. The documented mode's fixed
  epsilons (0.001, 0.01) are too large at small scales (light leaks) and too small at large ones (shadow acne); an
  offset from the hit point's magnitude alone misses the rounding of a large primitive's own test
  (c = |O - C|^2 - R^2 rounds at ULP(R^2)).
"""

from __future__ import annotations

import numpy as np

from . import transforms as tf
from .kernels import (
    CylinderKernel,
    Kernel,
    PlaneKernel,
    SphereKernel,
    TrianglesKernel,
    _nearest,
    _plane_t,
    dot,
    ray_count,
)

# How far off its surface a secondary ray starts, in epsilons of the magnitude its primitive's test subtracts (the
# radius for a sphere, radius + height for a cylinder, the coordinates of a plane's point or a triangle's vertices)
# or of the hit point's own coordinates, whichever is larger. A sphere's c = |O - C|^2 - R^2 carries about 5 u R^2
# of roundoff (u = eps / 2) against a true 2 R d at a distance d, and putting the point back on the surface adds
# about 3 u R: d > 3 eps R is needed. Measured (tests/test_stability.py, rays leaving a convex surface in every
# direction down to 1e-6 of grazing in float64 and 1e-4 in float32): 2 eps is enough for every primitive (the
# triangles' watertight test included), size and position. 4 is above both; a larger offset would only let light
# through gaps narrower than it.
OFFSET_EPSILONS = 4.0


def _stable_roots(
    a: np.ndarray, half_b: np.ndarray, f_perp: np.ndarray, D_perp: np.ndarray, c: np.ndarray, radius_squared: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both roots of a t^2 - 2 half_b t + c = 0 with the discriminant taken from the perpendicular distance.

    half_b is b' = -(f . D), f_perp the offset of the origin from the centre (or axis) and D_perp the direction, both
    perpendicular to the axis for a cylinder. Returns (real, t0, t1)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        closest = f_perp + D_perp * (half_b / a)
        discriminant = a * (radius_squared - dot(closest, closest))
        real = (discriminant >= 0.0) & (a > 0.0)
        q = half_b + np.where(half_b >= 0.0, 1.0, -1.0) * np.sqrt(np.where(real, discriminant, 0.0))
        t0 = np.where(q != 0.0, c / q, 0.0)
        t1 = q / a
    return real, t0, t1


class RobustSphereKernel(SphereKernel):
    def __init__(self, sphere: tf.WorldSphere, dtype: np.dtype) -> None:
        super().__init__(sphere, dtype)
        self.radius = dtype.type(sphere.radius)
        self.scale = sphere.radius  # f = O - C is exact to u |f|, so the centre's own magnitude does not count

    def surface(self, P: np.ndarray, part: np.ndarray) -> tuple[np.ndarray, np.ndarray | float]:
        """Signed distances (n,) of points P (3, n) from the surface along the outward unit normal, and the
        magnitude that bounds the rounding of this primitive's test (a number or (n,))."""
        f = P - self.center
        return np.sqrt(dot(f, f)) - self.radius, self.scale

    def _hit(self, O, D, t_min, t_max):
        f = O - self.center
        a = dot(D, D)
        half_b = -dot(f, D)
        c = dot(f, f) - self.radius_squared
        real, t0, t1 = _stable_roots(a, half_b, f, D, c, self.radius_squared)
        best_t = np.full(ray_count(O, D), np.inf, dtype=self.dtype)
        best_part = np.zeros(best_t.shape, dtype=np.int8)
        for t in (t0, t1):
            _nearest(best_t, best_part, t, real & (t > t_min) & (t < t_max), 0)
        return best_t, best_part


class RobustCylinderKernel(CylinderKernel):
    def __init__(self, cylinder: tf.WorldCylinder, dtype: np.dtype) -> None:
        super().__init__(cylinder, dtype)
        self.radius = dtype.type(cylinder.radius)
        self.scale = cylinder.height + cylinder.radius  # as a sphere's: the largest |O - base| near the surface

    def surface(self, P, part):
        h = dot(P - self.base, self.axis)
        side = P - (self.base + self.axis * h)
        side_distance = np.sqrt(dot(side, side)) - self.radius
        bottom_distance = -h
        top_distance = h - self.height
        return np.where(part == 0, side_distance, np.where(part == 1, bottom_distance, top_distance)), self.scale

    def _hit(self, O, D, t_min, t_max):
        f = O - self.base
        DV = dot(D, self.axis)
        fV = dot(f, self.axis)
        D_perp = D - self.axis * DV
        f_perp = f - self.axis * fV
        a = dot(D_perp, D_perp)
        # a ray along the axis has no side hit (only caps): decided explicitly, not by a tiny a
        along_axis = a <= dot(D, D) * np.finfo(self.dtype).eps * 16.0
        a = np.where(along_axis, 0.0, a)
        half_b = -dot(f_perp, D_perp)
        c = dot(f_perp, f_perp) - self.radius_squared
        real, t0, t1 = _stable_roots(a, half_b, f_perp, D_perp, c, self.radius_squared)
        best_t = np.full(ray_count(O, D), np.inf, dtype=self.dtype)
        best_part = np.zeros(best_t.shape, dtype=np.int8)
        for t in (t0, t1):
            h = fV + DV * t
            _nearest(best_t, best_part, t, real & (h >= 0.0) & (h <= self.height) & (t > t_min) & (t < t_max), 0)
        for part, normal, centre in self.caps:
            t, ok = _plane_t(O, D, normal, centre)
            ok &= (t > t_min) & (t < t_max)
            offset = O + D * np.where(ok, t, 0.0) - centre
            _nearest(best_t, best_part, t, ok & (dot(offset, offset) <= self.radius_squared), part)
        return best_t, best_part


class WatertightTrianglesKernel(TrianglesKernel):
    """Woop et al. 2013, without back-face culling, over all triangles of a mesh at once."""

    def __init__(self, mesh: tf.WorldTriangles, dtype: np.dtype) -> None:
        super().__init__(mesh, dtype)
        triangles = np.asarray(mesh.triangles, dtype=dtype)  # (T, 3 vertices, 3)
        self.vertices = np.transpose(triangles, (1, 2, 0))[:, :, None, :]  # (3 vertices, 3 axes, 1, T)
        self.scales = np.abs(np.asarray(mesh.triangles, dtype=np.float64)).max(axis=(1, 2)).astype(dtype)  # (T,)

    def surface(self, P, part):
        corner = self.v0[:, :, 0].take(part, axis=1)  # each point's triangle's first vertex (3, n)
        return dot(self.unit_normals.take(part, axis=1), P - corner), self.scales.take(part)

    CHUNK = 4096  # rays per pass: the test holds (3 vertices, 3 axes, rays, triangles) arrays

    def _hit(self, O, D, t_min, t_max):
        count = ray_count(O, D)
        D = np.broadcast_to(D, (3, count))
        O = np.broadcast_to(O, (3, count))
        if count <= self.CHUNK:
            return self._hit_chunk(O, D, t_min, t_max)
        parts = []
        for start in range(0, count, self.CHUNK):
            stop = min(start + self.CHUNK, count)
            limit = t_max[start:stop] if isinstance(t_max, np.ndarray) else t_max
            parts.append(self._hit_chunk(O[:, start:stop], D[:, start:stop], t_min, limit))
        return np.concatenate([t for t, _ in parts]), np.concatenate([part for _, part in parts])

    def _hit_chunk(self, O, D, t_min, t_max):
        limit = t_max[:, None] if isinstance(t_max, np.ndarray) else t_max
        t = _watertight_t(O, D, self.vertices, t_min, limit)  # (N, T)
        nearest = np.argmin(t, axis=1)
        return t.min(axis=1), nearest

    def pack(self, triangles: np.ndarray) -> np.ndarray:
        """Triangle indices (L, K) -> their vertices (9 = 3 vertices x 3 axes, L, K), for packed_t."""
        return self.vertices[:, :, 0, :].take(triangles, axis=2).reshape(9, *triangles.shape)

    def packed_t(self, O: np.ndarray, D: np.ndarray, packed: np.ndarray, t_min: float) -> np.ndarray:
        """Rays (3, P), each against its own triangles packed (9, P, K) -> t (P, K), inf where there is no hit:
        the same operations as _hit, so the same t for the same ray and triangle."""
        return _watertight_t(O, D, packed.reshape(3, 3, *packed.shape[1:]), t_min, np.inf)


def _watertight_t(O: np.ndarray, D: np.ndarray, vertices: np.ndarray, t_min: float, limit) -> np.ndarray:
    """Woop et al.'s test of rays (3, N) against triangles (3 vertices, 3 axes, 1 or N, T) -> t (N, T), inf where
    there is no hit in (t_min, limit)."""
    # the ray's dominant axis becomes z, kept right-handed
    kz = np.argmax(np.abs(D), axis=0)
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    flip = np.take_along_axis(D, kz[None], axis=0)[0] < 0.0
    kx, ky = np.where(flip, ky, kx), np.where(flip, kx, ky)

    def component(array: np.ndarray, axis: np.ndarray) -> np.ndarray:
        return np.take_along_axis(array, axis[None], axis=0)[0]

    Dz = component(D, kz)
    Sx, Sy, Sz = component(D, kx) / Dz, component(D, ky) / Dz, 1.0 / Dz
    relative = vertices - O[None, :, :, None]  # (3 vertices, 3 axes, N, T)

    def sheared(vertex: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        v = relative[vertex]
        vz = np.take_along_axis(v, kz[None, :, None], axis=0)[0]
        vx = np.take_along_axis(v, kx[None, :, None], axis=0)[0] - Sx[:, None] * vz
        vy = np.take_along_axis(v, ky[None, :, None], axis=0)[0] - Sy[:, None] * vz
        return vx, vy, vz

    (Ax, Ay, Az), (Bx, By, Bz), (Cx, Cy, Cz) = sheared(0), sheared(1), sheared(2)
    U = Cx * By - Cy * Bx
    V = Ax * Cy - Ay * Cx
    W = Bx * Ay - By * Ax
    inside = ~(((U < 0.0) | (V < 0.0) | (W < 0.0)) & ((U > 0.0) | (V > 0.0) | (W > 0.0)))
    determinant = U + V + W
    T = (U * Az + V * Bz + W * Cz) * Sz[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = T / determinant
        ok = inside & (determinant != 0.0) & (t > t_min) & (t < limit)
    return np.where(ok, t, np.inf)


class RobustPlaneKernel(PlaneKernel):
    """The documented plane test: its one failure, a ray in the plane's direction, is already explicit."""

    def __init__(self, plane: tf.WorldPlane, dtype: np.dtype) -> None:
        super().__init__(plane, dtype)
        self.scale = float(np.max(np.abs(plane.point)))

    def surface(self, P, part):
        return dot(self.unit, P - self.point), self.scale


def make_robust_kernel(primitive: tf.WorldPrimitive, dtype: np.dtype) -> Kernel:
    if isinstance(primitive, tf.WorldSphere):
        return RobustSphereKernel(primitive, dtype)
    if isinstance(primitive, tf.WorldPlane):
        return RobustPlaneKernel(primitive, dtype)
    if isinstance(primitive, tf.WorldCylinder):
        return RobustCylinderKernel(primitive, dtype)
    return WatertightTrianglesKernel(primitive, dtype)


def offset_origins(
    P: np.ndarray, N: np.ndarray, toward: np.ndarray, distance: np.ndarray, scale: np.ndarray
) -> np.ndarray:
    """Secondary-ray origins (3, n) for hit points P (3, n) with outward unit normals N (3, n).

    distance (n,): each point's signed distance from its surface along N; scale (n,): the magnitude that bounds the
    rounding of its primitive's test. The point goes back onto the surface and then off it, to the side of the
    direction `toward` (3, n or 1), by OFFSET_EPSILONS epsilons of the larger of scale and the point's own
    largest coordinate."""
    side = np.where(dot(N, toward) >= 0.0, P.dtype.type(1.0), P.dtype.type(-1.0))
    magnitude = np.maximum(np.max(np.abs(P), axis=0), scale)
    offset = (OFFSET_EPSILONS * np.finfo(P.dtype).eps) * magnitude
    return P + N * (side * offset - distance)
