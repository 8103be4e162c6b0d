"""Nothing lost, nothing silently wrong: one writer per output, interrupts (SIGINT, SIGTERM, SIGKILL in a real
process), leftovers of killed runs, absurd inputs, and a generated sweep of every verb's arguments."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hostile import VerbFlags, command_lines
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from processes import popen_as_from_a_shell

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.files import OutputClaim, locked_directory
from boat_twin.io.bags import write_bag
from boat_twin.link.mavlink_boat import MavlinkBoat
from boat_twin.twin import run_sea_trial, trial_messages
from boat_twin.twin.live import LiveTwin
from boat_twin.vessel import make_scenario

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "config" / "cable" / "default.yaml"
CALIBRATION = ROOT / "config" / "mavlink" / "ardupilot_two_outboards.yaml"
BOAT_TWIN = str(Path(sys.executable).parent / "boat-twin") if (Path(sys.executable).parent / "boat-twin").exists() \
    else (shutil.which("boat-twin") or "boat-twin")
"""The console script, as a user runs it."""


def _tree(path: Path) -> dict[str, bytes]:
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def _run(argv: list[str]) -> int:
    """``main`` in-process; argparse's usage errors exit through SystemExit."""
    try:
        return main(argv)
    except SystemExit as stop:
        return int(stop.code or 0)


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert "Traceback" not in err and len(lines) == 1, err
    return lines[0]


@pytest.fixture(scope="module")
def messages():
    trial = run_sea_trial(TwinConfig(), make_scenario("accel-stop", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=40.0), seed=0)
    return list(trial_messages(trial, truth=False))


@pytest.fixture(scope="module")
def small_bag(tmp_path_factory, messages) -> Path:
    path = tmp_path_factory.mktemp("bags") / "trial.mcap"
    write_bag(path, messages)
    return path


# --------------------------------------------------------------------------- one writer per output


def test_a_second_writer_of_one_output_is_refused_in_one_line(tmp_path, capsys) -> None:
    out = tmp_path / "same.mcap"
    argv = ["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(out)]
    with OutputClaim(out, force=False):  # another run writing it now
        assert main(argv) == 2
        assert "another run is writing it now" in _one_error_line(capsys.readouterr().err)
        assert not out.exists()
    assert main(argv) == 0 and out.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.mcap"]  # no lock, no scratch left


def test_two_concurrent_simulate_runs_cannot_both_succeed(tmp_path) -> None:
    argv = [BOAT_TWIN, "simulate", "accel-stop", "--duration", "30", "--no-noise",
            "--out", "same.mcap"]
    runs = [subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            for _ in range(2)]
    results = sorted((run.wait(timeout=300), run.stderr.read()) for run in runs if run.stderr is not None)
    assert [code for code, _ in results] == [0, 2], results
    line = _one_error_line(results[1][1])
    assert "another run is writing it now" in line or "already exists" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.mcap"]


def test_a_second_run_writing_reports_into_one_directory_is_refused(tmp_path, capsys) -> None:
    out = tmp_path / "report"
    out.mkdir()
    with locked_directory(out):  # another identify or diagnose writing there now
        for verb in ("identify", "diagnose"):
            assert main([verb, "--table", "dyda2021", "--out", str(out)]) == 2
            assert "another run is writing its reports into it" in _one_error_line(capsys.readouterr().err)
    assert list(out.iterdir()) == []
    assert main(["identify", "--table", "dyda2021", "--out", str(out)]) == 0


def test_leftovers_of_a_killed_writer_are_restored_or_removed_and_named(tmp_path, capsys) -> None:
    bag = tmp_path / "trial"
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 0
    original = _tree(bag)
    # A run killed between its two renames: the old bag moved aside, the new one still in its scratch.
    bag.rename(tmp_path / ".trial.old-999999")
    (tmp_path / ".trial.partial-999999").mkdir()
    (tmp_path / ".trial.partial-999999" / "half.mcap").write_bytes(b"half")
    (tmp_path / ".trial.partial-1").mkdir()  # another killed run's scratch
    (tmp_path / ".trial.mcap.partial-999999").mkdir()  # another output's: not ours to touch
    capsys.readouterr()
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 2
    err = capsys.readouterr().err
    assert "restored" in err and ".trial.old-999999" in err and "already exists" in err.splitlines()[-1]
    assert err.count("removed") == 2 and "Traceback" not in err
    assert _tree(bag) == original
    assert sorted(p.name for p in tmp_path.iterdir()) == [".trial.mcap.partial-999999", "trial"]


def test_a_tlog_is_written_next_to_its_name_and_a_failed_run_keeps_the_old_one(tmp_path, own_tlog) -> None:
    tlog = tmp_path / "drive.tlog"
    tlog.write_bytes(own_tlog.read_bytes())  # yesterday's log
    old = tlog.read_bytes()

    def drive(fail: bool) -> None:
        with MavlinkBoat(LiveTwin(TwinConfig(), seed=0, noise=False, epoch_s=1.7e9), None, tlog=tlog,
                         overwrite=True) as link:
            link.step(20)
            assert tlog.read_bytes() == old  # nothing partial under the final name
            assert (tmp_path / f".drive.tlog.partial-{os.getpid()}").is_dir()
            if fail:
                raise RuntimeError("the run fails")

    with pytest.raises(RuntimeError):
        drive(fail=True)
    assert tlog.read_bytes() == old and sorted(os.listdir(tmp_path)) == ["drive.tlog"]
    drive(fail=False)
    assert tlog.read_bytes() != old and sorted(os.listdir(tmp_path)) == ["drive.tlog"]


def test_force_replaces_only_an_output_of_the_same_kind(tmp_path, capsys) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("not a log")
    for flag in ("--tlog", "--out"):
        assert main(["simulate", "accel-stop", "--duration", "2", flag, str(notes), "--force"]) == 2
        kind = "MAVLink telemetry log" if flag == "--tlog" else "rosbag2 bag"
        assert f"is not a {kind}" in _one_error_line(capsys.readouterr().err)
    assert notes.read_text() == "not a log"


# --------------------------------------------------------------------------- interrupts in a real process


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGKILL, -9)])
def test_an_interrupt_while_writing_keeps_the_old_output(tmp_path, capsys, signum, code) -> None:
    """A run replacing a bag (--force) is signalled once its new bag is being written; the old bag stays
    whole, nothing partial is under its name, and a SIGKILL's scratch is removed (and named) by the next run."""
    bag = tmp_path / "trial"
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 0
    old = _tree(bag)
    run = popen_as_from_a_shell([BOAT_TWIN, "simulate", "accel-stop", "--duration", "600", "--out", str(bag),
                                 "--force"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    scratch = tmp_path / f".trial.partial-{run.pid}"
    deadline = time.monotonic() + 240
    while not scratch.exists() and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    assert scratch.exists(), "the run never started writing"
    time.sleep(0.3)
    run.send_signal(signum)
    status = run.wait(timeout=120)
    err = run.stderr.read() if run.stderr else ""
    assert status == code and "Traceback" not in err, err
    assert _tree(bag) == old
    if signum == signal.SIGKILL:
        assert scratch.exists()  # nothing can clean up after SIGKILL: the next writer does
        assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag), "--force"]) == 0
        assert f"removed {scratch}" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trial"]


# --------------------------------------------------------------------------- absurd inputs


@pytest.fixture()
def bad_files(tmp_path) -> dict[str, Path]:
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00\x81 not text")
    files = {"binary": binary}
    for name, text in {
        "accel": "um7:\n  accel_stdev_mps2: 1.0e+300\n",
        "temperature": "um7:\n  temperature_celsius: -1.0e+9\n",
        "latency": "gnss:\n  latency_s: 1.0e+9\n",
        "steering": "vessel:\n  max_steering_rad: 1.0e+9\n",
        "latitude": "gnss:\n  origin_lat_deg: 500\n",
        "csv": "t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n0,100,100,2000,0\n10,100,100,0,0\n",
        "drag": CASE.read_text().replace("drag: {model: sphere, cx: 0.47}", "drag: {model: [1, 2]}"),
    }.items():
        files[name] = tmp_path / (f"{name}.csv" if name == "csv" else f"{name}.yaml")
        files[name].write_text(text)
    return files


@pytest.mark.parametrize(("argv", "message"), [
    (["simulate", "accel-stop", "--config", "{binary}", "--json"], "binary.yaml: not a UTF-8 text file"),
    (["simulate", "accel-stop", "--model", "{binary}", "--json"], "binary.yaml: not a UTF-8 text file"),
    (["identify", "{tlog}", "--calibration", "{binary}"], "binary.yaml: not a UTF-8 text file"),
    (["cable", "depth", "--case", "{binary}"], "binary.yaml: not a UTF-8 text file"),
    (["simulate", "accel-stop", "--seed", "-1", "--json"], "--seed: must be an integer from 0"),
    (["diagnose", "{bag}", "--window", "nan"], "--window: expected a finite number, got nan"),
    (["diagnose", "{bag}", "--window", "0.01"], "--window 0.01 s: shorter than 2 s"),
    (["diagnose", "{bag}", "--window", "1e9"], "longer than the trial"),
    (["simulate", "accel-stop", "--config", "{accel}", "--json"], "um7.accel_stdev_mps2: must be <= 156.9"),
    (["simulate", "accel-stop", "--config", "{temperature}", "--json"], "um7.temperature_celsius: must be >= -40"),
    (["simulate", "accel-stop", "--config", "{latency}", "--json"], "gnss.latency_s: must be <= 10"),
    (["simulate", "accel-stop", "--config", "{steering}", "--json"], "'max_steering_rad' must be within ±π/2"),
    (["simulate", "accel-stop", "--config", "{latitude}", "--json"], "gnss.origin_lat_deg: must be <= 90"),
    (["simulate", "--commands", "{csv}", "--json"], "csv.csv:2: steering angle beyond ±π/2 rad"),
    (["simulate", "accel-stop", "--duration", "2", "--out", "/proc/boat_twin_out"], "/proc"),  # root or not
    (["cable", "depth", "--case", "{drag}"], "cable.drag.model: unknown drag model [1, 2]"),
    (["cable", "length", "--case", str(CASE), "--depth", "1e9"], "does not reach the surface from 1e+09 m"),
])
def test_absurd_inputs_are_one_line_and_exit_2(bad_files, small_bag, own_tlog, capsys, argv, message) -> None:
    names = {**{k: str(v) for k, v in bad_files.items()}, "bag": str(small_bag), "tlog": str(own_tlog)}
    assert _run([a.format(**names) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert message in err.strip().splitlines()[-1] and err.count("error:") == 1, err


def test_a_recorded_latitude_beyond_90_is_refused_not_mapped(tmp_path, messages, capsys) -> None:
    fixes = [i for i, m in enumerate(messages) if m[0] == "gnss/fix"]
    topic, stamp, msg = messages[fixes[len(fixes) // 2]]
    bad = list(messages)
    bad[fixes[len(fixes) // 2]] = (topic, stamp, replace(msg, latitude=500.0))
    write_bag(tmp_path / "bad.mcap", bad)
    assert main(["identify", str(tmp_path / "bad.mcap")]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"gnss_fix latitude 500 deg at sample {len(fixes) // 2} is outside [-90, 90] deg" in line


def test_thrust_that_is_all_nan_is_named_not_called_a_time_mismatch(tmp_path, messages, capsys) -> None:
    nan = [(t, s, replace(m, data=float("nan")) if t.endswith("/thrust") else m) for t, s, m in messages]
    write_bag(tmp_path / "nan.mcap", nan)
    assert main(["identify", str(tmp_path / "nan.mcap")]) == 2
    assert "every thrust value is NaN" in capsys.readouterr().err.strip().splitlines()[-1]


def test_a_cable_shorter_than_one_link_is_one_short_link(capsys) -> None:
    assert main(["cable", "depth", "--case", str(CASE), "--segment-length", "1e9", "--length", "0.001",
                 "--json"]) == 0
    assert '"links": 1' in capsys.readouterr().out


# --------------------------------------------------------------------------- generated sweep of every verb

NUMBERS = st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1e-9", "1e9", "1e300", "abc", "", "2", "0x10"])
INTEGERS = st.sampled_from(["-1", "0", "1", "99", "1e3", "abc", "", str(2**70)])
FILES = st.sampled_from(["{binary}", "{missing}", "{dir}", "{empty}", "{text}", "{bag}", str(CASE),
                         str(CALIBRATION)])
OUTS = st.sampled_from(["{new}", "", ".", "/proc/boat_twin_out", "{text}", "{dir}", "{own}"])
VERB_FLAGS: VerbFlags = {
    ("simulate", "accel-stop"): {"--duration": NUMBERS, "--seed": INTEGERS, "--config": FILES, "--model": FILES,
                                 "--commands": FILES, "--current": NUMBERS, "--out": OUTS, "--force": None,
                                 "--no-noise": None, "--storage": st.sampled_from(["mcap", "sqlite3", "x"])},
    ("identify",): {"": FILES, "--table": st.sampled_from(["dyda2021", "x"]), "--order": INTEGERS,
                    "--max-order": INTEGERS, "--steady-window": NUMBERS, "--thrust-tolerance": NUMBERS,
                    "--calibration": FILES, "--topic": st.sampled_from(["x", "gnss_vel=/a"]),
                    "--out": OUTS, "--force": None},
    ("diagnose",): {"": FILES, "--table": st.sampled_from(["dyda2021", "x"]), "--model-order": INTEGERS,
                    "--window": NUMBERS, "--config": FILES, "--out": OUTS},
    ("convert",): {"": FILES, "--out": OUTS, "--calibration": FILES, "--force": None},
    ("cable", "depth"): {"--case": FILES, "--length": NUMBERS, "--tow-speed": NUMBERS, "--segment-length": NUMBERS,
                         "--json": None},
    ("cable", "length"): {"--case": FILES, "--depth": NUMBERS, "--segment-length": NUMBERS, "--json": None},
    ("cable", "speed"): {"--case": FILES, "--depth": NUMBERS, "--length": NUMBERS, "--json": None},
    ("cable", "convergence"): {"--case": FILES, "--segments": NUMBERS, "--tolerance": NUMBERS, "--json": None},
}
"""Each verb's flags and the values they are given ("" is the positional argument; None: a switch)."""


def _cheap(verb: tuple[str, ...], argv: list[str]) -> list[str]:
    if verb[0] == "simulate" and "--duration" not in argv:
        argv += ["--duration", "2"]  # cheap runs
    if verb[0] in ("identify", "diagnose") and "{bag}" in argv and "--table" not in argv:
        argv += ["--window", "nan"] if verb[0] == "diagnose" else ["--order", "0"]  # refused before the work
    return argv


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(argv=command_lines(VERB_FLAGS, _cheap, frozenset({"--current", "--segments"})))
def test_every_verb_answers_bad_arguments_with_one_line_and_exit_2(argv, small_bag, capsys) -> None:
    """Exit 0 or 2, never a traceback; on exit 2 the last stderr line is the one error (progress lines such as
    "reading X ..." may come before it)."""
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        (base / "binary.yaml").write_bytes(b"\x00\xff\xfe\x81")
        (base / "dir").mkdir()
        (base / "dir" / "mine.txt").write_text("keep")
        (base / "empty.mcap").write_bytes(b"")
        (base / "text.yaml").write_text("just: [text\n")
        names = {"binary": base / "binary.yaml", "missing": base / "missing.yaml", "dir": base / "dir",
                 "empty": base / "empty.mcap", "text": base / "text.yaml", "bag": small_bag, "new": base / "new",
                 "own": base / "own.mcap"}
        before = {p: p.read_bytes() for p in base.rglob("*") if p.is_file()}
        names["own"].write_bytes(small_bag.read_bytes())  # a bag of the run's own, which --force may replace
        cwd = os.getcwd()
        os.chdir(base)
        try:
            code = _run([a.format(**{k: str(v) for k, v in names.items()}) for a in argv])
        finally:
            os.chdir(cwd)
        err = capsys.readouterr().err
        assert code in (0, 2), (argv, code, err)
        assert "Traceback" not in err, (argv, err)
        if code == 2:
            lines = err.strip().splitlines()
            assert lines and "error:" in lines[-1] and err.count("error:") == 1, (argv, err)
        assert all(p.read_bytes() == data for p, data in before.items()), argv  # no input or foreign file touched
