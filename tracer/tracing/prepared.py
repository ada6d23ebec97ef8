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
from .lights import DirectedLight, directed, prepare_lights
from .rays import CAMERA_T_MIN
from .recorder import view_axis

# this many still triangle meshes seen by the same rays go into the scene's hierarchy as one kernel (their
# triangles behind one hierarchy, MergedMeshKernel): 3,000 cubes as separate objects took 16x the time of the same
# triangles as one mesh, walking the scene's hierarchy node by node in Python. Below it (the default vane's 13
# objects) a leaf per object, as the small scenes' benchmarks were tuned
MERGE_MESHES_FROM = 64
MERGE_SIZE_FACTOR = 8.0  # merged: meshes at most this many times the group's median size (their boxes' longest side)


@dataclass
class PreparedScene:
    """What tracing needs, built once per scene: kernels, per-object materials, lights, background.

    headings: several frames of an animation at once (render_frame_pixels): each of the vane's parts is there once
    per heading, as an object of its own in the part's place in the object order (so that ties between objects go
    as in each frame's own scene), and sees only the rays of its frame; the rest of the scene is prepared once."""

    scene: sc.Scene
    headings: tuple[float, ...] | None = None
    dtype: np.dtype = field(init=False)
    kernels: list[Kernel] = field(init=False)

    def __post_init__(self) -> None:
        settings = self.scene.render
        self.dtype = np.dtype(settings.dtype)
        self.robust = settings.numerics == "robust"
        build = make_robust_kernel if self.robust else make_kernel
        objects, primitives, frame_of, vanes = self._placed_objects()
        # the vane's parts in a subtree of their own, the rest kept between an animation's frames (bvh.py)
        vane = self.scene.vane
        moving = None
        if vane is not None:
            moving = frozenset(index for index, obj in enumerate(objects) if obj.name in vane.parts)
        merged = self._merged_meshes(build, objects, primitives, frame_of, moving)
        self.kernels = [  # per object: normals
            merged[index]
            if index in merged
            else _instances_kernel(build, primitive, self.dtype)
            if isinstance(primitive, tf.WorldInstances)
            else _kernel(build, primitive, self.dtype)
            for index, primitive in enumerate(primitives)
        ]
        # a scene of documented spheres only: every hit's normal from its centre, gathered, in one set of passes
        self.centers = None
        if self.kernels and all(type(kernel) is SphereKernel for kernel in self.kernels):
            self.centers = np.concatenate([kernel.center for kernel in self.kernels], axis=1)  # (3, objects)
        # a large mesh enters the scene's hierarchy as one leaf with a hierarchy of its own over its triangles
        leaf_kernels = [
            _kernel(MeshKernel, kernel, primitive)
            if isinstance(primitive, tf.WorldTriangles)
            and len(primitive.triangles) > MESH_HIERARCHY_TRIANGLES
            and not isinstance(kernel, MergedMember)
            else kernel
            for kernel, primitive in zip(self.kernels, primitives, strict=True)
        ]
        # each merged kernel with each object's first triangle in it (-1: not one of its members), for normals()
        self.merged_starts: list[tuple[MergedMeshKernel, np.ndarray]] = []
        for kernel in {id(k.merged): k.merged for k in merged.values()}.values():
            start_of = np.full(len(objects), -1, dtype=np.int64)
            start_of[kernel.members] = kernel.starts
            self.merged_starts.append((kernel, start_of))
        leaves = []  # (owner object, kernel): a merged kernel once, in its first member's place
        for index, kernel in enumerate(leaf_kernels):
            if isinstance(kernel, MergedMember):
                if kernel.start == 0:
                    leaves.append((index, kernel.merged))
            else:
                leaves.append((index, kernel))
        owners = [owner for owner, _ in leaves]
        leaf_frames = None if frame_of is None else [frame_of[owner] for owner in owners]
        self.hierarchy = Hierarchy([kernel for _, kernel in leaves], self.dtype, owners, moving, leaf_frames)

        def seen_by(flag: str) -> Hierarchy:  # the objects one kind of ray sees (Blender's ray visibility)
            if all(getattr(obj, flag) for obj in objects):
                return self.hierarchy
            chosen = [position for position, owner in enumerate(owners) if getattr(objects[owner], flag)]
            kernels = [leaves[position][1] for position in chosen]
            seen = [owners[position] for position in chosen]
            frames = None if frame_of is None else [frame_of[owner] for owner in seen]
            return Hierarchy(kernels, self.dtype, seen, moving, frames)

        self.camera_hierarchy = seen_by("visible_camera")
        self.shadow_hierarchy = seen_by("visible_shadow")
        self.mirror_hierarchy = seen_by("visible_reflection")
        self._choose_brute_force()
        self.holdout = np.asarray([obj.holdout for obj in objects], dtype=bool)
        self.any_holdout = bool(self.holdout.any())
        self.has_alpha = self.scene.has_alpha
        self.channels = 4 if self.has_alpha else 3  # a traced pixel's: colour, and alpha where the scene has one
        self._materials(objects)
        # where shadow rays pass partly transparent surfaces: the objects that block them whole (every material of
        # theirs has alpha 1), so that shadows.passing follows only the rays they leave open
        self.opaque_shadows = None
        if self.shadow_alpha:
            opaque = self._opaque_objects(len(objects))
            chosen = [
                (owner, kernel)
                for owner, kernel in leaves
                if objects[owner].visible_shadow
                and all(opaque[member] for member in getattr(kernel, "members", np.array([owner])).tolist())
            ]
            if chosen:
                frames = None if frame_of is None else [frame_of[owner] for owner, _ in chosen]
                kernels, seen = [kernel for _, kernel in chosen], [owner for owner, _ in chosen]
                self.opaque_shadows = Hierarchy(kernels, self.dtype, seen, moving, frames)
                if getattr(self, "_samples", None) is not None:
                    self.opaque_shadows.choose_brute(*self._samples)
        if settings.passes:  # what the passes read of the placed objects and the material rows (recorder.py)
            self.object_names = [obj.name for obj in objects]
            self.object_pass_index = np.asarray([obj.pass_index for obj in objects], dtype=self.dtype)
            self.view_axis = view_axis(self.scene.camera, self.dtype)
        self._smooth_normals(objects, primitives, vanes)
        self._textures(objects, primitives)
        self.lights = prepare_lights(self.scene, self.dtype)
        # the documented arithmetic (one intensity per point) unless a light or a material needs colours
        self.colored = self.colored or any(
            light.color != sc.WHITE
            or getattr(light, "falloff", "none") != "none"
            or isinstance(light, sc.SpotLight | sc.AreaLight)
            for light in self.scene.lights
        )
        background = self.scene.background
        self.documented_color = None
        if background.type == "documented":
            direction = cam.documented_background_direction(self.scene.camera, settings)
            self.documented_color = column(background.sky(direction[2]), self.dtype)
        self.origin = column(self.scene.camera.location, self.dtype)
        self.screen = None  # which camera rays each bounded kernel can meet
        if self.camera_hierarchy.boxes is not None:
            self.screen = ScreenRectangles.build(
                self.scene.camera, settings, self.origin.ravel().astype(np.float64), self.camera_hierarchy.boxes
            )
            screen = self.screen
            if screen is not None and not self.camera_hierarchy.culls_well(screen.kernels, screen.shares):
                self.screen = None
        self.mirrors = self._mirror_rectangles(primitives)
        if self.shadow_hierarchy.boxes is not None:
            boxes = self.shadow_hierarchy.boxes
            for light in directed(self.lights):
                light.grid = light.make_grid(*boxes)
                if light.grid is not None and self.shadow_hierarchy.brute:
                    shares = self._sample_shares(light)
                    if shares is None or not self.shadow_hierarchy.culls_well(light.grid.kernels, shares):
                        light.grid = None

    def _merged_meshes(
        self,
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
                index
                for index, size in zip(candidates, sizes.tolist(), strict=True)
                if size <= MERGE_SIZE_FACTOR * typical
            ]
            if len(members) < MERGE_MESHES_FROM:
                continue
            meshes = [primitives[index] for index in members]
            kernel = _kernel(MergedMeshKernel, build, self.dtype, tuple(members), *meshes)
            merged.update((index, kernel.member(position)) for position, index in enumerate(members))
        return merged

    def _placed_objects(
        self,
    ) -> tuple[tuple[sc.SceneObject, ...], list[tf.WorldPrimitive], list[int] | None, list[sc.Vane | None]]:
        """The objects as traced, their world primitives, the frame each one's rays belong to (-1: every frame's;
        None without headings) and the vane that places each (one of its headings for a part)."""
        scene, headings = self.scene, self.headings
        if headings is None:
            return scene.objects, _world_primitives(scene), None, [scene.vane] * len(scene.objects)
        if scene.vane is None:
            raise ValueError("frames at several headings need a scene with a vane")
        turned = [replace(scene.vane, heading=heading) for heading in headings]
        objects, primitives, frame_of, vanes = [], [], [], []
        for obj in scene.objects:
            if obj.name not in scene.vane.parts:
                objects.append(obj)
                primitives.append(_still_primitive(obj, scene.vane))
                frame_of.append(-1)
                vanes.append(scene.vane)
                continue
            for frame, vane in enumerate(turned):
                objects.append(obj)
                primitives.append(tf.world_primitive(obj, vane))
                frame_of.append(frame)
                vanes.append(vane)
        return tuple(objects), primitives, frame_of, vanes

    def _mirror_rectangles(self, primitives: list) -> dict[int, ScreenRectangles]:
        """For each reflective plane that camera rays can meet: which of its mirror rays each bounded kernel can
        meet, by the pixels of the camera rays they continue (ScreenRectangles.mirrored). Keyed by the plane's
        object index; empty where the camera rays have no screen rectangles or the mirror rays are not walked
        through boxes (brute force tests every kernel on every ray)."""
        mirrors = {}
        hierarchy = self.mirror_hierarchy
        if self.screen is None or hierarchy.boxes is None or hierarchy.brute:
            return mirrors
        location = self.origin.ravel().astype(np.float64)
        for index in self.camera_hierarchy.unbounded:
            owner = self.camera_hierarchy.owners[index]
            plane = primitives[owner]
            if not isinstance(plane, tf.WorldPlane):
                continue
            reflective = self.reflective.take(self.material_of(np.array([owner]), np.zeros(1, dtype=np.int32)))
            if not reflective[0] > 0.0:
                continue
            rectangles = ScreenRectangles.mirrored(
                self.scene.camera,
                self.scene.render,
                location,
                hierarchy.boxes,
                np.asarray(plane.point, dtype=np.float64),
                np.asarray(plane.normal, dtype=np.float64),
            )
            if rectangles is not None:
                mirrors[owner] = rectangles
        return mirrors

    def _sample_shares(self, light: DirectedLight) -> np.ndarray | None:
        """The share (k,) of a light's shadow rays that its grid gives each kernel, estimated on the rays from where
        _choose_brute_force's sample camera rays hit (None: none hits)."""
        O, D = self._samples
        t, obj, _ = self.camera_hierarchy.closest(O, D, CAMERA_T_MIN)
        hit = indices(obj >= 0)
        if hit.size == 0:
            return None
        return light.grid_shares(take(O, hit) + take(D, hit) * t.take(hit))

    def _choose_brute_force(self) -> None:
        """Whether each hierarchy is walked or every kernel tests every ray (Hierarchy.choose_brute), decided on a
        32 x 24 grid of the camera's rays (the same bytes either way: only the work differs)."""
        settings, camera = self.scene.render, self.scene.camera
        if all(h.root is None for h in (self.camera_hierarchy, self.shadow_hierarchy, self.mirror_hierarchy)):
            return
        O, D = self._samples = _sample_rays(camera, settings)
        for hierarchy in {
            id(h): h for h in (self.camera_hierarchy, self.shadow_hierarchy, self.mirror_hierarchy)
        }.values():
            hierarchy.choose_brute(O, D)

    def _materials(self, objects: tuple[sc.SceneObject, ...]) -> None:
        """The materials as arrays (3, M) and (M,), and each object's (or a mesh's each triangle's) index into them.
        Without per-triangle materials the rows are the objects' own materials (M = objects): a hit's object is its
        row, as in the documented tracer (no index to look up per hit)."""
        names = list(self.scene.materials)
        number = {name: index for index, name in enumerate(names)}
        self.object_material: np.ndarray | None = None
        self.triangle_materials: dict[int, np.ndarray] = {}
        for index, obj in enumerate(objects):
            if getattr(obj, "material_indices", None) is not None:
                # by triangle; an instance's part (instance * T + triangle) is taken modulo T (material_of)
                slots = np.asarray([number[name] for name in obj.materials], dtype=np.intp)
                self.triangle_materials[index] = slots.take(np.asarray(obj.material_indices, dtype=np.intp))
        if self.triangle_materials:
            table = [self.scene.materials[name] for name in names]
            self.object_material = np.asarray([number[obj.material] for obj in objects], dtype=np.intp)
            self.material_names = names
        else:
            table = [self.scene.materials[obj.material] for obj in objects]
            self.material_names = [obj.material for obj in objects]
        self.material_pass_index = np.asarray([m.pass_index for m in table], dtype=self.dtype)
        as_columns = lambda values: np.asarray(values, dtype=self.dtype).T.reshape(3, -1)  # noqa: E731
        self.colors = as_columns([m.color for m in table])  # (3, materials)
        self.specular = np.asarray([m.specular for m in table], dtype=self.dtype)
        self.reflective = np.asarray([m.reflective for m in table], dtype=self.dtype)
        self.emission = as_columns([m.emission for m in table])
        self.emissive = any(m.emission != sc.BLACK for m in table)
        self.specular_colors = as_columns([m.color if m.specular_color is None else m.specular_color for m in table])
        self.colored = any(m.specular_color is not None for m in table)
        self.two_sided = np.asarray([m.two_sided for m in table], dtype=bool)
        self.any_two_sided = bool(self.two_sided.any())
        # glass and transparency (trace_see_through): only where some material has them, else nothing of it runs
        self.see_through = any(m.see_through for m in table)
        self.shadow_alpha = any(m.alpha < 1.0 for m in table)  # shadow rays pass such surfaces (shadows.passing)
        if self.see_through:
            self.alpha = np.asarray([m.alpha for m in table], dtype=self.dtype)
            self.transmission = np.asarray([m.transmission for m in table], dtype=self.dtype)
            self.ior = np.asarray([m.ior for m in table], dtype=self.dtype)

    def _opaque_objects(self, count: int) -> list[bool]:
        """Whether each placed object's materials (a mesh's every triangle's) all have alpha 1."""
        opaque = []
        for index in range(count):
            if index in self.triangle_materials:
                rows = self.triangle_materials[index]
            else:
                rows = np.array([index if self.object_material is None else self.object_material[index]])
            opaque.append(bool(np.all(self.alpha.take(rows) >= 1.0)))
        return opaque

    def _smooth_normals(self, objects: tuple[sc.SceneObject, ...], primitives: list, vanes: list) -> None:
        """For each mesh with corner normals: its triangles' v0, e1, e2 and corner normals n0, n1, n2 (3, T) each,
        float64 (the reference's numbers); vanes: the vane that places each object."""
        self.smooth: dict[int, tuple[np.ndarray, ...]] = {}
        self.smooth_instances: dict[int, np.ndarray] = {}  # an instanced mesh's corner normals (T, 3, 3), local
        for index, (obj, primitive, vane) in enumerate(zip(objects, primitives, vanes, strict=True)):
            if isinstance(obj, sc.MeshInstances):
                if obj.normals is not None:
                    self.smooth_instances[index] = np.asarray(obj.normals, dtype=np.float64).reshape(-1, 3, 3)
                continue
            corners = tf.world_corner_normals(obj, vane)
            if corners is None:
                continue
            triangles = np.asarray(primitive.triangles, dtype=np.float64)  # (T, 3, 3)
            v0 = triangles[:, 0]
            parts = (v0, triangles[:, 1] - v0, triangles[:, 2] - v0, corners[:, 0], corners[:, 1], corners[:, 2])
            self.smooth[index] = tuple(np.ascontiguousarray(part.T) for part in parts)

    def _textures(self, objects: tuple[sc.SceneObject, ...], primitives: list) -> None:
        """Where a material row has a texture and a mesh has UVs or corner colours (textured): each such row's
        textures, and each such mesh's triangles' v0, e1, e2 (3, T) and corner UVs (2, T) or colours (3, T) each
        (float64, as for smooth normals), or an instanced mesh's corner UVs (T, 3, 2) or colours (T, 3, 3) in its own
        space. Without them nothing here runs while tracing."""
        rows = [self.scene.materials[name] for name in self.material_names]
        self.row_textures = [m.texture for m in rows]
        self.row_emission_textures = [m.emission_texture for m in rows]
        with_texture = [m.texture is not None or m.emission_texture is not None for m in rows]
        self.textured = any(with_texture) and any(
            getattr(obj, "uvs", None) is not None or getattr(obj, "colors", None) is not None for obj in objects
        )
        if not self.textured:
            return
        self.has_texture = np.asarray(with_texture, dtype=bool)
        self.emissive = self.emissive or any(e is not None for e in self.row_emission_textures)
        self.uv_meshes: dict[int, tuple[np.ndarray, ...]] = {}
        self.uv_instances: dict[int, np.ndarray] = {}
        self.color_meshes: dict[int, tuple[np.ndarray, ...]] = {}
        self.color_instances: dict[int, np.ndarray] = {}
        for index, (obj, primitive) in enumerate(zip(objects, primitives, strict=True)):
            for key, meshes, instances, width in (
                ("uvs", self.uv_meshes, self.uv_instances, 2),
                ("colors", self.color_meshes, self.color_instances, 3),
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

    def cryptomatte_hashes(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """The distinct names of the placed objects (cryptomatte_object) or material rows (cryptomatte_material)
        hashed as Cryptomatte's float ids (K,) float32, and each object's or row's index into them."""
        from .cryptomatte import name_hash

        names = self.object_names if name == "cryptomatte_object" else self.material_names
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
