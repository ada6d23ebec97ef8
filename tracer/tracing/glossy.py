"""A wavefront's hits on glossy surfaces, rough glass and diffuse bounces -> their sampled lobes over arrays: GGX
microfacets of Cycles' roughness (alpha = roughness^2, Smith's height-correlated or separable masking-shadowing),
the lights' terms through a glossy lobe (or the world's alone, untraced), the reflection rays it sends, rough
glass's reflected and refracted rays (GGX, or Beckmann as Cycles samples it), and diffuse bounces' cosine-weighted
rays (Heitz 2018's sampling of the visible normals, at the fixed stratified pairs of lightsamples.glossy_pairs,
rough glass's turned by a rotation of each camera sample and depth). docs/algorithm.md, "Glossy reflection" and
"Diffuse bounces"; the per-pixel reference (reference_glossy.py) does the same one hit at a time."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import lightsamples
from ..geometry.kernels import indices, take
from . import surfaces
from .batch import Hits
from .lights import facing_basis, x_y_z_squared
from .prepared import PreparedScene

SCHLICK_MEAN = 1.0 / 21.0  # the hemispherical mean of (1 - cos)^5 weighted by the cosine: Schlick's F_avg

# Beckmann rough glass (_beckmann_visible_normal, _beckmann_lambda): Cycles' constants; the reference has the same
BECKMANN_NORMAL_INCIDENCE = 0.99999  # a stretched view's cosine from which its slopes are those of normal incidence
BECKMANN_NEWTON_STEPS = 3
BECKMANN_PRECISION = 1e-6
BECKMANN_NO_SHADOW = 0.625  # 1 / (alpha tan) above 1.6: Lambda 0
INV_SQRT_PI = 0.56418958354
ERF = (0.0705230784, 0.0422820123, 0.0092705272, 0.0001520143, 0.0002765672, 0.0000430638)
IERF_LIMIT = 0.99999994
IERF_CENTRAL = (
    2.81022636e-08, 3.43273939e-07, -3.5233877e-06, -4.39150654e-06, 0.00021858087, -0.00125372503, -0.00417768164,
    0.246640727, 1.50140941,
)  # fmt: skip
IERF_TAIL = (
    -0.000200214257, 0.000100950558, 0.00134934322, -0.00367342844, 0.00573950773, -0.0076224613, 0.00943887047,
    1.00167406, 2.83297682,
)  # fmt: skip


@dataclass
class Lobes:
    """The glossy lobes of some hits (k of them), float64 in each point's frame (z along the shading normal).

    rows (k,): which hits; e1, e2, n (3, k): the frame; v (3, k): toward the viewer, local and unit; alpha (k,);
    color (3, k): the lobe's colour (F0 under Schlick's Fresnel); schlick (k,) bool; boost (3, k): the multiscatter
    gain 1 + F_avg (1 - E) / E (ones for single scattering), E the lobe's albedo along v estimated from its samples;
    facing (k,) bool: the viewer is above the shading normal's horizon (else the lobe adds nothing); traced (k,)
    bool: the lobe takes the lights and sends rays (else it reflects the background alone, environment()); light
    (3, k): what the lights (or the background) add through the lobes (shading.find_intensity sets it)."""

    rows: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    n: np.ndarray
    v: np.ndarray
    alpha: np.ndarray
    color: np.ndarray
    schlick: np.ndarray
    boost: np.ndarray
    facing: np.ndarray
    traced: np.ndarray
    separable: np.ndarray | bool = False  # (k,): Smith's separable masking-shadowing (glossy_shadowing)
    light: np.ndarray | None = None
    multiscatter: np.ndarray | None = None  # (k,) bool: the lobe's energy is multiscatter
    sampled: tuple[np.ndarray, np.ndarray] | None = None  # samples() at every pair: (3, m, k) and (m, k)

    def take(self, keep: np.ndarray) -> Lobes:
        """The lobes keep (j,) of these (their light left out)."""
        return Lobes(
            self.rows.take(keep),
            *(take(array, keep) for array in (self.e1, self.e2, self.n, self.v)),
            self.alpha.take(keep),
            take(self.color, keep),
            self.schlick.take(keep),
            take(self.boost, keep),
            self.facing.take(keep),
            self.traced.take(keep),
            self.separable if np.ndim(self.separable) == 0 else self.separable.take(keep),
            None,
            None if self.multiscatter is None else self.multiscatter.take(keep),
            None if self.sampled is None else (self.sampled[0][:, :, keep], self.sampled[1][:, keep]),
        )


def lobes_at(scene: PreparedScene, hits: Hits) -> Lobes | None:
    """The lobes of the hits whose material is glossy, None where none is."""
    rows = indices(scene.glossy_rows.take(hits.material))
    if not rows.size:
        return None
    material = hits.material.take(rows)
    S = np.asarray(take(hits.S, rows), dtype=np.float64)
    n = S / np.sqrt(x_y_z_squared(S))
    e1, e2 = facing_basis(n)
    V = np.asarray(take(hits.V, rows), dtype=np.float64)
    V = V / np.sqrt(x_y_z_squared(V))
    v = np.stack((_dot(V, e1), _dot(V, e2), _dot(V, n)))
    roughness = scene.roughness.take(material).astype(np.float64)
    alpha = roughness * roughness
    color = scene.glossy.take(material, axis=1).astype(np.float64)
    schlick = scene.glossy_schlick.take(material)
    facing = v[2] > 0.0
    traced = scene.glossy_traced.take(material)
    separable = scene.glossy_separable.take(material)
    lobes = Lobes(rows, e1, e2, n, v, alpha, color, schlick, np.ones_like(color), facing, traced, separable)
    lobes.multiscatter = scene.glossy_multiscatter.take(material)
    if (lobes.multiscatter & traced).any():  # the lobes of the world alone: environment() at its own pairs
        ones = lobes.take(indices(traced))
        ones.multiscatter = lobes.multiscatter.take(indices(traced))
        lobes.boost[:, indices(traced)] = _boost(ones, scene.glossy_pairs)
    return lobes


def _boost(lobes: Lobes, pairs: np.ndarray) -> np.ndarray:
    """The lobes' multiscatter gain (3, k) from their samples at the pairs (m, 2), kept in lobes.sampled: 1 + F_avg
    (1 - E) / E, E the mean weight (the albedo along v); 1 for single scattering or E = 0."""
    lobes.sampled = samples(lobes, pairs[:, :1], pairs[:, 1:])
    albedo = lobes.sampled[1].mean(axis=0)
    mean_fresnel = np.where(lobes.schlick, lobes.color + (1.0 - lobes.color) * SCHLICK_MEAN, lobes.color)
    gain = 1.0 + mean_fresnel * ((1.0 - albedo) / np.where(albedo > 0.0, albedo, 1.0))
    return np.where(lobes.multiscatter & (albedo > 0.0), gain, 1.0)


def light_factor(lobes: Lobes, L: np.ndarray) -> np.ndarray:
    """What the lobes reflect toward the viewer of a light along L (3, k) (world, any length), per unit of the
    light's intensity as the diffuse term counts it: pi F D G2 / (4 v.z) times the boost (3, k); 0 below either
    horizon. (Cycles' diffuse is the albedo / pi: the tracer's intensity is the irradiance / pi.)"""
    L = np.asarray(L, dtype=np.float64)
    length = np.sqrt(x_y_z_squared(L))
    lx, ly, lz = _dot(L, lobes.e1) / length, _dot(L, lobes.e2) / length, _dot(L, lobes.n) / length
    vx, vy, vz = lobes.v
    hx, hy, hz = lx + vx, ly + vy, lz + vz
    h_length = np.sqrt(hx * hx + hy * hy + hz * hz)
    above = (lz > 0.0) & lobes.facing & (h_length > 0.0)
    safe = np.where(h_length > 0.0, h_length, 1.0)
    cos_h = hz / safe
    a2 = lobes.alpha * lobes.alpha
    d = cos_h * cos_h * (a2 - 1.0) + 1.0
    D = a2 / (math.pi * d * d)
    lambda_v = _smith_lambda(np.where(lobes.facing, vz, 1.0), a2)
    G2 = _shadowing(lambda_v, _smith_lambda(np.where(above, lz, 1.0), a2), lobes.separable)
    VH = (vx * hx + vy * hy + vz * hz) / safe
    F = fresnel(lobes, VH)
    value = F * (math.pi * D * G2 / (4.0 * np.where(lobes.facing, vz, 1.0))) * lobes.boost
    return np.where(above, value, 0.0)


def samples(lobes: Lobes, u1: np.ndarray, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lobes' reflected directions for the numbers u1, u2 in [0, 1) ((k,), or (m, 1) for m pairs at every
    lobe) -> local directions (3, ...) and the estimator's weights G2 / G1(v) (...) (0 below the horizon, and where
    the viewer is), by sampling the visible normals (Heitz 2018, "Sampling the GGX distribution of visible
    normals")."""
    vx, vy, vz = lobes.v
    alpha = lobes.alpha
    mx, my, mz = _visible_normal(vx, vy, vz, alpha, u1, u2)
    k = 2.0 * (vx * mx + vy * my + vz * mz)
    lx, ly, lz = k * mx - vx, k * my - vy, k * mz - vz
    a2 = alpha * alpha
    above = (lz > 0.0) & lobes.facing
    lambda_v = _smith_lambda(np.where(lobes.facing, vz, 1.0), a2)
    weight = (1.0 + lambda_v) * _shadowing(lambda_v, _smith_lambda(np.where(above, lz, 1.0), a2), lobes.separable)
    return np.stack((lx, ly, lz)), np.where(above, weight, 0.0)


def sample_rays(
    scene: PreparedScene, lobes: Lobes, chosen: np.ndarray, keys: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The reflection rays of the lobes: at a hit whose chosen (k,) is -1 (a path's first glossy surface) the pairs
    of scene.glossy_pairs its camera sample takes (keys (k,): their sharing keys, lightsamples.shared_pairs), the
    chosen pair alone elsewhere -> the rays' lobes (j,) (indices into the lobes), their pairs (j,), unit world
    directions (3, j) and weights (3, j): F G2 / G1(v) times the boost, times the pair's share; only rays of weight
    > 0."""
    pairs = scene.glossy_pairs
    count = len(pairs)
    fresh = chosen < 0
    lobe, pair, every = _ray_pairs(chosen, count, keys, lightsamples.world_share(scene.scene.render, count))
    one = lobes.take(lobe)
    directions, weight = samples(one, pairs[:, 0].take(pair), pairs[:, 1].take(pair))
    lx, ly, lz = directions
    D = lx * one.e1 + ly * one.e2 + lz * one.n
    vx, vy, vz = one.v
    hx, hy, hz = lx + vx, ly + vy, lz + vz
    h_length = np.sqrt(hx * hx + hy * hy + hz * hz)
    VH = (vx * hx + vy * hy + vz * hz) / np.where(h_length > 0.0, h_length, 1.0)
    share = np.where(fresh.take(lobe), every, 1.0)
    value = fresnel(one, VH) * (weight * share) * one.boost
    keep = indices((weight > 0.0) & np.any(value > 0.0, axis=0))
    return lobe.take(keep), pair.take(keep), take(D, keep), take(value, keep)


def environment(scene: PreparedScene, lobes: Lobes, keys: np.ndarray) -> np.ndarray:
    """What lobes of glossy_source "world" reflect of the background (3, k): the mean over the scene.world_pairs their
    camera samples take (keys (k,): their sharing keys; the pairs p = key mod g + g t, lightsamples.shared_pairs) of
    F G2 / G1(v) times the background along each sampled direction (no ray traced: nothing blocks it), times the
    multiscatter gain from all the pairs; 0 where the viewer is below the horizon."""
    lobes.boost = _boost(lobes, scene.world_pairs)
    local, weight = lobes.sampled  # (3, m, k), (m, k)
    pairs = weight.shape[0]  # every pair's: the pixel's samples hold them all, each standing for 1 / pairs of the lobe
    share = lightsamples.world_share(scene.scene.render, pairs)
    if share > 1:  # the pairs p = key mod g + g t of each lobe's camera sample: (3, m / g, k), (m / g, k)
        chosen = (keys % share)[None, :] + share * np.arange(pairs // share)[:, None]
        local, weight = np.take_along_axis(local, chosen[None], axis=1), np.take_along_axis(weight, chosen, axis=0)
    lx, ly, lz = local
    vx, vy, vz = lobes.v
    hx, hy, hz = lx + vx, ly + vy, lz + vz
    h_length = np.sqrt(hx * hx + hy * hy + hz * hz)
    VH = (vx * hx + vy * hy + vz * hz) / np.where(h_length > 0.0, h_length, 1.0)
    count, size = weight.shape
    grazing = (1.0 - np.clip(VH, 0.0, 1.0)) ** 5  # (m, k)
    color = lobes.color[:, None]
    F = np.where(lobes.schlick, color + (1.0 - color) * grazing, color)  # (3, m, k)
    if scene.scene.background.type in ("solid", "documented", "none"):  # one radiance in every direction
        sky = surfaces.background(scene, lobes.n[:, :1], None).astype(np.float64)  # (3, 1)
        return (F * weight).mean(axis=1) * sky * lobes.boost
    D = lx[None] * lobes.e1[:, None] + ly[None] * lobes.e2[:, None] + lz[None] * lobes.n[:, None]  # (3, m, k)
    D = np.where(weight > 0.0, D, lobes.n[:, None])  # a sample of weight 0 looks up nothing of its own
    background = scene.scene.background
    if background.type == "image":  # the picture blurred to each sample's share of its lobe
        solid_angles = np.where(weight > 0.0, _sample_solid_angle(lobes, local, h_length, pairs), 0.0)
        sky = surfaces.blurred_environment(background, D.reshape(3, -1), solid_angles.ravel())
        sky = sky.reshape(3, count, size)
    else:
        sky = surfaces.background(scene, D.reshape(3, -1), None).reshape(3, count, size).astype(np.float64)
    return (F * weight * sky).mean(axis=1) * lobes.boost


def _sample_solid_angle(lobes: Lobes, local: np.ndarray, h_length: np.ndarray, count: int) -> np.ndarray:
    """The solid angle (m, k) each of count samples of the lobes stands for: 1 / (count pdf), pdf the density of the
    visible normals' sampling over reflected directions, G1(v) D(h) / (4 v.z) (Heitz 2018), at the samples' local
    directions (3, m, k) whose half vectors are h_length long (the same operations as reference_glossy's)."""
    vz = np.where(lobes.facing, lobes.v[2], 1.0)
    a2 = lobes.alpha * lobes.alpha
    cos_h = (local[2] + lobes.v[2]) / np.where(h_length > 0.0, h_length, 1.0)
    d = cos_h * cos_h * (a2 - 1.0) + 1.0
    density = a2 / (math.pi * d * d) / (4.0 * vz * (1.0 + _smith_lambda(vz, a2)))
    with np.errstate(divide="ignore"):
        return 1.0 / (count * density)


def diffuse_rays(
    scene: PreparedScene, hits: Hits, rows: np.ndarray, chosen: np.ndarray, keys: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The diffuse bounce rays of hits rows (k,): for each pair its camera sample takes (keys (k,), as sample_rays)
    at a path's first glossy or diffuse bounce (chosen -1), else the path's pair, the cosine-weighted direction
    (sqrt(u1) cos 2 pi u2, sqrt(u1) sin 2 pi u2, sqrt(1 - u1)) about the shading normal turned toward the viewer
    (the albedo times the mean of what they bring is the indirect light: Lambert's 1 / pi and the cosine cancel the
    density) -> the rays' hits (j,) (indices into rows), pairs (j,), unit directions (3, j) and shares (j,) (the
    pair's share, or 1)."""
    S = np.asarray(take(hits.S, rows), np.float64)
    V = np.asarray(take(hits.V, rows), np.float64)
    n = np.where(_dot(S, V) < 0.0, -S, S)
    n = n / np.sqrt(x_y_z_squared(n))
    e1, e2 = facing_basis(n)
    pairs = scene.glossy_pairs
    count = len(pairs)
    fresh = chosen < 0
    hit, pair, every = _ray_pairs(chosen, count, keys, lightsamples.world_share(scene.scene.render, count))
    u1, u2 = pairs[:, 0].take(pair), pairs[:, 1].take(pair)
    r, phi = np.sqrt(u1), 2.0 * math.pi * u2
    x, y, z = r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u1)
    D = x * e1[:, hit] + y * e2[:, hit] + z * n[:, hit]
    return hit, pair, D, np.where(fresh.take(hit), every, 1.0)


def glass_rays(
    scene: PreparedScene, glass: Glass, chosen: np.ndarray, rotation: np.ndarray, keys: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rays of rough glass hits (k,) (glass_at: met along D, their rotation (2, k) given again here): at a path's
    first glossy surface (chosen -1) the pairs its camera sample takes (keys (k,): their sharing keys,
    lightsamples.shared_pairs, as a glossy lobe's), else the path's pair, each pair turned by the hit's Cranley-
    Patterson rotation (2, k) (rotated(): its own for every camera sample and depth, camera.glass_rotations, so that
    neither the pixels nor a path's entry and exit share one pattern), a microfacet normal m sampled about the shading
    normal turned to face the ray (as the sharp glass bends by it), then a reflected ray of weight F G2 / G1(v) and a
    refracted one of weight (1 - F) G2 / G1(v) (Walter et al. 2007; F the dielectric Fresnel at v.m, eta = ior entering
    by the geometric normal, 1 / ior leaving), at a first hit each times its pairs' share (share / count), and for
    multiscatter energy by E, the mean of both weights over every pair (what single scattering keeps: Cycles'
    Multiscatter GGX glass loses nothing); a ray on the wrong side of the surface, or refracted in total internal
    reflection, is dropped -> the rays' hits (j,) (indices into the hits), pairs (j,), unit directions (3, j), weights
    (j,) and whether each is refracted (j,)."""
    e1, e2, n, v, eta, alpha = glass.e1, glass.e2, glass.n, glass.v, glass.eta, glass.alpha
    separable, beckmann, gain = glass.separable, glass.beckmann, glass.gain
    pairs = scene.glossy_pairs
    count = len(pairs)
    fresh = chosen < 0
    hit, pair, every_share = _ray_pairs(chosen, count, keys, lightsamples.world_share(scene.scene.render, count))
    u1 = rotated(pairs[:, 0].take(pair), rotation[0].take(hit))
    u2 = rotated(pairs[:, 1].take(pair), rotation[1].take(hit))
    split = _glass_split(v[:, hit], eta.take(hit), alpha.take(hit), u1, u2, separable.take(hit), beckmann.take(hit))
    reflected, T, weight_r, weight_t = split
    scale = np.where(fresh.take(hit), every_share, 1.0) * gain.take(hit)
    weight_r, weight_t = weight_r * scale, weight_t * scale
    world = lambda local: (  # noqa: E731
        local[0] * e1[:, hit] + local[1] * e2[:, hit] + local[2] * n[:, hit]
    )
    keep_r, keep_t = indices(weight_r > 0.0), indices(weight_t > 0.0)
    directions = np.concatenate((take(world(reflected), keep_r), take(world(T), keep_t)), axis=1)
    both = np.concatenate((keep_r, keep_t))
    refracted = np.concatenate((np.zeros(keep_r.size, dtype=bool), np.ones(keep_t.size, dtype=bool)))
    weights = np.concatenate((weight_r.take(keep_r), weight_t.take(keep_t)))
    order = np.lexsort((refracted, both))  # a hit's rays together: by pair, the reflected before the refracted
    hit, pair = hit.take(both.take(order)), pair.take(both.take(order))
    return hit, pair, take(directions, order), weights.take(order), refracted.take(order)


@dataclass
class Glass:
    """Rough glass at some hits (k of them), float64, as its rays and the lights see it: the frame (e1, e2, n) (3, k)
    with n the shading normal turned to face the viewer, the unit view v (3, k) in it, eta (k,) (the ior entering
    by the geometric normal, 1 / ior leaving), alpha (k,), Smith's separable masking-shadowing and Beckmann's
    distribution (k,) bool, and the multiscatter gain (k,): 1 / E, E the mean of both weights over every pair at the
    hit's rotation (1 for single scattering)."""

    e1: np.ndarray
    e2: np.ndarray
    n: np.ndarray
    v: np.ndarray
    eta: np.ndarray
    alpha: np.ndarray
    separable: np.ndarray
    beckmann: np.ndarray
    gain: np.ndarray

    def take(self, keep: np.ndarray) -> Glass:
        """The hits keep (j,) of these."""
        frame = (take(array, keep) for array in (self.e1, self.e2, self.n, self.v))
        return Glass(*frame, *(array.take(keep) for array in (self.eta, self.alpha, self.separable, self.beckmann,
                                                              self.gain)))  # fmt: skip


def glass_at(scene: PreparedScene, hits: Hits, rows: np.ndarray, D: np.ndarray, rotation: np.ndarray) -> Glass:
    """The rough glass hits rows (k,) met along D (3, k), their pairs turned by rotation (2, k) (glass_rays)."""
    material = hits.material.take(rows)
    N, S = np.asarray(take(hits.N, rows), np.float64), np.asarray(take(hits.S, rows), np.float64)
    d = np.asarray(D, np.float64)
    d = d / np.sqrt(x_y_z_squared(d))
    facing = np.where(_dot(S, d) < 0.0, S, -S)
    n = facing / np.sqrt(x_y_z_squared(facing))
    ior = scene.ior.take(material).astype(np.float64)
    eta = np.where(_dot(N, d) < 0.0, ior, 1.0 / ior)
    e1, e2 = facing_basis(n)
    v = np.stack((-_dot(d, e1), -_dot(d, e2), -_dot(d, n)))
    alpha = scene.transmission_roughness.take(material) ** 2
    separable = scene.glossy_separable.take(material)
    beckmann = scene.transmission_beckmann.take(material)
    pairs = scene.glossy_pairs
    gain = np.ones(rows.size)
    multiscatter = scene.glossy_multiscatter.take(material)
    if multiscatter.any():
        every = rotated(pairs[:, :1], rotation[0]), rotated(pairs[:, 1:], rotation[1])  # (m, k) each
        _, _, weight_r, weight_t = _glass_split(v, eta, alpha, *every, separable, beckmann)  # (m, k)
        albedo = (weight_r + weight_t).mean(axis=0)
        gain = np.where(multiscatter & (albedo > 0.0), 1.0 / np.where(albedo > 0.0, albedo, 1.0), 1.0)
    return Glass(e1, e2, n, v, eta, alpha, separable, beckmann, gain)


def glass_light_factor(glass: Glass, L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What rough glass sends toward the viewer of a light along L (3, k) (world, any length), per unit of the
    light's intensity as the diffuse term counts it, reflected and refracted (k,) each, times the gain: on the
    viewer's side pi F D G2 / (4 v.z) at h = (v + l) / |v + l|; on the other pi (1 - F) D G2 (v.m) eta^2 |l.m| /
    (v.z (v.m + eta l.m)^2) at m = (v + eta l) / |v + eta l| turned up, which is the refracted rays' weight (1 - F)
    G2 / G1(v) times the density of sampling l by the visible normals (Walter et al. 2007), so that the light
    through the glass is what its rays would find; F the dielectric Fresnel at v.m (1 in total internal
    reflection), D and Lambda GGX's or Beckmann's; 0 where l is not the reflection or refraction of v by a
    microfacet facing the viewer."""
    L = np.asarray(L, dtype=np.float64)
    length = np.sqrt(x_y_z_squared(L))
    lx, ly, lz = _dot(L, glass.e1) / length, _dot(L, glass.e2) / length, _dot(L, glass.n) / length
    vx, vy, vz = glass.v
    eta, a2 = glass.eta, glass.alpha * glass.alpha
    above = lz > 0.0
    scale = np.where(above, 1.0, eta)  # the half vector v + l above, v + eta l below
    mx, my, mz = vx + scale * lx, vy + scale * ly, vz + scale * lz
    m_length = np.sqrt(mx * mx + my * my + mz * mz)
    up = np.where(mz < 0.0, -1.0, 1.0) / np.where(m_length > 0.0, m_length, 1.0)
    mx, my, mz = mx * up, my * up, mz * up
    c = vx * mx + vy * my + vz * mz  # v.m
    lm = lx * mx + ly * my + lz * mz  # l.m
    g2 = eta * eta - 1.0 + c * c
    inside = g2 > 0.0
    g = np.sqrt(np.where(inside, g2, 1.0))
    safe_c = np.where(c > 0.0, c, 1.0)
    A = (g - safe_c) / (g + safe_c)
    B = (safe_c * (g + safe_c) - 1.0) / (safe_c * (g - safe_c) + 1.0)
    F = np.where(inside, 0.5 * A * A * (1.0 + B * B), 1.0)
    cos2 = mz * mz
    safe_cos2 = np.where(cos2 > 0.0, cos2, 1.0)
    ggx = cos2 * (a2 - 1.0) + 1.0
    D = np.where(
        glass.beckmann,
        np.exp(-(1.0 - cos2) / (safe_cos2 * a2)) / (math.pi * a2 * safe_cos2 * safe_cos2),
        a2 / (math.pi * ggx * ggx),
    )
    seen = np.where(vz > 0.0, vz, 1.0)
    l_cos = np.where(lz != 0.0, np.abs(lz), 1.0)
    lambda_v, lambda_l = _smith_lambda(seen, a2), _smith_lambda(l_cos, a2)
    if glass.beckmann.any():
        lambda_v = np.where(glass.beckmann, _beckmann_lambda(seen, a2), lambda_v)
        lambda_l = np.where(glass.beckmann, _beckmann_lambda(l_cos, a2), lambda_l)
    G2 = _shadowing(lambda_v, lambda_l, glass.separable)
    valid = (vz > 0.0) & (m_length > 0.0) & (mz > 0.0) & (c > 0.0)
    reflected = np.where(valid & above, F * (math.pi * D * G2 / (4.0 * seen)), 0.0)
    denominator = c + eta * lm
    bent = valid & ~above & (lz < 0.0) & (lm < 0.0) & inside & (denominator != 0.0)
    safe_denominator = np.where(bent, denominator, 1.0)
    transmitted = (1.0 - F) * math.pi * D * G2 * c * (eta * eta) * -lm / (seen * safe_denominator * safe_denominator)
    return reflected * glass.gain, np.where(bent, transmitted, 0.0) * glass.gain


def rotated(u: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Sample numbers u in [0, 1) moved by offsets in [0, 1) and wrapped: u + offset, less 1 where that reaches 1
    (Cranley and Patterson 1976; the reference's rotated, to the bit)."""
    moved = u + offset
    return np.where(moved >= 1.0, moved - 1.0, moved)


def _ray_pairs(chosen: np.ndarray, count: int, keys: np.ndarray, share: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The rays of hits whose chosen pair (k,) is -1 (a path's first glossy surface or bounce: the count / share
    pairs p = key mod share + share t its camera sample takes, keys (k,), lightsamples.shared_pairs; every pair at
    share 1) or a pair of its path (that one) -> each ray's hit (j,) and pair (j,), a hit's rays together in pair
    order, and a fresh ray's share of its hit's light (share / count)."""
    fresh = indices(chosen < 0)
    per = count // share
    first = np.repeat(keys.take(fresh) % share, per) + share * np.tile(np.arange(per), fresh.size)
    hit = np.concatenate((np.repeat(fresh, per), indices(chosen >= 0)))
    pair = np.concatenate((first, chosen.take(indices(chosen >= 0))))
    order = np.argsort(hit, kind="stable")
    return hit.take(order), pair.take(order), share / count


def _glass_split(
    v: np.ndarray,
    eta: np.ndarray,
    alpha: np.ndarray,
    u1: np.ndarray,
    u2: np.ndarray,
    separable: np.ndarray,
    beckmann: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rough glass seen from v (3, k) (local, z the normal facing the viewer) with eta and alpha (k,), at the numbers
    u1, u2 ((k,), or (m, 1) for m pairs at every hit), its distribution GGX, or Beckmann where beckmann (k,) ->
    the reflected and refracted local directions (3, ...) and their weights F G2 / G1(v) and (1 - F) G2 / G1(v) (...)
    (0 where a direction is on the wrong side, or in total internal reflection)."""
    vx, vy, vz = v
    lambda_of = _smith_lambda
    if beckmann.any():
        steep = np.where(vz > 0.0, vz, 1.0)  # the Beckmann sampler's view, well defined where the weight is not 0
        m = np.where(
            beckmann, _beckmann_visible_normal(vx, vy, steep, alpha, u1, u2), _visible_normal(vx, vy, vz, alpha, u1, u2)
        )

        def lambda_of(cosine: np.ndarray, a2: np.ndarray) -> np.ndarray:
            return np.where(beckmann, _beckmann_lambda(cosine, a2), _smith_lambda(cosine, a2))

    else:
        m = _visible_normal(vx, vy, vz, alpha, u1, u2)
    mx, my, mz = m
    c = vx * mx + vy * my + vz * mz
    g2 = eta * eta - 1.0 + c * c
    inside = g2 > 0.0  # else total internal reflection at this microfacet: F = 1
    g = np.sqrt(np.where(inside, g2, 1.0))
    A = (g - c) / (g + c)
    B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    F = np.where(inside, 0.5 * A * A * (1.0 + B * B), 1.0)
    a2 = alpha * alpha
    lambda_v = lambda_of(np.where(vz > 0.0, vz, 1.0), a2)
    reflected = np.stack((2.0 * c * mx - vx, 2.0 * c * my - vy, 2.0 * c * mz - vz))
    up = reflected[2] > 0.0
    weight_r = np.where(up, F * _shadowing(lambda_v, lambda_of(np.where(up, reflected[2], 1.0), a2), separable), 0.0)
    # through m: T = (-v + (c - g) m) / eta, the sharp glass's rule with m for the normal
    T = np.stack(((c - g) * mx - vx, (c - g) * my - vy, (c - g) * mz - vz)) / eta
    T = T / np.sqrt(x_y_z_squared(T))
    down = inside & (T[2] < 0.0)
    lambda_t = lambda_of(np.where(down, -T[2], 1.0), a2)
    weight_t = np.where(down, (1.0 - F) * _shadowing(lambda_v, lambda_t, separable), 0.0)
    seen = (1.0 + lambda_v) * (vz > 0.0)
    return reflected, T, weight_r * seen, weight_t * seen


def _visible_normal(
    vx: np.ndarray, vy: np.ndarray, vz: np.ndarray, alpha: np.ndarray, u1: np.ndarray, u2: np.ndarray
) -> np.ndarray:
    """A microfacet normal (3, n) sampled among those visible from v (local, z up; Heitz 2018) at u1, u2."""
    hx, hy, hz = alpha * vx, alpha * vy, vz
    h_length = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / h_length, hy / h_length, hz / h_length
    lensq = hx * hx + hy * hy
    flat = lensq > 0.0
    inverse = np.where(flat, 1.0 / np.sqrt(np.where(flat, lensq, 1.0)), 0.0)
    t1x, t1y = np.where(flat, -hy * inverse, 1.0), np.where(flat, hx * inverse, 0.0)
    t2x, t2y, t2z = -hz * t1y, hz * t1x, hx * t1y - hy * t1x
    r = np.sqrt(u1)
    phi = 2.0 * math.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + hz)
    p2 = (1.0 - s) * np.sqrt(1.0 - p1 * p1) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx, ny, nz = p1 * t1x + p2 * t2x + p3 * hx, p1 * t1y + p2 * t2y + p3 * hy, p2 * t2z + p3 * hz
    mx, my, mz = alpha * nx, alpha * ny, np.maximum(0.0, nz)
    m_length = np.sqrt(mx * mx + my * my + mz * mz)
    return np.stack((mx / m_length, my / m_length, mz / m_length))


def _beckmann_visible_normal(
    vx: np.ndarray, vy: np.ndarray, vz: np.ndarray, alpha: np.ndarray, u1: np.ndarray, u2: np.ndarray
) -> np.ndarray:
    """A Beckmann microfacet normal (3, n) sampled among those visible from v (local, z up, vz > 0) at u1, u2 (Heitz
    and d'Eon 2014's stretched slopes; the slope along the view by Jakob's inversion of its CDF, Newton steps kept
    in their bracket, as Cycles' microfacet_beckmann_sample_vndf; erf and its inverse as Cycles' fast_erff and
    fast_ierff); at normal incidence the slopes are erf^-1(2u - 1), the same formula's limit."""
    sx, sy, sz = alpha * vx, alpha * vy, vz
    length = np.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = sx / length, sy / length, sz / length
    steep = sz < BECKMANN_NORMAL_INCIDENCE
    sin = np.sqrt(np.maximum(0.0, 1.0 - sz * sz))
    safe_sin = np.where(steep, sin, 1.0)
    tan = np.where(steep, sin / sz, 0.0)
    cot = sz / safe_sin
    erf_a = np.where(steep, _erf(cot), 1.0)
    exp_a2 = np.where(steep, np.exp(-cot * cot), 0.0)
    cos_phi, sin_phi = np.where(steep, sx / safe_sin, 1.0), np.where(steep, sy / safe_sin, 0.0)
    K = tan * INV_SQRT_PI
    y_approx = u1 * (1.0 + erf_a + K * (1.0 - erf_a * erf_a))
    y_exact = u1 * (1.0 + erf_a + K * exp_a2)
    safe_K = np.where(K > 0.0, K, 1.0)
    b = np.where(K > 0.0, (0.5 - np.sqrt(K * (K - y_approx + 1.0) + 0.25)) / safe_K, y_approx - 1.0)
    inverse = _inverse_erf(b)
    begin_x, begin_y, end_x = np.full_like(b, -1.0), -y_exact + 0.0 * b, erf_a + 0.0 * b
    current_x, current_y = b, 1.0 + b + K * np.exp(-inverse * inverse) - y_exact
    going = np.ones(b.shape, dtype=bool)
    for _ in range(BECKMANN_NEWTON_STEPS):
        going = going & (np.abs(current_y) > BECKMANN_PRECISION)
        same = np.sign(begin_y) == np.sign(current_y)
        begin_x, begin_y = np.where(same, current_x, begin_x), np.where(same, current_y, begin_y)
        end_x = np.where(same, end_x, current_x)
        newton = current_x - current_y / (1.0 - inverse * tan)
        step = np.where((newton >= begin_x) & (newton <= end_x), newton, 0.5 * (begin_x + end_x))
        current_x = np.where(going, step, current_x)
        inverse = _inverse_erf(current_x)
        current_y = 1.0 + current_x + K * np.exp(-inverse * inverse) - y_exact
    slope_x, slope_y = inverse, _inverse_erf(2.0 * u2 - 1.0)
    slope_x, slope_y = cos_phi * slope_x - sin_phi * slope_y, sin_phi * slope_x + cos_phi * slope_y
    mx, my = -alpha * slope_x, -alpha * slope_y
    m_length = np.sqrt(mx * mx + my * my + 1.0)
    return np.stack((mx / m_length, my / m_length, 1.0 / m_length))


def _beckmann_lambda(cosine: np.ndarray, a2: np.ndarray) -> np.ndarray:
    """Smith's Lambda of Beckmann at cosines > 0 to the normal, Walter et al. 2007's rational approximation (Cycles'):
    with a = 1 / (alpha tan), ((0.396 a - 1.259) a + 1) / ((2.181 a + 3.535) a) below a = 1.6, else 0 (1 / G1 - 1 of
    Cycles 3.x's bsdf_beckmann_G1)."""
    inverse_a = np.sqrt(a2 * np.maximum(0.0, 1.0 - cosine * cosine)) / cosine
    shadowed = inverse_a >= BECKMANN_NO_SHADOW
    a = 1.0 / np.where(shadowed, inverse_a, 1.0)
    return np.where(shadowed, ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a), 0.0)


def _erf(x: np.ndarray) -> np.ndarray:
    """erf(x) by Abramowitz and Stegun 7.1.28 (Cycles' fast_erff, error below 2e-6)."""
    a = np.abs(x)
    r = ((((((ERF[5] * a + ERF[4]) * a + ERF[3]) * a + ERF[2]) * a + ERF[1]) * a + ERF[0]) * a) + 1.0
    s = r * r
    t = s * s
    u = t * t
    return np.where(a >= 12.3, np.sign(x), np.sign(x) * (1.0 - 1.0 / (u * u)))


def _inverse_erf(x: np.ndarray) -> np.ndarray:
    """erf^-1(x) by Giles 2010's single-precision polynomials (Cycles' fast_ierff), |x| held below 1."""
    a = np.minimum(np.abs(x), IERF_LIMIT)
    w = -np.log((1.0 - a) * (1.0 + a))
    central = w < 5.0
    w = np.where(central, w - 2.5, np.sqrt(w) - 3.0)
    p_central, p_tail = IERF_CENTRAL[0], IERF_TAIL[0]
    for c, t in zip(IERF_CENTRAL[1:], IERF_TAIL[1:], strict=True):
        p_central, p_tail = p_central * w + c, p_tail * w + t
    return np.where(central, p_central, p_tail) * x


def fresnel(lobes: Lobes, cosine: np.ndarray) -> np.ndarray:
    """The lobes' Fresnel reflectance (3, k) at the cosines (k,) between the view and the microfacet normal: the
    colour (constant), or Schlick's F0 + (1 - F0) (1 - cos)^5."""
    grazing = (1.0 - np.clip(cosine, 0.0, 1.0)) ** 5
    return np.where(lobes.schlick, lobes.color + (1.0 - lobes.color) * grazing, lobes.color)


def _shadowing(lambda_v: np.ndarray, lambda_l: np.ndarray, separable: np.ndarray) -> np.ndarray:
    """Smith's masking-shadowing G2 from Lambda of the view and the light: height-correlated 1 / (1 + Lv + Ll)
    (Cycles 4.0 and later), or separable 1 / ((1 + Lv)(1 + Ll)) where separable (Cycles 3.x)."""
    return np.where(separable, 1.0 / ((1.0 + lambda_v) * (1.0 + lambda_l)), 1.0 / (1.0 + lambda_v + lambda_l))


def _smith_lambda(cosine: np.ndarray, a2: np.ndarray) -> np.ndarray:
    """Smith's Lambda of GGX at cosines > 0 to the normal: (sqrt(1 + a^2 tan^2) - 1) / 2."""
    c2 = cosine * cosine
    return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c2) / c2) - 1.0)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
