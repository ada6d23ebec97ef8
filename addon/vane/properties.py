"""The add-on's settings on the scene (`scene.weathervane`): wind, vane, spin, materials, lights, render."""

from __future__ import annotations

import math
import os

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from . import lights, materials


def _color(name: str, default: tuple[float, float, float], description: str, **extra):
    """A linear RGB color property in [0, 1] (the tracer's colors)."""
    return FloatVectorProperty(
        name=name, subtype="COLOR", size=3, min=0.0, max=1.0, default=default, description=description, **extra
    )


# F12 of a scene the add-on did not build: antialiased, the samples spent where neighbouring pixels differ (adaptive
# sampling); Build sets the scene file's own (the documented vane: 1 sample, the seed's image)
ANTIALIASED_SAMPLES = 16
ANTIALIASED_THRESHOLD = 0.005


def _square_counts(one: str, where: str) -> list[tuple[str, str, str]]:
    """Enum items for a stratified n x n count (1, 4, 9, 16, 64): one's tooltip, and "Stratified n x n" + where."""
    return [("1", "1", one)] + [(str(n * n), str(n * n), f"Stratified {n} x {n}{where}") for n in (2, 3, 4, 8)]


def _material_changed(part, context) -> None:
    if not materials.syncing():  # the node's edit being copied here: the node holds it already
        materials.refresh_all(context.scene)


def _light_changed(light, context) -> None:
    lights.apply(light)
    if light.kind == "AMBIENT":
        materials.refresh_all(context.scene)


def _model_changed(settings, context) -> None:
    materials.refresh_all(context.scene)


def _workers_mode(settings) -> int:
    return 0 if settings.workers == 0 else 1


def _set_workers_mode(settings, value: int) -> None:
    """Auto-Detect is 0 processes; Fixed starts at one per core, as Blender's Threads Mode shows its count."""
    if value == 0:
        settings.workers = 0
    elif settings.workers == 0:
        settings.workers = min(64, max(1, os.cpu_count() or 1))


class WEATHERVANE_PG_material(bpy.types.PropertyGroup):
    """One tracer material: the documented model's color, specular exponent and reflectivity."""

    color: _color("Color", (0.8, 0.8, 0.8), "Linear RGB color", update=_material_changed)
    specular: FloatProperty(
        name="Shininess",
        min=0.0,
        max=10000.0,
        soft_max=1000.0,
        default=0.0,
        description="The specular exponent s of the documented model: larger is a smaller, sharper highlight "
        "(Blinn-Phong uses s times Shininess Scale); 0 is matte",
        update=_material_changed,
    )
    reflective: FloatProperty(
        name="Reflectivity",
        subtype="FACTOR",
        min=0.0,
        max=1.0,
        default=0.0,
        description="Share of the mirrored ray in the color",
        update=_material_changed,
    )
    parts: StringProperty(name="Parts", description="Objects that use this material")


class WEATHERVANE_PG_light(bpy.types.PropertyGroup):
    """One light of the documented model; point and directional lights drive a Blender light object."""

    kind: EnumProperty(
        name="Type",
        items=[
            ("AMBIENT", "Ambient", "Adds its intensity everywhere"),
            ("POINT", "Point", "A light at a position; no falloff, as documented"),
            ("DIRECTIONAL", "Directional", "A light at infinity, shining along a direction"),
        ],
        default="POINT",
        update=_light_changed,
    )
    intensity: FloatProperty(
        name="Intensity",
        min=0.0,
        soft_max=2.0,
        max=100.0,
        default=0.5,
        description="Scalar intensity of the white light",
        update=_light_changed,
    )
    object_name: StringProperty(name="Object", description="The Blender light object this entry drives")


class WEATHERVANE_PG_settings(bpy.types.PropertyGroup):
    scene_file: StringProperty(
        name="Scene File",
        description="A tracer scene (.json) to build; empty builds the default weathervane (the folder button "
        "browses .json files only)",
    )
    # ---- wind (animatable: key them on the timeline) ----
    wind_direction: FloatProperty(
        name="Wind From",
        subtype="ANGLE",
        unit="ROTATION",
        min=-2 * math.pi,
        max=4 * math.pi,
        soft_min=0.0,
        soft_max=2 * math.pi,
        default=math.radians(270.0),
        description="Compass direction the wind comes from, clockwise from north (+Y)",
    )
    wind_speed: FloatProperty(
        name="Wind Speed", unit="VELOCITY", min=0.0, max=60.0, default=5.0, description="Wind speed in m/s"
    )
    gust_intensity: FloatProperty(
        name="Gusts",
        subtype="FACTOR",
        min=0.0,
        max=1.0,
        default=0.0,
        description="Turbulence intensity (sigma_u / U); 0.1-0.2 over open country",
    )
    gust_time_scale: FloatProperty(
        name="Gust Time",
        unit="TIME_ABSOLUTE",
        min=0.05,
        max=60.0,
        default=2.0,
        description="Correlation time of the gusts in seconds",
    )
    gust_seed: IntProperty(name="Seed", min=0, max=1_000_000, default=0, description="Seed of the gusts")
    start_frame: IntProperty(name="Start", min=0, default=1, description="The wind starts blowing at this frame")
    use_stop: BoolProperty(name="Stop", default=False, description="Calm the wind at a frame")
    stop_frame: IntProperty(name="Stop Frame", min=0, default=250, description="The wind stops at this frame")
    # ---- the vane ----
    mode: EnumProperty(
        name="Motion",
        items=[
            ("WIND", "Wind", "A real vane's damped response to the wind"),
            ("SPIN", "Spin", "Turn at a set speed, whatever the wind (the course's second mode)"),
        ],
        default="WIND",
    )
    damping: FloatProperty(
        name="Damping",
        min=0.02,
        max=5.0,
        soft_max=1.5,
        default=0.4,
        description="Damping ratio zeta: the smoothness of the swing (0.3-0.7 in real vanes)",
    )
    wavelength: FloatProperty(
        name="Swing Length",
        unit="LENGTH",
        min=0.5,
        max=100.0,
        default=8.0,
        description="Natural wavelength: metres of wind that pass during one undamped swing (6-10 m in real vanes)",
    )
    threshold: FloatProperty(
        name="Starting Speed",
        unit="VELOCITY",
        min=0.0,
        max=20.0,
        default=0.5,
        description="Threshold: below this wind speed the vane does not turn",
    )
    friction_time: FloatProperty(
        name="Friction Time",
        unit="TIME_ABSOLUTE",
        min=0.05,
        max=30.0,
        default=0.6,
        description="Seconds for bearing friction to stop a becalmed vane",
    )
    spin_direction: EnumProperty(
        name="Direction",
        items=[
            ("clockwise", "Clockwise", "Seen from above"),
            ("counterclockwise", "Counter-Clockwise", "Seen from above"),
        ],
        default="clockwise",
    )
    spin_speed: FloatProperty(
        name="Speed (°/s)",
        min=0.0,
        max=3600.0,
        soft_max=720.0,
        default=90.0,
        precision=1,
        description="Spin speed in degrees per second",
    )
    spin_smoothness: FloatProperty(
        name="Smoothness",
        unit="TIME_ABSOLUTE",
        min=0.0,
        max=60.0,
        default=1.0,
        description="Seconds to spin up after start and down after stop",
    )
    tolerance: FloatProperty(
        name="Key Accuracy (°)",
        min=0.001,
        max=5.0,
        default=0.05,
        precision=3,
        description="Tolerance: the largest angle in degrees by which the baked keys may miss the simulated motion "
        "(smaller: more keys)",
    )
    # ---- materials and lights ----
    materials: CollectionProperty(type=WEATHERVANE_PG_material)
    material_index: IntProperty(name="Material", default=0)
    lights: CollectionProperty(type=WEATHERVANE_PG_light)
    light_index: IntProperty(name="Light", default=0)
    built_from: StringProperty(
        name="Built From", default="", description="The scene file the vane was built from (empty: the default)"
    )
    scene_settings_set: StringProperty(
        name="Scene Settings Set",
        default="",
        description="The scene settings the last Build set (JSON): a later Build from another file changes only "
        "those still at these values or Blender's factory values",
        options={"HIDDEN"},
    )
    other_lights: BoolProperty(
        name="Other Lights",
        default=False,
        description="Also render the scene's lights that the add-on did not make (the startup file's Light, "
        "lights you added), converted by their power; off, the tracer renders the listed lights only",
    )
    # ---- the documented tracer ----
    depth: IntProperty(
        name="Reflections",
        min=0,
        max=16,
        default=3,
        description="How many times a ray bounces off mirrors: the documented tracer's recursion depth (0: no "
        "reflections)",
    )
    model: EnumProperty(
        name="Model",
        items=[
            (
                "blinn-phong",
                "Blinn-Phong",
                "Highlights from the half vector between light and view: round highlights (the documented model's "
                "default)",
            ),
            (
                "phong",
                "Phong",
                "Highlights from the light reflected about the surface: stretched, cut off at grazing angles",
            ),
        ],
        default="blinn-phong",
        update=_model_changed,
    )
    coef: FloatProperty(
        name="Shininess Scale",
        min=0.1,
        max=16.0,
        default=3.0,
        description="Blinn-Phong's highlight exponent is each material's Shininess times this (the documented "
        "model's exponent factor, coef; 2-4 keeps highlights as tight as Phong's)",
        update=_model_changed,
    )
    background: EnumProperty(
        name="Background",
        items=[
            ("sky", "Sky", "Vertical gradient by the ray's elevation"),
            ("solid", "Solid", "One color"),
            (
                "documented",
                "Centre Sky Color",
                "As documented: every ray that misses gets the sky's color at the image centre, as the course's "
                "tracer does",
            ),
            ("none", "None", "Black"),
        ],
        default="sky",
    )
    background_color: _color("Color", (0.05, 0.05, 0.05), "The solid background's color")
    horizon: _color("Horizon", (0.75, 0.82, 0.9), "The sky's color at the horizon and below")
    zenith: _color("Zenith", (0.25, 0.45, 0.8), "The sky's color straight up")
    workers: IntProperty(
        name="Processes",
        min=0,
        max=64,
        default=0,
        description="How many processes trace the image's bands at once (the tracer's workers; 0: one per CPU core)",
    )
    workers_mode: EnumProperty(
        name="Processes",
        items=[
            ("AUTO", "Auto-Detect", "One process per CPU core (the tracer's workers 0)", 0),
            ("FIXED", "Fixed", "A set number of processes (the tracer's workers)", 1),
        ],
        get=_workers_mode,
        set=_set_workers_mode,
        description="How many processes trace the image's bands at once, as Blender's Threads Mode",
    )
    numerics: EnumProperty(
        name="Ray Hits",
        items=[
            (
                "documented",
                "As Documented",
                "The course's fixed epsilons and formulas (numerics: documented): dark speckles (shadow acne) far "
                "from the scene's origin",
            ),
            (
                "robust",
                "Robust",
                "No speckles or gaps (numerics: robust): stable quadratics, watertight triangles, offsets from each "
                "surface's own rounding",
            ),
        ],
        default="documented",
    )
    precision: EnumProperty(
        name="Precision",
        items=[
            ("float64", "64-bit", "Double precision (float64): the documented tracer's numbers"),
            ("float32", "32-bit (Faster)", "Single precision (float32): about a quarter faster, coarser"),
        ],
        default="float64",
    )
    samples: EnumProperty(
        name="Samples",
        description="Camera samples per pixel, at most (render.samples): 1 is the documented tracer's one ray through "
        "each pixel centre; more antialias edges, where Threshold spends them",
        items=_square_counts("One ray through each pixel centre", ""),
        default=str(ANTIALIASED_SAMPLES),
    )
    noise_threshold: FloatProperty(
        name="Threshold",
        description="Noise threshold of adaptive sampling (render.adaptive_threshold): every pixel at 1 sample first, "
        "then Samples only where a pixel differs by more than this from the midpoint of two opposite neighbours "
        "(edges, texture detail, penumbrae; not smooth gradients); 0 traces every pixel at Samples",
        min=0.0,
        max=1.0,
        precision=4,
        step=0.1,
        default=ANTIALIASED_THRESHOLD,
    )
    shadow_samples: EnumProperty(
        name="Shadows",
        description="Shadow samples: points each pixel samples on each light of a size (area lights, a sun's angle, "
        "a light's radius) for its shadow (render.shadow_samples), multi-jittered (from 9, four patterns over each "
        "2 x 2 block of pixels): 1 is a hard shadow from the light's centre, more a penumbra as wide as the light",
        items=_square_counts("The light's centre alone: hard shadows", " over the light"),
        default="1",
    )
    glossy_samples: EnumProperty(
        name="Glossy",
        description="Glossy samples: reflection rays from each point of a rough metal, Glossy BSDF or rough glass at "
        "a path's first glossy surface, shared out among a pixel's samples (render.glossy_samples); more rays, a "
        "smoother blurred reflection and a longer render",
        items=[(str(n), str(n), f"{n} reflection rays a point") for n in (4, 16, 64, 256)],
        default="16",
    )
    # the Rendered view's own samples (Render Properties > Weathervane Tracer > Viewport): each at most F12's above
    viewport_samples: EnumProperty(
        name="Samples",
        description="Viewport samples: rays a pixel in the Rendered view, at most F12's Samples; the view's first "
        "image after a change is 1 sample of everything, then more up to these",
        items=_square_counts("One ray through each pixel centre", ""),
        default="1",
    )
    viewport_shadow_samples: EnumProperty(
        name="Shadows",
        description="Viewport shadow samples: points on each light of a size in the Rendered view, at most F12's "
        "Shadows (the world light: these, at least 4 directions)",
        items=_square_counts("The light's centre alone: hard shadows", " over the light"),
        default="4",
    )
    viewport_glossy_samples: EnumProperty(
        name="Glossy",
        description="Viewport glossy samples: reflection rays from each point of a rough surface in the Rendered "
        "view, at most F12's Glossy",
        items=[(str(n), str(n), f"{n} reflection rays a point") for n in (1, 4, 16, 64, 256)],
        default="4",
    )
    diffuse_bounces: IntProperty(
        name="Bounces",
        description="Diffuse bounces: indirect light between surfaces (render.diffuse_bounces), the diffuse bounces a "
        "path may take, "
        "as Cycles' Light Paths > Diffuse; 0 (the default) is the documented model's direct light only; each bounce "
        "sends Glossy rays from a path's first surface",
        min=0,
        max=8,
        default=0,
    )
    motion_blur_steps: IntProperty(
        name="Steps",
        description="Motion blur steps: the renders of the scene at evenly spaced times over Blender's shutter "
        "(Render > Motion Blur), averaged into the frame (poses in the scene file); each step is one render",
        min=2,
        max=64,
        default=16,
    )
    world_light: EnumProperty(
        name="World Light",
        description="How the world lights a scene the add-on did not build",
        items=(
            ("SHADOWED", "Shadowed", "Objects shadow the world's light, as in Cycles (16 shadow rays a point or more)"),
            ("AMBIENT", "Ambient", "The world's mean light everywhere, unshadowed: faster, flatter"),
        ),
        default="SHADOWED",
    )


class WEATHERVANE_PG_view_layer(bpy.types.PropertyGroup):
    """A view layer's boxes for the tracer's passes Blender has none for (View Layer > Passes draws them beside
    Blender's own, which are the view layer's too: each view layer asks for its own passes)."""

    use_pass_ambient: BoolProperty(
        name="Ambient",
        default=False,
        description="Ambient pass: the ambient lights' share of the image (ambient times colour times 1 - "
        "reflectivity); with the other light passes (not Shadow) it adds up to Combined",
    )
    use_pass_reflection: BoolProperty(
        name="Reflection",
        default=False,
        description="Reflection pass: what the mirror rays bring back (the reflected surfaces' shading and their "
        "emission, weighted by reflectivity)",
    )
    use_pass_transmission: BoolProperty(
        name="Transmission",
        default=False,
        description="Transmission pass: what the rays through glass (refracted) and through transparency (straight "
        "on) bring back, weighted; with the other light passes it adds up to Combined",
    )


CLASSES = (WEATHERVANE_PG_material, WEATHERVANE_PG_light, WEATHERVANE_PG_settings, WEATHERVANE_PG_view_layer)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.weathervane = PointerProperty(type=WEATHERVANE_PG_settings)
    bpy.types.ViewLayer.weathervane = PointerProperty(type=WEATHERVANE_PG_view_layer)


def unregister() -> None:
    del bpy.types.ViewLayer.weathervane
    del bpy.types.Scene.weathervane
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
