"""One convention per frame job: wrapping to [−π, π), ENU ↔ NED yaw, a quaternion's yaw."""

import math

import numpy as np
import pytest

from boat_twin.frames import enu_yaw_from_ned, ned_yaw_from_enu, quaternion_xyzw, quaternion_yaw_rad, wrap_pi


def test_wrap_is_half_open_at_plus_pi_for_floats_and_arrays() -> None:
    assert wrap_pi(math.pi) == pytest.approx(-math.pi)
    assert wrap_pi(-math.pi) == pytest.approx(-math.pi)
    angles = np.array([0.5 + 2.0 * math.pi * k for k in (-3, 0, 2)] + [3.0 * math.pi])
    np.testing.assert_allclose(wrap_pi(angles), [0.5, 0.5, 0.5, -math.pi])
    assert np.all((wrap_pi(np.linspace(-20.0, 20.0, 1001)) >= -math.pi)
                  & (wrap_pi(np.linspace(-20.0, 20.0, 1001)) < math.pi))


@pytest.mark.parametrize(("enu_deg", "ned_deg"), [(0.0, 90.0), (90.0, 0.0), (180.0, -90.0), (-90.0, 180.0)])
def test_enu_and_ned_yaw_are_each_others_inverse(enu_deg: float, ned_deg: float) -> None:
    """East is 0 in ENU and 90° (a compass's east) in NED; north is 90° in ENU and 0 in NED."""
    ned = math.radians(ned_deg)
    assert wrap_pi(ned_yaw_from_enu(math.radians(enu_deg)) - ned) == pytest.approx(0.0, abs=1e-12)
    assert wrap_pi(enu_yaw_from_ned(ned) - math.radians(enu_deg)) == pytest.approx(0.0, abs=1e-12)


def test_quaternion_yaw_inverts_the_quaternion_whatever_the_roll_and_pitch() -> None:
    rng = np.random.default_rng(5)
    yaw = rng.uniform(-math.pi, math.pi, 200)
    roll, pitch = rng.uniform(-0.5, 0.5, (2, 200))
    q = quaternion_xyzw(roll, pitch, yaw)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(wrap_pi(quaternion_yaw_rad(*q.T) - yaw), 0.0, atol=1e-12)
    # the same rotation through an independent path: Rz(yaw) Ry(pitch) Rx(roll) applied to the body x axis
    heading = np.arctan2(np.sin(yaw) * np.cos(pitch), np.cos(yaw) * np.cos(pitch))
    np.testing.assert_allclose(wrap_pi(quaternion_yaw_rad(*q.T) - heading), 0.0, atol=1e-12)
