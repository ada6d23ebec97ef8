"""Adaptive sampling (render.adaptive_threshold): which pixels it traces again, that those are the uniform render's
to the byte and the rest the first pass's, the same bytes for any number of workers, and on the default frame an
error against 256 samples no worse than uniform 16 samples' at under 40% of its camera rays."""

from __future__ import annotations

import numpy as np
import pytest

from tracer.scene.loader import default_scene, scene_from_dict
from tracer.workers import adaptive
from tracer.workers.parallel import Renderer, bands, render


def test_disagreeing_pixels_are_both_sides_of_an_edge_and_nothing_flat() -> None:
    image = np.zeros((6, 8, 3))
    image[:, 5:] = 0.5  # a vertical edge between columns 4 and 5
    image[2, 1, 1] = 0.004  # a step below the threshold
    flagged = adaptive.disagreeing(image, 0.005)
    expected = np.zeros((6, 8), dtype=bool)
    expected[:, 4:6] = True
    np.testing.assert_array_equal(flagged, expected)
    alpha = np.zeros((5, 5, 4))
    alpha[2, 2, 3] = 1.0  # alpha alone differs: the pixel and its eight neighbours (each 0.5 from a midpoint)
    flagged = adaptive.disagreeing(alpha, 0.4)
    assert flagged[1:4, 1:4].all() and flagged.sum() == 9
    assert np.flatnonzero(adaptive.disagreeing(alpha, 0.5)).tolist() == [12]


def test_a_smooth_gradient_is_not_flagged_and_a_line_a_pixel_wide_is() -> None:
    """A lamp's falloff: 0.01 a pixel along x and 0.007 along y (each above the threshold from pixel to pixel), a
    midpoint of its neighbours everywhere; a line one pixel wide across it differs from theirs by its own step."""
    y, x = np.mgrid[0:8, 0:10]
    image = np.repeat((0.2 + 0.01 * x + 0.007 * y)[..., None], 3, axis=2)
    assert not adaptive.disagreeing(image, 0.005).any()
    image[:, 4] += 0.02
    flagged = adaptive.disagreeing(image, 0.005)
    assert flagged[:, 3:6].all() and not flagged[:, :3].any() and not flagged[:, 6:].any()


def test_grown_adds_the_eight_neighbours() -> None:
    flagged = np.zeros((5, 5), dtype=bool)
    flagged[0, 0] = flagged[3, 3] = True
    expected = np.zeros((5, 5), dtype=bool)
    expected[:2, :2] = expected[2:, 2:] = True
    np.testing.assert_array_equal(adaptive.grown(flagged), expected)


def test_base_samples_are_a_coarser_grid() -> None:
    assert [adaptive.base_samples(n) for n in (4, 9, 16, 49, 64, 256)] == [1, 1, 1, 1, 4, 16]


def test_adaptive_pixels_are_the_uniform_renders_or_the_first_pass_and_workers_agree() -> None:
    scene = default_scene().with_render(width=96, height=72, samples=16)
    adaptive_scene = scene.with_render(adaptive_threshold=0.005)
    assert adaptive.applies(adaptive_scene.render)
    result = render(adaptive_scene, workers=2)
    assert np.array_equal(result.image, render(adaptive_scene, workers=1).image)
    uniform = render(scene, workers=1).image
    first = render(scene.with_render(samples=1), workers=1).image
    flagged = adaptive.grown(adaptive.disagreeing(first, 0.005))
    assert 0.0 < result.adaptive == pytest.approx(flagged.mean())
    assert np.array_equal(result.image[flagged], uniform[flagged])
    assert np.array_equal(result.image[~flagged], first[~flagged])


def test_on_the_default_frame_adaptive_16_is_as_close_to_256_samples_as_uniform_16_with_under_40_percent_of_rays():
    """Measured at 160x120 (docs/performance.md has the 640x480 figures and the time)."""
    scene = default_scene().with_render(width=160, height=120)
    truth = render(scene.with_render(samples=256), workers=2).image
    uniform = render(scene.with_render(samples=16), workers=2)
    adaptive_result = render(scene.with_render(samples=16, adaptive_threshold=0.005), workers=2)

    def rmse(image: np.ndarray) -> float:
        return float(np.sqrt(np.mean((image - truth) ** 2)))

    assert rmse(adaptive_result.image) <= rmse(uniform.image) * 1.001
    assert adaptive_result.rays.total <= 0.4 * uniform.rays.total
    assert adaptive_result.rays.camera <= 0.4 * uniform.rays.camera


def test_passes_and_render_borders_render_every_pixel_at_the_full_count() -> None:
    base = default_scene().with_render(samples=16, adaptive_threshold=0.01)
    assert not adaptive.applies(base.with_render(passes=("depth",)).render)
    assert not adaptive.applies(base.with_render(border=(0.1, 0.1, 0.5, 0.5)).render)
    assert not adaptive.applies(base.with_render(samples=1).render)


def test_the_threshold_is_checked_with_a_clear_message() -> None:
    from tracer.scene.loader import SceneError

    document = {
        "materials": {"m": {"color": [1, 1, 1]}},
        "objects": [{"type": "sphere", "material": "m"}],
        "lights": [{"type": "ambient", "intensity": 1}],
        "render": {"adaptive_threshold": 2},
    }
    with pytest.raises(SceneError, match="adaptive_threshold"):
        scene_from_dict(document)


@pytest.mark.parametrize("workers", [1, 2])
def test_the_second_pass_is_told_to_progress_and_shown_run_by_run_and_gives_the_same_image(workers: int) -> None:
    """An F12 display follows both passes: one count over the first pass's bands and the second pass's runs, and
    each run's rows shown as it finishes."""
    scene = default_scene().with_render(width=96, height=72, samples=16, adaptive_threshold=0.005)
    told, shown = [], []
    with Renderer(workers) as renderer:
        result = renderer.render(
            scene,
            lambda done, total: told.append((done, total)),
            None,
            lambda image, rows: shown.append((image.copy(), rows)),
        )
        pieces = renderer.pixel_pieces(scene.render)
    first_bands = len(bands(scene.with_render(samples=1).render))
    totals = {total for _, total in told}
    assert totals == {first_bands + pieces}
    done = [d for d, _ in told]
    assert done == sorted(done) and done[-1] == first_bands + pieces and len(done) == first_bands + pieces
    # the second pass's runs: every traced-again pixel's row shown, and the last image shown is the result's
    flagged = adaptive.grown(adaptive.disagreeing(render(scene.with_render(samples=1), workers=1).image, 0.005))
    second = shown[first_bands:]
    assert len(second) == pieces
    assert set(np.flatnonzero(flagged.any(axis=1))) <= set(np.concatenate([rows for _, rows in second]).tolist())
    assert np.array_equal(second[-1][0], result.image)
    assert np.array_equal(result.image, render(scene, workers=1).image)


def _cube_under_the_world() -> dict:
    """A cube on a ground under a uniform world light (its contact shadow), 96x72."""
    return {
        "materials": {"white": {"color": [0.8, 0.8, 0.8], "specular": 0}, "red": {"color": [0.8, 0.2, 0.2]}},
        "objects": [
            {"name": "ground", "type": "plane", "material": "white", "size": [20, 20]},
            {"name": "cube", "type": "box", "material": "red", "location": [0, 0, 0.5], "size": [1, 1, 1]},
        ],
        "lights": [{"type": "world", "intensity": 1.0, "samples": 16}],
        "camera": {"location": [3.5, -3.5, 3.0], "rotation": [60, 0, 45], "lens": 35},
        "background": {"type": "solid", "color": [0.9, 0.9, 0.9]},
        "render": {"width": 96, "height": 72, "depth": 1, "samples": 16, "adaptive_threshold": 0.005},
    }


@pytest.mark.parametrize("workers", [1, 2])
def test_under_a_world_light_the_pixels_to_trace_again_are_flagged_by_the_steady_pass(workers: int) -> None:
    """Each pixel turns the world light's directions (noise, which more samples of the pixel do not lessen): the
    pixels traced again are the ones a pass with the world light unshadowed and its directions the same everywhere
    flags, not the noise's; they are the uniform render's, the others the first pass's, and the progress counts the
    flagging pass too."""
    scene = scene_from_dict(_cube_under_the_world())
    assert adaptive.steadied(scene)
    told = []
    with Renderer(workers) as renderer:
        result = renderer.render(scene, lambda done, total: told.append((done, total)))
        pieces = renderer.pixel_pieces(scene.render)
    first = render(scene.with_render(samples=1, adaptive_threshold=0.0), workers=1).image
    steady = render(scene.with_render(samples=1, adaptive_threshold=0.0, adaptive_flags=True), workers=1).image
    flagged = adaptive.grown(adaptive.disagreeing(steady, 0.005))
    noisy = adaptive.grown(adaptive.disagreeing(first, 0.005))
    assert 0.0 < flagged.mean() < 0.25 < 0.75 < noisy.mean()  # measured 12% (the cube's outline) against 91%
    assert result.adaptive == pytest.approx(flagged.mean())
    uniform = render(scene.with_render(adaptive_threshold=0.0), workers=1).image
    assert np.array_equal(result.image[flagged], uniform[flagged])
    assert np.array_equal(result.image[~flagged], first[~flagged])
    first_bands = len(bands(scene.with_render(samples=1).render))
    assert told[-1] == (2 * first_bands + pieces, 2 * first_bands + pieces)
