"""``boat-twin simulate``: run a scenario (or a command file / recorded trial's commands) into a ROS 2 bag."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.io.files import to_json
from boat_twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import describe, load_params
from boat_twin.vessel.scenarios import SCENARIO_NAMES, CommandProfile, make_scenario, read_command_csv


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` verb."""
    p = subparsers.add_parser(
        "simulate",
        help="simulate a sea trial and write it as a ROS 2 bag",
        description="Simulate the boat through a scenario; write commands, GNSS, UM7 IMU and ground truth "
        "as a rosbag2 (MCAP by default). Units: SI (N, rad, m/s, s).",
    )
    p.add_argument("scenario", nargs="?", help=f"one of: {', '.join(SCENARIO_NAMES)} (omit with --commands)")
    p.add_argument("--commands", type=Path, metavar="FILE",
                   help="command profile: CSV 't,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad' "
                   "(zero-order hold) or a recorded bag whose thruster topics are replayed")
    p.add_argument("--config", type=Path, help="twin configuration YAML (sections vessel, environment, gnss, um7)")
    p.add_argument("--model", type=Path, help="identified model YAML overriding the vessel (resistance, mass)")
    p.add_argument("--current", type=float, nargs=2, metavar=("EAST", "NORTH"),
                   help="water current over ground, m/s (ENU components)")
    p.add_argument("--duration", type=float, help="trial length, s (default: the scenario's own)")
    p.add_argument("--seed", type=int, default=0, help="seed of the one random generator (default 0)")
    p.add_argument("--no-noise", action="store_true", help="exact measurements (no noise, dropouts or bias)")
    p.add_argument("--out", type=Path, help="output bag: a directory, or a file ending in .mcap")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (default mcap)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    p.set_defaults(handler=run)


def load_twin_config(args: argparse.Namespace) -> TwinConfig:
    """The configuration from --config, --model and --current, in that order of precedence (last wins)."""
    config = load_config(args.config) if args.config else TwinConfig()
    if args.model:
        config = TwinConfig(load_params(args.model, config.vessel), config.environment, config.gnss, config.um7)
    if args.current:
        config = TwinConfig(config.vessel, Environment(*args.current), config.gnss, config.um7)
    return config


def _scenario(args: argparse.Namespace, config: TwinConfig):
    if args.commands and args.scenario:
        raise InputError("give a scenario or --commands, not both")
    if args.commands:
        if args.commands.is_dir() or args.commands.suffix == ".mcap":
            from boat_twin.io.bags import read_trial

            trial = read_trial(args.commands)
            values = np.nan_to_num(trial.commands, nan=0.0)
            t_abs = trial.t_s + trial.metadata.start_time_s
            profile = CommandProfile(args.commands.name, t_abs, values, float(t_abs[-1]))
        else:
            profile = read_command_csv(args.commands)
        if args.duration is not None:
            return make_scenario_with_duration(profile, args.duration)
        return profile
    if not args.scenario:
        raise InputError(f"name a scenario ({', '.join(SCENARIO_NAMES)}) or give --commands FILE")
    return make_scenario(args.scenario, config.vessel, np.random.default_rng(args.seed), args.duration)


def make_scenario_with_duration(profile: CommandProfile, duration_s: float) -> CommandProfile:
    """The same command profile run for ``duration_s`` (the last row held)."""
    if not duration_s > 0.0:
        raise InputError(f"--duration must be a positive number of seconds, got {duration_s!r}")
    return CommandProfile(profile.name, profile.times_s, profile.values, duration_s, profile.initial_surge_mps)


def summarize(t_s: np.ndarray, states: np.ndarray) -> dict[str, float | None]:
    """Figures of a simulated trial's truth: duration, top speed, extreme yaw rate, and the final steady
    turning diameter 2·U/|r| (averaged over the last 20 s; None unless the boat ends in a turn)."""
    last = t_s >= t_s[-1] - 20.0
    u, v, r = states[last, 0, 3], states[last, 0, 4], states[last, 0, 5]
    turning = bool(np.all(np.abs(r) > 0.02) and np.ptp(r) < 0.05 * np.mean(np.abs(r)))
    return {
        "duration_s": float(t_s[-1]),
        "max_surge_mps": float(np.max(states[:, 0, 3])),
        "max_abs_yaw_rate_radps": float(np.max(np.abs(states[:, 0, 5]))),
        "final_turn_diameter_m": float(np.mean(2.0 * np.hypot(u, v) / np.abs(r))) if turning else None,
        "final_turn_speed_mps": float(np.mean(np.hypot(u, v))) if turning else None,
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``simulate``."""
    config = load_twin_config(args)
    scenario = _scenario(args, config)
    if args.out is None and not args.json:
        raise InputError("nothing to do: give --out BAG (and/or --json)")
    trial = run_sea_trial(config, scenario, args.seed, noise=not args.no_noise)
    result = {"scenario": scenario.name, "seed": args.seed, **summarize(trial.record.t_s, trial.record.states),
              "vessel": describe(config.vessel)}
    if args.out is not None:
        from boat_twin.io.bags import write_bag

        result["bag"] = str(args.out)
        result["messages"] = write_bag(args.out, trial_messages(trial), args.storage, args.force)
    if args.json:
        print(to_json(result))
    else:
        print(f"simulated {scenario.name}: {result['duration_s']:.1f} s, top surge {result['max_surge_mps']:.2f} m/s",
              file=sys.stdout)
        if args.out is not None:
            print(f"wrote {result['messages']} messages to {args.out}")
    return 0
