"""The roles a trial's streams play (names only, free of heavy imports: the command line lists them in --help)."""

COMMAND_ROLES = ("thrust_left", "thrust_right", "angle_left", "angle_right")
"""Command streams, each one scalar per message (N or rad)."""
SENSOR_ROLES = ("gnss_fix", "gnss_vel", "imu")
"""Measured streams: GNSS fix (lat, lon, alt), GNSS velocity (east, north), IMU (yaw, yaw rate, ax, ay)."""
TRIAL_ROLES = COMMAND_ROLES + SENSOR_ROLES
"""Roles a topic remap may name."""
