"""The rays of one wavefront and their hits -> named struct-of-arrays records the tracing stages pass each other:
RayBatch (each ray's camera sample, origin, direction, weight, bounces left and, in scenes with glass or
transparency, what a straight continuation carries), and Hits (where the rays met surfaces, and what those surfaces
are there)."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from ..geometry.kernels import take


def _columns(array: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    """array's entries at rows: the columns of a (k, n) array (a (3, 1) column shared by every ray stays as it is),
    the items of an (n,) one; None stays None."""
    if array is None:
        return None
    return take(array, rows) if array.ndim == 2 else array.take(rows)


@dataclass
class RayBatch:
    """A wavefront's rays (n of them), in ascending order of the camera sample each belongs to.

    origin, direction (3, n), or a shared (3, 1) origin (camera rays that start at the camera). weight: what the
    ray's colour is multiplied by, (n,) for mirror paths or (3, n) where glass tints them; None: 1 (camera rays).
    left: bounces left, one number for every ray of a Whitted wavefront, (n,) where glass and transparency give
    rays of one wavefront different histories. reach: where each ray stops (n,) (a clipped camera's clip_end; inf
    for rays that are not camera rays), None: never.

    The see-through fields (None in scenes without glass or transparency): camera (n,) bool, camera rays and their
    straight continuations through partly transparent surfaces; layers (n,), straight continuations on the path;
    tag (n,) int8, the pass a ray adds to (0 the camera ray's own hit, 1 under a mirror ray, 2 under a refracted or
    straight one: Transmission); clear (n,), a camera ray's product of 1 - alpha so far (the film's alpha);
    pending (n,) bool, camera rays whose data passes are not written yet. sample (n,), in scenes with glossy
    surfaces: the glossy sample pair a ray's path took at its first glossy surface (-1: none yet), the one pair a
    glossy surface after it sends its ray by (glossy.sample_rays). bounces (n,) and diffuse (n,) bool, in scenes with
    diffuse bounces: the diffuse bounces on the path so far, and whether the ray is one (its miss adds nothing: the
    world's light is the world light's). lamps (n,) bool, in scenes with area lights seen in mirrors: the ray sees
    them (mirror and refracted rays; not camera, glossy, rough glass or diffuse ones). serial (n,), in scenes with
    rough glass: the global index of the camera sample a ray's tree belongs to (camera.sample_serial: its rough glass
    hits' pair rotations, camera.glass_rotations)."""

    pixel: np.ndarray
    origin: np.ndarray
    direction: np.ndarray
    weight: np.ndarray | None = None
    left: int | np.ndarray = 0
    reach: np.ndarray | None = None
    camera: np.ndarray | None = None
    layers: np.ndarray | None = None
    tag: np.ndarray | None = None
    clear: np.ndarray | None = None
    pending: np.ndarray | None = None
    sample: np.ndarray | None = None
    bounces: np.ndarray | None = None
    diffuse: np.ndarray | None = None
    lamps: np.ndarray | None = None
    serial: np.ndarray | None = None

    @property
    def size(self) -> int:
        return self.pixel.size

    def take(self, rows: np.ndarray) -> RayBatch:
        """The rays rows (k,) of this batch (in that order)."""
        left = self.left if isinstance(self.left, int) else self.left.take(rows)
        return RayBatch(
            self.pixel.take(rows),
            take(self.origin, rows),
            take(self.direction, rows),
            _columns(self.weight, rows),
            left,
            *(
                _columns(getattr(self, name), rows)
                for name in (
                    "reach",
                    "camera",
                    "layers",
                    "tag",
                    "clear",
                    "pending",
                    "sample",
                    "bounces",
                    "diffuse",
                    "lamps",
                    "serial",
                )
            ),
        )

    def with_rays(self, **changes: object) -> RayBatch:
        return replace(self, **changes)

    @staticmethod
    def joined(batches: list[RayBatch]) -> RayBatch:
        """The rays of several batches in one, in ascending order of camera sample (a stable sort: a sample's rays
        keep the order of the batches). Every batch has the same fields set."""
        if len(batches) == 1:
            return batches[0]
        values = {}
        for field in fields(RayBatch):
            parts = [getattr(batch, field.name) for batch in batches]
            values[field.name] = None if parts[0] is None else np.concatenate(parts, axis=-1)
        order = np.argsort(values["pixel"], kind="stable")
        return RayBatch(
            **{name: None if value is None else value.take(order, axis=-1) for name, value in values.items()}
        )


@dataclass
class Hits:
    """Where the rays of a wavefront met a surface (n of them) and what the surface is there.

    P (3, n) the points; V (3, n) toward where each ray came from (-D); N (3, n) the geometric unit normals; S (3, n)
    the shading normals (N itself where nothing changes them); obj, part (n,) the object and its primitive (a mesh's
    triangle); material (n,) each hit's row in the material table; surface: robust numerics' (distance, scale) (n,)
    for offset_origins, else None; colors, specular_colors, emission (3, n): the surfaces' colours there
    (specular_colors None unless the scene is coloured, emission None unless emissive); image_pixel (n,), in
    scenes with a world light: the flat pixel j * W + i of the camera sample each hit belongs to (its turn of the
    world light's directions, camera.world_turns)."""

    P: np.ndarray
    V: np.ndarray
    N: np.ndarray
    S: np.ndarray
    obj: np.ndarray
    part: np.ndarray
    material: np.ndarray
    surface: tuple[np.ndarray, np.ndarray] | None
    colors: np.ndarray
    specular_colors: np.ndarray | None
    emission: np.ndarray | None
    image_pixel: np.ndarray | None = None

    @property
    def geometric(self) -> np.ndarray | None:
        """The geometric normals where the shading normals differ (None: they are the same array)."""
        return None if self.S is self.N else self.N

    def take(self, rows: np.ndarray) -> Hits:
        """The hits rows (k,) (the shading normals stay the geometric ones' array where they are the same)."""
        N = take(self.N, rows)
        return Hits(
            take(self.P, rows),
            take(self.V, rows),
            N,
            N if self.S is self.N else take(self.S, rows),
            self.obj.take(rows),
            self.part.take(rows),
            self.material.take(rows),
            None if self.surface is None else tuple(part.take(rows) for part in self.surface),
            take(self.colors, rows),
            _columns(self.specular_colors, rows),
            _columns(self.emission, rows),
            _columns(self.image_pixel, rows),
        )
