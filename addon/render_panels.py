"""The tracer engine in the Properties editor: Blender's own panels that mean something for it (output, format, frame
range, metadata, post processing, colour management, camera and light data), and its own in Render and World.

Blender shows a panel for an engine when the engine is in the panel's COMPAT_ENGINES. Registering adds
WEATHERVANE_TRACER to the chosen stock panels and remembers which; unregistering removes it from exactly those.
The engine's own panels draw the same scene settings as the sidebar (one source of truth), Blender-style.
"""

from __future__ import annotations

import bpy

from .panels import draw_background, draw_highlights

ENGINE = "WEATHERVANE_TRACER"

# Data panels of the camera and the light that mean something for the tracer (lens, sensor, shift, clipping,
# display, safe areas; the light's own panel).
DATA_PANELS = {"DATA_PT_context_camera", "DATA_PT_context_light", "DATA_PT_light", "DATA_PT_custom_props_camera",
               "DATA_PT_custom_props_light"}  # fmt: skip
_added: list[type] = []


def _stock_panels() -> list[type]:
    """Blender's panels to show for the tracer: every Output panel, colour management, camera and light data."""
    chosen = []
    for cls in bpy.types.Panel.__subclasses__():
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not isinstance(engines, set) or not cls.is_registered:
            continue
        name, context = cls.__name__, getattr(cls, "bl_context", "")
        if name.startswith(("CYCLES_", "EEVEE_")) or "stereoscopy" in name or "_dof" in name:
            continue  # another engine's own panels, and what the tracer does not render (3D, depth of field)
        if (
            context == "output"
            or (context == "render" and name.startswith("RENDER_PT_color_management"))
            or (context == "data" and (name in DATA_PANELS or name.startswith(("DATA_PT_camera", "DATA_PT_lens"))))
        ):
            chosen.append(cls)
    return chosen


class TracerPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def split_layout(self):
        """The panel's layout in Blender's Properties style: labels in a column, no keyframe decorators."""
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        return layout


class WEATHERVANE_RENDER_PT_tracer(TracerPanel, bpy.types.Panel):
    bl_label = "Weathervane Tracer"
    bl_context = "render"

    def draw(self, context):
        layout = self.split_layout()
        settings = context.scene.weathervane
        layout.prop(settings, "depth")
        layout.prop(settings, "samples")
        layout.prop(settings, "workers")
        layout.prop(settings, "numerics")
        layout.prop(settings, "precision")
        # the tracer's values are display values: only Standard shows them as `python -m tracer render --srgb` does
        transform = context.scene.view_settings.view_transform
        icon = "CHECKMARK" if transform == "Standard" else "ERROR"
        layout.label(text=f"View Transform: {transform}", icon=icon)


class WEATHERVANE_RENDER_PT_shading(TracerPanel, bpy.types.Panel):
    bl_label = "Highlights"
    bl_context = "render"
    bl_parent_id = "WEATHERVANE_RENDER_PT_tracer"

    def draw(self, context):
        # the model's names and "Exponent Factor" are longer than a label column holds at the editor's default width
        draw_highlights(self.layout, context.scene.weathervane, text="")


class WEATHERVANE_WORLD_PT_background(TracerPanel, bpy.types.Panel):
    bl_label = "Tracer Background"
    bl_context = "world"

    def draw(self, context):
        draw_background(self.split_layout(), context.scene.weathervane)


CLASSES = (WEATHERVANE_RENDER_PT_tracer, WEATHERVANE_RENDER_PT_shading, WEATHERVANE_WORLD_PT_background)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for cls in _stock_panels():
        if ENGINE not in cls.COMPAT_ENGINES:
            cls.COMPAT_ENGINES.add(ENGINE)
            _added.append(cls)


def unregister() -> None:
    for cls in _added:
        cls.COMPAT_ENGINES.discard(ENGINE)
    _added.clear()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
