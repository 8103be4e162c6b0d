"""The twin tick by tick, for live use (the simulator node, a ground-station link): commands in, messages out.

It runs the same dynamics kernel, sensor models and message builders as a batch sea trial. Sensors need a short
history (GNSS latency), so each tick measures a sliding window of truth samples and publishes the samples stamped
at the current tick's nominal time; a live node restamps them with its clock (:func:`boat_twin.io.messages.restamped`).
Correlated noise processes (Gauss-Markov position error, gyro bias random walk) restart
with every window in live mode; white noise, constant biases and latency are as in batch.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.sensors.gnss import GnssModel
from boat_twin.sensors.um7 import Um7Model
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.simulate import INTEGRATION_RATE_HZ, OUTPUT_RATE_HZ, SimulationRecord
from boat_twin.vessel.tow import tow_drag_table


class LiveTwin:
    """One boat stepped at the output rate; ``tick(commands)`` returns that tick's messages.

    ``epoch_s`` is the absolute time of the first tick (e.g. the ROS clock at start-up): stamps are
    ``epoch_s + k / OUTPUT_RATE_HZ``.
    """

    def __init__(self, config: TwinConfig, seed: int = 0, noise: bool = True, epoch_s: float = 0.0) -> None:
        self.config = config
        self.dynamics = Dynamics(config.vessel, tow_drag_table(config.tow, config.vessel))
        self.state = np.zeros((1, 6))
        self.environments = config.environment.as_vector()[None, :]
        self.commands = np.zeros(4)
        self.epoch_s = epoch_s
        self.tick_index = 0
        rng = np.random.default_rng(seed)
        self.gnss_model = GnssModel(config.gnss, rng, noise=noise)
        self.imu_model = Um7Model(config.um7, rng, noise=noise)
        self._gnss_step = round(OUTPUT_RATE_HZ / config.gnss.rate_hz)
        self._imu_step = round(OUTPUT_RATE_HZ / config.um7.rate_hz)
        history_ticks = math.ceil(config.gnss.latency_s * OUTPUT_RATE_HZ) + 2
        self._window = max(history_ticks, self._gnss_step, self._imu_step) + max(self._gnss_step, self._imu_step)
        self._history: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = deque(maxlen=self._window + 1)

    @property
    def time_s(self) -> float:
        """Absolute time of the next tick, s."""
        return self.epoch_s + self.tick_index / OUTPUT_RATE_HZ

    def set_command(self, index: int, value: float) -> None:
        """Set one command (0 thrust_left_N, 1 thrust_right_N, 2 angle_left_rad, 3 angle_right_rad); held."""
        if math.isfinite(value):
            self.commands[index] = value

    def tick(self) -> list[messages.Message]:
        """Record this tick under the held commands, step the dynamics one output period, return the messages."""
        commands = self.commands[None, None, :].copy()
        substeps = round(INTEGRATION_RATE_HZ / OUTPUT_RATE_HZ)
        states, derivatives = self.dynamics.run(self.state, commands, self.environments, 1.0 / INTEGRATION_RATE_HZ,
                                                substeps)
        now = self.time_s
        self._history.append((now, states[0], commands[0], derivatives[0]))
        out = list(messages.command_messages(np.array([now]), commands[0]))
        out += self._sensor_messages(now)
        self.tick_index += 1
        return out

    def _window_record(self, step: int, last_only: bool = False) -> SimulationRecord | None:
        """The buffered ticks whose first sample is on this sensor's decimation phase (or just the last)."""
        first_tick = self.tick_index - len(self._history) + 1
        offset = len(self._history) - 1 if last_only else (-first_tick) % step
        items = list(self._history)[offset:]
        if len(items) < 1:
            return None
        return SimulationRecord(
            t_s=np.array([i[0] for i in items]),
            states=np.array([i[1] for i in items]),
            commands=np.array([i[2] for i in items]),
            derivatives=np.array([i[3] for i in items]),
            environment=self.config.environment,
        )

    def _sensor_messages(self, now: float) -> list[messages.Message]:
        out: list[messages.Message] = []
        gnss_window = self._window_record(self._gnss_step)
        if gnss_window is not None and self.tick_index % self._gnss_step == 0:
            out += [m for m in messages.gnss_messages(self.gnss_model.measure(gnss_window.truth()))
                    if abs(m[1] - round(now * 1e9)) < 1000]
        imu_window = self._window_record(self._imu_step)
        if imu_window is not None and self.tick_index % self._imu_step == 0:
            out += [m for m in messages.imu_messages(self.imu_model.measure(imu_window.truth()))
                    if abs(m[1] - round(now * 1e9)) < 1000]
        last = self._window_record(1, last_only=True)
        if last is not None:
            out += list(messages.truth_messages(last.truth()))
        return out
