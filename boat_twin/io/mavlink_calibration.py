"""The calibration map of a MAVLink log's commands: logged PWM pulse widths (µs) or joystick axes → per-engine
thrust (N) and steering angle (rad), read from YAML (see ``config/mavlink/``)::

    commands:
      thrust_left:  {source: SERVO1, table: [[1100, -1000.0], [1500, 0.0], [1900, 2000.0]]}
      angle_left:   {source: SERVO2, table: [[1100, -0.5236], [1900, 0.5236]]}
      angle_right:  {value: 0.0}

A boat with its own actuators (a boat file's propulsion section) names them by their command topics instead of
the slot roles (the same rule as a bag's per-actuator topics, :func:`~boat_twin.io.roles.actuator_roles`)::

    commands:
      thrusters/prop/cmd:  {source: SERVO3, table: [[1100, -20.0], [1500, 0.0], [1900, 20.0]]}   # rev/s
      rudders/main/angle:  {source: SERVO1, table: [[1100, 0.61], [1900, -0.61]]}                 # rad

(a single thruster leaves the second slot at 0).
``source`` is ``SERVO<n>``, ``RC<n>`` or ``MANUAL_CONTROL.<x|y|z|r>`` (where each is read:
:mod:`boat_twin.io.mavlink`); ``table`` lists [input, value] points with the input strictly increasing and the
value monotone, linear in between and clamped beyond; ``value`` gives a constant instead. A pulse width of 0 (no
pulse) or 65535 (unused channel) and a MANUAL_CONTROL axis of 32767 (invalid) map to NaN: the command is unknown.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.io.roles import COMMAND_ROLES, actuator_roles
from boat_twin.validation import number

ROLE_UNITS = {"thrust_left": "N", "thrust_right": "N", "angle_left": "rad", "angle_right": "rad"}
"""Unit of each command role's value."""

_SOURCE = re.compile(r"^(?:(SERVO|RC)([1-9][0-9]?)|MANUAL_CONTROL\.([XYZR]))$")
_MAX_CHANNEL = {"SERVO": 32, "RC": 18}
_INVALID_RAW = {"SERVO": (0.0, 65535.0), "RC": (0.0, 65535.0), "MANUAL_CONTROL": (32767.0,)}


@dataclass(frozen=True)
class CommandMap:
    """How one command role is read: a source and a piecewise linear table, or a constant ``value``."""

    role: str
    source: str | None
    """``SERVO<n>``, ``RC<n>`` or ``MANUAL_CONTROL.<axis>``; None for a constant."""
    raw: np.ndarray
    """Table inputs (PWM µs, or axis units), strictly increasing."""
    value: np.ndarray
    """Table outputs (N for thrust, rad for steering), monotone."""
    constant: float | None = None

    @property
    def kind(self) -> str:
        """``SERVO``, ``RC``, ``MANUAL_CONTROL`` or ``constant``."""
        return "constant" if self.source is None else self.source.split(".")[0].rstrip("0123456789")

    @property
    def channel(self) -> int | str:
        """Channel number (SERVO, RC) or axis letter (MANUAL_CONTROL, lower case)."""
        assert self.source is not None
        if self.kind == "MANUAL_CONTROL":
            return self.source.split(".")[1].lower()
        return int(self.source[len(self.kind):])

    def to_value(self, raw: Any) -> np.ndarray:
        """Logged inputs → command (N or rad); NaN for the 'no pulse / unused / invalid' codes."""
        raw = np.asarray(raw, dtype=float)
        if self.constant is not None:
            return np.full(raw.shape, self.constant)
        out = np.interp(raw, self.raw, self.value)
        return np.where(~np.isfinite(raw) | np.isin(raw, _INVALID_RAW[self.kind]), np.nan, out)

    def to_raw(self, value: Any) -> np.ndarray:
        """Command → logged input (the inverse map, e.g. to write a log): the middle of a flat stretch of the
        table, clamped to the table's ends."""
        if self.constant is not None:
            raise ValueError(f"{self.role} is a constant, it has no logged input")
        vals, raws = self.value, self.raw
        if vals[-1] < vals[0]:
            vals, raws = vals[::-1], raws[::-1]
        value = np.asarray(value, dtype=float)
        out = np.interp(value, vals, raws)  # exact inverse on every rising stretch
        for i in np.flatnonzero(np.diff(vals) == 0):  # a flat stretch (a dead band): its middle
            flat = np.flatnonzero(vals == vals[i])
            out = np.where(value == vals[i], 0.5 * (raws[flat[0]] + raws[flat[-1]]), out)
        return np.asarray(out, dtype=float)


@dataclass(frozen=True)
class Calibration:
    """Command role → :class:`CommandMap`; ``source`` names the file it came from."""

    commands: dict[str, CommandMap]
    source: str = "<calibration>"
    actuators: dict[str, str] = field(default_factory=dict)
    """Command role → the boat's actuator it was named by (``thrusters/<name>/cmd``...; empty: slot roles)."""

    def to_value(self, role: str, raw: Any) -> np.ndarray:
        """Logged inputs of ``role`` → N or rad."""
        return self.commands[role].to_value(raw)

    def to_raw(self, role: str, value: Any) -> np.ndarray:
        """N or rad of ``role`` → logged input (PWM µs or axis units), for writers of logs."""
        return self.commands[role].to_raw(value)


def calibration_from_dict(data: Any, source: str = "<calibration>", order: Sequence[str] = ()) -> Calibration:
    """Validate a calibration map (the YAML's content); every error names ``source`` and the field. ``order``: the
    boat file's actuator names in its order, which fill the slots (:func:`~boat_twin.io.roles.actuator_slots`)."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: a calibration must be a mapping with a 'commands' section")
    unknown = sorted(set(data) - {"commands", "description"})
    if unknown:
        raise InputError(f"{source}: unknown key '{unknown[0]}' (allowed: commands, description)")
    commands = data.get("commands")
    if not isinstance(commands, dict) or not commands:
        raise InputError(f"{source}: missing field 'commands' (role: {{source, table}} or {{value}})")
    roles = actuator_roles(commands, f"{source}: commands", order)
    maps = {}
    for key, entry in commands.items():
        role = roles.get(str(key), str(key))
        maps[role] = _command_map(role, entry, f"{source}: commands.{key}", _unit(str(key)))
    if roles and "thrust_left" in maps and "thrust_right" not in maps:  # a single thruster: no second slot
        maps["thrust_right"] = CommandMap("thrust_right", None, np.zeros(0), np.zeros(0), 0.0)
    return Calibration(maps, source, {role: key for key, role in roles.items()})


def _unit(key: str) -> str:
    """The unit of a command's values: N or rad for the slot roles; for an actuator's topic N (``thrust``), its
    table's unit or rev/s (``cmd``), rad (``pos``, ``angle``)."""
    if key in ROLE_UNITS:
        return ROLE_UNITS[key]
    return {"thrust": "N", "cmd": "the thruster's unit"}.get(key.rsplit("/", 1)[-1], "rad")


def _command_map(role: str, entry: Any, where: str, unit: str) -> CommandMap:
    """One role's entry validated (its values in ``unit``); errors name ``where`` (the file and the field)."""
    if role not in COMMAND_ROLES:
        raise InputError(f"{where}: unknown role (roles: {', '.join(COMMAND_ROLES)}, or a boat's actuators: "
                         "thrusters/<name>/thrust|cmd|pos, rudders/<name>/angle)")
    if not isinstance(entry, dict):
        raise InputError(f"{where}: expected a mapping with 'source' and 'table', or 'value'")
    extra = sorted(set(entry) - {"source", "table", "value", "description"})
    if extra:
        raise InputError(f"{where}: unknown key '{extra[0]}' (allowed: source, table, value, description)")
    if "value" in entry:
        if "source" in entry or "table" in entry:
            raise InputError(f"{where}: give either 'value' or 'source' with 'table', not both")
        constant = number(f"{where}.value", entry["value"])
        return CommandMap(role, None, np.zeros(0), np.zeros(0), constant)
    for key in ("source", "table"):
        if key not in entry:
            raise InputError(f"{where}: missing field '{key}'")
    spec = str(entry["source"]).strip().upper()
    match = _SOURCE.match(spec)
    if match is None:
        raise InputError(f"{where}.source: {entry['source']!r} is not SERVO<n>, RC<n> or MANUAL_CONTROL.<x|y|z|r>")
    if match.group(1) and not 1 <= int(match.group(2)) <= _MAX_CHANNEL[match.group(1)]:
        raise InputError(f"{where}.source: channel {match.group(2)} out of range 1-{_MAX_CHANNEL[match.group(1)]}")
    table = entry["table"]
    if not isinstance(table, list) or len(table) < 2:
        raise InputError(f"{where}.table: expected at least two [input, {unit}] points")
    points = []
    for i, point in enumerate(table):
        if not isinstance(point, (list, tuple)) or len(point) != 2:
            raise InputError(f"{where}.table[{i}]: expected [input, {unit}], got {point!r}")
        points.append((number(f"{where}.table[{i}]", point[0]), number(f"{where}.table[{i}]", point[1])))
    raw = np.array([p[0] for p in points])
    value = np.array([p[1] for p in points])
    if np.any(np.diff(raw) <= 0):
        raise InputError(f"{where}.table: inputs must be strictly increasing")
    steps = np.diff(value)
    if np.any(steps > 0) and np.any(steps < 0):
        raise InputError(f"{where}.table: values must be monotone (all rising or all falling)")
    return CommandMap(role, spec, raw, value)


def load_calibration(path: Path, order: Sequence[str] = ()) -> Calibration:
    """Read and validate a calibration YAML (format: the module docstring and ``config/mavlink/``); ``order``: the
    boat file's actuator names in its order."""
    return calibration_from_dict(load_yaml(Path(path)), str(path), order)

