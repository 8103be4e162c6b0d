"""The current profile V_T(Y): current speed (m/s) as a function of depth Y (m, positive down).

Sign convention (Babanin & Melkonyan 2025, eqs. 5 and 9): the flow met by the cable and the vehicle is
V = V_k + V_T(Y), with V_k the tow speed over ground. So V_T > 0 is a *head* current (running against the
tow direction, adding to the flow past the cable) and V_T < 0 a following current.
The profile is piecewise linear between the given depths and constant beyond the first and last ones.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.validation import number


@dataclass(frozen=True)
class CurrentProfile:
    """Head-current speed ``speed_mps[i]`` (m/s) at depth ``depth_m[i]`` (m), depths strictly increasing."""

    depth_m: tuple[float, ...]
    speed_mps: tuple[float, ...]

    def speed_at(self, depth_m: np.ndarray | float) -> np.ndarray:
        """V_T(Y) in m/s at depth(s) ``depth_m``; linear inside the table, constant outside it."""
        return np.asarray(np.interp(depth_m, self.depth_m, self.speed_mps))

    @property
    def min_speed_mps(self) -> float:
        """The lowest current speed anywhere in the profile (m/s)."""
        return min(self.speed_mps)

    def to_dict(self) -> dict[str, Any]:
        """Plain data that :func:`current_from_spec` reads back."""
        return {"depth_m": list(self.depth_m), "speed_mps": list(self.speed_mps)}


def current_from_spec(spec: Any, where: str = "current") -> CurrentProfile:
    """Read a current: a number (m/s, uniform), ``{speed_mps: v}`` or ``{depth_m: [..], speed_mps: [..]}``."""
    if not isinstance(spec, Mapping):
        return CurrentProfile((0.0,), (number(where, spec),))
    unknown = set(spec) - {"depth_m", "speed_mps"}
    if unknown:
        raise InputError(f"{where}: unknown field(s) {sorted(unknown)} (expected depth_m, speed_mps)")
    speeds = spec.get("speed_mps")
    if "depth_m" not in spec:
        return CurrentProfile((0.0,), (number(f"{where}.speed_mps", speeds),))
    depths = spec["depth_m"]
    for key, values in (("depth_m", depths), ("speed_mps", speeds)):
        if not isinstance(values, Sequence) or isinstance(values, str) or len(values) == 0:
            raise InputError(f"{where}.{key}: expected a non-empty list of numbers")
    assert isinstance(speeds, Sequence)  # checked just above (for the type checker)
    if len(depths) != len(speeds):
        raise InputError(f"{where}: depth_m has {len(depths)} values but speed_mps has {len(speeds)}")
    d = tuple(number(f"{where}.depth_m", v) for v in depths)
    v = tuple(number(f"{where}.speed_mps", s) for s in speeds)
    if d[0] < 0.0:
        raise InputError(f"{where}.depth_m: depths must be >= 0 m (got {d[0]})")
    if any(b <= a for a, b in pairwise(d)):
        raise InputError(f"{where}.depth_m: depths must increase strictly, got {list(d)}")
    return CurrentProfile(d, v)
