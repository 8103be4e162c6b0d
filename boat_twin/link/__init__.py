"""The twin as a live MAVLink boat for ground stations (a front end over the twin, like the ROS nodes)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "MavlinkBoat": "boat_twin.link.mavlink_boat",
    "parse_stream_rates": "boat_twin.link.schedule",
}
"""Public name → its module, imported on first use."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
