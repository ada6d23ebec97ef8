"""Scenes nobody on the team built: ordinary bpy calls from factory settings, never the add-on's Build.

Each builder takes nothing, builds into bpy.context.scene (already reset to empty factory settings), sets a camera,
a small resolution and a frame range, and returns a Built that says what the acceptance tests measure on it
(tests/addon/test_foreign_scenes.py renders each with the engine and with Cycles), in two parts: geometry,
frames and visibility; materials, lights and world.

The API differences between Blender 3.4 and 5.0 that matter here go through addon/compat.py (read only) or the two
small helpers below (Geometry Nodes group sockets, Principled inputs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

try:
    import bpy
    from mathutils import Vector
except ImportError:  # tests/test_foreign_scenes_blender34.py reads only the case names, outside Blender
    bpy = Vector = None

WIDTH, HEIGHT = 96, 72


@dataclass
class Built:
    """What a test measures on a built scene."""

    frames: tuple[int, ...] = (1,)  # frames rendered (centroid tests render each, F12 and animation)
    track: bool = False  # centroid of the whole coverage mask per frame (the scene has one moving object)
    transparent: bool = True  # film transparent (the coverage mask is Cycles' alpha)
    bounces: int | None = None  # Cycles' max bounces where the comparison needs direct light only (0)
    samples: int = 16  # Cycles samples
    patches: dict = field(default_factory=dict)  # name -> world point: mean colour of a 3x3 patch there
    isolate: bool = False  # the engine renders it in a Blender process of its own (it has crashed Blender)
    notes: str = ""


# ---------------------------------------------------------------------------------------------------- helpers


def _frame(first: int = 1, last: int = 1, width: int = WIDTH, height: int = HEIGHT) -> None:
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.frame_start, scene.frame_end = first, last
    scene.frame_set(first)
    scene.world = None  # no world: Cycles renders black where rays miss


def _camera(location, target=(0.0, 0.0, 0.0), lens: float = 50.0, name: str = "Camera"):
    data = bpy.data.cameras.new(name)
    data.lens = lens
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    direction = Vector(target) - Vector(location)
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = obj
    return obj


def _ortho_camera(location, target, scale: float):
    obj = _camera(location, target)
    obj.data.type = "ORTHO"
    obj.data.ortho_scale = scale
    return obj


def _sun(rotation=(40.0, 10.0, 30.0), strength: float = 3.0, color=(1.0, 1.0, 1.0), name: str = "Sun"):
    data = bpy.data.lights.new(name, "SUN")
    data.energy = strength
    data.color = color
    data.angle = 0.0  # a hard sun: Cycles' direct light is then noise-free
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    obj.rotation_euler = [math.radians(angle) for angle in rotation]
    return obj


def _add(operator, **arguments):
    """A primitive through its bpy.ops operator (as a user adds it); returns the new object."""
    operator(**arguments)
    return bpy.context.active_object


def _material(name: str, color=(0.8, 0.8, 0.8), kind: str = "DIFFUSE", **inputs):
    """A material whose output is one shader node: DIFFUSE, PRINCIPLED (inputs by role: metallic, roughness,
    specular) or EMISSION (strength). The Viewport Display colour is left at its default on purpose."""
    from addon.compat import enable_nodes, principled_socket

    material = bpy.data.materials.new(name)
    enable_nodes(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    rgba = (*color, 1.0)
    if kind == "DIFFUSE":
        shader = nodes.new("ShaderNodeBsdfDiffuse")
        shader.inputs["Color"].default_value = rgba
    elif kind == "EMISSION":
        shader = nodes.new("ShaderNodeEmission")
        shader.inputs["Color"].default_value = rgba
        shader.inputs["Strength"].default_value = inputs.get("strength", 1.0)
    else:
        shader = nodes.new("ShaderNodeBsdfPrincipled")
        shader.inputs["Base Color"].default_value = rgba
        shader.inputs["Metallic"].default_value = inputs.get("metallic", 0.0)
        shader.inputs["Roughness"].default_value = inputs.get("roughness", 0.5)
        principled_socket(shader, "specular").default_value = inputs.get("specular", 0.5)
    links.new(shader.outputs[0], output.inputs["Surface"])
    return material


def _assign(obj, *materials) -> None:
    for material in materials:
        obj.data.materials.append(material)


def _world(color, strength: float = 1.0) -> None:
    world = bpy.data.worlds.new("World")
    if bpy.app.version < (5, 0, 0):  # a node tree is always there from 5.0 (use_nodes is deprecated)
        world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    bpy.context.scene.world = world


def _smooth(obj) -> None:
    """Shade Smooth, as the operator does, without the 4.1+ operator's extra modifiers."""
    mesh = obj.data
    mesh.polygons.foreach_set("use_smooth", [True] * len(mesh.polygons))
    mesh.update()


def _ground(size: float = 12.0, z: float = 0.0):
    return _add(bpy.ops.mesh.primitive_plane_add, size=size, location=(0.0, 0.0, z))


def _geometry_nodes_group(name: str):
    """An empty Geometry Nodes group with one geometry input and output (5.0: interface; 3.4: inputs/outputs)."""
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    if hasattr(group, "interface"):
        group.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:
        group.inputs.new("NodeSocketGeometry", "Geometry")
        group.outputs.new("NodeSocketGeometry", "Geometry")
    return group


def _key(obj, data_path: str, frames_values: list[tuple[int, object]]) -> None:
    """Keyframes as a user sets them (value, then Insert Keyframe), Blender's default interpolation."""
    for frame, value in frames_values:
        setattr(obj, data_path, value)
        obj.keyframe_insert(data_path, frame=frame)


# -------------------------------------------------------------------------------- geometry, frames and visibility


def keyed_cube() -> Built:
    """A cube keyed from x=0 at frame 1 to x=3 at frame 5 (Bezier keys, as the UI makes them)."""
    _frame(1, 5)
    cube = _add(bpy.ops.mesh.primitive_cube_add, size=1.4)
    _key(cube, "location", [(1, (0.0, 0.0, 0.0)), (5, (3.0, 0.0, 0.0))])
    _camera((1.5, -8.0, 3.0), (1.5, 0.0, 0.0))
    bpy.context.scene.frame_set(1)
    return Built(frames=(1, 2, 3, 4, 5), track=True)


def keyed_camera() -> Built:
    """A still cylinder, the camera keyed sideways and turning over frames 1-5."""
    _frame(1, 5)
    _add(bpy.ops.mesh.primitive_cylinder_add, radius=0.6, depth=1.5)
    camera = _camera((0.0, -8.0, 2.0))
    start = camera.rotation_euler.copy()
    _key(camera, "location", [(1, (-2.0, -8.0, 2.0)), (5, (2.0, -7.0, 3.0))])
    _key(camera, "rotation_euler", [(1, start), (5, (start[0], start[1], start[2] + math.radians(8.0)))])
    bpy.context.scene.frame_set(1)
    return Built(frames=(1, 2, 3, 4, 5), track=True)


def parented_child() -> Built:
    """A cone parented to an empty that turns 90 degrees about z over frames 1-5 (the empty itself is not drawn)."""
    _frame(1, 5)
    parent = bpy.data.objects.new("Turntable", None)
    bpy.context.scene.collection.objects.link(parent)
    child = _add(bpy.ops.mesh.primitive_cone_add, radius1=0.9, depth=1.5, location=(2.0, 0.0, 0.0))
    child.parent = parent
    _key(parent, "rotation_euler", [(1, (0.0, 0.0, 0.0)), (5, (0.0, 0.0, math.radians(90.0)))])
    _camera((0.0, -3.0, 9.0), (0.0, 0.0, 0.0))
    bpy.context.scene.frame_set(1)
    return Built(frames=(1, 2, 3, 4, 5), track=True)


def text_object() -> Built:
    _frame()
    text = _add(bpy.ops.object.text_add, location=(-1.6, 0.0, 0.0))
    text.data.body = "Vane"
    text.data.extrude = 0.1
    text.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    _camera((0.0, -6.0, 0.6), (0.0, 0.0, 0.35))
    return Built()


def bevelled_curve() -> Built:
    _frame()
    curve = _add(bpy.ops.curve.primitive_bezier_circle_add, radius=1.5)
    curve.data.bevel_depth = 0.25
    curve.rotation_euler = (math.radians(60.0), 0.0, 0.0)
    _camera((0.0, -8.0, 2.0))
    return Built()


def metaball() -> Built:
    _frame()
    ball = _add(bpy.ops.object.metaball_add, type="BALL", radius=1.0)
    element = ball.data.elements.new()
    element.co = (1.2, 0.0, 0.3)
    element.radius = 0.8
    _camera((0.5, -7.0, 2.0), (0.5, 0.0, 0.0))
    return Built()


def nurbs_surface() -> Built:
    _frame()
    _add(bpy.ops.surface.primitive_nurbs_surface_torus_add, radius=1.0)
    _camera((0.0, -6.0, 4.0))
    return Built()


def collection_instance() -> Built:
    """A collection (not in the scene) holding a cube and a cone, instanced twice by empties."""
    _frame()
    props = bpy.data.collections.new("Props")
    for obj in (
        _add(bpy.ops.mesh.primitive_cube_add, size=0.8),
        _add(bpy.ops.mesh.primitive_cone_add, radius1=0.4, depth=1.0, location=(0.0, 0.0, 0.9)),
    ):
        props.objects.link(obj)
        bpy.context.scene.collection.objects.unlink(obj)
    for location, turn in (((-1.2, 0.0, 0.0), 0.0), ((1.4, 0.5, 0.2), 35.0)):
        empty = bpy.data.objects.new("Instance", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = props
        empty.location = location
        empty.rotation_euler = (0.0, 0.0, math.radians(turn))
        bpy.context.scene.collection.objects.link(empty)
    _camera((0.0, -7.0, 3.0), (0.0, 0.0, 0.3))
    return Built()


def vertex_instancing() -> Built:
    """A plane whose four vertices instance its child cone (Instancing: Vertices)."""
    _frame()
    parent = _add(bpy.ops.mesh.primitive_plane_add, size=3.0)
    child = _add(bpy.ops.mesh.primitive_cone_add, radius1=0.35, depth=0.8, location=(0.0, 0.0, 0.0))
    child.parent = parent
    parent.instance_type = "VERTS"
    _camera((0.0, -7.0, 5.0))
    return Built()


def geometry_nodes_instances() -> Built:
    """Geometry Nodes: a cube instanced on each vertex of a grid (Instance on Points)."""
    _frame()
    grid = _add(bpy.ops.mesh.primitive_grid_add, x_subdivisions=3, y_subdivisions=3, size=3.0)
    group = _geometry_nodes_group("Cubes on points")
    nodes, links = group.nodes, group.links
    source, sink = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    instance, cube = nodes.new("GeometryNodeInstanceOnPoints"), nodes.new("GeometryNodeMeshCube")
    cube.inputs["Size"].default_value = (0.4, 0.4, 0.4)
    links.new(source.outputs[0], instance.inputs["Points"])
    links.new(cube.outputs["Mesh"], instance.inputs["Instance"])
    links.new(instance.outputs["Instances"], sink.inputs[0])
    grid.modifiers.new("Geometry Nodes", "NODES").node_group = group
    _camera((0.0, -6.0, 5.0))
    return Built()


def smooth_suzanne() -> Built:
    """Suzanne, Subdivision (render level 2) and Shade Smooth, a white Diffuse BSDF under a sun; Cycles direct
    light only (max bounces 0), so the shading differs only by the normals."""
    _frame()
    monkey = _add(bpy.ops.mesh.primitive_monkey_add, size=2.0)
    subdivision = monkey.modifiers.new("Subdivision", "SUBSURF")
    subdivision.levels, subdivision.render_levels = 1, 2
    _smooth(monkey)
    _assign(monkey, _material("Clay", (0.8, 0.8, 0.8)))
    _sun(rotation=(50.0, 0.0, 20.0), strength=2.0)
    _camera((0.0, -6.0, 0.5))
    return Built(bounces=0)


def flat_suzanne() -> Built:
    """smooth_suzanne with Shade Flat: Cycles' own smooth-vs-flat difference, the scale of the smooth test."""
    built = smooth_suzanne()
    monkey = bpy.data.objects["Suzanne"]
    monkey.data.polygons.foreach_set("use_smooth", [False] * len(monkey.data.polygons))
    monkey.data.update()
    return built


def mirrored_object() -> Built:
    """Suzanne (left-right symmetric) twice: as modelled on the left, scale x = -1 on the right. In Blender both
    shade alike; wound inward, the mirrored one would render black."""
    _frame()
    clay = _material("Clay", (0.8, 0.8, 0.8))
    for x, scale in ((-1.3, 1.0), (1.3, -1.0)):
        monkey = _add(bpy.ops.mesh.primitive_monkey_add, size=1.6, location=(x, 0.0, 0.0))
        monkey.scale = (scale, 1.0, 1.0)
        monkey.name = "Mirrored" if scale < 0 else "Original"
        _assign(monkey, clay)
    _sun(rotation=(50.0, 0.0, 0.0), strength=2.0)  # lit from the front, symmetric about x = 0
    _camera((0.0, -7.0, 0.5))
    return Built(bounces=0)


def per_face_materials() -> Built:
    """A cube with two material slots, red on +x, +y, +z faces... alternating, a sun; the Viewport Display colours
    are set too so that the per-face test does not depend on the materials' node-tree mapping."""
    _frame()
    cube = _add(bpy.ops.mesh.primitive_cube_add, size=2.0)
    red, blue = _material("Red", (0.8, 0.05, 0.05)), _material("Blue", (0.05, 0.1, 0.8))
    red.diffuse_color, blue.diffuse_color = (0.8, 0.05, 0.05, 1.0), (0.05, 0.1, 0.8, 1.0)
    _assign(cube, red, blue)
    for polygon in cube.data.polygons:
        polygon.material_index = polygon.index % 2
    cube.rotation_euler = (math.radians(20.0), math.radians(-10.0), math.radians(35.0))
    _sun(rotation=(30.0, 20.0, 60.0), strength=3.0)
    _world((0.3, 0.3, 0.3))  # every face lit a little, so none is black in Cycles
    _camera((0.0, -7.0, 2.0))
    return Built(bounces=0)


def _visibility_stage():
    """A ground, a sphere and a cube, seen from above at an angle: the visibility scenes hide parts of it."""
    _frame()
    _ground(size=6.0, z=-1.0)
    sphere = _add(bpy.ops.mesh.primitive_uv_sphere_add, radius=0.9, location=(-1.0, 0.0, 0.0))
    cube = _add(bpy.ops.mesh.primitive_cube_add, size=1.4, location=(1.2, 0.3, -0.3))
    _camera((0.0, -8.0, 4.0), (0.0, 0.0, -0.5))
    return sphere, cube


def _move_to_collection(obj, name: str):
    collection = bpy.data.collections.get(name) or bpy.data.collections.new(name)
    if collection.name not in bpy.context.scene.collection.children:
        bpy.context.scene.collection.children.link(collection)
    for owner in obj.users_collection:
        owner.objects.unlink(obj)
    collection.objects.link(obj)
    return collection


def excluded_collection() -> Built:
    """The sphere and a bright point light in a collection excluded from the view layer (the checkbox); the rest is
    white Diffuse under a sun (Cycles direct light only): the excluded light must light nothing."""
    sphere, cube = _visibility_stage()
    clay = _material("Clay", (0.8, 0.8, 0.8))
    for obj in (sphere, cube, bpy.data.objects["Plane"]):
        _assign(obj, clay)
    _sun(rotation=(30.0, 0.0, 20.0), strength=2.0)
    collection = _move_to_collection(sphere, "Excluded")
    light = bpy.data.objects.new("Excluded light", bpy.data.lights.new("Excluded light", "POINT"))
    light.data.energy = 1000.0
    light.location = (0.0, -2.0, 1.0)
    collection.objects.link(light)
    bpy.context.view_layer.layer_collection.children["Excluded"].exclude = True
    return Built(bounces=0)


def collection_disabled_in_renders() -> Built:
    """The cube in a collection with Disable in Renders (the camera icon)."""
    _, cube = _visibility_stage()
    _move_to_collection(cube, "Not rendered").hide_render = True
    return Built()


def camera_ray_visibility_off() -> Built:
    """The sphere with Object Properties > Visibility > Ray Visibility > Camera off (it still casts shadows)."""
    sphere, _ = _visibility_stage()
    sphere.visible_camera = False
    return Built()


def holdout_object() -> Built:
    """The cube as a holdout: alpha 0 where it covers, hiding what is behind it."""
    _, cube = _visibility_stage()
    cube.is_holdout = True
    return Built()


def holdout_collection() -> Built:
    """The cube in a collection set to Holdout in the view layer (the Outliner's toggle): alpha 0 where it covers."""
    _, cube = _visibility_stage()
    _move_to_collection(cube, "Masks")
    bpy.context.view_layer.layer_collection.children["Masks"].holdout = True
    return Built()


def indirect_only_collection() -> Built:
    """A sphere over a white ground under a sun, in a collection set to Indirect Only in the view layer: the camera
    sees the ground through it, and its shadow stays."""
    _frame()
    clay = _material("Clay", (0.8, 0.8, 0.8))
    _assign(_ground(size=8.0), clay)
    sphere = _add(bpy.ops.mesh.primitive_uv_sphere_add, radius=0.8, location=(0.0, 0.0, 1.2))
    _assign(sphere, clay)
    _move_to_collection(sphere, "Ghosts")
    bpy.context.view_layer.layer_collection.children["Ghosts"].indirect_only = True
    _sun(rotation=(35.0, 0.0, 30.0), strength=2.0)
    _camera((0.0, -7.0, 4.0), (0.0, 0.0, 0.4))
    return Built(bounces=0)


def film_transparent() -> Built:
    """The stage with Film > Transparent: alpha 0 wherever camera rays miss (the ground does not fill the frame)."""
    _visibility_stage()
    return Built()


def back_facing_plane() -> Built:
    """Two planes side by side under a sun from the camera's side: the left one's normal faces the camera, the right
    one's faces away (flipped). Blender shades both sides alike (two-sided shading for Blender's meshes)."""
    _frame()
    clay = _material("Clay", (0.8, 0.8, 0.8))
    for x, turn in ((-1.1, 90.0), (1.1, -90.0)):
        plane = _add(bpy.ops.mesh.primitive_plane_add, size=2.0, location=(x, 0.0, 0.0))
        plane.rotation_euler = (math.radians(turn), 0.0, 0.0)  # +90: normal toward -y (the camera); -90: away
        _assign(plane, clay)
    _sun(rotation=(60.0, 0.0, 0.0), strength=2.0)  # from -y, above: toward the camera's side of both planes
    _camera((0.0, -6.0, 0.0))
    return Built(bounces=0)


def viewport_disabled_moved() -> Built:
    """A cube set to Disable in Viewports, then moved from x = -1.5 to x = 1.5: Blender renders it where it now is."""
    _frame()
    cube = _add(bpy.ops.mesh.primitive_cube_add, size=1.2, location=(-1.5, 0.0, 0.0))
    bpy.context.view_layer.update()
    cube.hide_viewport = True
    cube.location = (1.5, 0.0, 0.0)
    _add(bpy.ops.mesh.primitive_uv_sphere_add, radius=0.6, location=(0.0, 1.0, 0.0))
    _camera((0.0, -7.0, 2.0))
    return Built()


def shadow_ray_visibility_off() -> Built:
    """A sphere over a white ground under a sun, the sphere's Ray Visibility > Shadow off: no shadow on the ground."""
    _frame()
    clay = _material("Clay", (0.8, 0.8, 0.8))
    _assign(_ground(size=8.0), clay)
    sphere = _add(bpy.ops.mesh.primitive_uv_sphere_add, radius=0.8, location=(0.0, 0.0, 1.2))
    _assign(sphere, clay)
    sphere.visible_shadow = False
    _sun(rotation=(35.0, 0.0, 30.0), strength=2.0)
    _camera((0.0, -7.0, 4.0), (0.0, 0.0, 0.4))
    return Built(bounces=0)


def render_border() -> Built:
    """Render Region (border) on, Crop to Render Region off: the full-size image, traced only inside the region."""
    _visibility_stage()
    render = bpy.context.scene.render
    render.use_border, render.use_crop_to_border = True, False
    render.border_min_x, render.border_max_x, render.border_min_y, render.border_max_y = 0.2, 0.7, 0.25, 0.9
    return Built(isolate=True)  # with crop, bpy 5.0.1 crashed (segmentation fault) in the engine's render


def render_border_cropped() -> Built:
    """Render Region with Crop to Render Region: the image is the region's size."""
    built = render_border()
    bpy.context.scene.render.use_crop_to_border = True
    return built


def degenerate_triangle() -> Built:
    """A mesh of two quads and one zero-area triangle (two of its corners at one place): Blender renders the quads."""
    _frame()
    mesh = bpy.data.meshes.new("Sliver")
    vertices = [(-1, 0, -1), (0, 0, -1), (0, 0, 1), (-1, 0, 1), (1, 0, -1), (1, 0, 1), (2, 0, 0), (3, 0, 0), (2, 0, 0)]
    faces = [(0, 1, 2, 3), (1, 4, 5, 2), (6, 7, 8)]
    mesh.from_pydata(vertices, [], faces)
    mesh.update()
    obj = bpy.data.objects.new("Sliver", mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.rotation_euler = (0.0, 0.0, math.radians(20.0))
    _camera((0.5, -6.0, 1.5), (0.5, 0.0, 0.0))
    return Built()


def mesh_without_faces() -> Built:
    """The only mesh is a wire square (vertices and edges, no faces): Blender renders the empty world."""
    _frame()
    mesh = bpy.data.meshes.new("Wire")
    mesh.from_pydata([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)], [(0, 1), (1, 2), (2, 3), (3, 0)], [])
    mesh.update()
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Wire", mesh))
    _camera((0.0, -6.0, 0.0))
    return Built()


# ------------------------------------------------------------------------------------ materials, lights and world


def red_principled_sphere() -> Built:
    """A red Principled BSDF sphere (roughness 1, specular 0: diffuse) under an orange sun, no world."""
    _frame()
    sphere = _add(bpy.ops.mesh.primitive_uv_sphere_add, segments=48, ring_count=24, radius=1.0)
    _smooth(sphere)
    _assign(sphere, _material("Red", (0.8, 0.05, 0.05), "PRINCIPLED", roughness=1.0, specular=0.0))
    _sun(rotation=(35.0, 0.0, 30.0), strength=2.0, color=(1.0, 0.7, 0.4))
    _camera((0.0, -6.0, 0.0))
    return Built(bounces=0, samples=32)


def _light_on_plane(kind: str, watts: float, height: float) -> Built:
    """A white Diffuse plane (0.8), a point or spot light of `watts` at `height` above its centre, radius 0 (a hard
    light, noise-free in Cycles), no world; seen straight down by an orthographic camera. Patches: under the light
    (distance height) and 1.5*height to the side (distance 1.8*height)."""
    _frame()
    plane = _ground(size=80.0)
    _assign(plane, _material("White", (0.8, 0.8, 0.8)))
    data = bpy.data.lights.new(f"{kind.title()} {watts:g} W", kind)
    data.energy = watts
    data.shadow_soft_size = 0.0
    if kind == "SPOT":
        data.spot_size = math.radians(120.0)  # the cone's full angle: 60 degrees either side of the axis
        data.spot_blend = 0.15
    light = bpy.data.objects.new(data.name, data)
    light.location = (0.0, 0.0, height)  # pointing down (-z), as a new light does
    bpy.context.scene.collection.objects.link(light)
    _ortho_camera((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), scale=8.0 * height)
    near, far = (0.0, 0.0, 0.0), (1.5 * height, 0.0, 0.0)
    return Built(bounces=0, transparent=False, patches={"near": near, "far": far})


def point_light_100w() -> Built:
    return _light_on_plane("POINT", 100.0, 2.0)


def point_light_1000w() -> Built:
    return _light_on_plane("POINT", 1000.0, 6.0)


def spot_light_100w() -> Built:
    return _light_on_plane("SPOT", 100.0, 2.0)


def spot_light_1000w() -> Built:
    return _light_on_plane("SPOT", 1000.0, 6.0)


def light_ray_visibility() -> Built:
    """point_light_100w with its light's Glossy ray visibility off, and a 3 W/m^2 sun whose Diffuse ray visibility is
    off: the matte plane is lit by the point light alone (the sun would double it), as in Cycles."""
    built = _light_on_plane("POINT", 100.0, 2.0)
    bpy.data.objects["Point 100 W"].visible_glossy = False
    sun = _sun(rotation=(20.0, 0.0, 0.0), strength=3.0)
    sun.visible_diffuse = False
    built.samples = 512  # Cycles still picks the sun for its light samples and gets nothing: noise, 16 samples 15%
    return built


def spot_light_stretched() -> Built:
    """spot_light_100w with the light scaled (1.6, 0.6, 1) and turned 30 degrees about z: Cycles 4+ stretches the
    cone into an ellipse along the light's x (3.4's stays round)."""
    built = _light_on_plane("SPOT", 100.0, 2.0)
    light = bpy.data.objects["Spot 100 W"]
    light.scale, light.rotation_euler = (1.6, 0.6, 1.0), (0.0, 0.0, math.radians(30.0))
    return built


def emission_plane() -> Built:
    """A plane with an Emission shader only (colour (0.2, 0.5, 0.8), strength 1), no lights, no world."""
    _frame()
    plane = _add(bpy.ops.mesh.primitive_plane_add, size=2.0, rotation=(math.radians(90.0), 0.0, 0.0))
    _assign(plane, _material("Glow", (0.2, 0.5, 0.8), "EMISSION", strength=1.0))
    _camera((0.3, -5.0, 0.5), (0.0, 0.0, 0.0))
    return Built(samples=16)


def world_colour() -> Built:
    """A world Background (0.05, 0.15, 0.3) x strength 2, a grey cube lit by it alone; film not transparent."""
    _frame()
    _world((0.05, 0.15, 0.3), strength=2.0)
    _add(bpy.ops.mesh.primitive_cube_add, size=1.0)
    _camera((3.0, -5.0, 2.0))
    return Built(transparent=False, samples=16)


def mirror_scene() -> Built:
    """A Principled metallic 1, roughness 0, white floor (a perfect mirror), a red and a green emission cube on it,
    a blue world; no lights: every pixel is either an emission, the world or their reflection (noise-free)."""
    _frame()
    floor = _ground(size=8.0)
    _assign(floor, _material("Mirror", (1.0, 1.0, 1.0), "PRINCIPLED", metallic=1.0, roughness=0.0))
    for location, color, turn in (((-1.0, 0.5, 0.6), (0.9, 0.1, 0.1), 20.0), ((1.2, -0.3, 0.4), (0.1, 0.8, 0.2), 50.0)):
        cube = _add(bpy.ops.mesh.primitive_cube_add, size=0.8, location=location)
        cube.rotation_euler = (0.0, 0.0, math.radians(turn))
        _assign(cube, _material("Glow", color, "EMISSION", strength=1.0))
    _world((0.1, 0.2, 0.45), strength=1.0)
    _camera((0.0, -7.0, 2.5), (0.0, 0.0, 0.3))
    return Built(transparent=False, samples=16)


def glossy_ray_visibility_off() -> Built:
    """mirror_scene with the red cube's Ray Visibility > Glossy off: it is seen, but not in the mirror."""
    built = mirror_scene()
    next(obj for obj in bpy.data.objects if obj.name.startswith("Cube")).visible_glossy = False
    return built


def factory_startup() -> Built:
    """Blender's factory startup scene (cube, 1000 W point light, camera, grey world) at 5% of its 1920x1080."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    scene.render.resolution_percentage = 5  # 96x54: the scene itself is as Blender starts
    return Built(transparent=False, samples=32)


# ---------------------------------------------------------------------------------------------------- the cases

SCENES = {
    builder.__name__: builder
    for builder in (
        keyed_cube,
        keyed_camera,
        parented_child,
        text_object,
        bevelled_curve,
        metaball,
        nurbs_surface,
        collection_instance,
        vertex_instancing,
        geometry_nodes_instances,
        smooth_suzanne,
        flat_suzanne,
        mirrored_object,
        per_face_materials,
        excluded_collection,
        collection_disabled_in_renders,
        camera_ray_visibility_off,
        holdout_object,
        holdout_collection,
        indirect_only_collection,
        film_transparent,
        back_facing_plane,
        viewport_disabled_moved,
        shadow_ray_visibility_off,
        render_border,
        render_border_cropped,
        degenerate_triangle,
        mesh_without_faces,
        red_principled_sphere,
        point_light_100w,
        point_light_1000w,
        spot_light_100w,
        spot_light_1000w,
        spot_light_stretched,
        light_ray_visibility,
        emission_plane,
        world_colour,
        mirror_scene,
        glossy_ray_visibility_off,
        factory_startup,
    )
}

# which scenes each acceptance check runs on (tests/addon/test_foreign_scenes.py)
KEYED = ["keyed_cube", "keyed_camera", "parented_child"]
VISIBILITY = [
    "excluded_collection",
    "collection_disabled_in_renders",
    "camera_ray_visibility_off",
    "holdout_object",
    "holdout_collection",
    "indirect_only_collection",
    "film_transparent",
]
COVERAGE = [
    "viewport_disabled_moved",
    *KEYED,
    "text_object",
    "bevelled_curve",
    "metaball",
    "nurbs_surface",
    "collection_instance",
    "vertex_instancing",
    "geometry_nodes_instances",
    "smooth_suzanne",
    "mirrored_object",
    "per_face_materials",
    *VISIBILITY,
    "render_border",
    "render_border_cropped",
    "degenerate_triangle",
    "mesh_without_faces",
]
LIGHTS = ["point_light_100w", "point_light_1000w", "spot_light_100w", "spot_light_1000w", "light_ray_visibility"]
SPOTS = ["spot_light_100w", "spot_light_1000w", "spot_light_stretched"]
