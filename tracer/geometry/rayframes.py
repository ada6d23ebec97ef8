"""Rays of several animation frames traced in one query -> which of them belong to each frame.

An animation's frames differ only in where the vane's parts are. Traced together (wavefront.TracedScene with
headings), the still objects see every ray and each frame's copy of a part sees only the rays of its frame: the
hierarchy asks select() for them. A query's rays come in runs (one per light in a shadow query, one otherwise), each
ordered by frame, so a frame's rays are one slice of each run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RayFrames:
    """cuts (R, K + 1): in run r, the rays of frame f are those with cuts[r, f] <= index < cuts[r, f + 1]; the runs
    follow each other (cuts[r + 1, 0] = cuts[r, K])."""

    cuts: np.ndarray

    @classmethod
    def of(cls, samples: np.ndarray, sample_cuts: np.ndarray, start: int = 0) -> RayFrames:
        """One run of rays whose camera samples (n,) ascend, of frames whose samples start at sample_cuts (K + 1,);
        the run's first ray is at index start of the query."""
        cuts = np.searchsorted(samples, sample_cuts)
        return cls((cuts + start if start else cuts)[None])

    @classmethod
    def joined(cls, runs: list[RayFrames]) -> RayFrames:
        """The runs of several queries, one after another as their rays are (each run's cuts already offset)."""
        return cls(runs[0].cuts if len(runs) == 1 else np.concatenate([run.cuts for run in runs]))

    @property
    def sizes(self) -> np.ndarray:
        """How many rays (K,) each frame has in the query."""
        return np.diff(self.cuts, axis=1).sum(axis=0)

    def select(self, frame: int, rays: np.ndarray | None) -> np.ndarray:
        """Of the rays (n,) ascending (None: every ray of the query), the indices of those of frame, ascending."""
        starts, ends = self.cuts[:, frame].tolist(), self.cuts[:, frame + 1].tolist()
        if rays is None:
            if len(starts) == 1:
                return np.arange(starts[0], ends[0])
            return np.concatenate([np.arange(start, end) for start, end in zip(starts, ends, strict=True)])
        if len(starts) == 1:
            first, last = np.searchsorted(rays, (starts[0], ends[0])).tolist()
            return rays[first:last]
        bounds = np.searchsorted(rays, self.cuts[:, frame : frame + 2].ravel()).tolist()
        pieces = [rays[bounds[k] : bounds[k + 1]] for k in range(0, len(bounds), 2)]
        return np.concatenate(pieces)
