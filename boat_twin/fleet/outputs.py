"""The files one trial's report holds, per verb: what ``identify`` / ``diagnose`` / ``follow TRIAL --out DIR``
write (:mod:`boat_twin.fleet.reports`), replaced as one set. A light module: the verbs name them before any work."""

from __future__ import annotations

from boat_twin.diagnose.defaults import EXTENDED_MODEL_NAME

IDENTIFY_OUTPUTS = ("identify.json", "model.yaml", "twin.yaml", "trial.png", "resistance.png", "resimulation.png")
"""What ``identify TRIAL --out DIR`` writes."""
DIAGNOSE_OUTPUTS = (EXTENDED_MODEL_NAME, "diagnosis_signals.png", "diagnosis_residuals.png",
                    "diagnosis_evidence.png", "diagnosis.json", "diagnosis_track.png",
                    "diagnosis_summary.png")
"""What ``diagnose TRIAL --out DIR`` writes."""
FOLLOW_OUTPUTS = ("follow.json", "follow_innovations.png", "follow_model.png", "follow_causes.png", "twin.yaml",
                  "follow_track.png", "follow_summary.png")
"""What ``follow TRIAL --out DIR`` writes."""
