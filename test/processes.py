"""Processes started as a user's shell starts them, without ``preexec_fn``.

``preexec_fn`` runs Python in the child between fork and exec; in a pytest worker that holds other threads (a
Dask cluster's, a timer's) the child can deadlock there, and ``Popen`` then waits for its exec forever, a wait
no ``timeout`` of ``subprocess.run`` covers. So the parent sets what the child must inherit around the spawn
(SIGINT's default action), or a small ``python -c`` sets it in the child and execs the command in place (the
same pid)."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

_WITH_FILE_SIZE_LIMIT = ("import os, resource, sys; n = int(sys.argv[1]); "
                         "resource.setrlimit(resource.RLIMIT_FSIZE, (n, n)); os.execv(sys.argv[2], sys.argv[2:])")


def popen_as_from_a_shell(argv: list[str], **kwargs: Any) -> subprocess.Popen:
    """``Popen(argv)`` with Ctrl-C (SIGINT) at its default action, as a shell starts a command: a pytest worker
    started in the background of a non-interactive shell ignores SIGINT, and its children would inherit that."""
    previous = signal.signal(signal.SIGINT, signal.SIG_DFL)
    try:
        return subprocess.Popen(argv, **kwargs)
    finally:
        signal.signal(signal.SIGINT, previous)


def run_as_from_a_shell(argv: list[str], timeout_s: float, **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(argv, capture_output=True, text=True)`` started as :func:`popen_as_from_a_shell` starts it
    (killed after ``timeout_s``)."""
    with popen_as_from_a_shell(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs) as run:
        try:
            stdout, stderr = run.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            run.kill()
            raise
    return subprocess.CompletedProcess(argv, run.returncode, stdout, stderr)


def run_with_file_size_limit(argv: list[str], limit_bytes: int, **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(argv)`` under RLIMIT_FSIZE = ``limit_bytes`` (writing past it fails as on a full disk)."""
    return subprocess.run([sys.executable, "-c", _WITH_FILE_SIZE_LIMIT, str(limit_bytes), *argv], **kwargs)


BOAT_TWIN = str(Path(sys.executable).parent / "boat-twin") if (Path(sys.executable).parent / "boat-twin").exists() \
    else (shutil.which("boat-twin") or "boat-twin")
"""The console script, as a user runs it."""


def file_tree(path: Path) -> dict[str, bytes]:
    """Every file under ``path`` (relative name → bytes): what a run must leave as it was."""
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def one_error_line(err: str) -> str:
    """The one ``error:`` line a refused run printed (no traceback, nothing else said to be an error)."""
    lines = err.strip().splitlines()
    assert "Traceback" not in err and lines, err
    assert sum("error:" in line for line in lines) == 1 and "error:" in lines[-1], err
    return lines[-1]
