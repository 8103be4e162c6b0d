"""Bags: write with rosbags, read back with our reader and with an independent decoder; Trial; bad input."""

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.trial import Stream, build_trial
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.scenarios import make_scenario


@pytest.fixture(scope="module")
def sea_trial():
    config = TwinConfig()
    scenario = make_scenario("random", config.vessel, np.random.default_rng(2), duration_s=60.0)
    return run_sea_trial(config, scenario, seed=2, noise=False)


@pytest.fixture(scope="module")
def mcap_bag(sea_trial, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bags") / "trial"
    write_bag(path, trial_messages(sea_trial))
    return path


def test_independent_decoder_reads_what_we_write(mcap_bag, sea_trial) -> None:
    files = list(mcap_bag.glob("*.mcap"))
    assert len(files) == 1
    fixes = []
    with files[0].open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        topics = set()
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            topics.add(channel.topic)
            if channel.topic == "/gnss/fix":
                stamp = decoded.header.stamp.sec + decoded.header.stamp.nanosec * 1e-9
                assert message.log_time == decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec
                fixes.append((stamp, decoded.latitude, decoded.longitude))
    assert {"/gnss/fix", "/gnss/vel", "/imu/data", "/imu/mag", "/imu/rpy", "/imu/temperature", "/odom/truth",
            "/thrusters/left/thrust", "/thrusters/right/pos"} <= topics
    fixes = np.array(fixes)
    np.testing.assert_allclose(fixes[:, 0], sea_trial.gnss.stamp_s, atol=1e-9)
    np.testing.assert_allclose(fixes[:, 1], sea_trial.gnss.lat_deg, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fixes[:, 2], sea_trial.gnss.lon_deg, rtol=0, atol=1e-12)


def test_trial_from_bag_matches_the_simulation(mcap_bag, sea_trial) -> None:
    trial = read_trial(mcap_bag)
    record = sea_trial.record
    truth = record.truth()
    # GNSS carries the state latency_s before its stamp; compare against the truth at that time.
    latency = TwinConfig().gnss.latency_s
    t_true = trial.t_s + trial.metadata.start_time_s - latency
    assert np.isnan(trial.vel_east_mps[0]) and trial.t_s[1] + trial.metadata.start_time_s == pytest.approx(latency)
    np.testing.assert_allclose(trial.vel_east_mps[1:], np.interp(t_true, truth.t_s, truth.vel_east_mps)[1:], atol=1e-9)
    np.testing.assert_allclose(trial.east_m[1:], np.interp(t_true, truth.t_s, truth.east_m)[1:], atol=1e-3)
    held = np.searchsorted(record.t_s, trial.t_s + trial.metadata.start_time_s + 1e-9, side="right") - 1
    np.testing.assert_array_equal(trial.thrust_left_N, record.commands[held, 0, 0])
    np.testing.assert_array_equal(trial.angle_right_rad, record.commands[held, 0, 3])
    np.testing.assert_allclose(trial.yaw_rate_radps, np.interp(trial.t_s + trial.metadata.start_time_s,
                                                               truth.t_s, truth.yaw_rate_radps), atol=1e-9)
    assert trial.metadata.missing == [] and trial.metadata.gaps == []
    assert trial.metadata.rates_hz["gnss_fix"] == pytest.approx(10.0)


def test_sqlite3_and_bare_mcap_give_the_same_trial(mcap_bag, sea_trial, tmp_path) -> None:
    reference = read_trial(mcap_bag)
    write_bag(tmp_path / "sql", trial_messages(sea_trial), storage="sqlite3")
    write_bag(tmp_path / "bare.mcap", trial_messages(sea_trial))
    for path in (tmp_path / "sql", tmp_path / "bare.mcap"):
        other = read_trial(path)
        np.testing.assert_array_equal(other.t_s, reference.t_s)
        np.testing.assert_array_equal(other.speed_mps, reference.speed_mps)
        np.testing.assert_array_equal(other.thrust_right_N, reference.thrust_right_N)


def test_remapped_and_namespaced_topics(mcap_bag, sea_trial, tmp_path) -> None:
    renamed = ((("boat1/" + topic) if topic != "gnss/vel" else "gps/velocity", stamp, msg)
               for topic, stamp, msg in trial_messages(sea_trial))
    from boat_twin.io import messages

    messages.TOPICS["gps/velocity"] = messages.TOPICS["gnss/vel"]
    for name, msgtype in list(messages.TOPICS.items()):
        messages.TOPICS.setdefault("boat1/" + name, msgtype)
    try:
        write_bag(tmp_path / "ns", renamed)
    finally:
        for name in [n for n in messages.TOPICS if n.startswith("boat1/") or n == "gps/velocity"]:
            del messages.TOPICS[name]
    trial = read_trial(tmp_path / "ns", remap={"gnss_vel": "/gps/velocity"}, namespace="/boat1")
    np.testing.assert_array_equal(trial.speed_mps, read_trial(mcap_bag).speed_mps)


def test_gaps_are_reported_not_interpolated(sea_trial, tmp_path) -> None:
    dropped = ((topic, stamp, msg) for topic, stamp, msg in trial_messages(sea_trial)
               if not (topic == "gnss/vel" and 20e9 <= stamp <= 25e9))
    write_bag(tmp_path / "gap", dropped)
    trial = read_trial(tmp_path / "gap")
    assert [g[0] for g in trial.metadata.gaps] == ["gnss_vel"]
    t_abs = trial.t_s + trial.metadata.start_time_s
    inside = (t_abs > 19.95) & (t_abs < 25.05)  # the samples stamped 20.0 ... 25.0 s were dropped
    assert np.all(np.isnan(trial.vel_east_mps[inside]))
    after_first_fix = t_abs >= 0.1 - 1e-9  # the first fix is stamped one latency after the first command
    assert np.all(np.isfinite(trial.vel_east_mps[~inside & after_first_fix]))


def test_existing_output_is_refused_without_force(mcap_bag, sea_trial) -> None:
    before = sorted(p.stat().st_mtime_ns for p in mcap_bag.iterdir())
    with pytest.raises(InputError, match="already exists"):
        write_bag(mcap_bag, trial_messages(sea_trial))
    assert sorted(p.stat().st_mtime_ns for p in mcap_bag.iterdir()) == before


@pytest.mark.parametrize("damage", ["truncate", "garbage"])
def test_corrupt_bag_is_one_clean_error(mcap_bag, tmp_path, damage) -> None:
    target = tmp_path / "broken.mcap"
    data = next(mcap_bag.glob("*.mcap")).read_bytes()
    target.write_bytes(data[: len(data) // 2] if damage == "truncate" else b"\x89MCAP0\r\n" + b"\x00" * 500)
    with pytest.raises(InputError, match="broken.mcap"):
        read_trial(target)


def test_missing_topic_and_wrong_type_are_clean_errors(sea_trial, tmp_path) -> None:
    no_gnss = ((t, s, m) for t, s, m in trial_messages(sea_trial) if not t.startswith("gnss/"))
    write_bag(tmp_path / "nognss", no_gnss)
    with pytest.raises(InputError, match="no GNSS"):
        read_trial(tmp_path / "nognss")
    with pytest.raises(InputError, match="has type sensor_msgs/msg/Imu, expected geometry_msgs/msg/TwistStamped"):
        read_trial(tmp_path / "nognss", remap={"gnss_vel": "/imu/data"})
    with pytest.raises(InputError, match="not in the bag"):
        read_trial(tmp_path / "nognss", remap={"gnss_vel": "/nowhere"})


def test_commands_and_gnss_without_overlap_are_rejected(sea_trial, tmp_path) -> None:
    late = ((t, s + (10**12 if t.startswith("thrusters/") else 0), m) for t, s, m in trial_messages(sea_trial))
    write_bag(tmp_path / "late", sorted(late, key=lambda x: x[1]))
    with pytest.raises(InputError, match="do not overlap"):
        read_trial(tmp_path / "late")


def test_simulate_cli_replays_a_command_csv(tmp_path, capsys) -> None:
    csv = tmp_path / "cmd.csv"
    csv.write_text("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n"
                   "0,200,200,0,0\n20,300,300,0.1,0.1\n40,0,0,0,0\n")
    assert main(["simulate", "--commands", str(csv), "--no-noise", "--out", str(tmp_path / "bag")]) == 0
    trial = read_trial(tmp_path / "bag")
    assert trial.t_s[-1] == pytest.approx(40.0 - TwinConfig().gnss.latency_s, abs=0.11)
    at = np.searchsorted(trial.t_s, [10.0, 30.0])
    np.testing.assert_array_equal(trial.thrust_left_N[at], [200.0, 300.0])
    np.testing.assert_array_equal(trial.angle_left_rad[at], [0.0, 0.1])
    # Replaying the recorded bag's commands reproduces the same trial.
    assert main(["simulate", "--commands", str(tmp_path / "bag"), "--no-noise", "--out", str(tmp_path / "again")]) == 0
    again = read_trial(tmp_path / "again")
    n = min(len(again), len(trial)) - 2
    np.testing.assert_allclose(again.speed_mps[:n], trial.speed_mps[:n], atol=1e-6)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time,a,b,c,d\n0,1,1,0,0\n", "header must be"),
        ("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n0,1,1,0,0\n0,2,2,0,0\n", ":3: time 0.0"),
        ("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n0,1,x,0,0\n", ":2: not a number"),
        ("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n0,1,nan,0,0\n", ":2: values must be finite"),
    ],
)
def test_bad_command_csv_exits_2_with_one_line(tmp_path, capsys, text, message) -> None:
    csv = tmp_path / "cmd.csv"
    csv.write_text(text)
    assert main(["simulate", "--commands", str(csv), "--out", str(tmp_path / "bag")]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "bag").exists()


def test_unknown_scenario_and_bad_config_exit_2(tmp_path, capsys) -> None:
    assert main(["simulate", "figure-eight", "--out", str(tmp_path / "x")]) == 2
    assert "unknown scenario 'figure-eight'" in capsys.readouterr().err
    cfg = tmp_path / "boat.yaml"
    cfg.write_text("vessel: {mass_kg: -1300}\n")
    assert main(["simulate", "accel-stop", "--config", str(cfg), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "boat.yaml" in err and "mass_kg" in err



@pytest.mark.parametrize("name", ["run.tlog", "run.BIN", "run.csv"])
def test_a_bag_named_like_another_format_is_refused(tmp_path, capsys, name) -> None:
    """A bag directory named x.tlog would be read back as a MAVLink log (and refused as 'not a file')."""
    assert main(["simulate", "accel-stop", "--out", str(tmp_path / name)]) == 2
    assert "--tlog FILE" in capsys.readouterr().err and not (tmp_path / name).exists()

def test_unwritable_output_exits_2(tmp_path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["simulate", "accel-stop", "--out", str(blocker / "bag")]) == 2
    assert "boat-twin simulate: error:" in capsys.readouterr().err


def test_imu_fields_marked_not_provided_read_as_nan(sea_trial, tmp_path) -> None:
    """REP-145: covariance[0] = −1 says the field is not provided; its zeros must not read as a measurement."""
    def unmark(topic, stamp, msg):
        if topic == "imu/data" and 20e9 <= stamp <= 25e9:
            msg.orientation_covariance = np.array([-1.0] + [0.0] * 8)
            msg.angular_velocity_covariance = np.array([-1.0] + [0.0] * 8)
        return topic, stamp, msg

    write_bag(tmp_path / "unmarked", (unmark(*m) for m in trial_messages(sea_trial)))
    trial = read_trial(tmp_path / "unmarked")
    t_abs = trial.t_s + trial.metadata.start_time_s
    inside = (t_abs > 20.05) & (t_abs < 24.95)
    assert np.all(np.isnan(trial.heading_rad[inside])) and np.all(np.isnan(trial.yaw_rate_radps[inside]))
    assert np.all(np.isfinite(trial.accel_x_mps2[inside]))
    assert np.all(np.isfinite(trial.heading_rad[(t_abs > 1.0) & ~((t_abs > 19.95) & (t_abs < 25.05))]))


def test_a_rosbag2_directory_named_dot_bag_reads(tmp_path) -> None:
    """`simulate --out run.bag` writes a rosbag2 directory; it must read back whatever its name (rosbags'
    AnyReader alone takes any .bag path for a ROS 1 file)."""
    from boat_twin.cli import main

    assert main(["simulate", "accel-stop", "--duration", "5", "--no-noise", "--out", str(tmp_path / "run.bag")]) == 0
    trial = read_trial(tmp_path / "run.bag")
    assert trial.metadata.source == str(tmp_path / "run.bag") and len(trial.t_s) > 40


def test_commands_sit_on_the_grid_time_nearest_their_stamp() -> None:
    """A command between two grid times acts from the nearer one (a tie from the later one), so replays of a
    helm that decided between log ticks err by at most half a period either way, never late on average."""
    grid = np.arange(0.0, 6.05, 0.1)
    stamps = np.array([0.0, 1.04, 2.06, 3.05, 4.0])
    streams = {"gnss_vel": Stream(grid, np.zeros((grid.size, 2))),
               "thrust_left": Stream(stamps, np.arange(1.0, 6.0)[:, None])}
    trial = build_trial(streams, "hand-made", {})
    thrust = dict(zip(np.round(trial.t_s, 2), trial.thrust_left_N, strict=True))
    assert [thrust[t] for t in (0.9, 1.0, 1.1)] == [1.0, 2.0, 2.0]  # 1.04 s: from 1.0 s
    assert [thrust[t] for t in (2.0, 2.1)] == [2.0, 3.0]  # 2.06 s: from 2.1 s
    assert [thrust[t] for t in (3.0, 3.1)] == [3.0, 4.0]  # 3.05 s, a tie: from 3.1 s
    assert [thrust[t] for t in (3.9, 4.0, 6.0)] == [4.0, 5.0, 5.0]  # on a grid time: from it


def test_a_stream_without_one_finite_stamp_is_named() -> None:
    grid = np.arange(0.0, 5.0, 0.1)
    streams = {"gnss_vel": Stream(grid, np.zeros((grid.size, 2))), "thrust_left": Stream(grid, np.ones((grid.size, 1))),
               "thrust_right": Stream(np.array([np.nan]), np.array([[1.0]]))}
    with pytest.raises(InputError, match="thrust_right: none of its 1 sample.s. has a finite time stamp"):
        build_trial(streams, "hand-made", {})
