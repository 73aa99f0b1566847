"""Reference for :func:`armlab.trajectory.sampling.sample_times`: the straightforward form it
had before issue 26 (np.unique of the fixed times, their neighbours of each regular sample by
two clipped gathers, one sort of the union). The package's version merges and searches with
fewer numpy calls; both must give the same times, bit for bit."""

from __future__ import annotations

import numpy as np

MERGE_FRACTION = 1e-2


def sample_times(duration: float, dt: float, knots=()) -> np.ndarray:
    duration, dt = float(duration), float(dt)
    if duration <= 0:
        return np.zeros(1)
    n = int(np.floor(duration / dt + 1e-9))
    grid = dt * np.arange(n + 1)
    k = np.asarray(knots, dtype=float).reshape(-1)
    tiny = 8 * np.finfo(float).eps * duration
    fixed = np.unique(np.append(k[(k > tiny) & (k < duration - tiny)], duration))
    fixed = fixed[np.append(np.diff(fixed) > tiny, True)]
    i = np.searchsorted(fixed, grid)
    left = fixed[np.clip(i - 1, 0, fixed.size - 1)]
    right = fixed[np.clip(i, 0, fixed.size - 1)]
    near = np.minimum(np.abs(grid - left), np.abs(right - grid)) < MERGE_FRACTION * dt
    near[0] = False
    out = np.concatenate((grid[~near], fixed))
    out.sort()
    return out
