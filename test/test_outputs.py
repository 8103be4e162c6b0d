"""Nothing lost: --force replaces a bag or a file, never anything else, and only once the new output exists."""

from __future__ import annotations

import json
import os
import socket
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.files import prepare_output, replace_output, to_json
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.messages import header, twist_stamped
from boat_twin.twin import run_sea_trial, trial_messages
from boat_twin.vessel import make_scenario


def _tree(path) -> dict[str, bytes]:
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


@pytest.fixture()
def precious(tmp_path):
    """A directory of a user's unrelated files, with a sub-directory."""
    home = tmp_path / "work"
    (home / "notes").mkdir(parents=True)
    (home / "thesis.tex").write_text("months of work")
    (home / "notes" / "trial.csv").write_text("t,v\n0,1\n")
    return home


@pytest.mark.parametrize("out", [".", "", "notes"])
def test_force_never_deletes_what_is_not_a_bag(precious, monkeypatch, capsys, out) -> None:
    monkeypatch.chdir(precious)
    before = _tree(precious)
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", out, "--force"]) == 2
    assert _tree(precious) == before
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refusing" in err[0]


def test_force_replaces_a_bag_and_only_after_the_new_one_is_written(tmp_path) -> None:
    bag = tmp_path / "trial"
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 0
    old = _tree(bag)
    assert main(["simulate", "accel-stop", "--duration", "3", "--no-noise", "--out", str(bag), "--force"]) == 0
    assert _tree(bag) != old and (bag / "metadata.yaml").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trial"]  # no temporary left behind


def test_a_failure_after_the_check_keeps_the_old_bag(tmp_path) -> None:
    bag = tmp_path / "trial"
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 0
    old = _tree(bag)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        code = main(["simulate", "--mavlink", f"udpin:127.0.0.1:{port}", "--duration", "1", "--out", str(bag),
                     "--force"])
    assert code == 2 and _tree(bag) == old


def test_replace_output_swaps_in_the_new_and_removes_the_old(tmp_path) -> None:
    target, new = tmp_path / "out.mcap", tmp_path / ".out.mcap.tmp"
    target.write_bytes(b"old")
    new.write_bytes(b"new")
    prepare_output(target, force=True)
    replace_output(new, target)
    assert target.read_bytes() == b"new" and sorted(os.listdir(tmp_path)) == ["out.mcap"]


def test_prepare_output_refuses_the_current_directory_and_its_parents(tmp_path, monkeypatch) -> None:
    inner = tmp_path / "a" / "b"
    inner.mkdir(parents=True)
    monkeypatch.chdir(inner)
    for path in (".", "..", str(tmp_path)):
        with pytest.raises(InputError, match="refusing"):
            prepare_output(Path(path), force=True)


def test_identify_reports_are_not_overwritten_without_force(tmp_path, capsys) -> None:
    out = tmp_path / "report"
    assert main(["identify", "--table", "dyda2021", "--out", str(out)]) == 0
    before = _tree(out)
    (out / "report.txt").write_text("my notes")
    assert main(["identify", "--table", "dyda2021", "--out", str(out)]) == 2
    assert "identify.json exists; use --force" in capsys.readouterr().err
    assert (out / "report.txt").read_text() == "my notes"
    assert main(["identify", "--table", "dyda2021", "--out", str(out), "--force"]) == 0
    assert _tree(out) == before


def test_an_input_file_is_never_an_output_directory(tmp_path, capsys) -> None:
    log = tmp_path / "trial.tlog"
    log.write_bytes(b"raw log")
    assert main(["identify", "--table", "dyda2021", "--out", str(log), "--force"]) == 2
    assert log.read_bytes() == b"raw log" and "must be a directory" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "message"), [
    (["simulate", "accel-stop", "--duration", "1e7", "--out", "x"], "up to 604800 (7 days)"),
    (["cable", "depth", "--case", str(Path(__file__).resolve().parents[1] / "config" / "cable" / "default.yaml"),
      "--segment-length", "1e-6", "--json"], "more than 200000 links"),
])
def test_work_beyond_memory_is_refused_before_it_starts(tmp_path, monkeypatch, capsys, argv, message) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_a_gnss_stamp_far_ahead_is_a_clock_error_not_a_huge_grid(tmp_path) -> None:


    trial = run_sea_trial(TwinConfig(), make_scenario("accel-stop", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=60.0), seed=0)
    messages = list(trial_messages(trial, truth=False))
    topic, stamp, msg = next(m for m in reversed(messages) if m[0] == "gnss/vel")
    glitch = (topic, stamp, replace(msg, header=header(stamp + 3 * 10**15, msg.header.frame_id)))
    write_bag(tmp_path / "glitch", sorted([m for m in messages if m[2] is not msg] + [glitch], key=lambda m: m[1]))
    with pytest.raises(InputError, match="gnss_vel stamps jump by 3e\\+06 s"):
        read_trial(tmp_path / "glitch")


def test_stamps_running_backwards_are_dropped_and_reported_not_sorted_into_the_data(tmp_path) -> None:
    trial = run_sea_trial(TwinConfig(), make_scenario("accel-stop", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=60.0), seed=0)
    messages = []
    for topic, stamp, msg in trial_messages(trial, truth=False):
        if topic == "gnss/vel" and 30e9 <= stamp < 32e9:  # a clock fault: 2 s of fixes stamped 20 s earlier
            msg = replace(msg, header=header(stamp - 20 * 10**9, msg.header.frame_id))
        messages.append((topic, stamp, msg))
    write_bag(tmp_path / "faulty", messages)
    read = read_trial(tmp_path / "faulty")
    assert read.metadata.backward_stamps["gnss_vel"][0] == 20
    assert "gnss_vel: 20 stamp(s) ran backwards" in read.metadata.summary_line()
    assert np.all(np.diff(read.t_s) > 0)


def test_an_input_is_never_replaced_by_the_output(tmp_path, capsys) -> None:
    bag = tmp_path / "trial"
    assert main(["simulate", "accel-stop", "--duration", "2", "--no-noise", "--out", str(bag)]) == 0
    before = _tree(bag)
    assert main(["simulate", "--commands", str(bag), "--out", str(bag), "--force"]) == 2
    assert "also an input" in capsys.readouterr().err and _tree(bag) == before
    tlog = tmp_path / "t.tlog"
    tlog.write_bytes(b"raw telemetry")
    assert main(["simulate", "accel-stop", "--duration", "2", "--tlog", str(tlog), "--out", str(tlog), "--force"]) == 2
    assert tlog.read_bytes() == b"raw telemetry"


def _first_chunk_records(data: bytes) -> tuple[int, int, int]:
    """Offset of the first MCAP chunk, offset and length of its compressed records (the MCAP specification)."""
    pos = 8
    while data[pos] != 0x06:
        pos += 9 + int.from_bytes(data[pos + 1:pos + 9], "little")
    name_length = int.from_bytes(data[pos + 9 + 28:pos + 9 + 32], "little")
    at = pos + 9 + 32 + name_length
    return pos, at + 8, int.from_bytes(data[at:at + 8], "little")


@pytest.mark.parametrize("where", [0.05, 0.3, 0.5, 0.7, 0.95])
def test_a_flipped_bit_inside_a_chunk_is_an_error_never_data(tmp_path, where) -> None:
    trial = run_sea_trial(TwinConfig(), make_scenario("accel-stop", TwinConfig().vessel, np.random.default_rng(0),
                                                      duration_s=30.0), seed=0)
    path = tmp_path / "trial.mcap"
    write_bag(path, trial_messages(trial, truth=False))
    data = bytearray(path.read_bytes())
    chunk, start, length = _first_chunk_records(bytes(data))
    data[start + int(where * length)] ^= 0x10  # without chunk CRCs, 15 of 19 such flips read back as data
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=rf"trial.mcap: MCAP chunk at byte {chunk} is corrupt"):
        read_trial(path)


def test_convert_refuses_to_write_over_its_log(tmp_path, own_tlog, capsys) -> None:
    log = tmp_path / "twin.tlog"
    log.write_bytes(own_tlog.read_bytes())
    before = log.read_bytes()
    assert main(["convert", str(log), "--out", str(log), "--force"]) == 2
    assert "also an input" in capsys.readouterr().err and log.read_bytes() == before


def test_a_drag_coefficient_must_be_finite(tmp_path, capsys) -> None:
    case = Path(__file__).resolve().parents[1] / "config" / "cable" / "default.yaml"
    text = case.read_text()
    bad = tmp_path / "case.yaml"
    assert "drag: {model: sphere, cx: 0.47}" in text
    bad.write_text(text.replace("drag: {model: sphere, cx: 0.47}", "drag: {model: sphere, cx: .inf}"))
    assert main(["cable", "depth", "--case", str(bad), "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cable.drag.cx: expected a finite number" in err[0], err


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_reports_get_the_umask_permissions_a_bag_gets(tmp_path, umask) -> None:
    """Atomic writes go through mkstemp (0600): the files they leave have the mode open() would give, like a bag."""
    previous = os.umask(umask)
    try:
        assert main(["identify", "--table", "dyda2021", "--out", str(tmp_path / "report")]) == 0
        velocity = twist_stamped(header(1, "gnss_link"), (1.0, 0.0, 0.0))
        write_bag(tmp_path / "bag.mcap", iter([("gnss/vel", 1, velocity)]))
    finally:
        os.umask(previous)
    expected = 0o666 & ~umask
    modes = {p.name: p.stat().st_mode & 0o777 for p in [*(tmp_path / "report").iterdir(), tmp_path / "bag.mcap"]}
    assert set(modes) >= {"identify.json", "report.txt", "model.yaml", "fits.png", "bag.mcap"}
    assert modes == dict.fromkeys(modes, expected)



def test_json_output_is_strict_with_null_for_non_finite_numbers() -> None:
    """--json output parses anywhere: NaN and ±inf (an unmeasurable value, an unbounded interval) are null."""
    text = to_json({"interval": (np.float64(2.0), float("inf")), "values": np.array([np.nan, 1.5]), "n": np.int64(3)})
    assert "Infinity" not in text and "NaN" not in text
    assert json.loads(text) == {"interval": [2.0, None], "values": [None, 1.5], "n": 3}
