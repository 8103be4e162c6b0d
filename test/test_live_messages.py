"""The messages only the simulator node publishes (tf_static, gnss/vel_cov) and frame prefixes, without ROS."""

from __future__ import annotations

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.twin.live import LiveTwin


def test_static_transforms_place_the_antenna_above_base_link_and_the_imu_on_it() -> None:
    msg = messages.static_transforms(5, 1.5, "boat1/")
    by_child = {t.child_frame_id: t for t in msg.transforms}
    assert set(by_child) == {"boat1/gnss_link", "boat1/imu_link"}
    for t in msg.transforms:
        assert t.header.frame_id == "boat1/base_link" and t.header.stamp.nanosec == 5
        assert (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w) == (
            0.0, 0.0, 0.0, 1.0)
    gnss = by_child["boat1/gnss_link"].transform.translation
    assert (gnss.x, gnss.y, gnss.z) == (0.0, 0.0, 1.5)
    assert by_child["boat1/imu_link"].transform.translation.z == 0.0
    decoded = messages.deserialize(messages.serialize(msg, messages.LIVE_TOPICS["tf_static"]),
                                   messages.LIVE_TOPICS["tf_static"])
    assert decoded.transforms[0].child_frame_id == "boat1/gnss_link"


def test_a_frame_prefix_reaches_every_header_and_child_frame_of_a_tick() -> None:
    tick = LiveTwin(TwinConfig(), noise=False).tick()
    out = messages.restamped(tick, 42, "boat2/")
    frames = set()
    for _topic, stamp_ns, msg in out:
        assert stamp_ns == 42
        if hasattr(msg, "header"):
            frames.add(msg.header.frame_id)
            frames.add(getattr(msg, "child_frame_id", "boat2/"))
        for t in getattr(msg, "transforms", []):
            frames |= {t.header.frame_id, t.child_frame_id}
    assert frames and all(f.startswith("boat2/") for f in frames), frames
    assert "boat2/base_link" in frames and "boat2/map" in frames
    unprefixed = {msg.header.frame_id for _t, _s, msg in messages.restamped(tick, 42) if hasattr(msg, "header")}
    assert not any("/" in f for f in unprefixed)


def test_the_covariance_velocity_is_gnss_vel_with_the_model_variances() -> None:
    vel = messages.twist_stamped(messages.header(7, "gnss_link"), [1.0, -2.0, 0.0])
    stdev = TwinConfig().gnss.velocity_stdev_mps
    msg = messages.velocity_with_covariance(vel, "map", [stdev**2] * 3)
    assert msg.header.frame_id == "map" and msg.header.stamp == vel.header.stamp
    assert (msg.twist.twist.linear.x, msg.twist.twist.linear.y) == (1.0, -2.0)
    cov = msg.twist.covariance.reshape(6, 6)
    np.testing.assert_array_equal(np.diag(cov), [stdev**2] * 3 + [messages.UNMEASURED_VARIANCE] * 3)
    assert np.count_nonzero(cov - np.diag(np.diag(cov))) == 0
    assert stdev**2 == pytest.approx(0.0025)
