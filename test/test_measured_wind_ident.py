"""A measured true wind as a known, time-varying input of the identification and the replay (issue 36, item 3):
on a boat integrated apart from the twin's kernel (test/independent.py) with a known windage, in a wind that
turns round halfway, the surge output-error fit recovers the wind drag coefficient (not the wind) within its
interval, and the replay meets the wind as it was measured, window by window."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from independent import boat_trial

from boat_twin.config import TwinConfig
from boat_twin.io.trial import Trial
from boat_twin.units import AIR_DENSITY_KGPM3
from boat_twin.vessel.params import WINDAGE_DRAG_COEFFICIENT, VesselParams

AREA_M2 = 4.0
"""The independent boat's frontal windage (the default boat's is 2.6 m²)."""
DURATION_S = 400.0


def _wind(t_s: float) -> tuple[float, float]:
    """8 m/s from the east, gusting, then from the west-north-west: (east, north) m/s."""
    if t_s < DURATION_S / 2:
        return -8.0 + 1.5 * math.sin(2 * math.pi * t_s / 97), 2.0
    return 6.0, -2.0 + 1.5 * math.cos(2 * math.pi * t_s / 131)


@pytest.fixture(scope="module")
def windy() -> tuple[VesselParams, Trial]:
    """A 400 s trial: thrust steps every 30 s, the outboards held at 0.04 rad (the boat circles), the anemometer
    logged."""
    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2)
    rng = np.random.default_rng(1)
    levels = rng.choice([300.0, 600.0, 900.0, 1200.0], size=40)
    trial = boat_trial(params, lambda t: float(levels[min(int(max(t, 0.0) // 30), 39)]), lambda t: 0.04,
                       DURATION_S, rng, wind_mps=_wind)
    return params, trial


def test_the_surge_fit_recovers_the_wind_drag_coefficient(windy: tuple[VesselParams, Trial]) -> None:
    from boat_twin.ident.pipeline import identify_trials
    from boat_twin.ident.report import model_lines

    _, trial = windy
    result, _ = identify_trials([trial])
    true = 0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT * AREA_M2
    drag = result["wind_drag"]
    lo, hi = drag["selected"]["ci95_Ns2pm2"]
    assert lo <= true <= hi and hi - lo < 0.2 * true  # measured: 1.927 [1.880, 1.974] against 1.96
    assert drag["baseline"]["model"] == "baseline" and np.all(np.isfinite(drag["baseline"]["ci95_Ns2pm2"]))
    assert result["twin"]["vessel"]["frontal_windage_area_m2"] == pytest.approx(AREA_M2, rel=0.05)
    assert result["twin"]["sources"]["frontal_windage_area_m2"].startswith("identified")
    assert any(line.startswith("measured wind (an anemometer on 1 trial(s)") for line in model_lines(result))
    blind = replace(trial, wind_east_mps=None, wind_north_mps=None)  # the same recording without its anemometer
    assert "wind_drag" not in identify_trials([blind])[0]


def test_the_replay_meets_the_wind_as_it_was_measured(windy: tuple[VesselParams, Trial]) -> None:
    """The trial's mean wind alone leaves each half's wind 7 m/s off; window by window the replay follows it."""
    from boat_twin.twin.replay import cut_windows, predict, with_measured_wind

    params, trial = windy
    config = with_measured_wind(TwinConfig(vessel=params), trial)
    windows = cut_windows(trial, 20.0)
    rms = []
    for each in (windows, replace(windows, wind_departure_mps=None)):
        prediction = predict(each, config)
        error = np.concatenate([(each.measured[s] - prediction.signals[s]).ravel()
                                for s in ("vel_east_mps", "vel_north_mps")])
        rms.append(float(np.sqrt(np.nanmean(error**2))))
    assert rms[0] < 0.15 and rms[0] < rms[1] / 4  # measured: 0.08 against 0.77 m/s (GNSS noise 0.05 m/s)


def test_the_diagnosis_names_the_measured_wind_and_nothing_else(windy: tuple[VesselParams, Trial]) -> None:
    from boat_twin.diagnose.pipeline import diagnose_trial

    params, trial = windy
    done = diagnose_trial(trial, TwinConfig(vessel=params))
    assert done.result["measured_wind"]["named"]
    assert done.result["verdict"] == [] and done.result["unexplained"] is False


def test_windows_meet_their_measured_wind_whatever_the_configs_steady_wind(
        windy: tuple[VesselParams, Trial]) -> None:
    """The manoeuvring fit replays several trials through one config: re-referenced to it, each window meets its
    own measured wind as the diagnosis' config (the trial's mean) gives it."""
    from boat_twin.twin.replay import cut_windows, predict, wind_against, with_measured_wind

    params, trial = windy
    windows, calm = cut_windows(trial, 20.0), TwinConfig(vessel=params)
    against = predict(wind_against(windows, calm), calm)
    measured = predict(windows, with_measured_wind(calm, trial))
    for signal in ("vel_east_mps", "vel_north_mps", "yaw_rate_radps"):
        np.testing.assert_allclose(against.signals[signal], measured.signals[signal], atol=1e-9)
    plain = predict(windows, calm)  # the departures alone on a calm config: not the measured wind
    assert np.nanmax(np.abs(plain.signals["vel_east_mps"] - measured.signals["vel_east_mps"])) > 0.05


def test_the_manoeuvring_fit_takes_the_measured_wind_as_a_known_input() -> None:
    """The same wind over a boat steered ±0.15 rad every 20 s: every turning coefficient within its interval
    (measured: without the anemometer the sway damping's interval misses, [242, 530] N·s/m² against 649)."""
    from boat_twin.ident.manoeuvring import fit_manoeuvring
    from boat_twin.vessel.params import derive_coefficients

    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2, steering_rate_radps=0.0)  # instant outboards
    rng = np.random.default_rng(1)
    levels = rng.choice([300.0, 600.0, 900.0, 1200.0], size=40)
    trial = boat_trial(params, lambda t: float(levels[min(int(max(t, 0.0) // 30), 39)]),
                       lambda t: 0.15 * math.copysign(1.0, math.sin(2 * math.pi * t / 40)), DURATION_S, rng,
                       wind_mps=_wind)
    found = fit_manoeuvring([trial], TwinConfig(vessel=params)).to_dict()
    truth = derive_coefficients(params)
    for key in ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms", "yaw_quadratic_Nms2"):
        low, high = found["ci95"][key]
        assert low <= getattr(truth, key) <= high, (key, getattr(truth, key), low, high)


def test_the_manoeuvring_fit_finds_the_lateral_windage_in_the_measured_wind() -> None:
    """The boat's lateral windage 1.5x the boat file's: with an anemometer in the log, the fit scales it (a known
    wind, the boat's response fitted) and its interval holds 1.5, not the file's 1; the coefficients still hold."""
    from boat_twin.ident.manoeuvring import fit_manoeuvring
    from boat_twin.vessel.params import derive_coefficients

    nominal = replace(VesselParams(), frontal_windage_area_m2=AREA_M2, steering_rate_radps=0.0)
    truth = replace(nominal, lateral_windage_area_m2=1.5 * nominal.lateral_windage_area_m2)
    rng = np.random.default_rng(1)
    levels = rng.choice([300.0, 600.0, 900.0, 1200.0], size=40)
    trial = boat_trial(truth, lambda t: float(levels[min(int(max(t, 0.0) // 30), 39)]),
                       lambda t: 0.15 * math.copysign(1.0, math.sin(2 * math.pi * t / 40)), DURATION_S, rng,
                       wind_mps=_wind)
    fit = fit_manoeuvring([trial], TwinConfig(vessel=nominal))
    low, high = fit.ci95["lateral_windage_factor"]
    assert 1.0 < low <= 1.5 <= high, (low, high)
    assert fit.config.vessel.lateral_windage_area_m2 == pytest.approx(
        nominal.lateral_windage_area_m2 * fit.values["lateral_windage_factor"])
    coefficients = derive_coefficients(truth)
    for key in ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms"):
        low, high = fit.ci95[key]
        assert low <= getattr(coefficients, key) <= high, (key, getattr(coefficients, key), low, high)
    calm = replace(trial, wind_east_mps=None, wind_north_mps=None)
    assert "lateral_windage_factor" not in fit_manoeuvring([calm], TwinConfig(vessel=nominal)).fitted


def test_the_resimulation_runs_in_the_measured_wind() -> None:
    """identify's closing of the loop: the trial's commands re-simulated with the boat's own model meet the GNSS
    speed in the measured (steady) wind; the same recording without its anemometer is re-simulated in calm air and
    misses by the wind's drag."""
    from boat_twin.ident.resimulate import resimulate

    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2)
    rng = np.random.default_rng(5)
    levels = rng.choice([400.0, 800.0, 1200.0], size=10)
    trial = boat_trial(params, lambda t: float(levels[min(int(max(t, 0.0) // 30), 9)]), lambda t: 0.0, 300.0, rng,
                       wind_mps=lambda t: (-8.0, 2.0))
    windy = resimulate(trial, {}, params).to_dict()
    calm = resimulate(replace(trial, wind_east_mps=None, wind_north_mps=None), {}, params).to_dict()
    assert windy["wind_east_north_mps"] == pytest.approx([-8.0, 2.0], abs=0.1)
    assert "measured wind" in windy["conditions"] and "wind_east_north_mps" not in calm
    # measured: 0.061 against 1.55 m/s (GNSS noise 0.05 m/s)
    assert windy["speed_rmse_mps"] < 0.1 < calm["speed_rmse_mps"], (windy["speed_rmse_mps"], calm["speed_rmse_mps"])


def test_the_resimulation_follows_a_measured_wind_that_turns() -> None:
    """The wind of :func:`_wind` (from the east, then from the west-north-west): re-simulated in the wind as it
    was measured (held over each 20 s) the speed is met; in the trial's mean wind alone it is not."""
    from boat_twin.ident.resimulate import resimulate

    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2)
    rng = np.random.default_rng(6)
    levels = rng.choice([400.0, 800.0, 1200.0], size=14)
    trial = boat_trial(params, lambda t: float(levels[min(int(max(t, 0.0) // 30), 13)]), lambda t: 0.0,
                       DURATION_S, rng, wind_mps=_wind)
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    steady = replace(trial, wind_east_mps=np.full(trial.t_s.size, np.nanmean(trial.wind_east_mps)),
                     wind_north_mps=np.full(trial.t_s.size, np.nanmean(trial.wind_north_mps)))
    measured = resimulate(trial, {}, params).to_dict()["speed_rmse_mps"]
    mean_only = resimulate(steady, {}, params).to_dict()["speed_rmse_mps"]
    # measured: 0.075 against 1.15 m/s (GNSS noise 0.05 m/s)
    assert measured < 0.1 and measured < mean_only / 3, (measured, mean_only)


def test_a_simulation_in_a_wind_track_holds_each_chunks_mean() -> None:
    """simulate_chunks in a steady wind track is the simulation in that steady wind, tick for tick; each chunk's
    record says the wind it ran in."""
    from boat_twin.vessel.environment import Environment, WindTrack
    from boat_twin.vessel.scenarios import make_scenario
    from boat_twin.vessel.simulate import simulate, simulate_chunks

    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2)
    scenario = make_scenario("random", params, np.random.default_rng(3))
    steady = simulate(params, scenario, Environment(wind_east_mps=-7.0, wind_north_mps=2.0))
    t = np.arange(0.0, scenario.duration_s + 1.0, 1.0)
    track = WindTrack(t, np.full(t.size, -7.0), np.full(t.size, 2.0))
    chunks = list(simulate_chunks(params, scenario, chunk_ticks=200, wind_track=track))
    np.testing.assert_array_equal(np.concatenate([c.states for c in chunks]), steady.states)
    turning = WindTrack(t, np.where(t < 100.0, -7.0, 5.0), np.zeros(t.size))
    winds = [c.environment.wind_east_mps for c in simulate_chunks(params, scenario, chunk_ticks=200,
                                                                     wind_track=turning)]
    assert winds[:5] == [-7.0] * 5 and winds[5] == 5.0 and winds[-1] == 5.0


def test_a_wind_known_only_before_the_first_speed_is_held() -> None:
    """A vane that logged only before the GNSS gave its first speed: the re-simulation holds its last reading."""
    from boat_twin.ident.resimulate import resimulate

    params = replace(VesselParams(), frontal_windage_area_m2=AREA_M2)
    trial = boat_trial(params, lambda t: 800.0, lambda t: 0.0, 120.0, np.random.default_rng(7),
                       wind_mps=lambda t: (-8.0, 2.0))
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    late = np.arange(trial.t_s.size) >= 50  # the first GNSS velocity at sample 50
    early = np.arange(trial.t_s.size) < 20  # the vane's last reading at sample 19
    windy = replace(trial, vel_east_mps=np.where(late, trial.vel_east_mps, np.nan),
                    vel_north_mps=np.where(late, trial.vel_north_mps, np.nan),
                    wind_east_mps=np.where(early, trial.wind_east_mps, np.nan),
                    wind_north_mps=np.where(early, trial.wind_north_mps, np.nan))
    result = resimulate(windy, {}, params).to_dict()
    assert result["wind_east_north_mps"] == pytest.approx([-8.0, 2.0], abs=0.3)
    assert result["speed_rmse_mps"] < 0.1
