"""A simulated sea trial end to end: scenario → dynamics → GNSS and UM7 models → time-ordered ROS 2 messages."""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.sensors.gnss import GnssMeasurements, GnssModel
from boat_twin.sensors.um7 import ImuMeasurements, Um7Model
from boat_twin.vessel.scenarios import Scenario
from boat_twin.vessel.simulate import SimulationRecord, simulate
from boat_twin.vessel.tow import tow_drag_table

COMMAND_HEARTBEAT_S = 1.0
"""Command topics are logged when a value changes and at least once per this period, s (as a helm or
autopilot driver publishes them); the reader holds each value until the next message."""


@dataclass(frozen=True)
class SeaTrial:
    """The truth and what the sensors measured during one simulated trial."""

    record: SimulationRecord
    gnss: GnssMeasurements
    imu: ImuMeasurements


def run_sea_trial(config: TwinConfig, scenario: Scenario, seed: int, noise: bool = True) -> SeaTrial:
    """Simulate ``scenario`` with the boat, sea and sensors of ``config``; one seeded RNG drives all noise."""
    rng = np.random.default_rng(seed)
    record = simulate(config.vessel, scenario, config.environment,
                      extra_drag_N=tow_drag_table(config.tow, config.vessel))
    truth = record.truth()
    gnss = GnssModel(config.gnss, rng, noise=noise).measure(truth)
    imu = Um7Model(config.um7, rng, noise=noise).measure(truth)
    return SeaTrial(record, gnss, imu)


def command_log_ticks(t_s: np.ndarray, commands: np.ndarray, heartbeat_s: float = COMMAND_HEARTBEAT_S) -> np.ndarray:
    """Indices of the ticks at which the commands are published: on change, and every ``heartbeat_s``."""
    keep, last_t, last_row = [], -np.inf, None
    for i, (t, row) in enumerate(zip(t_s, commands, strict=True)):
        if last_row is None or not np.array_equal(row, last_row) or t - last_t >= heartbeat_s - 1e-9:
            keep.append(i)
            last_t, last_row = t, row
    return np.array(keep, dtype=int)


def trial_messages(trial: SeaTrial, truth: bool = True) -> Iterator[messages.Message]:
    """All messages of the trial, merged in stamp order: commands, GNSS, UM7 and (optionally) ground truth."""
    record = trial.record
    commands = record.commands[:, 0, :]
    ticks = command_log_ticks(record.t_s, commands)
    streams = [
        messages.command_messages(record.t_s[ticks], commands[ticks]),
        messages.gnss_messages(trial.gnss),
        messages.imu_messages(trial.imu),
    ]
    if truth:
        streams.append(messages.truth_messages(record.truth()))
    return heapq.merge(*streams, key=lambda m: m[1])
