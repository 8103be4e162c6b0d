"""``boat-twin cable``: outputs, plots, and bad input as one line with exit code 2."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
import yaml

from boat_twin.cli import main

CONFIG = Path(__file__).resolve().parents[1] / "config" / "cable"
DEFAULT = yaml.safe_load((CONFIG / "default.yaml").read_text())


def write_case(tmp_path: Path, **changes: object) -> Path:
    """The default case with dotted fields replaced (``{"cable.diameter_m": 0}``), as a file."""
    data = copy.deepcopy(DEFAULT)
    for dotted, value in changes.items():
        *parents, leaf = dotted.split("__")
        node = data
        for part in parents:
            node = node[part]
        node[leaf] = value
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def run_json(capsys: pytest.CaptureFixture, *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def test_depth_json_has_the_documented_keys(capsys: pytest.CaptureFixture) -> None:
    out = run_json(capsys, "cable", "depth", "--case", str(CONFIG / "default.yaml"), "--length", "250",
                   "--tow-speed", "2.0", "--json")
    for key in ("vehicle_depth_m", "vehicle_offset_m", "alpha_deg", "top_tension_N", "top_angle_deg",
                "top_horizontal_N", "top_vertical_N", "length_m", "link_tension_N", "link_angle_deg"):
        assert key in out
    assert out["length_m"] == pytest.approx(250.0) and out["tow_speed_mps"] == 2.0
    assert len(out["shape"]["x_m"]) == len(out["shape"]["depth_m"]) == out["links"] + 1
    assert out["shape"]["depth_m"][0] == out["vehicle_depth_m"] and 0.0 < out["vehicle_depth_m"] < 250.0


def test_length_json_inverts_depth(capsys: pytest.CaptureFixture) -> None:
    case = str(CONFIG / "default.yaml")
    p1 = run_json(capsys, "cable", "depth", "--case", case, "--length", "222.2", "--json")
    depth = p1["vehicle_depth_m"]
    out = run_json(capsys, "cable", "length", "--case", case, "--depth", repr(depth), "--json")
    assert out["length_m"] == pytest.approx(222.2, rel=1e-6)
    assert out["problem"] == "length"


def test_plot_writes_a_png_and_refuses_to_overwrite(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    argv = ["cable", "depth", "--case", str(CONFIG / "default.yaml"), "--plot", "--out", str(tmp_path)]
    assert main(argv) == 0
    png = tmp_path / "cable_depth.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    assert main(argv) == 2
    assert "already exists" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0


def test_convergence_prints_the_study(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    argv = ["cable", "convergence", "--case", str(CONFIG / "babanin2025_table2.yaml"),
            "--segments", "10", "5", "--plot", "--out", str(tmp_path)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "observed order" in captured.out and "l for 0.10% depth accuracy" in captured.out
    assert "links of 10 m" in captured.err  # progress goes to stderr
    assert (tmp_path / "cable_convergence.png").exists()


def test_speed_json(capsys: pytest.CaptureFixture) -> None:
    out = run_json(capsys, "cable", "speed", "--case", str(CONFIG / "babanin2025_table1.yaml"),
                   "--depth", "200", "--json")
    slower = run_json(capsys, "cable", "speed", "--case", str(CONFIG / "babanin2025_table1.yaml"),
                      "--depth", "220", "--json")
    assert 0.0 < slower["tow_speed_mps"] < out["tow_speed_mps"]


def assert_one_line_error(capsys: pytest.CaptureFixture, argv: list[str], *needles: str) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    for needle in needles:
        assert needle in err


@pytest.mark.parametrize(("flag", "value", "needle"), [
    ("--length", "0", "cable length"), ("--length", "-5", "cable length"),
    ("--length", "1200", "winch capacity"),
    ("--tow-speed", "-1", "tow speed"), ("--segment-length", "0", "segment length"),
    ("--length", "nan", "cable length"),
])
def test_bad_flags_depth(capsys: pytest.CaptureFixture, flag: str, value: str, needle: str) -> None:
    argv = ["cable", "depth", "--case", str(CONFIG / "default.yaml"), flag, value]
    assert_one_line_error(capsys, argv, needle)


@pytest.mark.parametrize("depth", ["0", "-10"])
def test_bad_depth(capsys: pytest.CaptureFixture, depth: str) -> None:
    argv = ["cable", "length", "--case", str(CONFIG / "default.yaml"), "--depth", depth]
    assert_one_line_error(capsys, argv, "vehicle depth")


@pytest.mark.parametrize(("field", "value", "needle"), [
    ("cable__diameter_m", 0.0, "cable.diameter_m"),
    ("cable__diameter_m", -0.02, "cable.diameter_m"),
    ("vehicle__d_m", 0.0, "vehicle.d_m"),
    ("cable__length_m", -300.0, "cable.length_m"),
    ("cable__segment_length_m", 0, "cable.segment_length_m"),
    ("target_depth_m", -1.0, "target_depth_m"),
    ("current__depth_m", [], "current.depth_m"),
    ("current__depth_m", [0.0, 400.0, 100.0], "increase strictly"),
    ("current__speed_mps", [0.3, 0.1], "current"),
    ("cable__length_m", 1500.0, "winch capacity"),
    ("cable__drag", {"model": "morison"}, "cable.drag.model"),
    ("cable__colour", "red", "unknown field"),
    ("tow_speed_mps", "fast", "tow_speed_mps"),
    ("vehicle__cx", {"alpha_deg": [0, 90], "value": [1.0]}, "vehicle.cx"),
])
def test_bad_case_file(tmp_path: Path, capsys: pytest.CaptureFixture, field: str, value: object,
                       needle: str) -> None:
    path = write_case(tmp_path, **{field: value})
    assert_one_line_error(capsys, ["cable", "depth", "--case", str(path)], needle, str(path))


def test_missing_and_malformed_files(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert_one_line_error(capsys, ["cable", "depth", "--case", str(tmp_path / "nope.yaml")], "cannot read")
    bad = tmp_path / "bad.yaml"
    bad.write_text("cable: [1, 2\n")
    assert_one_line_error(capsys, ["cable", "depth", "--case", str(bad)], "malformed YAML")


def test_non_convergence_is_reported(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    floating = write_case(tmp_path, vehicle__cy=5.0, cable__weight_in_water_Npm=1.0, tow_speed_mps=3.0)
    argv = ["cable", "depth", "--case", str(floating), "--length", "100"]
    assert_one_line_error(capsys, argv, "lift exceeds")
    argv = ["cable", "length", "--case", str(CONFIG / "default.yaml"), "--depth", "990"]
    assert_one_line_error(capsys, argv, "winch capacity")


def test_bad_convergence_segments(capsys: pytest.CaptureFixture) -> None:
    argv = ["cable", "convergence", "--case", str(CONFIG / "default.yaml"), "--segments", "1", "2"]
    assert_one_line_error(capsys, argv, "decrease strictly")
