"""A large simulated ensemble in chunks: boats drawn around the twin, run through a scenario, summarised per boat,
each chunk a task whose rows stream to its own file.

:func:`run_ensemble` is what ``boat-twin simulate SCENARIO --ensemble N --out DIR`` runs. Boat ``i`` is drawn
from its own generator, seeded by (seed, i) (:func:`~boat_twin.ident.manoeuvring_trials.draw_boat`: every
manoeuvring coefficient within ±30 %, the lateral centre and steering offset likewise, directionally stable),
and every boat's arithmetic in the compiled kernel is its own: the same seed gives the same rows whatever the
chunk size and the number of workers. A chunk holds one simulation record at a time (152 bytes per boat and
output tick), so a worker's memory is bounded by :attr:`EnsembleSpec.chunk_boats`, not the ensemble.

``DIR/ensemble.json`` holds the settings; ``DIR/chunk-NNNNN.csv`` one row per boat (``boat``, the drawn
coefficients, the track's figures and, for a zigzag, the 42 features of Pashentsev 2025); ``DIR/summary.csv`` and
``DIR/summary.json`` one row per chunk (status, error, seconds, worker, its peak resident memory). A chunk whose
file exists is complete and skipped by a later run with the same settings (resume).
"""

from __future__ import annotations

import csv
import io
import json
import os
import resource
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig, config_to_dict
from boat_twin.errors import InputError
from boat_twin.files import atomic_write_text, ensure_out_dir, locked_directory, to_json
from boat_twin.fleet.batch import write_summary

RECORD_BYTES_PER_BOAT_TICK = 152
"""What a simulation record holds per boat and output tick: states, derivatives, commands, steering, stamps."""
CHUNK_RECORD_BYTES = 200e6
"""Default chunk: as many boats as fill a record of this size (one at a time per worker), bytes."""
MAX_CHUNK_BOATS = 2000
"""Largest default chunk, boats (the training sets' ensemble runs)."""
SETTINGS_FILE = "ensemble.json"
CHUNK_COLUMNS = ("chunk", "first_boat", "boats", "status", "error", "file", "finite_feature_rows", "seconds",
                 "cpu_s", "worker", "peak_rss_mb")
"""Columns of the ensemble's summary (one row per chunk)."""
TRACK_COLUMNS = ("max_surge_mps", "max_abs_yaw_rate_radps", "final_east_m", "final_north_m", "final_yaw_rad")
"""Figures of every boat's track (truth)."""


@dataclass(frozen=True)
class EnsembleSpec:
    """An ensemble: ``boats`` boats drawn around ``config``'s vessel (boat i seeded by (``seed``, i)), all run
    through the registered scenario ``scenario`` (built with ``seed``; ``duration_s`` None: its own length), in
    tasks of ``chunk_boats`` boats."""

    scenario: str
    boats: int
    seed: int = 0
    duration_s: float | None = None
    chunk_boats: int = 0
    """Boats per task; 0: as many as fill a :data:`CHUNK_RECORD_BYTES` record, at most :data:`MAX_CHUNK_BOATS`."""
    config: TwinConfig = field(default_factory=TwinConfig)

    def settings(self) -> dict[str, Any]:
        """What makes the rows (the chunking does not): compared with an earlier run's before resuming."""
        return {"scenario": self.scenario, "boats": self.boats, "seed": self.seed, "duration_s": self.duration_s,
                "config": config_to_dict(self.config)}


def _scenario(spec: EnsembleSpec) -> Any:
    from boat_twin.vessel.scenarios import make_scenario

    return make_scenario(spec.scenario, spec.config.vessel, np.random.default_rng(spec.seed), spec.duration_s)


def chunk_size(spec: EnsembleSpec) -> int:
    """Boats per chunk: :attr:`EnsembleSpec.chunk_boats`, or the default from the scenario's length."""
    if spec.chunk_boats:
        return spec.chunk_boats
    from boat_twin.vessel.simulate import output_ticks

    ticks = output_ticks(_scenario(spec).duration_s)
    return int(max(1, min(MAX_CHUNK_BOATS, CHUNK_RECORD_BYTES // (ticks * RECORD_BYTES_PER_BOAT_TICK))))


def ensemble_chunks(spec: EnsembleSpec) -> list[tuple[int, int, int]]:
    """(chunk, first boat, boats) of every chunk; an unknown scenario or a bad size is refused here."""
    if spec.boats < 1:
        raise InputError(f"--ensemble must be at least 1 boat, got {spec.boats}")
    if spec.chunk_boats < 0:
        raise InputError(f"--chunk must be at least 1 boat, got {spec.chunk_boats}")
    size = chunk_size(spec)
    return [(i, lo, min(size, spec.boats - lo)) for i, lo in enumerate(range(0, spec.boats, size))]


def boat_draws(spec: EnsembleSpec, first: int, count: int) -> tuple[list[Any], list[dict[str, float]]]:
    """Vessels and drawn coefficients of boats ``first`` .. ``first + count - 1``, each from its own generator
    seeded by (seed, boat index): independent of the chunking."""
    from boat_twin.ident.manoeuvring_trials import draw_boat

    vessels, truths = [], []
    for index in range(first, first + count):
        config, truth = draw_boat(spec.config, np.random.default_rng([spec.seed, index]))
        vessels.append(config.vessel)
        truths.append(truth)
    return vessels, truths


def chunk_rows(spec: EnsembleSpec, first: int, count: int) -> tuple[list[str], np.ndarray]:
    """Column names and the (count, columns) rows of boats ``first`` .. ``first + count - 1``: boat index, the
    drawn coefficients, the track's figures and, for a zigzag, its 42 features (NaN where an event is missing)."""
    from boat_twin.ident.zigzag_features import FEATURE_NAMES, ensemble_features
    from boat_twin.vessel.scenarios import Zigzag
    from boat_twin.vessel.simulate import simulate

    scenario = _scenario(spec)
    vessels, truths = boat_draws(spec, first, count)
    record = simulate(spec.config.vessel, scenario, environment=spec.config.environment, boats=vessels)
    states = record.states
    keys = list(truths[0])
    columns = ["boat", *keys, *TRACK_COLUMNS]
    parts = [np.arange(first, first + count, dtype=float)[:, None],
             np.array([[t[k] for k in keys] for t in truths]),
             np.column_stack([states[:, :, 3].max(axis=0), np.abs(states[:, :, 5]).max(axis=0),
                              states[-1, :, 0], states[-1, :, 1], states[-1, :, 2]])]
    if isinstance(scenario, Zigzag):
        columns += list(FEATURE_NAMES)
        parts.append(ensemble_features(record))
    del record
    return columns, np.concatenate(parts, axis=1)


def _csv_text(columns: list[str], rows: np.ndarray) -> str:
    """Rows as CSV, every float written to round-trip exactly (``repr``), NaN as ``nan``, the boat as an
    integer."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(columns)
    for row in rows.tolist():
        writer.writerow([int(row[0]), *(repr(v) for v in row[1:])])
    return text.getvalue()


def run_chunk(spec: EnsembleSpec, chunk: int, first: int, count: int, path: str, one_thread: bool
              ) -> dict[str, Any]:
    """Simulate one chunk, write its rows to ``path`` (atomically: a chunk file is complete), return its
    summary row; a failure becomes the row's ``error``. ``one_thread``: numba on one thread (a worker among
    several on the machine)."""
    if one_thread:
        from boat_twin.threads import use_one_numba_thread

        use_one_numba_thread()
    start, cpu = time.perf_counter(), time.process_time()
    row: dict[str, Any] = {"chunk": chunk, "first_boat": first, "boats": count, "status": "ok", "error": None,
                           "file": Path(path).name, "finite_feature_rows": None}
    try:
        columns, rows = chunk_rows(spec, first, count)
        atomic_write_text(Path(path), _csv_text(columns, rows))
        row["finite_feature_rows"] = int(np.all(np.isfinite(rows), axis=1).sum())
    except (InputError, ValueError, FloatingPointError) as err:
        row.update(status="error", error=f"{type(err).__name__}: {err}" if not isinstance(err, InputError)
                   else str(err))
    row.update(seconds=time.perf_counter() - start, cpu_s=time.process_time() - cpu,
               worker=f"{socket.gethostname()}:{os.getpid()}",
               peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
    return row


def chunk_file(chunk: int) -> str:
    """File name of chunk ``chunk``."""
    return f"chunk-{chunk:05d}.csv"


def _check_settings(out: Path, spec: EnsembleSpec, force: bool) -> None:
    """An earlier ensemble in ``out`` with other settings is refused without ``force`` (its chunks would mix)."""
    path = out / SETTINGS_FILE
    if path.exists() and not force:
        try:
            earlier = json.loads(path.read_text())
        except (OSError, ValueError):
            earlier = None
        if not isinstance(earlier, dict) or json.loads(to_json(spec.settings())) != earlier.get("settings"):
            raise InputError(f"{out}: holds an ensemble with other settings ({path}); use --force to replace it")


def run_ensemble(spec: EnsembleSpec, out: Path, client: Any = None, *, force: bool = False,
                 progress: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Run the ensemble ``spec`` into ``out`` (the module's contract): each chunk a task on ``client``'s workers
    (a Dask client) or, with None, one after another here. ``force`` redoes complete chunks (and replaces an
    ensemble of other settings); ``progress(row)`` is called as each chunk finishes. Returns the chunk rows."""
    chunks = ensemble_chunks(spec)
    out = ensure_out_dir(out).resolve()
    with locked_directory(out):
        _check_settings(out, spec, force)
        atomic_write_text(out / SETTINGS_FILE, to_json({"settings": spec.settings(), "chunk_boats": chunks[0][2],
                                                        "chunks": len(chunks)}) + "\n")
        rows: dict[int, dict[str, Any]] = {}
        pending = []
        for chunk, first, count in chunks:
            if not force and (out / chunk_file(chunk)).exists():
                rows[chunk] = {"chunk": chunk, "first_boat": first, "boats": count, "status": "ok", "error": None,
                               "file": chunk_file(chunk), "finite_feature_rows": None, "seconds": None,
                               "cpu_s": None, "worker": "an earlier run", "peak_rss_mb": None}
                if progress is not None:
                    progress(rows[chunk])
            else:
                pending.append((chunk, first, count))

        def finished(row: dict[str, Any]) -> None:
            rows[row["chunk"]] = row
            write_summary(out, [rows[c] for c, _, _ in chunks if c in rows], CHUNK_COLUMNS)
            if progress is not None:
                progress(row)

        if client is None:
            for chunk, first, count in pending:
                finished(run_chunk(spec, chunk, first, count, str(out / chunk_file(chunk)), False))
        else:
            _run_on_dask(client, spec, pending, out, finished)
        ordered = [rows[c] for c, _, _ in chunks]
        write_summary(out, ordered, CHUNK_COLUMNS)
    return ordered


def _run_on_dask(client: Any, spec: EnsembleSpec, chunks: list[tuple[int, int, int]], out: Path,
                 finished: Callable[[dict[str, Any]], None]) -> None:
    """One task per chunk, the spec scattered once; rows recorded as chunks complete."""
    from distributed import as_completed

    shared = client.scatter(spec, broadcast=True)
    futures = {client.submit(run_chunk, shared, chunk, first, count, str(out / chunk_file(chunk)), True,
                             pure=False, key=f"ensemble-{chunk}-{os.getpid()}"): (chunk, first, count)
               for chunk, first, count in chunks}
    try:
        for future in as_completed(futures):
            chunk, first, count = futures[future]
            try:
                row = future.result()
            except Exception as err:  # noqa: BLE001  the worker died or the task was lost: this chunk's row
                row = {"chunk": chunk, "first_boat": first, "boats": count, "status": "error",
                       "error": f"task lost: {type(err).__name__}: {err}", "file": chunk_file(chunk),
                       "finite_feature_rows": None, "seconds": None, "cpu_s": None, "worker": None,
                       "peak_rss_mb": None}
            finished(row)
    finally:
        client.cancel(list(futures))
