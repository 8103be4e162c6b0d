"""Fit catalogue effects to a trial, judge them on held-out time, and name the ones the data support.

Method (docs/diagnosis.md states it with the numbers):

- Residuals are measured − predicted (:mod:`~boat_twin.twin.replay`) per signal, divided by the signal's
  white-noise level estimated from the data itself, so signals of different units weigh by their information.
- A model's parameters are fitted (``scipy.optimize.least_squares``, fed part by part:
  :mod:`~boat_twin.diagnose.streamed_lsq`) on all windows. A candidate that passes
  the in-sample conditions of the decision rule (:attr:`Candidate.plausible`) is then judged on held-out
  windows: they are dealt to :data:`FOLDS` folds in turn (window k → fold k mod FOLDS) — each window starts
  afresh from the measurements, so windows are nearly independent, and dealing them makes every fold hold
  every speed and heading the trial visited (contiguous blocks of a thrust-steps trial would each hold one
  speed, and a speed-dependent effect could never be judged out of its block). The parameters are refitted
  without each fold and judged on it: the *held-out gain* is 1 − SSE_held-out(candidate) /
  SSE_held-out(current model). The same fold fits give jackknife standard errors of the parameters and 95 %
  intervals with the t quantile of FOLDS − 1 degrees of freedom.
- BIC with an effective sample size: each signal's n divided by the integrated autocorrelation time of the
  candidate's residuals, ΔBIC = Σ_s n_eff,s·ln(SSE_s,new / SSE_s,old) + Δk·ln(Σ n_eff,s).
- Decision rule: a candidate is *named* when ΔBIC < :data:`BIC_THRESHOLD` (very strong evidence, Kass &
  Raftery 1995) **and** its held-out gain > :data:`MIN_HELDOUT_GAIN` **and** its 95 % interval excludes the
  null value of at least one parameter **and** its size reaches the effect's
  :attr:`~boat_twin.diagnose.effects.EffectSpec.min_size` **and** no parameter ends on a bound of its physical
  range (:attr:`Effect.lower`/``upper``: a current of 3 m/s or a resistance × 4 that the fit wants is a
  stand-in for another cause, e.g. a resistance change taking up a towed body's drag) **and**, from the second
  round on, it leaves the size of every effect already named within :data:`TAKEOVER_FRACTION` of what it was
  (a candidate that takes over an earlier one's part is not separable from it on this trial) **and** no
  candidate of its round fits better (lower ΔBIC) while failing only the size floor (:func:`below_floor`: the
  data prefer a cause too small to name, which this one would stand in for) **and** it carries a substantial
  share of the misfit it claims (:func:`misfit_share`): the signals that carry at least
  :data:`CLAIM_FRACTION` of its held-out SSE reduction are *its* signals; over them it removes at least
  :data:`MIN_MISFIT_SHARE` of the current model's held-out RMS misfit in excess of the noise floor, or leaves
  them within :data:`~boat_twin.diagnose.structure.MISFIT_FACTOR` of it. A cause that lowers an 8× misfit by
  12-20 % stays a candidate. **And** it raises no signal's held-out misfit by more than :data:`MAX_MISFIT_RISE`
  (:func:`misfit_rise`): a cause that buys one signal's fit with another's stands in for one outside the catalogue.
- Withheld: after forward selection, a named cause whose claimed signals the final model still leaves
  unexplained (above :data:`~boat_twin.diagnose.structure.MISFIT_FACTOR` times their noise, or structured beyond
  what the twin normally leaves) explains only part of something outside the catalogue: it is reported
  ``withheld``, not the verdict (:func:`withheld`, the rule the live diagnosis shares).
- One heading: on a trial whose heading stays within :data:`ONE_HEADING_SPREAD_RAD` (circular standard
  deviation), a wind is a constant force in the body frame, as a water current, a thrust asymmetry, a steering
  offset or a resistance change are (:data:`WIND_ALIASES`). When the best named candidate of a round is the wind
  or one of those and the other side would be named too, neither is: both are reported as ``ambiguous``
  candidates and forward selection stops. On any trial the same holds when the other side's held-out gain is
  within :data:`MIN_HELDOUT_GAIN` of the best's or above it: the held-out windows do not tell them apart (a wind
  blowing a boat over many headings drifts it much as a current sets it; issue 42).
- Timing: a command delay, a GNSS latency and an engine lag all move the measured response later; when the best
  named candidate is one of :data:`TIMING_ALIASES` and another of them is named within |BIC_THRESHOLD| of its ΔBIC,
  neither is named: both are ``ambiguous`` and forward selection stops.
  Forward selection: the named candidate with the lowest ΔBIC joins the model, its parameters stay free,
  and the remaining candidates are tried again against the extended model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import stdtrit

from boat_twin.config import TwinConfig
from boat_twin.diagnose.defaults import PART_WINDOWS
from boat_twin.diagnose.effects import EFFECTS, Effect
from boat_twin.diagnose.initial_state import InitialStateProjection, stack_signals
from boat_twin.diagnose.model_error import normal_misfit, structure_folds, yardstick
from boat_twin.diagnose.streamed_lsq import streamed_least_squares
from boat_twin.diagnose.structure import MISFIT_FACTOR, Signature
from boat_twin.errors import InputError
from boat_twin.signal_noise import white_noise_stdev
from boat_twin.twin.replay import SIGNALS, MeasuredMotion, Prediction, Windows, measured_motion, motion_key, predict

FOLDS = 5
"""Folds of windows (dealt in turn) for held-out judgement and jackknife uncertainty."""
BIC_THRESHOLD = -10.0
"""ΔBIC below this is one condition of naming a candidate: 'very strong' evidence."""
MIN_HELDOUT_GAIN = 0.01
"""A named candidate must lower the held-out weighted SSE by more than this fraction."""
MAX_EFFECTS = 3
"""Forward selection stops after this many named effects."""
INFEASIBLE_RESIDUAL = 1e3
"""Normalized residual of every sample for parameters the vessel loader refuses: steers the fit away."""
BOUND_MARGIN = 0.01
"""A fitted parameter this close to a bound (fraction of its range) is on it."""
TAKEOVER_FRACTION = 0.5
"""A candidate that changes an already named effect's size by more than this fraction of it is refused."""
MIN_MISFIT_SHARE = 0.7
"""A named candidate removes at least this share of the held-out misfit's excess over the noise floor in its
signals, (m_old − m_new) / (m_old − 1) with m the RMS over the noise floor (unless it leaves them within
MISFIT_FACTOR of the floor). A wind taken for a thrust asymmetry (issue 17: velocity RMSE 20 % and 12 % lower,
8× the noise left) removes 18 %; in the accuracy study (docs/diagnosis.md) a hidden catalogue effect removes
81-100 %, a catalogue effect standing in for an out-of-catalogue probe on random commands 5-48 %."""
MAX_MISFIT_RISE = 0.1
"""A named candidate raises no signal's held-out misfit (RMS over the noise floor) by more than this over the
current model's: a cause in the catalogue explains the data as a whole, while a stand-in for a cause outside it
buys one signal's fit with another's. A gyro reading 5 % high on a zigzag, taken for a boat that turns faster
(a_r × 0.81), takes the yaw rate's misfit from 5.2 to 1.3 and the north velocity's from 1.12 to 1.55; the
windows' initial-state correction hides part of that rise in each window's heading and sway, and the ΔBIC, with
each signal weighted by its effective sample size, counts the structured rise little (docs/diagnosis.md)."""
CLAIM_FRACTION = 0.1
"""A signal is one a candidate claims when it carries at least this fraction of the candidate's held-out SSE
reduction."""
ONE_HEADING_SPREAD_RAD = 0.2
"""A trial whose measured heading has a circular standard deviation below this (rad, 11°) holds one heading:
a wind cannot be told from the constant body-frame forces of :data:`WIND_ALIASES` there."""
TIMING_ALIASES = ("command_delay", "gnss_latency", "thrust_lag")
"""Effects that move the measured response later: on a trial that only steps the thrust (no steering), a command
delay, a GNSS latency and an engine lag of about the same size are nearly the same change of the GNSS velocity.
When the best candidate of a round is one of them and another would be named too with a ΔBIC within
|:data:`BIC_THRESHOLD`| of it (no strong evidence against either), neither is named: both are ``ambiguous``."""
WIND_ALIASES = tuple(name for name, spec in EFFECTS.items() if spec.wind_alias)
"""Effects a wind is confounded with on a trial that holds one heading (:attr:`EffectSpec.wind_alias
<boat_twin.diagnose.effects.EffectSpec.wind_alias>`): water_current, thrust_asymmetry, steering_offset,
resistance_shape."""
MAX_EVALUATIONS = 40
"""Model evaluations per least-squares fit (each a replay of every window)."""
MOTIONS_KEPT = 4
"""Sensor configurations whose measured motion a diagnosis keeps (each three trial-length arrays)."""


@dataclass
class Residuals:
    """Normalized residuals of one model: signal → (T, m) (NaN where not measured), each window's best
    initial-state correction removed (:mod:`~boat_twin.diagnose.initial_state`)."""

    values: dict[str, np.ndarray]
    prediction: Prediction
    """The replay from the measured initial states (uncorrected)."""
    prior: np.ndarray | None = None
    """(q, m) the windows' initial-state corrections over their prior standard deviations (None: none made)."""

    def sse(self) -> np.ndarray:
        """(n_signals, m) sums of squares per signal and window."""
        return np.stack([np.nansum(self.values[s] ** 2, axis=0) for s in SIGNALS])

    def counts(self) -> np.ndarray:
        """(n_signals, m) samples per signal and window."""
        return np.stack([np.sum(np.isfinite(self.values[s]), axis=0) for s in SIGNALS])


def joined(parts: list[Residuals]) -> Residuals:
    """The residuals of consecutive parts of the windows as one."""
    values = {s: np.concatenate([p.values[s] for p in parts], axis=1) for s in parts[0].values}
    signals = {s: np.concatenate([p.prediction.signals[s] for p in parts], axis=1)
               for s in parts[0].prediction.signals}
    position = np.concatenate([p.prediction.position for p in parts], axis=1)
    prior = None if parts[0].prior is None else np.concatenate([p.prior for p in parts], axis=1)
    return Residuals(values, Prediction(signals, position), prior)


RELEASED = Residuals({}, Prediction({}, np.zeros((0, 0, 2))))
"""The residuals of a released fit (:meth:`Fit.released`): none; reading a signal of them is a KeyError."""


@dataclass(frozen=True, kw_only=True)
class Fit:
    """A model (effects with parameters) fitted to a trial, with its held-out judgement."""

    effects: list[Effect]
    values: np.ndarray
    """All effects' parameters, concatenated, SI."""
    stderr: np.ndarray
    sse: np.ndarray
    """(n_signals,) in-sample SSE with the full-data fit."""
    heldout_sse: np.ndarray
    """(n_signals,) SSE of every fold predicted by the fit without it (NaN until :meth:`Diagnosis.judge`)."""
    residuals: Residuals
    n_eff: np.ndarray = field(default_factory=lambda: np.zeros(len(SIGNALS)))
    """(n_signals,) effective sample sizes of the residuals."""

    def released(self) -> Fit:
        """This fit without its residuals (:data:`RELEASED`): a judged candidate that cannot become the model keeps
        its parameters and sums of squares for the report, not its (T, m) arrays (on a 6-hour trial ~20 MB a fit,
        ~40 fits a diagnosis)."""
        return replace(self, residuals=RELEASED)

    def split(self) -> list[tuple[Effect, np.ndarray, np.ndarray]]:
        """(effect, values, stderr) per effect."""
        out, i = [], 0
        for effect in self.effects:
            out.append((effect, self.values[i:i + effect.size], self.stderr[i:i + effect.size]))
            i += effect.size
        return out


def correlation_time(residual: np.ndarray) -> float:
    """Integrated autocorrelation time (samples) of (T, m) residuals: 1 + 2·Σρ(k) up to ρ's first dip < 0.05."""
    x = np.where(np.isfinite(residual), residual, 0.0)
    x = x - x.mean(axis=0)
    var = float(np.sum(x * x))
    if var <= 0.0:
        return 1.0
    tau = 1.0
    for lag in range(1, x.shape[0] // 2):
        rho = float(np.sum(x[lag:] * x[:-lag])) / var
        if rho < 0.05:
            break
        tau += 2.0 * rho
    return tau


class Diagnosis:
    """One trial's windows, the base model, and everything needed to fit and judge extensions of it."""

    def __init__(self, windows: Windows, base: TwinConfig, progress: Callable[[str], None] | None = None) -> None:
        self.windows = windows
        self.base = base
        self.sigma = {s: white_noise_stdev(windows.measured[s]) for s in SIGNALS}
        """White-noise level per signal, from its measured samples only (GNSS samples bridged across a lost
        one are NaN in the windows: an interpolation has less noise than a measurement)."""
        self.scale = yardstick(windows, self.sigma, base.model_error)
        """What residuals are divided by: the noise, with the twin's own model error where it has one."""
        self.projection = InitialStateProjection.for_model(windows, base, self.sigma, self.scale)
        self.normal = normal_misfit(windows, base.model_error)
        """(n_signals,) the mean square misfit the twin normally has here (1: no model error, no condition)."""
        m = windows.t_s.shape[1]
        self.folds = np.arange(m) % FOLDS
        self.structure_folds = structure_folds(self.folds, base.model_error)
        """(m,) the structure test's folds: :attr:`folds`, or stretches of windows against a model error."""
        self.progress = progress or (lambda _msg: None)
        self.evaluations = 0
        self._motions: dict[tuple[float, ...], MeasuredMotion] = {}
        """The measured motion of the last :data:`MOTIONS_KEPT` sensor configurations (:func:`motion_key`): a fit
        of vessel or environment parameters replays every evaluation with the same one."""

    def _motion(self, config: TwinConfig) -> MeasuredMotion:
        key = motion_key(config)
        if key not in self._motions:
            if len(self._motions) >= MOTIONS_KEPT:
                del self._motions[next(iter(self._motions))]
            self._motions[key] = measured_motion(self.windows, config)
        return self._motions[key]

    def config(self, effects: list[Effect], values: np.ndarray) -> TwinConfig:
        """The base extended by ``effects`` with the concatenated parameter ``values``."""
        config, i = self.base, 0
        for effect in effects:
            config = effect.apply(config, values[i:i + effect.size])
            i += effect.size
        return config

    def parts(self) -> list[slice]:
        """The windows a replay runs at a time (:data:`PART_WINDOWS`)."""
        m = self.folds.size
        return [slice(first, min(first + PART_WINDOWS, m)) for first in range(0, m, PART_WINDOWS)]

    def residuals(self, config: TwinConfig) -> Residuals:
        """Normalized residuals of ``config`` over every window, replayed :meth:`parts` at a time."""
        self.evaluations += 1
        return joined([self.part_residuals(config, columns) for columns in self.parts()])

    def part_residuals(self, config: TwinConfig, columns: slice) -> Residuals:
        """Normalized residuals of ``config`` over the windows ``columns``."""
        windows = self.windows.part(columns)
        try:
            prediction = predict(windows, config, self._motion(config))
        except InputError:  # parameters the boat cannot have (e.g. a reference turn it could not hold)
            # (a signal the windows do not measure stays unmeasured: NaN, as in every feasible fit)
            infeasible = {s: np.where(np.isfinite(windows.measured[s]), INFEASIBLE_RESIDUAL, np.nan)
                          for s in SIGNALS}
            return Residuals(infeasible, Prediction(infeasible, np.zeros(windows.position.shape)),
                             np.zeros((self.projection.stdev.size, windows.t_s.shape[1])))
        scale = {s: v[:, columns] if isinstance(v, np.ndarray) else v for s, v in self.scale.items()}
        corrected, prior = self.projection.apply(stack_signals(windows, prediction.signals, scale), columns)
        values = dict(zip(SIGNALS, np.split(corrected, len(SIGNALS)), strict=True))
        return Residuals(values, prediction, prior)

    def _fit_values(self, effects: list[Effect], start: np.ndarray, train: np.ndarray) -> np.ndarray:
        """Least squares over the windows ``train`` (bool (m,)), in scaled parameters; returns SI values. The
        trial-length series kept for earlier fits' configs are dropped first: a fit keeps only its own."""
        self._motions.clear()
        self.windows.forget()
        null = np.concatenate([e.null for e in effects])
        scale = np.concatenate([e.scale for e in effects])
        lower = (np.concatenate([e.lower for e in effects]) - null) / scale
        upper = (np.concatenate([e.upper for e in effects]) - null) / scale
        # A null on a bound (tow drag 0) would start the trust region on it, where it cannot grow: start one
        # scale unit inside.
        x0 = np.clip((start - null) / scale, lower + np.minimum(1.0, (upper - lower) / 2), upper - 1e-9)

        parts = self.parts()

        def at(x: np.ndarray) -> Callable[[int], np.ndarray]:
            config = self.config(effects, null + scale * x)

            def part(k: int) -> np.ndarray:
                res = self.part_residuals(config, parts[k])
                keep = train[parts[k]]
                prior = [] if res.prior is None else [res.prior[:, keep].ravel()]
                stacked = np.concatenate([res.values[s][:, keep].ravel() for s in SIGNALS] + prior)
                return np.where(np.isfinite(stacked), stacked, 0.0)
            return part

        def evaluated() -> None:
            self.evaluations += 1

        x = streamed_least_squares(at, len(parts), x0, lower, upper, evaluated, diff_step=0.01,
                                   max_nfev=MAX_EVALUATIONS, x_scale=1.0, xtol=1e-3, ftol=1e-4)
        return null + scale * x

    def fit(self, effects: list[Effect], start: np.ndarray | None = None) -> Fit:
        """Fit ``effects`` on all windows (not yet judged on held-out time: see :meth:`judge`)."""
        null = np.concatenate([e.null for e in effects]) if effects else np.zeros(0)
        start = null if start is None else start
        if not effects:
            res = self.residuals(self.base)
            sse = res.sse().sum(axis=1)
            return self._finish(Fit(effects=effects, values=null, stderr=np.zeros(0), sse=sse, heldout_sse=sse,
                                    residuals=res))
        values = self._fit_values(effects, start, np.ones(self.folds.size, dtype=bool))
        res = self.residuals(self.config(effects, values))
        unjudged = np.full(len(SIGNALS), np.nan)
        return self._finish(Fit(effects=effects, values=values, stderr=np.full(values.size, np.nan),
                                sse=res.sse().sum(axis=1), heldout_sse=unjudged, residuals=res))

    def judge(self, fit: Fit) -> Fit:
        """``fit`` with its held-out judgement: its effects refitted without each fold in turn, the held-out SSE
        and the jackknife standard errors."""
        heldout = np.zeros(len(SIGNALS))
        folds = []
        for k in range(FOLDS):
            held = self.folds == k
            fold = self._fit_values(fit.effects, fit.values, ~held)
            folds.append(fold)
            heldout += self.residuals(self.config(fit.effects, fold)).sse()[:, held].sum(axis=1)
        fold_values = np.array(folds)
        stderr = np.sqrt((FOLDS - 1) / FOLDS * np.sum((fold_values - fold_values.mean(axis=0)) ** 2, axis=0))
        return replace(fit, stderr=stderr, heldout_sse=heldout)

    def _finish(self, fit: Fit) -> Fit:
        counts = fit.residuals.counts().sum(axis=1)
        tau = np.array([correlation_time(fit.residuals.values[s]) for s in SIGNALS])
        return replace(fit, n_eff=counts / tau)


def delta_bic(new: Fit, old: Fit) -> float:
    """BIC(new) − BIC(old) with the new model's effective sample sizes (see the module docstring)."""
    n_eff = np.where(new.n_eff > 0.0, np.maximum(new.n_eff, 1.0), 0.0)  # 0: a signal the trial has not
    ratio = np.maximum(new.sse, 1e-300) / np.maximum(old.sse, 1e-300)
    extra = new.values.size - old.values.size
    return float(np.sum(n_eff * np.log(ratio)) + extra * np.log(np.sum(n_eff)))


def heldout_gain(new: Fit, old: Fit) -> float:
    """1 − held-out SSE(new) / held-out SSE(old), all signals weighted by their noise."""
    return float(1.0 - new.heldout_sse.sum() / old.heldout_sse.sum())


def ci95(values: np.ndarray, stderr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """95 % interval with the t quantile of FOLDS − 1 degrees of freedom."""
    half = stdtrit(FOLDS - 1, 0.975) * stderr
    return values - half, values + half


def on_bound(effect: Effect, values: np.ndarray) -> bool:
    """True when a parameter lies within :data:`BOUND_MARGIN` of its range from a bound that is not its null."""
    margin = BOUND_MARGIN * (effect.upper - effect.lower)
    low = (values <= effect.lower + margin) & (effect.lower != effect.null)
    high = (values >= effect.upper - margin) & (effect.upper != effect.null)
    return bool(np.any(low | high))


def takes_over(new: Fit, old: Fit) -> bool:
    """True when ``new`` (``old``'s effects plus one) changes the magnitude of one of ``old``'s effects by more
    than :data:`TAKEOVER_FRACTION` of it: the two are not separable on this trial."""
    for (effect, before, _), (_, after, _) in zip(old.split(), new.split(), strict=False):
        if abs(effect.magnitude(after) - effect.magnitude(before)) > TAKEOVER_FRACTION * effect.magnitude(before):
            return True
    return False


def misfit_share(new: Fit, old: Fit, floor: np.ndarray, normal: np.ndarray | None = None
                 ) -> tuple[tuple[str, ...], float, bool]:
    """(signals ``new`` claims, share of their excess misfit it removes, whether it leaves them within
    MISFIT_FACTOR of the noise floor) against ``old``, all held out.

    ``floor`` (n_signals,) is each signal's held-out SSE of pure noise (its sample count: residuals are
    normalized by the noise level). The misfit of the claimed signals is their pooled RMS over the noise floor,
    m = √(ΣSSE / Σfloor); the share is (m_old − m_new) / (m_old − 1), 1 when m_old ≤ 1.

    ``normal`` (n_signals,): the mean square misfit the twin normally has
    (:func:`~boat_twin.diagnose.model_error.normal_misfit`). Where it is above 1 (the signal has a model error)
    "within MISFIT_FACTOR" is within it instead, when lower: MISFIT_FACTOR is the margin a model that fits its
    data leaves above the sensors' noise (its own small initialization error, 0.97-1.3 on clean simulated
    trials), and the model-error yardstick already holds that margin; 2× of it lets a stand-in removing a fifth
    of a misfit just beyond the twin's normal one through (issue 42: a 4 m/s wind after the thrust of both
    engines at 0.85×, its signals' mean square 1.57 → 1.42 against a normal 1.41). Where it is 1 (no model
    error): MISFIT_FACTOR, today's rule.
    """
    removed = old.heldout_sse - new.heldout_sse
    total = float(np.sum(np.maximum(removed, 0.0)))
    claimed = removed > CLAIM_FRACTION * total if total > 0 else np.zeros(removed.size, dtype=bool)
    if not claimed.any():
        return (), 0.0, False
    n = float(np.sum(floor[claimed]))
    before = float(np.sqrt(np.sum(old.heldout_sse[claimed]) / n))
    after = float(np.sqrt(np.sum(new.heldout_sse[claimed]) / n))
    share = (before - after) / (before - 1.0) if before > 1.0 else 1.0
    limit = np.full(floor.size, MISFIT_FACTOR**2) if normal is None else np.where(
        normal > 1.0, np.minimum(normal, MISFIT_FACTOR**2), MISFIT_FACTOR**2)
    within = bool(np.all(new.heldout_sse[claimed] <= limit[claimed] * floor[claimed]))
    return tuple(s for s, c in zip(SIGNALS, claimed, strict=True) if c), share, within


def misfit_rise(new: Fit, old: Fit, floor: np.ndarray) -> tuple[str, ...]:
    """The signals whose held-out misfit (RMS over the noise floor, ``floor`` as in :func:`misfit_share`)
    ``new`` raises by more than :data:`MAX_MISFIT_RISE` over ``old``'s."""
    measured = floor > 0  # a signal the trial has not rises nowhere
    safe = np.where(measured, floor, 1.0)
    rise = np.where(measured, np.sqrt(new.heldout_sse / safe) - np.sqrt(old.heldout_sse / safe), 0.0)
    return tuple(s for s, r in zip(SIGNALS, rise, strict=True) if r > MAX_MISFIT_RISE)


def beyond_normal(claims: tuple[str, ...], old: Fit, floor: np.ndarray, normal: np.ndarray) -> bool:
    """True when the held-out misfit of the signals ``claims`` under ``old`` (their pooled mean square over the
    yardstick, ``floor`` as in :func:`misfit_share`) exceeds what the twin normally has there (``normal``:
    :func:`~boat_twin.diagnose.model_error.normal_misfit`, pooled the same way): a cause must remove a misfit the
    twin does not normally have. Always True where the normal misfit is 1 (no model error: today's rule)."""
    claimed = np.array([s in claims for s in SIGNALS])
    if not claimed.any():
        return True
    n = float(np.sum(floor[claimed]))
    bound = float(np.sum(normal[claimed] * floor[claimed]) / n)
    return bound <= 1.0 or float(np.sum(old.heldout_sse[claimed])) / n > bound


def excludes_null(effect: Effect, values: np.ndarray, stderr: np.ndarray) -> bool:
    """True when the 95 % interval of at least one parameter leaves out the effect's null value."""
    lo, hi = ci95(values, stderr)
    return bool(np.any((effect.null < lo) | (effect.null > hi)))


@dataclass
class Candidate:
    """One effect tried against the current model in one round of forward selection."""

    effect: Effect
    fit: Fit
    delta_bic: float
    size: float
    """The effect's magnitude (:attr:`Effect.magnitude`)."""
    at_bound: bool
    """A parameter ended on a bound of its physical range: the effect stands in for something else."""
    takes_over: bool
    """Adding it changed the size of an effect already named by more than :data:`TAKEOVER_FRACTION`."""
    heldout_gain: float = float("nan")
    """NaN when the candidate failed the in-sample conditions and was not judged on held-out time."""
    significant: bool = False
    claims: tuple[str, ...] = ()
    """The signals carrying its held-out gain (:func:`misfit_share`)."""
    share: float = float("nan")
    """Share of those signals' held-out misfit in excess of the noise floor it removes (NaN: not judged)."""
    leaves_noise: bool = False
    """It leaves its signals within MISFIT_FACTOR of their noise floor, or within the twin's normal misfit where
    that is lower (held out; :func:`misfit_share`)."""
    worsens: tuple[str, ...] = ()
    """The signals whose held-out misfit it raises by more than :data:`MAX_MISFIT_RISE` (:func:`misfit_rise`)."""
    beyond_normal: bool = True
    """Its claimed signals' held-out misfit before it lies above the twin's normal misfit
    (:func:`beyond_normal`; always with a zero model error)."""
    outranked: bool = False
    """A candidate of the same round fits better (lower ΔBIC) and fails only the size floor: the data prefer a
    cause too small to name, and this one would stand in for it (:func:`below_floor`)."""
    pair_share: float = float("nan")
    """Share of the misfit it and the cause named with it in the next round remove together (NaN: no pair
    tried; :func:`forward_select`)."""

    @property
    def failed_conditions(self) -> list[str]:
        """The in-sample conditions of the decision rule it fails, in words (empty: it is judged held out)."""
        spec = self.effect.spec
        failed = [f"ΔBIC {self.delta_bic:.1f}, not below {BIC_THRESHOLD:g}"] if self.delta_bic >= BIC_THRESHOLD else []
        if self.size < spec.min_size:
            unit = spec.size_unit.split(" ")[0]
            failed.append(f"size {self.size:.3g} below the floor {spec.min_size:g}{'' if unit == '-' else ' ' + unit}")
        if self.at_bound:
            failed.append("a parameter on a bound of its physical range")
        if self.takes_over:
            failed.append("changes an effect already named")
        if self.outranked:
            failed.append("a cause too small to name fits better")
        return failed

    @property
    def plausible(self) -> bool:
        """The in-sample conditions of the decision rule, checked before the held-out judgement."""
        return not self.failed_conditions

    @property
    def carries_share(self) -> bool:
        """It carries a substantial share of the misfit it claims (:data:`MIN_MISFIT_SHARE`)."""
        return self.share >= MIN_MISFIT_SHARE or self.leaves_noise or self.pair_share >= MIN_MISFIT_SHARE

    @property
    def short_of_share(self) -> bool:
        """It passes every condition of the decision rule but the share of the misfit: a cause that may share
        its signals with a second one (:func:`forward_select`)."""
        return (self.plausible and self.heldout_gain > MIN_HELDOUT_GAIN and self.significant
                and not self.carries_share and not self.worsens and self.beyond_normal)

    @property
    def named(self) -> bool:
        """The decision rule (before the one-heading ambiguity of :func:`forward_select`)."""
        return (self.plausible and self.heldout_gain > MIN_HELDOUT_GAIN and self.significant and self.carries_share
                and not self.worsens and self.beyond_normal)


@dataclass
class Selection:
    """The outcome of forward selection."""

    baseline: Fit
    final: Fit
    rounds: list[list[Candidate]]
    named: list[Candidate]
    """The named candidates in the order they joined the model."""
    ambiguous: list[Candidate] = field(default_factory=list)
    """Candidates the decision rule would name but this trial cannot tell apart (one heading: a wind and one of
    :data:`WIND_ALIASES`; a wind and one of them whose held-out gains do not prefer the best; or two of
    :data:`TIMING_ALIASES` within |BIC_THRESHOLD|); none of them is named."""
    ambiguity: str = ""
    """Which rule found them: ``"wind"`` (one heading), ``"held_out"`` or ``"timing"`` ('' : none)."""


def withheld(named: list[Candidate], signatures: list[Signature], misfit: bool | None = None) -> list[Candidate]:
    """The named causes not to present as the verdict: a cause that leaves the misfit it explains real and
    structured explains only part of something outside the catalogue, a partial relabel a user would act on. Empty
    when no structure is left (``signatures``, :func:`~boat_twin.diagnose.structure.residual_structure` of the
    final model); otherwise, with ``misfit`` None (a whole trial: its own residuals judge), each cause whose
    claimed signals (:attr:`Candidate.claims`) include one left above
    :data:`~boat_twin.diagnose.structure.MISFIT_FACTOR` times its noise floor, or one the structure test flags
    within it when the cause was named without removing :data:`MIN_MISFIT_SHARE` of their misfit (by the share
    rule's "leaves them within MISFIT_FACTOR" clause, which takes what is left for noise and the twin's normal
    error: structure left says it is not. Issue 42: against a real-like twin's model error a 3.5 m/s wind stood
    in for a gyro reading 1.1×, removing 15 % of its signals' misfit and leaving the yaw rate 1.4× the yardstick
    with a held-out R² of 0.39); with
    ``misfit`` given (evidence from outside the data diagnosed that the model misfits: the live twin's
    innovations, where a 130 s window's own noise floor is too uncertain to judge), every cause when it is True,
    none when False. The causes named
    after a withheld one are withheld with it: they were fitted and judged against a model that held it (a
    steering dead band on a 130 s zigzag: ``manoeuvring`` leaves the yaw rate 2.1× its noise, and the
    ``resistance_shape`` named next would otherwise be the verdict alone).

    One rule for the offline and the live diagnosis (:mod:`boat_twin.shadow.rolling` passes ``misfit``). An
    actuator fault the catalogue lacks (the outboards losing up to 30 % of their thrust when steered, random
    commands) was named a thrust asymmetry that removed 74 % of its signals' misfit in excess of the noise
    (:data:`MIN_MISFIT_SHARE` is 70 %) and left them 4.6× their noise; two causes of the catalogue at once, the
    second named in the next round, leave nothing and are both presented."""
    if not signatures:
        return []
    if misfit is not None:
        return list(named) if misfit else []
    far = {s.signal for s in signatures if s.misfit > MISFIT_FACTOR}
    structured = {s.signal for s in signatures}

    def partial(c: Candidate) -> bool:
        return bool(far.intersection(c.claims)) or (bool(structured.intersection(c.claims)) and not (
            c.share >= MIN_MISFIT_SHARE or c.pair_share >= MIN_MISFIT_SHARE))

    first = next((i for i, c in enumerate(named) if partial(c)), len(named))
    return list(named[first:])


def below_floor(candidate: Candidate) -> bool:
    """True when ``candidate`` passes the in-sample conditions except the size floor: a supported cause too
    small to name."""
    return (candidate.delta_bic < BIC_THRESHOLD and candidate.size < candidate.effect.spec.min_size
            and not candidate.at_bound and not candidate.takes_over)


def heading_spread_rad(windows: Windows) -> float:
    """Circular standard deviation of the measured heading over the windows, rad."""
    heading = windows.measured["heading_rad"]
    heading = heading[np.isfinite(heading)]
    resultant = float(np.hypot(np.mean(np.cos(heading)), np.mean(np.sin(heading))))
    return float(np.sqrt(-2.0 * np.log(max(resultant, 1e-12))))


def _wind_ambiguity(named: list[Candidate], best: Candidate, one_heading: bool) -> list[Candidate]:
    """The best candidate and its other side (the wind against its best-ranked alias, or the reverse) when both
    would be named and the trial cannot tell them apart: it holds one heading, or the held-out windows do not
    prefer the best (the other's held-out gain within :data:`MIN_HELDOUT_GAIN` of its own or above it: issue 42,
    a 7.6 m/s wind best by ΔBIC for a hidden current, held-out gains 43.9 % and 43.4 %); empty otherwise."""
    if best.effect.name == "wind":
        others = [c for c in named if c.effect.spec.wind_alias]
    elif best.effect.spec.wind_alias:
        others = [c for c in named if c.effect.name == "wind"]
    else:
        return []
    if one_heading:
        return [best, min(others, key=lambda c: c.delta_bic)] if others else []
    close = [c for c in others if c.heldout_gain >= best.heldout_gain - MIN_HELDOUT_GAIN]
    return [best, max(close, key=lambda c: c.heldout_gain)] if close else []


def _timing_ambiguity(named: list[Candidate], best: Candidate) -> list[Candidate]:
    """The best candidate and the best other of :data:`TIMING_ALIASES` when both would be named and their ΔBIC
    differ by less than |:data:`BIC_THRESHOLD`|; empty otherwise."""
    if best.effect.name not in TIMING_ALIASES:
        return []
    close = [c for c in named if c is not best and c.effect.name in TIMING_ALIASES
             and c.delta_bic - best.delta_bic < -BIC_THRESHOLD]
    return [best, min(close, key=lambda c: c.delta_bic)] if close else []


def _round(diagnosis: Diagnosis, current: Fit, remaining: dict[str, Effect], floor: np.ndarray, number: int
           ) -> list[Candidate]:
    """Every effect of ``remaining`` fitted on top of ``current`` and judged by the decision rule."""
    round_ = []
    for name, effect in remaining.items():
        diagnosis.progress(f"round {number}: {name}")
        start = np.concatenate([current.values, effect.null])
        fit = diagnosis.fit(current.effects + [effect], start)
        _, values, _ = fit.split()[-1]
        candidate = Candidate(effect, fit, delta_bic(fit, current), effect.magnitude(values),
                              on_bound(effect, values), takes_over(fit, current))
        if candidate.failed_conditions:  # (outranked below only adds a failure)
            candidate.fit = fit.released()
        round_.append(candidate)
    small = [c.delta_bic for c in round_ if below_floor(c)]
    for candidate in round_:
        candidate.outranked = bool(small) and candidate.delta_bic > min(small)
        effect, fit = candidate.effect, candidate.fit
        _, values, _ = fit.split()[-1]
        if candidate.plausible:  # the held-out judgement costs FOLDS more fits: only where it can matter
            fit = candidate.fit = diagnosis.judge(fit)
            candidate.heldout_gain = heldout_gain(fit, current)
            candidate.significant = excludes_null(effect, values, fit.split()[-1][2])
            candidate.claims, candidate.share, candidate.leaves_noise = misfit_share(fit, current, floor,
                                                                                      diagnosis.normal)
            candidate.worsens = misfit_rise(fit, current, floor)
            candidate.beyond_normal = beyond_normal(candidate.claims, current, floor, diagnosis.normal)
    for candidate in round_:
        if not (candidate.named or candidate.short_of_share):  # it can become neither the model nor a pair's first
            candidate.fit = candidate.fit.released()
    return round_


def forward_select(diagnosis: Diagnosis, effects: dict[str, Effect]) -> Selection:
    """Forward selection over ``effects`` with the decision rule of :class:`Candidate`.

    Two causes in the same signals: when a round names nothing and its best candidate fails only the share of
    the misfit (:attr:`Candidate.short_of_share`: a second cause is still in its signals), the next round is
    tried with it in the model; a cause named there that, together with it, removes :data:`MIN_MISFIT_SHARE` of
    the misfit the model before both left (and worsens no signal against that model) joins with it as a pair
    (:attr:`Candidate.pair_share`). Otherwise neither joins and the selection stops, as before."""
    baseline = diagnosis.fit([])
    floor = baseline.residuals.counts().sum(axis=1).astype(float)
    one_heading = heading_spread_rad(diagnosis.windows) < ONE_HEADING_SPREAD_RAD
    current = baseline
    rounds: list[list[Candidate]] = []
    chosen: list[Candidate] = []
    ambiguous: list[Candidate] = []
    reason = ""
    remaining = dict(effects)
    while remaining and len(current.effects) < MAX_EFFECTS:
        round_ = _round(diagnosis, current, remaining, floor, len(rounds) + 1)
        rounds.append(round_)
        named = [c for c in round_ if c.named]
        if not named:
            short = [c for c in round_ if c.short_of_share]
            first = min(short, key=lambda c: c.delta_bic) if short else None
            if (first is None or first.delta_bic > min(c.delta_bic for c in round_)
                    or len(current.effects) + 2 > MAX_EFFECTS):
                break
            rest = {k: e for k, e in remaining.items() if k != first.effect.name}
            following = _round(diagnosis, first.fit, rest, floor, len(rounds) + 1)
            named = [c for c in following if c.named]
            if not named:
                break
            second = min(named, key=lambda c: c.delta_bic)
            if (_wind_ambiguity(named, second, one_heading) or _timing_ambiguity(named, second)
                    or misfit_rise(second.fit, current, floor)):
                break
            _, together, _ = misfit_share(second.fit, current, floor)
            if together < MIN_MISFIT_SHARE:
                break
            first.pair_share = second.pair_share = together
            rounds.append(following)
            chosen += [first, second]
            current = second.fit
            remaining = {k: e for k, e in rest.items() if k != second.effect.name}
            _release(rounds, current)
            continue
        best = min(named, key=lambda c: c.delta_bic)
        if ambiguous := _wind_ambiguity(named, best, one_heading):
            reason = "wind" if one_heading else "held_out"
            break
        if ambiguous := _timing_ambiguity(named, best):
            reason = "timing"
            break
        chosen.append(best)
        current = best.fit
        del remaining[best.effect.name]
        _release(rounds, current)
    _release(rounds, current)
    return Selection(baseline, current, rounds, chosen, ambiguous, reason if ambiguous else "")


def _release(rounds: list[list[Candidate]], current: Fit) -> None:
    """Release every candidate's fit but the ``current`` model's (:meth:`Fit.released`): a selection holds the
    residuals of its baseline and its final model only, so its memory does not grow with the rounds."""
    for candidate in (c for round_ in rounds for c in round_):
        if candidate.fit is not current:
            candidate.fit = candidate.fit.released()
