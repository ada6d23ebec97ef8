"""Render passes (tracer/scene/passes.py, tracer/tracing/recorder.py): asking for them leaves the image's bytes as
they were, the Whitted passes add up to the image, and the data passes hold what the scene's geometry says they must
(a plane at a known distance, objects' and materials' pass indices, the mist's falloff)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tests.random_scenes import extended_scene_document
from tracer.scene import passes as ps
from tracer.scene import scene as sc
from tracer.scene.loader import SceneError, default_scene, default_scene_dict, scene_from_dict
from tracer.workers.parallel import render

SHADING_AND_DATA = tuple(name for name in ps.PASSES if not name.startswith("cryptomatte"))


@pytest.mark.parametrize("seed", range(12))
def test_passes_leave_the_image_as_it_was_and_the_whitted_passes_add_up_to_it(seed: int) -> None:
    document = extended_scene_document(seed, width=24, height=18)
    document["render"]["samples"] = [1, 4][seed % 2]
    document["render"]["dtype"] = ["float64", "float64", "float32"][seed % 3]
    document["render"]["model"] = ["phong", "blinn-phong"][seed % 2]
    plain = scene_from_dict(document)
    with_passes = plain.with_render(passes=SHADING_AND_DATA)
    expected, result = render(plain, workers=1), render(with_passes, workers=2)
    assert np.array_equal(result.image, expected.image)
    assert (result.alpha is None) == (expected.alpha is None)
    if expected.alpha is not None:
        assert np.array_equal(result.alpha, expected.alpha)
    assert set(result.passes) == set(SHADING_AND_DATA)
    for name, values in result.passes.items():
        assert values.shape == (*result.image.shape[:2], ps.width(name)), name
    total = sum(result.passes[name].astype(np.float64) for name in ps.WHITTED)
    # the same terms added in another order: a few units in the last place of the image's dtype
    tolerance = 8 * np.finfo(result.image.dtype).eps * np.maximum(1.0, np.abs(result.image))
    assert np.all(np.abs(total - result.image) <= tolerance)


@pytest.mark.parametrize("seed", range(6))
def test_with_glass_and_transparency_the_passes_with_transmission_add_up_to_the_image(seed: int) -> None:
    from tests.random_scenes import see_through_scene_document

    document = see_through_scene_document(seed, width=24, height=18)
    document["render"]["samples"] = [1, 4][seed % 2]
    document["render"]["dtype"] = ["float64", "float64", "float32"][seed % 3]
    plain = scene_from_dict(document)
    expected, result = render(plain, workers=1), render(plain.with_render(passes=SHADING_AND_DATA), workers=2)
    assert np.array_equal(result.image, expected.image)
    assert "transmission" in ps.WHITTED
    total = sum(result.passes[name].astype(np.float64) for name in ps.WHITTED)
    tolerance = 16 * np.finfo(result.image.dtype).eps * np.maximum(1.0, np.abs(result.image))
    assert np.all(np.abs(total - result.image) <= tolerance)
    if seed < 3:
        assert np.any(result.passes["transmission"] != 0.0)


def test_a_glass_pane_s_passes_are_its_fresnel_shares() -> None:
    # a camera looking straight at a glass pane (n = 1.5, white) under the sky: its mirror ray sees the zenith
    # (Environment: F zenith), its refracted ray the horizon (Transmission: (1 - F) horizon), nothing is shaded
    glass = sc.Material(color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.5)
    pane = sc.Plane(name="pane", material="glass", location=(0.0, 0.0, -2.0))
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0))
    settings = sc.RenderSettings(width=1, height=1, passes=SHADING_AND_DATA)
    scene = sc.Scene({"glass": glass}, (pane,), (sc.AmbientLight(0.3),), camera, render=settings)
    passes = render(scene, workers=1).passes
    F = (0.5 / 2.5) ** 2
    sky = scene.background
    np.testing.assert_allclose(passes["environment"][0, 0], F * np.asarray(sky.zenith), rtol=0, atol=1e-12)
    np.testing.assert_allclose(passes["transmission"][0, 0], (1 - F) * np.asarray(sky.horizon), rtol=0, atol=1e-12)
    for name in ("ambient", "diffuse", "specular", "emission", "reflection"):
        assert np.all(passes[name] == 0.0), name
    assert passes["depth"][0, 0, 0] == pytest.approx(2.0)  # the data passes are the pane's


def test_an_alpha_one_half_wall_s_passes_are_half_the_wall_s_and_half_the_sky() -> None:
    opaque = plane_scene(4.0, passes=SHADING_AND_DATA)
    half = replace(opaque, materials={"wall": replace(opaque.materials["wall"], alpha=0.5)})
    wall, seen = render(opaque, workers=1).passes, render(half, workers=1).passes
    for name in ("ambient", "diffuse", "specular"):
        np.testing.assert_allclose(seen[name], 0.5 * wall[name], rtol=0, atol=1e-12)
    behind = render(replace(opaque, objects=()), workers=1).passes["environment"]  # the sky beyond the wall
    np.testing.assert_allclose(seen["transmission"], 0.5 * behind, rtol=0, atol=1e-12)
    assert np.all(seen["environment"] == 0.0) and np.any(behind > 0.0)


def whole_image_passes(scene: sc.Scene, max_samples: int | None) -> dict[str, np.ndarray]:
    """Every row of the scene traced in one process through render_rows in pieces of at most max_samples camera
    samples (None: all at once): the passes' planes."""
    from tracer.tracing.recorder import plane_dtype, plane_shape
    from tracer.tracing.wavefront import TracedScene

    settings = scene.render
    planes = {
        name: np.full(
            plane_shape(name, settings.height, settings.width, settings.cryptomatte_levels),
            np.nan,
            plane_dtype(name, settings.dtype),
        )
        for name in settings.passes
    }
    prepared = TracedScene(scene)
    for rows in (np.arange(0, settings.height, 2), np.arange(1, settings.height, 2)):  # two bands of every 2nd row
        prepared.render_rows(rows, max_samples, passes=planes)
    return planes


@pytest.mark.parametrize(
    ("samples", "border"), [(1, None), (4, None), (1, [0.2, 0.1, 0.9, 0.7]), (4, [0.1, 0.3, 0.6, 1.0])]
)
def test_passes_are_the_same_bytes_in_pieces_of_rows_or_of_a_rows_columns(samples: int, border) -> None:
    """A band traced whole, in pieces of whole rows, or in pieces of one row's columns gives every pass the same
    bytes, and every pixel of every pass is written (the planes start as NaN)."""
    document = extended_scene_document(5, width=23, height=14)
    document["render"].update(samples=samples, passes=list(ps.PASSES))
    if border is not None:
        document["render"]["border"] = border
    scene = scene_from_dict(document)
    whole = whole_image_passes(scene, None)
    for max_samples in (3 * 23 * samples, 5 * samples):  # 3 rows at a time; 5 columns of a row at a time
        pieces = whole_image_passes(scene, max_samples)
        for name, plane in whole.items():
            assert not np.isnan(plane).any(), name
            assert np.array_equal(pieces[name], plane), (name, max_samples)


def test_a_held_results_passes_keep_their_bytes_while_later_frames_use_the_image_file() -> None:
    """The passes lie in the frame's shared file beside the image: a file is used again only once no array of its
    frame is held, the passes' included."""
    from tracer.workers.parallel import Renderer

    scene = default_scene().with_render(width=48, height=36, passes=("depth", "normal", "cryptomatte_object"))
    turned = scene.with_heading(90.0)
    with Renderer(2) as renderer:
        held = renderer.render(scene).passes  # the image goes; its file's passes stay held
        copies = {name: values.copy() for name, values in held.items()}
        for _ in range(3):
            later = renderer.render(turned)
        assert not np.array_equal(later.passes["normal"], copies["normal"])
    for name, values in held.items():
        assert np.array_equal(values, copies[name]), name
        assert np.array_equal(values, render(scene, workers=1).passes[name]), name


def test_passes_of_frames_whose_image_file_is_not_kept_are_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    """A large frame's file goes with the frame: each band's mapping of it closes once the band is written (no pass
    array may still use it), and the frames' passes are whole."""
    from tracer.workers import parallel

    monkeypatch.setattr(parallel, "KEEP_IMAGE_BYTES", 0)
    scene = default_scene().with_render(width=40, height=30, passes=tuple(ps.PASSES))
    expected = render(scene, workers=1)
    with parallel.Renderer(2) as renderer:
        results = [renderer.render(scene) for _ in range(2)]
    for result in results:
        for name, values in expected.passes.items():
            assert np.array_equal(result.passes[name], values), name


def test_passes_come_back_from_the_workers_where_there_is_no_shared_memory() -> None:
    from tracer.workers.parallel import Renderer

    scene = default_scene().with_render(width=40, height=30, samples=4, passes=tuple(ps.PASSES))
    expected = render(scene, workers=1)
    with Renderer(2) as renderer:
        renderer._images = None  # as where the system has no memfd: bands (and their passes) come back pickled
        result = renderer.render(scene)
    assert np.array_equal(result.image, expected.image)
    for name, values in expected.passes.items():
        assert np.array_equal(result.passes[name], values), name


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_pixels_samples_add_up_to_the_same_bits_as_numpys_sum(dtype: str) -> None:
    from tracer.tracing.recorder import _sample_sum

    generator = np.random.default_rng(7)
    for samples in (2, 3, 4, 5, 7, 8, 9, 16):
        values = generator.standard_normal((3, 500 * samples)) * 10.0 ** generator.uniform(-6, 6, 500 * samples)
        values = values.astype(dtype)
        expected = values.reshape(3, 500, samples).sum(axis=2)
        assert _sample_sum(values, samples).tobytes() == expected.tobytes(), samples


def test_the_memory_estimate_holds_the_passes_arrays() -> None:
    """The resource check counts the passes' arrays a render returns (beside the image), and the values a recorder
    keeps per camera sample while a band is traced at more than 1 sample."""
    from tracer.tracing.recorder import PassRecorder
    from tracer.tracing.wavefront import TracedScene
    from tracer.workers.resources import band_samples, memory_needed

    for samples, dtype in ((1, "float64"), (4, "float32")):
        plain = default_scene().with_render(width=40, height=30, samples=samples, dtype=dtype)
        every = plain.with_render(passes=tuple(ps.PASSES))
        planes = sum(values.nbytes for values in render(every, workers=1).passes.values())
        kept = PassRecorder(TracedScene(every), 1000 * samples)
        per_sample = 0 if samples == 1 else sum(rows.nbytes for rows in kept.rows.values()) / (1000 * samples)
        at_once = min(band_samples(every.render), 40 * 30 * samples)
        assert memory_needed(every.render, 2) - memory_needed(plain.render, 2) == planes + 2 * at_once * per_sample


def plane_scene(distance: float, **render: object) -> sc.Scene:
    """A camera at the origin looking down -Z (rotation 0) at a plane z = -distance, facing it; pass indices set."""
    materials = {"wall": sc.Material(color=(0.5, 0.5, 0.5), pass_index=7)}
    plane = sc.Plane(name="wall", material="wall", location=(0.0, 0.0, -distance), pass_index=3)
    camera = sc.Camera(location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0), lens=50.0)
    settings = sc.RenderSettings(width=16, height=12, **render)
    lights = (sc.AmbientLight(0.2), sc.PointLight(location=(0.0, 0.0, 0.0), intensity=0.8))
    return sc.Scene(materials, (plane,), lights, camera, render=settings)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_depth_normal_position_and_indices_of_a_plane_at_a_known_distance(dtype: str) -> None:
    scene = plane_scene(4.25, passes=("depth", "normal", "position", "object_index", "material_index"), dtype=dtype)
    passes = render(scene, workers=1).passes
    tolerance = 1e-4 if dtype == "float32" else 1e-9
    assert np.allclose(passes["depth"], 4.25, atol=tolerance)  # along the view axis, whatever the pixel's angle
    assert np.allclose(passes["normal"], [0.0, 0.0, 1.0], atol=tolerance)
    assert np.allclose(passes["position"][..., 2], -4.25, atol=tolerance)
    # each pixel's point is where its centre's ray meets the plane: x grows to the right, y down the rows
    x, y = passes["position"][..., 0], passes["position"][..., 1]
    assert np.all(np.diff(x, axis=1) > 0) and np.all(np.diff(y, axis=0) < 0)
    assert np.all(passes["object_index"] == 3) and np.all(passes["material_index"] == 7)


def test_the_background_is_far_in_depth_full_in_mist_and_empty_elsewhere() -> None:
    scene = plane_scene(4.0, passes=("depth", "mist", "normal", "object_index", "shadow"))
    scene = replace(scene, objects=())
    passes = render(scene, workers=1).passes
    assert np.all(passes["depth"] == ps.FAR) and np.all(passes["mist"] == 1.0)
    assert np.all(passes["normal"] == 0.0) and np.all(passes["object_index"] == 0.0) and np.all(passes["shadow"] == 0)


@pytest.mark.parametrize(
    ("falloff", "shape"), [("LINEAR", lambda m: m), ("QUADRATIC", lambda m: m * m), ("INVERSE_QUADRATIC", math.sqrt)]
)
def test_mist_follows_the_worlds_start_depth_and_falloff(falloff: str, shape) -> None:
    scene = plane_scene(6.0, passes=("mist", "position"), mist_start=2.0, mist_depth=10.0, mist_falloff=falloff)
    passes = render(scene, workers=1).passes
    distance = np.sqrt((passes["position"] ** 2).sum(axis=2))  # from the camera at the origin
    expected = np.vectorize(shape)(np.clip((distance - 2.0) / 10.0, 0.0, 1.0))
    assert np.allclose(passes["mist"][..., 0], expected, atol=1e-12)


def test_shadow_is_the_share_of_lights_that_reach_the_point() -> None:
    """Two lights in front of the plane and a small sphere hiding one of them from the plane's middle."""
    scene = plane_scene(4.0, passes=("shadow",))
    lights = (sc.PointLight((0.0, 0.0, -1.0), 0.5), sc.PointLight((3.0, 0.0, 0.0), 0.5))
    blocker = sc.Sphere(name="blocker", material="wall", location=(0.0, 0.0, -2.0), radius=0.2, visible_camera=False)
    scene = replace(scene, objects=(*scene.objects, blocker), lights=lights)
    shadow = render(scene, workers=1).passes["shadow"][..., 0]
    assert set(np.unique(shadow)) <= {0.5, 1.0}
    assert shadow[6, 8] == 0.5 and shadow[0, 0] == 1.0  # the middle loses the light behind the blocker


def test_a_holdout_shows_in_no_pass() -> None:
    scene = plane_scene(4.0, passes=SHADING_AND_DATA)
    held = replace(scene, objects=(replace(scene.objects[0], holdout=True),))
    result = render(held, workers=1)
    for name in SHADING_AND_DATA:
        if name not in ("depth", "mist"):
            assert np.all(result.passes[name] == 0.0), name


def test_a_scene_file_asks_for_passes_by_name_and_unknown_names_are_refused() -> None:
    document = default_scene_dict()
    document["render"]["passes"] = ["normal", "depth"]
    assert scene_from_dict(document).render.passes == ("depth", "normal")  # the registry's order
    document["render"]["passes"] = ["depth", "vector"]
    with pytest.raises(SceneError, match=r'render\.passes: unknown pass "vector"'):
        scene_from_dict(document)
    assert ps.parse("all") == tuple(ps.PASSES)
    with pytest.raises(ValueError, match="unknown pass uv"):
        ps.parse("depth,uv")


def test_passes_are_off_by_default() -> None:
    assert default_scene().render.passes == () and render(default_scene().with_render(width=8, height=6)).passes is None


def test_the_command_line_writes_every_pass_into_a_multilayer_exr(tmp_path) -> None:
    """`python -m tracer render --passes all -o out.exr`: each pass as Blender names its layers, read back with the
    OpenEXR bindings, equal to the render's own passes; Cryptomatte's manifest in the header."""
    import json
    import subprocess
    import sys

    from tests.test_cli import ROOT
    from tracer.tracing.exr import read_exr_channels

    out = tmp_path / "out.exr"
    size = ["--width", "40", "--height", "30", "--samples", "4", "--workers", "1"]
    result = subprocess.run(
        [sys.executable, "-m", "tracer", "render", "--passes", "all", "-o", str(out), *size],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    channels, header = read_exr_channels(out)
    expected = {f"ViewLayer.Combined.{c}" for c in "RGBA"}
    for definition in ps.PASSES.values():
        if definition.combine == "ranks":
            # Cycles' layout at the default levels (6): three RGBA layers, channels in lower case
            expected |= {f"ViewLayer.{definition.blender}0{k}.{c}" for k in range(3) for c in "rgba"}
        else:
            expected |= {f"ViewLayer.{definition.blender}.{c}" for c in definition.channels}
    assert set(channels) == expected
    scene = default_scene().with_render(width=40, height=30, samples=4, passes=tuple(ps.PASSES))
    rendered = render(scene, workers=1)
    assert np.array_equal(channels["ViewLayer.Depth.Z"], rendered.passes["depth"][..., 0].astype(np.float32))
    assert np.array_equal(channels["ViewLayer.Combined.G"], rendered.image[..., 1].astype(np.float32))
    manifests = [json.loads(value) for key, value in header.items() if key.endswith("/manifest")]
    assert sorted(len(manifest) for manifest in manifests) == sorted([len(scene.materials), len(scene.objects)])
    with_png = subprocess.run(
        [sys.executable, "-m", "tracer", "render", "--passes", "depth", "-o", str(tmp_path / "beauty.png"), *size],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert with_png.returncode == 0, with_png.stderr
    assert (tmp_path / "beauty.png").exists() and "ViewLayer.Depth.Z" in read_exr_channels(tmp_path / "beauty.exr")[0]


def test_a_scenes_bytes_do_not_depend_on_what_the_process_traced_before(monkeypatch) -> None:
    """Two scenes that differ only in the sign of a zero (a ground turned by -0.0 about Z, whose normal is then
    (0, -0.0, 1)) compare equal under ==; a process that traced the one first must still give the other's own bytes
    (its kernels are kept between scenes), as a fresh process (a Dask worker) does: the normals pass held -0.0 on the
    ground where a fresh process writes 0.0 (a local animation's EXR files then differed from a cluster's)."""
    from collections import OrderedDict

    from tracer.geometry import camera as cam
    from tracer.tracing import prepared

    base = default_scene().with_render(width=80, height=60, passes=("normal", "depth", "position"), workers=1)

    def turned(zero: float) -> sc.Scene:
        ground = [replace(o, rotation=(0.0, 0.0, zero)) if isinstance(o, sc.Plane) else o for o in base.objects]
        return replace(base, objects=tuple(ground))

    def traced(*scenes: sc.Scene) -> bytes:
        monkeypatch.setattr(prepared, "_KERNELS", OrderedDict())  # a fresh process's caches
        monkeypatch.setattr(cam, "_BAND_CACHE", OrderedDict())
        for scene in scenes:
            result = render(scene, workers=1)
        return result.image.tobytes() + b"".join(result.passes[name].tobytes() for name in sorted(result.passes))

    negative, positive = turned(-0.0), turned(0.0)
    assert negative == positive  # what the kernels' cache once compared them by
    assert traced(negative, positive) == traced(positive)
    assert traced(positive, negative) == traced(negative)
