"""Towed vehicle on a flexible cable in a depth-varying current (Babanin & Melkonyan 2025), as a library.

Problem 1 :func:`solve_depth` (cable length -> vehicle depth and shape), problem 2 :func:`solve_length`
(vehicle depth -> cable length), the boat's tow load :func:`tow_load`, the continuous ODE reference and the
convergence study. Cases come from YAML (:func:`load_case`); everything is SI inside.
"""

from boat_twin.cable.case import CableCase, case_from_dict, load_case, with_overrides
from boat_twin.cable.continuous import continuous_depth, continuous_length
from boat_twin.cable.convergence import convergence_study
from boat_twin.cable.errors import CableSolveError
from boat_twin.cable.problems import (
    CableSolution,
    TowLoad,
    solve_depth,
    solve_length,
    tow_load,
    tow_speed_for_depth,
)

__all__ = [
    "CableCase",
    "CableSolution",
    "CableSolveError",
    "TowLoad",
    "case_from_dict",
    "continuous_depth",
    "continuous_length",
    "convergence_study",
    "load_case",
    "solve_depth",
    "solve_length",
    "tow_load",
    "tow_speed_for_depth",
    "with_overrides",
]
