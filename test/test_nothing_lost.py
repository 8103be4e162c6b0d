"""Nothing lost, round three (issue 41): --force replaces only an output of the same kind inside a report set,
a full disk or a file-size limit on every writer, a long command file (progress, linear cost, Ctrl-C)."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from processes import BOAT_TWIN, file_tree, one_error_line, popen_as_from_a_shell, run_with_file_size_limit

from boat_twin.cli import main

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "bags" / "thrust_steps_sample"
CABLE_CASE = ROOT / "config" / "cable" / "default.yaml"


# --------------------------------------------------------------------------- a directory where a file goes


@pytest.mark.parametrize(("argv", "mine"), [
    (["identify", str(SAMPLE)], "identify.json"),
    (["identify", "--table", "dyda2021"], "fits.png"),
    (["diagnose", str(SAMPLE)], "diagnosis.json"),
    (["follow", str(SAMPLE)], "follow.json"),
    (["demo", "--sample", str(SAMPLE)], "sample_trial.png"),
    (["demo", "--sample", str(SAMPLE)], "identify"),  # identify's report directory, holding a user's file
    (["demo", "--sample", str(SAMPLE)], "thrust_steps"),  # a bag directory, holding a user's file
])
def test_force_never_replaces_a_directory_where_a_report_goes(tmp_path, capsys, argv, mine) -> None:
    """``rep/NAME/`` a directory holding a user's file where a report file (or a report directory of other
    files) goes: refused before any work with one line naming it, exit 2, the user's file kept."""
    rep = tmp_path / "rep"
    (rep / mine).mkdir(parents=True)
    (rep / mine / "notes.txt").write_text("the user's own")
    assert main([*argv, "--out", str(rep), "--force"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f"{rep / mine}: is a directory" in line and "same kind" in line, line
    assert file_tree(rep) == {f"{mine}/notes.txt": b"the user's own"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no scratch, no lock left


def test_cable_refuses_a_directory_where_its_plot_goes_before_any_work(tmp_path, capsys) -> None:
    """``cable convergence --plot --out OUT --force`` with ``OUT/cable_convergence.png/`` a user's directory:
    refused before the study (no progress line, nothing else printed; depth and length check as early), the
    user's file kept."""
    verb = "convergence"
    mine = tmp_path / "OUT" / f"cable_{verb}.png"
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("the user's own")
    assert main(["cable", verb, "--case", str(CABLE_CASE), "--plot", "--out", str(tmp_path / "OUT"), "--force"]) == 2
    captured = capsys.readouterr()
    assert captured.err == f"boat-twin cable: error: {mine}: is not a file; refusing to replace it\n", captured.err
    assert captured.out == "" and (mine / "notes.txt").read_text() == "the user's own"


def test_force_still_replaces_the_verbs_own_report_directory(tmp_path) -> None:
    """The same check lets --force replace what the verb wrote itself: demo's ``identify/`` of identify's files
    (only those), its bag, its plot."""
    from boat_twin.cli.demo import OUTPUT_KINDS
    from boat_twin.files import ReportSet

    rep = tmp_path / "rep"
    (rep / "identify").mkdir(parents=True)
    (rep / "identify" / "identify.json").write_text("{}")
    (rep / "thrust_steps").mkdir()
    (rep / "thrust_steps" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (rep / "sample_trial.png").write_bytes(b"png")
    (rep / "notes.txt").write_text("kept")
    with ReportSet(rep, ("thrust_steps", "sample_trial.png", "identify"), True, OUTPUT_KINDS) as reports:
        (reports.staging / "sample_trial.png").write_bytes(b"new")
        reports.commit()
    assert file_tree(rep) == {"notes.txt": b"kept", "sample_trial.png": b"new"}


# --------------------------------------------------------------------------- a long command file


def _command_csv(path: Path, rows: int, step_s: float = 0.1) -> Path:
    """A command file of ``rows`` rows ``step_s`` apart: thrust and steering varying slowly (every row differs)."""
    import numpy as np

    t_s = np.arange(rows) * step_s
    thrust = 400.0 + 300.0 * np.sin(t_s / 200.0)
    angle = 0.2 * np.sin(t_s / 50.0)
    np.savetxt(path, np.column_stack([t_s, thrust, thrust, angle, angle]), fmt="%.4f", delimiter=",",
               header="t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad", comments="")
    return path


def test_a_long_command_file_shows_its_progress_on_stderr(tmp_path, capsys, monkeypatch) -> None:
    """Progress lines while reading the file, simulating and writing the bag, in simulated seconds of the whole
    (here one per look at the clock; a user sees one every PROGRESS_EVERY_S of wall time), the last at the end."""
    import boat_twin.cli.simulate as simulate
    import boat_twin.vessel.scenarios as scenarios

    commands = _command_csv(tmp_path / "long.csv", 1200, step_s=1.0)
    monkeypatch.setattr(simulate, "PROGRESS_EVERY_S", 0.0)
    monkeypatch.setattr(scenarios, "PROGRESS_ROWS", 500)
    assert main(["simulate", "--commands", str(commands), "--out", str(tmp_path / "o.mcap")]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[:2] == [f"simulate: reading {commands}: up to {t} s" for t in (499, 999)], lines[:3]
    simulated = [line for line in lines if line.startswith("simulate: simulated ")]
    writing = [line for line in lines if line.startswith(f"simulate: writing {tmp_path / 'o.mcap'}: ")]
    assert simulated and simulated[-1] == "simulate: simulated 1199 of 1199 s", lines
    assert len(writing) > 10 and writing[0].endswith(" 0 of 1199 s") and " 11" in writing[-1], writing[-3:]


def test_a_short_simulation_prints_no_progress(tmp_path, capsys) -> None:
    assert main(["simulate", "accel-stop", "--duration", "30", "--out", str(tmp_path / "o.mcap")]) == 0
    assert "simulate:" not in capsys.readouterr().err


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_a_long_command_file_within_a_second(tmp_path, signum, code) -> None:
    """An 8.3-hour command file (300,000 rows): signalled once its first progress line is out (5 s in), the
    run stops within a second (its one line: the new bag already dropped), the process ends (the interpreter's
    shutdown frees the trial: up to 0.9 s more on a loaded 2-core machine), the old bag kept, no scratch or lock
    left."""
    commands = _command_csv(tmp_path / "long.csv", 300_000)
    out = tmp_path / "o.mcap"
    out.write_bytes(b"\x89MCAP0\r\nthe old bag")
    run = popen_as_from_a_shell([BOAT_TWIN, "simulate", "--commands", str(commands), "--out", str(out), "--force"],
                                cwd=tmp_path, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        assert run.stderr is not None
        first = run.stderr.readline()
        assert first.startswith("simulate: "), first
        sent = time.monotonic()
        run.send_signal(signum)
        said = run.stderr.readline()
        stopped_s = time.monotonic() - sent
        rest = said + run.stderr.read()
        assert run.wait(timeout=10) == code, rest
    finally:
        run.kill()
        run.wait()
    assert stopped_s < 1.0, stopped_s
    assert said in ("boat-twin: interrupted\n", "boat-twin: terminated\n") and said == rest, rest
    assert out.read_bytes() == b"\x89MCAP0\r\nthe old bag"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.csv", "o.mcap"]


# --------------------------------------------------------------------------- a full disk


def _old_outputs(tmp_path: Path) -> dict[str, bytes]:
    """Yesterday's outputs of every verb under test, in ``tmp_path``: a bag, a bag directory, a .tlog, a plot,
    a report set beside a user's notes, a cable plot."""
    (tmp_path / "new.mcap").write_bytes(b"\x89MCAP0\r\nyesterday's bag")
    (tmp_path / "new").mkdir()
    (tmp_path / "new" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (tmp_path / "new.tlog").write_bytes(b"\x00" * 8 + b"\xfd yesterday's log")
    (tmp_path / "track.png").write_bytes(b"yesterday's track")
    (tmp_path / "rep").mkdir()
    for name in ("identify.json", "fits.png", "diagnosis_table.png", "notes.txt"):
        (tmp_path / "rep" / name).write_text(f"yesterday's {name}")
    (tmp_path / "plots").mkdir()
    (tmp_path / "plots" / "cable_depth.png").write_bytes(b"yesterday's plot")
    return file_tree(tmp_path)


WRITERS = [
    (["simulate", "accel-stop", "--duration", "20", "--out", "new.mcap", "--force"], "new.mcap"),
    (["simulate", "accel-stop", "--duration", "20", "--storage", "sqlite3", "--out", "new", "--force"], "new"),
    (["simulate", "accel-stop", "--duration", "20", "--plot", "track.png", "--force"], "track.png"),
    (["simulate", "accel-stop", "--duration", "5", "--tlog", "new.tlog", "--force"], "new.tlog"),
    (["convert", "{tlog}", "--out", "new.mcap", "--force"], "new.mcap"),
    (["identify", "--table", "dyda2021", "--out", "rep", "--force"], "rep/"),
    (["diagnose", "--table", "dyda2021", "--out", "rep", "--force"], "rep/"),
    (["cable", "depth", "--case", str(CABLE_CASE), "--plot", "--out", "plots", "--force"], "plots/cable_depth.png"),
]
"""Every kind of writer (bag in MCAP and sqlite3, .tlog, plot, report set, cable plot) and what it names."""


@pytest.mark.parametrize(("argv", "named"), WRITERS)
def test_a_full_disk_reported_only_when_the_data_reach_the_disk_is_one_line(tmp_path, capsys, monkeypatch,
                                                                            own_tlog, argv, named) -> None:
    """A file system that takes the writes into its cache and reports the full disk only when they are flushed
    (delayed allocation, a quota, NFS): every writer flushes each file to the disk (fsync) before renaming it into
    place, so the failure is exit 2 and one line naming the output by its own name, the old outputs untouched."""
    old = _old_outputs(tmp_path)
    monkeypatch.chdir(tmp_path)

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    assert main([a.replace("{tlog}", str(own_tlog)) for a in argv]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert f"error: {named}" in line and "No space left on device" in line and "partial" not in line, line
    assert file_tree(tmp_path) == old  # no scratch, no lock, nothing replaced


@pytest.mark.parametrize(("argv", "named", "limit"), [
    (["cable", "convergence", "--case", str(CABLE_CASE), "--plot", "--out", "OUT", "--force"],
     "OUT/cable_convergence.png", 20_000),
    (["identify", "--table", "dyda2021", "--out", "rep", "--force"], "rep/", 20_000),
    pytest.param(["identify", str(SAMPLE), "--out", "rep", "--force"], "rep/", 20_000, marks=pytest.mark.slow),
    pytest.param(["diagnose", str(SAMPLE), "--out", "rep", "--force"], "rep/", 20_000, marks=pytest.mark.slow),
    pytest.param(["follow", str(SAMPLE), "--out", "rep", "--force"], "rep/", 20_000, marks=pytest.mark.slow),
])
def test_a_file_size_limit_names_the_output_and_keeps_the_old_one(tmp_path, argv, named, limit) -> None:
    """RLIMIT_FSIZE (as a full disk) in a real ``boat-twin``, the cases of issue 41: exit 2, one line naming
    the file by its name in --out (never the scratch copy's), the old outputs byte-identical."""
    (tmp_path / "OUT").mkdir()
    (tmp_path / "OUT" / "cable_convergence.png").write_bytes(b"yesterday's plot")
    (tmp_path / "rep").mkdir()
    for name in ("identify.json", "diagnosis.json", "follow.json", "fits.png", "notes.txt"):
        (tmp_path / "rep" / name).write_text(f"yesterday's {name}")
    old = file_tree(tmp_path)
    run = run_with_file_size_limit([BOAT_TWIN, *argv], limit, cwd=tmp_path, capture_output=True, text=True,
                                   timeout=600)
    assert run.returncode == 2, (run.returncode, run.stderr)
    line = one_error_line(run.stderr)
    assert f"error: {named}" in line and "cannot write it (File too large)" in line and "partial" not in line, line
    assert file_tree(tmp_path) == old


def test_a_users_unreadable_file_beside_the_reports_does_not_stop_the_flush(tmp_path, monkeypatch) -> None:
    """The flush before the swap opens every file of the new set, the user's other files of DIR (hard links)
    included: one this user may not read (mode 0200; root reads anything, so refused here by a stand-in for
    open) is skipped, not a crash; it was never written by this run."""
    from boat_twin.files import ReportSet

    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "secret").write_text("write-only")
    real_open = os.open

    def refusing_open(path: object, flags: int, *args: object, **kwargs: object) -> int:
        if str(path).endswith("secret") and flags == os.O_RDONLY and not kwargs:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, flags, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "open", refusing_open)
    with ReportSet(rep, ("identify.json",), False) as reports:
        (reports.staging / "identify.json").write_text("{}")
        reports.commit()
    assert file_tree(rep) == {"identify.json": b"{}", "secret": b"write-only"}
