"""Effective surge mass m (hull plus added mass) and resistance Fc(v) jointly from transients.

Model: m·dv/dt = F − Fc(v), Fc(v) = Σ c_i·v^i (Dyda & Chumakova 2021). Method: modulating functions
(Shinbrot 1954) in discrete form. Over a window of samples t_0..t_K, each sampling interval k obeys
m·(v_{k+1} − v_k) = dt_k·F_k − dt_k·(Fc(v_k) + Fc(v_{k+1}))/2 (thrust held between samples, trapezoid
for Fc). Weighting interval k by a trapezoid ψ_k (0 at both window ends, rising to 1 over ``ramp_s``) and
summing gives one linear equation per window:

    m·Σ ψ_k·Δv_k + Σ_i a_i·Σ ψ_k·dt_k·(B_i(v_k) + B_i(v_{k+1}))/2 = Σ ψ_k·dt_k·F_k

Because ψ vanishes at both ends, Σ ψ_k·Δv_k = −Σ v_k·(ψ_k − ψ_{k−1}): speed enters only through averages
over the ramps, so GNSS noise is smoothed, never differentiated (noise variance of the mass regressor
2σ²·dt/ramp). B_i are Legendre polynomials on the speed domain (conditioning); results are reported in
the plain power basis. Windows end every ``stride_s``; with the default stride = length they do not overlap,
so window errors are independent and the ordinary least-squares covariance gives the uncertainty (it
counts the misfit of a polynomial Fc as if it were noise). Windows containing a sampling gap longer than
``max_gap_s`` are skipped. Identifiability: the mass is separable from the shape of Fc only over speeds the
boat crossed both accelerating and decelerating (at a given speed, m·(dv/dt_up − dv/dt_down) = F_up −
F_down whatever Fc is); :attr:`DynamicResult.two_way_fraction` reports that share. A staircase of steps up
only leaves the mass to the polynomial form of Fc.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import linalg, stats

from boat_twin.errors import InputError
from boat_twin.ident.steady import MAX_ORDER, choose_order, legendre_design, power_matrix, speed_domain


@dataclass(frozen=True)
class DynamicWindow:
    """Window settings shared by batch and online dynamic identification (seconds)."""

    length_s: float = 10.0
    """Window length, s: long enough to average noise, short next to the boat's slowest time constant."""
    ramp_s: float = 2.0
    """Rise and fall time of the trapezoid weight ψ, s: the speed is averaged over this at each end."""
    stride_s: float = 10.0
    """Time between window ends, s (= length: independent windows)."""
    max_gap_s: float = 1.0
    """A window with a sampling gap longer than this is skipped, s."""

    def __post_init__(self) -> None:
        if not all(np.isfinite(v) and v > 0.0 for v in asdict(self).values()):
            raise InputError(
                "dynamic window: length_s, ramp_s, stride_s and max_gap_s must be positive numbers"
            )
        if self.ramp_s > self.length_s / 2.0:
            raise InputError("dynamic window: ramp_s must not exceed half of length_s")


def window_row(
    t_s: np.ndarray,
    thrust_N: np.ndarray,
    speed_mps: np.ndarray,
    ramp_s: float,
    basis: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, float, float]:
    """One window's equation: regressors [Σψ·Δv, Σψ·dt·B_i(v̄)...], right side Σψ·dt·F, and Σψ·dt (s)."""
    mid = 0.5 * (t_s[1:] + t_s[:-1])
    psi = np.clip(np.minimum(mid - t_s[0], t_s[-1] - mid) / ramp_s, 0.0, 1.0)
    w = psi * np.diff(t_s)
    b = basis(speed_mps)
    row = np.empty(b.shape[1] + 1)
    row[0] = psi @ np.diff(speed_mps)
    row[1:] = w @ (0.5 * (b[1:] + b[:-1]))
    return row, float(w @ thrust_N[:-1]), float(w.sum())


def window_bounds(t_s: np.ndarray, window: DynamicWindow) -> tuple[list[tuple[int, int]], int]:
    """Sample ranges [start, stop) of the usable windows, and how many were skipped for gaps.

    A window ends at the first sample at or after the previous end + stride (the first at t_0 + length) and
    holds the samples no older than ``length_s`` (the same rule :class:`OnlineThrustSpeedIdentifier` follows).
    """
    bounds: list[tuple[int, int]] = []
    skipped = 0
    next_end = t_s[0] + window.length_s
    while True:
        k = int(np.searchsorted(t_s, next_end, side="left"))
        if k >= t_s.size:
            return bounds, skipped
        start = int(np.searchsorted(t_s, t_s[k] - window.length_s, side="left"))
        if k - start >= 2 and np.max(np.diff(t_s[start : k + 1])) <= window.max_gap_s:
            bounds.append((start, k + 1))
        else:
            skipped += 1
        next_end = t_s[k] + window.stride_s


def check_samples(t_s: Any, thrust_N: Any, speed_mps: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate a trial's sample arrays: 1-D, same length, finite, time strictly increasing."""
    try:
        arrays = [np.asarray(a, dtype=float) for a in (t_s, thrust_N, speed_mps)]
    except (TypeError, ValueError):
        raise InputError("samples: time, thrust and speed must be numbers") from None
    t, f, v = arrays
    if any(a.ndim != 1 for a in arrays) or not t.size == f.size == v.size:
        raise InputError(
            f"samples: time, thrust and speed must be 1-D of one length, got {t.size}, {f.size}, {v.size}"
        )
    if t.size < 3:
        raise InputError(f"samples: at least 3 samples are needed, got {t.size}")
    for name, a in (("time", t), ("thrust", f), ("speed", v)):
        bad = ~np.isfinite(a)
        if np.any(bad):
            raise InputError(
                f"samples: {int(bad.sum())} {name} value(s) are NaN or infinite "
                f"(first at index {int(np.argmax(bad))})"
            )
    if np.any(np.diff(t) <= 0.0):
        raise InputError(
            f"samples: time must increase strictly "
            f"(first violation at index {int(np.argmax(np.diff(t) <= 0)) + 1})"
        )
    return t, f, v


TWO_WAY_THRESHOLD_MPS = 0.05
"""A window counts as accelerating (decelerating) when its ramp-averaged speed rises (falls) by more, m/s."""


@dataclass(frozen=True)
class DynamicResult:
    """Mass and resistance identified jointly from transients (SI)."""

    mass_kg: float
    """Effective surge mass (hull + added mass), kg."""
    mass_stderr_kg: float
    """Standard error of the mass, kg."""
    mass_ci95_kg: tuple[float, float]
    """95 % interval of the mass (Student t), kg."""
    order: int
    """Order N of Fc."""
    coefficients: np.ndarray
    """c_0..c_N of Fc in N/(m/s)^i."""
    stderr: np.ndarray
    """Standard errors of c_0..c_N."""
    ci95: np.ndarray
    """95 % intervals of c_0..c_N, shape (N + 1, 2)."""
    rmse_N: float
    """RMS of the window residuals, each divided by its window's Σψ·dt: a mean force misfit, N."""
    cv_rmse_N: float
    """The same, leave-one-window-out (hat matrix), N."""
    bic: float
    """n·ln(SSE/n) + k·ln n over the windows."""
    selection_reason: str
    """How the order was chosen."""
    two_way_fraction: float
    """Share of the visited speed range crossed both accelerating and decelerating, 0..1. Only there is the
    mass separable from the shape of Fc; elsewhere it rests on Fc's polynomial form (docs/identification.md)."""
    n_windows: int
    """Windows used."""
    windows_skipped: int
    """Windows skipped for sampling gaps."""
    speed_domain_mps: tuple[float, float]
    """Speed domain of the Fc estimate, m/s."""
    window: DynamicWindow
    """Window settings used."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the ``dynamic`` entry of ``boat-twin identify --json``)."""
        return {
            "mass_kg": self.mass_kg,
            "mass_stderr_kg": self.mass_stderr_kg,
            "mass_ci95_kg": list(self.mass_ci95_kg),
            "order": self.order,
            "coefficients": self.coefficients.tolist(),
            "stderr": self.stderr.tolist(),
            "ci95": self.ci95.tolist(),
            "rmse_N": self.rmse_N,
            "cv_rmse_N": self.cv_rmse_N if np.isfinite(self.cv_rmse_N) else None,
            "bic": self.bic,
            "selection_reason": self.selection_reason,
            "two_way_fraction": self.two_way_fraction,
            "n_windows": self.n_windows,
            "windows_skipped": self.windows_skipped,
            "speed_domain_mps": list(self.speed_domain_mps),
            "window": asdict(self.window),
        }


def _two_way_fraction(spans: np.ndarray, change: np.ndarray, domain: tuple[float, float]) -> float:
    """Share of a grid over ``domain`` covered by accelerating and by decelerating windows' speed spans."""
    grid = np.linspace(domain[0], domain[1], 200)
    inside = (spans[:, :1] <= grid) & (grid <= spans[:, 1:])
    up = np.any(inside[change > TWO_WAY_THRESHOLD_MPS], axis=0)
    down = np.any(inside[change < -TWO_WAY_THRESHOLD_MPS], axis=0)
    return float(np.mean(up & down))


def _solve(x: np.ndarray, y: np.ndarray, weight: np.ndarray) -> dict[str, Any]:
    """Column-equilibrated QR least squares with covariance, LOO CV (force units) and BIC."""
    n, p = x.shape
    scale = np.max(np.abs(x), axis=0)
    scale[scale == 0.0] = 1.0
    q, r = np.linalg.qr(x / scale)
    diag = np.abs(np.diag(r))
    if diag[0] < 1e-9 * diag.max() or diag.min() < 1e-12 * diag.max():
        raise InputError(
            "dynamic identification: mass and resistance cannot be separated (no transients, or too few "
            "distinct speeds for the order); the trial needs thrust steps"
        )
    theta = linalg.solve_triangular(r, q.T @ y) / scale
    resid = y - x @ theta
    sse = float(resid @ resid)
    r_inv = linalg.solve_triangular(r, np.eye(p))
    cov = sse / (n - p) * (r_inv @ r_inv.T) / np.outer(scale, scale)
    leverage = np.sum(q * q, axis=1)
    with np.errstate(divide="ignore"):
        loo = resid / (1.0 - leverage) / weight
    return {
        "theta": theta,
        "cov": cov,
        "dof": n - p,
        "rmse": float(np.sqrt(np.mean((resid / weight) ** 2))),
        "cv": float(np.sqrt(np.mean(loo**2))) if np.all(leverage < 1.0 - 1e-10) else float("inf"),
        "bic": float(n * np.log(max(sse / n, np.finfo(float).tiny)) + p * np.log(n)),
    }


def identify_dynamic(
    t_s: Any,
    thrust_N: Any,
    speed_mps: Any,
    order: int | None = None,
    window: DynamicWindow | None = None,
    max_order: int = 8,
) -> DynamicResult:
    """Least-squares m and c_0..c_N from all windows of a trial; see the module docstring.

    ``order`` None selects N in 1..``max_order`` by leave-one-window-out CV and BIC, with the rule of
    :func:`~boat_twin.ident.steady.choose_order` (the windows hold far more data than the steady points,
    so the dynamic fit usually supports a higher order than the steady fit).
    """
    t, f, v = check_samples(t_s, thrust_N, speed_mps)
    window = window or DynamicWindow()
    for name, value in (("order", order), ("max_order", max_order)):
        if value is not None and (not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_ORDER):
            raise InputError(
                f"dynamic identification: {name} must be an integer from 1 to {MAX_ORDER}, got {value!r}"
            )
    domain = speed_domain(v)
    if domain[1] <= domain[0]:
        raise InputError("dynamic identification: the speed is zero throughout; nothing to identify")
    bounds, skipped = window_bounds(t, window)
    orders = [order] if order is not None else list(range(1, min(max_order, len(bounds) - 3) + 1))
    top = max(orders) if orders else 1
    if len(bounds) < top + 3:
        raise InputError(
            f"dynamic identification: {len(bounds)} window(s) of {window.length_s:g} s fit in the trial, "
            f"order {top} needs at least {top + 3} (mass + {top + 1} coefficients + 1)"
        )
    rows, rhs, weight, spans = [], [], [], []
    for start, stop in bounds:
        seg = v[start:stop]
        row, y, w = window_row(
            t[start:stop], f[start:stop], seg, window.ramp_s, lambda s: legendre_design(s, domain, top)
        )
        rows.append(row)
        rhs.append(y)
        weight.append(w)
        spans.append((seg.min(), seg.max()))
    x = np.asarray(rows)
    y_all = np.asarray(rhs)
    w_all = np.asarray(weight)
    if np.max(np.abs(x[:, 0])) <= 0.0:
        raise InputError(
            "dynamic identification: the speed never changes within a window; the mass is unidentifiable"
        )
    fits = {n: _solve(x[:, : n + 2], y_all, w_all) for n in orders}
    if order is None:
        chosen, reason = choose_order([(n, fits[n]["cv"], fits[n]["bic"]) for n in orders], "N")
    else:
        chosen, reason = order, f"N = {order}: given"
    best = fits[chosen]
    theta, cov = best["theta"], best["cov"]
    m = power_matrix(domain, chosen)
    coef = m @ theta[1:]
    se_c = np.sqrt(np.clip(np.diag(m @ cov[1:, 1:] @ m.T), 0.0, None))
    tq = float(stats.t.ppf(0.975, best["dof"]))
    se_m = float(np.sqrt(max(cov[0, 0], 0.0)))
    return DynamicResult(
        mass_kg=float(theta[0]),
        mass_stderr_kg=se_m,
        mass_ci95_kg=(float(theta[0] - tq * se_m), float(theta[0] + tq * se_m)),
        order=int(chosen),
        coefficients=coef,
        stderr=se_c,
        ci95=np.column_stack([coef - tq * se_c, coef + tq * se_c]),
        rmse_N=best["rmse"],
        cv_rmse_N=best["cv"],
        bic=best["bic"],
        selection_reason=reason,
        two_way_fraction=_two_way_fraction(np.asarray(spans), x[:, 0], (float(v.min()), domain[1])),
        n_windows=len(bounds),
        windows_skipped=skipped,
        speed_domain_mps=domain,
        window=window,
    )
