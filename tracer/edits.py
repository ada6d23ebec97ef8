"""A rendered image and an edit (a material, a light's intensity, an object's place) -> the edited scene's image,
tracing again only the pixels the edit can change; bit for bit the whole render of the edited scene.

The image keeps every segment of every pixel's ray tree (camera and mirror rays up to their hit, with the object
hit; shadow rays over their whole range, with their light). A pixel can change only if its tree touches what the
edit changes (footprint.py gives the reasoning):

- a material: some camera or mirror segment of the tree hits an object of that material (shadow rays do not look at
  materials);
- a light's intensity: the tree has a shadow segment toward that light (a point is given one wherever the light
  could add to it, whatever the intensity); an ambient light's: the tree hits anything;
- an object's location or rotation: some segment meets the object's box before or after the move.

Those pixels are traced again (their segments replace theirs in the store); the others keep their bytes. One
process, in memory: about 90 bytes a segment (640x480 at depth 3 on the default scene: 870,000 segments, 77 MB in
float64), for an interactive session (the viewport), not for a farm.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import scene as sc
from . import transforms as tf
from .footprint import Volume
from .kernels import make_kernel
from .parallel import band_samples
from .wavefront import PreparedScene, RayCounts


class RayStore:
    """Every segment of the traced pixels' ray trees, appended as they are traced (a recorder for trace())."""

    def __init__(self) -> None:
        self._parts: list[tuple] = []
        self._pixels = np.empty(0, dtype=np.int64)  # the pixels of the piece being traced
        self._samples = 1

    def begin(self, pixels: np.ndarray, samples: int) -> None:
        """The next trace is of these flat pixels (P,), samples each: its sample indices map to them."""
        self._pixels, self._samples = np.asarray(pixels, dtype=np.int64), samples

    def record(self, samples, O, D, t_min, t_max, hit=None, light=None) -> None:
        """Segments (3, n) of camera samples (n,): for camera and mirror segments the object hit (n,; -1: none), for
        shadow segments their light's index."""
        count = samples.size
        if not count:
            return
        pixel = self._pixels.take(samples // self._samples)
        O = np.broadcast_to(O, (3, count)).astype(np.float64)
        D = np.broadcast_to(D, (3, count)).astype(np.float64)
        start = np.broadcast_to(np.asarray(t_min, dtype=np.float64), (count,))
        end = np.broadcast_to(np.asarray(t_max, dtype=np.float64), (count,))
        hits = np.full(count, -1, dtype=np.int32) if hit is None else hit.astype(np.int32)
        lights = np.full(count, -1 if light is None else light, dtype=np.int32)
        self._parts.append((pixel, O, D, start, end, hits, lights))

    def segments(self) -> Segments:
        columns = list(zip(*self._parts, strict=True)) if self._parts else [[]] * 7
        self._parts = []
        if not columns[0]:
            return Segments.empty()
        return Segments(*(np.concatenate(column, axis=1 if k in (1, 2) else 0) for k, column in enumerate(columns)))


@dataclass
class Segments:
    pixel: np.ndarray  # (n,) flat pixel index
    O: np.ndarray  # (3, n) float64
    D: np.ndarray  # (3, n)
    start: np.ndarray  # (n,) t_min
    end: np.ndarray  # (n,) the hit's t, or the segment's end
    hit: np.ndarray  # (n,) object hit, -1 for none or for a shadow segment
    light: np.ndarray  # (n,) the light a shadow segment seeks, -1 for the others

    @classmethod
    def empty(cls) -> Segments:
        return cls(
            np.empty(0, np.int64), np.empty((3, 0)), np.empty((3, 0)), np.empty(0), np.empty(0),
            np.empty(0, np.int32), np.empty(0, np.int32),
        )  # fmt: skip

    def without(self, pixels: np.ndarray) -> Segments:
        keep = ~np.isin(self.pixel, pixels)
        return Segments(*(array[..., keep] for array in self.columns))

    def joined(self, other: Segments) -> Segments:
        return Segments(*(np.concatenate((a, b), axis=-1) for a, b in zip(self.columns, other.columns, strict=True)))

    @property
    def columns(self) -> tuple[np.ndarray, ...]:
        return self.pixel, self.O, self.D, self.start, self.end, self.hit, self.light


@dataclass(frozen=True)
class MaterialEdit:
    name: str
    material: sc.Material


@dataclass(frozen=True)
class LightEdit:
    index: int  # in scene.lights
    intensity: float


@dataclass(frozen=True)
class TransformEdit:
    name: str  # an object's name
    location: sc.Vec3
    rotation: sc.Vec3


Edit = MaterialEdit | LightEdit | TransformEdit


class EditableImage:
    """A scene's image that edits update in place of a whole render (one process)."""

    def __init__(self, scene: sc.Scene) -> None:
        self.scene = scene
        settings = scene.render
        self.pixels = settings.width * settings.height
        store = RayStore()
        colors, self.rays = PreparedScene(scene).render_pixels(np.arange(self.pixels), band_samples(settings), store)
        self.image = colors.reshape(settings.height, settings.width, 3)
        self.segments = store.segments()
        self.last_traced = self.pixels

    def apply(self, edit: Edit) -> np.ndarray:
        """The edited scene's image (height, width, 3); self.scene becomes the edited scene."""
        edited = _edited(self.scene, edit)
        pixels = self._affected(edit, edited)
        store = RayStore()
        colors, rays = PreparedScene(edited).render_pixels(pixels, band_samples(edited.render), store)
        self.image.reshape(-1, 3)[pixels] = colors
        self.segments = self.segments.without(pixels).joined(store.segments())
        self.scene, self.rays, self.last_traced = edited, rays, len(pixels)
        return self.image

    def _affected(self, edit: Edit, edited: sc.Scene) -> np.ndarray:
        """The flat pixels (P,) whose trees touch what the edit changes, ascending."""
        segments = self.segments
        if isinstance(edit, MaterialEdit):
            objects = [k for k, obj in enumerate(self.scene.objects) if obj.material == edit.name]
            touched = np.isin(segments.hit, objects)
        elif isinstance(edit, LightEdit):
            if isinstance(self.scene.lights[edit.index], sc.AmbientLight):
                touched = segments.hit >= 0
            else:
                touched = segments.light == edit.index
        else:
            index = next(k for k, obj in enumerate(self.scene.objects) if obj.name == edit.name)
            boxes = [_box(self.scene, index), _box(edited, index)]
            if any(box is None for box in boxes):  # an unbounded plane moved: anything may change
                return np.arange(self.pixels)
            volume = Volume.around(boxes, np.dtype(np.float64), float(np.abs(np.concatenate(boxes)).max()))
            touched = volume.meets(segments.O, segments.D, segments.start, segments.end)
        return np.unique(segments.pixel[touched])


def _box(scene: sc.Scene, index: int) -> tuple[np.ndarray, np.ndarray] | None:
    primitive = tf.world_primitive(scene.objects[index], scene.vane)
    return make_kernel(primitive, np.dtype(np.float64)).bounds()


def _edited(scene: sc.Scene, edit: Edit) -> sc.Scene:
    if isinstance(edit, MaterialEdit):
        return replace(scene, materials={**scene.materials, edit.name: edit.material})
    if isinstance(edit, LightEdit):
        lights = list(scene.lights)
        lights[edit.index] = replace(lights[edit.index], intensity=edit.intensity)
        return replace(scene, lights=tuple(lights))
    objects = tuple(
        replace(obj, location=edit.location, rotation=edit.rotation) if obj.name == edit.name else obj
        for obj in scene.objects
    )
    return replace(scene, objects=objects)


__all__ = ["EditableImage", "LightEdit", "MaterialEdit", "RayCounts", "TransformEdit"]
