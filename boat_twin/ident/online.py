"""Online identification: recursive least squares, a steady-state detector, and the one identifier class
that the ROS node and bag replay both feed sample by sample (no ROS here).

Steady-state criterion (stated): thrust is constant while it stays within max(``thrust_tolerance_N``, 1 %) of the
segment's first value. When the segment ends, its speed is tested over tails of growing length (``window_s``,
then in steps of ``window_s``/2, up to the whole segment, at most its last ``max_segment_s``): a straight
line v = a + b·t is fitted by least squares, and the tail passes when

- trend: the 95 % upper bound of the speed change across the tail, (|b| + t₀.₉₇₅·se(b))·L, is within
  max(``max_drift_mps`` = 0.05 m/s, ``max_drift_rel`` = 1 % of the mean speed). On the shortest tail this
  bounds |dv/dt| by 2.5 mm/s², a force imbalance m·|dv/dt| of ~3 N for a 1.4 t boat; with 10 Hz GNSS and
  0.05 m/s noise, the uncertainty term alone is ~0.024 m/s;
- spread: the residual standard deviation about the line is within ``max_spread_mps`` (no oscillation, no
  manoeuvre).

The steady point is the mean over the longest tail whose shorter tails all pass and whose drift bound is no
looser than the shortest tail's (so a slow approach is not averaged in). A segment whose shortest tail fails
never settled: it is rejected with the reason, never averaged into a biased point.

The defaults (window 20 s, tolerance 5 N) suit the 6 m boat and its GNSS, and are what the live identifier
uses; ``boat-twin identify`` sizes both from the recording (:mod:`boat_twin.ident.settling`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from scipy import linalg, stats

from boat_twin.errors import InputError
from boat_twin.ident.dynamic import DynamicWindow, check_samples, window_row
from boat_twin.ident.steady import MAX_ORDER, legendre_design, power_matrix

EDGE_TOLERANCE_S = 1e-4
"""Samples within 0.1 ms of a window edge count as on it: far below any sampling period (1 ms at 1 kHz), far
above the rounding of stamps (1 ulp of 1.7e9 s is 0.24 µs), so seconds from ``sec + nanosec·1e-9`` or from
``ns·1e-9`` give the same windows."""


class RecursiveLeastSquares:
    """θ̂ minimising Σ_j λ^(k−j)·(y_j − x_jᵀθ)², one sample at a time (Ljung & Söderström 1983, §2.2).

    ``forgetting`` λ ∈ (0, 1] (1: ordinary least squares). P starts at ``initial_covariance``·I (θ₀ = 0),
    a prior that biases parameters of order one by ~1e-8 relative. Against covariance wind-up while the
    regressors do not excite every direction, trace(P) is kept at or below its initial value.
    """

    def __init__(self, n_params: int, forgetting: float = 1.0, initial_covariance: float = 1e8) -> None:
        if not 0.0 < forgetting <= 1.0:
            raise InputError(f"RLS: forgetting factor must be in (0, 1], got {forgetting}")
        self._theta = np.zeros(n_params)
        self._p = np.eye(n_params) * initial_covariance
        self._max_trace = n_params * initial_covariance
        self._trace = self._max_trace
        self.forgetting = forgetting
        self._loss = 0.0
        self._weight = 0.0
        self.n_updates = 0

    def update(self, x: np.ndarray, y: float, forgetting: float | None = None) -> float:
        """Add one observation y ≈ xᵀθ (λ: ``forgetting`` or the default); returns the prior error."""
        lam = self.forgetting if forgetting is None else forgetting
        px = self._p.dot(x)
        denom = lam + float(x.dot(px))
        gain = px / denom
        error = y - float(x.dot(self._theta))
        self._theta += gain * error
        p = self._p
        p -= gain[:, None] * px
        p *= 1.0 / lam
        # trace(P) after the update, without a pass over P: (trace − gain·px)/λ
        self._trace = (self._trace - float(gain.dot(px))) / lam
        if self._trace > self._max_trace:
            p *= self._max_trace / self._trace
            self._trace = self._max_trace
        self._loss = lam * self._loss + error * error * lam / denom  # prior × posterior error
        self._weight = lam * self._weight + 1.0
        self.n_updates += 1
        return float(error)

    @property
    def theta(self) -> np.ndarray:
        """Current estimate (a copy)."""
        return self._theta.copy()

    @property
    def p_matrix(self) -> np.ndarray:
        """P: the covariance of θ̂ divided by the noise variance (a copy)."""
        return self._p.copy()

    @property
    def noise_variance(self) -> float:
        """Residual variance: the λ-weighted loss over its effective degrees of freedom (nan if none)."""
        dof = self._weight - self._theta.size
        return self._loss / dof if dof > 0.0 else float("nan")

    @property
    def covariance(self) -> np.ndarray:
        """Covariance of θ̂: noise variance × P."""
        return self.noise_variance * self._p


@dataclass(frozen=True)
class SteadyCriteria:
    """When a constant-thrust segment counts as steady (see the module docstring)."""

    window_s: float = 20.0
    """Shortest settled tail, s."""
    max_drift_mps: float = 0.05
    """Bound on the speed change the 95 % upper trend implies across the tail, m/s (or the relative bound)."""
    max_drift_rel: float = 0.01
    """Relative drift bound, -: the bound is max(``max_drift_mps``, this × mean speed of the tail)."""
    max_spread_mps: float = 0.2
    """Bound on the residual standard deviation of speed about its trend, m/s."""
    thrust_tolerance_N: float = 5.0
    """Thrust counts as constant within max(this, ``thrust_tolerance_rel``·|F|) of the segment start, N."""
    thrust_tolerance_rel: float = 0.01
    """Relative thrust tolerance, -."""
    max_segment_s: float = 600.0
    """Only the last this-many seconds of a segment are kept and analysed (bounded memory online), s."""
    max_gap_s: float = 1.0
    """A sampling gap longer than this splits the analysable tail, s."""
    noise_correlation_s: float = 0.0
    """Time over which the speed's noise is correlated, s (0: white noise, as a receiver's velocity; a speed
    smoothed from positions: the smoother's window). The trend's standard error counts one independent sample
    per this much time."""

    def __post_init__(self) -> None:
        values = asdict(self)
        if not (math.isfinite(values.pop("noise_correlation_s")) and self.noise_correlation_s >= 0.0):
            raise InputError("steady-state criteria: noise_correlation_s must be a number >= 0")
        if not all(math.isfinite(v) and v > 0.0 for v in values.values()):
            raise InputError("steady-state criteria: every setting must be a positive number")
        if self.max_segment_s < self.window_s:
            raise InputError("steady-state criteria: max_segment_s must be at least window_s")


@dataclass(frozen=True)
class SteadySegment:
    """One constant-thrust segment and the verdict of the detector (SI)."""

    start_s: float
    """First sample of the segment, s."""
    end_s: float
    """Last sample of the segment, s."""
    thrust_N: float
    """Mean thrust over the segment's analysed part, N."""
    accepted: bool
    """True when the speed settled."""
    reason: str
    """Why the segment was rejected ('' when accepted)."""
    speed_mps: float
    """Mean speed over the settled tail (accepted) or over the last ``window_s`` (rejected), m/s."""
    duration_s: float
    """Length of the settled tail, s (0 when rejected)."""
    drift_mps: float
    """95 % upper bound of the trend times the tail length, m/s (shortest tail when rejected)."""
    spread_mps: float
    """Residual standard deviation of speed about its trend, m/s."""
    speed_stderr_mps: float
    """Standard error of the mean speed, assuming white noise, m/s."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (undefined figures as None)."""
        return {
            k: None if isinstance(x, float) and not math.isfinite(x) else x for k, x in asdict(self).items()
        }


def _tail_starts(t: np.ndarray, first: int, window_s: float) -> np.ndarray:
    """Start indices of tails of length window_s, 1.5·window_s, ... and of the whole part after ``first``."""
    held = t[-1] - t[first]
    lengths = np.r_[np.arange(window_s, held - EDGE_TOLERANCE_S, window_s / 2.0), held]
    return np.searchsorted(t, t[-1] - lengths + EDGE_TOLERANCE_S, side="right") - 1


def analyse_segment(
    t: np.ndarray, speed: np.ndarray, thrust: np.ndarray, criteria: SteadyCriteria
) -> SteadySegment:
    """Verdict on one constant-thrust segment (arrays of its samples, time increasing)."""
    gaps = np.flatnonzero(np.diff(t) > criteria.max_gap_s)
    first = int(gaps[-1]) + 1 if gaps.size else 0
    thrust_mean = float(np.mean(thrust[first:]))

    def rejected(
        reason: str, speed_mean: float, drift: float = float("nan"), spread: float = float("nan")
    ) -> SteadySegment:
        return SteadySegment(
            float(t[0]),
            float(t[-1]),
            thrust_mean,
            False,
            reason,
            speed_mean,
            0.0,
            drift,
            spread,
            float("nan"),
        )

    held = float(t[-1] - t[first])
    if held < criteria.window_s - EDGE_TOLERANCE_S or t.size - first < 4:
        after = " after a sampling gap" if gaps.size else ""
        return rejected(
            f"held {held:.1f} s{after}, shorter than the {criteria.window_s:.3g} s test window",
            float(np.mean(speed[first:])),
        )
    starts = np.maximum(_tail_starts(t, first, criteria.window_s), first)
    tau = t - t[-1]
    dv = speed - speed[-1]

    # suffix sums: statistics of every tail [s, end] in O(1) each
    def suffix(a: np.ndarray) -> np.ndarray:
        return np.cumsum(a[::-1])[::-1][starts]

    n = (t.size - starts).astype(float)
    st, sv, stt, stv, svv = suffix(tau), suffix(dv), suffix(tau * tau), suffix(tau * dv), suffix(dv * dv)
    sxx = stt - st * st / n
    sxy = stv - st * sv / n
    syy = svv - sv * sv / n
    slope = sxy / sxx
    spread = np.sqrt(np.maximum(syy - slope * sxy, 0.0) / (n - 2.0))
    length = t[-1] - t[starts]
    # correlated noise: one independent sample per noise_correlation_s (at most n)
    per_sample = np.maximum(criteria.noise_correlation_s * (n - 1.0) / np.maximum(length, 1e-9), 1.0)
    se = spread / np.sqrt(sxx) * np.sqrt(per_sample)
    dof = np.maximum(n / per_sample - 2.0, 1.0)
    drift = (np.abs(slope) + stats.t.ppf(0.975, dof) * se) * length
    bound = np.maximum(criteria.max_drift_mps, criteria.max_drift_rel * np.abs(speed[-1] + sv / n))
    # a longer tail is used only while it bounds the drift at least as tightly as the shortest one
    ok = (drift <= bound) & (spread <= criteria.max_spread_mps) & (drift <= drift[0])
    if not ok[0]:
        last = float(speed[-1] + sv[0] / n[0])
        if spread[0] > criteria.max_spread_mps:
            why = f"speed unsteady: spread {spread[0]:.3f} m/s > {criteria.max_spread_mps:g} m/s"
        else:
            why = (
                f"speed never settled: trend {slope[0]:+.4f} m/s² over the last {length[0]:.0f} s, "
                f"drift bound {drift[0]:.3f} m/s > {bound[0]:.3g} m/s"
            )
        return rejected(why, last, float(drift[0]), float(spread[0]))
    j = int(np.argmin(ok)) - 1 if not np.all(ok) else ok.size - 1
    mean = float(speed[-1] + sv[j] / n[j])
    return SteadySegment(
        float(t[0]),
        float(t[-1]),
        thrust_mean,
        True,
        "",
        mean,
        float(length[j]),
        float(drift[j]),
        float(spread[j]),
        float(spread[j] / np.sqrt(n[j] / per_sample[j])),
    )


class SteadyStateDetector:
    """Streaming splitter of (t, thrust, speed) samples into constant-thrust segments, judged at their end."""

    def __init__(self, criteria: SteadyCriteria | None = None) -> None:
        self.criteria = criteria or SteadyCriteria()
        self._t: deque[float] = deque()
        self._f: deque[float] = deque()
        self._v: deque[float] = deque()
        self._ref = 0.0
        self._start = 0.0

    def update(self, t_s: float, thrust_N: float, speed_mps: float) -> SteadySegment | None:
        """Add one sample (time increasing); returns the segment that this sample closed, if any."""
        closed = None
        c = self.criteria
        if self._t and abs(thrust_N - self._ref) > max(
            c.thrust_tolerance_N, c.thrust_tolerance_rel * abs(self._ref)
        ):
            closed = self.finish()
        if not self._t:
            self._ref = thrust_N
            self._start = t_s
        self._t.append(t_s)
        self._f.append(thrust_N)
        self._v.append(speed_mps)
        while t_s - self._t[0] > c.max_segment_s:
            self._t.popleft()
            self._f.popleft()
            self._v.popleft()
        return closed

    def finish(self) -> SteadySegment | None:
        """Judge and close the current segment (end of data); None when there is none."""
        if not self._t:
            return None
        t = np.fromiter(self._t, float, len(self._t))
        seg = analyse_segment(
            t, np.fromiter(self._v, float, t.size), np.fromiter(self._f, float, t.size), self.criteria
        )
        seg = replace(seg, start_s=self._start)
        self._t.clear()
        self._f.clear()
        self._v.clear()
        return seg


def detect_steady_segments(
    t_s: Any,
    thrust_N: Any,
    speed_mps: Any,
    criteria: SteadyCriteria | None = None,
) -> list[SteadySegment]:
    """All constant-thrust segments of a trial with their verdicts (the same code path as online)."""
    t, f, v = check_samples(t_s, thrust_N, speed_mps)
    detector = SteadyStateDetector(criteria)
    segments = [s for s in map(detector.update, t.tolist(), f.tolist(), v.tolist()) if s is not None]
    last = detector.finish()
    return segments + ([last] if last is not None else [])


class OnlineThrustSpeedIdentifier:
    """The identifier core fed sample by sample by the ROS node and by bag replay alike.

    Two recursive least-squares estimators with exponential forgetting (time constant ``memory_s``:
    λ = exp(−Δt/memory_s) per update) run on the batch regressors: the steady curve Fc(v) of order
    ``order`` on the steady points the detector accepts (as :func:`~boat_twin.ident.steady.fit_power_series`),
    and mass + Fc of order ``dynamic_order`` (default ``order``) on the transient windows (as
    :func:`~boat_twin.ident.dynamic.identify_dynamic`, same window rule). ``through_origin`` imposes
    Fc(0) = 0 on the steady curve, as the batch fit of a trial does. Inside, speed is scaled by
    ``speed_scale_mps`` and thrust by ``thrust_scale_N`` for conditioning
    only. Non-finite samples and samples not later than the previous one are ignored and counted.
    """

    def __init__(
        self,
        order: int = 3,
        dynamic_order: int | None = None,
        *,
        memory_s: float = 3600.0,
        through_origin: bool = True,
        criteria: SteadyCriteria | None = None,
        window: DynamicWindow | None = None,
        speed_scale_mps: float = 10.0,
        thrust_scale_N: float = 1000.0,
    ) -> None:
        dynamic_order = order if dynamic_order is None else dynamic_order
        for value in (order, dynamic_order):
            if not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_ORDER:
                raise InputError(
                    f"online identifier: orders must be integers from 1 to {MAX_ORDER}, got {value!r}"
                )
        if not all(math.isfinite(x) and x > 0.0 for x in (memory_s, speed_scale_mps, thrust_scale_N)):
            raise InputError(
                "online identifier: memory_s, speed_scale_mps and thrust_scale_N must be positive"
            )
        self.order = int(order)
        self.dynamic_order = int(dynamic_order)
        self.memory_s = memory_s
        self.window = window or DynamicWindow()
        self.detector = SteadyStateDetector(criteria)
        self._domain = (0.0, speed_scale_mps)
        self._fscale = thrust_scale_N
        # steady parameters live in the subspace with Fc(0) = 0 when through_origin (columns of _zero)
        at_rest = legendre_design(np.zeros(1), self._domain, self.order)
        self._zero = linalg.null_space(at_rest) if through_origin else np.eye(self.order + 1)
        self._power = power_matrix(self._domain, self.order) @ self._zero
        self._dyn_power = power_matrix(self._domain, self.dynamic_order)
        self._steady = RecursiveLeastSquares(self._zero.shape[1])
        self._dynamic = RecursiveLeastSquares(self.dynamic_order + 2)
        self._buf: deque[tuple[float, float, float]] = deque()
        self._next_end = math.nan
        self._last_t = -math.inf
        self._last_steady_t = math.nan
        self._last_window_t = math.nan
        self.segments: list[SteadySegment] = []
        self.n_samples = 0
        self.n_ignored = 0
        self.windows_skipped = 0

    def _basis(self, speed: np.ndarray) -> np.ndarray:
        return legendre_design(speed, self._domain, self.order)

    def _dyn_basis(self, speed: np.ndarray) -> np.ndarray:
        return legendre_design(speed, self._domain, self.dynamic_order)

    def _forget(self, t_s: float, last: float) -> float:
        return 1.0 if math.isnan(last) else math.exp(-(t_s - last) / self.memory_s)

    def _add_segment(self, seg: SteadySegment) -> None:
        self.segments.append(seg)
        if seg.accepted:
            lam = self._forget(seg.end_s, self._last_steady_t)
            x = self._basis(np.array([seg.speed_mps]))[0] @ self._zero
            self._steady.update(x, seg.thrust_N / self._fscale, lam)
            self._last_steady_t = seg.end_s

    def _add_window(self, t_s: float) -> None:
        t, f, v = (np.array(a) for a in zip(*self._buf, strict=True))
        if t.size < 3 or np.max(np.diff(t)) > self.window.max_gap_s:
            self.windows_skipped += 1
            return
        row, y, _ = window_row(t, f, v, self.window.ramp_s, self._dyn_basis)
        x = np.concatenate(([row[0] / self._domain[1]], row[1:] / self.window.length_s))
        self._dynamic.update(
            x, y / (self._fscale * self.window.length_s), self._forget(t_s, self._last_window_t)
        )
        self._last_window_t = t_s

    def update(self, t_s: float, thrust_N: float, speed_mps: float) -> SteadySegment | None:
        """Feed one sample (s, total thrust N, speed m/s); returns the constant-thrust segment it closed."""
        if (
            not (math.isfinite(t_s) and math.isfinite(thrust_N) and math.isfinite(speed_mps))
            or t_s <= self._last_t
        ):
            self.n_ignored += 1
            return None
        self._last_t = t_s
        self.n_samples += 1
        seg = self.detector.update(t_s, thrust_N, speed_mps)
        if seg is not None:
            self._add_segment(seg)
        if math.isnan(self._next_end):
            self._next_end = t_s + self.window.length_s
        self._buf.append((t_s, thrust_N, speed_mps))
        while self._buf[0][0] < t_s - self.window.length_s - EDGE_TOLERANCE_S:
            self._buf.popleft()
        if t_s >= self._next_end - EDGE_TOLERANCE_S:
            self._add_window(t_s)
            self._next_end = t_s + self.window.stride_s
        return seg

    def finish(self) -> SteadySegment | None:
        """Close the current constant-thrust segment (end of a bag or shutdown); returns it if any."""
        seg = self.detector.finish()
        if seg is not None:
            self._add_segment(seg)
        return seg

    @property
    def steady_points(self) -> list[SteadySegment]:
        """Accepted segments so far."""
        return [s for s in self.segments if s.accepted]

    def resistance(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Steady-curve c_0..c_N in N/(m/s)^i and their standard errors; None before N + 2 steady points."""
        if len(self.steady_points) < self.order + 2:
            return None
        coef = self._power @ self._steady.theta * self._fscale
        cov = self._power @ self._steady.covariance @ self._power.T * self._fscale**2
        return coef, np.sqrt(np.clip(np.diag(cov), 0.0, None))

    def dynamic(self) -> dict[str, Any] | None:
        """Mass (kg) and Fc c_0..c_N (N/(m/s)^i) from the transient windows, standard errors; None early."""
        if self._dynamic.n_updates < self.dynamic_order + 3:
            return None
        to_mass = self._fscale * self.window.length_s / self._domain[1]
        theta = self._dynamic.theta
        cov = self._dynamic.covariance
        coef = self._dyn_power @ theta[1:] * self._fscale
        cov_c = self._dyn_power @ cov[1:, 1:] @ self._dyn_power.T * self._fscale**2
        return {
            "mass_kg": float(theta[0] * to_mass),
            "mass_stderr_kg": float(np.sqrt(max(cov[0, 0], 0.0)) * to_mass),
            "coefficients": coef.tolist(),
            "stderr": np.sqrt(np.clip(np.diag(cov_c), 0.0, None)).tolist(),
            "n_windows": self._dynamic.n_updates,
        }

    def snapshot(self) -> dict[str, Any]:
        """JSON-ready state: what the node publishes and replay reports (SI)."""
        res = self.resistance()
        return {
            "order": self.order,
            "dynamic_order": self.dynamic_order,
            "memory_s": self.memory_s,
            "n_samples": self.n_samples,
            "n_ignored_samples": self.n_ignored,
            "steady_points": len(self.steady_points),
            "rejected_segments": len(self.segments) - len(self.steady_points),
            "coefficients": None if res is None else res[0].tolist(),
            "stderr": None if res is None else res[1].tolist(),
            "dynamic": self.dynamic(),
            "windows_skipped": self.windows_skipped,
        }
