"""Fleets: identify / diagnose / follow --each over many trials (one corrupt), resume after a killed run, ensembles
whose rows do not depend on the chunking or the workers, and a cluster started by hand on loopback (docs/fleet.md).

The identify batch runs on independently integrated trials of another boat (test_other_boat's Otter, RK4 written
apart from the twin's kernel), whose true mass each row must find."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from processes import popen_as_from_a_shell
from test_other_boat import OTTER, integrator_bag

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.diagnose import hidden
from boat_twin.fleet import engine
from boat_twin.fleet.batch import ROW_FILE, run_batch
from boat_twin.fleet.ensemble import EnsembleSpec, run_ensemble
from boat_twin.fleet.jobs import RUN_COLUMNS
from boat_twin.fleet.trials import expand_trials, name_trials, trial_bytes

OTTER_MASS_KG = 1.10 * OTTER["mass_kg"]
"""The independent Otter's surge mass (test_other_boat.integrate)."""


def run_cli(*argv: str) -> tuple[int, str, str]:
    """``boat-twin ARGV`` in this process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def otters(tmp_path_factory) -> Path:
    """Three independent Otter trials in a folder per boat, and a corrupt file among them."""
    root = tmp_path_factory.mktemp("fleet")
    for seed, boat in ((0, "otter-a"), (1, "otter-a"), (2, "otter-b")):
        (root / boat).mkdir(exist_ok=True)
        integrator_bag(root / boat / f"day{seed}.mcap", seed)
    (root / "otter-b" / "broken.mcap").write_bytes(b"\x89MCAP0\r\n truncated by a dying logger")
    return root


def summary(out: Path) -> tuple[list[dict], list[dict]]:
    """(summary.json rows, summary.csv rows)."""
    with (out / "summary.csv").open() as fh:
        return json.loads((out / "summary.json").read_text()), list(csv.DictReader(fh))


def test_identify_each_reports_every_trial_and_names_the_corrupt_one(otters, tmp_path) -> None:
    out = tmp_path / "out"
    code, _, stderr = run_cli("identify", otters, "--each", "--out", out, "--scheduler", "sync")
    assert code == 2  # a trial failed: said in one last line, the others complete
    assert stderr.splitlines()[-1].startswith("boat-twin identify: error: 1 of 4 trial(s) failed")
    rows, table = summary(out)
    assert [r["trial"] for r in rows] == ["day0", "day1", "broken", "day2"]  # the order found, per folder
    assert [r["trial"] for r in table] == [r["trial"] for r in rows]
    broken = rows[2]
    assert broken["status"] == "error" and "broken.mcap" in broken["error"] and broken["boat"] == "otter-b"
    assert table[2]["status"] == "error" and table[2]["error"] == broken["error"]
    for row in rows[:2] + rows[3:]:
        assert row["status"] == "ok" and row["error"] is None, row
        # within 25 %: the identification's accuracy is test_other_boat's and test_ident_output_error's; this is
        # the batch's check (the row is the single verb's result)
        assert row["mass_kg"] == pytest.approx(OTTER_MASS_KG, rel=0.25)
        assert row["mass_ci95_low_kg"] < row["mass_kg"] < row["mass_ci95_high_kg"]
        assert row["duration_s"] == pytest.approx(199.9, abs=0.2)
        report = out / row["trial"]
        assert {"identify.json", "model.yaml", "twin.yaml", ROW_FILE} <= {p.name for p in report.iterdir()}
        single = json.loads((report / "identify.json").read_text())
        assert single["model"]["effective_mass_kg"] == row["mass_kg"]
    assert [r["boat"] for r in rows] == ["otter-a", "otter-a", "otter-b", "otter-b"]
    assert not (out / "broken").exists() or not (out / "broken" / ROW_FILE).exists()


def test_a_batch_row_is_what_the_single_trial_verb_reports(otters, tmp_path) -> None:
    trial = otters / "otter-a" / "day1.mcap"
    code, stdout, _ = run_cli("identify", trial, "--json")
    assert code == 0
    alone = json.loads(stdout)
    code, stdout, _ = run_cli("identify", trial, "--each", "--out", tmp_path / "b", "--scheduler", "sync", "--json")
    assert code == 0
    (row,) = json.loads(stdout)
    assert row["mass_kg"] == alone["model"]["effective_mass_kg"]
    assert row["model"] == alone["output_error"]["selected"]["model"]
    assert row["misfit_speed_rmse_mps"] == alone["resimulation"]["speed_rmse_mps"]


def test_diagnose_each_names_a_hidden_current_and_keeps_going_past_a_corrupt_file(tmp_path) -> None:
    trials = tmp_path / "trials"
    trials.mkdir()
    current, _ = hidden.draw_effect("water_current", TwinConfig(), np.random.default_rng(21))
    hidden.write_trial(trials / "current.mcap", current, "zigzag", 21, 200.0)
    (trials / "empty.mcap").write_bytes(b"")
    out = tmp_path / "out"
    code, _, _ = run_cli("diagnose", f"{trials}/*.mcap", "--each", "--out", out, "--scheduler", "sync")
    assert code == 2
    rows, table = summary(out)
    by_name = {r["trial"]: r for r in rows}
    assert by_name["current"]["status"] == "ok" and by_name["current"]["verdict"] == ["water_current"]
    assert by_name["current"]["unexplained"] is False and by_name["current"]["misfit_x_noise"] > 1.0
    assert {r["trial"]: r["verdict"] for r in table}["current"] == "water_current"
    assert by_name["empty"]["status"] == "error" and "empty.mcap" in by_name["empty"]["error"]
    assert (out / "current" / "diagnosis.json").is_file() and (out / "current" / "extended_model.yaml").is_file()


def test_follow_each_rows_are_what_follow_reports_alone(tmp_path) -> None:
    trial = hidden.write_trial(tmp_path / "random.mcap", TwinConfig(), "random", 3, 120.0)
    (tmp_path / "empty.mcap").write_bytes(b"")
    code, stdout, _ = run_cli("follow", trial, "--json")
    assert code == 0
    final = json.loads(stdout)["final"]
    code, _, _ = run_cli("follow", trial, tmp_path / "empty.mcap", "--each", "--out", tmp_path / "out",
                         "--scheduler", "sync")
    assert code == 2
    rows, _ = summary(tmp_path / "out")
    assert rows[0]["status"] == "ok" and rows[1]["status"] == "error" and "empty.mcap" in rows[1]["error"]
    assert rows[0]["mass_kg"] == final["mass_kg"] and rows[0]["causes"] == final["causes"]
    assert rows[0]["misfit_speed_innovation_ratio"] == final["speed_innovation_ratio"]
    assert rows[0]["misfit_yaw_rate_innovation_ratio"] == final["yaw_rate_innovation_ratio"]
    assert (tmp_path / "out" / "random" / "twin.yaml").is_file()


def test_resume_after_a_killed_run_skips_complete_reports_and_force_redoes_them(otters, tmp_path) -> None:
    out = tmp_path / "out"
    good = [otters / "otter-a" / "day0.mcap", otters / "otter-b" / "day2.mcap"]
    argv = [sys.executable, "-m", "boat_twin.cli", "identify", *map(str, good), "--each", "--out", str(out),
            "--scheduler", "sync"]
    run = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    first = out / "day0" / ROW_FILE
    deadline = time.monotonic() + 60.0
    while not first.exists() and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    run.send_signal(signal.SIGKILL)  # killed mid-batch, as a dying machine would
    run.wait()
    assert first.exists()
    killed_row = json.loads(first.read_text())
    assert killed_row["worker"].endswith(f":{run.pid}")
    code, stdout, _ = run_cli("identify", *good, "--each", "--out", out, "--scheduler", "sync")
    assert code == 0
    assert "2 ok (1 complete from an earlier run)" in stdout or "2 ok (2 complete from an earlier run)" in stdout
    rows, _ = summary(out)
    assert [r["status"] for r in rows] == ["ok"] * 2 and rows[0] == killed_row
    code, stdout, _ = run_cli("identify", *good, "--each", "--out", out, "--scheduler", "sync", "--force")
    assert code == 0 and "(0 complete from an earlier run)" in stdout
    redone = json.loads(first.read_text())
    assert redone["worker"] == f"{socket.gethostname()}:{os.getpid()}"
    assert 10.0 < redone["peak_rss_mb"] < 1e5  # this process's peak resident memory, MB (not kB, not bytes)


BOAT_TWIN = str(Path(sys.executable).parent / "boat-twin")
"""The console script, as a user runs it."""


def _inodes(report: Path) -> dict[str, int]:
    return {p.name: p.stat().st_ino for p in report.iterdir()}


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_during_a_batch_leaves_each_trial_report_old_or_new_whole(accel_stop_bag, tmp_path, signum,
                                                                            code) -> None:
    """``follow --each --force`` over a complete batch, signalled once a trial's new report is being written:
    every trial directory is the old report or a whole new one (never a mix of files), the two summaries agree,
    nothing is left beside them, and the next run resumes every trial as complete."""
    trials = tmp_path / "trials"
    trials.mkdir()
    for name in "abc":
        shutil.copy(accel_stop_bag, trials / f"{name}.mcap")
    out = tmp_path / "out"
    assert run_cli("follow", trials, "--each", "--out", out, "--scheduler", "sync")[0] == 0
    old = {name: _inodes(out / name) for name in "abc"}
    run = popen_as_from_a_shell([BOAT_TWIN, "follow", str(trials), "--each", "--out", str(out), "--scheduler",
                                 "sync", "--force"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    staging = out / f".a.partial-{run.pid}" / "a"
    deadline = time.monotonic() + 120.0
    while run.poll() is None and time.monotonic() < deadline:  # the first file of a's new report is written
        if _inodes(out / "a") != old["a"] or (staging.is_dir() and any(staging.iterdir())):
            break
        time.sleep(0.002)
    assert run.poll() is None, "the batch ended before it was signalled"
    time.sleep(0.1)  # further files of the report written
    run.send_signal(signum)
    status = run.wait(timeout=60)
    err = run.stderr.read() if run.stderr else ""
    assert status == code and "Traceback" not in err, err
    kept = 0
    for name in "abc":
        now = _inodes(out / name)
        assert set(now) == set(old[name]), name
        same = [file for file in now if now[file] == old[name][file]]
        assert same in ([], list(now)), f"{name}: a mix of old {same} and new files"
        kept += bool(same)
        if not same:  # a whole new report
            assert json.loads((out / name / ROW_FILE).read_text())["worker"].endswith(f":{run.pid}")
    assert kept >= 2  # signalled during the first trial's report: the last two not yet started
    assert sorted(p.name for p in out.iterdir()) == ["a", "b", "c", "summary.csv", "summary.json"]
    rows, table = summary(out)
    assert [r["trial"] for r in rows] == [r["trial"] for r in table] and \
        [r["worker"] for r in rows] == [r["worker"] for r in table]
    code, stdout, _ = run_cli("follow", trials, "--each", "--out", out, "--scheduler", "sync")
    assert code == 0 and "(3 complete from an earlier run)" in stdout, stdout


def test_a_report_moved_aside_by_a_batch_killed_mid_swap_is_restored_before_the_resume(accel_stop_bag,
                                                                                      tmp_path) -> None:
    """Killed between the two renames of a trial's swap (its old report aside as .a.old-PID, a missing) and
    while writing another (.b.partial-PID): the next run restores a, removes the scratch, names both and resumes
    both trials as complete instead of redoing a."""
    trials = tmp_path / "trials"
    trials.mkdir()
    for name in "ab":
        shutil.copy(accel_stop_bag, trials / f"{name}.mcap")
    out = tmp_path / "out"
    assert run_cli("follow", trials, "--each", "--out", out, "--scheduler", "sync")[0] == 0
    row = (out / "a" / ROW_FILE).read_bytes()
    os.rename(out / "a", out / ".a.old-999999")
    (out / ".b.partial-999999").mkdir()
    code, stdout, stderr = run_cli("follow", trials, "--each", "--out", out, "--scheduler", "sync")
    assert code == 0 and "(2 complete from an earlier run)" in stdout, (stdout, stderr)
    assert f"restored {out / 'a'}" in stderr and f"removed {out / '.b.partial-999999'}" in stderr, stderr
    assert (out / "a" / ROW_FILE).read_bytes() == row
    assert sorted(p.name for p in out.iterdir()) == ["a", "b", "summary.csv", "summary.json"]


def test_trials_are_named_uniquely_and_bags_are_not_entered(tmp_path) -> None:
    for boat in ("a", "b"):
        (tmp_path / boat / "bag").mkdir(parents=True)
        (tmp_path / boat / "bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
        (tmp_path / boat / "bag" / "bag_0.mcap").write_bytes(b"")
        (tmp_path / boat / "run.tlog").write_bytes(b"")
    (tmp_path / "notes.txt").write_text("not a trial")
    tasks = name_trials(expand_trials([tmp_path]))
    assert [(t.name, t.boat) for t in tasks] == [("a__bag", "a"), ("a__run", "a"), ("b__bag", "b"), ("b__run", "b")]
    code, _, stderr = run_cli("diagnose", tmp_path / "nothing-*.mcap", "--each", "--out", tmp_path / "o")
    assert code == 2 and stderr.strip().endswith("no trial matches this pattern")
    code, _, stderr = run_cli("diagnose", tmp_path / "a" / "run.tlog", tmp_path / "b" / "run.tlog")
    assert code == 2 and "--each" in stderr


def test_without_dask_the_default_runs_here_with_one_line_and_an_address_is_refused(otters, tmp_path,
                                                                                     monkeypatch) -> None:
    monkeypatch.setattr(engine, "dask_installed", lambda: False)
    code, _, stderr = run_cli("identify", otters / "otter-a" / "day0.mcap", "--each", "--out", tmp_path / "o")
    assert code == 0
    assert stderr.splitlines()[0] == (f"boat-twin: {engine.MISSING}: running the tasks one after another in "
                                      "this process")
    code, _, stderr = run_cli("identify", otters / "otter-a" / "day0.mcap", "--each", "--out", tmp_path / "p",
                              "--scheduler", "tcp://127.0.0.1:1")
    assert code == 2 and stderr.strip() == f"boat-twin identify: error: --scheduler tcp://127.0.0.1:1: {engine.MISSING}"


def ensemble_rows(out: Path) -> list[list[str]]:
    """Every boat's row of the ensemble in ``out``, chunk files concatenated."""
    rows = []
    for path in sorted(out.glob("chunk-*.csv")):
        with path.open() as fh:
            rows += list(csv.reader(fh))[1:]
    return rows


SPEC = EnsembleSpec("zigzag-20-20", 7, seed=5, duration_s=75.0, chunk_boats=3)
"""A small zigzag ensemble: 7 drawn boats, chunks of 3 (the last of 1)."""


def test_ensemble_rows_do_not_depend_on_the_chunking_or_the_workers(tmp_path) -> None:
    pytest.importorskip("distributed")
    serial = run_ensemble(SPEC, tmp_path / "serial")
    assert [r["boats"] for r in serial] == [3, 3, 1] and all(r["status"] == "ok" for r in serial)
    reference = ensemble_rows(tmp_path / "serial")
    assert [int(r[0]) for r in reference] == list(range(7))
    features = np.array([[float(v) for v in r[14:]] for r in reference])
    assert features.shape == (7, 42) and np.isfinite(features).all(axis=1).sum() >= 5
    for workers, chunk in ((1, 7), (2, 2)):
        out = tmp_path / f"w{workers}"
        with engine.open_client(engine.LOCAL, workers, quiet=True) as client:
            rows = run_ensemble(EnsembleSpec(**{**SPEC.__dict__, "chunk_boats": chunk}), out, client)
            cluster_workers = len(client.scheduler_info()["workers"])
        # Which worker runs which chunk is the scheduler's choice (on a loaded machine one worker may take them
        # all before the other starts): the rows must not depend on it.
        assert cluster_workers == workers and 1 <= len({r["worker"] for r in rows}) <= workers, rows
        assert ensemble_rows(out) == reference  # every float written to round-trip: bit-identical
    other = run_ensemble(EnsembleSpec(**{**SPEC.__dict__, "seed": 6}), tmp_path / "other")
    assert other and ensemble_rows(tmp_path / "other") != reference


def test_an_ensemble_resumes_only_with_the_same_settings(tmp_path) -> None:
    small = EnsembleSpec("turning-circle", 2, seed=1, duration_s=30.0, chunk_boats=1)
    run_ensemble(small, tmp_path)
    again = run_ensemble(small, tmp_path)
    assert [r["worker"] for r in again] == ["an earlier run"] * 2
    code, _, stderr = run_cli("simulate", "turning-circle", "--duration", "30", "--ensemble", "2", "--seed", "2",
                              "--out", tmp_path, "--scheduler", "sync")
    assert code == 2 and "holds an ensemble with other settings" in stderr


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@pytest.mark.slow  # 30 s on the shared 2-core machine: three processes start and import the package
def test_a_scheduler_and_two_workers_started_by_hand_give_the_serial_results(otters, tmp_path) -> None:
    """As on two machines: `dask scheduler` and two `dask worker` processes, here on loopback."""
    pytest.importorskip("distributed")
    address = f"tcp://127.0.0.1:{free_port()}"
    started = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                 "--port", address.rsplit(":", 1)[1], "--no-dashboard"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        started += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads",
                                      "1", "--no-dashboard", "--name", f"w{i}"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    for i in range(2)]
        from distributed import Client

        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        trials = [otters / "otter-a" / "day0.mcap", otters / "otter-b" / "day2.mcap"]
        code, stdout, _ = run_cli("identify", *trials, "--each", "--out", tmp_path / "cluster", "--scheduler",
                                  address, "--json")
        assert code == 0
        cluster = json.loads(stdout)
        code, stdout, _ = run_cli("identify", *trials, "--each", "--out", tmp_path / "serial", "--scheduler", "sync",
                                  "--json")
        assert code == 0
        serial = json.loads(stdout)
        assert [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in cluster] == \
               [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in serial]
        assert all(not r["worker"].endswith(f":{os.getpid()}") for r in cluster)  # ran on the workers
    finally:
        for process in reversed(started):
            process.terminate()
        for process in started:
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()


class StartTimeJob:
    """A job that only notes when its trial started (the order a cluster runs the trials in)."""

    verb, columns, outputs, curves = "probe", ("started_ns",), (), ()

    def __call__(self, path: Path, out: Path, named: Path | None = None) -> dict:
        return {"started_ns": time.monotonic_ns()}


def test_a_cluster_starts_the_largest_recordings_first(tmp_path) -> None:
    pytest.importorskip("distributed")
    sizes = {"small": 100, "large": 3000, "medium": 1000}
    for name, size in sizes.items():
        (tmp_path / f"{name}.mcap").write_bytes(b"\0" * size)
    (tmp_path / "bag").mkdir()
    metadata = "rosbag2_bagfile_information: {}\n"
    (tmp_path / "bag" / "metadata.yaml").write_text(metadata)
    (tmp_path / "bag" / "bag_0.mcap").write_bytes(b"\0" * 2000)
    tasks = name_trials(expand_trials([tmp_path]))
    assert {t.name: trial_bytes(t) for t in tasks} == {**sizes, "bag": 2000 + len(metadata)}
    with engine.open_client(engine.LOCAL, 1, quiet=True) as client:
        rows = run_batch(StartTimeJob(), tasks, tmp_path / "out", client).rows
    assert [r["trial"] for r in rows] == [t.name for t in tasks]  # the summary keeps the order given
    started = sorted(rows, key=lambda r: r["started_ns"])
    assert [r["trial"] for r in started] == ["large", "bag", "medium", "small"]


def test_a_trial_that_failed_under_force_is_tried_again_though_its_older_report_stays(otters, tmp_path) -> None:
    trial, out = tmp_path / "day0.mcap", tmp_path / "out"
    shutil.copyfile(otters / "otter-a" / "day0.mcap", trial)
    assert run_cli("identify", trial, "--each", "--out", out, "--scheduler", "sync")[0] == 0
    older = (out / "day0" / ROW_FILE).read_text()
    trial.write_bytes(b"\x89MCAP0\r\n cut short")
    assert run_cli("identify", trial, "--each", "--out", out, "--scheduler", "sync", "--force")[0] == 2
    assert (out / "day0" / ROW_FILE).read_text() == older  # the failure lost nothing
    code, stdout, _ = run_cli("identify", trial, "--each", "--out", out, "--scheduler", "sync")
    assert code == 2 and "(0 complete from an earlier run)" in stdout  # tried again, not taken from the old report
    assert summary(out)[0][0]["status"] == "error"
