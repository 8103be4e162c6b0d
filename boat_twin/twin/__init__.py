"""The twin as a whole: vessel, environment and sensors run together, batch (a sea trial) or tick by tick (live);
and a recorded trial's commands replayed through it window by window (:mod:`boat_twin.twin.replay`)."""

from boat_twin.twin.live import LiveTwin
from boat_twin.twin.sea_trial import SeaTrial, run_sea_trial, trial_messages

__all__ = ["LiveTwin", "SeaTrial", "run_sea_trial", "trial_messages"]
