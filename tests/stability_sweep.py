"""One primitive's own size and distance from the world origin -> its wrongly shadowed and wrongly lit pixels.

A receiver (sphere, capped cylinder, box of triangles or a square plane) of size s under a sun, with a sphere above
it casting a shadow onto it. Every pixel that shows the receiver is decided analytically in the receiver's own
normalised frame (where float64 is exact enough), with a 5% margin: facing the sun with the occluder's shadow line
clear of it by 5% of its radius, it must be lit (else acne: self-shadowing); with the shadow line inside 95% of the
radius, it must be dark (else a leak). Two layouts:

- ratio: the whole arrangement scales with s (the camera at a fixed distance ratio);
- fixed: the camera and the occluder stay put while the receiver grows below them, its top at z = 0 (a large
  receiver is a ground seen from a few metres: the case where the receiver's own rounding, not the scene's, counts).

Both are moved by `position` along (1, 1, 1) to test far from the origin. Used by tests/test_stability.py and
scripts/stability_pictures.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracer.geometry import transforms as tf
from tracer.geometry.camera import band_directions
from tracer.scene import scene as sc
from tracer.tracing.wavefront import TracedScene
from tracer.workers.parallel import render

KINDS = ("sphere", "cylinder", "box", "plane")
SIZES = tuple(10.0**k for k in range(-3, 7))
LAYOUTS = ("ratio", "fixed")
POSITIONS = (0.0, 1e6)
SUN = np.array([0.3, -0.4, 1.0]) / np.linalg.norm([0.3, -0.4, 1.0])
BOX_TURN = 30.0  # degrees about z: the box's faces are not aligned with the world axes
PLANE_TILT = 20.0  # degrees about x
WIDTH, HEIGHT = 96, 72
FIXED_OCCLUDER = 0.3  # the occluder's radius in the fixed layout


@dataclass(frozen=True)
class Cell:
    kind: str
    size: float
    layout: str
    position: float
    dtype: str

    def representable(self) -> bool:
        """Whether the scene is resolved in this dtype: every object's size at least 2^13 epsilons of the largest
        coordinate in it (a 1 mm ball 1,000 km away, or a 30 cm ball on a sphere of 1,000 km, is not a float32
        scene: its coordinates round by a fifth of the ball)."""
        smallest = self.size if self.layout == "ratio" else min(self.size, FIXED_OCCLUDER)
        largest = max(self.position + 3 * self.size, 1.0)
        return smallest >= 8192 * np.finfo(self.dtype).eps * largest


def _layout(cell: Cell) -> tuple[np.ndarray, float, np.ndarray, float, float]:
    """(receiver centre (3,), occluder radius, occluder centre (3,), camera distance, camera lens)."""
    s, shift = cell.size, np.full(3, cell.position)
    if cell.layout == "ratio":
        return shift, 0.4 * s, shift + np.array([0.0, 0.0, 2.2 * s]), 7.0 * s, 30.0
    # the receiver's top at z = 0 under a fixed camera and occluder; a small one shows as a few pixels
    return shift + np.array([0.0, 0.0, -s]), FIXED_OCCLUDER, shift + np.array([0.0, 0.0, 1.2]), 7.0, 30.0


def _receiver(cell: Cell, centre: np.ndarray) -> sc.SceneObject:
    s, where = cell.size, tuple(float(x) for x in centre)
    if cell.kind == "sphere":
        return sc.Sphere(name="receiver", material="m", location=where, radius=s)
    if cell.kind == "cylinder":
        return sc.Cylinder(name="receiver", material="m", location=where, radius=s, height=2 * s)
    if cell.kind == "box":
        return sc.Box(name="receiver", material="m", location=where, rotation=(0, 0, BOX_TURN), size=(2 * s,) * 3)
    top = tuple(float(x) for x in centre + np.array([0.0, 0.0, s]))  # a square at the others' top
    return sc.Plane(name="receiver", material="m", location=top, rotation=(PLANE_TILT, 0, 0), size=(2 * s, 2 * s))


def scene_for(cell: Cell, numerics: str) -> sc.Scene:
    centre, occluder_radius, occluder_centre, distance, lens = _layout(cell)
    look = np.array([0.0, -math.sin(math.radians(70)), math.cos(math.radians(70))])  # camera pitched 70 degrees
    target = centre + np.array([0.0, 0.0, cell.size])  # the receiver's top
    return sc.Scene(
        materials={"m": sc.Material(color=(1, 1, 1))},
        objects=(
            _receiver(cell, centre),
            sc.Sphere(
                name="occluder", material="m", location=tuple(map(float, occluder_centre)), radius=occluder_radius
            ),
        ),
        lights=(sc.DirectionalLight(direction=tuple(map(float, SUN)), intensity=1.0),),
        camera=sc.Camera(location=tuple(map(float, target + distance * look)), rotation=(70, 0, 0), lens=lens),
        background=sc.Background(type="none"),
        render=sc.RenderSettings(width=WIDTH, height=HEIGHT, depth=0, numerics=numerics, dtype=cell.dtype),
    )


def _local(cell: Cell, centre: np.ndarray, P: np.ndarray) -> np.ndarray:
    """World points (3, n) -> the receiver's frame, divided by its size: the unit receiver about the origin."""
    if cell.kind == "plane":
        centre = centre + np.array([0.0, 0.0, cell.size])
        rotation = np.asarray(tf.euler_xyz_matrix((PLANE_TILT, 0, 0)))
    elif cell.kind == "box":
        rotation = np.asarray(tf.euler_xyz_matrix((0, 0, BOX_TURN)))
    else:
        rotation = np.eye(3)
    return rotation.T @ ((P - centre[:, None]) / cell.size), rotation


def _normals(cell: Cell, local: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """World unit normals (3, n) of the unit receiver at local points (3, n) on it."""
    if cell.kind == "sphere":
        n = local
    elif cell.kind == "plane":
        n = np.tile([[0.0], [0.0], [1.0]], local.shape[1])
    elif cell.kind == "box":
        axis = np.argmax(np.abs(local), axis=0)
        n = np.zeros_like(local)
        n[axis, np.arange(local.shape[1])] = np.sign(local[axis, np.arange(local.shape[1])])
    else:
        radial = np.hypot(local[0], local[1])
        cap = np.abs(local[2]) - 1.0 > radial - 1.0  # nearer a cap's plane than the side
        n = np.where(cap, np.stack((0 * radial, 0 * radial, np.sign(local[2]))), local * [[1], [1], [0]])
    n = rotation @ n
    return n / np.linalg.norm(n, axis=0)


def wrong_pixels(cell: Cell, numerics: str) -> tuple[int, int, int]:
    """(acne, leaks, receiver pixels decided) for one cell and mode."""
    scene = scene_for(cell, numerics)
    lit = render(scene, workers=1).image[..., 0].reshape(-1) > 0.0
    centre, occluder_radius, occluder_centre, *_ = _layout(cell)
    exact = TracedScene(scene.with_render(dtype="float64", numerics="robust"))
    D = band_directions(scene.camera, scene.render, np.arange(HEIGHT))
    t, obj, _ = exact.hierarchy.closest(exact.origin, D, 0.0)
    on_receiver = obj == 0
    P = exact.origin + D * np.where(on_receiver, t, 0.0)
    local, rotation = _local(cell, centre, P[:, on_receiver])
    facing = (_normals(cell, local, rotation) * SUN[:, None]).sum(axis=0)
    # the sun's line from each point passes the occluder's centre at this distance, in its radii
    offset = (occluder_centre[:, None] - P[:, on_receiver]) / occluder_radius
    along = (offset * SUN[:, None]).sum(axis=0)
    miss = np.sqrt(np.maximum((offset * offset).sum(axis=0) - along**2, 0.0))
    clear = (facing > 0.05) & ((miss > 1.05) | (along < 0))
    shadowed = (miss < 0.95) & (along > 0)
    shown = lit[on_receiver]
    return int((~shown[clear]).sum()), int(shown[shadowed].sum()), int(clear.sum() + shadowed.sum())


def cells(dtypes: tuple[str, ...] = ("float64", "float32")) -> list[Cell]:
    every = [
        Cell(kind, size, layout, position, dtype)
        for dtype in dtypes
        for position in POSITIONS
        for layout in LAYOUTS
        for kind in KINDS
        for size in SIZES
    ]
    return [cell for cell in every if cell.representable()]
