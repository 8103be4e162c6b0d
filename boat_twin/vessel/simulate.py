"""Run a scenario through the dynamics: RK4 at 50 Hz inside, states and commands recorded at 10 Hz.

An open-loop scenario's commands change at output ticks (a 10 Hz command log); a closed-loop scenario's helm
(zigzag) is asked at every integration step, so it reverses the steering within 1/50 s of its threshold,
and a fresh helm is made for every run (no state carried from one run or boat to another). A registered
closed-loop scenario (zigzag, turning circle at a constant engine setting) has a compiled helm
(``vessel.helms``): the whole run then stays inside the compiled kernel; any other helm (a wrapped scenario, a
test's spy) is asked from the Python step loop below, whose order and arithmetic the kernel follows bit for
bit (``test/test_helms.py``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from boat_twin.errors import InputError
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.environment import Environment, WindTrack
from boat_twin.vessel.helms import CompiledHelm
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import CommandProfile, Scenario
from boat_twin.vessel.truth import TruthSeries, ground_velocity_enu

OUTPUT_RATE_HZ = 10.0
"""Output (sensor and command) rate, Hz: the 10 Hz logging of Dyda & Chumakova (2021)."""
INTEGRATION_RATE_HZ = 50.0
"""RK4 rate, Hz: the fastest mode here (yaw, T ≈ 1 s) is resolved with > 50 steps per time constant."""


def output_ticks(duration_s: float) -> int:
    """Number of output ticks of a run of ``duration_s`` seconds, both ends included (at least 0)."""
    return max(int(np.floor(duration_s * OUTPUT_RATE_HZ + 1e-9)) + 1, 0)


@dataclass(frozen=True)
class SimulationRecord:
    """What happened, at the output ticks: ``t_s`` (n,), ``states`` (n, N, 6), ``commands`` (n, N, 4).

    ``commands[i]`` is the command in force at ``t_s[i]`` (an open-loop scenario holds it to ``t_s[i+1]``; a
    closed-loop helm may change it between ticks); ``derivatives`` (n, N, 6) are the state derivatives at each
    tick (they give the accelerometer's reading); ``steering_rad`` (n, N, 2) the outboards' real angles
    (left, right) then, which trail the commanded ones at the steering rate.
    """

    t_s: np.ndarray
    states: np.ndarray
    commands: np.ndarray
    derivatives: np.ndarray
    environment: Environment
    steering_rad: np.ndarray
    command_issued_s: np.ndarray | None = None
    """(n, N) when the command in force at ``t_s[i]`` was issued, s: within (t_s[i-1], t_s[i]] when a closed-loop
    helm changed it between the ticks (at an integration step), else t_s[i]; None: every command was issued at
    its tick (an open-loop scenario). A command log stamps its messages with these times."""

    def command_stamps_s(self, boat: int = 0) -> np.ndarray:
        """(n,) the times a command log stamps boat ``boat``'s commands with (:attr:`command_issued_s`), s."""
        return self.t_s if self.command_issued_s is None else self.command_issued_s[:, boat]

    def truth(self, boat: int = 0) -> TruthSeries:
        """The true motion of one boat of the ensemble, for the sensor models."""
        east, north, yaw, u, v, r = (self.states[:, boat, j] for j in range(6))
        du, dv = self.derivatives[:, boat, 3], self.derivatives[:, boat, 4]
        env = self.environment
        vel_east, vel_north = ground_velocity_enu(yaw, u, v, env.current_east_mps, env.current_north_mps)
        return TruthSeries(
            t_s=self.t_s,
            east_m=east,
            north_m=north,
            yaw_rad=yaw,
            vel_east_mps=vel_east,
            vel_north_mps=vel_north,
            surge_mps=u,
            sway_mps=v,
            yaw_rate_radps=r,
            accel_x_mps2=du - r * v,
            accel_y_mps2=dv + r * u,
        )


def simulate(
    params: VesselParams,
    scenario: Scenario,
    environment: Environment | None = None,
    n_boats: int = 1,
    initial_states: np.ndarray | None = None,
    extra_drag_N: np.ndarray | None = None,
    boats: Sequence[VesselParams] | None = None,
    compiled_helm: bool = True,
) -> SimulationRecord:
    """Simulate ``n_boats`` identical boats through ``scenario`` for its whole duration.

    Unless ``initial_states`` (N, 6) is given, every boat starts at the origin heading east, moving ahead at
    the scenario's initial surge speed through the water. ``boats``: one vessel per boat instead (sway/yaw
    coefficients of their own, the resistance of ``params``, which the scenario's helm uses); ``n_boats`` is
    then their number. ``compiled_helm=False``: a closed-loop scenario's Python helm is asked at every step even
    where the compiled kernel has the helm (the reference the compiled helms are tested and timed against).
    """
    chunks = simulate_chunks(params, scenario, environment, n_boats, initial_states, extra_drag_N, boats=boats,
                             compiled_helm=compiled_helm)
    return next(chunks)


def simulate_chunks(
    params: VesselParams,
    scenario: Scenario,
    environment: Environment | None = None,
    n_boats: int = 1,
    initial_states: np.ndarray | None = None,
    extra_drag_N: np.ndarray | None = None,
    chunk_ticks: int | None = None,
    boats: Sequence[VesselParams] | None = None,
    compiled_helm: bool = True,
    wind_track: WindTrack | None = None,
) -> Iterator[SimulationRecord]:
    """:func:`simulate` as consecutive records of at most ``chunk_ticks`` output ticks each (None: one record).

    The boats' states carry over from chunk to chunk, so the chunks together are exactly the one record of
    :func:`simulate`, but only one chunk (144 bytes per boat and tick) is held at a time. ``wind_track``: a
    measured wind (times on the scenario's clock) instead of ``environment``'s steady one, each chunk run in its
    mean over the chunk (:meth:`~boat_twin.vessel.environment.WindTrack.mean_over`; the record's environment says
    which).
    """
    environment = environment or Environment()
    dynamics = Dynamics(params, extra_drag_N, boats)
    if boats is not None:
        n_boats = len(boats)
    if initial_states is None:
        states = np.zeros((n_boats, 6))
        states[:, 3] = scenario.initial_surge_mps
    else:
        states = np.array(initial_states, dtype=float)
    environments = np.tile(environment.as_vector(), (states.shape[0], 1))
    n_ticks = output_ticks(scenario.duration_s)
    step = chunk_ticks if chunk_ticks is not None else max(n_ticks, 1)
    if step < 1:
        raise ValueError(f"chunk_ticks must be at least 1, got {chunk_ticks}")
    substeps = int(round(INTEGRATION_RATE_HZ / OUTPUT_RATE_HZ))
    dt_s = 1.0 / INTEGRATION_RATE_HZ
    helm = scenario.helm(states.shape[0])
    delay_s = params.command_delay_s
    compiled = _compiled_helm(scenario) if compiled_helm else None
    closed_loop = None if compiled is None else dynamics.closed_loop(compiled, states.shape[0], delay_s, dt_s,
                                                                      scenario.initial_surge_mps)
    steering: np.ndarray | None = None
    thrust: np.ndarray | None = None
    issued_queue: deque[tuple[float, np.ndarray]] = deque()  # a closed-loop helm's commands not yet acting
    acting: np.ndarray | None = None
    last_command: np.ndarray | None = None  # a closed-loop helm's: its last command and when it changed, per boat
    changed_s = np.zeros(states.shape[0])
    start = 0
    while True:
        stop = min(start + step, n_ticks)
        t_s = np.arange(start, stop) / OUTPUT_RATE_HZ
        issued: np.ndarray | None = None
        chunk_environment = environment
        if wind_track is not None and t_s.size:
            east, north = wind_track.mean_over(float(t_s[0]), float(t_s[-1]) + 1.0 / OUTPUT_RATE_HZ)
            chunk_environment = replace(environment, wind_east_mps=east, wind_north_mps=north)
            environments[:, 2:4] = (east, north)
        if isinstance(helm, CommandProfile):
            index = np.searchsorted(helm.times_s, t_s + 1e-9, side="right") - 1
            rows = np.where(index[:, None] >= 0, helm.values[np.maximum(index, 0)], 0.0)
            commands = np.repeat(rows[:, None, :], states.shape[0], axis=1)
            applied, switch, before = commands, None, None
            if delay_s > 0.0:
                applied, switch, before = _delayed_profile(helm, t_s, delay_s, states.shape[0])
            if steering is None and t_s.size:
                steering = dynamics.steering_targets(applied[0])
                thrust = dynamics.thrust_start(applied[0])
            out_states, derivatives, out_steering = dynamics.run(states, applied, environments, dt_s, substeps,
                                                                 steering, thrust, switch, before)
        elif closed_loop is not None:
            out_states, derivatives, out_steering, commands, issued = dynamics.run_closed_loop(
                closed_loop, states, environments, t_s.size, dt_s, substeps, OUTPUT_RATE_HZ)
        else:
            commands = np.empty((t_s.size, states.shape[0], 4))
            out_states = np.empty((t_s.size,) + states.shape)
            derivatives = np.empty_like(out_states)
            out_steering = np.empty((t_s.size, states.shape[0], 2))
            issued = np.empty((t_s.size, states.shape[0]))
            for i, t in enumerate(t_s):
                for j in range(substeps):
                    command = dynamics.layout_commands(helm.command(float(t) + j * dt_s, states),
                                                       scenario.initial_surge_mps)
                    changed = np.ones(states.shape[0], dtype=bool) if last_command is None else np.any(
                        command != last_command, axis=1)
                    changed_s[changed], last_command = float(t) + j * dt_s, command.copy()
                    issued_queue.append((float(t) + j * dt_s, command.copy()))
                    while issued_queue and issued_queue[0][0] <= float(t) + j * dt_s - delay_s + 1e-9:
                        acting = issued_queue.popleft()[1]
                    now = command if acting is None else acting  # before the first delayed command: the first
                    if steering is None or thrust is None:
                        steering = dynamics.steering_targets(now)
                        thrust = dynamics.thrust_start(now)
                    if j > 0:
                        dynamics.step(states, now, environments, dt_s, steering, thrust)
                        continue
                    tick_states, tick_derivatives, tick_steering = dynamics.run(
                        states, now[None], environments, dt_s, 1, steering, thrust)
                    commands[i], out_states[i], derivatives[i] = command, tick_states[0], tick_derivatives[0]
                    out_steering[i] = tick_steering[0]
                    recent = changed_s > float(t) - 1.0 / OUTPUT_RATE_HZ + 1e-9
                    issued[i] = np.where(recent, changed_s, t)
        if not np.all(np.isfinite(out_states)):
            tick = int(np.flatnonzero(~np.all(np.isfinite(out_states), axis=(1, 2)))[0])
            raise InputError(f"the simulation diverged at t = {t_s[tick]:.1f} s (a non-finite state): these vessel "
                             f"parameters cannot be integrated at {INTEGRATION_RATE_HZ:g} Hz; check the masses, "
                             "damping and resistance")
        yield SimulationRecord(t_s, out_states, commands, derivatives, chunk_environment, out_steering, issued)
        start = stop
        if start >= n_ticks:
            return


def _compiled_helm(scenario: Scenario) -> CompiledHelm | None:
    """The scenario's helm as the compiled kernel runs it, if its class has one (a registered closed-loop
    scenario); None: its Python helm is asked at every step (any other helm: a wrapped one, a test's spy)."""
    if isinstance(scenario, CommandProfile):
        return None
    make = getattr(type(scenario), "compiled_helm", None)  # the class's, never a wrapper's delegated attribute
    return None if make is None else make(scenario)


def _delayed_profile(profile: CommandProfile, t_s: np.ndarray, delay_s: float, boats: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the outboards act on at the ticks ``t_s`` when the commands logged at the ticks act ``delay_s``
    late: the commands (ticks, boats, 4) each tick holds from its switch time (ticks, boats), s after the tick,
    and the command in force before the first tick (boats, 4), as
    :meth:`~boat_twin.vessel.dynamics.Dynamics.run` takes them. The command logged at tick j acts from
    t_j + delay: from tick j + k, k = ⌊delay·rate⌋, plus the rest of the delay (the live twin does the same);
    before the first logged command acts, the first holds (the boat was held there)."""
    ticks = np.round(t_s * OUTPUT_RATE_HZ).astype(int)
    shift = int(np.floor(delay_s * OUTPUT_RATE_HZ + 1e-9))
    rest = delay_s - shift / OUTPUT_RATE_HZ
    source = np.maximum(np.concatenate([ticks[:1] - 1, ticks]) - shift, 0) / OUTPUT_RATE_HZ
    index = np.searchsorted(profile.times_s, source + 1e-9, side="right") - 1
    rows = np.where(index[:, None] >= 0, profile.values[np.maximum(index, 0)], 0.0)
    changed = np.any(rows[1:] != rows[:-1], axis=1)
    switch = np.where(changed, rest, 0.0)
    return (np.repeat(rows[1:, None, :], boats, axis=1), np.repeat(switch[:, None], boats, axis=1),
            np.repeat(rows[:1], boats, axis=0))
