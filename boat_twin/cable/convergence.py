"""Convergence of the lumped-link model toward the continuous ODE as the link length l shrinks.

The paper (Fig. 5) compares l = 5, 2.5, 1.25, 0.625 m by eye; here each l is measured against the ODE
reference: problem 1 (vehicle depth for the reference length) and problem 2 (length for the reference depth).
The observed order between successive l is p = ln(e₁/e₂)/ln(l₁/l₂); from the two finest links the error law
e = C·l^p gives the l for a requested relative depth accuracy, which is then checked by a run at that l
(and shrunk by the same law until the check passes).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

from boat_twin.cable.case import CableCase, with_overrides
from boat_twin.cable.continuous import continuous_depth, continuous_length
from boat_twin.cable.problems import solve_depth, solve_length
from boat_twin.errors import InputError

PAPER_SEGMENTS_M = (5.0, 2.5, 1.25, 0.625)
"""The link lengths of the paper's Fig. 5, m."""

_MAX_CHECKS = 5
"""Runs that check (and if needed shrink) the estimated l until the depth error is within the tolerance."""


@dataclass(frozen=True)
class ConvergenceRow:
    """One link length: problem 1 depth and problem 2 length, with their errors against the ODE (m)."""

    segment_length_m: float
    links: int
    vehicle_depth_m: float
    depth_error_m: float
    length_m: float
    length_error_m: float
    depth_order: float | None
    length_order: float | None


@dataclass(frozen=True)
class ConvergenceStudy:
    """The study; ``segment_for_tolerance_m`` is an l found (by the error law, then checked) to reach
    ``tolerance`` in relative depth, ``check_depth_error_m`` the depth error measured with it."""

    case_name: str
    drag_model: str
    reference_length_m: float
    reference_depth_m: float
    rows: tuple[ConvergenceRow, ...]
    tolerance: float
    segment_for_tolerance_m: float | None
    check_depth_error_m: float | None

    @property
    def depth_order(self) -> float | None:
        """Observed order of the depth error from the two finest links."""
        return self.rows[-1].depth_order

    @property
    def length_order(self) -> float | None:
        """Observed order of the length error from the two finest links."""
        return self.rows[-1].length_order

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready study."""
        return {
            "case": self.case_name, "drag_model": self.drag_model,
            "reference_length_m": self.reference_length_m, "reference_depth_m": self.reference_depth_m,
            "rows": [row.__dict__ for row in self.rows],
            "depth_order": self.depth_order, "length_order": self.length_order,
            "tolerance": self.tolerance, "segment_for_tolerance_m": self.segment_for_tolerance_m,
            "check_depth_error_m": self.check_depth_error_m,
        }


def observed_order(coarse_error: float, fine_error: float, coarse_l: float, fine_l: float) -> float | None:
    """ln(e₁/e₂)/ln(l₁/l₂), or None when an error is zero or the two have opposite signs."""
    if coarse_error * fine_error <= 0.0:
        return None
    return math.log(coarse_error / fine_error) / math.log(coarse_l / fine_l)


def convergence_study(
    case: CableCase, segments_m: Sequence[float] = PAPER_SEGMENTS_M, tolerance: float = 1e-3,
    progress: Callable[[str], None] | None = None,
) -> ConvergenceStudy:
    """Run the study on ``case`` (its cable length, or else its target depth, sets the reference)."""
    segments = [float(s) for s in segments_m]
    if len(segments) < 2 or any(not (math.isfinite(s) and s > 0.0) for s in segments):
        raise InputError(f"segment lengths must be at least two numbers > 0 m (got {list(segments_m)})")
    if any(b >= a for a, b in pairwise(segments)):
        raise InputError(f"segment lengths must decrease strictly (got {segments})")
    if not (0.0 < tolerance < 1.0):
        raise InputError(f"tolerance must be between 0 and 1 (got {tolerance})")
    say = progress or (lambda _msg: None)
    say("continuous reference (ODE) ...")
    if case.cable.length_m is not None:
        reference = continuous_depth(case, case.cable.length_m)
    elif case.target_depth_m is not None:
        reference = continuous_length(case, case.target_depth_m)
    else:
        raise InputError(f"{case.source}: set cable.length_m or target_depth_m for a convergence study")
    ref_length, ref_depth = reference.length_m, reference.vehicle_depth_m
    rows: list[ConvergenceRow] = []
    for seg in segments:
        say(f"links of {seg:g} m ...")
        sized = with_overrides(case, segment_length_m=seg)
        p1 = solve_depth(sized, ref_length)
        p2 = solve_length(sized, ref_depth)
        depth_error, length_error = p1.vehicle_depth_m - ref_depth, p2.length_m - ref_length
        prev = rows[-1] if rows else None
        rows.append(ConvergenceRow(
            seg, int(p1.link_length_m.size), p1.vehicle_depth_m, depth_error, p2.length_m, length_error,
            observed_order(prev.depth_error_m, depth_error, prev.segment_length_m, seg) if prev else None,
            observed_order(prev.length_error_m, length_error, prev.segment_length_m, seg) if prev else None,
        ))
    order, finest = rows[-1].depth_order, rows[-1]
    best = check = None
    if order is not None and order > 0.0:
        allowed = tolerance * ref_depth
        best = (allowed / (abs(finest.depth_error_m) / finest.segment_length_m**order)) ** (1.0 / order)
        for _ in range(_MAX_CHECKS):
            say(f"check at l = {best:.4g} m ...")
            check_case = with_overrides(case, segment_length_m=best)
            check = solve_depth(check_case, ref_length).vehicle_depth_m - ref_depth
            if abs(check) <= allowed:
                break
            best *= 0.99 * (allowed / abs(check)) ** (1.0 / order)
    return ConvergenceStudy(case.name, case.cable.drag.to_dict()["model"], ref_length, ref_depth, tuple(rows),
                            tolerance, best, check)
