"""The diagnosis: hide an effect in a simulated trial's bag, pass only the bag to ``diagnose``, find it.

Trials are 5 minutes (the accuracy study in benchmarks/bench_diagnose.py runs 10-minute trials over many
seeds); each test draws the effect's size at random above its detection threshold with a seeded generator.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
from dataclasses import replace
from pathlib import Path

import independent
import numpy as np
import pytest
import yaml

from boat_twin.cli import main
from boat_twin.config import TwinConfig, load_config
from boat_twin.diagnose import hidden
from boat_twin.diagnose.effects import EFFECTS, catalogue, resistance_knots_mps
from boat_twin.diagnose.initial_state import predictable
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.diagnose.report import text_report
from boat_twin.diagnose.search import (
    MIN_MISFIT_SHARE,
    WIND_ALIASES,
    Candidate,
    Fit,
    misfit_rise,
    misfit_share,
    withheld,
)
from boat_twin.diagnose.structure import MISFIT_FACTOR, Signature
from boat_twin.diagnose.table import runs_test_p
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.trial import Trial
from boat_twin.sensors.um7 import Um7Config
from boat_twin.twin.replay import LONGITUDINAL_ACCEL, SIGNALS, cut_windows, predict
from boat_twin.twin.sea_trial import SeaTrial, run_sea_trial, trial_messages
from boat_twin.vessel.params import VesselParams, derive_coefficients
from boat_twin.vessel.scenarios import make_scenario

TRIAL_S = 300.0
"""Length of the test trials, s."""
TOLERANCE = {
    "water_current": ("east_mps", 0.05), "gyro_bias": ("bias_radps", 0.0015), "gnss_latency": ("delay_s", 0.1),
    "steering_offset": ("offset_rad", 0.01), "mass_error": ("mass_factor", 0.08), "tow_load": ("drag_scale", 0.35),
    "wind": ("east_mps", 0.5), "manoeuvring": ("yaw_damping_factor", 0.03),
}
"""(parameter checked, absolute tolerance) per effect: ~3× the jackknife standard error seen on 5-minute trials.
A test-side accuracy bound on the fitted value, in the parameter's unit; not the registry's detection threshold
or minimum size (:class:`~boat_twin.diagnose.effects.EffectSpec`), which bound the effect's size."""


def _diagnose(tmp_path: Path, config: TwinConfig, kind: str, seed: int, *extra: str) -> dict:
    bag = hidden.write_trial(tmp_path / "trial.mcap", config, kind, seed, TRIAL_S)
    out = tmp_path / "out"
    args = ["diagnose", str(bag), "--json", "--out", str(out), *extra]
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert main(args) == 0
    return json.loads(buffer.getvalue(), parse_constant=_not_strict_json)


def _not_strict_json(constant: str) -> None:
    pytest.fail(f"--json printed {constant}: not strict JSON")


def _true_boat(effect: str, kind: str, seed: int) -> tuple[TwinConfig, dict]:
    """The boat with ``effect`` hidden in it (a resistance change inside the speeds the trial visits)."""
    base = TwinConfig()
    speeds = hidden.visited_speeds_mps(base, kind, seed, TRIAL_S) if effect == "resistance_shape" else None
    return hidden.draw_effect(effect, base, np.random.default_rng(seed), speeds)


def _names(result: dict) -> list[str]:
    return [v["effect"] for v in result["verdict"]]


SLOW = pytest.mark.slow
"""A diagnosis study of a whole trial (10-90 s on a busy 2-core machine): run by CI and `make test SLOW=1`."""


@pytest.mark.parametrize(("effect", "kind", "seed"), [
    ("water_current", "zigzag", 21),
    pytest.param("gyro_bias", "thrust-steps", 22, marks=SLOW),
    ("gnss_latency", "random", 23),
    pytest.param("thrust_asymmetry", "zigzag", 24, marks=SLOW),
    pytest.param("steering_offset", "random", 25, marks=SLOW),
    pytest.param("mass_error", "thrust-steps", 26, marks=SLOW),
    pytest.param("tow_load", "thrust-steps", 28, marks=SLOW),
    pytest.param("wind", "random", 29, marks=SLOW),
    pytest.param("wind", "zigzag", 30, marks=SLOW),
    pytest.param("manoeuvring", "zigzag", 91, marks=SLOW),
])
def test_hidden_effect_is_named_with_its_size(tmp_path: Path, effect: str, kind: str, seed: int) -> None:
    config, truth = _true_boat(effect, kind, seed)
    result = _diagnose(tmp_path, config, kind, seed)
    assert _names(result)[:1] == [effect], (truth, result["verdict"], result["candidates"][:3])
    found = result["verdict"][0]["parameters"]
    if effect in TOLERANCE:
        name, tol = TOLERANCE[effect]
        assert found[name] == pytest.approx(truth[name], abs=tol)
        if effect == "manoeuvring":  # the extended model holds the corrected coefficients themselves
            _corrected_coefficients_match(Path(result["extended_model"]), config)
    else:  # thrust_asymmetry
        weak = "left_factor" if truth["left_factor"] < 1 else "right_factor"
        assert found[weak] == pytest.approx(truth[weak], abs=0.03)


RESISTANCE_SIZE_ERROR = 0.5
"""|found − best| / |true change| of a resistance change's peak, at most, where *best* is the closest the
correction's own shape comes to the true change over the speeds the trial visited (:func:`_representable`). The
hidden change has sharp edges (ramps a fifth of its band) where the correction is piecewise linear between 5
knots at quantiles of the visited speeds, and the boat with the change leaves the band it was drawn in (drawn on
the unchanged boat's speeds): on seed 227 the trial spends 10 % of its time in the band (0.15 m/s wide) and 2 %
below the first knot, the band's upper edge lies between the first two knots (3.04, 3.15 m/s), and the best
five-knot shape puts −0.20 at 3.04 m/s against the true −0.16. The fit gives −0.27 (95 % CI −0.32…−0.22;
without the windows' initial-state correction −0.24, CI −0.29…−0.19, the same within their intervals). Measured
on seeds 27/127/227/327: 19, 3, 44, 22 % from the best shape; 45, 3, 69, 48 % from the true plateau. With the
longitudinal accelerometer compared (issue 38), which sees the boat accelerate through the band's edges: 38, 3, 66,
23 % (seed 227: −0.30 against the best −0.20; the seed is an expected failure of the 50 % bar, see
docs/diagnosis.md)."""


def _representable(knots_mps: np.ndarray, true_boat: TwinConfig, speeds_mps: np.ndarray) -> np.ndarray:
    """The correction at ``knots_mps`` (piecewise linear, constant beyond the ends) closest in least squares to
    the true boat's resistance change at the measured speeds ``speeds_mps``: what the correction can represent."""
    speeds = speeds_mps[np.isfinite(speeds_mps)]
    basis = np.stack([np.interp(speeds, knots_mps, np.eye(knots_mps.size)[i]) for i in range(knots_mps.size)], axis=1)
    change = true_boat.vessel.resistance.factor(speeds) - 1.0
    return np.linalg.lstsq(basis, change, rcond=None)[0]


@SLOW
@pytest.mark.parametrize("seed", [27, 127, pytest.param(227, marks=pytest.mark.xfail(
    strict=True, reason="with the accelerometer the peak is 66 % of the true change from the best shape (bar 50 %)")),
    327])
def test_a_resistance_change_is_named_in_its_place_with_its_size_on_every_seed(tmp_path: Path, seed: int) -> None:
    """A resistance change on a zigzag (one course, one speed band): named first, its largest change at a knot
    inside the true band or at the knot next to it, with the true sign, and sized within RESISTANCE_SIZE_ERROR of
    the closest the correction's shape comes to the true change."""
    config, truth = _true_boat("resistance_shape", "zigzag", seed)
    result = _diagnose(tmp_path, config, "zigzag", seed)
    assert _names(result)[:1] == ["resistance_shape"], (truth, result["verdict"], result["candidates"][:3])
    found = {float(k.split("_")[2]): v for k, v in result["verdict"][0]["parameters"].items()}
    knots = sorted(found)
    peak = max(knots, key=lambda k: abs(found[k]))
    low, high = truth["band_mps"]
    below = [k for k in knots if k < low]
    above = [k for k in knots if k > high]
    near = {k for k in knots if low <= k <= high} | set(below[-1:]) | set(above[:1])
    assert peak in near, (peak, truth["band_mps"], found)
    assert np.sign(found[peak]) == np.sign(truth["change"])
    speeds = read_trial(tmp_path / "trial.mcap").speed_mps
    best = dict(zip(knots, _representable(resistance_knots_mps(speeds), config, speeds), strict=True))
    assert abs(found[peak] - best[peak]) <= RESISTANCE_SIZE_ERROR * abs(truth["change"]), (found, best, truth)


def _corrected_coefficients_match(model_path: Path, true_boat: TwinConfig) -> None:
    """The extended model's lift damping within 3 % of the true boat's (a_r) and 5 % (a_v)."""
    found, true = derive_coefficients(load_config(model_path).vessel), derive_coefficients(true_boat.vessel)
    assert found.yaw_damping_Nms == pytest.approx(true.yaw_damping_Nms, rel=0.03)
    assert found.sway_damping_Nspm2 == pytest.approx(true.sway_damping_Nspm2, rel=0.05)
    assert found.yaw_damping_Nms != pytest.approx(derive_coefficients(TwinConfig().vessel).yaw_damping_Nms, rel=0.1)


def _hidden_lift_damping(which: str, seed: int) -> tuple[TwinConfig, dict[str, float]]:
    """A boat whose lift damping differs from the model's: ``drawn`` is the registry's draw (the yaw damping
    beyond the threshold, the sway within it either way); ``sway`` changes the sway damping alone, by 1.2-2× the
    threshold either way, drawn here with the seeded generator."""
    if which == "drawn":
        return _true_boat("manoeuvring", "random", seed)
    rng = np.random.default_rng(seed)
    change = EFFECTS["manoeuvring"].threshold * rng.uniform(1.2, 2.0) * rng.choice([-1.0, 1.0])
    truth = {"yaw_damping_factor": 1.0, "sway_damping_factor": 1.0 + change}
    return EFFECTS["manoeuvring"].apply(TwinConfig(), np.array(list(truth.values()))), truth


@SLOW
@pytest.mark.parametrize(("which", "seed", "trial_s"), [("drawn", 92, TRIAL_S), ("sway", 93, 180.0)])
def test_manoeuvring_on_random_commands_is_named_with_both_factors_inside_their_intervals(
        tmp_path: Path, which: str, seed: int, trial_s: float) -> None:
    """Random commands (steering held 5-25 s anywhere within ±60 % of its limit) turn enough to carry the
    turning coefficients, not only a zigzag: the yaw and/or sway lift damping are named, alone, with both
    factors within 0.03 of the truth, each inside its 95 % interval, and the extended model holds the true boat's
    a_r, a_v within 3 %. The sway-only case runs 3 minutes to keep the test short (measured: yaw 1.019, sway 1.284
    against 1.000, 1.298)."""
    config, truth = _hidden_lift_damping(which, seed)
    bag = hidden.write_trial(tmp_path / "trial.mcap", config, "random", seed, trial_s)
    out = tmp_path / "out"
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert main(["diagnose", str(bag), "--json", "--out", str(out)]) == 0
    result = json.loads(buffer.getvalue())
    assert _names(result) == ["manoeuvring"] and not result["unexplained"], (truth, result["candidates"][:4])
    (verdict,) = result["verdict"]
    for name, true in truth.items():
        assert verdict["parameters"][name] == pytest.approx(true, abs=TOLERANCE["manoeuvring"][1]), name
        low, high = verdict["ci95"][name]
        assert low <= true <= high, (name, true, low, high)
    found, real = derive_coefficients(load_config(Path(result["extended_model"])).vessel), derive_coefficients(
        config.vessel)
    assert found.yaw_damping_Nms == pytest.approx(real.yaw_damping_Nms, rel=0.03)
    assert found.sway_damping_Nspm2 == pytest.approx(real.sway_damping_Nspm2, rel=0.03)


@pytest.mark.parametrize("name", list(EFFECTS))
def test_registry_entry_is_consistent(name: str) -> None:
    """Floor = half the threshold; a drawn effect is 1-2.5× its threshold and is the registry's own apply."""
    spec, base = EFFECTS[name], TwinConfig()
    assert spec.min_size == pytest.approx(spec.threshold / 2, rel=0.01)
    effect = catalogue(base, np.linspace(0.5, 9.0, 200))[name]
    assert effect.magnitude(effect.null) == pytest.approx(0.0, abs=1e-12)
    assert np.all((effect.lower <= effect.null) & (effect.null <= effect.upper))
    if name in TOLERANCE:
        assert TOLERANCE[name][0] in effect.parameter_names
    if spec.per_knot:
        return
    for seed in range(5):
        config, truth = hidden.draw_effect(name, base, np.random.default_rng(seed))
        values = np.array([truth[n] for n in effect.parameter_names])
        assert spec.threshold <= effect.magnitude(values) <= 2.5 * spec.threshold
        assert effect.apply(base, values) == config


@pytest.mark.parametrize(("kind", "seed"), [("zigzag", 31), ("random", 32), ("thrust-steps", 33)])
def test_clean_trial_has_an_empty_verdict(tmp_path: Path, kind: str, seed: int) -> None:
    result = _diagnose(tmp_path, TwinConfig(), kind, seed)
    assert result["verdict"] == [], result["verdict"]
    assert not result["unexplained"], result["signature"]


FALSE_ALARM_SEEDS = 20
"""Clean trials in the false-alarm test; at most one may name an effect (≤ 5 %)."""
FALSE_ALARM_TRIAL_S = 180.0
"""Shorter than the other tests' trials (9 windows instead of 15), so the test stays fast; shorter trials give
the decision rule less data, the harder case for false alarms."""


@SLOW
def test_false_alarms_stay_at_most_5_percent_over_many_clean_trials(tmp_path: Path) -> None:
    alarms, unexplained = [], []
    for i in range(FALSE_ALARM_SEEDS):
        kind = hidden.TRIAL_KINDS[i % len(hidden.TRIAL_KINDS)]
        bag = hidden.write_trial(tmp_path / f"clean-{i}.mcap", TwinConfig(), kind, 500 + i, FALSE_ALARM_TRIAL_S)
        result = diagnose_trial(read_trial(bag), TwinConfig()).result
        if result["verdict"]:
            alarms.append((kind, 500 + i, [v["effect"] for v in result["verdict"]]))
        if result["unexplained"]:
            unexplained.append((kind, 500 + i, result["signature"]))
    assert len(alarms) <= 0.05 * FALSE_ALARM_SEEDS, alarms
    assert len(unexplained) <= 0.05 * FALSE_ALARM_SEEDS, unexplained


@SLOW
def test_another_boat_far_off_the_model_is_never_an_all_clear(tmp_path: Path) -> None:
    """A 2.5 m, 60 kg survey boat (other vessel parameters) diagnosed against the default 6 m twin: whatever is
    named, the residuals stay far above the noise floor and the report says so."""
    vessel = replace(TwinConfig().vessel, mass_kg=60.0, length_m=2.5, beam_m=1.2, draft_m=0.1,
                     radius_of_gyration_yaw_m=0.6, engine_x_m=-1.1, engine_y_m=0.4, bollard_thrust_N=120.0,
                     engine_power_W=800.0, turn_diameter_m=12.0, turn_speed_mps=2.0, lateral_centre_x_m=-0.4,
                     frontal_windage_area_m2=0.3, lateral_windage_area_m2=0.6, windage_centre_x_m=0.2)
    result = _diagnose(tmp_path, replace(TwinConfig(), vessel=vessel), "random", 61)
    assert result["unexplained"], result
    assert max(sig["misfit"] for sig in result["signature"]) > 2.0


@SLOW
@pytest.mark.parametrize(("kind", "seed"), [("random", 71), ("zigzag", 72)])
def test_a_gyro_scale_error_outside_the_catalogue_is_unexplained_not_labelled(tmp_path: Path, kind: str,
                                                                              seed: int) -> None:
    """An out-of-catalogue probe made by this test, not by the twin: the recorded gyro reads 5 % high."""
    from dataclasses import replace as replace_msg

    from rosbags.highlevel import AnyReader

    from boat_twin.io import messages

    clean = hidden.write_trial(tmp_path / "clean.mcap", TwinConfig(), kind, seed, TRIAL_S)
    scaled = []
    with AnyReader([clean]) as reader:
        for connection, stamp, raw in reader.messages():
            topic = connection.topic.lstrip("/")
            msg = messages.deserialize(raw, messages.TOPICS[topic])
            if topic == "imu/data":
                msg = replace_msg(msg, angular_velocity=replace_msg(msg.angular_velocity,
                                                                    z=1.05 * msg.angular_velocity.z))
            scaled.append((topic, stamp, msg))
    write_bag(tmp_path / "scaled.mcap", scaled)
    result = diagnose_trial(read_trial(tmp_path / "scaled.mcap"), TwinConfig()).result
    assert result["verdict"] == [] and result["unexplained"], result["verdict"]
    worst = max(result["signature"], key=lambda sig: sig["misfit"])
    assert worst["signal"] == "yaw_rate_radps" and worst["misfit"] > 2.0


@SLOW
@pytest.mark.parametrize(("probe", "seed"), [("steering_thrust_loss", 73), ("steering_dead_band", 74)])
def test_an_actuator_fault_outside_the_catalogue_is_unexplained_not_labelled(tmp_path: Path, probe: str,
                                                                            seed: int) -> None:
    """Physical causes the catalogue lacks, made by :func:`hidden.write_probe_trial` without the catalogue: the
    outboards deliver less thrust when steered, or turn through a 4° dead band; the bag records the helm's
    commands. A catalogue effect takes up part of the misfit (held-out gain > 20 %) but not the share the rule
    asks: it is listed as a candidate, not named."""
    bag = hidden.write_probe_trial(tmp_path / "probe.mcap", probe, "random", seed, TRIAL_S)
    result = diagnose_trial(read_trial(bag), TwinConfig()).result
    assert result["verdict"] == [] and result["ambiguous"] is None, result["verdict"]
    assert result["unexplained"] and max(sig["misfit"] for sig in result["signature"]) > 2.0
    partial = [c for c in result["candidates"] if (c["heldout_gain"] or 0.0) > 0.2]
    assert partial and all(c["misfit_share"] < MIN_MISFIT_SHARE and not c["named"] for c in partial), partial


def _fit(sse: list[float]) -> Fit:
    """A fit judged on held-out windows with the held-out SSE ``sse`` per motion signal (normalized residuals),
    of a trial without an accelerometer (its SSE 0)."""
    sse = sse + [0.0] * (len(SIGNALS) - len(sse))
    return Fit(effects=[], values=np.zeros(0), stderr=np.zeros(0), sse=np.array(sse), heldout_sse=np.array(sse),
               residuals=None)  # type: ignore[arg-type]


def _floor(n: float) -> np.ndarray:
    """The noise floor's held-out SSE per signal: ``n`` samples of each motion signal, none of the accelerometer."""
    return np.array([0.0 if s == LONGITUDINAL_ACCEL else n for s in SIGNALS])


def test_a_cause_removing_a_small_share_of_an_8x_misfit_is_a_candidate_not_a_verdict() -> None:
    """Issue 17's case: velocity RMSE 8× the noise, a cause that lowers it by 20 % and 12 % (and makes the yaw
    rate slightly worse) passes every other condition but is not named; one that removes most of it is."""
    n = 1000.0
    floor = _floor(n)
    baseline = _fit([64 * n, 64 * n, 1.0 * n, 1.0 * n])
    weak = _fit([64 * n * 0.80**2, 64 * n * 0.88**2, 1.05 * n, 1.0 * n])
    strong = _fit([1.3 * n, 1.2 * n, 1.0 * n, 1.0 * n])
    effect = catalogue(TwinConfig(), np.linspace(0.5, 9.0, 200))["thrust_asymmetry"]
    for fit, named in ((weak, False), (strong, True)):
        candidate = Candidate(effect, fit, delta_bic=-300.0, size=0.06, at_bound=False, takes_over=False,
                              heldout_gain=float(1 - fit.heldout_sse.sum() / baseline.heldout_sse.sum()),
                              significant=True)
        candidate.claims, candidate.share, candidate.leaves_noise = misfit_share(fit, baseline, floor)
        assert candidate.claims == ("vel_east_mps", "vel_north_mps")
        assert candidate.plausible and candidate.heldout_gain > 0.2
        assert candidate.named is named, candidate.share
    _, share, within = misfit_share(weak, baseline, floor)
    assert 0.12 <= share <= 0.25 < MIN_MISFIT_SHARE and not within


def test_a_cause_that_buys_one_signals_fit_with_anothers_is_not_named() -> None:
    """The gyro-scale probe's case (zigzag, seed 72, the held-out misfits measured there): a 5 % gyro scale error
    taken for a boat that turns faster (a_r × 0.81) takes the yaw rate's misfit from 5.2× the noise to 1.35× and
    removes 92 % of it, but raises the north velocity's from 1.12× to 1.55×: not named. A true change of the yaw
    damping (zigzag, seed 91) lowers every signal's and is."""
    n = 1000.0
    floor = _floor(n)
    effect = catalogue(TwinConfig(), np.linspace(0.5, 9.0, 200))["manoeuvring"]
    cases = (([1.297, 1.115, 5.239, 1.002], [1.316, 1.550, 1.347, 1.066], False),
             ([1.125, 1.852, 4.218, 1.046], [1.003, 1.054, 0.976, 1.008], True))
    for before, after, named in cases:
        baseline, fit = _fit([m * m * n for m in before]), _fit([m * m * n for m in after])
        candidate = Candidate(effect, fit, delta_bic=-400.0, size=0.2, at_bound=False, takes_over=False,
                              heldout_gain=float(1 - fit.heldout_sse.sum() / baseline.heldout_sse.sum()),
                              significant=True)
        candidate.claims, candidate.share, candidate.leaves_noise = misfit_share(fit, baseline, floor)
        candidate.worsens = misfit_rise(fit, baseline, floor)
        assert candidate.plausible and candidate.share > MIN_MISFIT_SHARE
        assert candidate.worsens == (() if named else ("vel_north_mps",))
        assert candidate.named is named


def test_a_candidate_not_judged_says_which_conditions_it_fails() -> None:
    effect = catalogue(TwinConfig(), np.linspace(0.5, 9.0, 200))["water_current"]
    fit = _fit([1.0, 1.0, 1.0, 1.0])
    weak = Candidate(effect, fit, delta_bic=-4.0, size=0.02, at_bound=False, takes_over=True)
    assert weak.failed_conditions == ["ΔBIC -4.0, not below -10", "size 0.02 below the floor 0.075 m/s",
                                      "changes an effect already named"]
    assert not weak.plausible
    assert Candidate(effect, fit, delta_bic=-40.0, size=0.2, at_bound=False, takes_over=False).failed_conditions == []


@SLOW
def test_wind_on_a_trial_that_holds_one_heading_is_reported_with_its_alias_not_guessed(tmp_path: Path) -> None:
    """A 6 m/s head wind on thrust steps (no steering: the heading stays put) is a force along the hull, as a
    current or a thrust loss are: the wind and its best alias are reported as ambiguous, neither is named."""
    config = replace(TwinConfig(), environment=replace(TwinConfig().environment, wind_east_mps=-6.0))
    result = _diagnose(tmp_path, config, "thrust-steps", 81)
    ambiguous = result["ambiguous"]
    assert ambiguous is not None and "wind" in ambiguous["effects"], result["candidates"]
    (alias,) = set(ambiguous["effects"]) - {"wind"}
    assert alias in WIND_ALIASES
    assert not {"wind", alias} & set(_names(result))
    assert ambiguous["parameters"]["wind"]["east_mps"] == pytest.approx(-6.0, abs=1.0)
    assert result["unexplained"]
    assert f"ambiguous   {' or '.join(ambiguous['effects'])}" in text_report(result)


@SLOW
def test_two_effects_at_once_are_both_named(tmp_path: Path) -> None:
    rng = np.random.default_rng(41)
    config, current = hidden.draw_effect("water_current", TwinConfig(), rng)
    config, bias = hidden.draw_effect("gyro_bias", config, rng)
    result = _diagnose(tmp_path, config, "random", 41)
    assert sorted(_names(result)) == ["gyro_bias", "water_current"]


@SLOW
def test_extended_model_reproduces_the_reported_gain(tmp_path: Path) -> None:
    config, _ = hidden.draw_effect("gyro_bias", TwinConfig(), np.random.default_rng(61))
    result = _diagnose(tmp_path, config, "random", 61)
    model = load_config(Path(result["extended_model"]))
    windows = cut_windows(read_trial(tmp_path / "trial.mcap"), 20.0)
    miss = windows.measured["yaw_rate_radps"] - predict(windows, model).signals["yaw_rate_radps"]
    assert float(np.sqrt(np.nanmean(miss**2))) == pytest.approx(result["extended"]["rmse"]["yaw_rate_radps"],
                                                                 rel=1e-6)
    assert result["extended"]["rmse"]["yaw_rate_radps"] < 0.5 * result["baseline"]["rmse"]["yaw_rate_radps"]
    for name in ("diagnosis_signals.png", "diagnosis_residuals.png", "diagnosis_evidence.png"):
        assert (tmp_path / "out" / name).stat().st_size > 1000


def test_table_names_resistance_shape_and_the_plateau(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["diagnose", "--table", "dyda2021", "--model-order", "1", "--json", "--out", str(tmp_path)]) == 0
    result = json.loads(capsys.readouterr().out)
    (verdict,) = result["verdict"]
    assert verdict["effect"] == "resistance_shape"
    low, high = verdict["parameters"]["plateau_kn"]
    assert 6.0 <= low <= 8.0 and 10.0 <= high <= 12.0  # Table 1's flat stretch: 44-50 kgf at 7-11 kn
    assert verdict["gain"]["thrust_kgf"] > 0.5
    model = yaml.safe_load((tmp_path / "extended_model.yaml").read_text())
    assert model["vessel"]["resistance"]["model"] == "table"


def test_runs_test_sees_structure_and_not_noise() -> None:
    rng = np.random.default_rng(7)
    assert runs_test_p(rng.standard_normal(200)) > 0.01
    assert runs_test_p(np.sin(np.linspace(0, 6, 200))) < 0.01


@pytest.mark.parametrize(("argv", "message"), [
    (["diagnose"], "give a TRIAL"),
    (["diagnose", "--table", "nope"], "dyda2021"),
    (["diagnose", "--table", "dyda2021", "--model-order", "2"], "--model-order"),
    (["diagnose", "missing.mcap"], "missing.mcap"),
    (["diagnose", "missing.mcap", "--table", "dyda2021"], "either a TRIAL or --table"),
    (["diagnose", "missing.mcap", "--window", "0"], "--window"),
])
def test_bad_input_is_one_line_and_exit_2(argv: list[str], message: str, capsys: pytest.CaptureFixture) -> None:
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse's own usage errors (a value outside the choices)
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_outputs_are_not_overwritten_without_force(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "extended_model.yaml").write_text("keep\n")
    assert main(["diagnose", "--table", "dyda2021", "--out", str(tmp_path)]) == 2
    assert (tmp_path / "extended_model.yaml").read_text() == "keep\n"
    assert "--force" in capsys.readouterr().err


def test_a_trial_too_short_to_split_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    bag = hidden.write_trial(tmp_path / "short.mcap", TwinConfig(), "random", 1, 60.0)
    assert main(["diagnose", str(bag)]) == 2
    err = capsys.readouterr().err  # the trial summary, then the one error line
    last = err.strip().splitlines()[-1]
    assert "windows" in last and "at least" in last and err.count("error:") == 1 and "Traceback" not in err


# --- issue 23: clean means clean; timing and heading effects, on data the twin did not make --------------------

def _simulated(tmp_path: Path, name: str, *args: str) -> Path:
    """``boat-twin simulate ARGS --out tmp_path/name`` (the CLI's own scenarios and helm)."""
    bag = tmp_path / name
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["simulate", *args, "--out", str(bag)]) == 0
    return bag


@pytest.mark.parametrize("seed", [0, *(pytest.param(seed, marks=SLOW) for seed in range(1, 6))])
def test_clean_zigzags_of_the_simulator_are_not_unexplained(tmp_path: Path, seed: int) -> None:
    """``boat-twin simulate zigzag-20-20 --seed N`` (130 s; its helm decides at 50 Hz, between the 10 Hz log's
    samples), seeds 0-5 (1-5 with the slow studies), every one: an empty verdict and not unexplained (issue 23:
    unexplained on 6 of 6, a steering-correlated yaw-rate residual from commands replayed up to half a sample
    early or late)."""
    bag = _simulated(tmp_path, f"zigzag-{seed}", "zigzag-20-20", "--seed", str(seed))
    result = diagnose_trial(read_trial(bag), TwinConfig()).result
    assert not _names(result) and not result["unexplained"], (seed, _names(result), result["signature"])


def _steps(t_s: float) -> float:
    """Thrust per engine, N: 400 and 800 in turn every 15 s (7.8-10.8 m/s, inside the engines' envelope)."""
    return 400.0 + 400.0 * (int(max(t_s, 0.0) // 15.0) % 2)


def _zigzag(t_s: float) -> float:
    """Steering, rad: ±15° reversed every 10 s."""
    return math.radians(15.0) * (1.0 if int(max(t_s, 0.0) // 10.0) % 2 == 0 else -1.0)


def _turns(t_s: float) -> float:
    """Steering, rad: a course held 20 s, then 10 s of 12° to port, in turn (every heading visited)."""
    return math.radians(12.0) if t_s % 30.0 > 20.0 else 0.0


OTHER_BOATS = {
    "default": {},
    "lighter, stronger": {"mass_kg": 900.0, "engine_power_W": 40_000.0, "bollard_thrust_N": 2_400.0},
    "heavier, slower to turn": {"mass_kg": 1_700.0, "radius_of_gyration_yaw_m": 1.9},
}
"""Boats of the straight-run test (VesselParams changes): each diagnosed against its own config."""


@pytest.mark.parametrize(("name", "seed"), [
    pytest.param(name, seed, marks=() if (name, seed) == ("lighter, stronger", 1) else SLOW)
    for name in OTHER_BOATS for seed in (1, 2)])
def test_clean_straight_thrust_steps_are_not_unexplained(name: str, seed: int) -> None:
    """A straight run of thrust steps at 7.8-10.8 m/s from the independent integrator (test/independent.py),
    three boats × two seeds (the lighter boat's seed 1 alone without the slow studies), each diagnosed against
    its own config, every one: an empty verdict and not unexplained (issue 23: 5 of 5 unexplained, the sideways
    velocity stepping from window to window as each window's heading, 0.3° off at 8 m/s, rotates its path)."""
    params = replace(VesselParams(steering_rate_radps=0.0), **OTHER_BOATS[name])
    trial = independent.boat_trial(params, _steps, lambda t: 0.0, 180.0, np.random.default_rng(seed))
    result = diagnose_trial(trial, TwinConfig(vessel=params)).result
    assert not _names(result) and not result["unexplained"], (name, seed, _names(result), result["signature"])


def _long_run_astern(seed: int) -> SeaTrial:
    """The twin's ``crash-stop`` (seeded) stretched to 180 s: 10 s ahead, then 170 s full astern at about
    12 m/s, a fifth of the GNSS fixes lost."""
    base = TwinConfig()
    config = replace(base, gnss=replace(base.gnss, dropout_probability=0.2))
    made = make_scenario("crash-stop", config.vessel, np.random.default_rng(seed))
    return run_sea_trial(config, replace(made, duration_s=180.0), seed)  # type: ignore[type-var]


def test_the_predictability_horizon_is_the_first_sample_where_the_response_stops_being_linear() -> None:
    """A window whose response to ± a prior-sized initial error is linear (however large) keeps every sample; one
    whose yaw-rate response grows faster on one side than it falls on the other is cut at the first sample where
    the second difference exceeds the noise level, in every signal from there on; unmeasured samples (NaN) never
    cut a window; one that departs from linear at its first compared sample is compared whole where the data lie
    outside the replays from the initial states the prior allows (a model far off), cut where they lie inside (an
    unstable course), unless no window would be left anything to compare."""
    samples, windows = 50, 2
    t = np.arange(samples, dtype=float)
    linear = np.tile(np.concatenate([0.5 * t] * len(SIGNALS))[:, None], (1, windows))  # up to 25 noise levels
    base = np.zeros_like(linear)
    base[:10] = np.nan  # the settling second: not compared
    plus, minus = base + linear, base - linear
    yaw = slice(2 * samples, 3 * samples)
    plus[yaw, 1] += 2.0 * np.exp(0.2 * (t - 30.0))  # second difference: 1 noise level at t = 30, then growing
    compared = predictable(base, [plus], [minus])
    assert compared[:, 0].all()
    assert compared[:31, 1].all() and not compared[31:, 1].any(), np.flatnonzero(~compared[:, 1])
    plus[yaw.start + 10, 1] += 5.0  # departs from linear at the first compared sample
    far = base.copy()
    far[10:, 1] = 40.0  # the data beyond every replay from the initial states the prior allows: a model that
    np.testing.assert_array_equal(predictable(far, [far + plus], [far + minus], least=11).sum(axis=0),
                                  [samples, samples])  # cannot follow them, compared whole
    near = predictable(base, [plus], [minus], least=11)  # the data within the replays' spread: an unstable
    assert near[:, 0].all() and near.sum(axis=0)[1] == 10  # course, cut at its horizon as any other
    assert predictable(base, [plus], [minus]).sum(axis=0)[1] == 10  # without the floor: nothing compared
    lone = predictable(base[:, 1:], [plus[:, 1:]], [minus[:, 1:]], least=11)  # but never every window cut
    assert lone.all()


def test_a_long_clean_run_astern_is_not_alarmed(tmp_path: Path) -> None:
    """A straight course astern is directionally unstable in the model (a sway or yaw error grows e-fold in
    0.5 s at 12 m/s): from the initial state the sensors give, each window's replay turned round within seconds
    and the diagnosis named ``tow_load`` and ``unexplained`` on the twin's own clean trial (issue 23, seed 1018).
    Each window is now compared up to its predictability horizon (docs/diagnosis.md): three seeds of the twin
    and one of the independent integrator, every one with nothing named, nothing ambiguous, not unexplained,
    and with the horizon inside the trial (a share of its time left uncompared, said in the report)."""
    outcomes = []
    for seed in (1018, 1, 2):
        bag = tmp_path / f"astern-{seed}.mcap"
        write_bag(bag, trial_messages(_long_run_astern(seed), truth=False), force=True)
        outcomes.append(("twin", seed, diagnose_trial(read_trial(bag), TwinConfig()).result))
    params = VesselParams(steering_rate_radps=0.0)
    trial = independent.boat_trial(params, lambda t: -1_000.0, lambda t: 0.0, 180.0, np.random.default_rng(3),
                                   initial_surge_mps=-8.0)
    outcomes.append(("independent", 3, diagnose_trial(trial, TwinConfig(vessel=params)).result))
    summary = [(who, seed, _names(r), r["ambiguous"], r["unexplained"], r["windows"]["compared_fraction"])
               for who, seed, r in outcomes]
    assert all(not names and not ambiguous and not unexplained and fraction < 1.0
               for _, _, names, ambiguous, unexplained, fraction in summary), summary
    assert "predictability horizon" in text_report(outcomes[0][2])
    assert "not an all-clear" in text_report(outcomes[0][2])  # nothing named, but most of the trial not judged


@pytest.mark.parametrize("family", ["twin_outboards", "skid_steer_catamaran"])
def test_a_hull_unstable_at_once_astern_is_cut_at_its_horizon_not_alarmed(tmp_path: Path, family: str) -> None:
    """The boat files' hulls (Clarke's derivatives) are more unstable astern than the default boat's: at full
    astern a yaw error grows e-fold in about 0.2 s and every window departed from linear before its first compared
    sample. Those windows were compared whole (the rule for a model that cannot follow its data) and the twin's
    own clean run came back unexplained or named ``manoeuvring``. The data lie within the replays' spread there,
    so they are cut at their horizon: nothing named, not unexplained, most of the trial not compared."""
    from boat_twin.config import load_twin_config
    from boat_twin.io.messages import actuator_order

    config = load_twin_config(Path(__file__).resolve().parents[1] / "config" / "boats" / f"{family}.yaml", None,
                              None)
    made = make_scenario("crash-stop", config.vessel, np.random.default_rng(2000))
    bag = tmp_path / "astern.mcap"
    write_bag(bag, trial_messages(run_sea_trial(config, replace(made, duration_s=180.0), 2000), truth=False))
    result = diagnose_trial(read_trial(bag, order=actuator_order(config.vessel.propulsion)), config).result
    assert (_names(result), result["ambiguous"], result["unexplained"]) == ([], None, False), result["signature"]
    assert result["windows"]["compared_fraction"] < 0.5


@pytest.mark.parametrize("kind", ["zigzag", "random"])
def test_gnss_dropouts_are_not_alarmed_and_the_noise_is_measured_on_real_fixes(tmp_path: Path, kind: str) -> None:
    """A quarter of the GNSS fixes lost (the reader interpolates across single losses): the noise floor is the
    receiver's 0.05 m/s (measured on real fixes only; interpolated ones gave 0.036), and three seeds each come
    back with an empty verdict, not unexplained."""
    base = TwinConfig()
    lossy = replace(base, gnss=replace(base.gnss, dropout_probability=0.25))
    outcomes = []
    for seed in (1, 2, 3):
        bag = hidden.write_trial(tmp_path / f"{kind}-{seed}.mcap", lossy, kind, 230 + seed, 180.0)
        result = diagnose_trial(read_trial(bag), base).result
        assert result["noise"]["vel_east_mps"] == pytest.approx(base.gnss.velocity_stdev_mps, rel=0.1)
        assert result["windows"]["compared_fraction"] == 1.0  # a stable course: every sample compared
        outcomes.append((seed, _names(result), result["unexplained"], result["signature"]))
    assert all(not names and not unexplained for _, names, unexplained, _ in outcomes), outcomes


HIDDEN_TIMING = {
    "command_delay": ("delay_s", "delay_s", _steps, _zigzag, 0.03),
    "thrust_lag": ("time_constant_s", "lag_s", _steps, lambda t: 0.0, 0.15),
    "heading_offset": ("offset_rad", "yaw_offset_rad", lambda t: 350.0, _turns, math.radians(0.3)),
}
"""Effect → (its parameter, the independent integrator's argument, thrust per engine (N) and steering (rad) over
time, absolute tolerance on the size found)."""


@pytest.mark.parametrize(("effect", "seed"), [("command_delay", 41), ("thrust_lag", 42), ("heading_offset", 43)])
def test_timing_and_heading_effects_are_named_and_sized_on_an_independent_boat(effect: str, seed: int) -> None:
    """Each new effect drawn by the registry (1.2-2× its threshold, seeded) and made by the independent
    integrator, not the twin: commands acting late on thrust steps and a zigzag, engines lagging on thrust steps
    (no steering), an IMU yaw offset on a boat that turns through every heading. Named first, sized within the
    tolerance. (The 95 % intervals are statistical: the delay's, ±0.002 s wide, can miss the truth by microseconds
    where the replay's segments and this integrator's stages differ; docs/diagnosis.md.)"""
    parameter, argument, thrust, steering, tolerance = HIDDEN_TIMING[effect]
    params = VesselParams(steering_rate_radps=0.0)
    base = TwinConfig(vessel=params)
    _, truth = hidden.draw_effect(effect, base, np.random.default_rng(seed))
    trial = independent.boat_trial(params, thrust, steering, 200.0, np.random.default_rng(seed),
                                   **{argument: truth[parameter]})
    result = diagnose_trial(trial, base).result
    assert _names(result)[:1] == [effect], (truth, result["verdict"], result["candidates"][:4])
    found = result["verdict"][0]
    assert found["parameters"][parameter] == pytest.approx(truth[parameter], abs=tolerance), (truth, found)


def test_without_an_accelerometer_a_delay_on_straight_thrust_steps_is_ambiguous_with_a_gnss_latency() -> None:
    """Commands acting 0.45 s late on a straight run of thrust steps (the independent integrator), logged without
    an accelerometer: every measured response moves later by as much as a 0.45 s GNSS latency would move the
    GNSS's (the gyro sees no turn), so the two come within 10 of each other's ΔBIC and neither is named:
    ``ambiguous``, with the delay's size. The accelerometer is left out of every figure, not reported as NaN."""
    params = VesselParams(steering_rate_radps=0.0)
    trial = independent.boat_trial(params, _steps, lambda t: 0.0, 200.0, np.random.default_rng(1), delay_s=0.45)
    result = diagnose_trial(trial, TwinConfig(vessel=params)).result
    assert LONGITUDINAL_ACCEL not in result["noise"] and LONGITUDINAL_ACCEL not in result["baseline"]["rmse"]
    assert result["verdict"] == [] and result["ambiguous"] is not None, result["candidates"][:4]
    assert "command_delay" in result["ambiguous"]["effects"], result["ambiguous"]
    assert set(result["ambiguous"]["effects"]) <= {"command_delay", "gnss_latency", "thrust_lag"}
    assert result["ambiguous"]["parameters"]["command_delay"]["delay_s"] == pytest.approx(0.45, abs=0.03)


ACCEL_STDEV_MPS2 = Um7Config().accel_stdev_mps2
"""The twin's accelerometer noise, m/s² (0.039), that of the independent integrator's when it logs one."""
HEAVIER = replace(VesselParams(steering_rate_radps=0.0), **OTHER_BOATS["heavier, slower to turn"])
"""A boat other than the default (1700 kg), diagnosed against its own config."""


@pytest.mark.parametrize(("effect", "argument", "size_s", "parameter"), [
    ("command_delay", "delay_s", 0.45, "delay_s"),
    ("gnss_latency", "latency_s", 0.6, "delay_s"),
    ("thrust_lag", "lag_s", 0.5, "time_constant_s"),
])
def test_the_accelerometer_tells_a_delay_a_gnss_latency_and_an_engine_lag_apart_on_straight_thrust_steps(
        effect: str, argument: str, size_s: float, parameter: str) -> None:
    """The straight run of thrust steps that leaves a delay ambiguous with a GNSS latency, logged with the IMU's
    accelerometer (the independent integrator, the heavier boat): the surge specific force steps when the engines
    deliver the thrust — at once under a GNSS latency, late under a command delay, smoothly under an engine lag —
    so each is named alone, sized within 0.1 s of the truth (the GNSS latency is the total, 0.1 s nominal)."""
    trial = independent.boat_trial(HEAVIER, _steps, lambda t: 0.0, 200.0, np.random.default_rng(1),
                                   accel_stdev_mps2=ACCEL_STDEV_MPS2, **{argument: size_s})
    result = diagnose_trial(trial, TwinConfig(vessel=HEAVIER)).result
    assert _names(result) == [effect] and result["ambiguous"] is None, result["candidates"][:4]
    assert result["verdict"][0]["parameters"][parameter] == pytest.approx(size_s, abs=0.1)
    assert not result["unexplained"], result["signature"]
    assert result["noise"][LONGITUDINAL_ACCEL] == pytest.approx(ACCEL_STDEV_MPS2, rel=0.15)


def test_a_clean_straight_run_with_an_accelerometer_names_nothing() -> None:
    """The same straight run of the heavier boat, its accelerometer logged, nothing hidden: nothing named, not
    unexplained (the accelerometer compared within its noise)."""
    trial = independent.boat_trial(HEAVIER, _steps, lambda t: 0.0, 200.0, np.random.default_rng(2),
                                   accel_stdev_mps2=ACCEL_STDEV_MPS2)
    result = diagnose_trial(trial, TwinConfig(vessel=HEAVIER)).result
    assert not _names(result) and result["ambiguous"] is None and not result["unexplained"], result["candidates"][:3]
    assert result["baseline"]["rmse"][LONGITUDINAL_ACCEL] < 1.2 * ACCEL_STDEV_MPS2


def test_a_thrust_asymmetry_and_a_gnss_latency_together_are_named_as_the_pair(tmp_path: Path) -> None:
    """The twin's random-command trial (seed 61, 300 s) of a boat whose left engine gives 88 % and whose GNSS is
    0.62 s late: the asymmetry alone removes only half its signals' misfit (the latency is still in the
    velocities), so it was a candidate and nothing was named; tried with it, the next round names the latency,
    and the two together remove the misfit: both are the verdict, each within its tolerance, nothing left."""
    rng = np.random.default_rng(61)
    config, asymmetry = hidden.draw_effect("thrust_asymmetry", TwinConfig(), rng)
    config, latency = hidden.draw_effect("gnss_latency", config, rng)
    result = _diagnose(tmp_path, config, "random", 61)
    assert _names(result) == ["thrust_asymmetry", "gnss_latency"], result["candidates"][:4]
    first, second = result["verdict"]
    assert first["parameters"]["left_factor"] == pytest.approx(asymmetry["left_factor"], abs=0.03)
    assert second["parameters"]["delay_s"] == pytest.approx(latency["delay_s"], abs=0.1)
    assert not result["unexplained"] and result["withheld"] == [], result["signature"]
    alone = next(c for c in result["candidates"] if c["round"] == 1 and c["named"])
    assert alone["effect"] == "thrust_asymmetry" and alone["misfit_share"] < MIN_MISFIT_SHARE, alone


@pytest.mark.parametrize(("seed", "north_mps"), [(1, 0.5), (2, 0.8)])
def test_a_current_over_half_the_area_stays_unexplained(seed: int, north_mps: float) -> None:
    """The independent integrator's boat (thrust steps, every heading, accelerometer logged) in a current that
    flows north only east of the track's median: no constant current explains it (a fitted one removes a fifth
    of the misfit), no pair of catalogue causes does either, and the verdict is ``unexplained``, nothing named."""
    params = VesselParams(steering_rate_radps=0.0)
    trial = independent.boat_trial(params, _steps, _turns, 200.0, np.random.default_rng(seed),
                                   accel_stdev_mps2=ACCEL_STDEV_MPS2)
    east = np.convolve(trial.east_m, np.ones(21) / 21, mode="same")
    inside = east > np.median(east)
    drift_m = np.cumsum(np.where(inside, north_mps * 0.1, 0.0))  # logged at 10 Hz
    trial = replace(trial, vel_north_mps=trial.vel_north_mps + np.where(inside, north_mps, 0.0),
                    north_m=trial.north_m + drift_m)
    result = diagnose_trial(trial, TwinConfig(vessel=params)).result
    assert result["verdict"] == [] and result["unexplained"], result["candidates"][:3]


def _with_current(trial: Trial, east_mps: float, north_mps: float, from_s: float = 0.0) -> Trial:
    """``trial`` of the independent integrator (no current) as measured in a uniform current from ``from_s``: the
    water-relative motion is the same, so the GNSS's velocity gains the current and its track drifts with it."""
    on = trial.t_s >= from_s
    drift_s = np.where(on, trial.t_s - from_s, 0.0)
    return replace(trial, vel_east_mps=trial.vel_east_mps + np.where(on, east_mps, 0.0),
                   vel_north_mps=trial.vel_north_mps + np.where(on, north_mps, 0.0),
                   east_m=trial.east_m + east_mps * drift_s, north_m=trial.north_m + north_mps * drift_s)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_cause_that_leaves_its_signals_misfit_with_structure_is_withheld_not_the_verdict(seed: int) -> None:
    """The independent integrator's boat (thrust steps, every heading) in a 0.8 m/s current switched on at 35 s
    of 200: a constant current, fitted at 0.77 m/s, removes 72 % of the velocities' misfit in excess of the noise
    (the share rule's floor is 70 %) and leaves the east velocity 3× its noise, the structure the catalogue cannot
    explain. Before, it was the verdict beside ``unexplained``; now it is ``withheld`` (named in the report with
    its size and why), the verdict is empty, ``unexplained`` holds, and the extended model leaves it out."""
    params = VesselParams(steering_rate_radps=0.0)
    trial = _with_current(independent.boat_trial(params, _steps, _turns, 200.0, np.random.default_rng(seed)),
                          0.8, 0.0, from_s=35.0)
    done = diagnose_trial(trial, TwinConfig(vessel=params))
    result = done.result
    assert [c.effect.name for c in done.selection.named] == ["water_current"], result["candidates"]
    assert result["verdict"] == [] and result["unexplained"], result["verdict"]
    (withheld,) = result["withheld"]
    assert withheld["effect"] == "water_current" and withheld["parameters"]["east_mps"] == pytest.approx(0.8, abs=0.1)
    assert withheld["misfit_share"] >= MIN_MISFIT_SHARE and max(withheld["misfit_left"].values()) > MISFIT_FACTOR
    assert done.extended == TwinConfig(vessel=params)  # the model a user loads holds no withheld cause
    text = text_report(result)
    assert "withheld    water_current (not the verdict)" in text and "verdict     UNEXPLAINED" in text


def test_two_catalogue_causes_are_both_named_when_the_first_leaves_the_second_in_its_signals() -> None:
    """Commands acting 0.45 s late and a 0.3 m/s current, on the independent integrator's boat: the delay, named
    first, removes 72 % of its signals' misfit (the current is still in the velocities), and the current joins
    in the next round, leaving nothing: both are the verdict, nothing is withheld."""
    params = VesselParams(steering_rate_radps=0.0)
    trial = _with_current(independent.boat_trial(params, _steps, _turns, 200.0, np.random.default_rng(1),
                                                 delay_s=0.45), 0.0, 0.3)
    result = diagnose_trial(trial, TwinConfig(vessel=params)).result
    assert _names(result) == ["command_delay", "water_current"], result["candidates"]
    assert result["withheld"] == [] and not result["unexplained"], result["signature"]
    assert result["verdict"][0]["parameters"]["delay_s"] == pytest.approx(0.45, abs=0.03)
    assert result["verdict"][1]["parameters"]["north_mps"] == pytest.approx(0.3, abs=0.03)


def test_the_withheld_rule_judges_each_cause_by_what_it_explains_and_withholds_the_causes_named_after_it() -> None:
    """``search.withheld``, the one rule of the offline and the live diagnosis: nothing is withheld without
    structure left; offline, a cause whose claimed signals stay above MISFIT_FACTOR × the noise is, or structured
    within it when the cause removes less than MIN_MISFIT_SHARE of their misfit (issue 42), with every cause named
    after it (fitted against a model that held it), while one named before it stands; live, the twin's misfit
    decides for all."""
    effects = catalogue(TwinConfig(), np.linspace(0.5, 9.0, 200))
    fit = _fit([1.0, 1.0, 1.0, 1.0])
    current = Candidate(effects["water_current"], fit, -500.0, 0.3, False, False, claims=("vel_east_mps",))
    turning = Candidate(effects["manoeuvring"], fit, -300.0, 0.2, False, False, claims=("yaw_rate_radps",))
    shape = Candidate(effects["resistance_shape"], fit, -50.0, 0.1, False, False, claims=("vel_north_mps",))
    named = [current, turning, shape]

    def left(signal: str, misfit: float) -> list[Signature]:
        return [Signature(signal, misfit, 0.3, ("speed",), 10.0)]

    assert withheld(named, []) == [] and withheld(named, [], misfit=True) == []
    assert withheld(named, left("yaw_rate_radps", 2.1)) == [turning, shape]  # the first named stands
    assert withheld(named, left("vel_east_mps", 2.1)) == named
    assert withheld(named, left("heading_rad", 5.0)) == []  # structure in a signal no cause claims: unexplained
    turning.share = 0.9
    assert withheld(named, left("yaw_rate_radps", 1.9)) == []  # structure within 2x the noise, 90 % removed: stands
    turning.share = 0.15  # named by the share rule's "within 2x" clause, structure left in its signal: withheld
    assert withheld(named, left("yaw_rate_radps", 1.9)) == [turning, shape]
    turning.pair_share = 0.8  # it and the cause named with it remove 80 %: stands
    assert withheld(named, left("yaw_rate_radps", 1.9)) == []
    assert withheld(named, left("yaw_rate_radps", 1.9), misfit=True) == named  # live: the twin misfits
    assert withheld(named, left("vel_east_mps", 5.0), misfit=False) == []  # live: the twin fits


def test_the_projection_replays_a_part_of_the_windows_at_a_time_with_the_same_numbers(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 37: the initial-state projection's 13 replays run PROJECTION_WINDOWS windows at a time, so their
    paths' memory does not grow with the trial; every window's sensitivity, horizon and inverse are those of one
    replay of all windows, bit for bit, and the traced peak is a fraction of it."""
    import tracemalloc

    from boat_twin.diagnose import initial_state
    from boat_twin.diagnose.search import white_noise_stdev

    trial = read_trial(Path(__file__).resolve().parents[1] / "bags" / "thrust_steps_sample")
    windows = cut_windows(trial, 20.0)
    sigma = {s: white_noise_stdev(windows.measured[s]) for s in SIGNALS}
    made, peaks = [], []
    for at_a_time in (10**6, 7):
        monkeypatch.setattr(initial_state, "PROJECTION_WINDOWS", at_a_time)
        initial_state.InitialStateProjection.for_model(windows, TwinConfig(), sigma)  # compiled, caches filled
        tracemalloc.start()
        made.append(initial_state.InitialStateProjection.for_model(windows, TwinConfig(), sigma))
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    whole, parts = made
    assert windows.start_index.size > 4 * 7
    for name in ("sensitivity", "compared", "inverse", "stdev"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)
    assert peaks[1] < 0.4 * peaks[0], peaks
