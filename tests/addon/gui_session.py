"""A real Blender window (run under Xvfb by tests/test_blender_gui.py): install and enable the add-on, open the
sidebar on the Weathervane tab, build the vane, take a screenshot; then, with the tracer as the engine, Output
Properties, F12 and the 3D View in Rendered shading; then a foreign scene added with Blender's own operators
(Suzanne with a Subdivision Surface modifier, a text, a collection instance of a cone) in F12 and in the Rendered
view; File > Export; quit.

    blender --factory-startup --python tests/addon/gui_session.py -- ADDON_ZIP SCREENSHOT.png WORK_FOLDER

Beside SCREENSHOT it writes SCREENSHOT-output.png (Output Properties with the tracer as the engine),
SCREENSHOT-rendered.png (the 3D View in Rendered shading, nothing over it), SCREENSHOT-rendered-ui.png (the same
with the interface), SCREENSHOT-foreign-f12.png (F12 of the vane with the foreign scene, 320 x 240),
SCREENSHOT-foreign-rendered.png (the Rendered view with it, laid out as SCREENSHOT-rendered.png) and
SCREENSHOT-export-menu.png; in WORK_FOLDER, f12.png (F12's image saved as PNG), f12-scene.json (the scene exported
at that moment), rendered-scene.json (the scene seen from the Rendered view, for the test to trace), the view
region's place in the window (rendered-region.json), foreign-f12-empty.png (F12 at 320 x 240 before the foreign
scene) and foreign.json (each new object's bounding box projected into F12's image and into the window).

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


def screenshot(suffix: str = "") -> str:
    """The whole window as SCREENSHOT with suffix before its extension; returns the path."""
    window, area, region = view3d()
    target = SCREENSHOT.replace(".png", f"{suffix}.png")
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
        setup()
    except Exception:
        import traceback

        traceback.print_exc()
        bpy.ops.wm.quit_blender()
    return None


def setup() -> None:
    assert bpy.ops.preferences.addon_install(filepath=ADDON_ZIP, overwrite=True) == {"FINISHED"}
    assert bpy.ops.preferences.addon_enable(module="weathervane") == {"FINISHED"}
    open_every_panel()
    bring_tab_forward()  # after: the other tabs' panels registered last, the Weathervane tab first
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
    classes = sys.modules["weathervane.panels"].CLASSES + sys.modules["weathervane.render_panels"].CLASSES
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
    found, tips = gui_measure.measure(bpy.context, sidebar.width, properties.width)
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
    line, kind = sys.modules["weathervane.operators"].result_line()
    return f"{kind}: {line}"


def reset_in_camera_view() -> float | None:
    """Reset (as its dialog's OK runs it) while the 3D View looks through the camera: the view stays the camera
    view once Blender has redrawn, and the sidebar shows Reset's result line."""
    window, area, region = view3d()
    assert area.spaces.active.region_3d.view_perspective == "CAMERA"
    print("WEATHERVANE-GUI result line after Build:", result_line())
    assert result_line().startswith(("INFO: Built", "WARNING: Built")), result_line()
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

    entry_kind = sys.modules["weathervane.export"].entry_kind  # what the sidebar's Lights panel draws
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
    assert result_line().startswith("INFO: Wrote"), result_line()
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
    return full_image_then(then or capture_rendered, idle=then is None)


def full_image_then(step, idle: bool = True) -> float | None:
    """Wait until the Rendered view shows its full image at the view's size, then run step. With idle, also until
    its thread has kept the image's ray trees for edits (the status line then says done), which takes longer than
    the image on a scene of many triangles."""
    import time

    started = time.perf_counter()

    def wait() -> float | None:
        _, area, region = view3d()
        sessions = list(sys.modules["weathervane.viewport"]._sessions)
        level = sessions[0].progressive.latest() if sessions else None
        if (
            level is None
            or level.divisor != 1
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
    viewport = sys.modules["weathervane.viewport"]
    (session,) = list(viewport._sessions)
    view = area.spaces.active.region_3d
    document = dict(session.document)
    document["camera"] = viewport.view_camera(view.view_matrix, view.window_matrix, region.width, region.height)
    document["render"] = {**document["render"], "width": region.width, "height": region.height}
    with open(os.path.join(WORK, "rendered-scene.json"), "w") as file:
        json.dump(document, file)
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
    (session,) = list(sys.modules["weathervane.viewport"]._sessions)
    print("WEATHERVANE-GUI rendered screenshot with the interface, status:", session.status)
    assert session.status.startswith("Weathervane Tracer: done in"), session.status
    return guarded(edit_in_rendered_view)


def edit_in_rendered_view() -> float | None:
    """A small edit (the tail fin's colour, as the Materials panel sets it) in the Rendered view: every status line
    drawn from then on is the new scene's ("updating", then the edit's or a level's), never the previous scene's
    "done" or a stale "1/1 resolution"; the time to the edited image is recorded (not asserted)."""
    import time

    (session,) = list(sys.modules["weathervane.viewport"]._sessions)
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
            _, area, _ = view3d()
            # back to Solid shading: Blender frees the view's engine, which stops its thread and workers
            area.spaces.active.shading.type = "SOLID"
            area.tag_redraw()
            return guarded(when_the_rendered_view_stopped(rendered_view_stopped))
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
    return guarded(render_empty_f12)


def open_export_menu() -> float | None:
    window, area, region = view3d()
    # File > Export, opened as a click on the menu would: the add-on's entry is in it (last: the menu stays open)
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.wm.call_menu(name="TOPBAR_MT_file_export")
    bpy.app.timers.register(capture_menu, first_interval=1.0)
    return None


def capture_menu() -> float | None:
    target = screenshot("-export-menu")
    print("WEATHERVANE-GUI export menu", target)
    return guarded(f12_then_quit)


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
    return guarded(add_foreign_scene)


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


bpy.app.timers.register(prepare, first_interval=1.0)
