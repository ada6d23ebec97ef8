"""The panel's wind and vane settings (keyframed or not) -> the motion code -> the fewest keys on the vane.

The wind properties are sampled at every frame from their F-curves (so an artist may key them on the timeline),
turned into a tracer Motion, simulated by tracer.scene.motion exactly as the tracer's own animations are, reduced by
tracer.scene.keyframes to the fewest LINEAR keys within the tolerance, and written on the turning empty's Z rotation.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from .. import compat
from .. import tracer_api as tracer
from . import build


def _sampled(blender_scene, name: str, frames: np.ndarray) -> np.ndarray:
    """A settings property at every frame: its F-curve where keyed, else its value."""
    fcurve = compat.find_fcurve(blender_scene, f"weathervane.{name}", 0)
    if fcurve is None:
        return np.full(frames.size, getattr(blender_scene.weathervane, name), dtype=np.float64)
    return np.array([fcurve.evaluate(float(frame)) for frame in frames])


def motion_for(blender_scene, last_frame: int):
    """The tracer Motion that the settings describe, frame 1 at time 0, over frames 1..last_frame."""
    settings = blender_scene.weathervane
    fps = blender_scene.render.fps / blender_scene.render.fps_base
    frames = np.arange(1, last_frame + 1, dtype=np.float64)
    directions = np.degrees(_sampled(blender_scene, "wind_direction", frames))
    speeds = np.clip(_sampled(blender_scene, "wind_speed", frames), 0.0, 60.0)
    keys = tuple(
        tracer.WindKey(float((frame - 1) / fps), float(direction % 360.0), float(speed))
        for frame, direction, speed in zip(frames, directions, speeds, strict=True)
    )
    gusts = None
    if settings.gust_intensity > 0.0:
        gusts = tracer.Gusts(settings.gust_intensity, settings.gust_time_scale, settings.gust_seed)
    wind = tracer.Wind(
        keys=keys,
        gusts=gusts,
        start=max(0.0, (settings.start_frame - 1) / fps),
        stop=(settings.stop_frame - 1) / fps if settings.use_stop else None,
    )
    spin = tracer.Spin(
        direction=settings.spin_direction,
        speed=settings.spin_speed,
        smoothness=settings.spin_smoothness,
        start=max(0.0, (settings.start_frame - 1) / fps),
        stop=(settings.stop_frame - 1) / fps if settings.use_stop else None,
    )
    return tracer.Motion(
        mode=settings.mode.lower(),
        damping=settings.damping,
        wavelength=settings.wavelength,
        threshold=settings.threshold,
        friction_time=settings.friction_time,
        fps=fps,
        wind=wind,
        spin=spin,
    )


def headings(blender_scene, last_frame: int, initial_heading: float) -> np.ndarray:
    """Degrees (last_frame,) at frames 1..last_frame."""
    return tracer.simulate(motion_for(blender_scene, last_frame), last_frame, initial_heading)


WIND_PROPERTIES = ("wind_direction", "wind_speed")


def unkeyed_change(blender_scene) -> str | None:
    """Why a bake would not follow what the panel shows: a keyed wind property whose value was changed without a
    key (Blender shows it orange) would be ignored by the keys. None where there is none."""
    settings = blender_scene.weathervane
    frame = blender_scene.frame_current
    for name in WIND_PROPERTIES:
        fcurve = compat.find_fcurve(blender_scene, f"weathervane.{name}", 0)
        if fcurve is None:
            continue
        shown, keyed = getattr(settings, name), fcurve.evaluate(float(frame))
        if abs(shown - keyed) > 1e-4 * max(1.0, abs(keyed)):
            label = settings.bl_rna.properties[name].name
            if name == "wind_direction":
                shown_text, keyed_text = f"{math.degrees(shown):.1f} degrees", f"{math.degrees(keyed):.1f} degrees"
            else:
                shown_text, keyed_text = f"{shown:.2f} m/s", f"{keyed:.2f} m/s"
            return (
                f"{label} shows {shown_text} but its keys give {keyed_text} at frame {frame}: key the change (I over "
                f"the field) or clear its keys (Alt+I) to use one value, then bake"
            )
    return None


def bake(context, progress=None) -> tuple[int, int]:
    """Write the vane's motion over the scene's frame range as keys; returns (keys written, frames)."""
    blender_scene = context.scene
    turn = bpy.data.objects.get(build.TURN)
    if turn is None:
        raise LookupError("build the weathervane first: there is no turning part to animate")
    problem = unkeyed_change(blender_scene)
    if problem is not None:
        raise ValueError(problem)
    first, last = blender_scene.frame_start, blender_scene.frame_end
    if last < first:
        raise ValueError(f"the frame range is empty: end {last} is before start {first}")
    if progress:
        progress(0.1)
    initial = turn.get("weathervane_initial_heading")
    if initial is None:
        initial = math.degrees(turn.rotation_euler[2])
        turn["weathervane_initial_heading"] = initial
    angles = headings(blender_scene, last, float(initial))
    if progress:
        progress(0.7)
    span = angles[max(first, 1) - 1 : last]
    frames = np.arange(max(first, 1), last + 1)
    keys = tracer.reduce_keys(span, blender_scene.weathervane.tolerance)
    compat.replace_fcurve(
        turn, "rotation_euler", 2, [float(frames[k]) for k in keys], [math.radians(float(span[k])) for k in keys]
    )
    if progress:
        progress(1.0)
    return int(keys.size), int(span.size)
