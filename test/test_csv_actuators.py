"""A CSV trial of a boat file's own actuators (issue 36): the mapping names its columns by the boat's command
topics (``thrusters/<name>/cmd`` in rev/s, ``rudders/<name>/angle`` in degrees), as a bag's topics and a MAVLink
calibration do, and they fill the same slots."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from boat_twin.cli import main
from boat_twin.errors import InputError
from boat_twin.io.bags import read_trial
from boat_twin.io.csv_trial import parse_columns
from boat_twin.io.sources import read_trial_file

SHIP = Path(__file__).resolve().parents[1] / "config" / "boats" / "single_screw_rudder.yaml"
MAPPING = {"columns": {
    "time": "t", "x": "east", "y": "north", "vel_east": "ve", "vel_north": "vn",
    "yaw": "yaw", "yaw_rate": "r",
    "thrusters/main/cmd": {"column": "shaft", "unit": "rpm"},
    "rudders/rudder/angle": {"column": "rudder", "unit": "deg"}}}


def _csv_of(bag: Path, out: Path) -> None:
    """The bag's trial written as a logger's CSV: shaft speed in rpm, rudder angle in degrees."""
    trial = read_trial(bag)
    with out.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["t", "east", "north", "ve", "vn", "yaw", "r", "shaft", "rudder"])
        for row in zip(trial.t_s, trial.east_m, trial.north_m, trial.vel_east_mps, trial.vel_north_mps,
                       trial.heading_rad, trial.yaw_rate_radps, 60.0 * trial.thrust_left_N,
                       np.degrees(trial.angle_left_rad), strict=True):
            writer.writerow([f"{v:.9g}" for v in row])


@pytest.fixture(scope="module")
def ship_csv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """(bag, CSV, columns YAML) of a simulated zigzag of the single-screw + rudder model ship."""
    folder = tmp_path_factory.mktemp("ship_csv")
    bag = folder / "zigzag.mcap"
    assert main(["simulate", "zigzag-10-10", "--config", str(SHIP), "--duration", "130", "--out", str(bag)]) == 0
    table = folder / "zigzag.csv"
    _csv_of(bag, table)
    columns = folder / "columns.yaml"
    columns.write_text(yaml.safe_dump(MAPPING))
    return bag, table, columns


def test_a_ships_columns_named_by_its_actuators_read_as_its_bag(ship_csv: tuple[Path, Path, Path]) -> None:
    """Shaft rpm → rev/s in the first thrust slot, the rudder in degrees → rad in the first steering slot, the
    empty second thruster slot at 0 N (as the bag reader does), each column noted with its actuator."""
    bag, table, columns = ship_csv
    from_bag = read_trial(bag)
    trial = read_trial_file(table, columns=columns, order=("main", "rudder"))
    np.testing.assert_allclose(trial.thrust_left_N, from_bag.thrust_left_N, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(trial.angle_left_rad, from_bag.angle_left_rad, rtol=1e-7, atol=1e-9)
    assert np.all(trial.thrust_right_N == 0.0) and np.all(trial.angle_right_rad == 0.0)
    assert np.nanmax(np.abs(trial.angle_left_rad)) == pytest.approx(math.radians(10.0))
    assert trial.metadata.topics["thrust_left"] == "column shaft (thrusters/main/cmd)"
    assert any("second slot is empty" in note for note in trial.metadata.stream_choices)


def test_identify_and_diagnose_take_a_ships_csv_named_by_its_actuators(
        ship_csv: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """The verbs read the CSV through the boat file's actuator order: the surge fitted as from the bag, the
    clean trial diagnosed silent."""
    bag, table, columns = ship_csv
    fits = []
    for trial, extra in ((bag, []), (table, ["--columns", str(columns)])):
        capsys.readouterr()
        assert main(["identify", str(trial), *extra, "--config", str(SHIP), "--json"]) == 0
        fits.append(json.loads(capsys.readouterr().out)["output_error"]["selected"])
    assert fits[1]["model"] == fits[0]["model"]
    assert fits[1]["coefficients"] == pytest.approx(fits[0]["coefficients"], rel=1e-3, abs=1e-3)
    assert fits[1]["rmse_mps"] == pytest.approx(fits[0]["rmse_mps"], rel=1e-3)
    assert main(["diagnose", str(table), "--columns", str(columns), "--config", str(SHIP), "--json"]) == 0
    diagnosis = json.loads(capsys.readouterr().out)
    assert diagnosis["trial"] == str(table)
    assert (diagnosis["verdict"], diagnosis["unexplained"], diagnosis["ambiguous"]) == ([], False, None)


@pytest.mark.parametrize(("columns", "message"), [
    ({"thrust_left": "a", "thrusters/main/cmd": "b"}, r"columns\.thrust_left: name the commands either by role"),
    ({"thrusters/a/thrust": "a", "thrusters/b/thrust": "b", "thrusters/c/thrust": "c"},
     r"columns\.thrusters/c/thrust: the twin has two thruster and two steering slots"),
    ({"thrusters/main/cmd": {"column": "a", "unit": "N"}}, r"columns\.thrusters/main/cmd: unknown unit 'N'"),
    ({"thrusters/main/thrust": {"column": "a", "unit": "rpm"}}, r"columns\.thrusters/main/thrust: unknown unit"),
    ({"thrusters/main/thrust": "a", "propellers/main/cmd": "b"}, r"unknown quantity 'propellers/main/cmd'"),
])
def test_a_wrong_actuator_mapping_is_refused_naming_its_field(tmp_path: Path, columns: dict, message: str) -> None:
    spec = tmp_path / "columns.yaml"
    spec.write_text(yaml.safe_dump({"columns": {"time": "t", "x": "e", "y": "n", **columns}}))
    with pytest.raises(InputError, match=message):
        parse_columns(spec)


def test_a_calibration_names_the_actuator_its_column_was_mapped_by(tmp_path: Path) -> None:
    """A PWM column calibrated under its actuator's name lands in that actuator's slot; a calibration of an
    actuator no column names is refused."""
    spec = tmp_path / "columns.yaml"
    body = {"columns": {"time": "t", "x": "e", "y": "n", "thrusters/port/cmd": "pwm_p",
                        "thrusters/stbd/cmd": "pwm_s"},
            "calibration": {"thrusters/stbd/cmd": [[1100, -1.0], [1900, 1.0]]}}
    spec.write_text(yaml.safe_dump(body))
    columns, calibration, _ = parse_columns(spec, order=("port", "stbd"))
    assert columns["thrust_left"].column == "pwm_p" and columns["thrust_right"].column == "pwm_s"
    assert list(calibration) == ["thrust_right"]
    for calibrated, message in (("thrusters/aft/cmd", r"calibration for 'thrusters/aft/cmd': only mapped commands"),
                                ("thrust_left", r"calibration for 'thrust_left': only mapped commands "
                                                r"\(thrusters/port/cmd, thrusters/stbd/cmd\)")):
        body["calibration"] = {calibrated: [[1100, -1.0], [1900, 1.0]]}
        spec.write_text(yaml.safe_dump(body))
        with pytest.raises(InputError, match=message):
            parse_columns(spec, order=("port", "stbd"))
    body["calibration"] = {"thrusters/stbd/cmd": [[1100, -1.0], [1900, 1.0]]}
    body["columns"]["thrusters/stbd/cmd"] = {"column": "pwm_s", "unit": "rpm"}
    spec.write_text(yaml.safe_dump(body))
    with pytest.raises(InputError, match=r"columns\.thrusters/stbd/cmd: a calibrated command's table .* drop its unit"):
        parse_columns(spec, order=("port", "stbd"))


def test_identify_takes_the_config_boat_as_the_boat_of_its_twin(ship_csv: tuple[Path, Path, Path],
                                                                tmp_path: Path) -> None:
    """Without --boat, the --config boat file the trial was read with is the boat: twin.yaml keeps its screw and
    rudder (not the default boat's two outboards) and its mass where the zigzag does not identify one."""
    from boat_twin.config import load_twin_config

    _, table, columns = ship_csv
    out = tmp_path / "out"
    assert main(["identify", str(table), "--columns", str(columns), "--config", str(SHIP), "--out", str(out)]) == 0
    twin = load_twin_config(out / "twin.yaml", None, None).vessel
    ship = load_twin_config(SHIP, None, None).vessel
    assert twin.propulsion is not None and [t.name for t in twin.propulsion.thrusters] == ["main"]
    assert [r.name for r in twin.propulsion.rudders] == ["rudder"]
    assert (twin.length_m, twin.beam_m) == (ship.length_m, ship.beam_m)
    sources = json.loads((out / "identify.json").read_text())["twin"]["sources"]
    assert sources["length_m"] == "boat file" and sources["mass_kg"].startswith("boat file (held")
    assert twin.mass_kg == ship.mass_kg
