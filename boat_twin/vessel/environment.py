"""The sea and air around the boat: a constant, uniform water current and wind (ENU)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from boat_twin.errors import InputError


@dataclass(frozen=True)
class Environment:
    """Constant water current and wind over ground in the ENU world frame (directions they flow *to*)."""

    current_east_mps: float = 0.0
    """Current velocity, east component, m/s."""
    current_north_mps: float = 0.0
    """Current velocity, north component, m/s."""

    wind_east_mps: float = 0.0
    """True wind velocity (air over ground), east component, m/s (meteorology's wind 'from' is the opposite)."""
    wind_north_mps: float = 0.0
    """True wind velocity, north component, m/s."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            limit = 10.0 if f.name.startswith("current") else 40.0
            if not math.isfinite(value) or abs(value) > limit:
                raise InputError(f"environment '{f.name}' must be a finite speed below {limit:g} m/s, got {value!r}")

    def as_vector(self) -> np.ndarray:
        """``[current_east, current_north, wind_east, wind_north]``, m/s: the dynamics kernel's environment row."""
        return np.array([self.current_east_mps, self.current_north_mps, self.wind_east_mps, self.wind_north_mps])
