"""Glass and transparency (materials' transmission, ior, alpha; docs/algorithm.md "Glass and transparency"): the
vectorized tracer equals the per-pixel reference to 1e-9 on random scenes using them (and their passes), and both
give the analytic answers: Fresnel's ((n - 1) / (n + 1))^2 at normal incidence, total internal reflection beyond the
critical angle, a ray through a slab leaving parallel and through a sphere leaving where Snell's law puts it, an
alpha-0 object invisible, alpha 0.5 the mean of the object and no object, shadows through alpha and not glass."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import see_through_scene_document
from tests.test_reference_passes import check_against_reference, with_passes
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, scene_from_dict
from tracer.tracing import reference as rf
from tracer.tracing.images import to_8bit
from tracer.tracing.raystore import RayStore
from tracer.tracing.reference_passes import render_reference_passes
from tracer.tracing.wavefront import TracedScene
from tracer.workers.parallel import render

SEEDS = range(30)
ATOL = 1e-9


def _with_alpha(result) -> np.ndarray:
    if result.alpha is None:
        return result.image
    return np.concatenate((result.image, result.alpha[..., None]), axis=2)


@pytest.mark.parametrize("seed", SEEDS)
def test_random_see_through_scene_matches_reference(seed: int) -> None:
    scene = scene_from_dict(see_through_scene_document(seed))
    expected = np.asarray(rf.render_reference(scene))
    image = _with_alpha(render(scene, workers=1))
    assert image.shape == expected.shape and np.all(np.isfinite(image))
    np.testing.assert_allclose(image, expected, rtol=0, atol=ATOL)


def test_random_see_through_scenes_cover_the_cases() -> None:
    scenes = [scene_from_dict(see_through_scene_document(seed)) for seed in SEEDS]
    materials = [m for scene in scenes for m in scene.materials.values()]
    assert any(m.transmission == 1.0 for m in materials) and any(0.0 < m.transmission < 1.0 for m in materials)
    assert any(m.alpha == 0.0 for m in materials) and any(0.0 < m.alpha < 1.0 for m in materials)
    assert {m.ior for m in materials} >= {0.7, 1.0, 1.45, 2.4}
    assert any(scene.render.film_transparent for scene in scenes) and any(
        obj.holdout for scene in scenes for obj in scene.objects
    )
    assert {scene.render.depth for scene in scenes} == set(range(6))
    # the trees refract, reflect inside (total internal reflection) and pass straight on
    tracer = rf.ReferenceTracer(scenes[3])
    totals = {"refracted": 0, "tir": 0}
    original = rf.refract

    def counting(D, N, eta):
        F, T = original(D, N, eta)
        totals["refracted" if T is not None else "tir"] += 1
        return F, T

    rf.refract = counting
    try:
        for scene in scenes[:10]:
            tracer = rf.ReferenceTracer(scene)
            for j in range(0, scene.render.height, 2):
                for i in range(0, scene.render.width, 2):
                    tracer.pixel(i, j)
    finally:
        rf.refract = original
    assert totals["refracted"] > 100 and totals["tir"] > 0


@pytest.mark.parametrize("seed", range(10))
def test_random_see_through_scene_passes_match_the_reference(seed: int) -> None:
    scene = scene_from_dict(with_passes(see_through_scene_document(seed), seed, samples=(1, 4)[seed % 2]))
    _, result = check_against_reference(scene)
    if seed in (0, 1, 2):  # the Transmission pass holds something
        assert np.any(result.passes["transmission"] != 0.0)


@pytest.mark.parametrize("seed", [1, 4, 7])
def test_see_through_in_two_workers_float32_and_robust(seed: int) -> None:
    scene = scene_from_dict(see_through_scene_document(seed, width=24, height=18))
    one = _with_alpha(render(scene, workers=1))
    np.testing.assert_array_equal(_with_alpha(render(scene, workers=2)), one)
    single = _with_alpha(render(scene.with_render(dtype="float32"), workers=1))
    assert np.all(np.isfinite(single)) and (np.abs(single - one).max(axis=2) < 1e-3).mean() > 0.9
    robust = _with_alpha(render(scene.with_render(numerics="robust"), workers=1))
    assert np.all(np.isfinite(robust)) and (np.abs(robust - one).max(axis=2) < 1e-3).mean() > 0.9


# ---- analytic answers ------------------------------------------------------------------------------------------

SKY = sc.Background(type="sky")


def _glass(**fields) -> sc.Material:
    return sc.Material(color=(1.0, 1.0, 1.0), transmission=1.0, **fields)


def _one_ray_scene(objects, materials, camera, depth=4, lights=(), background=SKY) -> sc.Scene:
    settings = sc.RenderSettings(width=1, height=1, depth=depth)
    return sc.Scene(materials, tuple(objects), tuple(lights), camera, background=background, render=settings)


def _both(scene: sc.Scene) -> tuple[np.ndarray, np.ndarray]:
    return render(scene, workers=1).image[0, 0], np.asarray(rf.render_reference(scene))[0, 0]


def _sky(z: float) -> np.ndarray:
    horizon, zenith = np.asarray(SKY.horizon), np.asarray(SKY.zenith)
    return horizon + (zenith - horizon) * min(max(z, 0.0), 1.0)


@pytest.mark.parametrize("ior", [1.33, 1.45, 2.4])
def test_fresnel_at_normal_incidence(ior: float) -> None:
    # a camera looking straight down -Z at a glass plane: the mirror ray goes up (the zenith), the refracted one on
    # down (the horizon), so the pixel is F zenith + (1 - F) horizon
    plane = sc.Plane(name="pane", material="glass", location=(0.0, 0.0, -2.0))
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0))
    scene = _one_ray_scene([plane], {"glass": _glass(ior=ior)}, camera)
    expected_F = ((ior - 1.0) / (ior + 1.0)) ** 2
    for pixel in _both(scene):
        F = (pixel - _sky(-1.0)) / (_sky(1.0) - _sky(-1.0))
        np.testing.assert_allclose(F, expected_F, rtol=0, atol=1e-12)
    F, T = rf.refract((0.0, 0.0, -1.0), (0.0, 0.0, 1.0), ior)
    assert math.isclose(F, expected_F, abs_tol=1e-15)
    np.testing.assert_allclose(T, (0.0, 0.0, -1.0), rtol=0, atol=1e-15)
    assert math.isclose(rf.fresnel(1.0, ior), expected_F, abs_tol=1e-15)


@pytest.mark.parametrize(("tilt", "total"), [(60.0, True), (43.0, False)])
def test_total_internal_reflection_beyond_the_critical_angle(tilt: float, total: bool) -> None:
    # the camera inside the glass (behind the plane's normal) looks at it tilted by `tilt` degrees; the critical
    # angle for n = 1.45 is asin(1 / 1.45) = 43.6 degrees: beyond it everything is reflected (F = 1)
    ior = 1.45
    plane = sc.Plane(name="pane", material="glass", location=(0.0, 0.0, -2.0), rotation=(180.0, 0.0, 0.0))
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(tilt, 0.0, 0.0))
    scene = _one_ray_scene([plane], {"glass": _glass(ior=ior)}, camera)
    D = (0.0, math.sin(math.radians(tilt)), -math.cos(math.radians(tilt)))
    reflected_z = -D[2]
    F, T = rf.refract(D, (0.0, 0.0, 1.0), 1.0 / ior)
    assert math.degrees(math.asin(1.0 / ior)) == pytest.approx(43.6, abs=0.05)
    if total:
        assert F == 1.0 and T is None
        expected = _sky(reflected_z)
    else:
        assert 0.0 < F < 1.0 and T is not None
        sin_t = math.sin(math.radians(tilt)) * ior  # Snell leaving the glass
        assert math.hypot(T[0], T[1]) == pytest.approx(sin_t, abs=1e-12)
        expected = F * _sky(reflected_z) + (1.0 - F) * _sky(T[2])
    for pixel in _both(scene):
        np.testing.assert_allclose(pixel, expected, rtol=0, atol=1e-12)


def _segments(scene: sc.Scene):
    """Every camera, mirror, refracted and straight segment of the single pixel's ray tree (no shadow rays)."""
    store = RayStore()
    TracedScene(scene).render_pixels(np.array([0]), store=store)
    segments = store.segments()
    return segments.take(np.flatnonzero(segments.light < 0))


def test_a_ray_through_a_glass_slab_leaves_parallel_and_shifted_by_snell() -> None:
    ior, tilt, thickness = 1.5, 35.0, 1.0
    slab = sc.Box(name="slab", material="glass", location=(0.0, 0.0, 0.0), size=(20.0, 20.0, thickness))
    camera = sc.Camera(location=(0.0, -3.0, 4.0), rotation=(tilt, 0.0, 0.0))
    scene = _one_ray_scene([slab], {"glass": _glass(ior=ior)}, camera)
    D = np.array([0.0, math.sin(math.radians(tilt)), -math.cos(math.radians(tilt))])
    O = np.array(camera.location)
    entry = O + D * ((O[2] - thickness / 2) / -D[2])
    inside = math.asin(math.sin(math.radians(tilt)) / ior)
    exit_point = entry + np.array([0.0, thickness * math.tan(inside), -thickness])
    segments = _segments(scene)
    # the rays leaving the bottom face downward: first where Snell's law puts the exit, then further on after
    # reflections inside; all parallel to the incoming ray
    leaving = [k for k in range(segments.pixel.size) if abs(segments.O[2, k] + thickness / 2) < 1e-9]
    downward = [k for k in leaving if segments.D[2, k] < 0.0]
    assert len(downward) >= 1
    for k in downward:
        np.testing.assert_allclose(segments.D[:, k], D, rtol=0, atol=1e-12)
    first = min(downward, key=lambda k: segments.O[1, k])
    np.testing.assert_allclose(segments.O[:, first], exit_point, rtol=0, atol=1e-12)
    # the lateral shift Snell's law gives: t sin(i - r) / cos(r)
    shift = np.linalg.norm(np.cross(exit_point - entry, D))
    assert shift == pytest.approx(thickness * math.sin(math.radians(tilt) - inside) / math.cos(inside), abs=1e-12)
    for pixel in _both(scene):  # both tracers see the same
        assert np.all(np.isfinite(pixel))
    a, b = _both(scene)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_a_ray_through_a_glass_sphere_leaves_where_snell_puts_it() -> None:
    ior, radius, height = 1.45, 1.0, 0.5
    ball = sc.Sphere(name="ball", material="glass", location=(0.0, 0.0, 0.0), radius=radius)
    camera = sc.Camera(location=(0.0, height, 5.0), rotation=(0.0, 0.0, 0.0))  # one ray along -Z at y = 0.5
    scene = _one_ray_scene([ball], {"glass": _glass(ior=ior)}, camera, depth=2)
    incidence = math.asin(height / radius)
    refraction = math.asin(math.sin(incidence) / ior)
    # in the y-z plane: the entry point at angle `incidence` from +Z; the chord turns by pi - 2 r about the centre
    entry_angle = incidence
    exit_angle = entry_angle + math.pi - 2.0 * refraction  # measured from +Z toward +Y
    exit_point = np.array([0.0, radius * math.sin(exit_angle), radius * math.cos(exit_angle)])
    deviation = 2.0 * (incidence - refraction)  # toward the axis: the ray bends down (toward -Y)
    out = np.array([0.0, -math.sin(deviation), -math.cos(deviation)])
    segments = _segments(scene)
    near = [k for k in range(segments.pixel.size) if np.linalg.norm(segments.O[:, k] - exit_point) < 1e-9]
    outward = [k for k in near if np.dot(segments.D[:, k], segments.O[:, k]) > 0.0]  # leaving the sphere
    assert len(outward) == 1
    np.testing.assert_allclose(segments.D[:, outward[0]], out, rtol=0, atol=1e-12)
    a, b = _both(scene)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def _default_with(extra: list[sc.SceneObject], materials: dict[str, sc.Material]) -> sc.Scene:
    base = default_scene().with_render(width=64, height=48)
    return replace(base, objects=(*base.objects, *extra), materials={**base.materials, **materials})


def test_an_alpha_0_object_is_invisible() -> None:
    # a sphere and a card of alpha 0 in front of the vane: the image (and its PNG bytes) is the scene without them;
    # they cast no shadow either
    veil = sc.Material(color=(1.0, 0.9, 0.1), specular=50.0, reflective=0.3, alpha=0.0)
    extra = [
        sc.Sphere(name="ghost", material="veil", location=(2.3, -2.7, 2.6), radius=0.5),
        sc.Plane(name="card", material="veil", location=(1.2, -1.5, 1.4), rotation=(80.0, 0.0, 40.0), size=(1, 1)),
    ]
    without = render(default_scene().with_render(width=64, height=48), workers=1).image
    scene = _default_with(extra, {"veil": veil})
    result = render(scene, workers=1)
    # the straight rays start again at the hits (from P, not the eye): the same surfaces, t rounded apart
    np.testing.assert_allclose(result.image, without, rtol=0, atol=1e-9)
    assert np.array_equal(to_8bit(result.image), to_8bit(without))
    np.testing.assert_allclose(np.asarray(rf.render_reference(scene)), without, rtol=0, atol=1e-9)


def test_alpha_one_half_is_the_mean_of_the_object_and_no_object() -> None:
    # a single card (one surface, hidden from shadow rays) in front of matte objects: every ray crosses it at most
    # once, so alpha 0.5 gives the mean of the opaque card's image and the image without it
    card = sc.Plane(
        name="card", material="card", location=(2.0, -2.4, 2.2), rotation=(80.0, 0.0, 40.0), size=(1.6, 1.0),
        visible_shadow=False,
    )  # fmt: skip
    base = default_scene().with_render(width=48, height=36, depth=0)
    matte = {name: replace(m, reflective=0.0) for name, m in base.materials.items()}
    base = replace(base, materials=matte)
    paint = sc.Material(color=(0.2, 0.7, 0.9), specular=20.0)
    opaque = replace(base, objects=(*base.objects, card), materials={**matte, "card": paint})
    half = replace(opaque, materials={**matte, "card": replace(paint, alpha=0.5)})
    mean = 0.5 * render(opaque, workers=1).image + 0.5 * render(base, workers=1).image
    got = render(half, workers=1).image
    np.testing.assert_allclose(got, mean, rtol=0, atol=1e-12)
    assert np.abs(render(opaque, workers=1).image - render(base, workers=1).image).max() > 0.1  # the card shows
    np.testing.assert_allclose(np.asarray(rf.render_reference(half)), got, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("cards", "through"),
    [((("glass", 1.0),), 0.0), ((("veil", 0.5),), 0.5), ((("veil", 0.5), ("veil", 0.5)), 0.25), ((), 1.0)],
)
def test_shadows_pass_alpha_and_not_glass(cards: tuple, through: float) -> None:
    # a floor lit from straight above (diffuse i, ambient a) under cards the camera does not see: its pixel is
    # (a + through * i) * colour, through the product of 1 - alpha (a glass card, alpha 1, blocks: caustics off)
    materials = {
        "floor": sc.Material(color=(0.5, 0.5, 0.5)),
        "glass": sc.Material(color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.5),
        "veil": sc.Material(color=(1.0, 0.0, 0.0), alpha=0.5),
        "unused": sc.Material(alpha=0.5),  # the scene always has a partly transparent material
    }
    floor = sc.Plane(name="floor", material="floor", location=(0.0, 0.0, 0.0))
    objects = [floor] + [
        sc.Plane(name=f"card{k}", material=name, location=(0.0, 0.0, 1.0 + k), size=(2.0, 2.0), visible_camera=False)
        for k, (name, _) in enumerate(cards)
    ]
    camera = sc.Camera(location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0))
    lights = (sc.AmbientLight(0.2), sc.PointLight((0.0, 0.0, 4.0), 0.7))
    scene = _one_ray_scene(objects, materials, camera, depth=2, lights=lights)
    for pixel in _both(scene):
        np.testing.assert_allclose(pixel, (0.2 + through * 0.7) * 0.5, rtol=0, atol=1e-12)


def test_a_glass_object_hidden_from_the_camera_still_refracts_for_mirrors() -> None:
    # visibility flags: the camera does not see the ball; a mirror ray (a transmission ray counts as one) does
    camera = sc.Camera(location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0))
    ball = sc.Sphere(name="ball", material="glass", location=(0.0, 0.0, 0.0), radius=1.0, visible_camera=False)
    scene = _one_ray_scene([ball], {"glass": _glass(ior=1.45)}, camera)
    for pixel in _both(scene):
        np.testing.assert_allclose(pixel, _sky(-1.0), rtol=0, atol=1e-12)  # straight on to the horizon


def test_frames_traced_together_with_glass_are_each_frame_alone() -> None:
    from tests.test_incremental import assert_frames_together_are_frames_alone, random_headings, turning_scene

    scene = turning_scene(2, "float64", "documented")
    materials = dict(scene.materials)
    materials["mirror"] = replace(materials["mirror"], transmission=0.7, ior=1.4, alpha=0.6)
    scene = replace(scene, materials=materials).with_render(width=24, height=18, depth=3)
    assert_frames_together_are_frames_alone(scene, random_headings(2, 3), 2)


def test_edits_of_a_see_through_scene_give_the_whole_render() -> None:
    from tracer.frames import edits

    document = see_through_scene_document(3, width=24, height=18)
    document["render"].pop("border", None)  # the editable image is the whole image's colours
    document["render"]["depth"] = 3
    scene = scene_from_dict(document)
    image = edits.EditableImage(scene)
    assert np.array_equal(image.image, render(scene, workers=1).image)
    name = sorted(scene.materials)[0]
    for material in (replace(scene.materials[name], color=(0.1, 0.9, 0.2)), replace(scene.materials[name], ior=2.0)):
        edited = image.apply(edits.MaterialEdit(name, material))
        assert np.array_equal(edited, render(image.scene, workers=1).image)
    changed = replace(scene, materials={**scene.materials, name: replace(scene.materials[name], alpha=0.3)})
    assert edits.edits_between(scene, changed) is None  # alpha changes what shadow rays pass: a whole render


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("transmission", 1.5, "materials.m0.transmission: must be <= 1, got 1.5"),
        ("transmission", -0.1, "materials.m0.transmission: must be >= 0, got -0.1"),
        ("ior", 0, "materials.m0.ior: must be > 0, got 0"),
        ("ior", "glass", "materials.m0.ior: must be a number"),
        ("alpha", 2, "materials.m0.alpha: must be <= 1, got 2"),
    ],
)
def test_bad_glass_fields_are_named(field: str, value: object, message: str) -> None:
    document = see_through_scene_document(0)
    document["materials"]["m0"][field] = value
    with pytest.raises(SceneError, match=message.replace("(", r"\(")):
        scene_from_dict(document)


def test_the_defaults_are_the_documented_model() -> None:
    # the fields written out at their defaults: the same bytes as without them, and no see-through code runs
    document = see_through_scene_document(5)
    for material in document["materials"].values():
        material.update(transmission=0.0, ior=1.45, alpha=1.0)
    scene = scene_from_dict(document)
    prepared = TracedScene(scene)
    assert not prepared.see_through and not prepared.shadow_alpha
    for material in document["materials"].values():
        for field in ("transmission", "ior", "alpha"):
            del material[field]
    assert np.array_equal(render(scene, workers=1).image, render(scene_from_dict(document), workers=1).image)


@pytest.mark.parametrize("seed", range(4))
def test_textured_glass_tints_its_refraction_by_the_texture(seed: int) -> None:
    # random textured scenes (tests/test_textures.py) with their textured materials made partly glass and partly
    # transparent: the refracted rays take the texture's colour at the hit, in both tracers
    from tests.test_textures import textured_scene_document

    document = textured_scene_document(seed)
    for material in document["materials"].values():
        if "texture" in material:
            material.update(transmission=0.6, ior=1.3, alpha=0.8)
    scene = scene_from_dict(document)
    assert any(m.texture is not None and m.see_through for m in scene.materials.values())
    expected = np.asarray(rf.render_reference(scene))
    np.testing.assert_allclose(_with_alpha(render(scene, workers=1)), expected, rtol=0, atol=ATOL)


@pytest.mark.parametrize(
    "camera",
    [
        {"type": "ORTHO", "ortho_scale": 7.0, "clip_start": 0.5},
        {"shift_x": 0.2, "shift_y": -0.1, "clip_start": 2.0, "clip_end": 7.5},
    ],
)
@pytest.mark.parametrize("seed", [1, 2, 9])
def test_see_through_scenes_through_other_cameras_match_the_reference(seed: int, camera: dict) -> None:
    # a camera ray's straight continuation keeps what is left of the clip_end; an orthographic camera's rays
    # start on the sensor
    document = see_through_scene_document(seed)
    document["camera"].update(camera)
    scene = scene_from_dict(document)
    expected = np.asarray(rf.render_reference(scene))
    np.testing.assert_allclose(_with_alpha(render(scene, workers=1)), expected, rtol=0, atol=ATOL)


@pytest.mark.parametrize(("alpha", "shows_card"), [(0.0, False), (0.3, False), (0.5, True), (0.8, True)])
def test_data_passes_show_the_first_surface_of_alpha_at_least_one_half(alpha: float, shows_card: bool) -> None:
    # Cycles' Alpha Threshold (0.5): a card of alpha below it leaves the depth, indices and Cryptomatte to the wall
    # behind; at or above it they are the card's
    from tests.test_passes import plane_scene

    wall = plane_scene(4.0, passes=("depth", "object_index", "material_index", "cryptomatte_object"))
    card = sc.Plane(name="card", material="card", location=(0.0, 0.0, -2.0), pass_index=9)
    materials = {**wall.materials, "card": sc.Material(color=(0.9, 0.1, 0.1), alpha=alpha, pass_index=5)}
    scene = replace(wall, objects=(*wall.objects, card), materials=materials)
    passes = render(scene, workers=1).passes
    np.testing.assert_allclose(passes["depth"], 2.0 if shows_card else 4.0, rtol=0, atol=1e-12)
    assert np.all(passes["object_index"] == (9 if shows_card else 3))
    assert np.all(passes["material_index"] == (5 if shows_card else 7))
    expected = render_reference_passes(scene)
    assert {name for row in expected.objects for samples in row for name in samples} == {
        "card" if shows_card else "wall"
    }
    np.testing.assert_allclose(np.asarray(expected.values["depth"])[..., 0], passes["depth"][..., 0], atol=1e-12)


def _forced(scene: sc.Scene) -> TracedScene:
    """The scene prepared as if some material were see-through (every alpha 1, transmission 0): trace() takes
    see_through.py's stages."""
    prepared = TracedScene(scene)
    count = len(prepared.reflective)
    prepared.see_through = True
    prepared.alpha, prepared.transmission = np.ones(count), np.zeros(count)
    prepared.ior = np.full(count, 1.45)
    return prepared


@pytest.mark.parametrize("seed", [None, *range(8)])
def test_the_see_through_way_with_nothing_see_through_is_the_documented_one(seed: int | None) -> None:
    # see_through.py's stages with every alpha 1 and transmission 0 give the Whitted stages' bytes, passes and ray
    # counts: the general wavefront reduces to the mirror-only one (the default scene, and scenes with Blender's
    # fields and passes)
    from tests.random_scenes import extended_scene_document

    if seed is None:
        scene = default_scene().with_render(width=64, height=48)
    else:
        document = with_passes(extended_scene_document(seed, width=20, height=15), seed, samples=(1, 4)[seed % 2])
        document["render"].pop("border", None)
        scene = scene_from_dict(document)
    rows = np.arange(scene.render.height)
    plain, plain_counts = TracedScene(scene).render_rows(rows)
    forced, forced_counts = _forced(scene).render_rows(rows)
    assert np.array_equal(forced, plain)
    assert forced_counts == plain_counts
