"""Instances export as instances: a geometry placed many times is one entry of the document's meshes table and a matrix
per placement, renders as the same scene realized, and is not read again while nothing changes it (scenes of real size).

The truth is Blender's own depsgraph: its object instances' matrices, and the engine's image of the same scene with
the instances realized (Geometry Nodes' Realize Instances) or the shared meshes made single-user."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.convert import export, mesh_export
from addon.convert.export import ExportNotes, scene_document
from tests.addon.node_groups import new_group
from tracer.scene.loader import scene_from_dict

SPHERE_TRIANGLES = 16 * (11 - 2) * 2 + 2 * 16  # the scatter's UV sphere: 16 segments, 11 rings


def document(notes: ExportNotes | None = None) -> dict:
    return scene_document(bpy.context, notes=notes)


def geometry_nodes(obj, name: str):
    """obj's new Geometry Nodes modifier's tree and its group output node (3.4's sockets or 4.0's interface)."""
    geometry = [("Geometry", "NodeSocketGeometry")]
    tree, _, output = new_group(name, "GeometryNodeTree", geometry, geometry)
    obj.modifiers.new(name, "NODES").node_group = tree
    return tree, output


def scatter(columns: int, rows: int, spacing: float = 1.0, realize: bool = False, material=None):
    """An object whose Geometry Nodes put a UV sphere (16 x 11, radius 0.35) on each point of a columns x rows grid,
    turned and scaled at random (the same on every run), realized or not."""
    obj = bpy.data.objects.new("Forest", bpy.data.meshes.new("Forest"))
    bpy.context.scene.collection.objects.link(obj)
    tree, group_out = geometry_nodes(obj, "Scatter")
    nodes, links = tree.nodes, tree.links
    grid = nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = spacing * (columns - 1)
    grid.inputs["Size Y"].default_value = spacing * (rows - 1)
    grid.inputs["Vertices X"].default_value, grid.inputs["Vertices Y"].default_value = columns, rows
    sphere = nodes.new("GeometryNodeMeshUVSphere")
    sphere.inputs["Segments"].default_value, sphere.inputs["Rings"].default_value = 16, 11
    sphere.inputs["Radius"].default_value = 0.35
    instance = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(grid.outputs["Mesh"], instance.inputs["Points"])
    shape = sphere.outputs["Mesh"]
    if material is not None:
        paint = nodes.new("GeometryNodeSetMaterial")
        paint.inputs["Material"].default_value = material
        links.new(shape, paint.inputs["Geometry"])
        shape = paint.outputs["Geometry"]
    links.new(shape, instance.inputs["Instance"])
    turn = nodes.new("FunctionNodeRandomValue")
    turn.data_type = "FLOAT_VECTOR"
    turn.inputs[1].default_value = (6.283, 6.283, 6.283)  # Max of the vector inputs
    angle = turn.outputs[0]
    if instance.inputs["Rotation"].type == "ROTATION":  # 4.1+: a rotation socket, from Euler angles
        euler = nodes.new("FunctionNodeEulerToRotation")
        links.new(angle, euler.inputs[0])
        angle = euler.outputs[0]
    links.new(angle, instance.inputs["Rotation"])
    size = nodes.new("FunctionNodeRandomValue")
    size.data_type = "FLOAT"
    size.inputs[2].default_value, size.inputs[3].default_value = 0.6, 1.3  # Min and Max of the float inputs
    links.new(size.outputs[1], instance.inputs["Scale"])
    shape = instance.outputs["Instances"]
    if realize:
        realized = nodes.new("GeometryNodeRealizeInstances")
        links.new(shape, realized.inputs["Geometry"])
        shape = realized.outputs["Geometry"]
    links.new(shape, group_out.inputs[0])
    return obj


def instance_matrices(depsgraph, obj) -> np.ndarray:
    """The (K, 3, 4) world matrices Blender places obj's generated instances at, rows sorted."""
    matrices = [
        np.array(instance.matrix_world)[:3]
        for instance in depsgraph.object_instances
        if instance.is_instance and instance.parent.original == obj and instance.object.type == "MESH"
    ]
    return sorted_rows(np.array(matrices))


def sorted_rows(matrices: np.ndarray) -> np.ndarray:
    """(K, 3, 4) matrices -> (K, 12) rows in the order of their translations (x, then y, then z; a grid's are apart)."""
    flat = matrices.reshape(len(matrices), -1).astype(np.float64)
    places = np.round(flat[:, [3, 7, 11]], 3)
    return flat[np.lexsort(places.T[::-1])]


def camera_and_sun(location=(0.0, -14.0, 10.0), rotation=(0.95, 0.0, 0.0)) -> None:
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = location, rotation
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.3, 0.4)
    for obj in (camera, sun):
        bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = camera


def render_engine(tmp_path: Path, name: str, width: int = 80, height: int = 60) -> np.ndarray:
    """The engine's F12 image (height, width, 3) float32, rows from the top."""
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = str(tmp_path / f"{name}.exr")
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    image = bpy.data.images.load(str(tmp_path / f"{name}.exr"))
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return np.flipud(pixels.reshape(height, width, 4))[..., :3]


def differing(a: np.ndarray, b: np.ndarray, tolerance: float = 1e-6) -> float:
    """The fraction of pixels where the two images differ by more than tolerance in some channel."""
    return float((np.abs(a - b).max(axis=2) > tolerance).mean())


@pytest.fixture
def reads(monkeypatch) -> list:
    """Every object whose geometry mesh_export.read reads from now on (its name)."""
    seen: list[str] = []
    read = mesh_export.read

    def counted(obj):
        seen.append(obj.name)
        return read(obj)

    monkeypatch.setattr(mesh_export, "read", counted)
    return seen


def test_a_geometry_nodes_scatter_is_one_mesh_and_a_matrix_per_instance() -> None:
    forest = scatter(50, 40)  # 2,000 spheres
    exported = document()
    assert list(exported["meshes"]) == [f"{forest.name}/{next(iter(exported['meshes'])).split('/')[-1]}"]
    mesh = next(iter(exported["meshes"].values()))
    assert len(mesh["triangles"]) == SPHERE_TRIANGLES
    groups = [obj for obj in exported["objects"] if obj["type"] == "instances"]
    assert len(groups) == 1 and len(groups[0]["matrices"]) == 2000
    # the document holds the sphere once: its triangles, not 2,000 times them
    assert sum(len(obj.get("triangles", ())) for obj in exported["objects"]) == 0
    placed = np.asarray(groups[0]["matrices"], dtype=np.float64).reshape(-1, 3, 4)
    expected = instance_matrices(bpy.context.evaluated_depsgraph_get(), forest)
    assert np.abs(sorted_rows(placed) - expected).max() < 1e-4
    assert len(scene_from_dict(exported).objects) == 1  # the tracer loads it as it is


def test_an_instanced_scene_renders_as_the_same_scene_realized(tmp_path: Path) -> None:
    leaf = bpy.data.materials.new("Leaf")
    leaf.diffuse_color = (0.2, 0.6, 0.25, 1.0)
    forest = scatter(9, 7, spacing=1.2, material=leaf)
    bpy.ops.mesh.primitive_plane_add(size=30)
    camera_and_sun()
    instanced = render_engine(tmp_path, "instanced")
    assert "meshes" in document()
    bpy.data.objects.remove(forest)
    scatter(9, 7, spacing=1.2, material=leaf, realize=True)
    assert "meshes" not in document()  # one world-space mesh of all the spheres' triangles
    realized = render_engine(tmp_path, "realized")
    assert instanced.std() > 0.02  # a picture, not a fill
    # the same picture. Blender realizes the instances in float32, so the realized triangles' normals differ from the
    # instances' (float32 sphere, float64 matrix) by float32 rounding: shading values near 2 differ by up to 1.2e-5
    # (in 6% of the pixels by more than 1e-6). Beyond 1e-4 only a silhouette pixel may differ, where rounding moves an
    # edge across a pixel centre: none here
    assert differing(instanced, realized, tolerance=1e-4) < 0.005


def test_shared_meshes_mirrored_and_stretched_render_as_their_single_user_copies(tmp_path: Path) -> None:
    bpy.ops.mesh.primitive_monkey_add()
    suzanne = bpy.context.object
    placements = [
        ((-3.0, 0.0, 1.0), (0.0, 0.0, 0.3), (1.0, 1.0, 1.0)),
        ((0.0, 0.0, 1.0), (0.4, 0.0, -0.2), (-1.0, 1.0, 1.0)),  # mirrored
        ((3.0, 0.0, 1.0), (0.0, 0.5, 0.2), (1.4, 0.6, 1.0)),  # stretched
    ]
    shared = [suzanne]
    for _ in placements[1:]:
        twin = suzanne.copy()  # a new object with the same mesh
        bpy.context.scene.collection.objects.link(twin)
        shared.append(twin)
    for obj, (location, rotation, scale) in zip(shared, placements, strict=True):
        obj.location, obj.rotation_euler, obj.scale = location, rotation, scale
    bpy.ops.mesh.primitive_plane_add(size=30)
    camera_and_sun(location=(0.0, -9.0, 4.0), rotation=(1.2, 0.0, 0.0))
    exported = document()
    assert list(exported["meshes"]) == [suzanne.data.name]
    group = next(obj for obj in exported["objects"] if obj["type"] == "instances")
    assert (
        np.abs(
            sorted_rows(np.asarray(group["matrices"]).reshape(-1, 3, 4))
            - sorted_rows(np.array([np.array(obj.matrix_world)[:3] for obj in shared]))
        ).max()
        < 1e-5
    )
    instanced = render_engine(tmp_path, "instanced")
    for obj in shared[1:]:
        obj.data = obj.data.copy()  # each its own mesh: world-space triangles, no instances
    assert "meshes" not in document()
    alone = render_engine(tmp_path, "alone")
    assert instanced.std() > 0.02
    assert differing(instanced, alone) < 0.005


def test_collection_instances_and_shared_meshes_are_instances_where_blender_puts_them() -> None:
    pieces = bpy.data.collections.new("Pieces")
    bpy.ops.mesh.primitive_cone_add(location=(1, 0, 0))
    cone = bpy.context.object
    for owner in cone.users_collection:
        owner.objects.unlink(cone)
    pieces.objects.link(cone)
    empties = []
    for k in range(3):
        bpy.ops.object.collection_instance_add(collection=pieces.name, location=(0, 4 * k, 0))
        empties.append(bpy.context.object)
        empties[-1].rotation_euler = (0.0, 0.0, 0.5 * k)
    bpy.ops.mesh.primitive_cube_add(location=(-5, 0, 0))
    cube = bpy.context.object
    twin = bpy.data.objects.new("Twin", cube.data)
    bpy.context.scene.collection.objects.link(twin)
    twin.location, twin.scale = (-5, 5, 0), (1, 2, 0.5)
    exported = document()
    assert sorted(exported["meshes"]) == sorted([cone.data.name, cube.data.name])
    groups = {obj["mesh"]: obj for obj in exported["objects"] if obj["type"] == "instances"}
    assert len(groups) == 2 and all(obj["type"] != "mesh" for obj in exported["objects"])
    placed = sorted_rows(np.asarray(groups[cone.data.name]["matrices"]).reshape(-1, 3, 4))
    placements = [np.array(empty.matrix_world) @ np.array(cone.matrix_world) for empty in empties]
    expected = sorted_rows(np.array(placements)[:, :3])
    assert np.abs(placed - expected).max() < 1e-5
    placed = sorted_rows(np.asarray(groups[cube.data.name]["matrices"]).reshape(-1, 3, 4))
    expected = sorted_rows(np.array([np.array(obj.matrix_world)[:3] for obj in (cube, twin)]))
    assert np.abs(placed - expected).max() < 1e-5
    # the meshes table holds each mesh as its data-block has it, in its own space
    vertices = np.asarray(exported["meshes"][cone.data.name]["vertices"])
    assert np.abs(vertices - np.array([vertex.co for vertex in cone.data.vertices])).max() < 1e-6


def test_an_unchanged_scene_and_a_moved_object_read_no_geometry_again(reads: list) -> None:
    scatter(20, 10)
    bpy.ops.mesh.primitive_cube_add(location=(0, -8, 0))
    mover = bpy.context.object
    bpy.ops.mesh.primitive_monkey_add(location=(4, -8, 0))
    bpy.context.object.modifiers.new("Subdivision", "SUBSURF")
    first = document()
    assert len(reads) >= 3  # the sphere, the cube, Suzanne (and the forest's own empty mesh)
    reads.clear()
    assert document() == first
    assert reads == []
    mover.location.x += 1.5
    moved = document()
    assert reads == []
    cube = next(obj for obj in moved["objects"] if obj["name"] == mover.name)
    assert np.asarray(cube["vertices"]).mean(axis=0)[0] == pytest.approx(1.5, abs=1e-5)


def test_an_edited_mesh_is_read_again_with_its_new_geometry(reads: list) -> None:
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    twin = bpy.data.objects.new("Twin", cube.data)  # shared: in the meshes table
    bpy.context.scene.collection.objects.link(twin)
    twin.location = (4, 0, 0)
    bpy.ops.mesh.primitive_ico_sphere_add(location=(0, 5, 0))
    document()
    reads.clear()
    cube.data.vertices[1].co = (-1.0, -1.0, 3.0)  # through the mesh's data: Blender tags the mesh for an update
    edited = document()
    assert reads == [cube.name]  # the edited mesh only
    vertices = np.asarray(edited["meshes"][cube.data.name]["vertices"])
    assert vertices[:, 2].max() == pytest.approx(3.0, abs=1e-6)
    reads.clear()
    for obj in bpy.context.scene.objects:
        obj.select_set(obj == cube)  # edit mode takes every selected mesh with it
    bpy.context.view_layer.objects.active = cube
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.transform.translate(value=(0, 0, 1))
    bpy.ops.object.mode_set(mode="OBJECT")
    edited = document()
    assert reads == [cube.name]
    vertices = np.asarray(edited["meshes"][cube.data.name]["vertices"])
    assert vertices[:, 2].max() == pytest.approx(4.0, abs=1e-6)


def test_f12_again_and_frames_that_only_move_objects_read_no_geometry_again(tmp_path: Path, reads: list) -> None:
    scatter(12, 8, spacing=1.3)
    bpy.ops.mesh.primitive_cube_add(location=(0, -6, 0.5))
    mover = bpy.context.object
    mover.keyframe_insert("location", frame=1)
    mover.location.x = 3.0
    mover.keyframe_insert("location", frame=3)
    camera_and_sun()
    first = render_engine(tmp_path, "first", 32, 24)
    assert len(reads) >= 2
    document()  # the viewport's own (it evaluates modifiers with their viewport settings)
    reads.clear()
    again = render_engine(tmp_path, "again", 32, 24)
    assert reads == [] and np.array_equal(first, again)
    scene = bpy.context.scene
    scene.frame_set(2)  # the viewport depsgraph evaluates frame 2: only the mover changed
    document()
    render_engine(tmp_path, "frame2", 32, 24)
    assert reads == []
    # an animation render evaluates frames the viewport never saw: the forest is checked by a fingerprint of its
    # geometry, not read
    scene.frame_start, scene.frame_end = 1, 3
    scene.render.filepath = str(tmp_path / "frame")
    scene.render.image_settings.file_format = "PNG"
    assert bpy.ops.render.render(animation=True) == {"FINISHED"}
    assert reads == []


def test_f12_again_loads_only_what_changed_and_renders_as_a_fresh_load(tmp_path: Path) -> None:
    """The last F12's materials and objects are used again where the document says the same (export.F12_LOADED):
    after a colour edit and a move, F12's image is the one F12 makes with nothing kept."""
    for k in range(4):
        bpy.ops.mesh.primitive_cube_add(location=(2.5 * k - 4, 0, 0.5))
        material = bpy.data.materials.new(f"Paint{k}")
        material.diffuse_color = (0.2 * k, 0.5, 0.8 - 0.2 * k, 1.0)
        bpy.context.object.data.materials.append(material)
    camera_and_sun()
    first = render_engine(tmp_path, "first", 48, 36)
    scene = export.F12_LOADED.scene
    assert np.array_equal(render_engine(tmp_path, "again", 48, 36), first)
    assert export.F12_LOADED.scene is scene and export.F12_LOADED.reused == 4 + 4  # its materials and cubes
    paint = bpy.data.materials["Paint2"]
    if paint.node_tree is not None:  # new materials have nodes from Blender 5.0 on
        paint.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    paint.diffuse_color = (1.0, 0.0, 0.0, 1.0)
    bpy.data.objects["Cube.001"].location.z += 1.0
    edited = render_engine(tmp_path, "edited", 48, 36)
    assert export.F12_LOADED.scene is not scene and export.F12_LOADED.reused == 3 + 3
    export.F12_LOADED.clear()  # the same F12 with nothing kept: the truth for the one above
    fresh = render_engine(tmp_path, "fresh", 48, 36)
    assert np.array_equal(edited, fresh) and differing(edited, first) > 0.01


def test_geometry_that_changes_with_the_frame_is_read_at_each_frame(tmp_path: Path, reads: list) -> None:
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=12, y_subdivisions=12, size=4)
    grid = bpy.context.object
    grid.modifiers.new("Wave", "WAVE")  # moves the vertices with the time
    bpy.ops.mesh.primitive_cube_add(location=(5, 0, 0))
    scene = bpy.context.scene
    heights = []
    for frame in (1, 8, 15):
        scene.frame_set(frame)
        reads.clear()
        exported = document()
        assert reads == ([grid.name, "Cube"] if frame == 1 else [grid.name])
        heights.append(np.asarray(next(o for o in exported["objects"] if o["name"] == grid.name)["vertices"])[:, 2])
        evaluated = grid.evaluated_get(bpy.context.evaluated_depsgraph_get())
        blender = np.array([vertex.co.z for vertex in evaluated.data.vertices])
        assert np.sort(heights[-1]) == pytest.approx(np.sort(blender), abs=1e-6)
    assert not np.allclose(heights[0], heights[1]) and not np.allclose(heights[1], heights[2])


def test_materials_are_converted_once_until_they_change(monkeypatch) -> None:
    from addon.convert import material_convert

    for k in range(4):
        bpy.ops.mesh.primitive_cube_add(location=(3 * k, 0, 0))
        material = bpy.data.materials.new(f"Paint{k}")
        bpy.context.object.data.materials.append(material)
    converted: list[str] = []
    convert = material_convert.convert_material

    def counted(material, **options):
        converted.append(material.name if material is not None else "")
        return convert(material, **options)

    monkeypatch.setattr(material_convert, "convert_material", counted)
    document()
    assert sorted(name for name in converted if name) == [f"Paint{k}" for k in range(4)]
    converted.clear()
    notes = ExportNotes()
    first = document(notes)
    assert [name for name in converted if name] == [] and set(notes.materials) == {f"Paint{k}" for k in range(4)}
    bpy.data.materials["Paint2"].diffuse_color = (1.0, 0.0, 0.0, 1.0)
    changed = document()
    assert [name for name in converted if name] == ["Paint2"]
    assert changed["materials"]["blender:Paint1"] == first["materials"]["blender:Paint1"]
    # a scene setting that no conversion reads (an update of the scene in the depsgraph): none converted again
    converted.clear()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.engine = 1280, "WEATHERVANE_TRACER"
    document()
    assert [name for name in converted if name] == []
    scene.weathervane.model = "phong"  # the highlight model, which every conversion reads: all of them again
    document()
    assert sorted(name for name in converted if name) == [f"Paint{k}" for k in range(4)]


def test_the_vanes_own_material_on_an_object_of_the_users_follows_the_panels_colour() -> None:
    """Its conversion is kept between exports (the scene is watched for the add-on's own materials alone), yet a
    colour changed in the panel (which changes the material's nodes too) is the next export's colour."""
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    settings = bpy.context.scene.weathervane
    own = next(m for m in bpy.data.materials if m.get("weathervane_material") == settings.materials[0].name)
    bpy.ops.mesh.primitive_cube_add(location=(5.0, 0.0, 0.0))
    bpy.context.object.data.materials.append(own)
    before = document()["materials"][f"blender:{own.name}"]["color"]
    settings.materials[0].color = (0.9, 0.1, 0.2)
    after = document()["materials"][f"blender:{own.name}"]["color"]
    assert after != pytest.approx(before) and after == pytest.approx([0.9, 0.1, 0.2], abs=1e-6)


def test_an_instance_scaled_to_nothing_and_zero_area_triangles_are_left_out_and_named() -> None:
    mesh = bpy.data.meshes.new("Sliver")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0)], [], [(0, 1, 2), (3, 4, 5)])
    for k, scale in enumerate(((1, 1, 1), (2, 2, 2), (1, 0, 1))):
        obj = bpy.data.objects.new(f"Sliver{k}", mesh)
        obj.location, obj.scale = (0, 2 * k, 0), scale
        bpy.context.scene.collection.objects.link(obj)
    notes = ExportNotes()
    exported = document(notes)
    assert len(exported["meshes"]["Sliver"]["triangles"]) == 1
    group = next(obj for obj in exported["objects"] if obj["type"] == "instances")
    assert len(group["matrices"]) == 2  # the flattened one renders nothing in Blender; the tracer refuses it
    # the sliver of each of the two, and both triangles of the flattened one
    assert notes.dropped_triangles == {group["name"]: 4}
    scene_from_dict(exported)  # loads


def test_the_handlers_come_and_go_with_the_add_on() -> None:
    assert export._on_depsgraph_update in bpy.app.handlers.depsgraph_update_post
    assert mesh_export.CACHE.enabled
    import addon

    addon.unregister()
    try:
        assert export._on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post
        assert not mesh_export.CACHE.enabled and not mesh_export.CACHE.entries
    finally:
        addon.register()


class Mesh:
    """A stand-in for a depsgraph update's ID (the cache reads its type's name and its pointer)."""

    original = None

    def __init__(self, pointer: int) -> None:
        self.pointer = pointer

    def as_pointer(self) -> int:
        return self.pointer


def test_an_evaluation_seen_by_view_update_and_then_by_the_handler_counts_once() -> None:
    """Blender calls the engine's view_update inside the evaluation and the depsgraph handlers after it: what the
    view's export read in between must stay valid; the next evaluation with the same change must not."""
    from types import SimpleNamespace

    cache = mesh_export.GeometryCache()
    cache.enabled = True
    scene = SimpleNamespace(frame_current=1, frame_subframe=0.0)
    depsgraph = SimpleNamespace(
        mode="VIEWPORT",
        updates=[SimpleNamespace(id=Mesh(42), is_updated_geometry=True)],
        scene_eval=scene,
        as_pointer=lambda: 7,
    )
    cache.observe(depsgraph, from_view_update=True)
    stamp = cache.clock  # the view's export begins
    assert cache.valid((42,), stamp)
    cache.observe(depsgraph)  # the handler, for the same evaluation
    assert cache.valid((42,), stamp)
    cache.observe(depsgraph)  # a later evaluation that changed the mesh again
    assert not cache.valid((42,), stamp)
    render = SimpleNamespace(**{**vars(depsgraph), "mode": "RENDER"})
    stamp = cache.clock
    cache.observe(render)  # a render depsgraph is new each time and reports everything: it says nothing
    assert cache.valid((42,), stamp)


def test_an_instanced_scenes_document_follows_the_schema() -> None:
    import json

    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads((Path(__file__).resolve().parents[2] / "docs" / "scene.schema.json").read_text())
    scatter(4, 3)
    bpy.ops.mesh.primitive_monkey_add(location=(0, -4, 0))
    suzanne = bpy.context.object
    suzanne.data.materials.append(bpy.data.materials.new("Skin"))
    suzanne.data.materials.append(bpy.data.materials.new("Eyes"))
    suzanne.data.polygons[0].material_index = 1
    twin = bpy.data.objects.new("Twin", suzanne.data)  # per-triangle materials in the meshes table
    bpy.context.scene.collection.objects.link(twin)
    twin.location = (3, -4, 0)
    exported = json.loads(json.dumps(document()))
    assert {obj["type"] for obj in exported["objects"]} == {"instances"}
    assert any("material_indices" in mesh for mesh in exported["meshes"].values())
    jsonschema.validate(exported, schema)
    scene_from_dict(exported)  # and the tracer loads it


def test_the_document_reaches_the_loader_as_json_would_give_it_without_the_round_trip() -> None:
    """export.as_json_types (what F12 hands the loader) equals json.loads(json.dumps(...)) of the document: the
    built vane's and an instanced scene's, with tuples anywhere turned into lists."""
    import json

    bpy.ops.weathervane.build()
    scatter(20, 10)
    camera_and_sun()
    built = document()
    built["extra"] = {"pair": (1.0, 2.0), "nested": [(1, 2), {"t": ((0.5, 0.25), "x")}]}
    assert export.as_json_types(built) == json.loads(json.dumps(built))
    assert any(obj.get("type") == "instances" for obj in built["objects"])


def test_geometry_nodes_instances_read_at_once_are_the_instances_read_one_by_one(monkeypatch) -> None:
    """Where Blender hands an object's Geometry Nodes instances over at once (4.3+), the export reads their matrices
    so (not one by one from the depsgraph), and the document holds the same placements as the one-by-one walk."""
    scatter(50, 40)  # 2,000 spheres
    used = []
    bulk = export._bulk_matrices
    monkeypatch.setattr(export, "_bulk_matrices", lambda *args: used.append(bulk(*args)) or used[-1])
    at_once = document()
    monkeypatch.setattr(export, "BULK_INSTANCES", 10**9)
    one_by_one = document()
    if hasattr(bpy.types.Object, "evaluated_geometry"):
        assert any(matrices is not None and len(matrices) == 2000 for matrices in used)
    assert at_once["meshes"].keys() == one_by_one["meshes"].keys()
    groups = [[obj for obj in doc["objects"] if obj["type"] == "instances"] for doc in (at_once, one_by_one)]
    assert [len(group) for group in groups] == [1, 1]
    placed = [sorted_rows(np.asarray(group[0]["matrices"], dtype=np.float64).reshape(-1, 3, 4)) for group in groups]
    assert placed[0].shape == (2000, 12)
    np.testing.assert_allclose(placed[0], placed[1], rtol=0, atol=1e-5)
