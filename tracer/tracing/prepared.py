"""A scene -> what tracing it needs, prepared once: the objects' kernels and hierarchies (one per kind of ray,
Blender's ray visibility), the material table and each hit's row in it, the prepared lights and their culling grids,
the camera's screen rectangles, smooth normals' and textures' corner arrays. The stages (shading, shadows,
see_through, wavefront) read it; nothing here traces a pixel."""

from __future__ import annotations

import functools
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.bvh import Hierarchy
from ..geometry.cull import ScreenRectangles
from ..geometry.instances import InstancesKernel, local_mesh_kernel
from ..geometry.kernels import (
    Kernel,
    PlaneKernel,
    SphereKernel,
    column,
    indices,
    make_kernel,
    quiet,
    take,
    unit,
)
from ..geometry.meshbvh import MESH_HIERARCHY_TRIANGLES, MergedMember, MergedMeshKernel, MeshKernel
from ..geometry.robust import make_robust_kernel
from ..scene import scene as sc
from ..scene import world_light
from . import emitters
from .lights import DirectedLight, PreparedLight, directed, prepare_lights
from .rays import CAMERA_T_MIN
from .recorder import view_axis

# this many still triangle meshes seen by the same rays go into the scene's hierarchy as one kernel (their
# triangles behind one hierarchy, MergedMeshKernel): 3,000 cubes as separate objects took 16x the time of the same
# triangles as one mesh, walking the scene's hierarchy node by node in Python. Below it (the default vane's 13
# objects) a leaf per object, as the small scenes' benchmarks were tuned
MERGE_MESHES_FROM = 64
MERGE_SIZE_FACTOR = 8.0  # merged: meshes at most this many times the group's median size (their boxes' longest side)


@dataclass(frozen=True)
class _Placed:
    """The objects as traced (a vane's part once per heading where several are traced at once), their world
    primitives, the frame each one's rays belong to (-1: every frame's; None without headings), the vane that places
    each, and which of them are the vane's parts (None: no vane), which the hierarchies keep in a subtree of their
    own (the rest kept between an animation's frames, bvh.py)."""

    objects: tuple[sc.SceneObject, ...]
    primitives: list[tf.WorldPrimitive]
    frame_of: list[int] | None
    vanes: list[sc.Vane | None]
    moving: frozenset[int] | None


@dataclass(eq=False)
class PreparedScene:
    """What tracing needs, built once per scene: kernels, per-object materials, lights, background.

    headings: several frames of an animation at once (render_frame_pixels): each of the vane's parts is there once
    per heading, as an object of its own in the part's place in the object order (so that ties between objects go
    as in each frame's own scene), and sees only the rays of its frame; the rest of the scene is prepared once."""

    scene: sc.Scene
    headings: tuple[float, ...] | None = None
    # numbers
    dtype: np.dtype = field(init=False)
    # camera rays through a 32 x 24 grid of pixels (origins, directions), where some hierarchy has boxes: what the
    # choices between walking a hierarchy and testing every kernel are made on (_choose_brute_force)
    sample_rays: tuple[np.ndarray, np.ndarray] | None = field(init=False, default=None)
    robust: bool = field(init=False)  # robust numerics (offset origins, watertight triangles) or the documented ones
    # geometry: each placed object's kernel, the hierarchies over them for each kind of ray
    kernels: list[Kernel] = field(init=False)
    centers: np.ndarray | None = field(init=False, default=None)  # (3, objects): a scene of spheres only
    merged_starts: list[tuple[MergedMeshKernel, np.ndarray]] = field(init=False, default_factory=list)
    hierarchy: Hierarchy = field(init=False)  # every object
    camera_hierarchy: Hierarchy = field(init=False)  # the objects each kind of ray sees (Blender's ray visibility)
    shadow_hierarchy: Hierarchy = field(init=False)
    mirror_hierarchy: Hierarchy = field(init=False)
    opaque_shadows: Hierarchy | None = field(init=False, default=None)  # objects that block shadow rays whole
    smooth: dict[int, tuple[np.ndarray, ...]] = field(init=False, default_factory=dict)
    smooth_instances: dict[int, np.ndarray] = field(init=False, default_factory=dict)
    # the material table (_materials: rows by object, or by triangle with object_material and triangle_materials)
    material_names: list[str] = field(init=False)
    object_material: np.ndarray | None = field(init=False, default=None)
    triangle_materials: dict[int, np.ndarray] = field(init=False, default_factory=dict)
    colors: np.ndarray = field(init=False)  # (3, rows)
    specular_colors: np.ndarray = field(init=False)  # (3, rows)
    emission: np.ndarray = field(init=False)  # (3, rows)
    specular: np.ndarray = field(init=False)  # (rows,)
    reflective: np.ndarray = field(init=False)  # (rows,)
    two_sided: np.ndarray = field(init=False)  # (rows,) bool
    material_pass_index: np.ndarray = field(init=False)  # (rows,)
    alpha: np.ndarray | None = field(init=False, default=None)  # (rows,), where some material is see-through
    transmission: np.ndarray | None = field(init=False, default=None)
    ior: np.ndarray | None = field(init=False, default=None)
    # glossy lobes (glossy.py): which rows have one (and which of them trace it), their colours (3, rows),
    # roughness, Fresnel and energy, and the sample pairs (m, 2) every glossy hit uses; any_glossy false: none of it
    # exists; traced_glossy: some lobe sends reflection rays
    any_glossy: bool = field(init=False)
    traced_glossy: bool = field(init=False, default=False)
    glossy_rows: np.ndarray | None = field(init=False, default=None)
    glossy_traced: np.ndarray | None = field(init=False, default=None)
    glossy: np.ndarray | None = field(init=False, default=None)
    roughness: np.ndarray | None = field(init=False, default=None)
    glossy_schlick: np.ndarray | None = field(init=False, default=None)
    glossy_multiscatter: np.ndarray | None = field(init=False, default=None)
    glossy_separable: np.ndarray | None = field(init=False, default=None)  # Smith's separable G (Cycles 3.x)
    glossy_pairs: np.ndarray | None = field(init=False, default=None)
    world_pairs: np.ndarray | None = field(init=False, default=None)  # a lobe of the world alone: fewer
    rough_glass: bool = field(init=False, default=False)  # some glass has a roughness (glossy.glass_rays)
    world_lit: bool = field(init=False, default=False)  # a world light: its directions turn pixel by pixel
    patterned: bool = field(init=False, default=False)  # a light of a size's samples differ pixel by pixel
    # under an image background, what the world light is lit by (world_light.lighting)
    world_lighting: world_light.WorldLighting | None = field(init=False, default=None)
    diffuse_bounces: int = field(init=False, default=0)  # render.diffuse_bounces (glossy.diffuse_rays)
    transmission_roughness: np.ndarray | None = field(init=False, default=None)  # (rows,) float64
    transmission_beckmann: np.ndarray | None = field(init=False, default=None)  # (rows,) bool: Beckmann rough glass
    colored: bool = field(init=False)  # lights or materials with colours: the terms as (3, n) colours
    emissive: bool = field(init=False)
    any_two_sided: bool = field(init=False)
    see_through: bool = field(init=False)  # some material has transmission or alpha < 1
    shadow_alpha: bool = field(init=False)  # some material has alpha < 1: shadow rays pass it
    textured: bool = field(init=False)  # the texture fields below exist (_textures)
    # objects' own flags
    holdout: np.ndarray = field(init=False)  # (objects,) bool
    any_holdout: bool = field(init=False)
    has_alpha: bool = field(init=False)
    channels: int = field(init=False)  # a traced pixel's: colour, and alpha where the scene has one
    # lights, camera, background
    lights: list[PreparedLight] = field(init=False)
    seen_lights: list = field(init=False, default_factory=list)  # area lights mirror rays see (emitters.py)
    seen_suns: list = field(init=False, default_factory=list)  # suns' discs mirror rays see (emitters.py)
    origin: np.ndarray = field(init=False)  # (3, 1) the camera's location
    screen: ScreenRectangles | None = field(init=False, default=None)  # which camera rays each kernel can meet
    mirrors: dict[int, ScreenRectangles] = field(init=False, default_factory=dict)  # the same for reflective planes
    documented_color: np.ndarray | None = field(init=False, default=None)  # (3, 1) the documented background's

    def __post_init__(self) -> None:
        settings = self.scene.render
        self.dtype = np.dtype(settings.dtype)
        self.robust = settings.numerics == "robust"
        placed = _placed_objects(
            self,
        )
        leaves = _kernels(self, placed)
        _visibility(self, placed, leaves)
        _choose_brute_force(
            self,
        )
        objects = placed.objects
        self.holdout = np.asarray([obj.holdout for obj in objects], dtype=bool)
        self.any_holdout = bool(self.holdout.any())
        self.has_alpha = self.scene.has_alpha
        self.channels = 4 if self.has_alpha else 3
        _materials(self, objects)
        if self.shadow_alpha:
            _opaque_shadows(self, placed, leaves)
        if settings.passes:  # what the passes read of the placed objects and the material rows (recorder.py)
            self.object_names = [obj.name for obj in objects]
            self.object_pass_index = np.asarray([obj.pass_index for obj in objects], dtype=self.dtype)
            self.view_axis = view_axis(self.scene.camera, self.dtype)
        _smooth_normals(self, objects, placed.primitives, placed.vanes)
        _textures(self, objects, placed.primitives)
        self.lights = prepare_lights(self.scene, self.dtype)
        self.world_lit = any(isinstance(light, sc.WorldLight) for light in self.scene.lights)
        self.patterned = any(light.patterns > 1 for light in self.lights)
        self.world_lighting = world_light.lighting(self.scene)
        self.seen_lights = emitters.prepare(self.scene, self.dtype)
        self.seen_suns = emitters.prepare_suns(self.scene)
        # the documented arithmetic (one intensity per point) unless a light or a material needs colours
        self.colored = self.colored or any(
            light.color != sc.WHITE
            or getattr(light, "falloff", "none") != "none"
            or isinstance(light, sc.SpotLight | sc.AreaLight | sc.WorldLight)
            for light in self.scene.lights
        )
        background = self.scene.background
        if background.type == "documented":
            direction = cam.documented_background_direction(self.scene.camera, settings)
            self.documented_color = column(background.sky(direction[2]), self.dtype)
        self.origin = column(self.scene.camera.location, self.dtype)
        _screen(
            self,
        )
        self.mirrors = _mirror_rectangles(self, placed.primitives)
        _light_grids(
            self,
        )

    def cryptomatte_hashes(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """The distinct names of the placed objects (cryptomatte_object) or material rows (cryptomatte_material),
        as Cryptomatte names them (render.cryptomatte_names), hashed as its float ids (K,) float32, and each object's
        or row's index into them."""
        from .cryptomatte import matte_names, name_hash

        kind = "object" if name == "cryptomatte_object" else "material"
        names = matte_names(self.object_names if kind == "object" else self.material_names, self.scene.render, kind)
        distinct = list(dict.fromkeys(names))
        where = {text: index for index, text in enumerate(distinct)}
        hashes = np.asarray([name_hash(text)[1] for text in distinct], dtype=np.float32)
        return hashes, np.asarray([where[text] for text in names], dtype=np.int64)

    def material_of(self, obj: np.ndarray, part: np.ndarray) -> np.ndarray:
        """Each hit's index into the material arrays (n,): its object's material, or its triangle's."""
        if self.object_material is None:
            return obj
        material = self.object_material.take(obj)
        for index, table in self.triangle_materials.items():
            rows = indices(obj == index)
            if rows.size:
                material[rows] = table.take(part.take(rows), mode="wrap")
        return material

    def normals(
        self, P: np.ndarray, obj: np.ndarray, part: np.ndarray
    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """Unit normals (3, N) at hit points P (3, N) on objects obj (N,), and in robust numerics what
        offset_origins() needs (else None): each point's signed distance (N,) from its surface along the normal, and
        its primitive's rounding magnitude (N,)."""
        if self.centers is not None:  # the same operations as SphereKernel.unit_normal, on every point at once
            return unit(P - self.centers.take(obj, axis=1)), None
        N = np.empty_like(P)
        if self.robust:
            distance, scale = np.empty(P.shape[1], dtype=self.dtype), np.empty(P.shape[1], dtype=self.dtype)
        for merged, start_of in self.merged_starts:  # merged meshes' points: one gather from the merged arrays
            starts = start_of.take(obj)
            rows = indices(starts >= 0)
            if not rows.size:
                continue
            where, parts = take(P, rows), starts.take(rows) + part.take(rows)
            normals = merged.inner.unit_normal(where, parts)
            for axis in range(3):
                N[axis][rows] = normals[axis]
            if self.robust:
                distance[rows], scale[rows] = merged.inner.surface(where, parts)
        # a stable sort of 8- or 16-bit keys is NumPy's radix sort: about twice as fast as on int32 here
        key = np.uint8 if len(self.kernels) <= 256 else np.uint16 if len(self.kernels) <= 65536 else obj.dtype
        order = np.argsort(obj.astype(key), kind="stable")
        start = 0
        for index, size in enumerate(np.bincount(obj, minlength=len(self.kernels)).tolist()):
            if size and self.merged_starts and isinstance(self.kernels[index], MergedMember):
                start += size  # done above
            elif size:
                rows = order[start : start + size]
                kernel = self.kernels[index]
                if isinstance(kernel, PlaneKernel):  # one normal for every point: no need to gather them
                    normals = kernel.unit
                else:
                    normals = kernel.unit_normal(take(P, rows), part.take(rows))
                for axis in range(3):
                    N[axis][rows] = normals[axis]
                if self.robust:
                    along, rounding = kernel.surface(take(P, rows), part.take(rows))
                    distance[rows] = along
                    scale[rows] = rounding
                start += size
        return N, ((distance, scale) if self.robust else None)


# ---- preparing a scene: what __post_init__ calls, in its order -----------------------------------------------


def _kernels(prepared: PreparedScene, placed: _Placed) -> list[tuple[int, Kernel]]:
    """Each placed object's kernel (prepared.kernels, for normals), the scene's hierarchy over them (prepared.hierarchy)
    -> its leaves: (owner object, kernel), a merged kernel once in its first member's place, a large mesh as a
    kernel with a hierarchy of its own over its triangles."""
    build = make_robust_kernel if prepared.robust else make_kernel
    objects, primitives = placed.objects, placed.primitives
    merged = _merged_meshes(prepared, build, objects, primitives, placed.frame_of, placed.moving)
    prepared.kernels = [
        merged[index]
        if index in merged
        else _instances_kernel(build, primitive, prepared.dtype)
        if isinstance(primitive, tf.WorldInstances)
        else _kernel(build, primitive, prepared.dtype)
        for index, primitive in enumerate(primitives)
    ]
    # a scene of documented spheres only: every hit's normal from its centre, gathered, in one set of passes
    if prepared.kernels and all(type(kernel) is SphereKernel for kernel in prepared.kernels):
        prepared.centers = np.concatenate([kernel.center for kernel in prepared.kernels], axis=1)  # (3, objects)
    leaf_kernels = [
        _kernel(MeshKernel, kernel, primitive)
        if isinstance(primitive, tf.WorldTriangles)
        and len(primitive.triangles) > MESH_HIERARCHY_TRIANGLES
        and not isinstance(kernel, MergedMember)
        else kernel
        for kernel, primitive in zip(prepared.kernels, primitives, strict=True)
    ]
    # each merged kernel with each object's first triangle in it (-1: not one of its members), for normals()
    for kernel in {id(k.merged): k.merged for k in merged.values()}.values():
        start_of = np.full(len(objects), -1, dtype=np.int64)
        start_of[kernel.members] = kernel.starts
        prepared.merged_starts.append((kernel, start_of))
    leaves = []
    for index, kernel in enumerate(leaf_kernels):
        if isinstance(kernel, MergedMember):
            if kernel.start == 0:
                leaves.append((index, kernel.merged))
        else:
            leaves.append((index, kernel))
    prepared.hierarchy = _hierarchy(prepared, placed, leaves)
    return leaves


def _hierarchy(prepared: PreparedScene, placed: _Placed, leaves: list[tuple[int, Kernel]]) -> Hierarchy:
    """The hierarchy over leaves (owner object, kernel), the vane's parts in a subtree of their own (the rest
    kept between an animation's frames, bvh.py), each leaf seeing its frame's rays."""
    owners = [owner for owner, _ in leaves]
    frames = None if placed.frame_of is None else [placed.frame_of[owner] for owner in owners]
    return Hierarchy([kernel for _, kernel in leaves], prepared.dtype, owners, placed.moving, frames)


def _visibility(prepared: PreparedScene, placed: _Placed, leaves: list[tuple[int, Kernel]]) -> None:
    """The hierarchies of the objects that camera, shadow and mirror rays see (Blender's ray visibility): the
    scene's own where every object is seen."""

    def seen_by(flag: str) -> Hierarchy:
        if all(getattr(obj, flag) for obj in placed.objects):
            return prepared.hierarchy
        return _hierarchy(prepared, placed, [leaf for leaf in leaves if getattr(placed.objects[leaf[0]], flag)])

    prepared.camera_hierarchy = seen_by("visible_camera")
    prepared.shadow_hierarchy = seen_by("visible_shadow")
    prepared.mirror_hierarchy = seen_by("visible_reflection")


def _opaque_shadows(prepared: PreparedScene, placed: _Placed, leaves: list[tuple[int, Kernel]]) -> None:
    """Where shadow rays pass partly transparent surfaces: the hierarchy of the objects that block them whole
    (every material of theirs has alpha 1), so that shadows.passing follows only the rays they leave open."""
    opaque = _opaque_objects(prepared, len(placed.objects))
    chosen = [
        (owner, kernel)
        for owner, kernel in leaves
        if placed.objects[owner].visible_shadow
        and all(opaque[member] for member in getattr(kernel, "members", np.array([owner])).tolist())
    ]
    if chosen:
        prepared.opaque_shadows = _hierarchy(prepared, placed, chosen)
        if prepared.sample_rays is not None:
            prepared.opaque_shadows.choose_brute(*prepared.sample_rays)


def _screen(prepared: PreparedScene) -> None:
    """Which camera rays each bounded kernel can meet (ScreenRectangles), where that culls well."""
    camera = prepared.scene.camera
    if prepared.camera_hierarchy.boxes is None or camera.aperture > 0.0 or camera.type == "PANO":  # not a projection
        return
    settings = prepared.scene.render
    screen = ScreenRectangles.build(
        prepared.scene.camera, settings, prepared.origin.ravel().astype(np.float64), prepared.camera_hierarchy.boxes
    )
    if screen is not None and prepared.camera_hierarchy.culls_well(screen.kernels, screen.shares):
        prepared.screen = screen


def _light_grids(prepared: PreparedScene) -> None:
    """Each light's coverage grid over the bounded kernels shadow rays see, where it culls well."""
    if prepared.shadow_hierarchy.boxes is None:
        return
    boxes = prepared.shadow_hierarchy.boxes
    for light in directed(prepared.lights):
        light.grid = light.make_grid(*boxes)
        if light.grid is not None and prepared.shadow_hierarchy.brute:
            shares = _sample_shares(prepared, light)
            if shares is None or not prepared.shadow_hierarchy.culls_well(light.grid.kernels, shares):
                light.grid = None


def _merged_meshes(
    prepared: PreparedScene,
    build,
    objects: tuple[sc.SceneObject, ...],
    primitives: list[tf.WorldPrimitive],
    frame_of: list[int] | None,
    moving: frozenset[int] | None,
) -> dict[int, MergedMember]:
    """Where at least MERGE_MESHES_FROM triangle meshes stand still and are seen by the same rays, one
    MergedMeshKernel for them, entering the scene's hierarchy once; -> each such object's member of it (its
    normals from the merged arrays), by object index. Other objects keep a kernel of their own."""
    groups: dict[tuple[bool, ...], list[int]] = {}
    for index, (obj, primitive) in enumerate(zip(objects, primitives, strict=True)):
        still = (frame_of is None or frame_of[index] < 0) and (moving is None or index not in moving)
        if still and isinstance(primitive, tf.WorldTriangles):
            flags = (obj.visible_camera, obj.visible_shadow, obj.visible_reflection)
            groups.setdefault(flags, []).append(index)
    merged: dict[int, MergedMember] = {}
    for candidates in groups.values():
        # a mesh much larger than the group's typical one (a ground under 3,000 cubes) stays a leaf of its own:
        # inside the merged hierarchy its triangles would widen every box above them (the ground doubled a
        # 1280x720 frame's time)
        sizes = np.array([np.ptp(primitives[index].triangles.reshape(-1, 3), axis=0).max() for index in candidates])
        typical = float(np.median(sizes)) if sizes.size else 0.0
        members = [
            index for index, size in zip(candidates, sizes.tolist(), strict=True) if size <= MERGE_SIZE_FACTOR * typical
        ]
        if len(members) < MERGE_MESHES_FROM:
            continue
        meshes = [primitives[index] for index in members]
        kernel = _kernel(MergedMeshKernel, build, prepared.dtype, tuple(members), *meshes)
        merged.update((index, kernel.member(position)) for position, index in enumerate(members))
    return merged


def _placed_objects(prepared: PreparedScene) -> _Placed:
    """The objects as traced: with headings each of the vane's parts once per heading."""
    scene, headings = prepared.scene, prepared.headings
    vane = scene.vane
    moving = None if vane is None else frozenset(i for i, obj in enumerate(scene.objects) if obj.name in vane.parts)
    if headings is None:
        return _Placed(scene.objects, _world_primitives(scene), None, [vane] * len(scene.objects), moving)
    if vane is None:
        raise ValueError("frames at several headings need a scene with a vane")
    turned = [replace(vane, heading=heading) for heading in headings]
    objects, primitives, frame_of, vanes = [], [], [], []
    for obj in scene.objects:
        if obj.name not in vane.parts:
            objects.append(obj)
            primitives.append(_still_primitive(obj, vane))
            frame_of.append(-1)
            vanes.append(vane)
            continue
        for frame, turned_vane in enumerate(turned):
            objects.append(obj)
            primitives.append(tf.world_primitive(obj, turned_vane))
            frame_of.append(frame)
            vanes.append(turned_vane)
    moving = frozenset(index for index, obj in enumerate(objects) if obj.name in vane.parts)
    return _Placed(tuple(objects), primitives, frame_of, vanes, moving)


def _mirror_rectangles(prepared: PreparedScene, primitives: list) -> dict[int, ScreenRectangles]:
    """For each reflective plane that camera rays can meet: which of its mirror rays each bounded kernel can
    meet, by the pixels of the camera rays they continue (ScreenRectangles.mirrored). Keyed by the plane's
    object index; empty where the camera rays have no screen rectangles or the mirror rays are not walked
    through boxes (brute force tests every kernel on every ray)."""
    mirrors = {}
    hierarchy = prepared.mirror_hierarchy
    if prepared.screen is None or hierarchy.boxes is None or hierarchy.brute:
        return mirrors
    location = prepared.origin.ravel().astype(np.float64)
    for index in prepared.camera_hierarchy.unbounded:
        owner = prepared.camera_hierarchy.owners[index]
        plane = primitives[owner]
        if not isinstance(plane, tf.WorldPlane):
            continue
        reflective = prepared.reflective.take(prepared.material_of(np.array([owner]), np.zeros(1, dtype=np.int32)))
        if not reflective[0] > 0.0:
            continue
        rectangles = ScreenRectangles.mirrored(
            prepared.scene.camera,
            prepared.scene.render,
            location,
            hierarchy.boxes,
            np.asarray(plane.point, dtype=np.float64),
            np.asarray(plane.normal, dtype=np.float64),
        )
        if rectangles is not None:
            mirrors[owner] = rectangles
    return mirrors


def _sample_shares(prepared: PreparedScene, light: DirectedLight) -> np.ndarray | None:
    """The share (k,) of a light's shadow rays that its grid gives each kernel, estimated on the rays from where
    _choose_brute_force's sample camera rays hit (None: none hits)."""
    O, D = prepared.sample_rays
    t, obj, _ = prepared.camera_hierarchy.closest(O, D, CAMERA_T_MIN)
    hit = indices(obj >= 0)
    if hit.size == 0:
        return None
    return light.grid_shares(take(O, hit) + take(D, hit) * t.take(hit))


def _choose_brute_force(prepared: PreparedScene) -> None:
    """Whether each hierarchy is walked or every kernel tests every ray (Hierarchy.choose_brute), decided on a
    32 x 24 grid of the camera's rays (the same bytes either way: only the work differs)."""
    settings, camera = prepared.scene.render, prepared.scene.camera
    if all(h.root is None for h in (prepared.camera_hierarchy, prepared.shadow_hierarchy, prepared.mirror_hierarchy)):
        return
    O, D = prepared.sample_rays = _sample_rays(camera, settings)
    for hierarchy in {
        id(h): h for h in (prepared.camera_hierarchy, prepared.shadow_hierarchy, prepared.mirror_hierarchy)
    }.values():
        hierarchy.choose_brute(O, D)


def _materials(prepared: PreparedScene, objects: tuple[sc.SceneObject, ...]) -> None:
    """The materials as arrays (3, M) and (M,), and each object's (or a mesh's each triangle's) index into them.
    Without per-triangle materials the rows are the objects' own materials (M = objects): a hit's object is its
    row, as in the documented tracer (no index to look up per hit)."""
    names = list(prepared.scene.materials)
    number = {name: index for index, name in enumerate(names)}
    prepared.object_material: np.ndarray | None = None
    prepared.triangle_materials: dict[int, np.ndarray] = {}
    for index, obj in enumerate(objects):
        if getattr(obj, "material_indices", None) is not None:
            # by triangle; an instance's part (instance * T + triangle) is taken modulo T (material_of)
            slots = np.asarray([number[name] for name in obj.materials], dtype=np.intp)
            prepared.triangle_materials[index] = slots.take(np.asarray(obj.material_indices, dtype=np.intp))
    if prepared.triangle_materials:
        table = [prepared.scene.materials[name] for name in names]
        prepared.object_material = np.asarray([number[obj.material] for obj in objects], dtype=np.intp)
        prepared.material_names = names
    else:
        table = [prepared.scene.materials[obj.material] for obj in objects]
        prepared.material_names = [obj.material for obj in objects]
    prepared.material_pass_index = np.asarray([m.pass_index for m in table], dtype=prepared.dtype)
    as_columns = lambda values: np.asarray(values, dtype=prepared.dtype).T.reshape(3, -1)  # noqa: E731
    prepared.colors = as_columns([m.color for m in table])  # (3, materials)
    prepared.specular = np.asarray([m.specular for m in table], dtype=prepared.dtype)
    prepared.reflective = np.asarray([m.reflective for m in table], dtype=prepared.dtype)
    prepared.emission = as_columns([m.emission for m in table])
    prepared.emissive = any(m.emission != sc.BLACK for m in table)
    prepared.specular_colors = as_columns([m.color if m.specular_color is None else m.specular_color for m in table])
    prepared.colored = any(m.specular_color is not None for m in table)
    prepared.two_sided = np.asarray([m.two_sided for m in table], dtype=bool)
    prepared.any_two_sided = bool(prepared.two_sided.any())
    # a glossy lobe's rays (glossy.py): several per camera sample, as glass's, so its scenes trace see-through (a
    # lobe of the world alone sends none: the Whitted wavefront)
    # a lobe of the world alone under no background (type none) adds nothing: left out
    seen = [m.is_glossy and (m.traces_glossy or prepared.scene.background.type != "none") for m in table]
    prepared.any_glossy = any(seen)
    if prepared.any_glossy:
        prepared.glossy_rows = np.asarray(seen, dtype=bool)
        prepared.glossy_traced = np.asarray([m.traces_glossy for m in table], dtype=bool)
        prepared.traced_glossy = bool(prepared.glossy_traced.any())
        prepared.glossy = as_columns([m.glossy for m in table])
        prepared.roughness = np.asarray([m.roughness for m in table], dtype=np.float64)
        prepared.glossy_schlick = np.asarray([m.glossy_fresnel == "schlick" for m in table], dtype=bool)
        prepared.glossy_multiscatter = np.asarray([m.glossy_energy == "multiscatter" for m in table], dtype=bool)
        prepared.glossy_separable = np.asarray([m.glossy_shadowing == "separable" for m in table], dtype=bool)
        prepared.glossy_pairs = np.asarray(
            lightsamples.glossy_pairs(prepared.scene.render.glossy_samples), dtype=np.float64
        )
        prepared.world_pairs = np.asarray(
            lightsamples.glossy_pairs(lightsamples.world_glossy_pairs(prepared.scene)), dtype=np.float64
        )
        prepared.colored = True
    # diffuse bounces (glossy.diffuse_rays): several rays per camera sample, at the glossy pairs
    prepared.diffuse_bounces = prepared.scene.render.diffuse_bounces
    if prepared.diffuse_bounces and prepared.glossy_pairs is None:
        prepared.glossy_pairs = np.asarray(
            lightsamples.glossy_pairs(prepared.scene.render.glossy_samples), dtype=np.float64
        )
    # glass and transparency (see_through.py's stages): only where some material has them, else none of it runs
    prepared.see_through = any(m.see_through for m in table) or prepared.traced_glossy or bool(prepared.diffuse_bounces)
    prepared.shadow_alpha = any(m.alpha < 1.0 for m in table)  # shadow rays pass such surfaces (shadows.passing)
    # rough glass (glossy.glass_rays): sampled reflection and refraction, several rays per hit as a glossy lobe's
    prepared.rough_glass = any(m.transmission > 0.0 and m.transmission_roughness > 0.0 for m in table)
    if prepared.rough_glass:
        prepared.transmission_roughness = np.asarray([m.transmission_roughness for m in table], dtype=np.float64)
        prepared.transmission_beckmann = np.asarray([m.transmission_distribution == "beckmann" for m in table])
        if prepared.glossy_pairs is None:
            prepared.glossy_pairs = np.asarray(
                lightsamples.glossy_pairs(prepared.scene.render.glossy_samples), dtype=np.float64
            )
            prepared.glossy_multiscatter = np.asarray([m.glossy_energy == "multiscatter" for m in table], dtype=bool)
            prepared.glossy_separable = np.asarray([m.glossy_shadowing == "separable" for m in table], dtype=bool)
    if prepared.see_through:
        prepared.alpha = np.asarray([m.alpha for m in table], dtype=prepared.dtype)
        prepared.transmission = np.asarray([m.transmission for m in table], dtype=prepared.dtype)
        prepared.ior = np.asarray([m.ior for m in table], dtype=prepared.dtype)


def _opaque_objects(prepared: PreparedScene, count: int) -> list[bool]:
    """Whether each placed object's materials (a mesh's every triangle's) all have alpha 1."""
    opaque = []
    for index in range(count):
        if index in prepared.triangle_materials:
            rows = prepared.triangle_materials[index]
        else:
            rows = np.array([index if prepared.object_material is None else prepared.object_material[index]])
        opaque.append(bool(np.all(prepared.alpha.take(rows) >= 1.0)))
    return opaque


def _smooth_normals(
    prepared: PreparedScene, objects: tuple[sc.SceneObject, ...], primitives: list, vanes: list
) -> None:
    """For each mesh with corner normals: its triangles' v0, e1, e2 and corner normals n0, n1, n2 (3, T) each,
    float64 (the reference's numbers); vanes: the vane that places each object."""
    prepared.smooth: dict[int, tuple[np.ndarray, ...]] = {}
    prepared.smooth_instances: dict[int, np.ndarray] = {}  # an instanced mesh's corner normals (T, 3, 3), local
    for index, (obj, primitive, vane) in enumerate(zip(objects, primitives, vanes, strict=True)):
        if isinstance(obj, sc.MeshInstances):
            if obj.normals is not None:
                prepared.smooth_instances[index] = np.asarray(obj.normals, dtype=np.float64).reshape(-1, 3, 3)
            continue
        corners = tf.world_corner_normals(obj, vane)
        if corners is None:
            continue
        triangles = np.asarray(primitive.triangles, dtype=np.float64)  # (T, 3, 3)
        v0 = triangles[:, 0]
        parts = (v0, triangles[:, 1] - v0, triangles[:, 2] - v0, corners[:, 0], corners[:, 1], corners[:, 2])
        prepared.smooth[index] = tuple(np.ascontiguousarray(part.T) for part in parts)


def _textures(prepared: PreparedScene, objects: tuple[sc.SceneObject, ...], primitives: list) -> None:
    """Where a material row has a texture and a mesh has UVs or corner colours (textured): each such row's
    textures, and each such mesh's triangles' v0, e1, e2 (3, T) and corner UVs (2, T) or colours (3, T) each
    (float64, as for smooth normals), or an instanced mesh's corner UVs (T, 3, 2) or colours (T, 3, 3) in its own
    space. Without them nothing here runs while tracing."""
    rows = [prepared.scene.materials[name] for name in prepared.material_names]
    prepared.row_textures = [m.texture for m in rows]
    prepared.row_emission_textures = [m.emission_texture for m in rows]
    with_texture = [m.texture is not None or m.emission_texture is not None for m in rows]
    prepared.textured = any(with_texture) and any(
        getattr(obj, "uvs", None) is not None or getattr(obj, "colors", None) is not None for obj in objects
    )
    if not prepared.textured:
        return
    prepared.has_texture = np.asarray(with_texture, dtype=bool)
    prepared.emissive = prepared.emissive or any(e is not None for e in prepared.row_emission_textures)
    prepared.uv_meshes: dict[int, tuple[np.ndarray, ...]] = {}
    prepared.uv_instances: dict[int, np.ndarray] = {}
    prepared.color_meshes: dict[int, tuple[np.ndarray, ...]] = {}
    prepared.color_instances: dict[int, np.ndarray] = {}
    for index, (obj, primitive) in enumerate(zip(objects, primitives, strict=True)):
        for key, meshes, instances, width in (
            ("uvs", prepared.uv_meshes, prepared.uv_instances, 2),
            ("colors", prepared.color_meshes, prepared.color_instances, 3),
        ):
            corners = getattr(obj, key, None)
            if corners is None:
                continue
            if isinstance(obj, sc.MeshInstances):
                instances[index] = np.asarray(corners, dtype=np.float64).reshape(-1, 3, width)
                continue
            triangles = np.asarray(primitive.triangles, dtype=np.float64)  # (T, 3, 3), world
            v0 = triangles[:, 0]
            parts = (v0, triangles[:, 1] - v0, triangles[:, 2] - v0, corners[:, 0], corners[:, 1], corners[:, 2])
            meshes[index] = tuple(np.ascontiguousarray(part.T) for part in parts)


@functools.lru_cache(maxsize=16)
def _sample_rays(camera: sc.Camera, settings: sc.RenderSettings) -> tuple[np.ndarray, np.ndarray]:
    """The camera's rays (3, n) each, origins and directions in the tracing dtype, through a 32 x 24 grid of its
    pixels (PreparedScene._choose_brute_force), kept for the frames of an animation (its camera stays put);
    read-only."""
    columns = np.unique(np.linspace(0, settings.width - 1, 32).astype(np.int64))
    rows = np.unique(np.linspace(0, settings.height - 1, 24).astype(np.int64))
    pixels = (rows[:, None] * settings.width + columns[None, :]).ravel()
    with quiet():
        D = cam.pixel_directions(camera, settings, pixels)
        O = column(camera.location, np.float64)
        if not cam.shares_origin(camera):
            O = cam.pixel_starts(camera, settings, pixels, D)[0]
        O, D = O.astype(settings.dtype), D.astype(settings.dtype)
    O.flags.writeable = D.flags.writeable = False
    return O, D


_KERNELS: OrderedDict[tuple, object] = OrderedDict()
KERNEL_CACHE_SIZE = 512
_STILL_PRIMITIVES: OrderedDict[int, tuple[sc.SceneObject, tf.WorldPrimitive]] = OrderedDict()


def _world_primitives(scene: sc.Scene) -> list[tf.WorldPrimitive]:
    """tf.world_primitives(scene), keeping, where the scene has a vane, those of the objects that are not its parts
    (which the heading does not move: tf.object_frame) for the same objects in later scenes: an animation's frames
    share their objects, and their 14 primitives cost about 1 ms a frame. Kept by the object itself (scenes are
    immutable), at most KERNEL_CACHE_SIZE of them. Without a vane nothing is kept (a million triangles' world
    arrays are 96 MB in each worker)."""
    if scene.vane is None:
        return tf.world_primitives(scene)
    parts = scene.vane.parts
    return [
        tf.world_primitive(obj, scene.vane) if obj.name in parts else _still_primitive(obj, scene.vane)
        for obj in scene.objects
    ]


def _still_primitive(obj: sc.SceneObject, vane: sc.Vane) -> tf.WorldPrimitive:
    """The world primitive of an object that is not one of the vane's parts, kept by the object itself."""
    kept = _STILL_PRIMITIVES.get(id(obj))
    if kept is None or kept[0] is not obj:
        kept = _STILL_PRIMITIVES[id(obj)] = (obj, tf.world_primitive(obj, vane))
        if len(_STILL_PRIMITIVES) > KERNEL_CACHE_SIZE:
            _STILL_PRIMITIVES.popitem(last=False)
    else:
        _STILL_PRIMITIVES.move_to_end(id(obj))
    return kept[1]


def _kernel(make, *parts: object):
    """make(*parts) (a primitive and a dtype, or a mesh's kernel and its primitive), kept for primitives that stay
    put between frames (in an animation all but the vane's parts); kernels never change once made. A mesh's key is
    its cache_key, which does not hold its world arrays alive; keys are found by their hash (a digest of a mesh's
    arrays, scene.ArraysByBits), never by comparing with every entry."""
    key = tuple(part.str if isinstance(part, np.dtype) else getattr(part, "cache_key", part) for part in (make, *parts))
    made = _KERNELS.get(key)
    if made is None:
        made = _KERNELS[key] = make(*parts)
        if len(_KERNELS) > KERNEL_CACHE_SIZE:
            _KERNELS.popitem(last=False)
    else:
        _KERNELS.move_to_end(key)
    return made


def _instances_kernel(make, primitive: tf.WorldInstances, dtype: np.dtype) -> InstancesKernel:
    """The kernel of a mesh placed many times: the mesh's own kernel and hierarchy kept by the mesh (its vertices
    and faces, found by their digest), so that every scene and frame that places it builds them once; the
    instances' hierarchy kept by the placements (the same matrices in the next frame: nothing built again)."""
    local = _kernel(local_mesh_kernel, make, primitive.mesh, dtype)
    return _kernel(InstancesKernel, local, primitive, dtype)
