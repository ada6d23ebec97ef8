"""Ray bookkeeping the tracer's stages share -> how many rays of each kind were traced, where each kind of ray starts
(the listings' t_min), and a bounce's colours added into its pixels."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..geometry.rayframes import RayFrames

CAMERA_T_MIN = 0.0  # seed 2.10: t >= 0
SHADOW_T_MIN = 0.001  # listing 3.2
REFLECTION_T_MIN = 0.01  # listing 3.1


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


def tally(counts: RayCounts | list[RayCounts], kind: str, rays: int, frames: RayFrames | None) -> None:
    """Add rays of a kind ("camera", "shadow", "reflection") to counts, or with frames each frame's rays to its
    own counts (a list)."""
    if frames is None:
        setattr(counts, kind, getattr(counts, kind) + rays)
        return
    for frame_counts, size in zip(counts, frames.sizes.tolist(), strict=True):
        setattr(frame_counts, kind, getattr(frame_counts, kind) + size)


def accumulate(color: np.ndarray, pixel: np.ndarray, value: np.ndarray, fresh: bool) -> None:
    """color[:, pixel] += value for unique pixel indices, a row at a time (several times faster than fancy `+=`).

    fresh: the pixels still hold their initial zeros (the camera rays' bounce), so the value is stored as it is."""
    for row, add in zip(color, value, strict=True):
        row[pixel] = add if fresh else row.take(pixel) + add
