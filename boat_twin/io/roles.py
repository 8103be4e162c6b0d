"""The roles a trial's streams play (names only, free of heavy imports: the command line lists them in --help)."""

COMMAND_ROLES = ("thrust_left", "thrust_right", "angle_left", "angle_right")
"""Command streams, each one scalar per message (N, a thruster's own unit, or rad)."""
SENSOR_ROLES = ("gnss_fix", "gnss_vel", "imu")
"""Measured streams: GNSS fix (lat, lon, alt), GNSS velocity (east, north), IMU (yaw, yaw rate, ax, ay)."""
MEASURED_INPUT_ROLES = ("wind",)
"""Measured inputs a recording may carry: the true wind over ground (east, north; the air's velocity, m/s) from
an anemometer, a known input of the diagnosis."""
TRIAL_ROLES = COMMAND_ROLES + SENSOR_ROLES + MEASURED_INPUT_ROLES
"""Roles a topic remap may name."""
