"""The diagnosis against the twin's own error (issue 42): the yardstick a recording's misfit is measured with, and
the measurement of a twin's model error on clean recordings of its boat (what ``identify`` writes into twin.yaml).

On a real boat the twin's ordinary error (what a 3-DOF model misses of a real hull, waves, an operator) is many
times the sensors' noise, and a diagnosis judged against the noise alone finds every window misfit. Here every
residual is divided by √(noise² + model error²) at its sample (:func:`yardstick`), so a misfit of 1 means "as good
as the training data", and every rule of :mod:`~boat_twin.diagnose.search` and
:mod:`~boat_twin.diagnose.structure` reads the misfit the twin does not normally have. With a zero model error the
yardstick is the noise: today's rule, unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy.optimize import nnls

from boat_twin.config import TwinConfig
from boat_twin.diagnose.defaults import WINDOW_S
from boat_twin.diagnose.initial_state import Scale
from boat_twin.diagnose.structure import structure_r2
from boat_twin.io.trial import Trial
from boat_twin.model_error import ModelError, SignalError
from boat_twin.twin.replay import SIGNALS, Windows, cut_windows

PASSES = 2
"""Measurements of the error: the first against the noise alone, the next with the error found so far in the
yardstick (the windows' initial-state corrections weigh the residuals by it, as the diagnosis will)."""


def situation(windows: Windows) -> tuple[np.ndarray, np.ndarray]:
    """(T, m) measured speed over ground (m/s) and yaw rate (rad/s) at every window sample, a sample without a
    measurement given its window's mean (0 in a window without any)."""
    out = []
    for values in (windows.trial.speed_mps[windows.index], windows.trial.yaw_rate_radps[windows.index]):
        known = np.isfinite(values)
        counts = known.sum(axis=0)
        mean = np.where(counts > 0, np.where(known, values, 0.0).sum(axis=0) / np.maximum(counts, 1), 0.0)
        out.append(np.where(known, values, mean[None, :]))
    return out[0], out[1]


def yardstick(windows: Windows, sigma: dict[str, float], error: ModelError) -> dict[str, Scale]:
    """Per signal, what its residuals are divided by: the noise level ``sigma`` where the twin has no model
    error (one number, as before issue 42), else √(noise² + error²) at every sample ((T, m))."""
    if error.zero:
        return dict(sigma)
    speed, yaw_rate = situation(windows)
    out: dict[str, Scale] = {}
    for s in SIGNALS:
        described = error.of(s)
        noise = sigma[s] if np.isfinite(sigma[s]) else 0.0
        out[s] = sigma[s] if described.zero else np.sqrt(noise**2 + described.stdev(speed, np.abs(yaw_rate)) ** 2)
    return out


def measure_model_error(trials: Sequence[Trial], twins: Sequence[TwinConfig], heldout: bool,
                        window_s: float = WINDOW_S) -> ModelError:
    """The model error of the twin on clean ``trials``, each replayed by its twin of ``twins`` (``heldout``: one
    identified without that trial). Per signal, the residuals of the diagnosis' replay (each window's
    initial-state correction made) after the noise: the error variance fitted as floor² + (a·speed)² + (b·yaw
    rate)² to the squared residuals less the noise variance (non-negative least squares), its integrated
    autocorrelation time, and the held-out R² of the residual on the boat's situation
    (:func:`~boat_twin.diagnose.structure.structure_r2`)."""
    from boat_twin.diagnose.search import Diagnosis, correlation_time  # search imports this module's yardstick

    error = ModelError()
    for _ in range(PASSES):
        parts: dict[str, list[np.ndarray]] = {s: [] for s in SIGNALS}
        r2: dict[str, list[float]] = {s: [] for s in SIGNALS}
        tau: dict[str, list[float]] = {s: [] for s in SIGNALS}
        for trial, twin in zip(trials, twins, strict=True):
            windows = cut_windows(trial, window_s)
            diagnosis = Diagnosis(windows, replace(twin, model_error=error))
            fit = diagnosis.fit([])
            speed, yaw_rate = situation(windows)
            found = structure_r2(windows, fit.residuals.values, fit.residuals.prediction, diagnosis.structure_folds,
                                 buffered=not error.zero)
            for s in SIGNALS:
                scaled = fit.residuals.values[s]
                si = scaled * diagnosis.scale[s]
                noise = diagnosis.sigma[s] if np.isfinite(diagnosis.sigma[s]) else 0.0
                keep = np.isfinite(si)
                parts[s].append(np.stack([si[keep] ** 2 - noise**2, speed[keep] ** 2, yaw_rate[keep] ** 2]))
                r2[s].append(found[s])
                tau[s].append(correlation_time(scaled) * windows.dt_s)
        error = ModelError(tuple((s, _signal_error(np.concatenate(parts[s], axis=1), float(np.mean(tau[s])),
                                                   float(np.mean(r2[s])))) for s in SIGNALS),
                           len(trials), heldout)
    return error


def _signal_error(samples: np.ndarray, correlation_time_s: float, r2: float) -> SignalError:
    """The spread's coefficients from (3, n) samples (squared residual − noise variance, speed², yaw rate²)."""
    if samples.shape[1] < 3:
        return SignalError()
    target, speed2, rate2 = samples
    design = np.stack([np.ones_like(target), speed2, rate2], axis=1)
    scale = np.maximum(np.sqrt(np.mean(design**2, axis=0)), 1e-12)
    coef, _ = nnls(design / scale, target)
    floor, per_speed, per_rate = np.sqrt(coef / scale)
    return SignalError(floor=float(floor), per_speed=float(per_speed), per_yaw_rate=float(per_rate),
                       correlation_time_s=correlation_time_s,
                       structure_r2=float(np.clip(r2, 0.0, 1.0)) if np.isfinite(r2) else 0.0)


NORMAL_Z = 3.0
"""How many standard errors above the twin's normal misfit a recording's misfit must lie before a cause may be
named for it (:func:`normal_misfit`)."""


def normal_misfit(windows: Windows, error: ModelError) -> np.ndarray:
    """(n_signals,) per signal of the replay, the largest mean squared residual over the yardstick (m²) that is
    still the twin's normal misfit on these windows: 1 + :data:`NORMAL_Z`·√(2τ/D), with τ the model error's
    correlation time and D the signal's measured time in the windows (the chance spread of a mean square of
    residuals correlated over τ). A signal without model error: 1, and the condition it sets is void (the
    sensors' white noise is known exactly: today's rule)."""
    out = np.ones(len(SIGNALS))
    for i, s in enumerate(SIGNALS):
        tau_s = error.of(s).correlation_time_s
        duration_s = float(np.sum(np.isfinite(windows.measured[s]))) * windows.dt_s
        if tau_s > 0.0 and duration_s > 0.0 and not error.of(s).zero:
            out[i] = 1.0 + NORMAL_Z * np.sqrt(2.0 * tau_s / duration_s)
    return out


def structure_folds(dealt: np.ndarray, error: ModelError) -> np.ndarray:
    """(m,) the folds of the structure test's held-out regression (:mod:`~boat_twin.diagnose.structure`): the
    diagnosis' ``dealt`` folds (window k → fold k mod FOLDS) where the twin has no model error, else the same number
    of folds, each one stretch of consecutive windows.

    Dealt windows are independent where the residual is the sensors' white noise: each window starts afresh from
    the measurements. The twin's own error is not: it follows the manoeuvre, and a manoeuvre (a command hold of
    8-25 s on the real-like boat) continues across a window's boundary, so a window's neighbours, in other dealt
    folds, hold the same error on the same heading and speed and "predict" it held out. Issue 42: a clean recording
    whose twin turned 0.01 rad/s too fast on a 40 s run north at 5-9 m/s (t 40-80 s, one command hold, two
    windows) left the east velocity a held-out R² of 0.28 on the heading × time with dealt folds (0.03 with
    stretches), the twin's normal error read as structure. A stretch shares a boundary with the
    others only at its ends; a cause outside the catalogue acts in every stretch (a gyro reading 1.1×: the yaw
    rate's R² 0.44-0.49 with stretches, 0.30-0.54 dealt). With a zero model error: the dealt folds, today's rule."""
    if error.zero or dealt.size == 0:
        return dealt
    m = dealt.size
    return np.arange(m) * len(np.unique(dealt)) // m
