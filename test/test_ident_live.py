"""The live identifier (what the identifier node wraps) agrees with replaying the same trial into the core;
``identify TRIAL`` end to end, closing the loop by re-simulating the trial with the identified model."""

import math

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.ident.live import LiveIdentifier
from boat_twin.ident.online import OnlineThrustSpeedIdentifier
from boat_twin.ident.pipeline import identify_arrays, trial_samples
from boat_twin.ident.resimulate import resimulate
from boat_twin.io import messages
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import load_params
from boat_twin.vessel.scenarios import make_scenario, thrust_steps

NOISE_MPS = TwinConfig().gnss.velocity_stdev_mps  # GNSS velocity noise per ENU axis, 0.05 m/s


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
            live.on_velocity(stamp_ns, msg.twist.linear.x, msg.twist.linear.y)
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
    assert main(["identify", str(bag), "--out", str(tmp_path / "report")]) == 0  # one run: text out, JSON saved
    text = capsys.readouterr().out
    result = json.loads((tmp_path / "report" / "identify.json").read_text())
    resim = result["resimulation"]
    assert resim["speed_nrmse"] == pytest.approx(resim["speed_rmse_mps"] / resim["mean_speed_mps"])
    assert resim["speed_rmse_mps"] > 0.95 * NOISE_MPS  # measured, not simulated, speed: the noise stays in
    assert resim["effective_mass_kg"] == pytest.approx(result["output_error"]["selected"]["mass_kg"])
    assert resim["mass_source"] == "identified"
    assert resim["duration_s"] > 900.0 and resim["samples"] > 9000
    assert (tmp_path / "report" / "resimulation.png").stat().st_size > 0
    assert len(result["steady_points"]) >= 9
    assert result["dynamic"]["mass_kg"] == pytest.approx(TwinConfig().vessel.mass_kg * 1.05, rel=0.05)
    for point in result["steady_points"]:
        truth = float(TwinConfig().vessel.resistance.force_N(point["speed_mps"]))
        assert point["thrust_N"] == pytest.approx(truth, rel=0.02)
    assert load_params(tmp_path / "report" / "model.yaml").resistance.to_dict() == result["model"]["resistance"]
    assert main(["identify", str(bag), "--topic", "gnss_vel=/nowhere"]) == 2
    assert "not in the bag" in capsys.readouterr().err
    assert f"speed RMSE {resim['speed_rmse_mps']:.3f} m/s = {resim['speed_nrmse']:.1%} of the mean speed" in text


LEVELS_N = (150, 300, 420, 455, 480, 530, 700, 900, 1150, 1000, 800, 600, 490, 445, 350, 200)
"""Thrust steps up and down through the hump of Table 1 (420-530 N): steady points cover the whole curve."""


@pytest.fixture(scope="module")
def stepped_trial(tmp_path_factory):
    """A 31-minute thrust-steps trial of the simulator, recorded (commands and GNSS) and read back."""
    config = TwinConfig()
    sea_trial = run_sea_trial(config, thrust_steps(config.vessel, LEVELS_N), seed=5)
    bag = tmp_path_factory.mktemp("resim") / "steps"
    write_bag(bag, (m for m in trial_messages(sea_trial, truth=False) if not m[0].startswith("imu/")))
    trial = read_trial(bag)
    return trial, identify_arrays(*trial_samples(trial))["model"]


def test_resimulation_error_is_the_gnss_noise_plus_a_small_model_error(stepped_trial) -> None:
    """The bound, from the GNSS velocity noise σ = 0.05 m/s per axis (along the track: the speed noise).

    Even the true model re-simulates with RMSE ≈ σ: checked within 5 % (18 600 samples estimate an RMS to
    0.5 %; the rest is the 0.1 s GNSS latency at steps and the noise at rest). The identified model adds its own
    error e (its Fc within 2 % RMS, divided by the slope dFc/dv: largest on the flat hump); we require
    e ≤ √3·σ, i.e. RMSE = √(σ² + e²) ≤ 2σ = 0.10 m/s. The noise cannot be beaten: RMSE ≥ 0.95·σ.
    """
    trial, model = stepped_trial
    config = TwinConfig()
    true_model = {"resistance": config.vessel.resistance.to_dict(),
                  "effective_mass_kg": config.vessel.mass_kg * (1.0 + config.vessel.surge_added_mass_ratio)}
    truth = resimulate(trial, true_model).to_dict()
    assert truth["speed_rmse_mps"] == pytest.approx(NOISE_MPS, rel=0.05)
    assert truth["speed_noise_mps"] == pytest.approx(NOISE_MPS, rel=0.1)  # the estimate from the data itself
    identified = resimulate(trial, model).to_dict()
    assert 0.95 * NOISE_MPS < identified["speed_rmse_mps"] < 2.0 * NOISE_MPS
    assert identified["speed_nrmse"] < 0.025 and abs(identified["speed_bias_mps"]) < NOISE_MPS
    assert identified["mass_source"] == "identified" and identified["initial_speed_mps"] < 2.0 * NOISE_MPS


def test_resimulation_error_grows_for_a_wrong_model(stepped_trial) -> None:
    trial, model = stepped_trial
    reference = resimulate(trial, model).to_dict()["speed_rmse_mps"]
    draggy = {**model, "resistance": {**model["resistance"],
                                      "force_N": [1.1 * f for f in model["resistance"]["force_N"]]}}
    assert resimulate(trial, draggy).to_dict()["speed_rmse_mps"] > 3.0 * reference  # steady speeds all off
    heavy = {**model, "effective_mass_kg": 1.3 * model["effective_mass_kg"]}
    assert resimulate(trial, heavy).to_dict()["speed_rmse_mps"] > 1.1 * reference  # transients lag
    no_mass = {"resistance": model["resistance"]}
    assert resimulate(trial, no_mass).mass_source == "the base boat's (none identified)"


def test_a_boat_files_commands_become_its_surge_thrust() -> None:
    """A single-screw ship's rev/s and rudder angle through its propeller and rudder (the propulsion section):
    the identifier sees the thrust the twin's own map gives, as an identifier fed that thrust in N does."""
    from pathlib import Path

    from boat_twin.config import load_config
    from boat_twin.vessel.propulsion import surge_thrust_N

    vessel = load_config(Path(__file__).resolve().parents[1] / "config" / "boats" / "single_screw_rudder.yaml").vessel
    ship, plain = LiveIdentifier(order=2, vessel=vessel), LiveIdentifier(order=2)
    for k in range(400):
        command, rudder, speed = 8.0 + 4.0 * (k // 100), 0.2 * ((k // 50) % 2), 0.5 + k / 400
        ship.set_command(0, command)
        ship.set_command(2, rudder)
        plain.set_command(0, float(surge_thrust_N(vessel, np.array([command, 0.0]), np.array([rudder, 0.0]), speed)))
        plain.set_command(1, 0.0)
        ship.on_velocity(k * 100_000_000, speed, 0.0)
        plain.on_velocity(k * 100_000_000, speed, 0.0)
    assert ship.core.snapshot() == plain.core.snapshot()
    assert ship.status()["held_commands"][1] == 0.0  # one screw: the second slot holds no thrust
