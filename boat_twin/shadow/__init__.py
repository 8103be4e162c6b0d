"""The twin following a real boat live: kept in step with its measurements (innovations against the sensors'
noise), its surge model adapted online, the diagnosis catalogue run on the recent window; and a recording
followed as if live. Sits above the analyses it uses (identification, diagnosis)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "FollowResult": "boat_twin.shadow.follow",
    "Innovation": "boat_twin.shadow.sync",
    "RollingDiagnosis": "boat_twin.shadow.rolling",
    "Shadow": "boat_twin.shadow.session",
    "ShadowSettings": "boat_twin.shadow.session",
    "ShadowTwin": "boat_twin.shadow.sync",
    "SurgeAdapter": "boat_twin.shadow.adapt",
    "SurgeModel": "boat_twin.shadow.adapt",
    "SyncSettings": "boat_twin.shadow.sync",
    "fit_surge": "boat_twin.shadow.adapt",
    "horizon_record": "boat_twin.ident.output_error",
    "follow_trial": "boat_twin.shadow.follow",
}
"""Public name → its module, imported on first use."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
