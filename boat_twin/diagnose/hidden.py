"""Trials with an effect hidden in them: the test bed of the diagnosis (its tests and its accuracy study).

The *true* boat is the twin's config changed by one or more catalogue effects (or by a wind, which the
catalogue does not hold); the trial is simulated with it and written as a bag with the default sensor noise.
The diagnosis then sees only the bag. Effect sizes are drawn at random above the detection thresholds the
diagnosis promises (:data:`THRESHOLDS`), with a seeded generator.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.resistance import CorrectedResistance
from boat_twin.vessel.scenarios import CommandProfile, Scenario, Zigzag, random_commands, thrust_steps
from boat_twin.vessel.tow import TowConfig, tow_drag_N

THRESHOLDS = {
    "water_current": 0.15,  # m/s
    "gyro_bias": 0.005,  # rad/s
    "gnss_latency": 0.3,  # s
    "thrust_asymmetry": 0.08,  # fraction
    "steering_offset": math.radians(1.5),  # rad
    "mass_error": 0.20,  # fraction
    "resistance_shape": 0.10,  # fraction over a speed band
    "tow_load": 50.0,  # m of cable, towing at 1-2 m/s
}
"""The smallest size of each effect the diagnosis must detect (issue 5), SI."""
BAND_TIME_SHARE = 0.4
"""A hidden resistance change covers the speeds where the trial spends this share of its time."""
TRIAL_KINDS = ("thrust-steps", "zigzag", "random")
"""Kinds of trial the study draws from."""
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
    if kind == "thrust-steps":
        return replace(thrust_steps(params), duration_s=duration_s)
    if kind == "zigzag":
        zigzag = Zigzag(params, math.radians(20.0), math.radians(20.0), duration_s=duration_s, name="zigzag")
        zigzag.initial_surge_mps = zigzag.speed_mps
        return zigzag
    if kind == "random":
        return random_commands(params, rng, duration_s)
    raise ValueError(f"unknown trial kind {kind!r}")


def visited_speeds_mps(config: TwinConfig, kind: str, seed: int, duration_s: float) -> np.ndarray:
    """Surge speed at every sample of the ``kind`` trial :func:`write_trial` runs with ``seed``, m/s (simulated
    without noise): where a resistance change can be seen at all."""
    rng = np.random.default_rng(seed)
    record = run_sea_trial(config, scenario(kind, config.vessel, rng, duration_s, config.tow), seed,
                           noise=False).record
    return record.states[:, 0, 3]


def draw_effect(name: str, base: TwinConfig, rng: np.random.Generator,
                speeds_mps: np.ndarray | None = None) -> tuple[TwinConfig, dict[str, Any]]:
    """The true config with effect ``name`` at a random size 1.2-2× its threshold, and the truth to find.

    A ``resistance_shape`` change covers the speeds where the trial spends 40 % of its time (between two
    quantiles of ``speeds_mps``, the trial's :func:`visited_speeds_mps`, drawn at random), with ramps a fifth of
    its width at both ends.
    """
    size = THRESHOLDS.get(name, 1.0) * rng.uniform(1.2, 2.0)
    sign = float(rng.choice([-1.0, 1.0]))
    vessel = base.vessel
    if name == "water_current":
        angle = rng.uniform(-math.pi, math.pi)
        east, north = size * math.cos(angle), size * math.sin(angle)
        return replace(base, environment=replace(base.environment, current_east_mps=east,
                                                 current_north_mps=north)), {"east_mps": east, "north_mps": north}
    if name == "gyro_bias":
        biased = replace(base.um7, gyro_bias_radps=(0.0, 0.0, sign * size))
        return replace(base, um7=biased), {"bias_radps": sign * size}
    if name == "gnss_latency":
        delay = base.gnss.latency_s + size
        return replace(base, gnss=replace(base.gnss, latency_s=delay)), {"delay_s": delay}
    if name == "thrust_asymmetry":
        factors = (1.0 - size, 1.0) if sign > 0 else (1.0, 1.0 - size)
        return (replace(base, vessel=replace(vessel, thrust_factor_left=factors[0], thrust_factor_right=factors[1])),
                {"left_factor": factors[0], "right_factor": factors[1]})
    if name == "steering_offset":
        return replace(base, vessel=replace(vessel, steering_offset_rad=sign * size)), {"offset_rad": sign * size}
    if name == "mass_error":
        factor = 1.0 + sign * size
        return replace(base, vessel=replace(vessel, mass_kg=vessel.mass_kg * factor)), {"mass_factor": factor}
    if name == "resistance_shape":
        if speeds_mps is None:
            raise ValueError("a resistance_shape change needs the speeds the trial visits")
        quantile = rng.uniform(0.1, 0.5)
        low, high = (float(v) for v in np.quantile(speeds_mps, [quantile, quantile + BAND_TIME_SHARE]))
        width = max(high - low, 0.1)
        ramp = 0.2 * width
        knots = (max(low - ramp, 0.0), low, low + width, low + width + ramp)
        factors = (1.0, 1.0 + sign * size, 1.0 + sign * size, 1.0)
        resistance = CorrectedResistance(vessel.resistance, knots, factors)
        return replace(base, vessel=replace(vessel, resistance=resistance)), {"band_mps": [low, low + width],
                                                                               "change": sign * size}
    if name == "tow_load":
        scale = rng.uniform(0.6, 1.5)
        return replace(base, tow=TowConfig(drag_scale=scale)), {"drag_scale": scale}
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
