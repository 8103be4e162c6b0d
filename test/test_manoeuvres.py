"""Manoeuvring: the outboards' steering rate, zigzag logic at the integration rate, scenarios without memory
between runs, and the IMO figures against tracks whose figures are known by construction."""

import json
import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.errors import InputError
from boat_twin.vessel.manoeuvres import manoeuvre_figures, stopping_figures, turning_figures, zigzag_figures
from boat_twin.vessel.params import VesselParams, derive_coefficients, load_params, sway_yaw_time_constants_s
from boat_twin.vessel.resistance import PowerSeriesResistance
from boat_twin.vessel.scenarios import (
    EngineTurningCircle,
    Zigzag,
    ZigzagHelm,
    crash_stop,
    engine_setting_thrust_N,
    make_scenario,
    turning_circle,
)
from boat_twin.vessel.simulate import INTEGRATION_RATE_HZ, simulate

PARAMS = VesselParams()


@pytest.mark.parametrize("rate_deg_s", [18.0, 5.0])
def test_outboards_swing_at_the_steering_rate(rate_deg_s: float) -> None:
    params = replace(PARAMS, steering_rate_radps=math.radians(rate_deg_s))
    record = simulate(params, make_scenario("turning-circle", params, np.random.default_rng(0), duration_s=20.0))
    angle = np.degrees(record.steering_rad[:, 0, :])  # (ticks, left/right)
    t = record.t_s
    expected = np.clip(rate_deg_s * (t - 10.0), 0.0, 30.0)  # execute at 10 s, full steering 30°
    np.testing.assert_allclose(angle, np.repeat(expected[:, None], 2, axis=1), atol=1e-9)
    assert np.all(np.degrees(record.commands[t >= 10.0, 0, 2]) == pytest.approx(30.0))  # the order is at once


def test_a_zero_steering_rate_is_instantaneous_and_a_slow_swing_turns_later() -> None:
    heading = {}
    for rate in (0.0, math.radians(5.0)):
        params = replace(PARAMS, steering_rate_radps=rate)
        record = simulate(params, make_scenario("turning-circle", params, np.random.default_rng(0), duration_s=14.0))
        if rate == 0.0:
            assert np.degrees(record.steering_rad[100, 0, 0]) == pytest.approx(30.0)  # at the execute tick
        heading[rate] = -math.degrees(record.states[-1, 0, 2])
    assert heading[math.radians(5.0)] < 0.7 * heading[0.0]


def test_steering_rate_is_read_from_the_twin_yaml(tmp_path) -> None:
    path = tmp_path / "boat.yaml"
    path.write_text("vessel:\n  steering_rate_radps: 0.25\n")
    assert load_params(path).steering_rate_radps == 0.25
    path.write_text("vessel:\n  steering_rate_radps: -1\n")
    with pytest.raises(InputError, match="steering_rate_radps"):
        load_params(path)


@dataclass(frozen=True)
class _Watched:
    """A zigzag whose helm records every call (time, deviation from the first execute's heading, steering)."""

    zigzag: Zigzag
    calls: list

    def __getattr__(self, name: str):
        return getattr(self.zigzag, name)

    def helm(self, n_boats: int):
        inner = ZigzagHelm(self.zigzag, n_boats)
        calls = self.calls

        class Spy:
            def command(self, t_s: float, states: np.ndarray) -> np.ndarray:
                out = inner.command(t_s, states)
                calls.append((t_s, float(states[0, 2]), float(states[0, 5]), float(out[0, 2])))
                return out

        return Spy()


def test_zigzag_reverses_within_one_integration_step_of_the_switch_heading() -> None:
    zigzag = make_scenario("zigzag-20-20", PARAMS, np.random.default_rng(0), duration_s=60.0)
    watched = _Watched(zigzag, [])
    simulate(PARAMS, watched)  # type: ignore[arg-type]
    t, yaw, rate, steer = (np.array(c) for c in zip(*watched.calls, strict=True))
    assert np.allclose(np.diff(t), 1.0 / INTEGRATION_RATE_HZ)  # asked at every integration step
    flips = np.flatnonzero(np.diff(np.sign(steer[t >= zigzag.approach_s])) != 0) + 1 + np.argmax(t >= 10.0)
    assert flips.size >= 3
    deviation = np.degrees(np.abs(yaw[flips] - yaw[np.argmax(t >= 10.0)]))
    step_deg = np.degrees(np.abs(rate[flips])) / INTEGRATION_RATE_HZ  # how far one step turns the boat
    assert np.all(deviation >= 20.0) and np.all(deviation - 20.0 <= step_deg + 1e-9)
    assert np.all(deviation < 20.35)  # the 10 Hz switch of the past reversed at 20.5-20.85°


def test_a_scenario_runs_the_same_twice_and_each_boat_keeps_its_own_heading() -> None:
    zigzag = make_scenario("zigzag-20-20", PARAMS, np.random.default_rng(0), duration_s=60.0)
    first, again = simulate(PARAMS, zigzag), simulate(PARAMS, zigzag)
    np.testing.assert_array_equal(first.states, again.states)
    starts = np.zeros((3, 6))
    starts[:, 2] = [0.0, 1.0, -2.0]
    starts[:, 3] = 6.0
    fleet = simulate(PARAMS, zigzag, initial_states=starts)
    for b in range(3):
        alone = simulate(PARAMS, zigzag, initial_states=starts[b : b + 1])
        np.testing.assert_array_equal(fleet.states[:, b], alone.states[:, 0])
    turned = np.degrees(fleet.states[:, :, 2] - starts[:, 2])
    assert np.ptp(turned.min(axis=0)) < 1e-6 and turned.min() < -30.0  # every boat zigzags about its own heading


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2 * np.pi) - np.pi


def test_turning_figures_of_a_track_built_by_hand() -> None:
    """Straight at 5 m/s on heading 160° (through the ±180° wrap once turning), execute at 10 s, 6 m more
    straight (the steering swinging over), then a starboard circle of radius 20 m at 3 m/s: advance 6 + 20 m,
    transfer 20 m, tactical and steady diameter 40 m, speed loss 1 − 3/5."""
    psi0, radius, reach, v0, v1 = math.radians(160.0), 20.0, 6.0, 5.0, 3.0
    ahead, right = np.array([math.cos(psi0), math.sin(psi0)]), np.array([math.sin(psi0), -math.cos(psi0)])
    t = np.arange(0.0, 120.0, 0.1)
    arc_start = 10.0 + reach / v0
    straight = np.minimum(t, arc_start) * v0
    theta = np.maximum(t - arc_start, 0.0) * v1 / radius
    pos = np.array([30.0, -70.0]) + np.outer(straight, ahead) + radius * (
        np.outer(np.sin(theta), ahead) + np.outer(1.0 - np.cos(theta), right))
    speed = np.where(t < arc_start, v0, v1)
    figures = turning_figures(t, pos[:, 0], pos[:, 1], _wrapped(psi0 - theta), speed, 10.0, 6.0)
    assert figures.side == "starboard"
    assert figures.advance_m == pytest.approx(reach + radius, abs=1e-3)
    assert figures.transfer_m == pytest.approx(radius, abs=1e-3)
    assert figures.tactical_diameter_m == pytest.approx(2 * radius, abs=1e-3)
    assert figures.steady_diameter_m == pytest.approx(2 * radius, rel=1e-9)
    data = figures.as_dict()
    assert data["speed_loss"] == pytest.approx(1.0 - v1 / v0)
    assert data["advance_L"] == pytest.approx(26.0 / 6.0, abs=1e-3) and data["advance_limit_L"] == 4.5
    assert data["tactical_diameter_limit_L"] == 5.0
    short = turning_figures(t[:300], pos[:300, 0], pos[:300, 1], _wrapped(psi0 - theta[:300]), speed[:300], 10.0, 6.0)
    assert short.steady_diameter_m is None and short.advance_m is not None  # 300° turned: not yet steady


def test_zigzag_figures_of_a_heading_record_built_by_hand() -> None:
    """Half-sine heading swings of known amplitudes 30°, 35°, 28°, 33° (deviation first to starboard) about
    an initial heading of 170° (the record wraps at ±180°); switch 20°: every figure follows in closed form."""
    omega, t1, amplitudes = 2 * math.pi / 20.0, 5.0, np.radians([30.0, 35.0, 28.0, 33.0])
    t = np.arange(0.0, 50.0, 0.1)
    tau = t - t1
    half = np.clip((tau // (math.pi / omega)).astype(int), 0, amplitudes.size - 1)
    sign = np.where(half % 2 == 0, -1.0, 1.0)
    deviation = np.where(tau > 0, sign * amplitudes[half] * np.abs(np.sin(omega * tau)), 0.0)
    switch = math.radians(20.0)
    figures = zigzag_figures(t, 4.0 * t, np.zeros_like(t), _wrapped(math.radians(170.0) + deviation),
                             np.full_like(t, 4.0), t1, switch, switch, 6.0)
    crossing = [t1 + j * math.pi / omega + math.asin(switch / a) / omega for j, a in enumerate(amplitudes)]
    np.testing.assert_allclose(figures.execute_t_s[1:5], crossing, atol=2e-3)
    assert figures.first_overshoot_deg == pytest.approx(10.0, abs=0.01)
    assert figures.second_overshoot_deg == pytest.approx(15.0, abs=0.01)
    assert figures.initial_turning_time_s == pytest.approx(crossing[0] - t1, abs=2e-3)
    assert figures.time_to_check_yaw_s == pytest.approx(t1 + math.pi / (2 * omega) - crossing[0], abs=0.01)
    assert figures.period_s == pytest.approx(crossing[2] - crossing[0], abs=2e-3)
    assert figures.initial_turning_distance_m == pytest.approx(4.0 * (crossing[0] - t1), abs=0.01)
    assert figures.as_dict()["first_overshoot_limit_deg"] == 25.0


def test_ten_ten_criteria_depend_on_length_over_speed() -> None:
    t = np.arange(0.0, 30.0, 0.1)
    deviation = -np.radians(15.0) * np.sin(np.clip(t - 1.0, 0.0, None) * 0.3)
    ten = math.radians(10.0)
    slow = zigzag_figures(t, t, 0 * t, deviation, np.full_like(t, 0.3), 1.0, ten, ten, 6.0).as_dict()
    assert slow["L_over_V_s"] == pytest.approx(20.0)
    assert slow["first_overshoot_limit_deg"] == pytest.approx(15.0)  # 5 + L/(2V)
    assert slow["second_overshoot_limit_deg"] == pytest.approx(32.5)  # 17.5 + 0.75 L/V
    assert slow["initial_turning_distance_limit_L"] == 2.5


def test_simulated_turning_circle_and_zigzag_report_their_figures() -> None:
    circle = make_scenario("turning-circle", PARAMS, np.random.default_rng(0))
    turn = manoeuvre_figures(circle, simulate(PARAMS, circle).truth(), PARAMS.length_m)
    assert turn is not None and turn["side"] == "starboard"
    assert turn["tactical_diameter_m"] > turn["steady_diameter_m"] > 0.0  # the boat slows in the turn
    assert 0.0 < turn["speed_loss"] < 1.0
    zigzag = make_scenario("zigzag-10-10", PARAMS, np.random.default_rng(0))
    zig = manoeuvre_figures(zigzag, simulate(PARAMS, zigzag).truth(), PARAMS.length_m)
    assert zig is not None and zig["first_overshoot_deg"] > 0.0 and zig["period_s"] > zig["initial_turning_time_s"]
    assert manoeuvre_figures(make_scenario("accel-stop", PARAMS, np.random.default_rng(0)),
                             simulate(PARAMS, make_scenario("accel-stop", PARAMS, np.random.default_rng(0),
                                                            duration_s=2.0)).truth(), 6.0) is None


def test_simulate_json_prints_the_imo_figures(capsys) -> None:
    assert main(["simulate", "zigzag-20-20", "--no-noise", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    zigzag = make_scenario("zigzag-20-20", PARAMS, np.random.default_rng(0))
    expected = manoeuvre_figures(zigzag, simulate(PARAMS, zigzag).truth(), PARAMS.length_m)
    assert expected is not None and set(result["manoeuvre"]) == set(expected)
    for key, value in expected.items():
        assert result["manoeuvre"][key] == (pytest.approx(value) if isinstance(value, (float, list)) else value)
    assert len(result["vessel"]["sway_yaw_time_constants_at_turn_speed_s"]) == 2
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--json"]) == 0
    assert "manoeuvre" not in json.loads(capsys.readouterr().out)


def test_coupled_sway_yaw_time_constants_match_a_simulated_response() -> None:
    """The slow pole of the linear sway-yaw system is the decay of a small yaw rate on a straight course."""
    fast, slow = sway_yaw_time_constants_s(PARAMS, 6.0)
    assert fast < slow
    start = np.array([[0.0, 0.0, 0.0, 6.0, 0.0, 0.01]])
    hold = _approach(PARAMS, 6.0)
    record = simulate(PARAMS, hold, initial_states=start)
    r = record.states[:, 0, 5]
    t = record.t_s
    late = (t > 5 * fast) & (t < 2 * slow)
    decay = -np.polyfit(t[late], np.log(np.abs(r[late])), 1)[0]
    assert 1.0 / decay == pytest.approx(slow, rel=0.05)


def _approach(params: VesselParams, speed: float):
    from boat_twin.vessel.scenarios import CommandProfile, steady_speed_mps

    thrust = float(params.resistance.force_N(speed)) / 2.0
    assert steady_speed_mps(params, 2 * thrust) == pytest.approx(speed)
    return CommandProfile("hold", np.array([0.0]), np.array([[thrust, thrust, 0.0, 0.0]]), 20.0, speed)


def test_a_helm_deciding_at_the_log_rate_reverses_only_on_log_ticks() -> None:
    zigzag = replace(make_scenario("zigzag-20-20", PARAMS, np.random.default_rng(0), duration_s=40.0),
                     decision_rate_hz=10.0)
    watched = _Watched(zigzag, [])
    simulate(PARAMS, watched)  # type: ignore[arg-type]
    t, _, _, steer = (np.array(c) for c in zip(*watched.calls, strict=True))
    flips = t[1:][np.diff(steer) != 0.0]
    assert flips.size >= 3
    np.testing.assert_allclose(flips * 10.0, np.round(flips * 10.0), atol=1e-9)


def test_replayed_commands_drive_the_same_rate_limited_steering() -> None:
    from boat_twin.vessel.dynamics import Dynamics

    commands = np.zeros((40, 4))
    commands[3:, 2:] = math.radians(30.0)
    commands[20:25] = np.nan  # a gap in the log: the next known command starts at its target
    commands[25:, 2:] = math.radians(-10.0)
    angles = np.degrees(Dynamics(PARAMS).steering_history(0.1, commands)[:, 0])
    np.testing.assert_allclose(angles[:4], 0.0)
    np.testing.assert_allclose(angles[4:8], [1.8, 3.6, 5.4, 7.2])
    assert angles[19] == pytest.approx(28.8) and np.all(np.isnan(angles[21:25]))
    assert angles[25] == pytest.approx(-10.0)
    record = simulate(PARAMS, _profile(commands[:20]))
    np.testing.assert_allclose(np.degrees(record.steering_rad[:20, 0, 0]), angles[:20], atol=1e-9)


def _profile(rows: np.ndarray):
    from boat_twin.vessel.scenarios import CommandProfile

    return CommandProfile("rows", np.arange(rows.shape[0]) * 0.1, rows, (rows.shape[0] - 1) * 0.1)


def test_a_run_that_ends_before_the_execute_has_no_figures(capsys: pytest.CaptureFixture[str]) -> None:
    """A turning circle cut before its execute (10 s) reports no figures instead of failing."""
    assert main(["simulate", "turning-circle", "--duration", "5", "--json", "--no-noise"]) == 0
    figures = json.loads(capsys.readouterr().out)["manoeuvre"]
    assert figures["advance_m"] is None and figures["tactical_diameter_m"] is None


def test_stopping_figures_of_a_track_built_by_hand() -> None:
    """A boat on a 50 m circle to port from heading 0.7 rad, its speed falling at 2 m/s² from 6 m/s after the
    full-astern order at t = 1.03 s (off the 10 Hz samples): dead in the water 3 s later, after 9 m of track
    (u0²/2a), 50·sin(9/50) m ahead and 50·(1 − cos(9/50)) m to port of the original course."""
    radius, u0, decel, psi0, t_exec = 50.0, 6.0, 2.0, 0.7, 1.03
    t = np.arange(0.0, 8.0, 0.1)
    tau = np.clip(t - t_exec, 0.0, None)
    travelled = np.where(tau < u0 / decel, u0 * tau - 0.5 * decel * tau**2, u0**2 / (2 * decel)) + u0 * np.minimum(
        t - t_exec, 0.0)
    surge = np.where(t < t_exec, u0, u0 - decel * tau)  # keeps falling past zero (backing)
    turned = travelled / radius
    yaw = psi0 + turned
    east = radius * (np.sin(yaw) - math.sin(psi0))
    north = radius * (math.cos(psi0) - np.cos(yaw))
    fig = stopping_figures(t, east, north, yaw, surge, t_exec, 6.0)
    reach = u0**2 / (2 * decel)
    assert fig.time_to_stop_s == pytest.approx(u0 / decel, abs=1e-9)
    assert fig.track_reach_m == pytest.approx(reach, rel=1e-4)  # the polyline's chords of a 50 m arc
    assert fig.head_reach_m == pytest.approx(radius * math.sin(reach / radius), abs=2e-3)
    assert fig.lateral_deviation_m == pytest.approx(radius * (1 - math.cos(reach / radius)), abs=2e-3)
    d = fig.as_dict()
    assert d["track_reach_L"] == pytest.approx(reach / 6.0, rel=1e-4) and d["track_reach_limit_L"] == 15.0
    assert stopping_figures(t[:30], east[:30], north[:30], yaw[:30], surge[:30], t_exec, 6.0).track_reach_m is None


def test_simulated_crash_stop_against_the_closed_form() -> None:
    """Full astern from 6 m/s on a boat whose resistance is k·u² and whose astern thrust is constant (the reverse
    limit, ½ bollard per outboard): m11·u̇ = −T − k·u² stops it in m11/√(T·k)·atan(u0·√(k/T)) after
    m11/(2k)·ln(1 + k·u0²/T) of straight track."""
    k = 30.0
    params = replace(PARAMS, resistance=PowerSeriesResistance((0.0, 0.0, k), 20.0))
    figures = manoeuvre_figures(crash_stop(params), simulate(params, crash_stop(params)).truth(), params.length_m)
    assert figures is not None and figures["manoeuvre"] == "full astern stopping"
    m11 = derive_coefficients(params).m11_kg
    thrust = 2.0 * params.reverse_thrust_ratio * params.bollard_thrust_N
    u0 = 6.0
    assert figures["approach_speed_mps"] == pytest.approx(u0, abs=1e-6)
    assert figures["time_to_stop_s"] == pytest.approx(
        m11 / math.sqrt(thrust * k) * math.atan(u0 * math.sqrt(k / thrust)), rel=2e-3)
    reach = m11 / (2.0 * k) * math.log(1.0 + k * u0**2 / thrust)
    assert figures["track_reach_m"] == pytest.approx(reach, rel=2e-3)
    assert figures["head_reach_m"] == pytest.approx(reach, rel=2e-3)
    assert abs(figures["lateral_deviation_m"]) < 1e-6


def test_turning_at_a_constant_engine_setting_holds_the_shaft_power() -> None:
    """MSC.137(76) holds the approach's engine setting through the turn. The twin holds each outboard's shaft
    power P (the setting that gives the approach thrust T0 at u0: P = T0·u0/η), so the thrust is η·P/u: T0 at the
    approach speed, 2·T0 at half of it, the bollard thrust at a standstill; in the steady turn thrust × speed
    through water stays η·P. The constant-thrust turning circle (the VRX convention) slows more and turns
    tighter."""
    scenario = EngineTurningCircle(PARAMS, duration_s=90.0)
    t0 = scenario.shaft_power_W * PARAMS.propulsive_efficiency / 6.0
    assert float(PARAMS.resistance.force_N(6.0)) / 2.0 == pytest.approx(t0, rel=1e-9)
    thrust = engine_setting_thrust_N(PARAMS, scenario.shaft_power_W, np.array([6.0, 3.0, 0.0]))
    np.testing.assert_allclose(thrust, [t0, 2.0 * t0, PARAMS.bollard_thrust_N], rtol=1e-9)
    record = simulate(PARAMS, scenario)
    u = record.states[:, 0, 3]
    before = record.t_s < scenario.execute_s
    np.testing.assert_allclose(u[before], 6.0, atol=1e-6)  # the setting holds the approach speed
    late = record.t_s > 60.0
    np.testing.assert_allclose(record.commands[late, 0, 0] * u[late], PARAMS.propulsive_efficiency
                               * scenario.shaft_power_W, rtol=0.02)  # sampled at the tick: u moves a little
    engine = manoeuvre_figures(scenario, record.truth(), PARAMS.length_m)
    held = manoeuvre_figures(turning_circle(PARAMS, turn_s=80.0), simulate(PARAMS, turning_circle(PARAMS, turn_s=80.0)
                                                                           ).truth(), PARAMS.length_m)
    assert engine is not None and held is not None
    assert engine["engine_setting"]["shaft_power_W"] == pytest.approx(scenario.shaft_power_W)
    assert engine["steady_speed_mps"] > held["steady_speed_mps"] and engine["speed_loss"] < held["speed_loss"]
    assert engine["steady_diameter_m"] > held["steady_diameter_m"]
