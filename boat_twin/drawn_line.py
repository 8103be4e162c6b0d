"""The points an hours-long line is drawn with: an evenly spaced subset that keeps its ends and breaks (216,000
samples in 6 h at 10 Hz are several points a pixel on any figure; the legend's placement search and the renderer
otherwise hold every vertex several times over)."""

from __future__ import annotations

import numpy as np

DRAWN_POINTS = 20_000
"""Most points a line is drawn with."""


def drawn(points: np.ndarray, limit: int = DRAWN_POINTS) -> np.ndarray:
    """``points`` (n, k) as drawn: every j-th row (j the least that leaves at most about ``limit``), the last one,
    and every break (a row with a NaN) with the rows on either side of it, so that no gap is bridged."""
    n = points.shape[0]
    if n <= limit:
        return points
    keep = np.zeros(n, dtype=bool)
    keep[:: -(-n // limit)] = True
    keep[-1] = True
    breaks = np.flatnonzero(~np.all(np.isfinite(points), axis=1))
    for shift in (-1, 0, 1):
        keep[np.clip(breaks + shift, 0, n - 1)] = True
    return points[keep]


def drawn_series(t_s: np.ndarray, *values: np.ndarray, limit: int = DRAWN_POINTS) -> tuple[np.ndarray, ...]:
    """Time series sharing ``t_s`` as drawn (:func:`drawn` of their columns): (t, values...)."""
    rows = drawn(np.column_stack([t_s, *values]), limit)
    return tuple(rows[:, k] for k in range(rows.shape[1]))
