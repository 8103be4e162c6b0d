"""The thrusters' delivered thrust in numpy, for the Python side (the live twin's and offline identification's
surge records): each thruster's command through its map (:mod:`boat_twin.vessel.actuators`) — on the default
layout, the outboards' thrust command limited to their envelope, astern down to −k·T_bollard, ahead up to
min(T_bollard, η·P/|u|) at the surge through the water u — times its thrust factor, along the hull at its real
steering angle (or its fixed angle), and a rudder's drag. The compiled kernel (:mod:`boat_twin.vessel.dynamics`)
has the same maps in numba for its RK4 stages; ``test/test_propulsion.py`` checks that they agree."""

from __future__ import annotations

import numpy as np

from boat_twin.units import SEAWATER_DENSITY_KGPM3
from boat_twin.vessel.actuators import SLIPSTREAM_KAPPA, Thruster
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


def thruster_thrust_N(vessel: VesselParams, thruster: Thruster, command: np.ndarray,
                      surge_mps: np.ndarray | float) -> np.ndarray:
    """One thruster's thrust under ``command`` (its unit) at the surge ``surge_mps`` through the water, N, before
    its thrust factor: the envelope (newtons), the table, or the propeller's K_T(J)."""
    if thruster.table is not None:
        return thruster.table.thrust(command)
    if thruster.propeller is not None:
        return thruster.propeller.thrust(command, surge_mps)
    return engine_thrust_N(vessel, command, surge_mps)


def surge_thrust_N(vessel: VesselParams, command_N: np.ndarray, angle_rad: np.ndarray,
                   surge_mps: np.ndarray | float) -> np.ndarray:
    """The thrust along the hull, N: Σ k_i·T_i·cos δ_i of the thrusters' commands ``command_N`` (..., 2) (left,
    right; each in its thruster's unit) delivered at ``surge_mps`` (...) with the thrust factors k_i, at the real
    angles of the steering inputs ``angle_rad`` (..., 2) (a fixed thruster at its own angle), plus each rudder's
    drag −F_N·sin δ at its angle (its inflow along the hull: the surge and its slipstream, no sway or yaw rate)."""
    factors = np.array([vessel.thrust_factor_left, vessel.thrust_factor_right])
    command = np.asarray(command_N, dtype=float)
    angles = np.asarray(angle_rad, dtype=float)
    surge = np.asarray(surge_mps, dtype=float)
    layout = vessel.propulsion
    if layout is None:
        delivered = engine_thrust_N(vessel, command, surge[..., None])
        return np.sum(factors * delivered * np.cos(angles), axis=-1)
    total = np.zeros(np.broadcast_shapes(command.shape[:-1], surge.shape))
    thrusts = []
    for j, thruster in enumerate(layout.thrusters):
        thrust = factors[j] * thruster_thrust_N(vessel, thruster, command[..., j], surge)
        thrusts.append(thrust)
        direction = angles[..., j] if thruster.steered else thruster.angle_rad
        total = total + thrust * np.cos(direction)
    for r, rudder in enumerate(layout.rudders):
        inflow = surge
        if rudder.washed_by is not None:
            j = layout.thruster_index(rudder.washed_by)
            diameter = layout.thrusters[j].diameter_m
            push = np.maximum(thrusts[j], 0.0)
            far = np.sqrt(surge**2 + 8.0 * push / (SEAWATER_DENSITY_KGPM3 * np.pi * diameter**2))
            eta = min(1.0, diameter / rudder.span_m)
            wash = np.abs(surge) + SLIPSTREAM_KAPPA * (far - np.abs(surge))
            inflow = np.where(push > 0.0, np.sqrt(eta * wash**2 + (1.0 - eta) * surge**2), surge)
        gain = 0.5 * SEAWATER_DENSITY_KGPM3 * rudder.area_m2 * rudder.lift_slope
        delta = angles[..., r]
        total = total - gain * inflow**2 * np.sin(delta) ** 2
    return total
