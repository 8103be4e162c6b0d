"""The live twin (what the simulator node wraps) produces the batch trial's messages, tick by tick."""

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.io import messages
from boat_twin.sensors.gnss import GnssConfig
from boat_twin.sensors.um7 import Um7Config
from boat_twin.twin.live import LiveTwin
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import make_scenario


@pytest.mark.parametrize("config", [
    TwinConfig(),
    TwinConfig(gnss=GnssConfig(rate_hz=5.0, latency_s=0.23),
               um7=Um7Config(rate_hz=2.0, gyro_bias_radps=(0.01, 0.0, -0.02)),
               environment=Environment(current_east_mps=0.3, current_north_mps=-0.2)),
    TwinConfig(vessel=VesselParams(command_delay_s=0.3, thrust_time_constant_s=1.5), um7=Um7Config(yaw_offset_rad=0.1)),
], ids=["defaults", "slow-sensors-latency-bias-current", "command-delay-thrust-lag-yaw-offset"])
def test_live_ticks_reproduce_the_batch_trial_without_noise(config: TwinConfig) -> None:
    scenario = make_scenario("random", config.vessel, np.random.default_rng(4), duration_s=30.0)
    batch = run_sea_trial(config, scenario, seed=4, noise=False)
    sensor_topics = {"gnss/fix", "gnss/vel", "imu/data", "imu/mag", "imu/rpy", "imu/temperature", "odom/truth", "tf"}
    expected = [(t, s, messages.serialize(m, messages.TOPICS[t])) for t, s, m in trial_messages(batch)
                if t in sensor_topics]
    live = LiveTwin(config, seed=4, noise=False)
    got = []
    for row in batch.record.commands[:, 0, :]:
        for index, value in enumerate(row):
            live.set_command(index, float(value))
        got += [(t, s, messages.serialize(m, messages.TOPICS[t])) for t, s, m in live.tick() if t in sensor_topics]
    got = [g for g in got if g[1] <= expected[-1][1]]
    assert sorted(got) == sorted(expected)


def test_live_twin_holds_commands_and_ignores_non_finite_values() -> None:
    live = LiveTwin(TwinConfig(), noise=False, epoch_s=1.7e9)
    live.set_command(0, 400.0)
    live.set_command(1, 400.0)
    live.set_command(0, float("nan"))
    for _ in range(300):
        out = live.tick()
    assert live.state[0, 3] > 3.0
    thrust = [m.data for t, _, m in out if t == "thrusters/left/thrust"]
    assert thrust == [400.0]
    now_ns = (1.7e9 + 299 / 10.0) * 1e9
    assert {t for t, _, _ in out} >= {"gnss/fix", "gnss/vel", "imu/data", "odom/truth", "thrusters/left/thrust"}
    assert all(abs(s - now_ns) < 1e3 for _, s, _ in out)  # float64 seconds near 1.7e9 resolve to ~0.2 µs
