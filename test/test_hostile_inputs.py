"""Hostile inputs of the fault campaign (issue 24): YAML bombs, FIFOs, absurd durations and thrusts, corrupt MCAP
records, symlink loops, unset .tlog stamps, MAVLink floods, the live identifier fed absurd samples. Each is one
line and exit 2 (or a named warning), never a hang, a traceback or a silently changed result."""

from __future__ import annotations

import math
import os
import shutil
import socket
import struct
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.live import LiveIdentifier
from boat_twin.io.bags import write_bag
from boat_twin.io.mavlink import read_mavlink_trial
from boat_twin.io.mcap_crc import check_chunk_crcs
from boat_twin.link.mavlink_boat import MAX_PACKETS_PER_POLL, MavlinkBoat
from boat_twin.twin import run_sea_trial, trial_messages
from boat_twin.twin.live import LiveTwin
from boat_twin.vessel import make_scenario

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "config" / "cable" / "default.yaml"
CALIBRATION = ROOT / "config" / "mavlink" / "ardupilot_two_outboards.yaml"
BOAT_TWIN = str(Path(sys.executable).parent / "boat-twin") if (Path(sys.executable).parent / "boat-twin").exists() \
    else (shutil.which("boat-twin") or "boat-twin")
CSV_HEADER = "t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n"


def _run(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as stop:
        return int(stop.code or 0)


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert "Traceback" not in err and lines and err.count("error:") == 1 and "error:" in lines[-1], err
    return lines[-1]


BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi", strict=True))
YAML_FILES = {
    "bomb": "vessel:\n  mass_kg: 1300\n" + BOMB.replace("\n", "\n  ").join(["x:\n  ", ""]),
    "deep": "vessel: " + "[" * 3000 + "]" * 3000 + "\n",
    "duplicate": "vessel:\n  mass_kg: 1300\nvessel:\n  length_m: 6\n",
    "digits": "vessel:\n  mass_kg: " + "9" * 400 + "\n",
    "length": "vessel:\n  length_m: 1.0e+300\n",
    "engine": "vessel:\n  engine_x_m: -1.0e+300\n",
    "beside": "vessel:\n  mass_kg: 1300\nbeam_m: 3.0\n",
    "environment": "vessel:\n  mass_kg: 1300\nenvironment: {wind_speed_mps: 5}\n",
    "cal_list": "columns: {time: t, x: x, y: y, thrust_left: tl}\ncalibration: [1, 2]\n",
}


@pytest.fixture()
def hostile(tmp_path, accel_stop_bag) -> dict[str, str]:
    files = {}
    for name, text in YAML_FILES.items():
        (tmp_path / f"{name}.yaml").write_text(text)
        files[name] = str(tmp_path / f"{name}.yaml")
    (tmp_path / "huge.yaml").write_bytes(b"# " + b"x" * (5 << 20) + b"\n")
    os.mkfifo(tmp_path / "fifo.yaml")
    os.mkfifo(tmp_path / "fifo.mcap")
    os.mkfifo(tmp_path / "fifo.tlog")
    os.mkfifo(tmp_path / "fifo.csv")
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    (tmp_path / "trial.csv").write_text("t,x,y,tl\n0,0,0,1\n1,1,0,1\n2,2,0,1\n")
    (tmp_path / "wide.csv").write_text(CSV_HEADER + "0," + "1" * (10 << 20) + ",0,0,0\n")
    (tmp_path / "widetrial.csv").write_text("t,x,y,tl\n0,0,0," + "1" * (10 << 20) + "\n")
    for name, row in {"late": "604801,100,100,0,0", "thrust": "0,1e300,100,0,0", "mn": "0,2e6,100,0,0"}.items():
        (tmp_path / f"{name}.csv").write_text(CSV_HEADER + "0,0,0,0,0\n" + row.replace("0,", "1,", 0) + "\n"
                                              if name == "late" else CSV_HEADER + row + "\n1,0,0,0,0\n")
    bag = tmp_path / "fifobag"
    bag.mkdir()
    os.mkfifo(bag / "metadata.yaml")
    (bag / "fifobag_0.mcap").write_bytes(b"")
    bad_meta = tmp_path / "badmeta"
    bad_meta.mkdir()
    (bad_meta / "metadata.yaml").write_text(  # rosbags' YAML error spans several lines
        "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  relative_file_paths: [trial.mcap\n"
        "  duration: {nanoseconds: 1}\n")
    shutil.copy(accel_stop_bag, bad_meta / "trial.mcap")
    return {**files, **{p.stem: str(p) for p in tmp_path.iterdir() if p.suffix != ".yaml" and p.stem not in files},
            "fifo": str(tmp_path / "fifo.yaml"), "huge": str(tmp_path / "huge.yaml"), "tmp": str(tmp_path)}


@pytest.mark.parametrize(("argv", "message"), [
    (["simulate", "accel-stop", "--json", "--config", "{bomb}"], "alias bomb"),
    (["simulate", "accel-stop", "--json", "--model", "{bomb}"], "alias bomb"),
    (["identify", "{tlog}", "--calibration", "{bomb}"], "alias bomb"),
    (["cable", "depth", "--case", "{bomb}"], "alias bomb"),
    (["simulate", "accel-stop", "--json", "--config", "{deep}"], "nested deeper than"),
    (["simulate", "accel-stop", "--json", "--config", "{huge}"], "larger than 4 MiB"),
    (["simulate", "accel-stop", "--json", "--config", "/dev/zero"], "/dev/zero: not a regular file"),
    (["simulate", "accel-stop", "--json", "--config", "{fifo}"], "fifo.yaml: not a regular file"),
    (["simulate", "accel-stop", "--json", "--config", "{duplicate}"], "key 'vessel' given twice"),
    (["simulate", "accel-stop", "--json", "--config", "{digits}"], "an integer of 400 digits"),
    (["simulate", "accel-stop", "--json", "--config", "{length}"], "'length_m' must be <= 500 m"),
    (["simulate", "accel-stop", "--json", "--config", "{engine}"], "'engine_x_m' must be within ±500 m"),
    (["simulate", "accel-stop", "--json", "--model", "{beside}"], "'beam_m' beside 'vessel:'"),
    (["simulate", "accel-stop", "--json", "--model", "{environment}"], "'environment' beside 'vessel:'"),
    (["identify", "{small_bag}", "--boat", "{beside}"], "unknown section 'beam_m'"),
    (["identify", "{trial}", "--columns", "{cal_list}"], "calibration: expected a mapping"),
    (["identify", "{fifo_mcap}"], "fifo.mcap: not a regular file"),
    (["identify", "{fifo_tlog}", "--calibration", str(CALIBRATION)], "fifo.tlog: not a regular file"),
    (["convert", "{fifo_tlog}", "--out", "{tmp}/x.mcap"], "fifo.tlog: not a regular file"),
    (["identify", "{fifo_csv}", "--columns", "time=t,x=x,y=y,thrust_left=tl"], "fifo.csv: not a regular file"),
    (["identify", "{fifobag}"], "metadata.yaml: not a regular file"),
    (["identify", "{badmeta}"], "badmeta/metadata.yaml: malformed YAML at line"),
    (["identify", "{widetrial}", "--columns", "time=t,x=x,y=y,thrust_left=tl"], "malformed CSV"),
    (["simulate", "--commands", "{wide}", "--json"], "malformed CSV"),
    (["simulate", "--commands", "{late}", "--json"], "beyond 604800 s"),
    (["simulate", "--commands", "{thrust}", "--json"], "thrust beyond ±1e+06 N"),
    (["simulate", "--commands", "{mn}", "--json"], "thrust beyond ±1e+06 N"),
    (["simulate", "--commands", "{trial}", "--duration", "inf", "--json"], "seconds up to 604800"),
    (["simulate", "accel-stop", "--duration", "inf", "--json"], "seconds up to 604800"),
    (["simulate", "accel-stop", "--duration", "1e12", "--json"], "up to 604800 (7 days), got 1000000000000.0"),
    (["simulate", "accel-stop", "--duration", "1e300", "--mavlink", "udpout:127.0.0.1:9"], "up to 604800 (7 days)"),
    (["simulate", "accel-stop", "--duration", "604801", "--tlog", "{tmp}/x.tlog"], "up to 604800 (7 days)"),
    (["simulate", "accel-stop", "--duration", "2", "--out", "{loop}"], "symlink loop"),
    (["simulate", "accel-stop", "--duration", "2", "--out", "{tmp}/x.mcap", "--config", "{loop}"], "symlink loop"),
    (["simulate", "--commands", "{loop}", "--out", "{tmp}/x.mcap"], "symlink loop"),
    (["convert", "{loop}", "--out", "{tmp}/x.mcap"], "symlink loop"),
    (["identify", "--table", "dyda2021", "--out", "{loop}"], "loop"),
])
def test_hostile_input_is_one_line_and_exit_2(hostile, accel_stop_bag, own_tlog, capsys, argv, message) -> None:
    names = {**{k.replace(".", "_"): v for k, v in hostile.items()}, "small_bag": str(accel_stop_bag),
             "tlog": str(own_tlog),
             "fifo_mcap": hostile["tmp"] + "/fifo.mcap", "fifo_tlog": hostile["tmp"] + "/fifo.tlog",
             "fifo_csv": hostile["tmp"] + "/fifo.csv", "trial": hostile["tmp"] + "/trial.csv"}
    done: list[int] = []
    worker = threading.Thread(target=lambda: done.append(_run([a.format(**names) for a in argv])), daemon=True)
    worker.start()
    worker.join(60)
    if worker.is_alive():  # unblock a reader stuck on a FIFO, then fail
        for fifo in Path(hostile["tmp"]).rglob("*"):
            if fifo.is_fifo():
                fd = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)
                os.close(fd)
        pytest.fail(f"{argv}: still running after 60 s (a hang)")
    assert done == [2], (argv, done, capsys.readouterr().err)
    line = _one_error_line(capsys.readouterr().err)
    assert message in line, line


# --------------------------------------------------------------------------- corrupt MCAP records


def _chunk_offsets(data: bytes) -> list[int]:
    pos, found = 8, []
    while pos + 9 <= len(data):
        opcode, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        if opcode == 0x02:
            break
        if opcode == 0x06:
            found.append(pos)
        pos += 9 + length
    return found


@pytest.mark.parametrize("where", ["chunk_length", "after_chunks"])
def test_an_mcap_record_claiming_a_tebibyte_is_named_by_the_crc_pass(accel_stop_bag, tmp_path, where) -> None:
    """A chunk whose length field claims 1 TiB (the CRC pass, run when a read fails, would allocate it), and a
    length flipped in a record after the chunks (a seek to an absurd offset): an InputError naming the file and
    the record's offset, not a MemoryError or an OSError."""
    data = bytearray(accel_stop_bag.read_bytes())
    chunks = _chunk_offsets(bytes(data))
    at = chunks[0] if where == "chunk_length" else chunks[-1] + 9 + struct.unpack_from("<Q", data, chunks[-1] + 1)[0]
    struct.pack_into("<Q", data, at + 1, (1 << 40) if where == "chunk_length" else (1 << 64) - 2)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(InputError, match=rf"bad.mcap: MCAP record at byte {at} claims"):
        check_chunk_crcs(bad)


# --------------------------------------------------------------------------- .tlog receive stamps


def test_tlog_receive_stamps_all_unset_are_named(tmp_path, own_tlog) -> None:
    """Every receive stamp 2^64 - 1 µs (unset): the summary says so instead of reading them as a clock."""
    data, out, i = own_tlog.read_bytes(), bytearray(), 0
    while i + 10 < len(data):
        magic, length = data[i + 8], data[i + 9]
        size = 12 + length + (13 if data[i + 10] & 1 else 0) if magic == 0xFD else 8 + length
        out += struct.pack(">Q", (1 << 64) - 1) + data[i + 8:i + 8 + size]
        i += 8 + size
    unset = tmp_path / "unset.tlog"
    unset.write_bytes(bytes(out))
    summary = read_mavlink_trial(unset, CALIBRATION).metadata.summary_line()
    assert "receive stamp(s) are no Unix time" in summary and "boot time only" in summary, summary
    assert "no Unix time" not in read_mavlink_trial(own_tlog, CALIBRATION).metadata.summary_line()


# --------------------------------------------------------------------------- live: MAVLink flood, identifier


def test_a_flood_of_packed_datagrams_is_capped_by_packets_not_datagrams() -> None:
    link = MavlinkBoat(LiveTwin(TwinConfig(), noise=False, epoch_s=1.7e9), "udpin:127.0.0.1:0")
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    mav = mavlink2.MAVLink(None, 255, 190)
    packet = bytes(mav.heartbeat_encode(6, 8, 0, 0, 0).pack(mav))
    try:
        for _ in range(20):  # 20 datagrams of 200 packets each: 4000 packets
            sender.sendto(packet * 200, link.local_address)
        link.poll(timeout_s=1.0)
        assert link.stats.packets_received <= MAX_PACKETS_PER_POLL
        assert link.stats.packets_received + link.stats.flood_dropped >= MAX_PACKETS_PER_POLL
    finally:
        sender.close()
        link.close()


def _feed(ident: LiveIdentifier, hostile: bool) -> None:
    """Thrust steps 500..2500 N held 60 s each, speed from a first-order lag to v = sqrt(F/40); ``hostile``:
    ±1e300 and NaN commands and velocities sprinkled in (as a broken driver publishes)."""
    rng = np.random.default_rng(7)
    speed, t = 0.0, 0
    for level in (500.0, 1000.0, 1500.0, 2000.0, 2500.0, 1200.0, 700.0, 1800.0):
        ident.set_command(0, level / 2)
        ident.set_command(1, level / 2)
        for _ in range(600):
            speed += 0.1 * (math.sqrt(level / 40.0) - speed) / 5.0
            t += 100_000_000
            if hostile and rng.random() < 0.02:
                ident.set_command(int(rng.integers(0, 2)), float(rng.choice([1e300, -1e300, math.nan])))
                ident.on_velocity(t - 50_000_000, float(rng.choice([1e300, math.nan])), 0.0)
            ident.on_velocity(t, speed + 0.01 * rng.standard_normal(), 0.0)


def test_the_live_identifier_refuses_absurd_samples_and_recovers_from_a_non_finite_fit() -> None:
    clean, attacked = LiveIdentifier(order=2), LiveIdentifier(order=2)
    _feed(clean, hostile=False)
    _feed(attacked, hostile=True)
    _, expected = clean.coefficients()
    _, got = attacked.coefficients()
    assert all(math.isfinite(v) for v in got), got
    assert attacked.rejected > 0 and attacked.status()["rejected_samples"] == attacked.rejected
    np.testing.assert_allclose(got[-1], expected[-1], rtol=0.2)  # the mass
    # A fit gone non-finite (whatever the cause) restarts from the held commands instead of publishing NaN.
    attacked.core._steady._theta[:] = math.nan
    _feed(attacked, hostile=False)
    assert attacked.recoveries >= 1
    assert all(math.isfinite(v) for v in attacked.coefficients()[1])


# --------------------------------------------------------------------------- diagnose names what identify names


def test_diagnose_prints_the_trial_summary_and_names_absurd_thrust(accel_stop_bag, tmp_path, capsys) -> None:
    from rosbags.highlevel import AnyReader  # noqa: F401 - the bag is rewritten through the package's writer

    from boat_twin.io.messages import TS

    trial = run_sea_trial(TwinConfig(), make_scenario("thrust-steps", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=160.0), seed=0)
    messages = list(trial_messages(trial, truth=False))
    thrusts = [i for i, m in enumerate(messages) if m[0] == "thrusters/left/thrust"]
    for i in thrusts[5:15]:
        topic, stamp, msg = messages[i]
        messages[i] = (topic, stamp, TS.types["std_msgs/msg/Float64"](data=400_000.0))
    bag = tmp_path / "absurd.mcap"
    write_bag(bag, messages)
    assert main(["diagnose", str(bag), "--json"]) == 0
    err = capsys.readouterr().err
    assert "absurd.mcap: thrust_left" in err  # the summary identify prints
    assert "warning: thrust_left: " in err and "sample(s) beyond 1e+04 N" in err and "up to 4e+05 N" in err, err
    from boat_twin.ident.pipeline import trial_warnings
    from boat_twin.io.sources import read_trial_file

    named = [w for w in trial_warnings(read_trial_file(bag)) if "sample(s) beyond" in w]  # identify's warnings
    assert len(named) == 1 and "thrust_left: 100 sample(s) beyond 1e+04 N" in named[0], named


def test_sigterm_on_a_blocked_reader_never_hangs_the_tests() -> None:
    """Guard for the FIFO cases above: a real process reading a FIFO trial ends with exit 2, not a hang."""
    fifo = Path(os.environ.get("TMPDIR", "/tmp")) / f"boat_twin_fifo_{os.getpid()}.mcap"
    os.mkfifo(fifo)
    try:
        run = subprocess.run([BOAT_TWIN, "identify", str(fifo)], capture_output=True, text=True, timeout=60)
    finally:
        fifo.unlink()
    assert run.returncode == 2 and "not a regular file" in _one_error_line(run.stderr)


def test_diagnose_on_a_velocity_nan_throughout_is_one_line(tmp_path, capsys) -> None:
    trial = run_sea_trial(TwinConfig(), make_scenario("thrust-steps", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=160.0), seed=0)
    messages = []
    for topic, stamp, msg in trial_messages(trial, truth=False):
        if topic == "gnss/vel":
            msg.twist.linear.y = math.nan
        messages.append((topic, stamp, msg))
    write_bag(tmp_path / "nan_vel.mcap", messages)
    assert main(["diagnose", str(tmp_path / "nan_vel.mcap"), "--json"]) == 2
    assert "nan_vel.mcap: the speed over ground is unknown throughout" in _one_error_line(capsys.readouterr().err)


def test_an_alias_bomb_in_a_bags_metadata_is_refused_before_rosbags_parses_it(accel_stop_bag, tmp_path, capsys) -> None:
    bag = tmp_path / "bombed"
    bag.mkdir()
    shutil.copy(accel_stop_bag, bag / "trial.mcap")
    (bag / "metadata.yaml").write_text(BOMB)
    assert main(["identify", str(bag)]) == 2
    assert "metadata.yaml: malformed YAML" in _one_error_line(capsys.readouterr().err)


# --------------------------------------------------------------------------- a thrust held very long


def _steps_bag(path: Path, stop_thrust_after_s: float | None = None) -> Path:
    """The default boat's thrust-steps trial (its natural length) as a bag; ``stop_thrust_after_s``: the thrust
    topics stop publishing from then on (a logger fault: the reader's zero-order hold keeps the last value)."""
    run = run_sea_trial(TwinConfig(), make_scenario("thrust-steps", TwinConfig().vessel, np.random.default_rng(0)),
                        seed=0)
    cut_ns = math.inf if stop_thrust_after_s is None else stop_thrust_after_s * 1e9
    write_bag(path, [(topic, stamp, msg) for topic, stamp, msg in trial_messages(run, truth=False)
                     if not (topic.endswith("/thrust") and stamp > cut_ns)])
    return path


def test_a_thrust_held_beyond_15_surge_response_times_is_named_by_identify_and_diagnose(tmp_path, capsys,
                                                                                        monkeypatch) -> None:
    from boat_twin.diagnose import pipeline as diagnosis
    from boat_twin.ident.pipeline import trial_warnings
    from boat_twin.io.sources import read_trial_file
    from boat_twin.vessel.params import held_command_limit_s

    limit_s = held_command_limit_s(TwinConfig().vessel)
    assert 200.0 < limit_s < 300.0  # 15 x 16 s: the default boat's slowest speed build-up, m11·u/Fc(u)
    clean = read_trial_file(_steps_bag(tmp_path / "steps.mcap"))
    assert not [w for w in trial_warnings(clean) if "held" in w]  # the scenario's own steps (<= 180 s) pass
    stopped = _steps_bag(tmp_path / "stopped.mcap", stop_thrust_after_s=60.0)
    trial = read_trial_file(stopped)
    held = [w for w in trial_warnings(trial) if "held unchanged" in w]
    end = trial.t_s[-1]  # the first step (from t = 0, still on at 60 s) held to the end
    assert len(held) == 1 and "thrust_left: " in held[0] and "thrust_right: " in held[0], held
    assert f"held unchanged for {end:.0f} s, t = 0.0 to {end:.1f} s" in held[0], held
    assert f"longer than {limit_s:.0f} s" in held[0] and "stopped publishing" in held[0]

    def stop(*args, **kwargs):
        raise InputError("stopped after the summary")  # the diagnosis itself is test_diagnose's

    monkeypatch.setattr(diagnosis, "diagnose_trial", stop)
    assert main(["diagnose", str(stopped)]) == 2
    err = capsys.readouterr().err
    assert "warning: thrust_left: " in err and "held unchanged for" in err and "surge response time" in err, err
