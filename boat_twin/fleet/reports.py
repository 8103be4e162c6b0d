"""The report files of ``diagnose`` and ``follow TRIAL --out DIR``, written the same way by a batch (``--each
--out DIR``: each trial's report in ``DIR/<trial name>/``). Here, not beside their analyses, because their track
maps (:mod:`boat_twin.view.track_map`) sit above them; identify's writer is its own
(:func:`boat_twin.ident.report.write_identify_report`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.config import TwinConfig, save_config
from boat_twin.diagnose.defaults import EXTENDED_MODEL_NAME
from boat_twin.diagnose.pipeline import TrialDiagnosis
from boat_twin.diagnose.report import concerned_signals, evidence_figure, residual_figure, signal_figure
from boat_twin.files import atomic_save_figure, atomic_write_text, to_json

if TYPE_CHECKING:  # the live twin (and scipy.stats with it) is follow's: diagnose's report has no use for it
    from boat_twin.shadow.follow import FollowResult


def write_diagnosis_report(out: Path, done: TrialDiagnosis, source: str, named: Path | None = None) -> None:
    """The report of a :func:`~boat_twin.diagnose.pipeline.diagnose_trial` of ``source`` into ``out``: the
    extended model (its path set in ``done.result["extended_model"]``), five figures (the track map:
    :mod:`boat_twin.view.track_map`; the one-page summary: :mod:`boat_twin.view.summary`) and diagnosis.json.
    ``named``: the directory the texts name (default ``out``; a report set's final name)."""
    from boat_twin.view.summary import diagnosis_summary_figure
    from boat_twin.view.track_map import diagnosis_track_figure

    result = done.result
    names = ", ".join(v["effect"] for v in result["verdict"]) or "none"
    save_config(done.extended, out / EXTENDED_MODEL_NAME,
                f"boat_twin extended model: diagnose {source} (named: {names})\n"
                f"load with: boat-twin simulate ... --config {(named or out) / EXTENDED_MODEL_NAME}")
    result["extended_model"] = str((named or out) / EXTENDED_MODEL_NAME)
    concerned = concerned_signals(result)
    before, after = done.baseline_prediction, done.extended_prediction
    title = f"diagnose {source}"
    atomic_save_figure(out / "diagnosis_signals.png", signal_figure(done.windows, before, after, concerned), title)
    atomic_save_figure(out / "diagnosis_residuals.png", residual_figure(done.windows, before, after), title)
    atomic_save_figure(out / "diagnosis_evidence.png", evidence_figure(result), title)
    atomic_save_figure(out / "diagnosis_track.png", diagnosis_track_figure(done, f"track: {title}"))
    atomic_save_figure(out / "diagnosis_summary.png", diagnosis_summary_figure(done, title))
    atomic_write_text(out / "diagnosis.json", to_json(result) + "\n")


def write_follow_report(out: Path, done: FollowResult, config: TwinConfig, source: str) -> None:
    """The report of a :func:`~boat_twin.shadow.follow.follow_trial` of ``source`` (started from ``config``) into
    ``out``: follow.json, the five figures (the track map: :mod:`boat_twin.view.track_map`; the one-page
    summary: :mod:`boat_twin.view.summary`) and the adapted twin.yaml."""
    from boat_twin.shadow.plots import cause_figure, innovation_figure, model_figure
    from boat_twin.view.summary import follow_summary_figure
    from boat_twin.view.track_map import follow_track_figure

    atomic_write_text(out / "follow.json", to_json(done.to_dict()) + "\n")
    atomic_save_figure(out / "follow_innovations.png", innovation_figure(done))
    atomic_save_figure(out / "follow_model.png", model_figure(done, config.vessel.mass_kg))
    atomic_save_figure(out / "follow_causes.png", cause_figure(done))
    atomic_save_figure(out / "follow_track.png", follow_track_figure(done, f"track: follow {source}"))
    atomic_save_figure(out / "follow_summary.png", follow_summary_figure(done, f"follow {source}"))
    save_config(done.twin, out / "twin.yaml", f"boat_twin live twin adapted by: boat-twin follow {source}")
