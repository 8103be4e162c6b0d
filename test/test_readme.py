"""The README's commands run as written, from a copy of the clone, and print what the README shows.

A fenced ``sh`` block preceded by the line ``<!-- runnable -->`` is run here line by line (bash, from a temporary
directory holding ``bags/``, ``config/`` and ``.venv`` linked to this interpreter's environment); each line must
be a ``.venv/bin/boat-twin`` command or one of :data:`SUBSTITUTES`. When an output block follows, each of its
lines must appear in what the block printed (``…`` in the README stands for text left out).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MARK = "<!-- runnable -->"
SUBSTITUTES = {"make demo": ".venv/bin/boat-twin demo --out out/demo --force"}
"""README line → what the test runs instead (the Makefile recipe, without the environment set-up)."""
VENV = Path(sys.executable).parents[1]


def runnable_blocks(text: str) -> list[tuple[list[str], list[str]]]:
    """Each marked block: its command lines, and the lines of the output block right after it (if any)."""
    lines = text.splitlines()
    blocks = []
    for i, line in enumerate(lines):
        if line.strip() != MARK:
            continue
        assert lines[i + 1] == "```sh", f"README.md:{i + 2}: {MARK} must precede a ```sh block"
        end = lines.index("```", i + 2)
        commands = [c for c in lines[i + 2:end] if c.strip()]
        output: list[str] = []
        if end + 1 < len(lines) and lines[end + 1] == "```":
            output = lines[end + 2:lines.index("```", end + 2)]
        blocks.append((commands, output))
    return blocks


BLOCKS = runnable_blocks(README.read_text(encoding="utf-8"))


def test_the_readme_marks_its_quick_start_commands_and_only_commands_this_test_may_run() -> None:
    assert len(BLOCKS) >= 4
    for commands, _ in BLOCKS:
        for command in commands:
            assert command.startswith(".venv/bin/boat-twin ") or command in SUBSTITUTES, command
    makefile = (ROOT / "Makefile").read_text()
    assert "$(VENV)/bin/boat-twin demo --out $(OUT)/demo --force" in makefile  # what SUBSTITUTES runs


@pytest.fixture(scope="module")
def clone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory that looks like a clone after `make demo`: bags/, config/ and .venv."""
    if not (VENV / "bin" / "boat-twin").exists():
        pytest.skip(f"no boat-twin console script in {VENV / 'bin'} (the package is not installed there)")
    where = tmp_path_factory.mktemp("clone")
    for name in ("bags", "config"):
        shutil.copytree(ROOT / name, where / name)
    (where / ".venv").symlink_to(VENV)
    return where


def _contains_in_order(text: str, expected: str) -> bool:
    position = 0
    for piece in (p.strip() for p in expected.split("…")):
        found = text.find(piece, position)
        if found < 0:
            return False
        position = found + len(piece)
    return True


@pytest.mark.parametrize("commands, output", BLOCKS, ids=[b[0][0][:60] for b in BLOCKS])
def test_readme_block_runs_as_written(clone: Path, commands: list[str], output: list[str]) -> None:
    printed = ""
    for command in commands:
        done = subprocess.run(["bash", "-c", SUBSTITUTES.get(command, command)], cwd=clone, capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, f"{command}: exit {done.returncode}\n{done.stderr[-2000:]}"
        printed += done.stdout + done.stderr
    missing = [line for line in output if line.strip() and not _contains_in_order(printed, line)]
    assert not missing, "README shows lines the commands did not print:\n" + "\n".join(missing)
