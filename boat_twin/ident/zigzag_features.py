"""The 42 zigzag features of Pashentsev (2025): 6 events × 7 values, from a zigzag record (truth or measured).

Pashentsev, S. V. (2025) "Zigzag maneuvering test and trained neural network as tools for adequate
identification of the mathematical model of vessel motion", Vestnik of MSTU 28(4/1), 558-571: a zigzag is
summarised by the boat's state at six events, found in turn by the paper's two alternating searches —

- *equality* (events 1, 3, 5): the heading deviation from the initial heading reaches the rudder angle
  (the paper's ``delRuldK`` changing sign; its helm reverses the rudder there, so these are the instants "the
  rudder begins to swing from side to side");
- *extreme* (events 2, 4, 6): the largest heading deviation (the overshoot) before the next equality —

and at each event seven values: time, position x, y, speed V, heading deviation, rudder angle, yaw rate.
The rudder angle is the *actual* one, the steering actuator's position as the paper's simulator records it
(``Rulzig = rulk``), when the record has it (:attr:`ZigzagRecord.rudder_rad`: the simulator's actuator state,
or a rudder-angle indicator); it trails the command at the steering rate and differs from it by the steering
offset. Without it the commanded angle stands in, and then the rudder at every event and the deviation at the
equalities are the constants ±δ (9 of the 42 features).
Conventions here: time from the first execute (the first non-zero steering command), s; x along and y to port
of the approach heading from the position at the execute, m; speed over ground, m/s; heading deviation
*in the steering's sense* (positive: turned the way a positive steering angle turns the boat, to starboard),
rad; the rudder angle (mean of the two outboards), rad; yaw rate (REP-103: positive to port), rad/s. The
heading and position at the execute come from a straight-line fit over the last :data:`REFERENCE_WINDOW_S` of
the approach (noise of a measured record averages out; exact on a straight approach). Equalities are
interpolated linearly between samples (the zero of deviation − rudder) and extremes refined by a parabola
(:func:`~boat_twin.vessel.manoeuvres.level_crossing`, :func:`~boat_twin.vessel.manoeuvres.refined_extreme`, the
code of the IMO zigzag figures); the other values are interpolated linearly at the event's time (a commanded
rudder held, zero-order, as commanded).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.manoeuvring import gyro_heading
from boat_twin.io.trial import Trial
from boat_twin.twin.sea_trial import measured_trial
from boat_twin.vessel.manoeuvres import level_crossing, refined_extreme
from boat_twin.vessel.simulate import SimulationRecord

EVENTS = ("equality_1", "extreme_1", "equality_2", "extreme_2", "equality_3", "extreme_3")
"""The six events, in the order they happen."""
VALUES = ("t_s", "x_m", "y_m", "speed_mps", "heading_deviation_rad", "rudder_rad", "yaw_rate_radps")
"""The seven values recorded at each event."""
FEATURE_NAMES = tuple(f"{e}.{v}" for e in EVENTS for v in VALUES)
"""The 42 feature names, event-major (the order of :func:`zigzag_features` flattened)."""
REFERENCE_WINDOW_S = 3.0
"""Span of the approach (before and at the execute) fitted by a straight line for the initial heading and
position, s."""
STEERING_EPS_RAD = 1e-6
"""A steering command beyond this is an execute, rad."""


@dataclass(frozen=True)
class ZigzagRecord:
    """A zigzag on one time grid (n,): positions ENU (m), heading (ENU yaw, rad, wrapped or not), speed over
    ground (m/s), yaw rate (rad/s), the commanded steering angle (rad; its first non-zero sample is the execute)
    and, when known, the actual rudder (steering actuator) angle (rad)."""

    t_s: np.ndarray
    east_m: np.ndarray
    north_m: np.ndarray
    heading_rad: np.ndarray
    speed_mps: np.ndarray
    yaw_rate_radps: np.ndarray
    steering_rad: np.ndarray
    source: str = "zigzag record"
    rudder_rad: np.ndarray | None = None
    """The outboards' actual angle (mean of the two), rad; None: not recorded (the command stands in)."""


def _straight_fit_at(t_s: np.ndarray, values: np.ndarray, t: float) -> float:
    """Value at ``t`` of the least-squares straight line through the finite samples."""
    ok = np.isfinite(values)
    if ok.sum() < 2:
        return float(values[ok][0]) if ok.any() else float("nan")
    slope, intercept = np.polyfit(t_s[ok] - t, values[ok], 1)
    return float(intercept)


def zigzag_features(record: ZigzagRecord) -> np.ndarray:
    """(6, 7) values (:data:`VALUES`) at the six events (:data:`EVENTS`) of ``record``; a record without an
    execute, or ending before its third extreme, is an :class:`InputError` naming what is missing."""
    t = np.asarray(record.t_s, dtype=float)
    steering = np.asarray(record.steering_rad, dtype=float)
    executed = np.flatnonzero(np.abs(steering) > STEERING_EPS_RAD)
    if executed.size == 0:
        raise InputError(f"{record.source}: no steering command, so no zigzag execute")
    start = int(executed[0])
    t0 = float(t[start])
    approach = (t >= t0 - REFERENCE_WINDOW_S - 1e-9) & (t <= t0 + 1e-9)
    yaw = np.array(record.heading_rad, dtype=float)
    known = np.isfinite(yaw)
    yaw[known] = np.unwrap(yaw[known])
    psi0 = _straight_fit_at(t[approach], yaw[approach], t0)
    x0 = _straight_fit_at(t[approach], record.east_m[approach], t0)
    y0 = _straight_fit_at(t[approach], record.north_m[approach], t0)
    deviation = -(yaw - psi0)  # steering sense: a positive angle turns the boat to starboard (yaw falls)
    ahead, port = np.array([np.cos(psi0), np.sin(psi0)]), np.array([-np.sin(psi0), np.cos(psi0)])
    d_east, d_north = record.east_m - x0, record.north_m - y0
    x_along, y_port = ahead[0] * d_east + ahead[1] * d_north, port[0] * d_east + port[1] * d_north
    columns = (x_along, y_port, np.asarray(record.speed_mps, dtype=float),
               np.asarray(record.yaw_rate_radps, dtype=float))

    def row(t_event: float, deviation_value: float, steering_value: float) -> list[float]:
        interpolated = [float(np.interp(t_event, t, c)) for c in columns]
        return [t_event - t0, *interpolated[:3], deviation_value, steering_value, interpolated[3]]

    actual = record.rudder_rad is not None
    rudder = np.asarray(record.rudder_rad, dtype=float) if actual else steering

    def equality(index: int) -> tuple[float, int] | None:
        """The next zero of deviation − rudder from ``index``; a commanded rudder is a step (the helm may flip it
        between two samples of the crossing), so its level is the command in force at ``index``."""
        level = rudder if actual else float(steering[index])
        return level_crossing(t, deviation - level, 0.0, index)

    rows: list[list[float]] = []
    swung = np.flatnonzero(np.abs(rudder[start:]) >= 0.5 * abs(float(steering[start])))
    if swung.size == 0:
        raise InputError(f"{record.source}: the rudder never follows the steering command")
    index = start + int(swung[0])  # the rudder on its side: deviation − rudder is clearly below zero
    hit = equality(index)
    for k in range(3):
        if hit is None:
            raise InputError(f"{record.source}: the heading deviation never reaches the rudder angle "
                             f"(zigzag equality {k + 1} of 3): record too short?")
        t_equal, i_equal = hit
        at_equal = float(np.interp(t_equal, t, rudder)) if actual else float(steering[index])
        side = float(np.sign(at_equal))
        rows.append(row(t_equal, float(np.interp(t_equal, t, deviation)), at_equal))
        if actual:
            index = i_equal + 1 if deviation[i_equal] == rudder[i_equal] else i_equal
        else:
            reversed_at = np.flatnonzero(np.sign(steering[i_equal:]) == -side)
            if reversed_at.size == 0:
                raise InputError(f"{record.source}: the steering is not reversed after zigzag equality {k + 1}")
            index = i_equal + int(reversed_at[0])
        hit = equality(index)
        end = hit[1] if hit is not None else t.size
        t_extreme, value = refined_extreme(t, deviation, i_equal, end, side)
        if hit is None and t_extreme >= t[-2]:
            raise InputError(f"{record.source}: the record ends before zigzag extreme {k + 1} of 3")
        if actual:
            at_extreme = float(np.interp(t_extreme, t, rudder))
        else:  # a command holds until the next one
            at_extreme = float(steering[int(np.searchsorted(t, t_extreme, side="right")) - 1])
        rows.append(row(t_extreme, value, at_extreme))
    return np.array(rows)


def ensemble_features(record: SimulationRecord, actual_rudder: bool = True) -> np.ndarray:
    """(N, 42) features of every boat of a simulated zigzag ensemble (truth, no noise, the outboards' actual
    angle as the rudder; ``actual_rudder`` False: the commanded angle instead); a boat whose record lacks an
    event gets a row of NaN."""
    states = record.states
    out = np.full((states.shape[1], len(FEATURE_NAMES)), np.nan)
    for b in range(states.shape[1]):
        truth = record.truth(b)
        zigzag = ZigzagRecord(record.t_s, truth.east_m, truth.north_m, truth.yaw_rad,
                              np.hypot(truth.vel_east_mps, truth.vel_north_mps), truth.yaw_rate_radps,
                              record.commands[:, b, 2:4].mean(axis=1), source=f"boat {b}",
                              rudder_rad=record.steering_rad[:, b].mean(axis=1) if actual_rudder else None)
        try:
            out[b] = zigzag_features(zigzag).ravel()
        except InputError:
            continue
    return out


def measured_ensemble_features(record: SimulationRecord, config: TwinConfig, seeds: np.ndarray) -> np.ndarray:
    """(N, 42) features every boat of a simulated zigzag ensemble gives as a recorded trial: its truth measured
    by the sensor models of ``config`` (boat ``b``'s noise seeded by ``seeds[b]``,
    :func:`~boat_twin.twin.sea_trial.measured_trial`) and summarised by :func:`trial_features`; a boat whose
    record lacks an event gets a row of NaN."""
    out = np.full((record.states.shape[1], len(FEATURE_NAMES)), np.nan)
    for b in range(out.shape[0]):
        try:
            out[b] = trial_features(measured_trial(record, b, config, np.random.default_rng(int(seeds[b])))).ravel()
        except InputError:
            continue
    return out


def trial_features(trial: Trial) -> np.ndarray:
    """(6, 7) features of a recorded zigzag trial: GNSS position and speed, gyro yaw rate, the outboards' actual
    angle when the trial has it (:attr:`~boat_twin.io.trial.Trial.actual_angle_rad`; else the command), and the
    heading integrated from the gyro (:func:`~boat_twin.ident.manoeuvring.gyro_heading`): the IMU's
    own heading is too noisy for the extremes (a maximum of noisy samples overstates the overshoot)."""
    heading = gyro_heading(trial, int(np.argmax(np.isfinite(trial.yaw_rate_radps))))
    zigzag = ZigzagRecord(trial.t_s, trial.east_m, trial.north_m, heading, trial.speed_mps,
                          trial.yaw_rate_radps, 0.5 * (trial.angle_left_rad + trial.angle_right_rad),
                          source=str(trial.metadata.source), rudder_rad=trial.actual_angle_rad)
    return zigzag_features(zigzag)
