"""Ground-truth motion of one boat sampled at the output rate: what the sensor models measure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TruthSeries:
    """True motion of one boat at times ``t_s``; every array has shape (n,). World ENU, body FLU (REP-103).

    Velocities over ground are inertial (they include the water current); ``accel_*`` is the body-frame
    acceleration over ground (no gravity): what an accelerometer measures after removing +g on z.
    """

    t_s: np.ndarray
    """Time since the start of the trial, s."""
    east_m: np.ndarray
    """Position east of the geodetic origin, m."""
    north_m: np.ndarray
    """Position north of the geodetic origin, m."""
    yaw_rad: np.ndarray
    """Heading as ENU yaw: counter-clockwise from east, rad (unwrapped)."""
    vel_east_mps: np.ndarray
    """Velocity over ground, east component, m/s."""
    vel_north_mps: np.ndarray
    """Velocity over ground, north component, m/s."""
    surge_mps: np.ndarray
    """Body-frame forward velocity through the water, m/s."""
    sway_mps: np.ndarray
    """Body-frame leftward velocity through the water, m/s."""
    yaw_rate_radps: np.ndarray
    """Yaw rate about body z (up), rad/s."""
    accel_x_mps2: np.ndarray
    """Body-frame forward acceleration over ground, m/s^2."""
    accel_y_mps2: np.ndarray
    """Body-frame leftward acceleration over ground, m/s^2."""

    def __len__(self) -> int:
        return int(self.t_s.size)


def ground_velocity_enu(yaw_rad: np.ndarray, surge_mps: np.ndarray, sway_mps: np.ndarray, current_east_mps: float,
                        current_north_mps: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity over ground (east, north), m/s, of a boat at ENU yaw (rad) moving (surge, sway) through the water
    (body FLU, m/s) in a uniform current (ENU, m/s); arrays of any one shape."""
    cos, sin = np.cos(yaw_rad), np.sin(yaw_rad)
    return surge_mps * cos - sway_mps * sin + current_east_mps, surge_mps * sin + sway_mps * cos + current_north_mps
