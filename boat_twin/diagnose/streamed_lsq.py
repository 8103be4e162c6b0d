"""The diagnosis' bounded least squares by forward differences over residuals computed part by part (window
groups), never holding the Jacobian: the triangle of [f J] folded part by part (:mod:`boat_twin.folded_lsq`) is
what ``least_squares`` sees. The Jacobian's forward differences use ``least_squares``' own steps (``diff_step``
relative, turned back at a bound), each part of every shifted point replayed in turn: the same replays as its
``'2-point'`` Jacobian, in another order.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from boat_twin.folded_lsq import TriangleFold, folded_least_squares

FORWARD_EPS = float(np.sqrt(np.finfo(float).eps))
"""The forward-difference step where the relative one vanishes (x = 0), as ``least_squares``' ``'2-point'``."""

Residual = Callable[[np.ndarray], Callable[[int], np.ndarray]]
"""parameters → (part index → that part's residuals, 1-D and finite)."""


def forward_steps(x: np.ndarray, diff_step: float, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The forward-difference steps ``least_squares`` takes at ``x`` with a relative ``diff_step``: of ``x``'s
    sign (+ at 0), ``diff_step``·|x| (:data:`FORWARD_EPS`·max(1, |x|) where that does not move x), reversed where
    it would leave the bounds and the step fits on the other side, else the room to the farther bound."""
    sign = (x >= 0).astype(float) * 2 - 1
    h = diff_step * sign * np.abs(x)
    h = np.where((x + h) - x == 0, FORWARD_EPS * sign * np.maximum(1.0, np.abs(x)), h)
    below, above = x - lower, upper - x
    fitting = np.abs(h) <= np.maximum(below, above)
    h[((x + h < lower) | (x + h > upper)) & fitting] *= -1
    h = np.where(~fitting & (above >= below), above, h)
    return np.where(~fitting & (above < below), -below, h)


class _Compressed:
    """The residual's norm and the triangle of [f J] (:mod:`boat_twin.folded_lsq`). Keeps the parts of the
    residual at the last point evaluated (the Jacobian's base: ``least_squares`` asks the Jacobian only there)."""

    def __init__(self, residual: Residual, parts: int, diff_step: float, lower: np.ndarray,
                 upper: np.ndarray, evaluated: Callable[[], None]) -> None:
        self.residual, self.parts, self.diff_step = residual, parts, diff_step
        self.lower, self.upper, self.evaluated = lower, upper, evaluated
        self.x = np.full(lower.size, np.nan)
        self.f: list[np.ndarray] = []

    def norm(self, x: np.ndarray) -> float:
        self.x = np.array(x, dtype=float)
        at = self.residual(self.x)
        self.f = [at(k) for k in range(self.parts)]
        self.evaluated()
        return float(np.sqrt(sum(float(np.dot(part, part)) for part in self.f)))

    def triangle(self, x: np.ndarray) -> np.ndarray:
        if not np.array_equal(x, self.x):
            self.norm(x)
        n = x.size
        h = forward_steps(self.x, self.diff_step, self.lower, self.upper)
        shifted = [self.x.copy() for _ in range(n)]
        for j in range(n):
            shifted[j][j] += h[j]
        dx = np.array([shifted[j][j] - self.x[j] for j in range(n)])
        at = [self.residual(point) for point in shifted]
        fold = TriangleFold(n + 1)
        for k, base in enumerate(self.f):
            block = np.empty((base.size, n + 1))
            block[:, 0] = base
            for j in range(n):
                block[:, j + 1] = (at[j](k) - base) / dx[j]
            fold.add(block)
        for _ in range(n):
            self.evaluated()
        return fold.square()


def streamed_least_squares(residual: Residual, parts: int, x0: np.ndarray, lower: np.ndarray,
                           upper: np.ndarray, evaluated: Callable[[], None], **options: float) -> np.ndarray:
    """The parameters ``least_squares(method="trf")`` finds from ``x0`` within [``lower``, ``upper``] for the
    residual made of ``parts`` parts (``residual``), with forward differences of relative step
    ``options["diff_step"]``; ``evaluated`` is called once per whole residual computed. ``options``: the rest
    of ``least_squares``' (max_nfev, xtol, ftol, x_scale)."""
    options = dict(options)
    problem = _Compressed(residual, parts, options.pop("diff_step"), lower, upper, evaluated)
    return folded_least_squares(problem.norm, problem.triangle, x0, lower, upper, **options).x
