"""The diagnosis pipelines: what a model gets wrong on a recorded trial (or on the paper's steady-state table),
the cause from the effect catalogue, the extended model and the gain.

:func:`diagnose_trial` is what ``boat-twin diagnose TRIAL`` runs; :func:`diagnose_paper_table` what
``diagnose --table dyda2021`` runs. Results carry the ``--json`` contract (SI, JSON-ready).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_COEFFICIENTS, PAPER_ORDERS
from boat_twin.diagnose.defaults import WINDOW_S
from boat_twin.diagnose.effects import catalogue
from boat_twin.diagnose.report import DiagnosisResult, result_dict
from boat_twin.diagnose.search import Diagnosis, Selection, forward_select
from boat_twin.diagnose.structure import residual_structure
from boat_twin.diagnose.table import TableDiagnosis, diagnose_table, table_result
from boat_twin.errors import InputError
from boat_twin.io.trial import Trial
from boat_twin.twin.replay import Prediction, Windows, cut_windows
from boat_twin.units import KGF_N, KNOT_MPS
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


def diagnose_trial(trial: Trial, base: TwinConfig, window_s: float = WINDOW_S,
                   progress: Any = None) -> TrialDiagnosis:
    """Diagnose ``trial`` against the model ``base``: the library entry point of ``diagnose TRIAL``."""
    if not np.any(np.isfinite(trial.speed_mps)):
        raise InputError(f"{trial.metadata.source}: the speed over ground is unknown throughout (a GNSS velocity "
                         "component NaN in every sample, or no velocity or fix): nothing to diagnose")
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
    result["windows"]["compared_fraction"] = diagnosis.projection.compared_fraction()
    result["evaluations"] = diagnosis.evaluations
    return TrialDiagnosis(windows, selection, base, extended, baseline_prediction, extended_prediction, result)


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
