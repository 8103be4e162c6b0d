"""What reading a MAVLink log produces, and what its two readers (:mod:`boat_twin.io.tlog`,
:mod:`boat_twin.io.dataflash`) share: the plan of messages and channels to read and the
report of what the file said about itself. The conventions are :mod:`boat_twin.io.mavlink`'s."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from boat_twin.io.mavlink_calibration import Calibration
from boat_twin.io.trial import Stream

REBOOT_BACKSTEP_S = 5.0
"""A boot time going back by more than this is a reboot of the autopilot, s (also: a stamp leaping this far away
from both neighbours and back is a corrupt time field)."""
IMU_COLUMNS = ("yaw_rad", "yaw_rate_radps", "accel_x_mps2", "accel_y_mps2", "roll_rad", "pitch_rad",
               "roll_rate_radps", "pitch_rate_radps", "accel_z_mps2")
"""Columns of the ``imu`` stream of a :class:`MavlinkLog`: the Trial's four (ENU yaw, FLU yaw rate, FLU
accelerations x and y), then the rest of the attitude for writing full sensor_msgs/Imu messages."""


@dataclass
class ReadReport:
    """What a reader learnt about the file besides the rows: counts, span, clock, notes."""

    notes: list[str] = field(default_factory=list)
    log_messages: int = 0
    """Messages in the file (pymavlink's index of it), read or not."""
    message_counts: dict[str, int] = field(default_factory=dict)
    """Message type → messages decoded of the types the import reads."""
    corrupt: int = 0
    log_span_s: tuple[float, float] = (math.nan, math.nan)
    reboots: int = 0
    time_base: str = ""
    boot_offsets_s: np.ndarray | None = None
    """Per boot (a row's column 1), the offset from boot time to the log's absolute clock, s; None: the rows'
    times are already absolute."""


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
    report: ReadReport = field(default_factory=ReadReport)
    """What the reader learnt about the file (counts, span, clock); its ``notes`` gain the import's own."""

    def non_monotone(self) -> dict[str, int]:
        """Role → backward steps of its stamps, for the roles that have any."""
        steps = {role: int(np.sum(np.diff(s.stamps_s) < 0)) for role, s in self.streams.items()}
        return {role: n for role, n in steps.items() if n}


@dataclass
class ReadPlan:
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

