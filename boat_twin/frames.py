"""Frames and angles, one convention each: angles wrapped to [−π, π); ENU yaw (REP-103: counter-clockwise from
east) ↔ NED yaw (clockwise from north, the compass's, MAVLink's and the UM7's); yaw of a quaternion.

Every function takes floats or numpy arrays of any shape.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def wrap_pi(angle_rad: Any) -> Any:
    """Angles wrapped to [−π, π), rad: −π stays −π and π becomes −π (a heading or residual 2π off is the same)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def ned_yaw_from_enu(yaw_rad: Any) -> Any:
    """NED yaw (clockwise from north), rad, of an ENU yaw (counter-clockwise from east): π/2 − yaw, not wrapped."""
    return math.pi / 2.0 - yaw_rad


def enu_yaw_from_ned(yaw_ned_rad: Any) -> Any:
    """ENU yaw (counter-clockwise from east), rad, of a NED yaw or compass heading in rad: π/2 − ψ, not wrapped."""
    return math.pi / 2.0 - yaw_ned_rad


def quaternion_xyzw(roll_rad: np.ndarray, pitch_rad: np.ndarray, yaw_rad: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4), w >= 0, of R = Rz(yaw) Ry(pitch) Rx(roll) (REP-103 fixed-axis roll, pitch, yaw)."""
    cr, sr = np.cos(roll_rad / 2.0), np.sin(roll_rad / 2.0)
    cp, sp = np.cos(pitch_rad / 2.0), np.sin(pitch_rad / 2.0)
    cy, sy = np.cos(yaw_rad / 2.0), np.sin(yaw_rad / 2.0)
    q = np.column_stack([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ])
    return q * np.where(q[:, 3:] < 0.0, -1.0, 1.0)


def quaternion_yaw_rad(x: Any, y: Any, z: Any, w: Any) -> Any:
    """ENU yaw (REP-103) of quaternions given by their components (floats or arrays), rad, in [−π, π]: the
    inverse of :func:`quaternion_xyzw`'s yaw, whatever the roll and pitch."""
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
