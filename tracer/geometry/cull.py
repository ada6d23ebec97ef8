"""Rays that share a point or a direction -> for each bounded kernel, the rays that may meet it.

Shadow rays toward a point light all end at the light: seen from there, every ray is one point of a picture, and it
can only meet an object whose box covers that point. Shadow rays toward a directional light are parallel: projected
along the light, each ray is again one point. A CoverageGrid over that picture records in each cell which boxes
cover it, so a shadow ray is projected, looked up, and goes only to those boxes' kernels; most rays pass beside
every object and go nowhere. Camera rays need no projection at all: ScreenRectangles gives each kernel the pixels of
its box's rectangle on the screen.

Both only remove rays that cannot hit. Each grid area is grown by one cell (each rectangle by two pixels), and where
a bound on what rounding in the tracing dtype does (to the rays, the objects and the projection) is not well below
that margin (absurdly far rays, tiny objects, the point among the boxes), nothing is culled. A box that no picture
can hold (rt3.py's floor, a sphere of radius 99999: its box reaches behind the camera and spreads under the light)
is left out of it, and its kernel sees every ray (`whole`); the other boxes are still culled.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

import numpy as np

from ..scene import scene as sc
from . import camera as cam

CELLS = 128  # along the picture's longer side
GRID_BOXES = 64  # the most boxes a coverage grid tells apart (a bit each per cell); beyond, only whether any covers
DEPTH_MARGIN = 1e-3  # of the scene's size: a perspective picture needs every box at least this far in front
# How far rounding may move a ray, in units in the last place of the scene's size, that a pixel's footprint at the
# nearest box must exceed: a camera ray's own rounding; a mirror ray's adds its origin on the plane and the
# reflected direction (a few units each), and robust numerics' offset origin (robust.OFFSET_EPSILONS)
CAMERA_ROUNDING = 64.0
MIRROR_ROUNDING = 256.0


def picture_axes(forward: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit forward (3,) -> (right, up, forward) orthonormal rows."""
    helper = np.eye(3)[int(np.argmin(np.abs(forward)))]
    right = np.cross(forward, helper)
    right /= np.linalg.norm(right)
    return right, np.cross(forward, right), forward


def _rectangles(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Picture coordinates u, v (k, 8) of each box's corners -> its rectangle (k, 4): u_min, v_min, u_max, v_max."""
    return np.stack((u.min(axis=1), v.min(axis=1), u.max(axis=1), v.max(axis=1)), axis=1)


def _corners(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Boxes (k, 3) -> their corners (k, 8, 3)."""
    pick = np.array([[(i >> axis) & 1 for axis in range(3)] for i in range(8)], dtype=bool)  # (8, 3)
    return np.where(pick[None], upper[:, None, :], lower[:, None, :])


def project(axes: np.ndarray, Q: np.ndarray, perspective: bool, reverse: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Rays (3, n) -> their points u, v (n,) in a picture with axes (3, 3) (right, up, forward rows), computed in
    Q's own dtype (projection_error() bounds that rounding too).

    Q is, for a perspective picture, each ray's vector from the shared point, or with reverse its vector toward
    the point; for a parallel one, a point of each ray. A perspective ray that points away from the picture (or is
    NaN) gets u = -inf: it stays on the point's side away from everything in the picture."""
    right, up, forward = axes.astype(Q.dtype)
    u = right[0] * Q[0] + right[1] * Q[1] + right[2] * Q[2]
    v = up[0] * Q[0] + up[1] * Q[1] + up[2] * Q[2]
    if perspective:
        depth = forward[0] * Q[0] + forward[1] * Q[1] + forward[2] * Q[2]
        behind = ~(depth < 0.0) if reverse else ~(depth > 0.0)  # NaN included
        depth[behind] = 1.0
        u /= depth
        v /= depth
        u[behind] = -math.inf
    return u, v


def projection_error(dtype: np.dtype, q_reach: float, reach: float, depth: float | None, picture_reach: float) -> float:
    """A bound on how far rounding in the rays' dtype moves a ray's picture point (a generous one: 64 units in the
    last place of the largest coordinate involved), both the rays' own rounding and that of project().

    q_reach: the largest coordinate of the rays' Q (see project()); reach: the largest coordinate of what the
    picture holds and of the shared point; depth: the nearest depth in front of the shared point (None: a parallel
    picture); picture_reach: 1 + the largest picture coordinate."""
    eps = float(np.finfo(dtype).eps)
    error = 64.0 * eps * (q_reach + 2.0 * reach)
    if depth is not None:
        error *= picture_reach / depth  # a point moved by e at depth >= d moves by e (1 + |uv|) / d
        error += 16.0 * eps * picture_reach**2  # u = (r . Q) / (f . Q): 3 eps (1 + |u|) |Q| / depth
    return error


class CoverageGrid:
    """A picture of the boxes: each cell records which boxes cover it; select() picks the rays in covered cells."""

    def __init__(
        self,
        axes: np.ndarray,
        rectangles: np.ndarray,
        reach: float,
        depth: float | None,
        kernels: list[int],
        whole: list[int] | None = None,
    ) -> None:
        """axes (3, 3): right, up, forward rows; rectangles (k, 4): u_min, v_min, u_max, v_max of each box; reach:
        the largest coordinate of the boxes and the shared point; depth: the nearest corner's depth in front of the
        shared point (perspective), None for parallel rays; kernels (k,): the kernel each box bounds; whole: the
        kernels left out of the picture, which every ray may meet."""
        self.axes = axes
        self.kernels = kernels
        self.whole = whole or []
        self.perspective = depth is not None
        self.reach = reach
        self.depth = depth
        low, high = rectangles[:, :2].min(axis=0), rectangles[:, 2:].max(axis=0)
        extent = np.maximum(high - low, 1e-12)
        cell = float(extent.max()) / CELLS
        shape = np.maximum(np.ceil(extent / cell).astype(int), 1)
        self.origin = low
        self.scale = 1.0 / cell
        # one ring of empty cells around the grid: rays outside it are clipped into the ring
        self.columns, self.rows = int(shape[0]) + 2, int(shape[1]) + 2
        # up to 64 boxes, one bit each per cell, in the narrowest unsigned type that holds them (kernel_sets reads
        # every box's bit of every ray: the vane's 13 boxes in uint16, not uint64, about half the time); beyond
        # 64 boxes only whether any box covers it
        bits = np.zeros((self.rows, self.columns), dtype=_bits_type(len(kernels)))
        first = np.floor((rectangles[:, :2] - low) * self.scale).astype(int)  # grow each area by one cell
        last = np.floor((rectangles[:, 2:] - low) * self.scale).astype(int) + 2
        for box, ((u0, v0), (u1, v1)) in enumerate(zip(first.tolist(), last.tolist(), strict=True)):
            area = bits[max(v0, 0) : min(v1, self.rows - 2) + 1, max(u0, 0) : min(u1, self.columns - 2) + 1]
            area |= True if bits.dtype == bool else bits.dtype.type(1 << box)
        self.bits = None if bits.dtype == bool else bits.ravel()
        self.marked = bits.ravel() != 0
        self.picture_reach = 1.0 + float(np.abs(np.concatenate((low, high))).max())

    @classmethod
    def from_point(
        cls, point: np.ndarray, kernels: list[int], lower: np.ndarray, upper: np.ndarray
    ) -> CoverageGrid | None:
        """Rays through a shared point (3,) toward boxes (k, 3) of kernels (k,). A box that the point sits in or
        close beside for its size (a floor sphere's box under a light) is left out of the picture, and its kernel
        sees every ray (whole); None where no box is left."""
        view = _view_from(point, lower, upper)
        whole = []
        if view is None:
            alone = [_view_from(point, lower[j : j + 1], upper[j : j + 1]) is not None for j in range(len(kernels))]
            if all(alone) or not any(alone):
                return None
            whole = [kernel for kernel, keep in zip(kernels, alone, strict=True) if not keep]
            kernels = [kernel for kernel, keep in zip(kernels, alone, strict=True) if keep]
            lower, upper = lower[alone], upper[alone]
            view = _view_from(point, lower, upper)
            if view is None:
                return None
        axes, local = view
        rectangles = _rectangles(local[..., 0] / local[..., 2], local[..., 1] / local[..., 2])
        reach = float(max(np.abs(lower).max(), np.abs(upper).max(), np.abs(point).max()))
        return cls(axes, rectangles, reach, float(local[..., 2].min()), kernels, whole)

    @classmethod
    def from_direction(
        cls, direction: np.ndarray, kernels: list[int], lower: np.ndarray, upper: np.ndarray
    ) -> CoverageGrid:
        """Rays along a shared direction (3,) toward boxes (k, 3) of kernels (k,)."""
        axes = np.stack(picture_axes(direction / np.linalg.norm(direction)))
        local = _corners(lower, upper) @ axes.T
        rectangles = _rectangles(local[..., 0], local[..., 1])
        return cls(axes, rectangles, float(max(np.abs(lower).max(), np.abs(upper).max())), None, kernels)

    @property
    def coverage(self) -> float:
        """The share of the grid's cells that are marked (a measure of how much it can cull)."""
        return float(self.marked.mean())

    def select(self, Q: np.ndarray, reverse: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
        """Rays (3, n) -> (indices (m,) of those that may meet a box, ascending; for each of them the bits (m,)
        of the boxes its cell records, bit j for box j), or (all rays, None) where the grid cannot tell
        (more than 64 boxes, or rays too far away to place within a cell).

        Q is, for a perspective picture, each ray's vector from the shared point (a camera ray's direction), or
        with reverse its vector toward the point (a shadow ray's vector toward the light); for a parallel one, a
        point of each ray (its origin)."""
        if Q.shape[1] == 0 or not self._resolves(Q):
            return np.arange(Q.shape[1]), None
        u, v = project(self.axes, Q, self.perspective, reverse)
        origin, scale = self.origin.astype(Q.dtype), Q.dtype.type(self.scale)
        column = np.clip((u - origin[0]) * scale + 1.0, 0.0, self.columns - 1.0)
        row = np.clip((v - origin[1]) * scale + 1.0, 0.0, self.rows - 1.0)
        cell = row.astype(np.intp) * self.columns + column.astype(np.intp)
        rays = self.marked.take(cell, mode="clip").nonzero()[0]  # clip: a NaN ray lands anywhere, hits nothing
        if self.bits is None:
            return rays, None
        return rays, self.bits.take(cell.take(rays), mode="clip")

    def shares(self, Q: np.ndarray, reverse: bool = False) -> np.ndarray:
        """Sample rays (3, n) as for select() -> the share (k,) of them that select() gives each kernel."""
        rays, bits = self.select(Q, reverse)
        count = max(1, Q.shape[1])
        if bits is None:
            return np.full(len(self.kernels), rays.size / count)
        return (
            np.array([np.count_nonzero(bits & bits.dtype.type(1 << box)) for box in range(len(self.kernels))]) / count
        )

    def _resolves(self, Q: np.ndarray) -> bool:
        """Whether rounding in Q's dtype moves any ray's picture point by less than half a cell (a generous bound:
        64 units in the last place of the largest coordinate involved), both the rays' own rounding and that of
        projecting them in that dtype."""
        depth = self.depth if self.perspective else None
        error = projection_error(Q.dtype, float(np.abs(Q).max()), self.reach, depth, self.picture_reach)
        return error < 0.5 / self.scale


def _bits_type(boxes: int) -> type:
    """The narrowest unsigned integer type with a bit for each of boxes, or bool beyond GRID_BOXES."""
    for kind in (np.uint8, np.uint16, np.uint32, np.uint64):
        if boxes <= 8 * np.dtype(kind).itemsize <= GRID_BOXES:
            return kind
    return bool


def _view_from(point: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Boxes (k, 3) seen from a point (3,) -> the picture's axes (3, 3) and the boxes' corners in them (k, 8, 3), or
    None where the point sits among the boxes (a corner less than DEPTH_MARGIN of their size in front of it)."""
    center = (lower.min(axis=0) + upper.max(axis=0)) / 2.0
    forward = center - point
    distance = float(np.linalg.norm(forward))
    if distance == 0.0:
        return None
    axes = np.stack(picture_axes(forward / distance))
    local = (_corners(lower, upper) - point) @ axes.T
    size = float(np.max(upper.max(axis=0) - lower.min(axis=0))) + distance
    if float(local[..., 2].min()) <= DEPTH_MARGIN * size:
        return None
    return axes, local


def kernel_sets(pictures: list[tuple[list[int], np.ndarray]]) -> list[tuple[int, np.ndarray]]:
    """The rays of several grids' select(), one grid's after another's: each grid's kernels (k,) and bits (m,) ->
    (kernel, positions (n,) among all the rays, ascending) for every kernel that some ray may meet."""
    if all(kernels == pictures[0][0] for kernels, _ in pictures):  # the usual case: one pass over all the bits
        bits = pictures[0][1] if len(pictures) == 1 else np.concatenate([bits for _, bits in pictures])
        pictures = [(pictures[0][0], bits)]
    found: dict[int, list[np.ndarray]] = {}
    start = 0
    for kernels, bits in pictures:
        for box, kernel in enumerate(kernels):
            positions = ((bits & bits.dtype.type(1 << box)) != 0).nonzero()[0]  # a bool array's nonzero is faster
            if positions.size:
                found.setdefault(kernel, []).append(positions + start if start else positions)
        start += bits.size
    return [(kernel, parts[0] if len(parts) == 1 else np.concatenate(parts)) for kernel, parts in sorted(found.items())]


class ScreenRectangles:
    """Camera rays -> for each bounded kernel, the rays of a band whose pixels its box can cover.

    Seen through the camera, a box wholly in front of it covers at most the rectangle of its corners' pixels, and
    a camera ray's sample lies inside its own pixel; so a kernel need only see the rays of the pixels in that
    rectangle, grown by two pixels (far more than rounding moves a ray: build() checks). The sets come from pixel
    indices alone: no ray is projected, and the hierarchy is not walked for camera rays.
    """

    def __init__(
        self, kernels: list[int], rectangles: np.ndarray, size: tuple[int, int], samples: int, whole: list[int]
    ) -> None:
        """rectangles (k, 4) int: first column, first row, last column, last row of each kernel's pixels; size:
        the image's width and height; whole: the kernels left out of the picture, which see every ray."""
        self.kernels = kernels
        self.rectangles = rectangles
        self.width, self.height = size
        self.samples = samples
        self.whole = whole

    @classmethod
    def build(
        cls,
        camera: sc.Camera,
        settings: sc.RenderSettings,
        location: np.ndarray,
        boxes: tuple[list[int], np.ndarray, np.ndarray],
    ) -> ScreenRectangles | None:
        """location (3,): the camera's position as the tracer holds it; boxes: kernel indices (k,) with their boxes
        lower, upper (k, 3). A box that reaches behind the camera (a floor sphere of radius 99999, say) is left out
        of the picture: its kernel sees every camera ray (whole). None where no box is left, or a pixel is too fine
        for the dtype."""
        kernels, lower, upper = boxes
        return cls._from_corners(camera, settings, location, kernels, _corners(lower, upper), CAMERA_ROUNDING)

    @classmethod
    def mirrored(
        cls,
        camera: sc.Camera,
        settings: sc.RenderSettings,
        location: np.ndarray,
        boxes: tuple[list[int], np.ndarray, np.ndarray],
        point: np.ndarray,
        normal: np.ndarray,
    ) -> ScreenRectangles | None:
        """The rectangles of the boxes' mirror images in the plane through point (3,) with normal (3,): which
        mirror rays off that plane each kernel can meet, by their camera rays' pixels.

        A camera ray that meets the plane goes on, mirrored, as its mirror ray; mirrored back through the plane,
        that ray is the camera ray's own continuation beyond the plane, which can meet a box's mirror image only
        through the pixels of that image's rectangle. Rounding moves a mirror ray off that continuation by a few
        units in the last place of the scene's size (its origin, the reflected direction): within the rectangles'
        margin wherever _from_corners accepts the picture (MIRROR_ROUNDING)."""
        kernels, lower, upper = boxes
        unit_normal = normal / np.linalg.norm(normal)
        corners = _corners(lower, upper)  # (k, 8, 3)
        across = (corners - point) @ unit_normal  # signed distances (k, 8) from the plane
        mirrored = corners - 2.0 * across[..., None] * unit_normal
        return cls._from_corners(camera, settings, location, kernels, mirrored, MIRROR_ROUNDING, point)

    @classmethod
    def _from_corners(
        cls,
        camera: sc.Camera,
        settings: sc.RenderSettings,
        location: np.ndarray,
        kernels: list[int],
        corners: np.ndarray,
        rounding: float,
        also: np.ndarray | None = None,
    ) -> ScreenRectangles | None:
        """The rectangles of kernels' (k,) convex pieces, each the hull of its corners (k, 8, 3); rounding: the
        units in the last place of the scene's size by which the rays may stray (the pictured corners', the
        location's and also's (3,) largest coordinate)."""
        with np.errstate(divide="ignore", invalid="ignore"):  # a corner on the camera's plane: left out below
            x, y, depth = cam.to_pixels(camera, settings, corners, location)  # (k, 8) each
        location_reach = float(np.abs(location).max())
        if also is not None:
            location_reach = max(location_reach, float(np.abs(also).max()))
        box_reach = np.abs(corners).max(axis=(1, 2))  # (k,)
        pictured = depth.min(axis=1) > DEPTH_MARGIN * np.maximum(box_reach, location_reach)  # NaN: left out
        if not pictured.any():
            return None
        x, y, depth = x[pictured], y[pictured], depth[pictured]
        nearest = float(depth.min())
        reach = max(float(box_reach[pictured].max()), location_reach)
        if nearest <= DEPTH_MARGIN * reach:
            return None
        # rounding could move a ray by a pixel's footprint at the nearest corner
        if cam.pixel_footprint(camera, settings, nearest) < rounding * float(np.finfo(settings.dtype).eps) * reach:
            return None
        width, height = settings.width, settings.height
        rectangles = np.stack(
            (
                np.clip(np.floor(x.min(axis=1)) - 2, 0, width - 1),
                np.clip(np.floor(y.min(axis=1)) - 2, 0, height - 1),
                np.clip(np.floor(x.max(axis=1)) + 1, -1, width - 1),
                np.clip(np.floor(y.max(axis=1)) + 1, -1, height - 1),
            ),
            axis=1,
        ).astype(np.int64)
        chosen = [kernel for kernel, keep in zip(kernels, pictured.tolist(), strict=True) if keep]
        whole = [kernel for kernel, keep in zip(kernels, pictured.tolist(), strict=True) if not keep]
        return cls(chosen, rectangles, (width, height), settings.samples, whole)

    @property
    def shares(self) -> np.ndarray:
        """The share (k,) of the image's pixels in each pictured kernel's rectangle (of the rays it is given)."""
        first_column, first_row, last_column, last_row = self.rectangles.T
        area = np.maximum(last_column - first_column + 1, 0) * np.maximum(last_row - first_row + 1, 0)
        return area / float(self.width * self.height)

    def pixel_rays(
        self, pixels: np.ndarray, runs: list[int] | None = None, frame_of: list[int] | None = None
    ) -> list[tuple[int, np.ndarray | None]]:
        """rays() for camera rays of flat pixels j * width + i (P,) in any order (the pixels an animation's frame
        traces again), ordered pixel, sample as camera.pixel_directions gives them.

        runs: where each run of pixels starts, and the end (R + 1,), for pixels that come in ascending runs (the
        frames of a batch, rayframes.py): a kernel's pixels are then found from its rectangle's rows by two binary
        searches in each run, and its columns tested on those only; frame_of: the run each kernel index's rays
        must come from (-1: any), for the kernels that see one frame only."""
        if runs is None:
            column, row = pixels % self.width, pixels // self.width
            return self._sets(
                (kernel, ((column >= first_column) & (column <= last_column) & (row >= first_row) & (row <= last_row)))
                for kernel, first_column, first_row, last_column, last_row in self._nonempty()
            )
        column = pixels % self.width
        found = []
        for kernel, first_column, first_row, last_column, last_row in self._nonempty():
            frame = -1 if frame_of is None else frame_of[kernel]
            rows = (first_row * self.width, (last_row + 1) * self.width)  # the flat pixels of its rows
            pieces = []
            for run in range(len(runs) - 1) if frame < 0 else (frame,):
                start, end = runs[run], runs[run + 1]
                low, high = (np.searchsorted(pixels[start:end], rows) + start).tolist()
                if high > low:
                    inside = column[low:high]
                    pieces.append(((inside >= first_column) & (inside <= last_column)).nonzero()[0] + low)
            if pieces:
                found.append((kernel, pieces[0] if len(pieces) == 1 else np.concatenate(pieces)))
        return self._sets(found)

    def rays(self, rows: np.ndarray) -> list[tuple[int, np.ndarray | None]]:
        """Image rows (R,) of a band, ascending -> (kernel index, ray indices ascending) for every kernel that
        the band's camera rays can meet; rays are ordered row, column, sample as in camera.band_directions. A
        kernel left out of the picture comes with None: every ray."""
        found = []
        for kernel, first_column, first_row, last_column, last_row in self._nonempty():
            positions = ((rows >= first_row) & (rows <= last_row)).nonzero()[0]
            columns = np.arange(first_column, last_column + 1)
            found.append((kernel, (positions[:, None] * self.width + columns[None, :]).ravel()))
        return self._sets(found)

    def _nonempty(self) -> Iterator[tuple[int, int, int, int, int]]:
        """Each pictured kernel whose rectangle holds a pixel, with its first column, first row, last column and
        last row."""
        for kernel, (first_column, first_row, last_column, last_row) in zip(
            self.kernels, self.rectangles.tolist(), strict=True
        ):
            if last_column >= first_column:
                yield kernel, first_column, first_row, last_column, last_row

    def _sets(self, found: Iterable[tuple[int, np.ndarray]]) -> list[tuple[int, np.ndarray | None]]:
        """(kernel, its rays' pixels as positions (n,), or a mask over them) -> (kernel, ray indices) with every
        sample of each pixel, for the kernels with any, then the kernels left out of the picture (None: every
        ray)."""
        sets = []
        samples = np.arange(self.samples)
        for kernel, pixels in found:
            positions = pixels.nonzero()[0] if pixels.dtype == bool else pixels
            if positions.size:
                sets.append((kernel, (positions[:, None] * self.samples + samples[None, :]).ravel()))
        return sets + [(kernel, None) for kernel in self.whole]
