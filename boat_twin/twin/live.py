"""The twin tick by tick, for live use (the simulator node, a ground-station link): commands in, messages out.

It runs the same dynamics kernel, sensor models and message builders as a batch sea trial. Each sensor is its
expected-measurement function (:func:`boat_twin.sensors.gnss.expected_fix`,
:func:`boat_twin.sensors.um7.expected_imu`) evaluated on a short history of truth samples (GNSS latency), plus
one noise process per sensor (:class:`~boat_twin.sensors.gnss.GnssNoise`, :class:`~boat_twin.sensors.um7.Um7Noise`)
stepped once per sensor sample and kept across ticks, so correlated noise (Gauss-Markov position error, gyro bias
random walk) has the batch statistics. Without noise the messages equal the batch trial's, bit for bit. Messages
are stamped at the tick's nominal time; a live node restamps them with its clock
(:func:`boat_twin.io.messages.restamped`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import fields

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.sensors import decimation_step
from boat_twin.sensors.gnss import GnssMeasurements, GnssNoise, expected_fix, fixes
from boat_twin.sensors.um7 import ImuMeasurements, Um7Noise, expected_imu, imu_samples
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.simulate import INTEGRATION_RATE_HZ, OUTPUT_RATE_HZ, SimulationRecord
from boat_twin.vessel.tow import tow_drag_table
from boat_twin.vessel.truth import TruthSeries


class LiveTwin:
    """One boat stepped at the output rate; ``tick(commands)`` returns that tick's messages.

    ``epoch_s`` is the absolute time of the first tick (e.g. the ROS clock at start-up): stamps are
    ``epoch_s + k / OUTPUT_RATE_HZ``. ``seed`` seeds the one RNG both sensors' noise processes draw from.
    """

    def __init__(self, config: TwinConfig, seed: int = 0, noise: bool = True, epoch_s: float = 0.0) -> None:
        self.config = config
        self.dynamics = Dynamics(config.vessel, tow_drag_table(config.tow, config.vessel))
        self._command_topics = messages.command_topics(config.vessel.propulsion)
        self.state = np.zeros((1, 6))
        self.steering_rad: np.ndarray | None = None
        """(1, 2) the outboards' real angles; None until the first tick starts them where it drives them."""
        self.thrust_N: np.ndarray | None = None
        """(1, 2) the engines' thrust commands after their lag; None until the first tick starts them there."""
        self._issued: deque[tuple[int, np.ndarray]] = deque()
        """Commands issued (tick, row) that the boat does not act on yet (``vessel.command_delay_s``)."""
        self._acting: np.ndarray | None = None
        self.environments = config.environment.as_vector()[None, :]
        self.commands = np.zeros(4)
        self.epoch_s = epoch_s
        self.tick_index = 0
        self.tick_gnss: GnssMeasurements | None = None
        """This tick's GNSS fix (empty when it was lost; None off the GNSS rate): the measurements that front
        ends encode (ROS messages here, MAVLink in boat_twin.link)."""
        self.tick_imu: ImuMeasurements | None = None
        """This tick's UM7 sample (None off the IMU rate)."""
        rng = np.random.default_rng(seed)
        self._gnss_noise = GnssNoise(config.gnss, rng) if noise else None
        self._imu_noise = Um7Noise(config.um7, rng) if noise else None
        tick_times_s = np.array([0.0, 1.0 / OUTPUT_RATE_HZ])
        self._gnss_step = decimation_step(tick_times_s, config.gnss.rate_hz, "gnss.rate_hz")
        self._imu_step = decimation_step(tick_times_s, config.um7.rate_hz, "um7.rate_hz")
        history_ticks = math.ceil(config.gnss.latency_s * OUTPUT_RATE_HZ) + 2  # covers the fix's delayed state
        self._history: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = deque(
            maxlen=history_ticks)

    @property
    def time_s(self) -> float:
        """Absolute time of the next tick, s."""
        return self.epoch_s + self.tick_index / OUTPUT_RATE_HZ

    def set_command(self, index: int, value: float) -> None:
        """Set one command (0 thrust_left_N, 1 thrust_right_N, 2 angle_left_rad, 3 angle_right_rad); held."""
        if math.isfinite(value):
            self.commands[index] = value

    def _acting_command(self, issued: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """(1, 1, 4) the command the boat acts on this tick, (1, 1) when it takes over (s after the tick; None:
        at it) and (1, 4) the one before it: the command issued ⌊delay·rate⌋ ticks ago, from the rest of
        ``vessel.command_delay_s`` into this tick (as the batch simulator); the first issued one before any is
        due."""
        delay_ticks = self.config.vessel.command_delay_s * OUTPUT_RATE_HZ
        if delay_ticks == 0.0:
            return issued, None, issued[0]
        shift = math.floor(delay_ticks + 1e-9)
        self._issued.append((self.tick_index, issued[0, 0].copy()))
        previous = self._acting if self._acting is not None else issued[0, 0]
        while self._issued and self._issued[0][0] <= self.tick_index - shift:
            self._acting = self._issued.popleft()[1]
        acting = self._acting if self._acting is not None else issued[0, 0]
        switch = None
        if np.any(acting != previous):
            switch = np.array([[(delay_ticks - shift) / OUTPUT_RATE_HZ]])
        return acting[None, None, :], switch, previous[None, :].copy()

    def tick(self) -> list[messages.Message]:
        """Record this tick under the held commands (acting ``vessel.command_delay_s`` after they were issued,
        the engines' thrust lagging by ``vessel.thrust_time_constant_s``), step the dynamics one output period,
        return the messages."""
        commands = self.commands[None, None, :].copy()
        substeps = round(INTEGRATION_RATE_HZ / OUTPUT_RATE_HZ)
        acting, switch, before = self._acting_command(commands)
        if self.steering_rad is None or self.thrust_N is None:
            self.steering_rad = self.dynamics.steering_targets(acting[0])
            self.thrust_N = self.dynamics.thrust_start(acting[0])
        states, derivatives, steering = self.dynamics.run(self.state, acting, self.environments,
                                                          1.0 / INTEGRATION_RATE_HZ, substeps, self.steering_rad,
                                                          self.thrust_N, switch, before)
        now = self.time_s
        self._history.append((now, states[0], commands[0], derivatives[0], steering[0]))
        out = list(messages.command_messages(np.array([now]), commands[0], self._command_topics))
        out += self._sensor_messages()
        self.tick_index += 1
        return out

    def _recent_truth(self) -> TruthSeries:
        """The true motion over the buffered ticks (the current tick last)."""
        items = list(self._history)
        return SimulationRecord(
            t_s=np.array([i[0] for i in items]),
            states=np.array([i[1] for i in items]),
            commands=np.array([i[2] for i in items]),
            derivatives=np.array([i[3] for i in items]),
            environment=self.config.environment,
            steering_rad=np.array([i[4] for i in items]),
        ).truth()

    def _sensor_messages(self) -> list[messages.Message]:
        """This tick's GNSS fix and IMU sample (on their decimation phase, as in batch) and truth."""
        truth = self._recent_truth()
        last = slice(-1, None)
        out: list[messages.Message] = []
        gnss = self.config.gnss
        self.tick_gnss = self.tick_imu = None
        if self.tick_index % self._gnss_step == 0:
            expected = expected_fix(gnss, truth.t_s, truth.east_m, truth.north_m, truth.vel_east_mps,
                                    truth.vel_north_mps)
            if expected.has_state[-1]:
                errors = self._gnss_noise.step() if self._gnss_noise is not None else None
                self.tick_gnss = fixes(gnss, truth.t_s[last], expected.at(last), errors)
                out += messages.gnss_messages(self.tick_gnss)
        if self.tick_index % self._imu_step == 0:
            expected_sample = expected_imu(self.config.um7, truth.yaw_rad[last], truth.yaw_rate_radps[last],
                                           truth.accel_x_mps2[last], truth.accel_y_mps2[last])
            errors_imu = self._imu_noise.step() if self._imu_noise is not None else None
            self.tick_imu = imu_samples(self.config.um7, truth.t_s[last], expected_sample, errors_imu)
            out += messages.imu_messages(self.tick_imu)
        out += messages.truth_messages(TruthSeries(**{f.name: getattr(truth, f.name)[last] for f in fields(truth)}))
        return out
