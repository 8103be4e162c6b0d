"""The one rule by which the live twin changes a model (surge: :mod:`~boat_twin.shadow.adapt`, turning:
:mod:`~boat_twin.shadow.turning`): a candidate fitted on the recent horizon is adopted only when its covariance
rejects the current model (Hotelling's T²) and it predicts the held-out tail better by a margin; the model
replaced last comes back when it predicts better and the newest fit does not reject it. Updates are scheduled
every ``period_s``, less often while the current model stands."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np
from scipy import stats

REJECT_LEVEL = 0.95
"""Confidence at which the candidate's intervals must reject the current model before it may replace it."""
MAX_WAIT_PERIODS = 4.0
"""While fits keep confirming the current model, the time between updates doubles up to this many periods."""
FACTOR_RANGE = (0.3, 3.0)
"""Physical range of a fitted coefficient relative to the configured boat's, -: a fit outside is a stand-in for
something else (a current, a fault) and is not adopted."""

M = TypeVar("M")
Log = Callable[[str], None]


def hotelling_rejects(diff: np.ndarray, cov: np.ndarray, clusters: int, level: float = REJECT_LEVEL) -> bool:
    """Whether a difference ``diff`` (q,) of a fit's estimates from a model's, with the fit's covariance ``cov``
    (q, q) from ``clusters`` independent clusters, rejects the model at ``level``: Hotelling's T² against its F
    bound, q·(g − 1)/(g − q)·F(q, g − q). False where it cannot be judged (too few clusters, a covariance that
    is not finite or singular)."""
    q, g = diff.size, clusters
    if g <= q + 1 or not np.all(np.isfinite(cov)):
        return False
    try:
        t2 = float(diff @ np.linalg.solve(cov, diff))
    except np.linalg.LinAlgError:
        return False
    return t2 > q * (g - 1) / (g - q) * float(stats.f.ppf(level, q, g - q))


@dataclass(frozen=True)
class Outcome:
    """What one :meth:`Adopter.cycle` did."""

    standing: bool
    """The candidate does not reject the current model (or there is none)."""
    changed: str | None
    """``"adopted"``, ``"reverted"`` or None (the model stays)."""
    score: float
    """The held-out score of the model adopted or reverted to (NaN: none scored)."""


class Adopter(Generic[M]):
    """A live model and the ones it replaced, changed by the module's rule; subclasses say what is physical
    (:meth:`_physical`) and how a model reads in the log (:meth:`_describe`)."""

    def __init__(self, initial: M, *, period_s: float, margin: float, log: Log | None = None) -> None:
        self.current = initial
        self.previous: list[M] = []
        """Models replaced, latest last: what :meth:`revert` goes back to."""
        self.candidate: M | None = None
        """The latest fit, adopted or not."""
        self.swaps = 0
        self.period_s = period_s
        self.margin = margin
        """A model replaces another only if its held-out error is this share lower, -."""
        self.log = log or (lambda _line: None)
        self.wait_s = period_s
        """Time to the next update, s: ``period_s``, doubled while the current model stands up to
        :data:`MAX_WAIT_PERIODS` × ``period_s`` (fewer refits)."""
        self._next_s = math.nan

    def _scheduled(self, t_s: float) -> bool:
        """True when an update is due at ``t_s`` (then scheduled :attr:`wait_s` on); none before a first time."""
        if math.isnan(self._next_s) or t_s < self._next_s:
            return False
        self._next_s = t_s + self.wait_s
        return True

    def reset(self) -> None:
        """A restarted stream: the schedule starts again; the model is kept."""
        self._next_s = math.nan
        self.wait_s = self.period_s

    def back_off(self) -> None:
        """Double the time to the next update, up to :data:`MAX_WAIT_PERIODS` periods."""
        self.wait_s = min(2.0 * self.wait_s, MAX_WAIT_PERIODS * self.period_s)

    def cycle(self, candidate: M | None, now: float, score: Callable[[M], float], *,
              rejects: Callable[[M, M], bool], margin: float, revert_why: Callable[[float, float], str]) -> Outcome:
        """One update: revert to the model replaced last if it scores below ``(1 − margin) × now`` and
        ``candidate`` does not reject it (``revert_why(now, before)`` says why in the log); else adopt a
        ``candidate`` that rejects the current model, is physical and scores below ``(1 − margin) × now``
        (``margin``: this adoption's; :attr:`margin` is the revert's). ``now``: the current model's score;
        ``rejects(fit, model)``: whether the fit's covariance rejects the model."""
        standing = candidate is None or not rejects(candidate, self.current)
        if self.previous and (candidate is None or not rejects(candidate, self.previous[-1])):
            before = score(self.previous[-1])
            if before < (1.0 - self.margin) * now:
                self.revert(revert_why(now, before))
                return Outcome(standing, "reverted", before)
        if candidate is None or standing or not self._physical(candidate):
            return Outcome(standing, None, math.nan)
        new = score(candidate)
        if not new < (1.0 - margin) * now:
            return Outcome(standing, None, math.nan)
        self.previous.append(self.current)
        self.current = candidate
        self.swaps += 1
        return Outcome(standing, "adopted", new)

    def revert(self, why: str = "asked") -> bool:
        """Go back to the model replaced last (logged); False when there is none."""
        if not self.previous:
            return False
        replaced, self.current = self.current, self.previous.pop()
        self.swaps += 1
        self.log(f"{self._describe(self.current, replaced)}: {why}")
        return True

    def _physical(self, model: M) -> bool:
        """Whether ``model`` may be adopted at all (within :data:`FACTOR_RANGE` of the configured boat)."""
        raise NotImplementedError

    def _describe(self, back_to: M, replaced: M) -> str:
        """The log line of a revert from ``replaced`` to ``back_to`` (without its reason)."""
        raise NotImplementedError
