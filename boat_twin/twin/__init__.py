"""The twin as a whole: vessel, environment and sensors run together, batch (a sea trial) or tick by tick (live)."""

from boat_twin.twin.live import LiveTwin
from boat_twin.twin.sea_trial import SeaTrial, run_sea_trial, trial_messages

__all__ = ["LiveTwin", "SeaTrial", "run_sea_trial", "trial_messages"]
