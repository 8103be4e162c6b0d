"""Online adaptation of the twin's surge model: re-identified over a moving horizon, adopted only when it predicts
held-out recent data better (a hot swap, logged, reversible).

Model: m₁₁·du/dt = X − k·Fc₀(u), the twin's own resistance curve Fc₀ (the configured boat's) scaled by k, and
the effective surge mass m₁₁ = (1 + surge added-mass ratio)·mass; X is the surge force besides resistance that
the caller computes (:class:`~boat_twin.shadow.session.Shadow`: the delivered thrust along the hull at the
outboards' real angles plus the sway-yaw coupling m₂₂·v·r of the twin's state, which in a turn is as large as
a resistance error). :func:`fit_surge` is the one
identification the adaptation calls (swap it for another fit of (mass, resistance) and nothing else changes):
it solves the windowed equations of :mod:`boat_twin.ident.dynamic` (modulating functions: speed is averaged
over each window's ramps, never differentiated) with Fc₀ as the only resistance regressor, by least squares,
with the covariance that gives the 95 % intervals. A horizon whose speed barely changes does not fix the mass
(interval wider than :data:`MAX_MASS_REL_STDERR`): k alone is fitted, the mass kept.

Adoption (:class:`SurgeAdapter`): every ``period_s``, the candidate is fitted on the horizon without its last
``holdout_s``, and a score given by the caller says how well a model predicts those held-out seconds (the
session replays them through the whole 3-DOF twin and its sensor models, open loop in windows started from the
measurements, as the diagnosis does: :func:`boat_twin.twin.replay.predict`). The candidate replaces the
current model only when its held-out error is below (1 − :data:`ADOPT_MARGIN`) × the current one's; the
previous model is kept, and reinstated when it predicts the newest held-out data better by the same margin.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy import stats

from boat_twin.ident.dynamic import DynamicWindow, window_bounds, window_row
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.resistance import CorrectedResistance, ResistanceModel

ADOPT_MARGIN = 0.05
"""A model replaces another only if its held-out mean squared error is this share lower."""
MAX_MASS_REL_STDERR = 0.1
"""Above this relative standard error the horizon does not fix the mass: k alone is fitted."""
FACTOR_RANGE = (0.3, 3.0)
"""Physical range of the mass and resistance factors relative to the configured boat, -: a fit outside is a
stand-in for something else (a current, a fault) and is not adopted."""


@dataclass(frozen=True)
class SurgeModel:
    """The twin's surge model: mass and resistance factor on the configured boat, with 95 % intervals."""

    mass_kg: float
    """Displacement mass (VesselParams.mass_kg), kg."""
    resistance_factor: float
    """k: the resistance is k × the configured boat's Fc₀(u), -."""
    mass_ci95_kg: tuple[float, float] = (math.nan, math.nan)
    factor_ci95: tuple[float, float] = (math.nan, math.nan)
    windows: int = 0
    """Windows the fit used (0: the configured model, not fitted)."""

    def vessel(self, base: VesselParams) -> VesselParams:
        """``base`` with this mass and its resistance scaled by k."""
        top = base.resistance.max_speed_mps
        scaled: ResistanceModel = CorrectedResistance(base.resistance, (0.0, top),
                                                      (self.resistance_factor, self.resistance_factor))
        return replace(base, mass_kg=self.mass_kg, resistance=scaled)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (SI)."""
        return {"mass_kg": float(self.mass_kg), "mass_ci95_kg": [float(x) for x in self.mass_ci95_kg],
                "resistance_factor": float(self.resistance_factor),
                "resistance_factor_ci95": [float(x) for x in self.factor_ci95], "windows": self.windows}


def fit_surge(t_s: np.ndarray, force_N: np.ndarray, surge_mps: np.ndarray, base: VesselParams,
              current: SurgeModel, window: DynamicWindow | None = None) -> SurgeModel | None:
    """(mass, k) from samples of time (s, increasing), surge force X (N) and surge through the water (m/s);
    None when fewer than 4 windows fit. ``current`` gives the mass kept when the data do not fix it."""
    window = window or DynamicWindow()
    bounds, _ = window_bounds(t_s, window)
    if len(bounds) < 4:
        return None
    fc0 = base.resistance.force_N

    def basis(speed: np.ndarray) -> np.ndarray:
        return np.asarray(fc0(speed), dtype=float)[:, None]

    rows, rhs = [], []
    for start, stop in bounds:
        row, right, _ = window_row(t_s[start:stop], force_N[start:stop], surge_mps[start:stop], window.ramp_s,
                                   basis)
        rows.append(row)
        rhs.append(right)
    x, y = np.array(rows), np.array(rhs)
    added = 1.0 + base.surge_added_mass_ratio
    theta, cov = _least_squares(x, y)
    if theta is not None and math.sqrt(max(cov[0, 0], 0.0)) <= MAX_MASS_REL_STDERR * abs(theta[0]):
        q = float(stats.t.ppf(0.975, max(len(y) - 2, 1)))
        m11, k = float(theta[0]), float(theta[1])
        se_m, se_k = math.sqrt(cov[0, 0]), math.sqrt(max(cov[1, 1], 0.0))
        return SurgeModel(m11 / added, k, ((m11 - q * se_m) / added, (m11 + q * se_m) / added),
                          (k - q * se_k, k + q * se_k), len(y))
    m11 = current.mass_kg * added  # the mass is not fixed by this horizon: keep it, fit k alone
    theta1, cov1 = _least_squares(x[:, 1:], y - m11 * x[:, 0])
    if theta1 is None:
        return None
    q = float(stats.t.ppf(0.975, max(len(y) - 1, 1)))
    k, se_k = float(theta1[0]), math.sqrt(max(cov1[0, 0], 0.0))
    return SurgeModel(current.mass_kg, k, current.mass_ci95_kg, (k - q * se_k, k + q * se_k), len(y))


def _least_squares(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
    """Ordinary least squares: θ and its covariance (residual variance × (XᵀX)⁻¹); None if singular."""
    if len(y) <= x.shape[1]:
        return None, np.zeros((x.shape[1],) * 2)
    theta, _, rank, _ = np.linalg.lstsq(x, y, rcond=None)
    if rank < x.shape[1]:
        return None, np.zeros((x.shape[1],) * 2)
    resid = y - x @ theta
    sigma2 = float(resid @ resid) / (len(y) - x.shape[1])
    return theta, sigma2 * np.linalg.inv(x.T @ x)


Log = Callable[[str], None]
Score = Callable[[SurgeModel], float]
"""A model's error on the held-out tail (lower is better; NaN: cannot be judged)."""


class SurgeAdapter:
    """Collects (t, surge force, surge through water) live and keeps the twin's surge model current."""

    def __init__(self, base: VesselParams, *, horizon_s: float = 600.0, holdout_s: float = 120.0,
                 period_s: float = 30.0, log: Log | None = None) -> None:
        self.base = base
        self.horizon_s, self.holdout_s, self.period_s = horizon_s, holdout_s, period_s
        self.log = log or (lambda _line: None)
        self.current = SurgeModel(base.mass_kg, 1.0)
        self.previous: list[SurgeModel] = []
        """Models replaced, latest last: what :meth:`revert` goes back to."""
        self.candidate: SurgeModel | None = None
        """The latest fit, adopted or not (its intervals are what the fit says now)."""
        self.swaps = 0
        self._samples: deque[tuple[float, float, float]] = deque()
        self._next_s = math.nan

    def add(self, t_s: float, force_N: float, surge_mps: float) -> None:
        """One sample (time increasing; others are ignored)."""
        if not (math.isfinite(force_N) and math.isfinite(surge_mps)):
            return
        if self._samples and t_s <= self._samples[-1][0]:
            return
        self._samples.append((t_s, force_N, surge_mps))
        while self._samples[0][0] < t_s - self.horizon_s:
            self._samples.popleft()
        if math.isnan(self._next_s):
            self._next_s = t_s + self.holdout_s + self.period_s

    def due(self, t_s: float) -> bool:
        """True when an update is due at ``t_s`` (then scheduled ``period_s`` on)."""
        if math.isnan(self._next_s) or t_s < self._next_s:
            return False
        self._next_s = t_s + self.period_s
        return len(self._samples) > 0

    def reset(self) -> None:
        """Forget the samples (a restarted recording); the model is kept."""
        self._samples.clear()
        self._next_s = math.nan

    def _arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t, f, u = (np.array(c) for c in zip(*self._samples, strict=True))
        return t, f, u

    def update(self, score: Score) -> bool:
        """Fit a candidate on the horizon without its held-out tail and adopt it, or revert, if it predicts the
        tail better by ``score``; returns True when the model changed."""
        if len(self._samples) < 10:
            return False
        t, f, u = self._arrays()
        train = t <= t[-1] - self.holdout_s
        if train.sum() < 10:
            return False
        now = score(self.current)
        if not math.isfinite(now):
            return False
        if self.previous:
            before = score(self.previous[-1])
            if before < (1.0 - ADOPT_MARGIN) * now:
                self.revert(f"it predicts the last {self.holdout_s:.0f} s better (velocity RMS "
                            f"{math.sqrt(now):.3f} → {math.sqrt(before):.3f} m/s)")
                return True
        candidate = fit_surge(t[train], f[train], u[train], self.base, self.current)
        self.candidate = candidate
        if candidate is None or not self._physical(candidate):
            return False
        new = score(candidate)
        if not new < (1.0 - ADOPT_MARGIN) * now:
            return False
        self.previous.append(self.current)
        self.current = candidate
        self.swaps += 1
        self.log(f"adopted surge model: mass {candidate.mass_kg:.0f} kg [{candidate.mass_ci95_kg[0]:.0f}, "
                 f"{candidate.mass_ci95_kg[1]:.0f}], resistance ×{candidate.resistance_factor:.3f} "
                 f"[{candidate.factor_ci95[0]:.3f}, {candidate.factor_ci95[1]:.3f}]: held-out velocity RMS "
                 f"{math.sqrt(now):.3f} → {math.sqrt(new):.3f} m/s")
        return True

    def _physical(self, model: SurgeModel) -> bool:
        low, high = FACTOR_RANGE
        mass = model.mass_kg / self.base.mass_kg
        return bool(low <= mass <= high and low <= model.resistance_factor <= high)

    def revert(self, why: str = "asked") -> bool:
        """Go back to the model replaced last (logged); False when there is none."""
        if not self.previous:
            return False
        replaced, self.current = self.current, self.previous.pop()
        self.swaps += 1
        self.log(f"reverted surge model to mass {self.current.mass_kg:.0f} kg, resistance "
                 f"×{self.current.resistance_factor:.3f} (from {replaced.mass_kg:.0f} kg, "
                 f"×{replaced.resistance_factor:.3f}): {why}")
        return True

    def vessel(self) -> VesselParams:
        """The configured boat with the current surge model."""
        return self.current.vessel(self.base)
