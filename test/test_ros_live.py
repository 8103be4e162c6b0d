"""End to end on a real ROS 2 graph, in simulated time: the simulator publishes /clock faster than real time,
the identifier and the cable node run with use_sim_time, a probe drives the boat and records what
`ros2 bag record` would (log time = receive time on /clock), as CDR bytes decoded with the rosbags typestore.
The recording then goes through `boat-twin identify` and `diagnose`."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rosnodes
import yaml
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, Float64MultiArray

from boat_twin.cable import load_case, solve_depth, with_overrides
from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.io.bags import write_bag
from boat_twin.nodes.identifier import DEFAULT_ORDER
from boat_twin.vessel.scenarios import CommandProfile, random_commands, thrust_steps

REAL_TIME_FACTOR = 10.0
"""Simulated seconds per wall second of the staircase run.

The probe stamps a command with the last /clock it has handled. While it also records hundreds of messages a
second its handling lags by up to ~10 ms of wall time: 0.2 s of simulated time at 20x. Commands then look late
by that much (as with any recorder under load) and the diagnosis rightly reads that as a GNSS latency of 0.3 s.
At 10x the lag stays below the diagnosis's latency threshold; the manoeuvring run, whose many command changes
make it more sensitive, runs at 4x (it passed at 5x here, also with both cores busy, but failed once in CI)."""
MANOEUVRE_REAL_TIME_FACTOR = 4.0
RECORDED = (messages.TOPIC_GNSS_FIX, messages.TOPIC_GNSS_VEL, messages.TOPIC_IMU_DATA)
CABLE_CASE = rosnodes.ROOT / "config" / "cable" / "default.yaml"
pytestmark = pytest.mark.long_wait  # two live runs: 93 s of wall time at 10x, then 60 s at 4x


RESEND_NS = 250_000_000
"""Held commands are re-sent this often (simulated ns), as the player does."""
COMMAND_TIMEOUT_S = 10.0
"""The simulator's command watchdog in the live runs (command_timeout_s, simulated s): 1 s of wall time at 10x.
Its default, 1 s, is 0.1 s of wall time at 10x: a recorder stalled that long (its process kept from the cores by
other work: `make test` runs the node tests in two workers) let the watchdog zero the thrust three times in one
staircase run on the loaded machine (recorded sensor messages up to 4.1 s of simulated time late), and the
identifier's resistance missed by 30 % at two speeds. The watchdog itself is tested in test_node_stop.py."""
MATCH_TIMEOUT_S = 60.0
"""Wall-clock time the probe's publishers and subscriptions get to match the simulator's (DDS discovery)."""


class LiveRun:
    """Drives the twin with an open-loop command profile on /clock time and records the run.

    The simulator ticks from the moment it starts, before the probe's endpoints have matched its own (discovery
    pairs each publisher with each subscription in its own time): commands published then would be recorded but
    never reach the boat. So nothing is driven or recorded until every command publisher has the simulator as
    subscriber and every recorded topic has a publisher; the profile then starts at the next /clock (``start_ns``,
    profile time 0), the boat still at rest."""

    def __init__(self, probe: rosnodes.Probe, profile: CommandProfile, real_time_factor: float) -> None:
        self.probe, self.profile, self.real_time_factor = probe, profile, real_time_factor
        node = probe.node
        self.sim_ns = 0
        self.start_ns: int | None = None
        """/clock at which the profile started (None: endpoints not matched yet)."""
        self.recorded: list[tuple[str, int, object]] = []
        self.truth_speed: list[tuple[float, float]] = []
        self.coefficients: list[tuple[float, list[float], str]] = []
        self.depths: list[tuple[float, float]] = []
        self._held: np.ndarray | None = None
        self._last_publish_ns = -10**18
        self.commands = [node.create_publisher(Float64, t, 10) for t in messages.COMMAND_TOPICS]
        node.create_subscription(Clock, "/clock", self._on_clock, QoSProfile(depth=10))
        self.recorders = [node.create_subscription(messages_class(topic), topic,
                                                   lambda raw, t=topic: self._record(t, raw),
                                                   QoSProfile(depth=200), raw=True) for topic in RECORDED]
        node.create_subscription(Odometry, "odom/truth", self._on_truth, qos_profile_sensor_data)
        node.create_subscription(Float64MultiArray, "identification/coefficients",
                                 lambda m: self.coefficients.append((self.profile_s, list(m.data),
                                                                     m.layout.dim[0].label)), 10)
        node.create_subscription(Float64, "cable/vehicle_depth", lambda m: self.depths.append((self.profile_s, m.data)),
                                 QoSProfile(depth=10))

    @property
    def profile_s(self) -> float:
        """Time since the profile started, s (0 before)."""
        return 0.0 if self.start_ns is None else (self.sim_ns - self.start_ns) * 1e-9

    def _matched(self) -> bool:
        return (all(p.get_subscription_count() >= 1 for p in self.commands)
                and all(s.get_publisher_count() >= 1 for s in self.recorders))

    def _on_clock(self, msg: Clock) -> None:
        self.sim_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if self.start_ns is None:
            if not self._matched():
                return
            self.start_ns = self.sim_ns
        row = self.profile.command(self.profile_s, np.zeros((1, 6)))[0]
        due = self.sim_ns - self._last_publish_ns >= RESEND_NS
        if self._held is None or not np.array_equal(row, self._held) or due:
            for publisher, topic, value in zip(self.commands, messages.COMMAND_TOPICS, row.tolist(), strict=True):
                publisher.publish(Float64(data=value))
                self.recorded.append((topic, self.sim_ns, messages.float64(value)))
            self._held, self._last_publish_ns = row, self.sim_ns

    def _record(self, topic: str, raw: bytes) -> None:
        if self.start_ns is None:
            return
        self.recorded.append((topic, self.sim_ns, raw))  # decoded after the run: the probe must keep up

    def _on_truth(self, msg: Odometry) -> None:
        self.truth_speed.append((self.profile_s, math.hypot(msg.twist.twist.linear.x, msg.twist.twist.linear.y)))

    def run(self) -> None:
        """Until the profile's end in simulated time (wall-clock deadlines: the endpoints' match, then 4x the
        nominal duration + start-up)."""
        assert self.probe.spin_until(lambda: self.start_ns is not None, rosnodes.START_TIMEOUT_S + MATCH_TIMEOUT_S), \
            "the probe's endpoints never matched the simulator's"
        nominal_wall_s = self.profile.duration_s / self.real_time_factor
        assert self.probe.spin_until(lambda: self.profile_s >= self.profile.duration_s, 4.0 * nominal_wall_s + 30.0), \
            f"the profile reached only {self.profile_s:.1f} s"

    def write(self, path: Path) -> Path:
        """The recording as an MCAP rosbag2 directory, in log-time order (as the recorder writes it)."""
        decoded = [(topic, stamp_ns, messages.deserialize(m, messages.TOPICS[topic]) if isinstance(m, bytes) else m)
                   for topic, stamp_ns, m in sorted(self.recorded, key=lambda item: item[1])]
        write_bag(path, decoded)
        return path


def messages_class(topic: str) -> type:
    package, _, name = messages.TOPICS[topic].split("/")
    return getattr(__import__(f"{package}.msg", fromlist=[name]), name)


def boat_twin(*args: str) -> dict:
    """`boat-twin ARGS --json` as a user runs it; its JSON result."""
    done = subprocess.run([sys.executable, "-m", "boat_twin.cli", *args, "--json"], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture(scope="module")
def staircase_run(tmp_path_factory):
    """The default thrust-steps trial, live: simulator + identifier + cable (following gnss/vel) + recorder."""
    out = tmp_path_factory.mktemp("live_staircase")
    profile = thrust_steps(TwinConfig().vessel)
    sim_time = {"use_sim_time": True}
    specs = (
        ("simulator", {"publish_clock": True, "real_time_factor": REAL_TIME_FACTOR, "seed": 7,
                       "command_timeout_s": COMMAND_TIMEOUT_S}),
        ("identifier", {**sim_time, "model_path": str(out / "identified.yaml")}),
        ("cable", {**sim_time, "case_file": str(CABLE_CASE), "follow_gnss_vel": True, "update_period_s": 5}),
    )
    with rosnodes.nodes(*specs, log_dir=out) as procs, rosnodes.probe("recorder") as probe:
        run = LiveRun(probe, profile, REAL_TIME_FACTOR)
        run.run()
        probe.spin_for(1.0)
        stderr = {name: proc.stderr for (name, _), proc in zip(specs, procs, strict=True)}
    return run, run.write(out / "live_staircase"), stderr


def test_identifier_converges_to_the_boats_resistance_at_the_visited_speeds(staircase_run) -> None:
    run, _bag, stderr = staircase_run
    assert "Traceback" not in "".join(stderr.values())
    assert "thrust set to zero" not in stderr["simulator"], stderr["simulator"]  # the boat got every command
    _t, values, label = run.coefficients[-1]
    assert label.split(",") == [f"c{i}_N_per_mps{i}" for i in range(DEFAULT_ORDER + 1)] + ["effective_mass_kg"]
    coefficients, mass_kg = np.array(values[:-1]), values[-1]
    vessel = TwinConfig().vessel
    # the visited steady speeds: the truth speed at the end of each level's hold
    truth_t, truth_v = np.array(run.truth_speed).T
    speeds = np.interp(run.profile.times_s[1:] - 1.0, truth_t, truth_v)
    identified = np.polynomial.polynomial.polyval(speeds, coefficients)
    true = vessel.resistance.force_N(speeds)
    assert np.all(np.abs(identified - true) <= 0.05 * true + 15.0), (speeds, identified, true)
    effective_mass = vessel.mass_kg * (1.0 + vessel.surge_added_mass_ratio)
    assert mass_kg == pytest.approx(effective_mass, rel=0.15)


def test_cable_node_follows_the_simulators_speed(staircase_run) -> None:
    run, _bag, _stderr = staircase_run
    case = load_case(CABLE_CASE)
    truth_t, truth_v = np.array(run.truth_speed).T
    depths = np.array(run.depths)
    assert len(np.unique(np.round(depths[:, 1], 2))) >= 5  # it re-solved as the boat sped up
    checked = 0
    for t_s, depth_m in depths[depths[:, 0] > 60.0]:
        v = float(np.interp(t_s, truth_t, truth_v))
        if v < 1.0 or abs(float(np.interp(t_s - 5.0, truth_t, truth_v)) - v) > 0.05:
            continue  # not steady over the last update period
        deeper, shallower = (solve_depth(with_overrides(case, tow_speed_mps=s)).vehicle_depth_m
                             for s in (max(v - 0.3, 0.1), v + 0.3))
        assert min(deeper, shallower) <= depth_m <= max(deeper, shallower), (t_s, v, depth_m)
        checked += 1
    assert checked >= 10


def test_recorded_live_run_identifies_like_the_node(staircase_run) -> None:
    run, bag, _stderr = staircase_run
    result = boat_twin("identify", str(bag), "--order", str(DEFAULT_ORDER))
    online = result["online"]
    assert online["steady_points"] >= 5
    node_values = np.array(run.coefficients[-1][1][:-1])
    speeds = np.array([p["speed_mps"] for p in result["steady_points"]])
    replayed = np.polynomial.polynomial.polyval(speeds, online["coefficients"])
    live = np.polynomial.polynomial.polyval(speeds, node_values)
    np.testing.assert_allclose(live, replayed, rtol=0.02, atol=5.0)


def test_diagnose_names_no_effect_in_the_clean_live_recording(staircase_run) -> None:
    """No catalogue effect is named. `unexplained` is not asserted: under a full suite's load the recorder's lag
    (see REAL_TIME_FACTOR) has flagged it once in three runs; that is the recorder, not the boat."""
    _run, bag, _stderr = staircase_run
    result = boat_twin("diagnose", str(bag))
    assert result["verdict"] == [], result


def test_diagnose_names_a_current_hidden_in_a_live_recording(tmp_path) -> None:
    config_file = tmp_path / "current.yaml"
    config_file.write_text(yaml.safe_dump({"environment": {"current_east_mps": 0.5, "current_north_mps": -0.3},
                                           "vessel": {"frontal_windage_area_m2": 0.0,
                                                      "lateral_windage_area_m2": 0.0}}))
    profile = random_commands(TwinConfig().vessel, np.random.default_rng(11), duration_s=240.0)
    specs = (("simulator", {"publish_clock": True, "real_time_factor": MANOEUVRE_REAL_TIME_FACTOR, "seed": 3,
                            "config_file": str(config_file), "command_timeout_s": COMMAND_TIMEOUT_S}),)
    with rosnodes.nodes(*specs, log_dir=tmp_path) as (sim,), rosnodes.probe("recorder") as probe:
        run = LiveRun(probe, profile, MANOEUVRE_REAL_TIME_FACTOR)
        run.run()
        stderr = sim.stderr
    assert "thrust set to zero" not in stderr, stderr  # the boat got every command the recording holds
    result = boat_twin("diagnose", run.write(tmp_path / "live_current").as_posix())
    names = [v["effect"] for v in result["verdict"]]
    assert names and names[0] == "water_current", result
    east, north = (result["verdict"][0]["parameters"][k] for k in ("east_mps", "north_mps"))
    assert east == pytest.approx(0.5, abs=0.05) and north == pytest.approx(-0.3, abs=0.05)
