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

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TypedDict

import numpy as np

from boat_twin.diagnose.defaults import PART_WINDOWS
from boat_twin.twin.replay import SIGNALS, Prediction, Windows

REGRESSOR_NAMES = ("cos_heading", "sin_heading", "speed", "yaw_rate", "thrust_sum", "thrust_difference",
                   "steering")
"""What the residual may depend on: the commands and the model's prediction."""
NAMES = REGRESSOR_NAMES + tuple(f"{n}*time" for n in REGRESSOR_NAMES)
"""The regressors' names (:func:`regressors`): the situation, then the situation × time into the window."""
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


def regressors(windows: Windows, prediction: Prediction) -> np.ndarray:
    """(T, m, k) regressors (:data:`NAMES` and a constant): the situation, and the situation × time into the
    window.

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
    return np.concatenate([base, base * elapsed, np.ones(base.shape[:2] + (1,))], axis=-1)


def _solve(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """The ridge solution of normal equations xᵀx·w = xᵀy given as ``gram`` and ``rhs``."""
    return np.linalg.solve(gram + RIDGE * np.trace(gram) / gram.shape[0] * np.eye(gram.shape[0]), rhs)


def _parts(windows: Windows, prediction: Prediction) -> Iterator[tuple[slice, np.ndarray]]:
    """(window columns, their (T, c, k) regressors) for :data:`PART_WINDOWS` windows at a time."""
    for first in range(0, windows.start_index.size, PART_WINDOWS):
        columns = slice(first, first + PART_WINDOWS)
        part = Prediction({s: v[:, columns] for s, v in prediction.signals.items()}, prediction.position[:, columns])
        yield columns, regressors(windows.part(columns), part)


def misfit(residuals: dict[str, np.ndarray]) -> dict[str, float]:
    """Per signal, the RMS of the normalized residuals: 1 when only the measured noise is left."""
    return {s: float(np.sqrt(np.nanmean(residuals[s] ** 2))) for s in SIGNALS if np.isfinite(residuals[s]).any()}


def _heldout_r2(windows: Windows, prediction: Prediction, r: np.ndarray, folds: np.ndarray, buffered: bool = False
                ) -> tuple[float, np.ndarray, np.ndarray] | None:
    """Held-out R² of the residual ``r`` (T, m) on the standardized regressors of ``prediction``, and the normal
    equations (xᵀx, xᵀr) of all its samples; None where ``r`` has no sample (a sensor the trial has not). A fold
    without training samples (the accelerometer, past its horizon in every other fold) predicts nothing: no
    evidence. With ``buffered`` (folds that are stretches of consecutive windows) a held-out stretch's
    neighbouring windows are left out of its training too (h-block cross-validation, Burman, Chow & Nolan 1994:
    a serially correlated error must not reach across the stretch's boundary). The regressors are formed part by
    part (:func:`_parts`) and summed into each window's normal equations, never held for the whole trial."""
    def samples() -> Iterator[tuple[slice, np.ndarray, np.ndarray]]:
        for columns, x in _parts(windows, prediction):
            yield columns, x, np.isfinite(r[:, columns]) & np.all(np.isfinite(x), axis=-1)

    count = sum(int(ok.sum()) for _, _, ok in samples())
    if count == 0:
        return None
    mean = sum(x[ok].sum(axis=0) for _, x, ok in samples()) / count
    std = np.sqrt(sum(((x[ok] - mean) ** 2).sum(axis=0) for _, x, ok in samples()) / count)
    std[std == 0] = 1.0
    std[-1], mean[-1] = 1.0, 0.0
    m, k = folds.size, mean.size
    gram, rhs, has = np.zeros((m, k, k)), np.zeros((m, k)), np.zeros(m, dtype=bool)
    for columns, x, ok in samples():
        x = np.where(ok[..., None], (x - mean) / std, 0.0)
        gram[columns] = np.einsum("tci,tcj->cij", x, x)
        rhs[columns] = np.einsum("tci,tc->ci", x, np.where(ok, r[:, columns], 0.0))
        has[columns] = ok.any(axis=0)
    labels = np.unique(folds)
    weights = []
    for label in labels:
        train = folds != label
        if buffered:
            held = ~train
            train &= ~(np.concatenate([[False], held[:-1]]) | np.concatenate([held[1:], [False]]))
        weights.append(_solve(gram[train].sum(axis=0), rhs[train].sum(axis=0)) if np.any(has & train) else None)
    held, error = [], []
    for columns, x, ok in samples():
        x = (x - mean) / std
        for label, w in zip(labels, weights, strict=True):
            if w is not None:
                use = ok & (folds[columns] == label)[None, :]
                held.append(r[:, columns][use])
                error.append(held[-1] - x[use] @ w)
    observed = np.concatenate(held) if held else np.zeros(0)
    r2 = (1.0 - np.sum(np.concatenate(error) ** 2) / np.sum((observed - observed.mean()) ** 2)
          if observed.size > 1 else 0.0)
    return float(r2), gram.sum(axis=0), rhs.sum(axis=0)


def structure_r2(windows: Windows, residuals: dict[str, np.ndarray], prediction: Prediction,
                 folds: np.ndarray, buffered: bool = False) -> dict[str, float]:
    """Per signal, the held-out R² of its residual on the situation (what :func:`residual_structure` tests; 0
    for a signal the windows do not measure; ``buffered``: :func:`_heldout_r2`'s)."""
    held = {s: _heldout_r2(windows, prediction, residuals[s], folds, buffered) for s in SIGNALS}
    return {s: 0.0 if h is None else h[0] for s, h in held.items()}


def residual_structure(windows: Windows, residuals: dict[str, np.ndarray], prediction: Prediction,
                       folds: np.ndarray, normal_r2: dict[str, float] | None = None, buffered: bool = False
                       ) -> list[Signature]:
    """Signals left unexplained: the situation predicts their residual on held-out folds (held-out R² above
    R2_THRESHOLD plus ``normal_r2``, the R² the twin's residual shows on its clean training recordings: the
    structure it normally leaves, none by default), or their residual stays above MISFIT_FACTOR times the noise
    floor (with the twin's model error where it has one: :mod:`~boat_twin.diagnose.model_error`). ``buffered``:
    the folds are stretches whose neighbours are left out of their training (:func:`_heldout_r2`)."""
    ratio = misfit(residuals)
    normal_r2 = normal_r2 or {}
    found = []
    for signal in SIGNALS:
        r = residuals[signal]
        held = _heldout_r2(windows, prediction, r, folds, buffered)
        if held is None:  # a sensor the trial has not (an IMU without its accelerometer)
            continue
        r2, gram, rhs = held
        if r2 > R2_THRESHOLD + normal_r2.get(signal, 0.0) or ratio[signal] > MISFIT_FACTOR:
            weights = _solve(gram, rhs)[:-1]
            order = np.argsort(-np.abs(weights))[:3]
            compared = np.sum(np.isfinite(r), axis=0)  # a window may compare none (the accelerometer)
            worst = int(np.argmax(np.nansum(r**2, axis=0) / np.maximum(compared, 1)))
            middle = float(windows.t_s[windows.t_s.shape[0] // 2, worst])
            found.append(Signature(signal, ratio[signal], float(r2), tuple(NAMES[i] for i in order), middle))
    return found
