"""Blender's motion blur (Render > Motion Blur: shutter and position, the add-on's steps) -> where each object and the
camera are at the steps' times: their world matrices, read by evaluating the scene at each time, and the scene file's
poses made from them (tracer/workers/shutter.py renders one time slice per pose and averages them).

What the poses cannot say is named: a change of shape or scale over the shutter, moving lights, instances moved by
their instancer, Cycles' rolling shutter and shutter curve."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .. import compat
from . import mesh_export

POSITION_OFFSET = {"START": 0.0, "CENTER": -0.5, "END": -1.0}  # the shutter's opening, in shutters from the frame
MOVE_TOLERANCE = 1e-7  # metres or radians-ish matrix entries: below this a matrix has not changed
SCALE_TOLERANCE = 1e-5  # a pose's linear part this far from a rotation changed the object's scale or shape


@dataclass
class SampledMotion:
    """World matrices at the steps' times (mathutils 4x4 copies) of the objects that move over the shutter, by their
    original objects' names, and the scene camera's (None where it stays put)."""

    objects: dict[str, list] = field(default_factory=dict)
    camera: list | None = None
    deforming: list[str] = field(default_factory=list)  # objects whose shape changes with the frame (named)
    lights: list[str] = field(default_factory=list)  # lights that move (named: rendered at the frame's time)

    @property
    def steps(self) -> int:
        found = next(iter(self.objects.values()), None) or self.camera
        return len(found) if found else 0


def applies(blender_scene) -> bool:
    """Whether F12 and export blur motion: Render > Motion Blur is on and the shutter open for some time."""
    render = blender_scene.render
    return bool(render.use_motion_blur) and render.motion_blur_shutter > 0.0


def step_times(blender_scene, steps: int) -> list[float]:
    """The frames (with fractions) of the steps' times: the middles of steps equal parts of the shutter, which opens
    around the current frame as Position says (Cycles': at frame + offset * shutter). Middles, not the ends: equal
    weights on them spread the slices as the open shutter spreads time (the ends would lengthen a streak's
    spread by a step)."""
    render = blender_scene.render
    shutter = render.motion_blur_shutter
    opening = blender_scene.frame_current + POSITION_OFFSET.get(compat.motion_blur_position(blender_scene), -0.5) * (
        shutter
    )
    return [opening + shutter * (k + 0.5) / steps for k in range(steps)]


def _blurred(obj) -> bool:
    """Object Properties > Motion Blur (Cycles' per-object switch), on where the object has none."""
    settings = getattr(obj, "cycles", None)
    return bool(getattr(settings, "use_motion_blur", True))


def _deforms(obj) -> bool:
    """Whether the object's shape can change with the frame: an armature or another deforming modifier, animated
    shape keys or mesh data (Cycles blurs that too; the poses cannot)."""
    data = getattr(obj, "data", None)
    keys = getattr(data, "shape_keys", None)
    animated = [getattr(owner, "animation_data", None) for owner in (data, keys) if owner is not None]
    if any(animation is not None and (animation.action is not None or animation.drivers) for animation in animated):
        return True
    return any(modifier.type in {"ARMATURE", "LATTICE", "CURVE", "HOOK", "MESH_DEFORM"} for modifier in obj.modifiers)


STEPS = 16  # the add-on's default Steps (scene.weathervane.motion_blur_steps)


def sampled(blender_scene, depsgraph, set_time) -> SampledMotion | None:
    """sample() at the scene's Motion Blur steps where Render > Motion Blur is on (else None), the frame put back
    after (set_time(frame_current, frame_subframe)), also when the evaluation fails."""
    if not applies(blender_scene):
        return None
    frame, subframe = blender_scene.frame_current, blender_scene.frame_subframe
    steps = int(getattr(getattr(blender_scene, "weathervane", None), "motion_blur_steps", STEPS))
    try:
        return sample(blender_scene, depsgraph, set_time, steps)
    finally:
        set_time(frame, subframe)


def sample(blender_scene, depsgraph, set_time, steps: int) -> SampledMotion:
    """Evaluates the scene at each step's time (set_time(frame, subframe): RenderEngine.frame_set inside a render,
    Scene.frame_set for an export) and keeps the world matrices of what moves, and the names of objects whose shape
    differs between the shutter's opening and closing; the caller puts the frame back."""
    matrices: dict[str, list] = {}
    camera: list = []
    lights: dict[str, list] = {}
    shapes: dict[str, set] = {}
    candidates = {obj.name for obj in blender_scene.objects if _deforms(obj)}
    times = step_times(blender_scene, steps)
    for index, time in enumerate(times):
        frame = math.floor(time)
        set_time(frame, time - frame)
        ends = index in (0, len(times) - 1)
        for obj in depsgraph.objects:
            original = obj.original
            if obj.type == "LIGHT":
                lights.setdefault(original.name, []).append(obj.matrix_world.copy())
            elif _blurred(original):
                matrices.setdefault(original.name, []).append(obj.matrix_world.copy())
                if ends and original.name in candidates:
                    shapes.setdefault(original.name, set()).add(mesh_export.fingerprint(obj))
        if blender_scene.camera is not None:
            camera.append(blender_scene.camera.evaluated_get(depsgraph).matrix_world.copy())
    motion = SampledMotion()
    motion.objects = {name: found for name, found in matrices.items() if _moves(found)}
    motion.camera = camera if _moves(camera) else None
    motion.lights = sorted(name for name, found in lights.items() if _moves(found))
    motion.deforming = sorted(name for name, found in shapes.items() if len(found) > 1)
    return motion


def _moves(matrices: list) -> bool:
    return any(
        abs(a - b) > MOVE_TOLERANCE
        for matrix in matrices[1:]
        for row, first_row in zip(matrix, matrices[0], strict=True)
        for a, b in zip(row, first_row, strict=True)
    )


def pose(matrix) -> dict:
    """A world matrix (mathutils 4x4) -> a scene file pose: its location and Euler XYZ rotation in degrees (its
    scale left out)."""
    location, rotation, _ = matrix.decompose()
    return {"location": list(location), "rotation": [math.degrees(angle) for angle in rotation.to_euler("XYZ")]}


def relative_poses(matrices: list, placed) -> tuple[list[dict], bool]:
    """The poses of a world-space mesh placed by the matrix placed (its vertices are placed @ local): each step's
    matrix @ placed^-1 as a pose, and whether that is a rigid move throughout (else its scale or shape changes, which
    the poses leave out)."""
    inverse = placed.inverted_safe()
    poses, rigid = [], True
    for matrix in matrices:
        moved = matrix @ inverse
        linear = moved.to_3x3()
        product = linear @ linear.transposed()
        identity = all(
            abs(product[i][j] - (1.0 if i == j else 0.0)) <= SCALE_TOLERANCE for i in range(3) for j in range(3)
        )
        rigid = rigid and identity and linear.determinant() > 0.0
        poses.append(pose(moved))
    return poses, rigid


def unsupported(blender_scene) -> list[str]:
    """Cycles' shutter settings the poses do not render, one phrase each."""
    problems = []
    cycles = getattr(blender_scene, "cycles", None)
    if getattr(cycles, "rolling_shutter_type", "NONE") != "NONE":
        problems.append("rolling shutter (a global shutter)")
    curve = blender_scene.render.motion_blur_shutter_curve
    points = [point.location[1] for c in curve.curves for point in c.points] if curve is not None else []
    if points and any(abs(value - 1.0) > 1e-6 for value in points):
        problems.append("shutter curve (an open shutter throughout)")
    return problems
