"""bag_player → shadow on the real rclpy: a recording with a hidden water current, played at 10x with /clock; the
shadow node (use_sim_time) follows it, names the current on /diagnostics, takes it into its predictions and
saves the twin."""

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

CURRENT = (0.35, -0.2)
"""The hidden current, east and north, m/s."""


def _bag(path: Path) -> Path:
    base = TwinConfig()
    true = replace(base, environment=Environment(current_east_mps=CURRENT[0], current_north_mps=CURRENT[1]))
    run = run_sea_trial(true, scenario("zigzag", base.vessel, np.random.default_rng(2), 200.0), 2)
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
        with rosnodes.nodes(("shadow", {"use_sim_time": True, "twin_path": str(twin_path)}),
                            ("bag_player", {"trial": str(bag), "rate": 10.0}), log_dir=tmp_path) as (shadow, player):
            assert probe.spin_until(lambda: player.process.poll() is not None, rosnodes.START_TIMEOUT_S + 40.0), \
                player.stderr
            probe.spin_for(2.0)
            client = probe.node.create_client(Trigger, "/shadow/save")
            assert client.wait_for_service(timeout_sec=10.0)
            future = client.call_async(Trigger.Request())
            assert probe.spin_until(future.done, 20.0)
            assert future.result().success, future.result().message
            shadow_log = shadow.stderr
        assert player.wait(1.0) == 0, player.stderr
    assert "played to its end" in player.stderr
    assert "synchronised at" in shadow_log and "rolling diagnosis" in shadow_log, shadow_log
    named = [d.status[0] for d in diagnostics if d.status and d.status[0].name == "boat_twin: shadow twin"
             and "water_current" in d.status[0].message]
    assert named, shadow_log
    model = json.loads({kv.key: kv.value for kv in named[-1].values}["model"])
    cause = model["diagnosis"]["causes"][0]
    assert abs(cause["parameters"]["east_mps"] - CURRENT[0]) < 0.1
    assert abs(cause["parameters"]["north_mps"] - CURRENT[1]) < 0.1
    before = [r for t, r in ratios if 60.0 < t < 130.0]  # the first diagnosis runs at 130 s
    after = [r for t, r in ratios if t > 175.0]  # innovations all made with the current taken in
    assert before and after and np.nanmax(after) < 1.2 and np.mean(before) > 1.15 * np.mean(after), (before[-3:], after[-3:])
    saved = load_config(twin_path).environment
    assert abs(saved.current_east_mps - CURRENT[0]) < 0.1 and abs(saved.current_north_mps - CURRENT[1]) < 0.1
