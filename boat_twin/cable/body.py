"""The towed vehicle (Babanin & Melkonyan 2025, eqs. 1-5): hydrodynamic force, attack angle, cable pull.

Moment balance about the cable attachment point O, eq. (3):
    M(α) = p0·a·cos α − R_x0·b·sin α − R_y0·b·cos α = 0,
    R_x0 = cx(α)·ρV²/2·d²,  R_y0 = cy(α)·ρV²/2·d²   (eq. 4),  V = V_k + V_T(Y0)   (eq. 5).
The paper's text calls b = OG the arm of the hydrodynamic force and a = OD the arm of the weight while its
letters G (weight) and D (pressure centre) say the opposite; we follow equation (3): **a is the arm of the
weight p0, b the arm of the hydrodynamic force**. Force balance (eqs. 1-2) then gives the pull of the first
cable element on the vehicle: aft component R_x0, downward component p0 − R_y0 (R_y0 > 0 is lift, upward).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.optimize import brentq

from boat_twin.cable.errors import CableSolveError
from boat_twin.errors import InputError

_SCAN_STEP_RAD = math.radians(1.0)
"""Grid on which the sign change of M(α) is looked for before brentq refines it (the paper steps α too)."""


@dataclass(frozen=True)
class AngleCoefficient:
    """A vehicle coefficient (-): a constant (empty ``alpha_rad``) or a table over α, linear in between."""

    alpha_rad: tuple[float, ...]
    value: tuple[float, ...]

    def at(self, alpha_rad: float) -> float:
        """The coefficient at attack angle ``alpha_rad`` (rad)."""
        if not self.alpha_rad:
            return self.value[0]
        return float(np.interp(alpha_rad, self.alpha_rad, self.value))

    def to_spec(self) -> float | dict[str, list[float]]:
        """Plain data: the constant, or ``{"alpha_deg": [...], "value": [...]}``."""
        if not self.alpha_rad:
            return self.value[0]
        return {"alpha_deg": [math.degrees(a) for a in self.alpha_rad], "value": list(self.value)}


def coefficient_from_spec(spec: Any, where: str) -> AngleCoefficient:
    """Read a number or ``{alpha_deg: [...], value: [...]}`` (α strictly increasing, within ±90°)."""
    if isinstance(spec, Mapping):
        if set(spec) != {"alpha_deg", "value"}:
            raise InputError(f"{where}: a table needs exactly the fields alpha_deg and value")
        alpha, value = spec["alpha_deg"], spec["value"]
        for key, seq in (("alpha_deg", alpha), ("value", value)):
            if not isinstance(seq, Sequence) or isinstance(seq, str) or len(seq) < 2:
                raise InputError(f"{where}.{key}: expected a list of at least 2 numbers")
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                       for v in seq):
                raise InputError(f"{where}.{key}: must contain finite numbers only")
        if len(alpha) != len(value):
            raise InputError(f"{where}: alpha_deg has {len(alpha)} values but value has {len(value)}")
        if any(b <= a for a, b in pairwise(alpha)) or alpha[0] < -90.0 or alpha[-1] > 90.0:
            raise InputError(f"{where}.alpha_deg: must increase strictly within [-90, 90] deg")
        return AngleCoefficient(tuple(math.radians(a) for a in alpha), tuple(float(v) for v in value))
    if isinstance(spec, bool) or not isinstance(spec, (int, float)) or not math.isfinite(spec):
        raise InputError(f"{where}: expected a number or {{alpha_deg: [...], value: [...]}}, got {spec!r}")
    return AngleCoefficient((), (float(spec),))


@dataclass(frozen=True)
class Vehicle:
    """The towed body. Arms a, b follow eq. (3) (see the module note); the reference area is d²."""

    weight_in_water_N: float  # p0, weight minus buoyancy, N
    a_m: float
    b_m: float
    d_m: float
    cx: AngleCoefficient
    cy: AngleCoefficient

    def alpha_range_rad(self) -> tuple[float, float]:
        """Attack angles where both coefficients are defined, within ±90° (rad)."""
        lo, hi = -math.pi / 2.0, math.pi / 2.0
        for coef in (self.cx, self.cy):
            if coef.alpha_rad:
                lo, hi = max(lo, coef.alpha_rad[0]), min(hi, coef.alpha_rad[-1])
        return lo, hi

    def moment_Nm(self, density_kgpm3: float, flow_mps: float, alpha_rad: float) -> float:
        """M(α) of eq. (3) about O, N·m (positive: the weight's moment wins)."""
        q = 0.5 * density_kgpm3 * flow_mps * flow_mps * self.d_m**2
        rx, ry = self.cx.at(alpha_rad) * q, self.cy.at(alpha_rad) * q
        return (self.weight_in_water_N * self.a_m * math.cos(alpha_rad)
                - rx * self.b_m * math.sin(alpha_rad) - ry * self.b_m * math.cos(alpha_rad))


@dataclass(frozen=True)
class BodyEquilibrium:
    """The vehicle in equilibrium at one flow speed; forces in N, angle in rad."""

    alpha_rad: float
    flow_mps: float
    drag_N: float  # R_x0, aft
    lift_N: float  # R_y0, up
    pull_aft_N: float  # T1·cos β1, eq. (1)
    pull_down_N: float  # T1·sin β1 = p0 − R_y0, eq. (2)


def _scan(f: Any, start: float, stop: float) -> float | None:
    """First root of ``f`` met walking from ``start`` to ``stop`` (grid + brentq), or None."""
    n = max(1, math.ceil(abs(stop - start) / _SCAN_STEP_RAD))
    grid = np.linspace(start, stop, n + 1)
    prev = f(grid[0])
    if prev == 0.0:
        return float(grid[0])
    for a, b in pairwise(grid):
        cur = f(b)
        if cur == 0.0:
            return float(b)
        if (prev < 0.0) != (cur < 0.0):
            return float(brentq(f, min(a, b), max(a, b), xtol=1e-14))
        prev = cur
    return None


def body_equilibrium(vehicle: Vehicle, density_kgpm3: float, flow_mps: float) -> BodyEquilibrium:
    """Solve eq. (3) for α by root finding (first root from α = 0, as the paper scans), then eqs. (1)-(2).

    Raises :class:`CableSolveError` if no α in the coefficients' range balances the moment.
    """
    if flow_mps < 0.0:
        raise InputError(f"relative flow at the vehicle is {flow_mps:.3g} m/s < 0 "
                         "(a following current faster than the tow is outside the model)")
    p0 = vehicle.weight_in_water_N
    if flow_mps == 0.0:
        return BodyEquilibrium(math.pi / 2.0, 0.0, 0.0, 0.0, 0.0, p0)
    lo, hi = vehicle.alpha_range_rad()

    def moment(alpha: float) -> float:
        return vehicle.moment_Nm(density_kgpm3, flow_mps, alpha)

    zero = min(max(0.0, lo), hi)
    alpha = _scan(moment, zero, hi) if hi > zero else None
    if alpha is None and zero > lo:
        alpha = _scan(moment, zero, lo)
    if alpha is None:
        raise CableSolveError(
            f"no attack angle in [{math.degrees(lo):.1f}, {math.degrees(hi):.1f}] deg balances the vehicle's "
            f"moment (eq. 3) at flow {flow_mps:.3g} m/s: check vehicle.cx, vehicle.cy, a_m, b_m")
    q = 0.5 * density_kgpm3 * flow_mps**2 * vehicle.d_m**2
    drag, lift = vehicle.cx.at(alpha) * q, vehicle.cy.at(alpha) * q
    return BodyEquilibrium(alpha, flow_mps, drag, lift, drag, p0 - lift)
