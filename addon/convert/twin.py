"""A built weathervane scene -> render settings under which Cycles (and EEVEE, Workbench) compute the documented
model as closely as they can: the "twin" of the tracer.

Cycles: bounces = depth (glossy only: the documented model has no indirect diffuse light), a box pixel filter of
width 1, no denoising, no clamping, no adaptive sampling, a fixed seed, the Standard view transform with no look
and no dither (so the saved pixels are the linear result), and a world that only camera and mirror rays see (the
background is what a miss returns; it lights nothing). The materials and lights are built for this by
vane/materials.py and vane/lights.py.
"""

from __future__ import annotations

import bpy

from .. import compat

WORLD = "WV World"


def color_management(blender_scene) -> None:
    view = blender_scene.view_settings
    view.view_transform = "Standard"
    view.look = "None"
    view.exposure = 0.0
    view.gamma = 1.0
    blender_scene.display_settings.display_device = "sRGB"
    blender_scene.render.dither_intensity = 0.0


def world(blender_scene) -> bpy.types.World:
    """The background as a world seen by camera and mirror rays only, from the panel's background settings."""
    settings = blender_scene.weathervane
    shader = bpy.data.worlds.get(WORLD) or bpy.data.worlds.new(WORLD)
    compat.enable_nodes(shader)
    tree = shader.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputWorld")
    background = tree.nodes.new("ShaderNodeBackground")
    path = tree.nodes.new("ShaderNodeLightPath")
    seen = tree.nodes.new("ShaderNodeMath")
    seen.operation = "MAXIMUM"
    tree.links.new(path.outputs["Is Camera Ray"], seen.inputs[0])
    tree.links.new(path.outputs["Is Singular Ray"], seen.inputs[1])
    tree.links.new(seen.outputs[0], background.inputs["Strength"])
    tree.links.new(background.outputs[0], output.inputs["Surface"])
    kind = settings.background
    if kind == "sky":
        coordinates = tree.nodes.new("ShaderNodeTexCoord")
        split = tree.nodes.new("ShaderNodeSeparateXYZ")
        clamp = tree.nodes.new("ShaderNodeMath")
        clamp.operation = "MAXIMUM"
        clamp.inputs[1].default_value = 0.0
        clamp.use_clamp = True
        mix = tree.nodes.new("ShaderNodeMixRGB")
        mix.inputs["Color1"].default_value = (*settings.horizon, 1.0)
        mix.inputs["Color2"].default_value = (*settings.zenith, 1.0)
        tree.links.new(coordinates.outputs["Generated"], split.inputs[0])
        tree.links.new(split.outputs["Z"], clamp.inputs[0])
        tree.links.new(clamp.outputs[0], mix.inputs["Fac"])
        tree.links.new(mix.outputs[0], background.inputs["Color"])
    else:
        background.inputs["Color"].default_value = (*_flat_color(blender_scene), 1.0)
    compat.no_world_sampling(shader)
    blender_scene.world = shader
    return shader


def _flat_color(blender_scene) -> tuple[float, float, float]:
    settings = blender_scene.weathervane
    if settings.background == "solid":
        return tuple(settings.background_color)
    if settings.background == "none":
        return (0.0, 0.0, 0.0)
    # documented: the sky at the canvas centre, as the tracer computes it
    from .. import tracer_api as tracer
    from ..vane import camera as camera_module

    render = blender_scene.render
    scale = render.resolution_percentage / 100.0
    size = tracer.RenderSettings(
        width=max(1, round(render.resolution_x * scale)), height=max(1, round(render.resolution_y * scale))
    )
    direction = tracer.documented_background_direction(
        tracer.Camera(**camera_module.to_tracer(blender_scene.camera)), size
    )
    background = tracer.Background(horizon=tuple(settings.horizon), zenith=tuple(settings.zenith))
    return background.sky(direction[2])


def cycles(blender_scene, samples: int = 256, seed: int = 0) -> None:
    settings = blender_scene.weathervane
    blender_scene.render.engine = "CYCLES"
    options = blender_scene.cycles
    options.device = "CPU"
    options.samples = samples
    options.seed = seed
    options.use_denoising = False
    if hasattr(options, "use_adaptive_sampling"):
        options.use_adaptive_sampling = False
    options.sample_clamp_direct = 0.0
    options.sample_clamp_indirect = 0.0
    options.max_bounces = settings.depth
    options.diffuse_bounces = 0
    options.glossy_bounces = settings.depth
    options.transmission_bounces = 0
    options.volume_bounces = 0
    options.transparent_max_bounces = 0
    options.caustics_reflective = True
    options.blur_glossy = 0.0
    options.pixel_filter_type = "BOX"
    options.filter_width = 1.0
    if hasattr(options, "light_sampling_threshold"):
        options.light_sampling_threshold = 0.0
    if hasattr(options, "use_light_tree"):
        # the light tree ranks lights by inverse-square falloff; the documented point lights have none, so it would
        # rarely pick them for distant surfaces and weigh them hugely when it does (fireflies)
        options.use_light_tree = False
    blender_scene.render.film_transparent = False
    color_management(blender_scene)
    world(blender_scene)


def eevee(blender_scene, samples: int = 64) -> None:
    blender_scene.render.engine = compat.eevee_engine()
    options = blender_scene.eevee
    options.taa_render_samples = samples
    color_management(blender_scene)
    world(blender_scene)


def workbench(blender_scene) -> None:
    blender_scene.render.engine = "BLENDER_WORKBENCH"
    shading = blender_scene.display.shading
    shading.light = "STUDIO"
    shading.color_type = "MATERIAL"
    color_management(blender_scene)
