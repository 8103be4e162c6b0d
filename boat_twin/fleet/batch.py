"""A verb run on many trials, each on its own, as tasks: on a Dask client's workers or one after another here.

:func:`run_batch` is what ``boat-twin identify|diagnose TRIAL... --each --out DIR`` runs. Contract:

- ``DIR/<trial name>/`` holds each trial's own report (what the verb writes for one trial) and ``row.json``,
  its summary row, written as one set (:class:`~boat_twin.files.ReportSet`): the whole new report appears at
  once when the trial is done, or nothing of it (an error, an interrupt, a killed worker keep the old report
  whole). A trial with ``row.json`` is complete, and a later run skips it (resume) unless ``force`` or its row in
  the last summary says it failed. A trial that failed has no new report (an earlier complete one stays) and is
  tried again by the next run.
- ``DIR/summary.csv`` and ``DIR/summary.json`` (a list of rows, one per trial in the order given) are rewritten
  after every trial, each atomically and the two together with SIGINT and SIGTERM held back (they always
  agree), so that a killed run leaves the rows of the trials it finished. Each row has at least
  ``trial``, ``status`` ("ok", "error", or a verb's own such as identify's "no_twin"), ``error`` (null unless
  "error"), ``boat``, ``source``, ``duration_s``, the
  verb's headline (the job's ``columns``), ``seconds``, ``cpu_s``, ``worker`` and ``peak_rss_mb``. summary.json
  keeps every value as computed; summary.csv rounds floats to :data:`CSV_DIGITS` significant digits and leaves
  out a job's ``curves`` (multi-point x, y lists), which go to ``DIR/curves.csv``, one point a line.
- A failing trial (bad file, a pipeline error, even a crash of its worker) is reported in its row and never stops
  the others.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import resource
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from boat_twin import progress_line
from boat_twin.errors import InputError
from boat_twin.files import (
    OutputClaim,
    ReportSet,
    atomic_write_text,
    ensure_out_dir,
    locked_directory,
    refuse_input_as_output,
    signals_held,
    to_json,
)
from boat_twin.fleet.jobs import COMMON_COLUMNS, RUN_COLUMNS
from boat_twin.fleet.trials import TrialTask, trial_bytes

ROW_FILE = "row.json"
"""A trial's summary row in its report directory, written last: the mark of a complete report."""
SUMMARY_CSV = "summary.csv"
SUMMARY_JSON = "summary.json"
CURVES_CSV = "curves.csv"
CSV_DIGITS = 4
"""Significant digits of a float in summary.csv and curves.csv (summary.json keeps them all)."""
ERROR = "error"
"""Status of a trial whose run failed."""


class Job(Protocol):
    """One trial's work (:class:`~boat_twin.fleet.jobs.IdentifyJob`, :class:`~boat_twin.fleet.jobs.DiagnoseJob`)."""

    verb: str
    columns: tuple[str, ...]
    curves: tuple[str, ...]
    """(x, y) columns of ``columns`` holding a curve (lists of numbers), or ()."""
    outputs: tuple[str, ...]
    """The files of one trial's report (:mod:`boat_twin.fleet.outputs`)."""

    def __call__(self, path: Path, out: Path, named: Path | None = None) -> dict[str, Any]: ...


@dataclass
class BatchResult:
    """What :func:`run_batch` did: every row (in the order of the trials), how many were resumed from an earlier
    run, and the summary files."""

    rows: list[dict[str, Any]]
    resumed: int
    summary_csv: Path
    summary_json: Path

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The rows of the trials that failed."""
        return [row for row in self.rows if row["status"] == ERROR]


def run_task(job: Job, task: TrialTask, report_dir: str, one_thread: bool) -> dict[str, Any]:
    """Run ``job`` on ``task`` into ``report_dir`` and return its row; any failure becomes the row's ``error``.
    ``one_thread``: numba's kernels on one thread (a worker process among several on the machine)."""
    if one_thread:
        from boat_twin.threads import use_one_numba_thread

        use_one_numba_thread()
    start, cpu = time.perf_counter(), time.process_time()
    row: dict[str, Any] = {"trial": task.name, "status": "ok", "error": None, "boat": task.boat,
                           "source": task.path, "duration_s": None, **dict.fromkeys(job.columns)}
    out = Path(report_dir)

    def timed() -> None:
        row.update(seconds=time.perf_counter() - start, cpu_s=time.process_time() - cpu,
                   worker=f"{socket.gethostname()}:{os.getpid()}",
                   peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)

    try:
        with ReportSet(out, (*job.outputs, ROW_FILE), force=True) as report:
            row.update(job(Path(task.path), report.staging, out))
            timed()
            (report.staging / ROW_FILE).write_text(to_json(row) + "\n")
            report.commit()
    except InputError as err:
        row.update(status=ERROR, error=str(err))
    except Exception as err:  # noqa: BLE001  a bug or a broken file the readers did not foresee: this trial's row
        row.update(status=ERROR, error=f"{task.path}: {type(err).__name__}: {err}")
    if row["status"] == ERROR:
        timed()
    return row


def _crashed(task: TrialTask, job: Job, err: BaseException) -> dict[str, Any]:
    """The row of a trial whose task did not return (its worker died, the cluster lost it)."""
    return {"trial": task.name, "status": ERROR, "error": f"task lost: {type(err).__name__}: {err}",
            "boat": task.boat, "source": task.path, "duration_s": None, **dict.fromkeys(job.columns),
            **dict.fromkeys(RUN_COLUMNS)}


def _cell(value: Any, digits: int | None) -> Any:
    if value is None:
        return ""
    if isinstance(value, (list, tuple)):
        return ";".join(str(_cell(v, digits)) for v in value)
    if isinstance(value, float) and digits is not None and math.isfinite(value):
        return f"{value:.{digits}g}"
    return value


def _table(header: Sequence[str], lines: Sequence[Sequence[Any]], digits: int | None) -> str:
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(header)
    writer.writerows([_cell(v, digits) for v in line] for line in lines)
    return text.getvalue()


def write_summary(out: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str],
                  curves: Sequence[str] = (), digits: int | None = None) -> None:
    """``summary.json`` (the rows) and ``summary.csv`` (``columns`` but ``curves``; lists joined by ``;``, null
    empty, floats to ``digits`` significant digits, None: as they are) and, with ``curves`` (x, y columns),
    ``curves.csv`` (trial, x, y: one point a line); each atomically, the set with SIGINT and SIGTERM held back: an
    interrupt never leaves one newer than another."""
    shown = [c for c in columns if c not in curves]
    summary = _table(shown, [[row.get(c) for c in shown] for row in rows], digits)
    points = []
    if curves:
        x, y = curves
        points = [[row["trial"], a, b] for row in rows for a, b in zip(row.get(x) or (), row.get(y) or (), strict=True)]
    with signals_held():
        atomic_write_text(out / SUMMARY_JSON, to_json(list(rows)) + "\n")
        atomic_write_text(out / SUMMARY_CSV, summary)
        if curves:
            atomic_write_text(out / CURVES_CSV, _table(("trial", *curves), points, digits))


def _clean_leftovers(out: Path, tasks: Sequence[TrialTask]) -> None:
    """Leftovers of a run killed while writing a trial's report (``.NAME.partial-PID``) or swapping it in
    (``.NAME.old-PID``, the old report moved aside): removed or restored now, before the resume looks for
    complete reports (:class:`~boat_twin.files.OutputClaim` does it and names each on stderr)."""
    names = {task.name for task in tasks}
    stale = {m.group(1) for m in map(re.compile(r"\.(.+)\.(?:partial|old)-\d+").fullmatch, os.listdir(out)) if m}
    for name in sorted(stale & names):
        OutputClaim(out / name, force=True, kind="reports").release()


def _failed_last_time(out: Path) -> set[str]:
    """The trials whose row in ``out``'s summary from the last run says they failed: an older complete report of
    theirs (kept by the failure) is not the latest attempt's result, so a resume runs them again."""
    try:
        rows = json.loads((out / SUMMARY_JSON).read_text())
    except (OSError, ValueError):
        return set()
    if not isinstance(rows, list):
        return set()
    return {row["trial"] for row in rows if isinstance(row, dict) and row.get("status") == ERROR and "trial" in row}


def _complete_row(report_dir: Path) -> dict[str, Any] | None:
    """The row of an earlier complete report in ``report_dir``, or None."""
    try:
        row = json.loads((report_dir / ROW_FILE).read_text())
    except (OSError, ValueError):
        return None
    return row if isinstance(row, dict) and row.get("status") not in (None, ERROR) else None


class Progress:
    """A progress bar on stderr (:mod:`boat_twin.progress_line`: a stop or error line starts on its own line):
    trials done of all, errors, elapsed time."""

    WIDTH = 30

    def __init__(self, verb: str, total: int) -> None:
        self.verb, self.total, self.done, self.errors = verb, total, 0, 0
        self.start = time.monotonic()

    def update(self, row: dict[str, Any]) -> None:
        """Count ``row`` and redraw."""
        self.done += 1
        self.errors += row["status"] == ERROR
        filled = self.WIDTH * self.done // max(self.total, 1)
        elapsed = time.monotonic() - self.start
        progress_line.show(f"{self.verb} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {self.done}/{self.total}"
                           f", {self.errors} error(s), {elapsed:.0f} s")
        if self.done == self.total:
            progress_line.end()


def run_batch(job: Job, tasks: Sequence[TrialTask], out: Path, client: Any = None, *, force: bool = False,
              progress: Callable[[dict[str, Any]], None] | None = None) -> BatchResult:
    """Run ``job`` on every trial of ``tasks`` into ``out`` (the module's contract): on ``client``'s workers (a
    Dask client, one task per trial) or, with None, one after another in this process. ``force`` redoes the
    trials an earlier run completed; ``progress(row)`` is called for each trial as it finishes (first for those
    an earlier run completed). Returns the rows."""
    if not tasks:
        raise InputError("no trial to run")
    refuse_input_as_output(out, *(Path(t.path) for t in tasks))
    out = ensure_out_dir(out).resolve()
    columns = (*COMMON_COLUMNS, *job.columns, *RUN_COLUMNS)
    with locked_directory(out):
        _clean_leftovers(out, tasks)
        rows: dict[str, dict[str, Any]] = {}
        if not force:
            failed = _failed_last_time(out)
            for task in tasks:
                earlier = None if task.name in failed else _complete_row(out / task.name)
                if earlier is not None:
                    rows[task.name] = earlier
        resumed = len(rows)
        pending = [t for t in tasks if t.name not in rows]
        if progress is not None:
            for row in rows.values():
                progress(row)

        def finished(task: TrialTask, row: dict[str, Any]) -> None:
            rows[task.name] = row
            write_summary(out, [rows[t.name] for t in tasks if t.name in rows], columns, job.curves, CSV_DIGITS)
            if progress is not None:
                progress(row)

        if client is None:
            for task in pending:
                finished(task, run_task(job, task, str(out / task.name), False))
        else:
            _run_on_dask(client, job, pending, out, finished)
        ordered = [rows[t.name] for t in tasks]
        write_summary(out, ordered, columns, job.curves, CSV_DIGITS)
    return BatchResult(ordered, resumed, out / SUMMARY_CSV, out / SUMMARY_JSON)


def _run_on_dask(client: Any, job: Job, tasks: Sequence[TrialTask], out: Path,
                 finished: Callable[[TrialTask, dict[str, Any]], None]) -> None:
    """One Dask task per trial, the largest recordings first (a long trial started last would leave the other
    workers idle at the end); rows recorded as they complete, in any order."""
    from distributed import as_completed

    by_size = sorted(((trial_bytes(task), task) for task in tasks), key=lambda pair: -pair[0])
    futures = {client.submit(run_task, job, task, str(out / task.name), True, pure=False,
                             key=f"{job.verb}-{task.name}-{os.getpid()}-{i}", priority=size): task
               for i, (size, task) in enumerate(by_size)}
    try:
        for future in as_completed(futures):
            task = futures[future]
            try:
                row = future.result()
            except Exception as err:  # noqa: BLE001  the worker died or the task was lost: this trial's row
                row = _crashed(task, job, err)
            finished(task, row)
    finally:
        client.cancel(list(futures))
