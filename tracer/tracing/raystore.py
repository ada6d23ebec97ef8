"""Traced rays -> every segment of every pixel's ray tree (camera and mirror rays up to their hit, with the object hit;
shadow rays over their whole range, with their light): what an editable image keeps so an edit re-traces only the
pixels it touches (edits.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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

    def take(self, keep: np.ndarray) -> Segments:
        """The segments at positions keep (k,)."""
        return Segments(*(array.take(keep, axis=-1) for array in self.columns))

    def joined(self, *others: Segments) -> Segments:
        parts = [self, *others]
        return Segments(*(np.concatenate([part.columns[k] for part in parts], axis=-1) for k in range(7)))

    @property
    def columns(self) -> tuple[np.ndarray, ...]:
        return self.pixel, self.O, self.D, self.start, self.end, self.hit, self.light
