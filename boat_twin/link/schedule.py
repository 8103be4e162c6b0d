"""When the MAVLink boat sends what: HEARTBEAT at 1 Hz and ArduPilot's telemetry stream groups (``SRn_*``) at their
rates in simulated time, changed by a ground station's REQUEST_DATA_STREAM or PARAM_SET of ``SR0_*`` as
ArduPilot does (the groups and default rates: :mod:`boat_twin.link.mavlink_boat`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.errors import InputError

HEARTBEAT_RATE_HZ = 1.0
"""HEARTBEAT rate, Hz: ArduPilot sends one per second on every link."""

STREAMS: dict[str, tuple[str, ...]] = {
    "EXT_STAT": ("SYS_STATUS", "GPS_RAW_INT"),
    "POSITION": ("GLOBAL_POSITION_INT",),
    "RC_CHAN": ("SERVO_OUTPUT_RAW",),
    "EXTRA1": ("ATTITUDE",),
    "EXTRA2": ("VFR_HUD",),
    "EXTRA3": ("SYSTEM_TIME",),
}
"""ArduPilot telemetry stream groups (``SRn_<group>``) and the messages of each that this twin sends."""

ROVER_DEFAULT_RATES_HZ: dict[str, float] = dict.fromkeys(STREAMS, 1.0)
"""ArduPilot Rover's default stream rates, Hz: 1 for each group (GCS_MAVLink_Parameters.cpp; the commit:
:mod:`boat_twin.link.mavlink_boat`)."""

MAX_STREAM_RATE_HZ = 50.0
"""Highest rate a ground station may request, Hz (the SRn_* parameters' range, 0-50)."""

DATA_STREAM_GROUPS: dict[int, str | None] = {
    mavlink2.MAV_DATA_STREAM_RAW_SENSORS: None,
    mavlink2.MAV_DATA_STREAM_EXTENDED_STATUS: "EXT_STAT",
    mavlink2.MAV_DATA_STREAM_RC_CHANNELS: "RC_CHAN",
    mavlink2.MAV_DATA_STREAM_RAW_CONTROLLER: None,
    mavlink2.MAV_DATA_STREAM_POSITION: "POSITION",
    mavlink2.MAV_DATA_STREAM_EXTRA1: "EXTRA1",
    mavlink2.MAV_DATA_STREAM_EXTRA2: "EXTRA2",
    mavlink2.MAV_DATA_STREAM_EXTRA3: "EXTRA3",
}
"""REQUEST_DATA_STREAM ids → stream group (None: a group whose messages this twin does not produce)."""


def parse_stream_rates(items: list[str]) -> dict[str, float]:
    """``["POSITION=10", "ALL=4"]`` (repeated ``--mavlink-rate``) → ``{"POSITION": 10.0, ...}``; later items win."""
    rates: dict[str, float] = {}
    for item in items:
        group, sep, value = item.partition("=")
        group = group.strip().upper()
        try:
            rate = float(value)
        except ValueError:
            rate = math.nan
        if not sep or (group not in STREAMS and group != "ALL"):
            raise InputError(f"--mavlink-rate {item!r}: expected GROUP=HZ with GROUP one of ALL, {', '.join(STREAMS)}")
        if not 0.0 <= rate <= MAX_STREAM_RATE_HZ:
            raise InputError(f"--mavlink-rate {item!r}: the rate must be a number of Hz from 0 to "
                             f"{MAX_STREAM_RATE_HZ:g}")
        rates.update(dict.fromkeys(STREAMS, rate) if group == "ALL" else {group: rate})
    return rates



class Cadence:
    """One scheduled message or stream group: sends when the simulated time reaches ``due_s``."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.due_s = 0.0

    def set_rate(self, rate_hz: float, now_s: float) -> None:
        self.rate_hz = rate_hz
        self.due_s = now_s

    def is_due(self, now_s: float) -> bool:
        return self.rate_hz > 0.0 and now_s + 1e-6 >= self.due_s

    def sent(self, now_s: float) -> None:
        self.due_s += 1.0 / self.rate_hz
        if self.due_s <= now_s:  # after a stall or a rate above the tick rate: no bursts
            self.due_s = now_s + 1.0 / self.rate_hz



class Schedule:
    """The heartbeat and the stream groups' cadences; ``rates_hz``: group → Hz (default Rover's), validated."""

    def __init__(self, rates_hz: Mapping[str, float] | None = None) -> None:
        rates = dict(ROVER_DEFAULT_RATES_HZ)
        for name, rate in (rates_hz or {}).items():
            if name not in STREAMS:
                raise InputError(f"MAVLink stream {name!r}: unknown (streams: {', '.join(STREAMS)})")
            if not (math.isfinite(rate) and 0.0 <= rate <= MAX_STREAM_RATE_HZ):
                raise InputError(f"MAVLink stream {name}: rate must be 0-{MAX_STREAM_RATE_HZ:g} Hz, got {rate!r}")
            rates[name] = float(rate)
        self.streams = {name: Cadence(rate) for name, rate in rates.items()}
        self.heartbeat = Cadence(HEARTBEAT_RATE_HZ)

    def rates_hz(self) -> dict[str, float]:
        """Stream group → its rate in force, Hz."""
        return {name: stream.rate_hz for name, stream in self.streams.items()}

    def set_rate(self, group: str, rate_hz: float, now_s: float) -> None:
        """A group's rate (PARAM_SET of ``SR0_<group>``), clipped to 0-:data:`MAX_STREAM_RATE_HZ`."""
        self.streams[group].set_rate(max(0.0, min(MAX_STREAM_RATE_HZ, float(rate_hz))), now_s)

    def request_data_stream(self, stream_id: int, rate_hz: int, start_stop: int, now_s: float) -> None:
        """ArduPilot's handling: start_stop 0 stops, 1 sets ``rate_hz``; id 0 (ALL) sets every group."""
        if start_stop not in (0, 1):
            return
        rate = min(float(rate_hz), MAX_STREAM_RATE_HZ) if start_stop == 1 else 0.0
        if stream_id == mavlink2.MAV_DATA_STREAM_ALL:
            targets = list(self.streams)
        else:
            group = DATA_STREAM_GROUPS.get(stream_id)
            targets = [group] if group else []
        for name in targets:
            self.streams[name].set_rate(rate, now_s)

    def send_due(self, now_s: float, heartbeat: Callable[[], None], send: Callable[[str], bool]) -> None:
        """Send what is due at ``now_s``: ``heartbeat()``, and ``send(kind)`` for each message of a due group (a
        group counts as sent when any of its messages had data)."""
        if self.heartbeat.is_due(now_s):
            heartbeat()
            self.heartbeat.sent(now_s)
        for name, stream in self.streams.items():
            if stream.is_due(now_s):
                sent = [send(kind) for kind in STREAMS[name]]
                if any(sent):
                    stream.sent(now_s)
