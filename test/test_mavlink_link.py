"""The twin as a MAVLink boat: a pymavlink ground station on 127.0.0.1 receives, drives and probes it."""

import json
import math
import socket
import struct
import time
from collections import Counter

import numpy as np
import pymap3d
import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2
from scipy.spatial.transform import Rotation

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.link.mavlink_boat import (
    OVERRIDE_TIMEOUT_S,
    ROVER_DEFAULT_RATES_HZ,
    MavlinkBoat,
    ned_attitude,
    parse_url,
    pwm_from_fraction,
)
from boat_twin.twin.live import LiveTwin
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.scenarios import make_scenario

EPOCH_S = 1.7e9
STREAMED = {"HEARTBEAT", "SYS_STATUS", "SYSTEM_TIME", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "ATTITUDE", "VFR_HUD",
            "SERVO_OUTPUT_RAW"}


@pytest.fixture
def gcs():
    """A pymavlink ground station listening on an ephemeral loopback port (as QGC listens on 14550)."""
    conn = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255, source_component=190)
    yield conn
    conn.close()


def url_of(gcs) -> str:
    return f"udpout:127.0.0.1:{gcs.port.getsockname()[1]}"


def receive(gcs, link: MavlinkBoat, got: list) -> None:
    """Read until the ground station holds every packet the link has sent (loopback UDP: nothing is lost)."""
    while len(got) < link.stats.packets_sent:
        msg = gcs.recv_match(blocking=True, timeout=2.0)
        assert msg is not None, f"timed out after {len(got)} of {link.stats.packets_sent} packets"
        got.append(msg)


def run(link: MavlinkBoat, gcs, ticks: int, got: list, chunk: int = 10) -> None:
    for _ in range(ticks // chunk):
        link.step(chunk)
        receive(gcs, link, got)


def crc_ok(msg) -> bool:
    """Recompute the X.25 CRC (with the message's CRC_EXTRA) over the received bytes, independently of decode."""
    buf = bytes(msg.get_msgbuf())
    crc = mavlink2.x25crc(bytearray(buf[1:-2]) + bytearray([msg.crc_extra]))
    return struct.unpack("<H", buf[-2:])[0] == crc.crc


def angle_diff_deg(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_ned_attitude_matches_an_independent_rotation_library() -> None:
    ned_from_enu = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # its own inverse
    flu_from_frd = np.diag([1.0, -1.0, -1.0])
    for q in Rotation.random(50, random_state=1).as_quat():
        r_ned_frd = ned_from_enu @ Rotation.from_quat(q).as_matrix() @ flu_from_frd
        yaw, pitch, roll = Rotation.from_matrix(r_ned_frd).as_euler("ZYX")
        got_roll, got_pitch, got_yaw = ned_attitude(*q)
        assert got_pitch == pytest.approx(pitch, abs=1e-9)
        if abs(abs(pitch) - math.pi / 2) > 1e-3:  # roll and yaw are defined away from gimbal lock
            assert angle_diff_deg(math.degrees(got_roll), math.degrees(roll)) < 1e-7
            assert angle_diff_deg(math.degrees(got_yaw), math.degrees(yaw)) < 1e-7
    # Facing north (ENU yaw 90°): NED yaw 0; nose down (ENU pitch > 0) is a negative NED pitch.
    roll, pitch, yaw = ned_attitude(*Rotation.from_euler("ZYX", [math.pi / 2, 0.1, 0.0]).as_quat())
    assert yaw == pytest.approx(0.0, abs=1e-12) and pitch == pytest.approx(-0.1) and roll == pytest.approx(0.0)


def test_stream_ids_crc_rates_and_positions_match_the_simulators_truth(gcs) -> None:
    config = TwinConfig()
    scenario = make_scenario("turning-circle", config.vessel, np.random.default_rng(0), duration_s=45.0)
    truth = run_sea_trial(config, scenario, seed=0, noise=False).record
    link = MavlinkBoat(LiveTwin(config, seed=2, noise=False, epoch_s=EPOCH_S), url_of(gcs), scenario=scenario)
    got: list = []
    run(link, gcs, 300, got)  # 30 s simulated, default (ArduPilot Rover) rates
    assert {m.get_type() for m in got} == STREAMED
    assert all(m.get_type() != "BAD_DATA" and crc_ok(m) for m in got)
    headers = [m.get_header() for m in got]
    assert {(h.srcSystem, h.srcComponent) for h in headers} == {(1, 1)}
    assert all(bytes(m.get_msgbuf())[0] == 0xFD for m in got)  # MAVLink 2, as ArduPilot
    assert np.all(np.diff([h.seq for h in headers]) % 256 == 1)
    assert Counter(m.get_type() for m in got) == dict.fromkeys(STREAMED, 30)  # 1 Hz each over 30 s
    assert set(ROVER_DEFAULT_RATES_HZ.values()) == {1.0}
    attitude_ms = [m.time_boot_ms for m in got if m.get_type() == "ATTITUDE"]
    assert attitude_ms == list(range(0, 30000, 1000))

    latency_s = config.gnss.latency_s
    positions = [m for m in got if m.get_type() == "GLOBAL_POSITION_INT"]
    assert [m.time_boot_ms for m in positions] == [100] + list(range(1000, 30000, 1000))  # first fix at 0.1 s
    g = config.gnss
    for m in positions:
        i = round((m.time_boot_ms / 1000.0 - latency_s) * 10)
        east, north, up = pymap3d.geodetic2enu(m.lat * 1e-7, m.lon * 1e-7, m.alt * 1e-3,
                                               g.origin_lat_deg, g.origin_lon_deg, g.origin_alt_m)
        assert east == pytest.approx(truth.states[i, 0, 0], abs=0.02)
        assert north == pytest.approx(truth.states[i, 0, 1], abs=0.02)
        assert up == pytest.approx(g.antenna_height_m, abs=0.002)
        tr = truth.truth()
        assert m.vx / 100 == pytest.approx(tr.vel_north_mps[i], abs=0.006)  # NED: x north, y east
        assert m.vy / 100 == pytest.approx(tr.vel_east_mps[i], abs=0.006)
        j = round(m.time_boot_ms / 100)
        assert angle_diff_deg(m.hdg / 100, math.degrees(math.pi / 2.0 - truth.states[j, 0, 2]) % 360.0) < 0.006
    for m in (m for m in got if m.get_type() == "ATTITUDE"):
        j = round(m.time_boot_ms / 100)
        assert angle_diff_deg(math.degrees(m.yaw), 90.0 - math.degrees(truth.states[j, 0, 2])) < 1e-4
        assert m.yawspeed == pytest.approx(-truth.states[j, 0, 5], abs=1e-6)  # FRD: clockwise positive
    turning = [m for m in got if m.get_type() == "SERVO_OUTPUT_RAW" and m.time_usec >= 11_000_000]
    assert turning and all(m.servo1_raw == m.servo2_raw == 1900 for m in turning)  # full starboard helm
    row = truth.commands[-1, 0]
    assert {m.servo3_raw for m in turning} == {pwm_from_fraction(row[0] / config.vessel.bollard_thrust_N)}

    # A ground station asks for 5 Hz positions and no attitude (REQUEST_DATA_STREAM, as MAVProxy and QGC do).
    gcs.mav.request_data_stream_send(1, 1, mavlink2.MAV_DATA_STREAM_POSITION, 5, 1)
    gcs.mav.request_data_stream_send(1, 1, mavlink2.MAV_DATA_STREAM_EXTRA1, 0, 0)
    got_before = len(got)
    run(link, gcs, 100, got)
    later = got[got_before:]
    stamps = [m.time_boot_ms for m in later if m.get_type() == "GLOBAL_POSITION_INT"]
    assert len(stamps) == 50 and set(np.diff(stamps)) == {200}
    assert not any(m.get_type() == "ATTITUDE" for m in later)
    assert link.stats.packets_received == 2 and link.stats.dropped == 0
    link.close()


def test_manual_control_and_rc_override_drive_the_twin_and_lapse(gcs) -> None:
    twin = LiveTwin(TwinConfig(), seed=3, noise=False, epoch_s=EPOCH_S)
    vessel = twin.config.vessel
    link = MavlinkBoat(twin, url_of(gcs))
    got: list = []
    run(link, gcs, 10, got)  # the ground station hears a heartbeat, so it knows where to send
    for _ in range(40):  # 40 s: half right stick, 80 % throttle (ArduPilot Rover: y steers, z is throttle)
        gcs.mav.manual_control_send(1, 0, 500, 800, 0, 0)
        run(link, gcs, 10, got)
    assert twin.commands.tolist() == pytest.approx([0.8 * vessel.bollard_thrust_N] * 2
                                                   + [0.5 * vessel.max_steering_rad] * 2)
    assert twin.state[0, 3] > 3.0 and twin.state[0, 5] < -0.05  # under way, turning to starboard (REP-103)
    yaw = np.unwrap([m.yaw for m in got if m.get_type() == "ATTITUDE"][-20:])
    assert np.all(np.diff(yaw) > 0.0) and yaw[-1] - yaw[0] > 1.0  # NED yaw grows: clockwise, to starboard
    servo = [m for m in got if m.get_type() == "SERVO_OUTPUT_RAW"][-1]
    assert (servo.servo1_raw, servo.servo2_raw, servo.servo3_raw, servo.servo4_raw) == (1700, 1700, 1820, 1820)
    hud = [m for m in got if m.get_type() == "VFR_HUD"][-1]
    assert hud.throttle == 80 and hud.groundspeed == pytest.approx(math.hypot(*twin.state[0, 3:5]), abs=0.3)

    gcs.mav.manual_control_send(7, 0, -1000, 1000, 0, 0)  # for another vehicle: ignored
    for _ in range(30):  # RC override: channel 1 left of neutral, channel 3 ahead; others not overridden
        gcs.mav.rc_channels_override_send(1, 1, 1300, 65535, 1700, 65535, 65535, 65535, 65535, 65535)
        run(link, gcs, 10, got)
    assert link.override() == {"throttle": 0.5, "steering": -0.5}
    assert twin.state[0, 5] > 0.05  # now turning to port
    assert link.stats.commands_applied == 70 and link.stats.ignored == 1

    run(link, gcs, round(OVERRIDE_TIMEOUT_S * 10) + 10, got)  # the ground station falls silent
    assert link.override() == {"throttle": None, "steering": None}
    assert twin.commands.tolist() == [0.0, 0.0, 0.0, 0.0]
    link.close()


def test_unsupported_commands_get_an_unsupported_ack_and_parameters_answer(gcs) -> None:
    link = MavlinkBoat(LiveTwin(TwinConfig(), noise=False, epoch_s=EPOCH_S), url_of(gcs))
    got: list = []
    run(link, gcs, 10, got)
    gcs.mav.command_long_send(1, 1, mavlink2.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
    gcs.mav.command_int_send(1, 0, 0, mavlink2.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0, 430700000, 1319000000, 0)
    gcs.mav.command_long_send(42, 1, mavlink2.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)  # another system
    gcs.mav.param_request_list_send(1, 1)
    gcs.mav.param_set_send(1, 1, b"SR0_EXTRA1", 5.0, mavlink2.MAV_PARAM_TYPE_REAL32)
    run(link, gcs, 20, got)
    acks = [m for m in got if m.get_type() == "COMMAND_ACK"]
    assert [(a.command, a.result) for a in acks] == [
        (mavlink2.MAV_CMD_DO_SET_MODE, mavlink2.MAV_RESULT_UNSUPPORTED),
        (mavlink2.MAV_CMD_DO_REPOSITION, mavlink2.MAV_RESULT_UNSUPPORTED),
    ]
    assert {(a.target_system, a.target_component) for a in acks} == {(255, 190)}
    params = {m.param_id: m.param_value for m in got if m.get_type() == "PARAM_VALUE"}
    assert params["SR0_POSITION"] == 1.0 and params["SYSID_THISMAV"] == 1.0 and params["SR0_EXTRA1"] == 5.0
    attitude = [m.time_boot_ms for m in got if m.get_type() == "ATTITUDE" and m.time_boot_ms >= 1000]
    assert set(np.diff(attitude)) == {200}  # SR0_EXTRA1 = 5 Hz
    link.close()


def test_non_loopback_addresses_need_the_flag() -> None:
    with pytest.raises(InputError, match="--allow-remote") as err:
        parse_url("udpout:10.1.2.3:14550")
    assert "\n" not in str(err.value)
    assert parse_url("udpout:10.1.2.3:14550", allow_remote=True).loopback is False
    with pytest.raises(InputError, match="not a loopback"):
        parse_url("udpin:0.0.0.0:14550")
    assert parse_url("udpout:localhost:14550").loopback
    assert parse_url("udp:127.0.0.1:0").mode == "udpin"
    for bad in ("tcp:127.0.0.1:5760", "udpout:127.0.0.1", "udpout:127.0.0.1:0", "udpout:127.0.0.1:x", "/dev/ttyACM0"):
        with pytest.raises(InputError):
            parse_url(bad)
    with pytest.raises(InputError, match="allow-remote"):
        MavlinkBoat(LiveTwin(TwinConfig()), "udpout:192.0.2.1:14550")


def test_cli_refuses_a_remote_address_in_one_line(capsys) -> None:
    assert main(["simulate", "--mavlink", "udpout:192.0.2.1:14550", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--allow-remote" in err


def test_cli_streams_in_real_time_and_writes_tlog_and_bag(gcs, tmp_path, capsys) -> None:
    tlog, bag = tmp_path / "run.tlog", tmp_path / "run.mcap"
    start = time.monotonic()
    assert main(["simulate", "accel-stop", "--duration", "2", "--mavlink", url_of(gcs), "--mavlink-speed", "10",
                 "--tlog", str(tlog), "--out", str(bag), "--json", "--no-noise", "--mavlink-rate", "position=5"]) == 0
    wall_s = time.monotonic() - start
    assert wall_s >= 0.2  # 20 tick periods of 10 ms: paced, not as fast as possible
    result = json.loads(capsys.readouterr().out)
    assert result["duration_s"] == 2.0 and result["messages"] > 0 and result["link"]["send_errors"] == 0
    heard = []
    while (msg := gcs.recv_match(blocking=False)) is not None:
        heard.append(msg.get_type())
    assert heard.count("HEARTBEAT") == 3 and len(heard) == result["link"]["packets_sent"]
    # The .tlog: MAVProxy's layout (big-endian µs since the Unix epoch, then the packet), stamped in sim time.
    raw = tlog.read_bytes()
    first_us = struct.unpack(">Q", raw[:8])[0]
    assert abs(first_us * 1e-6 - time.time()) < 60.0 and raw[8] == 0xFD
    log = mavutil.mavlink_connection(str(tlog))
    stamps, kinds = [], []
    while (msg := log.recv_match()) is not None:
        stamps.append(msg._timestamp)
        kinds.append(msg.get_type())
    assert len(kinds) == result["link"]["packets_logged"] and set(kinds) == STREAMED
    assert kinds.count("GLOBAL_POSITION_INT") == 11 and kinds.count("ATTITUDE") == 3  # 0.1, 0.2 … 2.0 s; 1 Hz
    assert np.all(np.diff(stamps) >= 0) and stamps[-1] - stamps[0] == pytest.approx(2.0, abs=1e-3)
    assert main(["simulate", "accel-stop", "--tlog", str(tlog)]) == 2  # exists: refused without --force
    assert "already exists" in capsys.readouterr().err
    for bad in ("FOO=1", "POSITION=fast", "ALL=99", "POSITION"):
        assert main(["simulate", "accel-stop", "--tlog", str(tmp_path / "x.tlog"), "--mavlink-rate", bad]) == 2
        assert capsys.readouterr().err.count("\n") == 1


def test_fuzzed_datagrams_are_dropped_and_counted_never_applied() -> None:
    hypothesis = pytest.importorskip("hypothesis")
    st = pytest.importorskip("hypothesis.strategies")
    twin = LiveTwin(TwinConfig(), noise=False, epoch_s=EPOCH_S)
    link = MavlinkBoat(twin, "udpin:127.0.0.1:0")
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    target = link.local_address
    mav = mavlink2.MAVLink(None, 255, 190)
    valid = bytes(mav.manual_control_encode(1, 0, 900, 900, 0, 0).pack(mav))
    header = bytearray(valid[:10])
    header[7:10] = (0x7F_FF_F0).to_bytes(3, "little")  # a message id no dialect knows
    unknown = bytes(header) + valid[10:-2]
    unknown += struct.pack("<H", mavlink2.x25crc(bytearray(unknown[1:]) + bytearray([42])).crc)

    flipped = st.tuples(st.integers(0, len(valid) - 1), st.integers(1, 255)).map(
        lambda a: valid[: a[0]] + bytes([valid[a[0]] ^ a[1]]) + valid[a[0] + 1:])
    truncated = st.integers(1, len(valid) - 1).map(lambda n: valid[:n])
    malformed = st.one_of(flipped, truncated, st.just(unknown), st.just(unknown[:-3]))
    garbage = st.binary(max_size=400)

    def deliver(data: bytes) -> None:
        sender.sendto(data, target)
        assert link.poll(timeout_s=2.0) == 1

    @hypothesis.settings(max_examples=150, deadline=None, derandomize=True, database=None)
    @hypothesis.given(bad=malformed, noise=garbage, glue=st.booleans())
    def check(bad: bytes, noise: bytes, glue: bool) -> None:
        before = link.stats.as_dict()
        deliver(bad + noise if glue else bad)
        after = link.stats.as_dict()
        assert after["dropped"] > before["dropped"]
        assert after["commands_applied"] == before["commands_applied"]
        assert link.override() == {"throttle": None, "steering": None}
        if not glue:
            assert after["packets_received"] == before["packets_received"]
        before = after
        deliver(noise)
        after = link.stats.as_dict()
        if noise:  # every non-empty datagram is accounted for: a packet or a drop
            assert (after["packets_received"] + after["dropped"]
                    > before["packets_received"] + before["dropped"])

    check()
    deliver(valid)  # the link still works: a good packet right after the fuzzing is applied
    assert link.stats.commands_applied == 1 and link.override() == {"throttle": 0.9, "steering": 0.9}
    assert link.stats.dropped >= 150
    link.step(1)  # and the twin still ticks
    sender.close()
    link.close()


def test_a_tlog_the_twin_wrote_identifies_as_the_bag_of_the_same_trial(tmp_path) -> None:
    """One live run, two records: the .tlog (MAVLink, PWM commands) and the bag (ROS messages) identify alike.

    Telemetry the identifier can use needs 10 Hz streams (as a ground station requests them, or SR0_* = 10):
    at Rover's default 1 Hz the steady-state detector cannot judge 20 s windows. Five thrust levels of the
    paper's staircase (14, 23, 65, 80, 120 kgf) keep the run short; the 23 → 65 kgf step crosses the hump.
    """
    import yaml

    from boat_twin.ident.pipeline import identify_arrays
    from boat_twin.io.bags import write_bag
    from boat_twin.io.sources import read_trial_file
    from boat_twin.link.mavlink_boat import servo_calibration
    from boat_twin.units import KGF_N
    from boat_twin.vessel.scenarios import thrust_steps

    config = TwinConfig()
    scenario = thrust_steps(config.vessel, levels_N=tuple(kgf * KGF_N for kgf in (14, 23, 65, 80, 120)))
    rates = {"POSITION": 10.0, "EXTRA1": 10.0, "RC_CHAN": 10.0}
    tlog, bag, calibration = tmp_path / "steps.tlog", tmp_path / "steps.mcap", tmp_path / "twin.yaml"
    with MavlinkBoat(LiveTwin(config, seed=5, epoch_s=EPOCH_S), None, tlog=tlog, scenario=scenario,
                     rates_hz=rates) as link:
        ros = link.step(int(scenario.duration_s * 10) + 1)
    write_bag(bag, iter(ros))
    calibration.write_text(yaml.safe_dump(servo_calibration(config.vessel)))
    results = {}
    for name, trial in (("tlog", read_trial_file(tlog, calibration=calibration)), ("bag", read_trial_file(bag))):
        assert not trial.metadata.missing and not trial.metadata.gaps
        keep = np.isfinite(trial.surge_thrust_N) & np.isfinite(trial.speed_mps)
        assert keep.mean() > 0.99
        results[name] = identify_arrays(trial.t_s[keep], trial.surge_thrust_N[keep], trial.speed_mps[keep])
    from_tlog, from_bag = results["tlog"], results["bag"]
    assert len(from_tlog["steady_points"]) == len(from_bag["steady_points"]) == 5
    for a, b in zip(from_tlog["steady_points"], from_bag["steady_points"], strict=True):
        assert a["speed_mps"] == pytest.approx(b["speed_mps"], abs=0.005)  # cm/s telemetry vs float topics
        assert a["thrust_N"] == pytest.approx(b["thrust_N"], abs=5.5)  # PWM: 1 µs = 5 N per outboard here
        truth = float(config.vessel.resistance.force_N(a["speed_mps"]))
        assert a["thrust_N"] == pytest.approx(truth, abs=6.0 + 0.01 * truth)
    mass_tlog, mass_bag = from_tlog["dynamic"]["mass_kg"], from_bag["dynamic"]["mass_kg"]
    low, high = from_bag["dynamic"]["mass_ci95_kg"]
    assert low < mass_tlog < high and mass_tlog == pytest.approx(mass_bag, rel=0.02)
    assert mass_bag == pytest.approx(config.vessel.mass_kg * (1 + config.vessel.surge_added_mass_ratio), rel=0.05)
    speeds = np.linspace(1.0, 9.2, 50)
    curves = [np.polynomial.polynomial.polyval(speeds, next(
        f["coefficients"] for f in r["fits"] if f["order"] == r["selected_order"])) for r in (from_tlog, from_bag)]
    np.testing.assert_allclose(curves[0], curves[1], rtol=0.03, atol=5.0)
