"""A MAVLink log's streams (:class:`~boat_twin.io.mavlink_log.MavlinkLog`) put on the Trial grid, with what the
log said about its quality in the metadata; commands read from periodic telemetry become NaN (unknown, reported
as gaps) where that telemetry fell silent."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from boat_twin.errors import InputError
from boat_twin.io.mavlink_log import MavlinkLog
from boat_twin.io.trial import (
    COMMAND_ROLES,
    GAP_TOLERANCE_PERIODS,
    SENSOR_ROLES,
    Stream,
    Trial,
    TrialMetadata,
    build_trial,
)


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
                             f"({log.report.log_messages} messages in the file)")
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
        **base_fields, log_format=log.log_format, log_messages=log.report.log_messages,
        message_counts=dict(log.report.message_counts), corrupt=log.report.corrupt, log_span_s=log.report.log_span_s,
        non_monotone=log.non_monotone(), reboots=log.report.reboots, time_base=log.report.time_base,
        notes=list(log.report.notes),
    )
    return trial
