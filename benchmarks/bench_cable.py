"""Towed cable: problems 1 and 2 with 3000 links against a naive transcription of the paper's stepping.

The naive solver does what Babanin & Melkonyan (2025) describe: the attack angle scanned in 0.1° steps for a
sign change of eq. (3), the vehicle depth Y0 moved in 1 m steps (from the paper's first guess, 200 m) until
the top of the cable is within 1 m below the surface, each trial a link-by-link Python march; problem 2
counts whole links. Both run on the Table 1 case with l = 0.1 m, in this process, side by side.
Targets (printed, not asserted): problem 1 with 3000 links < 50 ms.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from boat_twin.cable import continuous_depth, load_case, solve_depth, solve_length, with_overrides
from boat_twin.cable.case import CableCase
from boat_twin.cable.drag import NormalTangentialDrag

CASE = Path(__file__).resolve().parents[1] / "config" / "cable" / "babanin2025_table1.yaml"
TARGET_P1_S = 0.050


def naive_alpha(case: CableCase, flow_mps: float) -> float:
    """Step α by 0.1° from 0 until the moment of eq. (3) changes sign (rad)."""
    alpha = 0.0
    previous = case.vehicle.moment_Nm(case.water_density_kgpm3, flow_mps, alpha)
    while alpha < math.pi / 2:
        alpha += math.radians(0.1)
        moment = case.vehicle.moment_Nm(case.water_density_kgpm3, flow_mps, alpha)
        if (moment < 0.0) != (previous < 0.0):
            return alpha
        previous = moment
    return math.pi / 2


def naive_march(case: CableCase, depth_m: float, links: int | None) -> tuple[float, int]:
    """Eqs. (1)-(10) link by link, ``links`` of them or up to the surface if None: (top depth, links)."""
    v = case.flow_mps(depth_m)
    alpha = naive_alpha(case, v)
    q = 0.5 * case.water_density_kgpm3 * v * v * case.vehicle.d_m**2
    tx, ty = case.vehicle.cx.at(alpha) * q, case.vehicle.weight_in_water_N - case.vehicle.cy.at(alpha) * q
    seg, cable = case.cable.segment_length_m, case.cable
    y, n = depth_m, 0
    while (links is None and y > 0.0) or (links is not None and n < links):
        beta = math.atan2(ty, tx)
        y -= seg * math.sin(beta)
        flow = case.flow_mps(y)
        tx += cable.drag.cx * 0.5 * case.water_density_kgpm3 * flow * abs(flow) * cable.diameter_m * seg
        ty += cable.weight_in_water_Npm * seg
        n += 1
    return y, n


def naive_depth(case: CableCase) -> float:
    """Problem 1 by the paper's stepping: Y0 from 200 m in 1 m steps until 0 <= Y_top < 1 m."""
    links = round(case.cable.length_m / case.cable.segment_length_m)
    depth = 200.0
    for _ in range(100_000):
        top, _n = naive_march(case, depth, links)
        if 0.0 <= top < 1.0:
            return depth
        depth += -1.0 if top >= 1.0 else 1.0
    raise RuntimeError("naive stepping did not settle")


def naive_length(case: CableCase, depth_m: float) -> float:
    """Problem 2 the paper's way: whole links until a node reaches the surface."""
    return naive_march(case, depth_m, None)[1] * case.cable.segment_length_m


def timed(fn: Callable[[], object], repeat: int) -> tuple[float, object]:
    """Median wall time (s) over ``repeat`` runs, and the last result."""
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    case = with_overrides(load_case(CASE), segment_length_m=0.1)
    links = round(case.cable.length_m / case.cable.segment_length_m)
    truth = continuous_depth(case, case.cable.length_m).vehicle_depth_m
    print(f"case {CASE.name}, l = 0.1 m, {links} links, tow {case.tow_speed_mps} m/s; "
          f"ODE depth {truth:.4f} m")

    t_ours, ours = timed(lambda: solve_depth(case), 21)
    t_naive, naive = timed(lambda: naive_depth(case), 3)
    verdict = "meets" if t_ours < TARGET_P1_S else "MISSES"
    print(f"problem 1  brentq + vectorized march : {t_ours * 1e3:8.2f} ms  "
          f"depth {ours.vehicle_depth_m:.4f} m (target < {TARGET_P1_S * 1e3:.0f} ms: {verdict})")
    print(f"problem 1  paper's stepping (naive)  : {t_naive * 1e3:8.2f} ms  depth {naive:.4f} m")
    print(f"problem 1  time ratio naive/ours {t_naive / t_ours:.1f}x; answer difference "
          f"{naive - ours.vehicle_depth_m:+.4f} m (ours - ODE {ours.vehicle_depth_m - truth:+.4f} m, "
          f"naive - ODE {naive - truth:+.4f} m)")

    depth = ours.vehicle_depth_m
    t_ours2, ours2 = timed(lambda: solve_length(case, depth), 21)
    t_naive2, naive2 = timed(lambda: naive_length(case, depth), 3)
    print(f"problem 2  march + cut in last link  : {t_ours2 * 1e3:8.2f} ms  length {ours2.length_m:.4f} m")
    print(f"problem 2  paper's stepping (naive)  : {t_naive2 * 1e3:8.2f} ms  length {naive2:.4f} m")
    print(f"problem 2  time ratio naive/ours {t_naive2 / t_ours2:.1f}x; answer difference "
          f"{naive2 - ours2.length_m:+.4f} m (exact inverse of problem 1: {case.cable.length_m:.4f} m)")

    nt = replace(case, cable=replace(case.cable, drag=NormalTangentialDrag()))
    t_nt, sol_nt = timed(lambda: solve_depth(nt), 11)
    verdict = "meets" if t_nt < TARGET_P1_S else "MISSES"
    print(f"problem 1  normal_tangential drag    : {t_nt * 1e3:8.2f} ms  "
          f"depth {sol_nt.vehicle_depth_m:.4f} m (target < {TARGET_P1_S * 1e3:.0f} ms: {verdict})")


if __name__ == "__main__":
    main()
