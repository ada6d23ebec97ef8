"""A scene -> the documented tracer over arrays: every ray of a bounce at once (listings 3.1 and 3.2, vectorized).

TraceRay's recursion becomes a loop over bounces: each bounce finds the closest hit of all live rays, adds the
background for misses and weight * local color for hits, and the rays that hit reflective surfaces continue with
their weight multiplied by r. PreparedScene prepares a scene once (kernels, hierarchies, materials' rows, lights)
and traces it; its shading (FindIntensity per light over all hit points, shadow rays as any-hit tests) is
shading.py's, glass and transparency see_through.py's, both mixed into it.
"""

from __future__ import annotations

import functools
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.bvh import Hierarchy
from ..geometry.cull import CoverageGrid, ScreenRectangles
from ..geometry.footprint import Footprint, Volume
from ..geometry.instances import InstancesKernel, local_mesh_kernel
from ..geometry.kernels import (
    Kernel,
    SphereKernel,
    column,
    dot,
    indices,
    make_kernel,
    quiet,
    take,
)
from ..geometry.meshbvh import MESH_HIERARCHY_TRIANGLES, MergedMember, MergedMeshKernel, MeshKernel
from ..geometry.rayframes import RayFrames
from ..geometry.robust import make_robust_kernel, offset_origins
from ..scene import scene as sc
from .rays import CAMERA_T_MIN, REFLECTION_T_MIN, RayCounts, accumulate, tally
from .raystore import RayStore
from .recorder import PassRecorder, view_axis
from .see_through import SeeThrough
from .shading import Light, Shading

# this many still triangle meshes seen by the same rays go into the scene's hierarchy as one kernel (their
# triangles behind one hierarchy, MergedMeshKernel): 3,000 cubes as separate objects took 16x the time of the same
# triangles as one mesh, walking the scene's hierarchy node by node in Python. Below it (the default vane's 13
# objects) a leaf per object, as the small scenes' benchmarks were tuned
MERGE_MESHES_FROM = 64
MERGE_SIZE_FACTOR = 8.0  # merged: meshes at most this many times the group's median size (their boxes' longest side)
# a scene with glass or transparency traces pieces of 1 / this of the camera samples a band may hold: its wavefronts
# hold several rays per camera sample. The default scene with every material glass of alpha 0.7, 640x480 in one
# process: peak 262 MB in whole pieces, 152 MB in halves, 83 MB in quarters (the default scene: 73 MB); with a glass
# ball, CPU per band 120, 114 and 144 ms (quarters' overhead shows)
SEE_THROUGH_PIECE = 2


@dataclass
class PreparedScene(Shading, SeeThrough):
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
        # theirs has alpha 1), so that _shadow_through follows only the rays they leave open
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
        self.lights = []
        for source, light in enumerate(self.scene.lights):
            color = column(light.color, self.dtype)
            first = len(self.lights)
            if isinstance(light, sc.AmbientLight):
                self.lights.append(Light("ambient", light.intensity, color=color))
            elif isinstance(light, sc.PointLight | sc.SpotLight):
                offsets = lightsamples.disk_offsets(settings.shadow_samples) if light.radius > 0.0 else [None]
                share = light.intensity / len(offsets) if len(offsets) > 1 else light.intensity
                for offset in offsets:
                    made = Light("point", share, column(light.location, self.dtype), 1.0, color=color)
                    made.inverse_square = light.falloff == "inverse_square"
                    if isinstance(light, sc.SpotLight):
                        made.spot, made.axis = light, column(tf.normalize(light.direction), self.dtype)
                    if len(offsets) > 1:
                        made.disk, made.weight = (
                            (light.radius * offset[0], light.radius * offset[1]),
                            1.0 / len(offsets),
                        )
                    self.lights.append(made)
            elif isinstance(light, sc.AreaLight):
                self.lights.extend(self._area_samples(light, color))
            else:  # a sun of an angle: its samples' directions (one: the direction itself)
                directions = lightsamples.sun_directions(light, settings.shadow_samples)
                share = light.intensity / len(directions) if len(directions) > 1 else light.intensity
                self.lights.extend(
                    Light("directional", share, column(d, self.dtype), color=color, weight=1.0 / len(directions))
                    for d in directions
                )
            for made in self.lights[first:]:
                made.source = source
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
            for light in self.lights:
                if light.kind == "point" and light.disk is not None:
                    continue  # its rays end on a disk that faces each point: no grid from one point
                if light.kind == "point":
                    light.grid = CoverageGrid.from_point(light.vector.ravel().astype(np.float64), *boxes)
                elif light.kind == "directional":
                    light.grid = CoverageGrid.from_direction(light.vector.ravel().astype(np.float64), *boxes)
                if light.grid is not None and self.shadow_hierarchy.brute:
                    shares = self._sample_shares(light)
                    if shares is None or not self.shadow_hierarchy.culls_well(light.grid.kernels, shares):
                        light.grid = None

    def _area_samples(self, light: sc.AreaLight, color: np.ndarray) -> list[Light]:
        """An area light as point lights at its render.shadow_samples sample points (lightsamples.area_points),
        each with 1 / samples of its intensity, shining as a one-sided cosine emitter with inverse-square falloff."""
        points = lightsamples.area_points(light, self.scene.render.shadow_samples)
        normal = column(lightsamples.area_frame(light)[0], self.dtype)
        share = light.intensity / len(points) if len(points) > 1 else light.intensity
        made = []
        for point in points:
            sample = Light("point", share, column(point, self.dtype), 1.0, color=color, weight=1.0 / len(points))
            sample.inverse_square, sample.emitter = True, normal
            made.append(sample)
        return made

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

    def _mirror_sets(
        self,
        rows: np.ndarray | None,
        pixels: np.ndarray | None,
        pixel: np.ndarray,
        came_from: np.ndarray,
        total: int,
        runs: list[int] | None = None,
    ) -> tuple[list, np.ndarray | None]:
        """The first mirror rays' sets for Hierarchy.closest: rays (n,) of camera rays pixel (n,) off objects
        came_from (n,), of total camera rays in rows (R,) or of flat pixels (P,) -> (kernel, rays) for every kernel
        that the rays off a culled plane can meet (from self.mirrors), and the other rays (walked), or (None, None)
        where no ray comes off such a plane. runs: the pixels' frames, as ScreenRectangles.pixel_rays takes them."""
        sets, culled = [], []
        position = None  # each camera ray's mirror ray, where it has one off the plane at hand
        for plane, rectangles in self.mirrors.items():
            off_plane = indices(came_from == plane)
            if off_plane.size == 0:
                continue
            culled.append(plane)
            if position is None:
                position = np.full(total, -1, dtype=np.intp)
            camera_ray = pixel.take(off_plane)
            position[camera_ray] = off_plane
            if rows is not None:
                found = rectangles.rays(rows)
            else:
                found = rectangles.pixel_rays(pixels, runs, self.mirror_hierarchy.frame_of)
            for kernel, camera_rays in found:
                if camera_rays is None:
                    sets.append((kernel, off_plane))
                    continue
                rays = position.take(camera_rays)
                rays = rays.take(indices(rays >= 0))
                if rays.size:
                    sets.append((kernel, rays))
            position[camera_ray] = -1
        if not culled:
            return None, None
        other = came_from != culled[0]
        for plane in culled[1:]:
            other &= came_from != plane
        return sets, indices(other)

    def _sample_shares(self, light: Light) -> np.ndarray | None:
        """The share (k,) of a light's shadow rays that its grid gives each kernel, estimated on the rays from where
        _choose_brute_force's sample camera rays hit (None: none hits)."""
        O, D = self._samples
        t, obj, _ = self.camera_hierarchy.closest(O, D, CAMERA_T_MIN)
        hit = indices(obj >= 0)
        if hit.size == 0:
            return None
        P = take(O, hit) + take(D, hit) * t.take(hit)
        if light.kind == "point":
            return light.grid.shares(light.vector - P, reverse=True)
        return light.grid.shares(P)

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
        self.shadow_alpha = any(m.alpha < 1.0 for m in table)  # shadow rays pass such surfaces (_shadow_through)
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

    # ---- TraceRay as a wavefront -------------------------------------------------------------------------------

    def trace(
        self,
        D: np.ndarray,
        counts: RayCounts,
        rows: np.ndarray | None = None,
        origins: np.ndarray | None = None,
        far: np.ndarray | None = None,
        footprint: Footprint | RayStore | None = None,
        alpha: np.ndarray | None = None,
        pixels: np.ndarray | None = None,
        frames: np.ndarray | None = None,
        recorder: PassRecorder | None = None,
    ) -> np.ndarray:
        """Camera rays (3, N) -> linear colors (3, N), unclamped; alpha (N,), where given (ones), is set to 0 for
        the rays that meet a holdout first, or nothing with a transparent film.

        frames: for a scene prepared with headings, where each frame's camera rays start (K + 1,): the rays come
        frame by frame, and counts is then a list of each frame's RayCounts (K,).

        rows: the image rows (R,) that the rays are, ordered as camera.band_directions gives them, if they are;
        else pixels: the flat pixels (P,) whose samples they are, pixel by pixel, where known (either lets the
        screen rectangles cull the camera rays and their first mirror rays).
        origins (3, N): where each ray starts (None: all at the camera); far (N,): where each stops (None: never),
        as camera.band_starts gives them for a clipped or orthographic camera. footprint: records which of the N
        camera rays' trees meet its volume. recorder: keeps the render passes of the N camera rays."""
        if self.see_through:
            return self.trace_see_through(D, counts, rows, origins, far, footprint, alpha, pixels, frames, recorder)
        depth = self.scene.render.depth
        total = D.shape[1]
        query = None if frames is None else RayFrames(frames[None])  # which frame each ray of a query is of
        tally(counts, "camera", total, query)
        transparent = self.scene.render.film_transparent
        # a camera ray that meets nothing shows the background (its colour 0 with a transparent film): every pixel
        # starts with it, and the camera rays' hits overwrite theirs (no list of the misses to make)
        if transparent:
            color = np.zeros((3, total), dtype=self.dtype)
        else:
            color = np.empty((3, total), dtype=self.dtype)
            color[...] = self.background(D, None)
        weight = None  # each ray's product of reflectivities; a camera ray's is 1 (1 * x = x: none kept)
        pixel = np.arange(total)
        O = self.origin if origins is None else origins  # (3, 1): every camera ray starts at the camera
        t_min = CAMERA_T_MIN
        came_from = None  # the first mirror rays' objects, where some may come off a culled plane
        runs = None if frames is None else (frames // self.scene.render.samples).tolist()  # each frame's pixels
        for bounce in range(depth + 1):
            sets = walk = None
            if bounce == 0 and self.screen is not None and (rows is not None or pixels is not None):
                if rows is not None:
                    sets = self.screen.rays(rows)
                else:
                    sets = self.screen.pixel_rays(pixels, runs, self.camera_hierarchy.frame_of)
            elif bounce == 1 and came_from is not None:
                sets, walk = self._mirror_sets(rows, pixels, pixel, came_from, total, runs)
            hierarchy = self.camera_hierarchy if bounce == 0 else self.mirror_hierarchy
            t, obj, part = hierarchy.closest(O, D, t_min, sets, walk, query)
            if bounce == 0 and far is not None:  # beyond the camera's clip_end: the nearest hit is, so all are
                obj[t >= far] = -1
            if footprint is not None:  # each ray up to its hit; a miss to its end
                end = np.where(obj >= 0, t, np.inf if bounce or far is None else far)
                footprint.record(pixel, O, D, t_min, end, hit=obj)
            if bounce == 0:  # the misses already hold the background (or 0 under a transparent film)
                if transparent and alpha is not None:
                    alpha[obj < 0] = 0.0  # the film shows nothing there
                if recorder is not None:
                    missed = indices(obj < 0)
                    recorder.environment(missed, take(color, missed))
            else:
                miss = indices(obj < 0)
                if miss.size:
                    sky = weight.take(miss) * self.background(D, miss)
                    accumulate(color, pixel.take(miss), sky, False)
                    if recorder is not None:
                        recorder.environment(pixel.take(miss), sky)
            hit = indices(obj >= 0)
            if hit.size == 0:
                break
            if self.any_holdout:  # a holdout adds nothing, and a camera ray that meets it first leaves alpha 0
                held = self.holdout.take(obj.take(hit))
                if held.any():
                    if bounce == 0:  # nothing shows there, not even the background it started with
                        color[:, hit.take(indices(held))] = 0.0
                        if alpha is not None:
                            alpha[hit.take(indices(held))] = 0.0
                        if recorder is not None:
                            recorder.holdout(hit.take(indices(held)))
                    hit = hit.take(indices(~held))
                    if not hit.size:
                        break
            O, D, t, obj, part = take(O, hit), take(D, hit), t.take(hit), obj.take(hit), part.take(hit)
            if bounce:
                weight, pixel = weight.take(hit), pixel.take(hit)
            else:  # the camera rays' own positions
                pixel = hit
            P = O + D * t
            V = -D
            O = D = t = None  # memory: a band's peak comes in the shading below
            N, surface = self.normals(P, obj, part)
            material = self.material_of(obj, part)
            S = self.shading_normals(N, V, P, obj, part, material)
            geometric = None if S is N else N
            specular = self.specular.take(material)
            points = None if frames is None else np.searchsorted(pixel, frames)  # where each frame's points start
            split = {} if recorder is not None and bounce == 0 and recorder.shading else None
            intensity = self.find_intensity(
                P, S, V, specular, counts, surface, footprint, pixel, geometric, points, split
            )
            reflective = self.reflective.take(material)
            colors, specular_colors, emission = self.surface_colors(material, P, obj, part)
            if recorder is not None and bounce == 0:
                recorder.first_hit(pixel, P, S, obj, material)
                if split is not None:
                    recorder.terms(pixel, split, material, reflective, (colors, specular_colors, emission))
            if self.colored:
                diffuse, highlight = intensity
                lit = diffuse * colors
                local = (lit + highlight * specular_colors) * (1.0 - reflective)
            else:
                local = (intensity * (1.0 - reflective)) * colors
            if self.emissive:
                local = local + emission
            if bounce:
                local = weight * local
            accumulate(color, pixel, local, bounce == 0)
            if recorder is not None and bounce:
                recorder.reflection(pixel, local)
            go_on = indices(reflective > 0.0)
            if bounce == depth or go_on.size == 0:
                break
            same = S is N
            P, N, V = take(P, go_on), take(N, go_on), take(V, go_on)
            S = N if same else take(S, go_on)
            k = 2.0 * dot(S, V)
            O, D = P, S * k - V
            if self.robust:
                O = offset_origins(P, N, D, *(part.take(go_on) for part in surface))
            ratio = reflective.take(go_on)
            weight, pixel = ratio if weight is None else weight.take(go_on) * ratio, pixel.take(go_on)
            if bounce == 0 and (rows is not None or pixels is not None) and self.mirrors:
                came_from = obj.take(go_on)
            if frames is not None:
                query = RayFrames.of(pixel, frames)
            tally(counts, "reflection", D.shape[1], query)
            t_min = 0.0 if self.robust else REFLECTION_T_MIN
        return color

    # ---- the bands' scheduling: pieces of camera samples, rows, pixels ------------------------------------------

    def _piece_samples(self, max_samples: int | None) -> int | None:
        """The camera samples a piece may hold: max_samples, or 1 / SEE_THROUGH_PIECE of it where the scene has
        glass or transparency (a see-through wavefront holds a mirror, a refracted and a straight ray per hit)."""
        if max_samples is None or not self.see_through:
            return max_samples
        return max(1, max_samples // SEE_THROUGH_PIECE)

    def render_rows(
        self,
        rows: np.ndarray,
        max_samples: int | None = None,
        volume: Volume | None = None,
        touched: np.ndarray | None = None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """Image rows (R,) -> (R, width, 3) linear image in the scene's dtype (4 channels with alpha), and the ray
        counts.

        max_samples: trace at most this many camera samples at once (memory); a larger band goes in pieces of whole
        rows, or of a row's columns where one row is too many. Every ray is traced by the same elementwise
        operations whatever else is in its piece, so the pixels are the same bytes either way. volume, touched
        (R, width) bool: marks each pixel some of whose rays' trees meet the volume (footprint.py). passes: the
        scene's render passes' planar arrays of the whole image (recorder.plane_shape, plane_dtype), whose rows go
        in; None: no pass is traced."""
        settings = self.scene.render
        per_row = settings.width * settings.samples
        rows = np.asarray(rows)
        max_samples = self._piece_samples(max_samples)
        if not settings.passes:
            passes = None
        if settings.border is not None:
            return self._render_border_rows(rows, max_samples, volume, touched, passes)
        if max_samples is None or len(rows) * per_row <= max_samples:
            return self._render_piece(rows, None, volume, touched, passes)
        counts = RayCounts()
        image = np.empty((len(rows), settings.width, self.channels), dtype=self.dtype)
        rows_at_once = max_samples // per_row
        if rows_at_once >= 1:
            for first in range(0, len(rows), rows_at_once):
                part = slice(first, first + rows_at_once)
                piece_touched = None if touched is None else touched[part]
                image[part], piece_counts = self._render_piece(rows[part], None, volume, piece_touched, passes)
                counts.add(piece_counts)
            return image, counts
        columns_at_once = max(1, max_samples // settings.samples)
        for index, row in enumerate(rows):
            for first in range(0, settings.width, columns_at_once):
                columns = np.arange(first, min(first + columns_at_once, settings.width))
                piece_touched = None if touched is None else touched[index : index + 1, first : first + len(columns)]
                piece, piece_counts = self._render_piece(np.asarray([row]), columns, volume, piece_touched, passes)
                image[index, columns] = piece[0]
                counts.add(piece_counts)
        return image, counts

    def _render_border_rows(
        self,
        rows: np.ndarray,
        max_samples: int | None,
        volume: Volume | None,
        touched: np.ndarray | None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """render_rows() with a render border: only the pixels inside it are traced (in pieces of whole rows of the
        border), the others are 0 (alpha 0, and every pass)."""
        settings = self.scene.render
        x0, x1, y0, y1 = cam.border_window(settings)
        image = np.zeros((len(rows), settings.width, self.channels), dtype=self.dtype)
        for plane in (passes or {}).values():
            plane[:, rows] = 0.0
        counts = RayCounts()
        inside = indices((rows >= y0) & (rows < y1))
        columns = np.arange(x0, x1)
        at_once = inside.size if max_samples is None else max(1, max_samples // (len(columns) * settings.samples))
        for first in range(0, inside.size, max(1, at_once)):
            part = inside[first : first + at_once]
            piece_touched = None if touched is None else np.zeros((len(part), len(columns)), dtype=bool)
            piece, piece_counts = self._render_piece(rows.take(part), columns, volume, piece_touched, passes)
            image[part, x0:x1] = piece
            if touched is not None:
                touched[part, x0:x1] = piece_touched
            counts.add(piece_counts)
        return image, counts

    def _render_piece(
        self,
        rows: np.ndarray,
        columns: np.ndarray | None,
        volume: Volume | None,
        touched: np.ndarray | None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """Rows (R,) and columns (C,) of the image (every column when None; else consecutive) -> (R, C, 3) and the
        ray counts; touched (R, C) is filled where a volume is given, and the passes' planes (render_rows) at those
        rows and columns."""
        settings = self.scene.render
        camera = self.scene.camera
        with quiet():  # the directions are not kept here: trace() lets them go after the first bounce
            if columns is None:
                directions = cam.cached_band_directions(camera, settings, rows, self.dtype)
            else:
                directions = cam.band_directions(camera, settings, rows, columns).astype(self.dtype)
        pixels = None if cam.shares_origin(camera) else cam.band_pixels(settings, rows, columns)
        # whole rows: the screen rectangles cull them
        at = (
            None
            if passes is None
            else (passes, rows, slice(None) if columns is None else slice(columns[0], columns[-1] + 1))
        )
        colors, counts, hit = self._trace_pixels(
            directions, pixels, rows if columns is None else None, volume, passes=at
        )
        width = settings.width if columns is None else len(columns)
        if touched is not None:
            touched[...] = hit.reshape(len(rows), width)
        return colors.reshape(len(rows), width, self.channels), counts

    def render_pixels(
        self, pixels: np.ndarray, max_samples: int | None = None, store: RayStore | None = None
    ) -> tuple[np.ndarray, RayCounts]:
        """Flat pixel indices j * W + i (P,) -> their linear colours (P, 3; P, 4 with alpha) in the scene's dtype,
        and the ray counts: the same bytes as those pixels of a whole image (the incremental frames' re-trace).
        store: keeps every segment of their ray trees (edits.py)."""
        settings = self.scene.render
        max_samples = self._piece_samples(max_samples)
        at_once = len(pixels) if max_samples is None else max(1, max_samples // settings.samples)
        colors = np.empty((len(pixels), self.channels), dtype=self.dtype)
        counts = RayCounts()
        for first in range(0, len(pixels), at_once):
            piece = np.asarray(pixels[first : first + at_once])
            with quiet():
                directions = cam.pixel_directions(self.scene.camera, settings, piece).astype(self.dtype)
            if store is not None:
                store.begin(piece, settings.samples)
            traced = self._trace_pixels(directions, piece, None, None, store)
            colors[first : first + at_once], piece_counts, _ = traced
            counts.add(piece_counts)
        return colors, counts

    def render_frame_pixels(
        self, frame_pixels: list[np.ndarray], max_samples: int | None = None
    ) -> list[tuple[np.ndarray, RayCounts]]:
        """For a scene prepared with headings (K,): each frame's flat pixels (P_k,), ascending -> their linear
        colours (P_k, channels) and ray counts, the same bytes as render_pixels() of the scene at that heading. The
        frames share one trace: every NumPy call of a bounce serves them all, and the still objects are prepared
        once."""
        if self.headings is None or len(frame_pixels) != len(self.headings):
            raise ValueError("render_frame_pixels needs one list of pixels per heading the scene was prepared with")
        if any(np.any(np.diff(pixels) < 0) for pixels in frame_pixels):
            raise ValueError("render_frame_pixels needs each frame's pixels in ascending order")
        settings = self.scene.render
        sizes = [len(pixels) for pixels in frame_pixels]
        pixels = np.concatenate([np.asarray(pixels, dtype=np.int64) for pixels in frame_pixels])
        starts = np.concatenate(([0], np.cumsum(sizes)))  # (K + 1,): where each frame's pixels start
        max_samples = self._piece_samples(max_samples)
        at_once = max(1, len(pixels)) if max_samples is None else max(1, max_samples // settings.samples)
        colors = np.empty((len(pixels), self.channels), dtype=self.dtype)
        counts = [RayCounts() for _ in sizes]
        for first in range(0, len(pixels), at_once):
            piece = pixels[first : first + at_once]
            with quiet():
                directions = cam.pixel_directions(self.scene.camera, settings, piece).astype(self.dtype)
            frames = np.clip(starts - first, 0, piece.size) * settings.samples
            traced = self._trace_pixels(directions, piece, None, None, None, frames, counts)
            colors[first : first + at_once] = traced[0]
        ends = starts.tolist()
        return [
            (colors[start:end], ray_counts) for start, end, ray_counts in zip(ends[:-1], ends[1:], counts, strict=True)
        ]

    def _trace_pixels(
        self,
        directions: np.ndarray,
        pixels: np.ndarray | None,
        rows: np.ndarray | None,
        volume: Volume | None,
        store: RayStore | None = None,
        frames: np.ndarray | None = None,
        frame_counts: list[RayCounts] | None = None,
        passes: tuple[dict[str, np.ndarray], np.ndarray, slice] | None = None,
    ) -> tuple[np.ndarray, RayCounts, np.ndarray | None]:
        """Camera rays (3, P * samples) of the flat pixels (P,; needed only for a camera whose rays do not all
        start at its location) -> colours (P, 3) box-filtered over each pixel's samples (P, 4 with the alpha, the
        share of samples that met a visible object, where the scene has one), the ray counts, and where a volume is
        given which pixels' trees met it (P,). frames, frame_counts: as trace() takes them (the counts returned are
        then empty). passes: (planes, rows, columns) where the pixels' render passes go (PassRecorder); None: none is
        traced."""
        settings = self.scene.render
        camera = self.scene.camera
        counts = RayCounts()
        footprint = store if store is not None else None if volume is None else Footprint(volume, directions.shape[1])
        with quiet():
            origins = far = None
            if not cam.shares_origin(camera):
                origins, far = cam.pixel_starts(camera, settings, pixels, directions)
                origins = origins.astype(self.dtype)
            alpha = np.ones(directions.shape[1], dtype=self.dtype) if self.has_alpha else None
            recorder = None if passes is None else PassRecorder(self, directions.shape[1], *passes)
            color = self.trace(
                directions,
                counts if frames is None else frame_counts,
                rows,
                origins,
                far,
                footprint,
                alpha,
                None if rows is not None else pixels,
                frames,
                recorder,
            )
        if alpha is not None:
            color = np.concatenate((color, alpha[None]))
        samples = color.reshape(color.shape[0], -1, settings.samples)
        image = samples.sum(axis=2) / settings.samples if settings.samples > 1 else samples[..., 0]
        if recorder is not None:
            recorder.combine(settings.samples)
        hit = None if volume is None else footprint.touched.reshape(-1, settings.samples).any(axis=1)
        return np.ascontiguousarray(image.T), counts, hit


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
