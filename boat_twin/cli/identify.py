"""``boat-twin identify``: the thrust–speed model m·dv/dt = F − Fc(v) from the paper's table or a trial.

A front end over :mod:`boat_twin.ident.pipeline` (the computation) and :mod:`boat_twin.ident.report` (text,
files, figures).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from boat_twin.cli import verb_help
from boat_twin.cli.options import TRIAL_HELP, add_trial_options, claim_out_dir, trial_from_args
from boat_twin.errors import InputError
from boat_twin.files import atomic_save_figure, atomic_write_text, to_json

TABLE_OUTPUTS = ("identify.json", "report.txt", "model.yaml", "fits.png", "residuals.png")
"""What ``identify --table --out DIR`` writes."""
TRIAL_OUTPUTS = ("identify.json", "model.yaml", "trial.png", "resistance.png", "resimulation.png")
"""What ``identify TRIAL --out DIR`` writes."""


def _run_table(args: argparse.Namespace) -> int:
    from boat_twin.ident.pipeline import identify_table, model_dict, write_model_yaml
    from boat_twin.ident.report import table_figures, table_report

    result, si_fit = identify_table(args.monotone, args.order, args.max_order, args.through_origin)
    report = table_report(result, si_fit)
    out = claim_out_dir(args.out, TABLE_OUTPUTS, args.force)
    if out is not None:
        atomic_write_text(out / "identify.json", to_json(result) + "\n")
        atomic_write_text(out / "report.txt", report)
        write_model_yaml(
            out / "model.yaml",
            model_dict(si_fit),
            f"Dyda & Chumakova (2021) Table 1 read as kn/kgf, least squares N = {si_fit.order}, SI units",
        )
        fits_fig, resid_fig = table_figures(result)
        atomic_save_figure(out / "fits.png", fits_fig)
        atomic_save_figure(out / "residuals.png", resid_fig)
    sys.stdout.write(to_json(result) + "\n" if args.json else report)
    return 0


def run(args: argparse.Namespace) -> int:
    """Handler of ``boat-twin identify``."""
    from boat_twin.ident.steady import MAX_ORDER

    if args.order is not None and not 1 <= args.order <= MAX_ORDER:
        raise InputError(f"--order must be from 1 to {MAX_ORDER}, got {args.order}")
    if not 1 <= args.max_order <= MAX_ORDER:
        raise InputError(f"--max-order must be from 1 to {MAX_ORDER}, got {args.max_order}")
    for name, value in (("--steady-window", args.steady_window), ("--thrust-tolerance", args.thrust_tolerance)):
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be a positive number, got {value:g}")
    if args.table is not None and args.trial:
        raise InputError("give a TRIAL or --table, not both")
    if args.table is not None:
        return _run_table(args)
    if not args.trial:
        raise InputError("nothing to identify: give a TRIAL (bag, .mcap, .tlog, .BIN) or --table dyda2021")
    return _run_trial(args)


def rejected_summary(rejected: list[dict[str, Any]]) -> str:
    """One line: the rejected segments counted by reason (the details are in identify.json / --json)."""
    kinds: dict[str, int] = {}
    for seg in rejected:
        reason = seg["reason"]
        kind = "held shorter than the test window" if "shorter than" in reason else reason.split(":")[0]
        kinds[kind] = kinds.get(kind, 0) + 1
    counts = ", ".join(f"{n} {kind}" for kind, n in sorted(kinds.items(), key=lambda item: -item[1]))
    return f"rejected segments: {counts} (each with its reason in --json / identify.json)"


def _run_trial(args: argparse.Namespace) -> int:
    """Recorded trials, pooled: replay through the online identifier, batch fits, dynamic mass, re-simulation of
    each with the identified model (closing the loop), report."""
    import numpy as np

    from boat_twin.ident.pipeline import identify_trials, pool, trial_samples
    from boat_twin.ident.report import resimulation_line, write_trial_report

    claim_out_dir(args.out, TRIAL_OUTPUTS, args.force)
    trials = []
    for path in args.trial:
        sys.stderr.write(f"reading {path} ...\n")
        trials.append(trial_from_args(path, args))
        sys.stderr.write(trials[-1].metadata.summary_line() + "\n")
    sys.stderr.write("identifying, then re-simulating the trial's commands with the identified model ...\n")
    result, resims = identify_trials(trials, order=args.order, max_order=min(args.max_order, 6),
                                     monotone=args.monotone, window_s=args.steady_window,
                                     thrust_tolerance_N=args.thrust_tolerance)
    if args.out is not None:
        t_s, thrust, speed = (np.concatenate(column) for column in zip(*pool([trial_samples(tr) for tr in trials]),
                                                                       strict=True))
        write_trial_report(args.out, result, t_s, thrust, speed, resims[0] if len(trials) == 1 else None)
    if args.json:
        sys.stdout.write(to_json(result) + "\n")
        return 0
    fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
    dyn = result.get("dynamic", {})
    names = ", ".join(map(str, args.trial))
    lines = [
        f"trial{'s' if len(trials) > 1 else ''} {names}: {len(result['steady_points'])} steady points, "
        f"{len(result.get('rejected_segments', []))} segments rejected",
        f"steady-state detector: window {result['steady_criteria']['window_s']:.3g} s, thrust tolerance "
        f"{result['steady_criteria']['thrust_tolerance_N']:.3g} N",
        f"selected order N = {result['selected_order']} ({result.get('selection_reason', '')})",
        "Fc(v) coefficients c0..cN, N/(m/s)^i: " + ", ".join(f"{c:.4g}" for c in fit["coefficients"]),
        f"RMSE {fit['rmse']:.2f} N",
        f"effective mass {dyn['mass_kg']:.0f} kg, 95% CI [{dyn['mass_ci95_kg'][0]:.0f}, {dyn['mass_ci95_kg'][1]:.0f}]"
        if "mass_kg" in dyn else f"effective mass: {dyn.get('error', 'not identified')}",
    ]
    if result.get("rejected_segments"):
        lines.append(rejected_summary(result["rejected_segments"]))
    for entry in result["trials"]:
        prefix = f"{entry['source']}: " if len(trials) > 1 else ""
        lines.append(prefix + resimulation_line(entry["resimulation"]))
    lines += [f"warning: {w}" for w in result.get("warnings", [])]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``identify`` verb."""
    p = subparsers.add_parser(
        "identify",
        help=verb_help("identify"),
        description="Identify the longitudinal model m·dv/dt = F - Fc(v), Fc(v) = sum c_i·v^i "
        "(Dyda & Chumakova 2021). Internally SI; the built-in table is reported in its own units (kn, kgf).",
    )
    p.add_argument("trial", nargs="*", type=Path,
                   help=TRIAL_HELP + "; several trials of one boat are pooled into one identification")
    add_trial_options(p)
    p.add_argument(
        "--table",
        choices=["dyda2021"],
        help="built-in steady-state table: dyda2021 = Dyda & Chumakova (2021) Table 1, v in kn, F in kgf",
    )
    p.add_argument(
        "--order", type=int,
        help="power-series order N (default: chosen by leave-one-out cross-validation and the Bayesian information "
        "criterion, BIC)"
    )
    p.add_argument(
        "--max-order", type=int, default=8,
        help="highest order N tried by the selection (default 8; a recorded trial tries at most 6)",
    )
    p.add_argument(
        "--monotone",
        action="store_true",
        help="constrain Fc to be non-decreasing from 0 to the top speed and Fc(0) >= 0",
    )
    p.add_argument(
        "--through-origin", action="store_true", help="impose Fc(0) = c0 = 0 (no resistance at rest)"
    )
    p.add_argument(
        "--steady-window", type=float, metavar="S",
        help="shortest settled tail the steady-state detector tests, s (default: derived from the trial: the surge "
        "time constant seen after thrust steps, or what the speed noise needs; see docs/identification.md)")
    p.add_argument(
        "--thrust-tolerance", type=float, metavar="N",
        help="thrust counts as constant within this of a segment's start, N (default: derived from the commands: "
        "half their smallest step, or 4 sigma of their jitter)")
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="write identify.json, model.yaml (SI) and PNG plots here (report.txt too with --table)",
    )
    p.add_argument("--force", action="store_true", help="overwrite existing reports in --out")
    p.set_defaults(handler=run)
