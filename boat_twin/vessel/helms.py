"""The closed-loop helms' decisions, compiled: one copy of each registered helm's logic, in numba.

A closed-loop helm is asked at every integration step for each boat's four commands (thrust_left_N,
thrust_right_N, angle_left_rad, angle_right_rad). The zigzag and the turning circle at a constant engine setting
are small state machines; :func:`helm_command` decides one boat's step. It is called from two places:

- the scenarios' Python helms (:class:`~boat_twin.vessel.scenarios.ZigzagHelm`,
  :class:`~boat_twin.vessel.scenarios.EngineTurningCircle`), through :func:`helm_commands`, one call per step for
  all boats: what the simulator's step loop, the live MAVLink boat and any wrapped helm ask;
- the compiled closed-loop kernel (``vessel.dynamics``), which runs a whole trial per boat without returning to
  Python (issue 27: the Python step loop was most of a closed-loop boat's time).

So both paths take the same decisions from the same states; ``test/test_helms.py`` checks that whole trials of the
two agree bit for bit.

A helm is a :class:`CompiledHelm`: its kind (``ZIGZAG``, ``ENGINE_TURN``), its parameters and
:data:`MEMORY_SIZE` floats of per-boat memory, zeroed by :func:`fresh_memory` for each run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

ZIGZAG = 1
"""A zigzag δ/ψ: parameters (approach thrust per outboard N, δ rad, ψ rad, approach s, decision rate Hz);
memory (steering side ±1, heading at the first execute rad, 1 once that heading is taken)."""
ENGINE_TURN = 2
"""A turning circle at a constant engine setting: parameters (shaft power per outboard W, execute s, full steering
rad, propulsive efficiency, bollard thrust N, engine power W); no memory."""
MEMORY_SIZE = 3
"""Floats of memory per boat a helm may keep."""
EXECUTE_TOLERANCE_S = 1e-9
"""An order due at time T is given at a step whose time is at least T minus this, s (float times of steps)."""
DECISION_TOLERANCE = 1e-6
"""A helm deciding at a rate decides at steps within this fraction of a period of its instants."""


@dataclass(frozen=True)
class CompiledHelm:
    """What the compiled kernel needs of a scenario's helm: its kind and its parameters (see the kinds)."""

    kind: int
    parameters: np.ndarray


def fresh_memory(n_boats: int) -> np.ndarray:
    """(n_boats, :data:`MEMORY_SIZE`) memory of a new run: a zigzag steers to starboard first, no heading yet."""
    memory = np.zeros((n_boats, MEMORY_SIZE))
    memory[:, 0] = 1.0
    return memory


@numba.njit(cache=True)
def engine_setting_thrust(shaft_power_W: float, efficiency: float, bollard_N: float, engine_power_W: float,
                          speed_mps: float) -> float:
    """Thrust per outboard at a constant engine setting that delivers ``shaft_power_W`` (W) at speed through water
    ``speed_mps``, N: η·P/|u| within the full-throttle envelope min(bollard, η·P_engine/|u|)."""
    speed = max(abs(speed_mps), 1e-9)
    return min(min(bollard_N, efficiency * engine_power_W / speed), efficiency * shaft_power_W / speed)


@numba.njit(cache=True)
def helm_command(kind: int, p: np.ndarray, t: float, s: np.ndarray, memory: np.ndarray, out: np.ndarray) -> None:
    """One boat's commands (4,) into ``out`` at time ``t`` (s since the start) from its state ``s`` (6,), updating
    its ``memory`` (:data:`MEMORY_SIZE`,)."""
    if kind == ZIGZAG:
        out[0] = p[0]
        out[1] = p[0]
        out[2] = 0.0
        out[3] = 0.0
        if t < p[3] - EXECUTE_TOLERANCE_S:
            return
        if memory[2] == 0.0:  # the first execute: the heading the zigzag swings about
            memory[1] = s[2]
            memory[2] = 1.0
        rate = p[4]
        if not (rate > 0.0 and abs(t * rate - np.round(t * rate)) > DECISION_TOLERANCE):
            deviation = s[2] - memory[1]  # > 0: bow to port
            if deviation <= -p[2]:
                memory[0] = -1.0
            if deviation >= p[2]:
                memory[0] = 1.0
        out[2] = memory[0] * p[1]  # between decisions the last one holds
        out[3] = out[2]
    elif kind == ENGINE_TURN:
        out[0] = engine_setting_thrust(p[0], p[3], p[4], p[5], s[3])
        out[1] = out[0]
        steer = p[2] if t >= p[1] - EXECUTE_TOLERANCE_S else 0.0
        out[2] = steer
        out[3] = steer
    else:
        raise ValueError("unknown helm kind")


@numba.njit(cache=True)
def helm_commands(kind: int, p: np.ndarray, t: float, states: np.ndarray, memory: np.ndarray, out: np.ndarray
                  ) -> None:
    """:func:`helm_command` of every boat: ``states`` (N, 6), ``memory`` (N, :data:`MEMORY_SIZE`), ``out`` (N, 4)."""
    for b in range(states.shape[0]):
        helm_command(kind, p, t, states[b], memory[b], out[b])
