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
MIN_CELLS = 1 << 12
CELLS_PER_RAY = 4
MAX_CELLS = 1 << 18  # about a 640 x 480 image's pixels: finer cells than the rays cost more to fill than they save
MAX_ENTRIES = 1 << 24  # 64 MB of int32 entries; coarser cells beyond
BUILD_TRIANGLES = 1 << 16  # triangles binned per pass: the pass's temporaries stay tens of MB
MARGIN_SAFETY = 4.0  # the margin a picture is built with, over the rounding bound of rays of the expected reach
HIT_TOLERANCE = {np.dtype(np.float64): 1e-6, np.dtype(np.float32): 1e-4}  # of the picture's size, as padded boxes


@dataclass(frozen=True)
class View:
    """Rays that share a point or a direction: kind "point" (each ray's Q is its vector from the point, or toward
    it with reverse) or "direction" (Q is a point of each ray, its origin); vector (3,) the point or direction."""

    kind: str
    vector: tuple[float, float, float]
    reverse: bool = False

    @property
    def perspective(self) -> bool:
        return self.kind == "point"


class TrianglePicture:
    """Triangles binned by their pictures: cells (rows x columns) -> entries[starts[c]:starts[c + 1]], the slots
    (indices the caller chose for each triangle) of the triangles whose grown picture rectangle touches cell c."""

    def __init__(
        self,
        view: View,
        axes: np.ndarray,
        low: np.ndarray,
        cell: float,
        shape: tuple[int, int],
        starts: np.ndarray,
        entries: np.ndarray,
        margin: float,
        reach: float,
        depth: float | None,
        picture_reach: float,
    ) -> None:
        self.view = view
        self.axes = axes
        self.low = low
        self.cell = cell
        self.rows, self.columns = shape
        self.starts = starts
        self.entries = entries
        self.margin = margin
        self.reach = reach
        self.depth = depth
        self.picture_reach = picture_reach

    @classmethod
    def build(
        cls, triangles: np.ndarray, slots: np.ndarray, view: View, dtype: np.dtype, rays: int = MAX_CELLS
    ) -> TrianglePicture | None:
        """triangles (T, 3 corners, 3) float64 and each one's slot (T,) -> the picture, or None where a perspective
        picture cannot hold the mesh (the point among or beside its triangles).

        rays: about how many rays a query brings (the first one's count): cells much finer than the rays cost more
        to fill than they save, so there are at most CELLS_PER_RAY times as many (and MAX_CELLS)."""
        vector = np.asarray(view.vector, dtype=np.float64)
        lower, upper = triangles.min(axis=(0, 1)), triangles.max(axis=(0, 1))
        if view.perspective:
            forward = (lower + upper) / 2.0 - vector
            distance = float(np.linalg.norm(forward))
            if distance == 0.0:
                return None
            axes = np.stack(picture_axes(forward / distance))
            local = (triangles - vector) @ axes.T  # (T, 3, 3)
            depth = float(local[..., 2].min())
            if depth <= DEPTH_MARGIN * (float(np.max(upper - lower)) + distance):
                return None
            u, v = local[..., 0] / local[..., 2], local[..., 1] / local[..., 2]
        else:
            axes = np.stack(picture_axes(vector / np.linalg.norm(vector)))
            local = triangles @ axes.T
            depth, u, v = None, local[..., 0], local[..., 1]
        del local
        u_low, u_high, v_low, v_high = u.min(axis=1), u.max(axis=1), v.min(axis=1), v.max(axis=1)  # (T,)
        reach = float(max(np.abs(lower).max(), np.abs(upper).max(), np.abs(vector).max()))
        picture_reach = 1.0 + float(max(np.abs(bound).max() for bound in (u_low, u_high, v_low, v_high)))
        size = float(max(u_high.max() - u_low.min(), v_high.max() - v_low.min()))
        # rays of Q up to a few times the scene's reach resolve (shadow rays toward a light come from anywhere in
        # it); a query of rays beyond that is refused and walked (cells())
        expected = projection_error(dtype, 4.0 * reach + 1.0, reach, depth, picture_reach)
        margin = MARGIN_SAFETY * expected + HIT_TOLERANCE[np.dtype(dtype)] * size
        u_low, v_low, u_high, v_high = u_low - margin, v_low - margin, u_high + margin, v_high + margin
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
            total = int(counts.sum())
            if total <= MAX_ENTRIES:
                break
            cell *= 1.5
        # every (triangle, cell) of the triangles' rectangles whose cell the triangle itself touches, triangle by
        # triangle, a slice of the mesh at a time (bounded temporaries); then grouped by cell (a stable sort keeps
        # each cell's triangles in the mesh's order)
        owners, cells = [], []
        for start in range(0, len(counts), BUILD_TRIANGLES):
            chunk = slice(start, start + BUILD_TRIANGLES)
            owner, cell_index = _touched(
                u[chunk], v[chunk], first_column[chunk], first_row[chunk], widths[chunk], counts[chunk], low, cell,
                margin, columns,
            )  # fmt: skip
            owners.append(owner + start)
            cells.append(cell_index)
        owner, cell_index = np.concatenate(owners), np.concatenate(cells)
        del owners, cells
        order = np.argsort(cell_index, kind="stable")
        entries = slots.take(owner.take(order)).astype(np.int32 if slots.max(initial=0) < 2**31 else np.int64)
        starts = np.zeros(rows * columns + 1, dtype=np.int64)
        np.cumsum(np.bincount(cell_index, minlength=rows * columns), out=starts[1:])
        return cls(view, axes, low, cell, (rows, columns), starts, entries, margin, reach, depth, picture_reach)

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


def _touched(
    u: np.ndarray,
    v: np.ndarray,
    first_column: np.ndarray,
    first_row: np.ndarray,
    widths: np.ndarray,
    counts: np.ndarray,
    low: np.ndarray,
    cell: float,
    margin: float,
    columns: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Triangles' pictures (corners u, v (T, 3)) and their rectangles' cells (first column and row, width in
    cells, cell count (T,)) -> (triangle (E,), cell (E,)) for each cell, grown by margin, that its triangle touches:
    a cell and a triangle are apart where one of the triangle's edge normals separates them (the rectangle already
    decides the cells' own axes), so about half of a sliver's rectangle drops out."""
    total = int(counts.sum())
    owner = np.repeat(np.arange(len(counts)), counts)
    within = np.arange(total, dtype=np.float64) - np.repeat(np.cumsum(counts) - counts, counts)
    # row and column within the rectangle by float division (exact for these small integers, and far faster than
    # integer // and % in NumPy)
    row_width = widths.astype(np.float64).take(owner)
    row = np.floor((within + 0.5) / row_width)
    column = within - row * row_width
    del within, row_width
    row += first_row.take(owner)
    column += first_column.take(owner)
    # each edge's normal n (per triangle): the cell of centre c and half side h is apart from the triangle where
    # n.c + h (|n_u| + |n_v|) < min or n.c - h (|n_u| + |n_v|) > max of the corners' n.p; with
    # c = low + (column + 1/2, row + 1/2) cell, n.c = n_u cell column + n_v cell row + n.(low + cell / 2)
    half = cell / 2.0 + margin
    apart = np.zeros(total, dtype=bool)
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        normal_u, normal_v = v[:, a] - v[:, b], u[:, b] - u[:, a]  # the edge a -> b turned a quarter (T,)
        edge = normal_u * u[:, a] + normal_v * v[:, a]  # a and b project here, c elsewhere
        other = normal_u * u[:, c] + normal_v * v[:, c]
        offset = normal_u * (low[0] + cell / 2.0) + normal_v * (low[1] + cell / 2.0)
        radius = half * (np.abs(normal_u) + np.abs(normal_v))
        below = np.minimum(edge, other) - radius - offset  # n.c - n.(low + cell / 2) must reach this
        above = np.maximum(edge, other) + radius - offset
        centre = (normal_u * cell).take(owner) * column
        centre += (normal_v * cell).take(owner) * row
        apart |= (centre < below.take(owner)) | (centre > above.take(owner))
    kept = (~apart).nonzero()[0]
    cells = row.take(kept).astype(np.int64) * columns + column.take(kept).astype(np.int64)
    return owner.take(kept), cells
