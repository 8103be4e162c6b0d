"""The white-noise level of a measured signal, estimated from the signal itself."""

from __future__ import annotations

import numpy as np

MAD_TO_SIGMA = 1.4826
"""Standard deviation of a normal variable per median absolute deviation, -."""
MIN_DIFFERENCES = 10
"""Fewer finite second differences than this give no estimate (NaN)."""


def white_noise_stdev(values: np.ndarray) -> float:
    """σ of white noise on a smooth signal sampled along axis 0, in the signal's unit.

    For x_k = s_k + e_k with smooth s, Δ²x ≈ e_{k+1} − 2e_k + e_{k−1} has variance 6σ²; the median absolute
    deviation (× :data:`MAD_TO_SIGMA`) makes steps, manoeuvres and outliers count little.
    """
    d2 = np.diff(np.asarray(values, dtype=float), n=2, axis=0)
    d2 = d2[np.isfinite(d2)]
    if d2.size < MIN_DIFFERENCES:
        return float("nan")
    return float(MAD_TO_SIGMA * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))
