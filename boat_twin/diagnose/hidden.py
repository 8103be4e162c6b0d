"""Trials with an effect hidden in them: the test bed of the diagnosis (its tests and its accuracy study).

The *true* boat is the twin's config changed by one or more catalogue effects; the trial is simulated with it
and written as a bag with the default sensor noise. The diagnosis then sees only the bag. Effect sizes are
drawn at random above the detection thresholds the diagnosis promises
(:attr:`~boat_twin.diagnose.effects.EffectSpec.threshold`), with a seeded generator; each effect's own draw is
in its registry entry (:data:`~boat_twin.diagnose.effects.EFFECTS`).

:data:`PROBES` are causes the catalogue does not hold, made here without it (no registry entry is used): a
sensor scale error applied to the recorded gyro, and two actuator faults between what the helm commands
(what the bag records) and what the outboards deliver (what the boat feels). The diagnosis must call them
unexplained, never name a catalogue effect for them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.diagnose.effects import EFFECTS
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import CommandProfile, Helm, Scenario, Zigzag, make_scenario
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ
from boat_twin.vessel.tow import TowConfig, tow_drag_N

TRIAL_SCENARIOS = {"thrust-steps": "thrust-steps", "zigzag": "zigzag-20-20", "random": "random"}
"""Kinds of trial the study draws from → the scenario each runs (:data:`~boat_twin.vessel.scenarios.SCENARIOS`)."""
TRIAL_KINDS = tuple(TRIAL_SCENARIOS)
"""Kinds of trial the study draws from, in the order the studies cycle through them."""
TOW_SPEEDS_MPS = (1.0, 1.5, 2.0, 1.25, 1.75)
"""Steady speeds of the towing trial, m/s: the 1-2 m/s the towed body is towed at."""
GYRO_SCALE = 1.05
"""Probe ``gyro_scale``: the recorded gyro's z axis reads this factor × the true yaw rate (5 % high; a MEMS
gyro's scale-factor error is specified at 1-3 %, an uncalibrated one can be worse)."""
THRUST_LOSS_AT_FULL_STEERING = 0.3
"""Probe ``steering_thrust_loss``: an outboard steered to its limit delivers this fraction less thrust,
linearly in |angle| (propeller ventilating in a hard turn); the catalogue's asymmetry is a constant factor."""
STEERING_DEAD_BAND_RAD = 0.07
"""Probe ``steering_dead_band``: play in the steering linkage, rad (4°): the outboard turns by the commanded
angle less this, zero inside it; the catalogue's steering offset is a constant angle."""
PROBES = ("gyro_scale", "steering_thrust_loss", "steering_dead_band")
"""Causes outside the catalogue, made by :func:`write_probe_trial`."""


def scenario(kind: str, params: VesselParams, rng: np.random.Generator, duration_s: float,
             tow: TowConfig | None = None) -> Scenario:
    """A trial of ``kind`` lasting ``duration_s``; with a tow, thrust steps at the towing speeds instead."""
    if tow is not None:
        speeds = np.array(TOW_SPEEDS_MPS)
        levels = params.resistance.force_N(speeds) + tow_drag_N(tow, speeds, params.resistance.max_speed_mps)
        times = np.arange(levels.size) * duration_s / levels.size
        rows = np.column_stack([levels / 2, levels / 2, np.zeros((levels.size, 2))])
        return CommandProfile("tow-steps", times, rows, duration_s, float(speeds[0]))
    if kind not in TRIAL_SCENARIOS:
        raise ValueError(f"unknown trial kind {kind!r}")
    chosen = make_scenario(TRIAL_SCENARIOS[kind], params, rng, duration_s)
    if isinstance(chosen, Zigzag):
        # A helm deciding at the 10 Hz log rate: its commands lie on the log's samples, which the replay holds
        # them over; a faster helm's reversal is replayed up to half a sample early or late (docs/diagnosis.md,
        # limitations), a small timing noise kept out of the hidden-effect trials.
        return replace(chosen, decision_rate_hz=OUTPUT_RATE_HZ)
    return chosen


def visited_speeds_mps(config: TwinConfig, kind: str, seed: int, duration_s: float) -> np.ndarray:
    """Surge speed at every sample of the ``kind`` trial :func:`write_trial` runs with ``seed``, m/s (simulated
    without noise): where a resistance change can be seen at all."""
    rng = np.random.default_rng(seed)
    record = run_sea_trial(config, scenario(kind, config.vessel, rng, duration_s, config.tow), seed,
                           noise=False).record
    return record.states[:, 0, 3]


def draw_effect(name: str, base: TwinConfig, rng: np.random.Generator,
                speeds_mps: np.ndarray | None = None) -> tuple[TwinConfig, dict[str, Any]]:
    """The true config with effect ``name`` at a random size 1.2-2× its threshold (a ``tow_load`` at 1-2.5×),
    and the truth to find.

    ``name`` is a catalogue effect, drawn by its :attr:`~boat_twin.diagnose.effects.EffectSpec.draw` (a
    ``resistance_shape`` change needs ``speeds_mps``, the trial's :func:`visited_speeds_mps`). The size and the
    sign ±1 are drawn first, so that a seed hides the same effect the same way whatever follows.
    """
    spec = EFFECTS.get(name)
    if spec is None:
        raise ValueError(f"unknown effect {name!r}")
    size = spec.threshold * rng.uniform(1.2, 2.0)
    sign = float(rng.choice([-1.0, 1.0]))
    return spec.draw(base, size, sign, rng, speeds_mps)


def write_trial(path: Path, config: TwinConfig, kind: str, seed: int, duration_s: float = 600.0) -> Path:
    """Simulate a ``kind`` trial of the true boat ``config`` (default sensor noise) into the bag ``path``."""
    rng = np.random.default_rng(seed)
    trial = run_sea_trial(config, scenario(kind, config.vessel, rng, duration_s, config.tow), seed)
    write_bag(path, trial_messages(trial, truth=False), force=True)
    return path


@dataclass
class _Delivered:
    """A scenario whose commands reach the outboards changed by ``deliver``; it keeps what was commanded."""

    scenario: Scenario
    deliver: Callable[[np.ndarray], np.ndarray]
    commanded: list[np.ndarray] = field(default_factory=list)
    """The commanded (N, 4) rows at the output ticks (what the command log records)."""

    @property
    def name(self) -> str:
        """The commanded scenario's name."""
        return self.scenario.name

    @property
    def duration_s(self) -> float:
        """Its length, s."""
        return self.scenario.duration_s

    @property
    def initial_surge_mps(self) -> float:
        """Its initial surge, m/s."""
        return self.scenario.initial_surge_mps

    def helm(self, n_boats: int) -> _DeliveredHelm:
        """The commanded scenario's own fresh helm, its commands changed on the way to the outboards."""
        return _DeliveredHelm(self, self.scenario.helm(n_boats))


class _DeliveredHelm:
    """One run of a :class:`_Delivered`. The simulator asks a closed-loop helm at every integration step; this
    one asks the scenario at the output ticks only and holds what it delivers in between, as the simulator holds
    an open-loop scenario's commands, so the trial has the same commands as :func:`write_trial`'s."""

    def __init__(self, delivered: _Delivered, inner: Helm) -> None:
        self.delivered = delivered
        self.inner = inner
        self.held: np.ndarray | None = None

    def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
        """What the outboards deliver of the scenario's command at the last output tick up to ``t_s``."""
        if self.held is None or abs(t_s * OUTPUT_RATE_HZ - round(t_s * OUTPUT_RATE_HZ)) < 1e-6:
            row = self.inner.command(t_s, states)
            self.delivered.commanded.append(row.copy())
            self.held = self.delivered.deliver(row)
        return self.held


def _thrust_loss(params: VesselParams, rows: np.ndarray) -> np.ndarray:
    out = rows.copy()
    steered = np.minimum(np.abs(rows[:, 2:]) / params.max_steering_rad, 1.0)
    out[:, :2] = rows[:, :2] * (1.0 - THRUST_LOSS_AT_FULL_STEERING * steered)
    return out


def _dead_band(params: VesselParams, rows: np.ndarray) -> np.ndarray:
    out = rows.copy()
    out[:, 2:] = np.sign(rows[:, 2:]) * np.maximum(np.abs(rows[:, 2:]) - STEERING_DEAD_BAND_RAD, 0.0)
    return out


def write_probe_trial(path: Path, probe: str, kind: str, seed: int, duration_s: float = 600.0,
                      config: TwinConfig | None = None) -> Path:
    """The ``kind`` trial :func:`write_trial` makes with ``seed`` (same commands, same sensor noise), with the
    out-of-catalogue cause ``probe`` (one of :data:`PROBES`) in it, written to the bag ``path``."""
    config = config or TwinConfig()
    commanded = scenario(kind, config.vessel, np.random.default_rng(seed), duration_s, config.tow)
    if probe == "gyro_scale":
        trial = run_sea_trial(config, commanded, seed)
        trial = replace(trial, imu=replace(trial.imu, gyro_radps=trial.imu.gyro_radps * [1.0, 1.0, GYRO_SCALE]))
    elif probe in ("steering_thrust_loss", "steering_dead_band"):
        fault = _thrust_loss if probe == "steering_thrust_loss" else _dead_band
        delivered = _Delivered(commanded, lambda rows: fault(config.vessel, rows))
        trial = run_sea_trial(config, delivered, seed)
        # the bag records what the helm commanded; the boat moved with what the outboards delivered
        trial = replace(trial, record=replace(trial.record, commands=np.stack(delivered.commanded)))
    else:
        raise ValueError(f"unknown probe {probe!r}")
    write_bag(path, trial_messages(trial, truth=False), force=True)
    return path
