"""Turning (manoeuvring) coefficients from recorded trials, by output error over windows (multiple shooting).

The sway/yaw coefficients of :mod:`boat_twin.vessel.dynamics` — sway and yaw inertia m22, m33, the lift damping
a_v, a_r, the lateral-resistance centre x_c, the cross-flow drag Y_vv, N_rr — and the outboards' steering offset
are fitted to zigzags and turning circles (any number of trials, at one or several speeds). Each trial is cut
into windows and replayed through the model by the twin's windowed replay (:func:`~boat_twin.twin.replay.predict`:
every window starts from the measured state, so a window's error is the model's, not accumulated drift); the
residuals (measured − predicted GNSS velocity, gyro yaw rate, IMU heading), each divided by its sensor's white
noise measured from the trial itself (:func:`~boat_twin.signal_noise.white_noise_stdev`), are minimised by
``scipy.optimize.least_squares`` over the parameters (positive ones in logarithms). Each window's initial
heading and surge are estimated with it (profiled out: :data:`INITIAL_STATE_NUISANCES`), since the sensors'
errors in them last through the window and would otherwise bias the coefficients.

Held, not fitted: surge (m11 and the resistance Fc, from the thrust–speed identification or the given model;
a caller may have its scale fitted with the coefficients, :data:`SURGE_FACTORS`), the thrust envelope and the
outboards' position (x_e, y_e). The yaw equation divided by m33 holds the engine
lever arm only as x_e/m33 (and a_r/m33, x_c·a_v/m33, ...): a wrong x_e rescales m33 and every yaw coefficient
together, which the trials cannot tell apart; the fit takes x_e as given.

Uncertainty: the covariance is the cluster-robust jackknife with windows as clusters (residuals within a window
share its initial-state error; windows start afresh and are nearly independent), and the 95 % intervals use
the t quantile with the Imbens-Kolesár degrees of freedom (at most windows − parameters). A parameter whose
interval reaches beyond a factor :data:`NOT_IDENTIFIED_FACTOR` of its value (x_c and the offset:
:data:`NOT_IDENTIFIED_ABSOLUTE`) is reported as not identified by these trials; it stays in the fit (holding it
at a prior would bias the others and hide that from their intervals), its value is the best fit and its interval
says how little that means.
A fit whose residuals, replayed from the measured initial states (a window's own estimated state could absorb
part of a misfit), stay above the measured noise (ratio above :data:`MISFIT_RATIO` on any signal) is flagged as
a misfit: its coefficients absorb a cause the model lacks and are biased.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.special import stdtrit

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.jackknife import cluster_degrees_of_freedom, cluster_squares, jackknife_covariance
from boat_twin.io.trial import Trial
from boat_twin.signal_noise import white_noise_stdev
from boat_twin.twin.replay import (
    HEADING_SMOOTHING_S,
    LATERAL_ACCEL,
    MOTION_SIGNALS,
    SETTLING_S,
    SURGE_SMOOTHING_S,
    SWAY_OBSERVER_S,
    Prediction,
    Windows,
    cut_windows,
    delayed_commands,
    measured_motion,
    measured_wind_mps,
    predict,
    predict_vessels,
    residual,
    wind_against,
    with_measured_wind,
)
from boat_twin.vessel.params import MANOEUVRING_KEYS, derive_coefficients
from boat_twin.vessel.resistance import CorrectedResistance

WINDOW_S = 20.0
"""Replay window, s: several yaw and sway time constants (0.4-9 s at 6 m/s), short enough that the heading a
window starts with (±0.3°) does not dominate its end; a 120 s zigzag gives 6 (the replay's minimum)."""
MISFIT_RATIO = {"vel_east_mps": 1.6, "vel_north_mps": 1.6, "heading_rad": 1.6, "accel_y_mps2": 1.6,
                "yaw_rate_radps": 2.5}
"""Residual RMS / measured white noise above which a signal is misfitted (the model lacks a cause). Measured
(docs/manoeuvring.md): fits of the right model stay at 0.95-1.4 (velocity, heading, accelerometer) and up to
1.9 on the gyro, whose noise (0.06°/s) is so low that a window's initial sway and surge errors show above it;
a thrust 10 % high or low gives 2.8 / 2.4 on the GNSS velocity (replayed from the measured initial states;
1.45 after each window's own heading and surge, which absorb part of it)."""
NOT_IDENTIFIED_FACTOR = 2.0
"""A positive coefficient whose 95 % interval reaches beyond this factor of its value (either way) is not
identified: the trials leave it free by more than its own size."""
NOT_IDENTIFIED_ABSOLUTE = {"lateral_centre_x_m": 0.5, "steering_offset_rad": math.radians(2.0)}
"""Half-interval above which a signed parameter is not identified (m; rad)."""
RUNAWAY_FACTOR = 1e3
"""A positive coefficient fitted beyond this factor of its start (either way) ran off towards 0 or ∞: its
sensitivity vanished with it, so the jackknife's spread is rounding (a cross-flow drag driven to 1e-24 N·s²/m² came
back with a zero-width interval on two 90 s zigzags). It is not identified and its interval is unbounded."""
TIMING_SHIFT_SAMPLES = 1
"""The steering commands are replayed this many samples late (0.1 s at 10 Hz) for the timing check's regressor:
the finite-difference sensitivity of every residual to a steering delay."""
TIMING_T_LIMIT = 3.0
"""|t| of the steering-timing score test above which a fit is flagged (``timing_flag``): the residuals keep a
component a steering delay or lag would explain. Measured (docs/manoeuvring.md): clean fits of the right model
|t| ≤ 1.7 over 6 seeds; a 0.2 s first-order lag of the steering on an independent integrator 6.8-16."""
SEPARATION_CORRELATION = 0.95
"""|correlation| above which two estimates are reported as not separated by the trials."""
DIVERGED_RESIDUAL = 1e3
"""Normalized residual of a sample whose prediction diverged (coefficients far off make the replay blow up):
steers the fit away instead of letting a NaN count as no error."""
MAX_EVALUATIONS = 30
"""Iterations of one least-squares fit (each replays every window of every trial 1 + parameters times)."""


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: its key (the ``vessel`` block of ``simulate --json``), unit and coordinate."""

    key: str
    meaning: str
    logarithmic: bool
    """Fitted as ln(value) (positive coefficients) or as value / :attr:`scale` (signed ones)."""
    scale: float = 1.0


PARAMETERS = (
    Parameter("m22_kg", "sway mass with added mass, kg", True),
    Parameter("m33_kgm2", "yaw inertia with added inertia, kg·m²", True),
    Parameter("sway_damping_Nspm2", "sway lift damping a_v in Y = −a_v·|u|·v, N·s²/m²", True),
    Parameter("lateral_centre_x_m", "centre of lateral resistance x_c, m forward of the centre of gravity", False,
              0.1),
    Parameter("yaw_damping_Nms", "yaw lift damping a_r in N = −a_r·|u|·r, N·m·s", True),
    Parameter("sway_quadratic_Ns2pm2", "cross-flow sway drag Y_vv in Y = −Y_vv·|v|·v, N·s²/m²", True),
    Parameter("yaw_quadratic_Nms2", "cross-flow yaw drag N_rr in N = −N_rr·|r|·r, N·m·s²", True),
    Parameter("steering_offset_rad", "outboards' real minus commanded steering angle, rad", False, 0.01),
)
"""What the fit can identify, in the order of the correlation matrix."""
PARAMETER_KEYS = tuple(p.key for p in PARAMETERS)
SURGE_FACTORS = (
    Parameter("surge_mass_factor", "held displacement mass (m11 with it) over the given model's, -", True),
    Parameter("resistance_factor", "held resistance Fc(u) over the given model's curve, -", True),
)
"""The held surge model's mass and resistance scale, fitted with the coefficients when asked (``free``): the
coefficients then depend on the given surge model's shape only, and its scale's uncertainty on the stretch enters
their intervals through the joint jackknife. Each window's surge relaxes towards the thrust–resistance balance
(time constant 4-18 s at 3-12 m/s on the configured boat, within a 20 s window), so a resistance 1 % off pulls the
predicted speed up to ~0.5 % off, which the coefficients otherwise absorbed through the m22·v·r surge coupling
and the speed in every lift term: holding a curve 1 % high moved a_v +9 % (issue 25, docs/live-twin.md)."""
SURGE_FACTOR_KEYS = tuple(p.key for p in SURGE_FACTORS)
LAYOUT_FACTORS = (
    Parameter("thrust_factor", "every thruster's thrust over its map's in the boat file (thrust table / K_T "
              "scale), -", True),
    Parameter("rudder_lift_factor", "every rudder's lift slope f_α over the boat file's, -", True),
)
"""The boat file's actuators' scale (:mod:`boat_twin.vessel.actuators`), fitted with the coefficients by default on
a boat with a propulsion section (the lift factor where it has rudders; :func:`default_free`): a thrust table or
open-water K_T(J) measured elsewhere, or Fujii's lift slope, is rarely exact on the boat. With the surge model held
(m11, Fc), the thrust's scale is seen in the speed the thrust holds and, on a skid-steer boat, in the yaw moment of
differential thrust; the rudder's in its sway force and yaw moment against the held m11·u·r coupling."""
LAYOUT_FACTOR_KEYS = tuple(p.key for p in LAYOUT_FACTORS)
WIND_FACTORS = (
    Parameter("lateral_windage_factor", "lateral windage area (the wind's sway force and yaw moment at the centre "
              "of windage) over the boat's, -", True),
)
"""The lateral wind coefficient's scale, fitted by default where a trial carries a measured wind (a known input:
the wind's own size and direction are the anemometer's, the boat's response to it is fitted). The frontal
coefficient is the surge identification's (:mod:`boat_twin.ident.wind_drag`); the lateral one, from the area
the boat file states or its length carries (``lateral_windage_area_m2`` ∝ L²), is rarely exact: a superstructure,
a mast, the trim."""
WIND_FACTOR_KEYS = tuple(p.key for p in WIND_FACTORS)
FITTABLE = PARAMETERS + SURGE_FACTORS + LAYOUT_FACTORS + WIND_FACTORS
"""Every parameter ``free`` may name, in the order of the correlation matrix."""


def default_free(base: TwinConfig, measured_wind: bool = False) -> tuple[str, ...]:
    """What :func:`fit_manoeuvring` fits unless told: the coefficients, on a boat file's propulsion section its
    thrust factor and, where it has rudders, their lift factor (:data:`LAYOUT_FACTORS`), and with a
    ``measured_wind`` (a trial's anemometer) the lateral windage factor (:data:`WIND_FACTORS`)."""
    layout = base.vessel.propulsion
    wind = WIND_FACTOR_KEYS if measured_wind and base.vessel.lateral_windage_area_m2 > 0.0 else ()
    if layout is None:
        return PARAMETER_KEYS + wind
    return PARAMETER_KEYS + ("thrust_factor",) + (("rudder_lift_factor",) if layout.rudders else ()) + wind

HELD_NOTE = ("held, not fitted: m11 and the resistance Fc(u) (surge: the thrust–speed identification or the given "
             "model), the thrust envelope and {thrust}, the outboards' position x_e, y_e")
SCALED_NOTE = ("held, not fitted: the given surge model (m11 and the shape of Fc(u)) but for the factors fitted with "
               "the coefficients ({fitted}), the thrust envelope and {thrust}, the outboards' position x_e, y_e")
LEVER_ARM_NOTE = ("engine lever arm x_e: the yaw equation holds it only as x_e/m33 (with a_r/m33, x_c·a_v/m33, "
                  "N_rr/m33), so a wrong x_e rescales m33 and the yaw coefficients together; taken as given "
                  "({x_e:+.2f} m), m33, a_r and N_rr are relative to it")
LAYOUT_LEVER_NOTE = ("the boat file's thrusters and rudders are held as given ({where}): the yaw equation holds their "
                     "moments only over m33, so a wrong position or rudder area rescales m33 and the yaw coefficients "
                     "together")
LAYOUT_FACTOR_NOTE = ("fitted with the coefficients: {fitted} (the boat file's thrust map and rudder lift slope "
                      "scaled, their shape held; the thrust's scale rests on the held surge model m11, Fc(u): a "
                      "resistance x % off reads as a thrust x % off)")
WIND_FACTOR_NOTE = ("fitted with the coefficients: lateral_windage_factor, the lateral windage area ({area:g} m² in "
                    "the boat) scaled in the trials' measured wind (a known input), its centre held ({x:+.2f} m)")
TIMING_NOTE = ("STEERING TIMING: the residuals follow the steering's timing (score test t = {t:+.1f}, limit "
               "±{t_limit:g}): the outboards act {delay_s:+.2f} s late (95 % [{low:+.2f}, {high:+.2f}] s, linearized) "
               "against the model, a command delay or actuator lag it lacks; the coefficients and their intervals "
               "absorb it (m22, m33 and the damping biased): model the timing (config) or fix the recording")
PAIR_REASONS = {
    frozenset(("sway_damping_Nspm2", "sway_quadratic_Ns2pm2")):
        "lift a_v·|u|·v and cross-flow Y_vv·|v|·v are told apart by the drift |v| against the speed |u|: "
        "add trials at another speed or with more drift (turning circles, larger steering)",
    frozenset(("yaw_damping_Nms", "yaw_quadratic_Nms2")):
        "a_r·|u|·r and N_rr·|r|·r are told apart by the yaw rate against the speed: add another speed or a "
        "turning circle",
    frozenset(("m22_kg", "sway_damping_Nspm2")):
        "inertia and damping are told apart by the transients: faster steering reversals separate them",
    frozenset(("m33_kgm2", "yaw_damping_Nms")):
        "inertia and damping are told apart by the transients: faster steering reversals separate them",
}
"""Why a pair of parameters can be confounded, when the correlation says so."""


def _start_values(base: TwinConfig) -> dict[str, float]:
    coeff = derive_coefficients(base.vessel)
    values = {key: float(getattr(coeff, key)) for key in MANOEUVRING_KEYS}
    values["lateral_centre_x_m"] = float(coeff.lateral_centre_x_m)
    values["steering_offset_rad"] = float(base.vessel.steering_offset_rad)
    values.update({key: 1.0 for key in SURGE_FACTOR_KEYS + LAYOUT_FACTOR_KEYS + WIND_FACTOR_KEYS})
    return values


def _scaled_layout(base: TwinConfig, thrust_factor: float, lift_factor: float) -> TwinConfig:
    """``base`` with every thruster's thrust factor × ``thrust_factor`` and every rudder's lift slope ×
    ``lift_factor`` (:data:`LAYOUT_FACTORS`)."""
    vessel = base.vessel
    changes: dict[str, Any] = {}
    if thrust_factor != 1.0:
        changes.update(thrust_factor_left=vessel.thrust_factor_left * thrust_factor,
                       thrust_factor_right=vessel.thrust_factor_right * thrust_factor)
    if lift_factor != 1.0 and vessel.propulsion is not None:
        rudders = tuple(replace(r, lift_slope_per_rad=r.lift_slope * lift_factor) for r in vessel.propulsion.rudders)
        changes["propulsion"] = replace(vessel.propulsion, rudders=rudders)
    return replace(base, vessel=replace(vessel, **changes)) if changes else base


def apply_parameters(base: TwinConfig, values: dict[str, float]) -> TwinConfig:
    """``base`` with the manoeuvring ``values`` (keys of :data:`PARAMETER_KEYS`, any subset) put in its vessel."""
    vessel = base.vessel
    manoeuvring = dict(vessel.manoeuvring)
    manoeuvring.update({k: float(v) for k, v in values.items() if k in MANOEUVRING_KEYS})
    changes: dict[str, Any] = {"manoeuvring": manoeuvring}
    for key in ("lateral_centre_x_m", "steering_offset_rad"):
        if key in values:
            changes[key] = float(values[key])
    return replace(base, vessel=replace(vessel, **changes))


FIT_SIGNALS = MOTION_SIGNALS + (LATERAL_ACCEL,)
"""Signals fitted: the replay's motion signals (GNSS velocity, gyro, IMU heading) and the lateral accelerometer
v̇ + u·r, which sees the sway transient that separates m22 from the lift damping (used when the trial records it).
Not the longitudinal accelerometer the diagnosis compares: the turning fit holds the surge model."""


@dataclass(frozen=True)
class TrialData:
    """One trial cut into replay windows, with its sensors' white noise measured from the trial."""

    windows: Windows
    measured: dict[str, np.ndarray]
    """Signal → (T, m) measured values of the fitted signals."""
    noise: dict[str, float]
    """Signal → white-noise standard deviation measured on the trial (SI)."""


START_SAMPLES = 3
"""Gyro samples at a trial's start that :func:`turning_at_start` averages (the replay's initial yaw rate is their
mean), -."""


def turning_at_start(trial: Trial) -> bool:
    """Whether the boat turns as the trial starts: the mean of the first :data:`START_SAMPLES` gyro samples more
    than three of its standard errors (white noise measured on the trial) from zero. The replay's sway observer
    starts from rest (:data:`~boat_twin.twin.replay.SWAY_OBSERVER_S` of run-in before each window, none before the
    first sample): right for a trial that starts running straight, wrong for one cut from a stream mid-turn (the
    sway then scales with the yaw rate, so a rate within the gyro's noise leaves a negligible error)."""
    rate = trial.yaw_rate_radps
    first = rate[:START_SAMPLES][np.isfinite(rate[:START_SAMPLES])]
    noise = white_noise_stdev(rate)
    if first.size == 0 or not np.isfinite(noise):
        return False
    return bool(abs(float(np.mean(first))) > 3.0 * noise / math.sqrt(first.size))


def prepare(trial: Trial, window_s: float = WINDOW_S, noise: dict[str, float] | None = None) -> TrialData:
    """Cut ``trial`` into windows and measure its sensors' noise floor (a trial without a lateral accelerometer
    is fitted without it); ``noise`` (signal → white-noise standard deviation, SI) is taken instead of measured: a
    noise-free simulated trial weighted as a recorded one would be (:mod:`boat_twin.ident.trial_advice`).

    The commands act when they were issued (:attr:`~boat_twin.io.trial.Trial.command_switch_s`, which the replay
    integrates across; issue 25): replayed on the log's grid, a helm changing them between samples biased the
    coefficients (T's independent boats of ``benchmarks/bench_live_adapt.py --only O``: a_r up to +9.0 %, outside
    its interval; docs/studies/manoeuvring.md, "The commands' issue times"). The first window starts after the sway
    observer's run-in when the boat turns at the trial's start (:func:`turning_at_start`) and the trial can spare
    it."""
    try:
        windows = cut_windows(trial, window_s, SWAY_OBSERVER_S if turning_at_start(trial) else 0.0)
    except InputError:  # too short to spare the run-in: the first window starts without it
        windows = cut_windows(trial, window_s)
    index = windows.start_index[None, :] + np.arange(windows.t_s.shape[0])[:, None]
    measured = {**{s: windows.measured[s] for s in MOTION_SIGNALS}, LATERAL_ACCEL: trial.accel_y_mps2[index]}
    if noise is not None:
        return TrialData(windows, {s: measured[s] for s in noise}, dict(noise))
    noise = {}
    for s in FIT_SIGNALS:
        sigma = white_noise_stdev(measured[s])
        if np.isfinite(sigma) and sigma > 0.0:
            noise[s] = sigma
        elif s != LATERAL_ACCEL:
            raise InputError(f"{trial.metadata.source}: no noise level measurable on {s} (constant or missing)")
    return TrialData(windows, {s: measured[s] for s in noise}, noise)


def _normalized_residuals(data: TrialData, prediction: Prediction) -> dict[str, np.ndarray]:
    """Signal → (T, m) measured − predicted over noise (headings wrapped), NaN where not measured; a prediction
    that diverged (non-finite after the window's settling second) counts :data:`DIVERGED_RESIDUAL` per sample."""
    settled = np.arange(data.windows.t_s.shape[0])[:, None] >= int(round(SETTLING_S / data.windows.dt_s))
    out = {}
    for s in data.noise:
        measured, predicted = data.measured[s], prediction.signals[s]
        diverged = settled & np.isfinite(measured) & ~np.isfinite(predicted)
        out[s] = np.where(diverged, DIVERGED_RESIDUAL, residual(s, measured, predicted) / data.noise[s])
    return out


def prediction_error(data: TrialData, config: TwinConfig) -> float:
    """Mean squared residual of ``config``'s replay of ``data``'s windows, each signal over its measured noise
    (the fit's own measure, at the windows' measured initial states): ≈ 1 when the model is right, -."""
    with np.errstate(all="ignore"), warnings.catch_warnings():  # a diverged replay is scored as such
        warnings.simplefilter("ignore", RuntimeWarning)
        residuals = _normalized_residuals(data, predict(data.windows, config))
    return float(np.nanmean(np.concatenate([r.ravel() for r in residuals.values()]) ** 2))


def _steering_late(windows: Windows, samples: int) -> Windows:
    """``windows`` with the steering commands (not the thrust) acting ``samples`` samples late: each sample's
    steering is the trial's from ``samples`` earlier (the first held), and each steering change keeps its issue
    time within its sample (:attr:`~boat_twin.io.trial.Trial.command_switch_s`, moved with it; a thrust change
    keeps its own, the steering's where both change at one sample): every change exactly ``samples`` samples
    late."""
    trial, dt = windows.trial, windows.dt_s
    switch = np.zeros(len(trial)) if trial.command_switch_s is None else trial.command_switch_s
    moved, moved_switch = delayed_commands(trial.commands, switch, dt, samples * dt)
    late = trial.commands.copy()
    late[:, 2:4] = moved[:, 2:4]
    steered = np.concatenate([[False], np.any(late[1:, 2:4] != late[:-1, 2:4], axis=1)])
    thrust = np.concatenate([[False], np.any(late[1:, :2] != late[:-1, :2], axis=1)])
    late_switch = np.where(steered, moved_switch, np.where(thrust, switch, 0.0))
    trial = replace(trial, angle_left_rad=late[:, 2], angle_right_rad=late[:, 3],
                    command_switch_s=late_switch if np.any(late_switch != 0.0) else None)
    return replace(windows, commands=late[windows.index], trial=trial)


DIFFERENCE_STEP = 1e-4
"""Forward-difference step of the Jacobian in fitted coordinates (relative for the logarithmic parameters)."""
INITIAL_STATE_NUISANCES = ((2, 0.005), (3, 0.02))
"""Initial-state components every window estimates for itself (state index, difference step): heading (rad) and
surge (m/s). The sensors give them with errors (±0.3° from the smoothed IMU heading, ±0.016 m/s from ±1 s of GNSS
velocity) that persist through the window (the surge's time constant is tens of seconds; the heading error
rotates the whole path), and those errors, not the signals' noise, dominated the coefficients' errors
(docs/manoeuvring.md). The steps are of the size of those errors. The initial yaw rate (±0.035°/s from the
3-sample mean of the gyro) is taken as measured: estimating it too removed a +5 % a_r bias on the twin's zigzags
but left intervals too narrow on independent integrators' trials (docs/studies/manoeuvring.md, "The commands' issue
times")."""


NUISANCE_PRIOR_WIDENING = 2.0
"""The prior standard deviation of a window's initial heading and surge is this many times what the sensors'
white noise alone leaves after the smoothing of :func:`~boat_twin.twin.replay.measured_motion` (the GNSS
velocity's and the IMU heading's errors are also correlated, which the white-noise figure leaves out)."""


def nuisance_prior_stdev(data: TrialData) -> np.ndarray:
    """(q,) prior standard deviation of the :data:`INITIAL_STATE_NUISANCES` of a window of ``data``: heading (rad),
    the IMU heading noise averaged over the 2h + 1 samples of ±HEADING_SMOOTHING_S; surge (m/s), the GNSS velocity
    noise through the centre value of a local quadratic over the 2h + 1 samples of ±SURGE_SMOOTHING_S (variance
    factor 3(3h² + 3h − 1) / ((2h − 1)(2h + 1)(2h + 3))); both × :data:`NUISANCE_PRIOR_WIDENING`."""
    dt = data.windows.dt_s
    h_heading = max(1, int(round(HEADING_SMOOTHING_S / dt)))
    h = max(2, int(round(SURGE_SMOOTHING_S / dt)))
    quadratic = 3.0 * (3 * h * h + 3 * h - 1) / ((2 * h - 1) * (2 * h + 1) * (2 * h + 3))
    velocity = 0.5 * (data.noise["vel_east_mps"] + data.noise["vel_north_mps"])
    heading = data.noise["heading_rad"] / math.sqrt(2 * h_heading + 1)
    return NUISANCE_PRIOR_WIDENING * np.array([heading, velocity * math.sqrt(quadratic)])


class _Projection:
    """One trial's windows' nuisances, estimated with their prior (linearized variable projection): for residuals
    r of a window with sensitivity S to its own initial-state nuisances δ, the best correction
    δ* = (SᵀS + Λ)⁻¹·Sᵀ·r, Λ = diag(1/σ²) from the prior standard deviations σ, leaves r − S·δ* and the prior's
    own residuals δ*/σ, whose sum of squares is the minimum over δ of |r − S·δ|² + |δ/σ|²."""

    def __init__(self, sensitivity: np.ndarray, prior_stdev: np.ndarray) -> None:
        self.sensitivity = sensitivity
        """(rows, m, q) ∂ residual / ∂ nuisance per window (rows: signals × samples, NaN as 0)."""
        self.prior_stdev = prior_stdev
        normal = np.einsum("rmi,rmj->mij", sensitivity, sensitivity) + np.diag(prior_stdev**-2.0)
        self.inverse = np.linalg.inv(normal)

    def apply(self, residuals: np.ndarray) -> np.ndarray:
        """(rows + q, m, ...) residuals (finite) with each window's best nuisance correction removed, followed
        by the corrections over their prior standard deviations (q rows)."""
        flat = residuals.reshape(residuals.shape[:2] + (-1,))
        step = np.einsum("mij,mjc->mic", self.inverse, np.einsum("rmi,rmc->mic", self.sensitivity, flat))
        corrected = flat - np.einsum("rmi,mic->rmc", self.sensitivity, step)
        prior = step.transpose(1, 0, 2) / self.prior_stdev[:, None, None]
        out = np.concatenate([corrected, prior])
        return out.reshape((out.shape[0],) + residuals.shape[1:])


class _Problem:
    """The least-squares problem: free parameters in fitted coordinates → stacked normalized residuals, each
    window's initial heading and surge profiled out (:data:`INITIAL_STATE_NUISANCES`, :class:`_Projection`).

    Every replay of a set of candidate parameters (the Jacobian's steps, the nuisance sensitivities) is one
    kernel run per trial (:func:`~boat_twin.twin.replay.predict_vessels`); the outboards' angle history,
    which only the steering offset changes, is kept by
    :meth:`~boat_twin.twin.replay.Windows.steering_rad`."""

    def __init__(self, data: Sequence[TrialData], base: TwinConfig, start: dict[str, float],
                 free: Sequence[str]) -> None:
        self.data, self.base, self.start = data, base, start
        self.free = [p for p in FITTABLE if p.key in free]
        self.evaluations = 0
        self.motion = [measured_motion(d.windows, base) for d in data]  # the vessel does not change it
        self.priors = [nuisance_prior_stdev(d) for d in data]
        self._last: tuple[np.ndarray, list[np.ndarray], list[_Projection], list[np.ndarray]] | None = None

    def coordinates(self, values: dict[str, float]) -> np.ndarray:
        """The fitted coordinates of ``values`` (the inverse of :meth:`values`)."""
        return np.array([math.log(values[p.key] / self.start[p.key]) if p.logarithmic
                         else (values[p.key] - self.start[p.key]) / p.scale for p in self.free])

    def values(self, x: np.ndarray) -> dict[str, float]:
        values = dict(self.start)
        for p, xi in zip(self.free, x, strict=True):
            values[p.key] = self.start[p.key] * math.exp(xi) if p.logarithmic else self.start[p.key] + p.scale * xi
        return values

    def config(self, values: dict[str, float]) -> TwinConfig:
        """The model at ``values``: ``base`` with the coefficients and, when fitted, its surge scaled
        (:data:`SURGE_FACTORS`)."""
        base = self.base
        if values["surge_mass_factor"] != 1.0 or values["resistance_factor"] != 1.0:
            base = _scaled_surge(base, math.log(values["surge_mass_factor"]), math.log(values["resistance_factor"]))
        base = _scaled_layout(base, values["thrust_factor"], values["rudder_lift_factor"])
        if values["lateral_windage_factor"] != 1.0:
            area = base.vessel.lateral_windage_area_m2 * values["lateral_windage_factor"]
            base = replace(base, vessel=replace(base.vessel, lateral_windage_area_m2=area))
        return apply_parameters(base, values)

    def _replay(self, xs: Sequence[np.ndarray], nuisances: bool) -> list[list[np.ndarray]]:
        """Per trial, per point of ``xs`` (followed, with ``nuisances``, by the first point with each nuisance
        stepped), the (rows, m) normalized residuals (signals of the trial's noise dict stacked; NaN kept).
        One kernel run per trial and resistance factor (a kernel's boats share one resistance table)."""
        self.evaluations += len(xs)
        configs = [self.config(self.values(x)) for x in xs]
        if nuisances:
            configs += [configs[0]] * len(INITIAL_STATE_NUISANCES)
        groups: dict[float, list[int]] = {}
        for i, x in enumerate(xs):
            groups.setdefault(self.values(x)["resistance_factor"], []).append(i)
        groups[self.values(xs[0])["resistance_factor"]] += list(range(len(xs), len(configs)))
        out = []
        for d, m in zip(self.data, self.motion, strict=True):
            shift = np.zeros((len(configs), d.windows.start_index.size, 6))
            if nuisances:
                for j, (state, step) in enumerate(INITIAL_STATE_NUISANCES):
                    shift[len(xs) + j, :, state] = step
            replays: list[np.ndarray] = [np.empty(0)] * len(configs)
            for members in groups.values():
                config = configs[members[0]]
                vessels = [replace(configs[i].vessel, resistance=config.vessel.resistance) for i in members]
                with np.errstate(all="ignore"), warnings.catch_warnings():  # a diverged replay is scored as such
                    warnings.simplefilter("ignore", RuntimeWarning)
                    predictions = predict_vessels(d.windows, config, vessels, m, initial_shift=shift[members])
                for i, p in zip(members, predictions, strict=True):
                    replays[i] = np.concatenate([r for r in _normalized_residuals(d, p).values()])
            out.append(replays)
        return out

    def evaluate(self, x: np.ndarray) -> tuple[list[np.ndarray], list[_Projection], list[np.ndarray]]:
        """Per trial, the (rows, m) residuals at ``x`` after the nuisance correction (NaN kept), the
        projections and the residuals before it (cached for the last ``x``)."""
        x = np.asarray(x, dtype=float)
        if self._last is not None and np.array_equal(self._last[0], x):
            return self._last[1], self._last[2], self._last[3]
        projected, projections, raw = [], [], []
        for replays, prior in zip(self._replay([x], nuisances=True), self.priors, strict=True):
            r = replays[0]
            finite = np.isfinite(r)
            steps = [step for _, step in INITIAL_STATE_NUISANCES]
            sensitivity = np.stack([np.where(finite & np.isfinite(q), q - r, 0.0) / step
                                    for q, step in zip(replays[1:], steps, strict=True)], axis=-1)
            projection = _Projection(sensitivity, prior)
            kept = np.concatenate([finite, np.ones((len(steps), r.shape[1]), dtype=bool)])
            projected.append(np.where(kept, projection.apply(np.where(finite, r, 0.0)), np.nan))
            projections.append(projection)
            raw.append(r)
        self._last = (x, projected, projections, raw)
        return projected, projections, raw

    def residuals(self, x: np.ndarray) -> list[dict[str, np.ndarray]]:
        """Per trial, signal → (T, m) normalized residuals of the replay from the measured initial states (NaN
        kept)."""
        out = []
        for d, r in zip(self.data, self.evaluate(x)[2], strict=True):
            parts = np.split(r, len(d.noise))
            out.append(dict(zip(d.noise, parts, strict=True)))
        return out

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.concatenate([np.where(np.isfinite(r), r, 0.0).ravel() for r in self.evaluate(x)[0]])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Forward differences of the residuals, steps :data:`DIFFERENCE_STEP`·max(1, |x|), all the steps'
        replays in one kernel run per trial, projected like the residuals (Kaufman's variable-projection
        Jacobian: the projection's own change with x is left out, a second-order term at the solution)."""
        x = np.asarray(x, dtype=float)
        _, projections, raw = self.evaluate(x)
        steps = DIFFERENCE_STEP * np.where(x >= 0.0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
        points = [x + steps[j] * np.eye(x.size)[j] for j in range(x.size)]
        h = np.array([p[j] - x[j] for j, p in enumerate(points)])
        columns = []
        for replays, projection, r in zip(self._replay(points, nuisances=False), projections, raw, strict=True):
            finite = np.isfinite(r)
            derivative = np.stack([np.where(finite & np.isfinite(q), q - r, 0.0) for q in replays], axis=-1) / h
            columns.append(projection.apply(derivative).reshape(-1, x.size))
        return np.concatenate(columns)

    def steering_timing(self, x: np.ndarray, jac: np.ndarray, fun: np.ndarray, p_count: int) -> dict[str, Any]:
        """Score (Lagrange multiplier) test for a steering delay the model lacks, at the solution ``x``.

        The regressor is each residual's change when the steering commands are replayed
        :data:`TIMING_SHIFT_SAMPLES` late (projected like the Jacobian, then orthogonalized against its columns:
        what the fitted coefficients cannot mimic). Its score sᵀr over the cluster-robust standard deviation
        (windows as clusters, as the intervals) is t, ≈ N(0, 1) when the steering acts when commanded; a delay or
        a first-order lag of the steering (a lag τ is a delay τ at the frequencies a zigzag excites) leaves
        residuals along it. The one-step estimate of the delay, −(sᵀr)/(sᵀs)·shift, and its 95 % interval size
        it (linearized: indicative beyond a few tenths of a second)."""
        _, projections, raw = self.evaluate(x)
        config = self.config(self.values(x))
        columns = []
        shift_s = 0.0
        for d, m, projection, r in zip(self.data, self.motion, projections, raw, strict=True):
            late = _steering_late(d.windows, TIMING_SHIFT_SAMPLES)
            shift_s = TIMING_SHIFT_SAMPLES * d.windows.dt_s
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                prediction = predict_vessels(late, config, [config.vessel], m)[0]
            q = np.concatenate(list(_normalized_residuals(d, prediction).values()))
            change = np.where(np.isfinite(r) & np.isfinite(q), q - r, 0.0)
            columns.append(projection.apply(change[..., None]).reshape(-1))
        s = np.concatenate(columns)
        coefficients, *_ = np.linalg.lstsq(jac, s, rcond=None)
        s = s - jac @ coefficients
        clusters = self.clusters()
        score = float(s @ fun)
        groups = np.unique(clusters)
        variance = sum(float(s[clusters == g] @ fun[clusters == g]) ** 2 for g in groups)
        variance *= groups.size / max(groups.size - p_count - 1, 1)
        t_value = score / math.sqrt(variance) if variance > 0.0 else 0.0
        curvature = float(s @ s)
        delay = -score / curvature * shift_s if curvature > 0.0 else 0.0
        half = (float(stdtrit(max(groups.size - p_count - 1, 1), 0.975)) * math.sqrt(variance) / curvature
                * shift_s if curvature > 0.0 else math.inf)
        return {"t": t_value, "flagged": bool(abs(t_value) > TIMING_T_LIMIT), "t_limit": TIMING_T_LIMIT,
                "delay_s": delay, "delay_ci95_s": [delay - half, delay + half]}

    def clusters(self) -> np.ndarray:
        """Window index (over all trials) of every stacked residual."""
        labels, offset = [], 0
        for d in self.data:
            t, m = d.windows.t_s.shape
            rows = len(d.noise) * t + len(INITIAL_STATE_NUISANCES)  # the signals', then the nuisances' priors
            labels.append(np.broadcast_to(offset + np.arange(m), (rows, m)).ravel())
            offset += m
        return np.concatenate(labels)


@dataclass(frozen=True, kw_only=True)
class ManoeuvringFit:
    """A fit and its statistics; :meth:`to_dict` is the ``--json`` contract's ``manoeuvring`` block."""

    values: dict[str, float]
    """Every parameter of :data:`PARAMETER_KEYS` as fitted, and the factors (:data:`SURGE_FACTOR_KEYS`,
    :data:`LAYOUT_FACTOR_KEYS`, :data:`WIND_FACTOR_KEYS`; 1: held)."""
    fitted: list[str]
    ci95: dict[str, tuple[float, float]]
    stderr: dict[str, float]
    """Standard error in fitted coordinates (relative for the logarithmic ones)."""
    correlation: np.ndarray
    """Correlation of the fitted parameters (order of :attr:`fitted`)."""
    window_squares: np.ndarray
    """(G, p, p) J_wᵀJ_w of each window's normalized, projected residuals at the solution, fitted coordinates (order
    of :attr:`fitted`): the Gauss-Newton information is their sum; :mod:`boat_twin.ident.trial_advice` adds a
    candidate trial's windows to them."""
    degrees_of_freedom: dict[str, float]
    """Degrees of freedom of each 95 % interval's t quantile (:func:`interval_degrees_of_freedom`)."""
    not_identified: dict[str, str]
    not_separated: list[dict[str, Any]]
    residual_to_noise: dict[str, float]
    noise: dict[str, float]
    misfit: bool
    windows: int
    trials: list[str]
    evaluations: int
    fit_time_s: float
    config: TwinConfig
    notes: list[str]
    steering_timing: dict[str, Any]
    """The steering-timing check (:meth:`_Problem.steering_timing`): score test ``t``, ``flagged``, the
    linearized delay estimate ``delay_s`` and its ``delay_ci95_s``."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready result (SI)."""
        return {
            "parameters": {k: self.values[k] for k in PARAMETER_KEYS + tuple(
                k for k in SURGE_FACTOR_KEYS + LAYOUT_FACTOR_KEYS + WIND_FACTOR_KEYS if k in self.fitted)},
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "fitted": list(self.fitted),
            "correlation": {"parameters": list(self.fitted), "matrix": np.round(self.correlation, 4).tolist()},
            "not_identified": dict(self.not_identified),
            "not_separated": list(self.not_separated),
            "misfit": self.misfit,
            "steering_timing": dict(self.steering_timing),
            "residual_to_noise": dict(self.residual_to_noise),
            "noise_floor": dict(self.noise),
            "misfit_threshold": {s: MISFIT_RATIO[s] for s in self.residual_to_noise},
            "degrees_of_freedom": dict(self.degrees_of_freedom),
            "windows": self.windows,
            "trials": list(self.trials),
            "evaluations": self.evaluations,
            "fit_time_s": self.fit_time_s,
            "notes": list(self.notes),
        }


def _solve(problem: _Problem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares from the start values: (x, Jacobian, residuals) at the solution."""
    x0 = np.zeros(len(problem.free))
    result = least_squares(problem, x0, jac=problem.jacobian, method="trf", x_scale=1.0,
                           max_nfev=MAX_EVALUATIONS, xtol=1e-4, ftol=1e-6)
    return result.x, np.asarray(result.jac), result.fun


def _scaled_surge(base: TwinConfig, log_mass: float, log_resistance: float) -> TwinConfig:
    """``base`` with its mass and resistance curve scaled by exp(``log_mass``), exp(``log_resistance``)."""
    vessel = base.vessel
    resistance = CorrectedResistance.scaled(vessel.resistance, math.exp(log_resistance))
    return replace(base, vessel=replace(vessel, mass_kg=vessel.mass_kg * math.exp(log_mass), resistance=resistance))


def fit_manoeuvring(trials: Sequence[Trial], base: TwinConfig, window_s: float = WINDOW_S,
                    free: Sequence[str] | None = None) -> ManoeuvringFit:
    """Fit the manoeuvring coefficients ``free`` (keys of :data:`PARAMETER_KEYS`, every one by default) of
    ``base`` (the prior; its surge and the others held) to ``trials``; ``free`` may name the
    :data:`SURGE_FACTOR_KEYS` too, the scale of ``base``'s surge model, which is then fitted with them (its curve's
    shape held) instead of taken as exact, the :data:`LAYOUT_FACTOR_KEYS`, the scale of its thrust and rudder
    lift, and the :data:`WIND_FACTOR_KEYS`. None: :func:`default_free` (every coefficient, a boat file's layout
    factors, and the lateral windage where a trial has a measured wind)."""
    if not trials:
        raise InputError("no trial to fit the manoeuvring coefficients to")
    measured_wind = any(measured_wind_mps(trial) is not None for trial in trials)
    free = default_free(base, measured_wind) if free is None else free
    unknown = sorted(set(free) - {p.key for p in FITTABLE})
    if unknown or not free:
        raise ValueError(f"manoeuvring parameters to fit: unknown {unknown}" if unknown else "nothing to fit")
    started = time.perf_counter()
    data = [prepare(trial, window_s) for trial in trials]
    data = [replace(d, windows=wind_against(d.windows, base)) for d in data]  # a measured wind: a known input
    start = _start_values(base)
    free = [p.key for p in FITTABLE if p.key in free]
    problem = _Problem(data, base, start, free)
    x, jac, fun = _solve(problem)
    evaluations = problem.evaluations
    clusters = problem.clusters()
    cov, groups = jackknife_covariance(jac, fun, clusters)
    stderr = np.sqrt(np.maximum(np.diag(cov), 0.0))
    squares = cluster_squares(jac, clusters)
    dof = interval_degrees_of_freedom(squares)
    quantiles = stdtrit(dof, 0.975)
    values = problem.values(x)
    not_identified = {}
    runaway = {p.key for p, xi in zip(problem.free, x, strict=True)
               if p.logarithmic and abs(xi) > math.log(RUNAWAY_FACTOR)}
    for p, se, quantile in zip(problem.free, stderr, quantiles, strict=True):
        if p.key in runaway:
            not_identified[p.key] = (f"fitted to {values[p.key]:.3g}, beyond a factor {RUNAWAY_FACTOR:g} of its start "
                                     f"{problem.start[p.key]:.3g}: these trials do not bound it (its effect vanished "
                                     "with it), the interval is unbounded")
        elif p.logarithmic and not quantile * se <= math.log(NOT_IDENTIFIED_FACTOR):
            not_identified[p.key] = (f"95 % interval ×/÷ {_factor(quantile * se):.3g}: these trials do not "
                                     "determine it (the value is the best fit, not a measurement)")
        elif not p.logarithmic and not quantile * p.scale * se <= NOT_IDENTIFIED_ABSOLUTE[p.key]:
            not_identified[p.key] = (f"95 % half-interval {quantile * p.scale * se:.3g} exceeds "
                                     f"{NOT_IDENTIFIED_ABSOLUTE[p.key]:.3g}: these trials do not determine it (the "
                                     "value is the best fit, not a measurement)")
    if len(not_identified) == len(free):
        raise InputError("the trials determine none of the manoeuvring coefficients (every 95 % interval is "
                         "wider than the value): record zigzags or turning circles with the steering in the "
                         "commands")
    values = problem.values(x)
    ci95: dict[str, tuple[float, float]] = {}
    for p, se, quantile in zip(problem.free, stderr, quantiles, strict=True):
        v = values[p.key]
        ci95[p.key] = ((0.0, math.inf) if p.key in runaway
                       else (v / _factor(quantile * se), v * _factor(quantile * se)) if p.logarithmic
                       else (v - quantile * p.scale * se, v + quantile * p.scale * se))
    scale = np.where(stderr > 0, stderr, 1.0)
    correlation = cov / np.outer(scale, scale)
    config = problem.config(values)
    residuals = problem.residuals(x)  # a window's own initial state could absorb a misfit
    used = [s for s in FIT_SIGNALS if any(s in d.noise for d in data)]
    ratio = {s: float(np.sqrt(np.nanmean(np.concatenate([r[s].ravel() for r in residuals if s in r]) ** 2)))
             for s in used}
    noise = {s: float(np.median([d.noise[s] for d in data if s in d.noise])) for s in used}
    timing = problem.steering_timing(x, jac, fun, len(free))
    scaled = [key for key in SURGE_FACTOR_KEYS if key in free]
    layout = base.vessel.propulsion
    thrust = "the thrust factors' ratio" if "thrust_factor" in free else "thrust factors"
    notes = [SCALED_NOTE.format(fitted=", ".join(scaled), thrust=thrust) if scaled else HELD_NOTE.format(thrust=thrust),
             LEVER_ARM_NOTE.format(x_e=base.vessel.engine_x_m) if layout is None else LAYOUT_LEVER_NOTE.format(
                 where=", ".join([f"{t.name} x {t.x_m:+.2f} m" for t in layout.thrusters]
                                 + [f"rudder {r.name} x {r.x_m:+.2f} m, {r.area_m2:g} m²" for r in layout.rudders]))]
    layout_fitted = [key for key in LAYOUT_FACTOR_KEYS if key in free]
    if layout_fitted:
        notes.append(LAYOUT_FACTOR_NOTE.format(fitted=", ".join(layout_fitted)))
    if "lateral_windage_factor" in free:
        notes.append(WIND_FACTOR_NOTE.format(area=base.vessel.lateral_windage_area_m2,
                                             x=base.vessel.windage_centre_x_m))
    if timing["flagged"]:
        notes.append(TIMING_NOTE.format(**timing, low=timing["delay_ci95_s"][0], high=timing["delay_ci95_s"][1]))
    return ManoeuvringFit(
        values=values, fitted=list(free), ci95=ci95,
        stderr={p.key: float(se) for p, se in zip(problem.free, stderr, strict=True)},
        correlation=correlation, window_squares=squares,
        degrees_of_freedom={p.key: float(d) for p, d in zip(problem.free, dof, strict=True)},
        not_identified=not_identified,
        not_separated=_not_separated(free, correlation),
        residual_to_noise=ratio, noise=noise, misfit=any(r > MISFIT_RATIO[s] for s, r in ratio.items()),
        windows=groups, trials=[str(t.metadata.source) for t in trials], evaluations=evaluations + 1,
        fit_time_s=time.perf_counter() - started, config=config, notes=notes, steering_timing=timing,
    )


def interval_degrees_of_freedom(squares: np.ndarray) -> np.ndarray:
    """(p,) degrees of freedom of each coefficient's 95 % interval from the windows' J_wᵀJ_w ``squares``: the
    Imbens-Kolesár (Bell-McCaffrey) figure (:func:`~boat_twin.ident.jackknife.cluster_degrees_of_freedom`), at most
    G − p, at least 1: where a few windows carry a coefficient (a turning circle beside two zigzags), G − p credits
    its variance estimate with every window (test/test_jackknife_dof.py). On the hidden boats' trial sets it is
    close to G − p (docs/manoeuvring.md)."""
    groups, p = squares.shape[0], squares.shape[1]
    return np.clip(cluster_degrees_of_freedom(squares.sum(axis=0), squares), 1.0, max(groups - p, 1))


def window_information(fit: ManoeuvringFit, base: TwinConfig, data: Sequence[TrialData]) -> np.ndarray:
    """(G, p, p) J_wᵀJ_w of each window of ``data`` at ``fit``'s solution (its fitted coordinates, ``base`` its
    prior): what those trials would add to :attr:`ManoeuvringFit.window_squares`."""
    problem = _Problem(data, base, _start_values(base), fit.fitted)
    return cluster_squares(problem.jacobian(problem.coordinates(fit.values)), problem.clusters())


def _factor(log_half_width: float) -> float:
    """exp(``log_half_width``), a multiplicative interval's factor; inf where it overflows (a coefficient the
    trials leave free by hundreds of orders of magnitude)."""
    return math.exp(log_half_width) if log_half_width < 700.0 else math.inf


def _not_separated(keys: Sequence[str], correlation: np.ndarray) -> list[dict[str, Any]]:
    """Pairs of fitted parameters the trials do not separate (|ρ| > :data:`SEPARATION_CORRELATION`), and why."""
    out = []
    for i in range(len(keys)):
        for j in range(i + 1, len(keys)):
            rho = float(correlation[i, j])
            if abs(rho) > SEPARATION_CORRELATION:
                why = PAIR_REASONS.get(frozenset((keys[i], keys[j])),
                                       "their effects on the measured signals are nearly proportional on these "
                                       "trials; manoeuvres at other speeds or steering angles separate them")
                out.append({"parameters": [keys[i], keys[j]], "correlation": rho, "why": why})
    return out


TURN_AVERAGING_S = 1.0
"""Positions are averaged over ± this long around the execute and the 180° instant (2.1 m GNSS noise → 0.5 m)."""


def tactical_diameter_m(t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, yaw_rad: np.ndarray,
                        execute_index: int) -> float | None:
    """Transfer when the heading has changed by 180° since the execute (IMO MSC.137(76) tactical diameter), m:
    the displacement normal to the approach heading between the execute and that instant; None if the heading
    never turns that far or no position is known there. Positions are averaged over ±:data:`TURN_AVERAGING_S`
    (both instants are stationary points of the transfer)."""
    change = np.abs(yaw_rad[execute_index:] - yaw_rad[execute_index])
    beyond = np.flatnonzero(change >= math.pi)
    if beyond.size == 0:
        return None
    half = max(0, int(round(TURN_AVERAGING_S / float(np.median(np.diff(t_s))))))
    heading = yaw_rad[execute_index]
    normal = np.array([-math.sin(heading), math.cos(heading)])

    def around(i: int) -> np.ndarray:
        span = slice(max(i - half, 0), i + half + 1)
        east, north = east_m[span], north_m[span]
        known = np.isfinite(east) & np.isfinite(north)
        return np.array([np.mean(east[known]), np.mean(north[known])]) if known.any() else np.full(2, np.nan)

    across = float(abs(normal @ (around(execute_index + int(beyond[0])) - around(execute_index))))
    return across if math.isfinite(across) else None


def gyro_heading(trial: Trial, first: int) -> np.ndarray:
    """Heading from the gyro integrated from ``first``, anchored on the IMU heading's mean over the trial."""
    rate = np.where(np.isfinite(trial.yaw_rate_radps), trial.yaw_rate_radps, 0.0)
    dt = float(np.median(np.diff(trial.t_s)))
    turned = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt)])
    turned -= turned[first]
    return turned + float(np.nanmean(trial.heading_rad[first:] - turned[first:]))


def _rms_or_none(squares: np.ndarray) -> float | None:
    """√(mean of the finite ``squares``), or None when there is none (e.g. a trial without positions)."""
    finite = squares[np.isfinite(squares)]
    return float(np.sqrt(np.mean(finite))) if finite.size else None


def validate(trial: Trial, config: TwinConfig) -> dict[str, Any]:
    """Replay a trial that was not fitted through ``config`` open loop (one window, from its first sample with
    commands and sensors to the last) and report the errors: yaw rate against the gyro, heading against the
    gyro-integrated heading, track against GNSS, and the tactical diameter when the boat turns 180°."""
    commands_known = np.all(np.isfinite(trial.commands), axis=1)
    sensors = np.isfinite(trial.vel_east_mps) & np.isfinite(trial.yaw_rate_radps) & np.isfinite(trial.heading_rad)
    usable = commands_known & sensors
    if not usable.any():
        raise InputError(f"{trial.metadata.source}: no sample with commands and sensors to replay")
    first = int(np.argmax(usable))
    gaps = np.flatnonzero(~commands_known[first:])
    stop = first + (int(gaps[0]) if gaps.size else trial.t_s.size - first)
    index = np.arange(first, stop)[:, None]
    values = {"vel_east_mps": trial.vel_east_mps, "vel_north_mps": trial.vel_north_mps,
              "yaw_rate_radps": trial.yaw_rate_radps, "heading_rad": trial.heading_rad}
    window = Windows(t_s=trial.t_s[index], commands=trial.commands[index],
                     measured={s: values[s][index] for s in MOTION_SIGNALS},
                     position=np.stack([trial.east_m[index], trial.north_m[index]], axis=-1), trial=trial,
                     start_index=np.array([first]))
    prediction = predict(window, with_measured_wind(config, trial))  # one window: the measured wind's mean
    yaw = gyro_heading(trial, first)[first:stop]
    model_yaw = prediction.signals["heading_rad"][:, 0]
    rate_error = trial.yaw_rate_radps[first:stop] - prediction.signals["yaw_rate_radps"][:, 0]
    track_error = window.position[:, 0] - prediction.position[:, 0]
    result: dict[str, Any] = {
        "source": str(trial.metadata.source),
        "duration_s": float(trial.t_s[stop - 1] - trial.t_s[first]),
        "yaw_rate_rmse_degps": math.degrees(float(np.sqrt(np.nanmean(rate_error**2)))),
        "heading_rmse_deg": math.degrees(float(np.sqrt(np.nanmean((yaw - model_yaw) ** 2)))),
        "track_rmse_m": _rms_or_none(np.sum(track_error**2, axis=-1)),
    }
    steering = trial.commands[first:stop, 2]
    changed = np.flatnonzero(np.abs(steering - steering[0]) > 1e-6)
    if changed.size:
        t = trial.t_s[first:stop]
        measured = tactical_diameter_m(t, trial.east_m[first:stop], trial.north_m[first:stop], yaw, int(changed[0]))
        predicted = tactical_diameter_m(t, prediction.position[:, 0, 0], prediction.position[:, 0, 1], model_yaw,
                                        int(changed[0]))
        if measured is not None and predicted is not None:
            result["tactical_diameter_m"] = {"measured": measured, "predicted": predicted,
                                             "error_rel": predicted / measured - 1.0}
    return result
