"""One hit on a glossy surface -> its rough specular lobe, one number at a time: the per-pixel reference's side of
glossy.py (GGX of Cycles' roughness, Smith's height-correlated masking-shadowing, Heitz 2018's sampling of the
visible normals at lightsamples.glossy_pairs, Cycles' multiscatter gain; rough glass's Beckmann microfacets as
Cycles samples them), written from the formulas, not from the arrays."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..scene import scene as sc


class Tracing(Protocol):
    """What rays(), glass(), glass_light() and diffuse() need of the reference tracer: its pairs, its ray counts,
    TraceRay (path: its (pair, diffuse bounces, kind: 0 mirror, 1 glossy, 2 diffuse) triple) and FindIntensity."""

    glossy_pairs: list[tuple[float, float]]
    rays: dict[str, int]
    settings: sc.RenderSettings
    serial: int  # the camera sample being traced (camera.sample_serial)
    camera_sample: int  # its sample of the pixel: which glossy pairs a path's first glossy surface takes

    def background(self, D: sc.Vec3, solid_angle: float | None = None) -> sc.Color: ...

    def find_intensities(
        self, P: sc.Vec3, N: sc.Vec3, V: sc.Vec3, specular: float, split: dict | None = None, lobe: object = None
    ) -> tuple[list[float], list[float]]: ...

    def trace_ray(
        self,
        O: sc.Vec3,
        D: sc.Vec3,
        t_min: float,
        t_max: float,
        depth: int,
        camera: bool,
        layers: int,
        path: tuple[int, int, int],
    ) -> sc.Color: ...


REFLECTION_T_MIN = 0.01  # listing 3.1, as the reference's mirror rays

SCHLICK_MEAN = 1.0 / 21.0

# Beckmann rough glass: Cycles' constants (microfacet_beckmann_sample_vndf, bsdf_beckmann_G1, fast_erff, fast_ierff)
BECKMANN_NORMAL_INCIDENCE = 0.99999
BECKMANN_NEWTON_STEPS = 3
BECKMANN_PRECISION = 1e-6
BECKMANN_NO_SHADOW = 0.625
INV_SQRT_PI = 0.56418958354
ERF = (0.0705230784, 0.0422820123, 0.0092705272, 0.0001520143, 0.0002765672, 0.0000430638)
IERF_LIMIT = 0.99999994
IERF_CENTRAL = (2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503,
                -0.00417768164, 0.246640727, 1.50140941)  # fmt: skip
IERF_TAIL = (-0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613,
             0.00943887047, 1.00167406, 2.83297682)  # fmt: skip


def _dot(a: sc.Vec3, b: sc.Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit(a: sc.Vec3) -> sc.Vec3:
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def shadowing(lambda_v: float, lambda_l: float, separable: bool) -> float:
    """Smith's G2: height-correlated 1 / (1 + Lv + Ll), or separable 1 / ((1 + Lv)(1 + Ll))."""
    if separable:
        return 1.0 / ((1.0 + lambda_v) * (1.0 + lambda_l))
    return 1.0 / (1.0 + lambda_v + lambda_l)


def smith_lambda(cosine: float, a2: float) -> float:
    c2 = cosine * cosine
    return 0.5 * (math.sqrt(1.0 + a2 * (1.0 - c2) / c2) - 1.0)


@dataclass
class Lobe:
    """A glossy material's lobe at one hit: its frame (e1, e2, n), the unit view v in it, alpha, colour, Fresnel
    (schlick) and multiscatter gain per channel."""

    e1: sc.Vec3
    e2: sc.Vec3
    n: sc.Vec3
    v: sc.Vec3
    alpha: float
    color: sc.Color
    schlick: bool
    gain: sc.Color = (1.0, 1.0, 1.0)
    shine: sc.Color = (0.0, 0.0, 0.0)  # the lights through it (ReferenceTracer.find_intensities sets it)
    traced: bool = True  # glossy_source "traced"; else the background alone (environment())
    separable: bool = False  # glossy_shadowing "separable": G2 = G1(v) G1(l)

    def fresnel(self, cosine: float) -> sc.Color:
        if not self.schlick:
            return self.color
        grazing = (1.0 - min(max(cosine, 0.0), 1.0)) ** 5
        return tuple(c + (1.0 - c) * grazing for c in self.color)

    def sample(self, u1: float, u2: float) -> tuple[sc.Vec3, float]:
        """The reflected direction (local) for the numbers u1, u2 and its weight G2 / G1(v) (0 below the horizon)."""
        vx, vy, vz = self.v
        a = self.alpha
        m = visible_normal(self.v, a, u1, u2)
        k = 2.0 * _dot(self.v, m)
        out = (k * m[0] - vx, k * m[1] - vy, k * m[2] - vz)
        if not (out[2] > 0.0 and vz > 0.0):
            return out, 0.0
        a2 = a * a
        lambda_v = smith_lambda(vz, a2)
        return out, (1.0 + lambda_v) * shadowing(lambda_v, smith_lambda(out[2], a2), self.separable)

    def world(self, local: sc.Vec3) -> sc.Vec3:
        return tuple(local[0] * self.e1[k] + local[1] * self.e2[k] + local[2] * self.n[k] for k in range(3))

    def light(self, L: sc.Vec3) -> sc.Color:
        """pi F D G2 / (4 v.z) times the gain, for a light along L (world): glossy.light_factor."""
        length = math.sqrt(_dot(L, L))
        lz = _dot(L, self.n) / length
        vz = self.v[2]
        if not (lz > 0.0 and vz > 0.0):
            return (0.0, 0.0, 0.0)
        local = (_dot(L, self.e1) / length, _dot(L, self.e2) / length, lz)
        half = tuple(local[k] + self.v[k] for k in range(3))
        h_length = math.sqrt(_dot(half, half))
        if not h_length > 0.0:
            return (0.0, 0.0, 0.0)
        cos_h = half[2] / h_length
        a2 = self.alpha * self.alpha
        d = cos_h * cos_h * (a2 - 1.0) + 1.0
        D = a2 / (math.pi * d * d)
        G2 = shadowing(smith_lambda(vz, a2), smith_lambda(lz, a2), self.separable)
        F = self.fresnel(_dot(self.v, half) / h_length)
        shape = math.pi * D * G2 / (4.0 * vz)
        return tuple(F[c] * shape * self.gain[c] for c in range(3))


def visible_normal(v: sc.Vec3, a: float, u1: float, u2: float) -> sc.Vec3:
    """A microfacet normal among those visible from v (local, z up), Heitz 2018's sampling at u1, u2."""
    h = _unit((a * v[0], a * v[1], v[2]))
    lensq = h[0] * h[0] + h[1] * h[1]
    root = math.sqrt(lensq)
    t1 = (-h[1] / root, h[0] / root, 0.0) if lensq > 0.0 else (1.0, 0.0, 0.0)
    t2 = (h[1] * t1[2] - h[2] * t1[1], h[2] * t1[0] - h[0] * t1[2], h[0] * t1[1] - h[1] * t1[0])
    r, phi = math.sqrt(u1), 2.0 * math.pi * u2
    p1, p2 = r * math.cos(phi), r * math.sin(phi)
    s = 0.5 * (1.0 + h[2])
    p2 = (1.0 - s) * math.sqrt(1.0 - p1 * p1) + s * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    normal = tuple(p1 * t1[k] + p2 * t2[k] + p3 * h[k] for k in range(3))
    return _unit((a * normal[0], a * normal[1], max(0.0, normal[2])))


def beckmann_visible_normal(v: sc.Vec3, a: float, u1: float, u2: float) -> sc.Vec3:
    """A Beckmann microfacet normal among those visible from v (local, z up, v.z > 0) at u1, u2: the stretched view's
    slopes, the one along it by Jakob's inversion of its CDF (Newton steps within their bracket, up to 3 while the
    residual is above 1e-6, as Cycles' microfacet_beckmann_sample_vndf), the other erf^-1(2 u2 - 1); at normal
    incidence (the stretched cosine from 0.99999) both erf^-1(2u - 1)."""
    stretched = _unit((a * v[0], a * v[1], v[2]))
    cos_phi, sin_phi, tan, erf_a, exp_a2 = 1.0, 0.0, 0.0, 1.0, 0.0
    if stretched[2] < BECKMANN_NORMAL_INCIDENCE:
        sin = math.sqrt(max(0.0, 1.0 - stretched[2] * stretched[2]))
        tan, cot = sin / stretched[2], stretched[2] / sin
        erf_a, exp_a2 = erf(cot), math.exp(-cot * cot)
        cos_phi, sin_phi = stretched[0] / sin, stretched[1] / sin
    K = tan * INV_SQRT_PI
    y_approx = u1 * (1.0 + erf_a + K * (1.0 - erf_a * erf_a))
    y_exact = u1 * (1.0 + erf_a + K * exp_a2)
    b = (0.5 - math.sqrt(K * (K - y_approx + 1.0) + 0.25)) / K if K > 0.0 else y_approx - 1.0
    inverse = inverse_erf(b)
    begin, end = (-1.0, -y_exact), erf_a
    x, y = b, 1.0 + b + K * math.exp(-inverse * inverse) - y_exact
    steps = 0
    while abs(y) > BECKMANN_PRECISION and steps < BECKMANN_NEWTON_STEPS:
        steps += 1
        if math.copysign(1.0, begin[1]) * (begin[1] != 0.0) == math.copysign(1.0, y) * (y != 0.0):
            begin = (x, y)
        else:
            end = x
        newton = x - y / (1.0 - inverse * tan)
        x = newton if begin[0] <= newton <= end else 0.5 * (begin[0] + end)
        inverse = inverse_erf(x)
        y = 1.0 + x + K * math.exp(-inverse * inverse) - y_exact
    slope_x, slope_y = inverse, inverse_erf(2.0 * u2 - 1.0)
    slope_x, slope_y = cos_phi * slope_x - sin_phi * slope_y, sin_phi * slope_x + cos_phi * slope_y
    return _unit((-a * slope_x, -a * slope_y, 1.0))


def beckmann_lambda(cosine: float, a2: float) -> float:
    """Smith's Lambda of Beckmann by Walter et al. 2007's rational approximation: 0 where 1 / (alpha tan) > 1.6."""
    inverse_a = math.sqrt(a2 * max(0.0, 1.0 - cosine * cosine)) / cosine
    if inverse_a < BECKMANN_NO_SHADOW:
        return 0.0
    a = 1.0 / inverse_a
    return ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)


def erf(x: float) -> float:
    """Abramowitz and Stegun 7.1.28's erf (glossy._erf)."""
    a = abs(x)
    if a >= 12.3:
        return math.copysign(1.0, x)
    c = ERF
    r = ((((((c[5] * a + c[4]) * a + c[3]) * a + c[2]) * a + c[1]) * a + c[0]) * a) + 1.0
    s = r * r
    t = s * s
    u = t * t
    sign = 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)
    return sign * (1.0 - 1.0 / (u * u))


def inverse_erf(x: float) -> float:
    """Giles 2010's erf^-1 (glossy._inverse_erf)."""
    a = min(abs(x), IERF_LIMIT)
    w = -math.log((1.0 - a) * (1.0 + a))
    central = w < 5.0
    coefficients = IERF_CENTRAL if central else IERF_TAIL
    w = w - 2.5 if central else math.sqrt(w) - 3.0
    p = coefficients[0]
    for c in coefficients[1:]:
        p = p * w + c
    return p * x


def glass(
    tracer: Tracing,
    P: sc.Vec3,
    D: sc.Vec3,
    N: sc.Vec3,
    S: sc.Vec3,
    material: sc.Material,
    depth: int,
    layers: int,
    path: tuple[int, int, int],
) -> sc.Color:
    """What the lights add through a rough glass hit (glass_light) and, while depth lasts, what its sampled rays
    (glass_rays) bring back, before its glass share a t, at the rotation of the tracer's camera sample and this depth
    (camera.glass_rotation). The reason for 9 parameters: the tracer, the hit and the ray's state as trace_ray carries
    them."""
    light = glass_light(tracer, P, D, N, S, material, depth)
    if depth <= 0:
        return light
    rotation = cam.glass_rotation(tracer.settings.seed, tracer.serial, depth)
    first = lightsamples.shared_pairs(tracer.settings, len(tracer.glossy_pairs), tracer.camera_sample)
    rays = [ray[:3] for ray in glass_rays(tracer.glossy_pairs, D, N, S, material, path, rotation, first)]
    seen = traced(tracer, P, rays, depth, layers)
    return (light[0] + seen[0], light[1] + seen[1], light[2] + seen[2])


@dataclass
class GlassLobe:
    """Rough glass at one hit as the lights see it (glossy.Glass): its frame (e1, e2, n), n the shading normal facing
    the viewer, the unit view v in it, eta, alpha, masking-shadowing and distribution, its multiscatter gain, the
    colour that tints what it refracts, and which sides count ("both", "reflected", "refracted"); shine: what the
    lights add through it (ReferenceTracer.find_intensities sets it)."""

    e1: sc.Vec3
    e2: sc.Vec3
    n: sc.Vec3
    v: sc.Vec3
    eta: float
    alpha: float
    separable: bool
    beckmann: bool
    gain: float
    tint: sc.Color
    sides: str = "both"
    shine: sc.Color = (0.0, 0.0, 0.0)
    traced: bool = True

    def light(self, L: sc.Vec3, reflected: bool = True, refracted: bool = True) -> sc.Color:
        """glossy.glass_light_factor for a light along L (world), the refracted part times the tint; reflected,
        refracted: whether the light adds off the glass (its Glossy visibility) and through it (Transmission)."""
        length = math.sqrt(_dot(L, L))
        toward = (_dot(L, self.e1) / length, _dot(L, self.e2) / length, _dot(L, self.n) / length)
        v, eta, a2 = self.v, self.eta, self.alpha * self.alpha
        above = toward[2] > 0.0
        scale = 1.0 if above else eta
        m = tuple(v[k] + scale * toward[k] for k in range(3))
        m_length = math.sqrt(_dot(m, m))
        if (
            not (v[2] > 0.0 and m_length > 0.0)
            or toward[2] == 0.0
            or self.sides == ("refracted" if above else "reflected")
            or not (reflected if above else refracted)
        ):
            return (0.0, 0.0, 0.0)
        up = (-1.0 if m[2] < 0.0 else 1.0) / m_length
        m = (m[0] * up, m[1] * up, m[2] * up)
        c, lm = _dot(v, m), _dot(toward, m)
        if not (m[2] > 0.0 and c > 0.0):
            return (0.0, 0.0, 0.0)
        g2 = eta * eta - 1.0 + c * c
        F = 1.0
        if g2 > 0.0:
            g = math.sqrt(g2)
            A, B = (g - c) / (g + c), (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
            F = 0.5 * A * A * (1.0 + B * B)
        cos2 = m[2] * m[2]
        if self.beckmann:
            D = math.exp(-(1.0 - cos2) / (cos2 * a2)) / (math.pi * a2 * cos2 * cos2)
        else:
            d = cos2 * (a2 - 1.0) + 1.0
            D = a2 / (math.pi * d * d)
        lambda_of = beckmann_lambda if self.beckmann else smith_lambda
        G2 = shadowing(lambda_of(v[2], a2), lambda_of(abs(toward[2]), a2), self.separable)
        if above:
            value = F * (math.pi * D * G2 / (4.0 * v[2])) * self.gain
            return (value, value, value)
        denominator = c + eta * lm
        if not (lm < 0.0 and g2 > 0.0 and denominator != 0.0):
            return (0.0, 0.0, 0.0)
        value = (1.0 - F) * math.pi * D * G2 * c * (eta * eta) * -lm / (v[2] * denominator * denominator) * self.gain
        return tuple(value * t for t in self.tint)


def through_lobe(lobe: Lobe | GlassLobe | None, light: sc.Light, L: sc.Vec3) -> sc.Color | None:
    """What a light along L adds through a hit's lobe (glossy, or rough glass's) per unit of its intensity; None for
    no lobe, a lobe not traced, the world's directions, or where the light's ray visibility leaves it out: its Glossy
    visibility the light off a lobe or the glass, its Transmission visibility the light through the glass."""
    if lobe is None or not lobe.traced or isinstance(light, sc.WorldLight):
        return None
    glossy, transmission = getattr(light, "visible_glossy", True), getattr(light, "visible_transmission", True)
    if isinstance(lobe, GlassLobe):
        return lobe.light(L, glossy, transmission) if glossy or transmission else None
    return lobe.light(L) if glossy else None


def glass_lobe(
    pairs: list[tuple[float, float]],
    D: sc.Vec3,
    N: sc.Vec3,
    S: sc.Vec3,
    material: sc.Material,
    rotation: tuple[float, float],
    sides: str = "both",
) -> GlassLobe:
    """The rough glass hit met along D (geometric normal N, shading normal S) as the lights see it, its gain at the
    rotation's pairs (glass_rays')."""
    d = _unit(D)
    n = _unit(S if _dot(S, d) < 0.0 else (-S[0], -S[1], -S[2]))
    eta = material.ior if _dot(N, d) < 0.0 else 1.0 / material.ior
    e1, e2 = lightsamples.facing_basis(n)
    v = (-_dot(d, e1), -_dot(d, e2), -_dot(d, n))
    a = material.transmission_roughness * material.transmission_roughness
    separable = material.glossy_shadowing == "separable"
    beckmann = material.transmission_distribution == "beckmann"
    gain = _glass_gain(pairs, v, eta, a, material, rotation)
    return GlassLobe(e1, e2, n, v, eta, a, separable, beckmann, gain, material.color, sides)


def _glass_gain(
    pairs: list[tuple[float, float]], v: sc.Vec3, eta: float, a: float, material: sc.Material, rotation: tuple
) -> float:
    """Multiscatter glass's gain 1 / E, E both weights' mean over every pair at the rotation; 1 otherwise."""
    if material.glossy_energy != "multiscatter" or not v[2] > 0.0:
        return 1.0
    separable = material.glossy_shadowing == "separable"
    beckmann = material.transmission_distribution == "beckmann"
    turned = [(rotated(u1, rotation[0]), rotated(u2, rotation[1])) for u1, u2 in pairs]
    splits = [_glass_split(v, eta, a, u1, u2, separable, beckmann) for u1, u2 in turned]
    albedo = sum(weight_r + weight_t for _, _, weight_r, weight_t in splits) / len(pairs)
    return 1.0 / albedo if albedo > 0.0 else 1.0


def glass_light(
    tracer: Tracing, P: sc.Vec3, D: sc.Vec3, N: sc.Vec3, S: sc.Vec3, material: sc.Material, depth: int, sides="both"
) -> sc.Color:
    """What the lights (not ambient, not the world's directions) add through a rough glass hit's microfacets, per
    unit of its glass share, at the rotation of the tracer's camera sample and this depth (shading.glass_light);
    sides: "both", or the "reflected" or "refracted" part alone. The reason for 8 parameters: glass()'s."""
    rotation = cam.glass_rotation(tracer.settings.seed, tracer.serial, depth)
    lobe = glass_lobe(tracer.glossy_pairs, D, N, S, material, rotation, sides)
    tracer.find_intensities(P, S, (-D[0], -D[1], -D[2]), 0.0, None, lobe)
    return lobe.shine


def glass_rays(
    pairs: list[tuple[float, float]],
    D: sc.Vec3,
    N: sc.Vec3,
    S: sc.Vec3,
    material: sc.Material,
    path: tuple,
    rotation: tuple[float, float],
    first: tuple[range, float],
) -> list[tuple[sc.Vec3, sc.Color, tuple[int, int, int], bool]]:
    """A rough glass hit's rays (glossy.glass_rays, one ray at a time): per pair (at a path's first glossy surface
    the pairs the camera sample takes and their share, first: lightsamples.shared_pairs; else the path's) turned by
    the hit's rotation (rotated), a visible microfacet normal m about S turned to face D, a reflected ray of weight
    F G2 / G1(v) and a refracted one of (1 - F) G2 / G1(v) times the colour -> (direction, weight, path, refracted)
    each (they do not see the lights: the lights through the glass are its GlassLobe's)."""
    d = _unit(D)
    n = _unit(S if _dot(S, d) < 0.0 else (-S[0], -S[1], -S[2]))
    eta = material.ior if _dot(N, d) < 0.0 else 1.0 / material.ior
    e1, e2 = lightsamples.facing_basis(n)
    v = (-_dot(d, e1), -_dot(d, e2), -_dot(d, n))
    if not v[2] > 0.0:
        return []
    a = material.transmission_roughness * material.transmission_roughness
    chosen, share = first if path[0] < 0 else ((path[0],), 1.0)
    separable = material.glossy_shadowing == "separable"
    beckmann = material.transmission_distribution == "beckmann"
    turned = [(rotated(u1, rotation[0]), rotated(u2, rotation[1])) for u1, u2 in pairs]
    splits = [_glass_split(v, eta, a, u1, u2, separable, beckmann) for u1, u2 in turned]
    gain = _glass_gain(pairs, v, eta, a, material, rotation)
    made = []
    for index in chosen:
        reflected, T, weight_r, weight_t = splits[index]
        for direction, weight, tint, bent in ((reflected, weight_r, (1.0, 1.0, 1.0), False),
                                              (T, weight_t, material.color, True)):  # fmt: skip
            weight = weight * share * gain
            if weight > 0.0:
                world = tuple(direction[0] * e1[k] + direction[1] * e2[k] + direction[2] * n[k] for k in range(3))
                made.append((world, tuple(weight * c for c in tint), (index, path[1], 1), bent))  # 1: sees no light
    return made


def rotated(u: float, offset: float) -> float:
    """A sample number u in [0, 1) moved by offset in [0, 1), wrapped (Cranley-Patterson; glossy.rotated)."""
    moved = u + offset
    return moved - 1.0 if moved >= 1.0 else moved


def traced(tracer: Tracing, P: sc.Vec3, rays: list[tuple], depth: int, layers: int) -> sc.Color:
    """The sum of each ray's weight times what it brings back: rays (direction, weight, path) from P, each a
    reflection ray of one bounce less."""
    out = [0.0, 0.0, 0.0]
    for direction, weight, path in rays:
        tracer.rays["reflection"] += 1
        seen = tracer.trace_ray(P, direction, REFLECTION_T_MIN, math.inf, depth - 1, False, layers, path)
        out = [out[k] + weight[k] * seen[k] for k in range(3)]
    return tuple(out)


def _glass_split(
    v: sc.Vec3, eta: float, a: float, u1: float, u2: float, separable: bool, beckmann: bool
) -> tuple[sc.Vec3, sc.Vec3, float, float]:
    """The reflected and refracted local directions at the numbers u1, u2 and their weights F G2 / G1(v) and
    (1 - F) G2 / G1(v) (0 on the wrong side, or refracted in total internal reflection), of GGX or Beckmann."""
    a2 = a * a
    lambda_of = beckmann_lambda if beckmann else smith_lambda
    lambda_v = lambda_of(v[2], a2)
    m = beckmann_visible_normal(v, a, u1, u2) if beckmann else visible_normal(v, a, u1, u2)
    c = _dot(v, m)
    g2 = eta * eta - 1.0 + c * c
    F, g = 1.0, 1.0
    if g2 > 0.0:
        g = math.sqrt(g2)
        A, B = (g - c) / (g + c), (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
        F = 0.5 * A * A * (1.0 + B * B)
    reflected = tuple(2.0 * c * m[k] - v[k] for k in range(3))
    weight_r = 0.0
    if reflected[2] > 0.0:
        weight_r = F * shadowing(lambda_v, lambda_of(reflected[2], a2), separable) * (1.0 + lambda_v)
    T, weight_t = (0.0, 0.0, -1.0), 0.0
    if g2 > 0.0:
        T = _unit(tuple((-v[k] + (c - g) * m[k]) / eta for k in range(3)))
        if T[2] < 0.0:
            weight_t = (1.0 - F) * shadowing(lambda_v, lambda_of(-T[2], a2), separable) * (1.0 + lambda_v)
    return reflected, T, weight_r, weight_t


def lobe_at(material: sc.Material, S: sc.Vec3, V: sc.Vec3, pairs: list[tuple[float, float]]) -> Lobe:
    """The material's lobe at a hit of shading normal S seen from V (toward the viewer), its multiscatter gain 1 +
    F_avg (1 - E) / E from E, the mean weight of its samples at the pairs."""
    n = _unit(S)
    e1, e2 = lightsamples.facing_basis(n)
    u = _unit(V)
    v = (_dot(u, e1), _dot(u, e2), _dot(u, n))
    lobe = Lobe(e1, e2, n, v, material.roughness * material.roughness, material.glossy,
                material.glossy_fresnel == "schlick")  # fmt: skip
    lobe.separable = material.glossy_shadowing == "separable"
    if material.glossy_energy == "multiscatter" and v[2] > 0.0:
        albedo = sum(lobe.sample(u1, u2)[1] for u1, u2 in pairs) / len(pairs)
        if albedo > 0.0:
            mean = [c + (1.0 - c) * SCHLICK_MEAN if lobe.schlick else c for c in lobe.color]
            lobe.gain = tuple(1.0 + f * ((1.0 - albedo) / albedo) for f in mean)
    return lobe


def environment(lobe: Lobe, pairs: list[tuple[float, float]], tracer: Tracing) -> sc.Color:
    """A lobe of glossy_source "world": the mean over the pairs the tracer's camera sample takes
    (lightsamples.shared_pairs) of F G2 / G1(v) times tracer.background(direction, solid angle) along each sampled
    direction (nothing traced; a picture blurred to the solid angle the sample stands for, 1 / (pairs pdf),
    pdf = G1(v) D(h) / (4 v.z) of the visible normals' sampling), times the gain."""
    total = [0.0, 0.0, 0.0]
    if lobe.v[2] <= 0.0:
        return (0.0, 0.0, 0.0)
    a2 = lobe.alpha * lobe.alpha
    taken, _ = lightsamples.shared_pairs(tracer.settings, len(pairs), tracer.camera_sample)
    for u1, u2 in (pairs[index] for index in taken):
        local, weight = lobe.sample(u1, u2)
        if not weight > 0.0:
            continue
        half = tuple(local[k] + lobe.v[k] for k in range(3))
        h_length = math.sqrt(_dot(half, half))
        F = lobe.fresnel(_dot(lobe.v, half) / h_length if h_length > 0.0 else 0.0)
        cos_h = (local[2] + lobe.v[2]) / (h_length if h_length > 0.0 else 1.0)
        d = cos_h * cos_h * (a2 - 1.0) + 1.0
        density = a2 / (math.pi * d * d) / (4.0 * lobe.v[2] * (1.0 + smith_lambda(lobe.v[2], a2)))
        sky = tracer.background(lobe.world(local), 1.0 / (len(pairs) * density) if density > 0.0 else math.inf)
        total = [total[c] + F[c] * weight * sky[c] for c in range(3)]
    return tuple(total[c] / len(taken) * lobe.gain[c] for c in range(3))


def ray(lobe: Lobe, u1: float, u2: float, share: float) -> tuple[sc.Vec3, sc.Color] | None:
    """One reflection ray of the lobe: its world direction and weight F G2 / G1(v) times the gain and share (the
    hit's 1 / rays); None where the weight is 0."""
    local, weight = lobe.sample(u1, u2)
    if not weight > 0.0:
        return None
    half = tuple(local[k] + lobe.v[k] for k in range(3))
    h_length = math.sqrt(_dot(half, half))
    F = lobe.fresnel(_dot(lobe.v, half) / h_length if h_length > 0.0 else 0.0)
    value = tuple(F[c] * (weight * share) * lobe.gain[c] for c in range(3))
    if not any(c > 0.0 for c in value):
        return None
    return lobe.world(local), value


def rays(
    tracer: Tracing,
    P: sc.Vec3,
    V: sc.Vec3,
    S: sc.Vec3,
    material: sc.Material,
    depth: int,
    layers: int,
    path: tuple[int, int, int],
    lobe: Lobe | None = None,
) -> sc.Color:
    """What a glossy lobe's reflection rays (lobe_rays) bring back. The reason for 9 parameters: the tracer, the hit
    and the ray's state as trace_ray carries them."""
    if lobe is None:
        lobe = lobe_at(material, S, V, tracer.glossy_pairs)
    first = lightsamples.shared_pairs(tracer.settings, len(tracer.glossy_pairs), tracer.camera_sample)
    return traced(tracer, P, lobe_rays(lobe, tracer.glossy_pairs, path, first), depth, layers)


def lobe_rays(lobe: Lobe, pairs: list[tuple[float, float]], path: tuple, first: tuple[range, float]) -> list[tuple]:
    """A glossy lobe's reflection rays: at a path's first glossy surface (its pair -1) the pairs the camera sample
    takes and their share (first: lightsamples.shared_pairs), each ray then carrying its pair, else the path's pair
    alone (ray()'s weights) -> (direction, weight, path) each (glossy rays: they see no lights)."""
    if lobe.v[2] <= 0.0:
        return []
    chosen, share = first if path[0] < 0 else ((path[0],), 1.0)
    made = []
    for index in chosen:
        found = ray(lobe, *pairs[index], share)
        if found is not None:
            made.append((*found, (index, path[1], 1)))
    return made


def diffuse(
    tracer: Tracing,
    P: sc.Vec3,
    V: sc.Vec3,
    S: sc.Vec3,
    albedo: sc.Color,
    depth: int,
    layers: int,
    path: tuple[int, int, int],
) -> sc.Color:
    """What a hit's diffuse bounce rays (bounce_rays) bring back. The reason for 8 parameters: the tracer, the hit and
    the ray's state as trace_ray carries them."""
    if depth <= 0:
        return (0.0, 0.0, 0.0)
    first = lightsamples.shared_pairs(tracer.settings, len(tracer.glossy_pairs), tracer.camera_sample)
    return traced(tracer, P, bounce_rays(tracer.glossy_pairs, V, S, albedo, path, first), depth, layers)


def bounce_rays(
    pairs: list[tuple[float, float]], V: sc.Vec3, S: sc.Vec3, albedo: sc.Color, path: tuple, first: tuple[range, float]
) -> list:
    """A hit's diffuse bounce rays (glossy.diffuse_rays, one ray at a time): per pair (those the camera sample takes
    at a path's first glossy surface or bounce, first as lobe_rays takes it, else the path's), the cosine-weighted
    direction about S turned toward V, weighted by the albedo times the pair's share -> (direction, weight, path)
    each, diffuse rays of the next bounce."""
    if not any(c > 0.0 for c in albedo):
        return []
    n = _unit(S if _dot(S, V) >= 0.0 else (-S[0], -S[1], -S[2]))
    e1, e2 = lightsamples.facing_basis(n)
    chosen, share = first if path[0] < 0 else ((path[0],), 1.0)
    made = []
    for index in chosen:
        u1, u2 = pairs[index]
        r, phi = math.sqrt(u1), 2.0 * math.pi * u2
        local = (r * math.cos(phi), r * math.sin(phi), math.sqrt(1.0 - u1))
        direction = tuple(local[0] * e1[k] + local[1] * e2[k] + local[2] * n[k] for k in range(3))
        made.append((direction, tuple(c * share for c in albedo), (index, path[1] + 1, 2)))
    return made
