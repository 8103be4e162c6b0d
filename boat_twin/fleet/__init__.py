"""Fleets: a verb run on many recorded trials, each on its own, and large simulated ensembles, as tasks on a Dask
cluster (local by default, an existing scheduler when one machine is outgrown) or one after another in this
process. :func:`run_batch` is what ``identify`` / ``diagnose --each`` run; :func:`run_ensemble` what
``simulate --ensemble`` runs; :func:`open_client` gives the Dask client either takes (or None)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "BatchResult": "boat_twin.fleet.batch",
    "DiagnoseJob": "boat_twin.fleet.jobs",
    "EnsembleSpec": "boat_twin.fleet.ensemble",
    "IdentifyJob": "boat_twin.fleet.jobs",
    "ReadOptions": "boat_twin.fleet.jobs",
    "TrialTask": "boat_twin.fleet.trials",
    "expand_trials": "boat_twin.fleet.trials",
    "name_trials": "boat_twin.fleet.trials",
    "open_client": "boat_twin.fleet.engine",
    "run_batch": "boat_twin.fleet.batch",
    "run_ensemble": "boat_twin.fleet.ensemble",
}
"""Public name → its module, imported on first use (a verb's ``--help`` loads neither dask nor the pipelines)."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
