"""Default settings of the diagnosis, in a module free of heavy imports (``boat-twin diagnose --help`` shows
them at once)."""

WINDOW_S = 20.0
"""Default replay window, s: long enough for a 1.5° steering offset to turn the track by several degrees,
short enough that a heading error from the start does not dominate."""
EXTENDED_MODEL_NAME = "extended_model.yaml"
"""File name of the extended model a diagnosis writes into its report directory."""
PART_WINDOWS = 180
"""Windows a replay, a fit and the residual regression take at a time (an hour of 20 s windows): their working
arrays are those of this many windows, whatever the trial's length."""
