"""The boat: parameters derived from physical facts, resistance models, the 3-DOF dynamics, the environment
(current, wind) and the scenarios that command it. SI units inside; REP-103 frames (ENU world, FLU body)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "CommandProfile": "boat_twin.vessel.scenarios",
    "CorrectedResistance": "boat_twin.vessel.resistance",
    "Environment": "boat_twin.vessel.environment",
    "PowerSeriesResistance": "boat_twin.vessel.resistance",
    "ResistanceModel": "boat_twin.vessel.resistance",
    "SCENARIOS": "boat_twin.vessel.scenarios",
    "SCENARIO_NAMES": "boat_twin.vessel.scenario_names",
    "Scenario": "boat_twin.vessel.scenarios",
    "SimulationRecord": "boat_twin.vessel.simulate",
    "TableResistance": "boat_twin.vessel.resistance",
    "VesselParams": "boat_twin.vessel.params",
    "derive_coefficients": "boat_twin.vessel.params",
    "load_params": "boat_twin.vessel.params",
    "level_crossing": "boat_twin.vessel.manoeuvres",
    "make_scenario": "boat_twin.vessel.scenarios",
    "manoeuvre_figures": "boat_twin.vessel.manoeuvres",
    "refined_extreme": "boat_twin.vessel.manoeuvres",
    "resistance_from_dict": "boat_twin.vessel.resistance",
    "save_params": "boat_twin.vessel.params",
    "similar_boat": "boat_twin.vessel.params",
    "simulate": "boat_twin.vessel.simulate",
    "thrust_steps": "boat_twin.vessel.scenarios",
    "turning_figures": "boat_twin.vessel.manoeuvres",
    "zigzag_figures": "boat_twin.vessel.manoeuvres",
}
"""Public name → its module. Imported on first use: importing one light module of the package (e.g. from a
sensor model) must not load the compiled simulator."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
