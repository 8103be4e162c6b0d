"""Hidden boats and their zigzag trials: the test bed of the manoeuvring identification (tests and benchmark).

A hidden boat is the twin's vessel with every manoeuvring coefficient drawn within ±:data:`SPREAD` of its
derived value (x_c and the steering offset by absolute amounts), kept only when directionally stable. Its trials
are IMO zigzags simulated with the default sensor noise and read back from a bag, as a recorded trial is:
starboard-first by the closed-loop :class:`~boat_twin.vessel.scenarios.Zigzag`, port-first as the mirror of
those commands replayed open loop on the same boat.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.trial import Trial
from boat_twin.twin.sea_trial import SeaTrial, actual_angle_on_grid, run_sea_trial, trial_messages
from boat_twin.vessel.params import MANOEUVRING_KEYS, derive_coefficients
from boat_twin.vessel.scenarios import CommandProfile, Scenario, Zigzag
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

SPREAD = 0.3
"""Relative spread of each hidden coefficient (uniform ±30 %)."""
LATERAL_CENTRE_SPREAD_M = 0.3
"""Spread of the hidden lateral-resistance centre x_c, m (±30 % of the default −1 m)."""
STEERING_OFFSET_SPREAD_RAD = math.radians(1.0)
"""Spread of the hidden steering offset, rad (a linkage set within ±1°)."""
ZIGZAG_SPEEDS_MPS = (4.0, 7.0)
"""Approach speeds of the zigzag set, m/s."""
ZIGZAG_ANGLES_DEG = (20.0, 10.0)
"""Zigzags of the set: 20°/20° and 10°/10°."""
ZIGZAG_S = 120.0
"""Length of each zigzag trial, s: 10 s approach and 110 s of zigzag, six 20 s replay windows."""


def draw_boat(base: TwinConfig, rng: np.random.Generator) -> tuple[TwinConfig, dict[str, float]]:
    """A directionally stable hidden boat around ``base`` and its true coefficients (``manoeuvring`` keys)."""
    coeff = derive_coefficients(base.vessel)
    while True:
        truth = {key: float(getattr(coeff, key)) * rng.uniform(1.0 - SPREAD, 1.0 + SPREAD) for key in MANOEUVRING_KEYS}
        truth["lateral_centre_x_m"] = base.vessel.lateral_centre_x_m + rng.uniform(-1.0, 1.0) * LATERAL_CENTRE_SPREAD_M
        truth["steering_offset_rad"] = rng.uniform(-1.0, 1.0) * STEERING_OFFSET_SPREAD_RAD
        # Linearized sway-yaw stability (derive_coefficients): a_v·a_r > m11·(m22 − m11 + x_c·a_v).
        munk = truth["m22_kg"] - coeff.m11_kg
        if truth["sway_damping_Nspm2"] * truth["yaw_damping_Nms"] > coeff.m11_kg * (
                munk + truth["lateral_centre_x_m"] * truth["sway_damping_Nspm2"]):
            break
    vessel = replace(base.vessel, manoeuvring={k: truth[k] for k in MANOEUVRING_KEYS},
                     lateral_centre_x_m=truth["lateral_centre_x_m"], steering_offset_rad=truth["steering_offset_rad"])
    return replace(base, vessel=vessel), truth


def mirrored(trial: SeaTrial, name: str) -> CommandProfile:
    """The commands of ``trial`` with the steering mirrored (port ↔ starboard), as an open-loop profile."""
    record = trial.record
    values = record.commands[:, 0, :].copy()
    values[:, 2:] *= -1.0
    return CommandProfile(name, record.t_s, values, float(record.t_s[-1]), float(record.states[0, 0, 3]))


def zigzag_scenarios(config: TwinConfig, speeds_mps: Sequence[float] = ZIGZAG_SPEEDS_MPS,
                     angles_deg: Sequence[float] = ZIGZAG_ANGLES_DEG, duration_s: float = ZIGZAG_S
                     ) -> list[Scenario]:
    """Starboard-first zigzags of the set (each angle at each speed), with a helm deciding at the 10 Hz log rate
    so that the recorded commands are exactly the ones that steered (a helm between log samples is replayed
    from the nearest sample, ±50 ms: timing noise the study leaves out; docs/manoeuvring.md)."""
    return [Zigzag(config.vessel, math.radians(a), math.radians(a), speed_mps=s, duration_s=duration_s,
                   name=f"zigzag-{a:g}-{a:g}-{s:g}mps", decision_rate_hz=OUTPUT_RATE_HZ)
            for s in speeds_mps for a in angles_deg]


def recorded(trial: SeaTrial, name: str, directory: Path) -> Trial:
    """``trial`` as a recorded trial: written to a bag without truth and read back, with the outboards' actual
    angle the simulator knows (a boat with a rudder-angle indicator; the bag has no topic for it)."""
    path = directory / name
    write_bag(path, trial_messages(trial, truth=False), force=True)
    out = read_trial(path)
    out.actual_angle_rad = actual_angle_on_grid(trial.record, 0, out)
    return out


def zigzag_set(config: TwinConfig, seed: int, both_sides: bool = True, directory: Path | None = None,
               **kwargs: Any) -> list[Trial]:
    """The zigzag set of the true boat ``config`` with default sensor noise (seeds ``seed``, ``seed`` + 1, ...),
    starboard-first and (``both_sides``) port-first, as recorded trials; the bags stay in ``directory`` (named
    after the scenarios) when it is given. ``kwargs`` go to :func:`zigzag_scenarios`."""
    trials = []
    with tempfile.TemporaryDirectory(prefix="boat_twin_zigzags_") as tmp:
        where = directory or Path(tmp)
        for i, scenario in enumerate(zigzag_scenarios(config, **kwargs)):
            sea = run_sea_trial(config, scenario, seed + 2 * i)
            trials.append(recorded(sea, scenario.name, where))
            if both_sides:
                port = mirrored(sea, scenario.name + "-port")
                trials.append(recorded(run_sea_trial(config, port, seed + 2 * i + 1), port.name, where))
    return trials
