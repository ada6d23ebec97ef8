"""Primitive test cases with their analytic answers: (label, object, origin, direction, expected t)."""

from __future__ import annotations

import math

from tracer.scene import scene as sc

INF = math.inf
S2 = math.sqrt(2.0)

CASES = [
    # (label, object, origin, direction, expected t)
    ("sphere hit", sc.Sphere(name="s", material="m", radius=2.0), (0, -10, 0), (0, 1, 0), 8.0),
    ("sphere miss", sc.Sphere(name="s", material="m", radius=2.0), (0, -10, 2.5), (0, 1, 0), INF),
    ("sphere tangent", sc.Sphere(name="s", material="m", radius=2.0), (0, -10, 2), (0, 1, 0), 10.0),
    (
        "sphere from inside",
        sc.Sphere(name="s", material="m", location=(1, 1, 1), radius=2.0),
        (1, 1, 1),
        (0, 0, 1),
        2.0,
    ),
    ("sphere behind", sc.Sphere(name="s", material="m", radius=2.0), (0, 10, 0), (0, 1, 0), INF),
    ("sphere unnormalised ray", sc.Sphere(name="s", material="m", radius=1.0), (0, 0, 5), (0, 0, -2), 2.0),
    ("plane hit", sc.Plane(name="p", material="m", location=(0, 0, 1)), (3, 4, 5), (0, 0, -1), 4.0),
    ("plane parallel", sc.Plane(name="p", material="m", location=(0, 0, 1)), (0, 0, 5), (1, 0, 0), INF),
    ("plane behind", sc.Plane(name="p", material="m", location=(0, 0, 1)), (0, 0, 5), (0, 0, 1), INF),
    (
        "plane rotated",
        sc.Plane(name="p", material="m", location=(0, 3, 0), rotation=(90, 0, 0)),
        (0, 0, 0),
        (0, 1, 0),
        3.0,
    ),
    ("finite plane inside", sc.Plane(name="p", material="m", size=(2, 2)), (0.5, -0.9, 5), (0, 0, -1), 5.0),
    ("finite plane outside", sc.Plane(name="p", material="m", size=(2, 2)), (1.5, 0, 5), (0, 0, -1), INF),
    ("cylinder side", sc.Cylinder(name="c", material="m", radius=1, height=2), (-5, 0, 0), (1, 0, 0), 4.0),
    ("cylinder top cap", sc.Cylinder(name="c", material="m", radius=1, height=2), (0.3, 0.2, 5), (0, 0, -1), 4.0),
    ("cylinder bottom cap", sc.Cylinder(name="c", material="m", radius=1, height=2), (0.5, 0, -5), (0, 0, 1), 4.0),
    ("cylinder over the top", sc.Cylinder(name="c", material="m", radius=1, height=2), (-5, 0, 1.5), (1, 0, 0), INF),
    (
        "cylinder along its axis outside",
        sc.Cylinder(name="c", material="m", radius=1, height=2),
        (2, 0, -5),
        (0, 0, 1),
        INF,
    ),
    ("cylinder tangent", sc.Cylinder(name="c", material="m", radius=1, height=2), (-5, 1, 0), (1, 0, 0), 5.0),
    ("cylinder from inside", sc.Cylinder(name="c", material="m", radius=1, height=2), (0, 0, 0), (1, 0, 0), 1.0),
    (
        "cylinder rotated",
        sc.Cylinder(name="c", material="m", rotation=(0, 90, 0), radius=1, height=2),
        (5, 0, 0),
        (-1, 0, 0),
        4.0,
    ),
    ("cylinder scaled", sc.Cylinder(name="c", material="m", radius=0.5, height=4), (0, -3, 1.9), (0, 1, 0), 2.5),
    ("box top", sc.Box(name="b", material="m", location=(1, 1, 1), size=(2, 4, 6)), (1, 1, 10), (0, 0, -1), 6.0),
    ("box side", sc.Box(name="b", material="m", location=(1, 1, 1), size=(2, 4, 6)), (-10, 2, 3), (1, 0, 0), 10.0),
    ("box miss", sc.Box(name="b", material="m", location=(1, 1, 1), size=(2, 4, 6)), (-10, 2, 4.5), (1, 0, 0), INF),
    ("box face diagonal", sc.Box(name="b", material="m", size=(2, 2, 2)), (0, 0, 10), (0, 0, -1), 9.0),
    ("box from inside", sc.Box(name="b", material="m", size=(2, 2, 2)), (0, 0, 0), (0, 0, 1), 1.0),
    (
        "box rotated to its edge",
        sc.Box(name="b", material="m", rotation=(0, 0, 45), size=(2, 2, 2)),
        (-10, 0, 0),
        (1, 0, 0),
        10.0 - S2,
    ),
    ("pyramid side", sc.Pyramid(name="y", material="m", size=(2, 2, 2)), (0.5, 0, 10), (0, 0, -1), 10.0),
    ("pyramid base", sc.Pyramid(name="y", material="m", size=(2, 2, 2)), (0.2, 0.3, -10), (0, 0, 1), 9.0),
    ("pyramid near a corner", sc.Pyramid(name="y", material="m", size=(2, 2, 2)), (0.9, 0.9, 10), (0, 0, -1), 10.8),
    ("pyramid outside its base", sc.Pyramid(name="y", material="m", size=(2, 2, 2)), (1.1, 0.5, 10), (0, 0, -1), INF),
    (
        "pyramid pointing along +X",
        sc.Pyramid(name="y", material="m", rotation=(0, 90, 0), size=(2, 2, 4)),
        (10, 0, 0.5),
        (-1, 0, 0),
        10.0,
    ),
    (
        "mesh triangle",
        sc.TriangleMesh(name="t", material="m", vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0)), triangles=((0, 1, 2),)),
        (0.25, 0.25, 3),
        (0, 0, -1),
        3.0,
    ),
    (
        "mesh triangle edge",
        sc.TriangleMesh(name="t", material="m", vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0)), triangles=((0, 1, 2),)),
        (0.5, 0.5, 3),
        (0, 0, -1),
        3.0,
    ),
    (
        "mesh triangle outside",
        sc.TriangleMesh(name="t", material="m", vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0)), triangles=((0, 1, 2),)),
        (0.6, 0.6, 3),
        (0, 0, -1),
        INF,
    ),
]
