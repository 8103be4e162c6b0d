"""Is anything left in the residuals? Their size against the noise floor, and a held-out regression of each
signal's residual on what the boat did.

A model far off its data is never an all-clear: a signal whose residual RMS stays above
:data:`MISFIT_FACTOR` times its measured noise after the named effects is unexplained, whatever was named.

After the best extensions, a residual that is only noise (and the replay's own small initialization error)
cannot be predicted from the boat's situation. A residual that an unmodelled effect leaves — a wind that
depends on heading, a drag that depends on speed — can. Each signal's normalized residual is regressed on
:data:`REGRESSOR_NAMES`, each also multiplied by the time since the window's start (an unmodelled force
makes the error grow through the window), with the diagnosis' leave-one-fold-out folds (against a twin's model
error, each fold one stretch of consecutive windows:
:func:`~boat_twin.diagnose.model_error.structure_folds`); the held-out R² above :data:`R2_THRESHOLD` marks
structure. The signature names the signal, the regressors that
carry it and the time where the residual is largest.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict

import numpy as np

from boat_twin.twin.replay import SIGNALS, Prediction, Windows

REGRESSOR_NAMES = ("cos_heading", "sin_heading", "speed", "yaw_rate", "thrust_sum", "thrust_difference",
                   "steering")
"""What the residual may depend on: the commands and the model's prediction."""
R2_THRESHOLD = 0.15
"""Held-out R² of a residual above this: structure the model does not explain (set above what clean trials
of every kind give in the accuracy study, docs/diagnosis.md)."""
MISFIT_FACTOR = 2.0
"""A signal whose residual RMS, after the named effects, stays above this many times its measured noise floor is
unexplained, whatever was named: on clean simulated trials (thrust steps, zigzag, random) the ratio is 0.97-1.3
(the replay's initialization error adds to the noise); a 7 m/s wind diagnosed without the catalogue's ``wind``
leaves 7-11."""
RIDGE = 1e-3
"""Ridge regularization relative to the regressors' scale (they are standardized)."""


class SignatureResult(TypedDict):
    """An unexplained signal in the ``--json`` report (:meth:`Signature.to_dict`)."""

    signal: str
    misfit: float
    """Residual RMS over the measured noise floor."""
    heldout_r2: float
    correlated_with: list[str]
    worst_time_s: float


@dataclass(frozen=True)
class Signature:
    """Structure left in one signal's residual."""

    signal: str
    misfit: float
    """Residual RMS over the measured noise floor (white-noise stdev) of this signal, after the named effects."""
    heldout_r2: float
    correlated_with: tuple[str, ...]
    """The regressors with the largest standardized weights, strongest first."""
    worst_time_s: float
    """Trial time of the middle of the window where the residual is largest, s."""

    def to_dict(self) -> SignatureResult:
        """Plain data for the JSON report."""
        return {"signal": self.signal, "misfit": self.misfit, "heldout_r2": self.heldout_r2,
                "correlated_with": list(self.correlated_with), "worst_time_s": self.worst_time_s}


def regressors(windows: Windows, prediction: Prediction) -> tuple[np.ndarray, tuple[str, ...]]:
    """(T, m, k) regressors and their names: the situation, and the situation × time into the window.

    The situation is what the boat was commanded and what the model predicts it did — never a measured
    signal, whose noise is part of the residual it would be regressed against.
    """
    cmd = windows.commands
    predicted = prediction.signals
    heading = predicted["heading_rad"]
    speed = np.hypot(predicted["vel_east_mps"], predicted["vel_north_mps"])
    base = np.stack([np.cos(heading), np.sin(heading), speed, predicted["yaw_rate_radps"],
                     cmd[..., 0] + cmd[..., 1], cmd[..., 0] - cmd[..., 1], 0.5 * (cmd[..., 2] + cmd[..., 3])],
                    axis=-1)
    elapsed = (windows.t_s - windows.t_s[0])[..., None]
    names = REGRESSOR_NAMES + tuple(f"{n}*time" for n in REGRESSOR_NAMES)
    return np.concatenate([base, base * elapsed, np.ones(base.shape[:2] + (1,))], axis=-1), names


def _solve(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    gram = x.T @ x
    return np.linalg.solve(gram + RIDGE * np.trace(gram) / gram.shape[0] * np.eye(gram.shape[0]), x.T @ y)


def misfit(residuals: dict[str, np.ndarray]) -> dict[str, float]:
    """Per signal, the RMS of the normalized residuals: 1 when only the measured noise is left."""
    return {s: float(np.sqrt(np.nanmean(residuals[s] ** 2))) for s in SIGNALS if np.isfinite(residuals[s]).any()}


def _heldout_r2(x_all: np.ndarray, r: np.ndarray, folds: np.ndarray
                ) -> tuple[float, np.ndarray, np.ndarray] | None:
    """Held-out R² of the residual ``r`` (T, m) on the regressors ``x_all`` (T, m, k), the standardized
    regressors and the samples used; None where ``r`` has no sample (a sensor the trial has not). A fold without
    training samples (the accelerometer, past its horizon in every other fold) predicts nothing: no evidence."""
    ok = np.isfinite(r) & np.all(np.isfinite(x_all), axis=-1)
    if not ok.any():
        return None
    mean, std = x_all[ok].mean(axis=0), x_all[ok].std(axis=0)
    std[std == 0] = 1.0
    std[-1], mean[-1] = 1.0, 0.0
    x = (x_all - mean) / std
    predicted = np.full(r.shape, np.nan)
    for k in np.unique(folds):
        train = ok & (folds != k)[None, :]
        test = ok & (folds == k)[None, :]
        if train.any():
            predicted[test] = x[test] @ _solve(x[train], r[train])
    held = ok & np.isfinite(predicted)
    r2 = (1.0 - np.sum((r - predicted)[held] ** 2) / np.sum((r[held] - r[held].mean()) ** 2)
          if held.sum() > 1 else 0.0)
    return float(r2), x, ok


def structure_r2(windows: Windows, residuals: dict[str, np.ndarray], prediction: Prediction,
                 folds: np.ndarray) -> dict[str, float]:
    """Per signal, the held-out R² of its residual on the situation (what :func:`residual_structure` tests; 0
    for a signal the windows do not measure)."""
    x_all, _ = regressors(windows, prediction)
    held = {s: _heldout_r2(x_all, residuals[s], folds) for s in SIGNALS}
    return {s: 0.0 if h is None else h[0] for s, h in held.items()}


def residual_structure(windows: Windows, residuals: dict[str, np.ndarray], prediction: Prediction,
                       folds: np.ndarray, normal_r2: dict[str, float] | None = None) -> list[Signature]:
    """Signals left unexplained: the situation predicts their residual on held-out folds (held-out R² above
    R2_THRESHOLD plus ``normal_r2``, the R² the twin's residual shows on its clean training recordings: the
    structure it normally leaves, none by default), or their residual stays above MISFIT_FACTOR times the noise
    floor (with the twin's model error where it has one: :mod:`~boat_twin.diagnose.model_error`)."""
    ratio = misfit(residuals)
    x_all, names = regressors(windows, prediction)
    normal_r2 = normal_r2 or {}
    found = []
    for signal in SIGNALS:
        r = residuals[signal]
        held = _heldout_r2(x_all, r, folds)
        if held is None:  # a sensor the trial has not (an IMU without its accelerometer)
            continue
        r2, x, ok = held
        if r2 > R2_THRESHOLD + normal_r2.get(signal, 0.0) or ratio[signal] > MISFIT_FACTOR:
            weights = _solve(x[ok], r[ok])[:-1]
            order = np.argsort(-np.abs(weights))[:3]
            compared = np.sum(np.isfinite(r), axis=0)  # a window may compare none (the accelerometer)
            worst = int(np.argmax(np.nansum(r**2, axis=0) / np.maximum(compared, 1)))
            middle = float(windows.t_s[windows.t_s.shape[0] // 2, worst])
            found.append(Signature(signal, ratio[signal], float(r2), tuple(names[i] for i in order), middle))
    return found
