"""Calm-water resistance Fc(u) in surge: the force (N) opposing motion at speed through water u (m/s).

Every model is odd in u (going astern meets the mirrored resistance) and vectorized over numpy arrays.
Beyond the speed range it was measured or fitted on, a model extrapolates with the quadratic law
Fc = Fc(u_max)·(u/u_max)², continuous in value: resistance of a planing hull above its hump grows roughly
with the square of speed (Savitsky 1964; Faltinsen 2005, ch. 9), so this is the stated, sane continuation.

Models are written to / read from plain dicts (the YAML of a vessel or of an identified model):
``{"model": "table", "speed_mps": [...], "force_N": [...]}`` or
``{"model": "power_series", "coefficients": [c0, c1, ...], "max_speed_mps": u_max}`` with c_i in N/(m/s)^i, or
``{"model": "corrected", "base": {...}, "speed_mps": [...], "factor": [...]}`` (a base curve times a
piecewise-linear factor: what the diagnosis' ``resistance_shape`` writes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from boat_twin.errors import InputError


class ResistanceModel(Protocol):
    """Fc(u): surge resistance in N at speed through water u in m/s."""

    @property
    def max_speed_mps(self) -> float:
        """Highest speed the model was built from, m/s (a quadratic law beyond)."""

    def force_N(self, speed_mps: np.ndarray | float) -> np.ndarray:
        """Resistance in N, same shape as ``speed_mps``."""

    def to_dict(self) -> dict[str, Any]:
        """Plain-data description that :func:`resistance_from_dict` reads back."""


def _odd_with_quadratic_tail(
    speed_mps: np.ndarray | float, inside: Any, max_speed_mps: float
) -> np.ndarray:
    """Evaluate ``inside`` on |u| ≤ u_max, continue quadratically beyond, and mirror for u < 0."""
    u = np.asarray(speed_mps, dtype=float)
    a = np.abs(u)
    top = float(inside(np.array([max_speed_mps]))[0])
    core = inside(np.minimum(a, max_speed_mps))
    tail = top * (a / max_speed_mps) ** 2
    return np.sign(u) * np.where(a <= max_speed_mps, core, tail)


class Pchip:
    """``scipy.interpolate.PchipInterpolator(x, y, extrapolate=False)`` of 1-D ``y``, bit for bit: the same
    derivatives (Fritsch & Carlson's weighted harmonic mean, one-sided three-point ends), the same cubic
    coefficients, evaluated as scipy's piecewise polynomial does (Σ c_k·s^k from the constant term, s from the
    interval's left end; NaN outside [x_0, x_n]). Here because importing scipy.interpolate costs 0.1 s of CPU that
    ``diagnose`` and ``follow`` spend on nothing else of it."""

    def __init__(self, x: np.ndarray, y: np.ndarray) -> None:
        self.x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        h = np.diff(self.x)
        slope = np.diff(y) / h
        d = self._derivatives(h, slope)
        t = (d[:-1] + d[1:] - 2 * slope) / h
        self.c = (t / h, (slope - d[:-1]) / h - t, d[:-1], y[:-1])

    @staticmethod
    def _derivatives(h: np.ndarray, m: np.ndarray) -> np.ndarray:
        if m.size == 1:
            return np.array([m[0], m[0]])
        sign = np.sign(m)
        flat = (sign[1:] != sign[:-1]) | (m[1:] == 0) | (m[:-1] == 0)
        w1, w2 = 2 * h[1:] + h[:-1], h[1:] + 2 * h[:-1]
        with np.errstate(divide="ignore", invalid="ignore"):
            harmonic = (w1 / m[:-1] + w2 / m[1:]) / (w1 + w2)
        d = np.zeros(m.size + 1)
        d[1:-1][~flat] = 1.0 / harmonic[~flat]
        d[0] = Pchip._end(h[0], h[1], m[0], m[1])
        d[-1] = Pchip._end(h[-1], h[-2], m[-1], m[-2])
        return d

    @staticmethod
    def _end(h0: float, h1: float, m0: float, m1: float) -> float:
        d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
        if np.sign(d) != np.sign(m0):
            return 0.0
        if np.sign(m0) != np.sign(m1) and abs(d) > 3.0 * abs(m0):
            return 3.0 * m0
        return d

    def __call__(self, at: np.ndarray) -> np.ndarray:
        at = np.asarray(at, dtype=float)
        x = self.x
        i = np.minimum(np.searchsorted(x, at, side="right") - 1, x.size - 2)
        inside = (at >= x[0]) & (at <= x[-1])
        i = np.where(inside, i, 0)
        s = at - x[i]
        c0, c1, c2, c3 = (c[i] for c in self.c)
        value = 0.0 + c3 * 1.0 + c2 * s + c1 * (s * s) + c0 * (s * s * s)
        return np.where(inside, value, np.nan)


@dataclass(frozen=True)
class TableResistance:
    """Measured steady points (u_j, F_j), joined by a monotone cubic (PCHIP, Fritsch & Carlson 1980).

    PCHIP never overshoots between points, so a non-decreasing table gives a non-decreasing Fc and a
    unique steady speed for every thrust above the flat stretches of the table.
    """

    speeds_mps: tuple[float, ...]
    forces_N: tuple[float, ...]
    _pchip: Pchip = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        u = np.asarray(self.speeds_mps, dtype=float)
        f = np.asarray(self.forces_N, dtype=float)
        if u.ndim != 1 or u.size < 2 or u.size != f.size:
            raise InputError("resistance table: speed_mps and force_N need the same length, at least 2")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(f))):
            raise InputError("resistance table: speed_mps and force_N must be finite numbers")
        if u[0] != 0.0 or f[0] != 0.0:
            raise InputError("resistance table: the first point must be (0 m/s, 0 N)")
        if np.any(np.diff(u) <= 0.0):
            raise InputError("resistance table: speed_mps must increase strictly")
        if np.any(np.diff(f) < 0.0):
            raise InputError("resistance table: force_N must not decrease with speed")
        object.__setattr__(self, "_pchip", Pchip(u, f))

    @property
    def max_speed_mps(self) -> float:
        """Highest measured speed, m/s; above it the quadratic law takes over."""
        return float(self.speeds_mps[-1])

    def force_N(self, speed_mps: np.ndarray | float) -> np.ndarray:
        """Resistance in N at speed through water ``speed_mps`` (m/s)."""
        return _odd_with_quadratic_tail(speed_mps, self._pchip, self.max_speed_mps)

    def to_dict(self) -> dict[str, Any]:
        """``{"model": "table", "speed_mps": [...], "force_N": [...]}``."""
        return {"model": "table", "speed_mps": list(self.speeds_mps), "force_N": list(self.forces_N)}


@dataclass(frozen=True)
class PowerSeriesResistance:
    """Fc(u) = Σ c_i·|u|^i·sign(u) for |u| ≤ u_max (Dyda & Chumakova 2021, eq. 1), c_i in N/(m/s)^i."""

    coefficients: tuple[float, ...]
    max_speed_mps: float

    def __post_init__(self) -> None:
        c = np.asarray(self.coefficients, dtype=float)
        if c.ndim != 1 or c.size < 1 or not np.all(np.isfinite(c)):
            raise InputError("power_series resistance: coefficients must be a non-empty list of finite numbers")
        if not (math.isfinite(self.max_speed_mps) and self.max_speed_mps > 0.0):
            raise InputError("power_series resistance: max_speed_mps must be a positive number")

    @property
    def order(self) -> int:
        """Highest power N of the series."""
        return len(self.coefficients) - 1

    def _series(self, a: np.ndarray) -> np.ndarray:
        return np.polynomial.polynomial.polyval(a, np.asarray(self.coefficients, dtype=float))

    def force_N(self, speed_mps: np.ndarray | float) -> np.ndarray:
        """Resistance in N at speed through water ``speed_mps`` (m/s)."""
        return _odd_with_quadratic_tail(speed_mps, self._series, self.max_speed_mps)

    def to_dict(self) -> dict[str, Any]:
        """``{"model": "power_series", "coefficients": [...], "max_speed_mps": u_max}``."""
        return {
            "model": "power_series",
            "coefficients": [float(c) for c in self.coefficients],
            "max_speed_mps": float(self.max_speed_mps),
        }


@dataclass(frozen=True)
class CorrectedResistance:
    """A base curve times a piecewise-linear factor of speed: Fc(u) = Fc_base(u)·k(u).

    ``k`` is linear between the knots (``speeds_mps``, ``factors``) and constant beyond the first and the
    last knot. It describes a resistance that differs from the base over a speed band (fouling, a load, a
    different displacement-to-planing transition).
    """

    base: ResistanceModel
    speeds_mps: tuple[float, ...]
    factors: tuple[float, ...]

    def __post_init__(self) -> None:
        knots, factors = np.asarray(self.speeds_mps, float), np.asarray(self.factors, float)
        if knots.size < 2 or knots.size != factors.size or np.any(np.diff(knots) <= 0):
            raise InputError("corrected resistance: need ≥ 2 increasing 'speed_mps' knots, one 'factor' each")
        if not np.all(np.isfinite(factors)) or np.any(factors <= 0):
            raise InputError("corrected resistance: every 'factor' must be a positive number")

    @property
    def max_speed_mps(self) -> float:
        """Speed up to which the curve is tabulated exactly, m/s: the base's range, extended to the last knot
        (beyond the last knot k is constant, so the quadratic tail of Fc_base·k continues it)."""
        return max(self.base.max_speed_mps, float(self.speeds_mps[-1]))

    @classmethod
    def scaled(cls, base: ResistanceModel, factor: float) -> CorrectedResistance:
        """``base`` × a constant ``factor`` (-) at every speed."""
        return cls(base, (0.0, base.max_speed_mps), (factor, factor))

    def factor(self, speed_mps: np.ndarray | float) -> np.ndarray:
        """k(|u|), -."""
        return np.interp(np.abs(np.asarray(speed_mps, dtype=float)), self.speeds_mps, self.factors)

    def force_N(self, speed_mps: np.ndarray | float) -> np.ndarray:
        """Fc_base(u)·k(|u|), N."""
        return self.base.force_N(speed_mps) * self.factor(speed_mps)

    def to_dict(self) -> dict[str, Any]:
        """``{"model": "corrected", "base": {...}, "speed_mps": [...], "factor": [...]}``."""
        return {"model": "corrected", "base": self.base.to_dict(), "speed_mps": [float(x) for x in self.speeds_mps],
                "factor": [float(x) for x in self.factors]}


def _float_list(spec: Mapping[str, Any], key: str, where: str) -> tuple[float, ...]:
    values = spec.get(key)
    if not isinstance(values, Sequence) or isinstance(values, str):
        raise InputError(f"{where}: '{key}' must be a list of numbers")
    try:
        return tuple(float(x) for x in values)
    except (TypeError, ValueError):
        raise InputError(f"{where}: '{key}' must contain numbers only") from None


def resistance_from_dict(spec: Any, where: str = "resistance") -> ResistanceModel:
    """Build a resistance model from its plain-data description; ``where`` names it in error messages."""
    if not isinstance(spec, Mapping):
        raise InputError(f"{where}: expected a mapping with a 'model' key")
    kind = spec.get("model")
    if kind == "table":
        return TableResistance(_float_list(spec, "speed_mps", where), _float_list(spec, "force_N", where))
    if kind == "power_series":
        try:
            max_speed = float(spec.get("max_speed_mps", "nan"))
        except (TypeError, ValueError):
            raise InputError(f"{where}: 'max_speed_mps' must be a number") from None
        return PowerSeriesResistance(_float_list(spec, "coefficients", where), max_speed)
    if kind == "corrected":
        base = resistance_from_dict(spec.get("base"), f"{where}: base")
        try:
            return CorrectedResistance(base, _float_list(spec, "speed_mps", where), _float_list(spec, "factor", where))
        except InputError as err:
            raise InputError(f"{where}: {err}") from None
    raise InputError(f"{where}: unknown model {kind!r} (expected 'table', 'power_series' or 'corrected')")


def dyda2021_resistance() -> TableResistance:
    """The measured curve of Dyda & Chumakova (2021), Table 1, read as knots and kgf, in SI."""
    from boat_twin.data import dyda2021_table1_si

    speed_mps, force_n = dyda2021_table1_si()
    return TableResistance(tuple(speed_mps.tolist()), tuple(force_n.tolist()))
