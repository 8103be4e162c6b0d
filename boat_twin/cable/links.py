"""The paper's lumped-link cable (Babanin & Melkonyan 2025, eqs. 6-10), marched from the vehicle upward.

Element j is a rigid link j of length l_j from node j−1 to node j plus a small sphere at node j that carries
the element's weight p*·l_j and drag (evaluated at node j's depth and link j's angle). Node 0 is the vehicle.
With h_j = T_j·(cos β_j, sin β_j) the (aft, down) pull of link j on node j, the equilibrium of node j reads
    h_{j+1} = h_j + F_j          (eqs. 6-7),      h_1 = (R_x0, p0 − R_y0)   (eqs. 1-2),
and the node positions are Y_j = Y_0 − Σ l_i sin β_i, X_j = Σ l_i cos β_i (eqs. 8, 10). The force the
boat feels at the top node n is h_n + F_n.

F_j depends on node j's depth and link j's angle, which depend on the links below: the recurrence is
sequential. It is solved here by sweeping up to CHUNK_LINKS links at once with numpy (Picard iteration on the
depth/angle profile): each sweep recomputes all loads from the previous profile. Because node j depends only
on nodes below it, sweep s is exact on the first s links, so at most n + 1 sweeps reproduce the sequential
march; in practice the profile stops changing after a few to a few tens of sweeps (fewer when a neighbouring
profile is given as a guess). Longer cables are swept chunk after chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boat_twin.cable.drag import CableLoading

_ANGLE_TOL_RAD = 1e-13
_DEPTH_TOL_M = 1e-10


@dataclass(frozen=True)
class Marched:
    """Links 1..n above a start node; arrays have one entry per link / per upper node, in metres, N, rad."""

    angle_rad: np.ndarray
    tension_N: np.ndarray
    node_depth_m: np.ndarray
    node_forward_m: np.ndarray
    next_pull_aft_N: float  # h_n + F_n: what holds the top node
    next_pull_down_N: float
    sweeps: int


CHUNK_LINKS = 1024
"""Links swept together; a longer cable is marched chunk by chunk (fewer sweeps where coupling is strong)."""


def march(loading: CableLoading, pull_aft_N: float, pull_down_N: float, start_depth_m: float,
          lengths_m: np.ndarray, guess_angle_rad: np.ndarray | None = None) -> Marched:
    """March links of ``lengths_m`` up from a node at ``start_depth_m`` pulled by (aft, down) = ``pull_*_N``.

    ``guess_angle_rad`` (one angle per link) only speeds the sweeps up; the answer does not depend on it.
    Horizontal positions are measured forward (toward the boat) from the start node.
    """
    lengths = np.asarray(lengths_m, dtype=float)
    if guess_angle_rad is not None and np.shape(guess_angle_rad) != lengths.shape:
        guess_angle_rad = None
    parts = []
    pull_aft, pull_down, start = pull_aft_N, pull_down_N, start_depth_m
    for first in range(0, lengths.size, CHUNK_LINKS):
        part = slice(first, first + CHUNK_LINKS)
        guess = None if guess_angle_rad is None else guess_angle_rad[part]
        parts.append(_sweep(loading, pull_aft, pull_down, start, lengths[part], guess))
        pull_aft, pull_down = parts[-1].next_pull_aft_N, parts[-1].next_pull_down_N
        start = float(parts[-1].node_depth_m[-1])
    if len(parts) == 1:
        return parts[0]
    angle = np.concatenate([m.angle_rad for m in parts])
    return Marched(
        angle_rad=angle,
        tension_N=np.concatenate([m.tension_N for m in parts]),
        node_depth_m=np.concatenate([m.node_depth_m for m in parts]),
        node_forward_m=np.cumsum(lengths * np.cos(angle)),
        next_pull_aft_N=pull_aft,
        next_pull_down_N=pull_down,
        sweeps=sum(m.sweeps for m in parts),
    )


def _sweep(loading: CableLoading, pull_aft: float, pull_down: float, start_depth_m: float,
           lengths: np.ndarray, guess_angle_rad: np.ndarray | None) -> Marched:
    """Picard sweeps over one chunk until the profile stops changing (at most n + 1 sweeps)."""
    n = lengths.size
    if guess_angle_rad is None:
        angle = np.full(n, np.arctan2(pull_down, pull_aft))
    else:
        angle = np.array(guess_angle_rad, dtype=float)
    depth = start_depth_m - np.cumsum(lengths * np.sin(angle))
    h_aft = np.empty(n)
    h_down = np.empty(n)
    sweeps = 0
    for sweeps in range(1, n + 2):  # noqa: B007 (the count is reported)
        load_aft, load_down = loading.per_length(depth, angle)
        h_aft[0], h_down[0] = pull_aft, pull_down
        np.cumsum(load_aft[:-1] * lengths[:-1], out=h_aft[1:])
        np.cumsum(load_down[:-1] * lengths[:-1], out=h_down[1:])
        h_aft[1:] += pull_aft
        h_down[1:] += pull_down
        new_angle = np.arctan2(h_down, h_aft)
        new_depth = start_depth_m - np.cumsum(lengths * np.sin(new_angle))
        settled = (np.max(np.abs(new_angle - angle), initial=0.0) <= _ANGLE_TOL_RAD
                   and np.max(np.abs(new_depth - depth), initial=0.0) <= _DEPTH_TOL_M)
        angle, depth = new_angle, new_depth
        if settled:
            break
    load_aft, load_down = loading.per_length(depth[-1:], angle[-1:])
    return Marched(
        angle_rad=angle,
        tension_N=np.hypot(h_aft, h_down),
        node_depth_m=depth,
        node_forward_m=np.cumsum(lengths * np.cos(angle)),
        next_pull_aft_N=float(h_aft[-1] + load_aft[0] * lengths[-1]),
        next_pull_down_N=float(h_down[-1] + load_down[0] * lengths[-1]),
        sweeps=sweeps,
    )


def link_lengths(length_m: float, segment_length_m: float) -> np.ndarray:
    """Links of length l covering ``length_m``, the last one shorter if L is not a multiple of l (eq. 11)."""
    full = int(np.floor(length_m / segment_length_m * (1.0 + 1e-12)))
    rest = length_m - full * segment_length_m
    lengths = np.full(full, segment_length_m)
    if rest > 1e-9 * segment_length_m or (full == 0 and length_m > 0.0):  # a cable shorter than one link
        lengths = np.append(lengths, rest)
    return lengths
