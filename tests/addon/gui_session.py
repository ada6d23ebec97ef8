"""A real Blender window (run under Xvfb by tests/test_blender_gui.py): install and enable the add-on, open the
sidebar on the Weathervane tab, build the vane, take a screenshot, quit.

    blender --factory-startup --python tests/addon/gui_session.py -- ADDON_ZIP SCREENSHOT.png

Blender 3.4 has no API to choose a sidebar tab (Region.active_panel_category came later); the sidebar opens on
its first category. The built-in panels of "Item" are written in C and registered first, but they only show with
an active object, and the Python ones can be registered again after the add-on's; so, as a user would before
looking at the vane, the session deletes the startup cube and leaves no object active.
"""

import sys

import bpy

ADDON_ZIP, SCREENSHOT = sys.argv[sys.argv.index("--") + 1 :][:2]


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    return window, area, region


def bring_tab_forward() -> None:
    panels = {cls.__name__: cls for cls in bpy.types.Panel.__subclasses__() if cls.is_registered}

    def depth(cls) -> int:
        parent = panels.get(getattr(cls, "bl_parent_id", ""))
        return 0 if parent is None else 1 + depth(parent)

    def root(cls):
        parent = panels.get(getattr(cls, "bl_parent_id", ""))
        return cls if parent is None else root(parent)

    sidebar = {
        cls
        for cls in panels.values()
        if getattr(root(cls), "bl_space_type", "") == "VIEW_3D"
        and getattr(root(cls), "bl_region_type", "") == "UI"
        and getattr(root(cls), "bl_category", "") != "Weathervane"
    }
    ordered = sorted(sidebar, key=depth)
    for cls in reversed(ordered):
        bpy.utils.unregister_class(cls)
    for cls in ordered:
        bpy.utils.register_class(cls)


def prepare() -> float | None:
    try:
        setup()
    except Exception:
        import traceback

        traceback.print_exc()
        bpy.ops.wm.quit_blender()
    return None


def setup() -> None:
    assert bpy.ops.preferences.addon_install(filepath=ADDON_ZIP, overwrite=True) == {"FINISHED"}
    assert bpy.ops.preferences.addon_enable(module="weathervane") == {"FINISHED"}
    bring_tab_forward()
    cube = bpy.data.objects.get("Cube")
    if cube is not None:
        bpy.data.objects.remove(cube)
    window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.ed.undo_push(message="before the weathervane")
        # as the button calls it: the positional True asks for the operator's undo step
        assert bpy.ops.weathervane.build("EXEC_DEFAULT", True) == {"FINISHED"}
        # undo takes the whole build back, and redo brings it again
        bpy.ops.ed.undo()
        assert bpy.data.collections.get("Weathervane") is None, "undo left the weathervane"
        assert "Camera" in bpy.data.objects and "Light" in bpy.data.objects
        bpy.ops.ed.redo()
        assert len(bpy.data.collections["Weathervane"].objects) == 19, "redo did not rebuild the weathervane"
        print("WEATHERVANE-GUI undo and redo")
        window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.context.view_layer.objects.active = None
        for obj in bpy.context.view_layer.objects:
            obj.select_set(False)
        area.spaces.active.show_region_ui = True
        area.spaces.active.shading.color_type = "MATERIAL"
        bpy.ops.view3d.view_camera()
        bpy.ops.view3d.view_center_camera()
    print("WEATHERVANE-GUI built")
    bpy.app.timers.register(capture, first_interval=2.0)


class Recorder:
    """A stand-in for a panel's layout that notes each property drawn with the label text it gets."""

    def __init__(self, drawn: list) -> None:
        self.drawn = drawn
        self.active = True

    def __getattr__(self, name: str):
        if name in ("row", "column", "box", "split"):
            return lambda *args, **kwargs: Recorder(self.drawn)
        return lambda *args, **kwargs: None

    def prop(self, data, name: str, text: str | None = None, **kwargs) -> None:
        if text == "":
            return  # no label: the field holds only its value
        rna = data.bl_rna.properties[name]
        label = text if text is not None else rna.name
        if rna.type in ("FLOAT", "INT") and getattr(rna, "array_length", 0) == 0:
            self.drawn.append(label)


def measure_labels() -> None:
    """Each number field's label plus room for its value, against the sidebar's width, in Blender's UI font."""
    import blf

    _, area, _ = view3d()
    sidebar = next(r for r in area.regions if r.type == "UI")
    scale = bpy.context.preferences.system.ui_scale
    if bpy.app.version >= (4, 0, 0):
        blf.size(0, 11 * scale)
    else:
        blf.size(0, 11, int(72 * scale))
    drawn: list = []
    holder = type("Panel", (), {})()
    for cls in bpy.types.Panel.__subclasses__():
        if getattr(cls, "bl_category", "") == "Weathervane" and cls.is_registered:
            holder.layout = Recorder(drawn)
            cls.draw(holder, bpy.context)
    # a field spans the panel's width less its margins; its value needs about 8 characters ("600 ms", "200°")
    room = sidebar.width - 2 * 14 * scale - blf.dimensions(0, "0000.000")[0] - 12 * scale
    widths = {label: blf.dimensions(0, label)[0] for label in set(drawn)}
    too_wide = sorted(label for label, width in widths.items() if width > room)
    widest = max(widths, key=widths.get)
    print(
        f"WEATHERVANE-GUI sidebar {sidebar.width} px, {len(widths)} labels, widest {widest!r} {widths[widest]:.0f} of "
        f"{room:.0f} px"
    )
    print("WEATHERVANE-GUI labels fit" if not too_wide else f"WEATHERVANE-GUI labels too wide: {too_wide}")


def capture() -> float | None:
    measure_labels()
    window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=SCREENSHOT)
    print("WEATHERVANE-GUI screenshot", SCREENSHOT)
    # File > Export, opened as a click on the menu would: the add-on's entry is in it
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.wm.call_menu(name="TOPBAR_MT_file_export")
    bpy.app.timers.register(capture_menu, first_interval=1.0)
    return None


def capture_menu() -> float | None:
    window, area, region = view3d()
    target = SCREENSHOT.replace(".png", "-export-menu.png")
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=target)
    print("WEATHERVANE-GUI export menu", target)
    bpy.app.timers.register(lambda: bpy.ops.wm.quit_blender() and None, first_interval=0.5)
    return None


bpy.app.timers.register(prepare, first_interval=1.0)
