"""bag_player → shadow on the real rclpy: a recording with a hidden water current, played at 5x with /clock; the
shadow node (use_sim_time) follows it to the end, names the current on /diagnostics with its size, and saves the
twin with the current in it."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from boat_twin.config import TwinConfig, load_config
from boat_twin.diagnose.hidden import scenario
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.environment import Environment

CURRENT = (0.4, -0.25)
"""The hidden current, east and north, m/s."""


def _bag(path: Path) -> Path:
    base = TwinConfig()
    true = replace(base, environment=Environment(current_east_mps=CURRENT[0], current_north_mps=CURRENT[1]))
    run = run_sea_trial(true, scenario("zigzag", base.vessel, np.random.default_rng(2), 165.0), 2)
    write_bag(path, trial_messages(run, truth=False))
    return path


def test_bag_player_to_shadow_names_a_hidden_current_and_follows_it(tmp_path: Path) -> None:
    bag = _bag(tmp_path / "current.mcap")
    twin_path = tmp_path / "twin.yaml"
    diagnostics: list[DiagnosticArray] = []
    ratios: list[tuple[float, float]] = []
    with rosnodes.probe("shadow_probe") as probe:
        probe.node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, QoSProfile(depth=50))
        probe.node.create_subscription(Float64MultiArray, "shadow/innovations",
                                       lambda m: ratios.append((m.data[0], m.data[3])), QoSProfile(depth=1000))
        with rosnodes.nodes(("shadow", {"use_sim_time": True, "twin_path": str(twin_path), "reorder_s": 1.0}),
                            ("bag_player", {"trial": str(bag), "rate": 5.0}), log_dir=tmp_path) as (shadow, player):
            assert probe.spin_until(lambda: player.process.poll() is not None, rosnodes.START_TIMEOUT_S + 40.0), \
                player.stderr
            # the diagnosis of the first full window (at 130 s) runs in the node's worker thread: wait for it
            # (2-3 s of one core alone; far longer on a loaded machine, hence the generous deadline)
            probe.spin_until(lambda: any("water_current" in d.status[0].message for d in diagnostics if d.status),
                             120.0)
            client = probe.node.create_client(Trigger, "/shadow/save")
            assert client.wait_for_service(timeout_sec=10.0)
            future = client.call_async(Trigger.Request())
            assert probe.spin_until(future.done, 20.0)
            assert future.result().success, future.result().message
            shadow_log = shadow.stderr
        assert player.wait(1.0) == 0, player.stderr
    assert "played to its end" in player.stderr
    assert "synchronised at" in shadow_log and "rolling diagnosis" in shadow_log, shadow_log
    named = [d.status[0] for d in diagnostics if d.status and d.status[0].name == "shadow: shadow twin"
             and "water_current" in d.status[0].message]
    assert named, shadow_log
    model = json.loads({kv.key: kv.value for kv in named[-1].values}["model"])
    cause = model["diagnosis"]["causes"][0]
    assert abs(cause["parameters"]["east_mps"] - CURRENT[0]) < 0.1
    assert abs(cause["parameters"]["north_mps"] - CURRENT[1]) < 0.1
    assert ratios and ratios[-1][0] > 160.0 and ratios[-1][1] < 2.0  # in step with the boat to the end
    saved = load_config(twin_path).environment
    assert abs(saved.current_east_mps - CURRENT[0]) < 0.1 and abs(saved.current_north_mps - CURRENT[1]) < 0.1
