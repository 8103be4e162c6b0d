"""Identification of the longitudinal model m·dv/dt = F − Fc(v) (Dyda & Chumakova 2021): steady points and
power-series fits, mass from transients, the online (RLS) identifier shared by the ROS node and bag replay, the
paper's table, the pipelines that run them on a trial, and the identified boat as a whole twin; and the turning
(sway/yaw) coefficients from zigzags and turning circles (:func:`fit_manoeuvring`)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "DynamicWindow": "boat_twin.ident.dynamic",
    "FitResult": "boat_twin.ident.steady",
    "Identification": "boat_twin.ident.results",
    "IdentifyResult": "boat_twin.ident.results",
    "LiveIdentifier": "boat_twin.ident.live",
    "ManoeuvringFit": "boat_twin.ident.manoeuvring",
    "OnlineThrustSpeedIdentifier": "boat_twin.ident.online",
    "Resimulation": "boat_twin.ident.resimulate",
    "SteadyCriteria": "boat_twin.ident.online",
    "TrialIdentifyResult": "boat_twin.ident.results",
    "TrialsIdentification": "boat_twin.ident.results",
    "derive_criteria": "boat_twin.ident.settling",
    "detect_steady_segments": "boat_twin.ident.online",
    "fit_manoeuvring": "boat_twin.ident.manoeuvring",
    "fit_power_series": "boat_twin.ident.steady",
    "identify_and_resimulate": "boat_twin.ident.pipeline",
    "identify_arrays": "boat_twin.ident.pipeline",
    "identify_dynamic": "boat_twin.ident.dynamic",
    "identify_table": "boat_twin.ident.pipeline",
    "identify_pooled": "boat_twin.ident.pipeline",
    "identify_recordings": "boat_twin.ident.pipeline",
    "identify_trial": "boat_twin.ident.pipeline",
    "identify_trials": "boat_twin.ident.pipeline",
    "identified_vessel": "boat_twin.ident.twin_config",
    "load_boat": "boat_twin.ident.twin_config",
    "read_boat_file": "boat_twin.ident.twin_config",
    "model_dict": "boat_twin.ident.results",
    "resimulate": "boat_twin.ident.resimulate",
    "select_order": "boat_twin.ident.steady",
    "tactical_diameter_m": "boat_twin.ident.manoeuvring",
    "trial_samples": "boat_twin.ident.pipeline",
    "write_model_yaml": "boat_twin.ident.results",
    "ZigzagRecord": "boat_twin.ident.zigzag_features",
    "ensemble_features": "boat_twin.ident.zigzag_features",
    "trial_features": "boat_twin.ident.zigzag_features",
    "zigzag_features": "boat_twin.ident.zigzag_features",
}
"""Public name → its module. Imported on first use: importing one light module of the package (e.g. from a
sensor model) must not load the compiled simulator."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
