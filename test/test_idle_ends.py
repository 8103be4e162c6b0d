"""A recording that starts and ends idling (issue 43): the idle stretches must not make identify refuse the model
(the steady points at rest are below the speed floor of 3× the speed noise and are not checked), --start/--end cut
a trial for identify, diagnose and follow, and a refusal says what to do next.

The boat is test_csv_units' skid-steer hull driven straight (both thrusters alike) through a staircase, with 40 s
of idling (an ESC's 0.05 N trickle) before and after; GNSS velocity components with 0.05 m/s white noise, so the
speed over ground at rest is the noise's magnitude (about 0.06 m/s)."""

from __future__ import annotations

import json

import numpy as np
import pymap3d
import pytest
import yaml
from test_csv_units import ORIGIN, skid_steer

from boat_twin.cli import main
from boat_twin.config import load_config
from boat_twin.ident.report import model_lines
from boat_twin.ident.results import NOT_PHYSICAL_NEXT
from boat_twin.io.sources import read_trial_file
from boat_twin.io.span import trial_between

IDLE_N = 0.05
FORCES = ((IDLE_N, IDLE_N, 40.0), (10.0, 10.0, 30.0), (20.0, 20.0, 30.0), (30.0, 30.0, 30.0), (15.0, 15.0, 30.0),
          (IDLE_N, IDLE_N, 40.0))
COLUMNS = "time=t,lat=lat,lon=lon,vel_east=ve,vel_north=vn,thrust_left=fl,thrust_right=fr"


@pytest.fixture(scope="module")
def idle_log(tmp_path_factory):
    truth = skid_steer(FORCES)
    rng = np.random.default_rng(1)
    n = truth["t"].size
    ve = truth["surge"] * np.cos(truth["yaw"]) + rng.normal(0.0, 0.05, n)
    vn = truth["surge"] * np.sin(truth["yaw"]) + rng.normal(0.0, 0.05, n)
    lat, lon, _ = pymap3d.enu2geodetic(truth["east"] + rng.normal(0.0, 0.3, n),
                                       truth["north"] + rng.normal(0.0, 0.3, n), np.zeros(n), *ORIGIN)
    path = tmp_path_factory.mktemp("idle") / "idle.csv"
    path.write_text("\n".join(["t,lat,lon,ve,vn,fl,fr"] + [
        f"{truth['t'][i]:.1f},{lat[i]:.9f},{lon[i]:.9f},{ve[i]:.3f},{vn[i]:.3f},{truth['left'][i]},"
        f"{truth['right'][i]}" for i in range(n)]) + "\n")
    return path


def test_idling_at_both_ends_is_not_a_refusal(idle_log, tmp_path, capsys) -> None:
    assert main(["identify", str(idle_log), "--columns", COLUMNS, "--json", "--out", str(tmp_path / "o")]) == 0
    result = json.loads(capsys.readouterr().out)
    at_rest = [p for p in result["steady_points"] if p["thrust_N"] == pytest.approx(2 * IDLE_N)]
    assert len(at_rest) == 2 and all(p["speed_mps"] > 0.03 for p in at_rest)  # the noise's magnitude
    assert result["physical_problems"] == []
    (warning,) = [w for w in result["warnings"] if w.startswith("not checked, at rest")]
    assert "3× the speed noise" in warning and "held that speed steadily" in warning
    assert (tmp_path / "o" / "twin.yaml").exists()
    assert result["output_error"]["baseline"]["coefficients"][0] == pytest.approx(25.0, rel=0.05)


def test_a_refusal_says_what_to_do_next(idle_log, tmp_path, capsys) -> None:
    assert main(["identify", str(idle_log), "--columns", COLUMNS, "--json", "--start", "40", "--end", "159.9"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["physical_problems"] == [] and not any("at rest" in w for w in result["warnings"])
    refused = {**result, "physical_problems": ["Fc(0.06 m/s) = 1.5 N is above the 0.1 N that held that speed"]}
    lines = model_lines(refused)
    assert lines[0].startswith("NOT PHYSICAL, no twin:") and lines[1] == NOT_PHYSICAL_NEXT
    assert "--start/--end" in NOT_PHYSICAL_NEXT


def test_start_and_end_cut_the_trial(idle_log, capsys) -> None:
    whole = read_trial_file(idle_log, columns=COLUMNS)
    cut = trial_between(whole, 30.0, 190.0)
    assert cut.t_s[0] == 0.0 and cut.t_s[-1] == pytest.approx(160.0)
    assert cut.metadata.start_time_s == pytest.approx(whole.metadata.start_time_s + 30.0)
    np.testing.assert_array_equal(cut.thrust_left_N, whole.thrust_left_N[300:1901])
    np.testing.assert_array_equal(cut.vel_east_mps, whole.vel_east_mps[300:1901])
    assert "cut to 30.0-190.0 s of the recording (--start/--end)" in cut.metadata.summary_line()
    assert trial_between(whole) is whole
    for verb in ("identify", "diagnose", "follow"):
        assert main([verb, str(idle_log), "--columns", COLUMNS, "--start", "250"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].endswith("--start 250 s to --end 199.9 s keeps 0 sample(s), fewer than 20: the trial spans "
                                "0 to 199.9 s"), err


@pytest.mark.parametrize(("boat_mass_kg", "remarked"), [(15.0, True), (27.0, False)])
def test_a_mass_far_from_the_boat_files_is_remarked_and_twin_yaml_has_the_trials_origin(
        idle_log, tmp_path, capsys, boat_mass_kg, remarked) -> None:
    boat = tmp_path / "boat.yaml"
    boat.write_text(yaml.safe_dump({"vessel": {"mass_kg": boat_mass_kg, "length_m": 1.5, "beam_m": 0.8,
                                               "engine_y_m": 0.35, "bollard_thrust_N": 40.0, "turn_speed_mps": 0.8}}))
    assert main(["identify", str(idle_log), "--columns", COLUMNS, "--boat", str(boat), "--out", str(tmp_path / "o")
                 ]) == 0
    text = capsys.readouterr().out
    twin = load_config(tmp_path / "o" / "twin.yaml")
    assert twin.vessel.mass_kg == pytest.approx(26.7, rel=0.05)  # identified (28 kg with its added mass)
    departure = f"{abs(twin.vessel.mass_kg / boat_mass_kg - 1):.0%}"
    assert ("warning: the identified mass" in text) == remarked, text
    if remarked:
        assert f"the identified mass {twin.vessel.mass_kg:.4g} kg is {departure} above the boat file's 15 kg" in text
    first = read_trial_file(idle_log, columns=COLUMNS)
    assert (twin.gnss.origin_lat_deg, twin.gnss.origin_lon_deg) == (first.lat_deg[0], first.lon_deg[0])
    assert twin.gnss.origin_lat_deg == pytest.approx(ORIGIN[0], abs=1e-5)  # not the default (Vladivostok)
    assert twin.gnss.antenna_height_m == pytest.approx(1.5 * 1.5 / 6.0)  # carried to the 1.5 m boat, not 1.5 m
    assert json.loads((tmp_path / "o" / "identify.json").read_text())["twin"]["gnss_origin"][:2] == \
        [first.lat_deg[0], first.lon_deg[0]]
