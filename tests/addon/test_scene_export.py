"""Any Blender scene exports as Blender evaluates it: every object instance at the frame's evaluated place, text,
curves, metaballs and surfaces as meshes, mirrored objects facing out, zero-area triangles left out and named,
what the tracer cannot draw named. The truth is Blender's own depsgraph and mesh data."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.convert.export import ExportNotes, scene_document
from addon.engine import engine


def export(notes: ExportNotes | None = None) -> dict:
    return scene_document(bpy.context, notes=notes)


def by_name(document: dict) -> dict[str, dict]:
    return {obj["name"]: obj for obj in document["objects"]}


def centroid(obj: dict) -> np.ndarray:
    return np.asarray(obj["vertices"]).mean(axis=0)


def test_a_keyed_object_and_a_rotating_parents_child_export_where_blender_puts_them_each_frame() -> None:
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 0))
    cube = bpy.context.object
    cube.keyframe_insert("location", frame=1)
    cube.location = (3, 0, 0)
    cube.keyframe_insert("location", frame=5)
    bpy.ops.object.empty_add(location=(0, 5, 0))
    parent = bpy.context.object
    parent.keyframe_insert("rotation_euler", frame=1)
    parent.rotation_euler = (0, 0, np.pi)
    parent.keyframe_insert("rotation_euler", frame=5)
    bpy.ops.mesh.primitive_ico_sphere_add(radius=0.5, location=(2, 5, 0))
    child = bpy.context.object
    child.parent = parent
    child.matrix_parent_inverse = parent.matrix_world.inverted()
    scene = bpy.context.scene
    for frame in range(1, 6):
        scene.frame_set(frame)
        objects = by_name(export())
        for obj in (cube, child):
            evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
            local = np.array([vertex.co for vertex in evaluated.data.vertices]).mean(axis=0)
            expected = np.array(evaluated.matrix_world) @ np.append(local, 1.0)
            assert centroid(objects[obj.name]) == pytest.approx(expected[:3], abs=1e-5), (obj.name, frame)
    assert centroid(by_name(export())[cube.name])[0] == pytest.approx(3.0, abs=1e-5)


def test_text_curve_metaball_and_surface_objects_export_as_their_evaluated_meshes() -> None:
    bpy.ops.object.text_add(location=(0, 3, 0))
    bpy.ops.curve.primitive_bezier_circle_add(location=(3, 0, 0))
    bpy.context.object.data.bevel_depth = 0.1
    bpy.ops.object.metaball_add(location=(-3, 0, 0))
    bpy.ops.surface.primitive_nurbs_surface_sphere_add(location=(0, -3, 0))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    objects = by_name(export())
    for obj in bpy.context.scene.objects:
        mesh = obj.evaluated_get(depsgraph).to_mesh()
        mesh.calc_loop_triangles()
        triangles = len(mesh.loop_triangles)
        obj.evaluated_get(depsgraph).to_mesh_clear()
        assert obj.name in objects, f"{obj.type} {obj.name} was not exported"
        exported = len(objects[obj.name]["triangles"])
        assert 0 < exported <= triangles and exported >= 0.95 * triangles, (obj.name, exported, triangles)


def world_placements(document: dict) -> list[tuple[str, np.ndarray]]:
    """(object name, the world centroid of its vertices) for every placement in the document: each "mesh" object's,
    and each matrix of an "instances" object applied to its meshes-table entry's centroid."""
    placements = []
    for obj in document["objects"]:
        if obj["type"] == "mesh":
            placements.append((obj["name"], centroid(obj)))
        elif obj["type"] == "instances":
            local = centroid(document["meshes"][obj["mesh"]])
            for matrix in np.asarray(obj["matrices"], dtype=np.float64).reshape(-1, 3, 4):
                placements.append((obj["name"], matrix[:, :3] @ local + matrix[:, 3]))
    return placements


def test_instances_export_at_every_place_blender_puts_them() -> None:
    bpy.ops.mesh.primitive_plane_add(size=4)
    plane = bpy.context.object
    bpy.ops.mesh.primitive_ico_sphere_add(radius=0.2, subdivisions=1, location=(0, 0, 1))
    sphere = bpy.context.object
    sphere.parent = plane
    plane.instance_type = "VERTS"
    collection = bpy.data.collections.new("Pieces")
    bpy.ops.mesh.primitive_cone_add(location=(10, 0, 0))
    cone = bpy.context.object
    collection.objects.link(cone)
    bpy.ops.object.collection_instance_add(collection=collection.name, location=(0, 10, 0))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    local = {obj: np.array([vertex.co for vertex in obj.data.vertices]).mean(axis=0) for obj in (sphere, cone)}
    expected = sorted(
        tuple(np.round(np.array(instance.matrix_world) @ np.append(local[instance.object.original], 1.0), 5)[:3])
        for instance in depsgraph.object_instances
        if instance.object.type == "MESH" and instance.object.original in (sphere, cone)
    )
    document = export()
    placements = [(name, place) for name, place in world_placements(document) if name != plane.name]
    placed = sorted(tuple(np.round(place, 5)) for _, place in placements)
    assert len(expected) == 4 + 1 + 1 + 1  # four vertices, the sphere itself, the cone, its instance
    # every instance Blender renders is exported once, where Blender puts it
    assert len(placed) == len(expected)
    assert np.abs(np.array(placed) - np.array(expected)).max() < 1e-4
    # each mesh placed several times is in the meshes table once, in its own space, and placed by matrices
    assert sorted(document["meshes"]) == sorted([sphere.data.name, cone.data.name])
    for obj in (sphere, cone):
        vertices = np.asarray(document["meshes"][obj.data.name]["vertices"])
        assert np.abs(vertices - np.array([vertex.co for vertex in obj.data.vertices])).max() < 1e-6
    groups = [obj for obj in document["objects"] if obj["type"] == "instances"]
    assert sorted(len(obj["matrices"]) for obj in groups) == [2, 5]
    # named after the first placement's object ("instancer/object" for an instance): what the Outliner shows
    assert sorted(obj["name"].split("/")[-1] for obj in groups) == sorted([sphere.name, cone.name])


def test_a_mirrored_object_faces_out() -> None:
    bpy.ops.mesh.primitive_cube_add(location=(2, 0, 0))
    cube = bpy.context.object
    cube.scale = (-1, 1, 1)
    obj = by_name(export())[cube.name]
    vertices, triangles = np.asarray(obj["vertices"]), np.asarray(obj["triangles"])
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    outward = (a + b + c) / 3 - vertices.mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", normals, outward) > 0)


def test_smooth_faces_export_blenders_corner_normals_flat_faces_none() -> None:
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6)
    sphere = bpy.context.object
    assert "normals" not in by_name(export())[sphere.name]
    bpy.ops.object.shade_smooth()
    sphere.rotation_euler = (0.3, 0.2, 0.1)
    obj = by_name(export())[sphere.name]
    normals, vertices = np.asarray(obj["normals"]), np.asarray(obj["vertices"])
    corners = vertices[np.asarray(obj["triangles"])]
    # each corner's normal is Blender's vertex normal there, turned with the object
    world = np.array(sphere.matrix_world)
    positions = np.array([vertex.co for vertex in sphere.data.vertices]) @ world[:3, :3].T + world[:3, 3]
    vertex_normals = np.array([vertex.normal for vertex in sphere.data.vertices]) @ world[:3, :3].T
    nearest = np.linalg.norm(corners[:, :, None, :] - positions[None, None], axis=3).argmin(axis=2)
    expected = vertex_normals[nearest]
    assert np.abs(normals - expected).max() < 1e-5
    assert np.allclose(np.linalg.norm(normals, axis=2), 1.0)


def test_per_face_materials_export_per_triangle() -> None:
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    for name in ("Red", "Blue"):
        material = bpy.data.materials.new(name)
        cube.data.materials.append(material)
    for polygon in cube.data.polygons:
        polygon.material_index = 1 if polygon.normal.z > 0.5 else 0
    obj = by_name(export())[cube.name]
    assert obj["materials"] == ["blender:Red", "blender:Blue"]
    indices = np.asarray(obj["material_indices"])
    vertices, triangles = np.asarray(obj["vertices"]), np.asarray(obj["triangles"])
    top = vertices[triangles].mean(axis=1)[:, 2] > 0.99
    assert np.array_equal(indices, top.astype(int))


def test_zero_area_triangles_are_left_out_and_named() -> None:
    mesh = bpy.data.meshes.new("Sliver")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0)], [], [(0, 1, 2), (3, 4, 5)])
    obj = bpy.data.objects.new("Sliver", mesh)
    bpy.context.scene.collection.objects.link(obj)
    notes = ExportNotes()
    exported = by_name(export(notes))["Sliver"]
    assert len(exported["triangles"]) == 1
    assert notes.dropped_triangles == {"Sliver": 1}
    assert "1 zero-area triangle left out (Sliver)" in notes.line()


def test_what_the_tracer_cannot_draw_is_named_never_dropped_silently() -> None:
    volume = bpy.data.objects.new("Smoke", bpy.data.volumes.new("Smoke"))
    bpy.context.scene.collection.objects.link(volume)
    notes = ExportNotes()
    document = export(notes)
    assert "1 volume object not rendered (Smoke)" in notes.line()
    assert document["comment"] == notes.line()


def test_a_scene_with_nothing_to_render_exports_no_objects_and_a_material() -> None:
    mesh = bpy.data.meshes.new("Points")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [], [])
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Points", mesh))
    document = export()
    assert document["objects"] == [] and document["materials"]


def test_blender_visibility_is_followed_at_export() -> None:
    bpy.ops.mesh.primitive_cube_add()
    hidden = bpy.context.object
    hidden.hide_render = True
    collection = bpy.data.collections.new("Off")
    bpy.context.scene.collection.children.link(collection)
    bpy.ops.mesh.primitive_cone_add()
    cone = bpy.context.object
    for owner in cone.users_collection:
        owner.objects.unlink(cone)
    collection.objects.link(cone)
    collection.hide_render = True
    bpy.ops.mesh.primitive_ico_sphere_add()
    sphere = bpy.context.object
    sphere.visible_camera = False
    sphere.visible_glossy = False
    bpy.ops.mesh.primitive_torus_add()
    torus = bpy.context.object
    torus.is_holdout = True
    notes = ExportNotes()
    objects = by_name(export(notes))
    assert hidden.name not in objects and cone.name not in objects
    assert objects[sphere.name]["visible_camera"] is False and objects[sphere.name]["visible_reflection"] is False
    assert "visible_shadow" not in objects[sphere.name]
    assert objects[torus.name]["holdout"] is True
    assert notes.controls == {}  # the holdout is held out: nothing to name


@pytest.mark.parametrize("crop", [False, True])
def test_the_render_border_is_traced_alone_and_cropped_as_blender_does(tmp_path: Path, crop: bool) -> None:
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.object.camera_add(location=(0, -6, 0), rotation=(np.pi / 2, 0, 0))
    scene = bpy.context.scene
    scene.camera = bpy.context.object
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    scene.render.use_border, scene.render.use_crop_to_border = True, crop
    scene.render.border_min_x, scene.render.border_max_x = 0.25, 0.75
    scene.render.border_min_y, scene.render.border_max_y = 0.5, 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(tmp_path / "border.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    image = bpy.data.images.load(str(tmp_path / "border.exr"))
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, 4)  # rows from the bottom
    assert engine.border_region(scene.render, 64, 48) == (16, 24, 48, 48)
    scene.render.use_border = False
    scene.render.filepath = str(tmp_path / "whole.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    whole_image = bpy.data.images.load(str(tmp_path / "whole.exr"))
    whole = np.empty(64 * 48 * 4, dtype=np.float32)
    whole_image.pixels.foreach_get(whole)
    whole = whole.reshape(48, 64, 4)
    if crop:
        assert (width, height) == (32, 24)
        assert np.abs(pixels[..., :3] - whole[24:48, 16:48, :3]).max() < 1e-6
    else:
        assert (width, height) == (64, 48)
        assert np.abs(pixels[24:48, 16:48, :3] - whole[24:48, 16:48, :3]).max() < 1e-6
        outside = np.ones((48, 64), dtype=bool)
        outside[24:48, 16:48] = False
        assert np.all(pixels[outside][:, :3] == 0.0)


def test_problems_name_the_blender_object_not_the_export_index() -> None:
    from addon.convert.export import named_problems

    document = {"objects": [{"name": "Cube"}, {"name": "Suzanne"}]}
    problems = ["objects[1].vertices[3]: must be 3 finite numbers", "render.width: must be >= 1"]
    assert named_problems(problems, document) == [
        'object "Suzanne".vertices[3]: must be 3 finite numbers',
        "Resolution X x % (Output Properties): must be >= 1",
    ]


def test_a_panel_light_whose_type_is_changed_in_the_light_tab_exports_and_shows_as_the_new_type() -> None:
    from addon.convert.export import entry_kind

    assert bpy.ops.weathervane.build() == {"FINISHED"}
    settings = bpy.context.scene.weathervane
    entry = next(entry for entry in settings.lights if entry.kind == "DIRECTIONAL")
    before = [light["type"] for light in export()["lights"]]
    bpy.data.objects[entry.object_name].data.type = "POINT"
    assert entry_kind(entry) == "POINT"
    after = [light["type"] for light in export()["lights"]]
    assert before.count("directional") - 1 == after.count("directional")
    assert after.count("point") == before.count("point") + 1


def test_build_names_the_scenes_other_objects_that_render_beside_the_vane(capfd) -> None:
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    bpy.ops.mesh.primitive_cone_add()
    bpy.context.object.hide_render = True
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    reported = capfd.readouterr()
    line = next(line for line in (reported.out + reported.err).splitlines() if "Built" in line)
    assert f"also rendered with the vane: {cube.name} (hide them in renders" in line
    assert "Cone" not in line
    assert cube.name in by_name(export())  # and it is rendered, as said


def test_flat_faces_that_are_not_planar_shade_with_each_triangles_own_normal() -> None:
    """A flat Suzanne (its quads are not planar): no corner normals, so each triangle shades with its own normal, as
    Cycles does; a smooth one carries them."""
    bpy.ops.mesh.primitive_monkey_add()
    suzanne = bpy.context.object
    suzanne.modifiers.new("Subdivision", "SUBSURF")
    assert "normals" not in by_name(export())[suzanne.name]
    bpy.ops.object.shade_smooth()
    assert "normals" in by_name(export())[suzanne.name]


def test_export_sweeps_what_a_killed_export_left_and_keeps_a_live_writers_file(tmp_path: Path) -> None:
    """A killed writer's temporary file (its process gone, its lock free) is removed and named in the result line;
    one that a live writer holds (this process, inside atomic_path) stays."""
    import os
    import subprocess
    import sys

    from addon.vane import operators
    from tracer.tracing.images import atomic_path

    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    left = tmp_path / f".scene.json.weathervane-{int(gone.stdout)}-abcd_123.partial"
    left.write_text("half a scene")
    os.utime(left, (0, 0))
    bpy.ops.mesh.primitive_cube_add()
    with atomic_path(tmp_path / "other.json") as live:
        live.write_text("being written")
        assert bpy.ops.weathervane.export(filepath=str(tmp_path / "scene.json")) == {"FINISHED"}
        assert live.exists()
    assert not left.exists()
    assert sorted(path.name for path in tmp_path.iterdir()) == ["other.json", "scene.json"]
    line, kind = operators.result_line()
    assert "removed 1 temporary file(s) a killed export had left" in line and kind in {"INFO", "WARNING"}, line


def test_a_scene_files_lights_of_every_kind_build_into_blender_lights_that_export_as_the_same_lights(
    tmp_path: Path,
) -> None:
    import json

    from tracer.scene.loader import default_scene_dict, scene_from_dict

    document = default_scene_dict()
    document["lights"] = [
        {"type": "ambient", "intensity": 0.2},
        {"type": "point", "location": [2.0, -3.0, 4.0], "intensity": 0.5},
        {"type": "directional", "direction": [1.0, 4.0, 4.0], "intensity": 0.2},
        {"type": "point", "location": [-2.0, 1.0, 3.0], "intensity": 0.7, "color": [1.0, 0.5, 0.25],
         "falloff": "inverse_square", "radius": 0.3},
        {"type": "point", "location": [0.0, 2.0, 5.0], "intensity": 0.3, "color": [0.2, 0.4, 1.0]},
        {"type": "directional", "direction": [-1.0, 1.0, 2.0], "intensity": 0.4, "angle": 5.0},
        {"type": "spot", "location": [3.0, 3.0, 4.0], "direction": [-0.5, -0.5, -1.0], "intensity": 2.0,
         "falloff": "inverse_square", "spot_size": 40.0, "spot_blend": 0.3},
        {"type": "area", "location": [0.0, -2.0, 4.0], "direction": [0.0, 0.3, -1.0], "x_axis": [1.0, 0.0, 0.0],
         "shape": "rectangle", "size": [2.0, 0.5], "intensity": 3.0, "color": [1.0, 0.9, 0.8]},
        {"type": "area", "location": [1.0, 1.0, 3.0], "direction": [0.0, 0.0, -1.0], "x_axis": [0.6, 0.8, 0.0],
         "shape": "disk", "size": 1.5, "intensity": 1.0},
    ]  # fmt: skip
    document["render"]["shadow_samples"] = 16  # soft shadows of the area lights: the panel's Shadows
    path = tmp_path / "lights.json"
    path.write_text(json.dumps(document))
    assert bpy.ops.weathervane.build(filepath=str(path)) == {"FINISHED"}
    built = bpy.data.collections["Weathervane"].objects
    kinds = sorted(obj.data.type for obj in built if obj.type == "LIGHT")
    assert kinds == ["AREA", "AREA", "POINT", "POINT", "POINT", "SPOT", "SUN", "SUN"]  # no spot or area as a sun
    assert {"WV Spot 6", "WV Area 7", "WV Area 8"} <= {obj.name for obj in built}
    assert bpy.context.scene.weathervane.shadow_samples == "16"
    expected = scene_from_dict(document, "original").lights
    exported = scene_from_dict(json.loads(json.dumps(export())), "export").lights
    assert [type(light).__name__ for light in exported] == [type(light).__name__ for light in expected]
    for ours, theirs in zip(exported, expected, strict=True):
        for field in theirs.__dataclass_fields__:
            want, got = getattr(theirs, field), getattr(ours, field)
            if field == "spot_model":  # the spot as this Blender's Cycles shapes it
                assert got == ("cycles3" if bpy.app.version < (4, 0, 0) else "cycles4")
            elif isinstance(want, str):
                assert got == want, (type(theirs).__name__, field)
            elif field in ("direction", "x_axis"):  # a direction's length is not a Blender light's
                assert np.allclose(np.divide(got, np.linalg.norm(got)), np.divide(want, np.linalg.norm(want)),
                                   atol=1e-6), (type(theirs).__name__, field, got, want)  # fmt: skip
            else:
                assert np.allclose(got, want, rtol=1e-5, atol=1e-6), (type(theirs).__name__, field, got, want)
