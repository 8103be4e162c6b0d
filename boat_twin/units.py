"""Unit conversions used at the edges only (inside, everything is SI)."""

import math

KNOT_MPS = 1852.0 / 3600.0
"""One international knot in m/s (exact: 1852 m per hour)."""

KGF_N = 9.80665
"""One kilogram-force in N (standard gravity, exact by definition)."""

STANDARD_GRAVITY_MPS2 = 9.80665
"""Standard acceleration of gravity g0 in m/s^2 (CGPM 1901)."""


def enu_yaw_to_nautical_deg(yaw_rad: float) -> float:
    """ENU yaw (counter-clockwise from east, rad) to a nautical heading (clockwise from north, deg, 0..360)."""
    return math.degrees(math.pi / 2.0 - yaw_rad) % 360.0
