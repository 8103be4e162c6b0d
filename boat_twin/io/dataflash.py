"""Reading an ArduPilot DataFlash log (.BIN) into rows of numbers, streaming through pymavlink's DFReader; the
messages, clocks and conventions are :mod:`boat_twin.io.mavlink`'s. Times are seconds since boot (TimeUS, older
TimeMS; in GPS, T), plus pymavlink's GPS time base when the log has GPS time."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from boat_twin.errors import InputError
from boat_twin.frames import enu_yaw_from_ned, wrap_pi
from boat_twin.io.mavlink_log import ReadPlan, ReadReport
from boat_twin.rows import Rows

COMMAND_MESSAGES = {"SERVO": "RCOU", "RC": "RCIN"}
"""Command source kind → the DataFlash message it is read from (MANUAL_CONTROL is not logged)."""

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


class _Decoder:
    """One method per DataFlash message type read: the numbers it adds to its rows (first two columns: time s,
    boot index 0)."""

    def __init__(self, path: Path, plan: ReadPlan, rows: dict[str, Rows]) -> None:
        self.path = path
        self.rows = rows
        self.servo_channels = plan.numbered("SERVO")
        self.rc_channels = plan.numbered("RC")

    def handlers(self) -> dict[str, Callable[[Any, float], None]]:
        """Message type → its method, for the types this plan reads (their rows are created here)."""
        handlers: dict[str, Callable[[Any, float], None]] = {"GPS": self.gps, "ATT": self.att, "IMU": self.imu,
                                                             "WIND": self.wind}
        for name, width in (("GPS", 7), ("ATT", 5), ("IMU", 8), ("WIND", 4)):
            self.rows[name] = Rows(width)
        for name, chans in (("RCOU", self.servo_channels), ("RCIN", self.rc_channels)):
            if chans:
                handlers[name], self.rows[name] = self.channels(name, chans), Rows(2 + len(chans))
        return handlers

    def gps(self, m: Any, t: float) -> None:
        if getattr(m, "I", 0) != 0 or m.Status < 2:
            return
        course = math.radians(m.GCrs)
        self.rows["GPS"].add((t, 0.0, m.Lat, m.Lng, m.Alt, m.Spd * math.sin(course), m.Spd * math.cos(course)))

    def att(self, m: Any, t: float) -> None:
        if math.isfinite(m.Yaw):
            self.rows["ATT"].add((t, 0.0, wrap_pi(enu_yaw_from_ned(math.radians(m.Yaw))), math.radians(m.Roll),
                                  -math.radians(m.Pitch)))

    def imu(self, m: Any, t: float) -> None:
        if getattr(m, "I", 0) == 0:
            self.rows["IMU"].add((t, 0.0, m.GyrX, -m.GyrY, -m.GyrZ, m.AccX, -m.AccY, -m.AccZ))

    def wind(self, m: Any, t: float) -> None:
        """A rover's wind vane (AP_WindVane's WIND): the true wind's direction DrTru, degrees clockwise from north,
        the direction it comes from (as the telemetry's WIND), and its speed SpdTru, m/s → the air's velocity
        (east, north)."""
        if math.isfinite(m.DrTru) and math.isfinite(m.SpdTru):
            going = math.radians(m.DrTru + 180.0)
            self.rows["WIND"].add((t, 0.0, m.SpdTru * math.sin(going), m.SpdTru * math.cos(going)))

    def channels(self, name: str, chans: list[int]) -> Callable[[Any, float], None]:
        """The reader of RCOU or RCIN channels ``chans`` (their field names found in the first message)."""
        fields: list[str] = []

        def read(m: Any, t: float) -> None:
            if not fields:
                fields.extend(_channel_field(m, name, c, self.path) for c in chans)
            self.rows[name].add((t, 0.0, *(float(getattr(m, f)) for f in fields)))
        return read


def read_dataflash(path: Path, plan: ReadPlan, rows: dict[str, Rows], report: ReadReport) -> None:
    """Stream a DataFlash log into ``rows`` (first two columns: time since boot in s, boot index 0); counts and
    notes into ``report``."""
    from pymavlink import DFReader

    reader = DFReader.DFReader_binary(str(path))
    base = float(getattr(reader.clock, "timebase", 0.0) or 0.0) \
        if isinstance(reader.clock, (DFReader.DFReaderClock_usec, DFReader.DFReaderClock_msec)) else 0.0
    if plan.channels.get("MANUAL_CONTROL"):
        report.notes.append("MANUAL_CONTROL is not in DataFlash logs")
    handlers = _Decoder(path, plan, rows).handlers()
    counts: dict[str, int] = {}
    first = last = math.nan
    odd = 0
    types = list(handlers)
    try:
        while (m := reader.recv_match(type=types, strict=True)) is not None:
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
        report.log_messages = int(getattr(reader, "_count", 0))
    finally:
        reader.close()
    if odd:
        report.notes.append(f"{odd} message(s) with unexpected fields skipped")
    report.message_counts, report.corrupt, report.log_span_s, report.reboots = counts, 0, (first, last), 0
    stamp = "TimeMS" if isinstance(reader.clock, DFReader.DFReaderClock_msec) else "TimeUS"
    report.time_base = (f"Unix time: {stamp} + the log's GPS time base" if base
                        else f"seconds since autopilot boot ({stamp}; no GPS time in the log)")
