"""Batch least-squares fits of the steady resistance curve Fc(v) = Σ c_i·v^i (Dyda & Chumakova 2021, eq. 1).

Inside, every fit works in a Legendre basis on the speed domain [min(0, v_min), v_max] mapped to [-1, 1]
and solves by QR (never the normal equations), so an order-8 fit on 10^5 points is as well conditioned as a
straight line; coefficients, standard errors and intervals are then reported in the plain power basis
through the exact linear map between the two bases. Units are the caller's: speed in any unit ``U``,
force in any unit ``F`` give c_i in F/U^i (SI callers get N/(m/s)^i).

Statistics assume independent errors of equal variance: σ² = SSE/(n − k) with k free parameters,
AIC = n·ln(SSE/n) + 2k, BIC = n·ln(SSE/n) + k·ln n (Gaussian likelihood, constants dropped), leave-one-out
CV RMSE = RMS of e_j/(1 − h_jj) from the hat matrix (exact for linear least squares, no refits).

Monotone option: Fc must not decrease from rest to the highest fitted speed and must not be negative at rest,
so every thrust above Fc(0) has exactly one steady speed. The constraints dFc/dv ≥ 0 on a 2001-point grid
over [min(0, v_min), v_max] and Fc(0) ≥ 0 make a least-squares problem with linear inequalities, solved
exactly by the Lawson & Hanson (1974, ch. 23) reduction to a least-distance problem and NNLS. Statistics
of a constrained fit are those of the equality-constrained problem on its active set (the constraints that
hold with equality): exact for that active set, which is the usual convention.

Extrapolation: a fit describes Fc on its speed domain only. :meth:`FitResult.resistance_model` hands the
simulator a :class:`~boat_twin.vessel.resistance.PowerSeriesResistance`, which continues beyond v_max with
the planing-hull law Fc(v_max)·(v/v_max)², never with the raw polynomial.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.polynomial import legendre, polynomial
from scipy import linalg, optimize, stats

from boat_twin.errors import InputError
from boat_twin.vessel.resistance import PowerSeriesResistance

MAX_ORDER = 12
"""Highest order accepted: beyond it, power-basis coefficients mean nothing (they cancel to many digits)."""

GRID = 2001
"""Evenly spaced speeds over a fit's domain on which dFc/dv ≥ 0 is imposed (monotone option) and checked."""


def speed_domain(speed: np.ndarray) -> tuple[float, float]:
    """Domain of a fit: from rest (or the lowest speed, if negative) to the highest speed; input units."""
    lo = min(0.0, float(np.min(speed)))
    hi = float(np.max(speed))
    return lo, hi


def legendre_design(speed: np.ndarray, domain: tuple[float, float], order: int) -> np.ndarray:
    """Design matrix of Legendre polynomials P_0..P_order of the speed mapped from ``domain`` to [-1, 1]."""
    lo, hi = domain
    return legendre.legvander((2.0 * np.asarray(speed, dtype=float) - (hi + lo)) / (hi - lo), order)


def power_matrix(domain: tuple[float, float], order: int) -> np.ndarray:
    """Matrix M with c = M·a: Legendre coefficients a on ``domain`` to plain power-basis coefficients c."""
    p = order + 1
    m = np.zeros((p, p))
    for k in range(p):
        coef = legendre.Legendre.basis(k, domain=list(domain)).convert(kind=polynomial.Polynomial).coef
        m[: coef.size, k] = coef
    return m


def _derivative_design(grid: np.ndarray, domain: tuple[float, float], order: int) -> np.ndarray:
    """Rows: d/dv of every basis function at ``grid`` (up to the positive factor 2/(hi − lo))."""
    lo, hi = domain
    x = (2.0 * grid - (hi + lo)) / (hi - lo)
    cols = [legendre.legval(x, legendre.legder(np.eye(order + 1)[k])) for k in range(order + 1)]
    return np.column_stack(cols)


def _bands(grid: np.ndarray, bad: np.ndarray) -> tuple[tuple[float, float], ...]:
    """Contiguous runs of ``bad`` on ``grid`` as (first, last) grid values."""
    if not np.any(bad):
        return ()
    edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(np.int8), 0]))
    return tuple((float(grid[s]), float(grid[e - 1])) for s, e in zip(edges[::2], edges[1::2], strict=True))


def nonmonotone_bands(
    coefficients: np.ndarray, domain: tuple[float, float]
) -> tuple[tuple[float, float], ...]:
    """Speed bands inside ``domain`` where the power series ``coefficients`` decreases (dFc/dv < 0)."""
    grid = np.linspace(domain[0], domain[1], GRID)
    slope = polynomial.polyval(grid, polynomial.polyder(np.asarray(coefficients, dtype=float)))
    scale = np.max(np.abs(slope)) if slope.size else 0.0
    return _bands(grid, slope < -1e-9 * scale)


@dataclass(frozen=True)
class FitResult:
    """One least-squares fit of Fc(v) = Σ c_i·v^i; units follow the data (c_i in force/speed^i)."""

    order: int
    """Highest power N."""
    coefficients: np.ndarray
    """c_0..c_N, plain power basis."""
    stderr: np.ndarray
    """Standard errors of c_0..c_N."""
    ci95: np.ndarray
    """95 % intervals of c_0..c_N (Student t with the residual degrees of freedom), shape (N + 1, 2)."""
    covariance: np.ndarray = field(repr=False)
    """Covariance of c_0..c_N."""
    sse: float
    """Sum of squared residuals, force²."""
    rmse: float
    """sqrt(SSE/n), force."""
    r2: float
    """Coefficient of determination."""
    aic: float
    """n·ln(SSE/n) + 2k."""
    bic: float
    """n·ln(SSE/n) + k·ln n."""
    cv_rmse: float
    """Leave-one-out cross-validation RMSE, force (inf when a point has leverage 1)."""
    monotone_constraint: bool
    """True when the fit was constrained to be monotone (see the module docstring)."""
    through_origin: bool
    """True when Fc(0) = c_0 = 0 was imposed."""
    active_constraints: int
    """Monotone constraints holding with equality (0 for an unconstrained fit)."""
    nonmonotone_bands: tuple[tuple[float, float], ...]
    """Speed bands in ``domain`` where the fitted Fc decreases; empty when monotone."""
    domain: tuple[float, float]
    """Speed domain of the fit: [min(0, v_min), v_max]."""
    n_points: int
    """Number of (speed, force) points."""
    dof: int
    """Residual degrees of freedom n − k."""

    @property
    def monotone(self) -> bool:
        """Fc does not decrease anywhere on the fit's domain."""
        return not self.nonmonotone_bands

    def predict(self, speed: np.ndarray | float) -> np.ndarray:
        """The fitted polynomial at ``speed`` (no extrapolation rule: :meth:`resistance_model` has one)."""
        return polynomial.polyval(np.asarray(speed, dtype=float), self.coefficients)

    def resistance_model(self) -> PowerSeriesResistance:
        """The fit as a simulator model: valid up to v_max, quadratic law beyond (data must be SI)."""
        return PowerSeriesResistance(tuple(float(c) for c in self.coefficients), self.domain[1])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the ``fits`` entries of ``boat-twin identify --json``)."""
        return {
            "order": self.order,
            "coefficients": self.coefficients.tolist(),
            "stderr": self.stderr.tolist(),
            "ci95": self.ci95.tolist(),
            "sse": self.sse,
            "rmse": self.rmse,
            "r2": self.r2 if np.isfinite(self.r2) else None,
            "aic": self.aic,
            "bic": self.bic,
            "cv_rmse": self.cv_rmse if np.isfinite(self.cv_rmse) else None,
            "monotone": self.monotone,
            "monotone_constraint": self.monotone_constraint,
            "through_origin": self.through_origin,
            "active_constraints": self.active_constraints,
            "nonmonotone_bands": [list(b) for b in self.nonmonotone_bands],
            "domain": list(self.domain),
            "n_points": self.n_points,
        }


def check_points(speed: Any, force: Any, what: str = "steady points") -> tuple[np.ndarray, np.ndarray]:
    """Validate paired 1-D arrays of speed and force: same length, finite numbers."""
    try:
        v = np.asarray(speed, dtype=float)
        f = np.asarray(force, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what}: speed and force must be numbers") from None
    if v.ndim != 1 or f.ndim != 1 or v.size != f.size:
        raise InputError(f"{what}: speed and force must be 1-D arrays of the same length")
    bad = ~(np.isfinite(v) & np.isfinite(f))
    if np.any(bad):
        raise InputError(
            f"{what}: {int(bad.sum())} point(s) are NaN or infinite (first at index {int(np.argmax(bad))})"
        )
    return v, f


def _check_order(order: int, v: np.ndarray, what: str) -> None:
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or not 0 <= order <= MAX_ORDER:
        raise InputError(f"{what}: order must be an integer from 0 to {MAX_ORDER}, got {order!r}")
    if v.size < order + 2:
        raise InputError(
            f"{what}: order {order} needs at least {order + 2} points (N + 1 coefficients and one degree of "
            f"freedom for the error), got {v.size}"
        )
    distinct = np.unique(v).size
    if distinct < order + 1:
        raise InputError(f"{what}: order {order} needs at least {order + 1} distinct speeds, got {distinct}")


def _solve_monotone(r: np.ndarray, b: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Rows of ``g`` active at min ||R·a − b|| s.t. g·a ≥ 0 (LSI → LDP → NNLS, Lawson & Hanson ch. 23)."""
    gz = linalg.solve_triangular(r, g.T, trans="T").T  # constraints on z = R·a: (g·R⁻¹)·z ≥ 0
    h = -gz @ b  # with w = z − b: gz·w ≥ h; least-distance problem min ||w||
    e = np.vstack([gz.T, h[None, :]])
    target = np.zeros(e.shape[0])
    target[-1] = 1.0
    u, _ = optimize.nnls(e, target, maxiter=50 * e.shape[1])
    return np.flatnonzero(u > 0.0)


def fit_power_series(
    speed: Any, force: Any, order: int, monotone: bool = False, through_origin: bool = False
) -> FitResult:
    """Least-squares fit of order ``order`` to (speed, force) points; see the module docstring for the method.

    ``through_origin`` imposes Fc(0) = c_0 = 0 (no resistance at rest): use it when the points start well
    above rest, where a free c_0 is an extrapolation. ``monotone`` adds the monotone constraints.
    """
    v, f = check_points(speed, force)
    _check_order(order, v, "fit")
    domain = speed_domain(v)
    if domain[1] <= domain[0]:
        raise InputError("fit: all speeds are zero; the resistance curve is unidentifiable")
    x = legendre_design(v, domain, order)
    p = order + 1
    at_rest = legendre_design(np.zeros(1), domain, order)  # c_0 = Fc(0) as a function of the coefficients
    # columns of `basis` span the parameters allowed by the equality and the active inequality constraints
    basis = linalg.null_space(at_rest) if through_origin else np.eye(p)
    active = 0
    if monotone and order >= 1:
        grid = np.linspace(domain[0], domain[1], GRID)
        g = _derivative_design(grid, domain, order)
        if not through_origin:
            g = np.vstack([g, at_rest])
        g = g @ basis
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        q0, r0 = np.linalg.qr(x @ basis)
        rows = _solve_monotone(r0, q0.T @ f, g)
        if rows.size:
            sub = linalg.null_space(g[rows])
            active = basis.shape[1] - sub.shape[1]
            basis = basis @ sub
    q, r = np.linalg.qr(x @ basis)
    beta = linalg.solve_triangular(r, q.T @ f)
    a = basis @ beta
    resid = f - x @ a
    k = basis.shape[1]
    n = v.size
    dof = n - k
    sse = float(resid @ resid)
    sigma2 = sse / dof
    r_inv = linalg.solve_triangular(r, np.eye(k))
    cov_a = basis @ (sigma2 * (r_inv @ r_inv.T)) @ basis.T
    m = power_matrix(domain, order)
    coef = m @ a
    cov = m @ cov_a @ m.T
    if through_origin:  # exactly, not to rounding
        coef[0] = 0.0
        cov[0, :] = cov[:, 0] = 0.0
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    half = stats.t.ppf(0.975, dof) * se
    leverage = np.sum(q * q, axis=1)
    with np.errstate(divide="ignore"):
        loo = resid / (1.0 - leverage)
    cv = float(np.sqrt(np.mean(loo**2))) if np.all(leverage < 1.0 - 1e-10) else float("inf")
    sst = float(np.sum((f - f.mean()) ** 2))
    log_term = n * np.log(max(sse / n, np.finfo(float).tiny))
    return FitResult(
        order=order,
        coefficients=coef,
        stderr=se,
        ci95=np.column_stack([coef - half, coef + half]),
        covariance=cov,
        sse=sse,
        rmse=float(np.sqrt(sse / n)),
        r2=1.0 - sse / sst if sst > 0.0 else float("nan"),
        aic=float(log_term + 2 * k),
        bic=float(log_term + k * np.log(n)),
        cv_rmse=cv,
        monotone_constraint=monotone,
        through_origin=through_origin,
        active_constraints=active,
        nonmonotone_bands=nonmonotone_bands(coef, domain),
        domain=domain,
        n_points=n,
        dof=dof,
    )


@dataclass(frozen=True)
class OrderSelection:
    """Fits of several orders and the chosen one, with the reason in words."""

    fits: tuple[FitResult, ...]
    selected_order: int
    reason: str

    @property
    def selected(self) -> FitResult:
        """The fit of the selected order."""
        return next(f for f in self.fits if f.order == self.selected_order)


def select_order(
    speed: Any,
    force: Any,
    max_order: int = 8,
    monotone: bool = False,
    force_unit: str = "N",
    through_origin: bool = False,
) -> OrderSelection:
    """Fit orders 1..``max_order`` (as far as the points allow) and select one.

    The rule is :func:`choose_order` (CV screens out over-fitting orders, BIC chooses among the rest).
    """
    v, f = check_points(speed, force)
    top = min(int(max_order), v.size - 2, np.unique(v).size - 1, MAX_ORDER)
    if top < 1:
        raise InputError(
            f"order selection: at least 3 points at 2 distinct speeds are needed, got {v.size} point(s) "
            f"at {np.unique(v).size} speed(s)"
        )
    fits = tuple(fit_power_series(v, f, n, monotone, through_origin) for n in range(1, top + 1))
    chosen, reason = choose_order([(fr.order, fr.cv_rmse, fr.bic) for fr in fits], force_unit)
    return OrderSelection(fits=fits, selected_order=chosen, reason=reason)


CV_FACTOR = 2.0
"""Orders whose leave-one-out CV RMSE exceeds this multiple of the best are not candidates."""

BIC_MARGIN = 2.0
"""BIC differences below this are 'not worth more than a bare mention' (Kass & Raftery 1995)."""


def choose_order(candidates: Sequence[tuple[int, float, float]], force_unit: str = "N") -> tuple[int, str]:
    """The selection rule on (order, CV RMSE, BIC) triples; returns the order and the reason in words.

    Orders whose leave-one-out CV RMSE is more than :data:`CV_FACTOR` times the best are dropped (they
    over-fit: the curve swings between the points); of the rest, the lowest order whose BIC is within
    :data:`BIC_MARGIN` of the lowest BIC is taken (parsimony). ``force_unit`` labels the CV RMSE.
    """
    best_cv = min(candidates, key=lambda c: c[1])
    kept = [c for c in candidates if c[1] <= CV_FACTOR * best_cv[1]]
    best_bic = min(kept, key=lambda c: c[2])
    chosen = min(c for c in kept if c[2] <= best_bic[2] + BIC_MARGIN)
    span = f"N = {min(c[0] for c in candidates)}..{max(c[0] for c in candidates)}"
    dropped = sorted(c[0] for c in candidates if c not in kept)
    text = (
        f"N = {chosen[0]} among {span}: BIC {chosen[2]:.2f}"
        + (
            " is the lowest"
            if chosen is best_bic
            else f" within {BIC_MARGIN:g} of the lowest ({best_bic[2]:.2f} at "
            f"N = {best_bic[0]}), so the lower order is kept"
        )
        + f"; leave-one-out CV RMSE {chosen[1]:.3g} {force_unit} (best {best_cv[1]:.3g} at N = {best_cv[0]})"
    )
    if dropped:
        text += f"; N = {', '.join(map(str, dropped))} dropped: CV RMSE above {CV_FACTOR:g}x the best"
    return chosen[0], text
