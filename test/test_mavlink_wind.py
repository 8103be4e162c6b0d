"""A MAVLink log of a single-screw boat with a rudder and a wind vane (issue 36, items 1 and 3): its calibration
names the boat's actuators (``thrusters/<name>/cmd``, ``rudders/<name>/angle``) instead of the slot roles, and the
measured true wind (ArduPilot's WIND: the direction it comes from and its speed; or common WIND_COV) is read into
the trial. The log is written here with pymavlink, as a ground station records it."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavutil

from boat_twin.errors import InputError
from boat_twin.io.mavlink import calibration_from_dict
from boat_twin.io.sources import read_trial_file

UNIX0 = 1_700_000_000.0
CALIBRATION = """commands:
  thrusters/prop/cmd: {source: SERVO3, table: [[1100, -20.0], [1500, 0.0], [1900, 20.0]]}
  rudders/main/angle: {source: SERVO1, table: [[1100, 0.6], [1900, -0.6]]}
"""


def _wind_from(t_s: float) -> tuple[float, float]:
    """The wind vane's reading: direction it comes from (degrees clockwise from north) and speed (m/s)."""
    return (90.0 + 3.0 * t_s) % 360.0, 6.0 + 0.1 * t_s


def write_tlog(path: Path, wind: str = "WIND", duration_s: float = 30.0) -> None:
    """HEARTBEAT 1 Hz; GLOBAL_POSITION_INT, ATTITUDE, SERVO_OUTPUT_RAW 10 Hz (rudder on servo 1 sweeping,
    propeller on servo 3 in steps); ``wind`` (WIND or WIND_COV; anything else: none) at 1 Hz."""
    path.touch()
    conn = mavutil.mavlink_connection(str(path), write=True, source_system=1, source_component=1)
    mav = conn.mav
    for k in range(int(duration_s * 10)):
        t = k * 0.1
        ms = int(round((100.0 + t) * 1e3))

        def stamp(t: float = t) -> None:
            conn.write(struct.pack(">Q", int(round((UNIX0 + t + 0.01) * 1e6))))

        if k % 10 == 0:
            stamp()
            mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_SURFACE_BOAT, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                               0, 0, 0)
            direction, speed = _wind_from(t)
            stamp()
            if wind == "WIND":
                mav.wind_send(direction, speed, 0.0)
            elif wind == "WIND_COV":  # the air's velocity in NED
                going = math.radians(direction + 180.0)
                mav.wind_cov_send(int(round((100.0 + t) * 1e6)), speed * math.cos(going), speed * math.sin(going),
                                  0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        stamp()
        mav.global_position_int_send(ms, int(59.9e7), int(round((10.7 + 1e-5 * t) * 1e7)), 0, 0, 0, 56, 0, 9000)
        stamp()
        mav.attitude_send(ms, 0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.0)
        stamp()
        rudder = 1500 + int(round(300 * math.sin(t / 3.0)))
        prop = 1500 + 100 * (1 + int(t // 10))
        mav.servo_output_raw_send(int(round((100.0 + t) * 1e6)), 0, rudder, 1500, prop, 0, 0, 0, 0, 0)
    conn.close()


@pytest.fixture(scope="module")
def single_screw(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    work = tmp_path_factory.mktemp("mav")
    (work / "cal.yaml").write_text(CALIBRATION)
    write_tlog(work / "boat.tlog")
    return work / "boat.tlog", work / "cal.yaml"


def test_a_calibration_naming_the_boats_actuators_maps_the_servos(single_screw: tuple[Path, Path]) -> None:
    log, cal = single_screw
    trial = read_trial_file(log, calibration=str(cal))
    t = trial.t_s
    steady = (t > 1.0) & (t < 29.0) & (np.abs(t % 10.0 - 5.0) < 4.0)  # away from the propeller's steps
    expected_prop = np.interp(1500 + 100 * (1 + t // 10), [1100, 1500, 1900], [-20.0, 0.0, 20.0])
    np.testing.assert_allclose(trial.thrust_left_N[steady], expected_prop[steady])  # rev/s, the table's unit
    assert np.all(trial.thrust_right_N == 0.0)  # a single screw: the second slot empty
    rudder = np.interp(1500 + np.round(300 * np.sin(t / 3.0)), [1100, 1900], [0.6, -0.6])
    np.testing.assert_allclose(trial.angle_left_rad[steady], rudder[steady], atol=0.03)  # held 0.1 s
    topics = trial.metadata.topics
    assert "thrusters/prop/cmd" in topics["thrust_left"] and "rudders/main/angle" in topics["angle_left"]


@pytest.mark.parametrize("message", ["WIND", "WIND_COV"])
def test_the_measured_wind_is_read_as_the_air_over_ground(tmp_path: Path, message: str) -> None:
    (tmp_path / "cal.yaml").write_text(CALIBRATION)
    write_tlog(tmp_path / "boat.tlog", wind=message)
    trial = read_trial_file(tmp_path / "boat.tlog", calibration=str(tmp_path / "cal.yaml"))
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    assert trial.metadata.topics["wind"] == message
    at = np.flatnonzero(np.isclose(trial.t_s % 1.0, 0.0, atol=1e-6) & (trial.t_s > 0.5) & (trial.t_s < 29.5))
    for i in at:
        direction, speed = _wind_from(float(trial.t_s[i]))
        # from the east (90°) the air goes west: east = −speed·sin(from), north = −speed·cos(from)
        assert trial.wind_east_mps[i] == pytest.approx(-speed * math.sin(math.radians(direction)), abs=0.05)
        assert trial.wind_north_mps[i] == pytest.approx(-speed * math.cos(math.radians(direction)), abs=0.05)


def test_a_log_without_a_wind_vane_has_no_wind(tmp_path: Path) -> None:
    (tmp_path / "cal.yaml").write_text(CALIBRATION)
    write_tlog(tmp_path / "boat.tlog", wind="none")
    trial = read_trial_file(tmp_path / "boat.tlog", calibration=str(tmp_path / "cal.yaml"))
    assert trial.wind_east_mps is None and "wind" not in trial.metadata.topics


@pytest.mark.parametrize("commands, message", [
    ({"thrust_left": {"value": 0.0}, "rudders/main/angle": {"value": 0.0}}, "either by role"),
    ({f"thrusters/{n}/thrust": {"value": 0.0} for n in ("a", "b", "c")}, "commands.thrusters/c/thrust: the twin "
                                                                          "has two thruster"),
    ({"rudders/main/angle": {"source": "SERVO1", "table": [[1100, 0.6]]}}, r"\[input, rad\]"),
    ({"thrusters/p/cmd": {"source": "SERVO1", "table": [[1100, 1.0], ["x", 2.0]]}}, "thrusters/p/cmd.table"),
])
def test_a_wrong_actuator_calibration_is_refused_in_one_line(commands: dict, message: str) -> None:
    with pytest.raises(InputError, match=message) as err:
        calibration_from_dict({"commands": commands}, "cal.yaml")
    assert "\n" not in str(err.value) and str(err.value).startswith("cal.yaml: ")


def test_convert_writes_the_wind_vanes_wind_that_the_bag_reader_reads_back(
        single_screw: tuple[Path, Path], tmp_path: Path) -> None:
    from boat_twin.cli import main
    from boat_twin.io.bags import read_trial

    log, cal = single_screw
    bag = tmp_path / "boat.mcap"
    assert main(["convert", str(log), "--out", str(bag), "--calibration", str(cal)]) == 0
    mav, back = read_trial_file(log, calibration=str(cal)), read_trial(bag)
    assert back.metadata.topics["wind"] == "/wind" and back.wind_east_mps is not None
    assert mav.wind_east_mps is not None and mav.wind_north_mps is not None and back.wind_north_mps is not None
    at = back.t_s + back.metadata.start_time_s - mav.metadata.start_time_s  # the two grids on the log's clock
    for ours, theirs in ((back.wind_east_mps, mav.wind_east_mps), (back.wind_north_mps, mav.wind_north_mps)):
        known = np.isfinite(ours) & (at >= mav.t_s[0]) & (at <= mav.t_s[-1])
        assert np.count_nonzero(known) > 250
        np.testing.assert_allclose(ours[known], np.interp(at[known], mav.t_s, theirs), atol=1e-6)


DATAFLASH_FORMATS = {  # type id: (name, struct format of the payload, DataFlash format letters, columns)
    128: ("FMT", "<BB4s16s64s", "BBnNZ", "Type,Length,Name,Format,Columns"),
    130: ("GPS", "<QBBIHiiiff", "QBBIHLLeff", "TimeUS,I,Status,GMS,GWk,Lat,Lng,Alt,Spd,GCrs"),
    131: ("ATT", "<Qfff", "Qfff", "TimeUS,Roll,Pitch,Yaw"),
    132: ("WIND", "<Qffffff", "Qffffff", "TimeUS,DrRaw,DrApp,DrTru,SpdRaw,SpdApp,SpdTru"),
    133: ("RCOU", "<QHHH", "QHHH", "TimeUS,C1,C2,C3"),
}
"""The messages of the DataFlash log written below, as ArduPilot's logger defines them (AP_WindVane's WIND:
DrTru the true wind's direction in degrees, SpdTru its speed)."""


def _dataflash_record(kind: int, *values: object) -> bytes:
    """One DataFlash message: the 0xA3 0x95 head, its type id, the packed payload."""
    return bytes([0xA3, 0x95, kind]) + struct.pack(DATAFLASH_FORMATS[kind][1], *values)


def write_dataflash(path: Path, duration_s: float = 30.0) -> None:
    """A rover's DataFlash log: FMT records, then GPS, ATT and RCOU at 10 Hz and its wind vane's WIND at 1 Hz
    (the readings of :func:`_wind_from`), time since boot only (no GPS week: no time base)."""
    out = bytearray()
    for kind, (name, fmt, letters, columns) in DATAFLASH_FORMATS.items():
        length = 3 + struct.calcsize(fmt)
        out += _dataflash_record(128, kind, length, name.encode(), letters.encode(), columns.encode())
    for k in range(int(duration_s * 10)):
        t = k * 0.1
        us = int(round((100.0 + t) * 1e6))
        out += _dataflash_record(130, us, 0, 3, 0, 0, int(59.9e7), int(round((10.7 + 1e-5 * t) * 1e7)), 0, 0.5,
                                 90.0)
        out += _dataflash_record(131, us, 0.0, 0.0, 90.0)
        rudder = 1500 + int(round(300 * math.sin(t / 3.0)))
        out += _dataflash_record(133, us, rudder, 1500, 1500 + 100 * (1 + int(t // 10)))
        if k % 10 == 0:
            direction, speed = _wind_from(t)
            out += _dataflash_record(132, us, 0.0, 0.0, direction, 0.0, 0.0, speed)
    path.write_bytes(bytes(out))


def test_a_dataflash_logs_wind_vane_is_read_as_the_air_over_ground(tmp_path: Path) -> None:
    (tmp_path / "cal.yaml").write_text(CALIBRATION)
    write_dataflash(tmp_path / "boat.BIN")
    trial = read_trial_file(tmp_path / "boat.BIN", calibration=str(tmp_path / "cal.yaml"))
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    assert trial.metadata.topics["wind"] == "WIND"
    boot = trial.t_s + trial.metadata.start_time_s - 100.0  # the vane's clock: time since boot less 100 s
    at = np.flatnonzero(np.isclose(boot, np.round(boot), atol=1e-6) & (boot > 0.5) & (boot < 29.5))
    assert at.size > 20
    for i in at:
        direction, speed = _wind_from(float(boot[i]))
        assert trial.wind_east_mps[i] == pytest.approx(-speed * math.sin(math.radians(direction)), abs=0.05)
        assert trial.wind_north_mps[i] == pytest.approx(-speed * math.cos(math.radians(direction)), abs=0.05)
