"""Steady-state criteria sized from the trial itself: any boat, any sensor, not only the 6 m catamaran.

The detector (:mod:`boat_twin.ident.online`) needs a test window and a thrust tolerance. Both follow from what
the recording shows:

- **Thrust tolerance.** Clean commands are piecewise constant: every change between samples is a new level,
  and the tolerance is half the smallest change seen, so two levels 1 N apart stay apart. Noisy commands
  (thrust reconstructed from PWM or RPM, which jitter while held) change on most samples: the tolerance is
  then 4 robust standard deviations of that jitter (4·1.4826·median|ΔF|/√2), at least the smallest change
  (the command's resolution), so a hold stays one segment.
- **Surge time constant τ.** After a thrust step the speed approaches its new level v_f as
  dv/dt ≈ (v_f − v)/τ, with τ = m/(dFc/dv) near v_f. τ is the least-squares slope of the central-difference
  acceleration on (v_f − v) over every constant-thrust segment (v_f: the mean of the segment's last quarter);
  the noise variance is subtracted from Σ(v_f − v)², which it would otherwise inflate. A central difference
  does not contain the sample it is paired with, so noise does not bias the numerator.
- **Window.** A tail of length L over an approach still e^{-1} away shows a drift of 0.63 of the remaining
  gap, so with L ≥ τ a tail that passes the drift test is biased by at most ~1.6 drift bounds; and the drift
  test's noise term, t₀.₉₇₅(n − 2)·σ·√(12/n) for n = L·rate samples, may use at most half the drift bound
  (about L ≥ 12·(4σ/bound)²/rate). The window is the larger of the two, and at least 10 samples. With the
  catamaran's GNSS (σ = 0.05 m/s, 10 Hz, bound 0.05 m/s) the noise term alone gives 18.6 s, close to the
  20 s the fixed window had; a 15 kg boat with a 0.02 m/s speed noise gets about 3 s.

σ is the white-noise standard deviation of speed from its second differences
(:func:`boat_twin.signal_noise.white_noise_stdev`). A speed smoothed from positions has noise correlated over the
smoother's window: σ is then the smoother's own statement (or the second differences of samples one window apart),
the noise rule counts one independent sample per window, and so does the detector
(``SteadyCriteria.noise_correlation_s``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy import stats

from boat_twin.ident.online import SteadyCriteria
from boat_twin.signal_noise import white_noise_stdev

MIN_WINDOW_SAMPLES = 10
"""The test window holds at least this many samples (a line fit on fewer says little about a trend)."""
NOISY_COMMAND_SHARE = 0.5
"""Commands that change on more than this share of samples are noisy (jitter while held), not stepped."""
JITTER_SIGMAS = 4.0
"""Thrust tolerance of noisy commands: this many robust standard deviations of their sample-to-sample jitter."""
NOISE_SHARE = 0.5
"""Share of the drift bound the drift test's noise term may use on the shortest tail."""


@dataclass(frozen=True)
class DerivedCriteria:
    """Steady-state criteria derived from a trial, with the figures they came from (SI)."""

    criteria: SteadyCriteria
    time_constant_s: float | None
    """Surge time constant τ seen in the step responses, s (None: no step response to measure)."""
    speed_noise_mps: float
    """White-noise standard deviation of the speed, m/s."""
    sample_rate_hz: float
    """Median sample rate, Hz."""
    command_resolution_N: float
    """Smallest non-zero change of thrust between samples, N."""
    thrust_jitter_N: float | None
    """Robust standard deviation of the thrust's sample-to-sample jitter while held (None: stepped commands), N."""
    given: tuple[str, ...] = ()
    """Settings given by the user (not derived)."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the ``steady_criteria`` entry of ``boat-twin identify --json``)."""
        return {
            "window_s": self.criteria.window_s,
            "thrust_tolerance_N": self.criteria.thrust_tolerance_N,
            "thrust_tolerance_rel": self.criteria.thrust_tolerance_rel,
            "max_drift_mps": self.criteria.max_drift_mps,
            "time_constant_s": self.time_constant_s,
            "speed_noise_mps": self.speed_noise_mps,
            "sample_rate_hz": self.sample_rate_hz,
            "command_resolution_N": self.command_resolution_N,
            "thrust_jitter_N": self.thrust_jitter_N,
            "given": list(self.given),
        }

    def summary(self) -> str:
        """One line: the window and tolerance and where they came from."""
        tau = f"surge time constant {self.time_constant_s:.1f} s" if self.time_constant_s is not None \
            else "no step response to time"
        return (f"steady window {self.criteria.window_s:.3g} s, thrust tolerance "
                f"{self.criteria.thrust_tolerance_N:.3g} N ({tau}, speed noise {self.speed_noise_mps:.3f} m/s "
                f"at {self.sample_rate_hz:.3g} Hz" + (f"; given: {', '.join(self.given)}" if self.given else "")
                + ")")


def thrust_tolerance(thrust_pieces: list[np.ndarray]) -> tuple[float, float, float | None]:
    """Tolerance (N), resolution (N) and jitter (N, None for stepped commands) of the thrust (see module doc)."""
    steps = np.concatenate([np.abs(np.diff(f)) for f in thrust_pieces])
    scale = max((float(np.max(np.abs(f))) for f in thrust_pieces if f.size), default=0.0)
    moved = steps[steps > 1e-9 * max(scale, 1.0)]
    if moved.size == 0:
        return 1e-9 * max(scale, 1.0), 0.0, None
    resolution = float(np.min(moved))
    if moved.size > NOISY_COMMAND_SHARE * steps.size:
        jitter = 1.4826 * float(np.median(steps)) / math.sqrt(2.0)
        return max(JITTER_SIGMAS * jitter, resolution), resolution, jitter
    return 0.5 * resolution, resolution, None


def _segments(f: np.ndarray, tolerance_N: float, rel: float) -> list[slice]:
    """Constant-thrust runs, split as the detector splits them (against the run's first value)."""
    runs, start = [], 0
    for i in range(1, f.size):
        if abs(f[i] - f[start]) > max(tolerance_N, rel * abs(f[start])):
            runs.append(slice(start, i))
            start = i
    runs.append(slice(start, f.size))
    return runs


def time_constant(pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]], tolerance_N: float, rel: float,
                  noise_mps: float) -> float | None:
    """τ from the approach to each segment's final speed (see the module docstring); None when not measurable."""
    num = den = 0.0
    count = 0
    for t, f, v in pieces:
        for run in _segments(f, tolerance_N, rel):
            ts, vs = t[run], v[run]
            if ts.size < 8:
                continue
            final = float(np.mean(vs[-max(2, ts.size // 4):]))
            accel = (vs[2:] - vs[:-2]) / (ts[2:] - ts[:-2])
            gap = final - vs[1:-1]
            num += float(accel @ gap)
            den += float(gap @ gap) - gap.size * noise_mps**2
            count += gap.size
    if count == 0 or den <= 0.0 or num <= 0.0:
        return None
    return den / num


def noise_samples(sigma: float, budget: float) -> int:
    """Fewest independent samples n for which the drift test's noise term t₀.₉₇₅(n − 2)·σ·√(12/n) (the 95 %
    bound of a fitted trend times the tail length) stays within ``budget`` (same unit as ``sigma``)."""
    n = 4
    while stats.t.ppf(0.975, n - 2) * sigma * math.sqrt(12.0 / n) > budget:
        n = n + 1 if n < 64 else int(n * 1.1)
    return n


def derive_criteria(pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                    base: SteadyCriteria | None = None, *, window_s: float | None = None,
                    thrust_tolerance_N: float | None = None, noise_correlation_s: float = 0.0,
                    speed_noise_mps: float | None = None) -> DerivedCriteria:
    """Criteria for one or more recordings ``pieces`` of (t s, thrust N, speed m/s); ``window_s`` and
    ``thrust_tolerance_N`` given override the derived values. ``noise_correlation_s``: the speed's noise is
    correlated over this long (a speed smoothed from positions): its σ is then estimated from samples this far
    apart (unless ``speed_noise_mps`` states it), and the noise rule counts one independent sample per this much
    time. Other settings: ``base``."""
    base = base or SteadyCriteria()
    rate = float(np.median(np.concatenate([1.0 / np.diff(t) for t, _, _ in pieces if t.size > 1])))
    stride = max(1, int(round(noise_correlation_s * rate)))
    noise = [white_noise_stdev(v[::stride]) for _, _, v in pieces if v.size > 3 * stride]
    sigma = float(np.nanmedian(noise)) if noise and np.any(np.isfinite(noise)) else 0.0
    if speed_noise_mps is not None:
        sigma = speed_noise_mps
    tolerance, resolution, jitter = thrust_tolerance([f for _, f, _ in pieces])
    if thrust_tolerance_N is not None:
        tolerance = thrust_tolerance_N
    tau = time_constant(pieces, tolerance, base.thrust_tolerance_rel, sigma)
    window = max(tau or 0.0, noise_samples(sigma, NOISE_SHARE * base.max_drift_mps) * stride / rate,
                 MIN_WINDOW_SAMPLES / rate)
    if window_s is not None:
        window = window_s
    given = tuple(name for name, value in (("window", window_s), ("thrust tolerance", thrust_tolerance_N))
                  if value is not None)
    criteria = replace(base, window_s=float(window), thrust_tolerance_N=float(tolerance),
                       max_segment_s=max(base.max_segment_s, float(window)), noise_correlation_s=noise_correlation_s)
    return DerivedCriteria(criteria, tau, sigma, rate, resolution, jitter, given)
