"""A per-frame curve -> the fewest keyframes whose linear interpolation stays within a tolerance of every frame.

For each key i, the slopes of lines from (i, y_i) that stay within +-tolerance of every frame up to j form an
interval (the "sleeve"), narrowed frame by frame; the chord from i to j is allowed when its slope lies inside it,
and once the interval is empty no later j can be reached. A shortest path over the allowed chords gives the
minimum number of keys (first and last frame always kept). Keys are meant for LINEAR interpolation.
"""

from __future__ import annotations

from collections import deque

import numpy as np

DEFAULT_TOLERANCE = 0.05  # degrees


def reduce_keys(values: np.ndarray, tolerance: float = DEFAULT_TOLERANCE) -> np.ndarray:
    """Indices (k,) of the frames to key, fewest possible, for values (n,) sampled once per frame."""
    values = np.asarray(values, dtype=np.float64)
    count = values.size
    if count <= 2:
        return np.arange(count)
    # a margin for the consumer's rounding: Blender keeps F-curve values in float32
    allowed = tolerance - 4.0 * float(np.finfo(np.float32).eps) * float(np.max(np.abs(values)))
    previous = np.full(count, -1, dtype=np.int64)
    reached = np.zeros(count, dtype=bool)
    reached[0] = True
    queue = deque([0])
    while queue and not reached[-1]:
        i = queue.popleft()
        low, high = -np.inf, np.inf
        for j in range(i + 1, count):
            run = j - i
            slope = (values[j] - values[i]) / run
            if low <= slope <= high and not reached[j]:
                reached[j] = True
                previous[j] = i
                queue.append(j)
            low = max(low, (values[j] - allowed - values[i]) / run)
            high = min(high, (values[j] + allowed - values[i]) / run)
            if low > high:
                break
    keys = [count - 1]
    while keys[-1] != 0:
        keys.append(int(previous[keys[-1]]))
    return np.array(keys[::-1], dtype=np.int64)


def interpolate(keys: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """The linear interpolation (count,) through values at the key frames."""
    return np.interp(np.arange(count), keys, np.asarray(values)[keys])
