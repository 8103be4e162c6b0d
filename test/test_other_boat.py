"""A different boat end to end (issue 14): identify → twin.yaml → simulate / diagnose on a 2 m, 55 kg two-thruster
survey boat.

Its figures are the published ones of the Maritime Robotics Otter USV as T. I. Fossen's MSS toolbox models it
(VESSELS/otter.m in github.com/cybergalactic/MSS, MIT licence): length 2.0 m, beam 1.08 m, mass 55 kg, the two
pontoons' centres (and propellers) 0.395 m off the centreline, draft 0.134 m (55 kg in two pontoons of 0.25 m beam
and block coefficient 0.4), yaw radius of gyration 0.25·L, bollard thrust 24.4 kgf ahead and 13.6 kgf astern for
the pair, top speed 6 kn, linear surge damping Xu = 24.4 kgf / 6 kn = 77.5 N·s/m. Assumed here: the propellers'
shaft power holds the bollard thrust up to the top speed at η = 0.55 (672 W each), and the reference turn from which
the twin derives its hull's sway and yaw damping (docs/model.md) is stated at 2 m/s, a speed the trials hold: the
turning is not identified from thrust and speed, so the boat file states it where the identified Fc is known.

The boat runs by two routes: the twin with its own parameters, and a small straight-line integrator written here
(10 % surge added mass, Fc = 77.5·v + 4·v·|v| N, thrust lagging its command by 0.1 s, RK4 at 100 Hz, sensors sampled
at 10 Hz with white noise), written as a bag through the message builders.
"""

import json
import math
from dataclasses import replace

import numpy as np
import pymap3d
import pytest
import yaml
from independent import rk4_held

from boat_twin.cli import main
from boat_twin.config import TwinConfig, load_config, save_config
from boat_twin.errors import InputError
from boat_twin.ident.twin_config import load_boat, read_boat_file
from boat_twin.io import messages
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.sources import read_trial_file
from boat_twin.units import KGF_N, KNOT_MPS
from boat_twin.vessel.params import VesselParams, derive_coefficients, params_from_dict, similar_boat
from boat_twin.vessel.resistance import PowerSeriesResistance, resistance_from_dict

TOP_SPEED_MPS = 6.0 * KNOT_MPS
BOLLARD_N = 24.4 * KGF_N / 2.0
LINEAR_DAMPING = 24.4 * KGF_N / TOP_SPEED_MPS
OTTER = {  # the boat file a user would write (SI): published figures (module docstring)
    "mass_kg": 55.0, "length_m": 2.0, "beam_m": 1.08, "draft_m": 0.134, "radius_of_gyration_yaw_m": 0.5,
    "engine_y_m": 0.395, "bollard_thrust_N": BOLLARD_N, "reverse_thrust_ratio": 13.6 / 24.4,
    "engine_power_W": BOLLARD_N * TOP_SPEED_MPS / 0.55, "turn_speed_mps": 2.0,
}
LEVELS_N = (20.0, 40.0, 60.0, 80.0, 100.0, 70.0, 30.0, 0.0)
"""Thrust per propeller of the staircase, N (both alike: a straight run)."""
HOLD_S = 25.0
"""Each level's hold, s: over 30 surge time constants of the Otter (m11/Xu ≈ 0.75 s), and long enough for the
steady-state test to average a GNSS speed noise of 0.05 m/s."""
ORIGIN = (59.43, 10.47, 0.0)
COURSE = math.radians(20.0)
"""The independent integrator's course, ENU (counter-clockwise from east), rad."""


def otter_vessel() -> VesselParams:
    """The Otter as the twin's vessel: the boat file's facts, the rest carried from the default boat."""
    facts = {k: v for k, v in OTTER.items() if k != "mass_kg"}
    return similar_boat(PowerSeriesResistance((0.0, LINEAR_DAMPING), TOP_SPEED_MPS), OTTER["mass_kg"], facts)


TURN_N = (70.0, 30.0)
"""Left and right thrust of a turn to starboard by differential thrust, N (the Otter has no rudder)."""


def write_commands(path, turn=False):
    """The staircase as a command CSV; with ``turn``, then a hold of :data:`TURN_N`. Returns its duration, s."""
    levels = [(f, f) for f in LEVELS_N] + ([TURN_N, (0.0, 0.0)] if turn else [])
    rows = ["t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad"]
    rows += [f"{i * HOLD_S},{left},{right},0,0" for i, (left, right) in enumerate(levels)]
    path.write_text("\n".join(rows) + "\n")
    return len(levels) * HOLD_S


@pytest.fixture()
def boat_file(tmp_path):
    path = tmp_path / "otter.yaml"
    path.write_text(yaml.safe_dump({"vessel": OTTER}))
    return path


def test_the_default_boats_turn_is_not_kept_for_a_small_boat() -> None:
    """The failure this fixes: a 16.5 kg hull over the default 6 m boat's geometry and reference turn cannot
    derive its hull damping; the similar boat (carried to its size) can, and at 1300 kg it is the default boat.
    A vessel section that states another mass is carried too (issue 36), not laid over the 6 m boat."""
    resistance = {"model": "power_series", "coefficients": [0.0, 6.0, 12.0], "max_speed_mps": 2.0}
    with pytest.raises(Exception, match="negative hull damping"):
        derive_coefficients(replace(VesselParams(), resistance=PowerSeriesResistance((0.0, 6.0, 12.0), 2.0),
                                    mass_kg=16.5))
    carried = params_from_dict({"resistance": resistance, "mass_kg": 16.5}, "model")
    assert carried.length_m == pytest.approx(6.0 * (16.5 / 1300.0) ** (1 / 3))
    assert derive_coefficients(carried).yaw_damping_Nms > 0.0
    small = similar_boat(PowerSeriesResistance((0.0, 6.0, 12.0), 3.0), 16.5)
    assert small.length_m == pytest.approx(6.0 * (16.5 / 1300.0) ** (1 / 3))
    assert small.turn_speed_mps == pytest.approx(6.0 * math.sqrt(small.length_m / 6.0))  # Froude-scaled: 2.9 m/s
    assert similar_boat(PowerSeriesResistance((0.0, 6.0, 12.0), 2.0), 16.5).turn_speed_mps == 2.0  # where Fc is known
    assert derive_coefficients(small).yaw_damping_Nms > 0.0
    default = VesselParams()
    assert similar_boat(default.resistance, default.mass_kg) == default
    assert similar_boat(PowerSeriesResistance((0.0, 1.0), 1.0), 55.0, {"length_m": 2.0}).engine_x_m == \
        pytest.approx(default.engine_x_m / 3.0)


def test_twin_made_otter_identifies_into_a_twin_that_simulates_and_diagnoses_clean(tmp_path, boat_file, capsys):
    """The twin with the Otter's parameters runs the staircase (identified) and, with another seed, the staircase
    and a turn (diagnosed against the identified twin: its turning comes from the boat file's geometry)."""
    save_config(TwinConfig(vessel=otter_vessel()), tmp_path / "otter_twin.yaml")
    durations = {}
    for name, turn, seed in (("steps", False, "5"), ("turn", True, "6")):
        durations[name] = write_commands(tmp_path / f"{name}.csv", turn=turn)
        assert main(["simulate", "--commands", str(tmp_path / f"{name}.csv"), "--config",
                     str(tmp_path / "otter_twin.yaml"), "--duration", str(durations[name]), "--seed", seed,
                     "--out", str(tmp_path / f"{name}.mcap")]) == 0
    capsys.readouterr()
    assert main(["identify", str(tmp_path / "steps.mcap"), "--boat", str(boat_file), "--out",
                 str(tmp_path / "ident"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["twin"]["sources"]["length_m"] == "boat file"
    assert result["twin"]["sources"]["mass_kg"] == "identified (output-error fit)"
    twin_yaml = str(tmp_path / "ident" / "twin.yaml")
    twin = load_config(tmp_path / "ident" / "twin.yaml")
    assert (twin.vessel.length_m, twin.vessel.beam_m, twin.vessel.engine_y_m) == (2.0, 1.08, 0.395)
    assert twin.vessel.mass_kg == pytest.approx(55.0, rel=0.15)
    speeds = np.linspace(0.5, 2.5, 9)
    np.testing.assert_allclose(twin.vessel.resistance.force_N(speeds), LINEAR_DAMPING * speeds, rtol=0.08, atol=3.0)
    resim = result["resimulation"]
    assert resim["speed_rmse_mps"] < 1.5 * resim["speed_noise_mps"] + 0.02, resim
    assert main(["simulate", "--commands", str(tmp_path / "turn.csv"), "--config", twin_yaml, "--duration",
                 str(durations["turn"]), "--seed", "6", "--out", str(tmp_path / "again.mcap")]) == 0
    a, b = read_trial(tmp_path / "turn.mcap"), read_trial(tmp_path / "again.mcap")
    n = min(len(a), len(b))
    assert np.sqrt(np.nanmean((a.speed_mps[:n] - b.speed_mps[:n]) ** 2)) < 0.1  # same seed: noise cancels
    assert abs(a.heading_rad[n - 1] - b.heading_rad[n - 1]) < 0.2 * abs(a.heading_rad[n - 1] - a.heading_rad[0])
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "turn.mcap"), "--config", twin_yaml, "--json"]) == 0
    diagnosis = json.loads(capsys.readouterr().out)
    assert not diagnosis["unexplained"], diagnosis["signature"]
    # Clean, or what the identification got wrong: the identified mass is within 15 % of the Otter's, and a mass
    # more than the diagnosis' 10 % floor off is named with the true factor (measured: 61.3 kg identified, the
    # factor 55 / 61.3 = 0.897 named as 0.897, inside its interval).
    assert [v["effect"] for v in diagnosis["verdict"]] in ([], ["mass_error"]), diagnosis["verdict"]
    for named in diagnosis["verdict"]:
        low, high = named["ci95"]["mass_factor"]
        assert low <= OTTER["mass_kg"] / twin.vessel.mass_kg <= high, (named, twin.vessel.mass_kg)


def integrate(seed=0):
    """The independent Otter (module docstring) on a straight course 20° north of east, measured at 10 Hz:
    (t s, total thrust command N, true speed m/s, acceleration m/s², east m, north m, measured speed m/s,
    yaw rad, yaw rate rad/s), with white noise on the measurements."""
    rng = np.random.default_rng(seed)
    mass, quadratic, lag = 1.10 * OTTER["mass_kg"], 4.0, 0.1
    dt, sub = 0.1, 10
    h = dt / sub
    t = np.arange(0.0, len(LEVELS_N) * HOLD_S, dt)
    command = 2.0 * np.asarray(LEVELS_N)[np.minimum((t / HOLD_S).astype(int), len(LEVELS_N) - 1)]

    def deriv(x, u):
        drag = LINEAR_DAMPING * x[0] + quadratic * x[0] * abs(x[0])
        return np.array([(x[1] - drag) / mass, (u - x[1]) / lag, x[0]])

    rows = rk4_held(deriv, np.zeros(3), command, h, sub)
    speed, distance = rows[:, 0], rows[:, 2]
    east = distance * math.cos(COURSE) + rng.normal(0.0, 0.3, t.size)
    north = distance * math.sin(COURSE) + rng.normal(0.0, 0.3, t.size)
    return (t, command, speed, np.gradient(speed, dt), east, north, speed + rng.normal(0.0, 0.05, t.size),
            COURSE + rng.normal(0.0, 0.02, t.size), rng.normal(0.0, 0.005, t.size))


def integrator_bag(path, seed=0):
    """:func:`integrate` as a bag in the twin's topic layout. Returns (t s, true speed m/s)."""
    t, command, speed, accel, east, north, vel, yaw, rate = integrate(seed)
    course = COURSE
    lat, lon, alt = pymap3d.enu2geodetic(east, north, np.zeros(t.size), *ORIGIN)
    cov = messages.diagonal_covariance([0.09, 0.09, 1.0])
    out = []
    for i, ns in enumerate(messages.stamps_ns(t + 50.0).tolist()):
        out.append(("gnss/fix", ns, messages.navsatfix(messages.header(ns, "gnss_link"), lat[i], lon[i], alt[i], cov)))
        out.append(("gnss/vel", ns, messages.twist_stamped(messages.header(ns, "gnss_link"),
                                                           (vel[i] * math.cos(course), vel[i] * math.sin(course),
                                                            0.0))))
        q = (0.0, 0.0, math.sin(yaw[i] / 2), math.cos(yaw[i] / 2))
        out.append(("imu/data", ns, messages.imu(messages.header(ns, "imu_link"), q, (0.0, 0.0, rate[i]),
                                                 (accel[i], 0.0, 9.81), cov, cov, cov)))
        for topic in messages.COMMAND_TOPICS:
            value = command[i] / 2.0 if topic.endswith("thrust") else 0.0
            out.append((topic, ns, messages.float64(value)))
    write_bag(path, out)
    return t, speed


def test_an_independently_integrated_otter_gives_a_twin_that_follows_it(tmp_path, boat_file, capsys) -> None:
    t, speed = integrator_bag(tmp_path / "otter.mcap")
    assert main(["identify", str(tmp_path / "otter.mcap"), "--boat", str(boat_file), "--out",
                 str(tmp_path / "ident")]) == 0
    text = capsys.readouterr().out
    assert "twin: 2 m x 1.08 m" in text and "twin.yaml" in text
    twin = load_config(tmp_path / "ident" / "twin.yaml")
    assert twin.vessel.mass_kg * (1 + twin.vessel.surge_added_mass_ratio) == pytest.approx(1.10 * 55.0, rel=0.15)
    write_commands(tmp_path / "steps.csv")
    assert main(["simulate", "--commands", str(tmp_path / "steps.csv"), "--config",
                 str(tmp_path / "ident" / "twin.yaml"), "--duration", str(t[-1] + 0.1), "--no-noise",
                 "--out", str(tmp_path / "twin.mcap")]) == 0
    simulated = read_trial(tmp_path / "twin.mcap")
    true_speed = np.interp(simulated.t_s, t, speed)
    assert np.sqrt(np.nanmean((simulated.speed_mps - true_speed) ** 2)) < 0.05
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "otter.mcap"), "--config", str(tmp_path / "ident" / "twin.yaml"),
                 "--json"]) == 0
    diagnosis = json.loads(capsys.readouterr().out)
    assert not diagnosis["unexplained"], diagnosis["signature"]
    # Clean, or what the identification got wrong: the identified mass is within 15 % of the Otter's, and a mass
    # more than the diagnosis' 10 % floor off is named with the true factor (measured: 61.3 kg identified, the
    # factor 55 / 61.3 = 0.897 named as 0.897, inside its interval).
    assert [v["effect"] for v in diagnosis["verdict"]] in ([], ["mass_error"]), diagnosis["verdict"]
    for named in diagnosis["verdict"]:
        low, high = named["ci95"]["mass_factor"]
        assert low <= OTTER["mass_kg"] / twin.vessel.mass_kg <= high, (named, twin.vessel.mass_kg)
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "otter.mcap"), "--json"]) == 0  # the default 6 m twin: far off
    assert json.loads(capsys.readouterr().out)["unexplained"]
    assert main(["identify", str(tmp_path / "otter.mcap"), "--out", str(tmp_path / "no_boat_file")]) == 0
    guessed = load_config(tmp_path / "no_boat_file" / "twin.yaml").vessel  # the default boat carried to the mass
    assert guessed.length_m == pytest.approx(6.0 * (guessed.mass_kg / 1300.0) ** (1 / 3))
    similar_bollard_N = VesselParams().bollard_thrust_N * guessed.mass_kg / VesselParams().mass_kg  # ∝ mass
    assert 1.8 < guessed.length_m < 2.4  # bollard: the similar boat's, raised to the largest command held
    assert guessed.bollard_thrust_N == pytest.approx(max(max(LEVELS_N), similar_bollard_N))
    assert main(["simulate", "--commands", str(tmp_path / "steps.csv"), "--config",
                 str(tmp_path / "no_boat_file" / "twin.yaml"), "--out", str(tmp_path / "guessed.mcap")]) == 0


def test_one_boat_file_serves_simulate_and_identify(tmp_path, capsys) -> None:
    """A twin config (resistance, environment and all) is a boat file: identify reads its vessel facts, ignores
    and reports what it measures and the other sections; a field no vessel has is still refused."""
    config = tmp_path / "otter_twin.yaml"
    config.write_text(yaml.safe_dump({"vessel": {**OTTER, "resistance": {
        "model": "power_series", "coefficients": [0.0, LINEAR_DAMPING], "max_speed_mps": TOP_SPEED_MPS}},
        "environment": {"current_east_mps": 0.2}}))
    write_commands(tmp_path / "steps.csv")
    assert main(["simulate", "--commands", str(tmp_path / "steps.csv"), "--config", str(config), "--duration",
                 "5", "--json"]) == 0
    boat = read_boat_file(config)
    assert boat.facts == load_boat(config) == {k: float(v) for k, v in OTTER.items()}
    assert boat.ignored == ("vessel.resistance", "environment")
    (tmp_path / "typo.yaml").write_text("vessel: {length_m: 2.0, lenght_m: 2.0}\n")
    with pytest.raises(InputError, match="typo.yaml: unknown vessel field 'lenght_m'"):
        load_boat(tmp_path / "typo.yaml")
    (tmp_path / "section.yaml").write_text("vessel: {length_m: 2.0}\nsensors: {}\n")
    with pytest.raises(InputError, match="section.yaml: unknown section 'sensors'"):
        load_boat(tmp_path / "section.yaml")


PWM_TABLE = [[1100, -13.6 * KGF_N / 2], [1500, 0.0], [1900, BOLLARD_N]]
"""The CSV's thruster commands are PWM µs; this table (an ESC's, assumed) maps them to N per thruster."""


def write_csv(path, seed=0):
    """:func:`integrate` as a CSV a logger might write: NMEA-style lat/lon, speed and course over ground, compass
    heading, yaw rate, PWM per thruster; the compass columns at 5 Hz (blank cells in between)."""
    t, command, speed, _, east, north, vel, yaw, rate = integrate(seed)
    lat, lon, _ = pymap3d.enu2geodetic(east, north, np.zeros(t.size), *ORIGIN)
    pwm = np.interp(command / 2.0, [p[1] for p in PWM_TABLE], [p[0] for p in PWM_TABLE])
    lines = ["time_s,latitude,longitude,sog_mps,cog_deg,hdg_deg,r_radps,pwm_l,pwm_r"]
    for i in range(t.size):
        compass = f"{90.0 - math.degrees(yaw[i]):.3f},{rate[i]:.5f}" if i % 2 == 0 else ","
        lines.append(f"{t[i]:.2f},{lat[i]:.9f},{lon[i]:.9f},{vel[i]:.4f},{90.0 - math.degrees(COURSE):.2f},{compass},"
                     f"{pwm[i]:.2f},{pwm[i]:.2f}")
    path.write_text("\n".join(lines) + "\n")
    return t, speed


MAPPING = {"columns": {"time": "time_s", "lat": "latitude", "lon": "longitude", "speed": "sog_mps",
                       "course": "cog_deg", "heading": "hdg_deg", "yaw_rate": "r_radps", "thrust_left": "pwm_l",
                       "thrust_right": "pwm_r"},
           "calibration": {"thrust_left": PWM_TABLE, "thrust_right": PWM_TABLE}}


def test_a_csv_trial_identifies_and_diagnoses_like_a_bag(tmp_path, boat_file, capsys) -> None:
    t, speed = write_csv(tmp_path / "otter.csv")
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    trial = read_trial_file(tmp_path / "otter.csv", columns=tmp_path / "map.yaml")
    assert trial.metadata.rates_hz["imu"] == pytest.approx(5.0) and trial.metadata.rates_hz["gnss_vel"] == \
        pytest.approx(10.0)
    np.testing.assert_allclose(trial.heading_rad[:-1], COURSE, atol=0.1)  # the last row has no compass
    truth = np.interp(trial.t_s, t - t[0], speed)
    assert np.sqrt(np.nanmean((trial.speed_mps - truth) ** 2)) < 0.07
    assert main(["identify", str(tmp_path / "otter.csv"), "--columns", str(tmp_path / "map.yaml"), "--json",
                 "--boat", str(boat_file)]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["output_error"]["selected"]["mass_kg"] == pytest.approx(1.10 * 55.0, rel=0.15)
    model = resistance_from_dict(result["model"]["resistance"])
    grid = np.linspace(0.5, 2.5, 9)
    np.testing.assert_allclose(model.force_N(grid), LINEAR_DAMPING * grid + 4.0 * grid**2, rtol=0.08)
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "otter.csv"), "--columns", str(tmp_path / "map.yaml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["unexplained"]  # the default 6 m twin is far off this boat
    for columns, message in (("time=time_s,speed=sog_mps,thrust_left=pwm_l", "'speed' needs 'course', 'heading'"),
                             ("time=time_s,lat=latitude,thrust_left=pwm_l", "'lat' and 'lon' go together"),
                             ("time=time_s,sog=sog_mps", "unknown quantity 'sog'"), (None, "needs --columns")):
        assert main(["identify", str(tmp_path / "otter.csv")] + (["--columns", columns] if columns else [])) == 2
        assert message in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.parametrize(("edit", "message"), [
    (lambda rows: rows[:5] + ["0.4,abc" + rows[5][rows[5].index(",", 5):]] + rows[6:],
     "otter.csv: row 6, column 'latitude': not a number ('abc')"),
    (lambda rows: rows[:4] + [rows[2]] + rows[5:], "otter.csv: row 5, column 'time_s': time 0.1 s does not increase"),
    (lambda rows: [rows[0].replace("sog_mps", "speed")] + rows[1:],
     "otter.csv: column 'sog_mps' (for speed) is not in the header; it has: time_s, latitude"),
    (lambda rows: rows[:7] + [rows[7].replace(rows[7].split(",")[7], "1e999", 1)] + rows[8:],
     "otter.csv: row 8, column 'pwm_l': infinite value"),
])
def test_a_bad_csv_is_one_line_naming_file_row_and_column(tmp_path, capsys, edit, message) -> None:
    write_csv(tmp_path / "otter.csv")
    rows = (tmp_path / "otter.csv").read_text().splitlines()
    (tmp_path / "otter.csv").write_text("\n".join(edit(rows)) + "\n")
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    assert main(["identify", str(tmp_path / "otter.csv"), "--columns", str(tmp_path / "map.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1] and "Traceback" not in "\n".join(err)


def test_a_csv_with_local_positions_and_velocity_components_reads(tmp_path) -> None:
    """Local x/y (m) from an origin given in the mapping, ENU velocity components, yaw in rad, thrust in N; the
    inline mapping form."""
    t, command, speed, _, east, north, vel, yaw, rate = integrate(seed=3)
    lines = ["t,x,y,ve,vn,psi,tl,tr"] + [
        f"{t[i]:.2f},{east[i]:.4f},{north[i]:.4f},{vel[i] * math.cos(COURSE):.4f},{vel[i] * math.sin(COURSE):.4f},"
        f"{yaw[i]:.5f},{command[i] / 2:.3f},{command[i] / 2:.3f}" for i in range(t.size)]
    (tmp_path / "local.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "map.yaml").write_text(yaml.safe_dump({
        "columns": {"time": "t", "x": "x", "y": "y", "vel_east": "ve", "vel_north": "vn", "yaw": "psi",
                    "thrust_left": "tl", "thrust_right": "tr"}, "origin": list(ORIGIN[:2])}))
    trial = read_trial_file(tmp_path / "local.csv", columns=tmp_path / "map.yaml")
    assert trial.metadata.origin == (ORIGIN[0], ORIGIN[1], 0.0)
    np.testing.assert_allclose(trial.east_m, east, atol=1e-3)
    np.testing.assert_allclose(trial.north_m, north, atol=1e-3)
    np.testing.assert_allclose(trial.speed_mps, np.abs(vel), atol=1e-3)
    np.testing.assert_allclose(trial.surge_thrust_N, command, atol=1e-3)
    inline = read_trial_file(tmp_path / "local.csv", columns="time=t,x=x,y=y,thrust_left=tl,thrust_right=tr")
    assert "derived from GNSS positions" in inline.metadata.derived["gnss_vel"]  # no velocity mapped
