"""Trials with an effect hidden in them: the test bed of the diagnosis (its tests and its accuracy study).

The *true* boat is the twin's config changed by one or more catalogue effects (or by a wind, which the
catalogue does not hold); the trial is simulated with it and written as a bag with the default sensor noise.
The diagnosis then sees only the bag. Effect sizes are drawn at random above the detection thresholds the
diagnosis promises (:attr:`~boat_twin.diagnose.effects.EffectSpec.threshold`), with a seeded generator; each
effect's own draw is in its registry entry (:data:`~boat_twin.diagnose.effects.EFFECTS`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.diagnose.effects import EFFECTS
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import CommandProfile, Scenario, Zigzag, make_scenario, random_commands
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ
from boat_twin.vessel.tow import TowConfig, tow_drag_N

TRIAL_SCENARIOS = {"thrust-steps": "thrust-steps", "zigzag": "zigzag-20-20", "random": "random"}
"""Kinds of trial the study draws from → the scenario each runs (:data:`~boat_twin.vessel.scenarios.SCENARIOS`)."""
TRIAL_KINDS = tuple(TRIAL_SCENARIOS)
"""Kinds of trial the study draws from, in the order the studies cycle through them."""
TOW_SPEEDS_MPS = (1.0, 1.5, 2.0, 1.25, 1.75)
"""Steady speeds of the towing trial, m/s: the 1-2 m/s the towed body is towed at."""


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
    if kind == "random":  # commands drawn over the whole trial (the registry's draws 600 s, then holds the last)
        return random_commands(params, rng, duration_s)
    chosen = make_scenario(TRIAL_SCENARIOS[kind], params, rng, duration_s)
    if isinstance(chosen, Zigzag):
        # A helm deciding at the 10 Hz log rate: the replay holds commands over the log's samples, so a reversal
        # between two samples (a faster helm) would be logged up to a sample late, a timing error the replay
        # cannot see (docs/diagnosis.md, limitations).
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

    ``name`` is a catalogue effect (drawn by its :attr:`~boat_twin.diagnose.effects.EffectSpec.draw`; a
    ``resistance_shape`` change needs ``speeds_mps``, the trial's :func:`visited_speeds_mps`) or ``wind``, a
    10-14 m/s wind from a random direction, outside the catalogue. The size and the sign ±1 are drawn first,
    for every name, so that a seed hides the same effect the same way whatever follows.
    """
    spec = EFFECTS.get(name)
    size = (spec.threshold if spec is not None else 1.0) * rng.uniform(1.2, 2.0)
    sign = float(rng.choice([-1.0, 1.0]))
    if spec is not None:
        return spec.draw(base, size, sign, rng, speeds_mps)
    if name == "wind":
        angle = rng.uniform(-math.pi, math.pi)
        speed = rng.uniform(10.0, 14.0)
        wind = Environment(wind_east_mps=speed * math.cos(angle), wind_north_mps=speed * math.sin(angle))
        return replace(base, environment=wind), {"wind_speed_mps": speed}
    raise ValueError(f"unknown effect {name!r}")


def write_trial(path: Path, config: TwinConfig, kind: str, seed: int, duration_s: float = 600.0) -> Path:
    """Simulate a ``kind`` trial of the true boat ``config`` (default sensor noise) into the bag ``path``."""
    rng = np.random.default_rng(seed)
    trial = run_sea_trial(config, scenario(kind, config.vessel, rng, duration_s, config.tow), seed)
    write_bag(path, trial_messages(trial, truth=False), force=True)
    return path
