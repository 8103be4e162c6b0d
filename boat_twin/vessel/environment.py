"""The sea around the boat: a constant, uniform water current (ENU)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from boat_twin.errors import InputError


@dataclass(frozen=True)
class Environment:
    """Constant water current over ground in the ENU world frame (the direction the water flows *to*)."""

    current_east_mps: float = 0.0
    """Current velocity, east component, m/s."""
    current_north_mps: float = 0.0
    """Current velocity, north component, m/s."""

    def __post_init__(self) -> None:
        for name in ("current_east_mps", "current_north_mps"):
            value = getattr(self, name)
            if not math.isfinite(value) or abs(value) > 10.0:
                raise InputError(f"environment '{name}' must be a finite speed below 10 m/s, got {value!r}")
