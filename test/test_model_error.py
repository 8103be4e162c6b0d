"""The diagnosis against the twin's own error (issue 42): twin.yaml's ``model_error`` section, its measurement on
clean recordings, and the diagnosis that compares a recording's misfit with it — on a boat written apart from the
twin (test/real_like.py: its own equations, integrator and waves)."""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from boat_twin.config import TwinConfig, config_from_dict, config_to_dict, load_config, load_twin_config
from boat_twin.diagnose.effects import catalogue
from boat_twin.diagnose.model_error import measure_model_error, normal_misfit, structure_folds, yardstick
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.diagnose.search import FOLDS, RELEASED, Candidate, Fit, _wind_ambiguity, misfit_share
from boat_twin.diagnose.structure import R2_THRESHOLD, structure_r2
from boat_twin.errors import InputError
from boat_twin.fleet.twin_error import identified_model_error
from boat_twin.ident.manoeuvring import fit_manoeuvring
from boat_twin.ident.pipeline import identify_trials
from boat_twin.ident.report import identified_twin
from boat_twin.io.trial import Trial
from boat_twin.model_error import ModelError, SignalError
from boat_twin.twin.replay import LONGITUDINAL_ACCEL, MOTION_SIGNALS, SIGNALS, cut_windows

sys.path.insert(0, str(Path(__file__).resolve().parent))
from real_like import Boat, Hidden, simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FACTS = {"length_m": 5.5, "beam_m": 2.3, "engine_x_m": -2.4, "engine_y_m": 0.5,
         "max_steering_rad": math.radians(30.0),
         "steering_rate_radps": math.radians(20.0), "bollard_thrust_N": 1800.0, "engine_power_W": 80000.0,
         "mass_kg": 950.0}
"""The real-like boat as its user states it: dimensions, engines and mass, not its hydrodynamics."""


def test_a_twin_yaml_without_the_section_has_zero_model_error_and_writes_none() -> None:
    config = load_config(ROOT / "config" / "boat.yaml")
    assert config.model_error.zero and config.model_error == ModelError()
    assert "model_error" not in config_to_dict(config)


def test_the_section_round_trips() -> None:
    error = ModelError((("vel_east_mps", SignalError(0.1, 0.02, 0.5, 4.0, 0.1)),
                        ("heading_rad", SignalError(0.03, 0.0, 0.2, 6.0, 0.0))), 3, True)
    config = replace(TwinConfig(), model_error=error)
    data = config_to_dict(config)
    assert data["model_error"]["signals"]["vel_east_mps"]["per_speed"] == 0.02
    assert config_from_dict(data, "t.yaml") == config
    assert error.of("yaw_rate_radps").zero  # a signal not described has none


@pytest.mark.parametrize(("section", "message"), [
    ([1], "t.yaml: 'model_error' must be a mapping"),
    ({"signals": {"speed": {}}}, "t.yaml: model_error.signals: unknown signal 'speed'"),
    ({"signals": {"heading_rad": {"floor": -1.0}}}, "t.yaml: model_error.signals.heading_rad.floor must be"),
    ({"signals": {"heading_rad": {"spread": 1.0}}}, "t.yaml: model_error.signals.heading_rad: unknown field 'spread'"),
    ({"recordings": "3"}, "t.yaml: model_error.recordings must be a count"),
    ({"sigma": 1}, "t.yaml: unknown model_error field 'sigma'"),
])
def test_a_bad_section_is_named(section: object, message: str) -> None:
    with pytest.raises(InputError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        config_from_dict({"model_error": section}, "t.yaml")


def test_a_bad_section_in_twin_yaml_is_one_line_exit_2(tmp_path: Path) -> None:
    from processes import BOAT_TWIN, one_error_line, run_as_from_a_shell

    path = tmp_path / "twin.yaml"
    path.write_text("model_error:\n  signals:\n    heading_rad: {floor: .nan}\n")
    done = run_as_from_a_shell([BOAT_TWIN, "simulate", "thrust-steps", "--duration", "1", "--config", str(path)], 120)
    assert done.returncode == 2
    assert f"{path}: model_error.signals.heading_rad.floor must be a finite number" in one_error_line(done.stderr)


def test_zero_model_error_keeps_the_noise_as_the_yardstick() -> None:
    trial = simulate(Boat(), Hidden(), 130.0, 7)
    windows = cut_windows(trial)
    sigma = {s: 0.1 * (i + 1) for i, s in enumerate(SIGNALS)}
    assert yardstick(windows, sigma, ModelError()) == sigma
    assert np.all(normal_misfit(windows, ModelError()) == 1.0)
    dealt = np.arange(windows.t_s.shape[1]) % FOLDS
    assert np.array_equal(structure_folds(dealt, ModelError()), dealt)  # the structure test's folds as before


def _identified(trials: list[Trial]) -> TwinConfig:
    """``identify --boat`` (resistance, mass) then ``identify --manoeuvring`` (the turning coefficients)."""
    _, found = identify_trials(trials, boat=FACTS)
    twin = identified_twin(found)
    assert twin is not None
    return fit_manoeuvring(trials, twin).config


@pytest.fixture(scope="module")
def described() -> TwinConfig:
    """The twin a user gets from two clean recordings of the real-like boat, with its model error held out (each
    recording predicted by the twin identified from the other)."""
    trials = [simulate(Boat(), Hidden(), 180.0, seed) for seed in (11, 12)]
    folds = [_identified([trials[1]]), _identified([trials[0]])]
    return replace(_identified(trials), model_error=measure_model_error(trials, folds, heldout=True))


def test_identify_measures_the_error_held_out_for_twin_yaml() -> None:
    trials = [simulate(Boat(), Hidden(), 130.0, seed) for seed in (31, 32)]
    options = {"boat": FACTS}
    _, found = identify_trials(trials, **options)
    error, how = identified_model_error(trials, found, options)
    assert error is not None and error.recordings == 2 and error.heldout
    assert "each of 2 recordings predicted by the twin identified from the others" in how
    assert error.of("vel_east_mps").stdev(np.array([6.0]), np.array([0.1]))[0] > 3 * 0.05  # the GNSS velocity noise
    twin = identified_twin(found, error)
    assert twin is not None and config_from_dict(config_to_dict(twin), "twin.yaml").model_error == error
    one, how = identified_model_error(trials[:1], found, options)
    assert one is None and "two or more recordings" in how  # one recording: no held-out error, none written


def test_the_measured_error_is_many_times_the_noise_and_correlated(described: TwinConfig) -> None:
    error = described.model_error
    assert error.recordings == 2 and error.heldout
    windows = cut_windows(simulate(Boat(), Hidden(), 130.0, 13))
    speed, rate = np.array([6.0]), np.array([0.1])
    assert error.of("vel_east_mps").stdev(speed, rate)[0] > 2 * 0.05  # the GNSS velocity noise
    assert error.of("yaw_rate_radps").stdev(speed, rate)[0] > 3 * math.radians(0.06)  # the gyro's
    for signal in ("vel_east_mps", "yaw_rate_radps"):
        assert error.of(signal).correlation_time_s > 1.0  # an error over seconds, not white noise
    normal = dict(zip(SIGNALS, normal_misfit(windows, error), strict=True))
    assert all(normal[s] > 1.0 for s in MOTION_SIGNALS)
    assert normal[LONGITUDINAL_ACCEL] == 1.0  # the recordings log no accelerometer: no error, the noise's rule


@pytest.mark.parametrize(("hidden", "effect", "parameter", "size"), [
    (Hidden(delay_s=0.5), "command_delay", "delay_s", 0.5),
    (Hidden(heading_offset_rad=math.radians(8.0)), "heading_offset", "offset_rad", math.radians(8.0)),
    (Hidden(), None, None, 0.0),
])
def test_against_the_twins_own_error_a_hidden_effect_is_named_and_a_clean_file_is_silent(
        described: TwinConfig, hidden: Hidden, effect: str | None, parameter: str | None, size: float) -> None:
    trial = simulate(Boat(), hidden, 180.0, 22)
    against_noise = diagnose_trial(trial, replace(described, model_error=ModelError())).result
    assert against_noise["unexplained"]  # the rule before issue 42: the twin's ordinary error is "unexplained"
    result = diagnose_trial(trial, described).result
    assert result["ambiguous"] is None and not result["unexplained"]
    assert result["model_error"]["recordings"] == 2
    assert [v["effect"] for v in result["verdict"]] == ([effect] if effect else [])
    if effect and parameter:
        found = result["verdict"][0]["parameters"][parameter]
        low, high = result["verdict"][0]["ci95"][parameter]
        assert abs(found - size) < 0.25 * size and low < found < high


@pytest.mark.parametrize(("seed", "named"), [(20, "water_current"), (21, "water_current"), (26, "water_current"),
                                             (29, None)])
def test_a_hidden_current_is_never_named_a_wind_against_the_twins_own_error(
        described: TwinConfig, seed: int, named: str | None) -> None:
    """Issue 42: the real-like boat has no wind, and a 0.35 m/s current it drifts in was named a 7-10 m/s wind:
    on many headings a wind drifts the boat much as a current sets it. Where the wind removes only part of the
    misfit (seed 21: 63 %, seed 29: 38 %) the share rule's "leaves them within 2×" clause named it beside the
    current, both ``ambiguous``; against the twin's model error that clause reads "within its normal misfit", which
    the wind does not reach (seed 21: north velocity m² 1.89 against 1.66). Seed 21: the current alone (73 %);
    seed 26 (a wind alone once): the current, best by ΔBIC (−69 against −14) and held out (31 % against 9 %); seed
    29: neither removes 70 % or leaves the velocity normal (the current 68 %): nothing named, nothing wrong."""
    result = diagnose_trial(simulate(Boat(), Hidden(current_mps=(0.25, -0.25)), 180.0, seed), described).result
    assert "wind" not in [v["effect"] for v in result["verdict"]]
    assert [v["effect"] for v in result["verdict"]] == ([named] if named else []) and result["ambiguous"] is None


def test_a_wind_and_a_current_the_held_out_windows_do_not_tell_apart_are_ambiguous() -> None:
    """The held-out side of the wind's ambiguity (issue 42): both would be named, the wind best by ΔBIC but the
    current's held-out gain as high or higher (35 % against 31 %): neither is named. A current whose gain the
    wind's trails by more than :data:`MIN_HELDOUT_GAIN` is the verdict."""
    effects = catalogue(load_twin_config(), np.linspace(0.5, 6.0, 20))
    fit = _judged({}, np.full(len(SIGNALS), 100.0))

    def judged(name: str, delta_bic: float, gain: float) -> Candidate:
        return Candidate(effects[name], fit, delta_bic, 1.0, False, False, heldout_gain=gain)

    wind, current = judged("wind", -60.0, 0.31), judged("water_current", -50.0, 0.35)
    assert _wind_ambiguity([wind, current], wind, one_heading=False) == [wind, current]
    ahead = judged("water_current", -70.0, 0.35)
    assert _wind_ambiguity([wind, ahead], ahead, one_heading=False) == []
    assert _wind_ambiguity([wind, ahead], ahead, one_heading=True) == [ahead, wind]  # one heading: never apart


def test_the_twins_own_error_on_one_manoeuvre_across_two_windows_is_no_structure(described: TwinConfig) -> None:
    """Issue 42's false alarm: on clean 300 s recording 3004 the twin turns about 0.01 rad/s too fast through one
    command hold at 5-9 m/s heading north (t 40-80 s, two windows), and its east velocity drifts the same way in
    both. Dealt folds put the two windows in different folds, so each "predicts" the other held out: the east
    velocity's held-out R² on the heading × time rises above the threshold and a clean file came back
    ``unexplained``. Against a model error the structure test's folds are stretches of consecutive windows
    (``structure_folds``): the twin's normal error is no structure, and the file is silent."""
    diagnosis = diagnose_trial(simulate(Boat(), Hidden(), 300.0, 3004), described)
    result = diagnosis.result
    assert result["verdict"] == [] and result["ambiguous"] is None
    assert not result["unexplained"] and result["signature"] == []
    residuals = diagnosis.selection.final.residuals
    dealt = np.arange(diagnosis.windows.t_s.shape[1]) % FOLDS
    stretches = structure_folds(dealt, described.model_error)
    assert sorted(np.unique(stretches)) == sorted(np.unique(dealt)) and np.all(np.diff(stretches) >= 0)
    leaked = structure_r2(diagnosis.windows, residuals.values, residuals.prediction, dealt)["vel_east_mps"]
    held = structure_r2(diagnosis.windows, residuals.values, residuals.prediction, stretches)["vel_east_mps"]
    assert leaked > R2_THRESHOLD > held  # the neighbour's leak, and no structure without it


@pytest.mark.slow
def test_the_twins_own_error_does_not_reach_across_a_stretchs_boundary() -> None:
    """Stretches still meet their neighbours at their ends: on clean recording 3013, against the twin the
    real-like study trains (three 300 s recordings, the boat's facts without its mass), the north velocity's
    held-out R² was 0.16 with stretches (threshold 0.15), the neighbouring windows of each held-out stretch
    carrying the twin's error on the same manoeuvre into its training, and the file came back ``unexplained``.
    Leaving those neighbours out of the stretch's training (h-block cross-validation) it is no structure."""
    trials = [simulate(Boat(), Hidden(), 300.0, 1000 + k) for k in range(3)]
    facts = {k: v for k, v in FACTS.items() if k != "mass_kg"}

    def identified(chosen: list[Trial]) -> TwinConfig:
        _, found = identify_trials(chosen, boat=facts)
        twin = identified_twin(found)
        assert twin is not None
        return fit_manoeuvring(chosen, twin).config

    folds = [identified(trials[:k] + trials[k + 1:]) for k in range(3)]
    twin = replace(identified(trials), model_error=measure_model_error(trials, folds, heldout=True))
    diagnosis = diagnose_trial(simulate(Boat(), Hidden(), 300.0, 3013), twin)
    result = diagnosis.result
    assert (result["verdict"], result["ambiguous"], result["unexplained"]) == ([], None, False), result["signature"]
    residuals = diagnosis.selection.final.residuals
    stretches = structure_folds(np.arange(diagnosis.windows.t_s.shape[1]) % FOLDS, twin.model_error)
    reached = structure_r2(diagnosis.windows, residuals.values, residuals.prediction, stretches)["vel_north_mps"]
    held = structure_r2(diagnosis.windows, residuals.values, residuals.prediction, stretches,
                        buffered=True)["vel_north_mps"]
    assert reached > R2_THRESHOLD > held


def _judged(misfit: dict[str, float], floor: np.ndarray) -> Fit:
    """A fit whose held-out SSE is ``misfit`` (signal → mean square over the yardstick; 3 elsewhere) × ``floor``."""
    sse = np.array([misfit.get(s, 3.0) for s in SIGNALS]) * floor
    return Fit(effects=[], values=np.zeros(0), stderr=np.zeros(0), sse=sse, heldout_sse=sse, residuals=RELEASED)


def test_within_the_factor_means_within_the_twins_normal_misfit_where_that_is_lower() -> None:
    """Issue 42: after both engines' 0.85× a 4 m/s wind removed 24 % of what was left (north velocity 1.94 → 1.74,
    yaw rate 1.45 → 1.28, heading 1.33 → 1.24, mean squares over the yardstick) and was named by the share rule's
    "leaves them within 2×" clause. Against the twin's normal misfit (1.48, 1.46, 1.29 there) it leaves the north
    velocity beyond it: not within, and with 24 % it is a candidate. With no model error (normal misfit 1) the
    clause is 2× the noise: today's rule."""
    floor = np.full(len(SIGNALS), 2000.0)
    claimed = ("vel_north_mps", "yaw_rate_radps", "heading_rad")
    old = _judged(dict(zip(claimed, (1.94, 1.45, 1.33), strict=True)), floor)
    new = _judged(dict(zip(claimed, (1.74, 1.28, 1.24), strict=True)), floor)
    normal = np.array([{"vel_east_mps": 1.54, "vel_north_mps": 1.48, "yaw_rate_radps": 1.46,
                        "heading_rad": 1.29}.get(s, 1.0) for s in SIGNALS])
    claims, share, within = misfit_share(new, old, floor, normal)
    assert claims == claimed and share < 0.3 and not within
    assert misfit_share(new, old, floor, np.ones(len(SIGNALS)))[2]  # no model error: within 2×
    assert misfit_share(new, old, floor)[2]
    back = _judged(dict(zip(claimed, (1.3, 1.2, 1.1), strict=True)), floor)  # a cause leaving them normal
    assert misfit_share(back, old, floor, normal)[2]


def test_the_live_rolling_diagnosis_judges_its_window_against_the_same_error(described: TwinConfig) -> None:
    from boat_twin.shadow.rolling import DiagnosisJob

    window = simulate(Boat(), Hidden(delay_s=0.5), 130.0, 23)
    causes, withheld, structure_left = DiagnosisJob(130.0, 0.0, window, described).compute()
    assert [c.name for c in causes] == ["command_delay"] and not withheld and not structure_left
    outcome = DiagnosisJob(130.0, 0.0, window, replace(described, model_error=ModelError())).compute()
    assert [c.name for c in outcome[0]] != ["command_delay"] or outcome[2]


def test_identify_out_writes_the_model_error_into_twin_yaml(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                                            ) -> None:
    from boat_twin.cli import main

    bags = []
    for seed in ("1", "2"):
        bags.append(str(tmp_path / f"random{seed}.mcap"))
        assert main(["simulate", "random", "--duration", "130", "--seed", seed, "--out", bags[-1]]) == 0
    assert main(["identify", *bags, "--out", str(tmp_path / "two")]) == 0
    assert "model error measured: each of 2 recordings" in capsys.readouterr().err
    error = load_config(tmp_path / "two" / "twin.yaml").model_error
    assert error.recordings == 2 and error.heldout and not error.zero
    assert main(["identify", bags[0], "--out", str(tmp_path / "one")]) == 0
    assert "no model error measured (twin.yaml without one)" in capsys.readouterr().err
    assert load_config(tmp_path / "one" / "twin.yaml").model_error.zero
