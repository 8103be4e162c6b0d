"""Identification of trials from boat_twin's own simulator: run_sea_trial → rosbag2 → read_trial → identify.

The truth is the simulated boat: Fc(u) = the Table 1 curve (TableResistance), surge mass with added mass m11;
GNSS velocity noise 0.05 m/s per axis at 10 Hz, 0.1 s latency. Bad input goes through ``boat_twin.cli.main``.
"""

import dataclasses
import json
import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.dynamic import identify_dynamic
from boat_twin.ident.output_error import SurgeRecord
from boat_twin.ident.pipeline import identify_arrays, model_dict, trial_samples, write_model_yaml
from boat_twin.ident.report import write_trial_report
from boat_twin.ident.steady import fit_power_series
from boat_twin.io import messages
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import VesselParams, load_params
from boat_twin.vessel.resistance import PowerSeriesResistance, resistance_from_dict
from boat_twin.vessel.scenarios import CommandProfile, thrust_steps
from boat_twin.vessel.simulate import simulate

CONFIG = TwinConfig()
TRUTH = CONFIG.vessel.resistance
MASS_KG = CONFIG.vessel.mass_kg * (1.0 + CONFIG.vessel.surge_added_mass_ratio)  # 1.3 t + 5 % surge added mass
NOISE_MPS = CONFIG.gnss.velocity_stdev_mps
LEVELS_N = (150, 300, 420, 455, 480, 530, 700, 900, 1150, 1000, 800, 600, 490, 445, 350, 200)
"""Total thrust steps up and down over the Table 1 curve, through its hump (420-530 N); each held as
``thrust_steps`` holds it (6 local surge time constants, 30-150 s, + 30 s settled), then 60 s idle (31 min)."""


def recorded(profile, seed: int) -> list:
    """Messages of ``profile`` simulated with sensor noise ``seed``: commands and GNSS, as a recording of what
    the identifier reads (no IMU or truth topics: 2.7 times fewer messages to write, the same identification)."""
    sea_trial = run_sea_trial(CONFIG, profile, seed=seed)
    return [m for m in trial_messages(sea_trial, truth=False) if not m[0].startswith("imu/")]


def record(profile, seed: int, directory) -> tuple:
    """Simulate ``profile`` with sensor noise ``seed``, write the bag, read it back: (Trial, bag path)."""
    bag = directory / f"{profile.name}-{seed}"
    write_bag(bag, recorded(profile, seed))
    return read_trial(bag), bag


def staircase(levels, holds_s) -> CommandProfile:
    """Total thrust ``levels`` (N, split equally between the outboards) held ``holds_s`` each, straight ahead."""
    times = np.concatenate([[0.0], np.cumsum(holds_s)[:-1]])
    rows = np.array([[f / 2.0, f / 2.0, 0.0, 0.0] for f in levels])
    return CommandProfile(f"steps{len(levels)}", times, rows, float(np.sum(holds_s)))


@pytest.fixture(scope="module", params=[0, pytest.param(1, marks=pytest.mark.slow),
                                        pytest.param(2, marks=pytest.mark.slow)])
def identified(request, tmp_path_factory):
    trial, _ = record(thrust_steps(CONFIG.vessel, LEVELS_N), request.param, tmp_path_factory.mktemp("bags"))
    t, f, v = trial_samples(trial)
    return t, f, v, identify_arrays(t, f, v)


def nrms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def test_steady_points_within_2_percent_of_the_true_resistance(identified) -> None:
    *_, result = identified
    moving = [p for p in result["steady_points"] if p["thrust_N"] > 0.0]
    assert len(moving) >= 12
    for p in moving:
        assert p["thrust_N"] == pytest.approx(float(TRUTH.force_N(p["speed_mps"])), rel=0.02)
        assert p["duration_s"] >= 20.0
    # at rest (the closing idle) GNSS speed over ground is |2-D noise|, mean σ·√(π/2) = 0.063 m/s, not a speed
    assert all(p["speed_mps"] < 2.0 * NOISE_MPS for p in result["steady_points"] if p["thrust_N"] == 0.0)


def test_fitted_curve_within_2_percent_rms_over_the_visited_speeds(identified) -> None:
    *_, result = identified
    speed = np.array([p["speed_mps"] for p in result["steady_points"]])
    grid = np.linspace(speed.min(), speed.max(), 400)
    fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
    assert nrms(np.polynomial.polynomial.polyval(grid, fit["coefficients"]), TRUTH.force_N(grid)) < 0.02
    assert fit["coefficients"][0] == 0.0  # Fc(0) = 0 imposed for trials


def test_mass_within_5_percent_with_a_covering_interval(identified) -> None:
    *_, result = identified
    dyn = result["dynamic"]
    assert dyn["mass_kg"] == pytest.approx(MASS_KG, rel=0.05)
    lo, hi = dyn["mass_ci95_kg"]
    assert lo < dyn["mass_kg"] < hi and (hi - lo) < 0.3 * MASS_KG
    assert dyn["two_way_fraction"] > 0.5
    oe = result["output_error"]["selected"]  # the model's mass: the output-error fit's
    assert result["model"]["effective_mass_kg"] == oe["mass_kg"] == pytest.approx(MASS_KG, rel=0.05)
    lo, hi = oe["mass_ci95_kg"]
    assert lo < MASS_KG < hi and result["output_error"]["mass_identified"]


def test_output_error_curve_within_3_percent_rms_and_beats_the_baseline(identified) -> None:
    *_, result = identified
    model = resistance_from_dict(result["model"]["resistance"])
    grid = np.linspace(0.5, max(p["speed_mps"] for p in result["steady_points"]), 200)
    assert nrms(model.force_N(grid), TRUTH.force_N(grid)) < 0.03
    assert np.all(np.diff(model.force_N(np.linspace(0.0, 12.0, 500))) >= 0.0) and model.force_N(0.0) == 0.0
    cv = {c["model"]: c["cv_rmse_mps"] for c in result["output_error"]["candidates"]}
    assert result["output_error"]["selected"]["model"] != "baseline"  # the hump is beyond a·u + b·u|u|
    assert cv[result["output_error"]["selected"]["model"]] < 0.5 * cv["baseline"]
    assert result["physical_problems"] == []


def test_result_is_strict_json(identified) -> None:
    *_, result = identified
    text = json.dumps(result, allow_nan=False, default=lambda o: o.tolist())
    assert set(json.loads(text)) >= {"output_error", "physical_problems", "steady_points", "fits", "selected_order",
                                     "dynamic", "online", "model"}


def test_online_within_1_percent_of_batch(identified) -> None:
    *_, result = identified
    agreement = result["online"]["agreement_with_batch"]
    assert agreement["curve_nrms"] < 0.01
    assert abs(agreement["mass_rel"]) < 0.01
    assert result["online"]["steady_points"] == len(result["steady_points"])


def test_a_level_that_never_settles_is_rejected_and_reported(tmp_path) -> None:
    # 445 N sits on the hump (time constant ≈ 36 s): 45 s after the step from 400 N it is still accelerating
    levels, holds = (150, 300, 400, 445, 600, 800, 1000), (60, 60, 90, 45, 60, 60, 60)
    trial, _ = record(staircase(levels, holds), 4, tmp_path)
    result = identify_arrays(*trial_samples(trial), order=2)
    rejected = [s for s in result["rejected_segments"] if round(s["thrust_N"]) == 445]
    assert len(rejected) == 1 and rejected[0]["reason"].startswith("speed never settled")
    assert 445 not in {round(p["thrust_N"]) for p in result["steady_points"]}
    assert len(result["steady_points"]) + len(result["rejected_segments"]) == len(levels)
    assert all(s["reason"] and not s["accepted"] for s in result["rejected_segments"])


def test_dynamic_identification_is_exact_for_a_representable_resistance() -> None:
    truth = PowerSeriesResistance((0.0, 60.0, 8.0, 0.5), 20.0)
    levels = (200, 600, 300, 1000, 500, 1400, 100)
    record_ = simulate(VesselParams(resistance=truth), staircase(levels, (60,) * len(levels)))
    t, u = record_.t_s, record_.states[:, 0, 3]
    f = record_.commands[:, 0, 0] + record_.commands[:, 0, 1]
    dyn = identify_dynamic(t, f, u, 3)
    assert dyn.mass_kg == pytest.approx(MASS_KG, rel=2e-3)
    grid = np.linspace(0.5, u.max(), 50)
    assert nrms(np.polynomial.polynomial.polyval(grid, dyn.coefficients), truth.force_N(grid)) < 2e-3


def test_model_yaml_loads_as_vessel_override(identified, tmp_path) -> None:
    t, f, v, result = identified
    path = tmp_path / "model.yaml"
    write_model_yaml(path, result["model"], "identified\nfrom a simulated trial")
    assert path.read_text().startswith("# identified\n# from a simulated trial\n")
    params = load_params(path)
    assert params.resistance.to_dict() == result["model"]["resistance"]
    assert params.mass_kg * (1.0 + params.surge_added_mass_ratio) == pytest.approx(
        result["output_error"]["selected"]["mass_kg"])
    written = write_trial_report(tmp_path / "report", result, [SurgeRecord(t, f, v)], title="a simulated trial")
    assert all(p.stat().st_size > 0 for p in written)
    speed = [p["speed_mps"] for p in result["steady_points"]]
    thrust = [p["thrust_N"] for p in result["steady_points"]]
    assert model_dict(fit_power_series(speed, thrust, 2)).keys() == {"resistance"}


def test_nan_samples_are_refused_by_the_array_interface(identified) -> None:
    t, f, v, _ = identified
    v = v.copy()
    v[[100, 200]] = np.nan
    with pytest.raises(InputError, match=r"2 speed value\(s\) are NaN or infinite \(first at index 100\)"):
        identify_arrays(t, f, v)


# Bad input through the command line: exit code 2 and one line on stderr, never a traceback.

SHORT = staircase((150, 400, 800, 1100), (90, 90, 60, 60))
"""Four settled levels: enough for N = 2 (N + 2 = 4), too few for N = 3."""


@pytest.fixture(scope="module")
def short_messages() -> list:
    return recorded(SHORT, 7)


def edited_bag(messages_, directory, edit=None):
    """A bag of ``messages_``, each passed through ``edit(topic, stamp_ns, msg)`` → message or None (dropped)."""
    bag = directory / "edited"
    edit = edit or (lambda *m: m)
    write_bag(bag, sorted((m for m in (edit(*m) for m in messages_) if m is not None), key=lambda m: m[1]))
    return bag


def identify_fails(capsys, *argv: str) -> str:
    """Run ``boat-twin identify ARGV``; assert exit 2 and a one-line error last on stderr (after any progress
    lines), no traceback; return the error line."""
    assert main(["identify", *map(str, argv)]) == 2
    lines = capsys.readouterr().err.splitlines()
    errors = [line for line in lines if "error" in line.lower()]
    assert errors == lines[-1:] and lines[-1].startswith("boat-twin identify: error: ")
    assert not any("Traceback" in line for line in lines)
    return lines[-1]


def test_cli_too_few_steady_points_says_what_is_needed(tmp_path, capsys, short_messages) -> None:
    bag = edited_bag(short_messages, tmp_path)
    err = identify_fails(capsys, bag, "--order", "3")
    assert re.search(r"4 steady point\(s\) found, order 3 needs at least 5 \(N \+ 2\): hold more thrust levels", err)
    assert main(["identify", str(bag), "--order", "2", "--json"]) == 0  # the same bag suffices for N = 2
    assert len(json.loads(capsys.readouterr().out)["steady_points"]) == 4


def test_cli_constant_thrust_is_unidentifiable(tmp_path, capsys) -> None:
    _, bag = record(staircase((600,), (240,)), 7, tmp_path)
    err = identify_fails(capsys, bag)
    assert re.search(r"thrust is constant \(600\.0 N\) over the whole trial: .* unidentifiable", err)


@pytest.mark.parametrize(
    ("dropped", "expected"),
    [
        ((messages.TOPIC_THRUST_LEFT,), "no left outboard's thrust (thrust_left) in the trial"),
        ((messages.TOPIC_GNSS_VEL, messages.TOPIC_GNSS_FIX),
         "no GNSS fix (NavSatFix) or velocity (TwistStamped) topic found; the bag holds: "
         "/thrusters/left/pos (std_msgs/msg/Float64), /thrusters/left/thrust (std_msgs/msg/Float64)"),
    ],
)
def test_cli_missing_thrust_or_gnss_topic(tmp_path, capsys, short_messages, dropped, expected) -> None:
    bag = edited_bag(short_messages, tmp_path, lambda topic, ns, msg: None if topic in dropped else (topic, ns, msg))
    assert expected in identify_fails(capsys, bag)


def test_cli_nan_samples_are_dropouts_not_a_rejection(tmp_path, capsys, short_messages) -> None:
    """10 NaN velocity fixes in 1 s (of 3,000) become a reported gap; the trial identifies and says so."""
    def nan_velocity(topic, ns, msg):
        if topic == messages.TOPIC_GNSS_VEL and 100 * 10**9 <= ns < 101 * 10**9:
            msg = messages.twist_stamped(msg.header, (math.nan, math.nan, 0.0))
        return topic, ns, msg

    bag = edited_bag(short_messages, tmp_path, nan_velocity)
    trial = read_trial(bag)
    assert trial.metadata.dropouts == {"gnss_vel": 10}
    assert [g for g in trial.metadata.gaps if g[0] == "gnss_vel"] == [("gnss_vel", pytest.approx(99.9, abs=0.06),
                                                                       pytest.approx(101.0, abs=0.06))]
    assert main(["identify", str(bag), "--order", "2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert len(result["steady_points"]) == 4
    assert any("gnss_vel: 10 sample(s) with NaN values dropped as dropouts" in w for w in result["warnings"])


def test_cli_commands_and_gnss_without_overlap_in_time(tmp_path, capsys, short_messages) -> None:
    later_ns = int(SHORT.duration_s * 1e9) + 10**9  # every command after the last GNSS sample

    def commands_later(topic, ns, msg):
        return (topic, ns + later_ns, msg) if topic in messages.COMMAND_TOPICS else (topic, ns, msg)

    err = identify_fails(capsys, edited_bag(short_messages, tmp_path, commands_later))
    assert "commands and GNSS do not overlap in time" in err


def test_samples_inside_a_command_gap_are_skipped_not_refused(tmp_path) -> None:
    """A MAVLink log's commands are NaN where the servo outputs fell silent (a reported gap): skip them there."""
    trial, _ = record(SHORT, 7, tmp_path)
    inside = (trial.t_s > 100.0) & (trial.t_s < 110.0)
    thrust = np.where(inside, np.nan, trial.thrust_left_N)
    metadata = dataclasses.replace(trial.metadata, gaps=[*trial.metadata.gaps, ("thrust_left", 100.0, 110.0)])
    gapped = dataclasses.replace(trial, thrust_left_N=thrust, metadata=metadata)
    t, _, _ = trial_samples(gapped)
    assert t.size == np.sum(np.isfinite(trial.surge_thrust_N) & np.isfinite(trial.speed_mps)) - inside.sum()
    unreported = dataclasses.replace(trial, thrust_left_N=thrust)
    with pytest.raises(InputError, match="NaN outside the reported gaps"):
        trial_samples(unreported)


def test_thrust_seen_counts_what_the_engines_delivered_not_what_was_asked() -> None:
    from boat_twin.ident.twin_config import thrust_seen

    engines = VesselParams()
    speed = np.linspace(0.0, 12.0, 50)  # a trial's speed over ground, m/s, and commands far beyond the envelope
    asked = SimpleNamespace(speed_mps=speed, thrust_left_N=np.full(50, 3.0 * engines.bollard_thrust_N),
                            thrust_right_N=np.full(50, -3.0 * engines.bollard_thrust_N))
    seen = thrust_seen([asked], engines)
    assert seen["ahead_N"] == pytest.approx(engines.bollard_thrust_N)
    assert seen["astern_N"] == pytest.approx(engines.reverse_thrust_ratio * engines.bollard_thrust_N)
    assert seen["power_W"] <= engines.propulsive_efficiency * engines.engine_power_W * (1 + 1e-12)


def test_a_steered_trial_asking_more_than_the_engines_give_re_simulates_within_the_noise(tmp_path) -> None:
    """Random commands at speed ask more thrust than the engines' power delivers there; the fit reads the thrust
    through the envelope, and the identified twin keeps it (it had raised its power to the commands' T·|u|: the
    re-simulation ran 0.88 m/s RMS too fast)."""
    trial = tmp_path / "random.mcap"
    assert main(["simulate", "random", "--duration", "300", "--seed", "5", "--out", str(trial)]) == 0
    assert main(["identify", str(trial), "--out", str(tmp_path / "ident")]) == 0
    result = json.loads((tmp_path / "ident" / "identify.json").read_text())
    assert result["twin"]["sources"]["engine_power_W"] == "similar boat"
    assert result["resimulation"]["speed_rmse_mps"] < 0.2, result["resimulation"]
