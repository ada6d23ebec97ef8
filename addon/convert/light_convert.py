"""A Blender light object -> a tracer light (docs/scene-format.md) and one short line per thing it approximates.

Cycles' units, measured on a white diffuse plane (albedo 1) facing the light, radius 0, in Cycles 5.0.1 (bpy wheel)
and 3.4.1 (Debian), both giving the same numbers (tests/addon/test_shading_convert.py repeats it):

    point 100 W at 2 m: 0.63324, at 5 m: 0.10132; 1000 W at 2 m: 6.33241, at 5 m: 1.01321
        = P / (4 pi^2 d^2) to 1e-4: the tracer's diffuse i cos / d^2 (falloff "inverse_square") needs i = P / (4 pi^2)
    spot, on its axis: the same as a point of the same power (the cone does not concentrate it)
    sun of strength 1: 0.31831, 3: 0.95493 = S / pi: a directional light of i = S / pi

So a point or spot light is {"intensity": P / (4 pi^2), "falloff": "inverse_square"}, a sun a directional light of S /
pi, every light with its colour (times the blackbody colour where Use Temperature is on, and the power times 2^exposure
and, where 4.5+'s Normalize is off, times the emitter's area, as Cycles emits them). A spot shines along the light's -Z
axis in world space with Blender's spot_size (the full cone, here in degrees) and spot_blend. A sun's angle is the
directional light's "angle" (soft shadows with the render's Shadows setting); where it is above 0 and the sun's Glossy
ray visibility and Multiple Importance are on, "seen_in_mirrors" (mirrors show its disc at Cycles' radiance,
"disc_model" cycles3 in Blender 3.x: tests/addon/test_sun_in_mirrors.py).

An area light is the tracer's "area" light (a one-sided cosine emitter sampled over its shape, docs/scene-format.md):
its intensity along the normal is P / pi W/sr, so {"intensity": P / pi^2} in Blender 4.0-5.0 and P / pi^2 * pi / 4 in
3.4 (compat.area_light_share(): Cycles 3.4 emits pi / 4 as much for one power). Its size is Blender's size (and size_y
for a rectangle or an ellipse) times the object's scale along its local X and Y (a square or disk scaled unevenly
becomes a rectangle or an ellipse), its x_axis the object's local X. Measured on a white diffuse plane, 1000 W, 2 m
square, disk, 2 x 1 m rectangle and ellipse at 1, 2 and 5 m, straight under and 45 degrees off (Cycles 256 samples
against the tracer's 1024 shadow samples): within 0.31% in 5.0.1 and 0.08% in 3.4.1 (the 2 m square in the 4.2.23 wheel:
as 5.0.1's, within 0.2%) (tests/addon/test_area_lights_cycles.py repeats a few). A spread below 180 degrees is named
(the tracer's emitter is a full cosine). A point or spot light's radius is the tracer's "radius" (its shadow rays go
to a disk of that radius facing each point: soft shadows with Shadows above 1 sample); its intensity stays a point's,
and 4.0+'s Soft Falloff near the light is named (a 100 W point of radius 0.1 m is 0.25% darker than radius 0 at 2 m,
3.9% at 0.5 m; radius 0.25 m at 0.5 m: 20%).

The add-on's own lights (vane/lights.py: documented point lights with a constant-falloff node, and suns) convert back to
exactly the intensity, location and direction the panel and the scene file hold.
"""

from __future__ import annotations

import math

import bpy
from mathutils import Vector

from .. import compat
from ..vane.lights import MIRRORS_ONLY
from . import node_tree

POINT_WATTS_PER_UNIT = 4.0 * math.pi**2  # P = 4 pi^2 i (measured: see above)
SUN_STRENGTH_PER_UNIT = math.pi  # S = pi i
AREA_WATTS_PER_UNIT = math.pi**2  # an area light: P = pi^2 i (i along its normal; measured: see above)


def _shadow_samples(blender_scene) -> int:
    """The render's Shadows samples (1 where the add-on's settings are not there)."""
    settings = getattr(blender_scene, "weathervane", None)
    return int(getattr(settings, "shadow_samples", "1"))


def _area_document(obj, light, power: float, notes: list[str]) -> dict:
    """An area light as the tracer's "area" light (its size times the object's scale along local X and Y)."""
    matrix = obj.matrix_world.to_3x3()
    x_axis, y_axis = matrix @ Vector((1.0, 0.0, 0.0)), matrix @ Vector((0.0, 1.0, 0.0))
    shape = light.shape.lower()
    size_y = light.size_y if shape in ("rectangle", "ellipse") else light.size
    size = [float(light.size * x_axis.length), float(size_y * y_axis.length)]
    if shape in ("square", "disk") and not math.isclose(size[0], size[1], rel_tol=1e-9):
        shape = {"square": "rectangle", "disk": "ellipse"}[shape]
    factor = compat.area_light_share()
    spread = float(getattr(light, "spread", math.pi))
    if spread < math.pi - 1e-6:
        notes.append(f"area light spread {math.degrees(spread):.3g}°: 180°")
    return {
        "type": "area",
        "location": list(obj.matrix_world.translation),
        "direction": list(_world_axis(obj, -1.0)),
        "x_axis": list(x_axis.normalized()),
        "shape": shape,
        "size": size[0] if shape in ("square", "disk") else size,
        "intensity": power / AREA_WATTS_PER_UNIT * factor,
        # Object > Visibility > Ray Visibility > Glossy (on by default): mirrors and glass show the light's shape
        "seen_in_mirrors": bool(getattr(obj, "visible_glossy", True)),
    }


def _world_axis(obj, z: float) -> Vector:
    return (obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, z))).normalized()


def _falloff_node(light, notes: list[str] | None = None) -> tuple[str | None, float, tuple[float, float, float]]:
    """A Cycles light node tree, read through groups, reroutes and constant arithmetic (node_tree): (the Light
    Falloff output driving the Emission's Strength or None, strength, colour). An output with no shader is no light
    (strength 0), as in Cycles; what else varies is named in notes and read as the input's own value."""
    notes = [] if notes is None else notes
    if not compat.uses_nodes(light):
        return None, 1.0, (1.0, 1.0, 1.0)
    outputs = [n for n in light.node_tree.nodes if n.bl_idname == "ShaderNodeOutputLight"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    emission, _ = node_tree.source(output.inputs["Surface"]) if output is not None else (None, None)
    if emission is None:
        notes.append("light's node tree: no shader on its output, no light")
        return None, 0.0, (1.0, 1.0, 1.0)
    if emission.bl_idname != "ShaderNodeEmission":
        notes.append(f"{emission.bl_label} as the light's shader: the light's own colour and power")
        return None, 1.0, (1.0, 1.0, 1.0)
    color = node_tree.constant_color(emission.inputs["Color"])
    if color is None:
        feeding, _ = node_tree.source(emission.inputs["Color"])
        notes.append(f"{feeding.bl_label} on the light's Emission Color: white")
        color = (1.0, 1.0, 1.0)
    feeding, output_socket = node_tree.source(emission.inputs["Strength"])
    if feeding is not None and feeding.bl_idname == "ShaderNodeLightFalloff":
        strength = node_tree.constant_number(feeding.inputs["Strength"])
        if strength is None:
            notes.append("Light Falloff's Strength varies: its own value")
            strength = float(feeding.inputs["Strength"].default_value)
        return output_socket.name, strength, color
    strength = node_tree.constant_number(emission.inputs["Strength"])
    if strength is None:
        notes.append(f"{feeding.bl_label} on the light's Emission Strength: its own value")
        strength = float(emission.inputs["Strength"].default_value)
    return None, strength, color


def _multiple_importance(light) -> bool:
    """Whether Cycles samples the light by Multiple Importance (Light > Multiple Importance, on by default)."""
    settings = getattr(light, "cycles", None)
    return bool(getattr(settings, "use_multiple_importance_sampling", True))


def documented(light) -> bool:
    """Whether a Blender point light or sun is the documented light the Lights panel's entry holds, in any colour:
    a point of radius 0 driven by a Light Falloff node's Constant output, a sun of angle 0. Else it converts as
    Blender's light of its type, falloff, radius and angle included."""
    if light.type == "SUN":
        return light.angle == 0.0
    if light.type != "POINT" or light.shadow_soft_size != 0.0:
        return False
    return _falloff_node(light) == ("Constant", 1.0, (1.0, 1.0, 1.0))


def _own(obj, blender_scene) -> dict | None:
    """The add-on's own light as the documented light its panel entry holds; None where it is not one."""
    entries = getattr(getattr(blender_scene, "weathervane", None), "lights", ())
    name = obj.original.name if getattr(obj, "original", None) is not None else obj.name
    entry = next((e for e in entries if e.object_name == name and e.kind != "AMBIENT"), None)
    light = obj.data
    if entry is None or not documented(light):
        return None
    power = compat.light_power(light)
    if entry.kind == "POINT" and light.type == "POINT":
        expected = entry.intensity * POINT_WATTS_PER_UNIT
        intensity = entry.intensity if math.isclose(power, expected, rel_tol=1e-6) else power / POINT_WATTS_PER_UNIT
        document = {
            "type": "point",
            "location": [compat.float32_decimal(c) for c in obj.matrix_world.translation],
            "intensity": compat.float32_decimal(intensity),
        }
    elif entry.kind == "DIRECTIONAL" and light.type == "SUN":
        expected = entry.intensity * SUN_STRENGTH_PER_UNIT
        intensity = entry.intensity if math.isclose(power, expected, rel_tol=1e-6) else power / SUN_STRENGTH_PER_UNIT
        axis = _world_axis(obj, 1.0)
        stored = obj.get("weathervane_direction")
        if stored is not None and axis.angle(Vector(stored).normalized(), 1.0) <= 1e-5:
            direction = [float(c) for c in stored]
        else:
            direction = list(axis * float(obj.get("weathervane_direction_length", 1.0)))
        document = {"type": "directional", "direction": direction, "intensity": compat.float32_decimal(intensity)}
    else:
        return None  # its type was changed in Blender's Light tab: converted as Blender now has it
    color = compat.light_color(light)
    if any(c != 1.0 for c in color):
        document["color"] = [float(c) for c in color]
    return document


def convert_light(obj, *, blender_scene=None) -> tuple[dict, list[str]]:
    """A Blender light object (evaluated or not; its matrix_world is used) -> (tracer light dict, notes)."""
    blender_scene = blender_scene or bpy.context.scene
    light = obj.data
    own = _own(obj, blender_scene)
    if own is not None:
        return own, []
    notes: list[str] = []
    falloff, strength, node_color = _falloff_node(light, notes)
    color = [c * n for c, n in zip(compat.light_color(light), node_color, strict=True)]
    power = compat.light_power(light) * strength
    location = list(obj.matrix_world.translation)
    kind = light.type
    if kind == "SUN":
        document = {"type": "directional", "direction": list(_world_axis(obj, 1.0)), "intensity": power / math.pi}
        if light.angle > 0.0:
            document["angle"] = math.degrees(light.angle)
            # Cycles' mirrors show the disc where the sun's Glossy ray visibility and Multiple Importance are on
            # (kernel/light/distant.h: a sun without MIS is never met by a ray), as Blender has them by default
            met = _multiple_importance(light)
            if met and getattr(obj, "visible_glossy", True):
                document["seen_in_mirrors"] = True
                if compat.cycles_sun_disc_model() != "cycles4":
                    document["disc_model"] = compat.cycles_sun_disc_model()
            if met and getattr(obj, "visible_camera", False):  # off for a light unless the user turns it on
                notes.append("sun's Camera ray visibility: its disc not shown to the camera, only in mirrors")
            if _shadow_samples(blender_scene) == 1:
                notes.append(f"sun angle {math.degrees(light.angle):.3g}°: hard shadow")
    elif kind == "AREA":
        document = _area_document(obj, light, power, notes)
        if _shadow_samples(blender_scene) == 1:
            notes.append("area light: hard shadow")
        if falloff is not None and falloff != "Quadratic":
            notes.append(f"{falloff.lower()} falloff node on an area light: inverse square")
    else:
        document = {
            "type": "point",
            "location": location,
            "intensity": power / POINT_WATTS_PER_UNIT,
            "falloff": "none" if falloff == "Constant" else "inverse_square",
        }
        if falloff == "Linear":
            notes.append("linear falloff node: inverse square")
        if kind == "SPOT":
            document.update(
                type="spot",
                direction=list(_world_axis(obj, -1.0)),
                spot_size=math.degrees(light.spot_size),
                spot_blend=float(light.spot_blend),
            )
            if getattr(light, "use_square", False):
                notes.append("square spot: a round cone")
            elif compat.cycles_spot_model() == "cycles4" and _unevenly_scaled(obj):
                document.update(_stretched_cone(obj))  # Cycles 4+ stretches the cone with the scale (3.4's: round)
        if kind in ("POINT", "SPOT") and light.shadow_soft_size > 0.0:
            document["radius"] = float(light.shadow_soft_size)
            if _shadow_samples(blender_scene) == 1:
                notes.append(f"radius {light.shadow_soft_size:.3g} m: hard shadow")
            if compat.light_soft_falloff(light):
                notes.append(f"radius {light.shadow_soft_size:.3g} m, soft falloff: inverse square")
    if not compat.light_normalized(light):
        document["intensity"] *= _emitter_area(document)
    brightest = max(color)
    if brightest > 1.0:  # the format's colours lie in [0, 1]: the excess goes into the intensity, the same light
        document["intensity"] *= brightest
        color = [c / brightest for c in color]
    document["color"] = color
    if not compat.light_casts_shadow(light):
        notes.append("casts no shadow in Blender: shadowed here")
    linking = getattr(getattr(obj, "original", None) or obj, "light_linking", None)  # 4.0+
    if linking is not None and linking.receiver_collection is not None:
        notes.append(f'light linking ("{linking.receiver_collection.name}"): lights every object')
    if linking is not None and linking.blocker_collection is not None:
        notes.append(f'shadow linking ("{linking.blocker_collection.name}"): every object casts its shadow')
    for factor, what in (("diffuse_factor", "diffuse"), ("specular_factor", "specular")):
        if float(getattr(light, factor, 1.0)) != 1.0:
            notes.append(f"{what} factor {getattr(light, factor):.3g}: 1")
    # Object > Visibility > Ray Visibility of the light: the terms it reaches (Glossy set by Build from a scene file's
    # seen_in_mirrors, while it still says the same, is that alone: the file's light keeps its highlight)
    original = getattr(obj, "original", None) or obj
    for flag in ("visible_diffuse", "visible_glossy"):
        seen = getattr(obj, flag, True)
        if not seen and not (flag == "visible_glossy" and original.get(MIRRORS_ONLY) == seen):
            document[flag] = False
    # Transmission ray visibility: the light through rough glass (visible_transmission); off it is Glossy's
    glossy_flag = bool(getattr(obj, "visible_glossy", True))
    transmission_flag = bool(getattr(obj, "visible_transmission", True))
    transmission = transmission_flag
    if not compat.glass_closure_splits_light_visibility():  # Cycles 4+: rough glass shows both while either is on
        transmission = transmission_flag or glossy_flag
        if transmission_flag and not document.get("visible_glossy", True):
            notes.append("Glossy ray visibility off: not reflected in rough glass (Cycles reflects it there too)")
    if not transmission:
        document["visible_transmission"] = False
    if document.get("seen_in_mirrors") and glossy_flag != transmission_flag:
        notes.append(
            f"Transmission ray visibility {'off' if glossy_flag else 'on'}: smooth glass shows the light as its"
            f" Glossy visibility ({'on' if glossy_flag else 'off'}) says"
        )
    return document, notes


def _emitter_area(document: dict) -> float:
    """Cycles' area of a converted light's emitter, by which Blender 4.5+ multiplies the light's power where its
    Normalize is off: an area light's world size (times pi / 4 for a disk or an ellipse), 4 pi r^2 for a point or
    spot of radius r (its sphere's; the object's scale does not count), pi sin^2(angle / 2) for a sun; 1 where the
    emitter has no size. Measured in Cycles 4.5.15 and 5.0.1 on a diffuse plane: 4.0x for a 2 m square, 2.0x for a
    1 m square scaled 2 along X, 0.785x for a 1 m disk, 3.1416x for a 0.5 m radius, 0.0313x for a 0.2 rad sun."""
    kind = document["type"]
    if kind == "area":
        size = document["size"]
        width, height = (size, size) if isinstance(size, float | int) else size
        area = width * height * (math.pi / 4.0 if document["shape"] in ("disk", "ellipse") else 1.0)
    elif kind in ("point", "spot"):
        area = 4.0 * math.pi * document.get("radius", 0.0) ** 2  # a sphere's
    else:
        area = math.pi * math.sin(math.radians(document.get("angle", 0.0)) / 2.0) ** 2
    return area if area > 0.0 else 1.0


def _stretched_cone(obj) -> dict:
    """A spot light object's cone as its scale stretches it: "x_axis" its local X in the world, "cone_scale" its x and
    y scales over its z scale (Cycles 4's spot: the ray divided by each axis's scale)."""
    x, y, z = obj.matrix_world.to_3x3().col
    return {"x_axis": list(x.normalized()), "cone_scale": [x.length / z.length, y.length / z.length]}


def _unevenly_scaled(obj) -> bool:
    """Whether a light object's local x, y and z axes have different lengths in the world (its scale)."""
    lengths = [column.length for column in obj.matrix_world.to_3x3().col]
    return max(lengths) - min(lengths) > 1e-4 * max(lengths)
