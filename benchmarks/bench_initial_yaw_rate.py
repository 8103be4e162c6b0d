"""Which of the gyro's noise paths biases the yaw damping of the turning identification (issue 25's leftover).

The twin's one-speed zigzags of ``test_zigzags_steered_between_log_ticks_identify_without_bias`` (the example boat
of docs/studies/manoeuvring.md: 20°/20° and 10°/10°, seed pairs 1-2 … 23-24, 10 s windows) are fitted with each
window's initial state as the replay builds it (``twin/replay.py``: yaw rate the 3-sample mean of the gyro, sway
from the observer the gyro drives over the run-in before it); with one gyro path at a time replaced by the same
trial's noise-free gyro (the same boat and helm without sensor noise: the helm steers on the true heading, so the
motion is the same): the initial yaw rate, the sway observer's drive; with the initial yaw rate noise-free plus
white noise of a given fraction of the 3-sample mean's (the gyro's stated 0.06°/s over √3); and with each
window's initial yaw rate estimated as a third nuisance beside its heading and surge. Prints, per case, the
yaw-damping error's mean, range and t against zero, and how many of the 96 intervals hold the truth. Then the
four trials of ``test_data_from_an_independent_integrator_of_another_boat`` over noise seeds 1-12, as fitted and
with the nuisance: intervals holding the truth (of 96) and misfit flags.

A study, not a feature: the cases replace ``replay.initial_states`` or the fit's nuisances for their fits
(restored after).

Run: .venv/bin/python benchmarks/bench_initial_yaw_rate.py [--pairs 12] [--seeds 12]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

import boat_twin.ident.manoeuvring as manoeuvring
import boat_twin.twin.replay as replay
from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring import PARAMETER_KEYS, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import recorded
from boat_twin.io.trial import Trial
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import Zigzag

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "test"))
from test_ident_manoeuvring import (  # noqa: E402  (run as a script)
    EXAMPLE_BOAT,
    INDEPENDENT_CASES,
    SIGNED,
    _independent_boat,
    _independent_truth,
    _measured,
)

GYRO_NOISE_RADPS = math.radians(0.06)
"""The UM7's stated gyro white noise (``Um7Config``), rad/s."""


def pairs(count: int, directory: Path) -> tuple[TwinConfig, list[list[Trial]], dict[str, tuple[int, np.ndarray]]]:
    """The example boat, its ``count`` zigzag pairs as recorded (bags in ``directory``), and each trial's
    seed and noise-free gyro by its source."""
    vessel = replace(TwinConfig().vessel, lateral_centre_x_m=-0.8, steering_offset_rad=0.01,
                     manoeuvring={k: v for k, v in EXAMPLE_BOAT.items() if k not in SIGNED})
    config = replace(TwinConfig(), vessel=vessel)
    sets, clean = [], {}
    for k in range(count):
        trials = []
        for angle_deg, seed in ((20.0, 2 * k + 1), (10.0, 2 * k + 2)):
            zigzag = Zigzag(vessel, math.radians(angle_deg), math.radians(angle_deg))
            place = directory / str(k)
            place.mkdir(parents=True, exist_ok=True)
            noisy = recorded(run_sea_trial(config, zigzag, seed), f"zigzag-{angle_deg:g}", place)
            quiet = recorded(run_sea_trial(config, zigzag, seed, noise=False), f"quiet-{angle_deg:g}", place)
            clean[str(noisy.metadata.source)] = (seed, quiet.yaw_rate_radps)
            trials.append(noisy)
        sets.append(trials)
    return config, sets, clean


def initial_states_with(clean: dict[str, tuple[int, np.ndarray]], rate_clean: bool, drive_clean: bool,
                        added_fraction: float) -> Callable[..., np.ndarray]:
    """``replay.initial_states`` with the initial yaw rate (``rate_clean``) and the sway observer's drive
    (``drive_clean``) from the noise-free gyro's 3-sample mean, plus white noise of ``added_fraction`` of the
    3-sample mean's on the initial yaw rate (seeded by the trial's seed)."""

    def states(windows: replay.Windows, config: TwinConfig, dynamics: Dynamics, actuators: np.ndarray,
               motion: replay.MeasuredMotion | None = None) -> np.ndarray:
        motion = motion or replay.measured_motion(windows, config)
        source = str(windows.trial.metadata.source)
        seed, gyro = clean[source]
        quiet = replay._centred_mean(gyro, 1) - float(config.um7.gyro_bias_radps[2])
        start = np.tile(windows.start_index, actuators.shape[1])
        out = np.zeros((start.size, 6))
        out[:, 2], out[:, 3] = motion.heading_rad[start], motion.surge_mps[start]
        out[:, 5] = (quiet if rate_clean else motion.yaw_rate_radps)[start]
        if added_fraction:
            draw = np.random.default_rng(seed).normal(0.0, 1.0, windows.start_index.size)
            out[:, 5] += np.tile(draw, actuators.shape[1]) * added_fraction * GYRO_NOISE_RADPS / math.sqrt(3.0)
        out[:, 4] = replay._sway_observer(windows, config, dynamics, motion.heading_rad, motion.surge_mps,
                                          quiet if drive_clean else motion.yaw_rate_radps, actuators)
        return out

    return states


def yaw_rate_nuisance(widening: float) -> Callable[[], None]:
    """Make every window estimate its initial yaw rate too, as a third nuisance with its heading and surge
    (prior: ``widening`` × the gyro's measured white noise over √3); returns the undo."""
    nuisances, prior = manoeuvring.INITIAL_STATE_NUISANCES, manoeuvring.nuisance_prior_stdev

    def with_yaw_rate(data: manoeuvring.TrialData) -> np.ndarray:
        return np.append(prior(data), widening * data.noise["yaw_rate_radps"] / math.sqrt(3.0))

    module = vars(manoeuvring)  # the fit reads both at call time
    module.update(INITIAL_STATE_NUISANCES=nuisances + ((5, 1e-3),), nuisance_prior_stdev=with_yaw_rate)

    def undo() -> None:
        module.update(INITIAL_STATE_NUISANCES=nuisances, nuisance_prior_stdev=prior)

    return undo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=12, help="seed pairs (1-2, 3-4, ...)")
    parser.add_argument("--seeds", type=int, default=12, help="noise seeds of the independent integrator's trials")
    args = parser.parse_args()
    original = replay.initial_states

    def states(case: tuple[bool, bool, float]) -> Callable[[], None]:
        replay.initial_states = initial_states_with(clean, *case)

        def undo() -> None:
            replay.initial_states = original

        return undo

    cases: list[tuple[str, Callable[[], Callable[[], None]] | None]] = [
        ("as fitted (3-sample mean of the gyro)", None),
        ("initial yaw rate noise-free", lambda: states((True, False, 0.0))),
        ("sway observer driven by the noise-free gyro", lambda: states((False, True, 0.0))),
        ("initial yaw rate noise-free + 1.0x the 3-sample mean's noise", lambda: states((True, False, 1.0))),
        ("initial yaw rate noise-free + 0.5x the 3-sample mean's noise", lambda: states((True, False, 0.5))),
        ("initial yaw rate estimated per window (nuisance, prior 2x)", lambda: yaw_rate_nuisance(2.0)),
    ]
    with tempfile.TemporaryDirectory() as directory:
        _, sets, clean = pairs(args.pairs, Path(directory))
        for name, install in cases:
            undo = install() if install else None
            try:
                errors, held = [], 0
                for trials in sets:
                    fit = fit_manoeuvring(trials, TwinConfig(), window_s=10.0)
                    errors.append(fit.values["yaw_damping_Nms"] / EXAMPLE_BOAT["yaw_damping_Nms"] - 1.0)
                    held += sum(lo <= EXAMPLE_BOAT[k] <= hi for k, (lo, hi) in fit.ci95.items())
            finally:
                if undo:
                    undo()
            e = np.array(errors)
            t = e.mean() / (e.std(ddof=1) / math.sqrt(e.size)) if e.size > 1 else math.nan
            print(f"{name}: a_r error mean {e.mean():+.1%} ({e.min():+.1%} … {e.max():+.1%}, t {t:+.1f}); "
                  f"intervals holding the truth {held}/{len(PARAMETER_KEYS) * len(sets)}", flush=True)
    params, truth = _independent_boat()
    motion = _independent_truth(params, truth, INDEPENDENT_CASES)
    given = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))
    for name, widening in (("as fitted", 0.0), ("initial yaw rate estimated per window (nuisance, prior 2x)", 2.0)):
        undo = yaw_rate_nuisance(widening) if widening else None
        try:
            errors, held, misfits = [], 0, 0
            for seed in range(1, args.seeds + 1):
                fit = fit_manoeuvring(_measured(motion, np.random.default_rng(seed)), given, window_s=10.0)
                errors.append(fit.values["yaw_damping_Nms"] / truth["yaw_damping_Nms"] - 1.0)
                held += sum(lo <= truth[k] <= hi for k, (lo, hi) in fit.ci95.items())
                misfits += fit.misfit
        finally:
            if undo:
                undo()
        print(f"independent integrator, {name}: a_r error mean {np.mean(errors):+.1%} ({min(errors):+.1%} … "
              f"{max(errors):+.1%}); intervals holding the truth {held}/{len(PARAMETER_KEYS) * args.seeds}; "
              f"misfit flagged {misfits}/{args.seeds}", flush=True)


if __name__ == "__main__":
    main()
