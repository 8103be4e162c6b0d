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
| ``tow_load`` | ``drag_scale`` | ``tow`` = the packaged towed body on 50 m of cable, drag × scale |
| ``wind`` | ``east_mps``, ``north_mps`` | ``environment.wind_*`` = (east, north): air over ground, flowing *to* |
| ``manoeuvring`` | ``yaw_damping_factor``, ``sway_damping_factor`` | ``vessel.manoeuvring``: a_r, a_v ×= factor |

Each parameter has a *null* value (the effect absent) and a *scale* (a size the data resolve easily), so the
fit works in ``x = (p − null) / scale``. Each effect has a *size* (:attr:`EffectSpec.magnitude`), a detection
*threshold* (the size the diagnosis promises to detect: what the tests and the accuracy study hide, at 1.2-2×)
and a *minimum size* (the decision rule's floor, half the threshold), all in the effect's ``size_unit``.
``tow_load``'s size is its ``drag_scale`` (dimensionless: the towed system's drag relative to the packaged body
on its 50 m cable, which stays 50 m): threshold 0.6, floor 0.3, towed at 1-2 m/s. ``wind``'s size is the length
of the change of the wind's velocity, m/s: threshold 4 m/s, floor 2 m/s (its force is the twin's windage model,
:mod:`boat_twin.vessel.dynamics`, quadratic in the apparent wind). ``manoeuvring``'s size is the largest
|factor − 1| of the hull's two lift-damping coefficients (yaw a_r, sway a_v): threshold 15 %, floor 7.5 %; the
extended model carries the corrected coefficients themselves (N·m·s, N·s²/m²) in ``vessel.manoeuvring``.

Adding a diagnosis effect
-------------------------
Write its ``apply`` (config, parameters → extended config), its ``draw`` (how a trial hides it at a given
size) and one :class:`EffectSpec` entry in :data:`EFFECTS` (with ``wind_alias=True`` if, on a trial that
holds one heading, it is a constant body-frame force as a wind is); nothing else. Its position in :data:`EFFECTS` is
its place in the report, the accuracy study (``benchmarks/bench_diagnose.py``) picks it up, and the fit, the
decision rule (:mod:`~boat_twin.diagnose.search`) and the hidden trials (:mod:`~boat_twin.diagnose.hidden`)
read everything from the entry. Add a case to ``test/test_diagnose.py``'s parametrized hidden-effect test.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from functools import partial
from types import MappingProxyType
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.vessel.params import derive_coefficients
from boat_twin.vessel.resistance import CorrectedResistance
from boat_twin.vessel.tow import TowConfig

RESISTANCE_CHANGE_RANGE = (-0.5, 1.0)
"""Physical range of a resistance change, fraction of Fc: the hull's resistance at most halves or doubles
(fouling adds tens of percent, as does a heavier load or a planing regime reached earlier or later). A fit
that wants more — a tripled resistance at 1-2 m/s — is taking up something else, e.g. a towed body's drag."""
RESISTANCE_KNOTS = 5
"""Knots of the resistance correction k(u), at evenly spaced quantiles of the speeds the trial visited."""
MIN_KNOT_SPACING_MPS = 0.1
"""Smallest distance between two knots of the resistance correction, m/s."""
BAND_TIME_SHARE = 0.4
"""A hidden resistance change covers the speeds where the trial spends this share of its time."""

WIND_LIMIT_MPS = 25.0
"""Physical range of each wind component, m/s: a 6 m open boat is not tried in more than a gale (Beaufort 9 is
21-24 m/s); a fit that wants more stands in for another cause."""
DAMPING_FACTOR_RANGE = (0.4, 2.5)
"""Physical range of a lift-damping factor (``manoeuvring``), -: the twin derives a_v and a_r from an assumed
reference turn (a 60 m circle at 6 m/s, 20° of steering; :func:`~boat_twin.vessel.params.derive_coefficients`);
a real hull of this size turns in a circle of 3-10 lengths (IMO MSC.137(76) asks a tactical diameter under
5 lengths), i.e. a turning-rate gain of at most ~2.5× or ~0.4× the assumed one. A fit beyond stands in for
another cause."""

Draw = Callable[[TwinConfig, float, float, np.random.Generator, np.ndarray | None], tuple[TwinConfig, dict[str, Any]]]
"""(base config, size, sign ±1, generator, speeds the trial visits in m/s or None) → (true config, truth)."""


@dataclass(frozen=True)
class Parameter:
    """One parameter of an effect."""

    name: str
    """Its key in reports, unit suffixed (``east_mps``); a per-knot effect's is a format of ``knot_mps``."""
    unit: str
    """SI unit, ``-`` when dimensionless."""
    scale: float
    """A size the data resolve easily, in ``unit``: the fit works in (value − null) / scale."""
    lower: float
    """Physical range, in ``unit``: a fit ending on a bound stands in for another cause."""
    upper: float
    null: float | Callable[[TwinConfig], float] = 0.0
    """The value with the effect absent, in ``unit``: a number, or read from the base config."""

    def null_for(self, base: TwinConfig) -> float:
        """The null value for the base config ``base``."""
        return float(self.null(base)) if callable(self.null) else float(self.null)


@dataclass(frozen=True)
class EffectSpec:
    """One cause, everything about it: the registry's record (see "Adding a diagnosis effect" above)."""

    name: str
    """Canonical name, as the report and its JSON give it."""
    parameters: tuple[Parameter, ...]
    """Its parameters; a per-knot effect has one, repeated at every knot."""
    apply: Callable[..., TwinConfig]
    """(config, parameters) → the extended config; a per-knot effect also takes ``knots_mps=``."""
    magnitude: Callable[[np.ndarray, np.ndarray], float]
    """(parameters, null values) → the effect's size, in ``size_unit``."""
    size_unit: str
    """Unit of the size, threshold and minimum size."""
    threshold: float
    """The smallest size the diagnosis must detect (issue 5), in ``size_unit``: the tests and the accuracy study
    hide it at 1.2-2× this (``tow_load`` at 1-2.5×, see its draw)."""
    min_size: float
    """The smallest size the diagnosis names, in ``size_unit``: half the threshold (docs/diagnosis.md).
    Zero-mean errors of the replay's initial states (sensor noise carried through the hull's dynamics) leave
    spurious fits of up to ~0.02 m/s of current or ~3 % of mass on clean 10-minute trials: real, stable across
    the trial, but not a cause worth naming."""
    draw: Draw
    """How a trial hides it: (base, size, sign, generator, visited speeds) → (true config, truth by name)."""
    per_knot: bool = False
    """One parameter per knot of :func:`resistance_knots_mps` (the speeds the trial visited)."""
    wind_alias: bool = False
    """A constant force in the body frame on a trial that holds one heading, as a wind is there: the search
    reports it and the wind as ambiguous instead of naming either (:data:`~boat_twin.diagnose.search.WIND_ALIASES`)."""

    def for_trial(self, base: TwinConfig, speed_mps: np.ndarray) -> Effect:
        """The effect set up for a trial of the base config ``base`` that visited ``speed_mps`` (m/s)."""
        parameters, apply = self.parameters, self.apply
        if self.per_knot:
            knots = resistance_knots_mps(speed_mps)
            (one,) = self.parameters
            parameters = tuple(replace(one, name=one.name.format(knot_mps=k)) for k in knots)
            apply = partial(self.apply, knots_mps=knots)

        def column(values: list[float]) -> np.ndarray:
            return np.array(values, dtype=float)

        return Effect(self, tuple(p.name for p in parameters), column([p.null_for(base) for p in parameters]),
                      column([p.scale for p in parameters]), column([p.lower for p in parameters]),
                      column([p.upper for p in parameters]), apply)


@dataclass(frozen=True)
class Effect:
    """One cause set up for a trial: its parameters' names, null values, scales and bounds as arrays."""

    spec: EffectSpec
    parameter_names: tuple[str, ...]
    null: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    apply: Callable[[TwinConfig, np.ndarray], TwinConfig]
    """(config, parameters) → the extended config."""

    @property
    def name(self) -> str:
        """The effect's canonical name."""
        return self.spec.name

    @property
    def size(self) -> int:
        """Number of parameters."""
        return len(self.parameter_names)

    def magnitude(self, values: np.ndarray) -> float:
        """The effect's size at parameters ``values``, in :attr:`EffectSpec.size_unit`."""
        return self.spec.magnitude(values, self.null)

    def named(self, values: np.ndarray) -> dict[str, float]:
        """Parameters by name."""
        return {k: float(v) for k, v in zip(self.parameter_names, values, strict=True)}


def resistance_knots_mps(speed_mps: np.ndarray) -> np.ndarray:
    """:data:`RESISTANCE_KNOTS` knots at evenly spaced quantiles (2nd to 98th percentile) of the speeds visited,
    so that each segment holds an equal share of the trial's time; at least :data:`MIN_KNOT_SPACING_MPS` apart."""
    speed = speed_mps[np.isfinite(speed_mps)]
    knots = np.percentile(speed, np.linspace(2.0, 98.0, RESISTANCE_KNOTS))
    knots[0] = max(knots[0], 0.2)
    for i in range(1, knots.size):
        knots[i] = max(knots[i], knots[i - 1] + MIN_KNOT_SPACING_MPS)
    return knots


# --- how each effect extends a config (apply) and hides in a trial (draw) ---------------------------------


def _current(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    env = config.environment
    return replace(config, environment=replace(env, current_east_mps=env.current_east_mps + float(p[0]),
                                               current_north_mps=env.current_north_mps + float(p[1])))


def _draw_current(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                  speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    angle = rng.uniform(-math.pi, math.pi)
    east, north = size * math.cos(angle), size * math.sin(angle)
    return replace(base, environment=replace(base.environment, current_east_mps=east,
                                             current_north_mps=north)), {"east_mps": east, "north_mps": north}


def _gyro_bias(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    x, y, z = config.um7.gyro_bias_radps
    return replace(config, um7=replace(config.um7, gyro_bias_radps=(x, y, z + float(p[0]))))


def _draw_gyro_bias(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                    speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    return replace(base, um7=replace(base.um7, gyro_bias_radps=(0.0, 0.0, sign * size))), {"bias_radps": sign * size}


def _latency(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, gnss=replace(config.gnss, latency_s=float(p[0])))


def _draw_latency(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                  speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    delay = base.gnss.latency_s + size
    return replace(base, gnss=replace(base.gnss, latency_s=delay)), {"delay_s": delay}


def _asymmetry(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, vessel=replace(config.vessel, thrust_factor_left=float(p[0]),
                                          thrust_factor_right=float(p[1])))


def _draw_asymmetry(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                    speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    left, right = (1.0 - size, 1.0) if sign > 0 else (1.0, 1.0 - size)
    return (replace(base, vessel=replace(base.vessel, thrust_factor_left=left, thrust_factor_right=right)),
            {"left_factor": left, "right_factor": right})


def _steering(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    vessel = config.vessel
    return replace(config, vessel=replace(vessel, steering_offset_rad=vessel.steering_offset_rad + float(p[0])))


def _draw_steering(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                   speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    return replace(base, vessel=replace(base.vessel, steering_offset_rad=sign * size)), {"offset_rad": sign * size}


def _mass(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, vessel=replace(config.vessel, mass_kg=config.vessel.mass_kg * float(p[0])))


def _draw_mass(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
               speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    factor = 1.0 + sign * size
    return replace(base, vessel=replace(base.vessel, mass_kg=base.vessel.mass_kg * factor)), {"mass_factor": factor}


def _resistance(config: TwinConfig, p: np.ndarray, knots_mps: np.ndarray) -> TwinConfig:
    corrected = CorrectedResistance(config.vessel.resistance, tuple(knots_mps.tolist()), tuple((1.0 + p).tolist()))
    return replace(config, vessel=replace(config.vessel, resistance=corrected))


def _draw_resistance(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                     speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    """A change covering the speeds where the trial spends :data:`BAND_TIME_SHARE` of its time (between two
    quantiles of ``speeds_mps``, drawn at random), with ramps a fifth of its width at both ends."""
    if speeds_mps is None:
        raise ValueError("a resistance_shape change needs the speeds the trial visits")
    quantile = rng.uniform(0.1, 0.5)
    low, high = (float(v) for v in np.quantile(speeds_mps, [quantile, quantile + BAND_TIME_SHARE]))
    width = max(high - low, 0.1)
    ramp = 0.2 * width
    knots = (max(low - ramp, 0.0), low, low + width, low + width + ramp)
    factors = (1.0, 1.0 + sign * size, 1.0 + sign * size, 1.0)
    resistance = CorrectedResistance(base.vessel.resistance, knots, factors)
    return (replace(base, vessel=replace(base.vessel, resistance=resistance)),
            {"band_mps": [low, low + width], "change": sign * size})


def _tow(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    if p[0] <= 0.0:
        return replace(config, tow=None)
    tow = config.tow or TowConfig()
    return replace(config, tow=replace(tow, drag_scale=float(p[0])))


def _draw_tow(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
              speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    """A drag_scale uniform in 0.6-1.5 (1-2.5× the threshold: the packaged body, 40 % smaller to 50 % larger in
    drag), whatever ``size``."""
    scale = rng.uniform(0.6, 1.5)
    return replace(base, tow=TowConfig(drag_scale=scale)), {"drag_scale": scale}


def _wind(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    return replace(config, environment=replace(config.environment, wind_east_mps=float(p[0]),
                                               wind_north_mps=float(p[1])))


def _draw_wind(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
               speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    """A wind of speed ``size`` from a random direction, added to the base config's wind."""
    angle = rng.uniform(-math.pi, math.pi)
    env = base.environment
    east, north = env.wind_east_mps + size * math.cos(angle), env.wind_north_mps + size * math.sin(angle)
    return _wind(base, np.array([east, north])), {"east_mps": east, "north_mps": north}


def _manoeuvring(config: TwinConfig, p: np.ndarray) -> TwinConfig:
    """The hull's yaw and sway lift damping (a_r, a_v) × the factors ``p``, written as the corrected coefficients
    into ``vessel.manoeuvring`` (whatever else it holds stays)."""
    vessel = config.vessel
    try:
        coeff = derive_coefficients(vessel)
    except InputError:  # a boat the loader refuses stays refused: the replay reports it as infeasible
        return config
    overrides = {**vessel.manoeuvring, "yaw_damping_Nms": coeff.yaw_damping_Nms * float(p[0]),
                 "sway_damping_Nspm2": coeff.sway_damping_Nspm2 * float(p[1])}
    return replace(config, vessel=replace(vessel, manoeuvring=overrides))


def _draw_manoeuvring(base: TwinConfig, size: float, sign: float, rng: np.random.Generator,
                      speeds_mps: np.ndarray | None) -> tuple[TwinConfig, dict[str, Any]]:
    """The yaw damping changed by ``sign``·``size``, the sway damping by a uniform share of ±``size``."""
    factors = np.array([1.0 + sign * size, 1.0 + rng.uniform(-size, size)])
    return _manoeuvring(base, factors), {"yaw_damping_factor": float(factors[0]),
                                         "sway_damping_factor": float(factors[1])}


# --- the registry -------------------------------------------------------------------------------------------

EFFECTS: Mapping[str, EffectSpec] = MappingProxyType({spec.name: spec for spec in (
    EffectSpec(
        name="water_current",
        parameters=(Parameter("east_mps", "m/s", scale=0.05, lower=-3.0, upper=3.0),
                    Parameter("north_mps", "m/s", scale=0.05, lower=-3.0, upper=3.0)),
        apply=_current, magnitude=lambda p, null: float(np.hypot(p[0], p[1])), size_unit="m/s (current speed)",
        threshold=0.15, min_size=0.075, draw=_draw_current, wind_alias=True),
    EffectSpec(
        name="gyro_bias",
        parameters=(Parameter("bias_radps", "rad/s", scale=0.001, lower=-0.2, upper=0.2),),
        apply=_gyro_bias, magnitude=lambda p, null: abs(float(p[0])), size_unit="rad/s",
        threshold=0.005, min_size=0.0025, draw=_draw_gyro_bias),
    EffectSpec(
        name="gnss_latency",
        parameters=(Parameter("delay_s", "s", scale=0.1, lower=0.0, upper=3.0, null=lambda c: c.gnss.latency_s),),
        apply=_latency, magnitude=lambda p, null: abs(float(p[0]) - float(null[0])),
        size_unit="s (change of the latency)", threshold=0.3, min_size=0.15, draw=_draw_latency),
    EffectSpec(
        name="thrust_asymmetry",
        parameters=(Parameter("left_factor", "-", scale=0.03, lower=0.2, upper=2.0,
                              null=lambda c: c.vessel.thrust_factor_left),
                    Parameter("right_factor", "-", scale=0.03, lower=0.2, upper=2.0,
                              null=lambda c: c.vessel.thrust_factor_right)),
        apply=_asymmetry, magnitude=lambda p, null: float(np.max(np.abs(p - 1.0))),
        size_unit="- (largest |factor − 1|)", threshold=0.08, min_size=0.04, draw=_draw_asymmetry,
        wind_alias=True),
    EffectSpec(
        name="steering_offset",
        parameters=(Parameter("offset_rad", "rad", scale=0.005, lower=-0.3, upper=0.3),),
        apply=_steering, magnitude=lambda p, null: abs(float(p[0])), size_unit="rad",
        threshold=math.radians(1.5), min_size=0.013, draw=_draw_steering,  # min_size: 0.75°, rounded
        wind_alias=True),
    EffectSpec(
        name="mass_error",
        parameters=(Parameter("mass_factor", "-", scale=0.05, lower=0.3, upper=3.0, null=1.0),),
        apply=_mass, magnitude=lambda p, null: abs(float(p[0]) - 1.0), size_unit="- (|mass_factor − 1|)",
        threshold=0.20, min_size=0.10, draw=_draw_mass),
    EffectSpec(
        name="resistance_shape",
        parameters=(Parameter("change_at_{knot_mps:.2f}_mps", "- (fraction of Fc)", scale=0.03,
                              lower=RESISTANCE_CHANGE_RANGE[0], upper=RESISTANCE_CHANGE_RANGE[1]),),
        apply=_resistance, magnitude=lambda p, null: float(np.max(np.abs(p))),
        size_unit="- (largest |change| over a speed band)", threshold=0.10, min_size=0.05, draw=_draw_resistance,
        per_knot=True, wind_alias=True),
    EffectSpec(
        name="tow_load",
        parameters=(Parameter("drag_scale", "- ((size ratio)² of the packaged body and cable)", scale=0.1,
                              lower=0.0, upper=50.0),),
        apply=_tow, magnitude=lambda p, null: float(p[0]), size_unit="- (drag_scale, towing at 1-2 m/s)",
        threshold=0.6, min_size=0.3, draw=_draw_tow),
    EffectSpec(
        name="wind",
        parameters=(Parameter("east_mps", "m/s", scale=1.0, lower=-WIND_LIMIT_MPS, upper=WIND_LIMIT_MPS,
                              null=lambda c: c.environment.wind_east_mps),
                    Parameter("north_mps", "m/s", scale=1.0, lower=-WIND_LIMIT_MPS, upper=WIND_LIMIT_MPS,
                              null=lambda c: c.environment.wind_north_mps)),
        apply=_wind, magnitude=lambda p, null: float(np.hypot(p[0] - null[0], p[1] - null[1])),
        size_unit="m/s (change of the wind's speed over ground)", threshold=4.0, min_size=2.0, draw=_draw_wind),
    EffectSpec(
        name="manoeuvring",
        parameters=(Parameter("yaw_damping_factor", "- (a_r / the model's)", scale=0.03,
                              lower=DAMPING_FACTOR_RANGE[0], upper=DAMPING_FACTOR_RANGE[1], null=1.0),
                    Parameter("sway_damping_factor", "- (a_v / the model's)", scale=0.03,
                              lower=DAMPING_FACTOR_RANGE[0], upper=DAMPING_FACTOR_RANGE[1], null=1.0)),
        apply=_manoeuvring, magnitude=lambda p, null: float(np.max(np.abs(p - 1.0))),
        size_unit="- (largest |factor − 1| of a_r, a_v)", threshold=0.15, min_size=0.075, draw=_draw_manoeuvring),
)})
"""Every diagnosis effect by canonical name, in the order the report lists them."""
EFFECT_NAMES = tuple(EFFECTS)
"""Canonical names, in the order the report lists them."""


def catalogue(base: TwinConfig, speed_mps: np.ndarray) -> dict[str, Effect]:
    """Every effect, set up for a trial that visited the speeds ``speed_mps`` (through water, m/s)."""
    return {name: spec.for_trial(base, speed_mps) for name, spec in EFFECTS.items()}
