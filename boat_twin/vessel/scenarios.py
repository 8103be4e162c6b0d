"""Trial scenarios: what the helmsman commands, open loop (a profile) or closed loop (zigzag, turning circle).

A scenario gives the four commands (thrust_left_N, thrust_right_N, angle_left_rad, angle_right_rad) for every
boat of an ensemble through a *helm* made fresh for each run (:meth:`Scenario.helm`): an open-loop profile is
its own helm and is held from one output tick to the next (zero-order hold); a closed-loop helm (zigzag) keeps
its per-run, per-boat state (initial heading, steering side) and is asked at every integration step.
Steering sign: a positive outboard angle points the thrust to port, which pushes the stern to port and turns
the bow to starboard (yaw rate < 0, REP-103).

Adding a scenario
-----------------
Write a factory ``(params, rng) → Scenario`` (a :class:`CommandProfile` for open-loop commands, or a frozen
class with ``name``, ``duration_s``, ``initial_surge_mps`` and ``helm(n_boats)`` returning a new object with
``command(t_s, states)`` for closed loop) and add it to :data:`SCENARIOS` under the name the command line
takes, and that name to :data:`~boat_twin.vessel.scenario_names.SCENARIO_NAMES` (a light module, for
``--help``); that is all. ``boat-twin simulate``, its help and errors, the ``player`` node and
:func:`make_scenario` (with its ``--duration`` override) read the registry.
Give the scenario the same ``name``, which the run reports. A closed-loop scenario whose class also has
``compiled_helm()`` (a :class:`~boat_twin.vessel.helms.CompiledHelm`: its decision written in
``vessel/helms.py``, which its Python helm then calls too) runs whole trials inside the compiled kernel.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Protocol

import numpy as np
from scipy.optimize import brentq

from boat_twin.errors import InputError
from boat_twin.files import regular_input
from boat_twin.units import KGF_N
from boat_twin.validation import THRUST_LIMIT_N
from boat_twin.vessel.helms import (
    ENGINE_TURN,
    ZIGZAG,
    CompiledHelm,
    engine_setting_thrust,
    fresh_memory,
    helm_commands,
)
from boat_twin.vessel.params import VesselParams, max_thrust_N, surge_time_constant_s, top_speed_mps
from boat_twin.vessel.scenario_names import SCENARIO_NAMES

SETTLED_RECORD_S = 30.0
"""Time each thrust step is held after settling, s: the identifier's steady-state detector judges and averages
the last 20 s of a segment (boat_twin.ident.online), with margin."""

MAX_DURATION_S = 7 * 86400.0
"""Longest scenario, s (7 days): a week at 10 Hz is 6 million ticks, about 1.3 GB of simulation and sensors
(benchmarks/bench_memory.py measures 300 MB for 6 h); a longer run is refused before it allocates."""

CSV_HEADER = ("t", "thrust_left_N", "thrust_right_N", "angle_left_rad", "angle_right_rad")
"""The header a command CSV file must have, in this order."""

THRUST_STEP_LEVELS_KGF = (6.0, 14.0, 23.0, 31.0, 38.0, 53.0, 65.0, 80.0, 100.0, 120.0)
"""Total thrust levels of the default staircase, kgf: thrusts of Dyda & Chumakova (2021) Table 1, skipping the
flat stretch (44-50 kgf) where the measured curve has no unique steady speed."""


class Helm(Protocol):
    """Who steers during one run: ``command(t, states)`` → (N, 4) commands for the run's N boats."""

    def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
        """Commands for every boat at time ``t_s`` (s since the start) given their states (N, 6)."""


class Scenario(Protocol):
    """What is commanded over ``duration_s``; :meth:`helm` gives a fresh helm for each run."""

    @property
    def name(self) -> str:
        """Scenario name (as the command line knows it)."""

    @property
    def duration_s(self) -> float:
        """Length of the scenario, s."""

    @property
    def initial_surge_mps(self) -> float:
        """Surge speed the boat starts with, m/s."""

    def helm(self, n_boats: int) -> Helm:
        """A helm for one run of ``n_boats`` boats, holding no state from any earlier run."""


@dataclass(frozen=True)
class CommandProfile:
    """Open-loop commands: rows (t_s, 4 commands) held from one row to the next (zero before the first)."""

    name: str
    times_s: np.ndarray
    values: np.ndarray
    duration_s: float
    initial_surge_mps: float = 0.0

    def helm(self, n_boats: int) -> CommandProfile:
        """Open loop: the profile is its own (stateless) helm."""
        return self

    def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
        """The row in force at ``t_s`` (the last with time ≤ t), for every boat."""
        i = int(np.searchsorted(self.times_s, t_s + 1e-9, side="right")) - 1
        row = np.zeros(4) if i < 0 else self.values[i]
        return np.broadcast_to(row, (states.shape[0], 4)).copy()


def steady_speed_mps(params: VesselParams, total_thrust_N: float) -> float:
    """Speed through water where the resistance equals ``total_thrust_N`` (straight course), m/s."""
    if total_thrust_N <= 0.0:
        return 0.0
    hi = params.resistance.max_speed_mps
    while float(params.resistance.force_N(hi)) < total_thrust_N:
        hi *= 2.0
    return float(brentq(lambda u: float(params.resistance.force_N(u)) - total_thrust_N, 0.0, hi, xtol=1e-10))


def top_thrust_N(params: VesselParams) -> float:
    """Total thrust that holds the boat's top speed straight ahead (both outboards at their limit), N."""
    return float(params.resistance.force_N(top_speed_mps(params)))


def staircase_levels_N(params: VesselParams) -> tuple[float, ...]:
    """The paper's staircase (:data:`THRUST_STEP_LEVELS_KGF`) carried to ``params``' boat: each level the same
    share of the thrust that holds the top speed as on the default boat (exactly the paper's levels there)."""
    scale = top_thrust_N(params) / top_thrust_N(VesselParams())
    return tuple(f * KGF_N * scale for f in THRUST_STEP_LEVELS_KGF)


def thrust_steps(
    params: VesselParams, levels_N: tuple[float, ...] | None = None, settle_time_constants: float = 6.0
) -> CommandProfile:
    """The paper's experiment: a staircase of total thrust levels, split equally between the outboards; by
    default the paper's levels carried to the boat (:func:`staircase_levels_N`).

    Each level is held for ``settle_time_constants`` local surge time constants m11/(dFc/du) at its steady
    speed (6 → within 0.25 % of the final speed; at least 30 s, at most 150 s), plus
    :data:`SETTLED_RECORD_S` of settled speed for the steady-state detector to average; then 60 s at idle.
    """
    levels = levels_N or staircase_levels_N(params)
    times, rows, t = [], [], 0.0
    for level in levels:
        tau = surge_time_constant_s(params, steady_speed_mps(params, level))
        times.append(t)
        rows.append([level / 2.0, level / 2.0, 0.0, 0.0])
        t += float(np.clip(settle_time_constants * tau, 30.0, 150.0)) + SETTLED_RECORD_S
    times.append(t)
    rows.append([0.0, 0.0, 0.0, 0.0])
    return CommandProfile("thrust-steps", np.array(times), np.array(rows), t + 60.0)


def accel_stop(params: VesselParams, run_s: float = 60.0, coast_s: float = 60.0) -> CommandProfile:
    """Full ahead on both outboards from rest for ``run_s``, then idle (0 N) for ``coast_s``."""
    full = params.bollard_thrust_N
    return CommandProfile(
        "accel-stop", np.array([0.0, run_s]), np.array([[full, full, 0.0, 0.0], [0.0] * 4]), run_s + coast_s
    )


def _approach_thrust_N(params: VesselParams, speed_mps: float) -> float:
    """Thrust per outboard that holds ``speed_mps`` straight ahead (within the engine envelope), N."""
    need = float(params.resistance.force_N(speed_mps)) / 2.0
    return min(need, float(max_thrust_N(params, np.array(speed_mps))))


@dataclass(frozen=True)
class Zigzag:
    """IMO zigzag δ/ψ (MSC.137(76)): steer ±δ, reverse whenever the heading passes ±ψ of the initial heading.

    The boat starts at ``speed_mps`` and runs straight for ``approach_s`` at the thrust that holds it; the first
    execute is to starboard. ``steering_rad`` and ``heading_change_rad`` are δ and ψ (20°/20° or 10°/10°).
    ``decision_rate_hz``: how often the helm checks the heading, Hz; 0 (default): at every integration step, so
    it reverses within one step of ±ψ. A helm as slow as the 10 Hz command log reverses up to a tick late
    (20.5-20.85° on the 20°/20°) but only at logged instants, so a replay of the log has its commands exactly;
    a faster helm's commands are logged when issued and replayed from the nearest log tick (±half a tick)."""

    params: VesselParams
    steering_rad: float
    heading_change_rad: float
    speed_mps: float = 6.0
    approach_s: float = 10.0
    duration_s: float = 130.0
    name: str = "zigzag"
    decision_rate_hz: float = 0.0

    @property
    def initial_surge_mps(self) -> float:
        """The boat starts at the approach speed, m/s."""
        return self.speed_mps

    def helm(self, n_boats: int) -> ZigzagHelm:
        """A fresh zigzag helm for ``n_boats`` boats."""
        return ZigzagHelm(self, n_boats)

    def compiled_helm(self) -> CompiledHelm:
        """The helm as the compiled kernel runs it (:data:`~boat_twin.vessel.helms.ZIGZAG`)."""
        return CompiledHelm(ZIGZAG, np.array([_approach_thrust_N(self.params, self.speed_mps), self.steering_rad,
                                              self.heading_change_rad, self.approach_s, self.decision_rate_hz]))


class ZigzagHelm:
    """One run of a :class:`Zigzag`: each boat's initial heading (taken at the first execute) and steering side,
    decided by the compiled helm (:func:`~boat_twin.vessel.helms.helm_command`, the one copy of the logic)."""

    def __init__(self, zigzag: Zigzag, n_boats: int) -> None:
        self.compiled = zigzag.compiled_helm()
        self.memory = fresh_memory(n_boats)
        """(N, 3) each boat's steering side (+1: to starboard, a positive angle), initial heading, and 1 once
        that heading is taken."""

    def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
        """Thrust held; steering flips when the heading deviation reaches the threshold (per boat)."""
        if states.shape[0] != self.memory.shape[0]:
            raise ValueError(f"this helm steers {self.memory.shape[0]} boats, got states of {states.shape[0]}")
        out = np.empty((states.shape[0], 4))
        helm_commands(self.compiled.kind, self.compiled.parameters, float(t_s),
                      np.ascontiguousarray(states, dtype=float), self.memory, out)
        return out


@dataclass(frozen=True)
class TurningCircle(CommandProfile):
    """A turning circle (open loop): straight approach, then full steering held from ``execute_s``, s."""

    execute_s: float = 0.0


def turning_circle(params: VesselParams, speed_mps: float = 6.0, approach_s: float = 10.0,
                   turn_s: float = 120.0) -> TurningCircle:
    """Start at ``speed_mps``, run straight, then full steering to starboard with the approach thrust held.

    ``approach_s`` falls on an output tick (10 Hz), so the execute is exact; the steering then swings over at
    the outboards' rate (:attr:`VesselParams.steering_rate_radps`)."""
    thrust = _approach_thrust_N(params, speed_mps)
    rows = np.array([[thrust, thrust, 0.0, 0.0], [thrust, thrust, params.max_steering_rad, params.max_steering_rad]])
    return TurningCircle("turning-circle", np.array([0.0, approach_s]), rows, approach_s + turn_s, speed_mps,
                         execute_s=approach_s)


@dataclass(frozen=True)
class EngineTurningCircle:
    """A turning circle at a constant engine setting (IMO MSC.137(76): the approach's engine setting held):
    straight approach at ``speed_mps``, full steering to starboard from ``execute_s``, s; each outboard held at the
    shaft power that holds the approach speed, so its thrust grows as the turn slows the boat
    (:func:`engine_setting_thrust_N`; docs/model.md, "engine setting"). Closed loop: the thrust follows each boat's
    speed through water at every integration step."""

    params: VesselParams
    speed_mps: float = 6.0
    execute_s: float = 10.0
    duration_s: float = 130.0
    name: str = "turning-circle-engine"

    @property
    def initial_surge_mps(self) -> float:
        """The boat starts at the approach speed, m/s."""
        return self.speed_mps

    @property
    def shaft_power_W(self) -> float:
        """Shaft power per outboard of the engine setting that holds the approach speed straight ahead, W."""
        return _approach_thrust_N(self.params, self.speed_mps) * self.speed_mps / self.params.propulsive_efficiency

    def helm(self, n_boats: int) -> EngineTurningCircle:
        """Stateless: the engine setting and the steering follow the time and each boat's speed."""
        return self

    def compiled_helm(self) -> CompiledHelm:
        """The helm as the compiled kernel runs it (:data:`~boat_twin.vessel.helms.ENGINE_TURN`)."""
        p = self.params
        return CompiledHelm(ENGINE_TURN, np.array([self.shaft_power_W, self.execute_s, p.max_steering_rad,
                                                   p.propulsive_efficiency, p.bollard_thrust_N, p.engine_power_W]))

    def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
        """Thrust of the engine setting at each boat's surge speed; full steering from the execute."""
        helm = self.compiled_helm()
        out = np.empty((states.shape[0], 4))
        helm_commands(helm.kind, helm.parameters, float(t_s), np.ascontiguousarray(states, dtype=float),
                      fresh_memory(states.shape[0]), out)
        return out


def engine_setting_thrust_N(params: VesselParams, shaft_power_W: float, speed_mps: np.ndarray) -> np.ndarray:
    """Thrust per outboard at a constant engine setting (throttle) that delivers ``shaft_power_W``, at speed
    through water ``speed_mps``, N: η·P/|u| (the power branch of the engine envelope at that power, with its
    propulsive efficiency η), within the full-throttle envelope (the bollard thrust at low speed); the helm's
    own function (:func:`~boat_twin.vessel.helms.engine_setting_thrust`)."""
    speed = np.asarray(speed_mps, dtype=float)
    return np.array([engine_setting_thrust(shaft_power_W, params.propulsive_efficiency, params.bollard_thrust_N,
                                           params.engine_power_W, float(u)) for u in speed.ravel()]
                    ).reshape(speed.shape)


@dataclass(frozen=True)
class CrashStop(CommandProfile):
    """The full-astern stopping test (IMO MSC.137(76) §5.3, MSC/Circ.1053): straight approach, then full astern
    on both outboards from ``execute_s``, s (the engine envelope limits astern thrust to the reverse ratio of the
    bollard thrust)."""

    execute_s: float = 0.0


def crash_stop(params: VesselParams, speed_mps: float = 6.0, approach_s: float = 10.0,
               stop_s: float = 30.0) -> CrashStop:
    """Start at ``speed_mps`` at the thrust that holds it, then full astern (the astern share of the bollard
    thrust commanded on both outboards, steering amidships) from ``approach_s`` for ``stop_s``, s; the boat is dead
    in the water within seconds and then backs (the figures end at the stop)."""
    thrust = _approach_thrust_N(params, speed_mps)
    astern = -params.reverse_thrust_ratio * params.bollard_thrust_N  # full astern: what the engine gives astern
    rows = np.array([[thrust, thrust, 0.0, 0.0], [astern, astern, 0.0, 0.0]])
    return CrashStop("crash-stop", np.array([0.0, approach_s]), rows, approach_s + stop_s, speed_mps,
                     execute_s=approach_s)


def random_commands(params: VesselParams, rng: np.random.Generator, duration_s: float = 600.0,
                    min_hold_s: float = 5.0, max_hold_s: float = 25.0) -> CommandProfile:
    """Random piecewise-constant commands: total thrust, differential thrust and steering, each held 5-25 s.

    Total thrust is uniform in [0.2, 1.0] of the bollard thrust per engine, differential up to ±15 % (an engine
    never commanded beyond its bollard thrust),
    steering uniform within ±0.6 of the steering limit: a rich excitation of surge, sway and yaw.
    """
    times, rows, t = [], [], 0.0
    while t < duration_s:
        base = rng.uniform(0.2, 1.0) * params.bollard_thrust_N
        split = rng.uniform(-0.15, 0.15)
        angle = rng.uniform(-0.6, 0.6) * params.max_steering_rad
        times.append(t)
        left, right = min(base * (1 + split), params.bollard_thrust_N), min(base * (1 - split), params.bollard_thrust_N)
        rows.append([left, right, angle, angle])
        t += rng.uniform(min_hold_s, max_hold_s)
    return CommandProfile("random", np.array(times), np.array(rows), duration_s)


ScenarioFactory = Callable[[VesselParams, np.random.Generator], Scenario]
"""(vessel parameters, seeded generator) → the scenario at its natural length."""


def _zigzag(name: str, angle_deg: float) -> ScenarioFactory:
    """The IMO zigzag ``angle_deg``/``angle_deg`` (degrees), called ``name``, from its approach speed."""

    def make(params: VesselParams, rng: np.random.Generator) -> Scenario:
        angle = math.radians(angle_deg)
        return Zigzag(params, angle, angle, speed_mps=params.turn_speed_mps, name=name)

    return make


SCENARIOS: Mapping[str, ScenarioFactory] = MappingProxyType({
    "thrust-steps": lambda params, rng: thrust_steps(params),
    "accel-stop": lambda params, rng: accel_stop(params),
    "zigzag-20-20": _zigzag("zigzag-20-20", 20.0),
    "zigzag-10-10": _zigzag("zigzag-10-10", 10.0),
    "turning-circle": lambda params, rng: turning_circle(params, params.turn_speed_mps),
    "turning-circle-engine": lambda params, rng: EngineTurningCircle(params, speed_mps=params.turn_speed_mps),
    "crash-stop": lambda params, rng: crash_stop(params, params.turn_speed_mps),
    "random": lambda params, rng: random_commands(params, rng),
})
"""Every named scenario: name (as the command line takes it) → factory."""


def _layout_rows(params: VesselParams, demands: np.ndarray, surge_mps: float) -> np.ndarray:
    """A profile's demand rows (thrust per outboard, N, and steering, rad) as ``params``' boat's commands, each
    thrust read at the profile's initial surge ``surge_mps`` (at rest for a staircase;
    :meth:`~boat_twin.vessel.dynamics.Dynamics.layout_commands`)."""
    from boat_twin.vessel.dynamics import Dynamics  # the kernel compiles on first use

    return Dynamics(params).layout_commands(demands, surge_mps)


def make_scenario(name: str, params: VesselParams, rng: np.random.Generator,
                  duration_s: float | None = None) -> Scenario:
    """Build the scenario registered as ``name``; ``duration_s`` (s) overrides its natural length."""
    factory = SCENARIOS.get(name)
    if factory is None:
        raise InputError(f"unknown scenario {name!r} (choose from {', '.join(SCENARIO_NAMES)})")
    if name == "random" and duration_s is not None:  # drawn over the whole run, not 600 s then the last held
        scenario: Scenario = random_commands(params, rng, duration_s)
    else:
        scenario = factory(params, rng)
    if params.propulsion is not None and isinstance(scenario, CommandProfile):  # the boat's own commands
        scenario = replace(scenario, values=_layout_rows(params, scenario.values, scenario.initial_surge_mps))
    if duration_s is not None:
        if not (math.isfinite(duration_s) and 0.0 < duration_s <= MAX_DURATION_S):
            raise InputError(f"--duration must be a positive number of seconds up to {MAX_DURATION_S:g} "
                             f"(7 days), got {duration_s!r}")
        scenario = replace(scenario, duration_s=duration_s)  # type: ignore[type-var]
    return scenario


PROGRESS_ROWS = 65536
"""Rows of a command CSV read between two calls of its ``progress``."""


def read_command_csv(path: Path, progress: Callable[[Path, float], None] | None = None) -> CommandProfile:
    """Read a command profile from CSV with header ``t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad``.

    Times must increase strictly; the simulation runs until the last row's time (the last row is held
    only if a longer ``--duration`` is given). ``progress(path, t_s)``: called every :data:`PROGRESS_ROWS` rows
    with the time reached, s.
    """
    regular_input(path, "command CSV file")
    try:
        with path.open(newline="") as fh:
            reader = csv.reader(fh)
            header = tuple(h.strip() for h in next(reader, ()))
            if header != CSV_HEADER:
                raise InputError(f"{path}: header must be '{','.join(CSV_HEADER)}', got '{','.join(header)}'")
            rows: list[list[float]] = []
            for line_no, row in enumerate(reader, start=2):
                if not row or all(not c.strip() for c in row):
                    continue
                if len(row) != len(CSV_HEADER):
                    raise InputError(f"{path}:{line_no}: expected {len(CSV_HEADER)} columns, got {len(row)}")
                try:
                    values = [float(c) for c in row]
                except ValueError:
                    raise InputError(f"{path}:{line_no}: not a number in {row!r}") from None
                if not all(math.isfinite(v) for v in values):
                    raise InputError(f"{path}:{line_no}: values must be finite, got {row!r}")
                if any(abs(f) > THRUST_LIMIT_N for f in values[1:3]):
                    raise InputError(f"{path}:{line_no}: thrust beyond ±{THRUST_LIMIT_N:g} N (the bound of every "
                                     f"reader: a unit or decoding error), got {row!r}")
                if values[0] > MAX_DURATION_S:
                    raise InputError(f"{path}:{line_no}: time {values[0]:g} s beyond {MAX_DURATION_S:g} s (7 days, "
                                     "the longest simulation)")
                if any(abs(a) > math.pi / 2 for a in values[3:]):
                    raise InputError(f"{path}:{line_no}: steering angle beyond ±π/2 rad (an outboard turns at "
                                     f"most 90° either way), got {row!r}")
                if rows and values[0] <= rows[-1][0]:
                    raise InputError(f"{path}:{line_no}: time {values[0]} s does not increase")
                rows.append(values)
                if progress is not None and len(rows) % PROGRESS_ROWS == 0:
                    progress(path, values[0])
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text CSV file") from None
    except csv.Error as err:  # e.g. a field beyond csv.field_size_limit()
        raise InputError(f"{path}: malformed CSV ({err})") from None
    if not rows:
        raise InputError(f"{path}: no command rows")
    if rows[0][0] < 0.0:
        raise InputError(f"{path}:2: time must not be negative")
    table = np.array(rows)
    return CommandProfile(path.name, table[:, 0], table[:, 1:], float(max(table[-1, 0], 0.1)))


def scenario_warnings(params: VesselParams, scenario: Scenario) -> list[str]:
    """What in ``scenario`` the boat cannot do: commands beyond its engines' thrust (ahead: the bollard thrust;
    astern: its share), or a start above its top speed. Empty when it fits the boat."""
    warnings = []
    top = top_speed_mps(params)
    if scenario.initial_surge_mps > top * 1.001:
        warnings.append(f"{scenario.name} starts at {scenario.initial_surge_mps:.3g} m/s, above this boat's top "
                        f"speed {top:.3g} m/s")
    newtons = params.propulsion is None or all(t.command == "newtons" for t in params.propulsion.thrusters)
    if isinstance(scenario, CommandProfile) and scenario.values.size and newtons:  # else commands in other units
        thrust = scenario.values[:, :2]
        ahead, astern = params.bollard_thrust_N, params.reverse_thrust_ratio * params.bollard_thrust_N
        if np.max(thrust) > ahead * 1.001 or np.min(thrust) < -astern * 1.001:
            warnings.append(f"{scenario.name} commands {np.min(thrust):.4g} to {np.max(thrust):.4g} N per engine; "
                            f"this boat's engines give {-astern:.4g} to {ahead:.4g} N: they saturate")
    return warnings
