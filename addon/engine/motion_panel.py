"""Render Properties > Motion Blur for the tracer engine: Blender's own switch, position and shutter (the ones Cycles
reads) and the tracer's steps, the renders averaged over the shutter (convert/motion_blur.py)."""

from __future__ import annotations

import bpy

from .render_panels import TracerPanel


class WEATHERVANE_RENDER_PT_motion_blur(TracerPanel, bpy.types.Panel):
    bl_label = "Motion Blur"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.split_layout()
        scene = context.scene
        layout.active = scene.render.use_motion_blur
        render = scene.render
        # Position lives on the render settings from Blender 4.2, on Cycles' settings before
        owner = render if hasattr(render, "motion_blur_position") else getattr(scene, "cycles", None)
        if owner is not None and hasattr(owner, "motion_blur_position"):
            layout.prop(owner, "motion_blur_position", text="Position")
        layout.prop(render, "motion_blur_shutter")
        layout.prop(scene.weathervane, "motion_blur_steps")


CLASSES = (WEATHERVANE_RENDER_PT_motion_blur,)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
