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

The linearization is the window's own test of whether its replay can be judged at all: where the model is
unstable (a straight course astern), an initial error the prior allows grows until the response is no longer
linear in it, and from there no correction stands for it. Each window is compared only up to that
predictability horizon (:func:`predictable`), and the report says what share of the trial was compared.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.twin.replay import (
    HEADING_SMOOTHING_S,
    LONGITUDINAL_ACCEL,
    MOTION_SIGNALS,
    SETTLING_S,
    SIGNALS,
    SURGE_SMOOTHING_S,
    Windows,
    measured_motion,
    predict_vessels,
    residual,
)

Scale = float | np.ndarray
"""A signal's yardstick: one level, or one per sample of the windows ((T, m))."""
NUISANCES = (("heading_rad", 2, 0.005), ("surge_mps", 3, 0.02), ("sway_mps", 4, 0.02), ("yaw_rate_radps", 5, 0.002))
"""(name, state index, finite-difference step) of every initial-state component a window estimates for itself."""
NONLINEAR_LIMIT = 1.0
"""A window's replay is compared up to the first sample where its response to a nuisance of ± its prior
standard deviation departs from linear by more than this many noise levels (:func:`predictable`)."""
PROJECTION_WINDOWS = 100
"""Windows the projection's replays run at a time (:meth:`InitialStateProjection.for_model`): 100 windows × 13
replays of 200 samples hold about 30 MB of paths, whatever the trial's length."""
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

    def __init__(self, sensitivity: np.ndarray, stdev: np.ndarray, compared: np.ndarray | None = None) -> None:
        self.compared = (np.ones(sensitivity.shape[:2], dtype=bool) if compared is None
                         else np.tile(compared, (sensitivity.shape[0] // compared.shape[0], 1)))
        """(rows, m) the samples within each window's predictability horizon (:func:`predictable`)."""
        sensitivity[~self.compared] = 0.0
        self.sensitivity = sensitivity
        """(rows, m, q) ∂ normalized residual / ∂ nuisance per window (rows: signals × samples, NaN and the samples
        past the horizon as 0: set so in the array given)."""
        self.stdev = stdev
        """(q,) prior standard deviations of the nuisances (:data:`NUISANCES`' units)."""
        normal = np.einsum("rmi,rmj->mij", self.sensitivity, self.sensitivity) + np.diag(stdev**-2.0)
        self.inverse = np.linalg.inv(normal)

    @classmethod
    def for_model(cls, windows: Windows, config: TwinConfig, sigma: dict[str, float],
                  scale: dict[str, Scale] | None = None) -> InitialStateProjection:
        """The projection linearized at ``config`` (one replay with every nuisance stepped in turn), residuals
        normalized by ``scale`` (default ``sigma``: the diagnosis' yardstick, the sensors' noise with the twin's
        model error), the priors from the sensors' noise ``sigma``, each window compared up to its predictability
        horizon (the same replay has every nuisance also ± its prior standard deviation). Replayed
        :data:`PROJECTION_WINDOWS` windows at a time (each window's numbers are its own): the 3q + 1 replays of a
        whole 6-hour trial at once took the process from 250 MB to 1.2 GB."""
        q = len(NUISANCES)
        stdev = prior_stdev(windows, sigma)
        scale = scale or dict(sigma)
        motion = measured_motion(windows, config)
        least = int(round(SETTLING_S / windows.dt_s)) + 1  # the settling second and one compared sample
        m = windows.start_index.size
        sensitivity = np.empty((len(SIGNALS) * windows.t_s.shape[0], m, q))
        rows = np.empty(sensitivity.shape[:2], dtype=bool)
        for first in range(0, m, PROJECTION_WINDOWS):
            columns = slice(first, first + PROJECTION_WINDOWS)
            part = windows.part(columns)
            shift = np.zeros((3 * q + 1, part.start_index.size, 6))
            for j, (_, state, step) in enumerate(NUISANCES):
                shift[j + 1, :, state] = step
                shift[q + 1 + j, :, state] = stdev[j]
                shift[2 * q + 1 + j, :, state] = -stdev[j]
            with np.errstate(all="ignore"):
                predictions = predict_vessels(part, config, [config.vessel] * (3 * q + 1), motion, shift)
            part_scale = {s: v[:, first:first + PROJECTION_WINDOWS] if isinstance(v, np.ndarray) else v
                          for s, v in scale.items()}
            stacked = [stack_signals(part, p.signals, part_scale) for p in predictions]
            base = stacked[0]
            for j, (r, (_, _, step)) in enumerate(zip(stacked[1:q + 1], NUISANCES, strict=True)):
                sensitivity[:, columns, j] = np.where(np.isfinite(base) & np.isfinite(r), (r - base) / step, 0.0)
            plus, minus = stacked[q + 1:2 * q + 1], stacked[2 * q + 1:]
            compared = predictable(base, plus, minus, least)
            # the accelerometer (0.04 m/s² noise) departs from linear a second or more before the path does, and
            # its residual is taken less the window's mean: it is compared only in the windows every signal can be
            # predicted through (all of them on a course the model holds stably; none on a straight run astern)
            whole = np.all(compared & predictable(base, plus, minus, judged=(LONGITUDINAL_ACCEL,)), axis=0)
            accel = compared & whole[None, :]
            rows[:, columns] = np.concatenate([accel if s == LONGITUDINAL_ACCEL else compared for s in SIGNALS])
        return cls(sensitivity, stdev, rows)

    def compared_fraction(self) -> float:
        """The share of the windows' samples within their predictability horizons (1: every one compared), as
        the motion signals are compared (the first signal's rows)."""
        return float(np.mean(self.compared[:self.compared.shape[0] // len(SIGNALS)]))

    def corrections(self, residuals: np.ndarray, columns: slice = slice(None)) -> np.ndarray:
        """(m, q) each window's best correction δ* of its initial state for ``residuals`` (rows, m) of the
        windows ``columns``, NaN as 0."""
        compared, sensitivity = self.compared[:, columns], self.sensitivity[:, columns]
        r = np.where(np.isfinite(residuals) & compared, residuals, 0.0)
        return np.einsum("mij,mj->mi", self.inverse[columns], np.einsum("rmj,rm->mj", sensitivity, r))

    def apply(self, residuals: np.ndarray, columns: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """(rows, m) ``residuals`` of the windows ``columns`` with each window's best correction removed (NaN
        kept NaN, the samples past the window's predictability horizon NaN), and (q, m) the corrections over
        their prior standard deviations (the prior's residuals)."""
        step = self.corrections(residuals, columns)
        sensitivity = self.sensitivity[:, columns]
        corrected = np.where(self.compared[:, columns], residuals - np.einsum("rmi,mi->rm", sensitivity, step),
                             np.nan)
        return corrected, (step / self.stdev).T


def predictable(base: np.ndarray, plus: list[np.ndarray], minus: list[np.ndarray], least: int = 0,
                judged: tuple[str, ...] = MOTION_SIGNALS) -> np.ndarray:
    """(T, m) the samples of each window before its predictability horizon: the first sample where some
    signal's response to a nuisance of ± its prior standard deviation departs from linear by more than
    :data:`NONLINEAR_LIMIT` (normalized: in units of the signal's noise; of the signals ``judged``), i.e.
    where the window's best linear correction can no longer stand for the initial state the sensors leave
    uncertain. ``base``, ``plus``,
    ``minus``: (rows, m) stacked normalized residuals of the replay from the measured states and from each
    nuisance ± its prior standard deviation. A window whose horizon falls before its sample ``least`` (its first
    compared one) is compared whole when, over its first compared second, the data lie outside every replay
    from those initial states (the residual beyond the replays' spread about it): a model that cannot follow the
    data (a 55 kg boat against the default 6 m twin: residuals 3-100× the spread), and a model far off its data
    is never an all-clear. Inside the spread it is an unstable course the sensors' uncertainty explains (a
    hull whose yaw error grows e-fold in 0.2 s astern: residuals 0.05-0.3× the spread) and is cut there too,
    unless that would leave no window of ``base`` (a part of the trial's windows) anything to compare.

    On a course the model holds stably, a prior-sized error of the initial state changes the path linearly
    through the window (a heading 0.6° off turns it 0.6°) and the correction removes it: no sample is left out.
    On an unstable one — a straight course astern, where a sway or yaw error grows e-fold in 0.5 s at 12 m/s — the
    same error turns the replayed boat round within seconds, and from there the replay says nothing about the
    model: the samples after the horizon are not compared (docs/diagnosis.md).
    """
    signals = len(SIGNALS)
    curvature = np.zeros(base.shape)
    for p, n in zip(plus, minus, strict=True):
        second = 0.5 * (p + n) - base
        curvature = np.maximum(curvature, np.where(np.isfinite(second), np.abs(second), 0.0))
    rows = [i for i, s in enumerate(SIGNALS) if s in judged]
    worst = np.max(np.stack(np.split(curvature, signals))[rows], axis=0)  # (T, m)
    compared = np.cumsum(worst > NONLINEAR_LIMIT, axis=0) == 0
    early = compared.sum(axis=0) < least
    if np.any(early):
        spread = np.zeros(base.shape)
        for replay in (*plus, *minus):
            gap = np.abs(replay - base)
            spread = np.maximum(spread, np.where(np.isfinite(gap), gap, 0.0))
        head = slice(max(least - 1, 0), 2 * least - 1)  # the first compared second
        judged_rows = np.stack(np.split(np.abs(base), signals))[rows][:, head]
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # an unmeasured stretch: all-NaN
            residual_head = np.nanmax(judged_rows, axis=(0, 1))
        spread_head = np.max(np.stack(np.split(spread, signals))[rows][:, head], axis=(0, 1))
        outside = ~(residual_head <= spread_head)  # NaN (nothing measured): compared whole
        compared[:, early & outside] = True
        if not compared[least - 1:].any():  # every window cut: nothing left to judge the model on
            compared[:, early] = True
    return compared


def stack_signals(windows: Windows, predicted: dict[str, np.ndarray], sigma: dict[str, Scale]) -> np.ndarray:
    """(len(SIGNALS)·T, m) normalized residuals measured − ``predicted`` of every signal, stacked; ``sigma`` per
    signal one level or one per sample ((T, m): the noise with a model error that varies with speed)."""
    return np.concatenate([residual(s, windows.measured[s], predicted[s]) / _scale(sigma[s]) for s in SIGNALS])


def _scale(sigma: Scale) -> Scale:
    if isinstance(sigma, np.ndarray):
        return np.where(np.isfinite(sigma) & (sigma > 0), sigma, 1.0)
    return sigma if np.isfinite(sigma) and sigma > 0 else 1.0
