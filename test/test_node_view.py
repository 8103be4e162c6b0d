"""The shadow node on the real rclpy, following a short recording played by bag_player: its model and innovations
as one std_msgs/Float64 topic per quantity, read by name, and (``foxglove`` parameter) its live Foxglove view
decoded by a real client of the protocol."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rosnodes
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64

from boat_twin.config import TwinConfig
from boat_twin.diagnose.hidden import scenario
from boat_twin.io.bags import write_bag
from boat_twin.nodes.shadow import INNOVATION_TOPICS, MODEL_TOPICS
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages

pytest.importorskip("foxglove", reason="the view extra (foxglove-sdk) is not installed")
pytest.importorskip("websockets.sync.client")
pytest.importorskip("google.protobuf.descriptor_pb2")
from foxglove_client import collect, url_in  # noqa: E402 - the skips first

DURATION_S = 90.0
"""The recording, s: 18 s of wall time at rate 5."""


def test_shadow_publishes_typed_quantities_and_serves_its_foxglove_view(tmp_path: Path) -> None:
    base = TwinConfig()
    bag = tmp_path / "trial.mcap"
    write_bag(bag, trial_messages(run_sea_trial(base, scenario("zigzag", base.vessel, np.random.default_rng(3),
                                                                       DURATION_S), 3), truth=False))
    received: dict[str, list[float]] = {topic: [] for topic in (*MODEL_TOPICS, *INNOVATION_TOPICS)}
    seen: dict[str, Any] = {}
    with rosnodes.probe("view_probe") as probe:
        for topic, values in received.items():
            probe.node.create_subscription(Float64, topic, lambda m, v=values: v.append(m.data), QoSProfile(depth=100))
        params = {"use_sim_time": True, "foxglove": "127.0.0.1:0", "diagnose": False, "adapt": False,
                  "reorder_s": 1.0}
        with rosnodes.nodes(("shadow", params), log_dir=tmp_path) as (shadow,):
            assert probe.spin_until(lambda: url_in(shadow.stderr) is not None, rosnodes.START_TIMEOUT_S), \
                shadow.stderr
            url = url_in(shadow.stderr)
            assert url is not None and url.startswith("ws://127.0.0.1:")

            def listen() -> None:
                seen["info"], seen["received"] = collect(
                    url, ("/boat/fix", "/twin/fix", "/twin/innovations/speed_mps"), time.monotonic() + 120.0, 10)

            client = threading.Thread(target=listen)
            client.start()
            with rosnodes.nodes(("bag_player", {"trial": str(bag), "rate": 5.0}), log_dir=tmp_path) as (player,):
                assert probe.spin_until(lambda: player.process.poll() is not None,
                                        rosnodes.START_TIMEOUT_S + DURATION_S), player.stderr
                probe.spin_until(lambda: not client.is_alive(), 60.0)
            client.join(timeout=60.0)
            log = shadow.stderr
    assert not client.is_alive()
    assert "synchronised at" in log, log
    for topic, values in received.items():
        assert values, f"nothing on {topic}"
    mass = received["shadow/model/mass_kg"]
    assert mass[-1] == pytest.approx(base.vessel.mass_kg)  # adapt off: the configured boat
    low, high = received["shadow/model/mass_low_kg"][-1], received["shadow/model/mass_high_kg"][-1]
    assert math.isnan(low) or low <= mass[-1] <= high
    assert min(received["shadow/innovation/stdev_mps"]) > 0.0
    for topic in ("/boat/fix", "/twin/fix", "/twin/innovations/speed_mps"):
        assert len(seen["received"][topic]) >= 10, {t: len(v) for t, v in seen["received"].items()}
    fix = seen["received"]["/twin/fix"][-1]
    assert abs(fix["latitude"] - base.gnss.origin_lat_deg) < 0.05
    assert abs(fix["longitude"] - base.gnss.origin_lon_deg) < 0.05


def test_the_simulator_serves_its_boat_to_a_foxglove_client(tmp_path: Path) -> None:
    params = {"foxglove": "127.0.0.1:0", "publish_clock": True, "real_time_factor": 5.0}
    with rosnodes.nodes(("simulator", params), log_dir=tmp_path) as (simulator,):
        deadline = time.monotonic() + rosnodes.START_TIMEOUT_S
        while url_in(simulator.stderr) is None and simulator.process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
        url = url_in(simulator.stderr)
        assert url is not None and url.startswith("ws://127.0.0.1:"), simulator.stderr
        _, received = collect(url, ("/boat/fix", "/twin/fix", "/tf", "/scene"), time.monotonic() + 120.0, 5)
    assert min(len(items) for items in received.values()) >= 5, {t: len(v) for t, v in received.items()}
    origin = TwinConfig().gnss
    truth, measured = received["/twin/fix"][-1], received["/boat/fix"][-1]
    for fix in (truth, measured):  # the boat at rest at the origin: the truth there, the receiver within metres
        assert abs(fix["latitude"] - origin.origin_lat_deg) < 1e-4
        assert abs(fix["longitude"] - origin.origin_lon_deg) < 1e-4
    assert received["/tf"][-1]["transforms"][0]["child_frame_id"] == "twin"
    assert received["/scene"][-1]["entities"][0]["id"] == "twin"
