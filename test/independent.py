"""A plain RK4 integrator for the tests' independent boats: written apart from the twin's numba kernel, so the
analyses are also checked on data whose equations and integration the package did not make."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def rk4_held(deriv: Callable[[np.ndarray, float], np.ndarray], state: np.ndarray, commands: np.ndarray,
             h: float, substeps: int) -> np.ndarray:
    """Integrate ``deriv(state, command)`` with classic RK4 steps of ``h``, each command held for ``substeps``
    steps; returns the state at the start of every command, shape (len(commands), len(state))."""
    rows = np.empty((len(commands), state.size))
    for i, u in enumerate(commands):
        rows[i] = state
        for _ in range(substeps):
            k1 = deriv(state, u)
            k2 = deriv(state + h / 2 * k1, u)
            k3 = deriv(state + h / 2 * k2, u)
            k4 = deriv(state + h * k3, u)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return rows
