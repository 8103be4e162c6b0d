"""What a batch does to each trial: read it, run the verb's library pipeline, write its report, return its
summary row. A job is a small picklable value (the verb's options), called on a Dask worker or in this process."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.fleet.outputs import DIAGNOSE_OUTPUTS, FOLLOW_OUTPUTS, IDENTIFY_OUTPUTS
from boat_twin.io.trial import Trial

COMMON_COLUMNS = ("trial", "status", "error", "boat", "source", "duration_s")
"""Columns every summary row starts with (then the verb's :attr:`columns`, then :data:`RUN_COLUMNS`)."""
NO_TWIN = "no_twin"
"""Status of an identify row whose trial ran but gave no twin.yaml (its ``physical_problems`` and warnings say
why): not an error, not ok."""
RUN_COLUMNS = ("seconds", "cpu_s", "worker", "peak_rss_mb")
"""Columns every summary row ends with: the task's wall time and the CPU time of its process meanwhile, s, where
it ran (host:pid), and the peak resident memory of that process so far, MB (flat over a batch: no leak)."""


@dataclass(frozen=True)
class ReadOptions:
    """How a trial is read (``--topic``, ``--namespace``, ``--calibration``, ``--columns``, ``--start``/``--end``, the
    boat file's actuator order)."""

    remap: dict[str, str] = field(default_factory=dict)
    namespace: str = ""
    calibration: str | None = None
    columns: str | None = None
    start_s: float | None = None
    end_s: float | None = None
    """The stretch used, s since the trial's start (None: from its start, to its end)."""
    order: tuple[str, ...] = ()
    """The boat file's actuator names in its order (:func:`~boat_twin.io.messages.actuator_order`)."""

    def read(self, path: Path) -> Trial:
        """:func:`~boat_twin.io.sources.read_trial_file` of ``path`` with these options, cut to the stretch."""
        from boat_twin.io.sources import read_trial_file
        from boat_twin.io.span import trial_between

        trial = read_trial_file(path, remap=self.remap, namespace=self.namespace, calibration=self.calibration,
                                columns=self.columns, order=self.order)
        return trial_between(trial, self.start_s, self.end_s)


def duration_s(trial: Trial) -> float:
    """Length of a trial's time axis, s."""
    return float(trial.t_s[-1] - trial.t_s[0]) if trial.t_s.size else 0.0


@dataclass(frozen=True)
class IdentifyJob:
    """``boat-twin identify TRIAL --out DIR`` on one trial: the thrust-speed model, the twin, the re-simulation."""

    read: ReadOptions = field(default_factory=ReadOptions)
    order: int | None = None
    max_order: int = 6
    monotone: bool = False
    window_s: float | None = None
    thrust_tolerance_N: float | None = None
    boat: dict[str, float] | None = None
    """Boat facts for the twin (``--boat`` file's contents), None: the default boat's."""
    boat_file: str | None = None
    config: TwinConfig = field(default_factory=TwinConfig)
    """The twin configuration each trial is read with (``--config``: its engines deliver the thrust commands,
    its GNSS latency and IMU offsets apply; :func:`~boat_twin.ident.trial_record.trial_record`)."""
    verb = "identify"
    outputs = IDENTIFY_OUTPUTS
    columns = ("mass_kg", "mass_ci95_low_kg", "mass_ci95_high_kg", "mass_identified", "model", "curve_speed_mps",
               "curve_N", "heldout_rmse_mps", "baseline_heldout_rmse_mps", "physical_problems", "steady_points",
               "misfit_speed_rmse_mps", "warnings")
    """The headline: the model's effective mass and its 95 % interval, kg (null when the data do not identify
    it, even where a boat file's mass is held); the selected output-error model (``baseline`` or ``spline-K``) and
    its resistance Fc at eleven speeds from 0 to the top measured one (m/s, N: in summary.json and curves.csv,
    not in summary.csv); the held-out speed RMSE of the model and of the baseline a·u + b·u|u|, m/s; why the
    model is not physical (empty: it is); steady points seen; the re-simulation's speed RMSE (the identified
    model run on the trial's commands against the measured speed), m/s; warnings counted. The row's status is
    ``no_twin`` when no twin.yaml was written (the model is not physical, or no mass is known)."""
    curves = ("curve_speed_mps", "curve_N")
    """(x, y) columns holding a curve: written to curves.csv, one point a line, not into a summary.csv cell."""

    def __call__(self, path: Path, out: Path, named: Path | None = None) -> dict[str, Any]:
        """Identify the trial at ``path``, write its report into ``out`` (``named``: the directory its texts
        name, default ``out``); its row's values."""
        from boat_twin.ident.pipeline import identify_trials
        from boat_twin.ident.report import write_identify_report

        trial = self.read.read(path)
        result, found = identify_trials([trial], order=self.order, max_order=self.max_order,
                                        monotone=self.monotone, window_s=self.window_s,
                                        thrust_tolerance_N=self.thrust_tolerance_N, boat=self.boat,
                                        config=self.config)
        out.mkdir(parents=True, exist_ok=True)
        write_identify_report(out, result, found, str(path), self.boat_file, named)
        oe = result["output_error"]
        selected, table = oe["selected"], oe["selected"]["resistance_table"]
        known = oe["mass_identified"] and "effective_mass_kg" in result["model"]
        low, high = selected["mass_ci95_kg"] if known else (None, None)
        heldout = {c["model"]: c["cv_rmse_mps"] for c in oe["candidates"]}
        return {"status": "ok" if found.vessel is not None else NO_TWIN, "duration_s": duration_s(trial),
                "mass_kg": result["model"]["effective_mass_kg"] if known else None,
                "mass_ci95_low_kg": low, "mass_ci95_high_kg": high, "mass_identified": oe["mass_identified"],
                "model": selected["model"], "curve_speed_mps": table["speed_mps"], "curve_N": table["force_N"],
                "heldout_rmse_mps": heldout[selected["model"]], "baseline_heldout_rmse_mps": heldout["baseline"],
                "physical_problems": result["physical_problems"],
                "steady_points": len(result["steady_points"]),
                "misfit_speed_rmse_mps": result["resimulation"].get("speed_rmse_mps"),
                "warnings": len(result["warnings"])}


@dataclass(frozen=True)
class DiagnoseJob:
    """``boat-twin diagnose TRIAL --out DIR`` on one trial against the model ``config``."""

    config: TwinConfig = field(default_factory=TwinConfig)
    read: ReadOptions = field(default_factory=ReadOptions)
    window_s: float | None = None
    assumed: tuple[str, ...] = ()
    """Warnings of what the run assumed rather than was given (no --config: the built-in boat), in each report."""
    verb = "diagnose"
    outputs = DIAGNOSE_OUTPUTS
    curves: ClassVar[tuple[str, ...]] = ()
    columns = ("verdict", "unexplained", "ambiguous", "withheld", "misfit_x_noise", "misfit_extended_x_noise",
               "warnings")
    """The headline: the named effects; whether a structured residual is left that no catalogue effect explains;
    the candidates the trial cannot tell apart; the causes withheld from the verdict (they leave real, structured
    misfit in what they explain: :func:`~boat_twin.diagnose.search.withheld`); the largest signal RMSE over its
    noise before and after the named effects, -; warnings counted."""

    def __call__(self, path: Path, out: Path, named: Path | None = None) -> dict[str, Any]:
        """Diagnose the trial at ``path``, write its report into ``out`` (``named``: the directory its texts
        name, default ``out``); its row's values."""
        from boat_twin.diagnose.defaults import WINDOW_S
        from boat_twin.diagnose.pipeline import diagnose_trial
        from boat_twin.fleet.reports import write_diagnosis_report

        trial = self.read.read(path)
        done = diagnose_trial(trial, self.config, self.window_s or WINDOW_S)
        done.result["warnings"] += self.assumed
        out.mkdir(parents=True, exist_ok=True)
        write_diagnosis_report(out, done, str(path), named)
        result = done.result
        ambiguous = result["ambiguous"]
        return {"duration_s": duration_s(trial), "verdict": [v["effect"] for v in result["verdict"]],
                "unexplained": result["unexplained"], "ambiguous": ambiguous["effects"] if ambiguous else [],
                "withheld": [w["effect"] for w in result["withheld"]],
                "misfit_x_noise": _misfit(result["baseline"]["rmse"], result["noise"]),
                "misfit_extended_x_noise": _misfit(result["extended"]["rmse"], result["noise"]),
                "warnings": len(result["warnings"])}


@dataclass(frozen=True)
class FollowJob:
    """``boat-twin follow TRIAL --out DIR`` on one trial, the live twin started from ``config``."""

    config: TwinConfig = field(default_factory=TwinConfig)
    read: ReadOptions = field(default_factory=ReadOptions)
    assumed: tuple[str, ...] = ()
    """Warnings of what the run assumed rather than was given (no --config: the built-in boat), in each report."""
    verb = "follow"
    outputs = FOLLOW_OUTPUTS
    curves: ClassVar[tuple[str, ...]] = ()
    columns = ("mass_kg", "resistance_factor", "causes", "unexplained", "misfit_speed_innovation_ratio",
               "misfit_yaw_rate_innovation_ratio", "warnings")
    """The headline at the trial's end: the adapted surge mass, kg, and resistance factor, -; the causes the
    rolling diagnosis names and whether something is unexplained; the speed and the yaw-rate innovations' RMS
    over their noise in the last minute, -; warnings counted."""

    def __call__(self, path: Path, out: Path, named: Path | None = None) -> dict[str, Any]:
        """Follow the trial at ``path``, write its report into ``out`` (its texts name no directory: ``named``
        unused); its row's values."""
        from boat_twin.fleet.reports import write_follow_report
        from boat_twin.shadow.follow import follow_trial

        trial = self.read.read(path)
        done = follow_trial(trial, self.config)
        done.warnings += self.assumed
        out.mkdir(parents=True, exist_ok=True)
        write_follow_report(out, done, self.config, str(path))
        final = done.final
        return {"duration_s": duration_s(trial), "mass_kg": final["mass_kg"],
                "resistance_factor": final["resistance_factor"], "causes": list(final["causes"]),
                "unexplained": final["unexplained"], "misfit_speed_innovation_ratio": final["speed_innovation_ratio"],
                "misfit_yaw_rate_innovation_ratio": final["yaw_rate_innovation_ratio"],
                "warnings": len(done.warnings)}


def _misfit(rmse: dict[str, float], noise: dict[str, float]) -> float | None:
    """The largest RMSE over noise of the signals whose noise is known, -."""
    ratios = [rmse[s] / noise[s] for s in noise if s in rmse and np.isfinite(noise[s]) and noise[s] > 0.0]
    return float(max(ratios)) if ratios else None
