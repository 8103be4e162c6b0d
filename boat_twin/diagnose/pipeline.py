"""The diagnosis pipelines: what a model gets wrong on a recorded trial (or on the paper's steady-state table),
the cause from the effect catalogue, the extended model and the gain.

:func:`diagnose_trial` is what ``boat-twin diagnose TRIAL`` runs; :func:`diagnose_paper_table` what
``diagnose --table dyda2021`` runs. Results carry the ``--json`` contract (SI, JSON-ready).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_COEFFICIENTS, PAPER_ORDERS
from boat_twin.diagnose.defaults import WINDOW_S
from boat_twin.diagnose.effects import catalogue
from boat_twin.diagnose.report import DiagnosisResult, MeasuredWind, result_dict
from boat_twin.diagnose.search import (
    BIC_THRESHOLD,
    Candidate,
    Diagnosis,
    Selection,
    delta_bic,
    forward_select,
    withheld,
)
from boat_twin.diagnose.structure import residual_structure
from boat_twin.diagnose.table import TableDiagnosis, diagnose_table, table_result
from boat_twin.errors import InputError
from boat_twin.io.trial import Trial, long_holds, thrust_outliers
from boat_twin.twin.replay import SIGNALS, Prediction, Windows, cut_windows, measured_wind_mps, with_measured_wind
from boat_twin.units import KGF_N, KNOT_MPS
from boat_twin.vessel.params import (
    HELD_COMMAND_TIME_CONSTANTS,
    VesselParams,
    held_command_limit_s,
    surge_response_time_s,
)
from boat_twin.vessel.resistance import TableResistance


@dataclass
class TrialDiagnosis:
    """Everything one diagnosis of a trial produced."""

    windows: Windows
    selection: Selection
    base: TwinConfig
    extended: TwinConfig
    baseline_prediction: Prediction
    extended_prediction: Prediction
    result: DiagnosisResult
    withheld: list[Candidate]
    """Named candidates not presented as the verdict (:func:`~boat_twin.diagnose.search.withheld`): ``extended``
    leaves them out."""

    @property
    def presented(self) -> list[Candidate]:
        """The named candidates the verdict presents, in the order they joined the model."""
        return [c for c in self.selection.named if all(c is not w for w in self.withheld)]


def command_warnings(trial: Trial, vessel: VesselParams) -> list[str]:
    """What in ``trial``'s commands the diagnosis should not take on trust: thrust beyond 5 times ``vessel``'s
    bollard thrust, thrust held unchanged longer than its :func:`~boat_twin.vessel.params.held_command_limit_s`."""
    held = long_holds(trial, held_command_limit_s(vessel), f"{HELD_COMMAND_TIME_CONSTANTS:g} x the model's surge "
                      f"response time, {surge_response_time_s(vessel):.0f} s")
    return [w for w in (thrust_outliers(trial, vessel.bollard_thrust_N), held) if w]


def diagnose_trial(trial: Trial, base: TwinConfig, window_s: float = WINDOW_S,
                   progress: Any = None, misfit: bool | None = None) -> TrialDiagnosis:
    """Diagnose ``trial`` against the model ``base``: the library entry point of ``diagnose TRIAL``. ``misfit``:
    evidence from outside the trial whether the model misfits (the live twin's innovations), which decides with
    the structure left whether the named causes are withheld (:func:`~boat_twin.diagnose.search.withheld`);
    None: the trial's own residuals decide. The result's ``warnings``: :func:`command_warnings` and what reading
    the trial lost (:meth:`~boat_twin.io.trial.TrialMetadata.warnings`)."""
    if not np.any(np.isfinite(trial.speed_mps)):
        raise InputError(f"{trial.metadata.source}: the speed over ground is unknown throughout (a GNSS velocity "
                         "component NaN in every sample, or no velocity or fix): nothing to diagnose")
    windows = cut_windows(trial, window_s)
    wind = measured_wind_mps(trial)
    unaware = None
    if wind is not None:  # a measured wind is a known input: the twin replays with it as it varied, judged
        unaware = Diagnosis(replace(windows, wind_departure_mps=None), base).fit([])  # against the twin without
        base = with_measured_wind(base, trial)
    diagnosis = Diagnosis(windows, base, progress)
    selection = forward_select(diagnosis, catalogue(base, trial.speed_mps))
    baseline_prediction = selection.baseline.residuals.prediction
    signatures = residual_structure(windows, selection.final.residuals.values,
                                    selection.final.residuals.prediction, diagnosis.structure_folds,
                                    {s: base.model_error.of(s).structure_r2 for s in SIGNALS},
                                    buffered=not base.model_error.zero)
    held_back = withheld(selection.named, signatures, misfit)
    extended, extended_prediction = _presented_model(diagnosis, selection, held_back)
    result = result_dict(windows, selection, baseline_prediction, extended_prediction, signatures, None,
                         diagnosis.sigma, held_back)
    result["windows"]["compared_fraction"] = diagnosis.projection.compared_fraction()
    if wind is not None and unaware is not None:
        result["measured_wind"] = measured_wind_dict(wind, delta_bic(selection.baseline, unaware))
    result["evaluations"] = diagnosis.evaluations
    if not base.model_error.zero:  # the yardstick held the twin's own error (docs/diagnosis.md)
        result["model_error"] = base.model_error.to_dict()
    result["warnings"] = ([f"{trial.metadata.source}: {w}" for w in command_warnings(trial, base.vessel)]
                          + trial.metadata.warnings())
    return TrialDiagnosis(windows, selection, base, extended, baseline_prediction, extended_prediction, result,
                          held_back)


def measured_wind_dict(wind: tuple[float, float], delta_bic_value: float) -> MeasuredWind:
    """The ``measured_wind`` entry of a diagnosis: the wind (ENU components; speed and the nautical direction it
    comes from), and whether it explains a misfit the twin without it has (ΔBIC of the twin replayed with it
    against the twin as configured below :data:`~boat_twin.diagnose.search.BIC_THRESHOLD`: then it is named)."""
    east, north = wind
    from_deg = math.degrees(math.atan2(-east, -north)) % 360.0  # clockwise from north, where the air comes from
    return MeasuredWind(east_mps=east, north_mps=north, speed_mps=math.hypot(east, north), from_deg=from_deg,
                        delta_bic=delta_bic_value, named=bool(delta_bic_value < BIC_THRESHOLD))


def _presented_model(diagnosis: Diagnosis, selection: Selection,
                     held_back: list[Candidate]) -> tuple[TwinConfig, Prediction]:
    """The extended model with the causes the verdict presents (at their values in the final fit) and its
    replay: a withheld cause is not put into the model a user loads."""
    final = selection.final
    if not held_back:
        return diagnosis.config(final.effects, final.values), final.residuals.prediction
    names = {c.effect.name for c in held_back}
    kept = [(e, v) for e, v, _ in final.split() if e.name not in names]
    if not kept:
        return diagnosis.base, selection.baseline.residuals.prediction
    effects = [e for e, _ in kept]
    values = np.concatenate([v for _, v in kept])
    config = diagnosis.config(effects, values)
    return config, diagnosis.residuals(config).prediction


def diagnose_paper_table(model_order: int) -> tuple[dict[str, Any], TableDiagnosis, TableResistance | None]:
    """Dyda & Chumakova (2021) Table 1 against the paper's fit of ``model_order`` (1, 3 or 5): the result, the
    diagnosis and, when a regime change is named, the extended resistance (SI) a simulator loads."""
    if model_order not in PAPER_ORDERS:
        raise InputError(f"--model-order {model_order}: the paper's fits have orders "
                         f"{', '.join(map(str, PAPER_ORDERS))}")
    speed_kn, force_kgf = dyda2021_table1()
    diag = diagnose_table(speed_kn, force_kgf, PAPER_COEFFICIENTS[model_order])
    result = table_result(diag, model_order, ("kn", "kgf"))
    if not diag.named:
        return result, diag, None
    force_n = diag.extended * KGF_N
    force_n[speed_kn == 0.0] = 0.0  # at rest there is no resistance, whatever the correction's end value
    return result, diag, TableResistance(tuple((speed_kn * KNOT_MPS).tolist()), tuple(force_n.tolist()))
