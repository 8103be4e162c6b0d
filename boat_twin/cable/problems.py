"""The paper's two problems on the lumped-link model, solved by root finding, and the boat's tow load.

Problem 1 (given cable length L): the vehicle depth Y0 is the root of "top node depth = 0", bracketed in
[0, L] and found by brentq (the paper steps Y0 by hand). Problem 2 (given depth H): march from the vehicle
until a node crosses the surface and cut the last link where it does, so L is not a multiple of l.
Both answers are built by the same final march, so problem 2 inverts problem 1 to round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import brentq

from boat_twin.cable.body import BodyEquilibrium, body_equilibrium
from boat_twin.cable.case import CableCase, with_overrides
from boat_twin.cable.errors import CableSolveError
from boat_twin.cable.links import Marched, link_lengths, march
from boat_twin.errors import InputError

UNCONFIGURED_MAX_LENGTH_M = 20_000.0
"""Problem 2 gives up beyond this much cable when the case sets no cable.winch_capacity_m (m)."""


@dataclass(frozen=True)
class CableSolution:
    """An equilibrium. Arrays run from the vehicle (index 0, the paper's i = 0) to the tow point (last).

    ``node_x_m`` is the horizontal distance astern of the tow point (the vehicle trails at +offset),
    ``node_depth_m`` the depth below the surface; links i = 1..n have a tension (N) and an angle above the
    horizontal (rad). The top force (aft, down) is what the cable exerts on the boat at the tow point.
    """

    problem: str
    tow_speed_mps: float
    segment_length_m: float
    body: BodyEquilibrium
    node_x_m: np.ndarray
    node_depth_m: np.ndarray
    link_length_m: np.ndarray
    link_tension_N: np.ndarray
    link_angle_rad: np.ndarray
    top_aft_N: float
    top_down_N: float

    @property
    def length_m(self) -> float:
        """Cable length paid out, m."""
        return float(np.sum(self.link_length_m))

    @property
    def vehicle_depth_m(self) -> float:
        """Depth of the vehicle (cable attachment point O), m."""
        return float(self.node_depth_m[0])

    @property
    def vehicle_offset_m(self) -> float:
        """Horizontal distance of the vehicle astern of the tow point, m."""
        return float(self.node_x_m[0])

    @property
    def top_tension_N(self) -> float:
        """Tension at the tow point, N."""
        return math.hypot(self.top_aft_N, self.top_down_N)

    @property
    def top_angle_rad(self) -> float:
        """Angle of the top tension below the horizontal (pulling aft and down on the boat), rad."""
        return math.atan2(self.top_down_N, self.top_aft_N)

    def tow_frame_xz(self) -> tuple[np.ndarray, np.ndarray]:
        """Node positions in a frame at the tow point, x forward and z up (m), from the tow point down."""
        return -self.node_x_m[::-1], -self.node_depth_m[::-1]

    def to_dict(self, arrays: bool = True) -> dict[str, Any]:
        """JSON-ready result (degrees for angles, as at every edge); ``arrays=False`` leaves out the
        shape and per-link arrays."""
        summary = {
            "problem": self.problem,
            "vehicle_depth_m": self.vehicle_depth_m,
            "vehicle_offset_m": self.vehicle_offset_m,
            "alpha_deg": math.degrees(self.body.alpha_rad),
            "top_tension_N": self.top_tension_N,
            "top_angle_deg": math.degrees(self.top_angle_rad),
            "top_horizontal_N": self.top_aft_N,
            "top_vertical_N": self.top_down_N,
            "length_m": self.length_m,
            "segment_length_m": self.segment_length_m,
            "links": int(self.link_length_m.size),
            "tow_speed_mps": self.tow_speed_mps,
            "vehicle_flow_mps": self.body.flow_mps,
            "vehicle_drag_N": self.body.drag_N,
            "vehicle_lift_N": self.body.lift_N,
        }
        if not arrays:
            return summary
        return {**summary, "shape": {"x_m": self.node_x_m, "depth_m": self.node_depth_m},
                "link_tension_N": self.link_tension_N, "link_angle_deg": np.degrees(self.link_angle_rad)}


@dataclass(frozen=True)
class TowLoad:
    """Force of the cable on the boat at the tow point, N: magnitude, aft (horizontal) and down (vertical)."""

    tension_N: float
    horizontal_N: float  # positive pulls the boat astern
    vertical_N: float  # positive pulls the boat down


def _solution(case: CableCase, problem: str, body: BodyEquilibrium, vehicle_depth_m: float,
              lengths: np.ndarray, marched: Marched) -> CableSolution:
    forward = np.concatenate(([0.0], marched.node_forward_m))
    return CableSolution(
        problem=problem,
        tow_speed_mps=case.tow_speed_mps,
        segment_length_m=case.cable.segment_length_m,
        body=body,
        node_x_m=forward[-1] - forward,
        node_depth_m=np.concatenate(([vehicle_depth_m], marched.node_depth_m)),
        link_length_m=lengths,
        link_tension_N=marched.tension_N,
        link_angle_rad=marched.angle_rad,
        top_aft_N=marched.next_pull_aft_N,
        top_down_N=marched.next_pull_down_N,
    )


def _checked_length(case: CableCase, length_m: float | None) -> float:
    length = case.cable.length_m if length_m is None else length_m
    if length is None:
        raise InputError(f"{case.source}: no cable length (set cable.length_m or give a length)")
    if not (math.isfinite(length) and length > 0.0):
        raise InputError(f"cable length must be > 0 m (got {length!r})")
    capacity = case.cable.winch_capacity_m
    if capacity is not None and length > capacity:
        raise InputError(f"cable length {length:g} m exceeds the winch capacity "
                         f"cable.winch_capacity_m = {capacity:g} m ({case.source})")
    return float(length)


def solve_depth(case: CableCase, length_m: float | None = None) -> CableSolution:
    """Problem 1: vehicle depth, attack angle, shape and tensions for ``length_m`` (default: the case's)."""
    length = _checked_length(case, length_m)
    loading = case.loading()
    lengths = link_lengths(length, case.cable.segment_length_m)
    density = case.water_density_kgpm3
    last: dict[str, Any] = {}

    def top_depth(depth_m: float) -> float:
        body = body_equilibrium(case.vehicle, density, case.flow_mps(depth_m))
        marched = march(loading, body.pull_aft_N, body.pull_down_N, depth_m, lengths, last.get("angle"))
        last.update(angle=marched.angle_rad, body=body, marched=marched, depth=depth_m)
        return float(marched.node_depth_m[-1])

    upper = length * (1.0 + 1e-12) + 1e-12
    if top_depth(0.0) > 0.0:
        raise CableSolveError(
            f"with the vehicle at the surface the top of {length:g} m of cable is still under water: the "
            f"vehicle's lift exceeds the weights, no submerged equilibrium ({case.source})")
    try:
        depth = brentq(top_depth, 0.0, upper, xtol=1e-12 * max(1.0, length), maxiter=200)
    except (RuntimeError, ValueError) as err:
        raise CableSolveError(f"problem 1 did not converge for L = {length:g} m ({err})") from None
    if last["depth"] != depth:
        top_depth(depth)
    return _solution(case, "depth", last["body"], depth, lengths, last["marched"])


def solve_length(case: CableCase, depth_m: float | None = None) -> CableSolution:
    """Problem 2: cable length (not quantized to l), shape and tensions to hold the vehicle at ``depth_m``."""
    depth = case.target_depth_m if depth_m is None else depth_m
    if depth is None:
        raise InputError(f"{case.source}: no vehicle depth (set target_depth_m or give a depth)")
    if not (math.isfinite(depth) and depth > 0.0):
        raise InputError(f"vehicle depth must be > 0 m (got {depth!r})")
    capacity = case.cable.winch_capacity_m
    limit = UNCONFIGURED_MAX_LENGTH_M if capacity is None else capacity
    where = (f"the winch capacity cable.winch_capacity_m = {capacity:g} m" if capacity is not None
             else f"{UNCONFIGURED_MAX_LENGTH_M:g} m of cable")
    if depth > limit:  # refused before the march allocates links for the whole depth
        raise CableSolveError(f"the cable does not reach the surface from {depth:g} m within {where}")
    seg = case.cable.segment_length_m
    loading = case.loading()
    body = body_equilibrium(case.vehicle, case.water_density_kgpm3, case.flow_mps(depth))
    pull_aft, pull_down, start, used = body.pull_aft_N, body.pull_down_N, float(depth), 0.0
    chunk = max(64, math.ceil(2.0 * depth / seg))
    while used < limit:
        lengths = np.diff(np.minimum(used + seg * np.arange(chunk + 1), limit))
        lengths = lengths[lengths > 0.0]
        marched = march(loading, pull_aft, pull_down, start, lengths)
        above = np.flatnonzero(marched.node_depth_m <= 0.0)
        if above.size:
            k = int(above[0])
            below = start if k == 0 else marched.node_depth_m[k - 1]
            fraction = below / (below - marched.node_depth_m[k])
            length = used + float(np.sum(lengths[:k])) + fraction * lengths[k]
            break
        used += float(np.sum(lengths))
        pull_aft, pull_down = marched.next_pull_aft_N, marched.next_pull_down_N
        start = float(marched.node_depth_m[-1])
    else:
        raise CableSolveError(f"the cable does not reach the surface from {depth:g} m within {where}")
    lengths = link_lengths(length, seg)
    marched = march(loading, body.pull_aft_N, body.pull_down_N, depth, lengths)
    return _solution(case, "length", body, float(depth), lengths, marched)


def tow_load(case: CableCase, tow_speed_mps: float) -> TowLoad:
    """The load the boat feels at the tow point when towing the case's cable length at ``tow_speed_mps``."""
    solution = solve_depth(with_overrides(case, tow_speed_mps=tow_speed_mps))
    return TowLoad(solution.top_tension_N, solution.top_aft_N, solution.top_down_N)


def tow_speed_for_depth(case: CableCase, depth_m: float, length_m: float | None = None) -> float:
    """Tow speed (m/s) at which ``length_m`` of cable (default: the case's) holds the vehicle at depth_m."""
    length = _checked_length(case, length_m)
    if not (math.isfinite(depth_m) and depth_m > 0.0):
        raise InputError(f"vehicle depth must be > 0 m (got {depth_m!r})")

    def excess(speed: float) -> float:
        return solve_depth(with_overrides(case, tow_speed_mps=speed), length).vehicle_depth_m - depth_m

    low = max(0.0, -case.current.min_speed_mps)
    if excess(low) < 0.0:
        raise CableSolveError(f"even at the lowest tow speed, {length:g} m of cable holds the vehicle above "
                              f"{depth_m:g} m")
    high = low + 1.0
    while excess(high) > 0.0:
        high = 2.0 * high
        if high > 100.0:
            raise CableSolveError(f"no tow speed up to 100 m/s lifts the vehicle to {depth_m:g} m")
    return float(brentq(excess, low, high, xtol=1e-9))
