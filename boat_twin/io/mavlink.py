"""MAVLink logs into a :class:`~boat_twin.io.trial.Trial`: telemetry logs (.tlog) and DataFlash logs (.BIN).

What is read, per trial role (a .tlog's vehicle is the system and component of its first vehicle HEARTBEAT,
pymavlink's own rule; other systems are ignored except for MANUAL_CONTROL addressed to the vehicle):

============  =====================================================  ========================================
role          .tlog                                                  DataFlash .BIN
============  =====================================================  ========================================
gnss_fix      GLOBAL_POSITION_INT (default) or GPS_RAW_INT (≥ 2D)    GPS (instance 0, Status ≥ 2D fix)
gnss_vel      the same message: vx, vy (or vel and cog)              GPS: Spd and GCrs
imu           ATTITUDE (+ RAW_IMU accelerations)                     ATT (+ IMU instance 0 rates, accelerations)
commands      SERVO_OUTPUT_RAW, RC_CHANNELS or MANUAL_CONTROL        RCOU or RCIN
              through the calibration map                           through the calibration map
============  =====================================================  ========================================

Conventions. ArduPilot reports in NED (world) and FRD (body); boat_twin is ENU/FLU inside (REP-103):

- heading: ENU yaw ψ = π/2 − ψ_NED, wrapped to [−π, π) (ψ_NED clockwise from north, ATT.Yaw in degrees);
- roll stays, pitch_FLU = −pitch_FRD; body rates (p, −q, −r); specific force (ax, −ay, −az), +g on z at rest;
- velocity over ground: east = vy, north = vx (GLOBAL_POSITION_INT, cm/s); GPS_RAW_INT and GPS give the speed
  and the course c clockwise from north: (east, north) = speed·(sin c, cos c);
- altitude: above mean sea level, as these messages give it (the geoid undulation is a constant offset that a
  boat's local ENU frame does not notice);
- RAW_IMU: accelerations in milli-g (9.80665e-3 m/s² each), angular rates in mrad/s, as ArduPilot sends them.

Time. Every sample carries the log's own clock. A .tlog stamps each message with the ground station's Unix
receive time; the autopilot's messages also carry its boot time (time_boot_ms, time_usec; SERVO_OUTPUT_RAW's
32-bit time_usec is unwrapped against time_boot_ms). Boot times are mapped to Unix time with one offset per
boot, the smallest (receive − boot) seen, i.e. the least-delayed message (receive times far below the median
delay are corrupt and ignored): the receive jitter of the radio link is removed; clock drift (tens of ppm) is
not modelled. A boot time that jumps back by more than :data:`REBOOT_BACKSTEP_S` starts a new boot (a reboot,
counted). Messages without a clock of their own (MANUAL_CONTROL) keep the receive time. A DataFlash log's
clock is TimeUS since boot (older logs: TimeMS; in GPS, T), plus pymavlink's GPS time base when the log has GPS
time. A stamp that leaps away from both neighbours and back (a corrupt time field) is dropped and counted;
backward steps of a stream's stamps are counted (``non_monotone``) and the samples sorted; gaps and missing
streams are reported as for bags, and a command read from periodic telemetry is NaN (unknown, reported as a
gap) where that telemetry fell silent, not held.

Calibration. Commands are logged as PWM pulse widths (µs) or joystick axes; a YAML calibration map (see
``config/mavlink/``) turns them into per-engine thrust (N) and steering angle (rad)::

    commands:
      thrust_left:  {source: SERVO1, table: [[1100, -1000.0], [1500, 0.0], [1900, 2000.0]]}
      angle_left:   {source: SERVO2, table: [[1100, -0.5236], [1900, 0.5236]]}
      angle_right:  {value: 0.0}

``source`` is ``SERVO<n>`` (SERVO_OUTPUT_RAW servo<n>_raw / RCOU C<n>, or Ch<n>, Chan<n> in older logs), ``RC<n>``
(RC_CHANNELS chan<n>_raw / RCIN C<n>) or ``MANUAL_CONTROL.<x|y|z|r>`` (.tlog only, axis units −1000…1000);
``table`` lists [input, value] points with the input strictly increasing and the value monotone, linear in
between and clamped beyond; a channel the log does not have is an error naming it.
``value`` gives a constant instead (e.g. outboards that do not steer). The steering angle is the twin's: the
counter-clockwise (FLU) angle of the thrust vector, positive pushes the stern to port and turns the boat to
starboard. A pulse width of 0 (no pulse) or 65535 (unused channel) and a MANUAL_CONTROL axis of 32767 (invalid)
give NaN: the command is unknown there (reported as a gap). Without a calibration the command roles are
reported missing.

Reading streams through pymavlink's ``recv_match`` loop for the few message types needed (its index of a
.tlog lets it skip the others) and appends numbers to flat arrays: no message objects are kept. Anything
pymavlink cannot read becomes an :class:`~boat_twin.errors.InputError` naming the file.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import sys
import tempfile
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.frames import enu_yaw_from_ned, wrap_pi
from boat_twin.io.trial import (
    COMMAND_ROLES,
    GAP_TOLERANCE_PERIODS,
    SENSOR_ROLES,
    Stream,
    Trial,
    TrialMetadata,
    build_trial,
)
from boat_twin.units import STANDARD_GRAVITY_MPS2
from boat_twin.validation import number

LOG_SUFFIXES = (".tlog", ".bin")
"""File name endings (case-insensitive) read as MAVLink logs: telemetry logs and DataFlash logs."""
"""Standard gravity: RAW_IMU's milli-g to m/s², m/s²."""
REBOOT_BACKSTEP_S = 5.0
"""A boot time going back by more than this is a reboot of the autopilot, s."""
USEC32_WRAP_S = 2.0**32 * 1e-6
"""Period of a 32-bit microsecond counter (SERVO_OUTPUT_RAW.time_usec), s (about 71.6 min)."""
UNIX_USEC_MIN = 1e15
"""A 64-bit time_usec at least this large is Unix time (µs), not time since boot."""
DELAY_OUTLIER_S = 1.0
"""A .tlog receive delay this much below the median is a corrupt receive time, not a fast link, s."""
LATEST_RECEIVE_S = 4_102_444_800.0
"""Latest plausible .tlog receive stamp, Unix s (2100-01-01): beyond (2^64 - 1 us is 5.8e5 years) it is unset or
corrupt."""
VEHICLE_SEARCH_MESSAGES = 5000
"""How many messages of a .tlog are searched for the first vehicle HEARTBEAT."""
IMU_COLUMNS = ("yaw_rad", "yaw_rate_radps", "accel_x_mps2", "accel_y_mps2", "roll_rad", "pitch_rad",
               "roll_rate_radps", "pitch_rate_radps", "accel_z_mps2")
"""Columns of the ``imu`` stream of a :class:`MavlinkLog`: the Trial's four (ENU yaw, FLU yaw rate, FLU
accelerations x and y), then the rest of the attitude for writing full sensor_msgs/Imu messages."""
GNSS_SOURCES = {"tlog": ("GLOBAL_POSITION_INT", "GPS_RAW_INT"), "dataflash": ("GPS",)}
"""Messages a GNSS role can come from, in order of preference (``remap`` picks one)."""
IMU_SOURCES = {"tlog": ("ATTITUDE",), "dataflash": ("ATT",)}
"""Messages the heading comes from."""

_SOURCE = re.compile(r"^(?:(SERVO|RC)([1-9][0-9]?)|MANUAL_CONTROL\.([XYZR]))$")
_MAX_CHANNEL = {"SERVO": 32, "RC": 18}
_INVALID_RAW = {"SERVO": (0.0, 65535.0), "RC": (0.0, 65535.0), "MANUAL_CONTROL": (32767.0,)}
_ROLE_UNITS = {"thrust_left": "N", "thrust_right": "N", "angle_left": "rad", "angle_right": "rad"}


# --------------------------------------------------------------------------------------------- calibration
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

    def to_value(self, role: str, raw: Any) -> np.ndarray:
        """Logged inputs of ``role`` → N or rad."""
        return self.commands[role].to_value(raw)

    def to_raw(self, role: str, value: Any) -> np.ndarray:
        """N or rad of ``role`` → logged input (PWM µs or axis units), for writers of logs."""
        return self.commands[role].to_raw(value)


def calibration_from_dict(data: Any, source: str = "<calibration>") -> Calibration:
    """Validate a calibration map (the YAML's content); every error names ``source`` and the field."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: a calibration must be a mapping with a 'commands' section")
    unknown = sorted(set(data) - {"commands", "description"})
    if unknown:
        raise InputError(f"{source}: unknown key '{unknown[0]}' (allowed: commands, description)")
    commands = data.get("commands")
    if not isinstance(commands, dict) or not commands:
        raise InputError(f"{source}: missing field 'commands' (role: {{source, table}} or {{value}})")
    maps: dict[str, CommandMap] = {}
    for role, entry in commands.items():
        where = f"{source}: commands.{role}"
        if role not in COMMAND_ROLES:
            raise InputError(f"{where}: unknown role (roles: {', '.join(COMMAND_ROLES)})")
        if not isinstance(entry, dict):
            raise InputError(f"{where}: expected a mapping with 'source' and 'table', or 'value'")
        extra = sorted(set(entry) - {"source", "table", "value", "description"})
        if extra:
            raise InputError(f"{where}: unknown key '{extra[0]}' (allowed: source, table, value, description)")
        if "value" in entry:
            if "source" in entry or "table" in entry:
                raise InputError(f"{where}: give either 'value' or 'source' with 'table', not both")
            constant = number(f"{where}.value", entry["value"])
            maps[role] = CommandMap(role, None, np.zeros(0), np.zeros(0), constant)
            continue
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
            raise InputError(f"{where}.table: expected at least two [input, {_ROLE_UNITS[role]}] points")
        points = []
        for i, point in enumerate(table):
            if not isinstance(point, (list, tuple)) or len(point) != 2:
                raise InputError(f"{where}.table[{i}]: expected [input, {_ROLE_UNITS[role]}], got {point!r}")
            points.append((number(f"{where}.table[{i}]", point[0]), number(f"{where}.table[{i}]", point[1])))
        raw = np.array([p[0] for p in points])
        value = np.array([p[1] for p in points])
        if np.any(np.diff(raw) <= 0):
            raise InputError(f"{where}.table: inputs must be strictly increasing")
        steps = np.diff(value)
        if np.any(steps > 0) and np.any(steps < 0):
            raise InputError(f"{where}.table: values must be monotone (all rising or all falling)")
        maps[role] = CommandMap(role, spec, raw, value)
    return Calibration(maps, source)


def load_calibration(path: Path) -> Calibration:
    """Read and validate a calibration YAML (format: the module docstring and ``config/mavlink/``)."""
    return calibration_from_dict(load_yaml(Path(path)), str(path))


# --------------------------------------------------------------------------------------------- results
@dataclass
class MavlinkTrialMetadata(TrialMetadata):
    """:class:`TrialMetadata` of a MAVLink log, with what the log itself said about its quality."""

    log_format: str = ""
    """``tlog`` or ``dataflash``."""
    log_messages: int = 0
    """Messages in the file (pymavlink's index of it), read or not."""
    message_counts: dict[str, int] = field(default_factory=dict)
    """Message type → messages decoded of the types the import reads (all systems)."""
    corrupt: int = 0
    """Frames of those types that failed to decode (bad CRC, truncated) and were skipped."""
    log_span_s: tuple[float, float] = (math.nan, math.nan)
    """First and last time of the messages read, s: Unix receive time (.tlog), the trial's clock (DataFlash)."""
    non_monotone: dict[str, int] = field(default_factory=dict)
    """Role → backward steps of its stamps in the order logged (the samples were sorted)."""
    reboots: int = 0
    """Autopilot reboots seen in the log (its boot time went back)."""
    time_base: str = ""
    """What the stamps (and ``start_time_s``) are: Unix time or time since boot."""
    notes: list[str] = field(default_factory=list)
    """Anything else the reader noticed, one short phrase each."""

    def summary_line(self) -> str:
        """The bag summary, then the log's own quality: messages, span, corrupt, non-monotone, reboots, notes."""
        start, end = self.log_span_s
        span = f" over {end - start:.1f} s" if math.isfinite(start) and math.isfinite(end) else ""
        extra = [f"{self.log_messages} {self.log_format} messages{span}"]
        if self.corrupt:
            extra.append(f"{self.corrupt} corrupt frame(s) skipped")
        if self.non_monotone:
            extra.append("non-monotone times: " + ", ".join(f"{r} {n}" for r, n in self.non_monotone.items()))
        if self.reboots:
            extra.append(f"{self.reboots} autopilot reboot(s)")
        return super().summary_line() + "; " + "; ".join(extra + self.notes)


@dataclass
class MavlinkLog:
    """What one log gave, before gridding: per-role streams (SI, ENU/FLU; stamps on the log's clock, s,
    in logged order) and how they were read. The ``imu`` stream has the columns :data:`IMU_COLUMNS`."""

    source: str
    log_format: str
    streams: dict[str, Stream]
    topics: dict[str, str]
    """Role → the message (and field) it came from."""
    constants: dict[str, float] = field(default_factory=dict)
    """Command roles the calibration fixes to a constant (N or rad)."""
    periodic_commands: set[str] = field(default_factory=set)
    """Command roles read from periodic telemetry: a silence there is a gap, not a held command."""
    log_messages: int = 0
    message_counts: dict[str, int] = field(default_factory=dict)
    corrupt: int = 0
    log_span_s: tuple[float, float] = (math.nan, math.nan)
    reboots: int = 0
    time_base: str = ""
    notes: list[str] = field(default_factory=list)

    def non_monotone(self) -> dict[str, int]:
        """Role → backward steps of its stamps, for the roles that have any."""
        steps = {role: int(np.sum(np.diff(s.stamps_s) < 0)) for role, s in self.streams.items()}
        return {role: n for role, n in steps.items() if n}


# --------------------------------------------------------------------------------------------- reading
class _Rows:
    """Rows of numbers appended to one flat ``array('d')``: bounded memory, no message objects kept."""

    __slots__ = ("data", "width")

    def __init__(self, width: int) -> None:
        self.width = width
        self.data = array("d")

    def add(self, row: tuple[float, ...]) -> None:
        self.data.extend(row)

    def array(self) -> np.ndarray:
        """The rows as an (n, width) view of the buffer (no copy; append nothing after this)."""
        return np.frombuffer(self.data, dtype=float).reshape(-1, self.width)


class _Chatter:
    """A text sink for what pymavlink prints about bad bytes: counts the lines, keeps the first."""

    def __init__(self) -> None:
        self.lines = 0
        self.first = ""
        self._partial = ""

    def write(self, text: str) -> int:
        text = self._partial + text
        *complete, self._partial = text.split("\n")
        for line in complete:
            if line.strip():
                self.lines += 1
                self.first = self.first or line.strip()[:120]
        return len(text)

    def flush(self) -> None:
        pass


@contextlib.contextmanager
def _quiet(chatter: _Chatter) -> Iterator[None]:
    """Silence pymavlink while it reads: Python prints go to ``chatter``; its compiled DataFlash indexer writes
    straight to file descriptors 1 and 2, which go to a temporary file whose lines are counted afterwards."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with contextlib.ExitStack() as stack:
        try:
            sink = stack.enter_context(tempfile.TemporaryFile(mode="w+b"))
        except OSError:
            sink = None
        saved = []
        try:
            for fd in (1, 2) if sink is not None else ():
                try:
                    saved.append((fd, os.dup(fd)))
                    os.dup2(sink.fileno(), fd)  # type: ignore[union-attr]  # not None: see the loop's range
                except OSError:
                    pass
            with contextlib.redirect_stdout(chatter), contextlib.redirect_stderr(chatter):
                yield
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            if sink is not None:
                sink.seek(0)
                while block := sink.read(1 << 20):
                    chatter.write(block.decode("utf-8", "replace"))


class _BootClock:
    """Autopilot boot time → the .tlog's receive clock, one offset per boot: the smallest receive delay
    (receive − boot time), ignoring delays more than :data:`DELAY_OUTLIER_S` below the median (a receive
    time that is not CRC-protected and got corrupted)."""

    def __init__(self) -> None:
        self.delays = [array("d")]
        self.loose = [array("d")]
        self.top = -math.inf
        self.reboots = 0

    def now(self, boot_s: float, recv_s: float) -> int:
        """A 'current' boot stamp (time_boot_ms, RAW_IMU, SERVO): detect reboots, note the delay."""
        if boot_s < self.top - REBOOT_BACKSTEP_S:
            self.delays.append(array("d"))
            self.loose.append(array("d"))
            self.reboots += 1
            self.top = boot_s
        elif boot_s > self.top:
            self.top = boot_s
        self.delays[-1].append(recv_s - boot_s)
        return len(self.delays) - 1

    def stale(self, boot_s: float, recv_s: float) -> int:
        """A boot stamp that may be old (GPS_RAW_INT: time of the last fix): a fallback delay only."""
        self.loose[-1].append(recv_s - boot_s)
        return len(self.delays) - 1

    def final_offsets(self) -> np.ndarray:
        offsets = []
        for delays, loose in zip(self.delays, self.loose, strict=True):
            d = np.frombuffer(delays if len(delays) else loose, dtype=float)
            d = d[np.isfinite(d)]
            offsets.append(float(d[d >= np.median(d) - DELAY_OUTLIER_S].min()) if d.size else 0.0)
        return np.array(offsets)




@dataclass
class _Plan:
    """Which messages and channels one import needs."""

    log_format: str
    calibration: Calibration | None
    channels: dict[str, list[int | str]] = field(default_factory=dict)
    """Command kind (SERVO, RC, MANUAL_CONTROL) → channels (or axes) needed, sorted."""

    def __post_init__(self) -> None:
        needed: dict[str, set[int | str]] = {}
        if self.calibration is not None:
            for cmap in self.calibration.commands.values():
                if cmap.source is not None:
                    needed.setdefault(cmap.kind, set()).add(cmap.channel)
        self.channels = {kind: sorted(chans, key=str) if kind == "MANUAL_CONTROL" else sorted(chans)
                         for kind, chans in needed.items()}

    def numbered(self, kind: str) -> list[int]:
        """The channel numbers of SERVO or RC commands, ascending."""
        return [int(c) for c in self.channels.get(kind, [])]

    def axes(self) -> list[str]:
        """The MANUAL_CONTROL axes needed (x, y, z, r), sorted."""
        return [str(a) for a in self.channels.get("MANUAL_CONTROL", [])]


_TLOG_COMMAND_MESSAGES = {"SERVO": "SERVO_OUTPUT_RAW", "RC": "RC_CHANNELS", "MANUAL_CONTROL": "MANUAL_CONTROL"}
_DF_COMMAND_MESSAGES = {"SERVO": "RCOU", "RC": "RCIN"}


def _find_vehicle(path: Path) -> tuple[int, int] | None:
    """(system, component) of the first vehicle HEARTBEAT in the first messages of a .tlog (pymavlink's rule)."""
    from pymavlink import mavutil

    conn = mavutil.mavlogfile(str(path))
    try:
        for _ in range(VEHICLE_SEARCH_MESSAGES):
            msg = conn.recv_msg()
            if msg is None:
                break
            if msg.get_type() == "HEARTBEAT" and conn.probably_vehicle_heartbeat(msg):
                return msg.get_srcSystem(), msg.get_srcComponent()
    finally:
        conn.close()
    return None


def _read_tlog(path: Path, plan: _Plan, rows: dict[str, _Rows], info: dict[str, Any]) -> None:
    """Stream a .tlog into ``rows`` (first two columns: time s, boot index or −1 for absolute time)."""
    from pymavlink import mavutil

    vehicle = _find_vehicle(path)
    if vehicle is None:
        info["notes"].append("no vehicle HEARTBEAT: messages of every system read")
    clock = _BootClock()
    info["clock"] = clock
    servo_channels = plan.numbered("SERVO")
    rc_channels = plan.numbered("RC")
    axes = plan.axes()
    mg = STANDARD_GRAVITY_MPS2 * 1e-3
    servo_state = {"last": -1.0, "wraps": 0}

    def usec64(usec: int, recv: float, current: bool) -> tuple[float, float]:
        if usec >= UNIX_USEC_MIN:
            return usec * 1e-6, -1.0
        boot = usec * 1e-6
        return boot, float(clock.now(boot, recv) if current else clock.stale(boot, recv))

    def global_position(msg: Any, recv: float) -> None:
        if msg.lat == 0 and msg.lon == 0:
            return  # no position estimate yet
        boot = msg.time_boot_ms * 1e-3
        rows["GLOBAL_POSITION_INT"].add((boot, clock.now(boot, recv), msg.lat * 1e-7, msg.lon * 1e-7,
                                         msg.alt * 1e-3, msg.vy * 0.01, msg.vx * 0.01))

    def gps_raw(msg: Any, recv: float) -> None:
        if msg.fix_type < 2:
            return  # no fix
        t, sid = usec64(msg.time_usec, recv, current=False)
        if msg.vel == 65535 or msg.cog == 65535:
            east = north = math.nan
        else:
            course = math.radians(msg.cog * 0.01)
            east, north = msg.vel * 0.01 * math.sin(course), msg.vel * 0.01 * math.cos(course)
        rows["GPS_RAW_INT"].add((t, sid, msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3, east, north))

    def attitude(msg: Any, recv: float) -> None:
        if not (math.isfinite(msg.yaw) and math.isfinite(msg.yawspeed)):
            return
        boot = msg.time_boot_ms * 1e-3
        rows["ATTITUDE"].add((boot, clock.now(boot, recv), wrap_pi(enu_yaw_from_ned(msg.yaw)), -msg.yawspeed,
                              msg.roll, -msg.pitch, msg.rollspeed, -msg.pitchspeed))

    def raw_imu(msg: Any, recv: float) -> None:
        if "id" in msg.fieldnames and msg.id:  # (without the field, msg.id is the message id)
            return  # a second IMU
        t, sid = usec64(msg.time_usec, recv, current=True)
        rows["RAW_IMU"].add((t, sid, msg.xacc * mg, -msg.yacc * mg, -msg.zacc * mg,
                             msg.xgyro * 1e-3, -msg.ygyro * 1e-3, -msg.zgyro * 1e-3))

    def servo_output(msg: Any, recv: float) -> None:
        usec = msg.time_usec
        if math.isfinite(clock.top):  # unwrap the 32-bit µs counter against the boot clock
            wraps = max(0, round((clock.top - usec * 1e-6) / USEC32_WRAP_S))
        else:
            if usec < servo_state["last"] - 2**31:
                servo_state["wraps"] += 1
            wraps = servo_state["wraps"]
        servo_state["last"] = usec
        boot = usec * 1e-6 + wraps * USEC32_WRAP_S
        sid = clock.now(boot, recv)
        base = 8 * getattr(msg, "port", 0)
        values = []
        for channel in servo_channels:
            index = channel - base
            values.append(float(getattr(msg, f"servo{index}_raw", -1)) if 1 <= index <= 16 else -1.0)
        rows["SERVO_OUTPUT_RAW"].add((boot, sid, *values))

    def rc_input(msg: Any, recv: float) -> None:
        boot = msg.time_boot_ms * 1e-3
        rows["RC_CHANNELS"].add((boot, clock.now(boot, recv),
                                 *(float(getattr(msg, f"chan{c}_raw", -1)) for c in rc_channels)))

    def manual_control(msg: Any, recv: float) -> None:
        rows["MANUAL_CONTROL"].add((recv, -1.0, *(float(getattr(msg, a)) for a in axes)))

    handlers: dict[str, Callable[[Any, float], None]] = {
        "ATTITUDE": attitude, "RAW_IMU": raw_imu, "GLOBAL_POSITION_INT": global_position, "GPS_RAW_INT": gps_raw}
    for name, width in (("ATTITUDE", 8), ("RAW_IMU", 8), ("GLOBAL_POSITION_INT", 7), ("GPS_RAW_INT", 7)):
        rows[name] = _Rows(width)
    if servo_channels:
        handlers["SERVO_OUTPUT_RAW"], rows["SERVO_OUTPUT_RAW"] = servo_output, _Rows(2 + len(servo_channels))
    if rc_channels:
        handlers["RC_CHANNELS"], rows["RC_CHANNELS"] = rc_input, _Rows(2 + len(rc_channels))
    if axes:
        handlers["MANUAL_CONTROL"], rows["MANUAL_CONTROL"] = manual_control, _Rows(2 + len(axes))
    types = set(handlers) | {"HEARTBEAT", "BAD_DATA"}

    try:
        conn = mavutil.mavmmaplog(str(path))
        indexed = True
    except Exception as err:  # pymavlink's index trips over some corrupt files: read them sequentially
        conn = mavutil.mavlogfile(str(path))
        indexed = False
        info["notes"].append(f"pymavlink could not index the file ({type(err).__name__}): read sequentially")
    counts: dict[str, int] = {}
    total = corrupt = odd = unset = 0
    first = last = math.nan
    try:
        while True:
            msg = conn.recv_match(type=types) if indexed else conn.recv_msg()
            if msg is None:
                break
            total += 1
            name = msg.get_type()
            if name == "BAD_DATA":
                corrupt += 1
                continue
            if name not in types:
                continue
            counts[name] = counts.get(name, 0) + 1
            recv = msg._timestamp
            if not 0.0 < recv <= LATEST_RECEIVE_S:  # e.g. 2^64 - 1 us: an unset or corrupt receive stamp
                unset += 1
                recv = math.nan  # no receive delay from it; a message timed by it alone is dropped
            else:
                if not first <= recv:  # also true while first is NaN
                    first = recv
                if not last >= recv:
                    last = recv
            handler = handlers.get(name)
            if handler is None:
                continue
            if name == "MANUAL_CONTROL":
                if vehicle is not None and msg.target not in (0, vehicle[0]):
                    continue
            elif vehicle is not None and (msg.get_srcSystem(), msg.get_srcComponent()) != vehicle:
                continue
            try:
                handler(msg, recv)
            except (AttributeError, TypeError, ValueError, OverflowError):
                odd += 1
        info["log_messages"] = int(getattr(conn, "_count", 0)) if indexed else total
    finally:
        conn.close()
    if odd:
        info["notes"].append(f"{odd} message(s) with unexpected fields skipped")
    if unset:
        info["notes"].append(f"WARNING: {unset} of {sum(counts.values())} .tlog receive stamp(s) are no Unix time "
                             "(0, or beyond the year 2100, e.g. 2^64-1 us: unset or corrupt): ignored; "
                             + ("the stamps are the autopilot's boot time only" if unset == sum(counts.values())
                                else "their messages timed by the autopilot's boot time"))
    info.update(message_counts=counts, corrupt=corrupt, log_span_s=(first, last), reboots=clock.reboots)
    info["time_base"] = "Unix time: autopilot boot time + the smallest tlog receive delay, per boot"


CHANNEL_FIELDS = ("C{}", "Ch{}", "Chan{}")
"""Names of output/input channel n in RCOU and RCIN, newest first: C<n> (2015 on), Ch<n> and Chan<n> (older)."""


def _channel_field(m: Any, name: str, channel: int, path: Path) -> str:
    """The field of ``m`` (an RCOU or RCIN message) that holds ``channel``; a missing channel is an error."""
    for pattern in CHANNEL_FIELDS:
        if pattern.format(channel) in m._fieldnames:
            return pattern.format(channel)
    raise InputError(f"{path}: {name} has no channel {channel} (its fields: {', '.join(m._fieldnames)}); the "
                     f"calibration's {'SERVO' if name == 'RCOU' else 'RC'}{channel} is not in this log")


def _dataflash_boot_s(m: Any) -> float | None:
    """Time since boot of a DataFlash message, s: TimeUS (2015 on), or in older logs TimeMS — except in GPS,
    where TimeMS is the GPS time of week and T is the time since boot. None: the message has no clock."""
    time_us = getattr(m, "TimeUS", None)
    if time_us is not None:
        return float(time_us) * 1e-6
    if m.get_type() in ("GPS", "GPS2"):
        boot_ms = getattr(m, "T", None)
        return None if boot_ms is None else float(boot_ms) * 1e-3
    time_ms = getattr(m, "TimeMS", None)
    return None if time_ms is None else float(time_ms) * 1e-3


def _read_dataflash(path: Path, plan: _Plan, rows: dict[str, _Rows], info: dict[str, Any]) -> None:
    """Stream a DataFlash log into ``rows`` (first two columns: time since boot in s, boot index 0)."""
    from pymavlink import DFReader

    reader = DFReader.DFReader_binary(str(path))
    base = float(getattr(reader.clock, "timebase", 0.0) or 0.0) \
        if isinstance(reader.clock, (DFReader.DFReaderClock_usec, DFReader.DFReaderClock_msec)) else 0.0
    servo_channels = plan.numbered("SERVO")
    rc_channels = plan.numbered("RC")
    if plan.channels.get("MANUAL_CONTROL"):
        info["notes"].append("MANUAL_CONTROL is not in DataFlash logs")

    def gps(m: Any, t: float) -> None:
        if getattr(m, "I", 0) != 0 or m.Status < 2:
            return
        course = math.radians(m.GCrs)
        rows["GPS"].add((t, 0.0, m.Lat, m.Lng, m.Alt, m.Spd * math.sin(course), m.Spd * math.cos(course)))

    def att(m: Any, t: float) -> None:
        if math.isfinite(m.Yaw):
            rows["ATT"].add((t, 0.0, wrap_pi(enu_yaw_from_ned(math.radians(m.Yaw))), math.radians(m.Roll),
                             -math.radians(m.Pitch)))

    def imu(m: Any, t: float) -> None:
        if getattr(m, "I", 0) == 0:
            rows["IMU"].add((t, 0.0, m.GyrX, -m.GyrY, -m.GyrZ, m.AccX, -m.AccY, -m.AccZ))

    def channels(name: str, chans: list[int]) -> Callable[[Any, float], None]:
        fields: list[str] = []

        def read(m: Any, t: float) -> None:
            if not fields:
                fields.extend(_channel_field(m, name, c, path) for c in chans)
            rows[name].add((t, 0.0, *(float(getattr(m, f)) for f in fields)))
        return read

    handlers: dict[str, Callable[[Any, float], None]] = {"GPS": gps, "ATT": att, "IMU": imu}
    for name, width in (("GPS", 7), ("ATT", 5), ("IMU", 8)):
        rows[name] = _Rows(width)
    if servo_channels:
        handlers["RCOU"], rows["RCOU"] = channels("RCOU", servo_channels), _Rows(2 + len(servo_channels))
    if rc_channels:
        handlers["RCIN"], rows["RCIN"] = channels("RCIN", rc_channels), _Rows(2 + len(rc_channels))
    counts: dict[str, int] = {}
    first = last = math.nan
    odd = 0
    types = list(handlers)
    try:
        while True:
            m = reader.recv_match(type=types, strict=True)
            if m is None:
                break
            name = m.get_type()
            boot_s = _dataflash_boot_s(m)
            if name not in handlers or boot_s is None:
                continue
            counts[name] = counts.get(name, 0) + 1
            t = boot_s + base
            if not first <= t:
                first = t
            if not last >= t:
                last = t
            try:
                handlers[name](m, t)
            except (AttributeError, TypeError, ValueError, OverflowError):
                odd += 1
        info["log_messages"] = int(getattr(reader, "_count", 0))
    finally:
        reader.close()
    if odd:
        info["notes"].append(f"{odd} message(s) with unexpected fields skipped")
    info.update(message_counts=counts, corrupt=0, log_span_s=(first, last), reboots=0)
    stamp = "TimeMS" if isinstance(reader.clock, DFReader.DFReaderClock_msec) else "TimeUS"
    info["time_base"] = (f"Unix time: {stamp} + the log's GPS time base" if base
                         else f"seconds since autopilot boot ({stamp}; no GPS time in the log)")


def _time_spikes(t: np.ndarray) -> np.ndarray:
    """Samples whose stamp leaps away from both neighbours (in logged order) by more than
    :data:`REBOOT_BACKSTEP_S` and back: corrupt time fields (DataFlash has no checksum). A mask."""
    spike = np.zeros(t.size, dtype=bool)
    if t.size < 3:
        return spike
    before, after = t[1:-1] - t[:-2], t[1:-1] - t[2:]
    spike[1:-1] = ((before > REBOOT_BACKSTEP_S) & (after > REBOOT_BACKSTEP_S)) | (
        (before < -REBOOT_BACKSTEP_S) & (after < -REBOOT_BACKSTEP_S))
    steady = REBOOT_BACKSTEP_S
    spike[0] = abs(t[0] - t[1]) > steady and abs(t[1] - t[2]) <= steady
    spike[-1] = abs(t[-1] - t[-2]) > steady and abs(t[-2] - t[-3]) <= steady
    return spike


def _absolute(table: np.ndarray, clock: _BootClock | None) -> np.ndarray:
    """Column 0 (time) on the absolute clock, using column 1 (boot index, −1 = already absolute)."""
    t = table[:, 0].copy()
    if clock is not None and t.size:
        offsets = clock.final_offsets()
        sid = table[:, 1].astype(int)
        booted = sid >= 0
        t[booted] += offsets[np.clip(sid[booted], 0, offsets.size - 1)]
    return t


def _resample(src_t: np.ndarray, src_v: np.ndarray, dst_t: np.ndarray) -> np.ndarray:
    """Linear interpolation of (n, k) samples onto ``dst_t``; NaN outside them and across gaps."""
    out = np.full((dst_t.size, src_v.shape[1]), np.nan)
    order = np.argsort(src_t, kind="stable")
    t = src_t[order]
    keep = np.concatenate([[True], np.diff(t) > 0]) if t.size else np.zeros(0, bool)
    rows, t = order[keep], t[keep]
    if t.size == 0:
        return out
    if t.size == 1:
        out[np.abs(dst_t - t[0]) < 1e-6] = src_v[rows[0]]
        return out
    max_gap = GAP_TOLERANCE_PERIODS * float(np.median(np.diff(t)))
    right = np.clip(np.searchsorted(t, dst_t), 1, t.size - 1)
    bad = (dst_t < t[0] - 1e-6) | (dst_t > t[-1] + 1e-6) | (t[right] - t[right - 1] > max_gap)
    for k in range(src_v.shape[1]):  # column by column: no (n, k) temporaries
        column = np.interp(dst_t, t, src_v[rows, k])
        column[bad] = np.nan
        out[:, k] = column
    return out


def _choose(role: str, options: tuple[str, ...], remap: dict[str, str], tables: dict[str, np.ndarray]
            ) -> str | None:
    """The message a sensor role comes from: the remapped one, else the first with at least two samples."""
    if role in remap:
        return remap[role]
    return next((name for name in options if tables.get(name, np.zeros((0, 1))).shape[0] >= 2), None)


def _check_remap(remap: dict[str, str], namespace: str, log_format: str, source: str) -> dict[str, str]:
    if namespace:
        raise InputError(f"{source}: --namespace applies to bags, not to MAVLink logs")
    allowed = {"gnss_fix": GNSS_SOURCES[log_format], "gnss_vel": GNSS_SOURCES[log_format],
               "imu": IMU_SOURCES[log_format]}
    out = {}
    for role, name in remap.items():
        if role in COMMAND_ROLES:
            raise InputError(f"--topic {role}: a MAVLink log's commands come from the calibration file "
                             f"(commands.{role}.source)")
        if role not in allowed:
            raise InputError(f"--topic: unknown role '{role}' (roles: {', '.join(COMMAND_ROLES + SENSOR_ROLES)})")
        if name.upper() not in allowed[role]:
            raise InputError(f"--topic {role}={name}: a {log_format} log gives {role} from "
                             f"{' or '.join(allowed[role])}")
        out[role] = name.upper()
    return out


def read_mavlink_log(
    path: Path,
    calibration: Calibration | Path | None = None,
    remap: dict[str, str] | None = None,
    namespace: str = "",
) -> MavlinkLog:
    """Read a .tlog or DataFlash .BIN into per-role streams (see the module docstring), streaming.

    ``remap`` picks a sensor role's message (``gnss_vel: GPS_RAW_INT``); ``calibration`` maps the commands
    (a :class:`Calibration` or a YAML path; without one the command roles are missing).
    """
    path = Path(path)
    source = str(path)
    if path.suffix.lower() not in LOG_SUFFIXES:
        raise InputError(f"{source}: not a MAVLink log (expected .tlog or .BIN)")
    if not path.is_file():
        raise InputError(f"{source}: no such file" if not path.exists() else f"{source}: not a file")
    log_format = "tlog" if path.suffix.lower() == ".tlog" else "dataflash"
    remap = _check_remap(dict(remap or {}), namespace, log_format, source)
    if calibration is not None and not isinstance(calibration, Calibration):
        calibration = load_calibration(Path(calibration))
    plan = _Plan(log_format, calibration)
    rows: dict[str, _Rows] = {}
    info: dict[str, Any] = {"notes": []}
    chatter = _Chatter()
    try:
        with _quiet(chatter):
            (_read_tlog if log_format == "tlog" else _read_dataflash)(path, plan, rows, info)
    except InputError:
        raise
    except Exception as err:  # pymavlink raises many types on files it cannot parse
        detail = " ".join(str(err).split())[:160]
        raise InputError(f"{source}: cannot read this MAVLink log ({type(err).__name__}: {detail})") from None
    if chatter.lines:
        info["notes"].append(f"pymavlink reported {chatter.lines} problem(s), first: {chatter.first!r}")
    clock = info.get("clock")
    tables = {name: r.array() for name, r in rows.items()}
    absolute = {name: _absolute(table, clock) for name, table in tables.items()}
    spikes = 0
    for name, t in absolute.items():
        bad = _time_spikes(t) | ~np.isfinite(t)
        if np.any(bad):
            spikes += int(np.count_nonzero(bad))
            tables[name], absolute[name] = tables[name][~bad], t[~bad]
    if spikes:
        info["notes"].append(f"{spikes} sample(s) with impossible time stamps dropped")
    log = MavlinkLog(source, log_format, {}, {}, log_messages=info.get("log_messages", 0),
                     message_counts=info["message_counts"], corrupt=info["corrupt"],
                     log_span_s=info["log_span_s"], reboots=info["reboots"], time_base=info["time_base"],
                     notes=info["notes"])
    # GNSS: fix (lat, lon, alt) and velocity (east, north) from the chosen message.
    for role, columns in (("gnss_fix", slice(2, 5)), ("gnss_vel", slice(5, 7))):
        chosen = _choose(role, GNSS_SOURCES[log_format], remap, tables)
        if chosen is None:
            continue
        values = tables[chosen][:, columns]
        ok = np.all(np.isfinite(values), axis=1)
        if np.count_nonzero(ok) < 2:
            log.notes.append(f"{role}: fewer than 2 valid {chosen} samples")
            continue
        log.streams[role] = Stream(absolute[chosen][ok], values[ok])
        log.topics[role] = chosen
    _imu_stream(log, tables, absolute)
    _command_streams(log, plan, tables, absolute)
    if calibration is None:
        log.notes.append("no calibration: commands not mapped")
    return log


def _imu_stream(log: MavlinkLog, tables: dict[str, np.ndarray], absolute: dict[str, np.ndarray]) -> None:
    """The ``imu`` stream (:data:`IMU_COLUMNS`): attitude samples, rates and accelerations resampled onto them."""
    att_name, imu_name = ("ATTITUDE", "RAW_IMU") if log.log_format == "tlog" else ("ATT", "IMU")
    att, imu = tables[att_name], tables[imu_name]
    att_t, imu_t = absolute[att_name], absolute[imu_name]
    if att.shape[0] >= 2:
        t = att_t
        out = np.full((t.size, len(IMU_COLUMNS)), np.nan)
        if log.log_format == "tlog":  # ATTITUDE: yaw, r, roll, pitch, p, q
            out[:, [0, 1, 4, 5, 6, 7]] = att[:, 2:8]
        else:  # ATT: yaw, roll, pitch
            out[:, [0, 4, 5]] = att[:, 2:5]
        if imu.shape[0]:
            resampled = _resample(imu_t, imu[:, 2:8], t)
            if log.log_format == "tlog":  # RAW_IMU: accelerations x, y, z
                out[:, [2, 3, 8]] = resampled[:, [0, 1, 2]]
            else:  # IMU: rates p, q, r and accelerations x, y, z
                out[:, [6, 7, 1, 2, 3, 8]] = resampled
        log.topics["imu"] = att_name + (f" + {imu_name}" if imu.shape[0] else "")
    elif imu.shape[0] >= 2:  # no attitude: rates and accelerations only, heading unknown
        t = imu_t
        out = np.full((t.size, len(IMU_COLUMNS)), np.nan)
        if log.log_format == "tlog":  # RAW_IMU: ax, ay, az, p, q, r
            out[:, [2, 3, 8, 6, 7, 1]] = imu[:, 2:8]
        else:
            out[:, [6, 7, 1, 2, 3, 8]] = imu[:, 2:8]
        log.topics["imu"] = f"{imu_name} (no {att_name}: heading unknown)"
        log.notes.append(f"no {att_name}: heading unknown")
    else:
        return
    log.streams["imu"] = Stream(t, out)


def _command_streams(log: MavlinkLog, plan: _Plan, tables: dict[str, np.ndarray],
                     absolute: dict[str, np.ndarray]) -> None:
    """Command roles through the calibration: (stamp, N or rad) per logged sample of their channel."""
    if plan.calibration is None:
        return
    messages = _TLOG_COMMAND_MESSAGES if log.log_format == "tlog" else _DF_COMMAND_MESSAGES
    for role in COMMAND_ROLES:
        cmap = plan.calibration.commands.get(role)
        if cmap is None:
            continue
        if cmap.constant is not None:
            log.constants[role] = cmap.constant
            log.topics[role] = f"constant {cmap.constant:g} {_ROLE_UNITS[role]} (calibration)"
            continue
        name = messages.get(cmap.kind)
        if name is None or name not in tables:
            continue
        column = 2 + plan.channels[cmap.kind].index(cmap.channel)
        raw = tables[name][:, column]
        present = raw >= 0 if cmap.kind != "MANUAL_CONTROL" else np.ones(raw.size, bool)
        if not np.any(present):
            continue
        log.streams[role] = Stream(absolute[name][present], cmap.to_value(raw[present])[:, None])
        field_name = {"SERVO_OUTPUT_RAW": f"servo{cmap.channel}_raw", "RC_CHANNELS": f"chan{cmap.channel}_raw",
                      "MANUAL_CONTROL": str(cmap.channel)}.get(name, f"C{cmap.channel}")
        log.topics[role] = f"{name}.{field_name} ({cmap.source})"
        if name != "MANUAL_CONTROL":
            log.periodic_commands.add(role)


# --------------------------------------------------------------------------------------------- trial
_ROLE_ORDER = {role: i for i, role in enumerate(COMMAND_ROLES + SENSOR_ROLES)}


_COMMAND_COLUMNS = {"thrust_left": "thrust_left_N", "thrust_right": "thrust_right_N",
                    "angle_left": "angle_left_rad", "angle_right": "angle_right_rad"}


def _command_gaps(trial: Trial, log: MavlinkLog) -> None:
    """Report where a logged command is unknown: telemetry silences (a periodic stream missing for longer than
    the gap tolerance; the command is NaN there, not held) and runs of 'no pulse / invalid' inputs (NaN)."""
    meta = trial.metadata
    grid = trial.t_s + meta.start_time_s
    for role in COMMAND_ROLES:
        stream = log.streams.get(role)
        if stream is None or stream.stamps_s.size == 0:
            continue
        order = np.argsort(stream.stamps_s, kind="stable")
        stamps, values = stream.stamps_s[order], stream.values[order, 0]
        column = getattr(trial, _COMMAND_COLUMNS[role])
        steps = np.diff(stamps)
        if role in log.periodic_commands and np.count_nonzero(steps > 0) >= 2:
            tolerance = GAP_TOLERANCE_PERIODS * float(np.median(steps[steps > 0]))
            for j in np.flatnonzero(steps > tolerance):
                a, b = float(stamps[j]), float(stamps[j + 1])
                meta.gaps.append((role, a - meta.start_time_s, b - meta.start_time_s))
                column[(grid > a + tolerance) & (grid < b)] = np.nan
        unknown = ~np.isfinite(values)
        starts = np.flatnonzero(unknown & ~np.concatenate([[False], unknown[:-1]]))
        for i in starts:
            later = np.flatnonzero(~unknown[i:])
            end = float(stamps[i + later[0]]) if later.size else float(grid[-1])
            meta.gaps.append((role, float(stamps[i]) - meta.start_time_s, end - meta.start_time_s))


MAX_GRID_SAMPLES = 2_000_000
"""A trial longer than this many grid samples (55 h at 10 Hz) is refused: its time stamps are corrupt."""


def _check_grid_size(streams: dict[str, Stream], log: MavlinkLog) -> None:
    """Refuse a grid :func:`build_trial` could not allocate (wild stamps that survived the spike filter)."""
    clock = streams.get("gnss_vel") or streams["gnss_fix"]
    stamps = np.unique(clock.stamps_s[np.isfinite(clock.stamps_s)])
    if stamps.size < 2:
        return
    period = float(np.median(np.diff(stamps)))
    first = min(float(np.nanmin(s.stamps_s)) for r, s in streams.items() if r in COMMAND_ROLES)
    span = float(stamps[-1]) - min(first, float(stamps[0]))
    if span / period > MAX_GRID_SAMPLES:
        raise InputError(f"{log.source}: time stamps span {span:.0f} s at {1 / period:.3g} Hz "
                         f"(> {MAX_GRID_SAMPLES} samples): corrupt time fields?")


def trial_from_log(log: MavlinkLog, origin: tuple[float, float, float] | None = None, *,
                   derive_velocity: bool = True) -> Trial:
    """Put a log's streams on the Trial grid with :func:`~boat_twin.io.trial.build_trial` (``derive_velocity``:
    a missing velocity is derived from the positions).

    A log without GNSS (a DataFlash log of a vehicle without GPS) is gridded on its attitude (or command)
    samples, with position and velocity NaN and reported missing; a log without mapped commands gives NaN
    commands, reported missing. Commands from periodic telemetry become NaN inside telemetry gaps.
    """
    streams = {role: Stream(s.stamps_s, s.values[:, :4] if role == "imu" else s.values)
               for role, s in log.streams.items()}
    topics = dict(log.topics)
    placeholders = []
    if "gnss_vel" not in streams and "gnss_fix" not in streams:
        candidates = [streams[r] for r in ("imu", *COMMAND_ROLES) if r in streams]
        base = max(candidates, key=lambda s: np.unique(s.stamps_s[np.isfinite(s.stamps_s)]).size, default=None)
        if base is None or np.unique(base.stamps_s[np.isfinite(base.stamps_s)]).size < 2:
            raise InputError(f"{log.source}: no GNSS, attitude or command samples to build a trial from "
                             f"({log.log_messages} messages in the file)")
        streams["gnss_vel"] = Stream(base.stamps_s, np.full((base.stamps_s.size, 2), np.nan))
        placeholders.append("gnss_vel")
    clock = streams.get("gnss_vel") or streams["gnss_fix"]
    logged = [float(np.nanmin(streams[r].stamps_s)) for r in COMMAND_ROLES if r in streams]
    start = min(logged) if logged else float(np.nanmin(clock.stamps_s))  # constants hold from the first command
    for role, value in log.constants.items():
        streams[role] = Stream(np.array([start]), np.array([[value]]))
    if not any(role in streams for role in COMMAND_ROLES):
        streams["thrust_left"] = Stream(np.array([start]), np.array([[np.nan]]))
        placeholders.append("thrust_left")
    _check_grid_size(streams, log)
    trial = build_trial(streams, log.source, topics, origin, derive_velocity=derive_velocity)
    meta = trial.metadata
    for role in placeholders + list(log.constants):
        meta.counts.pop(role, None)
        meta.rates_hz.pop(role, None)
    meta.gaps = [g for g in meta.gaps if g[0] not in placeholders]
    meta.missing = sorted(set(meta.missing) | set(placeholders), key=_ROLE_ORDER.__getitem__)
    _command_gaps(trial, log)
    base_fields = {f.name: getattr(meta, f.name) for f in fields(TrialMetadata)}
    trial.metadata = MavlinkTrialMetadata(
        **base_fields, log_format=log.log_format, log_messages=log.log_messages,
        message_counts=dict(log.message_counts), corrupt=log.corrupt, log_span_s=log.log_span_s,
        non_monotone=log.non_monotone(), reboots=log.reboots, time_base=log.time_base, notes=list(log.notes),
    )
    return trial


def read_mavlink_trial(
    path: Path,
    calibration: Calibration | Path | None = None,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    origin: tuple[float, float, float] | None = None,
) -> Trial:
    """A .tlog or DataFlash .BIN as a :class:`Trial` (metadata: :class:`MavlinkTrialMetadata`)."""
    return trial_from_log(read_mavlink_log(path, calibration, remap, namespace), origin,
                          derive_velocity="gnss_vel" not in (remap or {}))  # a named velocity source stays missing


def is_mavlink_log(path: Path) -> bool:
    """Whether ``path`` is read as a MAVLink log (by its ending: .tlog, .bin, .BIN)."""
    return Path(path).suffix.lower() in LOG_SUFFIXES
