"""Lighting against the seed's formulas worked by hand: a sphere seen head-on and a plane seen at 45 degrees."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tracer.scene import scene as sc
from tracer.tracing.reference import render_reference
from tracer.workers.parallel import render

COLOR = (0.5, 0.25, 0.1)
# a 3 x 3 image from (0, -5, 0) looking along +Y: the centre pixel's ray hits the unit sphere at P = (0, -1, 0)
HEAD_ON = sc.Camera(location=(0, -5, 0), rotation=(90, 0, 0), lens=50)


def centre_pixel(scene: sc.Scene) -> np.ndarray:
    image = render(scene, workers=1).image
    reference = np.asarray(render_reference(scene))
    np.testing.assert_allclose(image, reference, rtol=0, atol=1e-12)
    return image[scene.render.height // 2, scene.render.width // 2]


def sphere_scene(
    lights: tuple[sc.Light, ...],
    model: str = "phong",
    specular: float = 10.0,
    coef: float = 3.0,
    reflective: float = 0.0,
    extra: tuple[sc.SceneObject, ...] = (),
) -> sc.Scene:
    material = sc.Material(color=COLOR, specular=specular, reflective=reflective)
    return sc.Scene(
        materials={"m": material, "black": sc.Material(color=(0, 0, 0))},
        objects=(sc.Sphere(name="ball", material="m", radius=1.0), *extra),
        lights=lights,
        camera=HEAD_ON,
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=3, height=3, depth=0, model=model, coef=coef),
    )


def test_ambient_only() -> None:
    pixel = centre_pixel(sphere_scene((sc.AmbientLight(0.3),)))
    assert pixel == pytest.approx([0.3 * c for c in COLOR], abs=1e-12)


def test_head_on_point_light_diffuse_and_phong_specular() -> None:
    # N = (0,-1,0), L = (0,-4,0): diffuse i * 4/4; R = 2N(N.L) - L = L, V = -D = N: specular i * 1^s
    pixel = centre_pixel(sphere_scene((sc.AmbientLight(0.2), sc.PointLight(location=(0, -5, 0), intensity=0.6))))
    assert pixel == pytest.approx([(0.2 + 0.6 + 0.6) * c for c in COLOR], abs=1e-12)


@pytest.mark.parametrize("model", ["phong", "blinn-phong"])
def test_oblique_point_light(model: str) -> None:
    i, s, coef = 0.5, 4.0, 3.0
    # P = (0,-1,0), L = (3,-3,0): cos(N, L) = 1/sqrt2; Phong: R = (-3,-3,0), cos(R, V) = 1/sqrt2;
    # Blinn-Phong: H = L/|L| + V, the half-way angle is 22.5 degrees from N
    scene = sphere_scene((sc.PointLight(location=(3, -4, 0), intensity=i),), model=model, specular=s, coef=coef)
    diffuse = i / math.sqrt(2)
    specular = i * (1 / math.sqrt(2)) ** s if model == "phong" else i * math.cos(math.radians(22.5)) ** (s * coef)
    assert centre_pixel(scene) == pytest.approx([(diffuse + specular) * c for c in COLOR], abs=1e-12)


def test_directional_light_keeps_its_length_and_casts_no_falloff() -> None:
    scene = sphere_scene((sc.DirectionalLight(direction=(0, -2, 0), intensity=0.3),), specular=0.0)
    assert centre_pixel(scene) == pytest.approx([0.3 * c for c in COLOR], abs=1e-12)


def test_matte_material_has_no_specular() -> None:
    scene = sphere_scene((sc.PointLight(location=(0, -5, 0), intensity=0.6),), specular=0.0)
    assert centre_pixel(scene) == pytest.approx([0.6 * c for c in COLOR], abs=1e-12)


def test_blocker_between_point_light_and_surface_casts_a_shadow() -> None:
    # the light comes from +X so that the blocker stays out of the camera ray
    lights = (sc.AmbientLight(0.1), sc.PointLight(location=(5, -1, 0), intensity=0.6))
    blocker = sc.Sphere(name="blocker", material="black", location=(2.5, -1, 0), radius=0.2)
    assert centre_pixel(sphere_scene(lights, extra=(blocker,))) == pytest.approx([0.1 * c for c in COLOR], abs=1e-12)


def test_blocker_beyond_the_point_light_casts_no_shadow() -> None:
    # shadow rays to point lights search t in (0.001, 1): only what lies between the surface and the light
    lights = (sc.PointLight(location=(5, -1, 0), intensity=0.6),)
    beyond = sc.Sphere(name="beyond", material="black", location=(8, -1, 0), radius=0.5)
    unlit = centre_pixel(sphere_scene(lights, specular=0.0))
    assert centre_pixel(sphere_scene(lights, specular=0.0, extra=(beyond,))) == pytest.approx(unlit, abs=1e-12)
    assert unlit == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)  # the light is at 90 degrees: N.L = 0


def test_directional_shadow_reaches_infinity() -> None:
    far = sc.Sphere(name="far", material="black", location=(0, -100, 0), radius=5)
    lights = (sc.DirectionalLight(direction=(0, -1, 0), intensity=0.4),)
    assert centre_pixel(sphere_scene(lights, extra=(far,))) == pytest.approx([0, 0, 0], abs=1e-12)


def test_reflection_mixes_local_and_mirrored_color() -> None:
    # the ball reflects the head-on ray straight back into a white wall behind the camera: no light, ambient 1
    wall = sc.Plane(name="wall", material="white", location=(0, -6, 0), rotation=(-90, 0, 0))
    scene = sphere_scene((sc.AmbientLight(1.0),), specular=0.0, reflective=0.25, extra=(wall,))
    scene = replace(scene, materials={**scene.materials, "white": sc.Material(color=(1, 1, 1))}).with_render(depth=1)
    assert centre_pixel(scene) == pytest.approx([0.75 * c + 0.25 for c in COLOR], abs=1e-12)
    assert centre_pixel(scene.with_render(depth=0)) == pytest.approx([0.75 * c for c in COLOR], abs=1e-12)


def plane_scene(gate: bool, model: str = "blinn-phong") -> sc.Scene:
    # camera 45 degrees above the floor: the centre ray hits the origin with V = (0, -1, 1)/sqrt2;
    # the directional light sits just below the horizon, so N.L < 0
    return sc.Scene(
        materials={"m": sc.Material(color=COLOR, specular=1.0)},
        objects=(sc.Plane(name="floor", material="m"),),
        lights=(sc.AmbientLight(0.1), sc.DirectionalLight(direction=(0, -1, -0.1), intensity=0.5)),
        camera=sc.Camera(location=(0, -5, 5), rotation=(45, 0, 0)),
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=3, height=3, depth=0, model=model, coef=2.0, gate_specular=gate),
    )


def test_documented_mode_adds_specular_below_the_horizon() -> None:
    light = np.array([0, -1, -0.1]) / math.sqrt(1.01)
    view = np.array([0, -1, 1]) / math.sqrt(2)
    half = light + view
    specular = 0.5 * (half[2] / np.linalg.norm(half)) ** 2.0
    assert centre_pixel(plane_scene(gate=False)) == pytest.approx([(0.1 + specular) * c for c in COLOR], abs=1e-12)
    assert centre_pixel(plane_scene(gate=True)) == pytest.approx([0.1 * c for c in COLOR], abs=1e-12)


def test_backgrounds() -> None:
    base = sphere_scene((sc.AmbientLight(1.0),))
    camera_up = sc.Camera(location=(0, -5, 0), rotation=(180, 0, 0))  # looks straight up
    sky = sc.Background(type="sky", horizon=(1, 0, 0), zenith=(0, 0, 1), color=(0, 1, 0))
    up = replace(base, camera=camera_up, background=sky)
    assert centre_pixel(up) == pytest.approx([0, 0, 1], abs=1e-12)
    assert centre_pixel(replace(up, background=replace(sky, type="solid"))) == pytest.approx([0, 1, 0])
    assert centre_pixel(replace(up, background=replace(sky, type="none"))) == pytest.approx([0, 0, 0])
    # the documented mode: every miss takes the sky's color at the canvas centre, here the horizon
    level = replace(
        base, camera=sc.Camera(location=(0, -5, 3), rotation=(90, 0, 0)), background=replace(sky, type="documented")
    )
    image = render(level.with_render(width=5, height=5), workers=1).image
    assert np.allclose(image, [1, 0, 0])
