"""The nodes' shared helpers (boat_twin/nodes/conventions.py), without a running graph."""

from __future__ import annotations

import pytest

from boat_twin.errors import InputError
from boat_twin.nodes import conventions


def test_a_bad_topics_parameter_is_refused_naming_the_parameter_not_the_cli_option():
    assert conventions.topic_remap("gnss_vel=/gps/vel, imu=/imu/data,") == {"gnss_vel": "/gps/vel", "imu": "/imu/data"}
    with pytest.raises(InputError, match=r"^parameter topics: 'gnss_vel': expected ROLE=TOPIC") as bad:
        conventions.topic_remap("gnss_vel")
    assert "--topic" not in str(bad.value)
    with pytest.raises(InputError, match=r"^parameter topics: 'speed=/v': unknown role 'speed'"):
        conventions.topic_remap("speed=/v")


def test_ros_time_and_message_class():
    stamp = conventions.ros_time(3_000_000_007)
    assert (stamp.sec, stamp.nanosec) == (3, 7)
    assert conventions.message_class("std_msgs/msg/Float64").__name__ == "Float64"
    assert conventions.message_class("no_such_pkg/msg/Thing") is None
