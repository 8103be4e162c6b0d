"""MAVLink logs into a :class:`~boat_twin.io.trial.Trial`: telemetry logs (.tlog) and DataFlash logs (.BIN).

What is read, per trial role (a .tlog's vehicle is the system and component of its first vehicle HEARTBEAT,
pymavlink's own rule; other systems are ignored except for MANUAL_CONTROL addressed to the vehicle):

============  =====================================================  ========================================
role          .tlog                                                  DataFlash .BIN
============  =====================================================  ========================================
gnss_fix      GLOBAL_POSITION_INT (default) or GPS_RAW_INT (≥ 2D)    GPS (instance 0, Status ≥ 2D fix)
gnss_vel      the same message: vx, vy (or vel and cog)              GPS: Spd and GCrs
imu           ATTITUDE (+ RAW_IMU accelerations)                     ATT (+ IMU instance 0 rates, accelerations)
wind          WIND (ArduPilot: direction it comes from, speed)       WIND (a rover's wind vane: DrTru, the
              or WIND_COV (wind_x north, wind_y east)                 direction it comes from, and SpdTru)
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
import os
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from boat_twin.errors import InputError
from boat_twin.io import dataflash, tlog
from boat_twin.io.mavlink_calibration import (
    ROLE_UNITS,
    Calibration,
    CommandMap,
    calibration_from_dict,
    load_calibration,
)
from boat_twin.io.mavlink_log import IMU_COLUMNS, REBOOT_BACKSTEP_S, MavlinkLog, ReadPlan, ReadReport
from boat_twin.io.mavlink_trial import MavlinkTrialMetadata, trial_from_log
from boat_twin.io.sources import LOG_SUFFIXES, is_mavlink_log
from boat_twin.io.trial import COMMAND_ROLES, GAP_TOLERANCE_PERIODS, SENSOR_ROLES, Stream, Trial
from boat_twin.rows import Rows

__all__ = ["IMU_COLUMNS", "LOG_SUFFIXES", "Calibration", "CommandMap", "MavlinkLog", "MavlinkTrialMetadata",
           "calibration_from_dict", "is_mavlink_log", "load_calibration", "read_mavlink_log", "read_mavlink_trial",
           "trial_from_log"]
"""The reading's public names, those of the modules it is split into included (callers import them here)."""

GNSS_SOURCES = {"tlog": ("GLOBAL_POSITION_INT", "GPS_RAW_INT"), "dataflash": ("GPS",)}
"""Messages a GNSS role can come from, in order of preference (``remap`` picks one)."""
IMU_SOURCES = {"tlog": ("ATTITUDE",), "dataflash": ("ATT",)}
"""Messages the heading comes from."""
WIND_SOURCES = {"tlog": ("WIND", "WIND_COV"), "dataflash": ("WIND",)}
"""Messages a measured true wind comes from, in order of preference."""


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


def _absolute(table: np.ndarray, offsets: np.ndarray | None) -> np.ndarray:
    """Column 0 (time) on the absolute clock, using column 1 (boot index, −1 = already absolute) and the
    per-boot ``offsets`` (None: the times are absolute)."""
    t = table[:, 0].copy()
    if offsets is not None and t.size:
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
    order: Sequence[str] = (),
) -> MavlinkLog:
    """Read a .tlog or DataFlash .BIN into per-role streams (see the module docstring), streaming.

    ``remap`` picks a sensor role's message (``gnss_vel: GPS_RAW_INT``); ``calibration`` maps the commands
    (a :class:`Calibration` or a YAML path, whose actuator names fill the slots in ``order``, the boat file's; without
    one the command roles are missing).
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
        calibration = load_calibration(Path(calibration), order)
    plan = ReadPlan(log_format, calibration)
    rows, report = _read_rows(path, plan)
    tables, absolute = _on_log_clock(rows, report)
    log = MavlinkLog(source, log_format, {}, {}, report=report)
    _gnss_streams(log, remap, tables, absolute)
    _imu_stream(log, tables, absolute)
    _wind_stream(log, tables, absolute)
    _command_streams(log, plan, tables, absolute)
    if calibration is None:
        log.report.notes.append("no calibration: commands not mapped")
    return log


def _read_rows(path: Path, plan: ReadPlan) -> tuple[dict[str, Rows], ReadReport]:
    """The log's rows of the plan's messages, by the reader of its format, pymavlink kept quiet; anything it
    cannot read is an InputError naming the file."""
    rows: dict[str, Rows] = {}
    report = ReadReport()
    chatter = _Chatter()
    try:
        with _quiet(chatter):
            (tlog.read_tlog if plan.log_format == "tlog" else dataflash.read_dataflash)(path, plan, rows, report)
    except InputError:
        raise
    except Exception as err:  # pymavlink raises many types on files it cannot parse
        detail = " ".join(str(err).split())[:160]
        raise InputError(f"{path}: cannot read this MAVLink log ({type(err).__name__}: {detail})") from None
    if chatter.lines:
        report.notes.append(f"pymavlink reported {chatter.lines} problem(s), first: {chatter.first!r}")
    return rows, report


def _on_log_clock(rows: dict[str, Rows], report: ReadReport) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Message type → (its rows, their stamps on the log's absolute clock), without the samples whose stamps are
    impossible (spikes, not finite; counted in a note)."""
    tables = {name: r.array() for name, r in rows.items()}
    absolute = {name: _absolute(table, report.boot_offsets_s) for name, table in tables.items()}
    spikes = 0
    for name, t in absolute.items():
        bad = _time_spikes(t) | ~np.isfinite(t)
        if np.any(bad):
            spikes += int(np.count_nonzero(bad))
            tables[name], absolute[name] = tables[name][~bad], t[~bad]
    if spikes:
        report.notes.append(f"{spikes} sample(s) with impossible time stamps dropped")
    return tables, absolute


def _gnss_streams(log: MavlinkLog, remap: dict[str, str], tables: dict[str, np.ndarray],
                  absolute: dict[str, np.ndarray]) -> None:
    """GNSS: fix (lat, lon, alt) and velocity (east, north) from the chosen message."""
    for role, columns in (("gnss_fix", slice(2, 5)), ("gnss_vel", slice(5, 7))):
        chosen = _choose(role, GNSS_SOURCES[log.log_format], remap, tables)
        if chosen is None:
            continue
        values = tables[chosen][:, columns]
        ok = np.all(np.isfinite(values), axis=1)
        if np.count_nonzero(ok) < 2:
            log.report.notes.append(f"{role}: fewer than 2 valid {chosen} samples")
            continue
        log.streams[role] = Stream(absolute[chosen][ok], values[ok])
        log.topics[role] = chosen


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
        log.report.notes.append(f"no {att_name}: heading unknown")
    else:
        return
    log.streams["imu"] = Stream(t, out)


def _wind_stream(log: MavlinkLog, tables: dict[str, np.ndarray], absolute: dict[str, np.ndarray]) -> None:
    """The measured true wind (``wind``: east, north m/s, the air's velocity) from ArduPilot's WIND (a rover's
    wind vane: the direction it comes from and its speed; in a DataFlash log AP_WindVane's WIND), else common
    WIND_COV (.tlog)."""
    for name in WIND_SOURCES.get(log.log_format, ()):
        table = tables.get(name)
        if table is not None and table.shape[0] >= 1:
            log.streams["wind"] = Stream(absolute[name], table[:, 2:4])
            log.topics["wind"] = name
            return


def _command_streams(log: MavlinkLog, plan: ReadPlan, tables: dict[str, np.ndarray],
                     absolute: dict[str, np.ndarray]) -> None:
    """Command roles through the calibration: (stamp, N or rad) per logged sample of their channel."""
    if plan.calibration is None:
        return
    messages = tlog.COMMAND_MESSAGES if log.log_format == "tlog" else dataflash.COMMAND_MESSAGES
    for role in COMMAND_ROLES:
        cmap = plan.calibration.commands.get(role)
        if cmap is None:
            continue
        if cmap.constant is not None:
            log.constants[role] = cmap.constant
            log.topics[role] = f"constant {cmap.constant:g} {ROLE_UNITS[role]} (calibration)"
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
        actuator = plan.calibration.actuators.get(role)
        log.topics[role] = f"{name}.{field_name} ({cmap.source}{' -> ' + actuator if actuator else ''})"
        if name != "MANUAL_CONTROL":
            log.periodic_commands.add(role)



def read_mavlink_trial(
    path: Path,
    calibration: Calibration | Path | None = None,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    origin: tuple[float, float, float] | None = None,
    order: Sequence[str] = (),
) -> Trial:
    """A .tlog or DataFlash .BIN as a :class:`Trial` (metadata: :class:`MavlinkTrialMetadata`); ``order``: the boat
    file's actuator names in its order, which fill the command slots."""
    return trial_from_log(read_mavlink_log(path, calibration, remap, namespace, order), origin,
                          derive_velocity="gnss_vel" not in (remap or {}))  # a named velocity source stays missing
