"""The add-on in Blender: building, geometry, the baked motion, materials, lights, export."""

from __future__ import annotations

import json
import math
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Vector

from addon import compat
from addon.convert import export, material_convert
from addon.vane import build, materials
from addon.vane.animation import motion_for
from tracer.geometry import transforms
from tracer.scene import motion as motion_module
from tracer.scene.keyframes import DEFAULT_TOLERANCE
from tracer.scene.loader import default_scene, default_scene_dict, scene_from_dict
from tracer.scene.wind import Wind, WindKey


def built() -> bpy.types.Collection:
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    bpy.context.view_layer.update()
    return bpy.data.collections[build.COLLECTION]


def test_build_makes_every_part_in_its_own_collection() -> None:
    collection = built()
    scene = default_scene()
    names = {obj.name for obj in collection.objects}
    assert {f"WV {obj.name}" for obj in scene.objects} <= names
    assert {build.PIVOT, build.TURN, "WV Camera"} <= names
    assert sum(obj.type == "LIGHT" for obj in collection.objects) == 2  # point and sun; ambient has no object
    assert bpy.context.scene.camera.name == "WV Camera"
    vane_parts = {obj.name for obj in bpy.data.objects[build.TURN].children}
    assert vane_parts == {f"WV {name}" for name in scene.vane.parts}


def test_building_again_replaces_only_its_own_collection() -> None:
    user_mesh = bpy.data.meshes.new("mine")
    user_mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    mine = bpy.data.objects.new("mine", user_mesh)
    bpy.context.scene.collection.objects.link(mine)
    mine.location = (5, 6, 7)
    first = len(built().objects)
    second = len(built().objects)
    assert first == second
    assert [c.name for c in bpy.data.collections] == [build.COLLECTION]
    assert bpy.data.objects["mine"].location[:] == pytest.approx((5, 6, 7))
    assert bpy.data.meshes.get("mine") is not None
    assert len([m for m in bpy.data.meshes if m.name.startswith("WV ")]) == len(default_scene().objects)


def test_a_bad_scene_file_is_refused_and_builds_nothing(tmp_path: Path) -> None:
    document = default_scene_dict()
    document["objects"][2]["radius"] = -1
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document))
    with pytest.raises(RuntimeError, match=r"objects\[2\].radius: must be > 0, got -1"):
        bpy.ops.weathervane.build(filepath=str(path))
    assert bpy.data.collections.get(build.COLLECTION) is None


def _renamed_material(document: dict, new: str) -> dict:
    old = document["objects"][0]["material"]
    document["materials"][new] = document["materials"].pop(old)
    for obj in document["objects"]:
        if obj["material"] == old:
            obj["material"] = new
    return document


def test_names_longer_than_blender_keeps_are_refused_before_anything_changes(tmp_path: Path) -> None:
    built()
    before = sorted(obj.name for obj in bpy.data.objects)
    long_name = "m" * (compat.MAX_NAME_BYTES - 2)  # with "WV " one byte too many
    path = tmp_path / "long.json"
    path.write_text(json.dumps(_renamed_material(default_scene_dict(), long_name)))
    expected = f"materials.{long_name}: the name is {compat.MAX_NAME_BYTES + 1} bytes in Blender"
    with pytest.raises(RuntimeError, match=expected):
        bpy.ops.weathervane.build(filepath=str(path))
    assert sorted(obj.name for obj in bpy.data.objects) == before  # the earlier build is untouched
    path.write_text(json.dumps(_renamed_material(default_scene_dict(), long_name[:-1])))  # fits exactly
    assert bpy.ops.weathervane.build(filepath=str(path)) == {"FINISHED"}


def _world_vertices(obj: bpy.types.Object) -> np.ndarray:
    return np.array([tuple(obj.matrix_world @ vertex.co) for vertex in obj.data.vertices])


def test_boxes_and_pyramids_are_the_tracers_triangles() -> None:
    built()
    scene = default_scene()
    for obj in scene.objects:
        if type(obj).__name__ not in ("Box", "Pyramid"):
            continue
        world = transforms.world_primitive(obj, scene.vane)
        blender_object = bpy.data.objects[f"WV {obj.name}"]
        faces = [
            tuple(_world_vertices(blender_object)[list(polygon.vertices)].ravel())
            for polygon in blender_object.data.polygons
        ]
        expected = [tuple(np.ravel(triangle)) for triangle in world.triangles]
        np.testing.assert_allclose(np.array(faces), np.array(expected), atol=1e-5)


def test_curved_parts_lie_on_the_analytic_surfaces_with_half_pixel_silhouettes() -> None:
    built()
    scene = default_scene()
    focal = build.focal_pixels(scene)
    for obj in scene.objects:
        kind = type(obj).__name__
        if kind not in ("Sphere", "Cylinder"):
            continue
        world = transforms.world_primitive(obj, scene.vane)
        vertices = _world_vertices(bpy.data.objects[f"WV {obj.name}"])
        if kind == "Sphere":
            distances = np.linalg.norm(vertices - np.array(world.center), axis=1)
            np.testing.assert_allclose(distances, obj.radius, rtol=1e-5)
            centre, reach = np.array(world.center), obj.radius
        else:
            offsets = vertices - np.array(world.base)
            along = offsets @ np.array(world.axis)
            radial = np.linalg.norm(offsets - np.outer(along, world.axis), axis=1)
            np.testing.assert_allclose(radial[radial > 1e-6], obj.radius, rtol=1e-5)
            assert along.min() == pytest.approx(0.0, abs=1e-5) and along.max() == pytest.approx(obj.height, abs=1e-5)
            centre = np.array(world.base) + np.array(world.axis) * obj.height / 2
            reach = max(obj.radius, obj.height / 2)
        segments = build.segments_for(obj.radius, np.linalg.norm(centre - scene.camera.location) - reach, focal)
        error = (
            focal
            * obj.radius
            * (1 - math.cos(math.pi / segments))
            / (np.linalg.norm(centre - scene.camera.location) - reach)
        )
        assert error <= 0.5
        if segments > build.MIN_SEGMENTS:  # the fewest: two fewer segments would show
            coarser = segments - 2
            assert (
                focal
                * obj.radius
                * (1 - math.cos(math.pi / coarser))
                / (np.linalg.norm(centre - scene.camera.location) - reach)
                > 0.5
            )


def _baked_degrees(frames: range) -> np.ndarray:
    turn = bpy.data.objects[build.TURN]
    fcurve = compat.find_fcurve(turn, "rotation_euler", 2)
    assert fcurve is not None and all(point.interpolation == "LINEAR" for point in fcurve.keyframe_points)
    return np.degrees([fcurve.evaluate(frame) for frame in frames])


def test_bake_matches_the_motion_code_on_every_frame() -> None:
    built()
    blender_scene = bpy.context.scene
    blender_scene.frame_start, blender_scene.frame_end = 1, 150
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    expected = motion_module.simulate(motion_for(blender_scene, 150), 150, default_scene().vane.heading)
    baked = _baked_degrees(range(1, 151))
    assert np.max(np.abs(baked - expected)) <= DEFAULT_TOLERANCE + 1e-4
    keys = len(compat.find_fcurve(bpy.data.objects[build.TURN], "rotation_euler", 2).keyframe_points)
    assert keys < 150


def test_bake_follows_wind_keyed_on_the_timeline() -> None:
    built()
    blender_scene = bpy.context.scene
    blender_scene.animation_data_clear()  # the default scene's own wind keys
    settings = blender_scene.weathervane
    settings.gust_intensity = 0.0
    settings.start_frame, settings.use_stop = 1, False
    blender_scene.render.fps, blender_scene.render.fps_base = 24, 1.0
    blender_scene.frame_start, blender_scene.frame_end = 1, 120
    # the artist keys the wind: from 300 to 20 degrees (through north) and 4 to 9 m/s
    for frame, direction, speed in ((1, 300.0, 4.0), (40, 340.0, 6.0), (80, 380.0, 9.0)):
        settings.wind_direction, settings.wind_speed = math.radians(direction), speed
        blender_scene.keyframe_insert("weathervane.wind_direction", frame=frame)
        blender_scene.keyframe_insert("weathervane.wind_speed", frame=frame)
    for owner_curve in compat.fcurves_of(blender_scene):
        for point in owner_curve.keyframe_points:
            point.interpolation = "LINEAR"
    blender_scene.frame_set(1)  # as moving on the timeline does: the fields show the keys again
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    wind = Wind(keys=(WindKey(0.0, 300.0, 4.0), WindKey(39 / 24, 340.0, 6.0), WindKey(79 / 24, 20.0, 9.0)))
    motion = motion_module.Motion(
        damping=settings.damping,
        wavelength=settings.wavelength,
        threshold=settings.threshold,
        friction_time=settings.friction_time,
        fps=24.0,
        wind=wind,
    )
    expected = motion_module.simulate(motion, 120, default_scene().vane.heading)
    assert np.max(np.abs(_baked_degrees(range(1, 121)) - expected)) <= DEFAULT_TOLERANCE + 1e-3


def test_spin_mode_bakes_the_seed_spin() -> None:
    built()
    blender_scene = bpy.context.scene
    settings = blender_scene.weathervane
    settings.mode, settings.spin_direction, settings.spin_speed, settings.spin_smoothness = "SPIN", "clockwise", 60, 1
    settings.start_frame, settings.use_stop, settings.stop_frame = 1, True, 97
    blender_scene.render.fps, blender_scene.render.fps_base = 24, 1.0
    blender_scene.frame_start, blender_scene.frame_end = 1, 200
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    baked = _baked_degrees(range(1, 201))
    heading = default_scene().vane.heading
    # 0.5 s ramp-up 30 deg... total: 60 * 4 s of spin = 240 degrees clockwise, ramps included
    assert baked[-1] == pytest.approx(heading - 240.0, abs=DEFAULT_TOLERANCE)


def test_material_edits_reach_the_node_graph_live() -> None:
    built()
    entry = next(entry for entry in bpy.context.scene.weathervane.materials if entry.name == "brass")
    entry.color = (0.1, 0.2, 0.3)
    entry.reflective = 0.6
    entry.specular = 0.0
    top = bpy.data.materials["WV brass"].node_tree.nodes[materials.TOP]
    assert tuple(top.inputs["Color"].default_value)[:3] == pytest.approx((0.1, 0.2, 0.3))
    assert top.inputs["Reflectivity"].default_value == pytest.approx(0.6)
    assert top.inputs["Shininess"].default_value == 0.0
    # the group's scene-wide values: the ambient light's intensity, and Blinn-Phong's exponent factor
    group = bpy.data.node_groups[materials.GROUP]
    assert group.nodes["WV Ambient Level"].outputs[0].default_value == pytest.approx(0.2)
    assert group.nodes["WV Exponent Factor"].outputs[0].default_value == pytest.approx(3.0)
    bpy.context.scene.weathervane.model = "phong"
    assert group.nodes["WV Exponent Factor"].outputs[0].default_value == pytest.approx(4.0)


def test_a_vane_materials_surface_is_one_node_with_the_panels_three_values() -> None:
    """The Material tab shows the Surface's node and its inputs: the vane material's colour, shininess and
    reflectivity, the panel's entry's values."""
    built()
    for entry in bpy.context.scene.weathervane.materials:
        material = bpy.data.materials[materials.material_name(entry.name)]
        output = material_convert.material_output(material.node_tree)
        top = output.inputs["Surface"].links[0].from_node
        assert top.name == materials.TOP and top.bl_idname == "ShaderNodeGroup"
        assert [socket.name for socket in top.inputs] == ["Color", "Shininess", "Reflectivity"]
        assert tuple(top.inputs["Color"].default_value)[:3] == tuple(entry.color)
        assert top.inputs["Shininess"].default_value == entry.specular
        assert top.inputs["Reflectivity"].default_value == entry.reflective


def _entry(name: str):
    return next(entry for entry in bpy.context.scene.weathervane.materials if entry.name == name)


def test_the_sidebar_and_the_material_tab_show_the_same_value_after_an_edit_on_either_side() -> None:
    built()
    entry, top = _entry("verdigris"), bpy.data.materials["WV verdigris"].node_tree.nodes[materials.TOP]
    # the Material tab: the node's inputs, copied to the entry at the next depsgraph evaluation
    top.inputs["Color"].default_value = (0.9, 0.1, 0.05, 1.0)
    top.inputs["Shininess"].default_value = 42.0
    top.inputs["Reflectivity"].default_value = 0.125
    bpy.context.view_layer.update()
    assert tuple(entry.color) == tuple(top.inputs["Color"].default_value)[:3] == pytest.approx((0.9, 0.1, 0.05))
    assert entry.specular == top.inputs["Shininess"].default_value == 42.0
    assert entry.reflective == top.inputs["Reflectivity"].default_value == 0.125
    assert tuple(bpy.data.materials["WV verdigris"].diffuse_color)[:3] == tuple(entry.color)  # Solid view too
    # the sidebar: the entry's values, written to the node at once
    entry.color, entry.specular, entry.reflective = (0.2, 0.4, 0.6), 7.0, 0.5
    assert tuple(top.inputs["Color"].default_value)[:3] == tuple(entry.color) == pytest.approx((0.2, 0.4, 0.6))
    assert top.inputs["Shininess"].default_value == entry.specular == 7.0
    assert top.inputs["Reflectivity"].default_value == entry.reflective == 0.5
    # a value the panel cannot hold (a colour above 1) is clamped on both sides, once: no update calls back
    top.inputs["Color"].default_value = (1.5, 0.5, 0.25, 1.0)
    bpy.context.view_layer.update()
    assert tuple(entry.color) == tuple(top.inputs["Color"].default_value)[:3] == (1.0, 0.5, 0.25)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    bpy.context.view_layer.update()
    assert not depsgraph.updates  # nothing left to evaluate: the copies stopped


def test_undo_and_redo_keep_the_sidebar_and_the_material_tab_at_one_value() -> None:
    built()

    def both() -> tuple[float, float]:
        top = bpy.data.materials["WV brass"].node_tree.nodes[materials.TOP]  # undo replaces the data: look again
        return _entry("brass").reflective, top.inputs["Reflectivity"].default_value

    bpy.ops.ed.undo_push(message="built")
    start = both()
    # as the Material tab does: the edit, its undo step at once (before the depsgraph copies it), then evaluation
    bpy.data.materials["WV brass"].node_tree.nodes[materials.TOP].inputs["Reflectivity"].default_value = 0.75
    bpy.ops.ed.undo_push(message="node edit")
    bpy.context.view_layer.update()
    assert both() == (0.75, 0.75)
    bpy.ops.ed.undo()
    assert both() == start
    bpy.ops.ed.redo()  # the step holds the node's new value and the entry's old one: redo copies it
    assert both() == (0.75, 0.75)
    _entry("brass").reflective = 0.5  # as the sidebar does: the edit (the node follows at once), its undo step
    bpy.ops.ed.undo_push(message="sidebar edit")
    assert both() == (0.5, 0.5)
    bpy.ops.ed.undo()
    assert both() == (0.75, 0.75)


def test_a_vane_materials_node_edit_reaches_the_export_of_the_rendered_view() -> None:
    built()
    top = bpy.data.materials["WV copper"].node_tree.nodes[materials.TOP]
    top.inputs["Color"].default_value = (0.0, 0.25, 1.0, 1.0)
    top.inputs["Reflectivity"].default_value = 0.0
    depsgraph = bpy.context.evaluated_depsgraph_get()  # the viewport's evaluation, as the Rendered view has it
    document = export.scene_document(bpy.context, depsgraph)
    assert document["materials"]["copper"]["color"] == pytest.approx([0.0, 0.25, 1.0])
    assert document["materials"]["copper"]["reflective"] == 0.0


def test_lights_can_be_added_and_removed() -> None:
    collection = built()
    settings = bpy.context.scene.weathervane
    before = len(settings.lights)
    assert bpy.ops.weathervane.light_add(kind="POINT") == {"FINISHED"}
    entry = settings.lights[-1]
    assert entry.object_name in collection.objects
    entry.intensity = 0.25
    assert bpy.data.objects[entry.object_name].data.energy == pytest.approx(0.25 * 4 * math.pi**2)
    name = entry.object_name
    assert bpy.ops.weathervane.light_remove() == {"FINISHED"}
    assert len(settings.lights) == before and bpy.data.objects.get(name) is None


def test_export_maps_the_built_scene_back_exactly(tmp_path: Path) -> None:
    built()
    path = tmp_path / "scene.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    exported = scene_from_dict(json.loads(path.read_text()))
    original = default_scene()
    assert [obj.name for obj in exported.objects] == [obj.name for obj in original.objects]
    for mine, theirs in zip(exported.objects, original.objects, strict=True):
        a, b = transforms.world_primitive(mine, exported.vane), transforms.world_primitive(theirs, original.vane)
        for field in ("center", "radius", "base", "axis", "height", "point", "normal", "half_size", "triangles"):
            if hasattr(b, field) and getattr(b, field) is not None:
                np.testing.assert_allclose(
                    np.array(getattr(a, field), dtype=float), np.array(getattr(b, field), dtype=float), atol=2e-5
                )
    assert exported.vane.heading == pytest.approx(original.vane.heading, abs=1e-4)
    assert [type(light).__name__ for light in exported.lights] == [type(light).__name__ for light in original.lights]
    np.testing.assert_allclose(exported.lights[2].direction, original.lights[2].direction, atol=1e-5)
    assert exported.camera.lens == pytest.approx(original.camera.lens)
    np.testing.assert_allclose(exported.camera.rotation, original.camera.rotation, atol=1e-4)


def test_export_turns_other_meshes_into_triangles(tmp_path: Path) -> None:
    built()
    mesh = bpy.data.meshes.new("quad")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    quad = bpy.data.objects.new("quad", mesh)
    quad.location = (2, 0, 0)
    bpy.context.scene.collection.objects.link(quad)
    path = tmp_path / "scene.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    document = json.loads(path.read_text())
    exported = next(obj for obj in document["objects"] if obj["name"] == "quad")
    assert exported["type"] == "mesh" and len(exported["triangles"]) == 2
    assert Vector(exported["vertices"][0]) == Vector((2, 0, 0))


@pytest.mark.parametrize("where", ["/proc/weathervane.json", "a file/scene.json"])
def test_export_to_a_place_that_cannot_be_written_reports_one_line_and_leaves_nothing(tmp_path: Path, where) -> None:
    built()
    (tmp_path / "a file").write_text("not a folder")
    target = where if where.startswith("/") else str(tmp_path / where)
    before = sorted(tmp_path.rglob("*"))
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.weathervane.export(filepath=target)
    message = str(raised.value)
    assert f"cannot write {target}:" in message and "Traceback" not in message and ".partial" not in message
    assert len([line for line in message.splitlines() if line.startswith("Error:")]) == 1
    assert sorted(tmp_path.rglob("*")) == before


def test_an_unexpected_error_in_an_operator_is_one_report_line(monkeypatch: pytest.MonkeyPatch) -> None:
    built()

    def broken(*_args, **_kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr("addon.vane.animation.bake", broken)
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.weathervane.bake()
    message = str(raised.value)
    assert "Bake Motion failed: ZeroDivisionError: a bug" in message and "Traceback" not in message


def test_file_import_export_and_add_menus_hold_the_operators_and_unregister_removes_them(tmp_path: Path) -> None:
    import addon
    from addon.vane import operators

    for menu, entry in operators.MENUS:
        assert entry in getattr(bpy.types, menu)._dyn_ui_initialize(), menu
    # Object > Weathervane holds every operator the add-on registers, so that menu search (F3) finds them
    registered = {cls.bl_idname for cls in operators.CLASSES} - {"weathervane.scene_file_browse"}
    assert {cls.bl_idname for cls in operators.WEATHERVANE_MT_object.OPERATORS} == registered
    # File > Import builds from a scene file, as the Build operator does
    document = default_scene_dict()
    document["objects"][0]["size"] = [12, 12]
    path = tmp_path / "small_ground.json"
    path.write_text(json.dumps(document))
    assert bpy.ops.weathervane.import_scene(filepath=str(path)) == {"FINISHED"}
    assert bpy.data.objects["WV ground"].dimensions.x == pytest.approx(12)
    addon.unregister()
    try:
        for menu, entry in operators.MENUS:
            assert entry not in getattr(bpy.types, menu)._dyn_ui_initialize(), menu
    finally:
        addon.register()


def test_bake_is_greyed_out_until_there_is_a_vane_and_lights_are_named_alike_however_made() -> None:
    assert not bpy.ops.weathervane.bake.poll()  # the button is greyed out, its tooltip says why
    built()
    assert bpy.ops.weathervane.bake.poll()
    settings = bpy.context.scene.weathervane
    built_names = [entry.object_name for entry in settings.lights if entry.object_name]
    assert all(name.startswith(("WV Point ", "WV Sun ")) for name in built_names), built_names
    assert bpy.ops.weathervane.light_add(kind="DIRECTIONAL") == {"FINISHED"}
    assert settings.lights[-1].object_name == f"WV Sun {len(settings.lights) - 1}"
    items = bpy.ops.weathervane.light_add.get_rna_type().properties["kind"].enum_items
    assert {item.identifier: item.icon for item in items} == {
        "POINT": "LIGHT_POINT",
        "DIRECTIONAL": "LIGHT_SUN",
        "AMBIENT": "WORLD",
    }


def test_the_scene_file_button_browses_json_files_only_and_sets_the_field(tmp_path: Path) -> None:
    rna = bpy.ops.weathervane.scene_file_browse.get_rna_type()
    assert rna.properties["filter_glob"].default == "*.json"
    path = tmp_path / "chosen.json"
    path.write_text(json.dumps(default_scene_dict()))
    assert bpy.ops.weathervane.scene_file_browse(filepath=str(path)) == {"FINISHED"}
    assert bpy.context.scene.weathervane.scene_file == str(path)
    assert bpy.ops.weathervane.build() == {"FINISHED"}  # Build uses the chosen file


def _exported(tmp_path: Path) -> dict:
    path = tmp_path / "scene.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) in ({"FINISHED"},)
    return json.loads(path.read_text())


def test_other_lights_are_left_out_until_asked_for_and_build_says_so(tmp_path: Path, capfd) -> None:
    from tracer.workers.parallel import render

    # the startup file's Light: 1000 W at (4.1, 1.0, 5.9)
    data = bpy.data.lights.new("Light", type="POINT")
    data.energy = 1000.0
    startup_light = bpy.data.objects.new("Light", data)
    startup_light.location = (4.08, 1.0, 5.9)
    bpy.context.scene.collection.objects.link(startup_light)
    built()
    report = [line for line in capfd.readouterr().out.splitlines() if "not rendered by the tracer" in line]
    assert len(report) == 1 and "Light" in report[0] and "Other Lights" in report[0]
    assert "the wind follows the file's 3 keys" in report[0]  # Build says it set the wind, not silently
    document = _exported(tmp_path)
    assert len(document["lights"]) == len(default_scene().lights)  # only the listed ones
    # and every render says so, as the Scene Conversion panel does (it does not call the light or the world exact)
    assert "1 light beside the vane's not rendered (Light; Lights > Other Lights renders them)" in document["comment"]
    from addon.convert import conversion_report

    rows = {(kind, name): notes for kind, name, notes in conversion_report.scene_conversion(bpy.context.scene)}
    assert rows[("LIGHT", "Light")] == ["off (see Other Lights)"]
    small = {"width": 64, "height": 48}
    document["render"].update(small)
    mean = render(scene_from_dict(document), workers=1).image.mean()
    expected = render(default_scene().with_render(**small), workers=1).image.mean()
    assert abs(mean - expected) < 0.1 * expected
    bpy.context.scene.weathervane.other_lights = True
    document = _exported(tmp_path)
    assert len(document["lights"]) == len(default_scene().lights) + 1
    # the startup light in Cycles' units: 1000 W with inverse-square falloff (addon/light_convert.py)
    added = document["lights"][-1]
    assert added["type"] == "point" and added["falloff"] == "inverse_square"
    assert added["intensity"] == pytest.approx(1000.0 / (4 * math.pi**2))
    document["render"].update(small)
    assert render(scene_from_dict(document), workers=1).image.mean() > 1.05 * expected  # what the user asked for


def test_a_lights_type_is_fixed_after_add_so_panel_and_blender_light_agree() -> None:
    built()
    settings = bpy.context.scene.weathervane
    for entry in settings.lights:
        obj = bpy.data.objects.get(entry.object_name) if entry.object_name else None
        if obj is not None:
            assert obj.data.type == {"POINT": "POINT", "DIRECTIONAL": "SUN"}[entry.kind]
    # the Lights panel, drawn: the selected light's type is a label, not a field, and Other Lights shows only when
    # there is another light
    settings.light_index = next(k for k, entry in enumerate(settings.lights) if entry.kind == "POINT")
    drawn = _draw_lights_panel()
    assert "kind" not in drawn["props"] and "intensity" in drawn["props"]
    assert any(text.startswith("Type: Point") for text in drawn["labels"])
    assert "other_lights" not in drawn["props"]
    data = bpy.data.lights.new("Lamp", type="POINT")
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Lamp", data))
    drawn = _draw_lights_panel()
    assert "other_lights" in drawn["props"] and "Lamp (not rendered)" in drawn["labels"]


class _Recorder:
    """A stand-in for a panel's layout that notes the properties and labels drawn."""

    def __init__(self, drawn: dict) -> None:
        self.drawn = drawn
        self.use_property_split = False

    def __getattr__(self, name: str):
        if name in ("row", "column", "box", "split"):
            return lambda *args, **kwargs: _Recorder(self.drawn)
        return lambda *args, **kwargs: None

    def prop(self, data, name: str, **kwargs) -> None:
        self.drawn["props"].append(name)

    def label(self, text: str = "", **kwargs) -> None:
        self.drawn["labels"].append(text)


def _draw_lights_panel() -> dict:
    from addon.vane import panels

    drawn: dict = {"props": [], "labels": []}
    holder = type("Panel", (), {"layout": _Recorder(drawn)})()
    panels.WEATHERVANE_PT_lights.draw(holder, bpy.context)
    return drawn


def test_bake_refuses_a_wind_edit_that_its_keys_would_ignore_and_follows_it_once_keyed() -> None:
    built()
    blender_scene = bpy.context.scene
    blender_scene.frame_set(1)
    settings = blender_scene.weathervane
    settings.wind_direction = math.radians(90.0)  # typed in the field: orange, changed but not keyed
    settings.wind_speed = 12.0
    with pytest.raises(
        RuntimeError, match=r"Wind From shows 90\.0 degrees but its keys give 200\.0 degrees at frame 1"
    ):
        bpy.ops.weathervane.bake()
    blender_scene.keyframe_insert("weathervane.wind_direction", frame=1)
    with pytest.raises(RuntimeError, match=r"Wind Speed shows 12\.00 m/s but its keys give 6\.00 m/s"):
        bpy.ops.weathervane.bake()
    blender_scene.keyframe_insert("weathervane.wind_speed", frame=1)
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    frames = np.arange(1, 3, dtype=np.float64)
    from addon.vane.animation import _sampled

    assert np.degrees(_sampled(blender_scene, "wind_direction", frames))[0] == pytest.approx(90.0)


def test_rebuild_keeps_the_users_work_and_reset_starts_over() -> None:
    built()
    blender_scene = bpy.context.scene
    settings = blender_scene.weathervane
    blender_scene.frame_set(1)
    settings.materials[0].color = (0.9, 0.1, 0.2)
    settings.materials[0].reflective = 0.45
    settings.wind_speed = 11.0
    blender_scene.keyframe_insert("weathervane.wind_speed", frame=1)
    assert bpy.ops.weathervane.bake() == {"FINISHED"}
    baked = compat.keyframes_of(bpy.data.objects[build.TURN], "rotation_euler", 2)
    blender_scene.render.resolution_percentage = 50
    light = next(bpy.data.objects[entry.object_name] for entry in settings.lights if entry.object_name)
    light.location = (1.0, 2.0, 3.0)
    camera_name = blender_scene.camera.name
    assert bpy.ops.weathervane.build() == {"FINISHED"}  # build again, from the same (default) scene
    assert tuple(settings.materials[0].color) == pytest.approx((0.9, 0.1, 0.2))
    assert settings.materials[0].reflective == pytest.approx(0.45)
    material = bpy.data.objects[f"WV {default_scene().objects[0].name}"].active_material
    assert material is not None
    assert compat.keyframes_of(blender_scene, "weathervane.wind_speed", 0)[1][0] == pytest.approx(11.0)
    assert compat.keyframes_of(bpy.data.objects[build.TURN], "rotation_euler", 2) == baked
    assert blender_scene.render.resolution_percentage == 50
    assert tuple(bpy.data.objects[light.name].location) == pytest.approx((1.0, 2.0, 3.0))
    assert blender_scene.camera.name == camera_name
    assert bpy.data.collections[build.COLLECTION].objects.get(light.name) is not None
    # Reset Weathervane (confirmed) takes everything back to the scene file's
    assert bpy.ops.weathervane.reset("EXEC_DEFAULT") == {"FINISHED"}
    original = default_scene()
    first = settings.materials[0]
    assert tuple(first.color) == pytest.approx(original.materials[first.name].color)
    assert blender_scene.render.resolution_percentage == 100
    assert compat.keyframes_of(bpy.data.objects[build.TURN], "rotation_euler", 2) is None


def test_artist_words_units_on_values_and_no_float_noise_in_light_angles() -> None:
    settings_rna = bpy.types.Scene.bl_rna.properties["weathervane"].fixed_type
    texts = []
    for prop in settings_rna.properties:
        texts += [prop.name, prop.description]
        if prop.type == "ENUM":
            texts += [text for item in prop.enum_items for text in (item.name, item.description)]
    words = " ".join(texts)
    assert "seed's" not in words and "Coef" not in words  # the course's words, not the source file's
    labels = {prop.identifier: prop.name for prop in settings_rna.properties}
    assert "°/s" in labels["spin_speed"] and "°" in labels["tolerance"]
    units = {prop.identifier: prop.unit for prop in settings_rna.properties if prop.type == "FLOAT"}
    assert units["wind_speed"] == "VELOCITY" and units["friction_time"] in ("TIME", "TIME_ABSOLUTE")
    built()
    settings = bpy.context.scene.weathervane
    for entry in settings.lights:
        if entry.kind == "DIRECTIONAL":
            angles = [math.degrees(a) for a in bpy.data.objects[entry.object_name].rotation_euler]
            assert all(a == 0.0 or abs(a) > 1e-3 for a in angles), angles


def test_render_settings_say_what_they_do_with_the_technical_term_in_the_tooltip() -> None:
    settings = bpy.context.scene.weathervane
    props = settings.bl_rna.properties
    labels = {prop.name for prop in props} | {item.name for prop in props for item in getattr(prop, "enum_items", [])}
    assert not labels & {"Textbook", "Accurate", "Workers", "Highlight Sharpness", "Numerics", "Depth"}
    assert "numerics: documented" in props["numerics"].enum_items["documented"].description
    assert "float64" in props["precision"].enum_items["float64"].description
    assert "coef" in props["coef"].description and "recursion depth" in props["depth"].description
    # Processes as Blender's Threads Mode: Auto-Detect is the tracer's workers 0, Fixed a count
    assert settings.workers == 0 and settings.workers_mode == "AUTO"
    settings.workers_mode = "FIXED"
    assert settings.workers >= 1 and settings.workers_mode == "FIXED"
    settings.workers = 3
    settings.workers_mode = "FIXED"
    assert settings.workers == 3
    settings.workers_mode = "AUTO"
    assert settings.workers == 0


def test_export_names_what_the_conversion_approximated_as_f12_does(tmp_path: Path) -> None:
    """File > Export of a scene the add-on did not build (the factory cube, its light and world): the result line
    says what the file's comment says was approximated (the README: named in the status bar); the vane's own scene
    exports with no such line."""
    from addon.vane import operators

    bpy.ops.wm.read_factory_settings(use_empty=False)
    path = tmp_path / "factory.json"
    assert bpy.ops.weathervane.export(filepath=str(path)) == {"FINISHED"}
    comment = json.loads(path.read_text())["comment"]
    assert "approximated:" in comment
    message, kind = operators._RESULT
    assert kind == "WARNING" and message == f"Wrote {path}; {comment}", operators._RESULT
    bpy.ops.wm.read_factory_settings(use_empty=True)
    built()
    assert bpy.ops.weathervane.export(filepath=str(tmp_path / "vane.json")) == {"FINISHED"}
    assert "comment" not in json.loads((tmp_path / "vane.json").read_text())
    assert [f"Wrote {tmp_path / 'vane.json'}", "INFO"] == operators._RESULT
