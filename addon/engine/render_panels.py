"""The tracer engine in the Properties editor: Blender's own panels that mean something for it (output, format, frame
range, metadata, post processing, colour management, camera data; material, light, world and object data as for
Cycles), and its own in Render and World.

Blender shows a panel for an engine when the engine is in the panel's COMPAT_ENGINES. Registering adds
WEATHERVANE_TRACER to the chosen stock panels and remembers which; unregistering removes it from exactly those.
The engine's own panels draw the same scene settings as the sidebar (one source of truth), Blender-style.
"""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

from ..convert import conversion_report
from ..vane import build
from ..vane.panels import draw_background, draw_highlights, draw_processes, panel_room, wrapped
from . import messages

ENGINE = "WEATHERVANE_TRACER"

# Data panels of the camera and the light that mean something for the tracer (lens, sensor, shift, clipping,
# display, safe areas; the light's own panel where Cycles' is not there).
DATA_PANELS = {"DATA_PT_context_camera", "DATA_PT_context_light", "DATA_PT_light", "DATA_PT_custom_props_camera",
               "DATA_PT_custom_props_light"}  # fmt: skip
# Material, World and Object Data Properties as Cycles has them (slot list, Surface with the node inputs, the light's
# type, colour, power and spot shape, the world's Surface, normals, UV maps, shape keys, attributes), found by the
# panels that list CYCLES, whose class names differ between Blender versions; not the ones for what the tracer does
# not render (previews, volumes, displacement, mist, Cycles' sampling and ray-visibility settings, light probes).
SHADING_CONTEXTS = ("material", "data", "world")
SKIPPED = ("preview", "volume", "_settings", "ray_visibility", "mist", "displacement", "_dof", "stereoscopy",
           "lightprobe")  # fmt: skip
_added: list[type] = []
_inherited: dict[type, object] = {}  # of _added, those whose COMPAT_ENGINES came from a base class: their own poll
_redrawn: dict[type, object] = {}  # of _added, those drawn otherwise for the tracer: their own draw


def _poll_for_tracer(cls):
    """cls's poll, answering for the tracer as for Cycles.

    Cycles' polls ask `CyclesButtonsPanel.poll(context)`, which reads the base class's set: while the tracer's panel
    polls, the engine is in that set, and only then (else every Cycles panel would show)."""
    original = cls.poll
    shared = [base.__dict__["COMPAT_ENGINES"] for base in cls.__mro__[1:] if "COMPAT_ENGINES" in base.__dict__]

    def poll(_cls, context):
        if context.engine != ENGINE:
            return original(context)
        lent = [engines for engines in shared if isinstance(engines, set) and ENGINE not in engines]
        for engines in lent:
            engines.add(ENGINE)
        try:
            return original(context)
        finally:
            for engines in lent:
                engines.discard(ENGINE)

    return classmethod(poll)


def _draw_for_tracer(cls):
    """cls's draw, drawing draw_light_data for the tracer and as it was for any other engine."""
    original = cls.draw

    def draw(self, context):
        if context.engine != ENGINE:
            return original(self, context)
        draw_light_data(self.layout, context.light, self.bl_space_type == "PROPERTIES")

    return draw


def draw_light_data(layout, light, expanded: bool) -> None:
    """The Light panel for the tracer in Blender 3.4-4.4, whose Cycles panel holds Cycles' own settings too (Max
    Bounces, Cast Shadow, Multiple Importance, Shadow Caustics, Portal: 4.5+ moved them to a Settings subpanel,
    which the tracer does not show): the light's type, colour, power and size, laid out as Cycles lays them out."""
    if expanded:
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True
    else:
        layout.use_property_split = True
        layout.row().prop(light, "type")
    column = layout.column()
    column.prop(light, "color")
    column.prop(light, "energy")
    column.separator()
    if light.type in {"POINT", "SPOT"}:
        if hasattr(light, "use_soft_falloff"):
            column.prop(light, "use_soft_falloff")
        column.prop(light, "shadow_soft_size", text="Radius")
    elif light.type == "SUN":
        column.prop(light, "angle")
    elif light.type == "AREA":
        column.prop(light, "shape", text="Shape")
        sizes = column.column(align=True)
        if light.shape in {"SQUARE", "DISK"}:
            sizes.prop(light, "size")
        else:
            sizes.prop(light, "size", text="Size X")
            sizes.prop(light, "size_y", text="Y")


def _stock_panels() -> list[type]:
    """Blender's panels to show for the tracer: every Output panel, colour management, camera and light data."""
    chosen = []
    cycles_light = getattr(bpy.types, "CYCLES_LIGHT_PT_light", None)
    for cls in bpy.types.Panel.__subclasses__():
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not isinstance(engines, set) or not cls.is_registered:
            continue
        name, context = cls.__name__, getattr(cls, "bl_context", "")
        if name.startswith(("CYCLES_", "EEVEE_")) or "stereoscopy" in name or "_dof" in name:
            continue  # another engine's own panels, and what the tracer does not render (3D, depth of field)
        if name == "DATA_PT_light" and cycles_light is not None:
            continue  # Cycles' Light panel (shading_panels) has the type, colour and power
        if (
            context == "output"
            or (context == "render" and name.startswith("RENDER_PT_color_management"))
            or (context == "data" and (name in DATA_PANELS or name.startswith(("DATA_PT_camera", "DATA_PT_lens"))))
        ):
            chosen.append(cls)
    return chosen


def shading_panels() -> list[type]:
    """Blender's Material, Light, World and Object Data panels that Cycles shows and that mean something here."""
    chosen = []
    for cls in bpy.types.Panel.__subclasses__():
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if not isinstance(engines, set) or "CYCLES" not in engines or not cls.is_registered:
            continue
        if getattr(cls, "bl_context", "") in SHADING_CONTEXTS and not any(
            word in cls.__name__.lower() for word in SKIPPED
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
        layout.prop(settings, "noise_threshold")
        layout.prop(settings, "shadow_samples")
        layout.prop(settings, "glossy_samples")
        layout.prop(settings, "diffuse_bounces")
        layout.prop(settings, "world_light")
        draw_processes(layout, settings)
        layout.prop(settings, "numerics")
        layout.prop(settings, "precision")
        # the vane's documented colours are display values: only Standard shows them as `python -m tracer render
        # --srgb` does (another is shown in red, to set it back here); a scene of the artist's own is radiance, as
        # Cycles', for any view transform
        if build.has_vane() and context.scene.view_settings.view_transform != "Standard":
            column = layout.column()
            column.alert = True
            column.prop(context.scene.view_settings, "view_transform", text="View Transform")


class WEATHERVANE_RENDER_PT_viewport(TracerPanel, bpy.types.Panel):
    # the Rendered view's own samples, as Cycles' Sampling has Viewport beside Render; F12's are in the panel above
    bl_label = "Viewport"
    bl_context = "render"
    bl_parent_id = "WEATHERVANE_RENDER_PT_tracer"

    def draw(self, context):
        layout = self.split_layout()
        settings = context.scene.weathervane
        layout.prop(settings, "viewport_samples")
        layout.prop(settings, "viewport_shadow_samples")
        layout.prop(settings, "viewport_glossy_samples")


class WEATHERVANE_RENDER_PT_shading(TracerPanel, bpy.types.Panel):
    bl_label = "Highlights"
    bl_context = "render"
    bl_parent_id = "WEATHERVANE_RENDER_PT_tracer"

    def draw(self, context):
        # the model's names and "Exponent Factor" are longer than a label column holds at the editor's default width
        draw_highlights(self.layout, context.scene.weathervane, text="")


class WEATHERVANE_WORLD_PT_background(TracerPanel, bpy.types.Panel):
    # the vane's background: shown only where the vane is built, as only then does F12 render it (without the vane
    # F12 renders the World's Surface, Blender's panel above it)
    bl_label = "Weathervane Background"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and build.has_vane()

    def draw(self, context):
        draw_background(self.split_layout(), context.scene.weathervane)


NOTE_INDENT = 44  # pixels before a note's text: the row's separator (factor 2) and the icon, with some room
NAME_INDENT = 24  # before a row's name: its icon


class WEATHERVANE_OT_conversion_note(bpy.types.Operator):
    # each line of a note in Scene Conversion is this button: its tooltip is the whole note (description below)
    bl_description = "What the conversion approximates here: click to copy the note to the clipboard"
    bl_idname = "weathervane.conversion_note"
    bl_label = "Conversion Note"
    bl_options = {"INTERNAL"}

    note: StringProperty(name="Note", description="The whole note, shown as the tooltip", options={"SKIP_SAVE"})

    @classmethod
    def description(cls, _context, properties):
        return properties.note or cls.bl_description

    def execute(self, context):
        if not self.note.strip():
            self.report({"ERROR"}, "No note to copy: each line of a Scene Conversion note passes its whole note")
            return {"CANCELLED"}
        try:
            context.window_manager.clipboard = self.note
        except Exception as error:  # no clipboard (a display without one): a line, never a traceback
            self.report({"ERROR"}, f"Cannot copy the note to the clipboard: {error}")
            return {"CANCELLED"}
        messages.report_whole(self, {"INFO"}, f"Copied to the clipboard: {self.note}")
        return {"FINISHED"}


class WEATHERVANE_RENDER_PT_conversion(TracerPanel, bpy.types.Panel):
    bl_label = "Scene Conversion"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        rows = conversion_report.scene_conversion(context.scene)
        # every text wrapped to the editor's width as Blender's font measures it; each line of a note is a button whose
        # tooltip is the whole note (and which copies it)
        width = context.region.width if context.region else 240
        room = panel_room(width)
        layout.label(text=conversion_report.summary_line(rows, fits=lambda line: messages.text_width(line) <= room))
        icons = {"MATERIAL": "MATERIAL", "LIGHT": "LIGHT", "WORLD": "WORLD"}
        for kind, name, notes in rows:
            column = layout.column(align=True)
            title = f"{name}: {'exact' if not notes else 'approximated'}"
            for index, line in enumerate(wrapped(title, width, NAME_INDENT)):
                column.label(text=line, icon=icons[kind] if index == 0 else "BLANK1")
            for note in notes:
                for index, line in enumerate(wrapped(note, width, NOTE_INDENT)):
                    row = column.row()
                    row.alignment = "LEFT"
                    row.separator(factor=2.0)
                    icon = "INFO" if index == 0 else "BLANK1"
                    button = row.operator("weathervane.conversion_note", text=line, icon=icon, emboss=False)
                    button.note = note


class WEATHERVANE_VIEWLAYER_PT_passes(TracerPanel, bpy.types.Panel):
    """View Layer > Passes for the tracer: Blender's own boxes for what it makes (its data passes, the light passes
    that are terms of the documented model, Cryptomatte), and its Ambient, Reflection and Transmission passes."""

    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.split_layout()
        view_layer = context.view_layer
        settings = view_layer.weathervane
        column = layout.column(heading="Data", align=True)
        column.prop(view_layer, "use_pass_combined")
        column.prop(view_layer, "use_pass_z")
        column.prop(view_layer, "use_pass_mist")
        column.prop(view_layer, "use_pass_normal")
        column.prop(view_layer, "use_pass_position")
        column.prop(view_layer, "use_pass_object_index")
        column.prop(view_layer, "use_pass_material_index")
        column = layout.column(heading="Light", align=True)
        column.prop(settings, "use_pass_ambient")
        column.prop(view_layer, "use_pass_diffuse_direct", text="Diffuse")
        column.prop(view_layer, "use_pass_glossy_direct", text="Glossy")
        column.prop(view_layer, "use_pass_emit", text="Emission")
        column.prop(settings, "use_pass_reflection")
        column.prop(view_layer, "use_pass_environment")
        column.prop(settings, "use_pass_transmission")
        column.prop(view_layer, "use_pass_shadow")
        column = layout.column(heading="Cryptomatte", align=True)
        column.prop(view_layer, "use_pass_cryptomatte_object", text="Object")
        column.prop(view_layer, "use_pass_cryptomatte_material", text="Material")


OPERATORS = (WEATHERVANE_OT_conversion_note,)
CLASSES = (
    WEATHERVANE_RENDER_PT_tracer,
    WEATHERVANE_RENDER_PT_viewport,
    WEATHERVANE_RENDER_PT_shading,
    WEATHERVANE_RENDER_PT_conversion,
    WEATHERVANE_WORLD_PT_background,
    WEATHERVANE_VIEWLAYER_PT_passes,
)


def register() -> None:
    for cls in OPERATORS + CLASSES:
        bpy.utils.register_class(cls)
    for cls in _stock_panels() + shading_panels():
        if ENGINE not in cls.COMPAT_ENGINES and cls not in _added:
            # a copy on the class itself: Cycles' panels share one set through their base class, and adding the
            # engine to it would show every Cycles panel (sampling, light paths, ...) for the tracer
            if "COMPAT_ENGINES" not in cls.__dict__:
                _inherited[cls] = cls.__dict__.get("poll")
                cls.poll = _poll_for_tracer(cls)
            cls.COMPAT_ENGINES = set(cls.COMPAT_ENGINES) | {ENGINE}
            _added.append(cls)
            if cls.__name__ == "CYCLES_LIGHT_PT_light" and not hasattr(bpy.types, "CYCLES_LIGHT_PT_settings"):
                _redrawn[cls] = cls.__dict__.get("draw")
                cls.draw = _draw_for_tracer(cls)
    conversion_report.register()


def unregister() -> None:
    conversion_report.unregister()
    for cls, draw in _redrawn.items():
        if draw is None:
            del cls.draw
        else:
            cls.draw = draw
    _redrawn.clear()
    for cls in _added:
        if cls in _inherited:
            del cls.COMPAT_ENGINES  # the base class's set again
            if _inherited[cls] is None:
                del cls.poll
            else:
                cls.poll = _inherited[cls]
        else:
            cls.COMPAT_ENGINES.discard(ENGINE)
    _added.clear()
    _inherited.clear()
    for cls in reversed(OPERATORS + CLASSES):
        bpy.utils.unregister_class(cls)
