"""tracer/scene/world_light.py: an image background's irradiance picture against sums over the picture, and the
weight's quadratic against the irradiance it approximates, under the background's rotation and strength."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracer.scene import scene as sc
from tracer.scene import world_light
from tracer.tracing.reference import environment


def _picture(height: int, width: int, radiance) -> np.ndarray:
    """An equirectangular picture (row 0 the zenith) whose texel at elevation e and azimuth a (Blender's u: a =
    (0.5 - u) 2 pi) has radiance(x, y, z) of its direction in each channel."""
    elevation = math.pi * (0.5 - (np.arange(height) + 0.5) / height)
    azimuth = (0.5 - (np.arange(width) + 0.5) / width) * 2.0 * math.pi
    e, a = np.meshgrid(elevation, azimuth, indexing="ij")
    value = radiance(np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e))
    return np.repeat(value[..., None], 3, axis=2).astype(np.float32)


def _lit(picture: np.ndarray, rotation: float = 0.0, strength: float = 1.0) -> world_light.WorldLighting:
    background = sc.Background(type="image", image=picture, rotation=rotation, strength=strength)
    scene = sc.Scene(materials={}, objects=(), lights=(sc.WorldLight(intensity=1.0),), background=background)
    lighting = world_light.lighting(scene)
    assert lighting is not None
    return lighting


def test_a_uniform_picture_is_its_own_irradiance_and_weighs_every_direction_alike() -> None:
    """The irradiance exactly; the weights within 1% of each other (the projection sums texel centres: 0.7%)."""
    lighting = _lit(np.full((40, 80, 3), 0.7, dtype=np.float32), strength=2.0)
    for d in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.6, -0.48, 0.64)):
        assert environment(lighting.irradiance, d) == pytest.approx((1.4, 1.4, 1.4), rel=1e-6)
        assert lighting.weight(d) == pytest.approx(lighting.weight((0.0, 0.0, -1.0)), rel=0.01)


def test_the_irradiance_is_the_cosine_weighted_mean_summed_over_the_picture() -> None:
    """A sky brightening toward the zenith and to one side, 128 x 256: the irradiance looked up at four normals
    against the picture's own texels summed with max(0, n . d) and their solid angles, within 0.5%."""
    picture = _picture(128, 256, lambda x, y, z: 0.3 + np.maximum(z, 0.0) ** 2 * 2.0 + 0.4 * np.maximum(x, 0.0))
    lighting = _lit(picture)
    elevation = math.pi * (0.5 - (np.arange(128) + 0.5) / 128)
    azimuth = (0.5 - (np.arange(256) + 0.5) / 256) * 2.0 * math.pi
    e, a = np.meshgrid(elevation, azimuth, indexing="ij")
    d = np.stack((np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)))
    solid = np.cos(e)  # each texel's solid angle, up to a constant
    for n in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.6, 0.0, -0.8)):
        cosine = np.maximum(np.tensordot(np.array(n), d, axes=1), 0.0) * solid
        truth = float((picture[..., 0] * cosine).sum() / cosine.sum())
        assert environment(lighting.irradiance, n)[0] == pytest.approx(truth, rel=0.005), n


def test_the_weight_follows_the_irradiance_and_turns_with_the_background() -> None:
    """A smooth sky (its irradiance a low-order function): the weight within 3% of the irradiance picture in every
    direction; turned by the Mapping's rotation as the lookups are, the same weight at the turned direction."""
    picture = _picture(64, 128, lambda x, y, z: 1.0 + 0.5 * z + 0.3 * x * y)
    lighting = _lit(picture)
    rng = np.random.default_rng(4)
    for d in rng.normal(size=(20, 3)):
        d = tuple(float(c) for c in d / np.linalg.norm(d))
        assert lighting.weight(d)[0] == pytest.approx(environment(lighting.irradiance, d)[0], rel=0.03), d
    turned = _lit(picture, rotation=30.0)
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    for d in ((0.6, 0.48, 0.64), (0.0, 1.0, 0.0)):
        looked_up = (c * d[0] - s * d[1], s * d[0] + c * d[1], d[2])
        assert turned.weight(d) == pytest.approx(lighting.weight(looked_up), rel=1e-9)


def test_a_sun_in_the_picture_leaves_every_weight_above_its_floor() -> None:
    """Second order rings below 0 opposite a bright spot: the weight is raised to WEIGHT_FLOOR of its mean."""
    picture = np.full((32, 64, 3), 0.1, dtype=np.float32)
    picture[5, 20] = 5000.0
    lighting = _lit(picture)
    rng = np.random.default_rng(2)
    weights = []
    for d in rng.normal(size=(400, 3)):
        weights.append(lighting.weight(tuple(float(c) for c in d / np.linalg.norm(d)))[0])
    assert min(weights) > 0.0


def test_a_read_only_picture_given_again_finds_its_lighting_without_reading_its_bits() -> None:
    """A view's edits hand the same read-only picture over in a new background: the lighting is found by the
    picture's identity (no digest of its bits); another picture, or another rotation, gets its own."""
    picture = np.full((32, 64, 3), 0.4, dtype=np.float32)
    picture[3, 7] = 30.0
    picture.flags.writeable = False
    first = _lit(picture)
    comparisons = sc.ARRAY_COMPARISONS[0]
    assert _lit(picture) is first and sc.ARRAY_COMPARISONS[0] == comparisons
    assert _lit(picture, rotation=10.0) is not first
    brighter = picture * 2.0
    brighter.flags.writeable = False
    assert _lit(brighter) is not first
    assert environment(_lit(brighter).irradiance, (0.0, 0.0, 1.0))[0] == pytest.approx(
        2.0 * environment(first.irradiance, (0.0, 0.0, 1.0))[0], rel=1e-6
    )


def test_a_floors_irradiance_is_the_zeniths_under_a_sky_bright_to_one_side() -> None:
    """A lookup straight up reads the irradiance at the zenith itself, within 0.2% of the picture's own sum (the end
    rows hold the poles'; the rows' centres, 2.8 degrees off, read 3% too much under forest.exr)."""
    picture = _picture(128, 256, lambda x, y, z: 0.2 + 5.0 * np.maximum(0.7 * x + 0.7 * z, 0.0) ** 8)
    elevation = math.pi * (0.5 - (np.arange(128) + 0.5) / 128)
    weight = np.maximum(np.sin(elevation), 0.0) * np.cos(elevation)
    truth = float((picture[..., 0] * weight[:, None]).sum() / (weight.sum() * 256))
    assert environment(_lit(picture).irradiance, (0.0, 0.0, 1.0))[0] == pytest.approx(truth, rel=0.002)
