"""A trial as the time-ordered samples a live boat sends: what ``follow``, the shadow node's tests and the bag player
stream (a layer below the live twin, so that playing a bag imports no analysis)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from boat_twin.frames import wrap_pi
from boat_twin.io.roles import COMMAND_ROLES
from boat_twin.io.trial import Trial

COMMAND_HEARTBEAT_S = 1.0
"""A held command is fed again at least this often, s."""
BLOCK_SAMPLES = 4096
"""Samples turned into Python numbers at a time (a whole hours-long trial as Python floats would take ~1 kB a
sample)."""


def trial_samples(trial: Trial) -> Iterator[tuple[str, float, tuple[float, ...]]]:
    """The samples of ``trial`` as a live boat sends them, in time order: (kind, stamp s, values) for
    :meth:`Shadow.add` (see the module docstring); a command that changed between samples at the instant it was
    issued (:attr:`~boat_twin.io.trial.Trial.command_switch_s`), as its own message was stamped."""
    columns = {
        "gnss_fix": (trial.lat_deg, trial.lon_deg, np.zeros_like(trial.lat_deg)),
        "gnss_vel": (trial.vel_east_mps, trial.vel_north_mps),
        "imu": (wrap_pi(trial.heading_rad), trial.yaw_rate_radps, trial.accel_x_mps2, trial.accel_y_mps2),
    }
    if trial.wind_east_mps is not None and trial.wind_north_mps is not None:
        columns["wind"] = (trial.wind_east_mps, trial.wind_north_mps)
    held = [math.nan] * 4
    sent = [-math.inf] * 4
    switch = np.zeros(trial.t_s.size) if trial.command_switch_s is None else trial.command_switch_s
    for start in range(0, trial.t_s.size, BLOCK_SAMPLES):
        block = slice(start, start + BLOCK_SAMPLES)
        sensors = {kind: np.column_stack([column[block] for column in values]) for kind, values in columns.items()}
        rows = {kind: values.tolist() for kind, values in sensors.items()}
        finite = {kind: np.all(np.isfinite(values[:, :2]), axis=1).tolist() for kind, values in sensors.items()}
        for i, (t, command_row, late_s) in enumerate(zip(trial.t_s[block].tolist(), trial.commands[block].tolist(),
                                                         switch[block].tolist(), strict=True)):
            commands = []
            for k, value in enumerate(command_row):
                if math.isfinite(value) and (value != held[k] or t - sent[k] >= COMMAND_HEARTBEAT_S):
                    commands.append((COMMAND_ROLES[k], t + late_s if value != held[k] else t, (value,)))
                    held[k], sent[k] = value, t
            commands.sort(key=lambda command: command[1])
            yield from (c for c in commands if c[1] <= t)
            for kind in sensors:
                if finite[kind][i]:
                    yield kind, t, tuple(rows[kind][i])
            yield from (c for c in commands if c[1] > t)  # issued after this sample's time: after its sensors
