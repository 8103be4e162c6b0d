"""What a model gets wrong on measured data: windowed replay of a trial's commands, a catalogue of effects
(causes), held-out fits and a decision rule naming the cause, the extended model and the gain; also the
steady-state table case. :func:`diagnose_trial` is the pipeline ``boat-twin diagnose`` runs."""

from boat_twin.diagnose.pipeline import WINDOW_S, TrialDiagnosis, diagnose_paper_table, diagnose_trial

__all__ = ["WINDOW_S", "TrialDiagnosis", "diagnose_paper_table", "diagnose_trial"]
