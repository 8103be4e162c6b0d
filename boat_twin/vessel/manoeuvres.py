"""The IMO manoeuvring figures of a turning circle and a zigzag, by their standard definitions.

Definitions (IMO MSC.137(76), Standards for ship manoeuvrability, §4.2, and MSC/Circ.1053, its explanatory
notes), measured on the track of the boat's reference point (here the centre of gravity) from the *execute*,
the instant the steering order is given:

- **advance**: distance travelled along the original course from the execute to where the heading has
  changed 90°; **transfer**: the distance travelled perpendicular to it, towards the turn, at that point;
- **tactical diameter**: the perpendicular distance at a heading change of 180°;
- **steady turning diameter**: the diameter of the circle the track settles to (a least-squares circle through
  the last 90° of a track that has turned at least 360°), and the **speed loss**: 1 − steady speed / approach
  speed, speed through water;
- **full-astern stopping** (crash stop): from the order for full astern until the boat is dead in the water
  (its speed ahead through the water gone), the **time** that takes, the **track reach** (the distance along the
  path), the **head reach** (along the original course) and the **lateral deviation** (perpendicular to it);
- **zigzag δ/ψ**: steering ±δ reversed whenever the heading deviation from the original heading reaches ±ψ
  (the 1st execute at the start, the 2nd at the first ±ψ, ...); the **first (second) overshoot** is the
  additional heading deviation after the 2nd (3rd) execute; **initial turning time**: from the 1st to the 2nd
  execute; **time to check yaw**: from the 2nd execute to the first heading extreme (yaw rate zero); **period**:
  one full oscillation, from the 2nd to the 4th execute (the same switch crossed the same way).

Criteria (MSC.137(76) §5.2, for ships; a 6 m planing boat is far outside their scope, they are reported as the
usual yardstick): advance ≤ 4.5 L and tactical diameter ≤ 5 L; 10°/10° zigzag: first overshoot ≤ 10° if
L/V < 10 s, ≤ 5 + L/(2V) below 30 s, else 20°, second ≤ 25° / 17.5 + 0.75·L/V / 40°, and no more than 2.5 L
travelled by the 10° heading change; 20°/20° zigzag: first overshoot ≤ 25°; full-astern stopping: track reach
≤ 15 L (§5.3.1.4; up to 20 L for large ships at the Administration's discretion).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from boat_twin.vessel.scenarios import CrashStop, EngineTurningCircle, Scenario, TurningCircle, Zigzag
from boat_twin.vessel.truth import TruthSeries

ADVANCE_LIMIT_L = 4.5
"""IMO criterion: advance at most 4.5 ship lengths (MSC.137(76) §5.2.1)."""
TACTICAL_DIAMETER_LIMIT_L = 5.0
"""IMO criterion: tactical diameter at most 5 ship lengths (MSC.137(76) §5.2.1)."""
TRACK_REACH_LIMIT_L = 15.0
"""IMO criterion: track reach of the full-astern stopping test at most 15 ship lengths (MSC.137(76) §5.3.1.4)."""
STEADY_ARC_RAD = math.pi / 2
"""The steady turning circle is fitted to the last quarter turn of the track, rad."""
STEADY_AFTER_RAD = 2 * math.pi
"""A turn counts as steady once the heading has changed by a full circle, rad."""


@dataclass(frozen=True)
class TurningFigures:
    """Turning-circle figures (m, m/s), None where the track does not reach the heading change they need."""

    length_m: float
    side: str
    """"starboard" or "port": the way the boat turned."""
    approach_speed_mps: float
    advance_m: float | None
    transfer_m: float | None
    tactical_diameter_m: float | None
    steady_diameter_m: float | None
    steady_speed_mps: float | None

    def as_dict(self) -> dict[str, Any]:
        """The figures, in ship lengths too, with the IMO criteria beside them (plain data for JSON)."""
        def lengths(value: float | None) -> float | None:
            return None if value is None else value / self.length_m

        loss = None if self.steady_speed_mps is None else 1.0 - self.steady_speed_mps / self.approach_speed_mps
        return {
            "manoeuvre": "turning circle", "side": self.side, "length_m": self.length_m,
            "approach_speed_mps": self.approach_speed_mps,
            "advance_m": self.advance_m, "advance_L": lengths(self.advance_m), "advance_limit_L": ADVANCE_LIMIT_L,
            "transfer_m": self.transfer_m, "transfer_L": lengths(self.transfer_m),
            "tactical_diameter_m": self.tactical_diameter_m, "tactical_diameter_L": lengths(self.tactical_diameter_m),
            "tactical_diameter_limit_L": TACTICAL_DIAMETER_LIMIT_L,
            "steady_diameter_m": self.steady_diameter_m, "steady_diameter_L": lengths(self.steady_diameter_m),
            "steady_speed_mps": self.steady_speed_mps, "speed_loss": loss,
        }


@dataclass(frozen=True)
class ZigzagFigures:
    """Zigzag δ/ψ figures (degrees, s, m), None where the record ends before the execute they need."""

    steering_deg: float
    switch_deg: float
    length_m: float
    approach_speed_mps: float
    execute_t_s: tuple[float, ...]
    """Times of the executes found (1st = the order to start), s."""
    first_overshoot_deg: float | None
    second_overshoot_deg: float | None
    initial_turning_time_s: float | None
    time_to_check_yaw_s: float | None
    period_s: float | None
    initial_turning_distance_m: float | None
    """Track length from the 1st to the 2nd execute, m (the 10°/10° 'initial turning ability')."""

    def as_dict(self) -> dict[str, Any]:
        """The figures with the IMO criteria that apply to this δ/ψ (None for other angles)."""
        ratio = self.length_m / self.approach_speed_mps  # L/V, s
        first_limit = second_limit = distance_limit = None
        if math.isclose(self.steering_deg, 10.0) and math.isclose(self.switch_deg, 10.0):
            first_limit = 10.0 if ratio < 10.0 else (5.0 + 0.5 * ratio if ratio < 30.0 else 20.0)
            second_limit = 25.0 if ratio < 10.0 else (17.5 + 0.75 * ratio if ratio < 30.0 else 40.0)
            distance_limit = 2.5
        elif math.isclose(self.steering_deg, 20.0) and math.isclose(self.switch_deg, 20.0):
            first_limit = 25.0
        distance = self.initial_turning_distance_m
        return {
            "manoeuvre": f"zigzag {self.steering_deg:g}/{self.switch_deg:g}", "length_m": self.length_m,
            "approach_speed_mps": self.approach_speed_mps, "L_over_V_s": ratio,
            "execute_t_s": list(self.execute_t_s),
            "first_overshoot_deg": self.first_overshoot_deg, "first_overshoot_limit_deg": first_limit,
            "second_overshoot_deg": self.second_overshoot_deg, "second_overshoot_limit_deg": second_limit,
            "initial_turning_time_s": self.initial_turning_time_s, "time_to_check_yaw_s": self.time_to_check_yaw_s,
            "period_s": self.period_s, "initial_turning_distance_m": distance,
            "initial_turning_distance_L": None if distance is None else distance / self.length_m,
            "initial_turning_distance_limit_L": distance_limit,
        }


@dataclass(frozen=True)
class StoppingFigures:
    """Full-astern stopping figures (s, m), None where the record ends before the boat stops."""

    length_m: float
    approach_speed_mps: float
    time_to_stop_s: float | None
    track_reach_m: float | None
    head_reach_m: float | None
    lateral_deviation_m: float | None

    def as_dict(self) -> dict[str, Any]:
        """The figures, the track reach in ship lengths too, with the IMO criterion beside it."""
        reach = self.track_reach_m
        return {
            "manoeuvre": "full astern stopping", "length_m": self.length_m,
            "approach_speed_mps": self.approach_speed_mps, "time_to_stop_s": self.time_to_stop_s,
            "track_reach_m": reach, "track_reach_L": None if reach is None else reach / self.length_m,
            "track_reach_limit_L": TRACK_REACH_LIMIT_L, "head_reach_m": self.head_reach_m,
            "lateral_deviation_m": self.lateral_deviation_m,
        }


def stopping_figures(t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, yaw_rad: np.ndarray,
                     surge_mps: np.ndarray, execute_t_s: float, length_m: float) -> StoppingFigures:
    """Full-astern stopping figures of a track (ENU position, yaw, surge speed through water; samples at ``t_s``)
    whose full-astern order was given at ``execute_t_s``: the boat is dead in the water where its surge first
    falls to zero (interpolated); the track reach is the path length to there (the polyline through the
    samples), the head reach and lateral deviation its displacement along and across the heading at the
    order."""
    start = int(np.searchsorted(t_s, execute_t_s))
    x0, y0, psi0 = (_at(t_s, v, execute_t_s) for v in (east_m, north_m, np.unwrap(yaw_rad)))
    approach = _at(t_s, surge_mps, execute_t_s)
    hit = level_crossing(t_s, surge_mps, 0.0, start)
    if hit is None or approach <= 0.0:
        return StoppingFigures(length_m, approach, None, None, None, None)
    t_stop, i_stop = hit
    t_path = np.concatenate([[execute_t_s], t_s[start:i_stop], [t_stop]])
    east = np.array([_at(t_s, east_m, t) for t in t_path])
    north = np.array([_at(t_s, north_m, t) for t in t_path])
    d = np.array([east[-1] - x0, north[-1] - y0])
    return StoppingFigures(
        length_m=length_m, approach_speed_mps=approach, time_to_stop_s=t_stop - execute_t_s,
        track_reach_m=float(np.sum(np.hypot(np.diff(east), np.diff(north)))),
        head_reach_m=float(d @ np.array([math.cos(psi0), math.sin(psi0)])),
        lateral_deviation_m=float(d @ np.array([-math.sin(psi0), math.cos(psi0)])),
    )


def level_crossing(t_s: np.ndarray, values: np.ndarray, level: float, start: int) -> tuple[float, int] | None:
    """First time at or after sample ``start`` where ``values`` reaches ``level`` (linear interpolation between
    samples), with the index of the sample at or after it; None if never (or ``start`` is past the record)."""
    if start >= values.size:
        return None
    side = np.sign(level - values[start])
    if side == 0:
        return float(t_s[start]), start
    beyond = np.flatnonzero(side * (values[start:] - level) >= 0.0)
    if beyond.size == 0:
        return None
    i = start + int(beyond[0])
    a, b = values[i - 1], values[i]
    frac = (level - a) / (b - a)
    return float(t_s[i - 1] + frac * (t_s[i] - t_s[i - 1])), i


def _at(t_s: np.ndarray, values: np.ndarray, t: float) -> float:
    return float(np.interp(t, t_s, values))


def turning_figures(t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, yaw_rad: np.ndarray,
                    speed_mps: np.ndarray, execute_t_s: float, length_m: float) -> TurningFigures:
    """Turning-circle figures of a track (ENU position, yaw, speed through water; samples at ``t_s``) whose
    steering order was given at ``execute_t_s``; ``length_m`` is the ship length L."""
    yaw = np.unwrap(yaw_rad)
    start = int(np.searchsorted(t_s, execute_t_s))
    psi0, x0, y0 = (_at(t_s, v, execute_t_s) for v in (yaw, east_m, north_m))
    change = yaw - psi0
    turn = 1.0 if change[-1] >= 0.0 else -1.0  # +1: to port (yaw grows, REP-103)
    change = turn * change
    ahead = np.array([math.cos(psi0), math.sin(psi0)])
    towards_turn = turn * np.array([-math.sin(psi0), math.cos(psi0)])

    def offsets(angle: float) -> tuple[float, float] | None:
        hit = level_crossing(t_s, change, angle, start)
        if hit is None:
            return None
        d = np.array([_at(t_s, east_m, hit[0]) - x0, _at(t_s, north_m, hit[0]) - y0])
        return float(d @ ahead), float(d @ towards_turn)

    at90, at180 = offsets(math.pi / 2), offsets(math.pi)
    steady_diameter = steady_speed = None
    if change[-1] >= STEADY_AFTER_RAD:
        arc = change >= change[-1] - STEADY_ARC_RAD
        steady_diameter = 2.0 * _circle_radius(east_m[arc], north_m[arc])
        steady_speed = float(np.mean(speed_mps[arc]))
    return TurningFigures(
        length_m=length_m, side="port" if turn > 0 else "starboard",
        approach_speed_mps=_at(t_s, speed_mps, execute_t_s),
        advance_m=None if at90 is None else at90[0], transfer_m=None if at90 is None else at90[1],
        tactical_diameter_m=None if at180 is None else at180[1],
        steady_diameter_m=steady_diameter, steady_speed_mps=steady_speed,
    )


def _circle_radius(x: np.ndarray, y: np.ndarray) -> float:
    """Radius of the least-squares circle through points (x, y) (Kasa's algebraic fit), m."""
    xm, ym = x - x.mean(), y - y.mean()
    a = np.column_stack([xm, ym, np.ones_like(xm)])
    (cx2, cy2, c), *_ = np.linalg.lstsq(a, xm**2 + ym**2, rcond=None)
    return float(math.sqrt(c + (cx2 / 2) ** 2 + (cy2 / 2) ** 2))


def refined_extreme(t_s: np.ndarray, values: np.ndarray, lo: int, hi: int, side: float) -> tuple[float, float]:
    """(time, value) of the extreme of ``side``·values over samples [lo, hi), refined by a parabola through
    the extreme sample and its neighbours."""
    i = lo + int(np.argmax(side * values[lo:hi]))
    if 0 < i < values.size - 1:
        a, b, c = side * values[i - 1], side * values[i], side * values[i + 1]
        curvature = a - 2 * b + c
        if curvature < 0:
            shift = 0.5 * (a - c) / curvature
            dt = t_s[i + 1] - t_s[i]
            return float(t_s[i] + shift * dt), float(side * (b - 0.25 * (a - c) * shift))
    return float(t_s[i]), float(values[i])


def zigzag_figures(t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray, yaw_rad: np.ndarray,
                   speed_mps: np.ndarray, execute_t_s: float, steering_rad: float, switch_rad: float,
                   length_m: float) -> ZigzagFigures:
    """Zigzag δ/ψ figures of a heading record whose 1st execute was at ``execute_t_s`` (δ = ``steering_rad``,
    ψ = ``switch_rad``; track and speed through water for the initial turning distance and L/V)."""
    yaw = np.unwrap(yaw_rad)
    deviation = yaw - _at(t_s, yaw, execute_t_s)
    start = int(np.searchsorted(t_s, execute_t_s))
    executes, indices = [execute_t_s], [start]
    first = np.flatnonzero(np.abs(deviation[start:]) >= switch_rad)
    side = float(np.sign(deviation[start + first[0]])) if first.size else 0.0
    while side != 0.0:
        hit = level_crossing(t_s, deviation, side * switch_rad, indices[-1])
        if hit is None:
            break
        executes.append(hit[0])
        indices.append(hit[1])
        side = -side
    overshoots: list[float] = []
    checks: list[float] = []
    side = float(np.sign(deviation[indices[1]])) if len(indices) > 1 else 0.0
    for k in range(1, len(indices)):
        hi = indices[k + 1] if k + 1 < len(indices) else deviation.size
        t_extreme, value = refined_extreme(t_s, deviation, indices[k], hi, side)
        if k + 1 == len(indices) and t_extreme >= t_s[-2]:
            break  # still turning that way when the record ends: no extreme yet
        overshoots.append(math.degrees(abs(value) - switch_rad))
        checks.append(t_extreme - executes[k])
        side = -side
    distance = None
    if len(indices) > 1:
        steps = np.hypot(np.diff(east_m), np.diff(north_m))
        path = np.concatenate([[0.0], np.cumsum(steps)])
        distance = _at(t_s, path, executes[1]) - _at(t_s, path, execute_t_s)
    return ZigzagFigures(
        steering_deg=math.degrees(steering_rad), switch_deg=math.degrees(switch_rad), length_m=length_m,
        approach_speed_mps=_at(t_s, speed_mps, execute_t_s), execute_t_s=tuple(executes),
        first_overshoot_deg=overshoots[0] if overshoots else None,
        second_overshoot_deg=overshoots[1] if len(overshoots) > 1 else None,
        initial_turning_time_s=executes[1] - executes[0] if len(executes) > 1 else None,
        time_to_check_yaw_s=checks[0] if checks else None,
        period_s=executes[3] - executes[1] if len(executes) > 3 else None,
        initial_turning_distance_m=distance,
    )


def execute_time_s(scenario: Scenario) -> float | None:
    """When a turning circle or zigzag gives its (first) steering order, or a crash stop its full-astern order,
    s; None for any other scenario."""
    if isinstance(scenario, Zigzag):
        return scenario.approach_s
    if isinstance(scenario, TurningCircle | EngineTurningCircle | CrashStop):
        return scenario.execute_s
    return None


def manoeuvre_figures(scenario: Scenario, truth: TruthSeries, length_m: float) -> dict[str, Any] | None:
    """The IMO figures of a simulated turning circle (at constant thrust or engine setting), zigzag or full-astern
    stop (by the scenario that steered it), as plain data; None for any other scenario."""
    speed = np.hypot(truth.surge_mps, truth.sway_mps)
    track = (truth.t_s, truth.east_m, truth.north_m, truth.yaw_rad, speed)
    execute = execute_time_s(scenario)
    if isinstance(scenario, Zigzag) and execute is not None:
        return zigzag_figures(*track, execute, scenario.steering_rad, scenario.heading_change_rad,
                              length_m).as_dict()
    if isinstance(scenario, TurningCircle | EngineTurningCircle) and execute is not None:
        figures = turning_figures(*track, execute, length_m).as_dict()
        if isinstance(scenario, EngineTurningCircle):
            figures["engine_setting"] = {"shaft_power_W": scenario.shaft_power_W,
                                         "held": "shaft power per outboard (constant engine setting)"}
        else:
            figures["engine_setting"] = {"held": "thrust per outboard (constant thrust command)"}
        return figures
    if isinstance(scenario, CrashStop) and execute is not None:
        return stopping_figures(truth.t_s, truth.east_m, truth.north_m, truth.yaw_rad, truth.surge_mps, execute,
                                length_m).as_dict()
    return None
