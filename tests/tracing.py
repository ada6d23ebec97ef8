"""Helpers for tests: one-object scenes, single rays through both the vectorized kernels and the reference, and a
scene's whole image through both."""

from __future__ import annotations

import math

import numpy as np

from tracer.scene import scene as sc
from tracer.tracing.reference import ReferenceTracer, render_reference
from tracer.tracing.wavefront import TracedScene
from tracer.workers.parallel import render

MATERIALS = {"m": sc.Material(color=(0.5, 0.25, 0.1), specular=10.0, reflective=0.0)}


def one_object_scene(obj: sc.SceneObject, **render: object) -> sc.Scene:
    return sc.Scene(
        materials=MATERIALS, objects=(obj,), lights=(sc.AmbientLight(1.0),), render=sc.RenderSettings(**render)
    )


def first_hit(scene: sc.Scene, origin: sc.Vec3, direction: sc.Vec3, t_min: float = 0.0) -> tuple[float, float]:
    """The nearest t along one ray by the vectorized tracer and by the reference (inf for a miss)."""
    prepared = TracedScene(scene)
    O = np.asarray(origin, dtype=float).reshape(3, 1)
    D = np.asarray(direction, dtype=float).reshape(3, 1)
    t, obj, _ = prepared.hierarchy.closest(O, D, t_min)
    vectorized = float(t[0]) if obj[0] >= 0 else math.inf
    index, _, reference_t = ReferenceTracer(scene).closest_intersection(origin, direction, t_min, math.inf)
    return vectorized, (reference_t if index >= 0 else math.inf)


def assert_matches_reference(scene: sc.Scene) -> None:
    """The vectorized tracer's image of the scene (with its alpha, where it has one) equals the per-pixel
    reference's to 1e-9."""
    result = render(scene, workers=1)
    image = result.image if result.alpha is None else np.concatenate((result.image, result.alpha[..., None]), axis=2)
    np.testing.assert_allclose(image, np.asarray(render_reference(scene)), rtol=0, atol=1e-9)
