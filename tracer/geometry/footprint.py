"""What moves in an animation -> the volume it sweeps, and which pixels' ray trees meet that volume.

Between two frames of an animation only the vane's parts move; everything else (camera, lights, other objects,
materials) stays. A pixel's value is a function of its ray tree: the camera ray, the mirror rays and the shadow rays
of every bounce, each a segment from its origin to its hit (or its end). If no segment of that tree meets the volume
that the moving parts sweep over the whole animation, then in any other frame every segment meets the same surfaces
at the same t (nothing in the volume is ever outside it, nothing outside it moves), so the tree and the pixel are the
same, bit for bit: the tracer's result for a ray does not depend on which other rays are traced with it. Such a
pixel is traced once; only the pixels whose trees meet the volume are traced again in each frame.

The volume is a box that holds the parts at every heading of the frames it serves (incremental.py takes runs of
frames whose headings stay close), or at every heading at all (the parts' box revolved a whole turn about the
vane's axis) where the headings to come are not known. Where the headings are known and the pixels' trees were
traced without the parts, HeadingMarks then tells, of the pixels the volume holds, which ones each heading changes:
those whose trees meet a part there, tested against the part's oriented box (its kernel's frame).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..scene import scene as sc
from . import transforms as tf
from .instances import placed_kernel
from .kernels import indices, padded_box, quiet, slab, take


@dataclass(frozen=True)
class Volume:
    """Axis-aligned boxes (lower, upper (3, 1) each, in the tracing dtype) grown by more than the tracing's rounding,
    and the box around them all (outer), which every segment meets first."""

    boxes: tuple[tuple[np.ndarray, np.ndarray], ...]
    outer: tuple[np.ndarray, np.ndarray]

    @classmethod
    def around(cls, boxes: list[tuple[np.ndarray, np.ndarray]], dtype: np.dtype, reach: float) -> Volume:
        """boxes: (lower, upper) (3,) float64; reach: the largest coordinate the tests subtract (padded_box)."""
        grown = tuple(padded_box(lower, upper, dtype, reach) for lower, upper in boxes)
        lower = np.min([low for low, _ in boxes], axis=0)
        upper = np.max([high for _, high in boxes], axis=0)
        return cls(grown, padded_box(lower, upper, dtype, reach))

    def meets(self, O: np.ndarray, D: np.ndarray, t_min: float | np.ndarray, t_max: float | np.ndarray) -> np.ndarray:
        """Whether each segment O + t D (3, n; either may be a shared (3, 1) column), t_min <= t <= t_max (numbers
        or (n,) each), meets a box: bool (n,). A ray parallel to a slab is decided by its other axes (slab's NaN
        rule)."""
        count = max(O.shape[1], D.shape[1])
        with quiet():
            inverse = 1.0 / D
            met = np.broadcast_to(_segment_meets(O, inverse, t_min, t_max, *self.outer), (count,))
            if len(self.boxes) == 1:
                return met
            near = indices(met)  # only the segments that meet the outer box go on to the boxes
            O_n, inverse_n = take(O, near), take(inverse, near)
            limit = t_max.take(near) if isinstance(t_max, np.ndarray) else t_max
            start = t_min.take(near) if isinstance(t_min, np.ndarray) else t_min
            inside = np.zeros(near.size, dtype=bool)
            for lower, upper in self.boxes:
                inside |= _segment_meets(O_n, inverse_n, start, limit, lower, upper)
        result = np.zeros(count, dtype=bool)
        result[near] = inside
        return result


def _segment_meets(O, inverse, t_min, t_max, lower, upper) -> np.ndarray:
    near, far = slab(O, inverse, lower, upper)
    return (near <= far) & (far >= t_min) & (near <= t_max)


def swept_volume(scene: sc.Scene, dtype: np.dtype, headings: np.ndarray | None = None) -> Volume | None:
    """Boxes that hold the vane's parts at each of the given headings (degrees), one per part; None: at every
    heading (the parts' boxes revolved a whole turn about the axis). None where there is no vane or a part is
    unbounded (an infinite plane as a part: every pixel could change)."""
    vane = scene.vane
    if vane is None or not vane.parts:
        return None
    pivot = np.asarray(vane.pivot, dtype=np.float64)
    axis = np.asarray(tf.normalize(vane.axis))
    turns = [0.0] if headings is None else np.unique(np.asarray(headings, dtype=np.float64)).tolist()
    boxes = []
    for obj in scene.objects:
        if obj.name not in vane.parts:
            continue
        lows, highs = [], []
        for heading in turns:
            turned = tf.world_primitive(obj, replace(vane, heading=heading))
            bounds = placed_kernel(turned, np.dtype(np.float64)).bounds()
            if bounds is None:
                return None
            lows.append(bounds[0])
            highs.append(bounds[1])
        lower, upper = np.min(lows, axis=0), np.max(highs, axis=0)
        boxes.append(_revolved(lower, upper, pivot, axis) if headings is None else (lower, upper))
    return Volume.around(boxes, dtype, float(np.abs(pivot).max()) + float(np.abs(np.concatenate(boxes)).max()))


def _revolved(
    lower: np.ndarray, upper: np.ndarray, pivot: np.ndarray, axis: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The box (3,) around a box turned a whole turn about the unit axis through pivot."""
    corners = np.array([[(upper if (k >> i) & 1 else lower)[i] for i in range(3)] for k in range(8)]) - pivot
    along = corners @ axis
    across = corners - np.outer(along, axis)
    radius = float(np.sqrt((across * across).sum(axis=1)).max())
    ends = np.array([pivot + axis * along.min(), pivot + axis * along.max()])
    # a disc of radius r about unit axis a reaches r * sqrt(1 - a_i^2) along world axis i
    reach = radius * np.sqrt(np.maximum(0.0, 1.0 - axis**2))
    return ends.min(axis=0) - reach, ends.max(axis=0) + reach


class Footprint:
    """Which camera samples' ray trees met a volume, recorded as they are traced."""

    def __init__(self, volume: Volume, count: int) -> None:
        self.volume = volume
        self.touched = np.zeros(count, dtype=bool)  # (count,): one per camera sample of the traced piece

    def record(
        self,
        samples: np.ndarray,
        O: np.ndarray,
        D: np.ndarray,
        t_min: float,
        t_max: float | np.ndarray,
        hit: np.ndarray | None = None,
        light: int | None = None,
    ) -> None:
        """Segments (3, n) of the trees of camera samples (n,) (indices into touched); what they hit (hit: objects
        (n,), -1 for none) or which light they seek (light) does not matter here."""
        if samples.size:
            self.touched[samples.take(indices(self.volume.meets(O, D, t_min, t_max)))] = True


# ---- the pixels each heading changes -------------------------------------------------------------------------------
#
# The frames of an animation can all start from one image of the scene without its vane (incremental.py): a frame at
# heading h differs from it only in the pixels whose trees (traced without the vane) meet a part at h, since a tree
# that meets no part is the same with the parts there. The volume (swept_volume) tells which pixels may change at
# any heading; HeadingMarks which ones each heading changes, testing those pixels' segments against each part's
# oriented box (its kernel's own frame: the object's axes, much tighter than the world box of a turned part). On the
# default animation that is 1.5% of the pixels a frame, against 9.0% for boxes over 90 degrees of headings.


@dataclass
class HeadingMarks:
    """For headings (H,) sorted, and pixel trees traced without the vane's parts: pixels[k], the flat pixels (sorted)
    whose trees meet some part's oriented box at headings[k]."""

    headings: np.ndarray
    pixels: list[np.ndarray]

    def at(self, heading: float) -> np.ndarray:
        """The flat pixels (sorted) that the parts at heading (one of the headings) change."""
        return self.pixels[int(np.searchsorted(self.headings, heading))]

    @classmethod
    def joined(cls, parts: list[HeadingMarks]) -> HeadingMarks:
        """The marks of disjoint sets of pixels, together."""
        pixels = [np.unique(np.concatenate([part.pixels[k] for part in parts])) for k in range(len(parts[0].headings))]
        return cls(parts[0].headings, pixels)


@dataclass
class HeadingParts:
    """The vane's parts at each of an animation run's headings, as heading_marks tests segments against them:
    headings (H,) sorted, and per part the world box of each heading (padded, float64 (3, 1) each) and the frame of
    its kernel there (to_local, origin, lower, upper: the oriented box; a sphere's (None, None, world box))."""

    headings: np.ndarray
    boxes: list[list[tuple[np.ndarray, np.ndarray]]]
    frames: list[list[tuple]]


def heading_parts(scene: sc.Scene, dtype: np.dtype, headings: np.ndarray) -> HeadingParts:
    """scene's vane parts at the headings (degrees) -> their HeadingParts. About 1.3 ms a heading for the default
    vane's four parts: made once per run (and in the parent, while the workers trace), not in every worker."""
    vane = scene.vane
    turns = np.unique(np.asarray(headings, dtype=np.float64))
    reach = float(np.abs(np.asarray(vane.pivot)).max())
    boxes, frames = [], []
    for obj in scene.objects:
        if obj.name not in vane.parts:
            continue
        boxes.append([])
        frames.append([])
        for heading in turns.tolist():
            kernel = placed_kernel(tf.world_primitive(obj, replace(vane, heading=heading)), dtype)  # its padding
            lower, upper = kernel.bounds()
            lower, upper = padded_box(lower, upper, dtype, reach + float(np.abs(np.concatenate((lower, upper))).max()))
            boxes[-1].append((lower.astype(np.float64), upper.astype(np.float64)))
            if kernel.frame is None:  # a sphere: its world box
                frames[-1].append((None, None, *boxes[-1][-1]))
            else:
                frames[-1].append(tuple(x.astype(np.float64) for x in kernel.frame))
    return HeadingParts(turns, boxes, frames)


def heading_marks(segments, parts: HeadingParts) -> HeadingMarks:
    """segments (raystore.Segments, float64) of pixel trees traced without the vane's parts -> HeadingMarks for the
    parts at their headings (heading_parts), every part bounded."""
    with quiet():
        inverse = 1.0 / segments.D
    rays = _Rays(segments.O, segments.D, inverse, segments.start, segments.end, segments.pixel)
    with quiet():
        # first the segments that meet any part's box at any heading
        lower = np.min([low for part in parts.boxes for low, _ in part], axis=0)
        upper = np.max([high for part in parts.boxes for _, high in part], axis=0)
        rays = rays.meeting(lower, upper)
        marks = [
            _part_marks(rays, part_boxes, part_frames)
            for part_boxes, part_frames in zip(parts.boxes, parts.frames, strict=True)
        ]
    pixels = [np.unique(np.concatenate([part[k] for part in marks])) for k in range(parts.headings.size)]
    return HeadingMarks(parts.headings, pixels)


@dataclass
class _Rays:
    """Segments as heading_marks tests them: origins, directions and their inverses (3, n), t ranges and pixels
    (n,)."""

    O: np.ndarray
    D: np.ndarray
    inverse: np.ndarray
    start: np.ndarray
    end: np.ndarray
    pixel: np.ndarray

    def meeting(self, lower: np.ndarray, upper: np.ndarray) -> _Rays:
        """Those that meet the box (lower, upper (3, 1)). Call inside quiet()."""
        return self.take(indices(_segment_meets(self.O, self.inverse, self.start, self.end, lower, upper)))

    def take(self, keep: np.ndarray) -> _Rays:
        return _Rays(
            self.O.take(keep, axis=1), self.D.take(keep, axis=1), self.inverse.take(keep, axis=1),
            self.start.take(keep), self.end.take(keep), self.pixel.take(keep),
        )  # fmt: skip


def _part_marks(rays: _Rays, boxes: list, frames: list) -> list[np.ndarray]:
    """For each heading k, the pixels (sorted) whose segments meet frames[k] (an oriented box); the headings are
    halved recursively, each half's segments those of the whole that meet the box around its headings' world boxes
    (boxes[k] holds frames[k]'s part), so that a segment meets few headings' oriented boxes. Call inside quiet()."""
    lows = np.stack([low for low, _ in boxes])  # (H, 3, 1)
    highs = np.stack([high for _, high in boxes])
    result = [np.empty(0, dtype=np.int64)] * len(boxes)
    pending = [(rays, 0, len(boxes))]
    while pending:
        rays, first, last = pending.pop()
        rays = rays.meeting(lows[first:last].min(axis=0), highs[first:last].max(axis=0))
        if not rays.pixel.size:
            continue
        if last - first > 1:
            middle = (first + last) // 2
            pending += [(rays, first, middle), (rays, middle, last)]
            continue
        to_local, origin, lower, upper = frames[first]
        if to_local is not None:  # a sphere has none: the world box just met is its box
            local_O = to_local @ (rays.O - origin)
            local_inverse = 1.0 / (to_local @ rays.D)
            rays = rays.take(indices(_segment_meets(local_O, local_inverse, rays.start, rays.end, lower, upper)))
        result[first] = np.unique(rays.pixel)
    return result
