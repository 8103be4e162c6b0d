"""Bounded least squares over residuals computed part by part, without ever holding the Jacobian.

``scipy.optimize.least_squares`` (trust region reflective) needs of a residual vector f and its Jacobian J only
fᵀf, Jᵀf and JᵀJ (the singular values and right vectors of J, and Uᵀf). The triangular factor R of [f J]
(QR, built part by part: each part's rows are stacked under the R so far and factored again, as a tall-skinny QR)
holds all three: with f̃ = (‖f‖, 0, …, 0) and J̃ = R's columns after the first, f̃ᵀf̃ = fᵀf, J̃ᵀf̃ = Jᵀf and J̃ᵀJ̃ = JᵀJ.
So the solver is handed f̃ and J̃ ((n + 1) rows): the same iterates as with the whole vectors, up to rounding,
while the memory is one part's rows, not the (rows × n) Jacobian that ``least_squares`` copied about five times
(on a 6-hour trial 43 MB a copy for a five-parameter fit). The Jacobian's forward differences use
``least_squares``' own steps (``diff_step`` relative, turned back at a bound), each part of every shifted point
replayed in turn: the same replays as its ``'2-point'`` Jacobian, in another order.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numpy as np
from scipy.optimize import least_squares

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
    """The residual and Jacobian ``least_squares`` sees: f̃ and J̃ of the module docstring. Keeps the parts of the
    residual at the last point evaluated (the Jacobian's base: ``least_squares`` asks the Jacobian only there)."""

    def __init__(self, residual: Residual, parts: int, diff_step: float, lower: np.ndarray,
                 upper: np.ndarray, evaluated: Callable[[], None]) -> None:
        self.residual, self.parts, self.diff_step = residual, parts, diff_step
        self.lower, self.upper, self.evaluated = lower, upper, evaluated
        self.x = np.full(lower.size, np.nan)
        self.f: list[np.ndarray] = []

    def fun(self, x: np.ndarray) -> np.ndarray:
        self.x = np.array(x, dtype=float)
        at = self.residual(self.x)
        self.f = [at(k) for k in range(self.parts)]
        self.evaluated()
        out = np.zeros(x.size + 1)
        out[0] = np.sqrt(sum(float(np.dot(part, part)) for part in self.f))
        return out

    def jac(self, x: np.ndarray) -> np.ndarray:
        if not np.array_equal(x, self.x):
            self.fun(x)
        n = x.size
        h = forward_steps(self.x, self.diff_step, self.lower, self.upper)
        shifted = [self.x.copy() for _ in range(n)]
        for j in range(n):
            shifted[j][j] += h[j]
        dx = np.array([shifted[j][j] - self.x[j] for j in range(n)])
        at = [self.residual(point) for point in shifted]
        r: np.ndarray = np.zeros((0, n + 1))
        for k, base in enumerate(self.f):
            block = np.empty((base.size, n + 1))
            block[:, 0] = base
            for j in range(n):
                block[:, j + 1] = (at[j](k) - base) / dx[j]
            r = cast(np.ndarray, np.linalg.qr(np.vstack([r, block]), mode="r"))  # mode "r": R alone
        for _ in range(n):
            self.evaluated()
        out = np.zeros((n + 1, n + 1))
        out[:r.shape[0]] = r
        if out[0, 0] < 0.0:
            out[0] *= -1.0
        return out[:, 1:]


def streamed_least_squares(residual: Residual, parts: int, x0: np.ndarray, lower: np.ndarray,
                           upper: np.ndarray, evaluated: Callable[[], None], **options: float) -> np.ndarray:
    """The parameters ``least_squares(method="trf")`` finds from ``x0`` within [``lower``, ``upper``] for the
    residual made of ``parts`` parts (``residual``), with forward differences of relative step
    ``options["diff_step"]``; ``evaluated`` is called once per whole residual computed. ``options``: the rest
    of ``least_squares``' (max_nfev, xtol, ftol, x_scale)."""
    options = dict(options)
    problem = _Compressed(residual, parts, options.pop("diff_step"), lower, upper, evaluated)
    result = least_squares(problem.fun, x0, jac=problem.jac, bounds=(lower, upper), method="trf", **options)
    return result.x
