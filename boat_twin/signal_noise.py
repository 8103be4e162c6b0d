"""The white-noise level of a measured signal, estimated from the signal itself; and the Savitzky-Golay smoother
of a measured signal (:func:`savgol_filter`: scipy.signal's, without importing scipy.signal)."""

from __future__ import annotations

import math

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


def savgol_filter(x: np.ndarray, window_length: int, polyorder: int, deriv: int = 0,
                  delta: float = 1.0) -> np.ndarray:
    """``scipy.signal.savgol_filter(x, window_length, polyorder, deriv, delta, mode="interp")`` of a 1-D ``x``
    (odd ``window_length`` ≤ ``x.size``, ``deriv`` ≤ ``polyorder``), bit for bit: the same least-squares
    coefficients and edge fits (scipy.linalg's ``lstsq``), and the centred correlation summed in the order of
    scipy.ndimage's ``correlate1d``. Here because importing scipy.signal loads scipy.stats with it (0.5 s of CPU,
    a sixth of a 10-minute ``diagnose``; test/test_long_runs.py)."""
    x = np.asarray(x, dtype=np.float64)
    if window_length % 2 == 0 or not 0 <= deriv <= polyorder < window_length <= x.size or x.ndim != 1:
        raise ValueError(f"savgol_filter: window {window_length} (odd, at most {x.size} samples), polyorder "
                         f"{polyorder} (below the window), deriv {deriv} (at most polyorder), of a 1-D array")
    half = window_length // 2
    y = _correlate_centred(x, _savgol_coefficients(window_length, polyorder, deriv, delta)[::-1])
    n = x.size
    y[:half] = _savgol_edge(x[:window_length], 0, half, polyorder, deriv, delta)
    y[n - half:] = _savgol_edge(x[n - window_length:], window_length - half, window_length, polyorder, deriv, delta)
    return y


def _savgol_coefficients(window_length: int, polyorder: int, deriv: int, delta: float) -> np.ndarray:
    """scipy.signal.savgol_coeffs(window_length, polyorder, deriv, delta) (odd window, use="conv")."""
    from scipy.linalg import lstsq

    half = window_length // 2
    t = np.flip(np.arange(-half, window_length - half, dtype=np.float64))
    design = t ** np.arange(polyorder + 1, dtype=np.float64).reshape(-1, 1)
    wanted = np.zeros(polyorder + 1)
    wanted[deriv] = float(math.factorial(deriv)) / (delta**deriv)
    return lstsq(design, wanted, cond=np.finfo(float).eps * max(design.shape))[0]


def _correlate_centred(x: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """scipy.ndimage.correlate1d(x, weights, mode="constant") of an odd ``weights``, its sums in its order: the
    symmetric and antisymmetric (within one ulp of 1) weights pair the samples about the centre first."""
    n, half = x.size, weights.size // 2
    padded = np.concatenate([np.zeros(half), x, np.zeros(half)])

    def at(j: int) -> np.ndarray:  # x[i + j] for every i (0 beyond the ends)
        return padded[half + j:half + j + n]

    eps = np.finfo(float).eps
    for sign in (1.0, -1.0):
        if all(abs(weights[half + k] - sign * weights[half - k]) <= eps for k in range(1, half + 1)):
            out = at(0) * weights[half]
            for j in range(-half, 0):
                out = out + (at(j) + at(-j) if sign > 0 else at(j) - at(-j)) * weights[half + j]
            return out
    out = at(half) * weights[-1]
    for j in range(-half, half):
        out = out + at(j) * weights[half + j]
    return out


def _savgol_edge(edge: np.ndarray, start: int, stop: int, polyorder: int, deriv: int, delta: float) -> np.ndarray:
    """scipy.signal's edge fit of mode="interp": the polynomial fitted to the ``edge`` samples (its scaled
    Vandermonde least squares), differentiated ``deriv`` times, at the edge's samples ``start:stop``."""
    from scipy.linalg import lstsq

    t = np.arange(edge.size, dtype=np.float64)
    design = t[:, None] ** np.flip(np.arange(polyorder + 1, dtype=np.float64))[None, :]
    scale = np.sqrt(np.sum(design * design, axis=0))
    design /= scale
    poly = lstsq(design, edge.reshape(-1, 1), cond=t.size * np.finfo(float).eps)[0]
    poly = (poly.T / scale).T
    if deriv > 0:
        n = poly.shape[0]
        poly = poly[:-deriv].copy()
        for k in range(deriv):
            poly *= np.arange(n - k - 1, deriv - k - 1, -1, dtype=poly.dtype).reshape(-1, 1)
    at = np.arange(start, stop, dtype=poly.dtype).reshape(-1, 1)
    values = np.zeros_like(at)
    for row in poly:
        values = values * at + row
    return (values / (delta**deriv)).reshape(-1)
