"""The "Weathervane" tab of the 3D View's sidebar: Wind, Vane, Timing, Materials, Lights, Camera, Render.

Fields carry their label inside (no split into a label column): at the sidebar's default width a label column
leaves about 60 pixels, which cut most of the words; inside the field a label and its value share the whole width.
The real-window test measures every label against that width with Blender's UI font."""

from __future__ import annotations

import bpy

from ..convert.export import entry_kind, other_lights
from ..engine import messages
from . import build
from .operators import result_line

LIGHT_ICONS = {
    "AMBIENT": "WORLD",
    "POINT": "LIGHT_POINT",
    "DIRECTIONAL": "LIGHT_SUN",
    "SPOT": "LIGHT_SPOT",
    "AREA": "LIGHT_AREA",
}


def _prop(layout, settings, name: str, text: str | None) -> None:
    """layout.prop with the property's own label where text is None."""
    if text is None:
        layout.prop(settings, name)
    else:
        layout.prop(settings, name, text=text)


def draw_highlights(layout, settings, text: str | None = None) -> None:
    """The highlight model and, for Blinn-Phong, its exponent factor (the sidebar and Render Properties)."""
    _prop(layout, settings, "model", text)
    row = layout.row()
    row.active = settings.model == "blinn-phong"
    row.prop(settings, "coef")


def draw_processes(layout, settings, expand: bool = False) -> None:
    """How many processes trace, as Blender's Threads Mode and Threads: Auto-Detect (one per core) or a count."""
    if expand:  # the sidebar: the label above, the two choices side by side
        layout.label(text="Processes")
        layout.row().prop(settings, "workers_mode", expand=True)
    else:
        layout.prop(settings, "workers_mode")
    if settings.workers:
        layout.prop(settings, "workers", text="Count")


def draw_background(layout, settings, text: str | None = None) -> None:
    """The tracer's background: its type, and the colours that type uses (the sidebar and World Properties)."""
    _prop(layout, settings, "background", text)
    if settings.background == "solid":
        layout.prop(settings, "background_color")
    elif settings.background in ("sky", "documented"):
        layout.prop(settings, "horizon")
        layout.prop(settings, "zenith")


def panel_room(width: int, indent: int = 0) -> float:
    """Pixels a line of text has in a panel width pixels wide, less indent pixels (an icon, a box): the panel's
    margins and a button's padding taken off (the real-window test measures the lines with Blender's font)."""
    return width - (2 * 14 + 12 + indent) * messages.interface_scale()


# the sidebar's category tabs (Item, Tool, View, Weathervane) take a strip at the right of its region: in Blender
# 3.4.1's window at an interface scale of 1.04 the region is 229 px wide and its panels 205 px (a screenshot's pixels)
SIDEBAR_TABS = 23.0


def sidebar_width(region) -> float:
    """The width the sidebar's panels have in pixels: its region's, less the category tabs' strip."""
    return (region.width if region is not None else 229) - SIDEBAR_TABS * messages.interface_scale()


def wrapped(text: str, width: int, indent: int = 0) -> list[str]:
    """text wrapped into lines that fit a panel of width pixels, less indent pixels, as Blender's font measures them
    (a word too long for a line, a file's path, broken after a '/', '_' or '.')."""
    return messages.fitted(text, panel_room(width, indent))


RESULT_ICONS = {"INFO": "INFO", "WARNING": "ERROR", "ERROR": "CANCEL"}


class WeathervanePanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Weathervane"


class WEATHERVANE_PT_main(WeathervanePanel, bpy.types.Panel):
    bl_label = "Weathervane"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        layout.label(text="Scene File (empty: default)")
        row = layout.row(align=True)
        row.prop(settings, "scene_file", text="")
        row.operator("weathervane.scene_file_browse", icon="FILEBROWSER", text="")
        layout.operator("weathervane.build", icon="MOD_BUILD")
        row = layout.row(align=True)
        row.operator("weathervane.export", icon="EXPORT", text="Export")
        row.operator("weathervane.reset", icon="LOOP_BACK", text="Reset")
        # the last action's result line, kept until the next one (Blender's status bar shows it only for a while)
        line, kind = result_line()
        if line:
            column = layout.box().column(align=True)
            width = sidebar_width(context.region)
            for index, text in enumerate(wrapped(line, width, indent=30)):
                column.label(text=text, icon=RESULT_ICONS.get(kind, "INFO") if index == 0 else "BLANK1")


class WEATHERVANE_PT_wind(WeathervanePanel, bpy.types.Panel):
    bl_label = "Wind"
    bl_parent_id = "WEATHERVANE_PT_main"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        layout.prop(settings, "mode", expand=True)
        column = layout.column(align=True)
        if settings.mode == "WIND":
            column.prop(settings, "wind_direction")
            column.prop(settings, "wind_speed")
            column = layout.column(align=True)
            column.prop(settings, "gust_intensity")
            sub = column.column(align=True)
            sub.active = settings.gust_intensity > 0.0
            sub.prop(settings, "gust_time_scale")
            sub.prop(settings, "gust_seed")
        else:
            column.prop(settings, "spin_direction", text="")
            column.prop(settings, "spin_speed")
            column.prop(settings, "spin_smoothness")


class WEATHERVANE_PT_vane(WeathervanePanel, bpy.types.Panel):
    bl_label = "Vane"
    bl_parent_id = "WEATHERVANE_PT_main"

    @classmethod
    def poll(cls, context):
        return context.scene.weathervane.mode == "WIND"

    def draw(self, context):
        column = self.layout.column(align=True)
        settings = context.scene.weathervane
        column.prop(settings, "damping")
        column.prop(settings, "wavelength")
        column.prop(settings, "threshold")
        column.prop(settings, "friction_time")


class WEATHERVANE_PT_timing(WeathervanePanel, bpy.types.Panel):
    bl_label = "Timing"
    bl_parent_id = "WEATHERVANE_PT_main"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        column = layout.column(align=True)
        column.prop(settings, "start_frame")
        row = column.row(align=True)
        row.prop(settings, "use_stop", text="")
        sub = row.row(align=True)
        sub.active = settings.use_stop
        sub.prop(settings, "stop_frame")
        layout.prop(settings, "tolerance")
        # the frames Bake keys are the scene's frame range (Output Properties), shown where the button is
        scene = context.scene
        layout.operator("weathervane.bake", icon="KEY_HLT", text=f"Bake Frames {scene.frame_start}-{scene.frame_end}")
        if bpy.data.objects.get(build.TURN) is None:
            layout.label(text="Build first, then bake", icon="INFO")


class WEATHERVANE_UL_materials(bpy.types.UIList):
    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_property, _index):
        row = layout.row(align=True)
        row.prop(item, "color", text="")
        row.label(text=item.name)


class WEATHERVANE_PT_materials(WeathervanePanel, bpy.types.Panel):
    bl_label = "Materials"
    bl_parent_id = "WEATHERVANE_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        layout.template_list("WEATHERVANE_UL_materials", "", settings, "materials", settings, "material_index", rows=3)
        if 0 <= settings.material_index < len(settings.materials):
            entry = settings.materials[settings.material_index]
            column = layout.column()
            column.prop(entry, "color")
            column.prop(entry, "specular")
            column.prop(entry, "reflective")
            for line in wrapped(f"Parts: {entry.parts}", sidebar_width(context.region)):
                column.label(text=line)


class WEATHERVANE_UL_lights(bpy.types.UIList):
    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_property, _index):
        # the type's name only: beside a value field "Directional" is cut at the sidebar's default width (the
        # intensity is the field under the list)
        kind = entry_kind(item)
        layout.label(text=kind.title(), icon=LIGHT_ICONS.get(kind, "LIGHT"))


class WEATHERVANE_PT_lights(WeathervanePanel, bpy.types.Panel):
    bl_label = "Lights"
    bl_parent_id = "WEATHERVANE_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        row = layout.row()
        row.template_list("WEATHERVANE_UL_lights", "", settings, "lights", settings, "light_index", rows=3)
        column = row.column(align=True)
        column.operator_menu_enum("weathervane.light_add", "kind", icon="ADD", text="")
        column.operator("weathervane.light_remove", icon="REMOVE", text="")
        if 0 <= settings.light_index < len(settings.lights):
            entry = settings.lights[settings.light_index]
            column = layout.column()
            # the type is the Blender light's: changed in the Light tab, it is rendered and shown as the new one
            kind = entry_kind(entry)
            column.label(text=f"Type: {kind.title()}", icon=LIGHT_ICONS.get(kind, "LIGHT"))
            if kind in ("AMBIENT", "POINT", "DIRECTIONAL"):
                column.prop(entry, "intensity")
            else:
                column.label(text="Power from the Light tab", icon="INFO")
            obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
            if obj is not None:
                if kind in ("POINT", "SPOT", "AREA"):
                    column.prop(obj, "location")
                else:
                    column.prop(obj, "rotation_euler", text="Rotation")
        others = other_lights(context.scene)
        if others:
            box = layout.box()
            box.prop(settings, "other_lights")
            for obj in others[:6]:
                rendered = "rendered" if settings.other_lights else "not rendered"
                box.label(text=f"{obj.name} ({rendered})", icon="LIGHT" if settings.other_lights else "HIDE_ON")


class WEATHERVANE_PT_camera(WeathervanePanel, bpy.types.Panel):
    bl_label = "Camera"
    bl_parent_id = "WEATHERVANE_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        camera = context.scene.camera
        if camera is None:
            layout.label(text="The scene has no camera", icon="INFO")
            return
        # Blender's own Object Properties layout: "Location X", "Y", "Z" in a label column beside the values (in a
        # row the label and three values share the sidebar's width and all four are cut)
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.column(align=True).prop(camera, "location")
        layout.column(align=True).prop(camera, "rotation_euler", text="Rotation")
        if camera.type == "CAMERA":
            column = layout.column()
            column.use_property_split = False  # the label inside the field: a label column cuts "Focal Length"
            column.prop(camera.data, "lens", text="Focal Length")


class WEATHERVANE_PT_render(WeathervanePanel, bpy.types.Panel):
    bl_label = "Render"
    bl_parent_id = "WEATHERVANE_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        settings = context.scene.weathervane
        layout.prop(settings, "depth")
        layout.label(text="Highlights")
        draw_highlights(layout, settings, text="")
        layout.label(text="Background")
        if build.has_vane():
            draw_background(layout, settings, text="")
        else:  # a scene without the vane renders its World (World Properties), as Cycles does
            layout.label(text="The World's (World tab)", icon="WORLD")
        layout.label(text="Samples per Pixel")
        layout.prop(settings, "samples", text="")
        draw_processes(layout, settings, expand=True)


CLASSES = (
    WEATHERVANE_PT_main,
    WEATHERVANE_PT_wind,
    WEATHERVANE_PT_vane,
    WEATHERVANE_PT_timing,
    WEATHERVANE_UL_materials,
    WEATHERVANE_PT_materials,
    WEATHERVANE_UL_lights,
    WEATHERVANE_PT_lights,
    WEATHERVANE_PT_camera,
    WEATHERVANE_PT_render,
)


register, unregister = bpy.utils.register_classes_factory(CLASSES)
