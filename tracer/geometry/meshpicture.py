"""A mesh's triangles seen from a shared point or along a shared direction -> for each cell of a grid over that
picture, the triangles that a ray through the cell may meet.

Camera rays start at the camera, a point light's shadow rays end at the light, a directional light's are parallel:
in the picture of such rays each ray is one point, and it can meet only a triangle whose picture holds that point
(a triangle's picture is the triangle of its corners' pictures, for a perspective picture too, as long as the whole
mesh lies in front of the point). The rectangles of the triangles' pictures, grown by a bound on rounding, are
binned in a grid whose cells are a fraction of a typical triangle, so a ray is tested against the few triangles of
its cell (about the mesh's depth complexity) and no box at all: the walk of meshbvh.py costs dozens of box tests
and triangle tests per ray. The test per triangle is the mesh kernel's own, on the same numbers, so the hits are
the ones the whole-mesh test finds where its ray meets the triangle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .cull import DEPTH_MARGIN, picture_axes, project, projection_error

CELL_SPLIT = 8.0  # cells per a typical (median) triangle's picture side
MIN_CELLS = 1 << 12  # cells however few rays ask: a small query still gets a picture worth keeping
CELLS_PER_RAY = 4  # cells per ray of the query that makes the picture (its count stands for the later ones)
MAX_CELLS = 1 << 18  # about a 640 x 480 image's pixels: finer cells than the rays cost more to fill than they save
MAX_ENTRIES = 1 << 24  # 64 MB of int32 entries; coarser cells beyond
MAX_DEPTH = 32  # candidates per ray (triangle-weighted mean over cells) beyond which the walk is cheaper
SMALL = 4  # cells of a triangle's rectangle that are kept without testing the triangle against each
BUILD_TRIANGLES = 1 << 16  # triangles binned per pass: the pass's temporaries stay tens of MB
MARGIN_SAFETY = 4.0  # the margin a picture is built with, over the rounding bound of rays of the expected reach
HIT_TOLERANCE = {np.dtype(np.float64): 1e-6, np.dtype(np.float32): 1e-4}  # of the picture's size, as padded boxes


@dataclass(frozen=True)
class View:
    """Rays that share a point or a direction: kind "point" (each ray's Q is its vector from the point, or toward
    it with reverse) or "direction" (Q is a point of each ray, its origin); vector (3,) the point or direction;
    share: the view is one of that many whose rays together are a light's (a light of a size's patterns, each
    taken by a quarter of the pixels), so that its picture pays for itself at 1 / share of the rays."""

    kind: str
    vector: tuple[float, float, float]
    reverse: bool = False
    share: int = 1

    @property
    def perspective(self) -> bool:
        return self.kind == "point"


@dataclass
class TrianglePicture:
    """Triangles binned by their pictures: cells (rows x columns) -> entries[starts[c]:starts[c + 1]], the slots
    (indices the caller chose for each triangle) of the triangles whose grown picture rectangle touches cell c.
    axes (3, 3): the picture's right, up, forward rows; low (2,): its lower corner; cell: a cell's side; margin: what
    the triangles were grown by; reach, depth, picture_reach: projection_error()'s terms."""

    view: View
    axes: np.ndarray
    low: np.ndarray
    cell: float
    rows: int
    columns: int
    starts: np.ndarray
    entries: np.ndarray
    margin: float
    reach: float
    depth: float | None
    picture_reach: float

    @classmethod
    def build(
        cls,
        corners: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        slots: np.ndarray,
        view: View,
        dtype: np.dtype,
        rays: int = MAX_CELLS,
    ) -> TrianglePicture | None:
        """corners (3 corners, 3 axes, T) float64 of the triangles, their box lower, upper (3,), and each
        triangle's slot (T,) -> the picture, or None where a perspective picture cannot hold the mesh (the point
        among or beside its triangles).

        rays: about how many rays a query brings (the first one's count): cells much finer than the rays cost more
        to fill than they save, so there are at most CELLS_PER_RAY times as many (and MAX_CELLS)."""
        vector = np.asarray(view.vector, dtype=np.float64)
        depth = None
        if view.perspective:
            forward = (lower + upper) / 2.0 - vector
            distance = float(np.linalg.norm(forward))
            if distance == 0.0:
                return None
            axes = np.stack(picture_axes(forward / distance))
            u, v, depths = zip(*(_local(corner, axes, vector) for corner in corners), strict=True)  # 3 x (T,)
            depth = min(float(z.min()) for z in depths)
            if depth <= DEPTH_MARGIN * (float(np.max(upper - lower)) + distance):
                return None
            for z, x, y in zip(depths, u, v, strict=True):
                x /= z
                y /= z
            del depths
        else:
            axes = np.stack(picture_axes(vector / np.linalg.norm(vector)))
            u, v, _ = zip(*(_local(corner, axes, np.zeros(3)) for corner in corners), strict=True)
        u_low, u_high = np.minimum(np.minimum(u[0], u[1]), u[2]), np.maximum(np.maximum(u[0], u[1]), u[2])  # (T,)
        v_low, v_high = np.minimum(np.minimum(v[0], v[1]), v[2]), np.maximum(np.maximum(v[0], v[1]), v[2])
        reach = float(max(np.abs(lower).max(), np.abs(upper).max(), np.abs(vector).max()))
        picture_reach = 1.0 + float(max(-u_low.min(), u_high.max(), -v_low.min(), v_high.max(), 0.0))
        size = float(max(u_high.max() - u_low.min(), v_high.max() - v_low.min()))
        # rays of Q up to a few times the scene's reach resolve (shadow rays toward a light come from anywhere in
        # it); a query of rays beyond that is refused and walked (cells())
        expected = projection_error(dtype, 4.0 * reach + 1.0, reach, depth, picture_reach)
        margin = MARGIN_SAFETY * expected + HIT_TOLERANCE[np.dtype(dtype)] * size
        u_low -= margin
        v_low -= margin
        u_high += margin
        v_high += margin
        low = np.array([u_low.min(), v_low.min()])
        extent = np.array([u_high.max(), v_high.max()]) - low
        typical = float(np.median(np.maximum(u_high - u_low, v_high - v_low)))
        longest = float(extent.max())
        most = min(MAX_CELLS, max(MIN_CELLS, CELLS_PER_RAY * rays))
        cell = max(typical / CELL_SPLIT, math.sqrt(float(extent[0] * extent[1]) / most), longest / 4096)
        cell = max(cell, longest * 1e-12)
        while True:
            columns, rows = (np.floor(extent / cell).astype(np.int64) + 1).tolist()
            first_column = np.minimum(((u_low - low[0]) / cell).astype(np.int64), columns - 1)
            last_column = np.minimum(((u_high - low[0]) / cell).astype(np.int64), columns - 1)
            first_row = np.minimum(((v_low - low[1]) / cell).astype(np.int64), rows - 1)
            last_row = np.minimum(((v_high - low[1]) / cell).astype(np.int64), rows - 1)
            widths, heights = last_column - first_column + 1, last_row - first_row + 1
            counts = widths * heights  # (T,)
            if int(counts.sum()) <= MAX_ENTRIES:
                break
            cell *= 1.5
        del u_low, u_high, v_low, v_high, last_column, last_row, heights
        # every (triangle, cell) of the triangles' rectangles whose cell the triangle itself touches, a slice of
        # the mesh at a time (bounded temporaries); then grouped by cell (the order within a cell does not matter:
        # a search takes the nearest hit and the lowest triangle index on ties)
        owners, cells = [], []
        for start in range(0, len(counts), BUILD_TRIANGLES):
            chunk = slice(start, start + BUILD_TRIANGLES)
            owner, cell_index = _touched(
                tuple(x[chunk] for x in u), tuple(y[chunk] for y in v), first_column[chunk], first_row[chunk],
                widths[chunk], counts[chunk], low, cell, margin, columns,
            )  # fmt: skip
            owners.append(owner + start)
            cells.append(cell_index)
        owner, cell_index = np.concatenate(owners), np.concatenate(cells).astype(np.int32)
        del owners, cells
        # stable: timsort takes the runs the triangles' rectangles leave in order (3,000 cubes' 557,000 entries:
        # 9 against 37 ms for quicksort), and random cells no slower
        entries = slots.take(owner.take(np.argsort(cell_index, kind="stable")))
        entries = entries.astype(np.int32 if len(slots) and entries.max(initial=0) < 2**31 else np.int64)
        occupancy = np.bincount(cell_index, minlength=rows * columns)
        # a ray meets about this many candidates where triangles lie (a cell weighted by its own count): deep
        # stacks (a dense mesh seen edge-on, a crumpled soup) are better walked, nearest first, than all tested
        if float(np.dot(occupancy, occupancy)) > MAX_DEPTH * float(occupancy.sum()):
            return None
        starts = np.zeros(rows * columns + 1, dtype=np.int64)
        np.cumsum(occupancy, out=starts[1:])
        return cls(view, axes, low, cell, rows, columns, starts, entries, margin, reach, depth, picture_reach)

    def cells(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Rays (3, n) -> (the rays (m,) whose cell holds any triangle, ascending; their cells (m,)), or None where
        rounding could move a ray's picture point by more than the margin the triangles were grown by.

        Q: as View says (each ray's vector from or toward the point, or a point of each ray)."""
        if Q.shape[1] == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        depth = self.depth if self.view.perspective else None
        if projection_error(Q.dtype, float(np.abs(Q).max()), self.reach, depth, self.picture_reach) > self.margin:
            return None
        u, v = project(self.axes, Q, self.view.perspective, self.view.reverse)
        scale = Q.dtype.type(1.0 / self.cell)
        column = (u - Q.dtype.type(self.low[0])) * scale
        row = (v - Q.dtype.type(self.low[1])) * scale
        inside = (column >= 0.0) & (column < self.columns) & (row >= 0.0) & (row < self.rows)  # NaN: outside
        rays = inside.nonzero()[0]
        cell = row.take(rays).astype(np.int64) * self.columns + column.take(rays).astype(np.int64)
        full = (self.starts.take(cell + 1) > self.starts.take(cell)).nonzero()[0]
        return rays.take(full), cell.take(full)


def _local(corner: np.ndarray, axes: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One corner of every triangle (3 axes, T) -> its coordinates (T,) x 3 along axes (3, 3) from origin (3,)."""
    relative = [corner[axis] - origin[axis] for axis in range(3)]
    return tuple(row[0] * relative[0] + row[1] * relative[1] + row[2] * relative[2] for row in axes)


def _touched(
    u: tuple[np.ndarray, ...],
    v: tuple[np.ndarray, ...],
    first_column: np.ndarray,
    first_row: np.ndarray,
    widths: np.ndarray,
    counts: np.ndarray,
    low: np.ndarray,
    cell: float,
    margin: float,
    columns: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Triangles' pictures (corners u, v: 3 x (T,)) and their rectangles' cells (first column and row, width in
    cells, cell count (T,)) -> (triangle (E,), cell (E,)) for each cell, grown by margin, that its triangle touches.

    A cell and a triangle are apart where one of the triangle's edge normals separates them (the rectangle already
    decides the cells' own axes): about half of a sliver's rectangle drops out. Triangles of at most SMALL cells
    keep them all (little to drop, and the test would cost more than it saves)."""
    large = counts > SMALL
    owner, row, column = _cells(first_column, first_row, widths, counts, ~large)
    owner_large, row_large, column_large = _cells(first_column, first_row, widths, counts, large)
    # each edge's normal n (per triangle): the cell of centre c and half side h is apart from the triangle where
    # n.c + h (|n_u| + |n_v|) < min or n.c - h (|n_u| + |n_v|) > max of the corners' n.p; with
    # c = low + (column + 1/2, row + 1/2) cell, n.c = n_u cell column + n_v cell row + n.(low + cell / 2)
    half = cell / 2.0 + margin
    apart = np.zeros(owner_large.size, dtype=bool)
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        normal_u, normal_v = v[a] - v[b], u[b] - u[a]  # the edge a -> b turned a quarter (T,)
        edge = normal_u * u[a] + normal_v * v[a]  # a and b project here, c elsewhere
        other = normal_u * u[c] + normal_v * v[c]
        offset = normal_u * (low[0] + cell / 2.0) + normal_v * (low[1] + cell / 2.0)
        radius = half * (np.abs(normal_u) + np.abs(normal_v))
        below = np.minimum(edge, other) - radius - offset  # n.c - n.(low + cell / 2) must reach this
        above = np.maximum(edge, other) + radius - offset
        centre = (normal_u * cell).take(owner_large) * column_large
        centre += (normal_v * cell).take(owner_large) * row_large
        apart |= (centre < below.take(owner_large)) | (centre > above.take(owner_large))
    kept = (~apart).nonzero()[0]
    owner = np.concatenate((owner, owner_large.take(kept)))
    row = np.concatenate((row, row_large.take(kept)))
    column = np.concatenate((column, column_large.take(kept)))
    return owner, row.astype(np.int64) * columns + column.astype(np.int64)


def _cells(
    first_column: np.ndarray, first_row: np.ndarray, widths: np.ndarray, counts: np.ndarray, chosen: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chosen (T,) triangles' rectangles -> every (triangle (E,), row (E,), column (E,)) of them, as floats for
    the rows and columns (exact for these small integers, and float division is far faster than integer // and %
    in NumPy)."""
    triangles = chosen.nonzero()[0]
    counts = counts.take(triangles)
    total = int(counts.sum())
    owner = np.repeat(triangles, counts)
    within = np.arange(total, dtype=np.float64) - np.repeat(np.cumsum(counts) - counts, counts)
    row_width = widths.astype(np.float64).take(owner)
    row = np.floor((within + 0.5) / row_width)
    column = within - row * row_width
    row += first_row.take(owner)
    column += first_column.take(owner)
    return owner, row, column
