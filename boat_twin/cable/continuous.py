"""Continuous reference: the same cable physics as an ODE in arc length s, integrated by scipy.

From the vehicle (s = 0) up, with h = T·(cos β, sin β) the (aft, down) tension and f the load per metre
(weight + drag, :class:`~boat_twin.cable.drag.CableLoading`):
    dh/ds = f(Y, β),   dX/ds = cos β,   dY/ds = −sin β,   β = atan2(h_down, h_aft),
    h(0) = (R_x0, p0 − R_y0) from the vehicle's equilibrium (eqs. 1-5).
This is the l → 0 limit of the lumped-link model; the convergence study measures the links against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from boat_twin.cable.body import BodyEquilibrium, body_equilibrium
from boat_twin.cable.case import CableCase
from boat_twin.cable.errors import CableSolveError
from boat_twin.cable.problems import UNCONFIGURED_MAX_LENGTH_M

RTOL = 1e-11
"""Relative tolerance of the integrator (DOP853); absolute tolerance is ATOL in m and N."""
ATOL = 1e-9


@dataclass(frozen=True)
class ContinuousSolution:
    """The ODE solution along the cable from the vehicle (index 0) to the top, SI units."""

    body: BodyEquilibrium
    arc_m: np.ndarray
    forward_m: np.ndarray
    depth_m: np.ndarray
    pull_aft_N: np.ndarray
    pull_down_N: np.ndarray

    @property
    def length_m(self) -> float:
        """Cable length integrated, m."""
        return float(self.arc_m[-1])

    @property
    def vehicle_depth_m(self) -> float:
        """Depth of the vehicle, m."""
        return float(self.depth_m[0])

    @property
    def vehicle_offset_m(self) -> float:
        """Horizontal distance of the vehicle astern of the top end, m."""
        return float(self.forward_m[-1])

    @property
    def top_tension_N(self) -> float:
        """Tension at the top end, N."""
        return math.hypot(self.pull_aft_N[-1], self.pull_down_N[-1])


def integrate(case: CableCase, vehicle_depth_m: float, length_m: float | None) -> ContinuousSolution:
    """Integrate up from a vehicle at ``vehicle_depth_m`` over ``length_m``, or to the surface if None."""
    loading = case.loading()
    body = body_equilibrium(case.vehicle, case.water_density_kgpm3, case.flow_mps(vehicle_depth_m))

    def rhs(_s: float, y: np.ndarray) -> list[float]:
        angle = math.atan2(y[3], y[2])
        aft, down = loading.per_length(np.asarray(y[1]), np.asarray(angle))
        return [math.cos(angle), -math.sin(angle), float(aft), float(down)]

    def surface(_s: float, y: np.ndarray) -> float:
        return float(y[1])

    surface.terminal = True  # type: ignore[attr-defined]
    surface.direction = -1.0  # type: ignore[attr-defined]
    end = UNCONFIGURED_MAX_LENGTH_M if length_m is None else length_m
    if length_m is None and case.cable.winch_capacity_m is not None:
        end = case.cable.winch_capacity_m
    sol = solve_ivp(rhs, (0.0, end), [0.0, vehicle_depth_m, body.pull_aft_N, body.pull_down_N],
                    method="DOP853", rtol=RTOL, atol=ATOL, events=None if length_m is not None else surface)
    if not sol.success:
        raise CableSolveError(f"the cable ODE failed: {sol.message}")
    if length_m is None and sol.status != 1:
        raise CableSolveError(f"the continuous cable does not reach the surface within {end:g} m")
    return ContinuousSolution(body, sol.t, sol.y[0], sol.y[1], sol.y[2], sol.y[3])


def continuous_depth(case: CableCase, length_m: float) -> ContinuousSolution:
    """Problem 1 on the continuous cable: the vehicle depth at which ``length_m`` ends at the surface."""
    upper = length_m * (1 + 1e-12) + 1e-12
    try:
        depth = brentq(lambda d: integrate(case, d, length_m).depth_m[-1], 0.0, upper,
                       xtol=1e-11 * max(1.0, length_m))
    except (RuntimeError, ValueError) as err:
        raise CableSolveError(f"continuous problem 1 failed for L = {length_m:g} m ({err})") from None
    return integrate(case, depth, length_m)


def continuous_length(case: CableCase, depth_m: float) -> ContinuousSolution:
    """Problem 2 on the continuous cable: the length that holds the vehicle at ``depth_m``."""
    return integrate(case, depth_m, None)
