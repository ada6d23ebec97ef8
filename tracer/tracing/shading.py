"""A prepared scene's hit points -> their colours by the documented model: listing 3.2's FindIntensity over arrays
(ambient, diffuse and highlight terms per light, shadow rays as any-hit tests; lights of a size by their samples,
spots, falloff, coloured and textured surfaces), split term by term for the render passes where asked, and the
background the rays that miss see. The beauty image and the passes both read these terms (one place)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.cull import CoverageGrid, kernel_sets
from ..geometry.footprint import Footprint
from ..geometry.kernels import (
    PlaneKernel,
    column,
    dot,
    indices,
    interpolated_corners,
    spread,
    take,
    unit,
    unit_or,
)
from ..geometry.meshbvh import MergedMember
from ..geometry.meshpicture import View
from ..geometry.rayframes import RayFrames
from ..geometry.robust import offset_origins
from ..scene import scene as sc
from .rays import SHADOW_T_MIN, RayCounts, tally
from .texturing import attribute
from .texturing import sample as sample_texture


@dataclass
class Light:
    """A light as the shading code uses it: a scene light, or one sample point of a light of a size."""

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


class Shading:
    """PreparedScene's shading, a mixin: the arrays it reads (materials' rows, lights, kernels, textures) are the
    ones PreparedScene.__post_init__ makes."""

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
        for index in dict.fromkeys((*self.uv_meshes, *self.uv_instances, *self.color_meshes, *self.color_instances)):
            rows = indices(obj == index)
            if rows.size:
                rows = rows.take(indices(self.has_texture.take(material.take(rows))))
            if not rows.size:
                continue
            triangle = part.take(rows)
            uv = self._corner_values(index, rows, triangle, P, self.uv_meshes, self.uv_instances)
            tint = self._corner_values(index, rows, triangle, P, self.color_meshes, self.color_instances)
            rows_material = material.take(rows)
            for row in np.unique(rows_material).tolist():
                mine = indices(rows_material == row)
                where = rows.take(mine)
                texture, glow = self.row_textures[row], self.row_emission_textures[row]
                value = self._texture_value(texture, uv, tint, mine)
                if value is not None:
                    colors[:, where] = value
                    if specular is not None and self.scene.materials[self.material_names[row]].specular_color is None:
                        specular[:, where] = value
                glowing = self._texture_value(glow, uv, tint, mine)
                if glowing is not None:
                    emission[:, where] = glowing
        return colors, specular, emission

    def _corner_values(
        self, index: int, rows: np.ndarray, triangle: np.ndarray, P: np.ndarray, meshes: dict, instances: dict
    ) -> np.ndarray | None:
        """Object index's corner values (UVs or colours) interpolated at its hits rows (k, n), or None where it has
        none."""
        if index in meshes:
            v0, e1, e2, c0, c1, c2 = meshes[index]
            w = take(P, rows).astype(np.float64) - v0.take(triangle, axis=1)
            corners = (c.take(triangle, axis=1) for c in (c0, c1, c2))
            return interpolated_corners(w, e1.take(triangle, axis=1), e2.take(triangle, axis=1), *corners)
        if index in instances:
            return self.kernels[index].corner_values(take(P, rows), triangle, instances[index])[0]
        return None

    def _texture_value(
        self, texture: sc.Texture | None, uv: np.ndarray | None, tint: np.ndarray | None, mine: np.ndarray
    ) -> np.ndarray | None:
        """A texture's colours (3, m) at the hits mine of the interpolated uv (2, n) or corner colours tint (3, n):
        an "attribute" texture by the colours, the others by the UVs; None where the mesh has not what it reads."""
        if texture is None:
            return None
        if texture.kind == "attribute":
            return None if tint is None else attribute(texture, tint.take(mine, axis=1)).astype(self.dtype)
        if uv is None:
            return None
        return sample_texture(texture, uv[0].take(mine), uv[1].take(mine)).astype(self.dtype)

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

    def _attenuation(self, light: Light, L: np.ndarray, length_l: np.ndarray) -> np.ndarray:
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
            tally(counts, "shadow", needed.size, own)
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
