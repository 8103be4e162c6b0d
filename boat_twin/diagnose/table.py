"""Diagnose a steady-state thrust–speed table against a power-series model (``diagnose --table dyda2021``).

The baseline is the paper's own fit of order N (Dyda & Chumakova 2021: N = 1, 3 or 5, its printed
coefficients). The only catalogue effect a steady table can show is ``resistance_shape``: the extension adds a
piecewise-linear correction ΔF(v) with K evenly spaced knots over the table's speeds, fitted by linear least
squares; K (2..:data:`MAX_KNOTS`) is chosen by leave-one-out cross-validation. The decision rule is the trial
diagnosis' (:mod:`boat_twin.diagnose.search`): ΔBIC < −10, cross-validated gain > 1 %, and a 95 % interval of
a knot that excludes zero. The regime change is located on the extended curve as the longest speed band
where its slope falls below half its median slope: the plateau between the displacement and planing regimes.
Whether the extended model's residuals still carry structure is judged by a runs test of their signs along
the speed (Wald & Wolfowitz 1940; two-sided p < :data:`RUNS_P_VALUE`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import polynomial
from scipy.special import ndtr, stdtrit

from boat_twin.diagnose.search import BIC_THRESHOLD, MIN_HELDOUT_GAIN

MAX_KNOTS = 12
"""Most knots the correction may use (37 rows: ≥ 3 rows per knot interval)."""
PLATEAU_SLOPE_FRACTION = 0.5
"""The plateau: where the extended curve's slope is below this fraction of its median slope."""
RUNS_P_VALUE = 0.01
"""Residual signs along the speed with fewer runs than chance at this level: structure left, 'unexplained'."""


def hat_design(speed: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(n, K) design of a piecewise-linear function with values at ``knots`` (constant beyond the ends)."""
    eye = np.eye(knots.size)
    return np.column_stack([np.interp(speed, knots, eye[k]) for k in range(knots.size)])


def _loo_sse(design: np.ndarray, y: np.ndarray) -> float:
    """Leave-one-out SSE of a linear least-squares fit (hat-matrix shortcut)."""
    q, _ = np.linalg.qr(design)
    leverage = np.sum(q * q, axis=1)
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    resid = y - design @ coef
    return float(np.sum((resid / np.maximum(1.0 - leverage, 1e-9)) ** 2))


def runs_test_p(residual: np.ndarray) -> float:
    """Two-sided p-value of the Wald–Wolfowitz runs test on the signs of ``residual`` (zeros dropped)."""
    signs = np.sign(residual[residual != 0])
    n_pos, n_neg = int(np.sum(signs > 0)), int(np.sum(signs < 0))
    if n_pos == 0 or n_neg == 0:
        return 0.0
    runs = 1 + int(np.sum(signs[1:] != signs[:-1]))
    n = n_pos + n_neg
    mean = 2.0 * n_pos * n_neg / n + 1.0
    var = (mean - 1.0) * (mean - 2.0) / (n - 1.0)
    return float(2.0 * ndtr(-abs(runs - mean) / np.sqrt(max(var, 1e-12))))


def _plateau(speed: np.ndarray, force: np.ndarray) -> tuple[float, float] | None:
    """Longest band where the slope of ``force(speed)`` is below PLATEAU_SLOPE_FRACTION of its median slope."""
    slope = np.gradient(force, speed)
    low = slope < PLATEAU_SLOPE_FRACTION * np.median(slope)
    best, start = None, None
    for i, flag in enumerate(np.append(low, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if best is None or speed[i - 1] - speed[start] > best[1] - best[0]:
                best = (float(speed[start]), float(speed[i - 1]))
            start = None
    return best


@dataclass(frozen=True)
class TableDiagnosis:
    """The diagnosis of one table; speeds and forces in the table's own units."""

    speed: np.ndarray
    force: np.ndarray
    baseline: np.ndarray
    extended: np.ndarray
    knots: np.ndarray
    correction: np.ndarray
    correction_ci95: np.ndarray
    delta_bic: float
    cv_gain: float
    named: bool
    plateau: tuple[float, float] | None
    band: tuple[float, float] | None
    runs_p: float

    @property
    def unexplained(self) -> bool:
        """Structure left in the residuals of the model the diagnosis ends with."""
        return self.runs_p < RUNS_P_VALUE


def diagnose_table(speed: np.ndarray, force: np.ndarray, coefficients: tuple[float, ...]) -> TableDiagnosis:
    """Diagnose the steady points (``speed``, ``force``) against the power series ``coefficients`` (c_0..c_N)."""
    baseline = polynomial.polyval(speed, coefficients)
    residual = force - baseline
    n = speed.size
    sse_base = float(np.sum(residual**2))
    choices = []
    for k in range(2, MAX_KNOTS + 1):
        knots = np.linspace(speed.min(), speed.max(), k)
        choices.append((_loo_sse(hat_design(speed, knots), residual), k, knots))
    cv_sse, k, knots = min(choices, key=lambda c: c[0])
    design = hat_design(speed, knots)
    coef, *_ = np.linalg.lstsq(design, residual, rcond=None)
    fitted = design @ coef
    sse = float(np.sum((residual - fitted) ** 2))
    dof = n - k
    cov = sse / dof * np.linalg.inv(design.T @ design)
    half = stdtrit(dof, 0.975) * np.sqrt(np.diag(cov))
    ci = np.column_stack([coef - half, coef + half])
    delta_bic = float(n * np.log(sse / sse_base) + k * np.log(n))
    gain = 1.0 - cv_sse / sse_base
    significant = (ci[:, 0] > 0) | (ci[:, 1] < 0)
    named = bool(delta_bic < BIC_THRESHOLD and gain > MIN_HELDOUT_GAIN and significant.any())
    final = baseline + fitted if named else baseline
    band = (float(knots[significant].min()), float(knots[significant].max())) if significant.any() else None
    return TableDiagnosis(speed, force, baseline, baseline + fitted, knots, coef, ci, delta_bic, gain, named,
                          _plateau(speed, baseline + fitted), band, runs_test_p(force - final))


def table_result(diag: TableDiagnosis, order: int, units: tuple[str, str]) -> dict[str, Any]:
    """The ``--json`` contract for a table (values in the table's units ``units`` = (speed, force))."""
    v_unit, f_unit = units
    rmse_base = float(np.sqrt(np.mean((diag.force - diag.baseline) ** 2)))
    rmse_ext = float(np.sqrt(np.mean((diag.force - diag.extended) ** 2)))
    parameters: dict[str, float | list[float]] = {
        f"change_at_{k:.2f}_{v_unit}_{f_unit}": float(c) for k, c in zip(diag.knots, diag.correction, strict=True)}
    ci95 = {f"change_at_{k:.2f}_{v_unit}_{f_unit}": [float(lo), float(hi)]
            for k, (lo, hi) in zip(diag.knots, diag.correction_ci95, strict=True)}
    if diag.plateau:
        parameters[f"plateau_{v_unit}"] = list(diag.plateau)
    if diag.band:
        parameters[f"band_{v_unit}"] = list(diag.band)
    candidate = {"effect": "resistance_shape", "parameters": parameters, "delta_bic": diag.delta_bic,
                 "heldout_gain": diag.cv_gain}
    verdict = [{"effect": "resistance_shape", "parameters": parameters, "ci95": ci95,
                "gain": {f"thrust_{f_unit}": diag.cv_gain}}] if diag.named else []
    return {
        "baseline": {"model_order": order, "rmse": {f"thrust_{f_unit}": rmse_base}},
        "extended": {"rmse": {f"thrust_{f_unit}": rmse_ext if diag.named else rmse_base}},
        "candidates": [candidate],
        "verdict": verdict,
        "unexplained": diag.unexplained,
        "residual_runs_p": diag.runs_p,
    }
