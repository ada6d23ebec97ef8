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
- secondary rays (Wachter and Binder, Ray Tracing Gems ch. 6): start shadow and mirror rays off the surface by a
  distance that scales with the hit point's magnitude (256 units in the last place of its largest coordinate), on
  the side the ray leaves from, with t from 0, instead of fixed epsilons (0.001, 0.01) that are too large at small
  scales (light leaks) and too small at large ones (shadow acne).
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

OFFSET_ULPS = 256.0


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
        relative = self.vertices - O[None, :, :, None]  # (3 vertices, 3 axes, N, T)

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
        limit = t_max[:, None] if isinstance(t_max, np.ndarray) else t_max
        with np.errstate(divide="ignore", invalid="ignore"):
            t = T / determinant
            ok = inside & (determinant != 0.0) & (t > t_min) & (t < limit)
        t = np.where(ok, t, np.inf)
        nearest = np.argmin(t, axis=1)
        return t.min(axis=1), nearest


def make_robust_kernel(primitive: tf.WorldPrimitive, dtype: np.dtype) -> Kernel:
    if isinstance(primitive, tf.WorldSphere):
        return RobustSphereKernel(primitive, dtype)
    if isinstance(primitive, tf.WorldPlane):
        return PlaneKernel(primitive, dtype)  # its only failure, a ray in the plane's direction, is already explicit
    if isinstance(primitive, tf.WorldCylinder):
        return RobustCylinderKernel(primitive, dtype)
    return WatertightTrianglesKernel(primitive, dtype)


def offset_origins(P: np.ndarray, N: np.ndarray, toward: np.ndarray, reach: np.ndarray | None = None) -> np.ndarray:
    """Secondary-ray origins (3, n): P moved along the unit normal N, to the side of direction `toward`, by 256 ULPs
    of the largest coordinate of P (or of `reach`, the ray's origin, when that is larger)."""
    side = np.where(dot(N, toward) >= 0.0, 1.0, -1.0)
    magnitude = np.max(np.abs(P), axis=0)
    if reach is not None:
        magnitude = np.maximum(magnitude, np.max(np.abs(np.broadcast_to(reach, P.shape)), axis=0))
    distance = OFFSET_ULPS * np.spacing(np.maximum(magnitude, 1.0 / 32.0).astype(P.dtype))
    return P + N * (side * distance)
