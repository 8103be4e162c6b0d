"""What an ``identify --each`` row says (issue 43): ``no_twin`` when no twin.yaml was written, a null mass when
the data do not identify it (even with a boat file's mass held), rounded numbers in summary.csv, and the
resistance curve in curves.csv, one point a line.

The trial is test_csv_units' skid-steer log: one thrust level held, then turns and idle: the data identify the
resistance but not the mass."""

from __future__ import annotations

import csv
import json

import pytest
import yaml
from test_csv_units import MAPPING, skid_steer, write_log

from boat_twin.cli import main


@pytest.fixture(scope="module")
def skid(tmp_path_factory):
    root = tmp_path_factory.mktemp("skid")
    (root / "trials").mkdir()
    write_log(root / "trials" / "skid.csv", skid_steer())
    (root / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    (root / "boat.yaml").write_text(yaml.safe_dump({"vessel": {
        "mass_kg": 30.0, "length_m": 1.5, "beam_m": 0.8, "engine_y_m": 0.35, "bollard_thrust_N": 40.0,
        "turn_speed_mps": 0.8}}))
    return root


def rows(out):
    with (out / "summary.csv").open() as fh:
        table = list(csv.DictReader(fh))
    with (out / "curves.csv").open() as fh:
        curves = list(csv.DictReader(fh))
    return json.loads((out / "summary.json").read_text()), table, curves


def test_a_trial_without_a_twin_is_no_twin_with_a_null_mass_and_its_curve_apart(skid, capsys) -> None:
    out = skid / "out"
    assert main(["identify", str(skid / "trials"), "--columns", str(skid / "map.yaml"), "--each", "--out",
                 str(out), "--scheduler", "sync"]) == 0  # no twin is not a failure
    assert "1 trial(s), 0 ok, 1 no twin (0 complete from an earlier run), 0 failed" in capsys.readouterr().out
    (row,), (line,), curves = rows(out)
    assert not (out / "skid" / "twin.yaml").exists()
    assert row["status"] == line["status"] == "no_twin" and row["error"] is None
    assert row["mass_identified"] is False and row["mass_kg"] is None and row["mass_ci95_low_kg"] is None
    assert line["mass_kg"] == ""
    assert "curve_N" not in line and "curve_speed_mps" not in line  # not packed into one cell
    assert len(curves) == len(row["curve_N"]) == 11 and {c["trial"] for c in curves} == {"skid"}
    for point, speed, force in zip(curves, row["curve_speed_mps"], row["curve_N"], strict=True):
        assert float(point["curve_speed_mps"]) == pytest.approx(speed, rel=1e-3, abs=1e-9)
        assert float(point["curve_N"]) == pytest.approx(force, rel=1e-3, abs=1e-9)
    for value in [*line.values(), *(v for c in curves for v in c.values())]:  # 4 significant digits at most
        digits = value.lstrip("-").split("e")[0].replace(".", "").lstrip("0")
        assert not value.replace(".", "").replace("-", "").isdigit() or len(digits) <= 4, value
    assert float(line["heldout_rmse_mps"]) == pytest.approx(row["heldout_rmse_mps"], rel=1e-3)
    capsys.readouterr()  # a resume keeps the row (a no_twin trial is complete, not failed)
    assert main(["identify", str(skid / "trials"), "--columns", str(skid / "map.yaml"), "--each", "--out",
                 str(out), "--scheduler", "sync"]) == 0
    assert "(1 complete from an earlier run)" in capsys.readouterr().out


def test_a_boat_files_mass_held_is_not_reported_as_identified(skid) -> None:
    out = skid / "held"
    assert main(["identify", str(skid / "trials"), "--columns", str(skid / "map.yaml"), "--boat",
                 str(skid / "boat.yaml"), "--each", "--out", str(out), "--scheduler", "sync", "--json"]) == 0
    (row,), _, _ = rows(out)
    report = json.loads((out / "skid" / "identify.json").read_text())
    assert report["model"]["effective_mass_kg"] > 30.0  # the boat file's, with its added mass, held
    assert row["mass_identified"] is False and row["mass_kg"] is None and row["mass_ci95_high_kg"] is None
    assert row["status"] == "ok" and (out / "skid" / "twin.yaml").exists()
    held = [w for w in report["warnings"] if "kg is held in the model" in w]  # said, not only in the text
    assert len(held) == 1 and "do not identify the mass" in held[0], report["warnings"]
    assert f"(with its added mass) {report['model']['effective_mass_kg']:.0f} kg is held" in held[0]


def test_a_line_after_the_batch_progress_bar_starts_on_its_own_line(capsys) -> None:
    """The batch bar is the one progress line (boat_twin.progress_line): an error or stop line ends it first."""
    from boat_twin import progress_line
    from boat_twin.fleet.batch import Progress

    bar = Progress("diagnose", 3)
    bar.update({"status": "ok"})
    progress_line.end()  # what the verbs' error and stop paths call before their line
    err = capsys.readouterr().err
    assert err.startswith("\rdiagnose [") and "1/3, 0 error(s)" in err and err.endswith("\n")
