"""The catalogue of physical causes: each a parametric extension of the twin's model (a change of its config).

| effect | parameters (SI) | what changes in the :class:`~boat_twin.config.TwinConfig` |
| --- | --- | --- |
| ``water_current`` | ``east_mps``, ``north_mps`` | ``environment.current_*`` += (east, north) |
| ``gyro_bias`` | ``bias_radps`` | ``um7.gyro_bias_radps[2]`` += bias |
| ``gnss_latency`` | ``delay_s`` | ``gnss.latency_s`` = delay |
| ``thrust_asymmetry`` | ``left_factor``, ``right_factor`` | ``vessel.thrust_factor_*`` = factor |
| ``steering_offset`` | ``offset_rad`` | ``vessel.steering_offset_rad`` += offset |
| ``mass_error`` | ``mass_factor`` | ``vessel.mass_kg`` ×= factor (every inertia and derived damping follows) |
| ``resistance_shape`` | ``change_at_<u>_mps`` per knot | ``vessel.resistance`` ×= 1 + piecewise-linear change(u) |
| ``tow_load`` | ``drag_scale`` | ``tow`` = the packaged towed body on 50 m, drag × scale |

Each parameter has a *null* value (the effect absent) and a *scale* (a size the data resolve easily), so the
fit works in ``x = (p − null) / scale``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.vessel.resistance import CorrectedResistance
from boat_twin.vessel.tow import TowConfig

EFFECT_NAMES = ("water_current", "gyro_bias", "gnss_latency", "thrust_asymmetry", "steering_offset", "mass_error",
                "resistance_shape", "tow_load")
"""Canonical names, in the order the report lists them."""
MIN_SIZES = {
    "water_current": 0.075,  # m/s, current speed
    "gyro_bias": 0.0025,  # rad/s
    "gnss_latency": 0.15,  # s, change of the latency
    "thrust_asymmetry": 0.04,  # largest |factor − 1|
    "steering_offset": 0.013,  # rad (0.75°)
    "mass_error": 0.10,  # |mass_factor − 1|
    "resistance_shape": 0.05,  # largest |change| of the resistance
    "tow_load": 0.3,  # drag_scale
}
"""The smallest size the diagnosis names: half the size it promises to detect (README "Diagnosis").
Zero-mean errors of the replay's initial states (sensor noise carried through the hull's dynamics)
leave spurious fits of up to ~0.02 m/s of current or ~3 % of mass on clean 10-minute trials: real, stable
across the trial, but not a cause worth naming."""
RESISTANCE_CHANGE_RANGE = (-0.5, 1.0)
"""Physical range of a resistance change, fraction of Fc: the hull's resistance at most halves or doubles
(fouling adds tens of percent, as does a heavier load or a planing regime reached earlier or later). A fit
that wants more — a tripled resistance at 1-2 m/s — is taking up something else, e.g. a towed body's drag."""
RESISTANCE_KNOTS = 5
"""Knots of the resistance correction k(u), at evenly spaced quantiles of the speeds the trial visited."""
MIN_KNOT_SPACING_MPS = 0.1
"""Smallest distance between two knots of the resistance correction, m/s."""


@dataclass(frozen=True)
class Effect:
    """One cause: its parameters and how they extend a model."""

    name: str
    parameter_names: tuple[str, ...]
    null: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    apply: Callable[[TwinConfig, np.ndarray], TwinConfig]
    """(config, parameters) → the extended config."""
    magnitude: Callable[[np.ndarray], float]
    """The effect's size from its parameters, in the units of :data:`MIN_SIZES`."""

    @property
    def size(self) -> int:
        """Number of parameters."""
        return len(self.parameter_names)

    def named(self, values: np.ndarray) -> dict[str, float]:
        """Parameters by name."""
        return {k: float(v) for k, v in zip(self.parameter_names, values, strict=True)}


def _vec(*values: float) -> np.ndarray:
    return np.array(values, dtype=float)


def _current(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    env = config.environment
    return replace(config, environment=replace(env, current_east_mps=env.current_east_mps + float(p[0]),
                                               current_north_mps=env.current_north_mps + float(p[1])))


def _gyro_bias(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    x, y, z = config.um7.gyro_bias_radps
    return replace(config, um7=replace(config.um7, gyro_bias_radps=(x, y, z + float(p[0]))))


def _latency(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, gnss=replace(config.gnss, latency_s=float(p[0])))


def _asymmetry(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, vessel=replace(config.vessel, thrust_factor_left=float(p[0]),
                                          thrust_factor_right=float(p[1])))


def _steering(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    vessel = config.vessel
    return replace(config, vessel=replace(vessel, steering_offset_rad=vessel.steering_offset_rad + float(p[0])))


def _mass(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, vessel=replace(config.vessel, mass_kg=config.vessel.mass_kg * float(p[0])))


def _tow(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    if p[0] <= 0.0:
        return replace(config, tow=None)
    tow = config.tow or TowConfig()
    return replace(config, tow=replace(tow, drag_scale=float(p[0])))


def _resistance(knots_mps: np.ndarray) -> Callable[[TwinConfig, np.ndarray], TwinConfig]:
    def apply(config: TwinConfig, p: np.ndarray) -> TwinConfig:
        base = config.vessel.resistance
        corrected = CorrectedResistance(base, tuple(knots_mps.tolist()), tuple((1.0 + p).tolist()))
        return replace(config, vessel=replace(config.vessel, resistance=corrected))

    return apply


def resistance_knots_mps(speed_mps: np.ndarray) -> np.ndarray:
    """:data:`RESISTANCE_KNOTS` knots at evenly spaced quantiles (2nd to 98th percentile) of the speeds visited,
    so that each segment holds an equal share of the trial's time; at least :data:`MIN_KNOT_SPACING_MPS` apart."""
    speed = speed_mps[np.isfinite(speed_mps)]
    knots = np.percentile(speed, np.linspace(2.0, 98.0, RESISTANCE_KNOTS))
    knots[0] = max(knots[0], 0.2)
    for i in range(1, knots.size):
        knots[i] = max(knots[i], knots[i - 1] + MIN_KNOT_SPACING_MPS)
    return knots


def catalogue(base: TwinConfig, speed_mps: np.ndarray) -> dict[str, Effect]:
    """Every effect, set up for a trial that visited the speeds ``speed_mps`` (through water, m/s)."""
    knots = resistance_knots_mps(speed_mps)
    n = knots.size
    vessel = base.vessel
    latency = base.gnss.latency_s
    effects = [
        Effect("water_current", ("east_mps", "north_mps"), _vec(0, 0), _vec(0.05, 0.05), _vec(-3, -3), _vec(3, 3),
               _current, lambda p: float(np.hypot(p[0], p[1]))),
        Effect("gyro_bias", ("bias_radps",), _vec(0), _vec(0.001), _vec(-0.2), _vec(0.2), _gyro_bias,
               lambda p: abs(float(p[0]))),
        Effect("gnss_latency", ("delay_s",), _vec(latency), _vec(0.1), _vec(0.0), _vec(3.0), _latency,
               lambda p: abs(float(p[0]) - latency)),
        Effect("thrust_asymmetry", ("left_factor", "right_factor"),
               _vec(vessel.thrust_factor_left, vessel.thrust_factor_right), _vec(0.03, 0.03), _vec(0.2, 0.2),
               _vec(2.0, 2.0), _asymmetry, lambda p: float(np.max(np.abs(p - 1.0)))),
        Effect("steering_offset", ("offset_rad",), _vec(0), _vec(0.005), _vec(-0.3), _vec(0.3), _steering,
               lambda p: abs(float(p[0]))),
        Effect("mass_error", ("mass_factor",), _vec(1), _vec(0.05), _vec(0.3), _vec(3.0), _mass,
               lambda p: abs(float(p[0]) - 1.0)),
        Effect("resistance_shape", tuple(f"change_at_{k:.2f}_mps" for k in knots), np.zeros(n), np.full(n, 0.03),
               np.full(n, RESISTANCE_CHANGE_RANGE[0]), np.full(n, RESISTANCE_CHANGE_RANGE[1]), _resistance(knots),
               lambda p: float(np.max(np.abs(p)))),
        Effect("tow_load", ("drag_scale",), _vec(0), _vec(0.1), _vec(0.0), _vec(50.0), _tow, lambda p: float(p[0])),
    ]
    return {e.name: e for e in effects}
