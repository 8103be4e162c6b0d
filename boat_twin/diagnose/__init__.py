"""What a model gets wrong on measured data: windowed replay of a trial's commands, a catalogue of effects
(causes), held-out fits and a decision rule naming the cause, the extended model and the gain; also the
steady-state table case. :func:`diagnose_trial` is the pipeline ``boat-twin diagnose`` runs."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "WINDOW_S": "boat_twin.diagnose.defaults",
    "DiagnosisResult": "boat_twin.diagnose.report",
    "TrialDiagnosis": "boat_twin.diagnose.pipeline",
    "diagnose_paper_table": "boat_twin.diagnose.pipeline",
    "diagnose_trial": "boat_twin.diagnose.pipeline",
}
"""Public name → its module, imported on first use (``boat-twin diagnose --help`` reads the light
:mod:`boat_twin.diagnose.defaults` without loading the pipeline)."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
