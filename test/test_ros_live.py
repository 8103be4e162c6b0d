"""End to end on a real ROS 2 graph, in simulated time: the simulator publishes /clock faster than real time,
the identifier and the cable node run with use_sim_time, a probe drives the boat through the default thrust steps
and records the run (test/liverun.py). The recording then goes through `boat-twin identify` and `diagnose`."""

from __future__ import annotations

import numpy as np
import pytest
import rosnodes
from liverun import COMMAND_TIMEOUT_S, REAL_TIME_FACTOR, LiveRun, boat_twin

from boat_twin.cable import load_case, solve_depth, with_overrides
from boat_twin.config import TwinConfig
from boat_twin.nodes.identifier import DEFAULT_ORDER
from boat_twin.vessel.scenarios import thrust_steps

CABLE_CASE = rosnodes.ROOT / "config" / "cable" / "default.yaml"


@pytest.fixture(scope="module")
def staircase_run(tmp_path_factory):
    """The default thrust-steps trial, live: simulator + identifier + cable (following gnss/vel) + recorder."""
    out = tmp_path_factory.mktemp("live_staircase")
    profile = thrust_steps(TwinConfig().vessel)
    sim_time = {"use_sim_time": True}
    specs = (
        ("simulator", {"publish_clock": True, "real_time_factor": REAL_TIME_FACTOR, "seed": 7,
                       "command_timeout_s": COMMAND_TIMEOUT_S}),
        ("identifier", {**sim_time, "model_path": str(out / "identified.yaml")}),
        ("cable", {**sim_time, "case_file": str(CABLE_CASE), "follow_gnss_vel": True, "update_period_s": 5}),
    )
    with rosnodes.nodes(*specs, log_dir=out) as procs, rosnodes.probe("recorder") as probe:
        run = LiveRun(probe, profile, REAL_TIME_FACTOR)
        run.run()
        probe.spin_for(1.0)
        stderr = {name: proc.stderr for (name, _), proc in zip(specs, procs, strict=True)}
    return run, run.write(out / "live_staircase"), stderr


def test_identifier_converges_to_the_boats_resistance_at_the_visited_speeds(staircase_run) -> None:
    run, _bag, stderr = staircase_run
    assert "Traceback" not in "".join(stderr.values())
    assert "thrust set to zero" not in stderr["simulator"], stderr["simulator"]  # the boat got every command
    _t, values, label = run.coefficients[-1]
    assert label.split(",") == [f"c{i}_N_per_mps{i}" for i in range(DEFAULT_ORDER + 1)] + ["effective_mass_kg"]
    coefficients, mass_kg = np.array(values[:-1]), values[-1]
    vessel = TwinConfig().vessel
    # the visited steady speeds: the truth speed at the end of each level's hold
    truth_t, truth_v = np.array(run.truth_speed).T
    speeds = np.interp(run.profile.times_s[1:] - 1.0, truth_t, truth_v)
    identified = np.polynomial.polynomial.polyval(speeds, coefficients)
    true = vessel.resistance.force_N(speeds)
    assert np.all(np.abs(identified - true) <= 0.05 * true + 15.0), (speeds, identified, true)
    effective_mass = vessel.mass_kg * (1.0 + vessel.surge_added_mass_ratio)
    assert mass_kg == pytest.approx(effective_mass, rel=0.15)


def test_cable_node_follows_the_simulators_speed(staircase_run) -> None:
    run, _bag, _stderr = staircase_run
    case = load_case(CABLE_CASE)
    truth_t, truth_v = np.array(run.truth_speed).T
    depths = np.array(run.depths)
    assert len(np.unique(np.round(depths[:, 1], 2))) >= 5  # it re-solved as the boat sped up
    checked = 0
    for t_s, depth_m in depths[depths[:, 0] > 60.0]:
        v = float(np.interp(t_s, truth_t, truth_v))
        if v < 1.0 or abs(float(np.interp(t_s - 5.0, truth_t, truth_v)) - v) > 0.05:
            continue  # not steady over the last update period
        deeper, shallower = (solve_depth(with_overrides(case, tow_speed_mps=s)).vehicle_depth_m
                             for s in (max(v - 0.3, 0.1), v + 0.3))
        assert min(deeper, shallower) <= depth_m <= max(deeper, shallower), (t_s, v, depth_m)
        checked += 1
    assert checked >= 10


def test_recorded_live_run_identifies_like_the_node(staircase_run) -> None:
    run, bag, _stderr = staircase_run
    result = boat_twin("identify", str(bag), "--order", str(DEFAULT_ORDER))
    online = result["online"]
    assert online["steady_points"] >= 5
    node_values = np.array(run.coefficients[-1][1][:-1])
    speeds = np.array([p["speed_mps"] for p in result["steady_points"]])
    replayed = np.polynomial.polynomial.polyval(speeds, online["coefficients"])
    live = np.polynomial.polynomial.polyval(speeds, node_values)
    np.testing.assert_allclose(live, replayed, rtol=0.02, atol=5.0)


def test_diagnose_names_no_effect_in_the_clean_live_recording(staircase_run) -> None:
    """No catalogue effect is named. `unexplained` is not asserted: under a full suite's load the recorder's lag
    (see REAL_TIME_FACTOR) has flagged it once in three runs; that is the recorder, not the boat."""
    _run, bag, _stderr = staircase_run
    result = boat_twin("diagnose", str(bag))
    assert result["verdict"] == [], result
