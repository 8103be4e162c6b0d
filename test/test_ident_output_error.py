"""The output-error surge identification on boats the twin did not make (test/independent.py's plain RK4): a small
boat with short holds and a reversing stretch, a closed-loop speed controller, slow ramps that leave the mass
unidentified; the physical checks; interval coverage over a handful of seeds (the full study:
benchmarks/bench_ident_coverage.py)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from independent import rk4_held

from boat_twin.ident import pipeline
from boat_twin.ident.output_error import (
    ResistanceBasis,
    SurgeRecord,
    autocorrelation,
    fit_surge,
    identify_surge,
    predict,
    rice_mean,
    speed_noise_mps,
    spline_basis,
    split_segments,
)

DT_S = 0.1
NOISE_MPS = 0.05


def small_boat_resistance_N(u: np.ndarray | float) -> np.ndarray:
    """A 20 kg survey boat's Fc: linear + quadratic + a plateau near 1 m/s (N); odd in u."""
    a = np.abs(np.asarray(u, dtype=float))
    return np.sign(u) * (4.0 * a + 3.0 * (np.tanh((a - 1.0) / 0.35) + np.tanh(1.0 / 0.35)) + 5.0 * a**2)


def run_boat(thrust_N: np.ndarray, mass_kg: float, rng: np.random.Generator,
             controller=None) -> tuple[SurgeRecord, np.ndarray]:
    """10 Hz samples of m·du/dt = T − Fc(u) (RK4, 10 substeps), T held per sample (or from ``controller(t,
    measured speed)``); GNSS speed over ground |(u, 0) + white noise per axis|. Returns the record and the true
    speed."""
    n = thrust_N.size if controller is None else int(controller.duration_s / DT_S)
    t = np.arange(n) * DT_S
    thrust = np.empty(n)
    u = np.empty(n)
    measured = np.empty(n)
    state = np.array([0.0])
    for k in range(n):
        u[k] = state[0]
        measured[k] = np.hypot(state[0] + rng.normal(0.0, NOISE_MPS), rng.normal(0.0, NOISE_MPS))
        thrust[k] = thrust_N[k] if controller is None else controller(t[k], measured[k])
        state = _step(state, thrust[k], mass_kg)
    return SurgeRecord(t, thrust, measured), u


def _step(state: np.ndarray, force_N: float, mass_kg: float) -> np.ndarray:
    """One 0.1 s sample interval of the independent RK4 (10 substeps)."""
    deriv = lambda s, f: np.array([(f - float(small_boat_resistance_N(s[0]))) / mass_kg])  # noqa: E731
    rows = rk4_held(deriv, state, np.array([force_N, force_N]), DT_S / 10, 10)
    return rows[-1]


def short_holds(rng: np.random.Generator, duration_s: float = 400.0) -> np.ndarray:
    """Random thrust levels -20..45 N held 5-20 s, one reversing hold at -25 N in the middle."""
    levels, t = [], 0.0
    while t < duration_s:
        hold = rng.uniform(5.0, 20.0)
        level = -25.0 if abs(t - duration_s / 2) < 10.0 else rng.uniform(0.0, 45.0)
        levels += [level] * int(hold / DT_S)
        t += hold
    return np.array(levels[: int(duration_s / DT_S)])


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


@pytest.fixture(scope="module")
def small_boat() -> tuple[SurgeRecord, np.ndarray, object]:
    rng = np.random.default_rng(3)
    record, truth = run_boat(short_holds(rng), 20.0, rng)
    return record, truth, identify_surge([record])


def test_small_boat_with_short_holds_and_reversing_resimulates_like_the_truth(small_boat) -> None:
    record, truth, result = small_boat
    segment = split_segments([record])[0]
    expected, _ = rice_mean(truth, speed_noise_mps(record.speed_mps))  # the true model's expected measurement
    truth_error = rmse(expected, record.speed_mps)
    selected = rmse(predict(result.selected, record, segment), record.speed_mps)
    baseline = rmse(predict(result.baseline, record, segment), record.speed_mps)
    assert np.min(truth) < -0.3  # the boat went astern
    assert selected <= 1.1 * truth_error and selected <= baseline
    assert result.selected.mass_kg == pytest.approx(20.0, rel=0.1)
    lo, hi = result.selected.mass_ci95_kg
    assert lo < 20.0 < hi and result.mass_identified


def test_small_boat_curve_is_physical_and_close_to_the_truth(small_boat) -> None:
    record, truth, result = small_boat
    model = result.selected.resistance_model()
    grid = np.linspace(0.0, float(np.max(np.abs(truth))), 100)
    force = model.force_N(grid)
    assert force[0] == 0.0 and np.all(np.diff(force) >= 0.0)
    assert rmse(force, small_boat_resistance_N(grid)) < 0.05 * float(small_boat_resistance_N(grid[-1]))
    assert model.force_N(-1.0) == -model.force_N(1.0)


class SpeedController:
    """A PI speed controller (as an autopilot's cruise control) stepping its set-point every 40 s."""

    duration_s = 400.0

    def __init__(self) -> None:
        self.integral = 0.0
        self.setpoints = (0.6, 1.5, 0.9, 2.0, 1.2, 0.4, 1.8, 1.0, 2.2, 0.8)

    def __call__(self, t_s: float, speed_mps: float) -> float:
        error = self.setpoints[int(t_s // 40.0) % len(self.setpoints)] - speed_mps
        self.integral += error * DT_S
        return float(np.clip(40.0 * error + 15.0 * self.integral, -20.0, 60.0))


def test_closed_loop_speed_controller_trial() -> None:
    rng = np.random.default_rng(5)
    record, truth = run_boat(np.empty(0), 20.0, rng, SpeedController())
    result = identify_surge([record])
    assert result.selected.mass_kg == pytest.approx(20.0, rel=0.1)
    grid = np.linspace(0.3, 2.0, 30)
    assert rmse(result.selected.resistance_N(grid), small_boat_resistance_N(grid)) < 1.0  # N, of 13-35 N
    assert pipeline.physical_problems(result.selected, [], [(record.t_s, record.thrust_N, record.speed_mps)]) == []


def test_slow_ramps_leave_the_mass_unidentified_and_say_so() -> None:
    """A 5-minute ramp (300 surge time constants): the mass's 95 % interval, -60 to 176 kg about 58, is far
    wider than ± half of it (with 10 minutes, -508 to 626 kg: the same verdict for twice the CPU)."""
    rng = np.random.default_rng(2)
    ramp = 40.0 * (0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, 3000)))  # 0 to 40 N over 5 min, τ ≈ 1 s
    record, _ = run_boat(ramp, 20.0, rng)
    samples = pipeline.identify_arrays(record.t_s, record.thrust_N, record.speed_mps)  # identify_surge inside
    result = samples["output_error"]
    assert not result["mass_identified"] and "do not identify the mass" in result["mass_note"]
    assert "effective_mass_kg" not in samples["model"]
    assert any("do not identify the mass" in w for w in samples["warnings"])
    held = identify_surge([record], mass_kg=20.0)
    assert held.selected.mass_fixed and held.selected.mass_kg == 20.0


def test_a_resistance_above_the_thrust_that_held_a_speed_is_not_physical() -> None:
    t = np.arange(0.0, 60.0, DT_S)
    record = SurgeRecord(t, np.full(t.size, 41.0), np.full(t.size, 1.5))
    fit = fit_surge([SurgeRecord(t, np.where(t < 30, 20.0, 60.0), np.where(t < 30, 1.0, 1.5))],
                    ResistanceBasis(), mass_kg=20.0)
    fit.coefficients[:] = (45.0, 0.0)  # Fc(1.0 m/s) = 45 N
    problems = pipeline.physical_problems(fit, [{"speed_mps": 1.0, "thrust_N": 20.0}],
                                          [(record.t_s, record.thrust_N, record.speed_mps)])
    assert any("above the 20 N that held that speed" in p for p in problems)
    assert any("exceeds the largest thrust: 41 N, yet the boat sustained 1.50 m/s" in p for p in problems)


@pytest.mark.slow  # a study over six boats (11 s on the loaded machine); seed 0's interval: test_ident_trials.py
def test_interval_coverage_over_seeds() -> None:
    """Mass intervals of the richest candidate (12 I-splines) hold the truth on at least 5 of 6 independent boats
    (95 % nominal: P(≤ 4 of 6) = 3 %; measured 5 of 6, the sixth 0.7 % off: the basis' approximation of the
    plateau biases the mass of a clean, precise trial by a few tenths of a percent — docs/identification.md)."""
    held = 0
    for seed in range(6):
        rng = np.random.default_rng(100 + seed)
        mass = float(rng.uniform(15.0, 60.0))
        record, _ = run_boat(short_holds(rng, 300.0), mass, rng)
        lo, hi = fit_surge([record], spline_basis(record.speed_mps, 12)).mass_ci95_kg
        held += lo <= mass <= hi
    assert held >= 5


def test_scenarios_are_carried_to_a_30_kg_boat() -> None:
    """The built-in scenarios derive their levels and speeds from the configured boat: on a 30 kg boat with 25 N
    per engine no command saturates it and no manoeuvre starts above its top speed; the 6 m boat's own
    staircase on it gets the warning."""
    from boat_twin.vessel.params import VesselParams, similar_boat, top_speed_mps
    from boat_twin.vessel.resistance import PowerSeriesResistance
    from boat_twin.vessel.scenarios import SCENARIOS, scenario_warnings, thrust_steps

    boat = similar_boat(PowerSeriesResistance((0.0, 4.0, 6.0), 2.5), 30.0, {"bollard_thrust_N": 25.0})
    for name, factory in SCENARIOS.items():
        scenario = factory(boat, np.random.default_rng(0))
        assert scenario_warnings(boat, scenario) == [], name
        assert scenario.initial_surge_mps <= top_speed_mps(boat), name
    levels = thrust_steps(boat).values[:, :2].sum(axis=1)
    assert 0.0 < levels.max() <= 2 * 25.0 and len(set(levels)) == 11  # ten levels and the idle
    assert any("saturate" in w for w in scenario_warnings(boat, thrust_steps(VesselParams())))


def test_a_short_plateau_trial_selects_a_curve_that_resimulates_like_the_truth() -> None:
    """test/data/plateau_short_holds.npz: 150 s of random holds (0.5-6 surge time constants) on an 86 kg boat whose
    resistance has a plateau at 40 % of its 5.7 m/s top speed, integrated by scipy's RK45 with waves and GNSS
    noise (benchmarks/bench_ident_coverage.py --seed 0, trial 17, written by the project). Cross-validated on four
    time blocks the training blocks missed whole speed ranges and a 5-term curve re-simulated 2.2× worse than the
    true model; the selected curve must do within 1.1× of it."""
    data = np.load(Path(__file__).parent / "data" / "plateau_short_holds.npz")
    record = SurgeRecord(data["t_s"], data["thrust_N"], data["speed_mps"])
    result = identify_surge([record])
    segment = split_segments([record])[0]
    truth_error = rmse(np.abs(data["true_speed_mps"]), record.speed_mps)
    assert rmse(predict(result.selected, record, segment), record.speed_mps) <= 1.1 * truth_error
    lo, hi = result.selected.mass_ci95_kg
    assert lo <= float(data["mass_kg"]) <= hi


def test_a_fit_whose_trust_region_reaches_a_stiff_near_massless_point_is_not_a_traceback(tmp_path) -> None:
    """The default twin's first 100 s of thrust steps (low speeds only): the solver tried masses of a few grams,
    where the speed's sensitivities reach 1e200 (or overflow) and scipy's SVD raised ValueError out of
    ``identify`` (issue 24). Such a point is now a failed step; the fit finds the twin's surge mass."""
    from boat_twin.config import TwinConfig
    from boat_twin.io.bags import write_bag
    from boat_twin.io.sources import read_trial_file
    from boat_twin.twin import run_sea_trial, trial_messages
    from boat_twin.vessel import make_scenario

    config = TwinConfig()
    run = run_sea_trial(config, make_scenario("thrust-steps", config.vessel, np.random.default_rng(0),
                                              duration_s=100.0), seed=0)
    write_bag(tmp_path / "short.mcap", trial_messages(run, truth=False))
    t_s, thrust, speed = pipeline.trial_samples(read_trial_file(tmp_path / "short.mcap"))
    result = identify_surge([SurgeRecord(t_s, thrust, speed)])
    m11 = config.vessel.mass_kg * (1.0 + config.vessel.surge_added_mass_ratio)
    assert result.selected.mass_kg == pytest.approx(m11, rel=0.15)


def test_a_coupling_force_s_scale_is_fitted_beside_the_mass() -> None:
    """A boat the twin did not make (m·du/dt = T + C − 150·u − 15·u|u|, 1,400 kg, the tests' RK4) whose further
    force C (a turning boat's sway-yaw coupling, swinging with its turns) the record gives 10 % low, as a sway
    model a little off does: the fit estimates the scale (1/0.9) and holds the mass and the curve; taken as
    given, the same record's force misleads the mass by over 1 %, outside its interval."""
    rng = np.random.default_rng(2)
    thrust = np.repeat(rng.uniform(300.0, 1500.0, 40), 150)
    t = np.arange(thrust.size) * DT_S
    coupling = -200.0 - 150.0 * np.sin(2 * np.pi * t / 23.0) * (np.sin(2 * np.pi * t / 170.0) > 0)

    def deriv(state: np.ndarray, force: float) -> np.ndarray:
        return np.array([(force - 150.0 * state[0] - 15.0 * state[0] * abs(state[0])) / 1400.0])

    speed = rk4_held(deriv, np.array([4.0]), thrust + coupling, DT_S / 10, 10)[:, 0]
    record = SurgeRecord(t, thrust, speed, 0.9 * coupling)
    fit = fit_surge([record], spline_basis(speed, 5))
    assert fit.coupling_scale == pytest.approx(1 / 0.9, rel=5e-3)
    assert fit.mass_kg == pytest.approx(1400.0, rel=2e-3)
    speeds = np.quantile(speed, [0.05, 0.5, 0.95])
    np.testing.assert_allclose(fit.resistance_N(speeds), 150.0 * speeds + 15.0 * speeds**2, rtol=2e-3)
    given = fit_surge([SurgeRecord(t, thrust + 0.9 * coupling, speed)], spline_basis(speed, 5))
    assert abs(given.mass_kg / 1400.0 - 1) > 0.01 and not given.mass_ci95_kg[0] <= 1400.0 <= given.mass_ci95_kg[1]


def _constant_thrust_zigzag(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A boat the twin did not make (surge-sway-yaw written here, the tests' RK4; m₁₁ 840 kg, m₂₂ 1,500 kg) on a
    300 s 20°/20° zigzag at a constant 400 N per outboard: times s, the surge thrust 2T·cos δ (N), the measured
    surge (m/s, GNSS noise 0.05 m/s) and the true sway-yaw coupling m₂₂·v·r over each interval (N). The speed
    changes only where the coupling acts (5-6 m/s, drift up to 11°)."""
    m11, m22, m33 = 840.0, 1500.0, 2600.0

    def deriv(state: np.ndarray, delta: float) -> np.ndarray:
        u, v, r = state
        fx, fy = 800.0 * np.cos(delta), 800.0 * np.sin(delta)
        return np.array([(fx + m22 * v * r - 60.0 * u - 9.0 * u * abs(u)) / m11,
                         (fy - m11 * u * r - 250.0 * abs(u) * v) / m22, (-2.3 * fy - 600.0 * abs(u) * r) / m33])

    t = np.arange(3000) * DT_S
    delta = np.radians(20.0) * np.where((t // 12.0) % 2, 1.0, -1.0)
    u, v, r = rk4_held(deriv, np.array([6.0, 0.0, 0.0]), delta, DT_S / 10, 10).T
    coupling = m22 * v * r
    measured = u + np.random.default_rng(seed).normal(0.0, NOISE_MPS, t.size)
    return t, 800.0 * np.cos(delta), measured, np.append(0.5 * (coupling[:-1] + coupling[1:]), coupling[-1])


def test_a_prior_on_the_coupling_scale_gives_constant_thrust_zigzags_their_mass() -> None:
    """At constant thrust the mass is seen only in the speed each turn costs, where the coupling m₂₂·v·r acts, so
    the mass and the coupling's scale c are confounded: fitted free, c carries an interval of ±10-15 % and the
    mass one over ±15 %. The record's coupling 2 % low (a sway model a little off): with a prior c ~ N(1, 0.03²)
    (a turning model known to 3 %), the mass interval is a few per cent wide and holds the truth, and the prior
    is what fixes c (its posterior deviation no smaller than the prior's: the data say nothing of c alone)."""
    t, thrust, measured, coupling = _constant_thrust_zigzag(0)
    record = SurgeRecord(t, thrust, measured, 0.98 * coupling)
    free = fit_surge([record], spline_basis(measured, 5))
    low, high = free.mass_ci95_kg
    assert free.coupling_scale_sd > 0.05 and (high - low) / 2 > 0.15 * free.mass_kg
    assert free.coupling_prior_sd == 0.0
    fit = fit_surge([record], spline_basis(measured, 5), coupling_sd=0.03)
    low, high = fit.mass_ci95_kg
    assert low <= 840.0 <= high and (high - low) / 2 < 0.08 * fit.mass_kg, (fit.mass_kg, low, high)
    assert fit.coupling_prior_sd == 0.03 and fit.coupling_scale_sd == pytest.approx(0.03, rel=0.1)
    assert fit.to_dict()["coupling_prior_sd"] == 0.03


def test_the_autocorrelation_is_the_direct_sum_to_rounding() -> None:
    """The FFT autocorrelation (zero-padded: no wrap-around) equals Σ c_i·c_(i+k) / Σ c_i² summed directly."""
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 1000, 4099):
        values = np.cumsum(rng.normal(size=n)) * 0.01 + rng.normal(size=n) + 5.0
        centred = values - values.mean()
        direct = np.correlate(centred, centred, "full")[n - 1:] / max(float(centred @ centred), 1e-300)
        np.testing.assert_allclose(autocorrelation(values), direct, rtol=0.0, atol=1e-12)
    assert np.all(autocorrelation(np.full(50, 2.0)) == 0.0)


def test_the_autocorrelation_of_a_six_hour_record_takes_a_moment() -> None:
    """O(n log n): 6 h at 10 Hz, five times over, in well under the ~2 min one direct O(n²) sum takes (issue 37:
    ``identify`` of a 6-hour trial spent its cross-validation there)."""
    residual = np.random.default_rng(4).normal(size=6 * 3600 * 10)
    start = time.process_time()
    for _ in range(5):
        autocorrelation(residual)
    assert time.process_time() - start < 10.0


def test_richer_bases_start_from_the_simpler_fit_and_select_as_a_scan_does(small_boat, monkeypatch) -> None:
    """Only the baseline's fits scan 13 trial masses; every richer basis starts its mass from the previous basis'
    fit to the same training data (issue 37: the scans were a third of identify's CPU). The candidates' held-out
    errors, the selection and the selected fit are those of fits that each start from their own scan."""
    from boat_twin.ident import output_error

    record, _, warm = small_boat
    scans = []
    own_guess = output_error._initial_guess

    def counted(problem, mass_start_kg=None):
        scans.append(mass_start_kg is None)
        return own_guess(problem, mass_start_kg)

    monkeypatch.setattr(output_error, "_initial_guess", counted)
    result = identify_surge([record])
    folds = len(output_error._folds([record], split_segments([record]))[0])
    assert sum(scans) == folds + 1  # the baseline's folds and its fit to everything
    assert len(scans) - sum(scans) >= 4 * folds + 2
    scans.clear()
    monkeypatch.setattr(output_error, "_initial_guess", lambda problem, mass_start_kg=None: own_guess(problem))
    scanned = identify_surge([record])
    assert result.reason == warm.reason == scanned.reason
    for a, b in zip(result.candidates, scanned.candidates, strict=True):
        assert a["cv_mse_mps2"] == pytest.approx(b["cv_mse_mps2"], rel=1e-3)
    assert result.selected.mass_kg == pytest.approx(scanned.selected.mass_kg, rel=1e-4)
    speeds = np.linspace(0.0, result.selected.top_speed_mps, 20)
    np.testing.assert_allclose(result.selected.resistance_N(speeds), scanned.selected.resistance_N(speeds),
                               rtol=1e-4, atol=1e-3)
