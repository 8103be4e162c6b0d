"""The twin as a whole: vessel, environment and sensors run together, batch (a sea trial) or tick by tick (live);
and a recorded trial's commands replayed through it window by window (:mod:`boat_twin.twin.replay`)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "LiveTwin": "boat_twin.twin.live",
    "Prediction": "boat_twin.twin.replay",
    "SeaTrial": "boat_twin.twin.sea_trial",
    "Windows": "boat_twin.twin.replay",
    "cut_windows": "boat_twin.twin.replay",
    "predict": "boat_twin.twin.replay",
    "predict_vessels": "boat_twin.twin.replay",
    "run_sea_trial": "boat_twin.twin.sea_trial",
    "trial_messages": "boat_twin.twin.sea_trial",
}
"""Public name → its module, imported on first use (the replay does not load the live twin's messages)."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
