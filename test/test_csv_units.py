"""A CSV trial in a logger's own units and conventions (issue 43): time in ms, heading in degrees NED, a clockwise
yaw rate in deg/s, NED local positions, forces per thruster. The mapping states them; the Trial read must match
the boat that made the log.

The boat is a small skid-steer hull integrated here (RK4, 100 Hz; written apart from the twin): surge
m·u' = F_L + F_R − d·u, yaw I·r' = b·(F_R − F_L) − n·r (ENU: the right thruster pushing harder turns it
counter-clockwise), logged at 10 Hz with white noise on every measured column.
"""

import math

import numpy as np
import pymap3d
import pytest
import yaml
from independent import rk4_held

from boat_twin.cli import main
from boat_twin.errors import InputError
from boat_twin.frames import wrap_pi
from boat_twin.io.sources import read_trial_file

ORIGIN = (43.29, 5.36, 0.0)
MASS_KG, DAMPING_NSPM, HALF_BEAM_M, INERTIA_KGM2, YAW_DAMPING_NMS = 30.0, 25.0, 0.35, 8.0, 30.0
FORCES_N = ((20.0, 20.0, 30.0), (30.0, 10.0, 40.0), (10.0, 30.0, 30.0), (0.0, 0.0, 20.0))
"""(left N, right N, held s): ahead, a turn to starboard, a turn to port, idle."""
START_HEADING_NED_DEG = 350.0
"""Starts heading just west of north: the logged heading wraps across 360°/0° as the boat turns."""
NOISE = {"position_m": 0.02, "heading_deg": 0.5, "yaw_rate_degps": 0.2}
HEADER = ("original_timestamp,lat,lon,yaw,yaw_rate,x_ned,y_ned,thr_left,thr_right,left_force,right_force")
MAPPING = {"columns": {
    "time": {"column": "original_timestamp", "unit": "ms"}, "lat": "lat", "lon": "lon",
    "heading": {"column": "yaw", "unit": "deg", "frame": "ned"},
    "yaw_rate": {"column": "yaw_rate", "unit": "deg/s", "sign": "cw"},
    "thrust_left": "left_force", "thrust_right": "right_force"}}


def skid_steer(forces: tuple[tuple[float, float, float], ...] = FORCES_N) -> dict[str, np.ndarray]:
    """The boat's truth at 10 Hz under ``forces`` ((left N, right N, held s), ...): t s, left and right force N,
    east and north m, ENU yaw rad, ENU yaw rate rad/s, surge m/s."""
    dt, sub = 0.1, 10
    left = np.concatenate([np.full(int(round(s / dt)), f) for f, _, s in forces])
    right = np.concatenate([np.full(int(round(s / dt)), f) for _, f, s in forces])

    def deriv(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        east, north, psi, surge, rate = x
        return np.array([surge * math.cos(psi), surge * math.sin(psi), rate,
                         (u[0] + u[1] - DAMPING_NSPM * surge) / MASS_KG,
                         (HALF_BEAM_M * (u[1] - u[0]) - YAW_DAMPING_NMS * rate) / INERTIA_KGM2])

    start = np.array([0.0, 0.0, math.pi / 2 - math.radians(START_HEADING_NED_DEG), 0.0, 0.0])
    rows = rk4_held(deriv, start, np.column_stack([left, right]), dt / sub, sub)
    return {"t": np.arange(left.size) * dt, "left": left, "right": right, "east": rows[:, 0], "north": rows[:, 1],
            "yaw": rows[:, 2], "rate": rows[:, 4], "surge": rows[:, 3]}


def write_log(path, truth: dict[str, np.ndarray], seed: int = 0) -> None:
    """The truth as the logger writes it: epoch milliseconds, heading in degrees NED in [0, 360), yaw rate
    clockwise in deg/s, NED positions, normalised commands beside the forces."""
    rng = np.random.default_rng(seed)
    n = truth["t"].size

    def noisy(x: np.ndarray, key: str) -> np.ndarray:
        return x + rng.normal(0.0, NOISE[key], n)

    north, east = noisy(truth["north"], "position_m"), noisy(truth["east"], "position_m")
    lat, lon, _ = pymap3d.enu2geodetic(east, north, np.zeros(n), *ORIGIN)
    heading = noisy(np.degrees(math.pi / 2 - truth["yaw"]), "heading_deg") % 360.0
    rate_cw = noisy(-np.degrees(truth["rate"]), "yaw_rate_degps")
    stamp_ms = 1_732_790_000_000 + np.round(truth["t"] * 1000.0).astype(np.int64)
    lines = [HEADER] + [
        f"{stamp_ms[i]},{lat[i]:.9f},{lon[i]:.9f},{heading[i]:.2f},{rate_cw[i]:.3f},{north[i]:.3f},{east[i]:.3f},"
        f"{truth['left'][i] / 50:.3f},{truth['right'][i] / 50:.3f},{truth['left'][i]:.2f},{truth['right'][i]:.2f}"
        for i in range(n)]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture()
def log(tmp_path):
    truth = skid_steer()
    write_log(tmp_path / "boat.csv", truth)
    return tmp_path / "boat.csv", truth


def test_a_log_in_ms_degrees_ned_and_clockwise_rate_reads_as_the_boat_that_made_it(tmp_path, log) -> None:
    path, truth = log
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    trial = read_trial_file(path, columns=tmp_path / "map.yaml")
    np.testing.assert_allclose(trial.t_s, truth["t"], atol=1e-6)  # ms → s, from the first row
    assert trial.metadata.rates_hz["gnss_fix"] == pytest.approx(10.0)
    assert np.ptp(truth["yaw"]) > 2 * math.pi  # it turned round, across north (360° → 0° in the log)
    heading_error = np.degrees(wrap_pi(trial.heading_rad - truth["yaw"]))
    assert np.sqrt(np.mean(heading_error**2)) < 1.5 * NOISE["heading_deg"]  # ENU, unwrapped across 360°/0°
    rate_error = np.degrees(trial.yaw_rate_radps - truth["rate"])
    assert np.sqrt(np.mean(rate_error**2)) < 1.5 * NOISE["yaw_rate_degps"]  # counter-clockwise positive
    assert np.min(trial.yaw_rate_radps[300:700]) < -0.2 and np.max(trial.yaw_rate_radps[700:1000]) > 0.2  # stbd, port
    east, north = truth["east"] - truth["east"][0], truth["north"] - truth["north"][0]  # origin: the first fix
    assert np.sqrt(np.mean((trial.east_m - east) ** 2 + (trial.north_m - north) ** 2)) < 4 * NOISE["position_m"]
    np.testing.assert_allclose(trial.thrust_left_N, truth["left"])
    np.testing.assert_allclose(trial.thrust_right_N, truth["right"])


def test_ned_positions_are_north_east_about_the_mapped_origin(tmp_path, log) -> None:
    path, truth = log
    mapping = {"columns": {**MAPPING["columns"], "x_ned": "x_ned", "y_ned": "y_ned"}, "origin": list(ORIGIN[:2])}
    del mapping["columns"]["lat"], mapping["columns"]["lon"]
    (tmp_path / "ned.yaml").write_text(yaml.safe_dump(mapping))
    trial = read_trial_file(path, columns=tmp_path / "ned.yaml")
    assert trial.metadata.origin == ORIGIN
    assert np.sqrt(np.mean((trial.east_m - truth["east"]) ** 2)) < 2 * NOISE["position_m"]
    assert np.sqrt(np.mean((trial.north_m - truth["north"]) ** 2)) < 2 * NOISE["position_m"]


def test_speed_in_knots_and_force_in_kgf_are_converted(tmp_path) -> None:
    rows = ["t,kn,cog,kgf"] + [f"{i * 0.1:.1f},2,90,{1.5 if i > 3 else 0}" for i in range(50)]
    (tmp_path / "k.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "k.yaml").write_text(yaml.safe_dump({"columns": {
        "time": "t", "speed": {"column": "kn", "unit": "kn"}, "course": "cog",
        "thrust_left": {"column": "kgf", "unit": "kgf"}}}))
    trial = read_trial_file(tmp_path / "k.csv", columns=tmp_path / "k.yaml")
    np.testing.assert_allclose(trial.vel_east_mps, 2 * 1852 / 3600)  # course 90° (NED): due east
    np.testing.assert_allclose(trial.vel_north_mps, 0.0, atol=1e-12)
    assert trial.thrust_left_N[-1] == pytest.approx(1.5 * 9.80665)


def test_a_millisecond_time_read_as_seconds_is_one_line_naming_the_unit(tmp_path, log, capsys) -> None:
    path, _ = log
    seconds = {"columns": {**MAPPING["columns"], "time": "original_timestamp"}}  # the unit left out
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(seconds))
    assert main(["identify", str(path), "--columns", str(tmp_path / "map.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "Traceback" not in "\n".join(err)
    assert "column 'original_timestamp' (time, read as s): median step 100 s" in err[-1]
    assert "map it as time: {column: original_timestamp, unit: ms}" in err[-1]
    inline = "time=original_timestamp,lat=lat,lon=lon,thrust_left=left_force,thrust_right=right_force"
    assert main(["diagnose", str(path), "--columns", inline]) == 2
    assert "unit: ms" in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.parametrize(("column", "message"), [
    ({"column": "yaw", "unit": "grad"}, "columns.heading: unknown unit 'grad' (units: rad, deg)"),
    ({"column": "yaw", "frame": "nwu"}, "columns.heading: frame 'nwu': expected ned"),
    ({"column": "yaw", "sign": "cw"}, "columns.heading: unknown key 'sign' (allowed here: column, frame, unit)"),
    ({"unit": "deg"}, "columns.heading: expected a column name or {column: NAME, unit: U}"),
])
def test_a_bad_unit_or_convention_is_named(tmp_path, column, message) -> None:
    (tmp_path / "map.yaml").write_text(yaml.safe_dump({"columns": {**MAPPING["columns"], "heading": column}}))
    (tmp_path / "x.csv").write_text(HEADER + "\n")
    with pytest.raises(InputError, match=message.replace("{", r"\{").replace("}", r"\}").replace("(", r"\(")
                       .replace(")", r"\)")):
        read_trial_file(tmp_path / "x.csv", columns=tmp_path / "map.yaml")
