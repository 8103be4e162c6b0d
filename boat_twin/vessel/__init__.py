"""The boat: parameters derived from physical facts, resistance models, the 3-DOF dynamics, the environment
(current, wind) and the scenarios that command it. SI units inside; REP-103 frames (ENU world, FLU body)."""

from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams, derive_coefficients, load_params, save_params
from boat_twin.vessel.resistance import (
    CorrectedResistance,
    PowerSeriesResistance,
    ResistanceModel,
    TableResistance,
    resistance_from_dict,
)
from boat_twin.vessel.scenarios import SCENARIO_NAMES, SCENARIOS, CommandProfile, Scenario, make_scenario, thrust_steps
from boat_twin.vessel.simulate import SimulationRecord, simulate

__all__ = [
    "SCENARIOS",
    "SCENARIO_NAMES",
    "CommandProfile",
    "CorrectedResistance",
    "Environment",
    "PowerSeriesResistance",
    "ResistanceModel",
    "Scenario",
    "SimulationRecord",
    "TableResistance",
    "VesselParams",
    "derive_coefficients",
    "load_params",
    "make_scenario",
    "resistance_from_dict",
    "save_params",
    "simulate",
    "thrust_steps",
]
