"""The outboards' delivered thrust in numpy, for the Python side (the live twin's and offline identification's
surge records): each engine delivers its thrust command limited to its envelope — astern down to
−k·T_bollard, ahead up to min(T_bollard, η·P/|u|) at the surge through the water u — times its thrust factor,
along the hull at its real steering angle. The compiled kernel (:mod:`boat_twin.vessel.dynamics`) has the same
envelope in numba for its RK4 stages; ``test/test_propulsion.py`` checks that they agree."""

from __future__ import annotations

import numpy as np

from boat_twin.vessel.params import VesselParams


def engine_thrust_N(vessel: VesselParams, command_N: np.ndarray, surge_mps: np.ndarray | float) -> np.ndarray:
    """The thrust ``command_N`` delivered within the engines' envelope at the surge ``surge_mps`` (broadcast;
    NaN stays NaN), N: astern down to −``reverse_thrust_ratio``·T_bollard, ahead up to min(T_bollard, η·P/|u|)."""
    speed = np.abs(np.asarray(surge_mps, dtype=float))
    with np.errstate(divide="ignore"):
        ahead = np.minimum(vessel.bollard_thrust_N,
                           np.where(speed > 1e-9, vessel.propulsive_efficiency * vessel.engine_power_W
                                    / np.maximum(speed, 1e-300), np.inf))
    astern = -vessel.reverse_thrust_ratio * vessel.bollard_thrust_N
    return np.minimum(np.maximum(np.asarray(command_N, dtype=float), astern), ahead)


def surge_thrust_N(vessel: VesselParams, command_N: np.ndarray, angle_rad: np.ndarray,
                   surge_mps: np.ndarray | float) -> np.ndarray:
    """The thrust along the hull Σ k_i·T_i·cos δ_i, N: the thrust commands ``command_N`` (..., 2) (left, right)
    delivered (:func:`engine_thrust_N` at ``surge_mps`` (...)) with the thrust factors k_i, at the outboards'
    real angles ``angle_rad`` (..., 2)."""
    factors = np.array([vessel.thrust_factor_left, vessel.thrust_factor_right])
    delivered = engine_thrust_N(vessel, command_N, np.asarray(surge_mps, dtype=float)[..., None])
    return np.sum(factors * delivered * np.cos(np.asarray(angle_rad, dtype=float)), axis=-1)
