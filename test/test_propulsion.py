"""The engines' envelope written once in numpy (vessel/propulsion.py, the live and offline surge records) agrees
with the numba kernel's."""

from dataclasses import replace

import numpy as np
import pytest

from boat_twin.vessel.dynamics import _delivered_thrust, compile_coefficients
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.propulsion import engine_thrust_N, surge_thrust_N


def test_numpy_envelope_is_the_kernels_and_the_surge_thrust_sums_along_the_hull() -> None:
    boat = replace(VesselParams(), engine_power_W=20000.0, thrust_factor_left=0.9)
    k = compile_coefficients(boat)
    rng = np.random.default_rng(5)
    commands, speeds = rng.uniform(-2500.0, 2500.0, 500), rng.uniform(-14.0, 14.0, 500)
    speeds[:5] = 0.0  # at rest: the bollard thrust
    delivered = engine_thrust_N(boat, commands, speeds)
    np.testing.assert_allclose(delivered, [_delivered_thrust(c, u, k) for c, u in zip(commands, speeds, strict=True)],
                               rtol=1e-12)
    assert np.any(delivered < np.minimum(commands, boat.bollard_thrust_N))  # the envelope bites η·P/u
    angles = rng.uniform(-0.5, 0.5, (500, 2))
    pairs = np.column_stack([commands, commands[::-1]])
    expected = (0.9 * engine_thrust_N(boat, pairs[:, 0], speeds) * np.cos(angles[:, 0])
                + engine_thrust_N(boat, pairs[:, 1], speeds) * np.cos(angles[:, 1]))
    np.testing.assert_allclose(surge_thrust_N(boat, pairs, angles, speeds), expected, rtol=1e-12)
    assert np.isnan(engine_thrust_N(boat, np.nan, 3.0))


def test_a_boat_files_thrust_maps_in_numpy_are_the_kernels_and_read_backwards_give_the_thrust() -> None:
    """The table and the propeller of a boat file (vessel/actuators.py, numpy) against the kernel's copies, and the
    kernel's command for a thrust (what scenarios ask) gives that thrust back."""
    from boat_twin.vessel.dynamics import _slot_thrust, _thrust_command
    from boat_twin.vessel.params import params_from_dict
    from boat_twin.vessel.propulsion import thruster_thrust_N

    boat = params_from_dict({"propulsion": {"thrusters": [
        {"name": "a", "x_m": -2.0, "y_m": 0.5, "command": "table",
         "table": {"command": [-1.0, 0.0, 0.5, 1.0], "thrust_N": [-300.0, 0.0, 400.0, 900.0]}},
        {"name": "b", "x_m": -2.0, "y_m": -0.5, "command": "propeller",
         "propeller": {"diameter_m": 0.35, "kt": [0.42, -0.2, -0.15], "wake_fraction": 0.1}}]}}, "boat")
    k = compile_coefficients(boat)
    rng = np.random.default_rng(7)
    table, propeller = boat.propulsion.thrusters  # type: ignore[union-attr]
    for slot, thruster, commands in ((0, table, rng.uniform(-1.2, 1.2, 200)),
                                     (1, propeller, rng.uniform(-25.0, 25.0, 200))):
        speeds = rng.uniform(0.0, 8.0, 200)
        np.testing.assert_allclose(thruster_thrust_N(boat, thruster, commands, speeds),
                                   [_slot_thrust(slot, c, u, k) for c, u in zip(commands, speeds, strict=True)],
                                   rtol=1e-12, atol=1e-9)
    for slot, thrust_N, speed in ((0, 650.0, 3.0), (0, -150.0, 0.0), (1, 500.0, 4.0), (1, -200.0, 0.0)):
        command = _thrust_command(slot, thrust_N, speed, k)
        assert _slot_thrust(slot, command, speed, k) == pytest.approx(thrust_N, rel=1e-9)


def test_a_thrust_tables_zero_thrust_command_is_its_neutral() -> None:
    from boat_twin.vessel.actuators import ThrustTable

    band = ThrustTable((1100.0, 1450.0, 1550.0, 1900.0), (-15.0, 0.0, 0.0, 25.0), "pwm_us")
    assert band.zero_thrust_command() == 1500.0  # the middle of the dead band
    crossing = ThrustTable((-1.0, 1.0), (-10.0, 30.0))
    assert crossing.zero_thrust_command() == -0.5
    assert float(crossing.thrust(crossing.zero_thrust_command())) == 0.0
    ahead_only = ThrustTable((0.0, 1.0), (2.0, 30.0))
    assert ahead_only.zero_thrust_command() == 0.0  # never zero: the end nearest to it
