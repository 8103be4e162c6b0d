"""``boat-twin diagnose``: what the model gets wrong on measured data, its cause, the extended model and the gain.

Front end over :mod:`~boat_twin.diagnose.replay` (windowed replay of the commands), :mod:`.effects` (the
catalogue), :mod:`.search` (fits, held-out judgement, decision rule, forward selection), :mod:`.structure`
(what is left) and :mod:`.table` (a steady-state table).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from boat_twin.config import TwinConfig, save_config
from boat_twin.data import dyda2021_table1
from boat_twin.diagnose.effects import catalogue
from boat_twin.diagnose.replay import SIGNALS, Prediction, Windows, cut_windows
from boat_twin.diagnose.report import evidence_figure, residual_figure, result_dict, signal_figure, text_report
from boat_twin.diagnose.search import Diagnosis, Selection, forward_select
from boat_twin.diagnose.structure import residual_structure
from boat_twin.diagnose.table import diagnose_table, table_result
from boat_twin.errors import InputError
from boat_twin.ident.paper import PAPER_COEFFICIENTS, PAPER_ORDERS
from boat_twin.io.files import (
    atomic_save_figure,
    atomic_write_text,
    atomic_write_yaml,
    ensure_out_dir,
    to_json,
)
from boat_twin.io.sources import TRIAL_HELP, add_trial_options, trial_from_args
from boat_twin.io.trial import Trial
from boat_twin.units import KGF_N, KNOT_MPS
from boat_twin.vessel.command import load_twin_config
from boat_twin.vessel.resistance import TableResistance

WINDOW_S = 20.0
"""Default replay window, s: long enough for a 1.5° steering offset to turn the track by several degrees,
short enough that a heading error from the start does not dominate."""
EXTENDED_MODEL_NAME = "extended_model.yaml"
"""File name of the extended model in --out."""


@dataclass
class TrialDiagnosis:
    """Everything one diagnosis of a trial produced."""

    windows: Windows
    selection: Selection
    base: TwinConfig
    extended: TwinConfig
    baseline_prediction: Prediction
    extended_prediction: Prediction
    result: dict[str, Any]


def diagnose_trial(trial: Trial, base: TwinConfig, window_s: float = WINDOW_S,
                   progress: Any = None) -> TrialDiagnosis:
    """Diagnose ``trial`` against the model ``base``: the library entry point of ``diagnose TRIAL``."""
    windows = cut_windows(trial, window_s)
    diagnosis = Diagnosis(windows, base, progress)
    selection = forward_select(diagnosis, catalogue(base, trial.speed_mps))
    extended = diagnosis.config(selection.final.effects, selection.final.values)
    baseline_prediction = selection.baseline.residuals.prediction
    extended_prediction = selection.final.residuals.prediction
    signatures = residual_structure(windows, selection.final.residuals.values, extended_prediction,
                                    diagnosis.folds)
    result = result_dict(windows, selection, baseline_prediction, extended_prediction, signatures, None,
                         diagnosis.sigma)
    result["evaluations"] = diagnosis.evaluations
    return TrialDiagnosis(windows, selection, base, extended, baseline_prediction, extended_prediction, result)


def _out_dir(args: argparse.Namespace, names: tuple[str, ...]) -> Path | None:
    """--out, checked before any work: existing outputs are refused without --force (replaced atomically)."""
    if args.out is None:
        return None
    for name in names:
        if (args.out / name).exists() and not args.force:
            raise InputError(f"{args.out / name} exists; use --force to overwrite it")
    return ensure_out_dir(args.out)


def _progress(message: str) -> None:
    sys.stderr.write(f"\rdiagnose: {message:60s}")
    sys.stderr.flush()


def _run_trial(args: argparse.Namespace) -> int:
    out = _out_dir(args, (EXTENDED_MODEL_NAME, "diagnosis_signals.png", "diagnosis_residuals.png",
                          "diagnosis_evidence.png", "diagnosis.json"))
    trial = trial_from_args(args.trial, args)
    done = diagnose_trial(trial, load_twin_config(args), args.window, None if args.json else _progress)
    if not args.json:
        sys.stderr.write("\r" + " " * 72 + "\r")
    result = done.result
    if out is not None:
        names = ", ".join(v["effect"] for v in result["verdict"]) or "none"
        save_config(done.extended, out / EXTENDED_MODEL_NAME,
                    f"boat_twin extended model: diagnose {args.trial} (named: {names})\n"
                    f"load with: boat-twin simulate ... --config {out / EXTENDED_MODEL_NAME}")
        result["extended_model"] = str(out / EXTENDED_MODEL_NAME)
        concerned = _concerned_signals(result)
        before, after = done.baseline_prediction, done.extended_prediction
        atomic_save_figure(out / "diagnosis_signals.png", signal_figure(done.windows, before, after, concerned))
        atomic_save_figure(out / "diagnosis_residuals.png", residual_figure(done.windows, before, after))
        atomic_save_figure(out / "diagnosis_evidence.png", evidence_figure(result))
        atomic_write_text(out / "diagnosis.json", to_json(result) + "\n")
    print(to_json(result) if args.json else text_report(result))
    return 0


def _concerned_signals(result: dict[str, Any]) -> list[str]:
    """Signals the named effects improved by ≥ 5 % (all when none did)."""
    gains = [v["gain"] for v in result["verdict"]]
    concerned = [s for s in SIGNALS if any(g.get(s, 0.0) >= 0.05 for g in gains)]
    return concerned or list(SIGNALS)


def _run_table(args: argparse.Namespace) -> int:
    if args.table != "dyda2021":
        raise InputError(f"--table {args.table!r}: the built-in table is 'dyda2021'")
    if args.model_order not in PAPER_ORDERS:
        raise InputError(f"--model-order {args.model_order}: the paper's fits have orders "
                         f"{', '.join(map(str, PAPER_ORDERS))}")
    out = _out_dir(args, (EXTENDED_MODEL_NAME, "diagnosis_table.png"))
    speed_kn, force_kgf = dyda2021_table1()
    diag = diagnose_table(speed_kn, force_kgf, PAPER_COEFFICIENTS[args.model_order])
    result = table_result(diag, args.model_order, ("kn", "kgf"))
    result["extended_model"] = None
    if out is not None and diag.named:
        force_n = diag.extended * KGF_N
        force_n[speed_kn == 0.0] = 0.0  # at rest there is no resistance, whatever the correction's end value
        resistance = TableResistance(tuple((speed_kn * KNOT_MPS).tolist()), tuple(force_n.tolist()))
        atomic_write_yaml(out / EXTENDED_MODEL_NAME, {"vessel": {"resistance": resistance.to_dict()}})
        result["extended_model"] = str(out / EXTENDED_MODEL_NAME)
    if out is not None:
        atomic_save_figure(out / "diagnosis_table.png", _table_figure(diag))
    print(to_json(result) if args.json else _table_text(result, diag))
    return 0


def _table_text(result: dict[str, Any], diag: Any) -> str:
    base = result["baseline"]["rmse"]["thrust_kgf"]
    ext = result["extended"]["rmse"]["thrust_kgf"]
    lines = [f"table       Dyda & Chumakova (2021) Table 1, 37 rows (kn, kgf); baseline: the paper's N = "
             f"{result['baseline']['model_order']} fit",
             f"RMSE        baseline {base:.2f} kgf, extended {ext:.2f} kgf",
             f"candidate   resistance_shape: {diag.knots.size} knots, ΔBIC {diag.delta_bic:.1f}, "
             f"leave-one-out gain {diag.cv_gain:+.1%}"]
    if result["verdict"]:
        params = result["verdict"][0]["parameters"]
        lines.append(f"verdict     resistance_shape; regime change (plateau between displacement and planing): "
                     f"{params.get('plateau_kn', ['?', '?'])[0]}–{params.get('plateau_kn', ['?', '?'])[1]} kn; "
                     f"model differs significantly over {params.get('band_kn')} kn")
    else:
        lines.append("verdict     no significant discrepancy")
    lines.append(f"residuals   runs test p = {result['residual_runs_p']:.2f}"
                 + (" (structure left: unexplained)" if result["unexplained"] else " (no structure left)"))
    if result["extended_model"]:
        lines.append(f"model       {result['extended_model']}")
    return "\n".join(lines)


def _table_figure(diag: Any) -> Any:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 6), layout="constrained")
    ax, ax_r = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    ax.plot(diag.speed, diag.force, "o", ms=4, label="Table 1")
    ax.plot(diag.speed, diag.baseline, label="paper's fit")
    ax.plot(diag.speed, diag.extended, label="extended (resistance_shape)")
    if diag.plateau:
        ax.axvspan(*diag.plateau, color="0.9", label="plateau (regime change)")
    ax.set_ylabel("thrust [kgf]")
    ax.legend()
    ax_r.plot(diag.speed, diag.force - diag.baseline, "o-", ms=3, label="baseline")
    ax_r.plot(diag.speed, diag.force - diag.extended, "o-", ms=3, label="extended")
    ax_r.axhline(0.0, color="k", lw=0.5)
    ax_r.set_xlabel("speed [kn]")
    ax_r.set_ylabel("residual [kgf]")
    ax_r.legend()
    return fig


def run(args: argparse.Namespace) -> int:
    """Dispatch: a table or a trial."""
    if args.table is not None:
        if args.trial is not None:
            raise InputError("give either a TRIAL or --table, not both")
        return _run_table(args)
    if args.trial is None:
        raise InputError("give a TRIAL (bag, .mcap, .tlog, .BIN) or --table dyda2021")
    if args.window <= 0:
        raise InputError(f"--window must be a positive number of seconds, got {args.window}")
    return _run_trial(args)


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` verb."""
    p = subparsers.add_parser(
        "diagnose", help="find what the model gets wrong on a trial (or a steady-state table)",
        description=__doc__.splitlines()[0])
    p.add_argument("trial", nargs="?", type=Path, help=TRIAL_HELP)
    add_trial_options(p)
    p.add_argument("--table", help="diagnose a built-in steady-state table instead: dyda2021")
    p.add_argument("--model-order", type=int, default=1, help="with --table: the paper's fit to start from (1, 3, 5)")
    p.add_argument("--config", type=Path,
                   help="twin configuration YAML of the model to diagnose (default: the seed boat)")
    p.add_argument("--model", type=Path, help="identified model YAML overriding the vessel (resistance, mass)")
    p.add_argument("--window", type=float, default=WINDOW_S, help=f"replay window, s (default {WINDOW_S:g})")
    p.add_argument("--out", type=Path, help="directory for the extended model YAML, JSON and PNG plots")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs in --out")
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    p.set_defaults(handler=run)
