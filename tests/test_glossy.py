"""Glossy surfaces (a material's glossy lobe): the vectorized tracer against the per-pixel reference, the lobe
against its analytic albedo (the white furnace), and the scene format's checks."""

from __future__ import annotations

import math
import random
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import extended_scene_document, see_through_scene_document
from tests.test_lights_and_world import _passes_add_up_and_workers_agree, _world_lit_document
from tests.tracing import assert_matches_reference
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, scene_from_dict
from tracer.workers.parallel import render


def _glossy_document(seed: int) -> dict:
    """A random scene (glass, transparency, world light and lamps included by seed) whose materials are glossy at
    random: colour, roughness from near-mirror to 1, Fresnel, energy and source of each kind, a diffuse colour or
    none; its glass sharp or rough; diffuse bounces 0, 1 or 2."""
    rng = random.Random(40_000 + seed)
    if seed % 3 == 0:
        document = _world_lit_document(seed)
    else:
        document = (see_through_scene_document if seed % 3 == 2 else extended_scene_document)(seed, 16, 12)
    materials = list(document["materials"].values())
    for index, material in enumerate(materials):
        if rng.random() < 0.7 or index == 0:
            material["glossy"] = [rng.uniform(0.2, 1.0) for _ in range(3)]
            material["roughness"] = rng.choice([0.05, 0.3, 0.6, 1.0, rng.uniform(0.01, 1.0)])
            material["glossy_fresnel"] = rng.choice(["constant", "schlick"])
            material["glossy_energy"] = rng.choice(["multiscatter", "single"])
            material["glossy_source"] = rng.choice(["traced", "traced", "world"])
            material["glossy_shadowing"] = rng.choice(["correlated", "separable"])
            if rng.random() < 0.4:
                material["color"] = [0.0, 0.0, 0.0]
        if material.get("transmission", 0.0) > 0.0:
            material["transmission_roughness"] = rng.choice([0.0, 0.2, 0.6, 1.0])
            material["glossy_shadowing"] = rng.choice(["correlated", "separable"])
    document["render"]["glossy_samples"] = rng.choice([1, 3, 8])
    document["render"]["diffuse_bounces"] = rng.choice([0, 0, 1, 2])
    document["render"]["depth"] = rng.choice([1, 2, 3])
    return document


@pytest.mark.parametrize("seed", range(9))
def test_glossy_scenes_match_the_reference(seed: int) -> None:
    assert_matches_reference(scene_from_dict(_glossy_document(seed)))


@pytest.mark.parametrize("seed", range(2))
def test_glossy_scenes_keep_the_passes_adding_up_and_workers_agree(seed: int) -> None:
    document = _glossy_document(seed + 1)
    document["render"].pop("border", None)
    _passes_add_up_and_workers_agree(scene_from_dict(document))


def _furnace(
    view_degrees: float, roughness: float, energy: str, samples: int = 64, source: str = "traced", shadowing=None
) -> float:
    """A white glossy plane (no diffuse) under a uniform white background, no lamp, seen at view_degrees from its
    normal by an orthographic camera: what its lobe reflects (by rays, or of the world alone)."""
    white = {"color": [0, 0, 0], "glossy": [1, 1, 1], "roughness": roughness, "glossy_energy": energy}
    white["glossy_source"] = source
    if shadowing is not None:
        white["glossy_shadowing"] = shadowing
    return _plane_under_white_seen_at(view_degrees, white, samples)


def _plane_under_white_seen_at(view_degrees: float, material: dict, samples: int) -> float:
    """A plane of the material under a uniform white background, no lamp, seen at view_degrees from its normal by an
    orthographic camera one pixel across, depth 1, at samples glossy pairs: the pixel's red."""
    angle = math.radians(view_degrees)
    document = {
        "materials": {"plane": material},
        "objects": [{"name": "plane", "type": "plane", "material": "plane"}],
        "lights": [{"type": "ambient", "intensity": 0.0}],
        "camera": {
            "location": [0.0, -50.0 * math.sin(angle), 50.0 * math.cos(angle)],
            "rotation": [view_degrees, 0.0, 0.0],
            "type": "ORTHO",
            "ortho_scale": 0.01,
        },
        "background": {"type": "solid", "color": [1.0, 1.0, 1.0]},
        "render": {"width": 1, "height": 1, "depth": 1, "glossy_samples": samples},
    }
    return float(render(scene_from_dict(document), workers=1).image[0, 0, 0])


def _hemisphere_grid(rows: int, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """A midpoint grid over the upper hemisphere in (cos theta, phi): cos theta (rows, columns) and the unit
    directions (3, rows, columns); each cell covers (1 / rows) (2 pi / columns) of solid angle."""
    mu = (np.arange(rows) + 0.5) / rows
    phi = (np.arange(columns) + 0.5) / columns * 2.0 * math.pi
    mu, phi = np.meshgrid(mu, phi, indexing="ij")
    sin = np.sqrt(1.0 - mu * mu)
    return mu, np.stack((sin * np.cos(phi), sin * np.sin(phi), mu))


def _ggx_albedo(view_degrees: float, roughness: float, separable: bool = False) -> float:
    """The single-scattering GGX lobe's albedo along the view (Fresnel 1), integrated over the hemisphere of light
    directions on a fine midpoint grid in (cos theta, phi): the integral of D G2 / (4 cos theta_v) d omega, written
    from the formulas (Walter et al. 2007; Heitz 2014's height-correlated Smith G2)."""
    a2 = roughness**4
    cos_rows, phi_rows = 3000, 720
    mu, light = _hemisphere_grid(cos_rows, phi_rows)
    theta = math.radians(view_degrees)
    view = np.array([0.0, math.sin(theta), math.cos(theta)])[:, None, None]
    half = light + view
    half = half / np.sqrt((half * half).sum(axis=0))
    d = half[2] ** 2 * (a2 - 1.0) + 1.0
    D = a2 / (math.pi * d * d)

    def smith(c):
        return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0)

    G2 = 1.0 / ((1.0 + smith(view[2])) * (1.0 + smith(mu))) if separable else 1.0 / (1.0 + smith(view[2]) + smith(mu))
    integrand = D * G2 / (4.0 * view[2])
    return float(integrand.sum() * (1.0 / cos_rows) * (2.0 * math.pi / phi_rows))


@pytest.mark.parametrize("view_degrees", [0.0, 45.0, 70.0])
@pytest.mark.parametrize("roughness", [0.3, 0.6, 1.0])
def test_the_white_furnace_single_scattering_is_the_lobes_albedo_and_multiscatter_keeps_all(
    view_degrees: float, roughness: float
) -> None:
    """Single scattering loses what the microfacets shadow: the pixel is the lobe's albedo, within 1.5% at 64
    samples (an independent quadrature); Cycles' multiscatter gain gives it back: 1 to rounding. A lobe of the world
    alone (no rays: nothing here to block them; at most 4 pairs) the same as a traced lobe at 4 samples."""
    albedo = _ggx_albedo(view_degrees, roughness)
    assert _furnace(view_degrees, roughness, "single") == pytest.approx(albedo, rel=0.015)
    separable = _ggx_albedo(view_degrees, roughness, separable=True)  # Cycles 3.x's G1 G1: darker at grazing views
    assert _furnace(view_degrees, roughness, "single", shadowing="separable") == pytest.approx(separable, rel=0.015)
    four = _furnace(view_degrees, roughness, "single", samples=4)
    assert _furnace(view_degrees, roughness, "single", source="world") == pytest.approx(four, abs=1e-12)
    assert _furnace(view_degrees, roughness, "multiscatter") == pytest.approx(1.0, abs=1e-12)
    assert _furnace(view_degrees, roughness, "multiscatter", source="world") == pytest.approx(1.0, abs=1e-12)


def _beckmann_document(seed: int) -> dict:
    """_glossy_document's scene with its glass rough and Beckmann (a random roughness per material)."""
    document = _glossy_document(seed)
    rng = random.Random(41_000 + seed)
    for material in document["materials"].values():
        if material.get("transmission", 0.0) > 0.0:
            material["transmission_roughness"] = rng.choice([0.1, 0.4, 0.7, 1.0])
            material["transmission_distribution"] = "beckmann"
    return document


@pytest.mark.parametrize("seed", [2, 5, 8])
def test_beckmann_rough_glass_scenes_match_the_reference(seed: int) -> None:
    document = _beckmann_document(seed)
    assert any(m.get("transmission_distribution") == "beckmann" for m in document["materials"].values())
    assert_matches_reference(scene_from_dict(document))


def _glass_furnace(view_degrees: float, roughness: float, distribution: str, shadowing: str) -> float:
    """A sheet of white rough glass (IOR 1.45, single scattering) under a uniform white background, seen at
    view_degrees by an orthographic camera, depth 1: its reflected and refracted rays' weights at 64 pairs."""
    glass = {"color": [1, 1, 1], "specular": 0, "transmission": 1.0, "ior": 1.45, "glossy_energy": "single"}
    glass.update(transmission_roughness=roughness, transmission_distribution=distribution, glossy_shadowing=shadowing)
    return _plane_under_white_seen_at(view_degrees, glass, 64)


def _glass_albedo(view_degrees: float, roughness: float, distribution: str, separable: bool) -> float:
    """Single-scattering rough glass's albedo along the view (IOR 1.45, entering): over the microfacet normals m on a
    midpoint grid in (theta, phi), D(m) (v.m)+ / v.z times F G2 toward the mirrored direction plus (1 - F) G2
    toward the refracted one (Walter et al. 2007's BSDF, its Jacobians folded in), D and Smith's Lambda written from
    the formulas: Beckmann's exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4) with Walter's rational Lambda, or GGX's;
    Fresnel from Snell's law's s and p amplitudes."""
    a2, eta = roughness**4, 1.45
    theta_rows, phi_rows = 600, 180  # theta: the peak of alpha 0.09 over some 30 rows
    theta_m = (np.arange(theta_rows) + 0.5) / theta_rows * 0.5 * math.pi
    phi = (np.arange(phi_rows) + 0.5) / phi_rows * 2.0 * math.pi
    theta_m, phi = np.meshgrid(theta_m, phi, indexing="ij")
    mu, sin = np.cos(theta_m), np.sin(theta_m)
    m = np.stack((sin * np.cos(phi), sin * np.sin(phi), mu))
    theta = math.radians(view_degrees)
    view = np.array([0.0, math.sin(theta), math.cos(theta)])[:, None, None]
    if distribution == "beckmann":
        D = np.exp(-(1.0 - mu * mu) / (mu * mu * a2)) / (math.pi * a2 * mu**4)

        def smith(c):
            x = c / np.maximum(np.sqrt(a2 * (1.0 - c * c)), 1e-12)  # 1 / (alpha tan)
            return np.where(x < 1.6, (1.0 - 1.259 * x + 0.396 * x * x) / (3.535 * x + 2.181 * x * x), 0.0)
    else:
        D = a2 / (math.pi * (mu * mu * (a2 - 1.0) + 1.0) ** 2)

        def smith(c):
            return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0)

    def shadowed(c):  # Smith's G2 with the view
        lambda_v = smith(view[2])
        return 1.0 / ((1.0 + lambda_v) * (1.0 + smith(c))) if separable else 1.0 / (1.0 + lambda_v + smith(c))

    c = (view * m).sum(axis=0)
    sin_t2 = (1.0 - c * c) / (eta * eta)
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t2))
    rs, rp = (c - eta * cos_t) / (c + eta * cos_t), (eta * c - cos_t) / (eta * c + cos_t)
    F = np.where(sin_t2 < 1.0, 0.5 * (rs * rs + rp * rp), 1.0)
    mirrored = 2.0 * c * m - view
    bent = -view / eta + (c / eta - cos_t) * m
    bent_z = bent[2] / np.sqrt((bent * bent).sum(axis=0))
    up, down = mirrored[2] > 0.0, bent_z < 0.0
    weights = np.where(up, F * shadowed(np.where(up, mirrored[2], 1.0)), 0.0)
    weights += np.where(down, (1.0 - F) * shadowed(np.where(down, -bent_z, 1.0)), 0.0)
    integrand = D * np.maximum(c, 0.0) / view[2] * weights * sin  # d omega = sin theta d theta d phi
    return float(integrand.sum() * (0.5 * math.pi / theta_rows) * (2.0 * math.pi / phi_rows))


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.parametrize("view_degrees", [0.0, 70.0])
def test_the_white_furnace_rough_glass_keeps_its_albedo(distribution: str, view_degrees: float) -> None:
    """Rough glass's reflected and refracted rays bring back its single-scattering albedo (an independent quadrature
    over the microfacet normals), within 1% at 64 pairs, for Beckmann and GGX, both masking-shadowings."""
    for roughness in (0.3, 0.6, 1.0):
        for separable in (False, True):
            expected = _glass_albedo(view_degrees, roughness, distribution, separable)
            shadowing = "separable" if separable else "correlated"
            got = _glass_furnace(view_degrees, roughness, distribution, shadowing)
            assert got == pytest.approx(expected, rel=0.01), (roughness, shadowing)


def test_beckmann_visible_normals_follow_their_density() -> None:
    """The Beckmann sampler's normals (uniform numbers) have the moments of D(m) (v.m)+ G1(v) / v.z (a quadrature
    with the exact erf Lambda), and the reference's normals are the same to 1e-12."""
    from tracer.tracing import glossy, reference_glossy

    rng = np.random.default_rng(7)
    count = 200_000
    u1, u2 = rng.random(count), rng.random(count)
    for alpha, theta in ((0.36, 0.3), (0.36, 1.2), (0.8, 1.4), (0.5, 0.0)):
        v = [math.sin(theta), 0.0, math.cos(theta)]
        full = [np.full(count, c) for c in v]
        m = glossy._beckmann_visible_normal(*full, np.full(count, alpha), u1, u2)
        mu, normals = _hemisphere_grid(2000, 360)
        D = np.exp(-(1.0 - mu * mu) / (mu * mu * alpha * alpha)) / (math.pi * alpha * alpha * mu**4)
        density = D * np.maximum(0.0, normals[0] * v[0] + normals[2] * v[2])
        for sampled, moment in ((m[2], normals[2]), (m[0], normals[0]), (m[0] ** 2, normals[0] ** 2)):
            expected = (density * moment).sum() / density.sum()
            assert float(sampled.mean()) == pytest.approx(float(expected), abs=3e-3)
        for i in range(20):
            one = reference_glossy.beckmann_visible_normal(tuple(v), alpha, float(u1[i]), float(u2[i]))
            np.testing.assert_allclose(one, m[:, i], rtol=0.0, atol=1e-12)


def test_glossy_fields_are_checked_with_clear_messages() -> None:
    base = {"objects": [{"type": "sphere", "material": "m"}], "lights": [{"type": "ambient", "intensity": 1}]}
    for material, render_settings, field in (
        ({"glossy": [1, 1, 1], "roughness": 0}, {}, "roughness"),
        ({"glossy": [1, 2, 1]}, {}, "glossy"),
        ({"glossy": [1, 1, 1], "glossy_fresnel": "fresnel"}, {}, "glossy_fresnel"),
        ({"glossy": [1, 1, 1], "glossy_energy": "many"}, {}, "glossy_energy"),
        ({"glossy": [1, 1, 1]}, {"glossy_samples": 0}, "glossy_samples"),
        ({"transmission": 1, "transmission_distribution": "ashikhmin"}, {}, "transmission_distribution"),
    ):
        document = {**base, "materials": {"m": {"color": [1, 1, 1], **material}}, "render": render_settings}
        with pytest.raises(SceneError, match=field):
            scene_from_dict(document)


@pytest.mark.parametrize("bounces", [0, 1, 2, 3])
def test_diffuse_bounces_inside_a_glowing_sphere_add_the_geometric_series(bounces: int) -> None:
    """Inside a closed sphere whose surface has albedo 0.5 and emission 0.1, no light: every bounce ray meets the
    same surface, so N bounces give 0.1 (1 + 0.5 + ... + 0.5^N) exactly, whatever the sample directions."""
    document = {
        "materials": {"inside": {"color": [0.5, 0.5, 0.5], "emission": [0.1, 0.1, 0.1], "two_sided": True}},
        "objects": [{"name": "room", "type": "sphere", "material": "inside", "radius": 5.0}],
        "lights": [{"type": "ambient", "intensity": 0.0}],
        "camera": {"location": [0.0, 0.0, 0.0], "rotation": [90.0, 0.0, 0.0]},
        "render": {"width": 2, "height": 2, "depth": 4, "diffuse_bounces": bounces, "glossy_samples": 4},
    }
    image = render(scene_from_dict(document), workers=1).image
    expected = 0.1 * sum(0.5**k for k in range(bounces + 1))
    np.testing.assert_allclose(image, expected, rtol=1e-12)


def test_a_diffuse_bounces_miss_adds_nothing_the_world_light_has_the_sky() -> None:
    """Open ground under a uniform sky lit by the world light: its bounce rays all miss, and add nothing."""
    document = {
        "materials": {"white": {"color": [0.8, 0.8, 0.8]}},
        "objects": [{"name": "ground", "type": "plane", "material": "white"}],
        "lights": [{"type": "world", "intensity": 1.0, "samples": 16}],
        "camera": {"location": [0.0, 0.0, 5.0], "rotation": [0.0, 0.0, 0.0], "type": "ORTHO", "ortho_scale": 0.01},
        "background": {"type": "solid", "color": [1.0, 1.0, 1.0]},
        "render": {"width": 1, "height": 1, "diffuse_bounces": 2},
    }
    bounced = render(scene_from_dict(document), workers=1).image
    document["render"]["diffuse_bounces"] = 0
    assert np.array_equal(bounced, render(scene_from_dict(document), workers=1).image)


def _rough_glass_document() -> dict:
    """A rough glass ball (roughness 0.6) on a floor under a sky, a lamp: 12 x 9 pixels at 4 samples, 4 pairs."""
    return {
        "materials": {
            "glass": {
                "color": [1, 1, 1],
                "specular": 0,
                "transmission": 1.0,
                "ior": 1.45,
                "transmission_roughness": 0.6,
            },
            "floor": {"color": [0.8, 0.4, 0.2]},
        },
        "objects": [
            {"name": "ball", "type": "sphere", "material": "glass", "location": [0, 0, 1], "radius": 1},
            {"name": "floor", "type": "plane", "material": "floor", "location": [0, 0, 0], "size": [20, 20]},
        ],
        "lights": [{"type": "ambient", "intensity": 0.3}, {"type": "point", "location": [3, -3, 5], "intensity": 0.7}],
        "camera": {"location": [0.0, -4.5, 1.5], "rotation": [88.0, 0.0, 0.0], "lens": 35},
        "background": {"type": "sky", "horizon": [0.78, 0.84, 0.9], "zenith": [0.3, 0.5, 0.82]},
        "render": {"width": 12, "height": 9, "depth": 3, "samples": 4, "glossy_samples": 4},
    }


def test_a_lamp_lights_rough_glass_through_its_microfacets_as_its_glossy_and_transmission_visibility_say() -> None:
    """The rough glass ball alone under a point light behind it and above, no floor: the lamp reaches the pixels only
    through the glass (its highlight and what the ball lets through), as much as the reference finds. With a second
    lamp in front, the lamps' Glossy visibility (visible_glossy) gives the light off the glass, their Transmission
    visibility (visible_transmission) the light through it, each as the reference finds it, the two adding up to the
    whole; with both off the image is the one without the lamps, with no shadow ray of them."""
    document = _rough_glass_document()
    document["objects"] = document["objects"][:1]
    document["lights"] = [{"type": "point", "location": [0.5, 4, 2], "intensity": 2.0}]
    assert_matches_reference(scene_from_dict(document))
    document["lights"].append({"type": "point", "location": [1.5, -3, 3], "intensity": 2.0})

    def seen(**flags) -> dict:
        return dict(document, lights=[{**light, **flags} for light in document["lights"]])

    off_only, through_only = seen(visible_transmission=False), seen(visible_glossy=False)
    for part in (off_only, through_only):
        assert_matches_reference(scene_from_dict(part))
    blind = seen(visible_glossy=False, visible_transmission=False)
    dark = dict(document, lights=[])
    with_lamp, without, unseen, off, through = (
        render(scene_from_dict(d), workers=1) for d in (document, dark, blind, off_only, through_only)
    )
    glow = with_lamp.image - without.image
    assert glow.max() > 0.05  # the glow through the ball
    assert 0.0 < (off.image - without.image).max() < glow.max()  # the front lamp's highlight
    assert 0.0 < (through.image - without.image).max() < glow.max()  # the lamp behind seen through the ball
    np.testing.assert_allclose((off.image - without.image) + (through.image - without.image), glow, atol=1e-6)
    np.testing.assert_array_equal(unseen.image, without.image)
    assert unseen.rays.shadow == 0 < with_lamp.rays.shadow


def test_rough_glass_turns_its_pairs_by_camera_sample_the_same_bytes_in_any_piece() -> None:
    """Rough glass's pairs turned by a rotation of each camera sample and depth (camera.glass_rotations): the
    reference's image to 1e-9, the same bytes for 1 or 2 workers and for a few pixels traced alone (the rotation
    follows the global sample, not its place in a band or piece), and its passes adding up."""
    from tracer.tracing.wavefront import TracedScene

    scene = scene_from_dict(_rough_glass_document())
    assert_matches_reference(scene)
    whole = _passes_add_up_and_workers_agree(scene).image
    pixels = np.array([14, 50, 51, 77, 100])
    alone, _ = TracedScene(scene).render_pixels(pixels)
    assert np.array_equal(alone, whole.reshape(-1, 3)[pixels])
    columns, _ = TracedScene(scene).render_rows(np.arange(9), max_samples=8)  # pieces of a row's columns
    assert np.array_equal(columns, whole)


def test_glass_rotations_differ_by_sample_and_depth_and_keep_the_pairs_stratified() -> None:
    """A camera sample's rotation differs from its neighbour's and from its own at the next depth; the pairs turned
    by one rotation still put one u1 in each of the glossy_samples strata."""
    from tracer.geometry import camera as cam
    from tracer.geometry.lightsamples import glossy_pairs
    from tracer.tracing.glossy import rotated

    turns = cam.glass_rotations(0, np.array([7, 8, 7]), np.array([3, 3, 2]))
    assert len({tuple(column) for column in turns.T.tolist()}) == 3
    assert tuple(turns[:, 0]) == cam.glass_rotation(0, 7, 3)
    pairs = np.asarray(glossy_pairs(16))
    u1 = rotated(pairs[:, 0], turns[0, 0])
    assert np.all((u1 >= 0.0) & (u1 < 1.0))
    assert sorted(np.floor(u1 * 16).astype(int).tolist()) == list(range(16))


@pytest.mark.parametrize("seed", range(4))
def test_glossy_pairs_shared_out_among_a_pixels_samples_match_the_reference(seed: int) -> None:
    """lightsamples.shared_pairs: 4 or 16 camera samples a pixel take a path's first glossy surface's (and first
    bounce's) pairs in turn, each at its share; the per-pixel reference does the same."""
    document = _glossy_document(seed)
    document["render"]["glossy_samples"] = 8 if seed % 2 else 16
    scene = scene_from_dict(document).with_render(samples=4 if seed % 2 else 16, width=6, height=5)
    assert_matches_reference(scene)


def _one_pixel_plane_under_white_sky(material: dict):
    """A plane of the material under a uniform white sky, one pixel looking down at it (16 glossy pairs, depth 1)
    -> its renders at 1 sample and at 16."""
    document = {
        "materials": {"plane": material},
        "objects": [{"name": "plane", "type": "plane", "material": "plane"}],
        "lights": [{"type": "ambient", "intensity": 0.0}],
        "camera": {"location": [0.0, -30.0, 40.0], "rotation": [36.87, 0.0, 0.0], "type": "ORTHO", "ortho_scale": 0.01},
        "background": {"type": "solid", "color": [1.0, 1.0, 1.0]},
        "render": {"width": 1, "height": 1, "depth": 1, "glossy_samples": 16},
    }
    one = render(scene_from_dict(document), workers=1)
    document["render"]["samples"] = 16
    return one, render(scene_from_dict(document), workers=1)


def test_shared_glossy_pairs_cost_one_ray_each_a_pixel_and_give_the_one_sample_value() -> None:
    """A rough white plane under a uniform white sky, one pixel at 16 samples and 16 pairs: each pair traced once
    for the pixel (as one sample sends), not 16 times each, and the pixel's value the one sample's (every point of
    the plane sees the same sky)."""
    white = {"color": [0.0, 0.0, 0.0], "specular": 0, "glossy": [1.0, 1.0, 1.0], "roughness": 0.5}
    one, shared = _one_pixel_plane_under_white_sky(white)
    # (a pair whose ray would leave below the horizon sends none: 15 of the 16 here, 240 without the sharing)
    assert 12 <= shared.rays.reflection == one.rays.reflection <= 16 and shared.rays.camera == 16
    assert shared.image[0, 0, 0] == pytest.approx(one.image[0, 0, 0], abs=1e-12)
    assert 0.3 < one.image[0, 0, 0] < 1.0 + 1e-9


def test_rough_glass_shares_its_pairs_among_a_pixels_samples_as_a_glossy_lobe_does() -> None:
    """A rough glass plane under a uniform white sky seen from above, one pixel: at 16 samples and 16 pairs each
    camera sample takes one pair at the glass (a reflected and a refracted ray, 32 for the pixel as one sample
    sends, not 512), and the pixel's value stays the sky's white within the pairs' spread (glass passes or
    reflects all of it: each sample's value is 1 up to the microfacet weights' rounding)."""
    glass = {"color": [1.0, 1.0, 1.0], "specular": 0, "transmission": 1.0, "ior": 1.5, "transmission_roughness": 0.5}
    one, shared = _one_pixel_plane_under_white_sky(glass)
    assert shared.rays.camera == 16 and one.rays.camera == 1
    assert 16 <= shared.rays.reflection <= 32 and 16 <= one.rays.reflection <= 32, (shared.rays, one.rays)
    assert shared.image[0, 0] == pytest.approx(one.image[0, 0], abs=0.05)


def _rough_plane_under_a_picture(roughness: float) -> sc.Scene:
    """A black dielectric plane of the given roughness that sees the world alone (glossy_source world), under a
    64 x 128 picture of seeded noise with a bright patch, seen at about 20 degrees above it: its pixels are its glossy
    lobe's reflection of the picture alone."""
    rng = np.random.default_rng(4)
    picture = rng.uniform(0.0, 1.0, (64, 128, 3)).astype(np.float32)
    picture[20:26, 60:70] = 8.0
    material = {"color": [0.0, 0.0, 0.0], "specular": 0, "glossy": [0.04, 0.04, 0.04], "roughness": roughness}
    material.update(glossy_fresnel="schlick", glossy_source="world")
    document = {
        "materials": {"black": material},
        "objects": [{"name": "ground", "type": "plane", "material": "black"}],
        "lights": [],
        "camera": {"location": [0.0, -8.0, 3.0], "rotation": [70.0, 0.0, 0.0], "lens": 35.0},
        "render": {"width": 24, "height": 12, "depth": 0},
    }
    scene = scene_from_dict(document)
    return replace(scene, background=sc.Background(type="image", image=picture))


def test_a_rough_lobe_of_the_world_reflects_its_integral_over_the_picture_not_copies_of_it(monkeypatch) -> None:
    """Roughness 0.6 from 16 samples a point: each sample reads the picture blurred to the solid angle it stands for
    (picture_levels), so every pixel is within 15% of the lobe's integral over the picture (256 samples of it
    unblurred) and their error 5% in the mean; 16 unblurred samples (sharp copies of the noise) miss by up to 34%,
    and 4 blurred ones by 55% (lightsamples.PICTURE_GLOSSY_PAIRS)."""
    from tracer.geometry import lightsamples
    from tracer.scene import picture_levels

    scene = _rough_plane_under_a_picture(0.6)
    blurred = render(scene, workers=1).image
    monkeypatch.setattr(picture_levels, "LEVEL_BIAS", -1e9)  # every sample at the picture's own texels
    sharp = render(scene, workers=1).image
    monkeypatch.setattr(lightsamples, "PICTURE_GLOSSY_PAIRS", 256)
    integral = render(scene.with_render(glossy_samples=256), workers=1).image
    assert np.all(integral > 0.0)
    error, sharp_error = np.abs(blurred / integral - 1.0), np.abs(sharp / integral - 1.0)
    assert error.max() < 0.15 and error.mean() < 0.05, (error.max(), error.mean())
    assert sharp_error.max() > 0.3, sharp_error.max()


@pytest.mark.parametrize("samples", [4, 16])
def test_a_lobe_of_the_worlds_pairs_shared_out_among_a_pixels_samples_match_the_reference(samples: int) -> None:
    """4 or 16 camera samples a pixel take a world lobe's 16 pairs in turn (lightsamples.shared_pairs), each reading
    the picture blurred for its share of the whole lobe; the per-pixel reference does the same."""
    scene = _rough_plane_under_a_picture(0.4).with_render(width=8, height=4, samples=samples)
    assert_matches_reference(scene)
