"""MAVLink import: a 1-hour .tlog into a Trial, against pymavlink's own bare recv_match loop over the same file.

Run: make bench   (or: .venv/bin/python benchmarks/bench_mavlink.py [minutes])
The log is generated here with pymavlink (vehicle 1/1 and a ground station 255/190), at the per-type rates of the
real ArduPilot log in ../shared/data/ardusub_log_tools/small.tlog (about 130 messages/s: ATTITUDE and AHRS2 at
20 Hz, VFR_HUD 10 Hz, NAMED_VALUE_FLOAT 16 Hz, GLOBAL_POSITION_INT 3 Hz, SERVO_OUTPUT_RAW 2 Hz, ...), with a
boat circling at 3 m/s. Printed, not asserted: messages/s of the importer (read_mavlink_trial: decode, convert,
grid) and of two bare loops (every message; only the importer's types), best of two runs each, their ratios,
and the importer's peak Python memory (tracemalloc).
"""

import math
import struct
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

from pymavlink import mavutil

from boat_twin.io.mavlink import load_calibration, read_mavlink_trial

ROOT = Path(__file__).resolve().parents[1]
CALIBRATION = ROOT / "config" / "mavlink" / "ardupilot_two_outboards.yaml"
RATES_HZ = {  # vehicle messages, Hz (ArduSub sample log); MANUAL_CONTROL and a HEARTBEAT come from the GCS
    "ATTITUDE": 20, "AHRS2": 20, "VFR_HUD": 10, "NAMED_VALUE_FLOAT": 16, "GLOBAL_POSITION_INT": 3,
    "LOCAL_POSITION_NED": 3, "AHRS": 3, "EKF_STATUS_REPORT": 3, "VIBRATION": 3, "BATTERY_STATUS": 3,
    "HWSTATUS": 3, "SYSTEM_TIME": 3, "GPS_RAW_INT": 2, "RAW_IMU": 2, "SCALED_IMU2": 2, "SCALED_PRESSURE": 2,
    "SERVO_OUTPUT_RAW": 2, "RC_CHANNELS": 2, "SYS_STATUS": 2, "MEMINFO": 2, "POWER_STATUS": 2,
    "NAV_CONTROLLER_OUTPUT": 2, "MISSION_CURRENT": 2, "HEARTBEAT": 1,
}
GCS_RATES_HZ = {"MANUAL_CONTROL": 5, "HEARTBEAT": 1}


def _filler(mav, name: str):
    """A message of type ``name`` with every field zero (content does not matter for decoding speed)."""
    cls = getattr(mavutil.mavlink, f"MAVLink_{name.lower()}_message")
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    args = []
    for name_, ftype in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = lengths[name_]
        if ftype == "char":
            args.append(b"x")
        elif length:
            args.append([0] * length)
        else:
            args.append(0)
    return cls(*args)


def write_tlog(path: Path, seconds: float, calibration) -> int:
    """A ground station's .tlog of a boat circling at 3 m/s for ``seconds``; returns the number of messages."""
    path.touch()
    conn = mavutil.mavlink_connection(str(path), write=True, source_system=1, source_component=1)
    mav = conn.mav
    events = []
    for name, rate in RATES_HZ.items():
        events += [(k / rate, name) for k in range(int(seconds * rate))]
    events += [(k / GCS_RATES_HZ["MANUAL_CONTROL"] + 0.01, "GCS_MANUAL_CONTROL")
               for k in range(int(seconds * GCS_RATES_HZ["MANUAL_CONTROL"]))]
    events += [(k + 0.02, "GCS_HEARTBEAT") for k in range(int(seconds))]
    events.sort()
    fillers = {name: _filler(mav, name) for name in RATES_HZ if name not in (
        "ATTITUDE", "GLOBAL_POSITION_INT", "GPS_RAW_INT", "RAW_IMU", "SERVO_OUTPUT_RAW", "HEARTBEAT")}
    unix0, boot0, omega, speed, radius = 1.7e9, 120.0, 0.05, 3.0, 60.0
    pwm_thrust = int(calibration.to_raw("thrust_left", 800.0))
    pwm_angle = int(calibration.to_raw("angle_left", 0.15))
    for t, name in events:
        conn.write(struct.pack(">Q", int((unix0 + t + 0.02) * 1e6)))
        boot, psi = boot0 + t, omega * t  # ENU course of the circle
        ms = int(boot * 1e3)
        if name == "ATTITUDE":
            mav.attitude_send(ms, 0.01, 0.02, math.remainder(math.pi / 2 - psi, 2 * math.pi), 0.0, 0.0, -omega)
        elif name == "GLOBAL_POSITION_INT":
            east, north = radius * math.sin(psi), -radius * math.cos(psi)
            mav.global_position_int_send(ms, int((43.07 + north / 111_320) * 1e7),
                                         int((131.9 + east / 81_300) * 1e7), 1500, 1500,
                                         int(speed * math.sin(psi) * 100), int(speed * math.cos(psi) * 100), 0, 0)
        elif name == "GPS_RAW_INT":
            mav.gps_raw_int_send(int(boot * 1e6), 3, 430700000, 1319000000, 1500, 90, 150, 300,
                                 int(math.degrees(math.pi / 2 - psi) % 360 * 100), 14)
        elif name == "RAW_IMU":
            mav.raw_imu_send(int(boot * 1e6), 0, int(speed * omega / 9.80665e-3), -1000, 0, 0, -50, 0, 0, 0)
        elif name == "SERVO_OUTPUT_RAW":
            mav.servo_output_raw_send(int(boot * 1e6) % 2**32, 0, pwm_thrust, pwm_angle, pwm_thrust, 0, 0, 0, 0, 0)
        elif name == "HEARTBEAT":
            mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_SURFACE_BOAT, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                               0, 0, 0)
        elif name.startswith("GCS_"):
            mav.srcSystem, mav.srcComponent = 255, 190
            if name == "GCS_HEARTBEAT":
                mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            else:
                mav.manual_control_send(1, 0, 0, 500, 0, 0)
            mav.srcSystem, mav.srcComponent = 1, 1
        else:
            mav.send(fillers[name])
    conn.close()
    return len(events)


def bare_loop(path: Path, types=None) -> int:
    """pymavlink alone: recv_match over the file (every message, or only ``types``)."""
    conn = mavutil.mavlink_connection(str(path))
    count = 0
    while conn.recv_match(type=types) is not None:
        count += 1
    conn.close()
    return count


def timed(fn, repeats: int = 2):
    """Smallest wall time of ``repeats`` calls, s, and the last result."""
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def main() -> None:
    minutes = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0
    calibration = load_calibration(CALIBRATION)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.tlog"
        gen_s, total = timed(lambda: write_tlog(path, minutes * 60.0, calibration), repeats=1)
        size_mb = path.stat().st_size / 1e6
        print(f"{minutes:g}-min .tlog: {total:,} messages ({total / (minutes * 60):.0f}/s), {size_mb:.1f} MB, "
              f"written in {gen_s:.1f} s")
        trial_s, trial = timed(lambda: read_mavlink_trial(path, calibration))
        types = sorted(trial.metadata.message_counts)
        all_s, all_n = timed(lambda: bare_loop(path))
        typed_s, typed_n = timed(lambda: bare_loop(path, set(types)))
        tracemalloc.start()
        read_mavlink_trial(path, calibration)
        peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    print(f"bare recv_match(), every message:        {all_s:6.2f} s  {all_n / all_s:9,.0f} msg/s ({all_n:,} messages)")
    print(f"bare recv_match(type=the importer's {len(types)}):  {typed_s:6.2f} s  {total / typed_s:9,.0f} msg/s "
          f"of the file ({typed_n:,} returned)")
    print(f"read_mavlink_trial -> Trial ({len(trial):,} samples): {trial_s:6.2f} s  {total / trial_s:9,.0f} msg/s "
          f"of the file")
    print(f"importer time / bare loop over every message: {trial_s / all_s:.2f}x; "
          f"/ bare loop over the same types: {trial_s / typed_s:.2f}x")
    print(f"importer peak Python memory: {peak_mb:.1f} MB (file {size_mb:.1f} MB)")
    print(trial.metadata.summary_line())


if __name__ == "__main__":
    main()
