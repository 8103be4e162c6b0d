"""The twin seen in Foxglove: the boat's measured track and the twin's predicted one on a map, the boat in 3-D
in the local ENU frame, the innovations against their noise band, the adapted model with its intervals and the
diagnosis verdicts as log entries — streamed live over the Foxglove WebSocket protocol and recorded to MCAP by the
foxglove-sdk (the optional ``view`` extra); and the reports' track maps (measured against predicted, matplotlib).
Sits above the live twin it shows (``shadow``)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "DEFAULT_HOST": "boat_twin.view.address",
    "DEFAULT_PORT": "boat_twin.view.address",
    "VIEW_MCAP": "boat_twin.view.address",
    "parse_address": "boat_twin.view.address",
    "require_sdk": "boat_twin.view.address",
    "TwinView": "boat_twin.view.stream",
    "ShadowView": "boat_twin.view.observer",
    "Pacer": "boat_twin.view.observer",
    "TOPICS": "boat_twin.view.stream",
    "SimulationView": "boat_twin.view.simulation",
    "show_trial": "boat_twin.view.simulation",
    "twin_layout": "boat_twin.view.layout",
    "layout_json": "boat_twin.view.layout",
    "track_figure": "boat_twin.view.track_map",
    "follow_track_figure": "boat_twin.view.track_map",
    "diagnosis_track_figure": "boat_twin.view.track_map",
}
"""Public name → its module, imported on first use."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
