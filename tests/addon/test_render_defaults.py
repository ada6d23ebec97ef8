"""Defaults an artist expects: F12 of a scene the add-on did not build is antialiased (16 samples
where neighbouring pixels differ, adaptive sampling), its edges' coverage Cycles' within a sample's share; the built
vane keeps the documented model's one sample a pixel, and its scene file says no adaptive sampling."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.convert.export import scene_document
from tests.addon.f12_images import AT_THE_ENDS, f12_exr


def _factory_cube_on_a_transparent_film() -> None:
    bpy.ops.wm.read_factory_settings()  # the factory cube, camera and light, as a new file has them
    scene = bpy.context.scene
    scene.render.resolution_percentage = 10  # 192 x 108
    scene.render.film_transparent = True
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 64, False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0  # a pixel's coverage, as the tracer's


@AT_THE_ENDS
def test_f12_of_the_factory_cube_has_antialiased_edges_as_cycles(tmp_path: Path) -> None:
    _factory_cube_on_a_transparent_film()
    scene = bpy.context.scene
    settings = scene.weathervane
    assert settings.samples == "16" and settings.noise_threshold == pytest.approx(0.005)
    render = scene_document(bpy.context)["render"]
    assert render["samples"] == 16 and render["adaptive_threshold"] == pytest.approx(0.005)
    alpha = {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        alpha[engine] = f12_exr(tmp_path / f"{engine}.exr", "RGBA")[..., 3]
    cycles, tracer = alpha["CYCLES"], alpha["WEATHERVANE_TRACER"]
    edge = (cycles > 0.02) & (cycles < 0.98)  # the silhouette's pixels: partly covered in Cycles
    assert edge.sum() > 100
    partial = (tracer > 0.02) & (tracer < 0.98)
    assert partial[edge].mean() > 0.8  # the tracer's edge pixels are partly covered too: antialiased, not 0 or 1
    # each pixel's coverage: 16 stratified samples against Cycles' 64 random ones (both noisy by about 1/16)
    assert np.abs(tracer - cycles)[edge].mean() < 0.06
    inside, outside = cycles >= 0.98, cycles <= 0.02
    print(
        f"edge pixels {edge.sum()}: partly covered in the tracer {partial[edge].mean():.3f}, mean |alpha - Cycles'| "
        f"{np.abs(tracer - cycles)[edge].mean():.4f}; inside whole {(tracer[inside] == 1.0).mean():.4f}"
    )
    assert (tracer[inside] == 1.0).mean() > 0.97 and (tracer[outside] == 0.0).mean() > 0.97


def test_the_built_vane_keeps_one_sample_a_pixel_and_no_adaptive_sampling() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    settings = bpy.context.scene.weathervane
    assert (settings.samples, settings.noise_threshold) == ("1", 0.0)
    render = scene_document(bpy.context)["render"]
    assert render["samples"] == 1 and "adaptive_threshold" not in render
