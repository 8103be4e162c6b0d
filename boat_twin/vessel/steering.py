"""The outboards' steering actuator in numpy, for the Python side (the replay's steering histories, the first
instant of a run): each outboard is driven to its target — the commanded angle plus the steering offset, within
±δ_max — and swings there at the steering rate ρ, δ(t + τ) = δ + clip(target − δ, −ρτ, ρτ); ρ = 0 is an
instantaneous actuator. The compiled kernel (:mod:`boat_twin.vessel.dynamics`) has the same two functions in
numba for its RK4 stages; ``test/test_steering.py`` checks that they agree."""

from __future__ import annotations

import numpy as np


def steering_target(command_rad: np.ndarray, offset_rad: np.ndarray | float,
                    limit_rad: np.ndarray | float) -> np.ndarray:
    """Where the outboards are driven, rad: ``command_rad`` + ``offset_rad`` within ±``limit_rad`` (broadcast)."""
    limit = np.asarray(limit_rad)
    return np.clip(np.asarray(command_rad) + offset_rad, -limit, limit)


def steering_after(angle_rad: np.ndarray, target_rad: np.ndarray, rate_radps: np.ndarray | float,
                   tau_s: float) -> np.ndarray:
    """The angles ``tau_s`` seconds on, swinging from ``angle_rad`` towards ``target_rad`` at ``rate_radps``
    (rad/s; 0: at the target at once), rad."""
    rate = np.asarray(rate_radps, dtype=float)
    reach = rate * tau_s
    swung = np.asarray(angle_rad) + np.clip(np.asarray(target_rad) - angle_rad, -reach, reach)
    return np.where(rate > 0.0, swung, target_rad)


def steering_history(target_rad: np.ndarray, rate_radps: float, dt_s: float) -> np.ndarray:
    """(n, 2) the outboards' angles at ``n`` samples ``dt_s`` apart under targets (n, 2) held from sample to
    sample, rad: starting at the first known target; NaN where the target is unknown (the next known target
    starts afresh there)."""
    out = np.empty_like(target_rad)
    angle = np.full(target_rad.shape[1:], np.nan)
    for i, target in enumerate(target_rad):
        out[i] = angle = np.where(np.isnan(angle), target, angle)
        angle = steering_after(angle, target, rate_radps, dt_s)
    return out
