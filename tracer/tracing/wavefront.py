"""A scene -> the documented tracer over arrays: every ray of a bounce at once (listings 3.1 and 3.2, vectorized).

TraceRay's recursion becomes a loop over bounces: each bounce finds the closest hit of all live rays, adds the
background for misses and weight * local color for hits, and the rays that hit reflective surfaces continue with
their weight multiplied by r. FindIntensity runs per light over all hit points, shadow rays as any-hit tests.
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry import transforms as tf
from ..geometry.bvh import Hierarchy
from ..geometry.cull import CoverageGrid, ScreenRectangles, kernel_sets
from ..geometry.footprint import Footprint, Volume
from ..geometry.instances import InstancesKernel, local_mesh_kernel
from ..geometry.kernels import (
    Kernel,
    PlaneKernel,
    SphereKernel,
    column,
    dot,
    indices,
    interpolated_corners,
    make_kernel,
    quiet,
    spread,
    take,
    unit,
    unit_or,
)
from ..geometry.meshbvh import MESH_HIERARCHY_TRIANGLES, MergedMember, MergedMeshKernel, MeshKernel
from ..geometry.meshpicture import View
from ..geometry.rayframes import RayFrames
from ..geometry.robust import make_robust_kernel, offset_origins
from ..scene import scene as sc
from .raystore import RayStore
from .recorder import PassRecorder, view_axis
from .texturing import sample as sample_texture

# this many still triangle meshes seen by the same rays go into the scene's hierarchy as one kernel (their
# triangles behind one hierarchy, MergedMeshKernel): 3,000 cubes as separate objects took 16x the time of the same
# triangles as one mesh, walking the scene's hierarchy node by node in Python. Below it (the default vane's 13
# objects) a leaf per object, as the small scenes' benchmarks were tuned
MERGE_MESHES_FROM = 64
MERGE_SIZE_FACTOR = 8.0  # merged: meshes at most this many times the group's median size (their boxes' longest side)
CAMERA_T_MIN = 0.0  # seed 2.10: t >= 0
SHADOW_T_MIN = 0.001  # listing 3.2
REFLECTION_T_MIN = 0.01  # listing 3.1
# a scene with glass or transparency traces pieces of 1 / this of the camera samples a band may hold: its wavefronts
# hold several rays per camera sample. The default scene with every material glass of alpha 0.7, 640x480 in one
# process: peak 262 MB in whole pieces, 152 MB in halves, 83 MB in quarters (the default scene: 73 MB); with a glass
# ball, CPU per band 120, 114 and 144 ms (quarters' overhead shows)
SEE_THROUGH_PIECE = 2


@dataclass
class RayCounts:
    camera: int = 0
    shadow: int = 0
    reflection: int = 0

    @property
    def total(self) -> int:
        return self.camera + self.shadow + self.reflection

    def add(self, other: RayCounts) -> None:
        self.camera += other.camera
        self.shadow += other.shadow
        self.reflection += other.reflection


@dataclass
class _Light:
    kind: str
    intensity: float
    vector: np.ndarray | None = None  # (3, 1): point location or direction toward the light
    t_max: float = math.inf
    grid: CoverageGrid | None = None  # which shadow rays can meet a bounded object
    color: np.ndarray | None = None  # (3, 1) in the tracing dtype
    inverse_square: bool = False  # a point or spot light's terms divided by |L|^2
    spot: sc.SpotLight | None = None  # a spot light: its terms multiplied by spot_attenuation()
    axis: np.ndarray | None = None  # a spot light's unit axis (3, 1)
    # one sample point of an area light: the unit normal it shines along (3, 1), its terms multiplied by the
    # cosine there (a one-sided Lambertian emitter) and by 1 / |L|^2
    emitter: np.ndarray | None = None
    source: int = 0  # the scene light it is (or is a sample of): its index in scene.lights
    weight: float = 1.0  # its share of that light (1 / samples for a light of a size), for the Shadow pass
    # one sample of a point or spot light of a radius: its offset (radius * (a, b)) on the disk facing each point
    # (lightsamples.facing_basis of the direction toward the light's centre)
    disk: tuple[float, float] | None = None

    @property
    def view(self) -> View | None:
        """What the light's shadow rays share, for the meshes' pictures: they end at a point light (their vectors
        point toward it) and run along a directional light's direction; nothing for a sample on a disk that faces
        each point (its rays end at different points: the meshes' hierarchies are walked)."""
        if self.disk is not None:
            return None
        vector = tuple(self.vector.ravel().astype(np.float64).tolist())
        return View("point", vector, reverse=True) if self.kind == "point" else View("direction", vector)


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
                self.lights.append(_Light("ambient", light.intensity, color=color))
            elif isinstance(light, sc.PointLight | sc.SpotLight):
                offsets = lightsamples.disk_offsets(settings.shadow_samples) if light.radius > 0.0 else [None]
                share = light.intensity / len(offsets) if len(offsets) > 1 else light.intensity
                for offset in offsets:
                    made = _Light("point", share, column(light.location, self.dtype), 1.0, color=color)
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
                    _Light("directional", share, column(d, self.dtype), color=color, weight=1.0 / len(directions))
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

    def _area_samples(self, light: sc.AreaLight, color: np.ndarray) -> list[_Light]:
        """An area light as point lights at its render.shadow_samples sample points (lightsamples.area_points),
        each with 1 / samples of its intensity, shining as a one-sided cosine emitter with inverse-square falloff."""
        points = lightsamples.area_points(light, self.scene.render.shadow_samples)
        normal = column(lightsamples.area_frame(light)[0], self.dtype)
        share = light.intensity / len(points) if len(points) > 1 else light.intensity
        made = []
        for point in points:
            sample = _Light("point", share, column(point, self.dtype), 1.0, color=color, weight=1.0 / len(points))
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

    def _sample_shares(self, light: _Light) -> np.ndarray | None:
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
        """Where a material row has a texture and a mesh has UVs (textured): each such row's textures, and each
        such mesh's triangles' v0, e1, e2 (3, T) and corner UVs (2, T) each (float64, as for smooth normals), or an
        instanced mesh's corner UVs (T, 3, 2) in its own space. Without them nothing here runs while tracing."""
        rows = [self.scene.materials[name] for name in self.material_names]
        self.row_textures = [m.texture for m in rows]
        self.row_emission_textures = [m.emission_texture for m in rows]
        with_texture = [m.texture is not None or m.emission_texture is not None for m in rows]
        self.textured = any(with_texture) and any(getattr(obj, "uvs", None) is not None for obj in objects)
        if not self.textured:
            return
        self.has_texture = np.asarray(with_texture, dtype=bool)
        self.emissive = self.emissive or any(e is not None for e in self.row_emission_textures)
        self.uv_meshes: dict[int, tuple[np.ndarray, ...]] = {}
        self.uv_instances: dict[int, np.ndarray] = {}
        for index, (obj, primitive) in enumerate(zip(objects, primitives, strict=True)):
            uvs = getattr(obj, "uvs", None)
            if uvs is None:
                continue
            if isinstance(obj, sc.MeshInstances):
                self.uv_instances[index] = np.asarray(uvs, dtype=np.float64).reshape(-1, 3, 2)
                continue
            triangles = np.asarray(primitive.triangles, dtype=np.float64)  # (T, 3, 3), world
            v0 = triangles[:, 0]
            parts = (v0, triangles[:, 1] - v0, triangles[:, 2] - v0, uvs[:, 0], uvs[:, 1], uvs[:, 2])
            self.uv_meshes[index] = tuple(np.ascontiguousarray(part.T) for part in parts)

    def surface_colors(
        self, material: np.ndarray, P: np.ndarray, obj: np.ndarray, part: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The hits' material colours (3, n), specular colours (3, n; None unless self.colored) and emission (3, n;
        None unless self.emissive): the material rows' own, and on a textured mesh the texture's sample at the hit's
        UV (the barycentric interpolation of its triangle's corner UVs, as smooth normals'): a texture replaces the
        colour (and the specular colour of a material without one), an emission texture the emission."""
        colors = self.colors.take(material, axis=1)
        specular = self.specular_colors.take(material, axis=1) if self.colored else None
        emission = self.emission.take(material, axis=1) if self.emissive else None
        if not self.textured:
            return colors, specular, emission
        for index in (*self.uv_meshes, *self.uv_instances):
            rows = indices(obj == index)
            if rows.size:
                rows = rows.take(indices(self.has_texture.take(material.take(rows))))
            if not rows.size:
                continue
            triangle = part.take(rows)
            if index in self.uv_meshes:
                v0, e1, e2, uv0, uv1, uv2 = self.uv_meshes[index]
                w = take(P, rows).astype(np.float64) - v0.take(triangle, axis=1)
                corners = (uv.take(triangle, axis=1) for uv in (uv0, uv1, uv2))
                uv = interpolated_corners(w, e1.take(triangle, axis=1), e2.take(triangle, axis=1), *corners)
            else:
                uv, _ = self.kernels[index].corner_values(take(P, rows), triangle, self.uv_instances[index])
            rows_material = material.take(rows)
            for row in np.unique(rows_material).tolist():
                mine = indices(rows_material == row)
                where = rows.take(mine)
                u, v = uv[0].take(mine), uv[1].take(mine)
                texture, glow = self.row_textures[row], self.row_emission_textures[row]
                if texture is not None:
                    value = sample_texture(texture, u, v).astype(self.dtype)
                    colors[:, where] = value
                    if specular is not None and self.scene.materials[self.material_names[row]].specular_color is None:
                        specular[:, where] = value
                if glow is not None:
                    emission[:, where] = sample_texture(glow, u, v).astype(self.dtype)
        return colors, specular, emission

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

    def shading_normals(
        self, N: np.ndarray, V: np.ndarray, P: np.ndarray, obj: np.ndarray, part: np.ndarray, material: np.ndarray
    ) -> np.ndarray:
        """The normals (3, n) that lighting and the mirror direction use: N (the geometric unit normals) where
        nothing changes them; a smooth mesh's interpolated corner normals; flipped where a two-sided material is
        hit from behind (N.V < 0, that is N.D > 0)."""
        S = N
        if self.smooth_instances:
            S = np.array(N, copy=True)
            for index, corners in self.smooth_instances.items():
                rows = indices(obj == index)
                if rows.size:
                    unit = self.kernels[index].smooth_normals(take(P, rows), part.take(rows), corners, take(N, rows))
                    for axis in range(3):
                        S[axis][rows] = unit[axis]
        if self.smooth:
            S = np.array(S, copy=True)
            for index, (v0, e1, e2, n0, n1, n2) in self.smooth.items():
                rows = indices(obj == index)
                if not rows.size:
                    continue
                triangle = part.take(rows)
                w = take(P, rows).astype(np.float64) - v0.take(triangle, axis=1)
                corners = (n.take(triangle, axis=1) for n in (n0, n1, n2))
                n = interpolated_corners(w, e1.take(triangle, axis=1), e2.take(triangle, axis=1), *corners)
                unit = unit_or(n, take(N, rows))  # the flat normal where the corners cancel
                for axis in range(3):
                    S[axis][rows] = unit[axis]
        if self.any_two_sided:
            flip = self.two_sided.take(material) & (dot(N, V) < 0.0)
            if flip.any():
                S = np.where(flip, -S, S)
        return S

    # ---- intersection ------------------------------------------------------------------------------------------

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

    # ---- shading -----------------------------------------------------------------------------------------------

    def find_intensity(
        self,
        P: np.ndarray,
        N: np.ndarray,
        V: np.ndarray,
        specular: np.ndarray,
        counts: RayCounts,
        surface: tuple[np.ndarray, np.ndarray] | None = None,
        footprint: Footprint | None = None,
        samples: np.ndarray | None = None,
        geometric: np.ndarray | None = None,
        frames: np.ndarray | None = None,
        split: dict[str, np.ndarray] | None = None,
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Listing 3.2 for every hit point at once: P, N, V (3, n), specular (n,) -> intensity (n,); where lights or
        materials have colours (self.colored) the (ambient + diffuse, specular) intensities (3, n) each instead.

        geometric: the surfaces' own unit normals where N (the shading normals) differs, for robust shadow origins.

        surface: robust numerics' (distance, scale) (n,) of each point, as normals() gives them. footprint: records
        the shadow rays of the camera samples (n,) the points belong to. frames: where each frame's points start
        (K + 1,), for a scene prepared with headings (counts is then a list of each frame's).

        The shadow rays of all lights go through the hierarchy in one batch; the terms are then added light by
        light in the listing's order.

        split: a dict to fill with the same sums term by term for the passes: "ambient", "diffuse", "specular" ((n,)
        each, (3, n) where coloured) and "shadow" (n,), the share of the lights (not ambient) that reach each point
        (face it and are not blocked); the intensity returned is the same bytes either way."""
        settings = self.scene.render
        count = P.shape[1]
        length_n = np.sqrt(dot(N, N))
        length_v = np.sqrt(dot(V, V))
        shiny = specular > 0.0
        exponent = specular * settings.coef if settings.model == "blinn-phong" else specular
        terms = []
        toward_eye = None  # V / |V|, the same for every light's half vector
        facing: dict[int, tuple] = {}  # a light of a radius: the disk's axes at each point, by scene light
        for light in self.lights:
            if light.kind == "ambient":
                terms.append(None)
                continue
            L = light.vector - P if light.kind == "point" else light.vector  # a directional L broadcasts
            if light.disk is not None:  # a sample on the disk of the light's radius that faces the point
                if light.source not in facing:
                    facing[light.source] = facing_basis(L)
                e1, e2 = facing[light.source]
                L = L + (light.disk[0] * e1 + light.disk[1] * e2).astype(self.dtype, copy=False)
            NL = dot(N, L)
            length_l = np.sqrt(dot(L, L))
            gate = shiny.copy()
            if settings.gate_specular:
                gate &= NL > 0.0
            if settings.model == "phong":
                k = 2.0 * dot(N, L)
                R = N * k - L
                RV = dot(R, V)
                gate &= RV > 0.0
                cosine = RV / (np.sqrt(dot(R, R)) * length_v)
            else:
                if toward_eye is None:
                    toward_eye = V / length_v
                H = L / length_l + toward_eye
                HN = dot(H, N)
                gate &= HN > 0.0
                cosine = HN / (np.sqrt(dot(H, H)) * length_n)
            # a shadow ray only where this light could add something: the result is the listing's, with fewer rays
            diffuse_gate = NL > 0.0
            factor = None
            if light.inverse_square or light.spot is not None or light.emitter is not None:
                factor = self._attenuation(light, L, length_l)
            if light.spot is not None or light.emitter is not None:
                needed = indices((diffuse_gate | gate) & (factor > 0.0))
            else:
                needed = indices(diffuse_gate | gate)
            terms.append((L, NL, length_l, diffuse_gate, gate, cosine, needed, factor))
        normals = N if geometric is None else geometric
        lit = self._lit(
            [term for term in terms if term is not None], P, normals, counts, surface, footprint, samples, frames
        )
        throughs = None  # each light's share that passes partly transparent surfaces (alpha < 1)
        if self.shadow_alpha:
            own = [term for term in terms if term is not None]
            throughs = self._shadow_through(own, lit, P, normals, counts, surface, frames)
            lit = [through > 0.0 for through in throughs]
        if split is not None:
            reached = [
                light_lit & (term[3] | term[4]) for light_lit, term in zip(lit, [t for t in terms if t], strict=True)
            ]
            if throughs is not None:
                reached = [light_reached * through for light_reached, through in zip(reached, throughs, strict=True)]
            share = np.zeros(count, dtype=self.dtype)
            weights = [light.weight for light in self.lights if light.kind != "ambient"]
            if all(weight == 1.0 for weight in weights):
                for light_reached in reached:
                    share += light_reached
                split["shadow"] = share / len(reached) if reached else np.ones(count, dtype=self.dtype)
            else:  # a light of a size counts once, each of its samples by its share
                for light_reached, weight in zip(reached, weights, strict=True):
                    share += light_reached * weight
                split["shadow"] = share / sum(weights)
        if self.colored:
            return self._colored(terms, lit, count, length_n, exponent, split, throughs)
        intensity = np.zeros(count, dtype=self.dtype)
        if split is not None:
            ambient, diffuse_sum, specular_sum = (np.zeros(count, dtype=self.dtype) for _ in range(3))
        shadow_rays = iter(lit)
        passing = None if throughs is None else iter(throughs)
        for light, term in zip(self.lights, terms, strict=True):
            if term is None:
                intensity = intensity + light.intensity
                if split is not None:
                    ambient = ambient + light.intensity
                continue
            L, NL, length_l, diffuse_gate, gate, cosine, needed, _ = term
            light_lit = next(shadow_rays)
            diffuse = light.intensity * NL / (length_n * length_l)
            if passing is not None:
                through = next(passing)
                diffuse = diffuse * through
            intensity = np.where(light_lit & diffuse_gate, intensity + diffuse, intensity)
            gate &= light_lit
            highlight = light.intensity * np.power(np.where(gate, cosine, 1.0), exponent)
            if passing is not None:
                highlight = highlight * through
            intensity = np.where(gate, intensity + highlight, intensity)
            if split is not None:
                diffuse_sum = np.where(light_lit & diffuse_gate, diffuse_sum + diffuse, diffuse_sum)
                specular_sum = np.where(gate, specular_sum + highlight, specular_sum)
        if split is not None:
            split.update(ambient=ambient, diffuse=diffuse_sum, specular=specular_sum)
        return intensity

    def _colored(
        self,
        terms: list,
        lit: list[np.ndarray],
        count: int,
        length_n: np.ndarray,
        exponent: np.ndarray,
        split: dict[str, np.ndarray] | None = None,
        throughs: list[np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The light-by-light sums of find_intensity with each light's colour and attenuation: (ambient + diffuse,
        specular) (3, n) each; split: also the ambient and the diffuse sums apart (find_intensity)."""
        diffuse_sum = np.zeros((3, count), dtype=self.dtype)
        specular_sum = np.zeros((3, count), dtype=self.dtype)
        ambient = lights_diffuse = None
        if split is not None:
            ambient, lights_diffuse = np.zeros((3, count), dtype=self.dtype), np.zeros((3, count), dtype=self.dtype)
        shadow_rays = iter(lit)
        passing = None if throughs is None else iter(throughs)
        for light, term in zip(self.lights, terms, strict=True):
            if term is None:
                diffuse_sum = diffuse_sum + light.intensity * light.color
                if split is not None:
                    ambient = ambient + light.intensity * light.color
                continue
            _, NL, length_l, diffuse_gate, gate, cosine, _, factor = term
            light_lit = next(shadow_rays)
            diffuse = light.intensity * NL / (length_n * length_l)
            highlight = light.intensity * np.power(np.where(gate & light_lit, cosine, 1.0), exponent)
            if factor is not None:
                diffuse = diffuse * factor
                highlight = highlight * factor
            if passing is not None:
                through = next(passing)
                diffuse = diffuse * through
                highlight = highlight * through
            diffuse_sum = np.where(light_lit & diffuse_gate, diffuse_sum + diffuse * light.color, diffuse_sum)
            if split is not None:
                lights_diffuse = np.where(
                    light_lit & diffuse_gate, lights_diffuse + diffuse * light.color, lights_diffuse
                )
            gate &= light_lit
            specular_sum = np.where(gate, specular_sum + highlight * light.color, specular_sum)
        if split is not None:
            split.update(ambient=ambient, diffuse=lights_diffuse, specular=specular_sum)
        return diffuse_sum, specular_sum

    def _attenuation(self, light: _Light, L: np.ndarray, length_l: np.ndarray) -> np.ndarray:
        """A point or spot light's factor (n,) on its terms: 1 / |L|^2 for inverse_square falloff, times a spot
        light's spot_attenuation() (the same operations as the reference's)."""
        factor = None
        if light.spot is not None:
            cosine = -dot(L, light.axis) / length_l  # the angle at the light between its axis and the point
            factor = spot_attenuation(cosine, light.spot)
        if light.emitter is not None:  # an area light's sample: a one-sided cosine emitter
            factor = np.maximum(-dot(L, light.emitter) / length_l, 0.0)
        if light.inverse_square:
            falloff = 1.0 / dot(L, L)
            factor = falloff if factor is None else factor * falloff
        return factor

    def _lit(
        self,
        terms: list[tuple],
        P: np.ndarray,
        N: np.ndarray,
        counts: RayCounts,
        surface: tuple[np.ndarray, np.ndarray] | None,
        footprint: Footprint | None = None,
        samples: np.ndarray | None = None,
        frames: np.ndarray | None = None,
    ) -> list[np.ndarray]:
        """One any-hit query for the shadow rays of every light: which points (n,) each light reaches; frames: where
        each frame's points start (K + 1,), as find_intensity() takes them.

        Robust numerics start each shadow ray just off the surface (offset_origins), on the light's side, and search
        t from 0; the documented ones start on the surface and search t from 0.001 (listing 3.2)."""
        lights = [(index, light) for index, light in enumerate(self.lights) if light.kind != "ambient"]
        t_min = 0.0 if self.robust else SHADOW_T_MIN
        shadows, origins, vectors, limits, bits, views, runs = [], [], [], [], [], [], []
        start = 0  # where the light's rays start in the query of all lights
        for (_, light), (L, *_, needed, _) in zip(lights, terms, strict=True):
            vector = take(L, needed)  # a directional light's vector stays a shared column
            origin = take(P, needed)
            if self.robust:
                target = take(P, needed) + vector if light.disk is not None else light.vector
                origin = offset_origins(origin, take(N, needed), vector, *(part.take(needed) for part in surface))
                if light.kind == "point":
                    vector = target - origin  # t = 1 is still exactly the light
            if footprint is not None:  # the whole segment: a blocker that moves in could block it anywhere
                footprint.record(samples.take(needed), origin, vector, t_min, light.t_max, light=light.source)
            own = None if frames is None else RayFrames.of(needed, frames)  # the light's rays by frame
            _tally(counts, "shadow", needed.size, own)
            # planes first, light by light (a shared direction keeps their test cheap); then only the rays that
            # the light's coverage grid cannot rule out go on to the hierarchy, all lights in one batch
            whole = [] if light.grid is None else light.grid.whole  # what the light's picture leaves out
            blocked = self.shadow_hierarchy.blocked_by_planes(origin, vector, t_min, light.t_max, whole, own)
            if light.grid is None:
                rest, covering = indices(~blocked), None
            else:
                rest, covering = light.grid.select(vector, True) if light.kind == "point" else light.grid.select(origin)
                keep = indices(~blocked.take(rest))
                rest = rest.take(keep)
                covering = None if covering is None else covering.take(keep)
            bits.append(None if covering is None else (light.grid.kernels, covering))
            shadows.append((needed, blocked, rest))
            if own is not None:
                runs.append(RayFrames.of(rest, own.cuts[0], start))
            start += rest.size
            every = light.grid is None and rest.size == needed.size  # nothing left out: no need to gather
            origins.append(origin if every and origin.shape[1] == rest.size else take(origin, rest))
            if vector.shape[1] == 1:
                vectors.append(np.broadcast_to(vector, (3, rest.size)))
            else:
                vectors.append(vector if every and vector.shape[1] == rest.size else take(vector, rest))
            if len(lights) > 1:
                limits.append(np.full(rest.size, light.t_max, dtype=self.dtype))
            views.append(light.view)
        if not shadows:
            return []
        # where every light's grid told which boxes each ray may meet, the hierarchy is not walked
        hierarchy = self.shadow_hierarchy
        sets = None if any(b is None for b in bits) else kernel_sets(bits)
        # which light's point or direction each ray shares, for the meshes' pictures
        which = np.repeat(np.arange(len(views)), [rest.size for *_, rest in shadows])
        one = len(shadows) == 1  # one light: its arrays as they are, its limit one number
        blocked_by_objects = hierarchy.occluded(
            origins[0] if one else np.concatenate(origins, axis=1),
            vectors[0] if one else np.concatenate(vectors, axis=1),
            t_min,
            lights[0][1].t_max if one else np.concatenate(limits),
            planes=False,
            sets=sets,
            views=(views, which),
            frames=RayFrames.joined(runs) if runs else None,
        )
        lit, start = [], 0
        for needed, blocked, rest in shadows:
            blocked[rest] = blocked_by_objects[start : start + rest.size]
            start += rest.size
            reached = np.zeros(P.shape[1], dtype=bool)
            reached[needed] = ~blocked
            lit.append(reached)
        return lit

    def background(self, D: np.ndarray, miss: np.ndarray | None) -> np.ndarray:
        """Colors (3, n) for the rays miss (n,) of rays D (3, N), which hit nothing (a sky reads only their z);
        miss None: for every ray (3, N)."""
        background = self.scene.background
        count = D.shape[1] if miss is None else miss.size
        if background.type == "none":
            return np.zeros((3, count), dtype=self.dtype)
        if background.type == "solid":
            return np.broadcast_to(column(background.color, self.dtype), (3, count))
        if background.type == "documented":
            return np.broadcast_to(self.documented_color, (3, count))
        if background.type == "image":
            seen = D if miss is None or D.shape[1] == 1 else take(D, miss)
            return spread(environment(background, seen).astype(self.dtype, copy=False), (3, count))
        z = D[2] if D.shape[1] == 1 or miss is None else D[2].take(miss)  # one direction for all, or each ray's own
        k = np.minimum(np.maximum(z, 0.0), 1.0)
        horizon = column(background.horizon, self.dtype)
        zenith = column(background.zenith, self.dtype)
        return spread(horizon + (zenith - horizon) * k, (3, count))

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
        _tally(counts, "camera", total, query)
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
                    _accumulate(color, pixel.take(miss), sky, False)
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
            _accumulate(color, pixel, local, bounce == 0)
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
            _tally(counts, "reflection", D.shape[1], query)
            t_min = 0.0 if self.robust else REFLECTION_T_MIN
        return color

    # ---- glass and transparency: TraceRay with refracted and straight-through rays --------------------------------

    def trace_see_through(
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
        """trace() for a scene with a material of transmission t > 0 or alpha a < 1 (docs/algorithm.md, "Glass and
        transparency"); the same arguments and result. A hit adds a (1 - t) times the documented local colour and
        sends on, each with its weight (3 channels: a refracted ray is tinted), a mirror ray (a ((1 - t) r + t F),
        F the dielectric Fresnel reflectance), a refracted ray (a t (1 - F) colour; none in total internal
        reflection) and a straight one (1 - a, the same direction, not a bounce: at most sc.TRANSPARENT_BOUNCES on
        a path; a camera ray's straight continuation stays a camera ray). A camera sample's rays may then be several
        in one wavefront: the wavefront is kept in order of camera sample and adds with np.add.at."""
        settings = self.scene.render
        total = D.shape[1]
        query = None if frames is None else RayFrames(frames[None])
        _tally(counts, "camera", total, query)
        color = np.zeros((3, total), dtype=self.dtype)
        runs = None if frames is None else (frames // settings.samples).tolist()  # each frame's pixels
        pixel = np.arange(total)  # each ray's camera sample, ascending
        O = self.origin if origins is None else origins
        weight = None  # (3, n); None: 1 (the camera rays)
        left = np.full(total, settings.depth)  # bounces left
        layers = np.zeros(total, dtype=np.int64)  # straight continuations on the path so far
        camera = np.ones(total, dtype=bool)  # camera rays and their straight continuations
        reach = far  # a camera ray's clip_end left beyond its origin (n,), inf for others; None: none
        tag = np.zeros(total, dtype=np.int8)  # the passes: 0 the camera ray's hit, 1 under a mirror ray, 2 under a
        # refracted or straight one (the Transmission pass)
        clear = np.ones(total, dtype=self.dtype)  # camera rays' product of 1 - alpha so far (the film's alpha)
        pending = np.ones(total, dtype=bool)  # camera rays whose data passes are not written yet
        first = True
        while pixel.size:
            t_min = CAMERA_T_MIN if first else 0.0 if self.robust else REFLECTION_T_MIN
            sets = None
            if first and self.screen is not None and (rows is not None or pixels is not None):
                if rows is not None:
                    sets = self.screen.rays(rows)
                else:
                    sets = self.screen.pixel_rays(pixels, runs, self.camera_hierarchy.frame_of)
            t, obj, part = self._closest_by_kind(O, D, t_min, camera, pixel, sets, frames)
            if reach is not None:
                obj[t >= reach] = -1
            if footprint is not None:
                end = np.where(obj >= 0, t, np.inf if reach is None else reach)
                footprint.record(pixel, O, D, t_min, end, hit=obj)
            miss = indices(obj < 0)
            if miss.size:
                seen = miss
                if settings.film_transparent:  # a camera ray that meets nothing adds nothing, and its share of alpha
                    film = camera.take(miss)
                    if alpha is not None and film.any():
                        gone = miss.take(indices(film))
                        np.subtract.at(alpha, pixel.take(gone), clear.take(gone))
                    seen = miss.take(indices(~film))
                if seen.size:
                    sky = self.background(D, seen)
                    if weight is not None:
                        sky = take(weight, seen) * sky
                    _add(color, pixel.take(seen), sky, first)
                    if recorder is not None:
                        _record_tagged(recorder, "environment", tag.take(seen), pixel.take(seen), sky)
            hit = indices(obj >= 0)
            if self.any_holdout and hit.size:  # a holdout adds nothing; a camera ray's share of alpha goes
                held = self.holdout.take(obj.take(hit))
                if held.any():
                    gone = hit.take(indices(held))
                    mine = gone.take(indices(camera.take(gone)))
                    if alpha is not None and mine.size:
                        np.subtract.at(alpha, pixel.take(mine), clear.take(mine))
                    if recorder is not None and first:
                        recorder.holdout(pixel.take(gone))
                    hit = hit.take(indices(~held))
            if not hit.size:
                break
            O, D, t, obj, part = take(O, hit), take(D, hit), t.take(hit), obj.take(hit), part.take(hit)
            pixel, left, layers = pixel.take(hit), left.take(hit), layers.take(hit)
            camera, tag, clear, pending = camera.take(hit), tag.take(hit), clear.take(hit), pending.take(hit)
            weight = None if weight is None else take(weight, hit)
            reach = None if reach is None else reach.take(hit)
            P = O + D * t
            V = -D
            O = None
            N, surface = self.normals(P, obj, part)
            material = self.material_of(obj, part)
            S = self.shading_normals(N, V, P, obj, part, material)
            colors, specular_colors, emission = self.surface_colors(material, P, obj, part)
            a, transmission = self.alpha.take(material), self.transmission.take(material)
            if recorder is not None:  # the data passes: the first surface of alpha >= the threshold met straight on
                shown = pending & (a >= sc.PASS_ALPHA_THRESHOLD)
                if shown.all():
                    recorder.first_hit(pixel, P, S, obj, material)
                elif shown.any():
                    rows_ = indices(shown)
                    recorder.first_hit(
                        pixel.take(rows_), take(P, rows_), take(S, rows_), obj.take(rows_), material.take(rows_)
                    )
            shaded = a * (1.0 - transmission)
            reflective = self.reflective.take(material)
            lit = indices(shaded > 0.0)
            if lit.size:
                self._see_through_local(
                    color, lit, P, N, S, V, material, surface, (colors, specular_colors, emission), shaded, weight,
                    pixel, tag, counts, footprint, frames, recorder, first,
                )  # fmt: skip
            # what goes on: mirror rays, refracted rays, straight continuations
            go = left > 0
            mirror = shaded * reflective
            bent_rows, bent_D, bent_weight = self._refract(go, a, transmission, material, N, S, D, mirror, colors)
            mirror_rows = indices(go & (mirror > 0.0))
            straight_rows = indices((a < 1.0) & (layers < sc.TRANSPARENT_BOUNCES))
            ones = None
            if weight is None:
                ones = np.ones((3, pixel.size), dtype=self.dtype)
            base = ones if weight is None else weight
            k = 2.0 * dot(S, V)
            children = []  # (rows, O, D, weight, left, layers, camera, tag, clear, reach)
            if mirror_rows.size:
                Sm, Vm = take(S, mirror_rows), take(V, mirror_rows)
                children.append(
                    (mirror_rows, Sm * k.take(mirror_rows) - Vm, take(base, mirror_rows) * mirror.take(mirror_rows),
                     left.take(mirror_rows) - 1, False, 1)
                )  # fmt: skip
            if bent_rows.size:
                children.append(
                    (bent_rows, bent_D, take(base, bent_rows) * bent_weight, left.take(bent_rows) - 1, False, 2)
                )
            if straight_rows.size:
                through = 1.0 - a.take(straight_rows)
                children.append(
                    (straight_rows, take(D, straight_rows), take(base, straight_rows) * through,
                     left.take(straight_rows), True, 2)
                )  # fmt: skip
            if not children:
                break
            parts = []
            for rows_, D_, weight_, left_, straight, kind in children:
                P_ = take(P, rows_)
                O_ = P_
                if self.robust:
                    O_ = offset_origins(P_, take(N, rows_), D_, *(part_.take(rows_) for part_ in surface))
                tag_ = tag.take(rows_)
                tag_ = np.where(tag_ == 0, np.int8(kind), tag_)
                if straight:
                    camera_ = camera.take(rows_)
                    layers_ = layers.take(rows_) + 1
                    clear_ = clear.take(rows_) * (1.0 - a.take(rows_))
                    reach_ = None if reach is None else np.where(camera_, reach.take(rows_) - t.take(rows_), np.inf)
                    pending_ = pending.take(rows_) & (a.take(rows_) < sc.PASS_ALPHA_THRESHOLD)
                else:
                    camera_ = np.zeros(rows_.size, dtype=bool)
                    layers_ = layers.take(rows_)
                    clear_ = np.zeros(rows_.size, dtype=self.dtype)
                    reach_ = None if reach is None else np.full(rows_.size, np.inf)
                    pending_ = np.zeros(rows_.size, dtype=bool)
                parts.append(
                    (pixel.take(rows_), O_, D_, weight_, left_, layers_, camera_, tag_, clear_, reach_, pending_)
                )
            joined = [
                None if parts[0][k_] is None else np.concatenate([p[k_] for p in parts], axis=-1) for k_ in range(11)
            ]
            order = np.argsort(joined[0], kind="stable")
            pixel, O, D, weight, left, layers, camera, tag, clear, reach, pending = (
                None if value is None else value.take(order, axis=-1) for value in joined
            )
            first = False
            query = None if frames is None else RayFrames.of(pixel, frames)
            _tally(counts, "reflection", pixel.size, query)
        return color

    def _closest_by_kind(
        self,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        camera: np.ndarray,
        pixel: np.ndarray,
        sets: list | None,
        frames: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hierarchy.closest for a see-through wavefront: the camera rays (camera, and their straight continuations)
        among the objects the camera sees, the others among those mirror rays see; sets: the camera rays' screen
        rectangles (the first wavefront, all camera rays)."""

        def of(rows: np.ndarray | None) -> RayFrames | None:
            return None if frames is None else RayFrames.of(pixel if rows is None else pixel.take(rows), frames)

        if camera.all():
            return self.camera_hierarchy.closest(O, D, t_min, sets, None, of(None))
        if self.camera_hierarchy is self.mirror_hierarchy or not camera.any():
            return self.mirror_hierarchy.closest(O, D, t_min, None, None, of(None))
        count = pixel.size
        t = np.full(count, np.inf, dtype=self.dtype)
        obj = np.full(count, -1, dtype=np.int32)
        part = np.zeros(count, dtype=np.int64)
        for hierarchy, rows in ((self.camera_hierarchy, indices(camera)), (self.mirror_hierarchy, indices(~camera))):
            found_t, found_obj, found_part = hierarchy.closest(
                take(O, rows), take(D, rows), t_min, None, None, of(rows)
            )
            t[rows], obj[rows], part[rows] = found_t, found_obj, found_part
        return t, obj, part

    def _see_through_local(
        self,
        color: np.ndarray,
        lit: np.ndarray,
        P: np.ndarray,
        N: np.ndarray,
        S: np.ndarray,
        V: np.ndarray,
        material: np.ndarray,
        surface: tuple[np.ndarray, np.ndarray] | None,
        paints: tuple[np.ndarray, np.ndarray | None, np.ndarray | None],
        shaded: np.ndarray,
        weight: np.ndarray | None,
        pixel: np.ndarray,
        tag: np.ndarray,
        counts: RayCounts,
        footprint: Footprint | RayStore | None,
        frames: np.ndarray | None,
        recorder: PassRecorder | None,
        first: bool,
    ) -> None:
        """The shaded share a (1 - t) of the hits lit (k,) of a see-through wavefront: listing 3.2 there and the
        local colour as trace() makes it (emission included), times the share and the rays' weights, added to their
        camera samples; the passes: a camera ray's own hit term by term, the others' by their tag."""
        every = lit.size == pixel.size  # every hit is shaded: no gathers
        pick = (lambda array: array) if every else (lambda array: take(array, lit))
        P_, S_, V_ = pick(P), pick(S), pick(V)
        geometric = None if S is N else pick(N)
        surface_ = None if surface is None else tuple(part if every else part.take(lit) for part in surface)
        material_ = material if every else material.take(lit)
        pixel_ = pixel if every else pixel.take(lit)
        points = None if frames is None else np.searchsorted(pixel_, frames)
        split = {} if recorder is not None and first and recorder.shading else None
        specular = self.specular.take(material_)
        intensity = self.find_intensity(
            P_, S_, V_, specular, counts, surface_, footprint, pixel_, geometric, points, split
        )
        reflective = self.reflective.take(material_)
        share = shaded if every else shaded.take(lit)
        colors, specular_colors, emission = (None if paint is None else pick(paint) for paint in paints)
        if self.colored:
            diffuse, highlight = intensity
            local = (diffuse * colors + highlight * specular_colors) * (1.0 - reflective)
        else:
            local = (intensity * (1.0 - reflective)) * colors
        if self.emissive:
            local = local + emission
        local = local * share
        value = local if weight is None else pick(weight) * local
        _add(color, pixel_, value, first)
        if recorder is None:
            return
        if first:
            if split is not None:  # the terms times (1 - r) a (1 - t): a reflectivity of 1 - (1 - r) a (1 - t)
                glow = None if emission is None else emission * share
                recorder.terms(
                    pixel_, split, material_, 1.0 - (1.0 - reflective) * share, (colors, specular_colors, glow)
                )
        else:
            _record_tagged(recorder, "reflection", tag.take(lit), pixel_, value)

    def _refract(
        self,
        go: np.ndarray,
        a: np.ndarray,
        transmission: np.ndarray,
        material: np.ndarray,
        N: np.ndarray,
        S: np.ndarray,
        D: np.ndarray,
        mirror: np.ndarray,
        colors: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The glass share of the hits that go on (go (n,)): adds a t F to their mirror weights (n,) in place and
        gives the rows (k,) that refract, their unit directions (3, k) and weights a t (1 - F) colour (3, k) (the
        reference's glass_split: eta = ior entering by the geometric normal N, 1 / ior leaving; the shading normal S
        turned to face D bends the ray; Cycles' fresnel_dielectric_cos)."""
        rows = indices(go & (transmission > 0.0) & (a > 0.0))
        if not rows.size:
            return rows, None, None
        N_, S_, D_ = take(N, rows), take(S, rows), take(D, rows)
        ior = self.ior.take(material.take(rows))
        eta = np.where(dot(N_, D_) < 0.0, ior, 1.0 / ior)
        facing = np.where(dot(S_, D_) < 0.0, S_, -S_)
        d = D_ / np.sqrt(dot(D_, D_))
        c = -dot(d, facing)
        g2 = eta * eta - 1.0 + c * c
        inside = g2 > 0.0  # else total internal reflection: F = 1
        g = np.sqrt(np.where(inside, g2, 1.0))
        A = (g - c) / (g + c)
        B = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
        F = np.where(inside, 0.5 * A * A * (1.0 + B * B), 1.0)
        glass = a.take(rows) * transmission.take(rows)
        mirror[rows] += glass * F
        share = glass * (1.0 - F)
        keep = indices(inside & (share > 0.0))
        T = take((d + (c - g) * facing) / eta, keep)
        T = T / np.sqrt(dot(T, T))
        return rows.take(keep), T, take(colors, rows.take(keep)) * share.take(keep)

    def _shadow_through(
        self,
        terms: list[tuple],
        lit: list[np.ndarray],
        P: np.ndarray,
        N: np.ndarray,
        counts: RayCounts,
        surface: tuple[np.ndarray, np.ndarray] | None,
        frames: np.ndarray | None,
    ) -> list[np.ndarray]:
        """Where some material has alpha < 1: the share (n,) of each light (not ambient) that reaches the points,
        from _lit's answer: 1 where nothing blocks, else the product of 1 - alpha over the surfaces the shadow ray
        meets, nearest first, each passed by a segment from its hit along the same vector (the rest of the range);
        0 at an opaque one (glass too: Cycles' caustics off) or past sc.TRANSPARENT_BOUNCES of them (the
        reference's shadow_through)."""
        lights = [light for light in self.lights if light.kind != "ambient"]
        t_min = 0.0 if self.robust else SHADOW_T_MIN
        throughs = []
        for light, term, reached in zip(lights, terms, lit, strict=True):
            L, needed = term[0], term[6]
            through = reached.astype(self.dtype)
            rows = needed.take(indices(~reached.take(needed)))
            if not rows.size:
                throughs.append(through)
                continue
            vector = np.array(np.broadcast_to(take(L, rows), (3, rows.size)))
            origin = np.array(np.broadcast_to(take(P, rows), (3, rows.size)))
            target = None
            if self.robust:  # as _lit starts them
                target = origin + vector if light.disk is not None else light.vector
                origin = offset_origins(origin, take(N, rows), vector, *(part.take(rows) for part in surface))
                if light.kind == "point":
                    vector = target - origin
            limit = np.full(rows.size, light.t_max, dtype=self.dtype)
            share = np.ones(rows.size, dtype=self.dtype)
            live = np.arange(rows.size)
            if self.opaque_shadows is not None:  # an object that blocks whole on the way: 0, whatever else is there
                query = None if frames is None else RayFrames.of(rows, frames)
                _tally(counts, "shadow", rows.size, query)
                whole = self.opaque_shadows.occluded(origin, vector, t_min, light.t_max, frames=query)
                share[whole] = 0.0
                live = indices(~whole)
            for layer in range(sc.TRANSPARENT_BOUNCES + 1):
                if not live.size:
                    break
                query = None if frames is None else RayFrames.of(rows.take(live), frames)
                _tally(counts, "shadow", live.size, query)
                O_, L_ = take(origin, live), take(vector, live)
                t, obj, part = self.shadow_hierarchy.closest(O_, L_, t_min, None, None, query)
                found = indices((obj >= 0) & (t < limit.take(live)))
                a = self.alpha.take(self.material_of(obj.take(found), part.take(found)))
                opaque = (a >= 1.0) | (layer >= sc.TRANSPARENT_BOUNCES)
                share[live.take(found.take(indices(opaque)))] = 0.0
                on = indices(~opaque)
                passed, at = found.take(on), t.take(found.take(on))
                live = live.take(passed)
                share[live] *= 1.0 - a.take(on)
                Q = take(O_, passed) + take(L_, passed) * at
                if self.robust:
                    normals, rounding = self.normals(Q, obj.take(passed), part.take(passed))
                    origin[:, live] = offset_origins(Q, normals, take(L_, passed), *rounding)
                    if light.kind == "point":
                        ends = target if target.shape[1] == 1 else take(target, live)
                        vector[:, live] = ends - origin[:, live]
                else:
                    origin[:, live] = Q
                    limit[live] -= at
            through[rows] = share
            throughs.append(through)
        return throughs

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


def spot_attenuation(cosine: np.ndarray, spot: sc.SpotLight) -> np.ndarray:
    """Cycles' spot light attenuation (n,) for the cosines (n,) of the angle at the light between its axis and the
    points; the same operations as reference.spot_attenuation. cycles4 (Blender 4.x, 5.0: kernel/light/spot.h):
    smoothstep((c - cos_half) / ((1 - cos_half) * blend)); cycles3 (Blender 3.4): 0 inside cos_half, else c times
    smoothstep((c - cos_half) / ((1 - cos_half) * blend)) while that is below 1, and c beyond. Blend 0: a hard edge."""
    cos_half = math.cos(math.radians(spot.spot_size) / 2.0)
    width = (1.0 - cos_half) * spot.spot_blend
    inside = cosine > cos_half
    if width == 0.0:
        step = np.where(inside, 1.0, 0.0)
    else:
        f = np.clip((cosine - cos_half) / width, 0.0, 1.0)
        ff = f * f
        step = 3.0 * ff - 2.0 * ff * f
    attenuation = np.where(inside, cosine * step if spot.spot_model == "cycles3" else step, 0.0)
    return attenuation.astype(cosine.dtype, copy=False)


def facing_basis(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """lightsamples.facing_basis of each column's direction (3, n) -> its two axes (3, n) each, float64 (the same
    operations)."""
    L = np.asarray(L, dtype=np.float64)
    x, y, z = L / np.sqrt(x_y_z_squared(L))
    sign = np.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    return np.stack((1.0 + sign * x * x * a, sign * b, -sign * x)), np.stack((b, sign + y * y * a, -y))


def x_y_z_squared(L: np.ndarray) -> np.ndarray:
    return L[0] * L[0] + L[1] * L[1] + L[2] * L[2]


def environment(background: sc.Background, D: np.ndarray) -> np.ndarray:
    """An image background's colours (3, n) float64 for directions D (3, n): Blender's equirectangular (u, v)
    (lightsamples.equirectangular, the same operations on arrays), then the texel by Cycles' rules: linear, bilinear
    between the texel centres around (u W - 0.5, v H - 0.5), v counted from the picture's bottom, wrapping around in
    u and clamped at the poles; closest, the texel (floor(u W), floor(v H)); times the strength."""
    image = background.image
    height, width = image.shape[:2]
    x, y, z = (np.asarray(axis, dtype=np.float64) for axis in D)
    if background.rotation != 0.0:
        c, s = math.cos(math.radians(background.rotation)), math.sin(math.radians(background.rotation))
        x, y = c * x - s * y, s * x + c * y
    u = 0.5 - np.arctan2(y, x) / (2.0 * math.pi)
    v = 0.5 + np.arctan2(z, np.hypot(x, y)) / math.pi
    if background.interpolation == "closest":
        column_ = np.floor(u * width).astype(np.int64) % width
        row = height - 1 - np.clip(np.floor(v * height).astype(np.int64), 0, height - 1)
        color = image[row, column_].T.astype(np.float64)
    else:
        px, py = u * width - 0.5, v * height - 0.5
        fx, fy = np.floor(px), np.floor(py)
        tx, ty = px - fx, py - fy
        x0 = fx.astype(np.int64) % width
        x1 = (x0 + 1) % width
        y0 = height - 1 - np.clip(fy.astype(np.int64), 0, height - 1)  # rows from the top
        y1 = height - 1 - np.clip(fy.astype(np.int64) + 1, 0, height - 1)
        texel = lambda r, c: image[r, c].T.astype(np.float64)  # noqa: E731
        color = (1.0 - ty) * ((1.0 - tx) * texel(y0, x0) + tx * texel(y0, x1)) + ty * (
            (1.0 - tx) * texel(y1, x0) + tx * texel(y1, x1)
        )
    return color * background.strength if background.strength != 1.0 else color


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


def _tally(counts: RayCounts | list[RayCounts], kind: str, rays: int, frames: RayFrames | None) -> None:
    """Add rays of a kind ("camera", "shadow", "reflection") to counts, or with frames each frame's rays to its
    own counts (a list)."""
    if frames is None:
        setattr(counts, kind, getattr(counts, kind) + rays)
        return
    for frame_counts, size in zip(counts, frames.sizes.tolist(), strict=True):
        setattr(frame_counts, kind, getattr(frame_counts, kind) + size)


def _add(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, unique: bool = False) -> None:
    """color[:, pixel] += value where pixels may repeat (a see-through wavefront holds several rays of a camera
    sample): np.add.at, in the order of the rays; unique: they do not (the camera rays' own wavefront), the faster
    gather and scatter of _accumulate (the same sums)."""
    if unique:
        _accumulate(color, pixel, value, False)
        return
    for row, add in zip(color, value, strict=True):
        np.add.at(row, pixel, add)


def _record_tagged(recorder: PassRecorder, name: str, tag: np.ndarray, pixel: np.ndarray, value: np.ndarray) -> None:
    """What rays of a see-through wavefront add (3, n) into their passes: under a refracted or straight ray (tag 2)
    the Transmission pass, else name (reflection for surfaces, environment for misses)."""
    mine = tag == 2
    if mine.any():
        recorder.add("transmission", pixel[mine], value[:, mine])
    if not mine.all():
        recorder.add(name, pixel[~mine], value[:, ~mine])


def _accumulate(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, fresh: bool) -> None:
    """color[:, pixel] += value for unique pixel indices, a row at a time (several times faster than fancy `+=`).

    fresh: the pixels still hold their initial zeros (the camera rays' bounce), so the value is stored as it is."""
    for row, add in zip(color, value, strict=True):
        row[pixel] = add if fresh else row.take(pixel) + add
