"""Physics of the vessel model: steady speed, turning, current drift, ensemble, parameters and scenarios."""

import math
from dataclasses import replace

import numpy as np
import pytest

from boat_twin.errors import InputError
from boat_twin.vessel import dynamics
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import (
    VesselParams,
    derive_coefficients,
    load_params,
    reference_turn_thrust_N,
    save_params,
)
from boat_twin.vessel.resistance import (
    CorrectedResistance,
    PowerSeriesResistance,
    TableResistance,
    dyda2021_resistance,
)
from boat_twin.vessel.scenarios import (
    SCENARIO_NAMES,
    SCENARIOS,
    CommandProfile,
    Zigzag,
    make_scenario,
    steady_speed_mps,
    thrust_steps,
)
from boat_twin.vessel.simulate import simulate

PARAMS = VesselParams()


def constant(thrust_per_engine_n: float, angle_rad: float = 0.0, duration_s: float = 400.0) -> CommandProfile:
    row = [thrust_per_engine_n, thrust_per_engine_n, angle_rad, angle_rad]
    return CommandProfile("constant", np.array([0.0]), np.array([row]), duration_s)


@pytest.mark.parametrize("total_thrust_n", [100.0, 300.0, 700.0, 1100.0])
def test_steady_speed_is_the_inverse_of_the_resistance_curve(total_thrust_n: float) -> None:
    record = simulate(PARAMS, constant(total_thrust_n / 2.0, duration_s=600.0))
    u_final = record.states[-1, 0, 3]
    expected = steady_speed_mps(PARAMS, total_thrust_n)
    assert float(PARAMS.resistance.force_N(expected)) == pytest.approx(total_thrust_n, rel=1e-9)
    assert u_final == pytest.approx(expected, rel=2e-3)


def test_reference_turn_is_reproduced_on_both_sides() -> None:
    thrust = reference_turn_thrust_N(PARAMS)
    for side in (+1.0, -1.0):  # negative steering angle turns to port (r > 0)
        record = simulate(PARAMS, constant(thrust, -side * PARAMS.turn_steering_rad, duration_s=120.0),
                          initial_states=np.array([[0, 0, 0, PARAMS.turn_speed_mps, 0, 0]]))
        _, _, _, u, v, r = record.states[-1, 0]
        speed = math.hypot(u, v)
        assert speed == pytest.approx(PARAMS.turn_speed_mps, rel=0.01)
        assert side * r == pytest.approx(speed / (PARAMS.turn_diameter_m / 2.0), rel=0.01)
        assert math.atan2(-side * v, u) == pytest.approx(PARAMS.turn_drift_rad, rel=0.02)


def test_boat_drifts_with_the_current() -> None:
    # Without windage: otherwise the still air over the drifting boat is a (real, small) wind.
    params = replace(PARAMS, frontal_windage_area_m2=0.0, lateral_windage_area_m2=0.0)
    env = Environment(current_east_mps=0.3, current_north_mps=-0.2)
    record = simulate(params, constant(0.0, duration_s=100.0), env)
    truth = record.truth()
    assert truth.east_m[-1] == pytest.approx(30.0, abs=1e-9)
    assert truth.north_m[-1] == pytest.approx(-20.0, abs=1e-9)
    moving = simulate(params, constant(150.0, duration_s=300.0), env).truth()
    assert moving.vel_east_mps[-1] - moving.surge_mps[-1] == pytest.approx(0.3, abs=1e-9)
    assert moving.surge_mps[-1] == pytest.approx(steady_speed_mps(params, 300.0), rel=2e-3)


def test_wind_pushes_the_boat_downwind_and_calm_air_changes_nothing() -> None:
    calm = simulate(PARAMS, constant(300.0, duration_s=120.0)).truth()
    assert calm.north_m[-1] == pytest.approx(0.0, abs=1e-9)
    windy = simulate(PARAMS, constant(300.0, duration_s=20.0), Environment(wind_north_mps=10.0)).truth()
    assert windy.north_m[-1] > 2.0  # a 10 m/s beam wind sets the boat ~4 m to leeward in 20 s


def test_ensemble_matches_single_runs_exactly() -> None:
    rng = np.random.default_rng(3)
    starts = np.zeros((4, 6))
    starts[:, 2] = rng.uniform(-np.pi, np.pi, 4)
    starts[:, 3] = rng.uniform(0.0, 8.0, 4)
    scenario = make_scenario("random", PARAMS, np.random.default_rng(5), duration_s=60.0)
    together = simulate(PARAMS, scenario, initial_states=starts)
    for b in range(4):
        alone = simulate(PARAMS, scenario, initial_states=starts[b : b + 1])
        np.testing.assert_array_equal(together.states[:, b], alone.states[:, 0])


@pytest.mark.parametrize("scenario_name", ["random", "zigzag-20-20"])
def test_large_ensembles_on_numba_threads_equal_the_serial_kernel(monkeypatch: pytest.MonkeyPatch,
                                                                   scenario_name: str) -> None:
    """Ensembles of PARALLEL_MIN_BOATS or more boats run on numba's threads (open-loop ticks and a closed-loop
    helm's steps): every boat's states, derivatives and steering equal the one-thread kernel's, bit for bit."""
    n = dynamics.PARALLEL_MIN_BOATS + 6
    rng = np.random.default_rng(8)
    boats = [replace(PARAMS, manoeuvring={"m33_kgm2": float(m)}, steering_offset_rad=float(o))
             for m, o in zip(rng.uniform(3000.0, 6000.0, n), rng.uniform(-0.02, 0.02, n), strict=True)]
    scenario = make_scenario(scenario_name, PARAMS, np.random.default_rng(5), duration_s=30.0)
    threaded = simulate(PARAMS, scenario, boats=boats)
    monkeypatch.setattr(dynamics, "PARALLEL_MIN_BOATS", 10 * n)
    serial = simulate(PARAMS, scenario, boats=boats)
    for name in ("states", "derivatives", "steering_rad"):
        np.testing.assert_array_equal(getattr(threaded, name), getattr(serial, name), err_msg=name)
    assert np.ptp(threaded.states[-1, :, 2]) > 0.01  # the boats differ



def _sway_by_ticks(dynamics_: Dynamics, start, vessel, lags, heading, surge, yaw_rate, acting, switch, actuators,
                   environments, dt) -> np.ndarray:
    """The sway observer as one two-tick :meth:`Dynamics.run` per sample for all boats (replay's loop before
    issue 37), each boat in its row of ``environments``: the reference :meth:`Dynamics.observe_sway` must equal."""
    last = len(acting) - 1
    sway = np.zeros(start.size)
    for lag in range(lags, 0, -1):
        index = start - lag
        inside = index >= 0
        index = np.maximum(index, 0)
        states = np.zeros((sway.size, 6))
        states[:, 2], states[:, 3], states[:, 4], states[:, 5] = heading[index], surge[index], sway, yaw_rate[index]
        following = np.minimum(index + 1, last)
        commands = np.stack([acting[index], acting[following]])
        angles = actuators[index, vessel, :2]
        angles = np.where(np.isfinite(angles), angles, dynamics_.steering_targets(commands[0]))
        thrust = actuators[index, vessel, 2:]
        thrust = np.where(np.isfinite(thrust), thrust, dynamics_.thrust_start(commands[0]))
        path, _, _ = dynamics_.run(states, commands, environments, dt, 1, angles, thrust,
                                   np.stack([switch[index], switch[following]]), acting[np.maximum(index - 1, 0)])
        sway = np.where(inside & np.isfinite(path[1, :, 4]), path[1, :, 4], sway)
    return sway


@pytest.mark.parametrize("boats_per_call", [None, 7])
def test_the_compiled_sway_observer_equals_a_run_per_sample(monkeypatch: pytest.MonkeyPatch,
                                                             boats_per_call: int | None) -> None:
    """Issue 37: the sway observer in one compiled call (or in groups of boats, as a long trial's is) gives the
    per-sample two-tick runs' sway bit for bit: commands switching between samples, NaN actuators, boats
    whose run-in starts before the trial, two vessels with their own coefficients."""
    rng = np.random.default_rng(4)
    n, dt, lags = 400, 0.1, 50
    vessels = [replace(PARAMS, steering_rate_radps=0.5, thrust_time_constant_s=1.0),
               replace(PARAMS, manoeuvring={"m22_kg": 90.0}, steering_offset_rad=0.01)]
    acting = np.column_stack([rng.uniform(0, 600, (n, 2)), rng.uniform(-0.3, 0.3, (n, 2))])
    acting[100:110] = np.nan
    switch = np.where(rng.random(n) < 0.3, rng.uniform(-0.05, 0.05, n), 0.0)
    actuators = np.stack([Dynamics(v).actuator_history(dt, acting, switch) for v in vessels], axis=1)
    heading, surge, yaw_rate = rng.uniform(-3, 3, n), rng.uniform(0, 8, n), rng.uniform(-0.3, 0.3, n)
    windows = np.array([20, 60, 105, 150, 230, 399])
    start, vessel = np.tile(windows, 2), np.repeat([0, 1], windows.size)
    model = Dynamics(PARAMS, boats=[v for v in vessels for _ in windows])
    environments = np.array([0.2, -0.1, 1.0, 2.0]) + rng.uniform(-3, 3, (start.size, 4)) * [0, 0, 1, 1]  # wind
    reference = _sway_by_ticks(model, start, vessel, lags, heading, surge, yaw_rate, acting, switch, actuators,
                               environments, dt)
    if boats_per_call:
        monkeypatch.setattr(dynamics, "CALL_BOAT_STEPS", boats_per_call * lags)
    observed = model.observe_sway(start, vessel, lags, heading, surge, yaw_rate, acting, switch, actuators,
                                  environments, dt)
    np.testing.assert_array_equal(observed, reference)
    assert np.all(np.abs(reference) > 1e-4)  # every boat observed a sway


def test_coefficients_of_another_number_of_boats_are_refused() -> None:
    """One coefficient row for all boats or one per boat; anything else would read past the rows."""
    dynamics = Dynamics(PARAMS, boats=[PARAMS, PARAMS])
    with pytest.raises(ValueError, match="3 boats stepped with the coefficients of 2"):
        dynamics.run(np.zeros((3, 6)), np.zeros((5, 3, 4)), np.zeros((3, 4)), 0.02, 5, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="3 boats"):
        dynamics.step(np.zeros((3, 6)), np.zeros((3, 4)), np.zeros((3, 4)), 0.02, np.zeros((3, 2)))

def test_ensemble_of_different_boats_matches_each_boat_alone() -> None:
    zig = Zigzag(PARAMS, math.radians(20), math.radians(20), duration_s=40.0)
    boats = [PARAMS, replace(PARAMS, manoeuvring={"m33_kgm2": 5000.0}),
             replace(PARAMS, lateral_centre_x_m=-0.7, steering_offset_rad=0.02)]
    together = simulate(PARAMS, zig, boats=boats)
    assert together.states.shape[1] == 3
    for b, boat in enumerate(boats):
        alone = simulate(boat, zig)
        np.testing.assert_array_equal(together.states[:, b], alone.states[:, 0])
        np.testing.assert_array_equal(together.steering_rad[:, b], alone.steering_rad[:, 0])
    assert np.abs(together.states[:, 1, 2] - together.states[:, 0, 2]).max() > 0.05  # the boats differ
    with pytest.raises(ValueError, match="resistance"):
        simulate(PARAMS, zig, boats=[replace(PARAMS, resistance=dyda2021_resistance())])


def test_zigzag_executes_to_starboard_first_and_overshoots() -> None:
    zig = Zigzag(PARAMS, math.radians(20), math.radians(20))
    yaw = np.degrees(simulate(PARAMS, zig).truth().yaw_rad)
    first = np.flatnonzero(np.abs(yaw) > 1.0)[0]
    assert yaw[first] < 0.0  # starboard = clockwise = negative ENU yaw
    assert 20.0 < -yaw.min() < 45.0 and 20.0 < yaw.max() < 45.0  # overshoots grow to ~20° at the 18°/s swing


@pytest.mark.parametrize("name", SCENARIO_NAMES)
def test_every_registered_scenario_is_built_under_its_name(name: str) -> None:
    scenario = make_scenario(name, PARAMS, np.random.default_rng(0), duration_s=42.0)
    assert scenario.name == name and scenario.duration_s == 42.0
    assert make_scenario(name, PARAMS, np.random.default_rng(0)).duration_s > 0.0
    assert tuple(SCENARIOS) == SCENARIO_NAMES


def test_unknown_scenario_names_the_registered_ones() -> None:
    with pytest.raises(InputError, match=r"unknown scenario 'nope' \(choose from thrust-steps, accel-stop, "):
        make_scenario("nope", PARAMS, np.random.default_rng(0))


def test_thrust_steps_hold_each_level_for_several_time_constants() -> None:
    profile = thrust_steps(PARAMS)
    record = simulate(PARAMS, profile)
    for k, start in enumerate(profile.times_s[:-1]):
        end = profile.times_s[k + 1]
        u_end = record.states[int(round(end * 10)) - 1, 0, 3]
        target = steady_speed_mps(PARAMS, 2.0 * profile.values[k, 0])
        assert u_end == pytest.approx(target, rel=0.03), f"level {k} at t={start:.0f}s did not settle"


def test_engine_envelope_limits_top_speed() -> None:
    record = simulate(PARAMS, constant(1e6, duration_s=300.0))
    top = record.states[-1, 0, 3]
    power = 2 * PARAMS.propulsive_efficiency * PARAMS.engine_power_W
    assert float(PARAMS.resistance.force_N(top)) == pytest.approx(power / top, rel=1e-3)


def test_resistance_models_are_odd_monotone_and_extrapolate_quadratically() -> None:
    table = dyda2021_resistance()
    u = np.linspace(0.0, 20.0, 2001)
    f = table.force_N(u)
    assert np.all(np.diff(f) >= 0.0)
    np.testing.assert_allclose(table.force_N(-u), -f)
    top = table.max_speed_mps
    assert table.force_N(2 * top) == pytest.approx(4 * table.force_N(top))
    series = PowerSeriesResistance((0.0, 10.0, 2.0), max_speed_mps=5.0)
    assert series.force_N(3.0) == pytest.approx(30.0 + 18.0)
    assert series.force_N(10.0) == pytest.approx(series.force_N(5.0) * 4)


@pytest.mark.parametrize(
    ("speeds", "forces", "message"),
    [
        ((0.0, 1.0, 1.0), (0.0, 1.0, 2.0), "increase"),
        ((0.0, 1.0), (0.0, -1.0), "decrease"),
        ((0.0, float("nan")), (0.0, 1.0), "finite"),
        ((0.5, 1.0), (0.0, 1.0), "first point"),
    ],
)
def test_bad_resistance_table_is_rejected(speeds, forces, message) -> None:
    with pytest.raises(InputError, match=message):
        TableResistance(speeds, forces)


def test_params_yaml_round_trip(tmp_path) -> None:
    params = VesselParams(mass_kg=1500.0, resistance=PowerSeriesResistance((0.0, 60.0, 9.0), 9.0))
    path = tmp_path / "boat.yaml"
    save_params(params, path)
    loaded = load_params(path)
    assert loaded == params
    assert derive_coefficients(loaded) == derive_coefficients(params)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("vessel: {mass_kg: -5}", "'mass_kg' must be positive"),
        ("vessel: {mass_kg: .nan}", "'mass_kg' must be a finite number"),
        ("vessel: {mass_kg: heavy}", "'mass_kg' must be a number"),
        ("vessel: {hull_colour: 3}", "unknown vessel parameter 'hull_colour'"),
        ("vessel: {resistance: {model: spline}}", "unknown model 'spline'"),
        ("vessel: [1, 2", "malformed YAML"),
    ],
)
def test_bad_params_yaml_names_the_field(tmp_path, text, message) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        load_params(path)
    assert str(path) in str(err.value)


def test_a_resistance_correction_above_the_base_table_acts_in_the_dynamics() -> None:
    """Table 1 ends at 9.26 m/s; a +30 % change at 11-13 m/s must still slow the boat where it applies."""
    corrected = CorrectedResistance(PARAMS.resistance, (10.0, 11.0, 13.0, 14.0), (1.0, 1.3, 1.3, 1.0))
    params = replace(PARAMS, resistance=corrected)
    thrust_n = float(PARAMS.resistance.force_N(12.0))
    base_u = simulate(PARAMS, constant(thrust_n / 2.0, duration_s=300.0)).states[-1, 0, 3]
    corrected_u = simulate(params, constant(thrust_n / 2.0, duration_s=300.0)).states[-1, 0, 3]
    assert base_u == pytest.approx(12.0, rel=2e-3)
    assert float(corrected.force_N(corrected_u)) == pytest.approx(thrust_n, rel=5e-3)


def test_a_diverging_simulation_is_an_error_not_a_bag_of_nan() -> None:
    """A non-finite state (here given as the start) stops the simulation with the time it happened."""
    from boat_twin.vessel.scenarios import make_scenario
    from boat_twin.vessel.simulate import simulate_chunks

    params = VesselParams()
    scenario = make_scenario("accel-stop", params, np.random.default_rng(0), 5.0)
    start = np.array([[0.0, 0.0, 0.0, np.nan, 0.0, 0.0]])
    with pytest.raises(InputError, match=r"diverged at t = 0\.\d s"):
        list(simulate_chunks(params, scenario, initial_states=start))


def test_a_thrust_lag_delivers_a_step_as_a_first_order_response() -> None:
    """Engines with a 1.5 s time constant on a straight run: after a thrust step the force the boat feels,
    m11·u̇ + Fc(u), follows T_new + (T_old − T_new)·exp(−t/τ) at every tick (the lag state is solved exactly;
    the kernel tabulates Fc within 1e-5 of it)."""
    tau, old, new = 1.5, 400.0, 900.0
    params = replace(VesselParams(), thrust_time_constant_s=tau)
    profile = CommandProfile("step", np.array([0.0, 2.0]), np.array([[old, old, 0.0, 0.0], [new, new, 0.0, 0.0]]),
                             8.0, steady_speed_mps(params, 2 * old))
    record = simulate(params, profile)
    m11 = derive_coefficients(params).m11_kg
    u = record.states[:, 0, 3]
    felt = m11 * record.derivatives[:, 0, 3] + params.resistance.force_N(u)
    t = record.t_s
    expected = 2 * np.where(t < 2.0, old, new + (old - new) * np.exp(-(t - 2.0) / tau))
    assert np.allclose(felt, expected, rtol=0.0, atol=0.01)  # the tabulated resistance: < 1e-5 of Fc


def test_a_command_delay_acts_as_the_commands_logged_that_much_later() -> None:
    """A 0.3 s delay: the boat moves as an undelayed boat under the same profile 0.3 s later; the record
    keeps the commands as logged (undelayed)."""
    params = VesselParams()
    times = np.array([0.0, 3.0, 6.0])
    rows = np.array([[500.0, 500.0, 0.0, 0.0], [900.0, 700.0, 0.2, 0.2], [600.0, 600.0, -0.1, -0.1]])
    delayed = simulate(replace(params, command_delay_s=0.3), CommandProfile("p", times, rows, 10.0, 5.0))
    shifted = simulate(params, CommandProfile("p", np.concatenate([[0.0], times + 0.3]),
                                              np.vstack([rows[:1], rows]), 10.0, 5.0))
    assert np.array_equal(delayed.states, shifted.states)
    assert np.array_equal(delayed.commands[:, 0], rows[np.searchsorted(times, delayed.t_s + 1e-9) - 1])


@pytest.mark.parametrize("seed", range(4))
def test_the_table_resistances_pchip_is_scipys_bit_for_bit(seed) -> None:
    """Its own PCHIP spares ``diagnose`` and ``follow`` the import of scipy.interpolate (issue 37)."""
    from scipy.interpolate import PchipInterpolator

    from boat_twin.vessel.resistance import Pchip

    rng = np.random.default_rng(seed)
    for _ in range(50):
        n = int(rng.integers(2, 20))
        x = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 3.0, n - 1))])
        y = rng.choice([np.concatenate([[0.0], np.cumsum(rng.uniform(0.0, 400.0, n - 1))]),
                        np.round(rng.normal(size=n)) * 3.0])
        at = np.concatenate([rng.uniform(-1.0, x[-1] + 1.0, 100), x, [np.nan]])
        assert np.array_equal(Pchip(x, y)(at), PchipInterpolator(x, y, extrapolate=False)(at), equal_nan=True)


def test_the_interpolation_of_every_column_is_numpys_bit_for_bit() -> None:
    """The GNSS latency's interpolation of a replay's (n, windows) arrays at once (issue 37) is np.interp's."""
    from boat_twin.sensors.gnss import delayed

    rng = np.random.default_rng(1)
    t = np.arange(200) * 0.1
    values = rng.normal(size=(200, 30)) * 50.0
    values[rng.random(values.shape) < 0.05] = np.nan
    for delay in (0.0, 0.05, 0.1, 0.37, -0.2, 50.0):
        expected = np.stack([np.interp(t - delay, t, values[:, j]) for j in range(30)], axis=1)
        assert np.array_equal(delayed(t, values, delay), expected, equal_nan=True)
