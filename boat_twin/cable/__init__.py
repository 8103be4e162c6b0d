"""Towed vehicle on a flexible cable in a depth-varying current (Babanin & Melkonyan 2025), as a library.

Problem 1 :func:`solve_depth` (cable length -> vehicle depth and shape), problem 2 :func:`solve_length`
(vehicle depth -> cable length), the boat's tow load :func:`tow_load`, the continuous ODE reference and the
convergence study. Cases come from YAML (:func:`load_case`); everything is SI inside.
"""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "CableCase": "boat_twin.cable.case",
    "CableSolution": "boat_twin.cable.problems",
    "CableSolveError": "boat_twin.cable.errors",
    "TowLoad": "boat_twin.cable.problems",
    "case_from_dict": "boat_twin.cable.case",
    "continuous_depth": "boat_twin.cable.continuous",
    "continuous_length": "boat_twin.cable.continuous",
    "convergence_study": "boat_twin.cable.convergence",
    "load_case": "boat_twin.cable.case",
    "solve_depth": "boat_twin.cable.problems",
    "solve_length": "boat_twin.cable.problems",
    "tow_load": "boat_twin.cable.problems",
    "tow_speed_for_depth": "boat_twin.cable.problems",
    "with_overrides": "boat_twin.cable.case",
}
"""Public name → its module, imported on first use: one problem does not load the others' solvers (the ODE
reference loads scipy.integrate)."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
