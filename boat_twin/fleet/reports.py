"""One trial's report files, written the same way by ``identify`` / ``diagnose`` / ``follow TRIAL --out DIR`` and
by a batch (``--each --out DIR``: each trial's report in ``DIR/<trial name>/``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from boat_twin.config import TwinConfig, save_config
from boat_twin.diagnose.defaults import EXTENDED_MODEL_NAME
from boat_twin.files import atomic_save_figure, atomic_write_text, ensure_out_dir, to_json
from boat_twin.ident.pipeline import TrialIdentifyResult
from boat_twin.ident.report import write_trial_report
from boat_twin.ident.results import TrialsIdentification
from boat_twin.model_error import ModelError
from boat_twin.sensors.gnss import GnssConfig
from boat_twin.vessel.params import VesselParams

if TYPE_CHECKING:  # the diagnosis and the live twin are imported by the verbs that write their reports only
    from boat_twin.diagnose.pipeline import TrialDiagnosis
    from boat_twin.shadow.follow import FollowResult


def antenna_height_m(vessel: VesselParams) -> float:
    """The twin's GNSS antenna height above the waterline, m: the default boat's (1.5 m on its 6 m) carried to
    the boat's length (a 1.2 m boat's antenna is not 1.5 m up)."""
    return GnssConfig.antenna_height_m * vessel.length_m / VesselParams().length_m


def identified_twin(found: TrialsIdentification, model_error: ModelError | None = None) -> TwinConfig | None:
    """The twin ``identify`` writes as twin.yaml (None: no vessel was built): the identified vessel, the GNSS at
    the first trial's origin and an antenna :func:`antenna_height_m` up, ``model_error`` when measured."""
    if found.vessel is None:
        return None
    lat, lon, alt = found.origin or (GnssConfig.origin_lat_deg, GnssConfig.origin_lon_deg, GnssConfig.origin_alt_m)
    gnss = GnssConfig(origin_lat_deg=lat, origin_lon_deg=lon, origin_alt_m=alt,
                      antenna_height_m=antenna_height_m(found.vessel))
    return TwinConfig(vessel=found.vessel, gnss=gnss, model_error=model_error or ModelError())


def write_identify_report(out: Path, result: TrialIdentifyResult, found: TrialsIdentification, sources: str,
                          boat_file: str | None, named: Path | None = None,
                          true_resistance_N: Callable[[np.ndarray], np.ndarray] | None = None,
                          model_error: ModelError | None = None) -> None:
    """The report of :func:`~boat_twin.ident.pipeline.identify_trials` (``result``, the contract of ``found``) on
    the trials read from ``sources`` into ``out``: twin.yaml (when a mass is known; geometry from ``boat_file`` or
    the default boat; the GNSS origin the first trial's), identify.json, model.yaml and the figures of the records
    the fit read (resimulation.png for a single trial; ``true_resistance_N``, speed m/s → N, drawn when known).
    ``named``: the directory the texts name (default ``out``; a report set's final name when ``out`` is its
    staging copy). ``model_error``: the twin's measured model error (twin.yaml's ``model_error`` section)."""
    ensure_out_dir(out)
    twin = identified_twin(found, model_error)
    if twin is not None:
        save_config(twin, out / "twin.yaml",
                    f"boat_twin twin of the boat identified from {sources}\n"
                    f"geometry: {boat_file or 'the default boat carried to the identified mass'}; where each fact "
                    "came from: identify.json 'twin'\n"
                    f"load with: boat-twin simulate ... --config {(named or out) / 'twin.yaml'}")
    write_trial_report(out, result, found.identification.records,
                       found.trials[0].resimulation if len(found.trials) == 1 else None, true_resistance_N,
                       title=f"identify {sources}")


def write_diagnosis_report(out: Path, done: TrialDiagnosis, source: str, named: Path | None = None) -> None:
    """The report of a :func:`~boat_twin.diagnose.pipeline.diagnose_trial` of ``source`` into ``out``: the
    extended model (its path set in ``done.result["extended_model"]``), five figures (the track map:
    :mod:`boat_twin.view.track_map`; the one-page summary: :mod:`boat_twin.view.summary`) and diagnosis.json.
    ``named``: the directory the texts name (default ``out``; a report set's final name)."""
    from boat_twin.diagnose.report import concerned_signals, evidence_figure, residual_figure, signal_figure
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
