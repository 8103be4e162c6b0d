"""The sea and air around the boat: a constant, uniform water current and wind (ENU), and a measured wind's
time course (:class:`WindTrack`) a simulation can be run in, held piecewise."""

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


@dataclass(frozen=True)
class WindTrack:
    """A measured true wind over time (an anemometer's): times s, the air's velocity over ground east and north,
    m/s (NaN: not known then)."""

    t_s: np.ndarray
    east_mps: np.ndarray
    north_mps: np.ndarray

    def mean_over(self, start_s: float, stop_s: float) -> tuple[float, float]:
        """The wind's mean over [``start_s``, ``stop_s``), m/s (east, north): its known samples there, else the
        known sample nearest to the span's middle (the wind held across the anemometer's gaps)."""
        known = np.isfinite(self.east_mps) & np.isfinite(self.north_mps)
        if not np.any(known):
            raise InputError("the wind track has no known sample")
        inside = known & (self.t_s >= start_s) & (self.t_s < stop_s)
        if np.any(inside):
            return float(np.mean(self.east_mps[inside])), float(np.mean(self.north_mps[inside]))
        nearest = int(np.argmin(np.where(known, np.abs(self.t_s - 0.5 * (start_s + stop_s)), np.inf)))
        return float(self.east_mps[nearest]), float(self.north_mps[nearest])
