"""Bounded least squares over residual rows computed part by part, without ever holding the Jacobian.

``scipy.optimize.least_squares`` (trust region reflective) needs of a residual vector f and its Jacobian J only
fᵀf, Jᵀf and JᵀJ (the singular values and right vectors of J, and Uᵀf). The triangular factor R of [f J]
(QR, folded part by part: each part's rows are stacked under the R so far and factored again, as a tall-skinny
QR) holds all three: with f̃ = (‖f‖, 0, …, 0) and J̃ = R's columns after the first, f̃ᵀf̃ = fᵀf, J̃ᵀf̃ = Jᵀf and
J̃ᵀJ̃ = JᵀJ (so J's column norms too: ``x_scale="jac"``). The solver is handed f̃ and J̃ ((n + 1) rows): the same
iterates as with the whole vectors, up to rounding, while the memory is one part's rows, not the (rows × n)
Jacobian that ``least_squares`` copies about five times (on a 6-hour trial 43 MB a copy for a five-parameter
fit). The diagnosis' fits (finite differences, :mod:`boat_twin.diagnose.search`) and the output-error surge fit
(analytic sensitivities, :mod:`boat_twin.ident.output_error`) share it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np
from scipy.optimize import OptimizeResult, least_squares


class TriangleFold:
    """The triangular factor R of the rows [f_i, J_i] stacked so far (their order does not matter)."""

    def __init__(self, columns: int) -> None:
        self.r = np.zeros((0, columns))

    def add(self, rows: np.ndarray) -> None:
        """Stack ``rows`` (k × columns) under the rows so far."""
        self.r = cast(np.ndarray, np.linalg.qr(np.vstack([self.r, rows]), mode="r"))  # mode "r": R alone

    def square(self) -> np.ndarray:
        """R as (columns × columns), zero rows below the rows stacked, its first diagonal element ‖f‖ ≥ 0."""
        columns = self.r.shape[1]
        out = np.zeros((columns, columns))
        out[: self.r.shape[0]] = self.r[:columns]
        if out[0, 0] < 0.0:
            out[0] *= -1.0
        return out


def folded_least_squares(norm: Callable[[np.ndarray], float], triangle: Callable[[np.ndarray], np.ndarray],
                         x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, **options: Any) -> OptimizeResult:
    """``least_squares(method="trf")`` from ``x0`` within [``lower``, ``upper``] on the residual whose norm at x
    is ``norm(x)`` (nan: a failed evaluation, which the solver steps back from) and whose [f J]'s triangle at x
    is ``triangle(x)`` (:meth:`TriangleFold.square`; asked only at points whose norm was asked). ``options``: the
    rest of ``least_squares``' (max_nfev, xtol, ftol, x_scale, …). The result's ``fun`` and ``jac`` are f̃ and J̃."""
    size = np.asarray(x0).size

    def fun(x: np.ndarray) -> np.ndarray:
        out = np.zeros(size + 1)
        out[0] = norm(x)
        return out if np.isfinite(out[0]) else np.full(size + 1, np.nan)

    def jac(x: np.ndarray) -> np.ndarray:
        return triangle(x)[:, 1:]

    return least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", **options)
