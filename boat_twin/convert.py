"""``boat-twin convert``: a MAVLink log (.tlog, .BIN) as a rosbag2 with the package's topics.

The log's samples are written as they were logged (not resampled): ``gnss/fix`` (NavSatFix, covariance
unknown), ``gnss/vel`` (TwistStamped, ENU velocity over ground), ``imu/data`` (Imu, FLU in ENU, gravity
included; REP-145: covariances unknown, element 0 = −1 where a field is not in the log) and the four thruster
topics (Float64, N and rad, through the calibration). Header stamps and log times are the log's clock
(:mod:`boat_twin.io.mavlink`). The bag is written next to its target and renamed into place.
"""

from __future__ import annotations

import argparse
import heapq
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.io.files import to_json
from boat_twin.io.sources import add_trial_options, parse_remap
from boat_twin.io.trial import COMMAND_ROLES

_UNKNOWN_COV = np.zeros(9)
_UNKNOWN_COV.flags.writeable = False
_NOT_PROVIDED_COV = np.zeros(9)
_NOT_PROVIDED_COV[0] = -1.0
_NOT_PROVIDED_COV.flags.writeable = False


def _sorted(stamps: np.ndarray, values: np.ndarray) -> tuple[list[int], np.ndarray]:
    from boat_twin.io.messages import stamps_ns

    order = np.argsort(stamps, kind="stable")
    return stamps_ns(stamps[order]).tolist(), values[order]


def log_messages(log: Any) -> Iterator[tuple[str, int, Any]]:
    """The package's messages for a :class:`~boat_twin.io.mavlink.MavlinkLog`, merged in stamp order."""
    from boat_twin.io import messages as msgs
    from boat_twin.io.bags import ROLE_TOPICS
    from boat_twin.sensors.um7 import quaternion_xyzw

    streams = []
    nav = msgs.TS.types["sensor_msgs/msg/NavSatFix"]

    def fixes(stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        for ns, (lat, lon, alt) in zip(stamps, values.tolist(), strict=True):
            msg = msgs.navsatfix(msgs.header(ns, msgs.FRAME_GNSS), lat, lon, alt, _UNKNOWN_COV)
            msg.position_covariance_type = nav.COVARIANCE_TYPE_UNKNOWN
            yield msgs.TOPIC_GNSS_FIX, ns, msg

    def velocities(stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        for ns, (east, north) in zip(stamps, values.tolist(), strict=True):
            yield msgs.TOPIC_GNSS_VEL, ns, msgs.twist_stamped(msgs.header(ns, msgs.FRAME_GNSS), (east, north, 0.0))

    def imus(stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        yaw, rate, ax, ay, roll, pitch, p, q, az = values.T
        roll_pitch = np.where(np.isfinite(roll) & np.isfinite(pitch), 1.0, 0.0)
        quats = quaternion_xyzw(np.nan_to_num(roll) * roll_pitch, np.nan_to_num(pitch) * roll_pitch,
                                np.nan_to_num(yaw))
        gyro = np.column_stack([p, q, rate])
        accel = np.column_stack([ax, ay, az])
        for i, ns in enumerate(stamps):
            has_q, has_w, has_a = np.isfinite(yaw[i]), np.all(np.isfinite(gyro[i])), np.all(np.isfinite(accel[i]))
            yield msgs.TOPIC_IMU_DATA, ns, msgs.imu(
                msgs.header(ns, msgs.FRAME_IMU),
                quats[i].tolist() if has_q else (0.0, 0.0, 0.0, 1.0),
                gyro[i].tolist() if has_w else (0.0, 0.0, 0.0),
                accel[i].tolist() if has_a else (0.0, 0.0, 0.0),
                _UNKNOWN_COV if has_q else _NOT_PROVIDED_COV,
                _UNKNOWN_COV if has_w else _NOT_PROVIDED_COV,
                _UNKNOWN_COV if has_a else _NOT_PROVIDED_COV,
            )

    def commands(topic: str, stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        for ns, value in zip(stamps, values[:, 0].tolist(), strict=True):
            yield topic, ns, msgs.float64(value)

    builders = {"gnss_fix": fixes, "gnss_vel": velocities, "imu": imus}
    first_command = [float(np.min(s.stamps_s)) for r, s in log.streams.items() if r in COMMAND_ROLES]
    for role, stream in log.streams.items():
        stamps, values = _sorted(stream.stamps_s, stream.values)
        if role in builders:
            streams.append(builders[role](stamps, values))
        else:
            streams.append(commands(ROLE_TOPICS[role], stamps, values))
    if log.constants:
        start = min(first_command) if first_command else min(
            (float(np.min(s.stamps_s)) for s in log.streams.values()), default=0.0)
        for role, value in log.constants.items():
            streams.append(commands(ROLE_TOPICS[role], *_sorted(np.array([start]), np.array([[value]]))))
    return heapq.merge(*streams, key=lambda item: item[1])


def run(args: argparse.Namespace) -> int:
    """Handler of ``boat-twin convert``."""
    from boat_twin.io.bags import write_bag
    from boat_twin.io.mavlink import is_mavlink_log, read_mavlink_log, trial_from_log

    log_path: Path = args.log
    if not is_mavlink_log(log_path):
        raise InputError(f"{log_path}: convert reads MAVLink logs (.tlog telemetry or .BIN DataFlash)")
    sys.stderr.write(f"reading {log_path} ...\n")
    log = read_mavlink_log(log_path, args.calibration, remap=parse_remap(args.topic))
    trial = trial_from_log(log)
    summary = trial.metadata.summary_line()
    sys.stderr.write(summary + "\n")
    sys.stderr.write(f"writing {args.out} ...\n")
    counts: dict[str, int] = {}

    def counted() -> Iterator[tuple[str, int, Any]]:
        for item in log_messages(log):
            counts[item[0]] = counts.get(item[0], 0) + 1
            yield item

    total = write_bag(args.out, counted(), storage=args.storage, force=args.force)
    notes = []
    if not {"gnss_fix", "gnss_vel"} & set(log.streams):
        notes.append("the log has no GNSS: boat_twin builds a trial from a bag only with gnss/fix or gnss/vel")
    if not any(role in log.streams or role in log.constants for role in COMMAND_ROLES):
        notes.append("no commands mapped (give --calibration): the bag has no thruster topics")
    if args.json:
        sys.stdout.write(to_json({
            "source": str(log_path), "out": str(args.out), "messages": total, "topics": counts,
            "summary": summary, "missing": trial.metadata.missing, "gaps": trial.metadata.gaps,
            "start_time_s": trial.metadata.start_time_s, "time_base": log.time_base, "notes": notes,
        }) + "\n")
        return 0
    lines = [f"wrote {args.out}: {total} messages"] + [f"  /{topic}: {n}" for topic, n in sorted(counts.items())]
    lines += [f"note: {note}" for note in notes]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``convert`` verb."""
    p = subparsers.add_parser(
        "convert",
        help="convert a MAVLink log (.tlog, .BIN) into a rosbag2 with the package's topics",
        description="Read an ArduPilot/MAVLink log (telemetry .tlog or DataFlash .BIN) and write its trial as a "
        "rosbag2 (MCAP by default): gnss/fix, gnss/vel, imu/data (ENU/FLU, SI) and, with --calibration, the "
        "thruster topics (N, rad). Samples keep the log's own time stamps.",
    )
    p.add_argument("log", type=Path, metavar="LOG", help="MAVLink telemetry log (.tlog) or DataFlash log (.BIN)")
    p.add_argument("--out", type=Path, required=True, metavar="BAG",
                   help="output bag: a directory, or a file ending in .mcap")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (default mcap)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    add_trial_options(p, bags=False)
    p.set_defaults(handler=run)
