"""Identification of the longitudinal model m·dv/dt = F − Fc(v) (Dyda & Chumakova 2021): steady points and
power-series fits, mass from transients, the online (RLS) identifier shared by the ROS node and bag replay, the
paper's table, and the pipelines that run them on a trial."""

from boat_twin.ident.dynamic import DynamicWindow, identify_dynamic
from boat_twin.ident.live import LiveIdentifier
from boat_twin.ident.online import OnlineThrustSpeedIdentifier, SteadyCriteria, detect_steady_segments
from boat_twin.ident.pipeline import (
    identify_arrays,
    identify_table,
    identify_trial,
    model_dict,
    trial_samples,
    write_model_yaml,
)
from boat_twin.ident.resimulate import Resimulation, resimulate
from boat_twin.ident.steady import FitResult, fit_power_series, select_order

__all__ = [
    "DynamicWindow",
    "FitResult",
    "LiveIdentifier",
    "OnlineThrustSpeedIdentifier",
    "Resimulation",
    "SteadyCriteria",
    "detect_steady_segments",
    "fit_power_series",
    "identify_arrays",
    "identify_dynamic",
    "identify_table",
    "identify_trial",
    "model_dict",
    "resimulate",
    "select_order",
    "trial_samples",
    "write_model_yaml",
]
