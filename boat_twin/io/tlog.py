"""Reading a MAVLink telemetry log (.tlog: each message after the ground station's 8-byte µs receive stamp) into
rows of numbers, streaming through pymavlink; the vehicle, messages, clocks and conventions are
:mod:`boat_twin.io.mavlink`'s. Boot times are put on the receive clock per boot (:class:`BootClock`)."""

from __future__ import annotations

import math
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.frames import enu_yaw_from_ned, wrap_pi
from boat_twin.io.mavlink_log import REBOOT_BACKSTEP_S, ReadPlan, ReadReport
from boat_twin.rows import Rows
from boat_twin.units import STANDARD_GRAVITY_MPS2

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
COMMAND_MESSAGES = {"SERVO": "SERVO_OUTPUT_RAW", "RC": "RC_CHANNELS", "MANUAL_CONTROL": "MANUAL_CONTROL"}
"""Command source kind → the .tlog message it is read from."""
MILLI_G_MPS2 = STANDARD_GRAVITY_MPS2 * 1e-3
"""RAW_IMU's acceleration unit, m/s²."""


class BootClock:
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


class _Decoder:
    """One method per .tlog message type read: the numbers it adds to its rows (first two columns: time s, boot
    index or −1 for absolute time). Boot stamps go through ``clock``."""

    def __init__(self, plan: ReadPlan, rows: dict[str, Rows], clock: BootClock) -> None:
        self.rows = rows
        self.clock = clock
        self.servo_channels = plan.numbered("SERVO")
        self.rc_channels = plan.numbered("RC")
        self.axes = plan.axes()
        self._servo_last = -1.0
        self._servo_wraps = 0

    def handlers(self) -> dict[str, Callable[[Any, float], None]]:
        """Message type → its method, for the types this plan reads (their rows are created here)."""
        handlers: dict[str, Callable[[Any, float], None]] = {
            "ATTITUDE": self.attitude, "RAW_IMU": self.raw_imu, "GLOBAL_POSITION_INT": self.global_position,
            "GPS_RAW_INT": self.gps_raw, "WIND": self.wind, "WIND_COV": self.wind_cov}
        for name, width in (("ATTITUDE", 8), ("RAW_IMU", 8), ("GLOBAL_POSITION_INT", 7), ("GPS_RAW_INT", 7),
                            ("WIND", 4), ("WIND_COV", 4)):
            self.rows[name] = Rows(width)
        commands: tuple[tuple[str, Callable[[Any, float], None], list[Any]], ...] = (
            ("SERVO_OUTPUT_RAW", self.servo_output, self.servo_channels),
            ("RC_CHANNELS", self.rc_input, self.rc_channels),
            ("MANUAL_CONTROL", self.manual_control, self.axes))
        for name, handler, channels in commands:
            if channels:
                handlers[name], self.rows[name] = handler, Rows(2 + len(channels))
        return handlers

    def _usec64(self, usec: int, recv: float, current: bool) -> tuple[float, float]:
        """A 64-bit time_usec: (Unix s, −1) or (boot s, boot index); ``current``: a fresh boot stamp."""
        if usec >= UNIX_USEC_MIN:
            return usec * 1e-6, -1.0
        boot = usec * 1e-6
        return boot, float(self.clock.now(boot, recv) if current else self.clock.stale(boot, recv))

    def global_position(self, msg: Any, recv: float) -> None:
        if msg.lat == 0 and msg.lon == 0:
            return  # no position estimate yet
        boot = msg.time_boot_ms * 1e-3
        self.rows["GLOBAL_POSITION_INT"].add((boot, self.clock.now(boot, recv), msg.lat * 1e-7, msg.lon * 1e-7,
                                              msg.alt * 1e-3, msg.vy * 0.01, msg.vx * 0.01))

    def gps_raw(self, msg: Any, recv: float) -> None:
        if msg.fix_type < 2:
            return  # no fix
        t, sid = self._usec64(msg.time_usec, recv, current=False)
        if msg.vel == 65535 or msg.cog == 65535:
            east = north = math.nan
        else:
            course = math.radians(msg.cog * 0.01)
            east, north = msg.vel * 0.01 * math.sin(course), msg.vel * 0.01 * math.cos(course)
        self.rows["GPS_RAW_INT"].add((t, sid, msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3, east, north))

    def attitude(self, msg: Any, recv: float) -> None:
        if not (math.isfinite(msg.yaw) and math.isfinite(msg.yawspeed)):
            return
        boot = msg.time_boot_ms * 1e-3
        self.rows["ATTITUDE"].add((boot, self.clock.now(boot, recv), wrap_pi(enu_yaw_from_ned(msg.yaw)),
                                   -msg.yawspeed, msg.roll, -msg.pitch, msg.rollspeed, -msg.pitchspeed))

    def raw_imu(self, msg: Any, recv: float) -> None:
        if "id" in msg.fieldnames and msg.id:  # (without the field, msg.id is the message id)
            return  # a second IMU
        t, sid = self._usec64(msg.time_usec, recv, current=True)
        mg = MILLI_G_MPS2
        self.rows["RAW_IMU"].add((t, sid, msg.xacc * mg, -msg.yacc * mg, -msg.zacc * mg,
                                  msg.xgyro * 1e-3, -msg.ygyro * 1e-3, -msg.zgyro * 1e-3))

    def wind(self, msg: Any, recv: float) -> None:
        """ArduPilot's WIND (no clock of its own: the receive time): the direction the wind comes from, degrees
        clockwise from north, and its speed, m/s → the air's velocity (east, north)."""
        if not (math.isfinite(msg.direction) and math.isfinite(msg.speed)):
            return
        going = math.radians(msg.direction + 180.0)
        self.rows["WIND"].add((recv, -1.0, msg.speed * math.sin(going), msg.speed * math.cos(going)))

    def wind_cov(self, msg: Any, recv: float) -> None:
        """common WIND_COV: the wind's velocity in NED (wind_x north, wind_y east, m/s; NaN: unknown)."""
        if not (math.isfinite(msg.wind_x) and math.isfinite(msg.wind_y)):
            return
        t, sid = self._usec64(msg.time_usec, recv, current=True)
        self.rows["WIND_COV"].add((t, sid, msg.wind_y, msg.wind_x))

    def servo_output(self, msg: Any, recv: float) -> None:
        usec = msg.time_usec
        if math.isfinite(self.clock.top):  # unwrap the 32-bit µs counter against the boot clock
            wraps = max(0, round((self.clock.top - usec * 1e-6) / USEC32_WRAP_S))
        else:
            if usec < self._servo_last - 2**31:
                self._servo_wraps += 1
            wraps = self._servo_wraps
        self._servo_last = usec
        boot = usec * 1e-6 + wraps * USEC32_WRAP_S
        sid = self.clock.now(boot, recv)
        base = 8 * getattr(msg, "port", 0)
        values = []
        for channel in self.servo_channels:
            index = channel - base
            values.append(float(getattr(msg, f"servo{index}_raw", -1)) if 1 <= index <= 16 else -1.0)
        self.rows["SERVO_OUTPUT_RAW"].add((boot, sid, *values))

    def rc_input(self, msg: Any, recv: float) -> None:
        boot = msg.time_boot_ms * 1e-3
        self.rows["RC_CHANNELS"].add((boot, self.clock.now(boot, recv),
                                      *(float(getattr(msg, f"chan{c}_raw", -1)) for c in self.rc_channels)))

    def manual_control(self, msg: Any, recv: float) -> None:
        self.rows["MANUAL_CONTROL"].add((recv, -1.0, *(float(getattr(msg, a)) for a in self.axes)))


@dataclass
class _Tally:
    """What one pass over a .tlog counted."""

    counts: dict[str, int] = field(default_factory=dict)
    total: int = 0
    corrupt: int = 0
    odd: int = 0
    """Messages whose fields the decoder could not use."""
    unset: int = 0
    """Receive stamps that are no Unix time."""
    first: float = math.nan
    last: float = math.nan

    def receive_s(self, msg: Any) -> float:
        """The message's receive stamp, Unix s, counted into the span; NaN when it is unset or corrupt."""
        recv = msg._timestamp
        if not 0.0 < recv <= LATEST_RECEIVE_S:  # e.g. 2^64 - 1 us: an unset or corrupt receive stamp
            self.unset += 1
            return math.nan  # no receive delay from it; a message timed by it alone is dropped
        if not self.first <= recv:  # also true while first is NaN
            self.first = recv
        if not self.last >= recv:
            self.last = recv
        return float(recv)


def _from_vehicle(msg: Any, name: str, vehicle: tuple[int, int] | None) -> bool:
    """Whether ``msg`` is the vehicle's (MANUAL_CONTROL: addressed to it); every message when none is known."""
    if vehicle is None:
        return True
    if name == "MANUAL_CONTROL":
        return bool(msg.target in (0, vehicle[0]))
    return bool((msg.get_srcSystem(), msg.get_srcComponent()) == vehicle)


def _open(path: Path, report: ReadReport) -> tuple[Any, bool]:
    """pymavlink's indexed reader of the file, or (an index it cannot build) its sequential one; (reader,
    indexed)."""
    from pymavlink import mavutil

    try:
        return mavutil.mavmmaplog(str(path)), True
    except Exception as err:  # pymavlink's index trips over some corrupt files: read them sequentially
        report.notes.append(f"pymavlink could not index the file ({type(err).__name__}): read sequentially")
        return mavutil.mavlogfile(str(path)), False


def _scan(conn: Any, indexed: bool, handlers: dict[str, Callable[[Any, float], None]],
          vehicle: tuple[int, int] | None) -> _Tally:
    """Every message of the types read (and HEARTBEAT, BAD_DATA, to count them) through its handler."""
    types = set(handlers) | {"HEARTBEAT", "BAD_DATA"}
    tally = _Tally()
    receive = (lambda: conn.recv_match(type=types)) if indexed else conn.recv_msg
    while (msg := receive()) is not None:
        tally.total += 1
        name = msg.get_type()
        if name == "BAD_DATA":
            tally.corrupt += 1
            continue
        if name not in types:
            continue
        tally.counts[name] = tally.counts.get(name, 0) + 1
        recv = tally.receive_s(msg)
        handler = handlers.get(name)
        if handler is None or not _from_vehicle(msg, name, vehicle):
            continue
        try:
            handler(msg, recv)
        except (AttributeError, TypeError, ValueError, OverflowError):
            tally.odd += 1
    return tally


def read_tlog(path: Path, plan: ReadPlan, rows: dict[str, Rows], report: ReadReport) -> None:
    """Stream a .tlog into ``rows`` (first two columns: time s, boot index or −1 for absolute time); the boot
    offsets, counts and notes into ``report``."""
    vehicle = _find_vehicle(path)
    if vehicle is None:
        report.notes.append("no vehicle HEARTBEAT: messages of every system read")
    clock = BootClock()
    handlers = _Decoder(plan, rows, clock).handlers()
    conn, indexed = _open(path, report)
    try:
        tally = _scan(conn, indexed, handlers, vehicle)
        report.log_messages = int(getattr(conn, "_count", 0)) if indexed else tally.total
    finally:
        conn.close()
    if tally.odd:
        report.notes.append(f"{tally.odd} message(s) with unexpected fields skipped")
    read = sum(tally.counts.values())
    if tally.unset:
        report.notes.append(
            f"WARNING: {tally.unset} of {read} .tlog receive stamp(s) are no Unix time (0, or beyond the year "
            "2100, e.g. 2^64-1 us: unset or corrupt): ignored; "
            + ("the stamps are the autopilot's boot time only" if tally.unset == read
               else "their messages timed by the autopilot's boot time"))
    report.message_counts, report.corrupt, report.log_span_s = tally.counts, tally.corrupt, (tally.first,
                                                                                           tally.last)
    report.reboots = clock.reboots
    report.boot_offsets_s = clock.final_offsets()
    report.time_base = "Unix time: autopilot boot time + the smallest tlog receive delay, per boot"
