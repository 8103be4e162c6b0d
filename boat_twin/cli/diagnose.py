"""``boat-twin diagnose``: what the model gets wrong on measured data, its cause, the extended model and the gain.

Front end over :mod:`~boat_twin.twin.replay` (windowed replay of the commands), :mod:`.effects` (the
catalogue), :mod:`.search` (fits, held-out judgement, decision rule, forward selection), :mod:`.structure`
(what is left) and :mod:`.table` (a steady-state table).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from boat_twin import progress_line
from boat_twin.cli import settled_imports, verb_help
from boat_twin.cli.options import (
    TRIAL_HELP,
    add_fleet_options,
    add_trial_options,
    assumed_config,
    claim_out_dir,
    read_options_from_args,
    run_each,
    trial_from_args,
    trial_inputs,
    twin_config_from_args,
)
from boat_twin.diagnose.defaults import EXTENDED_MODEL_NAME, WINDOW_S
from boat_twin.errors import InputError
from boat_twin.files import atomic_save_figure, atomic_write_yaml, to_json
from boat_twin.fleet.outputs import DIAGNOSE_OUTPUTS


def _progress(message: str) -> None:
    progress_line.show(f"diagnose: {message:60s}")


TRIAL_OUTPUTS = DIAGNOSE_OUTPUTS
"""What ``diagnose TRIAL --out DIR`` writes."""
TABLE_OUTPUTS = (EXTENDED_MODEL_NAME, "diagnosis_table.png")
"""What ``diagnose --table dyda2021 --out DIR`` writes."""


def _run_trial(args: argparse.Namespace, out: Path | None) -> int:
    with settled_imports():
        from boat_twin.diagnose.pipeline import command_warnings, diagnose_trial
        from boat_twin.diagnose.report import text_report
        from boat_twin.fleet.reports import write_diagnosis_report

        if out is not None:  # the report's figures (matplotlib): imported before the heap is settled
            import boat_twin.view.summary  # noqa: F401
            import boat_twin.view.track_map  # noqa: F401
    trial = trial_from_args(args.trial, args)
    config = twin_config_from_args(args)
    summary = trial.metadata.summary_line()  # what identify prints of a trial
    warnings = command_warnings(trial, config.vessel)
    sys.stderr.write("".join(f"{line}\n" for line in [summary, *(f"warning: {w}" for w in warnings)]))
    done = diagnose_trial(trial, config, args.window, None if args.json else _progress)
    progress_line.clear(72)
    result = done.result
    result["warnings"] += assumed_config(args)
    if out is not None:
        write_diagnosis_report(out, done, str(args.trial), args.out)
    print(to_json(result) if args.json else text_report(result))
    return 0


def _run_table(args: argparse.Namespace, out: Path | None) -> int:
    from boat_twin.diagnose.pipeline import diagnose_paper_table
    from boat_twin.diagnose.report import table_figure, table_text

    result, diag, resistance = diagnose_paper_table(args.model_order)
    result["extended_model"] = None
    if out is not None and resistance is not None:
        atomic_write_yaml(out / EXTENDED_MODEL_NAME, {"vessel": {"resistance": resistance.to_dict()}})
        result["extended_model"] = str(args.out / EXTENDED_MODEL_NAME)  # its final name (out: the staging copy)
    if out is not None:
        atomic_save_figure(out / "diagnosis_table.png", table_figure(diag),
                           f"diagnose --table dyda2021 (the paper's N = {args.model_order} fit)")
    print(to_json(result) if args.json else table_text(result, diag))
    return 0


def run(args: argparse.Namespace) -> int:
    """Dispatch: a table or a trial."""
    from boat_twin.validation import number

    if args.table is not None:
        if args.trial:
            raise InputError("give either a TRIAL or --table, not both")
        with claim_out_dir(args.out, TABLE_OUTPUTS, args.force) as reports:
            return _run_table(args, reports.staging if reports else None)
    if not args.trial:
        raise InputError("give a TRIAL (bag, .mcap, .tlog, .BIN, .csv) or --table dyda2021")
    number("--window", args.window, above=0.0)
    if args.each:
        from boat_twin.fleet.jobs import DiagnoseJob

        read = read_options_from_args(args)
        return run_each(args, DiagnoseJob(twin_config_from_args(args), read, args.window,
                                           tuple(assumed_config(args))))
    if len(args.trial) > 1:
        raise InputError(f"{len(args.trial)} trials given: diagnose reads one trial, or each of several with "
                         "--each --out DIR")
    args.trial = args.trial[0]
    with claim_out_dir(args.out, TRIAL_OUTPUTS, args.force, trial_inputs(args)) as reports:
        return _run_trial(args, reports.staging if reports else None)


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` verb."""
    p = subparsers.add_parser(
        "diagnose", help=verb_help("diagnose"),
        description="Find what the model gets wrong on measured data (a recorded trial, or a steady-state "
        "table), name the cause from a catalogue of effects, and write the extended model with the gain.")
    p.add_argument("trial", nargs="*", type=Path,
                   help=TRIAL_HELP + "; with --each several, directories of trials or quoted glob patterns")
    add_trial_options(p)
    add_fleet_options(p, "diagnose")
    p.add_argument("--table", choices=["dyda2021"],
                   help="diagnose a built-in steady-state table instead: dyda2021 = Dyda & Chumakova (2021) Table 1")
    p.add_argument("--model-order", type=int, choices=[1, 3, 5], default=1,
                   help="with --table: the paper's fit to start from (default 1)")
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="twin configuration YAML of the model to diagnose (default: the built-in boat)")
    p.add_argument("--model", type=Path, metavar="FILE",
                   help="identified model YAML overriding the vessel (resistance, mass)")
    p.add_argument("--window", type=float, default=WINDOW_S, metavar="S",
                   help=f"replay window, s: the model restarts from the measured state every window "
                   f"(default {WINDOW_S:g})")
    p.add_argument("--out", type=Path, metavar="DIR", help="directory for the extended model YAML, JSON and PNG plots")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs in --out")
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    p.set_defaults(handler=run)
