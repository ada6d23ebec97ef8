"""A real Blender window (run under Xvfb by tests/test_blender_gui.py): install and enable the add-on, open the
sidebar on the Weathervane tab, build the vane, take a screenshot; then, with the tracer as the engine, Output
Properties, F12 and the 3D View in Rendered shading; then a foreign scene added with Blender's own operators
(Suzanne with a Subdivision Surface modifier, a text, a collection instance of a cone) in F12 and in the Rendered
view; File > Export; quit.

    blender --factory-startup --python tests/addon/gui_session.py -- ADDON_ZIP SCREENSHOT.png WORK_FOLDER

Beside SCREENSHOT it writes SCREENSHOT-output.png (Output Properties with the tracer as the engine),
SCREENSHOT-rendered.png (the 3D View in Rendered shading, nothing over it), SCREENSHOT-rendered-ui.png (the same
with the interface), SCREENSHOT-foreign-f12.png (F12 of the vane with the foreign scene, 320 x 240),
SCREENSHOT-foreign-rendered.png (the Rendered view with it, laid out as SCREENSHOT-rendered.png),
SCREENSHOT-export-menu.png and SCREENSHOT-viewport-samples.png (the artist's scene finished in the Rendered view
beside Render Properties > Weathervane Tracer > Viewport); in WORK_FOLDER, f12.png (F12's image saved as PNG),
f12-scene.json (the scene exported at that moment), rendered-scene.json (the scene seen from the Rendered view, for
the test to trace), the view region's place in the window (rendered-region.json), foreign-f12-empty.png (F12 at 320
x 240 before the foreign scene) and foreign.json (each new object's bounding box projected into F12's image and into
the window).

Blender 3.4 has no API to choose a sidebar tab (Region.active_panel_category came later); the sidebar opens on
its first category. The built-in panels of "Item" are written in C and registered first, but they only show with
an active object, and the Python ones can be registered again after the add-on's; so, as a user would before
looking at the vane, the session deletes the startup cube and leaves no object active.
"""

import sys

import bpy

ADDON_ZIP, SCREENSHOT, WORK = sys.argv[sys.argv.index("--") + 1 :][:3]
RENDERED_WAIT_SECONDS = 120.0


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    return window, area, region


def tracing_quiet(timeout: float = 60.0) -> None:
    """Block until no Rendered view's tracing thread runs (each waits for its next scene). Before an operator called
    under a context override: Blender (3.4-5.0, Python 3.11) looks the override's members up without taking the GIL
    when another thread holds it (PyC_IsInterpreterActive reads the interpreter's current thread state, which is the
    other thread's), and crashed so twice in 5 window benchmarks while a view traced."""
    import time

    viewport = sys.modules.get("weathervane.engine.viewport")
    started = time.perf_counter()
    while viewport is not None and any(session.progressive.busy for session in list(viewport._sessions)):
        assert time.perf_counter() - started < timeout, "the Rendered view kept tracing"
        time.sleep(0.02)


def screenshot(suffix: str = "") -> str:
    """The whole window as SCREENSHOT with suffix before its extension; returns the path."""
    window, area, region = view3d()
    target = SCREENSHOT.replace(".png", f"{suffix}.png")
    tracing_quiet()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=target)
    return target


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
        assert bpy.ops.preferences.addon_install(filepath=ADDON_ZIP, overwrite=True) == {"FINISHED"}
        assert bpy.ops.preferences.addon_enable(module="weathervane") == {"FINISHED"}
        open_every_panel()
        bring_tab_forward()  # after: the other tabs' panels registered last, the Weathervane tab first
    except Exception:
        import traceback

        traceback.print_exc()
        bpy.ops.wm.quit_blender()
        return None
    return run_steps([f12_factory_cube(), conversion_notes()], setup)


def setup() -> None:
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
        # the tracer as the scene's engine, Render Properties open: its own panels draw in the real window
        bpy.context.scene.render.engine = "WEATHERVANE_TRACER"
        for properties in (a for a in window.screen.areas if a.type == "PROPERTIES"):
            properties.spaces.active.context = "RENDER"
        bpy.ops.view3d.view_camera()
        bpy.ops.view3d.view_center_camera()
    print("WEATHERVANE-GUI built")
    bpy.app.timers.register(capture, first_interval=2.0)


def open_every_panel() -> None:
    """The add-on's panels registered again without DEFAULT_CLOSED, before they are first drawn: the window shows
    every panel and sub-panel open (Blender 3.4 has no API to open a panel)."""
    for cls in reversed(PANELS()):
        bpy.utils.unregister_class(cls)
    for cls in PANELS():
        cls.bl_options = set(getattr(cls, "bl_options", set())) - {"DEFAULT_CLOSED"}
        bpy.utils.register_class(cls)


def PANELS() -> list:  # noqa: N802 - read like a constant
    """The add-on's panels: the sidebar's, and its own in the Properties editor (Scene Conversion opens too)."""
    classes = sys.modules["weathervane.vane.panels"].CLASSES + sys.modules["weathervane.engine.render_panels"].CLASSES
    return [cls for cls in classes if issubclass(cls, bpy.types.Panel)]


def measure_labels() -> None:
    """Every text of every panel in every state against its room (tests/addon/gui_measure.py), at the sidebar's
    and the Properties editor's widths as the window has them; and every tooltip one whole line."""
    import os

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import gui_measure

    window, area, _ = view3d()
    sidebar = next(r for r in area.regions if r.type == "UI")
    editor = next(a for a in window.screen.areas if a.type == "PROPERTIES")
    properties = next(r for r in editor.regions if r.type == "WINDOW")
    panels = sys.modules["weathervane.vane.panels"]
    found, tips = gui_measure.measure(bpy.context, panels.sidebar_width(sidebar), properties.width)
    too_wide = sorted((text, where, share) for text, (share, where) in found.items() if share > 1.0)
    widest = max(found, key=lambda text: found[text][0])
    print(
        f"WEATHERVANE-GUI sidebar {sidebar.width} px, Properties {properties.width} px: {len(found)} texts, the "
        f"widest {widest!r} ({found[widest][1]}) needs {100 * found[widest][0]:.0f}% of its room"
    )
    print("WEATHERVANE-GUI labels fit" if not too_wide else f"WEATHERVANE-GUI labels too wide: {too_wide}")
    print("WEATHERVANE-GUI tooltips one line" if not tips else f"WEATHERVANE-GUI tooltips cut: {tips}")


def screenshot_sidebar() -> None:
    """The sidebar with every panel open, scrolled a page at a time: SCREENSHOT-sidebar-N.png."""
    window, area, _ = view3d()
    sidebar = next(r for r in area.regions if r.type == "UI")
    for page in range(3):
        if page:
            with bpy.context.temp_override(window=window, area=area, region=sidebar):
                bpy.ops.view2d.scroll_down(page=True)
            sidebar.tag_redraw()
            bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
        screenshot(f"-sidebar-{page + 1}")
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        for _ in range(3):
            bpy.ops.view2d.scroll_up(page=True)
    bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)


def capture() -> float | None:
    measure_labels()
    screenshot_sidebar()
    screenshot()
    print("WEATHERVANE-GUI screenshot", SCREENSHOT)
    return guarded(reset_in_camera_view)


def result_line() -> str:
    """The add-on's last result line as the sidebar shows it (kind: text)."""
    line, kind = sys.modules["weathervane.vane.operators"].result_line()
    return f"{kind}: {line}"


def reset_in_camera_view() -> float | None:
    """Reset (as its dialog's OK runs it) while the 3D View looks through the camera: the view stays the camera
    view once Blender has redrawn, and the sidebar shows Reset's result line."""
    window, area, region = view3d()
    assert area.spaces.active.region_3d.view_perspective == "CAMERA"
    print("WEATHERVANE-GUI result line after Build:", result_line())
    assert result_line().startswith(("INFO: Built", "WARNING: Built")), result_line()
    tracing_quiet()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.weathervane.reset("EXEC_DEFAULT", True) == {"FINISHED"}
    return guarded(check_reset_kept_camera_view)


def check_reset_kept_camera_view() -> float | None:
    _, area, _ = view3d()
    perspective = area.spaces.active.region_3d.view_perspective
    assert perspective == "CAMERA", f"Reset left the camera view for {perspective}"
    assert result_line().startswith(("INFO: Built", "WARNING: Built")), result_line()
    screenshot("-after-reset")
    print("WEATHERVANE-GUI reset kept the camera view; result line:", result_line())
    return guarded(show_output_properties)


def guarded(step) -> float | None:
    """Run the next step from a timer; an exception is printed and ends the session (the test then fails)."""

    def run() -> float | None:
        try:
            return step()
        except Exception:
            import traceback

            traceback.print_exc()
            bpy.ops.wm.quit_blender()
            return None

    bpy.app.timers.register(run, first_interval=0.5)
    return None


def show_output_properties() -> float | None:
    """Output Properties with the tracer as the engine: Blender's own Format, Frame Range and Output panels."""
    window, _, _ = view3d()
    shown = []
    for name in ("RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output", "RENDER_PT_color_management"):
        panel = getattr(bpy.types, name)
        assert "WEATHERVANE_TRACER" in panel.COMPAT_ENGINES, name
        assert panel.poll(bpy.context), name
        shown.append(name)
    print("WEATHERVANE-GUI output panels", " ".join(shown))
    for properties in (a for a in window.screen.areas if a.type == "PROPERTIES"):
        properties.spaces.active.context = "OUTPUT"
    return guarded(capture_output_properties)


def capture_output_properties() -> float | None:
    screenshot("-output")
    print("WEATHERVANE-GUI output screenshot")
    return guarded(lambda: show_shading_tab(0))


# Blender's own panels that the tracer shows as Cycles does, per Properties tab: (tab, what is active, panels)
SHADING_TABS = (
    ("MATERIAL", "part", ("CYCLES_PT_context_material", "CYCLES_MATERIAL_PT_surface", "MATERIAL_PT_viewport")),
    ("DATA", "light", ("DATA_PT_context_light", "CYCLES_LIGHT_PT_light")),
    ("WORLD", "part", ("WORLD_PT_context_world", "CYCLES_WORLD_PT_surface")),
    ("DATA", "part", ("DATA_PT_context_mesh", "DATA_PT_uv_texture", "DATA_PT_shape_keys")),
)


def show_shading_tab(index: int) -> float | None:
    """Material, Light, World and Object Data Properties with the tracer as the engine: Blender's own panels poll
    True there (the slot list, Surface, the light's colour and power, the world's Surface, UV maps, shape keys)."""
    if index >= len(SHADING_TABS):
        return guarded(render_f12)
    tab, active, names = SHADING_TABS[index]
    settings = bpy.context.scene.weathervane
    if active == "light":
        obj = bpy.data.objects[next(entry.object_name for entry in settings.lights if entry.object_name)]
    else:
        obj = next(o for o in bpy.data.collections["Weathervane"].objects if o.type == "MESH")
    bpy.context.view_layer.objects.active = obj
    members = {"object": obj, "material": obj.active_material, "world": bpy.context.scene.world}
    members[obj.type.lower()] = obj.data  # context.light or context.mesh
    obj.select_set(True)
    with bpy.context.temp_override(**{key: value for key, value in members.items() if value is not None}):
        for name in names:
            assert getattr(bpy.types, name).poll(bpy.context), name
    print(f"WEATHERVANE-GUI shading panels {tab.lower()} {active}", " ".join(names))
    return guarded(lambda: open_shading_tab(index))


def open_shading_tab(index: int) -> float | None:
    """The tab, once the editor has redrawn with the active object (its tabs follow the object)."""
    window, _, _ = view3d()
    for properties in (a for a in window.screen.areas if a.type == "PROPERTIES"):
        properties.spaces.active.context = SHADING_TABS[index][0]
    return guarded(lambda: capture_shading_tab(index))


def capture_shading_tab(index: int) -> float | None:
    tab, active, _ = SHADING_TABS[index]
    screenshot(f"-{tab.lower()}-{active}")
    if active == "light":
        change_the_light_type_in_its_tab()
    bpy.context.view_layer.objects.active.select_set(False)
    bpy.context.view_layer.objects.active = None
    return guarded(lambda: show_shading_tab(index + 1))


def change_the_light_type_in_its_tab() -> None:
    """The Light tab's Type set to Spot on a light of the add-on's Lights panel: Export writes a spot light and the
    sidebar shows 'Spot'; then back to the type it had, so the steps after see the scene as built."""
    import json
    import os

    entry_kind = sys.modules["weathervane.convert.export"].entry_kind  # what the sidebar's Lights panel draws
    light = bpy.context.view_layer.objects.active
    entry = next(entry for entry in bpy.context.scene.weathervane.lights if entry.object_name == light.name)
    before = light.data.type
    light.data.type = "SPOT"
    target = os.path.join(WORK, "light-type.json")
    assert bpy.ops.weathervane.export(filepath=target) == {"FINISHED"}
    with open(target, encoding="utf-8") as file:
        kinds = [document["type"] for document in json.load(file)["lights"]]
    assert "spot" in kinds and entry_kind(entry) == "SPOT", (kinds, entry_kind(entry))
    light.data.type = before
    print(f"WEATHERVANE-GUI light type changed in the Light tab: exported {kinds}, sidebar Spot")


def render_f12() -> float | None:
    """F12 as the window runs it, its image saved as PNG through the scene's colour management, and the scene
    exported for the test to render with the command line."""
    import os

    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.image_settings.file_format, scene.render.image_settings.color_depth = "PNG", "8"
    scene.render.filepath = os.path.join(WORK, "f12.png")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert bpy.ops.weathervane.export(filepath=os.path.join(WORK, "f12-scene.json")) == {"FINISHED"}
    import json

    with open(os.path.join(WORK, "f12-scene.json"), encoding="utf-8") as file:
        comment = json.load(file).get("comment")  # what the export approximated: in its result line too, as a warning
    line = result_line()
    assert line.startswith("WARNING: Wrote" if comment else "INFO: Wrote") and line.endswith(comment or ""), line
    print("WEATHERVANE-GUI f12 rendered; result line after Export:", result_line())
    return guarded(show_rendered)


def show_rendered(then=None) -> float | None:
    """The 3D View in Rendered shading, nothing drawn over it (overlays, gizmos, headers, sidebar, toolbar, the
    camera view's darkened margin); then the next step (capture_rendered)."""

    _, area, _ = view3d()
    space = area.spaces.active
    space.show_region_ui = space.show_region_toolbar = False
    space.show_region_header = space.show_region_tool_header = False
    space.overlay.show_overlays = False
    space.show_gizmo = False
    bpy.context.scene.camera.data.show_passepartout = False
    space.shading.type = "RENDERED"
    return full_image_then(then or capture_rendered)


def full_image_then(step, idle: bool = True) -> float | None:
    """Wait until the Rendered view shows its full image at the view's size, then run step. With idle, also until
    its thread has kept the image's ray trees for edits (the status line then says done), which takes longer than
    the image on a scene of many triangles."""
    import time

    started = time.perf_counter()

    def wait() -> float | None:
        _, area, region = view3d()
        sessions = list(sys.modules["weathervane.engine.viewport"]._sessions)
        level = sessions[0].progressive.latest() if sessions else None
        if (
            level is None
            or not level.final
            or level.image.shape[:2] != (region.height, region.width)
            or (idle and sessions[0].progressive.busy)
        ):
            assert time.perf_counter() - started < RENDERED_WAIT_SECONDS, "the Rendered view did not finish"
            return 0.5
        busy = sessions[0].progressive.busy
        print(
            f"WEATHERVANE-GUI rendered view {region.width}x{region.height} traced in {level.seconds:.2f} s "
            f"({'keeping its ray trees' if busy else 'idle'} {time.perf_counter() - started:.1f} s into the wait)"
        )
        area.tag_redraw()  # drawn with that image before the next step
        return guarded(step)

    return guarded(wait)


def capture_rendered() -> float | None:
    import json
    import os

    window, area, region = view3d()
    viewport = sys.modules["weathervane.engine.viewport"]
    (session,) = list(viewport._sessions)
    view = area.spaces.active.region_3d
    document = dict(session.document)  # its arrays as NumPy's: written as lists, a World's picture as a .npy file
    world_convert = sys.modules["weathervane.convert.world_convert"]
    document["background"] = world_convert.background_for_json(document["background"])
    document["camera"] = viewport.view_camera(view.view_matrix, view.window_matrix, region.width, region.height)
    document["render"] = {**document["render"], "width": region.width, "height": region.height}
    with open(os.path.join(WORK, "rendered-scene.json"), "w") as file:
        json.dump(document, file, default=lambda value: value.tolist())
    place = {"x": region.x, "y": region.y, "width": region.width, "height": region.height, "window": window.height}
    # the last operator's panel (Reset's "Adjust Last Operation") drawn over the view's corner, in window pixels
    # (hiding it with show_region_hud crashes Blender 3.4.1 when the view then goes Rendered)
    huds = [r for r in area.regions if r.type == "HUD" and r.width > 1 and r.height > 1]
    place["hud"] = [[r.x, r.y, r.width, r.height] for r in huds]
    with open(os.path.join(WORK, "rendered-region.json"), "w") as file:
        json.dump(place, file)
    screenshot("-rendered")
    print("WEATHERVANE-GUI rendered screenshot")
    # as an artist sees it: headers, overlays and the engine's status text back on (the image is not traced again)
    space = area.spaces.active
    space.show_region_header = space.show_region_tool_header = True
    space.overlay.show_overlays = space.show_gizmo = True
    area.tag_redraw()  # the headers take room: a new view size, traced again
    return full_image_then(capture_rendered_with_the_interface)


def capture_rendered_with_the_interface() -> float | None:
    screenshot("-rendered-ui")
    (session,) = list(sys.modules["weathervane.engine.viewport"]._sessions)
    print("WEATHERVANE-GUI rendered screenshot with the interface, status:", session.status)
    assert session.status.startswith("Weathervane Tracer: done in"), session.status
    return guarded(edit_in_rendered_view)


def edit_in_rendered_view() -> float | None:
    """A small edit (the tail fin's colour, as the Materials panel sets it) in the Rendered view: every status line
    drawn from then on is the new scene's ("updating", then the edit's or a level's), never the previous scene's
    "done" or a stale "1/1 resolution"; the time to the edited image is recorded (not asserted)."""
    import time

    (session,) = list(sys.modules["weathervane.engine.viewport"]._sessions)
    before, generation = session.status, session.progressive.generation
    materials = {entry.name: entry for entry in bpy.context.scene.weathervane.materials}
    materials["verdigris"].color = (0.9, 0.2, 0.1)
    started, seen = time.perf_counter(), []

    def poll() -> float | None:
        if session.progressive.generation > generation and (not seen or seen[-1] != session.status):
            seen.append(session.status)
        if seen and session.progressive.done and not session.status.startswith("Weathervane Tracer: updating"):
            print(
                f"WEATHERVANE-GUI small edit in the Rendered view: {time.perf_counter() - started:.2f} s to "
                f"{session.status!r}; statuses drawn: {seen}"
            )
            assert before not in seen and not any("1/1 resolution" in status for status in seen), seen
            return measure_latencies()  # then Solid shading
        assert time.perf_counter() - started < RENDERED_WAIT_SECONDS, f"the edit was not drawn: {seen}"
        return 0.02

    return guarded(poll)


def when_the_rendered_view_stopped(then):
    """A step polling until the Rendered view's tracing thread has ended (after Solid shading), then `then`."""
    import threading

    waited = [0]

    def poll() -> float | None:
        if any(thread.name == "weathervane-progressive" for thread in threading.enumerate()):
            waited[0] += 1
            assert waited[0] < 40, "the Rendered view's tracing thread outlived the view's Rendered shading"
            return 0.25
        return then()

    return poll


def rendered_view_stopped() -> float | None:
    print("WEATHERVANE-GUI rendered view stopped with Solid shading")
    return guarded(refuse_a_scene_too_large)  # then render_empty_f12


def open_export_menu() -> float | None:
    window, area, region = view3d()
    # File > Export, opened as a click on the menu would: the add-on's entry is in it (last: the menu stays open)
    tracing_quiet()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.wm.call_menu(name="TOPBAR_MT_file_export")
    bpy.app.timers.register(capture_menu, first_interval=1.0)
    return None


def capture_menu() -> float | None:
    target = screenshot("-export-menu")
    print("WEATHERVANE-GUI export menu", target)
    return guarded(refusal_in_the_render_window)  # then f12_then_quit


def text_pixels(text: str) -> float:
    """text's width in pixels in Blender's interface font at the window's scale (as tests/addon/gui_measure.py)."""
    import blf

    blf.size(0, 11 * (bpy.context.preferences.system.ui_scale or 1.0))  # pixels (3.4 deprecates its DPI argument)
    return blf.dimensions(0, text)[0]


def save_png(rgb, path: str) -> None:
    """An (height, width, 3) uint8 image, rows from the top, written as PNG with Blender's own image API."""
    import numpy as np

    height, width = rgb.shape[:2]
    image = bpy.data.images.new("weathervane screen", width, height)
    try:
        rgba = np.ones((height, width, 4), dtype=np.float32)
        rgba[..., :3] = rgb[::-1] / 255.0  # Blender's rows start at the bottom
        image.pixels.foreach_set(rgba.ravel())
        image.filepath_raw, image.file_format = path, "PNG"
        image.save()
    finally:
        bpy.data.images.remove(image)


def refusal_in_the_render_window() -> float | None:
    """F12 as the key starts it, at Blender's default 1920x1080, of a scene too large for the free memory (the level-7
    cube and FAKE_FREE_MEMORY of refuse_a_scene_too_large), in the render window Blender opens: its image region shows
    the whole refusal over the empty image, in lines that each fit the region as Blender's font measures them and
    that are on screen (their pixels read from the X server, saved as SCREENSHOT-render-window.png); the Info editor
    holds the whole refusal and, last (what the status bar shows), the short line, which fits the bar. Then the memory
    and the scene as they were; the render window stays open for the F12 that follows (f12_then_quit)."""
    import re
    import time

    resources = sys.modules["weathervane.tracer_api"]
    messages = sys.modules["weathervane.engine.messages"]
    real = resources.available_memory
    resources.available_memory = lambda: FAKE_FREE_MEMORY
    scene = bpy.context.scene
    saved = (scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 1920, 1080, 100
    window, area, region = view3d()
    tracing_quiet()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, -3.0)) == {"FINISHED"}
        cube = bpy.context.active_object
        modifier = cube.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels, modifier.render_levels = 1, 7
        # Blender opens the render window around the pointer: at the window's middle, it covers the screen
        window.event_simulate("MOUSEMOVE", "NOTHING", x=window.width // 2, y=window.height // 2)
        assert bpy.ops.render.render("INVOKE_DEFAULT") == {"RUNNING_MODAL"}
    started = time.perf_counter()

    def shown() -> float | None:
        windows = list(bpy.context.window_manager.windows)
        if bpy.app.is_job_running("RENDER") or len(windows) < 2 or not messages.DRAWN:
            assert time.perf_counter() - started < 30.0, "the render window showed no refusal"
            return 0.1
        if "drawn" not in state:  # the window's first frames read back black here: a look later, as a user's
            state["drawn"] = time.perf_counter() - started
            return 0.5
        render_window = next(w for w in windows if w != window)
        image_area = next(a for a in render_window.screen.areas if a.type == "IMAGE_EDITOR")
        image_region = next(r for r in image_area.regions if r.type == "WINDOW")
        text, drawn = messages.render_window_text(), dict(messages.DRAWN)
        scale = bpy.context.preferences.system.ui_scale or 1.0
        room = image_region.width - (messages.MARGIN + messages.GIZMOS) * scale
        widths = [text_pixels(line) for line in drawn["lines"]]
        squeeze = lambda line: re.sub(r"\s+", "", line)  # noqa: E731
        assert text.startswith("Weathervane Tracer: not started: a 1920x1080 "), text
        assert drawn["region"] == (image_region.x, image_region.y, image_region.width, image_region.height), drawn
        whole = squeeze("".join(drawn["lines"])) == squeeze(text)
        # on screen: what the X server shows (a new window's own buffer reads back black here), the white text's
        # pixels inside each line's box; the render window opens over the whole screen, as a 1920x1080 render's does
        import numpy as np

        assert (render_window.width, render_window.height) == (window.width, window.height), render_window.width
        assert abs(render_window.x) <= 2 and abs(render_window.y) <= 2, (render_window.x, render_window.y)
        xscreen = XScreen()
        try:
            shown = xscreen.grab((0, 0, render_window.width, render_window.height))
        finally:
            xscreen.close()
        save_png(shown, SCREENSHOT.replace(".png", "-render-window.png"))
        lit = []
        for x, y, width, height in drawn["boxes"]:  # region pixels from the bottom; the screen's rows from the top
            left, top = int(image_region.x + x), render_window.height - int(image_region.y + y + height)
            box = shown[top : top + int(height) + 1, left : left + int(width) + 1]
            lit.append(int((box.min(axis=2) > 200).sum()))
        print(
            f"WEATHERVANE-GUI refusal in the render window {state['drawn']:.2f} s after F12, "
            f"{image_region.width}x{image_region.height}: {len(drawn['lines'])} lines, "
            f"{'the whole refusal' if whole else 'NOT the whole refusal'}, the widest {max(widths):.0f} px of "
            f"{room:.0f} px, white pixels per line {lit}"
        )
        assert whole and max(widths) <= room and min(lit) >= 20, (drawn, widths, lit, np.shape(shown))
        state.update(text=text)
        return None

    def in_info() -> None:
        """The Info editor's reports (the timeline's area made an Info editor a moment), copied as its Copy does."""
        text = state["text"]
        timeline = next(a for a in window.screen.areas if a.type == "DOPESHEET_EDITOR")
        ui_type = timeline.ui_type
        timeline.type = "INFO"
        info_region = next(r for r in timeline.regions if r.type == "WINDOW")
        with bpy.context.temp_override(window=window, area=timeline, region=info_region):
            bpy.ops.info.select_all(action="SELECT")
            bpy.ops.info.report_copy()
        timeline.type = "DOPESHEET_EDITOR"
        timeline.ui_type = ui_type
        copied = bpy.context.window_manager.clipboard.splitlines()
        short = messages.headline(text)
        bar = text_pixels(short)
        print(
            f"WEATHERVANE-GUI refusal in the Info editor: {'whole' if text in copied else 'NOT whole'}; the last "
            f"report (the status bar's) {'is the short line' if copied[-1] == short else repr(copied[-1])}, "
            f"{bar:.0f} px of the window's {window.width}: {short}"
        )
        assert text in copied and copied[-1] == short and bar <= window.width / 2, copied[-4:]
        resources.available_memory = real
        mesh = cube.data
        bpy.data.objects.remove(cube)
        bpy.data.meshes.remove(mesh)
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = saved
        print(f"WEATHERVANE-GUI render window and Info steps took {time.perf_counter() - started:.1f} s")

    state: dict = {}
    return run_steps([shown, in_info], f12_then_quit)


# F12's size and samples when Blender is quit during it: several seconds of tracing here (at 1280x720 and 1 sample,
# F12 in 3.4.1 takes about a second since bands are written once, and could end before the first look)
QUIT_DURING_F12 = (1920, 1080)
QUIT_DURING_F12_SAMPLES = "4"


def f12_then_quit() -> float | None:
    """F12 as the key starts it (a render job beside the window), and Blender quit while it traces: the test then
    checks that Blender's log has no leaked memory blocks and that no worker process outlives Blender."""
    import time

    window, area, region = view3d()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = QUIT_DURING_F12
    scene.weathervane.samples = QUIT_DURING_F12_SAMPLES
    scene.render.use_lock_interface = False
    tracing_quiet()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.render.render("INVOKE_DEFAULT") == {"RUNNING_MODAL"}
    started = time.perf_counter()

    def quit_while_tracing() -> float | None:
        if not bpy.app.is_job_running("RENDER"):
            assert time.perf_counter() - started < 30, "F12 did not start"
            return 0.02
        print(f"WEATHERVANE-GUI quitting during F12, {time.perf_counter() - started:.1f} s after it started")
        sys.stdout.flush()
        bpy.ops.wm.quit_blender()
        return None

    bpy.app.timers.register(quit_while_tracing, first_interval=0.05)
    return None


FOREIGN_F12 = (320, 240)  # F12's size for the foreign scene: each new object spans dozens of pixels


def foreign_f12(target: str) -> None:
    import os

    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = FOREIGN_F12
    scene.render.filepath = target
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    assert os.path.exists(target), target


def render_empty_f12() -> float | None:
    """F12 of the vane alone at the foreign scene's size: what the new objects' pixels are compared with."""
    import os
    import time

    FOREIGN_START[0] = time.perf_counter()
    foreign_f12(os.path.join(WORK, "foreign-f12-empty.png"))
    print(f"WEATHERVANE-GUI foreign f12 without the new objects in {time.perf_counter() - FOREIGN_START[0]:.2f} s")
    return guarded(material_tab_colour_in_f12)  # then add_foreign_scene


def add_foreign_scene() -> float | None:
    """Objects that Build did not make, added as a user would with Add menus and the Properties editor: Suzanne
    with a Subdivision Surface modifier (flat shaded), a text object and an instance of a collection that holds a
    cone (the collection itself excluded from the view layer, as an asset collection is), each placed where the
    camera sees it beside the vane."""
    import math
    import time

    from mathutils import Vector

    window, area, region = view3d()
    camera = bpy.context.scene.camera
    heading = camera.matrix_world.to_euler()[2]  # turned to face the camera

    def seen_at(right: float, up: float, distance: float) -> Vector:
        return camera.matrix_world @ Vector((right, up, -distance))

    with bpy.context.temp_override(window=window, area=area, region=region):
        # Add > Mesh > Monkey, then Add Modifier > Subdivision Surface (viewport level 1, render level 2)
        assert bpy.ops.mesh.primitive_monkey_add(
            size=1.0, location=seen_at(-1.55, 0.75, 7.5), rotation=(0, 0, heading)
        ) == {"FINISHED"}
        assert bpy.ops.object.modifier_add(type="SUBSURF") == {"FINISHED"}
        suzanne = bpy.context.active_object
        # Add > Text, typed over in Edit Mode
        rotation = (math.radians(90.0), 0.0, heading)
        assert bpy.ops.object.text_add(location=seen_at(1.2, 1.0, 7.5), rotation=rotation) == {"FINISHED"}
        text = bpy.context.active_object
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.font.delete(type="PREVIOUS_WORD")
        bpy.ops.font.text_insert(text="Vane")
        bpy.ops.object.mode_set(mode="OBJECT")
        # Add > Mesh > Cone, M > New Collection, the collection unchecked in the Outliner, Add > Collection Instance
        assert bpy.ops.mesh.primitive_cone_add(radius1=0.5, depth=1.2, location=(0.0, 0.0, 0.6)) == {"FINISHED"}
        assert bpy.ops.object.move_to_collection(collection_index=0, is_new=True, new_collection_name="Cones") == {
            "FINISHED"
        }
        bpy.context.view_layer.layer_collection.children["Cones"].exclude = True
        ground = seen_at(-1.3, -0.9, 8.0)
        assert bpy.ops.object.collection_instance_add(collection="Cones", location=(ground.x, ground.y, 0.0)) == {
            "FINISHED"
        }
        instance = bpy.context.active_object
    assert text.data.body == "Vane", text.data.body
    assert not any(face.use_smooth for face in suzanne.data.polygons)
    FOREIGN[:] = [suzanne.name, text.name, instance.name]
    print("WEATHERVANE-GUI foreign scene added", *FOREIGN, f"at {time.perf_counter() - FOREIGN_START[0]:.1f} s")
    return guarded(render_foreign_f12)


FOREIGN: list = []  # the new objects' names
FOREIGN_START = [0.0]  # when the foreign scene's steps began


def projected_boxes(project) -> dict:
    """Each new object's bounding box as Blender evaluates it (a text's mesh, the cone at the instance's matrix),
    its 8 corners projected by project(world point) -> (x, y) pixels, as [left, top, right, bottom]."""
    from mathutils import Vector

    boxes: dict = {}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for instance in depsgraph.object_instances:
        obj = instance.object
        owner = instance.parent.original if instance.is_instance and instance.parent is not None else obj.original
        if owner.name not in FOREIGN or obj.type != "MESH":
            continue
        # the evaluated mesh's own vertices, read while the iteration holds them: Blender 3.4 leaks a block when a
        # text's mesh instance (a temporary object) is asked for its bound_box, and asking the original's evaluated
        # copy instead crashed Blender here in 2 of 6 sessions (0 of 4 reading the vertices)
        coordinates = [0.0] * (3 * len(obj.data.vertices))
        obj.data.vertices.foreach_get("co", coordinates)
        matrix = instance.matrix_world.copy()
        corners = [coordinates[k : k + 3] for k in range(0, len(coordinates), 3)]
        points = [project(matrix @ Vector(corner)) for corner in corners]
        xs, ys = [p[0] for p in points], [p[1] for p in points]
        box = boxes.setdefault(owner.name, [min(xs), min(ys), max(xs), max(ys)])
        box[:] = [min(box[0], *xs), min(box[1], *ys), max(box[2], *xs), max(box[3], *ys)]
    assert sorted(boxes) == sorted(FOREIGN), boxes
    return boxes


def write_foreign(key: str, value: dict) -> None:
    """WORK/foreign.json: the new objects' projected boxes in F12's image and in the window, for the test."""
    import json
    import os

    PLACES[key] = value
    with open(os.path.join(WORK, "foreign.json"), "w") as file:
        json.dump(PLACES, file)


PLACES: dict = {}


def render_foreign_f12() -> float | None:
    """F12 of the vane with the new objects, and where Blender's camera projection puts each of them."""
    import time

    from bpy_extras.object_utils import world_to_camera_view

    scene = bpy.context.scene
    width, height = FOREIGN_F12

    def project(point):
        x, y, _ = world_to_camera_view(scene, scene.camera, point)
        return x * width, (1.0 - y) * height  # pixels from the image's top left

    started = time.perf_counter()
    foreign_f12(SCREENSHOT.replace(".png", "-foreign-f12.png"))
    print(
        f"WEATHERVANE-GUI foreign f12 rendered in {time.perf_counter() - started:.2f} s, "
        f"at {time.perf_counter() - FOREIGN_START[0]:.1f} s"
    )
    write_foreign("f12", {"size": list(FOREIGN_F12), "boxes": projected_boxes(project)})
    return guarded(show_foreign_rendered)


def show_foreign_rendered() -> float | None:
    """The 3D View in Rendered shading again, laid out as for the first Rendered screenshot (nothing over it)."""
    return show_rendered(then=capture_foreign_rendered)


def capture_foreign_rendered() -> float | None:
    import time

    from bpy_extras.view3d_utils import location_3d_to_region_2d

    window, area, region = view3d()
    view = area.spaces.active.region_3d

    def project(point):
        x, y = location_3d_to_region_2d(region, view, point)
        return region.x + x, window.height - (region.y + y)  # window pixels from the top left

    place = {"x": region.x, "y": region.y, "width": region.width, "height": region.height, "window": window.height}
    write_foreign("view", {"region": place, "boxes": projected_boxes(project)})
    target = screenshot("-foreign-rendered")
    print(
        f"WEATHERVANE-GUI foreign rendered screenshot {target} ({time.perf_counter() - FOREIGN_START[0]:.1f} s in all)"
    )
    # back to the interface and Solid shading, the view's tracing stopped, as before the foreign scene
    space = area.spaces.active
    space.show_region_header = space.show_region_tool_header = True
    space.overlay.show_overlays = space.show_gizmo = True
    space.shading.type = "SOLID"
    area.tag_redraw()
    return guarded(when_the_rendered_view_stopped(lambda: guarded(open_export_menu)))


# --- what the user sees: latencies read from the X screen ------------------------------------------------------------


class XScreen:
    """The X server's root window read with Xlib's XGetImage (what Xvfb shows: Blender's window after its swap), on a
    display connection of its own (one per thread). A 1600x900 read takes 7 ms, a box of a few hundred pixels 0.3 ms."""

    def __init__(self) -> None:
        import ctypes

        fields = "width height xoffset format data byte_order bitmap_unit bitmap_bit_order bitmap_pad depth"
        fields += " bytes_per_line bits_per_pixel"  # XImage's fields up to the ones read here

        class XImage(ctypes.Structure):
            _fields_ = [(name, ctypes.c_void_p if name == "data" else ctypes.c_int) for name in fields.split(" ")]

        x11 = ctypes.CDLL("libX11.so.6")
        x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
        x11.XDefaultRootWindow.restype, x11.XDefaultRootWindow.argtypes = ctypes.c_ulong, [ctypes.c_void_p]
        x11.XGetImage.restype = ctypes.POINTER(XImage)
        x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong] + [ctypes.c_int] * 2 + [ctypes.c_uint] * 2
        x11.XGetImage.argtypes += [ctypes.c_ulong, ctypes.c_int]
        x11.XDestroyImage.argtypes = [ctypes.POINTER(XImage)]
        x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
        self.ctypes, self.x11 = ctypes, x11
        self.display = x11.XOpenDisplay(None)
        assert self.display, "no X display"
        self.root = x11.XDefaultRootWindow(self.display)

    def grab(self, box):
        """box: (left, top, width, height) in screen pixels from the top left -> (height, width, 3) uint8 RGB."""
        import numpy as np

        left, top, width, height = box
        image = self.x11.XGetImage(self.display, self.root, left, top, width, height, 0xFFFFFFFF, 2)  # ZPixmap
        assert image, box
        try:
            found = image.contents
            assert found.bits_per_pixel == 32, found.bits_per_pixel
            raw = self.ctypes.string_at(found.data, found.bytes_per_line * found.height)
            pixels = np.frombuffer(raw, np.uint8).reshape(found.height, found.bytes_per_line // 4, 4)
            return pixels[:, :width, 2::-1]  # BGRX -> RGB
        finally:
            self.x11.XDestroyImage(image)

    def close(self) -> None:
        self.x11.XCloseDisplay(self.display)


class Watch:
    """A thread reading a box of the screen every INTERVAL seconds from before a change: for each read, the seconds
    since started, the share of the box's pixels that differ from the read before the change, and a checksum."""

    # Between reads of a box of an object; a whole view's every 0.03 s (its read takes 0.01 s). The reads take CPU from
    # the view they watch: a glass sphere's move was finished on screen 2.25 s after it unwatched, 2.47-2.51 s read
    # every 0.01 s and 2.78 s every 0.005 s (two boxes, the sphere's and the status line's, medians of 3 in a
    # 1321x759 Rendered view of Blender 3.4.1 under Xvfb)
    INTERVAL = 0.01

    def __init__(self, box, compare: bool = True) -> None:
        import threading

        self.box, self.compare = box, compare
        self.interval = self.INTERVAL if box[2] * box[3] < 100_000 else 3 * self.INTERVAL
        self.samples: list = []
        self.started = 0.0
        self._ready, self._stop = threading.Event(), threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="weathervane-gui-watch")
        self._thread.start()
        assert self._ready.wait(10.0), "the screen could not be read"

    def _run(self) -> None:
        import time
        import zlib

        import numpy as np

        screen = XScreen()
        try:
            self.reference = screen.grab(self.box).astype(np.int16)
            self._ready.set()
            while not self._stop.is_set():
                pixels = screen.grab(self.box)
                if self.box[2] * self.box[3] >= 100_000:  # a whole view: every second row and column
                    pixels = pixels[::2, ::2]
                share = 0.0
                if self.compare:
                    reference = self.reference if pixels.shape == self.reference.shape else self.reference[::2, ::2]
                    difference = np.abs(pixels.astype(np.int16) - reference)
                    share = float((difference.max(axis=2) > 8).mean())
                self.samples.append(
                    (time.perf_counter() - self.started, share, zlib.crc32(np.ascontiguousarray(pixels)))
                )
                time.sleep(self.interval)
        finally:
            self._ready.set()
            screen.close()

    def stop(self) -> list:
        self._stop.set()
        self._thread.join(5.0)
        return self.samples

    def times(self) -> tuple[float | None, float | None, float]:
        """(first change, finished, final share): the first read whose share is at least half the final read's, and
        the first read from which every read equals the final one (the finished image on screen)."""
        samples = self.samples
        final_share, final_sum = samples[-1][1], samples[-1][2]
        first = next((t for t, share, _ in samples if share >= 0.5 * final_share and share > 0), None)
        finished = None
        for t, _, checksum in reversed(samples):
            if checksum != final_sum:
                break
            finished = t
        return first, finished, final_share


def window_box(region, left: float, top: float, right: float, bottom: float, margin: int = 4) -> tuple:
    """A box in the region's pixels (from its bottom left, as Blender counts) -> screen pixels (left, top, width,
    height) from the top left, clipped to the region and grown by margin."""
    window, _, _ = view3d()
    left, right = max(0, int(left) - margin), min(region.width, int(right) + margin + 1)
    bottom, top = max(0, int(bottom) - margin), min(region.height, int(top) + margin + 1)
    assert right - left >= 4 and top - bottom >= 4, (left, top, right, bottom)
    return (region.x + left, window.height - (region.y + top), right - left, top - bottom)


def objects_box(names, offset=(0.0, 0.0, 0.0)) -> tuple:
    """The screen box of the named objects' bounding boxes as the view projects them (also moved by offset)."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    from mathutils import Vector

    _, area, region = view3d()
    view = area.spaces.active.region_3d
    points = []
    for name in names:
        obj = bpy.data.objects[name]
        for corner in obj.bound_box:
            world = obj.matrix_world @ Vector(corner)
            points += [location_3d_to_region_2d(region, view, world + Vector(shift)) for shift in ((0, 0, 0), offset)]
    xs, ys = [p[0] for p in points if p is not None], [p[1] for p in points if p is not None]
    return window_box(region, min(xs), max(ys), max(xs), min(ys))


def view_box() -> tuple:
    """The view's image on screen less its edges, the status text (top left) and the navigation gizmo (top right)."""
    _, _, region = view3d()
    return window_box(region, 12, region.height - 110, region.width - 110, 12, margin=0)


LATENCIES: dict = {}  # what -> [seconds, ...]
LATENCY_REPEATS = 3


def the_session():
    sessions = list(sys.modules["weathervane.engine.viewport"]._sessions)
    assert len(sessions) == 1, sessions
    return sessions[0]


def idle_view(least: float = 0.3):
    """A step: until the Rendered view's image is finished and its ray trees kept (and least seconds more)."""
    import time

    began: list = []

    def step() -> float | None:
        session = the_session()
        if session.progressive.busy or not session.progressive.done:
            began.clear()
            return 0.05
        began.append(began[0] if began else time.perf_counter())
        return None if time.perf_counter() - began[0] >= least else 0.05

    return step


def watched(what: str, box, change):
    """A step: reads the box of the screen (and the view's status text), makes the change (the input event), waits
    for the view to finish, then records the seconds from the event to the first changed pixels and to the finished
    image on screen, to the first change of the status text on screen (the change seen to be taken: "updating" or the
    change's first image) and which statuses the engine drew."""
    import time

    state: dict = {}

    def step() -> float | None:
        if "watch" not in state:
            state["watch"] = watch = Watch(box() if callable(box) else box)
            state["status"] = Watch(status_box())
            state["generation"] = the_session().progressive.generation
            DRAWN.clear()
            watch.started = state["status"].started = time.perf_counter()
            change()
            return 0.02
        watch = state["watch"]
        session = the_session()
        waited = time.perf_counter() - watch.started
        assert waited < RENDERED_WAIT_SECONDS, f"{what}: the view did not finish"
        if session.progressive.generation == state["generation"] or session.progressive.busy:
            return 0.05
        if waited < state.setdefault("finished", waited) + 0.5:  # half a second of reads after the view is idle
            return 0.05
        watch.stop()
        state["status"].stop()
        first, finished, share = watch.times()
        assert first is not None and finished is not None and share > 0, (what, first, finished, share)
        LATENCIES.setdefault(what, []).append((first, finished, share))
        taken = next((t for t, changed, _ in state["status"].samples if changed > 0), None)
        drawn = [f"{t - watch.started:.2f} {status.removeprefix('Weathervane Tracer: ')}" for t, status in DRAWN]
        # the engine's first draw after the change: "updating" or the change's first level, never the old "done"
        assert DRAWN and not DRAWN[0][1].startswith("Weathervane Tracer: done"), (what, drawn)
        SEEN.setdefault(what, []).append((taken, DRAWN[0][0] - watch.started, drawn))
        return None

    return step


def status_box() -> tuple:
    """The status text's line on screen: the view's top left, where Blender draws the engine's stats, the third line
    under the view's name and collection (overlays on; the region starts under the header and behind the tool
    header, the line 76-88 px below its top in this window); a thin box, so that reading it costs the machine little."""
    _, _, region = view3d()
    return window_box(region, 10, region.height - 72, 460, region.height - 94, margin=0)


SEEN: dict = {}  # what -> [(seconds to the status text's first change on screen, to the engine's first draw, [the
# statuses drawn]), ...]
DRAWN: list = []  # (time.perf_counter(), status) of each draw of the Rendered view since the last change


def record_draws() -> None:
    """Note the status of every draw of the Rendered view (the engine's view_draw), with its time."""
    import time

    viewport = sys.modules["weathervane.engine.viewport"]
    if getattr(viewport.ViewportSession.draw, "recorded", False):
        return
    draw = viewport.ViewportSession.draw

    def recorded(self, region):
        status = draw(self, region)
        DRAWN.append((time.perf_counter(), status))
        return status

    recorded.recorded, recorded.original = True, draw
    viewport.ViewportSession.draw = recorded


def stop_recording_draws() -> None:
    viewport = sys.modules["weathervane.engine.viewport"]
    viewport.ViewportSession.draw = getattr(viewport.ViewportSession.draw, "original", viewport.ViewportSession.draw)
    DRAWN.clear()


def run_steps(steps: list, then) -> float | None:
    """Run the steps one after another from one timer (each returns None when done, else seconds to its next look)."""

    def run() -> float | None:
        while steps:
            answer = steps[0]()
            if answer is not None:
                return answer
            steps.pop(0)
        return then()

    return guarded(run)


def keys(*names: str):
    """Keys pressed and released with the mouse over the view's centre (Blender's event_simulate)."""

    def change() -> None:
        window, _, region = view3d()
        x, y = region.x + region.width // 2, region.y + region.height // 2
        window.event_simulate("MOUSEMOVE", "NOTHING", x=x, y=y)
        for name in names:
            window.event_simulate(name, "PRESS", x=x, y=y)
            window.event_simulate(name, "RELEASE", x=x, y=y)

    return change


GLASS_BALL = "Glass ball"


def add_glass_and_area_light() -> None:
    """The artist's scene: beside the vane, a glass sphere (a UV sphere, 32 x 16, with a Glass BSDF) and a 1.5 m area
    light, rendered with Lights > Other Lights at F12's Shadows 16 (the view traces to its own Viewport samples).
    Made with bpy.data (no operator while the view traces: tracing_quiet)."""
    import bmesh

    scene = bpy.context.scene
    mesh = bpy.data.meshes.new(GLASS_BALL)
    shape = bmesh.new()
    bmesh.ops.create_uvsphere(shape, u_segments=32, v_segments=16, radius=0.6)
    for face in shape.faces:
        face.smooth = True
    shape.to_mesh(mesh)
    shape.free()
    glass = bpy.data.materials.new(GLASS_BALL)
    glass.use_nodes = True
    nodes = glass.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    bsdf = nodes.new("ShaderNodeBsdfGlass")
    glass.node_tree.links.new(bsdf.outputs[0], nodes["Material Output"].inputs[0])
    mesh.materials.append(glass)
    ball = bpy.data.objects.new(GLASS_BALL, mesh)
    ball.location = (1.6, -1.0, 0.6)
    light = bpy.data.lights.new("Area light", "AREA")
    light.energy, light.size = 300.0, 1.5
    area = bpy.data.objects.new("Area light", light)
    area.location = (2.0, -2.0, 4.0)
    for obj in (ball, area):
        scene.collection.objects.link(obj)
    settings = scene.weathervane
    settings.other_lights, settings.shadow_samples = True, "16"


def remove_glass_and_area_light() -> None:
    scene = bpy.context.scene
    scene.weathervane.other_lights, scene.weathervane.shadow_samples = False, "1"
    light = bpy.data.objects["Area light"].data
    bpy.data.objects.remove(bpy.data.objects["Area light"])
    bpy.data.lights.remove(light)
    mesh = bpy.data.objects[GLASS_BALL].data
    bpy.data.objects.remove(bpy.data.objects[GLASS_BALL])
    bpy.data.meshes.remove(mesh)
    bpy.data.materials.remove(bpy.data.materials[GLASS_BALL])


def set_ior(value: float):
    def change() -> None:
        bpy.data.materials[GLASS_BALL].node_tree.nodes["Glass BSDF"].inputs["IOR"].default_value = value

    return change


def move_glass(dx: float):
    def change() -> None:
        bpy.data.objects[GLASS_BALL].location.x += dx

    return change


def measure_latencies() -> float | None:
    """In the Rendered view as the artist sees it (headers and overlays on), on the artist's scene (the vane with a
    glass sphere and an area light at F12's Shadows 16; the view at its default Viewport samples): from the change or
    the input event to the changed pixels on screen (read from the X server), medians of LATENCY_REPEATS: the glass's
    IOR set as its Material tab sets it, the sphere moved, a numpad orbit (each its first, coarse image, its finished
    one and the status text's first change); then playback (Space) of the vane's turn keyed over 10 frames. The
    test asserts the issue's bars (tests/test_blender_gui.py)."""
    import os

    _, area, _ = view3d()
    view = area.spaces.active.region_3d
    saved = {
        "view_location": view.view_location.copy(),
        "view_rotation": view.view_rotation.copy(),
        "view_distance": view.view_distance,
        "view_camera_zoom": view.view_camera_zoom,
        "view_camera_offset": tuple(view.view_camera_offset),
    }
    perspective = view.view_perspective
    record_draws()
    LOADS.append(os.getloadavg()[0])
    steps: list = [add_glass_and_area_light, idle_view(1.0)]
    for repeat, ior in enumerate((1.6, 1.33, 1.5)[:LATENCY_REPEATS]):
        steps += [watched("glass-ior", lambda: objects_box([GLASS_BALL]), set_ior(ior)), idle_view()]
        dx = 0.3 if repeat % 2 == 0 else -0.3
        box = lambda dx=dx: objects_box([GLASS_BALL], (dx, 0.0, 0.0))  # noqa: E731 - where it is and where it goes
        steps += [watched("glass-moved", box, move_glass(dx)), idle_view()]

    def leave_the_camera_view() -> None:  # numpad 4 in the camera view turns nothing there in 3.4.1
        view.view_perspective = "PERSP"
        area.tag_redraw()

    steps += [leave_the_camera_view, idle_view()]
    for _ in range(LATENCY_REPEATS):
        steps += [watched("orbit", view_box, keys("NUMPAD_4")), idle_view()]

    def restore_view() -> None:
        for name, value in saved.items():
            setattr(view, name, value)
        view.view_perspective = perspective
        area.tag_redraw()

    editors: dict = {}

    def render_properties() -> None:  # Render Properties' Viewport samples beside the view, for the screenshot
        window, _, _ = view3d()
        for editor in (a.spaces.active for a in window.screen.areas if a.type == "PROPERTIES"):
            editors[editor], editor.context = editor.context, "RENDER"

    def screenshot_done_when() -> None:
        print("WEATHERVANE-GUI viewport samples screenshot", screenshot("-viewport-samples"), "status", status_box())
        for editor, context in editors.items():
            editor.context = context
        LOADS.append(os.getloadavg()[0])

    steps += [restore_view, render_properties, idle_view(0.5), screenshot_done_when, playback(), idle_view(0.5)]
    steps += [remove_glass_and_area_light, idle_view(0.5)]
    return run_steps(steps, report_latencies)


LOADS: list = []  # the load average (1 minute) when the measurements began and when they ended


PLAYBACK_SECONDS = 5.0


def playback():
    """A step: the vane's turn keyed over frames 1-10, Space over the view, the view's image read from the screen
    for PLAYBACK_SECONDS (each new image on screen is a frame seen), Space again; then the turn, its keys and the
    frame range as they were."""
    import time

    from mathutils import Euler

    state: dict = {}

    def step() -> float | None:
        scene, turn = bpy.context.scene, bpy.data.objects["WV Turn"]
        if "keyed" not in state:
            assert turn.animation_data is None or turn.animation_data.action is None, "the turn is keyed already"
            state.update(rotation=Euler(turn.rotation_euler), frames=(scene.frame_start, scene.frame_end))
            state["frame"] = scene.frame_current
            scene.frame_start, scene.frame_end = 1, 10
            for frame in range(1, 11):
                turn.rotation_euler.z = state["rotation"].z + 0.3 * frame
                turn.keyframe_insert("rotation_euler", index=2, frame=frame)
            state["action"] = turn.animation_data.action
            scene.frame_set(1)
            state["keyed"] = time.perf_counter()
            return 0.3
        if "watch" not in state:
            if not idle():
                return 0.05
            state["watch"] = Watch(view_box(), compare=False)
            state["watch"].started = time.perf_counter()
            keys("SPACE")()
            return 0.05
        watch = state["watch"]
        if time.perf_counter() - watch.started < PLAYBACK_SECONDS:
            return 0.05
        keys("SPACE")()  # stops it where it is
        samples = watch.stop()
        changes = [t for (t, _, new), (_, _, old) in zip(samples[1:], samples[:-1], strict=True) if new != old]
        LATENCIES["playback"] = [(len(changes) / PLAYBACK_SECONDS, changes[0] if changes else None, len(samples))]
        turn.animation_data_clear()
        bpy.data.actions.remove(state["action"])
        turn.rotation_euler = state["rotation"]
        scene.frame_start, scene.frame_end = state["frames"]
        scene.frame_set(state["frame"])
        return None

    return step


def idle() -> bool:
    progressive = the_session().progressive
    return progressive.done and not progressive.busy


def report_latencies() -> float | None:
    import os
    import statistics

    LOADS.append(os.getloadavg()[0])
    stop_recording_draws()
    print(f"WEATHERVANE-GUI latency load {max(LOADS):.2f} (1-minute load averages {LOADS})")
    for what, runs in SEEN.items():
        taken, drawn = [run[0] for run in runs], [run[1] for run in runs]
        print(
            f"WEATHERVANE-GUI latency {what}-drawn {statistics.median(drawn):.3f} s to the engine's first draw after "
            f"the change ({', '.join(f'{t:.2f}' for t in drawn)}): 'updating' or the change's first level"
        )
        print(
            f"WEATHERVANE-GUI latency {what}-taken {statistics.median(t if t is not None else 1e9 for t in taken):.3f}"
            f" s to the status text's first change on screen ({', '.join(f'{t:.2f}' for t in taken if t is not None)}"
            f"); statuses drawn: {runs[0][2][:6]}"
        )
    for what, runs in LATENCIES.items():
        if what == "playback":
            fps, first, reads = runs[0]
            print(
                f"WEATHERVANE-GUI latency playback {1.0 / fps if fps else float('inf'):.3f} s a frame: {fps:.1f} new "
                f"images a second on screen over {PLAYBACK_SECONDS:.0f} s of Space (10 keyed frames, {reads} reads "
                f"of the screen), the first {first if first is None else round(first, 2)} s after the key"
            )
            continue
        firsts, finished = [run[0] for run in runs], [run[1] for run in runs]
        shares = ", ".join(f"{100 * run[2]:.0f}%" for run in runs)
        runs_text = ", ".join(f"{a:.2f}/{b:.2f}" for a, b in zip(firsts, finished, strict=True))
        _, _, region = view3d()
        print(f"WEATHERVANE-GUI latency {what}-first-image {statistics.median(firsts):.3f}")
        print(
            f"WEATHERVANE-GUI latency {what} {statistics.median(finished):.3f} s to the finished pixels on screen "
            f"(first change {statistics.median(firsts):.3f} s; {len(runs)} runs first/finished: {runs_text}; pixels "
            f"changed in the watched box: {shares}; view {region.width}x{region.height})"
        )
    _, area, _ = view3d()
    area.spaces.active.shading.type = "SOLID"  # Blender frees the view's engine, which stops its thread and workers
    area.tag_redraw()
    return guarded(when_the_rendered_view_stopped(rendered_view_stopped))


FACTORY_F12_RUNS = 4  # the first starts the workers; the figure is the median of the others


def f12_factory_cube():
    """A step: F12 of Blender's factory scene (its cube, camera and light) at the default 1920x1080, 100%, with the
    tracer as the engine, as the key starts it (a render job, with Render In: Keep User Interface): seconds from the
    key to the job's end, FACTORY_F12_RUNS times (the first starts the engine's worker processes); then the engine
    and the preference as they were."""
    import os
    import time

    state: dict = {"runs": []}

    def step() -> float | None:
        scene = bpy.context.scene
        if "engine" not in state:
            assert "Cube" in bpy.data.objects and scene.render.resolution_percentage == 100
            assert (scene.render.resolution_x, scene.render.resolution_y) == (1920, 1080)
            state["engine"] = scene.render.engine
            scene.render.engine = "WEATHERVANE_TRACER"
            # no render window: a second window would cover the view the later steps read from the screen (and
            # closing it from a script crashed Blender 3.4.1 in the build that followed)
            state["display"] = bpy.context.preferences.view.render_display_type
            bpy.context.preferences.view.render_display_type = "NONE"
        if "started" not in state:
            window, area, region = view3d()
            with bpy.context.temp_override(window=window, area=area, region=region):
                assert bpy.ops.render.render("INVOKE_DEFAULT") == {"RUNNING_MODAL"}
            state["started"] = time.perf_counter()
            return 0.02
        seconds = time.perf_counter() - state["started"]
        if bpy.app.is_job_running("RENDER"):
            assert seconds < RENDERED_WAIT_SECONDS, "F12 of the factory cube did not end"
            return 0.02
        state["runs"].append(seconds)
        del state["started"]
        if len(state["runs"]) < FACTORY_F12_RUNS:
            return 0.5
        scene.render.engine = state["engine"]
        bpy.context.preferences.view.render_display_type = state["display"]
        first, *others = state["runs"]
        median = sorted(others)[len(others) // 2] if others else first
        print(
            f"WEATHERVANE-GUI latency f12-factory-cube-1920x1080 {median:.3f} s from F12 to the render job's end, "
            f"median of the F12s after the first (F12s: {', '.join(f'{run:.2f}' for run in state['runs'])} s; the "
            f"first starts the workers; load {os.getloadavg()[0]:.1f})"
        )
        return None

    return step


# a world picture whose file is missing, named as downloaded HDRIs are: its note, with the path, is the longest of
# Scene Conversion's, and its path one word no line holds
MISSING_PICTURE = "kloofendal_48d_partly_cloudy_puresky_4k.hdr"


def conversion_notes():
    """A step: Render Properties > Scene Conversion of the factory scene (no vane: the World's own notes) with the
    tracer, Shadows 16 and a world picture whose file is missing, as the Properties editor shows it: every text fits
    its room as Blender's font measures it (tests/addon/gui_measure.py), each note's lines as buttons make the whole
    note and show it whole as their tooltip; a screenshot (SCREENSHOT-conversion.png) with the editor scrolled to the
    panel; then the world, the engine and the editor as they were."""
    import os
    import time

    state: dict = {}

    def editor():
        window = bpy.context.window_manager.windows[0]
        area = next(a for a in window.screen.areas if a.type == "PROPERTIES")
        return window, area, next(r for r in area.regions if r.type == "WINDOW")

    def step() -> float | None:
        scene, (window, area, region) = bpy.context.scene, editor()
        if not state:
            state.update(engine=scene.render.engine, shadows=scene.weathervane.shadow_samples)
            state.update(tab=area.spaces.active.context, began=time.perf_counter())
            scene.render.engine = "WEATHERVANE_TRACER"
            scene.weathervane.shadow_samples = "16"
            world = scene.world
            world.use_nodes = True
            node = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
            node.image = bpy.data.images.new(MISSING_PICTURE, 4, 4)
            node.image.source, node.image.filepath = "FILE", f"//textures/hdri/{MISSING_PICTURE}"
            background = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
            world.node_tree.links.new(node.outputs["Color"], background.inputs["Color"])
            state["node"] = node
            area.spaces.active.context = "RENDER"
            return 0.3  # drawn once with the tab's panels, so that the editor knows how far it scrolls
        if "scrolled" not in state:
            state["scrolled"] = True
            with bpy.context.temp_override(window=window, area=area, region=region):
                for _ in range(3):  # to the end: Scene Conversion is the last open panel of the tab
                    bpy.ops.view2d.scroll_down(page=True)
            return 0.3
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import gui_measure

        found, notes, problems = gui_measure.measure_notes(bpy.context, window, area, region)
        region.tag_redraw()
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)
        screenshot("-conversion")
        too_wide = sorted((text, share) for text, (share, _) in found.items() if share > 1.0)
        widest = max(found, key=lambda text: found[text][0])
        longest = max((note for note, _ in notes), key=len)
        print(
            f"WEATHERVANE-GUI scene conversion in Properties {region.width} px: {len(found)} texts, the widest "
            f"{widest!r} needs {100 * found[widest][0]:.0f}% of its room; the longest note ({len(longest)} characters) "
            f"in {dict(notes)[longest]}"
        )
        assert any(MISSING_PICTURE in note for note, _ in notes), notes
        print(f"WEATHERVANE-GUI notes cut: {too_wide}" if too_wide else "WEATHERVANE-GUI scene conversion notes fit")
        print(f"WEATHERVANE-GUI notes: {problems}" if problems else "WEATHERVANE-GUI scene conversion notes whole")
        world = scene.world
        image = state["node"].image
        world.node_tree.nodes.remove(state["node"])
        bpy.data.images.remove(image)
        scene.render.engine, scene.weathervane.shadow_samples = state["engine"], state["shadows"]
        with bpy.context.temp_override(window=window, area=area, region=region):
            for _ in range(3):
                bpy.ops.view2d.scroll_up(page=True)
        area.spaces.active.context = state["tab"]
        print(f"WEATHERVANE-GUI scene conversion step took {time.perf_counter() - state['began']:.1f} s")
        return None

    return step


FAKE_FREE_MEMORY = 300_000_000  # bytes: the vane at F12's size fits (about 0.25 GB), a level-7 cube does not
HEARTBEAT_SECONDS = 0.02


def refuse_a_scene_too_large() -> float | None:
    """A scene whose preparation needs more than the free memory (faked: FAKE_FREE_MEMORY in the add-on's tracer
    facade, as tests/addon/test_memory_guard.py fakes it): a cube with Subdivision Surface at level 7, 196,608
    triangles, added as a user adds it; the 3D View switched to Rendered shows the one refusal line and traces
    nothing, the window keeps answering (a timer every HEARTBEAT_SECONDS; N over the view toggles the sidebar), and
    F12 is refused with Blender's report, nothing written; then the free memory, the scene and Solid shading as they
    were."""
    import time

    resources = sys.modules["weathervane.tracer_api"]  # what the add-on reads the free memory through
    real = resources.available_memory
    resources.available_memory = lambda: FAKE_FREE_MEMORY
    window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        assert bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, -3.0)) == {"FINISHED"}
        cube = bpy.context.active_object
        modifier = cube.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = modifier.render_levels = 7
    cube.select_set(False)
    bpy.context.view_layer.objects.active = None
    ticks: list = []

    def heartbeat() -> float | None:
        ticks.append(time.perf_counter())
        return HEARTBEAT_SECONDS if "done" not in state else None

    state: dict = {}

    def switch() -> None:
        state["started"] = time.perf_counter()
        bpy.app.timers.register(heartbeat, first_interval=HEARTBEAT_SECONDS)
        area.spaces.active.shading.type = "RENDERED"
        area.tag_redraw()

    def refused() -> float | None:
        sessions = list(sys.modules["weathervane.engine.viewport"]._sessions)
        waited = time.perf_counter() - state["started"]
        assert waited < 30.0, "the Rendered view showed no refusal"
        if not sessions or not sessions[0].error or sessions[0].status != sessions[0].error:
            return 0.02
        state.update(session=sessions[0], shown=waited)
        return None

    def press_n() -> float | None:
        space = area.spaces.active
        if "sidebar" not in state:
            state.update(sidebar=space.show_region_ui, pressed=time.perf_counter())
            keys("N")()
            return 0.01
        if space.show_region_ui == state["sidebar"]:
            assert time.perf_counter() - state["pressed"] < 30.0, "N over the view was not answered"
            return 0.01
        state["answered"] = time.perf_counter() - state["pressed"]
        space.show_region_ui = state["sidebar"]
        return None

    def f12() -> None:
        import os

        scene = bpy.context.scene
        target = os.path.join(WORK, "refused.png")
        scene.render.filepath = target
        started = time.perf_counter()
        try:
            bpy.ops.render.render(write_still=True)
            message = "F12 was not refused"
        except RuntimeError as error:
            message = str(error).strip()
        state.update(f12=message, f12_seconds=time.perf_counter() - started, written=os.path.exists(target))

    def report() -> float | None:
        state["done"] = True
        session = state["session"]
        import itertools

        gaps = [later - earlier for earlier, later in itertools.pairwise(ticks)]
        traced = session.progressive.latest() is not None or session.progressive.generation != 0
        resources.available_memory = real
        mesh = cube.data
        bpy.data.objects.remove(cube)
        bpy.data.meshes.remove(mesh)
        print(
            f"WEATHERVANE-GUI memory refusal in the Rendered view {state['shown']:.2f} s after Rendered shading, "
            f"{len(session.error.splitlines())} line, traced {'something' if traced else 'nothing'}: {session.error}"
        )
        print(
            f"WEATHERVANE-GUI memory refusal: the window answered N over the view in {state['answered']:.2f} s; a "
            f"timer every {HEARTBEAT_SECONDS} s fired {len(ticks)} times, the longest gap {max(gaps):.2f} s"
        )
        print(
            f"WEATHERVANE-GUI memory refusal in F12 in {state['f12_seconds']:.2f} s, "
            f"{'an image written' if state['written'] else 'nothing written'}: {state['f12']}"
        )
        area.spaces.active.shading.type = "SOLID"
        area.tag_redraw()
        return guarded(when_the_rendered_view_stopped(lambda: guarded(render_empty_f12)))

    return run_steps([switch, refused, view_text_in_lines, idle_seconds(1.0), press_n, f12], report)


def view_text_in_lines() -> None:
    """A step: the refusal as the Rendered view's text shows it (the engine's text, drawn line by line at the view's
    top left): the whole refusal, each line within the view's room (the toolbar and the gizmos' column left out) as
    Blender's font measures it; a screenshot, SCREENSHOT-refusal-view.png."""
    import re

    messages = sys.modules["weathervane.engine.messages"]
    _, area, region = view3d()
    refusal, lines = messages.VIEW_TEXT["status"], messages.VIEW_TEXT["shown"].split("\n")
    room = messages.view_room(region, area)
    widths = [text_pixels(line) for line in lines]
    whole = re.sub(r"\s+", "", "".join(lines)) == re.sub(r"\s+", "", refusal)
    target = screenshot("-refusal-view")
    print(
        f"WEATHERVANE-GUI refusal in the Rendered view's text: {len(lines)} lines, "
        f"{'the whole refusal' if whole else 'NOT the whole refusal'}, the widest {max(widths):.0f} px of "
        f"{room:.0f} px: {target}"
    )
    assert refusal.startswith("Weathervane Tracer: not started: ") and whole and max(widths) <= room, (lines, room)


def idle_seconds(seconds: float):
    """A step: nothing for seconds (the window drawing, timers firing)."""
    import time

    began: list = []

    def step() -> float | None:
        began.append(began[0] if began else time.perf_counter())
        return None if time.perf_counter() - began[0] >= seconds else 0.05

    return step


def material_tab_colour_in_f12() -> float | None:
    """The tail fin's colour edited in the Material tab (its "WV Surface" group node's Color input, as the tab's
    colour field sets it): F12 at FOREIGN_F12's size shows it (the fin's pixels against F12 before the edit, in
    WORK/material-tab.json for the test) and the sidebar shows the same value; then the colour as it was."""
    import json
    import os
    import time

    import numpy as np
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    scene = bpy.context.scene
    node = bpy.data.materials["WV verdigris"].node_tree.nodes["WV Surface"]
    before = tuple(node.inputs["Color"].default_value)
    edited = (0.05, 0.1, 0.9, 1.0)
    node.inputs["Color"].default_value = edited
    started = time.perf_counter()
    target = os.path.join(WORK, "material-tab-f12.png")
    foreign_f12(target)
    seconds = time.perf_counter() - started
    sidebar = tuple({entry.name: entry for entry in scene.weathervane.materials}["verdigris"].color)
    node.inputs["Color"].default_value = before

    def pixels(path: str):
        image = bpy.data.images.load(path)
        try:
            width, height = image.size
            values = np.array(image.pixels[:], dtype=np.float32).reshape(height, width, 4)[::-1, :, :3]
        finally:
            bpy.data.images.remove(image)
        return np.round(values * 255.0)

    width, height = FOREIGN_F12
    fin = bpy.data.objects["WV tail_fin"]
    corners = [world_to_camera_view(scene, scene.camera, fin.matrix_world @ Vector(c)) for c in fin.bound_box]
    left, right = int(min(c.x for c in corners) * width), int(np.ceil(max(c.x for c in corners) * width))
    top, bottom = int((1 - max(c.y for c in corners)) * height), int(np.ceil((1 - min(c.y for c in corners)) * height))
    old = pixels(os.path.join(WORK, "foreign-f12-empty.png"))[top:bottom, left:right]
    new = pixels(target)[top:bottom, left:right]
    changed = np.abs(new - old).max(axis=2) > 3
    figures = {
        "box": [left, top, right, bottom],
        "pixels": int(changed.size),
        "changed": int(changed.sum()),
        "before": old[changed].mean(axis=0).tolist() if changed.any() else None,
        "after": new[changed].mean(axis=0).tolist() if changed.any() else None,
        "colour": list(edited[:3]),
        "previous colour": list(before[:3]),
        "sidebar": list(sidebar),
        "seconds": seconds,
    }
    with open(os.path.join(WORK, "material-tab.json"), "w") as file:
        json.dump(figures, file)
    print(
        f"WEATHERVANE-GUI latency f12-material-tab-colour {seconds:.3f} s for F12 at {width}x{height}: "
        f"{figures['changed']} of the tail fin's {figures['pixels']} box pixels changed, their mean "
        f"{figures['before']} -> {figures['after']} (Color {edited[:3]}); the sidebar shows {sidebar}"
    )
    return guarded(add_foreign_scene)


MAIN_LOOP_SLEEP = 0.004  # seconds


def sleep_as_blender_does() -> float:
    """Blender's main loop sleeps 5 ms when no event is waiting, except with --enable-event-simulate (which this
    session needs for its keys): then it polls without pause and takes a whole core (3.0 s of CPU in 3 s idle here,
    against 0.04 s without the option), the core that Blender's drawing and the tracer's workers share with it on
    the 2-core machine. This timer, called on every turn of the loop, sleeps as Blender would (0.06 s in 3 s idle)."""
    import time

    time.sleep(MAIN_LOOP_SLEEP)
    return 0.0


bpy.app.timers.register(sleep_as_blender_does, first_interval=0.0, persistent=True)
bpy.app.timers.register(prepare, first_interval=1.0)
