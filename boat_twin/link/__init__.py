"""The twin as a live MAVLink boat for ground stations (a front end over the twin, like the ROS nodes)."""

from boat_twin.link.mavlink_boat import MavlinkBoat, parse_stream_rates

__all__ = ["MavlinkBoat", "parse_stream_rates"]
