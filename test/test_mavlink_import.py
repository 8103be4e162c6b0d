"""MAVLink log import: real ArduSub logs (../shared/data, the ``ardusub_logs`` fixture of conftest.py), a synthetic
.tlog of a simulated trial, convert, bad input, fuzzing."""

import math
import shutil
import struct
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink import mavutil

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.mavlink import MavlinkTrialMetadata, calibration_from_dict, load_calibration
from boat_twin.io.sources import read_trial_file
from boat_twin.twin.sea_trial import command_log_ticks, run_sea_trial, trial_messages
from boat_twin.vessel.scenarios import make_scenario

ROOT = Path(__file__).resolve().parents[1]
CALIBRATION = ROOT / "config" / "mavlink" / "ardupilot_two_outboards.yaml"

UNIX0 = 1_700_000_000.0
"""Unix time of the synthetic log's sim time 0, s."""
BOOT0 = 4_270.0
"""Autopilot boot time at sim time 0, s: SERVO_OUTPUT_RAW's 32-bit µs counter wraps 25 s into the trial."""
MG = 9.80665e-3


def _wrap(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def _euler_from_quaternion(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z, w = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def write_synthetic_tlog(path: Path, sea, calibration, *, seed: int = 0, reboot_at_s: float | None = None,
                         intruder: bool = True) -> dict[str, int]:
    """A .tlog as a ground station records it: 8-byte receive time (µs, big-endian) + MAVLink frame, written
    with pymavlink's mav.*_send. Vehicle 1/1 sends HEARTBEAT, GLOBAL_POSITION_INT (the GNSS measurements),
    ATTITUDE + RAW_IMU (the UM7 measurements, NED/FRD) and SERVO_OUTPUT_RAW (commands through the calibration);
    system 2 (an intruder) sends a HEARTBEAT and wrong ATTITUDEs the importer must ignore. Receive times lag the
    sends by 5-55 ms. Returns the vehicle's message counts."""
    rng = np.random.default_rng(seed)
    events = []  # (send time since sim start s, kind, payload)
    gnss, imu, record = sea.gnss, sea.imu, sea.record
    for i in range(len(gnss)):
        events.append((gnss.stamp_s[i], "gpi", i))
    for i in range(len(imu)):
        events.append((imu.stamp_s[i], "att", i))
    commands = record.commands[:, 0, :]
    for i in command_log_ticks(record.t_s, commands):
        events.append((record.t_s[i], "servo", i))
    for t in np.arange(0.0, record.t_s[-1], 1.0):
        events.append((t, "hb", 0))
        if intruder:
            events.append((t + 0.05, "intruder", 0))
    events.sort(key=lambda e: (e[0], e[1]))
    roll, pitch, yaw = _euler_from_quaternion(imu.quaternion_xyzw)
    pwm = {role: np.rint(calibration.to_raw(role, commands[:, k])).astype(int)
           for k, role in enumerate(("thrust_left", "thrust_right", "angle_left", "angle_right"))}
    path.touch()  # mavlink_connection opens an existing path as a log file (anything else as a serial port)
    conn = mavutil.mavlink_connection(str(path), write=True, source_system=1, source_component=1)
    mav = conn.mav
    counts: Counter = Counter()
    last_recv = 0.0
    for t, kind, i in events:
        boot = BOOT0 + t if reboot_at_s is None or t < reboot_at_s else 3.0 + (t - reboot_at_s)
        recv = max(last_recv, UNIX0 + t + 0.005 + rng.uniform(0.0, 0.05))
        last_recv = recv
        conn.write(struct.pack(">Q", int(round(recv * 1e6))))
        ms = int(round(boot * 1e3))
        if kind == "gpi":
            mav.global_position_int_send(ms, int(round(gnss.lat_deg[i] * 1e7)), int(round(gnss.lon_deg[i] * 1e7)),
                                         int(round(gnss.alt_m[i] * 1e3)), 0, int(round(gnss.vel_north_mps[i] * 100)),
                                         int(round(gnss.vel_east_mps[i] * 100)), 0, 0)
            counts["GLOBAL_POSITION_INT"] += 1
        elif kind == "att":
            w, a = imu.gyro_radps[i], imu.accel_mps2[i]
            mav.attitude_send(ms, roll[i], -pitch[i], float(_wrap(np.pi / 2 - yaw[i])), w[0], -w[1], -w[2])
            counts["ATTITUDE"] += 1
            conn.write(struct.pack(">Q", int(round(recv * 1e6))))
            mav.raw_imu_send(int(round(boot * 1e6)), int(round(a[0] / MG)), int(round(-a[1] / MG)),
                             int(round(-a[2] / MG)), int(round(w[0] * 1e3)), int(round(-w[1] * 1e3)),
                             int(round(-w[2] * 1e3)), 0, 0, 0)
            counts["RAW_IMU"] += 1
        elif kind == "servo":
            usec = int(round(boot * 1e6)) % 2**32
            mav.servo_output_raw_send(usec, 0, pwm["thrust_left"][i], pwm["angle_left"][i], pwm["thrust_right"][i],
                                      0, 0, 0, 0, 0)
            counts["SERVO_OUTPUT_RAW"] += 1
        elif kind == "hb":
            mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_SURFACE_BOAT, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                               0, 0, 0)
            counts["HEARTBEAT"] += 1
        else:  # another vehicle: its attitude must not leak into the trial
            mav.srcSystem = 2
            mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_SURFACE_BOAT, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                               0, 0, 0)
            conn.write(struct.pack(">Q", int(round(recv * 1e6))))
            mav.attitude_send(ms, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5)
            mav.srcSystem = 1
            counts["intruder ATTITUDE"] += 1
    conn.close()
    return dict(counts)


@pytest.fixture(scope="module")
def calibration():
    return load_calibration(CALIBRATION)


@pytest.fixture(scope="module")
def sea():
    config = TwinConfig()
    scenario = make_scenario("random", config.vessel, np.random.default_rng(4), duration_s=60.0)
    return run_sea_trial(config, scenario, seed=4)


@pytest.fixture(scope="module")
def tlog(sea, calibration, tmp_path_factory) -> tuple[Path, dict[str, int]]:
    path = tmp_path_factory.mktemp("tlog") / "trial.tlog"
    counts = write_synthetic_tlog(path, sea, calibration)
    return path, counts


@pytest.fixture(scope="module")
def bag_trial(sea, tmp_path_factory):
    path = tmp_path_factory.mktemp("bag") / "trial"
    write_bag(path, trial_messages(sea, truth=False))
    return read_trial(path)


def _records(data: bytes) -> list[tuple[int, int]]:
    """(offset, length) of each record of an unsigned .tlog: 8-byte time + MAVLink 1 or 2 frame."""
    records, o = [], 0
    while o + 10 <= len(data):
        length = 8 + data[o + 9] + (8 if data[o + 8] == 0xFE else 12)
        records.append((o, length))
        o += length
    return records


def _independent_tlog_census(path: Path, types: set[str]) -> tuple[int, Counter, float, float]:
    """Every message of the file with pymavlink's plain loop: total (with BAD_DATA), counts, span of ``types``."""
    conn = mavutil.mavlink_connection(str(path))
    total, counts, first, last = 0, Counter(), math.inf, -math.inf
    while (msg := conn.recv_match()) is not None:
        total += 1
        counts[msg.get_type()] += 1
        if msg.get_type() in types:
            first, last = min(first, msg._timestamp), max(last, msg._timestamp)
    conn.close()
    return total, counts, first, last


# ------------------------------------------------------------------------------------------ real logs
def test_ardusub_tlog_imports_with_the_right_counts_time_span_and_conventions(calibration, ardusub_logs) -> None:
    path = ardusub_logs / "small.tlog"
    trial = read_trial_file(path, calibration=CALIBRATION)
    meta = trial.metadata
    assert isinstance(meta, MavlinkTrialMetadata)
    total, counts, first, last = _independent_tlog_census(path, set(meta.message_counts))
    assert meta.log_messages == total == 35_916  # SOURCE.md
    assert meta.message_counts == {name: counts[name] for name in meta.message_counts}
    assert meta.message_counts["ATTITUDE"] == 5245 and meta.message_counts["GLOBAL_POSITION_INT"] == 792
    assert meta.log_span_s == (first, last) and last - first == pytest.approx(263.4, abs=0.1)
    assert meta.missing == [] and meta.reboots == 0
    # The vehicle's own clock: the trial runs from its first SERVO_OUTPUT_RAW to its last GLOBAL_POSITION_INT.
    conn = mavutil.mavlink_connection(str(path))
    servo, gpi, att = [], [], []
    while (msg := conn.recv_match(type=["SERVO_OUTPUT_RAW", "GLOBAL_POSITION_INT", "ATTITUDE"])) is not None:
        if msg.get_srcSystem() != 1:
            continue
        if msg.get_type() == "SERVO_OUTPUT_RAW":
            servo.append((msg.time_usec * 1e-6, msg.servo1_raw))
        elif msg.get_type() == "GLOBAL_POSITION_INT":
            gpi.append((msg.time_boot_ms * 1e-3, msg.vx * 0.01, msg.vy * 0.01))
        else:
            att.append((msg.time_boot_ms * 1e-3, msg.yaw, msg.yawspeed))
    conn.close()
    servo, gpi, att = np.array(servo), np.array(gpi), np.array(att)
    assert meta.counts == {"thrust_left": len(servo), "thrust_right": len(servo), "angle_left": len(servo),
                           "angle_right": len(servo), "gnss_fix": len(gpi), "gnss_vel": len(gpi), "imu": len(att)}
    assert trial.t_s[-1] == pytest.approx(gpi[-1, 0] - servo[0, 0], abs=1 / 3)
    # NED → ENU: heading = π/2 − yaw, yaw rate = −yawspeed, velocity east = vy.
    boot = trial.t_s + servo[0, 0]  # the trial starts with the first command
    ok = np.isfinite(trial.heading_rad)
    assert np.abs(_wrap(trial.heading_rad[ok] - (np.pi / 2 - np.interp(boot[ok], att[:, 0], np.unwrap(att[:, 1]))))
                  ).max() < 0.05
    assert np.nanmax(np.abs(trial.yaw_rate_radps[ok] + np.interp(boot[ok], att[:, 0], att[:, 2]))) < 0.05
    known = np.isfinite(trial.vel_east_mps)
    assert np.abs(trial.vel_east_mps[known] - np.interp(boot[known], gpi[:, 0], gpi[:, 2])).max() < 0.011
    half = 0.5 * (trial.t_s[1] - trial.t_s[0])  # SERVO1 PWM, zero-order hold on the nearest grid time
    held = servo[np.searchsorted(servo[:, 0], boot + half - 1e-6, side="left") - 1, 1]
    np.testing.assert_allclose(trial.thrust_left_N, calibration.to_value("thrust_left", held), atol=1e-9)
    assert np.ptp(trial.thrust_left_N) > 400.0  # the ROV's thrusters did move past the dead band
    line = meta.summary_line()
    assert "\n" not in line and "35916 tlog messages over 263.4 s" in line


def test_ardusub_joystick_and_rc_inputs_map_through_the_calibration(ardusub_logs) -> None:
    path = ardusub_logs / "small.tlog"
    cal = calibration_from_dict({"commands": {
        "thrust_left": {"source": "MANUAL_CONTROL.z", "table": [[0, 0.0], [1000, 2000.0]]},
        "thrust_right": {"source": "RC10", "table": [[1100, 0.0], [1900, 800.0]]}}}, "joystick")
    trial = read_trial_file(path, calibration=cal)
    conn = mavutil.mavlink_connection(str(path))
    manual, rc = [], []
    while (msg := conn.recv_match(type=["MANUAL_CONTROL", "RC_CHANNELS"])) is not None:
        if msg.get_type() == "MANUAL_CONTROL" and msg.target == 1:
            manual.append((msg._timestamp, msg.z))
        elif msg.get_type() == "RC_CHANNELS" and msg.get_srcSystem() == 1:
            rc.append(msg.chan10_raw)
    conn.close()
    meta = trial.metadata
    assert meta.counts["thrust_left"] == len(manual) == 1450 and meta.counts["thrust_right"] == len(rc) == 528
    assert meta.topics["thrust_left"].startswith("MANUAL_CONTROL") and meta.missing == ["angle_left", "angle_right"]
    stamps = np.array([m[0] for m in manual])  # the ground station's clock: MANUAL_CONTROL has no time field
    t = trial.t_s + meta.start_time_s
    held = np.searchsorted(stamps, t + 0.5 * (t[1] - t[0]) - 1e-6, side="left") - 1  # nearest grid time
    expected = np.where(held >= 0, np.array([m[1] for m in manual])[np.maximum(held, 0)] * 2.0, np.nan)
    np.testing.assert_allclose(trial.thrust_left_N, expected, atol=1e-6)
    seen = set(np.unique(trial.thrust_right_N[np.isfinite(trial.thrust_right_N)]))  # 1 N per µs above 1100 µs
    assert seen <= {float(v - 1100) for v in rc} and len(seen) > 2


def test_ardusub_bin_imports_and_reports_the_missing_gps(ardusub_logs) -> None:
    path = ardusub_logs / "small.BIN"
    reader = mavutil.mavlink_connection(str(path))
    counts, times = Counter(), {}
    while (msg := reader.recv_match()) is not None:
        counts[msg.get_type()] += 1
        if msg.get_type() in ("ATT", "IMU", "RCOU"):
            times.setdefault(msg.get_type(), []).append(msg.TimeUS * 1e-6)
    assert sum(counts.values()) == 7_510 and "GPS" not in counts  # SOURCE.md
    for cal in (None, CALIBRATION):
        trial = read_trial_file(path, calibration=cal)
        meta = trial.metadata
        assert meta.log_messages == 7_510
        assert {"gnss_fix", "gnss_vel"} <= set(meta.missing) and "imu" not in meta.missing
        assert "missing:" in meta.summary_line() and "gnss_fix, gnss_vel" in meta.summary_line()
        assert np.all(np.isnan(trial.lat_deg)) and np.all(np.isnan(trial.vel_east_mps))
        assert np.all(np.isfinite(trial.heading_rad))
        assert meta.counts["imu"] == counts["ATT"] == 237 and meta.message_counts["IMU"] == counts["IMU"] == 594
        assert meta.time_base.startswith("seconds since autopilot boot")
    assert meta.missing == ["gnss_fix", "gnss_vel"] and meta.counts["thrust_left"] == counts["RCOU"]
    span = (min(min(v) for v in times.values()), max(max(v) for v in times.values()))
    assert meta.log_span_s == pytest.approx(span, abs=1e-9)
    assert meta.start_time_s == pytest.approx(min(times["RCOU"]), abs=1e-9)  # the first command
    assert trial.t_s[-1] == pytest.approx(max(times["ATT"]) - min(times["RCOU"]), abs=0.1)


# ------------------------------------------------------------------------------------------ synthetic
def test_synthetic_tlog_imports_to_the_trial_of_the_simulation(tlog, bag_trial, sea, calibration) -> None:
    path, written = tlog
    trial = read_trial_file(path, calibration=calibration)
    meta = trial.metadata
    assert meta.missing == [] and meta.gaps == [] and meta.non_monotone == {} and meta.reboots == 0
    assert meta.counts["imu"] == written["ATTITUDE"]  # system 2's ATTITUDEs are not counted in
    assert meta.message_counts["ATTITUDE"] == written["ATTITUDE"] + written["intruder ATTITUDE"]  # ... but read
    assert meta.start_time_s == pytest.approx(UNIX0 + 0.005, abs=0.002)  # Unix time of sim time 0
    ref = bag_trial
    assert len(trial) == len(ref)
    np.testing.assert_allclose(trial.t_s, ref.t_s, atol=1e-3)
    # cm/s and 1e-7 deg integers; the Unix-time grid (float64 at 1.7e9 s) drifts by < 0.1 ms over the trial.
    np.testing.assert_allclose(trial.vel_east_mps, ref.vel_east_mps, atol=0.006, equal_nan=True)
    np.testing.assert_allclose(trial.vel_north_mps, ref.vel_north_mps, atol=0.006, equal_nan=True)
    np.testing.assert_allclose(trial.east_m, ref.east_m, atol=0.02, equal_nan=True)
    np.testing.assert_allclose(trial.north_m, ref.north_m, atol=0.02, equal_nan=True)
    np.testing.assert_allclose(trial.heading_rad, ref.heading_rad, atol=1e-3)
    np.testing.assert_allclose(trial.yaw_rate_radps, ref.yaw_rate_radps, atol=1e-3)
    np.testing.assert_allclose(trial.accel_x_mps2, ref.accel_x_mps2, atol=0.02)
    np.testing.assert_allclose(trial.accel_y_mps2, ref.accel_y_mps2, atol=0.02)
    # Commands: within half a microsecond of PWM at the steepest part of each table, clamped to the table (the
    # random scenario asks up to 115 % of the bollard thrust). Commands change on the 0.1 s grid itself, where
    # a float tie on Unix time may pick either side: compare the grid points away from those instants.
    cmd = sea.record.commands[:, 0, :]
    changes = sea.record.t_s[1:][np.any(np.diff(cmd, axis=0) != 0, axis=1)]
    away = np.min(np.abs(ref.t_s[:, None] - changes[None, :]), axis=1) > 2e-3
    slope = np.max(np.abs(np.diff(calibration.commands["thrust_left"].value)
                          / np.diff(calibration.commands["thrust_left"].raw)))
    for name, lo, hi, tol in (("thrust_left_N", -1000.0, 2000.0, 0.5 * slope), ("thrust_right_N", -1000.0, 2000.0,
                              0.5 * slope), ("angle_left_rad", -0.5236, 0.5236, 0.5 * 0.5236 / 400)):
        np.testing.assert_allclose(getattr(trial, name)[away], np.clip(getattr(ref, name)[away], lo, hi),
                                   atol=tol + 1e-6, err_msg=name)
    assert np.count_nonzero(away) > 500 and np.ptp(trial.thrust_left_N) > 500.0  # not trivially flat


def test_gnss_role_can_come_from_another_message(tlog, calibration) -> None:
    path, _ = tlog
    with pytest.raises(InputError, match="GPS_RAW_INT"):
        read_trial_file(path, calibration=calibration, remap={"gnss_vel": "RAW_IMU"})
    trial = read_trial_file(path, calibration=calibration, remap={"gnss_vel": "GPS_RAW_INT"})
    assert "gnss_vel" in trial.metadata.missing  # the synthetic log has no GPS_RAW_INT


def test_reboot_and_out_of_order_samples_are_reported_not_fatal(sea, calibration, tmp_path) -> None:
    path = tmp_path / "reboot.tlog"
    write_synthetic_tlog(path, sea, calibration, reboot_at_s=30.0, intruder=False)
    # Let ATTITUDE k+1 overtake ATTITUDE k on the link: swap the frames, and give every record from the first
    # to the second the later receive time (a message cannot be received before it was sent).
    data = bytearray(path.read_bytes())
    records = _records(data)
    attitudes = [o for o, n in records if data[o + 8 + (5 if data[o + 8] == 0xFE else 7)] == 30]
    first, second = attitudes[100], attitudes[101]
    frame = {o: bytes(data[o + 8:o + n]) for o, n in records if o in (first, second)}
    assert len(frame[first]) == len(frame[second])
    data[first + 8:first + 8 + len(frame[first])] = frame[second]
    data[second + 8:second + 8 + len(frame[second])] = frame[first]
    for o, _ in records:
        if first <= o < second:
            data[o:o + 8] = data[second:second + 8]
    path.write_bytes(bytes(data))
    trial = read_trial_file(path, calibration=calibration)
    meta = trial.metadata
    assert meta.reboots == 1 and meta.non_monotone == {"imu": 1}
    assert "1 autopilot reboot(s)" in meta.summary_line() and "non-monotone times: imu 1" in meta.summary_line()
    # Both boots land on one Unix clock: the trial is continuous, 60 s long, and still the simulation.
    assert trial.t_s[-1] == pytest.approx(sea.gnss.stamp_s[-1], abs=0.11)
    assert np.isfinite(trial.vel_east_mps[5:]).all()
    assert np.nanmax(np.abs(trial.speed_mps[1:] - np.hypot(sea.gnss.vel_east_mps, sea.gnss.vel_north_mps))) < 0.01


def test_convert_writes_a_bag_that_read_trial_reads_back(tlog, calibration, tmp_path, capsys) -> None:
    path, _ = tlog
    bag = tmp_path / "converted"
    assert main(["convert", str(path), "--out", str(bag), "--calibration", str(CALIBRATION)]) == 0
    assert "wrote" in capsys.readouterr().out
    mav, back = read_trial_file(path, calibration=calibration), read_trial(bag)
    assert back.metadata.missing == []
    np.testing.assert_allclose(back.t_s, mav.t_s, atol=1e-6)
    for name in ("lat_deg", "lon_deg", "vel_east_mps", "vel_north_mps", "heading_rad", "yaw_rate_radps",
                 "accel_x_mps2", "accel_y_mps2", "thrust_left_N", "thrust_right_N", "angle_left_rad",
                 "angle_right_rad"):
        # stamps go through integer nanoseconds: the Unix-time grid moves by < 1 µs
        np.testing.assert_allclose(getattr(back, name), getattr(mav, name), atol=1e-4, equal_nan=True, err_msg=name)
    assert main(["convert", str(path), "--out", str(bag)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["convert", str(path), "--out", str(bag), "--force", "--json"]) == 0
    assert '"thrusters/left/thrust"' not in capsys.readouterr().out  # no calibration: no thruster topics


def test_convert_of_the_ardusub_bin_keeps_its_attitude(tmp_path, capsys, ardusub_logs) -> None:
    bag = tmp_path / "bin.mcap"
    assert main(["convert", str(ardusub_logs / "small.BIN"), "--out", str(bag), "--json"]) == 0
    out = capsys.readouterr().out
    assert '"imu/data": 237' in out and "no GNSS" in out
    assert bag.is_file()


# ------------------------------------------------------------------------------------------ bad input
def test_calibration_tables_map_both_ways_and_are_validated() -> None:
    cal = calibration_from_dict({"commands": {
        "thrust_left": {"source": "servo1", "table": [[1100, -1000], [1475, 0], [1525, 0], [1900, 2000]]},
        "angle_left": {"source": "MANUAL_CONTROL.r", "table": [[-1000, 0.5], [1000, -0.5]]},
        "angle_right": {"value": 0.1}}})
    np.testing.assert_allclose(cal.to_value("thrust_left", [1000, 1100, 1500, 1712.5, 2000]),
                               [-1000, -1000, 0, 1000, 2000])
    assert np.isnan(cal.to_value("thrust_left", [0, 65535])).all()
    np.testing.assert_allclose(cal.to_raw("thrust_left", [-1000, 0, 1000]), [1100, 1500, 1712.5])
    np.testing.assert_allclose(cal.to_raw("angle_left", [0.25, -0.5]), [-500, 1000])
    assert cal.to_value("angle_right", [1, 2]).tolist() == [0.1, 0.1]
    for bad, message in (
        ({"commands": {"thrust_left": {"source": "SERVO1"}}}, "missing field 'table'"),
        ({"commands": {"thrust_left": {"table": [[1, 2], [3, 4]]}}}, "missing field 'source'"),
        ({"commands": {"thrust_middle": {"value": 0}}}, "unknown role"),
        ({"commands": {"thrust_left": {"source": "SERVO40", "table": [[1, 2], [3, 4]]}}}, "out of range"),
        ({"commands": {"thrust_left": {"source": "AUX1", "table": [[1, 2], [3, 4]]}}}, "is not SERVO"),
        ({"commands": {"thrust_left": {"source": "RC1", "table": [[3, 2], [1, 4]]}}}, "strictly increasing"),
        ({"commands": {"thrust_left": {"source": "RC1", "table": [[1, 2], [2, 4], [3, 1]]}}}, "monotone"),
        ({"commands": {"thrust_left": {"source": "RC1", "table": [[1, "x"], [2, 4]]}}}, "finite number"),
        ({"comands": {}}, "unknown key"),
    ):
        with pytest.raises(InputError, match=message) as err:
            calibration_from_dict(bad, "cal.yaml")
        assert str(err.value).startswith("cal.yaml: ")


def _one_line_error(capsys, code: int) -> str:
    captured = capsys.readouterr()
    assert code == 2, captured
    errors = [line for line in captured.err.splitlines() if not line.startswith("reading ")]  # progress lines
    assert len(errors) == 1 and errors[0].startswith("boat-twin ") and "Traceback" not in captured.err, captured.err
    return errors[0]


def test_bad_input_exits_2_with_one_line(tlog, tmp_path, capsys) -> None:
    path, _ = tlog
    garbage = tmp_path / "garbage.tlog"
    garbage.write_bytes(np.random.default_rng(0).integers(0, 256, 20_000, dtype=np.uint8).tobytes())
    garbage_bin = tmp_path / "garbage.BIN"
    garbage_bin.write_bytes(garbage.read_bytes())
    empty = tmp_path / "empty.BIN"
    empty.write_bytes(b"")
    no_table = tmp_path / "no_table.yaml"
    no_table.write_text("commands:\n  thrust_left:\n    source: SERVO1\n")
    out = str(tmp_path / "out")
    cases = [
        (["convert", str(tmp_path / "missing.tlog"), "--out", out], "missing.tlog: no such file"),
        (["convert", str(garbage), "--out", out], "garbage.tlog"),
        (["convert", str(garbage_bin), "--out", out], "garbage.BIN"),
        (["convert", str(empty), "--out", out], "empty.BIN"),
        (["convert", str(path), "--out", out, "--calibration", str(no_table)],
         "no_table.yaml: commands.thrust_left: missing field 'table'"),
        (["convert", str(path), "--out", out, "--calibration", str(tmp_path / "nope.yaml")], "nope.yaml"),
        (["convert", str(tmp_path), "--out", out], "convert reads MAVLink logs"),
        (["identify", str(path), "--calibration", str(no_table)], "missing field 'table'"),
        (["identify", str(path), "--topic", "thrust_left=SERVO1"], "calibration file"),
        (["identify", str(path), "--namespace", "boat1"], "--namespace applies to bags"),
    ]
    for argv, expected in cases:
        line = _one_line_error(capsys, main(argv))
        assert expected in line, (argv, line)
    assert not Path(out).exists()


# ------------------------------------------------------------------------------------------ fuzzing
@pytest.fixture(scope="module")
def small_tlog(tmp_path_factory) -> bytes:
    config = TwinConfig()
    scenario = make_scenario("random", config.vessel, np.random.default_rng(5), duration_s=8.0)
    path = tmp_path_factory.mktemp("fuzz") / "small.tlog"
    write_synthetic_tlog(path, run_sea_trial(config, scenario, seed=5), load_calibration(CALIBRATION))
    return path.read_bytes()


def _import_or_clean_error(data: bytes, suffix: str) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-"))
    try:
        path = tmp / f"fuzzed{suffix}"
        path.write_bytes(data)
        try:
            trial = read_trial_file(path, calibration=CALIBRATION)
        except InputError as err:
            message = str(err)
            assert "\n" not in message and str(path) in message, message
        else:
            assert len(trial) >= 1 and "\n" not in trial.metadata.summary_line()
    finally:
        shutil.rmtree(tmp)


_edits = st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(1, 255)), max_size=24)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.floats(0.0, 1.0), flips=_edits, junk=st.binary(max_size=64), junk_at=st.floats(0.0, 1.0))
def test_fuzzed_tlog_imports_or_fails_with_one_clean_line(small_tlog, cut, flips, junk, junk_at) -> None:
    data = bytearray(small_tlog[: max(0, int(len(small_tlog) * cut))] if cut < 0.98 else small_tlog)
    for where, mask in flips:
        if data:
            data[int(where * len(data))] ^= mask
    at = int(junk_at * len(data))
    _import_or_clean_error(bytes(data[:at]) + junk + bytes(data[at:]), ".tlog")


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(0, 90_000), flips=_edits)
def test_fuzzed_dataflash_imports_or_fails_with_one_clean_line(ardusub_logs, cut, flips) -> None:
    data = bytearray((ardusub_logs / "small.BIN").read_bytes()[:cut])
    for where, mask in flips:
        if data:
            data[int(where * len(data))] ^= mask
    _import_or_clean_error(bytes(data), ".BIN")
