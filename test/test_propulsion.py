"""The engines' envelope written once in numpy (vessel/propulsion.py, the live and offline surge records) agrees
with the numba kernel's."""

from dataclasses import replace

import numpy as np

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
