"""The tracer's camera -> a Blender camera object, and back: the models are the same (lens, sensor, fit, shift,
perspective or orthographic, clipping, a thin lens's depth of field as Cycles sizes it); what the tracer cannot
express is named by unsupported()."""

from __future__ import annotations

import math

import bpy

from .. import compat

PANORAMAS = ("EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID", "MIRRORBALL")  # the tracer's
DEFAULT_CLIP = (0.01, 1000.0)  # metres: a built camera's clip_start and clip_end where the scene file has none


def create(camera, collection, name: str = "WV Camera"):
    """A Blender camera object for a tracer Camera, linked into collection."""
    data = bpy.data.cameras.new(name)
    data.lens = camera.lens
    data.sensor_width = camera.sensor_width
    data.sensor_height = camera.sensor_height
    data.sensor_fit = camera.sensor_fit
    data.type = camera.type
    data.ortho_scale = camera.ortho_scale
    data.shift_x, data.shift_y = camera.shift_x, camera.shift_y
    # Blender needs a positive near plane and a finite far one (and a depth buffer that resolves the viewport):
    # where the scene file has none, Blender's usual 1 cm and 1 km, which export then writes
    data.clip_start = camera.clip_start if camera.clip_start > 0.0 else DEFAULT_CLIP[0]
    data.clip_end = camera.clip_end if camera.clip_end is not None else max(DEFAULT_CLIP[1], 2.0 * data.clip_start)
    obj = bpy.data.objects.new(name, data)
    obj.location = camera.location
    obj.rotation_euler = [math.radians(angle) for angle in camera.rotation]
    collection.objects.link(obj)
    return obj


def to_tracer(obj) -> dict:
    """A camera object -> the scene file's camera section (world transform, Euler XYZ degrees)."""
    location, rotation, _ = obj.matrix_world.decompose()
    euler = rotation.to_euler("XYZ")
    data = obj.data
    panorama = _panorama(data)
    return {
        "location": list(location),
        "rotation": [math.degrees(angle) for angle in euler],
        "lens": data.lens,
        "sensor_width": data.sensor_width,
        "sensor_height": data.sensor_height,
        "sensor_fit": data.sensor_fit,
        "type": "ORTHO" if data.type == "ORTHO" else "PANO" if panorama else "PERSP",
        "ortho_scale": data.ortho_scale,
        "shift_x": data.shift_x,
        "shift_y": data.shift_y,
        "clip_start": data.clip_start,
        "clip_end": data.clip_end,
        **(panorama or depth_of_field(obj)),
    }


def _panorama(data) -> dict:
    """A panoramic camera's settings as the scene file's ({} for another camera, or a panorama type the tracer does
    not have: unsupported() names it)."""
    if data.type != "PANO":
        return {}
    settings = compat.panorama_settings(data)
    if settings.panorama_type not in PANORAMAS:
        return {}
    return {
        "panorama_type": settings.panorama_type,
        "fisheye_fov": min(math.degrees(settings.fisheye_fov), 360.0),  # Blender keeps radians in float32
        "fisheye_lens": settings.fisheye_lens,
        **{
            name: min(max(math.degrees(getattr(settings, name)), -90.0), 90.0)
            for name in ("latitude_min", "latitude_max")
        },
        **{name: math.degrees(getattr(settings, name)) for name in ("longitude_min", "longitude_max")},
    }


def depth_of_field(obj) -> dict:
    """A camera object's depth of field as the scene file's thin lens ({} without): Cycles' aperture radius,
    lens / 1000 / (2 f-stop) metres for a perspective camera and 1 / (2 f-stop) for an orthographic one
    (intern/cycles/blender/camera.cpp), and its focus distance: the focus object's distance along the view axis
    where there is one, else the Focus Distance."""
    dof = obj.data.dof
    if not dof.use_dof:
        return {}
    fstop = max(float(dof.aperture_fstop), 1e-5)
    aperture = 1.0 / (2.0 * fstop) if obj.data.type == "ORTHO" else obj.data.lens * 1e-3 / (2.0 * fstop)
    distance = float(dof.focus_distance)
    if dof.focus_object is not None:
        axis = obj.matrix_world.to_3x3().col[2].normalized()  # the camera looks along its -Z
        offset = dof.focus_object.matrix_world.translation - obj.matrix_world.translation
        distance = abs(offset.dot(axis))
    return {"aperture": aperture, "focus_distance": max(distance, 1e-6)}


def _moves(obj) -> bool:
    """Whether an object or any of its parents is animated or constrained (its world transform can change)."""
    while obj is not None:
        animation = obj.animation_data
        if (animation is not None and (animation.action is not None or animation.drivers)) or obj.constraints:
            return True
        obj = obj.parent
    return False


def unsupported(blender_scene, exporting: bool = True) -> list[str]:
    """What of the scene's camera and render settings the tracer does not render, one short phrase each.

    exporting: a moving camera counts (a scene file holds one camera; the render engine renders each frame's)."""
    obj = blender_scene.camera
    problems = []
    if obj is not None:
        data = obj.data
        if data.type == "PANO" and compat.panorama_settings(data).panorama_type not in PANORAMAS:
            kind = compat.panorama_settings(data).panorama_type.replace("_", " ").lower()
            problems.append(f"panoramic camera, {kind} (rendered as perspective)")
        if data.type == "PANO" and data.dof.use_dof:
            problems.append("depth of field of a panoramic camera (rendered sharp)")
        if data.dof.use_dof and data.dof.aperture_blades >= 3:
            problems.append(f"aperture of {data.dof.aperture_blades} blades (a round one)")
        if data.dof.use_dof and data.dof.aperture_ratio != 1.0:
            problems.append("anamorphic aperture ratio (a round aperture)")
        if exporting and _moves(obj):
            problems.append(f"moving camera (exported as at frame {blender_scene.frame_current})")
    render = blender_scene.render
    if exporting and render.use_border:
        problems.append("render border (a scene file holds the whole frame; F12 renders only the border)")
    return problems
