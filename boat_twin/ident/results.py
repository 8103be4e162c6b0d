"""The identification's results, typed, and their serialisation apart: :class:`Identification` (what
:func:`~boat_twin.ident.pipeline.identify_pooled` computes) and :class:`TrialsIdentification` (with the trials,
their re-simulations and the twin) become the ``--json`` contract of ``boat-twin identify`` (:class:`IdentifyResult`,
:class:`TrialIdentifyResult`: SI, JSON-ready) through :func:`identification_dict` and
:func:`trials_identification_dict`; :func:`model_dict` / :func:`write_model_yaml` give the identified model that the
vessel loader accepts as an override. The report's files are written by :mod:`boat_twin.ident.report`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import yaml

from boat_twin.files import atomic_write_text
from boat_twin.ident.dynamic import DynamicResult
from boat_twin.ident.online import SteadySegment
from boat_twin.ident.output_error import OutputErrorResult, SurgeRecord
from boat_twin.ident.resimulate import Resimulation
from boat_twin.ident.settling import DerivedCriteria
from boat_twin.ident.steady import FitResult
from boat_twin.ident.wind_drag import WindDragResult
from boat_twin.vessel.params import VesselParams, params_to_dict

NOT_PHYSICAL_NEXT = (
    "what to do: cut the recording to where the boat runs (--start/--end S, seconds since the trial's start: "
    "leave out long idling at either end and towing or docking); check that the thrust is the force in N per "
    "thruster (--columns units, --calibration) and the speed over ground this boat's; a boat file (--boat) with "
    "its mass_kg holds the mass where the data do not fix it")
"""The line under a refusal (NOT PHYSICAL): what a user can do next."""


class IdentifyResult(TypedDict):
    """What :func:`identify_arrays` returns: the ``--json`` contract of ``boat-twin identify`` (SI, JSON-ready)."""

    output_error: dict[str, Any]
    """The model: OutputErrorResult.to_dict() (selected fit, the baseline beside it, every candidate's
    cross-validated error, why the selection, whether the mass is identified)."""
    physical_problems: list[str]
    """Why the model is not physical (empty when it is): such a model never becomes a twin."""

    steady_points: list[dict[str, float]]
    """Accepted constant-thrust segments: speed_mps, thrust_N, duration_s, start_s, end_s, speed_stderr_mps,
    recording (index of the pooled recording it came from)."""
    rejected_segments: list[dict[str, Any]]
    """Segments refused by the steady-state detector, each with its reason and recording."""
    steady_criteria: dict[str, Any]
    """The detector's window and thrust tolerance and the figures they were derived from (DerivedCriteria)."""
    fits: list[dict[str, Any]]
    """Steady power-series fits (FitResult.to_dict; a view of the data, not the model): coefficients N/(m/s)^i,
    intervals, RMSE, CV, BIC, ..."""
    selected_order: int | None
    """Order of the selected steady fit (None: too few steady points for any)."""
    selection_reason: str
    dynamic: dict[str, Any]
    """Mass + Fc from the transients (DynamicResult.to_dict; a view), or ``{"error": why}``."""
    online: dict[str, Any]
    """The online identifier replayed over the same samples (snapshot) and its agreement with batch."""
    model: dict[str, Any]
    """The identified model the vessel loader accepts: ``resistance`` (a monotone table of the output-error fit)
    and ``effective_mass_kg`` when identified or given."""
    warnings: list[str]


class TrialIdentifyResult(IdentifyResult, total=False):
    """What :func:`identify_trial` returns: :class:`IdentifyResult` plus the trial and the re-simulation."""

    trial: dict[str, Any]
    """Source, summary line, gaps, missing and derived roles of the (first) trial."""
    resimulation: dict[str, Any]
    """Resimulation.to_dict() of the (first) trial, or ``{"error": why}`` when the loop could not be closed."""
    trials: list[dict[str, Any]]
    """Every pooled trial: source, metadata line, gaps, missing, derived and its own ``resimulation``."""
    twin: dict[str, Any]
    """The identified twin's vessel (``vessel``: every fact; ``sources``: where each came from) or ``{"error"}``."""
    wind_drag: dict[str, Any]
    """Where trials measured the true wind: its drag coefficient fitted with the selected model and the baseline
    (:meth:`~boat_twin.ident.wind_drag.WindDragResult.to_dict`); absent otherwise."""


def model_dict(fit: FitResult, effective_mass_kg: float | None = None) -> dict[str, Any]:
    """The identified model as plain data: ``{"resistance": {...}, "effective_mass_kg": m}`` (SI fit).

    ``resistance`` is :meth:`PowerSeriesResistance.to_dict` (valid to the fit's top speed, quadratic law
    beyond); ``effective_mass_kg`` (hull + surge added mass) only when known.
    """
    model: dict[str, Any] = {"resistance": fit.resistance_model().to_dict()}
    if effective_mass_kg is not None:
        model["effective_mass_kg"] = float(effective_mass_kg)
    return model


def write_model_yaml(path: Path, model: dict[str, Any], comment: str = "") -> None:
    """Write ``model`` (:func:`model_dict`) as YAML to ``path`` atomically; ``comment`` lines go on top."""
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    atomic_write_text(path, header + yaml.safe_dump(model, sort_keys=False))


@dataclass
class Identification:
    """What :func:`~boat_twin.ident.pipeline.identify_pooled` found (SI); :func:`identification_dict` is its
    ``--json`` form (:class:`IdentifyResult`, whose fields say what each part means)."""

    output_error: OutputErrorResult
    physical_problems: list[str]
    points: list[tuple[int, SteadySegment]]
    """Accepted steady segments, each with the index of its recording."""
    rejected: list[tuple[int, SteadySegment]]
    criteria: DerivedCriteria
    fits: tuple[FitResult, ...]
    selected_order: int | None
    selection_reason: str
    dynamic: DynamicResult | None
    """None: not identified (:attr:`dynamic_error` says why)."""
    dynamic_error: str
    online: dict[str, Any]
    """The online identifier's snapshot, with ``agreement_with_batch``."""
    model: dict[str, Any]
    warnings: list[str]
    records: list[SurgeRecord]
    """The records the output-error fit read, one per recording on the pooled time axis (the steady points'
    times): a trial's surge record (:func:`~boat_twin.ident.trial_record.trial_record`). What the reports plot;
    not in the ``--json`` contract."""


@dataclass
class TrialReplay:
    """One pooled trial and the identified model's re-simulation of it (None: not done, :attr:`error` says why)."""

    source: str
    metadata: str
    """The trial's summary line."""
    gaps: list[Any]
    missing: list[str]
    derived: dict[str, str]
    resimulation: Resimulation | None
    error: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The contract's ``trials`` entry."""
        return {"source": self.source, "metadata": self.metadata, "gaps": self.gaps, "missing": self.missing,
                "derived": self.derived,
                "resimulation": self.resimulation.to_dict() if self.resimulation is not None
                else {"error": self.error}}


@dataclass
class TrialsIdentification:
    """:class:`Identification` of recorded trials, with each trial's re-simulation and the identified twin's
    vessel (None: not built, :attr:`twin_error` says why); :func:`trials_identification_dict` is its ``--json``
    form (:class:`TrialIdentifyResult`)."""

    identification: Identification
    trials: list[TrialReplay]
    vessel: VesselParams | None
    vessel_sources: dict[str, Any] = field(default_factory=dict)
    twin_error: str = ""
    origin: tuple[float, float, float] | None = None
    """The first trial's geodetic origin (lat deg, lon deg, ellipsoidal height m) for the twin's GNSS, None: the
    trials have no fix."""
    wind_drag: WindDragResult | None = None
    """The measured wind's drag coefficient (None: no trial measured the wind)."""


def steady_point_dicts(points: list[tuple[int, SteadySegment]]) -> list[dict[str, float]]:
    """Accepted steady segments (with their recording's index) as the contract's ``steady_points``."""
    return [{"speed_mps": s.speed_mps, "thrust_N": s.thrust_N, "duration_s": s.duration_s,
             "start_s": s.start_s, "end_s": s.end_s, "speed_stderr_mps": s.speed_stderr_mps,
             "recording": i} for i, s in points]


def identification_dict(found: Identification) -> IdentifyResult:
    """The ``--json`` contract of an identification (SI, JSON-ready)."""
    return {
        "output_error": found.output_error.to_dict(),
        "physical_problems": found.physical_problems,
        "steady_points": steady_point_dicts(found.points),
        "rejected_segments": [{**s.to_dict(), "recording": i} for i, s in found.rejected],
        "steady_criteria": found.criteria.to_dict(),
        "fits": [fr.to_dict() for fr in found.fits],
        "selected_order": found.selected_order,
        "selection_reason": found.selection_reason,
        "dynamic": found.dynamic.to_dict() if found.dynamic is not None else {"error": found.dynamic_error},
        "online": found.online,
        "model": found.model,
        "warnings": found.warnings,
    }


def trials_identification_dict(found: TrialsIdentification) -> TrialIdentifyResult:
    """The ``--json`` contract of an identification of trials: :func:`identification_dict`, the identified twin
    (``twin``), the first trial (``trial``, ``resimulation``) and every trial (``trials``)."""
    result = TrialIdentifyResult(**identification_dict(found.identification))
    result["twin"] = ({"vessel": params_to_dict(found.vessel), "sources": found.vessel_sources,
                       "gnss_origin": list(found.origin) if found.origin is not None else None}
                      if found.vessel is not None else {"error": found.twin_error})
    entries = [replay.to_dict() for replay in found.trials]
    result["trial"] = {k: x for k, x in entries[0].items() if k != "resimulation"}
    result["resimulation"] = entries[0]["resimulation"]
    result["trials"] = entries
    if found.wind_drag is not None:
        result["wind_drag"] = found.wind_drag.to_dict()
    return result
