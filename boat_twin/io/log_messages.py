"""A MAVLink log as the package's ROS 2 messages: what ``boat-twin convert`` writes to a bag.

The log's samples become messages as they were logged (not resampled): ``gnss/fix`` (NavSatFix, covariance
unknown), ``gnss/vel`` (TwistStamped, ENU velocity over ground), ``imu/data`` (Imu, FLU in ENU, gravity
included; REP-145: covariances unknown, element 0 = −1 where a field is not in the log), the four thruster
topics (Float64, N and rad, through the calibration) and a measured wind on ``wind`` (Vector3Stamped, ENU).
Stamps are the log's clock (:mod:`boat_twin.io.mavlink`).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from typing import Any

import numpy as np

from boat_twin.frames import quaternion_xyzw
from boat_twin.io import messages as msgs
from boat_twin.io.bags import ROLE_TOPICS
from boat_twin.io.trial import COMMAND_ROLES

_UNKNOWN_COV = np.zeros(9)
_UNKNOWN_COV.flags.writeable = False
_NOT_PROVIDED_COV = np.zeros(9)
_NOT_PROVIDED_COV[0] = -1.0
_NOT_PROVIDED_COV.flags.writeable = False


def _sorted(stamps: np.ndarray, values: np.ndarray) -> tuple[list[int], np.ndarray]:
    order = np.argsort(stamps, kind="stable")
    return msgs.stamps_ns(stamps[order]).tolist(), values[order]


def log_messages(log: Any) -> Iterator[tuple[str, int, Any]]:
    """The package's messages for a :class:`~boat_twin.io.mavlink.MavlinkLog`, merged in stamp order."""
    streams = []
    nav = msgs.TS.types["sensor_msgs/msg/NavSatFix"]

    def fixes(stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        for ns, (lat, lon, alt) in zip(stamps, values.tolist(), strict=True):
            msg = msgs.navsatfix(msgs.header(ns, msgs.FRAME_GNSS), lat, lon, alt, _UNKNOWN_COV)
            msg.position_covariance_type = nav.COVARIANCE_TYPE_UNKNOWN  # type: ignore[attr-defined]
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

    def winds(stamps: list[int], values: np.ndarray) -> Iterator[tuple[str, int, Any]]:
        for ns, (east, north) in zip(stamps, values.tolist(), strict=True):
            yield msgs.TOPIC_WIND, ns, msgs.vector3_stamped(msgs.header(ns, msgs.FRAME_MAP), (east, north, 0.0))

    builders = {"gnss_fix": fixes, "gnss_vel": velocities, "imu": imus, "wind": winds}
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
