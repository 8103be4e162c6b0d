"""A simulated sea trial end to end: scenario → dynamics → GNSS and UM7 models → time-ordered ROS 2 messages.

:func:`run_sea_trial` keeps the whole :class:`SimulationRecord` (every state, derivative and command) and all
measurements. :func:`run_compact_trial` gives the same messages, bit for bit, from a simulation run in chunks
of :data:`CHUNK_S` that keeps only boat 0's truth and the published command rows; the sensors measure that
truth a chunk at a time while the bag writer takes the messages, so a long trial holds its truth (88 bytes per
tick), not its measurements or messages.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterator
from dataclasses import dataclass, fields

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.frames import quaternion_yaw_rad
from boat_twin.io import messages
from boat_twin.io.roles import COMMAND_ROLES
from boat_twin.io.trial import Stream, Trial, build_trial
from boat_twin.sensors.gnss import GnssMeasurements, GnssModel
from boat_twin.sensors.um7 import ImuMeasurements, Um7Model
from boat_twin.vessel.scenarios import Scenario
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, SimulationRecord, output_ticks, simulate, simulate_chunks
from boat_twin.vessel.tow import tow_drag_table
from boat_twin.vessel.truth import TruthSeries

COMMAND_HEARTBEAT_S = 1.0
"""Command topics are logged when a value changes and at least once per this period, s (as a helm or
autopilot driver publishes them); the reader holds each value until the next message."""
CHUNK_S = 60.0
"""Simulated time per chunk of :func:`run_compact_trial`, s."""


@dataclass(frozen=True)
class SeaTrial:
    """The truth and what the sensors measured during one simulated trial."""

    record: SimulationRecord
    gnss: GnssMeasurements
    imu: ImuMeasurements


@dataclass(frozen=True)
class CompactTrial:
    """One simulated trial as the bag needs it: boat 0's truth, the published commands, and what measures them
    (the sensors of ``config``, noise seeded by ``seed``)."""

    truth: TruthSeries
    command_t_s: np.ndarray
    """Times of the published command rows, s (see :class:`CommandLog`), shape (m,)."""
    commands: np.ndarray
    """Published command rows (m, 4): thrust_left_N, thrust_right_N, angle_left_rad, angle_right_rad."""
    config: TwinConfig
    seed: int
    noise: bool


def run_sea_trial(config: TwinConfig, scenario: Scenario, seed: int, noise: bool = True) -> SeaTrial:
    """Simulate ``scenario`` with the boat, sea and sensors of ``config``; one seeded RNG drives all noise."""
    rng = np.random.default_rng(seed)
    record = simulate(config.vessel, scenario, config.environment,
                      extra_drag_N=tow_drag_table(config.tow, config.vessel))
    truth = record.truth()
    gnss = GnssModel(config.gnss, rng, noise=noise).measure(truth)
    imu = Um7Model(config.um7, rng, noise=noise).measure(truth)
    return SeaTrial(record, gnss, imu)


def run_compact_trial(config: TwinConfig, scenario: Scenario, seed: int, noise: bool = True,
                      chunk_s: float = CHUNK_S, progress: Callable[[float], None] | None = None) -> CompactTrial:
    """:func:`run_sea_trial` for a long trial: the same truth and commands (bit for bit), from a simulation run
    ``chunk_s`` seconds at a time that keeps 88 bytes of truth per tick instead of the record (filled in place,
    chunk by chunk). :func:`compact_trial_messages` measures it. ``progress(t_s)``: called after each chunk with
    the simulated time reached, s."""
    chunks = simulate_chunks(config.vessel, scenario, config.environment,
                             extra_drag_N=tow_drag_table(config.tow, config.vessel),
                             chunk_ticks=max(1, round(chunk_s * OUTPUT_RATE_HZ)))
    log = CommandLog()
    command_t_s, commands = [], []
    columns = {f.name: np.empty(output_ticks(scenario.duration_s)) for f in fields(TruthSeries)}
    start = 0
    for chunk in chunks:
        rows = chunk.commands[:, 0, :]
        ticks = log.ticks(chunk.t_s, rows)
        command_t_s.append(chunk.command_stamps_s()[ticks])
        commands.append(rows[ticks])
        piece, stop = chunk.truth(), start + chunk.t_s.size
        for name, column in columns.items():
            column[start:stop] = getattr(piece, name)
        start = stop
        if progress is not None and chunk.t_s.size:
            progress(float(chunk.t_s[-1]))
    truth = TruthSeries(**columns)
    return CompactTrial(truth, np.concatenate(command_t_s), np.concatenate(commands), config, seed, noise)


class CommandLog:
    """Picks the command ticks to publish, chunk after chunk: on change, and at least every ``heartbeat_s``."""

    def __init__(self, heartbeat_s: float = COMMAND_HEARTBEAT_S) -> None:
        self.heartbeat_s = heartbeat_s
        self._last_t = -np.inf
        self._last_row: np.ndarray | None = None

    def ticks(self, t_s: np.ndarray, commands: np.ndarray) -> np.ndarray:
        """Indices into this chunk's ticks ``t_s`` (n,) and ``commands`` (n, 4) of the rows to publish."""
        keep = []
        for i, (t, row) in enumerate(zip(t_s, commands, strict=True)):
            if (self._last_row is None or not np.array_equal(row, self._last_row)
                    or t - self._last_t >= self.heartbeat_s - 1e-9):
                keep.append(i)
                self._last_t, self._last_row = t, row.copy()
        return np.array(keep, dtype=int)


def command_log_ticks(t_s: np.ndarray, commands: np.ndarray, heartbeat_s: float = COMMAND_HEARTBEAT_S) -> np.ndarray:
    """Indices of the ticks at which the commands are published: on change, and every ``heartbeat_s``."""
    return CommandLog(heartbeat_s).ticks(t_s, commands)


def _merged(command_t_s: np.ndarray, commands: np.ndarray, gnss: GnssMeasurements, imu: ImuMeasurements,
            truth: TruthSeries | None, topics: dict[str, str] | None = None,
            wind: tuple[np.ndarray, float, float] | None = None) -> Iterator[messages.Message]:
    streams = [
        messages.command_messages(command_t_s, commands, topics),
        messages.gnss_messages(gnss),
        messages.imu_messages(imu),
    ]
    if wind is not None:  # an anemometer: the true wind, when the environment has one
        streams.append(messages.wind_messages(*wind))
    if truth is not None:
        streams.append(messages.truth_messages(truth))
    return heapq.merge(*streams, key=lambda m: m[1])


def _anemometer(config: TwinConfig, t_s: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """The anemometer's message times among ``t_s`` (every :data:`~boat_twin.io.messages.WIND_MESSAGE_PERIOD_S`)
    and the environment's wind (east, north, m/s); None in calm air (no anemometer topic)."""
    env = config.environment
    if env.wind_east_mps == 0.0 and env.wind_north_mps == 0.0:
        return None
    ticks = np.round(t_s / messages.WIND_MESSAGE_PERIOD_S, 9)
    return t_s[ticks == np.floor(ticks)], env.wind_east_mps, env.wind_north_mps


def trial_messages(trial: SeaTrial, truth: bool = True) -> Iterator[messages.Message]:
    """All messages of the trial, merged in stamp order: commands, GNSS, UM7 and (optionally) ground truth."""
    record = trial.record
    commands = record.commands[:, 0, :]
    ticks = command_log_ticks(record.t_s, commands)
    return _merged(record.command_stamps_s()[ticks], commands[ticks], trial.gnss, trial.imu,
                   record.truth() if truth else None)


def actual_angle_on_grid(record: SimulationRecord, boat: int, trial: Trial) -> np.ndarray:
    """Boat ``boat``'s outboards' actual steering angle (mean of the two, the actuator state the simulator
    integrates) on the grid of ``trial`` (a recording of that run: its t = 0 is the record's time
    ``trial.metadata.start_time_s``), linearly interpolated, NaN outside the run, rad."""
    angle = record.steering_rad[:, boat].mean(axis=1)
    return np.interp(trial.t_s + trial.metadata.start_time_s, record.t_s, angle, left=np.nan, right=np.nan)


def measured_trial(record: SimulationRecord, boat: int, config: TwinConfig, rng: np.random.Generator,
                   noise: bool = True) -> Trial:
    """Boat ``boat`` of ``record`` as a recorded trial, without a bag: its truth measured by the GNSS and UM7
    models of ``config`` (noise from ``rng``, GNSS then UM7, as :func:`run_sea_trial` draws it) and its commands
    at every tick (held between ticks, they are the logged ones on the grid), put on the trial grid by
    :func:`~boat_twin.io.trial.build_trial` from the values and stamps (ns-rounded) the bag would carry: equal
    to :func:`run_sea_trial` → bag → ``read_trial`` for the same seed, up to rounding (stamps read back from
    sec + nanosec differ by picoseconds). For the many trials of a training set,
    where the bag's serialisation would cost more than the simulation. The trial carries the outboards' actual
    angle (:func:`actual_angle_on_grid`), which a bag does not."""
    truth = record.truth(boat)
    gnss = GnssModel(config.gnss, rng, noise=noise).measure(truth)
    imu = Um7Model(config.um7, rng, noise=noise).measure(truth)
    commands = record.commands[:, boat, :]

    def stamped(t_s: np.ndarray, *columns: np.ndarray) -> Stream:
        return Stream(messages.stamps_ns(t_s) * 1e-9, np.column_stack(columns))

    yaw = quaternion_yaw_rad(*imu.quaternion_xyzw.T)  # as the bag reader takes it from the orientation
    streams = {role: stamped(record.command_stamps_s(boat), commands[:, k])
               for k, role in enumerate(COMMAND_ROLES)}
    streams["gnss_fix"] = stamped(gnss.stamp_s, gnss.lat_deg, gnss.lon_deg, gnss.alt_m)
    streams["gnss_vel"] = stamped(gnss.stamp_s, gnss.vel_east_mps, gnss.vel_north_mps)
    streams["imu"] = stamped(imu.stamp_s, yaw, imu.gyro_radps[:, 2], imu.accel_mps2[:, 0], imu.accel_mps2[:, 1])
    topics = {"gnss_fix": messages.TOPIC_GNSS_FIX, "gnss_vel": messages.TOPIC_GNSS_VEL,
              "imu": messages.TOPIC_IMU_DATA}
    trial = build_trial(streams, f"simulated boat {boat}", topics, release=True)
    trial.actual_angle_rad = actual_angle_on_grid(record, boat, trial)
    return trial


def compact_trial_messages(trial: CompactTrial, truth: bool = True,
                           chunk_s: float = CHUNK_S) -> Iterator[messages.Message]:
    """:func:`trial_messages` of a :class:`CompactTrial`: the same messages, measured and built ``chunk_s``
    seconds of truth at a time (the noise drawn as :func:`run_sea_trial` draws it: one RNG seeded by the
    trial's seed, GNSS then UM7)."""
    chunk_ticks = max(1, round(chunk_s * OUTPUT_RATE_HZ))
    rng = np.random.default_rng(trial.seed)
    gnss = GnssModel(trial.config.gnss, rng, noise=trial.noise).measure_chunks(trial.truth, chunk_ticks)
    imu = Um7Model(trial.config.um7, rng, noise=trial.noise).measure_chunks(trial.truth, chunk_ticks)
    t_s = trial.truth.t_s
    for start, gnss_block, imu_block in zip(range(0, max(t_s.size, 1), chunk_ticks), gnss, imu, strict=True):
        stop = start + chunk_ticks
        lo, hi = t_s[start] if t_s.size else 0.0, t_s[stop] if stop < t_s.size else np.inf
        rows = slice(*np.searchsorted(trial.command_t_s, (lo, hi)))  # the times increase: no scan of all rows
        piece = TruthSeries(**{f.name: getattr(trial.truth, f.name)[start:stop] for f in fields(TruthSeries)})
        yield from _merged(trial.command_t_s[rows], trial.commands[rows], gnss_block, imu_block,
                           piece if truth else None, messages.command_topics(trial.config.vessel.propulsion),
                           _anemometer(trial.config, t_s[start:stop]))
