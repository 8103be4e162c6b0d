"""Each replay window's initial state as a nuisance estimated with its prior: what the sensors cannot pin down.

A window starts from the state the sensors give (:func:`~boat_twin.twin.replay.initial_states`): heading
within ±0.3° (the smoothed IMU yaw), surge within ±0.02 m/s (±1 s of GNSS velocity), sway from the sway observer,
yaw rate from the gyro. Those errors are zero-mean but they last through the window (the surge's time constant is
tens of seconds; a heading error rotates the whole path: 0.3° at 8 m/s is 0.04 m/s sideways) and, seen from the
residuals, they are structure: a sideways velocity that steps from window to window, a yaw rate that drifts with
the speed. Read as the model's fault, they made clean trials ``unexplained`` (issue 23: 6 of 6 clean zigzags,
5 of 5 straight thrust-step runs).

So every window's initial heading, surge, sway and yaw rate get a correction δ estimated from the window itself,
held to the sensors' word by a Gaussian prior of standard deviations σ (:func:`prior_stdev`), as the turning
identification does with its window nuisances (:mod:`boat_twin.ident.manoeuvring`). For normalized residuals r
of a window with sensitivity S (∂r/∂δ, by finite differences of one replay of the base model), the best
correction δ* = (SᵀS + Λ)⁻¹·Sᵀ·r, Λ = diag(1/σ²), leaves r − S·δ* and the prior's own residuals δ*/σ: together
their sum of squares is the minimum over δ of |r − S·δ|² + |δ/σ|² (a linearized variable projection). The
sensitivity is computed once, for the base model, and used for every model the diagnosis tries: the
corrections are small (σ), so the linearization holds for any model near the data, and one projection for
every candidate keeps their sums of squares comparable.
"""

from __future__ import annotations

import math

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.twin.replay import (
    HEADING_SMOOTHING_S,
    SIGNALS,
    SURGE_SMOOTHING_S,
    Windows,
    predict_vessels,
    residual,
)

NUISANCES = (("heading_rad", 2, 0.005), ("surge_mps", 3, 0.02), ("sway_mps", 4, 0.02), ("yaw_rate_radps", 5, 0.002))
"""(name, state index, finite-difference step) of every initial-state component a window estimates for itself."""
PRIOR_WIDENING = 2.0
"""Each prior standard deviation is this many times what the sensors' white noise alone leaves after the
replay's smoothing (:func:`prior_stdev`): the GNSS velocity's and the IMU heading's errors are also correlated,
which the white-noise figure leaves out (the turning identification's ``NUISANCE_PRIOR_WIDENING``)."""


def prior_stdev(windows: Windows, sigma: dict[str, float]) -> np.ndarray:
    """(q,) prior standard deviation of :data:`NUISANCES` from the signals' white-noise levels ``sigma``.

    Heading, rad: the IMU heading noise averaged over the 2h + 1 samples of ±HEADING_SMOOTHING_S. Surge, m/s: the
    GNSS velocity noise through the centre value of a local quadratic over the 2h + 1 samples of
    ±SURGE_SMOOTHING_S (variance factor 3(3h² + 3h − 1) / ((2h − 1)(2h + 1)(2h + 3))). Sway, m/s: as the surge
    (the sway observer is driven by that surge and the gyro; a sway read from GNSS would be worse). Yaw rate,
    rad/s: the gyro noise over the 3-sample mean. Each × :data:`PRIOR_WIDENING`.
    """
    dt = windows.dt_s
    h_heading = max(1, int(round(HEADING_SMOOTHING_S / dt)))
    h = max(2, int(round(SURGE_SMOOTHING_S / dt)))
    quadratic = 3.0 * (3 * h * h + 3 * h - 1) / ((2 * h - 1) * (2 * h + 1) * (2 * h + 3))
    velocity = 0.5 * (sigma["vel_east_mps"] + sigma["vel_north_mps"]) * math.sqrt(quadratic)
    heading = sigma["heading_rad"] / math.sqrt(2 * h_heading + 1)
    yaw_rate = sigma["yaw_rate_radps"] / math.sqrt(3.0)
    return PRIOR_WIDENING * np.array([heading, velocity, velocity, yaw_rate])


class InitialStateProjection:
    """Removes each window's best initial-state correction from normalized residuals (module docstring)."""

    def __init__(self, sensitivity: np.ndarray, stdev: np.ndarray) -> None:
        self.sensitivity = sensitivity
        """(rows, m, q) ∂ normalized residual / ∂ nuisance per window (rows: signals × samples, NaN as 0)."""
        self.stdev = stdev
        """(q,) prior standard deviations of the nuisances (:data:`NUISANCES`' units)."""
        normal = np.einsum("rmi,rmj->mij", sensitivity, sensitivity) + np.diag(stdev**-2.0)
        self.inverse = np.linalg.inv(normal)

    @classmethod
    def for_model(cls, windows: Windows, config: TwinConfig, sigma: dict[str, float]) -> InitialStateProjection:
        """The projection linearized at ``config`` (one replay with every nuisance stepped in turn), residuals
        normalized by ``sigma``."""
        q = len(NUISANCES)
        m = windows.start_index.size
        shift = np.zeros((q + 1, m, 6))
        for j, (_, state, step) in enumerate(NUISANCES):
            shift[j + 1, :, state] = step
        with np.errstate(all="ignore"):
            predictions = predict_vessels(windows, config, [config.vessel] * (q + 1), initial_shift=shift)
        stacked = [stack_signals(windows, p.signals, sigma) for p in predictions]
        base = stacked[0]
        columns = [np.where(np.isfinite(base) & np.isfinite(r), (r - base) / step, 0.0)
                   for r, (_, _, step) in zip(stacked[1:], NUISANCES, strict=True)]
        return cls(np.stack(columns, axis=-1), prior_stdev(windows, sigma))

    def corrections(self, residuals: np.ndarray) -> np.ndarray:
        """(m, q) each window's best correction δ* of its initial state for ``residuals`` (rows, m), NaN as 0."""
        r = np.where(np.isfinite(residuals), residuals, 0.0)
        return np.einsum("mij,mj->mi", self.inverse, np.einsum("rmj,rm->mj", self.sensitivity, r))

    def apply(self, residuals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, m) ``residuals`` with each window's best correction removed (NaN kept NaN), and (q, m) the
        corrections over their prior standard deviations (the prior's residuals)."""
        step = self.corrections(residuals)
        corrected = residuals - np.einsum("rmi,mi->rm", self.sensitivity, step)
        return corrected, (step / self.stdev).T


def stack_signals(windows: Windows, predicted: dict[str, np.ndarray], sigma: dict[str, float]) -> np.ndarray:
    """(len(SIGNALS)·T, m) normalized residuals measured − ``predicted`` of every signal, stacked."""
    return np.concatenate([residual(s, windows.measured[s], predicted[s]) / _scale(sigma[s]) for s in SIGNALS])


def _scale(sigma: float) -> float:
    return sigma if np.isfinite(sigma) and sigma > 0 else 1.0
