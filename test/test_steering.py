"""The steering actuator written once in numpy (vessel/steering.py) agrees with the numba kernel's."""

from dataclasses import replace

import numpy as np
import pytest

from boat_twin.vessel.dynamics import Dynamics, _steering_after, _steering_target, compile_coefficients
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.steering import steering_after, steering_history, steering_target


def _boat(offset_rad: float, limit_rad: float, rate_radps: float) -> VesselParams:
    return replace(VesselParams(), steering_offset_rad=offset_rad, max_steering_rad=limit_rad,
                   steering_rate_radps=rate_radps)


@pytest.mark.parametrize("rate_radps", [0.0, 0.35, 2.0])
def test_numpy_actuator_is_the_kernels(rate_radps: float) -> None:
    rng = np.random.default_rng(int(rate_radps * 100))
    offset, limit = rng.uniform(-0.05, 0.05), rng.uniform(0.3, 0.6)
    k = compile_coefficients(_boat(offset, limit, rate_radps))
    commands = rng.uniform(-0.8, 0.8, 400)  # beyond the limit too
    angles = rng.uniform(-0.6, 0.6, 400)
    taus = rng.uniform(0.0, 0.2, 400)
    targets = steering_target(commands, offset, limit)
    np.testing.assert_array_equal(targets, [_steering_target(c, k) for c in commands])
    for angle, target, tau in zip(angles, targets, taus, strict=True):
        assert steering_after(angle, target, rate_radps, tau) == _steering_after(angle, target, k, tau)


def test_history_is_the_kernels_actuator_sample_by_sample_with_gaps_starting_afresh() -> None:
    params = _boat(0.02, 0.5, 0.35)
    k = compile_coefficients(params)
    rng = np.random.default_rng(3)
    commands = np.zeros((300, 4))
    commands[:, 2:4] = np.repeat(rng.uniform(-0.7, 0.7, (30, 2)), 10, axis=0)  # held 1 s at 10 Hz
    commands[120:125] = np.nan  # commands unknown for 0.5 s
    history = Dynamics(params).steering_history(0.1, commands)
    angle = np.full(2, np.nan)
    for i, command in enumerate(commands):
        target = np.array([_steering_target(c, k) for c in command[2:4]])
        angle = np.where(np.isnan(angle), target, angle)
        np.testing.assert_array_equal(history[i], angle)
        angle = np.array([_steering_after(a, t, k, 0.1) for a, t in zip(angle, target, strict=True)])
    assert np.isnan(history[121:125]).all() and np.all(np.abs(np.diff(history[:120], axis=0)) <= 0.035 + 1e-12)
    np.testing.assert_array_equal(history[125], steering_target(commands[125, 2:4], 0.02, 0.5))  # afresh
    assert np.array_equal(steering_history(history[:0], 0.35, 0.1), history[:0])
