"""A rendered image and an edit (a material, a light's intensity, an object's place) -> the edited scene's image,
tracing again only the pixels the edit can change; bit for bit the whole render of the edited scene.

The image keeps every segment of every pixel's ray tree (camera and mirror rays up to their hit, with the object
hit; shadow rays over their whole range, with their light). A pixel can change only if its tree touches what the
edit changes (footprint.py gives the reasoning):

- a material: some camera, mirror or refracted segment of the tree hits an object of that material (shadow rays do
  not look at materials, except for alpha: an edit of a material's alpha is not one of these edits);
- a light's intensity: the tree has a shadow segment toward that light (a point is given one wherever the light
  could add to it, whatever the intensity), or, for a sun seen in mirrors, a segment that meets nothing and points
  into its disc; an ambient light's: the tree hits anything;
- an object's location or rotation: some segment meets the object's box before or after the move.

Those pixels are traced again (their segments replace theirs in the store); the others keep their bytes. One
process, in memory: about 90 bytes a segment (640x480 at depth 3 on the default scene: 870,000 segments, 77 MB in
float64), for an interactive session (the viewport), not for a farm.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..geometry import transforms as tf
from ..geometry.footprint import Volume
from ..geometry.instances import placed_kernel
from ..scene import scene as sc
from ..tracing.raystore import RayStore, Segments
from ..tracing.wavefront import RayCounts, TracedScene
from ..workers.resources import band_samples


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
BUILD_PIECE_SAMPLES = 65536  # camera samples per piece of the first trace: about 60 ms here, between interruptions


def edits_between(old: sc.Scene, new: sc.Scene) -> list[Edit] | None:
    """The edits that turn old into new (materials, lights' intensities, objects' locations and rotations), or
    None where new differs in anything else (camera, render settings, background, the vane, an object's shape)."""
    edits: list[Edit] = []
    if old.materials.keys() != new.materials.keys() or len(old.lights) != len(new.lights):
        return None
    if [obj.name for obj in old.objects] != [obj.name for obj in new.objects]:
        return None
    edits += [
        MaterialEdit(name, new.materials[name]) for name in old.materials if old.materials[name] != new.materials[name]
    ]
    if any(old.materials[edit.name].alpha != edit.material.alpha for edit in edits):
        return None  # what shadow rays pass changes, and shadow segments do not name what they pass
    for index, (before, after) in enumerate(zip(old.lights, new.lights, strict=True)):
        if before != after and hasattr(after, "intensity") and type(before) is type(after):
            edits.append(LightEdit(index, after.intensity))
    for before, after in zip(old.objects, new.objects, strict=True):
        if before != after and type(before) is type(after):
            edits.append(TransformEdit(after.name, after.location, after.rotation))
    edited = old
    for edit in edits:
        edited = _edited(edited, edit)
    return edits if edited == new else None


class EditableImage:
    """A scene's image that edits update in place of a whole render (one process). alpha: (height, width) where the
    scene has one (film_transparent, holdouts), else None; a render border is not applied (the whole image is
    traced).

    The segments are kept in chunks, one per trace; a pixel traced again makes its older segments stale (each chunk
    notes the pixel's generation it was traced in), so an edit costs its own segments, not a copy of all of them;
    the chunks are compacted when stale segments are more than half."""

    def __init__(self, scene: sc.Scene, between_pieces: Callable[[], None] | None = None) -> None:
        """Trace the scene whole, keeping its segments. between_pieces: called after each piece of about
        BUILD_PIECE_SAMPLES camera samples (an exception from it stops the build: a caller that can be
        interrupted); the pieces are the same bytes as one trace."""
        self.scene = scene
        settings = scene.render
        self.pixels = settings.width * settings.height
        self.generation = np.zeros(self.pixels, dtype=np.int32)  # how often each pixel was traced again
        self.chunks: list[tuple[Segments, np.ndarray]] = []  # segments and the generation they belong to
        self.image = np.empty((settings.height, settings.width, 3), dtype=settings.dtype)
        self.alpha = np.empty((settings.height, settings.width), dtype=settings.dtype) if scene.has_alpha else None
        self.rays = RayCounts()
        # each pixel's live segments, and what a segment took to trace: an edit's time, estimated before tracing it
        self.segment_counts = np.zeros(self.pixels, dtype=np.int32)
        started, pieces = time.perf_counter(), max(1, self.pixels * settings.samples // BUILD_PIECE_SAMPLES)
        for piece in np.array_split(np.arange(self.pixels), pieces):
            self._trace(scene, piece)
            if between_pieces is not None:
                between_pieces()
        self.seconds_per_segment = (time.perf_counter() - started) / max(1, int(self.segment_counts.sum()))

    @property
    def segments(self) -> Segments:
        """The current segments, every pixel's latest tree (a copy)."""
        live = [chunk.take(self._live(chunk, generation)) for chunk, generation in self.chunks]
        return Segments.empty() if not live else live[0].joined(*live[1:])

    def seconds_for(self, pixels: np.ndarray) -> float:
        """About how long tracing these pixels again takes: their segments at the build's time a segment (a glass
        pixel's tree is many segments through a mesh, a ground pixel's two)."""
        return float(self.segment_counts[pixels].sum()) * self.seconds_per_segment

    def affected(self, edit: Edit) -> np.ndarray:
        """The flat pixels (P,) that apply(edit) would trace again, ascending."""
        return self._affected(edit, _edited(self.scene, edit))

    def apply(self, edit: Edit, pixels: np.ndarray | None = None) -> np.ndarray:
        """The edited scene's image (height, width, 3); self.scene becomes the edited scene. pixels: affected(edit)
        where the caller has it already."""
        edited = _edited(self.scene, edit)
        pixels = self._affected(edit, edited) if pixels is None else pixels
        self.generation[pixels] += 1
        self._trace(edited, pixels)
        self.scene = edited
        return self.image

    def _trace(self, scene: sc.Scene, pixels: np.ndarray) -> None:
        store = RayStore()
        colors, self.rays = TracedScene(scene).render_pixels(pixels, band_samples(scene.render), store)
        self.image.reshape(-1, 3)[pixels] = colors[:, :3]
        if self.alpha is not None and colors.shape[1] == 4:
            self.alpha.reshape(-1)[pixels] = colors[:, 3]
        chunk = store.segments()
        self.segment_counts[pixels] = np.bincount(chunk.pixel, minlength=self.pixels)[pixels]
        self.chunks.append((chunk, self.generation.take(chunk.pixel)))
        self.last_traced = len(pixels)
        total = sum(chunk.pixel.size for chunk, _ in self.chunks)
        if len(self.chunks) > 1 and 2 * sum(self._live(c, g).size for c, g in self.chunks) < total:
            current = self.segments
            self.chunks = [(current, self.generation.take(current.pixel))]

    def _live(self, chunk: Segments, generation: np.ndarray) -> np.ndarray:
        return (generation == self.generation.take(chunk.pixel)).nonzero()[0]

    def _affected(self, edit: Edit, edited: sc.Scene) -> np.ndarray:
        """The flat pixels (P,) whose trees touch what the edit changes, ascending."""
        if isinstance(edit, TransformEdit):
            index = next(k for k, obj in enumerate(self.scene.objects) if obj.name == edit.name)
            boxes = [_box(self.scene, index), _box(edited, index)]
            if any(box is None for box in boxes):  # an unbounded plane moved: anything may change
                return np.arange(self.pixels)
            volume = Volume.around(boxes, np.dtype(np.float64), float(np.abs(np.concatenate(boxes)).max()))
        # a mask of the pixels rather than np.unique of their segments' pixels: a sort of a million pixels was most
        # of the time an edit of the ground's colour spent finding it is not a small edit
        touched = np.zeros(self.pixels, dtype=bool)
        # uses[hit]: whether the object hit shows the material (the last entry, False, for a miss's -1)
        uses = np.zeros(len(self.scene.objects) + 1, dtype=bool)
        if isinstance(edit, MaterialEdit):
            uses[[k for k, obj in enumerate(self.scene.objects) if _uses(obj, edit.name)]] = True
        for segments, generation in self.chunks:  # stale segments are tested too, and left out after
            if isinstance(edit, MaterialEdit):
                hits = uses[segments.hit]
            elif isinstance(edit, LightEdit):
                light = self.scene.lights[edit.index]
                if isinstance(light, sc.AmbientLight):
                    hits = segments.hit >= 0
                else:
                    hits = segments.light == edit.index
                    if isinstance(light, sc.DirectionalLight) and light.seen_in_mirrors and light.angle > 0.0:
                        hits = hits | _into_the_disc(segments, light)
            else:
                hits = volume.meets(segments.O, segments.D, segments.start, segments.end)
            touched[segments.pixel[hits & (generation == self.generation.take(segments.pixel))]] = True
        return np.flatnonzero(touched)


def _into_the_disc(segments: Segments, sun: sc.DirectionalLight) -> np.ndarray:
    """(n,) bool: the segments that meet nothing and point into a sun's disc (emitters.see_suns' test): a mirror or
    refracted ray there sees the sun, where its tree may have no shadow segment toward it (through glass)."""
    toward = np.asarray(sun.direction, dtype=np.float64)
    cosine = (segments.D * (toward / np.linalg.norm(toward))[:, None]).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        cosine = cosine / np.sqrt((segments.D * segments.D).sum(axis=0))
    # a little wider than the disc: a segment's direction is stored in float64 from a float32 ray's
    return (segments.hit < 0) & (segments.light < 0) & (cosine >= math.cos(math.radians(sun.angle) / 2.0) - 1e-6)


def _uses(obj: sc.SceneObject, material: str) -> bool:
    """Whether an object shows the material: its own, or one of a mesh's per-triangle materials."""
    return obj.material == material or material in (getattr(obj, "materials", None) or ())


def _box(scene: sc.Scene, index: int) -> tuple[np.ndarray, np.ndarray] | None:
    primitive = tf.world_primitive(scene.objects[index], scene.vane)
    return placed_kernel(primitive, np.dtype(np.float64)).bounds()


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


__all__ = ["Edit", "EditableImage", "LightEdit", "MaterialEdit", "TransformEdit", "edits_between"]
