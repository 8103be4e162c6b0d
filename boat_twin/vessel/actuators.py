"""A boat's thrusters and rudders (the ``propulsion`` section of a boat file): where they are, how a command
becomes thrust, and the rudders' lift.

Three families of small craft are described by it (docs/model.md, "Propulsion and steering"): skid-steer boats
(two fixed thrusters, turned by differential thrust), steerable outboards or azimuth thrusters (the thrust turns
with the steering input), and propeller + rudder. A thruster's command becomes thrust by one of three maps:

- ``newtons``: the command is the thrust asked for, N, delivered within the engines' envelope (astern down to
  −reverse_thrust_ratio·T_bollard, ahead up to min(T_bollard, η·P/|u|): the vessel's engine facts);
- ``table``: a measured, speed-independent curve command → thrust (−1…1, PWM µs, any unit), linear between
  points, held at its ends (the VRX thruster convention);
- ``propeller``: the command is the shaft speed n in rev/s and T = ρ·n·|n|·D⁴·K_T(J) with the advance ratio
  J = V_A/(|n|·D), V_A = (1 − w)·u_p (u_p the surge at the propeller, w the wake fraction) and the open-water
  curve K_T(J) = k₀ + k₁·J + k₂·J² (Carlton 2012, ch. 6); astern (n < 0) it delivers ``astern_ratio`` of that.

A rudder's normal force is the MMG model's (Yasukawa & Yoshimura 2015, eq. 11-13; Fossen 2021, §9.4):
F_N = ½ρ·A_R·f_α·U_R²·sin α_R, with the lift slope f_α given or 6.13·Λ/(Λ + 2.25) of its aspect ratio Λ (Fujii), the
inflow U_R from the surge and sway at the rudder and, where a propeller or thruster washes it, the slipstream
speed u_R² = η·(u_A + κ·(V_∞ − u_A))² + (1 − η)·u_A² with V_∞² = u_A² + 8T/(ρπD²) (momentum theory; η = D / the
rudder's span, κ = 0.5). Sign: a positive rudder angle turns the boat like a positive outboard angle (its force
pushes the stern to port, the bow to starboard), so one helm steers either.

The kernel has two actuator slots (left = 0, right = 1), each a thruster and a steering input: a boat has one or
two thrusters and up to two rudders; steering input j drives rudder j where the boat has rudders, else thruster
j if it is steerable. ``None`` in :class:`~boat_twin.vessel.params.VesselParams` is the default layout, the seed
boat's two steerable outboards commanded in N at (engine_x_m, ±engine_y_m).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.units import SEAWATER_DENSITY_KGPM3
from boat_twin.validation import THRUST_LIMIT_N, number, number_list

__all__ = ["COMMAND_MAPS", "MAX_RUDDERS", "MAX_THRUSTERS", "TABLE_MAX_POINTS", "PropellerMap", "Propulsion",
           "Rudder", "ThrustTable", "Thruster", "fujii_lift_slope_per_rad", "propulsion_from_dict",
           "propulsion_to_dict"]

COMMAND_MAPS = ("newtons", "table", "propeller")
"""How a thruster's command becomes thrust (module docstring)."""
MAX_THRUSTERS = 2
"""Thrusters a boat may have: the kernel's two actuator slots."""
MAX_RUDDERS = 2
"""Rudders a boat may have, one per steering input."""
TABLE_MAX_POINTS = 24
"""Points a thrust table may hold (the kernel keeps it in the boat's coefficient row)."""
SLIPSTREAM_KAPPA = 0.5
"""κ: how far the slipstream has accelerated at the rudder, -: 0.5-0.6 (Yasukawa & Yoshimura 2015, Table 3)."""


@dataclass(frozen=True)
class ThrustTable:
    """A measured command → thrust curve: ``command`` increasing (its unit ``unit``), ``thrust_N`` at each, N."""

    command: tuple[float, ...]
    thrust_N: tuple[float, ...]
    unit: str = "normalised"

    def thrust(self, command: np.ndarray | float) -> np.ndarray:
        """Thrust at ``command``, N: linear between the points, held at the ends; NaN stays NaN."""
        return np.asarray(np.interp(command, self.command, self.thrust_N))

    def zero_thrust_command(self) -> float:
        """The command that gives no thrust, in the table's unit: the middle of its dead band where points give
        0 N, else where the curve first crosses zero (a PWM table's neutral, 1500 µs); the end nearest to zero
        thrust if it never does."""
        command, thrust = np.asarray(self.command), np.asarray(self.thrust_N)
        zero = command[thrust == 0.0]
        if zero.size:
            return float(0.5 * (zero.min() + zero.max()))
        crossing = np.flatnonzero(np.sign(thrust[:-1]) != np.sign(thrust[1:]))
        if crossing.size:
            i = int(crossing[0])
            return float(command[i] - thrust[i] * (command[i + 1] - command[i]) / (thrust[i + 1] - thrust[i]))
        return float(command[np.argmin(np.abs(thrust))])


@dataclass(frozen=True)
class PropellerMap:
    """A propeller commanded in rev/s (module docstring): diameter, open-water K_T(J) coefficients, wake, astern."""

    diameter_m: float
    kt: tuple[float, float, float] = (0.45, -0.22, -0.16)
    """K_T(J) = k₀ + k₁·J + k₂·J², -: default a Wageningen B4-70 screw of pitch ratio 1.0 read off its open-water
    chart (K_T 0.45 at J = 0, 0.30 at 0.5, 0.07 at 1.0; Carlton 2012, fig. 6.9), assumed."""
    wake_fraction: float = 0.05
    """w: the hull's wake at the propeller, -: 0-0.1 for a small fast craft's outboard or shaft (Faltinsen 2005,
    §9.4; assumed 0.05)."""
    astern_ratio: float = 0.6
    """Thrust astern as a share of ahead at the same |n|, -: 0.5-0.7 for a fixed-pitch screw (assumed)."""

    def thrust(self, rev_per_s: np.ndarray | float, inflow_mps: np.ndarray | float) -> np.ndarray:
        """T = ρ·n·|n|·D⁴·K_T(J), J = (1 − w)·u/(|n|·D), N (astern ``astern_ratio`` of it; 0 at n = 0)."""
        n = np.asarray(rev_per_s, dtype=float)
        d = self.diameter_m
        advance = (1.0 - self.wake_fraction) * np.asarray(inflow_mps, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            j = np.where(np.abs(n) > 1e-9, advance / (np.abs(n) * d), 0.0)
        kt = self.kt[0] + self.kt[1] * j + self.kt[2] * j * j
        thrust = SEAWATER_DENSITY_KGPM3 * n * np.abs(n) * d**4 * kt
        return np.where(n >= 0.0, thrust, self.astern_ratio * thrust)

    def rev_per_s_for(self, thrust_N: np.ndarray | float) -> np.ndarray:
        """The shaft speed that gives ``thrust_N`` at rest (J = 0: bollard), rev/s (what scenarios ask for)."""
        t = np.asarray(thrust_N, dtype=float)
        scale = SEAWATER_DENSITY_KGPM3 * self.diameter_m**4 * self.kt[0]
        return np.sign(t) * np.sqrt(np.abs(t) / (scale * np.where(t >= 0.0, 1.0, self.astern_ratio)))


@dataclass(frozen=True)
class Thruster:
    """One thruster: its position (FLU body frame, from the centre of gravity), how it points and is commanded."""

    name: str
    x_m: float
    y_m: float
    steered: bool = False
    """True: it turns with its steering input (an outboard, an azimuth thruster); False: fixed at ``angle_rad``."""
    angle_rad: float = 0.0
    """A fixed thruster's direction from the bow, rad (positive turns the thrust to port)."""
    command: str = "newtons"
    """How its command becomes thrust: one of :data:`COMMAND_MAPS`."""
    table: ThrustTable | None = None
    propeller: PropellerMap | None = None
    diameter_m: float = 0.0
    """The slipstream's diameter, m (a propeller's own; for another thruster only if a rudder sits in its wash)."""

    @property
    def command_topic(self) -> str:
        """Its command topic (the VRX convention): ``thrusters/<name>/thrust`` in N, else ``.../cmd``."""
        return f"thrusters/{self.name}/{'thrust' if self.command == 'newtons' else 'cmd'}"

    @property
    def stop_command(self) -> float:
        """The command that asks it for no thrust, in its own unit: 0 N, 0 rev/s, or its table's
        :meth:`~ThrustTable.zero_thrust_command`."""
        return self.table.zero_thrust_command() if self.table is not None else 0.0


@dataclass(frozen=True)
class Rudder:
    """One rudder: its position, area and aspect ratio, and the thruster whose slipstream washes it (if any)."""

    name: str
    x_m: float
    area_m2: float
    y_m: float = 0.0
    aspect_ratio: float = 1.5
    """Λ = span²/area, -: 1-2 for small craft rudders (Molland & Turnock 2007, ch. 3; assumed 1.5)."""
    washed_by: str | None = None
    """The name of the thruster whose slipstream reaches it, or None (only the hull's inflow)."""
    lift_slope_per_rad: float | None = None
    """f_α, its normal-force slope, 1/rad: given (measured, or fitted by ``identify --manoeuvring``), or None for
    Fujii's from its aspect ratio (:func:`fujii_lift_slope_per_rad`)."""

    @property
    def span_m(self) -> float:
        """Its span, m: √(Λ·A)."""
        return math.sqrt(self.aspect_ratio * self.area_m2)

    @property
    def lift_slope(self) -> float:
        """f_α, 1/rad: :attr:`lift_slope_per_rad` when given, else Fujii's of its aspect ratio."""
        return fujii_lift_slope_per_rad(self.aspect_ratio) if self.lift_slope_per_rad is None \
            else self.lift_slope_per_rad


def fujii_lift_slope_per_rad(aspect_ratio: float) -> float:
    """f_α = 6.13·Λ/(Λ + 2.25), the rudder's normal-force slope, 1/rad (Fujii; Yasukawa & Yoshimura 2015, eq. 13)."""
    return 6.13 * aspect_ratio / (aspect_ratio + 2.25)


@dataclass(frozen=True)
class Propulsion:
    """The boat's thrusters (one or two: the kernel's slots, left = first) and rudders (none to two)."""

    thrusters: tuple[Thruster, ...]
    rudders: tuple[Rudder, ...] = ()

    def steering_input(self, j: int) -> str:
        """What steering input ``j`` drives: ``rudder``, ``thruster`` or ``none``."""
        if j < len(self.rudders):
            return "rudder"
        if j < len(self.thrusters) and self.thrusters[j].steered:
            return "thruster"
        return "none"

    def thruster_index(self, name: str) -> int:
        """The slot of the thruster named ``name``."""
        return [t.name for t in self.thrusters].index(name)


def _mapping(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise InputError(f"{where}: expected a mapping, got {value!r}")
    return value


def _refuse_unknown(data: Mapping[str, Any], known: tuple[str, ...], where: str) -> None:
    unknown = sorted(str(key) for key in data if key not in known)
    if unknown:
        raise InputError(f"{where}: unknown key '{unknown[0]}' (expected {', '.join(known)})")


def _name(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value or not all(c.isalnum() or c == "_" for c in value):
        raise InputError(f"{where}: 'name' must be a topic-safe name (letters, digits, _), got {value!r}")
    return value


def _table(data: Any, where: str) -> ThrustTable:
    spec = _mapping(data, where)
    _refuse_unknown(spec, ("command", "thrust_N", "unit"), where)
    command = number_list(f"{where}: command", spec.get("command"), min_length=2)
    thrust = number_list(f"{where}: thrust_N", spec.get("thrust_N"), min_length=2)
    if len(command) != len(thrust):
        raise InputError(f"{where}: command and thrust_N need the same length, got {len(command)} and {len(thrust)}")
    if len(command) > TABLE_MAX_POINTS:
        raise InputError(f"{where}: at most {TABLE_MAX_POINTS} points, got {len(command)}")
    if np.any(np.diff(command) <= 0.0):
        raise InputError(f"{where}: command must increase strictly")
    if np.any(np.diff(thrust) < 0.0):
        raise InputError(f"{where}: thrust_N must not decrease as the command increases")
    if max(abs(t) for t in thrust) > THRUST_LIMIT_N:
        raise InputError(f"{where}: thrust_N beyond ±{THRUST_LIMIT_N:g} N (a unit error?)")
    unit = spec.get("unit", "normalised")
    if not isinstance(unit, str):
        raise InputError(f"{where}: 'unit' must be a name (e.g. normalised, pwm_us), got {unit!r}")
    return ThrustTable(command, thrust, unit)


def _propeller(data: Any, where: str) -> PropellerMap:
    spec = _mapping(data, where)
    _refuse_unknown(spec, ("diameter_m", "kt", "wake_fraction", "astern_ratio"), where)
    diameter = number(f"{where}: diameter_m", spec.get("diameter_m"), above=0.0, maximum=20.0)
    kt = PropellerMap.kt if "kt" not in spec else number_list(f"{where}: kt", spec["kt"], min_length=3)
    if len(kt) != 3 or kt[0] <= 0.0:
        raise InputError(f"{where}: kt must be [k0, k1, k2] of K_T(J) = k0 + k1·J + k2·J² with k0 > 0, got {kt!r}")
    wake = number(f"{where}: wake_fraction", spec.get("wake_fraction", PropellerMap.wake_fraction),
                  minimum=0.0, below=1.0)
    astern = number(f"{where}: astern_ratio", spec.get("astern_ratio", PropellerMap.astern_ratio),
                    minimum=0.0, maximum=1.0)
    return PropellerMap(diameter, (kt[0], kt[1], kt[2]), wake, astern)


THRUSTER_KEYS = ("name", "x_m", "y_m", "steered", "angle_rad", "command", "table", "propeller", "diameter_m")
RUDDER_KEYS = ("name", "x_m", "y_m", "area_m2", "aspect_ratio", "lift_slope_per_rad", "washed_by")


def _thruster(data: Any, where: str) -> Thruster:
    spec = _mapping(data, where)
    _refuse_unknown(spec, THRUSTER_KEYS, where)
    name = _name(spec.get("name"), where)
    command = spec.get("command", "newtons")
    if command not in COMMAND_MAPS:
        raise InputError(f"{where}: 'command' must be one of {', '.join(COMMAND_MAPS)}, got {command!r}")
    steered = spec.get("steered", False)
    if not isinstance(steered, bool):
        raise InputError(f"{where}: 'steered' must be true or false, got {steered!r}")
    table = _table(spec.get("table"), f"{where}: table") if command == "table" else None
    propeller = _propeller(spec.get("propeller"), f"{where}: propeller") if command == "propeller" else None
    for key, needed in (("table", "table"), ("propeller", "propeller")):
        if key in spec and command != needed:
            raise InputError(f"{where}: '{key}' given but 'command' is {command!r} (set command: {needed})")
    diameter = propeller.diameter_m if propeller is not None else number(
        f"{where}: diameter_m", spec.get("diameter_m", 0.0), minimum=0.0, maximum=20.0)
    return Thruster(name=name, x_m=number(f"{where}: x_m", spec.get("x_m"), minimum=-500.0, maximum=500.0),
                    y_m=number(f"{where}: y_m", spec.get("y_m", 0.0), minimum=-500.0, maximum=500.0),
                    steered=steered,
                    angle_rad=number(f"{where}: angle_rad", spec.get("angle_rad", 0.0), minimum=-math.pi,
                                     maximum=math.pi),
                    command=command, table=table, propeller=propeller, diameter_m=diameter)


def _rudder(data: Any, where: str, thrusters: tuple[Thruster, ...]) -> Rudder:
    spec = _mapping(data, where)
    _refuse_unknown(spec, RUDDER_KEYS, where)
    washed_by = spec.get("washed_by")
    names = [t.name for t in thrusters]
    if washed_by is not None and washed_by not in names:
        raise InputError(f"{where}: 'washed_by' names no thruster: {washed_by!r} (thrusters: {', '.join(names)})")
    if washed_by is not None and thrusters[names.index(washed_by)].diameter_m <= 0.0:
        raise InputError(f"{where}: thruster {washed_by!r} washes it but has no diameter_m (its slipstream's)")
    return Rudder(name=_name(spec.get("name"), where),
                  x_m=number(f"{where}: x_m", spec.get("x_m"), minimum=-500.0, maximum=500.0),
                  area_m2=number(f"{where}: area_m2", spec.get("area_m2"), above=0.0, maximum=1e4),
                  y_m=number(f"{where}: y_m", spec.get("y_m", 0.0), minimum=-500.0, maximum=500.0),
                  aspect_ratio=number(f"{where}: aspect_ratio", spec.get("aspect_ratio", 1.5), above=0.0,
                                      maximum=20.0),
                  washed_by=washed_by,
                  lift_slope_per_rad=None if spec.get("lift_slope_per_rad") is None else number(
                      f"{where}: lift_slope_per_rad", spec["lift_slope_per_rad"], above=0.0, maximum=4.0 * math.pi))


def propulsion_from_dict(data: Any, where: str) -> Propulsion:
    """The ``propulsion`` section of a boat file (module docstring); one line naming the field on any fault."""
    spec = _mapping(data, where)
    _refuse_unknown(spec, ("thrusters", "rudders"), where)
    listed = spec.get("thrusters")
    if not isinstance(listed, list) or not 1 <= len(listed) <= MAX_THRUSTERS:
        raise InputError(f"{where}: 'thrusters' must list one or {MAX_THRUSTERS} thrusters (the kernel's actuator "
                         f"slots), got {listed!r}")
    thrusters = tuple(_thruster(t, f"{where}: thrusters[{i}]") for i, t in enumerate(listed))
    rudder_list = spec.get("rudders", [])
    if not isinstance(rudder_list, list) or len(rudder_list) > MAX_RUDDERS:
        raise InputError(f"{where}: 'rudders' must list at most {MAX_RUDDERS} rudders, got {rudder_list!r}")
    rudders = tuple(_rudder(r, f"{where}: rudders[{i}]", thrusters) for i, r in enumerate(rudder_list))
    names = [t.name for t in thrusters] + [r.name for r in rudders]
    if len(set(names)) != len(names):
        raise InputError(f"{where}: thruster and rudder names must differ, got {', '.join(names)}")
    if rudders and any(t.steered for t in thrusters):
        raise InputError(f"{where}: a boat with rudders steers them: its thrusters must be fixed (steered: false)")
    return Propulsion(thrusters, rudders)


def propulsion_to_dict(propulsion: Propulsion) -> dict[str, Any]:
    """Plain data that :func:`propulsion_from_dict` reads back."""
    thrusters = []
    for t in propulsion.thrusters:
        item: dict[str, Any] = {"name": t.name, "x_m": t.x_m, "y_m": t.y_m, "steered": t.steered,
                                "command": t.command}
        if not t.steered:
            item["angle_rad"] = t.angle_rad
        if t.table is not None:
            item["table"] = {"command": list(t.table.command), "thrust_N": list(t.table.thrust_N),
                             "unit": t.table.unit}
        if t.propeller is not None:
            p = t.propeller
            item["propeller"] = {"diameter_m": p.diameter_m, "kt": list(p.kt), "wake_fraction": p.wake_fraction,
                                 "astern_ratio": p.astern_ratio}
        elif t.diameter_m > 0.0:
            item["diameter_m"] = t.diameter_m
        thrusters.append(item)
    rudders = [{"name": r.name, "x_m": r.x_m, "y_m": r.y_m, "area_m2": r.area_m2, "aspect_ratio": r.aspect_ratio,
                **({"lift_slope_per_rad": r.lift_slope_per_rad} if r.lift_slope_per_rad is not None else {}),
                **({"washed_by": r.washed_by} if r.washed_by else {})} for r in propulsion.rudders]
    return {"thrusters": thrusters, **({"rudders": rudders} if rudders else {})}

