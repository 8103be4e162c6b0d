"""The live identifier (what the identifier node wraps) agrees with replaying the same trial into the core."""

import math

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.ident.live import LiveIdentifier
from boat_twin.ident.online import OnlineThrustSpeedIdentifier
from boat_twin.io import messages
from boat_twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import load_params
from boat_twin.vessel.scenarios import make_scenario


def test_live_identifier_matches_direct_replay_and_saves_a_loadable_model(tmp_path) -> None:
    config = TwinConfig()
    trial = run_sea_trial(config, make_scenario("thrust-steps", config.vessel, np.random.default_rng(0)), seed=0)
    live = LiveIdentifier(order=3)
    direct = OnlineThrustSpeedIdentifier(3)
    held = [math.nan, math.nan, 0.0, 0.0]
    for topic, stamp_ns, msg in trial_messages(trial, truth=False):
        if topic in messages.COMMAND_TOPICS:
            index = messages.COMMAND_TOPICS.index(topic)
            live.set_command(index, msg.data)
            held[index] = msg.data
        elif topic == messages.TOPIC_GNSS_VEL:
            live.on_velocity(stamp_ns * 1e-9, msg.twist.linear.x, msg.twist.linear.y)
            thrust = held[0] * math.cos(held[2]) + held[1] * math.cos(held[3])
            direct.update(stamp_ns * 1e-9, thrust, math.hypot(msg.twist.linear.x, msg.twist.linear.y))
    labels, values = live.coefficients()
    assert labels[0] == "c0_N_per_mps0" and labels[-1] == "effective_mass_kg"
    np.testing.assert_allclose(values[:-1], direct.resistance()[0])
    assert live.save(tmp_path / "model.yaml")
    params = load_params(tmp_path / "model.yaml")
    u = np.array([2.0, 5.0, 8.0])
    truth = config.vessel.resistance.force_N(u)
    assert params.resistance.force_N(u) == pytest.approx(truth, rel=0.15)
    live.reset()
    assert live.model() is None and not live.save(tmp_path / "again.yaml")


def test_identify_cli_on_a_simulated_bag(tmp_path, capsys) -> None:
    import json

    from boat_twin.cli import main

    bag = tmp_path / "steps"
    assert main(["simulate", "thrust-steps", "--seed", "3", "--out", str(bag)]) == 0
    capsys.readouterr()
    assert main(["identify", str(bag), "--json", "--out", str(tmp_path / "report")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert len(result["steady_points"]) >= 9
    assert result["dynamic"]["mass_kg"] == pytest.approx(TwinConfig().vessel.mass_kg * 1.05, rel=0.05)
    for point in result["steady_points"]:
        truth = float(TwinConfig().vessel.resistance.force_N(point["speed_mps"]))
        assert point["thrust_N"] == pytest.approx(truth, rel=0.02)
    assert load_params(tmp_path / "report" / "model.yaml").resistance.order == result["selected_order"]
    assert main(["identify", str(bag), "--topic", "gnss_vel=/nowhere"]) == 2
    assert "not in the bag" in capsys.readouterr().err
