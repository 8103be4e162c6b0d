"""Output-error identification of the surge model over whole recordings, physical by construction.

    m·du/dt = T(t) − Fc(u),   Fc(u) = sign(u)·[a·|u| + b·u² + Σ_k w_k·I_k(|u|)],   a, b, w_k ≥ 0

m: the effective surge mass (hull plus added mass), kg; T: the surge thrust Σ T_i·cos δ_i held from one sample to
the next, N; a·|u| + b·u²: the simplest physical model (Fossen 2011, §6.4); I_k: quadratic I-splines (Ramsay 1988)
knotted at quantiles of the measured speeds, so Fc(0) = 0 and Fc never decreases (one steady speed per thrust;
astern the mirrored curve). The measured speed over ground is the Rice mean of a noisy velocity (:func:`rice_mean`).
A record may carry a further force C (the live twin's sway-yaw coupling) whose scale c is fitted, free or under a
prior N(1, σ_c²). Fit: every sample simulated (RK4, numba, the Jacobian from forward sensitivities), bounded least
squares over (w, m, c, each segment's initial speed). Complexity: the baseline (a, b), 3, 5, 8, 12 I-splines
and 12 with knots half spread evenly (:data:`KNOT_UNIFORM_SHARE`) compared by cross-validated multi-step
prediction. Uncertainty: the cluster-robust delete-one-block jackknife (CR3) over blocks of five
residual-correlation times with Student-t intervals, plus the spread to the next richer basis.
Each choice and why, with the measurements: docs/identification.md, "The model: output error over every sample".
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Any

import numba
import numpy as np
from scipy import fft, optimize, special, stats
from scipy.interpolate import BSpline
from threadpoolctl import threadpool_limits

from boat_twin.errors import InputError
from boat_twin.folded_lsq import TriangleFold, folded_least_squares
from boat_twin.ident.jackknife import jackknife_shift, jackknife_spread
from boat_twin.signal_noise import white_noise_stdev
from boat_twin.vessel.resistance import TableResistance

SPLINE_SIZES = (3, 5, 8, 12)
"""I-spline terms tried beside the baseline (complexity chosen by cross-validation)."""
CV_BLOCKS = 8
"""Consecutive time blocks a recording is split into for cross-validation when there are fewer than three."""
CV_COST_TOLERANCE = 1e-6
"""The folds' fits stop where the cost changes by less than this share (scipy's ftol; the final fits' 1e-8): a
held-out error needs no more (the candidates' held-out errors move by < 0.1 %, a twentieth of
:data:`CV_TOLERANCE`)."""
CV_TOLERANCE = 0.01
"""A smaller model within this share of the best held-out mean squared error is preferred, -."""
MAX_STEP_S = 0.1
"""Longest RK4 step inside a sample interval, s: one step per 10 Hz sample. RK4's relative error per step is
about (h/τ)⁵/120: below 4e-5 at the shortest surge time constant the mass scan tries (0.3 s), 3e-9 at a
small boat's 2 s (half the step moved the shipped sample's fit by < 2e-5 of each coefficient)."""
GRID_POINTS = 1201
"""Uniform speed grid (0 to twice the top speed) on which the basis is tabulated for the compiled simulation."""
MAX_GAP_S = 1.0
"""A sampling gap longer than this starts a new segment (its own initial speed), s."""
MIN_SEGMENT_SAMPLES = 20
"""Segments shorter than this are left out of the fit."""
FOLD_ROWS = 8192
"""Samples simulated with their sensitivities and folded into the solver's triangle at a time
(:meth:`_Problem.segment_rows`): about 1 MB of sensitivities, whatever the recording's length."""
MIN_CLUSTER_S = 10.0
"""Shortest block of the cluster-robust covariance, s."""
MASS_RELATIVE_LIMIT = 0.5
"""A 95 % mass interval wider than ± this share of the estimate: the mass is not identified by the data, -."""
EVEN_KNOT_SIZES = (12,)
"""I-spline terms tried last, with knots spread evenly in part (:data:`KNOT_UNIFORM_SHARE`)."""
KNOT_UNIFORM_SHARE = 0.5
"""Share of a uniform distribution over [0, top speed] in the distribution whose quantiles place the I-splines'
knots (:func:`spline_basis`): at least this share of the knots spread evenly over the speeds, so that a range the
boat crosses only in transients (a skid-steer catamaran's random trial: 10 % of its samples below 3.9 m/s of
6.5, where its resistance has its plateau) is not left to one I-spline, -."""
TABLE_POINTS = 41
"""Points of the table the fitted curve is written as (monotone cubic through them: TableResistance)."""


@dataclass(frozen=True)
class SurgeRecord:
    """One recording's known samples: time s, surge thrust N (Σ T_i·cos δ_i), measured speed over ground m/s."""

    t_s: np.ndarray
    thrust_N: np.ndarray
    speed_mps: np.ndarray
    coupling_N: np.ndarray | None = None
    """A further surge force the caller computes from a model of its own, held like the thrust, whose scale c the
    fit estimates beside the mass and the curve (T + c·coupling): the live twin's sway-yaw coupling m₂₂·v·r,
    from its sway model and state (N; None: no such force)."""


def held_thrust_N(t_s: np.ndarray, mean_thrust_N: np.ndarray, grid_s: np.ndarray) -> np.ndarray:
    """The thrust a record on the times ``grid_s`` (increasing) holds over each of its intervals, from a thrust
    known as its mean over each interval between the increasing stamps ``t_s``: ``mean_thrust_N[k]`` over
    (t_{k−1}, t_k] (``[0]``, over the interval before the first stamp, is not used). The fit holds each sample's
    thrust over the interval to the next sample (:func:`_simulate`: a zero-order hold on the record's own
    grid), so a thrust that varies inside an interval (outboards swinging, a coupling force) must be given as
    its mean over that interval: a value read at the interval's start lags it by half an interval, which the fit
    reads as inertia. Each grid interval gets the mean of the stamps' means it overlaps, weighted by the
    overlap (exact wherever the grid is the stamps shifted by a whole number of periods; no lookup that a
    rounding error moves to the neighbouring sample); grid times outside [t_0, t_−1] take the end values. The
    last grid sample, whose interval the fit never integrates, holds the last mean, N."""
    t_s, grid_s = np.asarray(t_s, dtype=float), np.asarray(grid_s, dtype=float)
    mean = np.asarray(mean_thrust_N, dtype=float)
    impulse = np.concatenate([[0.0], np.cumsum(mean[1:] * np.diff(t_s))])
    at = np.interp(grid_s, t_s, impulse)
    out = np.full(grid_s.size, mean[-1] if mean.size else np.nan)
    out[:-1] = np.diff(at) / np.diff(grid_s)
    return out


def horizon_record(t_s: np.ndarray, force_N: np.ndarray, speed_mps: np.ndarray, latency_s: float,
                   coupling_N: np.ndarray | None = None) -> SurgeRecord:
    """A record as the output-error fit reads it (the live twin's horizon, an offline trial's): each speed at the
    time it describes (stamp − latency), the thrust over each interval between those times from ``force_N``, each
    sample's mean since the previous one (:func:`held_thrust_N`), and the coupling force (whose scale the fit
    estimates; None or all zero: none) over each interval as the mean of ``coupling_N``, measured at the times
    the samples describe, at its two ends. Samples describing a time before the first stamp (whose force is not
    known) are left out."""
    at = t_s - latency_s
    keep = at >= t_s[0] - 1e-9
    coupling = None
    if coupling_N is not None and np.any(coupling_N):
        point = np.asarray(coupling_N, dtype=float)[keep]
        coupling = np.append(0.5 * (point[:-1] + point[1:]), point[-1:])
    return SurgeRecord(at[keep], held_thrust_N(t_s, force_N, at[keep]), np.abs(speed_mps[keep]), coupling)


@dataclass(frozen=True)
class Segment:
    """A stretch of samples without a gap: the unit simulated from one initial speed."""

    record: int
    start: int
    stop: int


@dataclass(frozen=True)
class ResistanceBasis:
    """The terms of Fc: a·|u|, b·u², then ``len(knots) − 3`` quadratic I-splines on the clamped knot vector."""

    knots_mps: tuple[float, ...] = ()
    """Clamped knot vector of the I-splines' B-spline derivatives (degree 2), m/s; empty: the baseline."""
    uniform_share: float = 0.0
    """Share of the uniform distribution in the one whose quantiles placed the knots (:func:`spline_basis`; 0: the
    measured speeds' quantiles), -."""

    @property
    def size(self) -> int:
        """Number of terms (coefficients), -."""
        return 2 + max(len(self.knots_mps) - 3, 0)

    @property
    def name(self) -> str:
        """``baseline``, ``spline-K`` (K I-spline terms) or ``spline-K-even`` (knots spread evenly in part:
        :attr:`uniform_share`)."""
        return "baseline" if self.size == 2 else f"spline-{self.size - 2}" + ("-even" if self.uniform_share else "")

    def design(self, speed_mps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Terms and their speed derivatives at |u|, shapes (n, size): φ_j(|u|) in N per unit coefficient."""
        a = np.abs(np.asarray(speed_mps, dtype=float))
        values, slopes = [a, a**2], [np.ones_like(a), 2.0 * a]
        knots = np.asarray(self.knots_mps)
        for k in range(self.size - 2):
            element = BSpline(knots, np.eye(self.size - 2)[k], 2, extrapolate=False)
            integral = element.antiderivative()
            top = float(integral(knots[-1]))
            values.append(np.where(a >= knots[-1], top, np.nan_to_num(integral(np.minimum(a, knots[-1])))))
            slopes.append(np.nan_to_num(element(a)))
        return np.column_stack(values), np.column_stack(slopes)


def spline_basis(speeds_mps: np.ndarray, terms: int, uniform_share: float = 0.0) -> ResistanceBasis:
    """``terms`` I-splines with interior knots at quantiles of ``speeds_mps`` over [0, max |speed|]; with
    ``uniform_share`` w > 0, at quantiles of the mixture (1 − w)·(the speeds' distribution) + w·U(0, max |speed|)
    (:data:`KNOT_UNIFORM_SHARE`: what :func:`identify_surge` takes), so that speeds the boat only crosses keep
    knots of their own."""
    top = float(np.max(np.abs(speeds_mps)))
    levels = np.linspace(0.0, 1.0, terms - 1)[1:-1]
    if terms <= 3:
        inner = np.array([])
    elif uniform_share > 0.0 and top > 0.0:
        data = np.sort(np.abs(np.asarray(speeds_mps, dtype=float)))
        at = np.union1d(data, np.linspace(0.0, top, 1001))
        cdf = (1.0 - uniform_share) * np.searchsorted(data, at, side="right") / data.size + uniform_share * at / top
        inner = np.interp(levels, cdf, at)
    else:
        inner = np.quantile(np.abs(speeds_mps), levels)
    inner = np.unique(np.clip(inner, 0.02 * top, 0.98 * top))
    knots = np.concatenate([[0.0] * 3, inner, [top] * 3])
    return ResistanceBasis(tuple(float(k) for k in knots), uniform_share if terms > 3 else 0.0)


@numba.njit(cache=True)
def _interp_row(table: np.ndarray, step: float, speed: float, out: np.ndarray) -> None:
    """Linear interpolation of every column of ``table`` (uniform speed grid) at |speed|, into ``out``."""
    a = abs(speed) / step
    i = min(int(a), table.shape[0] - 2)
    frac = a - i
    for j in range(table.shape[1]):
        out[j] = table[i, j] + frac * (table[i + 1, j] - table[i, j])


@numba.njit(cache=True)
def _derivative(state: np.ndarray, thrust: float, coupling: float, coupled: bool, mass: float, coeffs: np.ndarray,
                table: np.ndarray, step: float, row: np.ndarray, out: np.ndarray) -> None:
    """d/dt of [u, ∂u/∂w_j..., ∂u/∂m, (∂u/∂c,) ∂u/∂u0] for m·du/dt = T − Fc(u), ``thrust`` T = the thrust plus
    c·``coupling`` (∂u/∂c only when ``coupled``; of u alone when ``state`` holds u only)."""
    u = state[0]
    _interp_row(table, step, u, row)
    p = coeffs.shape[0]
    sign = 1.0 if u >= 0.0 else -1.0
    force = 0.0
    slope = 0.0
    for j in range(p):
        force += coeffs[j] * row[j]
        slope += coeffs[j] * row[p + j]
    force *= sign
    out[0] = (thrust - force) / mass
    if state.shape[0] == 1:
        return
    for j in range(p):
        out[1 + j] = (-sign * row[j] - slope * state[1 + j]) / mass
    out[1 + p] = -(thrust - force) / mass**2 - slope * state[1 + p] / mass
    if coupled:
        out[2 + p] = (coupling - slope * state[2 + p]) / mass
    last = state.shape[0] - 1
    out[last] = -slope * state[last] / mass


@numba.njit(cache=True)
def _simulate(t_s: np.ndarray, thrust: np.ndarray, coupling: np.ndarray, scale: float, coupled: bool,
              start: np.ndarray, mass: float, coeffs: np.ndarray, table: np.ndarray, step: float,
              max_step: float) -> np.ndarray:
    """The state at every sample from ``start`` at ``t_s[0]`` under the held thrust + ``scale``·``coupling``: with
    sensitivities (``start`` of p + 3 + coupled) [u, ∂u/∂w_j..., ∂u/∂m, (∂u/∂c,) ∂u/∂u0], else (``start`` of 1)
    the speed alone, the same values (its RK4 stages do not depend on the rest); shape (n, start's size). A run
    continued from its last row is the whole run, bit for bit."""
    n = t_s.shape[0]
    width = start.shape[0]
    out = np.empty((n, width))
    state = start.copy()
    row = np.empty(2 * coeffs.shape[0])
    k1, k2, k3, k4, tmp = np.empty(width), np.empty(width), np.empty(width), np.empty(width), np.empty(width)
    out[0] = state
    for i in range(n - 1):
        interval = t_s[i + 1] - t_s[i]
        sub = max(1, int(np.ceil(interval / max_step - 1e-9)))
        h = interval / sub
        force = thrust[i] + scale * coupling[i]
        for _ in range(sub):  # RK4, element by element: no temporary arrays in the hot loop
            _derivative(state, force, coupling[i], coupled, mass, coeffs, table, step, row, k1)
            for j in range(width):
                tmp[j] = state[j] + 0.5 * h * k1[j]
            _derivative(tmp, force, coupling[i], coupled, mass, coeffs, table, step, row, k2)
            for j in range(width):
                tmp[j] = state[j] + 0.5 * h * k2[j]
            _derivative(tmp, force, coupling[i], coupled, mass, coeffs, table, step, row, k3)
            for j in range(width):
                tmp[j] = state[j] + h * k3[j]
            _derivative(tmp, force, coupling[i], coupled, mass, coeffs, table, step, row, k4)
            for j in range(width):
                state[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        out[i + 1] = state
    return out


@dataclass(frozen=True, kw_only=True)
class SurgeFit:
    """One output-error fit (SI): coefficients, effective mass, covariance and what the fit left."""

    basis: ResistanceBasis
    coefficients: np.ndarray
    """a (N·s/m), b (N·s²/m²), then the I-spline weights (N), each ≥ 0."""
    mass_kg: float
    """Effective surge mass m (hull plus added mass), kg."""
    mass_fixed: bool
    """True when the mass was given, not fitted."""
    initial_speeds_mps: np.ndarray
    """Each segment's fitted initial speed (nuisance), m/s."""
    residual_mps: np.ndarray
    """Simulated minus measured speed at every fitted sample, m/s."""
    covariance: np.ndarray
    """Cluster-robust covariance of [coefficients, mass] (zero rows/columns for parameters held at a bound)."""
    clusters: int
    """Blocks of the cluster-robust covariance, -."""
    cluster_s: float
    """Their length, s."""
    top_speed_mps: float
    """Highest measured speed the fit saw, m/s (the curve is data up to here)."""
    evaluations: int = 0
    coupling_fitted: bool = False
    """True when the records carried a coupling force and its scale c was fitted."""
    coupling_scale: float = 1.0
    """The fitted scale c of the records' coupling force (1: none fitted), -."""
    coupling_scale_sd: float = 0.0
    """Its cluster-robust standard deviation, -."""
    coupling_prior_sd: float = 0.0
    """Standard deviation of the Gaussian prior N(1, σ²) the fit put on c (0: none; :func:`fit_surge`), -."""
    reference: SurgeFit | None = None
    """The next richer resistance basis fitted to the same data: the spread between the two is the basis'
    approximation error, which the intervals carry beside the sampling variance (None: sampling variance only)."""

    @property
    def rmse_mps(self) -> float:
        """RMS of the fit's residuals, m/s."""
        return float(np.sqrt(np.mean(self.residual_mps**2)))

    def t_quantile(self) -> float:
        """Student-t 97.5 % quantile on clusters − 1 degrees of freedom."""
        return float(stats.t.ppf(0.975, max(self.clusters - 1, 1)))

    @property
    def mass_ci95_kg(self) -> tuple[float, float]:
        """95 % interval of the effective mass, kg (a point when the mass was given): the sampling variance plus
        the squared spread to the :attr:`reference` fit."""
        spread = 0.0 if self.reference is None or self.mass_fixed else self.mass_kg - self.reference.mass_kg
        half = self.t_quantile() * float(np.sqrt(max(self.covariance[-1, -1], 0.0) + spread**2))
        return self.mass_kg - half, self.mass_kg + half

    def resistance_N(self, speed_mps: np.ndarray) -> np.ndarray:
        """Fc(u), N."""
        values, _ = self.basis.design(speed_mps)
        return np.sign(speed_mps) * (values @ self.coefficients)

    def resistance_ci95_N(self, speed_mps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise 95 % interval of Fc(u), N: the coefficients' covariance (delta method) plus the squared
        spread to the :attr:`reference` fit."""
        values, _ = self.basis.design(speed_mps)
        p = self.coefficients.size
        variance = np.maximum(np.einsum("ij,jk,ik->i", values, self.covariance[:p, :p], values), 0.0)
        centre = values @ self.coefficients
        if self.reference is not None:
            variance = variance + (centre - self.reference.resistance_N(np.abs(speed_mps))) ** 2
        sd = np.sqrt(variance)
        return centre - self.t_quantile() * sd, centre + self.t_quantile() * sd

    def resistance_model(self) -> TableResistance:
        """The fitted curve as a monotone table from 0 to the top measured speed (quadratic law beyond)."""
        speeds = np.linspace(0.0, self.top_speed_mps, TABLE_POINTS)
        forces = np.maximum.accumulate(self.resistance_N(speeds))
        forces[0] = 0.0
        return TableResistance(tuple(float(u) for u in speeds), tuple(float(f) for f in forces))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (SI)."""
        speeds = np.linspace(0.0, self.top_speed_mps, 11)
        lo, hi = self.resistance_ci95_N(speeds)
        return {
            "model": self.basis.name,
            "terms": self.basis.size,
            "coefficients": self.coefficients.tolist(),
            "coefficient_units": ["N·s/m", "N·s²/m²"] + ["N"] * (self.basis.size - 2),
            "knots_mps": list(self.basis.knots_mps),
            "mass_kg": self.mass_kg,
            "mass_ci95_kg": list(self.mass_ci95_kg),
            "mass_fixed": self.mass_fixed,
            "rmse_mps": self.rmse_mps,
            "clusters": self.clusters,
            "cluster_s": self.cluster_s,
            "top_speed_mps": self.top_speed_mps,
            "interval_reference": None if self.reference is None else self.reference.basis.name,
            "resistance_table": {"speed_mps": speeds.tolist(), "force_N": self.resistance_N(speeds).tolist(),
                                 "ci95_low_N": lo.tolist(), "ci95_high_N": hi.tolist()},
        } | ({"coupling_scale": self.coupling_scale, "coupling_scale_sd": self.coupling_scale_sd,
              "coupling_prior_sd": self.coupling_prior_sd} if self.coupling_fitted else {})


def speed_noise_mps(speed_mps: np.ndarray) -> float:
    """White noise σ of each GNSS velocity axis, m/s, estimated from the speeds (second differences); 0 if unknown."""
    sigma = white_noise_stdev(speed_mps)
    return float(sigma) if np.isfinite(sigma) else 0.0


def rice_mean(u_mps: np.ndarray, sigma_mps: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean GNSS speed over ground |(u, 0) + e| with e ~ N(0, σ²) per axis (the Rice distribution's mean) and its
    derivative in u: σ·√(π/2)·[(1 + 2z)·I0e(z) + 2z·I1e(z)] with z = u²/(4σ²) (I0e, I1e: exponentially scaled
    Bessel functions); its z-derivative is I0e + I1e. At rest σ·√(π/2), far from rest |u| + σ²/(2|u|)."""
    if sigma_mps <= 0.0:
        return np.abs(u_mps), np.sign(u_mps)
    z = u_mps**2 / (4.0 * sigma_mps**2)
    i0, i1 = special.i0e(z), special.i1e(z)
    scale = sigma_mps * np.sqrt(np.pi / 2.0)
    return scale * ((1.0 + 2.0 * z) * i0 + 2.0 * z * i1), scale * (i0 + i1) * u_mps / (2.0 * sigma_mps**2)


def split_segments(records: list[SurgeRecord], max_gap_s: float = MAX_GAP_S) -> list[Segment]:
    """Every recording cut at sampling gaps longer than ``max_gap_s``; segments shorter than
    :data:`MIN_SEGMENT_SAMPLES` dropped."""
    segments = []
    for r, rec in enumerate(records):
        cuts = np.concatenate([[0], np.flatnonzero(np.diff(rec.t_s) > max_gap_s) + 1, [rec.t_s.size]])
        segments += [Segment(r, int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:], strict=True)
                     if b - a >= MIN_SEGMENT_SAMPLES]
    return segments


class _Problem:
    """The stacked output-error residuals of a set of segments for one basis, mass free or given."""

    def __init__(self, records: list[SurgeRecord], segments: list[Segment], basis: ResistanceBasis,
                 top_speed_mps: float, mass_kg: float | None) -> None:
        self.records, self.segments, self.basis, self.mass_given = records, segments, basis, mass_kg
        self.grid = np.linspace(0.0, 2.0 * top_speed_mps, GRID_POINTS)
        values, slopes = basis.design(self.grid)
        self.table = np.ascontiguousarray(np.hstack([values, slopes]))
        self.step = float(self.grid[1])
        self.p = basis.size
        self.evaluations = 0
        self.noise_mps = [speed_noise_mps(rec.speed_mps) for rec in records]
        self.coupled = any(rec.coupling_N is not None for rec in records)
        """Whether the coupling's scale c is fitted (a parameter after the mass)."""
        self.couplings = [np.zeros(rec.t_s.size) if rec.coupling_N is None
                          else np.ascontiguousarray(rec.coupling_N, dtype=float) for rec in records]
        self.heads = self.p + (mass_kg is None) + self.coupled
        """Parameters before the initial speeds: coefficients, the mass when fitted, c when fitted."""

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """(coefficients, mass, initial speeds) from the optimiser's vector."""
        mass = float(x[self.p]) if self.mass_given is None else float(self.mass_given)
        return x[: self.p], mass, x[self.heads:]

    def scale(self, x: np.ndarray) -> float:
        """The coupling's scale c in the optimiser's vector (1 when it is not fitted)."""
        return float(x[self.heads - 1]) if self.coupled else 1.0

    def pack(self, coeffs: np.ndarray, mass: float, scale: float, u0: np.ndarray) -> np.ndarray:
        """The optimiser's vector: the coefficients, the mass when fitted, c when fitted, the initial speeds."""
        return np.concatenate([coeffs, [mass] if self.mass_given is None else [], [scale] if self.coupled else [],
                               u0])

    def sensitivity_columns(self) -> list[int]:
        """Columns of :func:`_simulate`'s output that hold the sensitivities to the fitted parameters before the
        initial speeds, in the vector's order."""
        return (list(range(1, 1 + self.p)) + ([1 + self.p] if self.mass_given is None else [])
                + ([2 + self.p] if self.coupled else []))

    def _run(self, x: np.ndarray, s: int, start: np.ndarray, rows: slice) -> np.ndarray:
        """Samples ``rows`` of segment ``s`` simulated at ``x`` from the state ``start`` at the first of them
        (:func:`_simulate`'s columns)."""
        coeffs, mass, _ = self.unpack(x)
        seg = self.segments[s]
        rec = self.records[seg.record]
        at = slice(seg.start + rows.start, seg.start + rows.stop)
        return _simulate(rec.t_s[at], rec.thrust_N[at], self.couplings[seg.record][at], self.scale(x), self.coupled,
                         start, mass, np.ascontiguousarray(coeffs, dtype=float), self.table, self.step, MAX_STEP_S)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residuals (simulated |u| − measured) alone, the speed simulated without its sensitivities: those of
        :meth:`segment_rows` at a fraction of the cost."""
        self.evaluations += 1
        rows = []
        for s, seg in enumerate(self.segments):
            run = self._run(x, s, np.array([self.unpack(x)[2][s]]), slice(0, seg.stop - seg.start))
            speed, _ = rice_mean(run[:, 0], self.noise_mps[seg.record])
            rows.append(speed - self.records[seg.record].speed_mps[seg.start:seg.stop])
        return np.concatenate(rows)

    def segment_rows(self, x: np.ndarray) -> Iterator[tuple[int, int, np.ndarray, np.ndarray]]:
        """The residuals (simulated |u| − measured) and their rows of the Jacobian with respect to ``x`` (the
        parameters before the initial speeds, then one column per segment's initial speed), simulated with
        sensitivities :data:`FOLD_ROWS` samples at a time: (segment, first row in the segment, residuals,
        Jacobian rows). On hours of data never the whole samples × parameters array."""
        columns = self.sensitivity_columns()
        width = self.heads + len(self.segments)
        for s, seg in enumerate(self.segments):
            start = np.zeros(self.p + 3 + int(self.coupled))
            start[0], start[-1] = self.unpack(x)[2][s], 1.0
            measured = self.records[seg.record].speed_mps[seg.start:seg.stop]
            for first in range(0, measured.size, FOLD_ROWS):
                last = min(first + FOLD_ROWS, measured.size)
                run = self._run(x, s, start, slice(first, min(last + 1, measured.size)))  # and the next start
                start = run[-1]
                out = run[: last - first]
                speed, slope = rice_mean(out[:, 0], self.noise_mps[seg.record])
                jac = np.zeros((last - first, width))
                jac[:, : self.heads] = slope[:, None] * out[:, columns]
                jac[:, self.heads + s] = slope * out[:, -1]
                yield s, first, speed - measured[first:last], jac

    def folded(self, x: np.ndarray, prior_row: tuple[float, int] | None = None) -> tuple[float, np.ndarray]:
        """The residuals' norm and the triangle of [f J] at ``x`` (:mod:`boat_twin.folded_lsq`); ``prior_row``
        (weight w, parameter index): a pseudo-observation w·(x_index − 1) after the data's rows. The norm is nan
        where the residuals are not finite or the squares of the sensitivities overflow (a stiff, near-massless
        trial point: the solver's scaling squares them)."""
        self.evaluations += 1
        size = x.size
        fold = TriangleFold(size + 1)
        squares, square_sum = 0.0, 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            for _, _, residual, jac in self.segment_rows(x):
                squares += float(residual @ residual)
                square_sum += float(np.sum(np.square(jac)))
                if np.isfinite(squares) and np.isfinite(square_sum):
                    fold.add(np.column_stack([residual, jac]))
            if prior_row is not None:
                weight, index = prior_row
                row = np.zeros((1, size + 1))
                row[0, 0], row[0, 1 + index] = weight * (x[index] - 1.0), weight
                squares += float(row[0, 0] ** 2)
                fold.add(row)
        if not (np.isfinite(squares) and np.isfinite(square_sum)):
            return float("nan"), np.full((size + 1, size + 1), np.nan)
        return float(np.sqrt(squares)), fold.square()

    def times(self) -> np.ndarray:
        """Sample times in residual order, s (each recording's own clock)."""
        return np.concatenate([self.records[g.record].t_s[g.start:g.stop] for g in self.segments])


def _speeds_and_thrusts(problem: _Problem) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """The fitted samples' measured speeds (m/s) and thrusts plus couplings (N), :data:`FOLD_ROWS` at a time."""
    for g in problem.segments:
        record = problem.records[g.record]
        for start in range(g.start, g.stop, FOLD_ROWS):
            rows = slice(start, min(start + FOLD_ROWS, g.stop))
            yield record.speed_mps[rows], record.thrust_N[rows] + problem.couplings[g.record][rows]


def _initial_guess(problem: _Problem, mass_start_kg: float | None = None) -> np.ndarray:
    """Coefficients from the quasi-steady balance T ≈ Fc(speed) (NNLS over all samples, on their folded
    triangle), then the mass from a scan of time constants 0.3-300 s at the median speed, or ``mass_start_kg``
    when given (where it keeps the simulation finite); initial speeds: each segment's first measurement."""
    fold = TriangleFold(problem.p + 1)  # of [sign·φ(speed), T]: NNLS on its triangle, the samples' minimiser
    for speed, thrust in _speeds_and_thrusts(problem):
        values, _ = problem.basis.design(speed)
        fold.add(np.column_stack([values * np.where(thrust >= 0.0, 1.0, -1.0)[:, None], thrust]))
    triangle = fold.square()
    coeffs, _ = optimize.nnls(triangle[:, : problem.p], triangle[:, problem.p], maxiter=50 * problem.p)
    if not np.any(coeffs > 0):
        coeffs = np.full(problem.p, 1.0)
    coeffs = np.maximum(coeffs, 1e-6 * float(np.max(coeffs)))
    u0 = np.array([problem.records[g.record].speed_mps[g.start] for g in problem.segments])
    if problem.mass_given is not None:
        return problem.pack(coeffs, problem.mass_given, 1.0, u0)
    if mass_start_kg is not None:
        start = problem.pack(coeffs, mass_start_kg, 1.0, u0)
        with np.errstate(over="ignore", invalid="ignore"):
            if np.all(np.isfinite(problem.residual(start))) and np.isfinite(problem.folded(start)[0]):
                return start
    slope = float(np.median(np.concatenate([problem.basis.design(speed)[1] @ coeffs
                                            for speed, _ in _speeds_and_thrusts(problem)]))) or 1.0
    trials = [problem.pack(coeffs, tau_s * slope, 1.0, u0) for tau_s in np.geomspace(0.3, 300.0, 13)]
    with np.errstate(over="ignore", invalid="ignore"):
        costs = [float(np.sum(problem.residual(x) ** 2)) for x in trials]
    for k in np.argsort(costs, kind="stable"):  # the cheapest whose sensitivities stay finite
        if np.isfinite(costs[k]) and np.isfinite(problem.folded(trials[k])[0]):
            return trials[k]
    raise InputError("the surge model diverges for every trial mass: check the thrust and speed units")


def autocorrelation(values: np.ndarray) -> np.ndarray:
    """Sample autocorrelation of ``values`` at lags 0 … n − 1 (lag 0: 1; all zero for a constant series), -:
    Σ_i c_i·c_(i+k) / Σ_i c_i² of the centred series c, through the FFT (zero-padded to at least 2n − 1: no wrap
    around), O(n log n); the direct sum (``np.correlate``) is O(n²): minutes on a 6-hour record at 10 Hz."""
    centred = np.asarray(values, dtype=float) - np.mean(values)
    n = centred.size
    size = fft.next_fast_len(2 * n - 1, real=True)
    spectrum = fft.rfft(centred, size)
    acf = fft.irfft(spectrum.real**2 + spectrum.imag**2, size)[:n]
    return acf / max(float(centred @ centred), 1e-300)


def _correlation_time_s(problem: _Problem, residual: np.ndarray) -> tuple[float, float]:
    """The residuals' sample interval and integrated correlation time dt·(1 + 2·Σ ρ_k) (the autocorrelation
    summed to its first non-positive lag), s."""
    times = problem.times()
    dt = float(np.median(np.diff(times))) if times.size > 1 else 1.0
    acf = autocorrelation(residual)
    negative = np.flatnonzero(acf[1:] <= 0.0)
    lags = acf[1: 1 + (int(negative[0]) if negative.size else acf.size - 1)]
    return dt, dt * (1.0 + 2.0 * float(np.sum(lags)))


def _cluster_covariance(problem: _Problem, x: np.ndarray, residual: np.ndarray, free: np.ndarray,
                        prior_information: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, float]:
    """Cluster-robust covariance of the free parameters at the solution ``x`` with ``residual``, the information
    JᵀJ + P of the free parameters, the number of clusters and their length (s); ``prior_information`` P (free ×
    free): a penalty's, kept in every replicate (:mod:`boat_twin.ident.jackknife`). Two passes over the
    segments' rows (the information, then each cluster's shift), never the whole Jacobian."""
    _, correlation_s = _correlation_time_s(problem, residual)
    cluster_s = max(MIN_CLUSTER_S, 5.0 * correlation_s)
    information = prior_information.copy()
    for _, _, _, jac in problem.segment_rows(x):
        information += jac[:, free].T @ jac[:, free]
    shifts = []
    cluster: tuple[int, int] | None = None  # (segment, block) of the cluster being summed
    squares, score = np.zeros_like(information), np.zeros(information.shape[0])
    for s, first, seg_residual, jac in problem.segment_rows(x):
        seg = problem.segments[s]
        t = problem.records[seg.record].t_s[seg.start:seg.stop]
        block = np.floor((t[first: first + seg_residual.size] - t[0]) / cluster_s).astype(int)
        bounds = np.concatenate([[0], np.flatnonzero(np.diff(block)) + 1, [block.size]])
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):  # runs of rows of one cluster (non-decreasing)
            if cluster != (s, int(block[a])):
                if cluster is not None:
                    shifts.append(jackknife_shift(information, squares, score))
                cluster, squares, score = (s, int(block[a])), np.zeros_like(squares), np.zeros_like(score)
            squares += jac[a:b, free].T @ jac[a:b, free]
            score += jac[a:b, free].T @ seg_residual[a:b]
    if cluster is not None:
        shifts.append(jackknife_shift(information, squares, score))
    return jackknife_spread(np.array(shifts)), information, len(shifts), cluster_s


def fit_surge(records: list[SurgeRecord], basis: ResistanceBasis, *, segments: list[Segment] | None = None,
              mass_kg: float | None = None, top_speed_mps: float | None = None,
              coupling_sd: float | None = None, mass_start_kg: float | None = None,
              cost_tolerance: float = 1e-8) -> SurgeFit:
    """Fit ``basis`` and the effective mass (or hold ``mass_kg``) by output error over ``segments`` (default: all
    of ``records`` cut at gaps). Returns the fit with its cluster-robust covariance. ``mass_start_kg``: where
    the fit starts the mass (e.g. a simpler basis' fit to the same samples), instead of a scan of 13 trial
    masses (:func:`_initial_guess`). ``cost_tolerance``: the solver stops where the cost changes by less than
    this share (scipy's ``ftol``).

    ``coupling_sd`` (-; None: none) is the standard deviation of a Gaussian prior c ~ N(1, σ_c²) on the coupling
    force's scale, for a caller that knows how far its coupling model may be off (:data:`SurgeRecord.coupling_N`).
    Where the data alone cannot tell c from the mass (the mass seen only where the coupling acts: constant-thrust
    zigzags) the prior lets them. It is a pseudo-observation w·(c − 1) beside the speed residuals, its weight
    w = s/σ_c with s² the residuals' long-run variance (their variance × the integrated correlation time over
    the sample interval: the variance the cluster-robust covariance gives the data's information), so that the
    fit weighs the prior against the data as their variances say; w is set from a first pass's residuals (the GNSS
    noise before) and the fit repeated from there. Its covariance: the jackknife over the data's clusters with the
    prior's information in every replicate, plus the prior's own variance carried through (the sandwich's
    H⁻¹·w²s²·eeᵀ·H⁻¹): the Gaussian posterior where the model is linear."""
    segments = segments if segments is not None else split_segments(records)
    if not segments:
        raise InputError(f"no stretch of {MIN_SEGMENT_SAMPLES} samples without a gap over {MAX_GAP_S:g} s: "
                         "nothing to simulate")
    top = top_speed_mps or float(max(np.max(np.abs(r.speed_mps)) for r in records))
    problem = _Problem(records, segments, basis, top, mass_kg)
    x0 = _initial_guess(problem, mass_start_kg)
    lower = np.concatenate([np.zeros(problem.p), [1e-6 * x0[problem.p]] if mass_kg is None else [],
                            [-np.inf] if problem.coupled else [], np.full(len(segments), -np.inf)])
    upper = np.full(x0.size, np.inf)
    cache: dict[bytes, tuple[float, np.ndarray]] = {}
    scale_at = problem.heads - 1  # c's place in the vector (when coupled)
    prior_sd = float(coupling_sd) if problem.coupled and coupling_sd is not None and coupling_sd > 0.0 else 0.0
    weight = [0.0]  # the prior row's weight w, m/s per unit of c (0: no prior)

    def evaluate(x: np.ndarray) -> tuple[float, np.ndarray]:
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = problem.folded(x, (weight[0], scale_at) if weight[0] > 0.0 else None)
        return cache[key]

    def solve(start: np.ndarray) -> optimize.OptimizeResult:
        cache.clear()
        return folded_least_squares(lambda x: evaluate(x)[0], lambda x: evaluate(x)[1], np.clip(start, lower, upper),
                                    lower, upper, x_scale="jac", max_nfev=200, ftol=cost_tolerance)

    # The solver's matrices are small ((parameters + 1)², :mod:`boat_twin.folded_lsq`): BLAS threads only spin,
    # so the fit runs on one.
    with np.errstate(over="ignore", invalid="ignore"), threadpool_limits(limits=1, user_api="blas"):
        if prior_sd > 0.0:
            weight[0] = float(np.sqrt(np.mean(np.square(problem.noise_mps)))) / prior_sd
            first = solve(x0)
            data = problem.residual(first.x)
            x0 = first.x if np.all(np.isfinite(data)) else x0
            if np.all(np.isfinite(data)):
                weight[0] = _long_run_sd(problem, data) / prior_sd
        result = solve(x0)
        evaluations = problem.evaluations
        residual = problem.residual(result.x)
    if not np.all(np.isfinite(residual)):
        raise InputError("the surge model diverged while fitting (non-finite speeds): check the recording's units")
    coeffs, mass, u0 = problem.unpack(result.x)
    free = np.ones(result.x.size, dtype=bool)
    free[: problem.p] = result.active_mask[: problem.p] == 0
    prior = np.zeros((int(free.sum()), int(free.sum())))
    if prior_sd > 0.0:
        at = int(np.count_nonzero(free[:scale_at]))
        prior[at, at] = weight[0] ** 2
    with threadpool_limits(limits=1, user_api="blas"):
        cov_free, information, clusters, cluster_s = _cluster_covariance(problem, result.x, residual, free, prior)
    if prior_sd > 0.0:  # the prior's own variance, (w·σ_c)² = s² on its row, through H⁻¹
        response = np.linalg.pinv(information)[:, at] * weight[0]
        cov_free = cov_free + np.outer(response, response) * (weight[0] * prior_sd) ** 2
    cov = np.zeros((result.x.size, result.x.size))
    cov[np.ix_(free, free)] = cov_free
    param_cov = np.zeros((problem.p + 1, problem.p + 1))  # the coefficients and the mass (c's share in them)
    n_params = problem.p + (mass_kg is None)
    param_cov[:n_params, :n_params] = cov[:n_params, :n_params]
    scale_sd = float(np.sqrt(max(cov[scale_at, scale_at], 0.0))) if problem.coupled else 0.0
    return SurgeFit(basis=basis, coefficients=np.array(coeffs), mass_kg=mass, mass_fixed=mass_kg is not None,
                    initial_speeds_mps=np.array(u0), residual_mps=residual, covariance=param_cov, clusters=clusters,
                    cluster_s=cluster_s, top_speed_mps=top, evaluations=evaluations,
                    coupling_fitted=problem.coupled, coupling_scale=problem.scale(result.x),
                    coupling_scale_sd=scale_sd, coupling_prior_sd=prior_sd)


def _long_run_sd(problem: _Problem, residual: np.ndarray) -> float:
    """√ of the residuals' long-run variance, m/s: their mean square × the integrated correlation time over the
    sample interval (:func:`_correlation_time_s`) — what one sample's residual weighs in the cluster-robust
    covariance of a parameter that acts smoothly over many samples."""
    dt, correlation_s = _correlation_time_s(problem, residual)
    return float(np.sqrt(np.mean(residual**2) * max(correlation_s / dt, 1.0)))


def predict(fit: SurgeFit, record: SurgeRecord, segment: Segment) -> np.ndarray:
    """Speed over ground the fitted model predicts over ``segment``, open loop from its first measured speed
    (the mean of its first five samples), m/s."""
    problem = _Problem([record], [Segment(0, segment.start, segment.stop)], fit.basis, fit.top_speed_mps,
                       fit.mass_kg)
    u0 = float(np.mean(record.speed_mps[segment.start: segment.start + 5]))
    residual = problem.residual(problem.pack(fit.coefficients, fit.mass_kg, fit.coupling_scale, np.array([u0])))
    return residual + record.speed_mps[segment.start:segment.stop]


@dataclass(frozen=True, kw_only=True)
class OutputErrorResult:
    """The output-error identification: every candidate's held-out error, the selected fit and the baseline."""

    selected: SurgeFit
    baseline: SurgeFit
    candidates: list[dict[str, Any]]
    """Per candidate: model, terms, cv_mse_mps2 (pooled held-out), cv_rmse_per_record_mps."""
    folds: str
    reason: str
    mass_identified: bool
    mass_note: str
    thrust_scale: dict[str, Any] | None = None
    """The thrust's scale with the effective mass held at a boat file's (:func:`thrust_scale`), for the selected
    fit and the baseline; None: no mass given."""

    def to_dict(self) -> dict[str, Any]:
        """The ``output_error`` entry of ``identify --json`` (SI)."""
        return {"selected": self.selected.to_dict(), "baseline": self.baseline.to_dict(),
                "candidates": self.candidates, "folds": self.folds, "selection_reason": self.reason,
                "mass_identified": self.mass_identified, "mass_note": self.mass_note} | (
                    {} if self.thrust_scale is None else {"thrust_scale": self.thrust_scale})


THRUST_SCALE_NOTE = ("the surge alone cannot tell a heavier boat from a weaker thrust: m·du/dt = k·T − Fc(u) moves "
                     "alike for (m, k, Fc) and (λm, λk, λFc); with the effective mass held at the boat file's "
                     "{mass:.4g} kg (taken as exact) the thrust is k × the boat file's map (thrust table, K_T(J) or "
                     "N), Fc k × the fitted curve; the model keeps k = 1 and the fitted mass")


def thrust_scale(result: OutputErrorResult, mass_kg: float) -> dict[str, Any]:
    """The thrust's scale k (thrust table / K_T scale: the thrust the boat felt over the one its commands map to)
    with the effective mass held at ``mass_kg`` (a boat file's), for the selected fit and the baseline. The fit with
    the mass held and k free is the fit with the mass free and k = 1 reparametrised (the model is invariant under
    (m, k, Fc) → (λm, λk, λFc): :data:`THRUST_SCALE_NOTE`), so k = ``mass_kg`` / m̂ and its 95 % interval is the
    fitted mass's mapped through it: [``mass_kg``/m_high, ``mass_kg``/m_low] (None: unbounded). Identified when the
    mass is (:func:`_mass_verdict`). The boat file's mass is taken as exact: its own error moves k by its share."""
    out: dict[str, Any] = {"mass_held_kg": mass_kg, "note": THRUST_SCALE_NOTE.format(mass=mass_kg)}
    for name, fit in (("selected", result.selected), ("baseline", result.baseline)):
        lo, hi = fit.mass_ci95_kg
        identified, _ = _mass_verdict(fit, None)
        out[name] = {"scale": mass_kg / fit.mass_kg,
                     "ci95": [mass_kg / hi if np.isfinite(hi) and hi > 0.0 else None,
                              mass_kg / lo if np.isfinite(lo) and lo > 0.0 else None],
                     "identified": identified}
    return out


def _folds(records: list[SurgeRecord], segments: list[Segment]) -> tuple[list[tuple[list[Segment],
                                                                                    list[Segment]]], str]:
    """(training segments, held-out segments) per fold, and how the folds were made."""
    if len(records) >= 3:
        return [([g for g in segments if g.record != r], [g for g in segments if g.record == r])
                for r in range(len(records))], f"leave one recording out ({len(records)} folds)"
    folds = []
    for b in range(CV_BLOCKS):
        train, held = [], []
        for g in segments:
            t = records[g.record].t_s
            edges = np.linspace(t[0], t[-1], CV_BLOCKS + 1)
            lo = int(np.searchsorted(t, edges[b], "left"))
            hi = int(np.searchsorted(t, edges[b + 1], "right")) if b == CV_BLOCKS - 1 \
                else int(np.searchsorted(t, edges[b + 1], "left"))
            lo, hi = max(lo, g.start), min(hi, g.stop)
            if hi - lo >= MIN_SEGMENT_SAMPLES:
                held.append(Segment(g.record, lo, hi))
            train += [Segment(g.record, a, c) for a, c in ((g.start, min(lo, g.stop)), (max(hi, g.start), g.stop))
                      if c - a >= MIN_SEGMENT_SAMPLES]
        if held and train:
            folds.append((train, held))
    return folds, f"leave one of {CV_BLOCKS} consecutive time blocks out ({len(folds)} folds)"


def _cross_validate(records: list[SurgeRecord], basis: ResistanceBasis, folds: list[tuple[list[Segment],
                    list[Segment]]], top: float, mass_kg: float | None,
                    mass_starts_kg: list[float | None]) -> tuple[float, np.ndarray]:
    """Pooled held-out mean squared error (m²/s²) and each record's held-out RMSE (m/s; NaN where none held).
    ``mass_starts_kg``: per fold, where its fit starts the mass (None: a scan), replaced by the fold's fitted
    mass: a richer basis' fold then starts from the simpler one's fit to the same training data (never from a
    fit that saw its held-out samples), without a scan of 13 trial masses over the training data."""
    sq = np.zeros(len(records))
    count = np.zeros(len(records))
    for f, (train, held) in enumerate(folds):
        try:
            fit = fit_surge(records, basis, segments=train, mass_kg=mass_kg, top_speed_mps=top,
                            mass_start_kg=mass_starts_kg[f], cost_tolerance=CV_COST_TOLERANCE)
        except InputError:
            return float("inf"), np.full(len(records), np.inf)
        mass_starts_kg[f] = fit.mass_kg
        for g in held:
            error = predict(fit, records[g.record], g) - records[g.record].speed_mps[g.start:g.stop]
            sq[g.record] += float(np.sum(error**2)) if np.all(np.isfinite(error)) else np.inf
            count[g.record] += error.size
    with np.errstate(invalid="ignore", divide="ignore"):
        return float(np.sum(sq) / max(np.sum(count), 1)), np.sqrt(sq / count)


def identify_surge(records: list[SurgeRecord], *, mass_kg: float | None = None,
                   spline_sizes: tuple[int, ...] = SPLINE_SIZES,
                   even_sizes: tuple[int, ...] = EVEN_KNOT_SIZES) -> OutputErrorResult:
    """Output-error identification of mass and resistance over ``records`` (module docstring): the baseline
    and the I-spline candidates (``spline_sizes`` knotted at the speeds' quantiles, then ``even_sizes`` with
    knots spread evenly in part: :data:`KNOT_UNIFORM_SHARE`) cross-validated, the selected one refitted on
    everything. ``mass_kg`` holds the effective mass (not fitted); otherwise it is fitted and judged identified
    when its 95 % interval is within ± :data:`MASS_RELATIVE_LIMIT` of it."""
    segments = split_segments(records)
    if not segments:
        raise InputError(f"no stretch of {MIN_SEGMENT_SAMPLES} samples without a gap over {MAX_GAP_S:g} s: "
                         "nothing to simulate")
    speeds = np.concatenate([r.speed_mps[g.start:g.stop] for g in segments for r in [records[g.record]]])
    top = float(np.max(np.abs(speeds)))
    if not top > 0.0:
        raise InputError("the boat never moved (every measured speed is 0): no resistance to identify")
    kinds = [(0, 0.0)] + [(k, 0.0) for k in spline_sizes] + [(k, KNOT_UNIFORM_SHARE) for k in even_sizes]

    def basis_of(terms: int, share: float) -> ResistanceBasis:
        return ResistanceBasis() if terms == 0 else spline_basis(speeds, terms, share)

    folds, how = _folds(records, segments)
    candidates = []
    mass_starts_kg: list[float | None] = [None] * len(folds)  # each fold's fitted mass, basis after basis
    for kind in kinds:
        basis = basis_of(*kind)
        mse, per_record = (_cross_validate(records, basis, folds, top, mass_kg, mass_starts_kg) if folds
                           else (np.nan, None))
        candidates.append({"model": basis.name, "terms": basis.size, "cv_mse_mps2": mse,
                           "cv_rmse_mps": float(np.sqrt(mse)),
                           "cv_rmse_per_record_mps": None if per_record is None else per_record.tolist()})
    chosen, reason = _choose(candidates)
    fits: dict[tuple[int, float], SurgeFit] = {}

    def fitted(terms: int, share: float = 0.0) -> SurgeFit:  # the baseline first: the others start from its mass
        if (terms, share) not in fits:
            fits[terms, share] = fit_surge(records, basis_of(terms, share), segments=segments, mass_kg=mass_kg,
                                           top_speed_mps=top,
                                           mass_start_kg=fits[0, 0.0].mass_kg if fits else None)
        return fits[terms, share]

    def with_reference(fit: SurgeFit) -> SurgeFit:  # the next richer basis of the same knot placement
        share = fit.basis.uniform_share
        return replace(fit, reference=fitted(_richer_terms(fit.basis.size - 2,
                                                           even_sizes if share else spline_sizes), share))

    baseline = with_reference(fitted(0))
    selected = baseline if chosen == 0 else with_reference(fitted(*kinds[chosen]))
    identified, note = _mass_verdict(selected, mass_kg)
    return OutputErrorResult(selected=selected, baseline=baseline, candidates=candidates, folds=how, reason=reason,
                             mass_identified=identified, mass_note=note)


def _richer_terms(terms: int, spline_sizes: tuple[int, ...]) -> int:
    """I-spline terms of the reference a fit's intervals are widened against: the next richer candidate, or
    4/3 of the richest."""
    richer = [k for k in spline_sizes if k > terms]
    return richer[0] if richer else -(-4 * max(terms, 3) // 3)


def _choose(candidates: list[dict[str, Any]]) -> tuple[int, str]:
    """Index of the selected candidate (0: the baseline) and why."""
    mse = np.array([c["cv_mse_mps2"] for c in candidates], dtype=float)
    if not np.all(np.isfinite(mse)):
        if np.isfinite(mse[0]):
            return 0, "baseline: a candidate could not be cross-validated"
        return 0, "baseline: no held-out data to compare the candidates on"
    best = float(np.min(mse))
    index = int(np.flatnonzero(mse <= best * (1.0 + CV_TOLERANCE))[0])
    if index == 0:
        return 0, (f"baseline: no richer resistance curve predicts held-out data better by more than "
                   f"{CV_TOLERANCE:.0%} (held-out RMSE {np.sqrt(mse[0]):.4g} m/s)")
    worse = [i for i, (own, base) in enumerate(zip(candidates[index]["cv_rmse_per_record_mps"],
                                                   candidates[0]["cv_rmse_per_record_mps"], strict=True))
             if np.isfinite(own) and own > base]
    if worse:
        return 0, (f"baseline: {candidates[index]['model']} predicts held-out data better overall but worse on "
                   f"recording(s) {', '.join(str(i + 1) for i in worse)}")
    return index, (f"{candidates[index]['model']}: held-out RMSE {np.sqrt(mse[index]):.4g} m/s against the "
                   f"baseline's {np.sqrt(mse[0]):.4g} m/s (smallest model within {CV_TOLERANCE:.0%} of the best)")


def _mass_verdict(fit: SurgeFit, given_kg: float | None) -> tuple[bool, str]:
    """Whether the data identify the mass, and the sentence that says so."""
    if given_kg is not None:
        return False, f"effective mass held at {given_kg:.4g} kg (given, not fitted)"
    lo, hi = fit.mass_ci95_kg
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi - fit.mass_kg > MASS_RELATIVE_LIMIT * fit.mass_kg \
            or lo <= 0.0:
        return False, (f"the data do not identify the mass (estimate {fit.mass_kg:.4g} kg, 95 % interval "
                       f"[{lo:.4g}, {hi:.4g}] kg): record thrust steps up and down")
    return True, f"effective mass {fit.mass_kg:.4g} kg, 95 % interval [{lo:.4g}, {hi:.4g}] kg"
