"""Online adaptation of the twin's turning coefficients when the boat steers: re-identified over the moving horizon
by the offline manoeuvring fit, adopted only when the data reject the current coefficients and the new ones
predict held-out recent data better (a hot swap, logged, reversible) — the surge model's rule
(:mod:`boat_twin.shadow.adapt`).

The identification is :func:`boat_twin.ident.manoeuvring.fit_manoeuvring` (the one ``identify --manoeuvring``
runs; nothing of it is copied here) on the horizon without its held-out tail, from the twin's current surge
model, whose scale (mass and resistance factors, :data:`~boat_twin.ident.manoeuvring.SURGE_FACTORS`) it fits
with the coefficients :data:`LIVE_KEYS` (held as exact, a surge curve 1 % off moved a_v 9 %, outside its
interval; issue 25): the sway and yaw inertia and lift damping and the yaw
cross-flow drag, which a zigzag or random steering at one speed determines (5-15 % intervals on a 470 s
horizon). The lateral-resistance centre, the steering offset and the sway cross-flow drag are held: one speed's
steering leaves them free or confounded (``identify``'s ``not_separated``), and a live twin cannot ask for a
turning circle.

A fit is tried on at least :data:`MIN_TRAINING_S` of training data, and only when it has steered enough
(:func:`steering_excitation`): the yaw rate's spread at least :data:`YAW_EXCITATION_RATIO` times the gyro's white
noise measured on the same samples, and at least :data:`MIN_REVERSALS` steering reversals (a zigzag's or a
helm's, beyond :data:`REVERSAL_DEADBAND_RAD`); a boat running straight costs no fit. A candidate is adopted when

1. it identifies every coefficient and does not misfit (:data:`LIVE_MISFIT_RATIO`: residuals above the measured
   noise mean that the coefficients absorb a cause the model lacks — a current, a fault);
2. its covariance (cluster-robust, windows as clusters) rejects the current coefficients: Hotelling's T² of the
   difference in the fit's coordinates (logarithms) above its 95 % point; and
3. it predicts the held-out tail better: the mean squared replay residual over the measured noise
   (:func:`~boat_twin.ident.manoeuvring.prediction_error`) below (1 − :data:`ADOPT_MARGIN`) × the current's (a
   wider margin than the surge model's 5 %: a turning error worth the name changes the held-out error many-fold).

The replaced coefficients are kept and reinstated when they predict the newest held-out tail better by the same
margin and the newest fit does not reject them. Cost: a fit takes 0.2-0.7 s of CPU; tries come every
``period_s`` (60 s) after a change of the coefficients, doubling up to :data:`MAX_WAIT_PERIODS` periods while
they stand (a fit rejecting them but barred from adoption, e.g. by a misfit, is not tried again every period).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.manoeuvring import (
    MISFIT_RATIO,
    SURGE_FACTOR_KEYS,
    WINDOW_S,
    ManoeuvringFit,
    apply_parameters,
    fit_manoeuvring,
)
from boat_twin.io.trial import Trial
from boat_twin.shadow.adapt import COUPLING_SCALE_SD, COUPLING_STATE_SD
from boat_twin.shadow.adopter import FACTOR_RANGE, REJECT_LEVEL, Adopter, hotelling_rejects
from boat_twin.signal_noise import white_noise_stdev
from boat_twin.vessel.params import VesselParams, derive_coefficients

LIVE_KEYS = ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms", "yaw_quadratic_Nms2")
"""Turning coefficients adapted live (module docstring; meanings in
:data:`boat_twin.ident.manoeuvring.PARAMETERS`), all positive and fitted in logarithms."""
YAW_EXCITATION_RATIO = 10.0
"""The yaw rate's standard deviation over the training stretch must be at least this many times the gyro's white
noise measured on it (0.6°/s for the UM7's 0.06°/s), -."""
MIN_REVERSALS = 4
"""Steering reversals (sign changes of the steering about its mean) the training stretch must hold, -."""
REVERSAL_DEADBAND_RAD = math.radians(1.0)
"""A reversal counts once the steering crosses to beyond this angle on the other side of its mean, rad."""
LIVE_MISFIT_RATIO = {**MISFIT_RATIO, "vel_east_mps": 2.5, "vel_north_mps": 2.5}
"""Residual over the measured noise above which a turning fit misfits and is not adopted: the offline fit's
:data:`~boat_twin.ident.manoeuvring.MISFIT_RATIO`, but 2.5 on the GNSS velocity, whose 1.6 is calibrated on
zigzags at one thrust: with the thrust changing (random commands) it stays at 1.3-1.9 with the true model (each
window's surge transient) and that gate refused every fit of a boat yawing 25 % otherwise; stretches the model
misfits gave 2.8-4.4 (a 470 s random-commands horizon of the configured boat at 9-13 m/s, whose fit moved the
coefficients 3-8 % and was adopted without this gate)."""
ADOPT_MARGIN = 0.5
"""Turning coefficients replace others only if their held-out error is this share lower. Measured (issue 25, the
held-out windows started after the sway observer's run-in: before, the first window's missing sway made the
score 9.9-24 on the configured boat and hid the rest): a fit of the configured boat making up for a surge mass
0.8 % high and its curve (``bench_live_adapt.py`` B, seed 1: m22 ×1.018, a_v ×1.037) improved it by 37 %
(2.36 → 1.48), which the 25 % margin of before adopted; fits of boats yawing up to 25 % otherwise by many-fold
(study T: every one adopted with this margin)."""
MIN_WINDOWS = 8
"""Replay windows (of :data:`~boat_twin.ident.manoeuvring.WINDOW_S`) the training stretch must hold: Hotelling's
test of the :data:`LIVE_KEYS` on G windows has G − 5 degrees of freedom, and on 6 (a 120 s stretch) it can reject
nothing (a 25 % yaw-damping error fitted within 2 % went untested); the intervals, with the two surge factors,
have G − 7, -."""
MIN_TRAINING_S = MIN_WINDOWS * WINDOW_S
"""The shortest training stretch a turning fit is tried on, s."""


def steering_excitation(trial: Trial) -> tuple[float, int]:
    """(yaw-rate spread over its white noise, steering reversals) of ``trial``: how much it steered."""
    rate = trial.yaw_rate_radps[np.isfinite(trial.yaw_rate_radps)]
    noise = white_noise_stdev(rate)
    ratio = float(np.std(rate) / noise) if rate.size > 2 and noise > 0.0 else 0.0
    steering = 0.5 * (trial.angle_left_rad + trial.angle_right_rad)
    steering = steering[np.isfinite(steering)]
    if steering.size == 0:
        return ratio, 0
    centred = steering - np.mean(steering)  # not the median: a zigzag's is one of its two sides
    side = np.sign(np.where(np.abs(centred) > REVERSAL_DEADBAND_RAD, centred, 0.0))
    sides = side[side != 0.0]
    return ratio, int(np.count_nonzero(np.diff(sides))) if sides.size else 0


def coefficients(vessel: VesselParams) -> dict[str, float]:
    """The :data:`LIVE_KEYS` coefficients the twin of ``vessel`` turns with (configured, derived or adopted)."""
    derived = derive_coefficients(vessel)
    return {key: float(getattr(derived, key)) for key in LIVE_KEYS}


@dataclass(frozen=True, kw_only=True)
class TurningModel:
    """Turning coefficients (:data:`LIVE_KEYS`) with their 95 % intervals; empty ``values``: the configured boat's
    (derived from its mass and reference turn as the mass changes)."""

    values: dict[str, float] = field(default_factory=dict)
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    covariance: tuple[tuple[float, ...], ...] = ()
    """Covariance of the logarithms of ``values`` (order of :data:`LIVE_KEYS`), cluster-robust."""
    windows: int = 0
    """Replay windows of the fit (its clusters; 0: not fitted), -."""
    residual_to_noise: dict[str, float] = field(default_factory=dict)
    not_identified: tuple[str, ...] = ()
    misfit: bool = False
    """A residual above its :data:`LIVE_MISFIT_RATIO`: the coefficients absorb a cause the model lacks."""
    surge_factors: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    """The held surge model's mass and resistance scale the fit found with the coefficients
    (:data:`~boat_twin.ident.manoeuvring.SURGE_FACTORS`): value, 95 % low, high, -. Off 1 beyond their interval:
    the twin's surge model misses this stretch's speed by more than its scale's noise."""

    @classmethod
    def from_fit(cls, fit: ManoeuvringFit) -> TurningModel:
        """The live coefficients of an offline fit over them."""
        index = [fit.fitted.index(k) for k in LIVE_KEYS]
        stderr = np.array([fit.stderr[k] for k in LIVE_KEYS])
        cov = fit.correlation[np.ix_(index, index)] * np.outer(stderr, stderr)
        return cls(values={k: fit.values[k] for k in LIVE_KEYS}, ci95={k: fit.ci95[k] for k in LIVE_KEYS},
                   covariance=tuple(tuple(float(x) for x in row) for row in cov), windows=fit.windows,
                   residual_to_noise=dict(fit.residual_to_noise),
                   not_identified=tuple(k for k in LIVE_KEYS if k in fit.not_identified),
                   misfit=any(r > LIVE_MISFIT_RATIO[s] for s, r in fit.residual_to_noise.items()),
                   surge_factors={k: (fit.values[k], *fit.ci95[k]) for k in SURGE_FACTOR_KEYS if k in fit.fitted})

    def config(self, base: TwinConfig) -> TwinConfig:
        """``base`` turning with these coefficients (unchanged for the configured ones)."""
        return apply_parameters(base, self.values) if self.values else base

    def to_dict(self, configured: dict[str, float], derived: dict[str, float] | None = None) -> dict[str, Any]:
        """JSON-ready (SI): each coefficient, its interval and its ratio to the ``configured`` boat's; ``derived``:
        what the twin turns with when these are the configured ones (they follow the adapted mass)."""
        values = self.values or derived or configured
        return {"fitted": bool(self.values),
                "coefficients": {k: float(v) for k, v in values.items()},
                "ci95": {k: [float(x) for x in v] for k, v in self.ci95.items()},
                "relative_to_configured": {k: float(values[k] / configured[k]) for k in values},
                "windows": self.windows, "not_identified": list(self.not_identified), "misfit": self.misfit,
                "residual_to_noise": dict(self.residual_to_noise),
                "surge_factors": {k: {"value": float(v[0]), "ci95": [float(v[1]), float(v[2])]}
                                  for k, v in self.surge_factors.items()}}

    def coupling_log_variance(self) -> float:
        """Variance of log(m₂₂/a_v) from the fit's covariance (NaN when not fitted), -: the relative variance of
        the sway-yaw coupling m₂₂·v·r the twin turns with (:meth:`TurningAdapter.coupling_sd`)."""
        if not self.values or not self.covariance:
            return math.nan
        i, j = LIVE_KEYS.index("m22_kg"), LIVE_KEYS.index("sway_damping_Nspm2")
        cov = np.array(self.covariance)
        return float(cov[i, i] + cov[j, j] - 2.0 * cov[i, j])

    def rejects(self, current: dict[str, float], level: float = REJECT_LEVEL) -> bool:
        """Whether this fit's covariance rejects the ``current`` coefficients at ``level``: Hotelling's T² of the
        difference of their logarithms against its F bound on the fit's windows."""
        if not self.values:
            return False
        diff = np.array([math.log(self.values[k] / current[k]) for k in LIVE_KEYS])
        return hotelling_rejects(diff, np.array(self.covariance), self.windows, level)


Log = Callable[[str], None]
Score = Callable[[TurningModel], float]
"""A turning model's error on the held-out tail (lower is better; NaN: cannot be judged)."""


class TurningAdapter(Adopter[TurningModel]):
    """Keeps the twin's turning coefficients current from the steering in the recent stream, by the rule of
    :mod:`~boat_twin.shadow.adopter` (module docstring).

    The caller (:class:`~boat_twin.shadow.session.Shadow`) says when an update is :meth:`due`, and gives the
    training stretch, the twin's config with the current model (its surge held by the fit) and the held-out
    score."""

    def __init__(self, configured: VesselParams, *, period_s: float = 60.0, log: Log | None = None) -> None:
        super().__init__(TurningModel(), period_s=period_s, margin=ADOPT_MARGIN, log=log)
        self.configured = coefficients(configured)
        self.fits = 0
        """Fits made (tries on a horizon that steered enough), -."""
        self.excitation: tuple[float, int] = (0.0, 0)
        """The latest training stretch's :func:`steering_excitation`."""

    def due(self, t_s: float, first_s: float) -> bool:
        """True when an update is due at ``t_s`` (then scheduled :attr:`wait_s` on); ``first_s``: the earliest."""
        if math.isnan(self._next_s):
            self._next_s = first_s
        return self._scheduled(t_s)

    def update(self, training: Trial, plain: TwinConfig, score: Score) -> bool:
        """Fit a candidate on ``training`` and adopt it, or revert, by the module docstring's rule; ``plain``: the
        twin as it predicts now but with the configured turning (the fit holds its surge model's shape and fits
        its scale, :data:`~boat_twin.ident.manoeuvring.SURGE_FACTORS`). True when the coefficients changed."""
        if training.t_s.size < 2 or training.t_s[-1] - training.t_s[0] < MIN_TRAINING_S:
            return False
        self.excitation = steering_excitation(training)
        ratio, reversals = self.excitation
        if ratio < YAW_EXCITATION_RATIO or reversals < MIN_REVERSALS:
            self.back_off()
            return False
        now = score(self.current)
        if not math.isfinite(now):
            return False
        try:  # coefficients far off make replays diverge, which the fit scores as such: no warning to log
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                fit = fit_manoeuvring([training], self.current.config(plain), free=LIVE_KEYS + SURGE_FACTOR_KEYS)
            candidate: TurningModel | None = TurningModel.from_fit(fit)
        except (InputError, ValueError, np.linalg.LinAlgError):
            candidate = None
        self.fits += 1
        self.candidate = candidate
        self.back_off()  # until the coefficients change: a fit that cannot be adopted is not tried every period
        outcome = self.cycle(
            candidate, now, score, margin=ADOPT_MARGIN,
            rejects=lambda fit, model: fit.rejects(coefficients(model.config(plain).vessel)),
            revert_why=lambda score_now, before: f"they predict the held-out tail better (normalized MSE "
                                                 f"{score_now:.2f} → {before:.2f}) and the newest fit does not "
                                                 "reject them")
        if outcome.changed is None:
            return False
        self.wait_s = self.period_s
        if outcome.changed == "adopted":
            adopted = self.current
            described = ", ".join(f"{k} ×{adopted.values[k] / self.configured[k]:.3f} "
                                  f"[{adopted.ci95[k][0] / self.configured[k]:.3f}, "
                                  f"{adopted.ci95[k][1] / self.configured[k]:.3f}]" for k in LIVE_KEYS)
            self.log(f"adopted turning coefficients ({described} of the configured): held-out normalized MSE "
                     f"{now:.2f} → {outcome.score:.2f}")
        return True

    def coupling_sd(self, vessel: VesselParams) -> float:
        """How far the twin's sway-yaw coupling m₂₂·v·r may be off, as a relative standard deviation (the surge
        fit's prior on its scale c, :func:`~boat_twin.ident.output_error.fit_surge`), -; ``vessel``: the twin's now.
        The twin's sway in a turn is v = (Y_T − m₁₁·u·r)/(a_v·u) (its steady sway balance), so the coupling scales
        with m₂₂/a_v. Judged by the latest turning fit (else the adopted one): its own variance of log(m₂₂/a_v) plus
        the squared log distance of the twin's ratio from the fit's (zero once adopted; small while the fit confirms
        the configured coefficients, large while it rejects them), plus the sway state's own error
        (:data:`~boat_twin.shadow.adapt.COUPLING_STATE_SD`). No fit yet:
        :data:`~boat_twin.shadow.adapt.COUPLING_SCALE_SD` (the configured a_v's drift-angle range and the state's)."""
        fit = self.candidate if self.candidate is not None and self.candidate.values else self.current
        variance = fit.coupling_log_variance()
        if not math.isfinite(variance):
            return COUPLING_SCALE_SD
        twin = coefficients(vessel)
        distance = math.log((twin["m22_kg"] / twin["sway_damping_Nspm2"])
                            / (fit.values["m22_kg"] / fit.values["sway_damping_Nspm2"]))
        return math.sqrt(max(variance, 0.0) + distance**2 + COUPLING_STATE_SD**2)

    def _physical(self, model: TurningModel) -> bool:
        """A fit that neither misfits nor leaves a coefficient unidentified, each within :data:`FACTOR_RANGE` of
        the configured boat's."""
        low, high = FACTOR_RANGE
        return not (model.misfit or model.not_identified) \
            and all(low <= model.values[k] / self.configured[k] <= high for k in LIVE_KEYS)

    def _describe(self, back_to: TurningModel, replaced: TurningModel) -> str:
        back = "the configured boat's" if not back_to.values else ", ".join(
            f"{k} ×{back_to.values[k] / self.configured[k]:.3f}" for k in LIVE_KEYS)
        return f"reverted turning coefficients to {back}"

    def to_dict(self, vessel: VesselParams) -> dict[str, Any]:
        """The adopted coefficients with intervals, the latest fit and the counters, JSON-ready; ``vessel``: the
        twin's now."""
        ratio, reversals = self.excitation
        return {**self.current.to_dict(self.configured, coefficients(vessel)),
                "latest_fit": self.candidate.to_dict(self.configured) if self.candidate is not None else None,
                "fits": self.fits, "swaps": self.swaps,
                "steering_excitation": {"yaw_rate_to_noise": ratio, "reversals": reversals}}
