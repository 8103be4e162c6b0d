"""``boat-twin follow``: a recorded trial replayed through the live twin as if it came live, faster than real time:
the innovations against the sensors' noise, the model's adaptation and the rolling diagnosis over time.

Front end over :func:`boat_twin.shadow.follow.follow_trial` (the core the ``shadow`` node runs).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from boat_twin import progress_line
from boat_twin.cli import verb_help
from boat_twin.cli.options import (
    TRIAL_HELP,
    add_fleet_options,
    add_foxglove_options,
    add_trial_options,
    announce_view,
    assumed_config,
    claim_out_dir,
    foxglove_address,
    read_options_from_args,
    run_each,
    trial_from_args,
    trial_inputs,
    twin_config_from_args,
)
from boat_twin.errors import InputError
from boat_twin.files import to_json
from boat_twin.fleet.outputs import FOLLOW_OUTPUTS
from boat_twin.view.address import VIEW_MCAP

OUTPUTS = FOLLOW_OUTPUTS
"""What ``follow TRIAL --out DIR`` writes."""


def _progress(message: str) -> None:
    progress_line.show(f"{message:60s}")


RATIO_SUFFIX = "_innovation_ratio"
EXPLAINED = (
    "innov./noise: RMS of a signal's innovations (measured − predicted) over the last minute over their stated "
    "spread (sensor noise + the twin's uncertainty): about 1 means the twin predicts that signal to its noise; "
    "above 1.5 the twin misfits it; '-': no sample yet.")
UNEXPLAINED = (
    "(unexplained): the rolling diagnosis found structure left in the residuals that no cause of its catalogue "
    "explains while the twin misfits, on consecutive runs: something outside the model (an actuator fault, a "
    "sensor error, a wrong boat file); the model is held (not adapted) meanwhile. docs/live-twin.md")


def _ratios(result: dict[str, Any]) -> list[str]:
    """The timeline's innovation-ratio keys, speed first (every signal the twin states a ratio of)."""
    keys = {k for e in result["timeline"] for k in e if k.endswith(RATIO_SUFFIX)}
    return sorted(keys, key=lambda k: (k != "speed" + RATIO_SUFFIX, k))


def _text(result: dict[str, Any]) -> str:
    from boat_twin.shadow.follow import final_model_text

    ratios = _ratios(result)
    names = [k[: -len(RATIO_SUFFIX)].replace("_", " ") + " innov./noise" for k in ratios]
    lines = ["t_s    " + "".join(f"{n:>22s}" for n in names) + "   mass_kg   resistance ×   causes"]
    unexplained = False
    final = result["final"]
    last = result["timeline"][-1]["t_s"] if result["timeline"] else -math.inf
    for e in result["timeline"] + ([final] if "causes" in final and final.get("t_s", -math.inf) > last else []):
        cells = "".join(f"{'-' if e.get(k) is None else format(e[k], '.2f'):>22s}" for k in ratios)
        unexplained |= bool(e["unexplained"])
        lines.append(f"{e['t_s']:7.0f}{cells}  {e['mass_kg']:8.0f}  {e['resistance_factor']:12.3f}   "
                     f"{', '.join(e['causes']) or '-'}{' (unexplained)' if e['unexplained'] else ''}")
    lines.append(final_model_text(result["final"]))
    lines.append(EXPLAINED)
    if unexplained or result["final"].get("unexplained"):
        lines.append(UNEXPLAINED)
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Follow the trial; print the timeline (text or JSON); plots, JSON and the adapted twin.yaml into --out."""
    if not args.trial:
        raise InputError("give a TRIAL (bag, .mcap, .tlog, .BIN, .csv)")
    if args.each and args.foxglove is not None:
        raise InputError("--foxglove shows one trial as it is followed: not with --each")
    address = foxglove_address(args)
    if args.each:
        from boat_twin.fleet.jobs import FollowJob

        read = read_options_from_args(args)
        return run_each(args, FollowJob(twin_config_from_args(args), read, tuple(assumed_config(args))))
    if len(args.trial) > 1:
        raise InputError(f"{len(args.trial)} trials given: follow reads one trial, or each of several with "
                         "--each --out DIR")
    trial_path = args.trial[0]
    names = OUTPUTS + ((VIEW_MCAP,) if address is not None else ())
    with claim_out_dir(args.out, names, args.force, trial_inputs(args)) as reports:
        out = reports.staging if reports else None  # the whole set is swapped in when complete
        from boat_twin.fleet.reports import write_follow_report
        from boat_twin.shadow.follow import follow_trial

        trial = trial_from_args(trial_path, args)
        config = twin_config_from_args(args)
        if address is None:
            done = follow_trial(trial, config, progress=None if args.json else _progress)
        else:
            from boat_twin.shadow.sync import INNOVATION_CHANNELS
            from boat_twin.view.observer import Pacer, ShadowView
            from boat_twin.view.stream import TwinView

            view = TwinView(address, out / VIEW_MCAP if out is not None else None, trial.metadata.start_time_s,
                            (config.vessel.length_m, config.vessel.beam_m), innovation_channels=INNOVATION_CHANNELS)
            try:
                announce_view(view.url)
                done = follow_trial(trial, config, progress=None if args.json else _progress,
                                    observer=ShadowView(view, Pacer(args.foxglove_speed)))
            finally:
                view.close()
        progress_line.clear(62)
        done.warnings += assumed_config(args)
        if not args.json:
            sys.stderr.write("".join(f"warning: {w}\n" for w in done.warnings))
        result = done.to_dict()
        if out is not None:
            write_follow_report(out, done, config, str(trial_path))
        print(to_json(result) if args.json else _text(result))
    return 0


def register(subparsers: Any) -> None:
    """Add the ``follow`` verb."""
    p = subparsers.add_parser(
        "follow", help=verb_help("follow"),
        description="Replay a recorded trial through the live twin as if it came live (faster than real time): "
        "the twin keeps in step with the boat, predicts each sensor sample, adapts its surge model (mass, "
        "resistance) when that predicts held-out data better, and runs the diagnosis on the recent window. "
        "Prints a timeline per simulated minute: t_s (s), each signal's innovation ratio (speed, yaw rate: RMS of "
        "its innovations over the last minute / their stated noise, -), mass_kg, resistance_factor (-), causes; "
        "then what the ratios and '(unexplained)' mean.")
    p.add_argument("trial", nargs="*", type=Path,
                   help=TRIAL_HELP + "; with --each several, directories of trials or quoted glob patterns")
    add_trial_options(p)
    add_fleet_options(p, "follow")
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="twin configuration YAML to start from (default: the built-in boat)")
    p.add_argument("--model", type=Path, metavar="FILE",
                   help="identified model YAML overriding the vessel (resistance, mass)")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="directory for follow.json, the adapted twin.yaml and PNG plots (innovations against the "
                   "noise band, the model converging with its 95 %% intervals, the cause timeline)")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs in --out")
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    add_foxglove_options(p, "the boat's and the twin's tracks, the boat in 3-D, the innovations against their "
                         "noise band, the adapted model and the diagnosis verdicts")
    p.set_defaults(handler=run)
