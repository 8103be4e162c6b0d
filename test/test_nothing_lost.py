"""Nothing lost, round three (issue 41): --force replaces only an output of the same kind inside a report set,
a full disk or a file-size limit on every writer, a long command file (progress, linear cost, Ctrl-C)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from boat_twin.cli import main

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "bags" / "thrust_steps_sample"
CABLE_CASE = ROOT / "config" / "cable" / "default.yaml"
BOAT_TWIN = str(Path(sys.executable).parent / "boat-twin") if (Path(sys.executable).parent / "boat-twin").exists() \
    else (shutil.which("boat-twin") or "boat-twin")
"""The console script, as a user runs it."""


def _tree(path: Path) -> dict[str, bytes]:
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert "Traceback" not in err and lines, err
    assert sum("error:" in line for line in lines) == 1 and "error:" in lines[-1], err
    return lines[-1]


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
    line = _one_error_line(capsys.readouterr().err)
    assert f"{rep / mine}: is a directory" in line and "same kind" in line, line
    assert _tree(rep) == {f"{mine}/notes.txt": b"the user's own"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no scratch, no lock left


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
    assert _tree(rep) == {"notes.txt": b"kept", "sample_trial.png": b"new"}
