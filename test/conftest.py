"""Suite-wide test configuration: the `ros_nodes` and `slow` markers.

Tests of a module that starts ROS 2 nodes (it imports ``test/rosnodes.py``) are marked ``ros_nodes``. `make test`
runs the rest on every core (pytest-xdist) and these alone afterwards: a live recorder that shares the cores with
other tests lags the simulated clock and records commands late (test/test_ros_live.py, REAL_TIME_FACTOR).
"""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "ros_nodes: starts ROS 2 node processes (run apart from the rest)")
    config.addinivalue_line("markers", "slow: longer than ~20 s (several fits or long simulations)")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        module = getattr(item, "module", None)
        if module is not None and "rosnodes" in vars(module):
            item.add_marker(pytest.mark.ros_nodes)
