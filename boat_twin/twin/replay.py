"""Replay a trial's commands through a model, window by window, and predict what the sensors should have read:
the twin's service to the analyses (the diagnosis judges its residuals, the turning identification fits them).

An open-loop replay of a whole trial drifts (a 1° heading error turns into tens of metres), so the trial is
cut into consecutive windows of ``window_s`` seconds. Each window starts from the state the sensors give at
its first sample — heading from the IMU yaw smoothed with the gyro, yaw rate from the gyro, surge from GNSS
velocity along that heading, sway from a sway observer driven by those measurements — and the model runs the
recorded commands through it (all windows at once, as an ensemble of the dynamics kernel). What a window's
prediction gets wrong is then the model's fault, not an accumulated drift: a multiple-shooting simulation error.

The model is a :class:`~boat_twin.config.TwinConfig`: the vessel, the current, a towed body, and the sensors'
gyro bias (z), the IMU's yaw offset and the GNSS latency, so every catalogue effect of the diagnosis is a change
of that one config (the vessel's command delay and thrust lag included: :meth:`Windows.acting`).
Only commands and sensor streams are used — never ground truth. Imports config, io, sensors and vessel only.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.frames import wrap_pi
from boat_twin.io.trial import Trial
from boat_twin.sensors.gnss import expected_fix
from boat_twin.sensors.um7 import expected_gyro, expected_yaw
from boat_twin.signal_noise import savgol_filter
from boat_twin.validation import number
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.tow import tow_drag_table
from boat_twin.vessel.truth import ground_velocity_enu

MOTION_SIGNALS = ("vel_east_mps", "vel_north_mps", "yaw_rate_radps", "heading_rad")
"""GNSS velocity over ground (ENU), gyro yaw rate, IMU heading: what every window's initial state is read from."""
LONGITUDINAL_ACCEL = "accel_x_mps2"
"""The accelerometer's longitudinal reading u̇ − v·r, m/s² (FLU body; a 3-DOF hull has no gravity on x): it sees a
thrust step when the engines deliver it, not when the GNSS reports its effect, so a GNSS latency, a command delay
and an engine lag move it differently (:data:`SIGNALS`). NaN where the trial has no accelerometer."""
SIGNALS = (*MOTION_SIGNALS, LONGITUDINAL_ACCEL)
"""Measured signals the diagnosis compares: :data:`MOTION_SIGNALS` and the longitudinal accelerometer (a trial
without one compares the others: its samples are NaN, which every sum leaves out)."""
BIAS_FREE_SIGNALS = (LONGITUDINAL_ACCEL,)
"""Signals compared without each window's mean residual: an accelerometer's bias and the hull's trim
(g·sin θ: 0.17 m/s² per degree on x) are unknown and nearly constant over a window, while the timing of a thrust
step, which only this signal carries, is not."""
LATERAL_ACCEL = "accel_y_mps2"
"""The accelerometer's lateral reading v̇ + u·r, m/s² (FLU body), which :func:`predict` also gives (the turning
identification, boat_twin.ident.manoeuvring, fits it: it sees the sway transient that sets m22)."""
ANGLE_SIGNALS = ("heading_rad",)
"""Signals that are angles: their residuals are wrapped to [−π, π) (:func:`~boat_twin.frames.wrap_pi`)."""


def measured_signals(windows: Windows) -> tuple[str, ...]:
    """The :data:`SIGNALS` ``windows`` hold at least one measured sample of (a trial without an accelerometer
    has no :data:`LONGITUDINAL_ACCEL`)."""
    return tuple(s for s in SIGNALS if np.isfinite(windows.measured[s]).any())


def residual(signal: str, measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """measured − predicted of ``signal``; for an angle, wrapped to [−π, π) (a heading 2π off is no error); for
    one of :data:`BIAS_FREE_SIGNALS` ((T, m) windows), less each window's mean over its finite samples."""
    diff = np.asarray(measured) - np.asarray(predicted)
    if signal in ANGLE_SIGNALS:
        return wrap_pi(diff)
    if signal in BIAS_FREE_SIGNALS:
        finite = np.isfinite(diff)
        count = np.sum(finite, axis=0)
        mean = np.sum(np.where(finite, diff, 0.0), axis=0) / np.maximum(count, 1)
        return diff - mean
    return diff


HEADING_SMOOTHING_S = 5.0
"""A window's initial heading averages IMU yaw minus integrated gyro over ± this long, s (3° noise → 0.3°)."""
SETTLING_S = 1.0
"""The first second of every window is not compared: it restates the measurements the window started from."""
REPLAY_INTEGRATION_RATE_HZ = 20.0
"""RK4 rate of the replay, Hz: on a 20°/20° zigzag it differs from the simulator's 50 Hz by < 2e-7 m/s and
< 2e-8 rad/s (far below the sensors' noise) at 2.5× less cost."""
SURGE_SMOOTHING_S = 1.0
"""A window's initial surge is a local quadratic fit to ±this long of GNSS surge, s: 0.05 m/s noise → 0.016 m/s,
and a change of the latency moves the fit smoothly instead of picking another noisy sample (which the surge's
35 s time constant at low speed would carry through the whole window, and a latency fit would exploit)."""
SWAY_OBSERVER_S = 10.0
"""Run-in of the sway observer before each window, s: ~4 sway time constants at 1.5 m/s, 26 at 10 m/s. Over
5 s the sway from rest kept ~0.7 % at 4 m/s (e⁻⁵): 0.002-0.007 m/s, which left the noise-free replay of an
independent integrator's zigzags 0.3-0.9× the gyro's noise off its true yaw rate (docs/identification.md)."""
STEERING_HISTORIES_KEPT = 4
"""Actuator histories (and delayed command series) a :class:`Windows` keeps, the latest."""
MIN_WINDOWS = 6
"""Fewer usable windows than this and a trial cannot be split into training and held-out parts."""
MIN_WINDOW_S = 2.0 * SETTLING_S
"""Shortest window, s: its first :data:`SETTLING_S` is not compared, so at least as long again is."""


@dataclass(frozen=True)
class Windows:
    """A trial cut into ``m`` windows of ``T`` samples: measured signals and commands as (T, m) / (T, m, 4)."""

    t_s: np.ndarray
    """(T, m) trial time of every window sample, s."""
    commands: np.ndarray
    """(T, m, 4) recorded commands (thrust_left_N, thrust_right_N, angle_left_rad, angle_right_rad)."""
    measured: dict[str, np.ndarray]
    """Signal name → (T, m) measured values (NaN where the sensor had no sample, and where a GNSS velocity was
    only interpolated across a lost sample: :attr:`~boat_twin.io.trial.Trial.gnss_bridged`)."""
    position: np.ndarray
    """(T, m, 2) measured GNSS position, local ENU, m (NaN where bridged, as the velocity)."""
    trial: Trial
    start_index: np.ndarray
    """(m,) index into the trial's grid of each window's first sample."""
    wind_departure_mps: np.ndarray | None = None
    """(m, 2) each window's mean measured true wind (east, north) less the trial's mean (:func:`measured_wind_mps`),
    m/s; None: no anemometer. The replay adds it to the config's steady wind, which for a trial with an anemometer
    holds the measured mean (:func:`with_measured_wind`): the twin meets the wind as it was measured, window by
    window."""
    _actuators: dict[tuple[float, ...], np.ndarray] = field(default_factory=dict, init=False, repr=False,
                                                            compare=False)
    """:meth:`actuators` by the actuator parameters it was computed for."""
    _acting: dict[float, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, init=False, repr=False,
                                                                compare=False)
    """:meth:`acting` by command delay."""

    @property
    def dt_s(self) -> float:
        """Sample period, s."""
        return float(self.t_s[1, 0] - self.t_s[0, 0])

    @property
    def index(self) -> np.ndarray:
        """(T, m) index into the trial's grid of every window sample."""
        return self.start_index[None, :] + np.arange(self.t_s.shape[0])[:, None]

    def part(self, columns: slice) -> Windows:
        """The windows ``columns`` of these, sharing the trial's command and actuator series kept here (a replay
        of many vessels run a part of the windows at a time holds only that part's paths)."""
        part = Windows(self.t_s[:, columns], self.commands[:, columns],
                       {name: values[:, columns] for name, values in self.measured.items()},
                       self.position[:, columns], self.trial, self.start_index[columns],
                       None if self.wind_departure_mps is None else self.wind_departure_mps[columns])
        object.__setattr__(part, "_actuators", self._actuators)
        object.__setattr__(part, "_acting", self._acting)
        return part

    def forget(self) -> None:
        """Drop the kept :meth:`actuators` and :meth:`acting` series (each trial-length): a caller whose next
        replays are of other configs keeps only theirs."""
        self._actuators.clear()
        self._acting.clear()

    def acting(self, delay_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The commands (n, 4) the boat acts on over the trial when they act ``delay_s`` after they were issued,
        and their switch times (n,), s after each sample (as
        :meth:`~boat_twin.vessel.dynamics.Dynamics.run` takes them): the recorded commands with the trial's own
        switch times (a helm faster than the grid), moved by the delay (:func:`delayed_commands`)."""
        if delay_s not in self._acting:
            if len(self._acting) >= STEERING_HISTORIES_KEPT:
                del self._acting[next(iter(self._acting))]
            switch = self.trial.command_switch_s
            switch = np.zeros(len(self.trial)) if switch is None else switch
            self._acting[delay_s] = delayed_commands(self.trial.commands, switch, self.dt_s, delay_s)
        return self._acting[delay_s]

    def actuators(self, dynamics: Dynamics) -> np.ndarray:
        """(n, 4) the outboards' angles and the engines' lagged thrust commands over the trial that
        ``dynamics``'s boat gives the commands it acts on (:meth:`acting`, its command delay;
        :meth:`~boat_twin.vessel.dynamics.Dynamics.actuator_history`), read-only. Kept per steering offset,
        limit and rate, thrust lag and delay: a diagnosis replays the same commands hundreds of times."""
        p = dynamics.params
        key = (p.steering_offset_rad, p.max_steering_rad, p.steering_rate_radps, p.thrust_time_constant_s,
               p.command_delay_s)
        if key not in self._actuators:
            if len(self._actuators) >= STEERING_HISTORIES_KEPT:  # a fit of the offset asks a new one each time
                del self._actuators[next(iter(self._actuators))]
            history = dynamics.actuator_history(self.dt_s, *self.acting(p.command_delay_s))
            history.flags.writeable = False
            self._actuators[key] = history
        return self._actuators[key]

    def steering_rad(self, dynamics: Dynamics) -> np.ndarray:
        """(n, 2) the outboards' angles of :meth:`actuators`, rad."""
        return self.actuators(dynamics)[:, :2]


def delayed_commands(commands: np.ndarray, switch_s: np.ndarray, dt_s: float, delay_s: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Commands (n, 4) on a grid ``dt_s`` apart, each taking over ``switch_s`` (n,) after its sample, moved
    ``delay_s`` later: on the same grid, the commands and switch times that act then (a command acts from its
    sample k = round(delay / dt) later, plus the remainder within ±half a sample; before the first the first
    holds). Exact for any delay (no rounding to the grid), and continuous in it."""
    if delay_s == 0.0:
        return commands, switch_s
    shift = int(round(delay_s / dt_s))
    rest = delay_s - shift * dt_s
    source = np.maximum(np.arange(len(commands)) - shift, 0)
    moved = commands[source]
    changed = np.concatenate([[False], np.any(moved[1:] != moved[:-1], axis=1)])
    return moved, np.where(changed, switch_s[source] + rest, 0.0)


def cut_windows(trial: Trial, window_s: float = 20.0, earliest_s: float = 0.0) -> Windows:
    """Cut ``trial`` into consecutive, non-overlapping windows of ``window_s`` with the commands known
    throughout and the sensors sampled at the start, the first starting no earlier than ``earliest_s`` after the
    trial's first sample."""
    t = trial.t_s
    if t.size < 3:
        raise InputError(f"{trial.metadata.source}: too few samples to diagnose ({t.size})")
    dt = float(np.median(np.diff(t)))
    number("--window", window_s, above=0.0)
    length = int(round(window_s / dt))
    if window_s < MIN_WINDOW_S or length < 3:
        raise InputError(f"--window {window_s:g} s: shorter than {MIN_WINDOW_S:g} s or 3 samples at the trial's "
                         f"{1.0 / dt:.3g} Hz")
    if length > t.size:
        raise InputError(f"--window {window_s:g} s: longer than the trial {trial.metadata.source} "
                         f"({t[-1] - t[0]:.1f} s)")
    commands = trial.commands
    known = np.all(np.isfinite(commands), axis=1)
    sensors = np.isfinite(trial.vel_east_mps) & np.isfinite(trial.yaw_rate_radps) & np.isfinite(trial.heading_rad)
    complete = np.convolve((~known).astype(int), np.ones(length, dtype=int), mode="full")[length - 1:] == 0
    candidate = sensors & complete
    starts, i0 = [], int(np.searchsorted(t, t[0] + earliest_s - 1e-9))
    while i0 + length <= t.size:
        if candidate[i0]:
            starts.append(i0)
            i0 += length
        else:
            i0 += 1
    if len(starts) < MIN_WINDOWS:
        absent = [r for r in ("thrust_left", "thrust_right") if r in trial.metadata.missing]
        blank = [what for what, values in (("GNSS velocity (gnss_vel)", trial.vel_east_mps),
                                           ("yaw rate (imu angular velocity)", trial.yaw_rate_radps),
                                           ("heading (imu orientation)", trial.heading_rad))
                 if not np.any(np.isfinite(values))]
        why = (f": the trial has no {' or '.join(absent)} command (a MAVLink log needs --calibration to map its "
               "servo or RC channels)") if absent else (
            f": the trial has no {' and no '.join(blank)}; the replay compares every window's velocity, yaw rate "
            "and heading" if blank else "")
        raise InputError(f"{trial.metadata.source}: only {len(starts)} windows of {window_s:g} s with commands "
                         f"and sensors; the diagnosis needs at least {MIN_WINDOWS}{why}")
    start = np.array(starts)
    index = start[None, :] + np.arange(length)[:, None]
    measured = np.full(t.size, True) if trial.gnss_bridged is None else ~trial.gnss_bridged
    values = {
        "vel_east_mps": np.where(measured, trial.vel_east_mps, np.nan),
        "vel_north_mps": np.where(measured, trial.vel_north_mps, np.nan),
        "yaw_rate_radps": trial.yaw_rate_radps, "heading_rad": trial.heading_rad,
        LONGITUDINAL_ACCEL: trial.accel_x_mps2,
    }
    return Windows(
        t_s=t[index],
        commands=commands[index],
        measured={name: values[name][index] for name in SIGNALS},
        position=np.stack([np.where(measured, trial.east_m, np.nan)[index],
                           np.where(measured, trial.north_m, np.nan)[index]], axis=-1),
        trial=trial,
        start_index=start,
        wind_departure_mps=_wind_departure(trial, index),
    )


def measured_wind_mps(trial: Trial) -> tuple[float, float] | None:
    """The trial's measured true wind over ground (east, north), m/s: its mean over the recording, None without
    an anemometer or a known sample."""
    if trial.wind_east_mps is None or trial.wind_north_mps is None:
        return None
    known = np.isfinite(trial.wind_east_mps) & np.isfinite(trial.wind_north_mps)
    if not np.any(known):
        return None
    return float(np.mean(trial.wind_east_mps[known])), float(np.mean(trial.wind_north_mps[known]))


def with_measured_wind(config: TwinConfig, trial: Trial) -> TwinConfig:
    """``config`` with its steady wind set to ``trial``'s mean measured wind (:func:`measured_wind_mps`; unchanged
    without an anemometer): a measured wind is a known input, and the windows carry how it varied."""
    wind = measured_wind_mps(trial)
    if wind is None:
        return config
    return replace(config, environment=replace(config.environment, wind_east_mps=wind[0], wind_north_mps=wind[1]))


def wind_against(windows: Windows, config: TwinConfig) -> Windows:
    """``windows`` whose measured wind departs from ``config``'s steady wind rather than from the trial's mean:
    replayed through ``config``, every window meets its own measured wind whatever the config holds (a fit of
    several trials with one config; unchanged without an anemometer)."""
    mean = measured_wind_mps(windows.trial)
    if windows.wind_departure_mps is None or mean is None:
        return windows
    env = config.environment
    shift = np.array(mean) - np.array([env.wind_east_mps, env.wind_north_mps])
    return replace(windows, wind_departure_mps=windows.wind_departure_mps + shift)


def _wind_departure(trial: Trial, index: np.ndarray) -> np.ndarray | None:
    """(m, 2) each window's (samples ``index``, (T, m)) mean measured wind less the trial's mean, m/s (0 for a
    window without a known wind sample); None without an anemometer."""
    mean = measured_wind_mps(trial)
    if mean is None or trial.wind_east_mps is None or trial.wind_north_mps is None:
        return None
    wind = np.stack([trial.wind_east_mps[index], trial.wind_north_mps[index]], axis=-1) - np.array(mean)
    known = np.all(np.isfinite(wind), axis=-1, keepdims=True)
    count = known.sum(axis=0)
    return np.where(count > 0, np.where(known, wind, 0.0).sum(axis=0) / np.maximum(count, 1), 0.0)


def _environments(windows: Windows, config: TwinConfig, vessels: int) -> np.ndarray:
    """(vessels·m, 4) the dynamics' environment row of every boat (boat j·m + w: vessel j, window w): the config's
    current and wind, plus each window's measured wind departure (:attr:`Windows.wind_departure_mps`)."""
    rows = np.tile(config.environment.as_vector(), (vessels * windows.start_index.size, 1))
    if windows.wind_departure_mps is not None:
        rows[:, 2:] += np.tile(windows.wind_departure_mps, (vessels, 1))
    return rows


def _centred_mean(values: np.ndarray, half: int) -> np.ndarray:
    """Moving mean over ±``half`` samples, NaN-aware (NaN where the whole span is NaN)."""
    finite = np.isfinite(values)
    filled = np.where(finite, values, 0.0)
    kernel = np.ones(2 * half + 1)
    total = np.convolve(filled, kernel, mode="same")
    count = np.convolve(finite.astype(float), kernel, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1.0), np.nan)


def _local_quadratic(values: np.ndarray, half: int) -> np.ndarray:
    """Least-squares quadratic over ±``half`` samples evaluated at the centre (Savitzky-Golay), NaN kept NaN.

    Unlike a moving mean it follows the surge's curvature after a thrust step without bias; gaps are bridged
    linearly for the filter only.
    """
    finite = np.isfinite(values)
    if finite.sum() <= 2 * half + 1:
        return values
    index = np.arange(values.size)
    filled = np.interp(index, index[finite], values[finite])
    return np.where(finite, savgol_filter(filled, 2 * half + 1, 2), np.nan)


def _integrated(rate: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoid integral of ``rate`` from sample 0, same length, NaN treated as 0."""
    r = np.where(np.isfinite(rate), rate, 0.0)
    return np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)])


def _sway_observer(windows: Windows, config: TwinConfig, dynamics: Dynamics, heading: np.ndarray,
                   surge: np.ndarray, yaw_rate: np.ndarray, actuators: np.ndarray,
                   columns: np.ndarray | None = None) -> np.ndarray:
    """(k·m,) sway through water at each window's start, m/s, for each of the ``k`` vessels of ``dynamics``
    (boat j·m + w: vessel j, window w): the model's sway equation run over the :data:`SWAY_OBSERVER_S` before
    it, from rest, driven by the commands the boat acts on (at their switch times) and the *measured* heading,
    surge (GNSS) and yaw rate (gyro) of the whole trial (``heading``, ``surge``, ``yaw_rate``: trial-length) and
    the outboards' angles and lagged thrust those commands drive on each vessel (``actuators``, (n, k, 4); or
    (n, u, 4) with ``columns`` (k,) the column of each vessel, when vessels share one).
    Each sample step is the kernel's RK4 step from the measured state with the observer's sway (the sway it
    ends with is kept, the rest is measured again at the next sample).

    Sway is a fast state (time constant m22 / (Y_v·u): 0.4 s at 10 m/s), so it forgets its start; the gyro
    that drives it through the m11·u·r term is 50× less noisy than a sway read from GNSS velocity and IMU
    heading (±0.06 m/s), which at low speed turns into a spurious turn of several degrees per window.
    Samples without commands or sensors hold the sway. Each window's observer runs in that window's
    environment (:func:`_environments`: the config's current and wind plus the window's measured wind).
    """
    columns = np.arange(actuators.shape[1]) if columns is None else np.asarray(columns)
    acting, switch = windows.acting(config.vessel.command_delay_s)
    return dynamics.observe_sway(np.tile(windows.start_index, columns.size),
                                 np.repeat(columns, windows.start_index.size),
                                 int(round(SWAY_OBSERVER_S / windows.dt_s)), heading, surge, yaw_rate, acting, switch,
                                 actuators, _environments(windows, config, columns.size),
                                 windows.dt_s)


@dataclass(frozen=True)
class MeasuredMotion:
    """Trial-length heading (rad), surge through water (m/s) and yaw rate (rad/s) from the sensors, as a
    config's sensors and current say they err (:func:`measured_motion`): the same for every vessel, so a fit of
    vessel coefficients computes it once."""

    heading_rad: np.ndarray
    surge_mps: np.ndarray
    yaw_rate_radps: np.ndarray


def measured_motion(windows: Windows, config: TwinConfig) -> MeasuredMotion:
    """Heading: mean over ±:data:`HEADING_SMOOTHING_S` of IMU yaw with the gyro's turn removed (the 3° IMU yaw
    noise drops to ~0.3°), less the IMU's yaw offset; yaw rate: gyro − bias, 3-sample mean; surge through water:
    the GNSS velocity stamped t + latency (it describes t) minus the current, along that heading, averaged over
    ±:data:`SURGE_SMOOTHING_S` by a local quadratic. Uses ``config``'s gyro bias, yaw offset, GNSS latency and
    current only."""
    trial, dt = windows.trial, windows.dt_s
    bias = float(config.um7.gyro_bias_radps[2])
    half = max(1, int(round(HEADING_SMOOTHING_S / dt)))
    turned = _integrated(trial.yaw_rate_radps - bias, dt)
    heading = _centred_mean(trial.heading_rad - turned, half) + turned - config.um7.yaw_offset_rad
    yaw_rate = _centred_mean(trial.yaw_rate_radps, 1) - bias
    stamped = trial.t_s + float(config.gnss.latency_s)
    env = config.environment
    we = np.interp(stamped, trial.t_s, trial.vel_east_mps) - env.current_east_mps
    wn = np.interp(stamped, trial.t_s, trial.vel_north_mps) - env.current_north_mps
    surge = _local_quadratic(we * np.cos(heading) + wn * np.sin(heading), max(2, int(round(SURGE_SMOOTHING_S / dt))))
    return MeasuredMotion(heading, surge, yaw_rate)


def motion_key(config: TwinConfig) -> tuple[float, ...]:
    """What of ``config`` :func:`measured_motion` uses: configs with equal keys have the same measured motion
    (a caller keeps it across the evaluations of a fit that varies other parameters)."""
    env = config.environment
    return (float(config.um7.gyro_bias_radps[2]), float(config.um7.yaw_offset_rad), float(config.gnss.latency_s),
            float(env.current_east_mps), float(env.current_north_mps))


def initial_states(windows: Windows, config: TwinConfig, dynamics: Dynamics, actuators: np.ndarray,
                   motion: MeasuredMotion | None = None, columns: np.ndarray | None = None) -> np.ndarray:
    """(k·m, 6) state at each window's start for each of the ``k`` vessels of ``dynamics`` (boat j·m + w:
    vessel j, window w), from the sensors as ``config`` says they err (``actuators``: the outboards' angles and
    lagged thrust over the trial on each vessel, (n, k, 4), :meth:`Windows.actuators`; or (n, u, 4) with
    ``columns`` (k,) the column of each vessel).

    Heading, surge and yaw rate: :func:`measured_motion` (``motion``, if already computed for ``config``'s
    sensors and current); sway: the :func:`_sway_observer`. Every term is a measurement or driven by
    measurements, so initialization errors are noise with zero mean, never a bias that a catalogue effect could
    absorb.
    """
    motion = motion or measured_motion(windows, config)
    columns = np.arange(actuators.shape[1]) if columns is None else np.asarray(columns)
    start = np.tile(windows.start_index, columns.size)
    states = np.zeros((start.size, 6))
    states[:, 2] = motion.heading_rad[start]
    states[:, 3] = motion.surge_mps[start]
    states[:, 4] = _sway_observer(windows, config, dynamics, motion.heading_rad, motion.surge_mps,
                                  motion.yaw_rate_radps, actuators, columns)
    states[:, 5] = motion.yaw_rate_radps[start]
    return states


@dataclass(frozen=True)
class Prediction:
    """What ``config`` predicts the sensors read, window by window: signal name → (T, m), and position (T, m, 2)."""

    signals: dict[str, np.ndarray]
    position: np.ndarray


def predict(windows: Windows, config: TwinConfig, motion: MeasuredMotion | None = None) -> Prediction:
    """Run every window's commands through ``config``'s model from its measured initial state; the sensors read
    the path as their expected-measurement functions say (:func:`~boat_twin.sensors.gnss.expected_fix`: velocity
    over ground and position delayed by the GNSS latency; :func:`~boat_twin.sensors.um7.expected_gyro`: yaw rate
    plus the gyro bias), noise-free; and the accelerometer (:data:`LONGITUDINAL_ACCEL`, u̇ − v·r;
    :data:`LATERAL_ACCEL`, v̇ + u·r).
    ``motion``: :func:`measured_motion` for ``config``'s sensors and current, when the caller keeps it."""
    return predict_vessels(windows, config, [config.vessel], motion)[0]


def predict_vessels(windows: Windows, config: TwinConfig, vessels: Sequence[VesselParams],
                    motion: MeasuredMotion | None = None, initial_shift: np.ndarray | None = None
                    ) -> list[Prediction]:
    """:func:`predict` for ``config`` with each of ``vessels`` in turn (they share ``config.vessel``'s resistance
    model), in one run of the dynamics kernel: the windows of every vessel are boats of one ensemble, which
    saves the per-call overhead when a fit replays the same windows through several candidate vessels. Each
    vessel's outboard angles and lagged thrust over the trial come from :meth:`Windows.actuators` (kept there).
    ``initial_shift``: (vessels, m, 6) added to the measured initial states (a fit that estimates a window's
    initial state instead of taking the sensors' word for it)."""
    m = windows.start_index.size
    drag = tow_drag_table(config.tow, config.vessel)
    dynamics = Dynamics(config.vessel, drag, boats=[v for v in vessels for _ in range(m)])
    column: dict[int, int] = {}  # a vessel given several times (a projection's nuisance steps): one history
    columns = np.array([column.setdefault(id(v), len(column)) for v in vessels])
    distinct = list({id(v): v for v in vessels}.values())
    history = np.stack([windows.actuators(dynamics if v is config.vessel else Dynamics(v)) for v in distinct],
                       axis=1)  # config.vessel's: the ensemble's own model (its coefficients, its params)
    states = initial_states(windows, config, dynamics, history, motion, columns)
    if initial_shift is not None:
        states += initial_shift.reshape(states.shape)
    substeps = max(1, int(round(windows.dt_s * REPLAY_INTEGRATION_RATE_HZ)))
    environments = _environments(windows, config, len(vessels))
    acting, switch = windows.acting(config.vessel.command_delay_s)
    index = windows.index
    commands = np.tile(acting[index], (1, len(vessels), 1))
    switching = None
    if np.any(switch[index] != 0.0):
        switching = np.tile(switch[index], (1, len(vessels)))
    before = np.tile(acting[np.maximum(windows.start_index - 1, 0)], (len(vessels), 1))
    start = history[windows.start_index][:, columns].transpose(1, 0, 2).reshape(-1, 4)
    path, rates, _ = dynamics.run(states, commands, environments, windows.dt_s / substeps, substeps,
                                  np.ascontiguousarray(start[:, :2]), np.ascontiguousarray(start[:, 2:]),
                                  switching, before)
    east, north, yaw, u, v, r = (path[..., j] for j in range(6))
    env = config.environment
    vel_east, vel_north = ground_velocity_enu(yaw, u, v, env.current_east_mps, env.current_north_mps)
    window_t_s = np.arange(path.shape[0]) * windows.dt_s
    fix = expected_fix(config.gnss, window_t_s, east, north, vel_east, vel_north)  # delayed; held at the start
    skip = int(round(SETTLING_S / windows.dt_s))
    signals = {"vel_east_mps": fix.vel_east_mps, "vel_north_mps": fix.vel_north_mps,
               "yaw_rate_radps": expected_gyro(config.um7, r)[..., 2], "heading_rad": expected_yaw(config.um7, yaw),
               LONGITUDINAL_ACCEL: rates[..., 3] - r * v, LATERAL_ACCEL: rates[..., 4] + r * u}
    position = np.stack([fix.east_m, fix.north_m], axis=-1)
    for values in (*signals.values(), position):
        values[:skip] = np.nan
    out = []
    for j in range(len(vessels)):
        boats = slice(j * m, (j + 1) * m)
        place = position[:, boats]
        with warnings.catch_warnings():  # a window without one measured position keeps a NaN offset
            warnings.simplefilter("ignore", RuntimeWarning)
            offset = np.nanmean(windows.position - place, axis=0)  # each window's start position: a nuisance
        out.append(Prediction(signals={name: values[:, boats] for name, values in signals.items()},
                              position=place + offset[None, :, :]))
    return out
