"""A verb's report set (every file of --out DIR) appears whole or not at all; inputs inside --out are refused;
a full disk or a file-size limit is one line on every writer. The signal cases signal a real ``boat-twin``."""

from __future__ import annotations

import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from processes import BOAT_TWIN, file_tree, one_error_line, popen_as_from_a_shell, run_with_file_size_limit

from boat_twin.cli import main
from boat_twin.cli.identify import TABLE_OUTPUTS, TRIAL_OUTPUTS

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "bags" / "thrust_steps_sample"


@pytest.fixture(scope="module")
def old_reports(tmp_path_factory) -> Path:
    """Yesterday's ``identify SAMPLE --out rep`` beside a user's own notes."""
    rep = tmp_path_factory.mktemp("old") / "rep"
    assert main(["identify", str(SAMPLE), "--out", str(rep)]) == 0
    (rep / "notes.txt").write_text("my notes on this trial")
    return rep


def _copy(old: Path, tmp_path: Path) -> Path:
    rep = tmp_path / "rep"
    shutil.copytree(old, rep)
    return rep


# --------------------------------------------------------------------------- a report set is one output


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130),  # SIGTERM and SIGKILL in CI (an identify each)
                                             pytest.param(signal.SIGTERM, 143, marks=pytest.mark.slow),
                                             pytest.param(signal.SIGKILL, -9, marks=pytest.mark.slow)])
def test_a_signal_while_identify_writes_its_reports_keeps_the_old_set_whole(tmp_path, old_reports, capsys, signum,
                                                                             code) -> None:
    """Signalled once the new set is being written (its first files exist): the old set stays whole, never a
    mix; after SIGKILL the next run removes the scratch and names it."""
    rep = _copy(old_reports, tmp_path)
    old = file_tree(rep)
    inodes = {p.name: p.stat().st_ino for p in rep.iterdir()}
    run = popen_as_from_a_shell([BOAT_TWIN, "identify", str(SAMPLE), "--out", str(rep), "--force"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    staging = tmp_path / f".rep.partial-{run.pid}" / "rep"
    deadline = time.monotonic() + 120
    while run.poll() is None and time.monotonic() < deadline:
        now = {p.name: p.stat().st_ino for p in rep.iterdir() if not p.name.startswith(".")}
        if now != inodes or (staging / "twin.yaml").exists():  # the first report of the new set is written
            break
        time.sleep(0.005)
    assert run.poll() is None, "the run ended before it was signalled"
    time.sleep(0.2)  # further reports written
    run.send_signal(signum)
    status = run.wait(timeout=60)
    err = run.stderr.read() if run.stderr else ""
    assert status == code and "Traceback" not in err, err
    assert file_tree(rep) == old
    if signum == signal.SIGKILL:
        assert main(["identify", "--table", "dyda2021", "--out", str(rep), "--force"]) == 0
        assert f"removed {tmp_path / f'.rep.partial-{run.pid}'}" in capsys.readouterr().err
        assert (rep / "notes.txt").read_text() == "my notes on this trial"
        assert all((rep / name).is_file() for name in TABLE_OUTPUTS)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_a_report_set_moved_aside_by_a_killed_run_is_restored_whole(tmp_path, old_reports, capsys) -> None:
    """Killed between its two renames: the old set is aside as .rep.old-PID and rep is missing; the next run
    restores it (and refuses to overwrite it without --force)."""
    old = file_tree(old_reports)
    shutil.copytree(old_reports, tmp_path / ".rep.old-999999")
    (tmp_path / ".rep.partial-999999").mkdir()
    assert main(["identify", "--table", "dyda2021", "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err
    assert "restored" in err and "removed" in err and "exists; use --force" in err.splitlines()[-1], err
    assert file_tree(tmp_path / "rep") == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_a_replaced_set_keeps_other_files_and_drops_the_verbs_stale_ones(tmp_path, old_reports) -> None:
    rep = _copy(old_reports, tmp_path)
    assert main(["identify", str(SAMPLE), "--out", str(rep), "--force"]) == 0
    assert (rep / "notes.txt").read_text() == "my notes on this trial"
    assert sorted(p.name for p in rep.iterdir()) == sorted([*TRIAL_OUTPUTS, "notes.txt"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_sigterm_once_the_reports_are_complete_exits_143_or_0(tmp_path) -> None:
    """SIGTERM after the set is in place ends the process with 143 or 0, never killed by the signal."""
    rep = tmp_path / "rep"
    run = subprocess.Popen([BOAT_TWIN, "identify", "--table", "dyda2021", "--out", str(rep)],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not all((rep / name).exists() for name in TABLE_OUTPUTS) and time.monotonic() < deadline:
        time.sleep(0.001)
    deadline = time.monotonic() + 60
    while run.poll() is None and time.monotonic() < deadline:
        run.send_signal(signal.SIGTERM)
        time.sleep(0.002)
    status = run.wait(timeout=30)
    assert status in (0, 143), (status, run.stderr.read() if run.stderr else "")
    assert all((rep / name).is_file() for name in TABLE_OUTPUTS)


# --------------------------------------------------------------------------- inputs inside --out


@pytest.mark.parametrize(("argv", "inside"), [
    (["identify", "{trial}", "--boat", "{rep}/twin.yaml"], "twin.yaml"),
    (["identify", "{trial}.csv", "--columns", "{rep}/model.yaml"], "model.yaml"),
    (["identify", "{tlog}", "--calibration", "{rep}/model.yaml"], "model.yaml"),
    (["identify", "{rep}/trial.mcap"], "trial.mcap"),
    (["diagnose", "{trial}", "--model", "{rep}/twin.yaml"], "twin.yaml"),
    (["diagnose", "{trial}", "--config", "{rep}/twin.yaml"], "twin.yaml"),
    (["demo", "--sample", "{rep}/thrust_steps"], "thrust_steps"),
])
def test_an_input_inside_out_is_refused_before_any_work(tmp_path, old_reports, own_tlog, capsys, argv,
                                                       inside) -> None:
    rep = _copy(old_reports, tmp_path)
    shutil.copytree(SAMPLE, rep / "thrust_steps")
    (rep / "trial.mcap").write_bytes(b"")
    before = file_tree(rep)
    names = {"trial": str(SAMPLE), "rep": str(rep), "tlog": str(own_tlog)}
    assert main([a.format(**names) for a in argv] + ["--out", str(rep), "--force"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "is also an input of this command" in line and inside in line, line
    assert file_tree(rep) == before


@pytest.mark.parametrize("mine", ["sample_trial.png", "identify/identify.json", "thrust_steps"])
def test_demo_without_force_never_replaces_a_users_file(tmp_path, capsys, mine) -> None:
    rep = tmp_path / "rep"
    (rep / mine).parent.mkdir(parents=True, exist_ok=True)
    (rep / mine).write_text("the user's own")
    assert main(["demo", "--sample", str(SAMPLE), "--out", str(rep)]) == 2
    assert "use --force" in one_error_line(capsys.readouterr().err)
    assert (rep / mine).read_text() == "the user's own"


# --------------------------------------------------------------------------- full disk, file-size limit


@pytest.mark.parametrize(("argv", "limit"), [
    (["simulate", "accel-stop", "--duration", "60", "--out", "new.mcap"], 40_000),
    (["simulate", "accel-stop", "--duration", "60", "--storage", "sqlite3", "--out", "new"], 40_000),
    (["simulate", "accel-stop", "--duration", "60", "--tlog", "new.tlog"], 20_000),
    (["convert", "{tlog}", "--out", "new.mcap"], 2_000),
    (["identify", "--table", "dyda2021", "--out", "rep", "--force"], 20_000),
    (["diagnose", "--table", "dyda2021", "--out", "rep", "--force"], 20_000),
    (["cable", "depth", "--case", str(ROOT / "config" / "cable" / "default.yaml"), "--plot", "--out", "plots"], 20_000),
])
def test_a_file_size_limit_is_one_line_and_leaves_nothing(tmp_path, old_reports, own_tlog, argv, limit) -> None:
    """RLIMIT_FSIZE (as a full disk): exit 2, one line naming what could not be written, the old reports kept,
    no scratch or lock left behind."""
    rep = _copy(old_reports, tmp_path)
    old = file_tree(rep)
    argv = [a.replace("{tlog}", str(own_tlog)) for a in argv]
    run = run_with_file_size_limit([BOAT_TWIN, *argv], limit, cwd=tmp_path, capture_output=True, text=True,
                                   timeout=120)
    assert run.returncode == 2, (run.returncode, run.stderr)
    line = one_error_line(run.stderr)
    assert "cannot write" in line and ("File too large" in line or "disk" in line), line
    assert file_tree(rep) == old
    assert file_tree(tmp_path) == {f"rep/{name}": data for name, data in old.items()}  # no scratch, lock or partial
