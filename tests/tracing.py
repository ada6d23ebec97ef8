"""Helpers for tests: one-object scenes, and single rays through both the vectorized kernels and the reference."""

from __future__ import annotations

import math

import numpy as np

from tracer.scene import scene as sc
from tracer.tracing.reference import ReferenceTracer
from tracer.tracing.wavefront import TracedScene

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
