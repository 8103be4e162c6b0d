"""Fleets on Dask: a batch of recordings diagnosed on a local cluster against one after another, a large zigzag
ensemble streamed to disk, the threaded ensemble kernel beside a busy loop, and a cluster started by hand on
loopback (a `dask scheduler` and two `dask worker` processes, as on two machines).

Run: .venv/bin/python benchmarks/bench_fleet.py [--recordings 8] [--duration 150] [--boats 6000] [--busy-boats 2000]
(needs the fleet extra: dask, distributed). Targets (issue 27, printed, not asserted): 40 recordings diagnosed on a
2-worker local cluster >= 1.8x the serial run, memory per worker flat; a 10^5-boat zigzag ensemble with features
streamed to disk, peak RSS per worker < 1 GB; beside a busy loop on one core, the ensemble at default settings
within 10 % of the best of {1 thread, 2 threads}; the loopback cluster's rows identical to the serial run's.
The default sizes are modest (the machine is shared); the figures of docs/fleet.md give the command they came from.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.fleet.batch import run_batch
from boat_twin.fleet.engine import LOCAL, open_client
from boat_twin.fleet.ensemble import EnsembleSpec, ensemble_chunks, run_ensemble
from boat_twin.fleet.jobs import RUN_COLUMNS, DiagnoseJob
from boat_twin.fleet.trials import expand_trials, name_trials
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.scenarios import make_scenario

KINDS = ("random", "zigzag-20-20", "thrust-steps")
"""Scenarios of the recordings, in turn."""


def recordings(folder: Path, count: int, duration_s: float) -> list[Path]:
    """``count`` simulated recordings of ``duration_s`` (the scenarios in turn, seeds 0..), as MCAP bags."""
    config = TwinConfig()
    paths = []
    for seed in range(count):
        kind = KINDS[seed % len(KINDS)]
        scenario = make_scenario(kind, config.vessel, np.random.default_rng(seed), duration_s)
        path = folder / f"rec{seed:03d}.mcap"
        write_bag(path, trial_messages(run_sea_trial(config, scenario, seed), truth=False))
        paths.append(path)
    return paths


def warm_up() -> None:
    """Import the pipelines and load the compiled kernels from numba's cache, as the first task of a long batch
    does once per process."""
    from boat_twin.diagnose import pipeline  # noqa: F401
    from boat_twin.vessel.simulate import simulate

    config = TwinConfig()
    simulate(config.vessel, make_scenario("random", config.vessel, np.random.default_rng(0), 5.0))


def worker_peak_rss_mb(rows: list[dict]) -> dict[str, float]:
    """Peak resident memory of every worker process over ``rows`` (each row's ``peak_rss_mb``), MB."""
    peaks: dict[str, float] = {}
    for row in rows:
        peaks[row["worker"]] = max(peaks.get(row["worker"], 0.0), row["peak_rss_mb"])
    return peaks


def findings(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in row.items() if k not in RUN_COLUMNS} for row in rows]


def half_batch(tasks: list, out: Path, ready: Any, go: Any, seconds: Any) -> None:
    """(In a plain child process.) Load the kernels, wait for the sibling, diagnose ``tasks`` one after another and
    put the wall time on ``seconds``."""
    warm_up()
    ready.release()
    go.wait()
    start = time.perf_counter()
    run_batch(DiagnoseJob(), tasks, out)
    seconds.put(time.perf_counter() - start)


def plain_pair(tasks: list, out: Path) -> float:
    """The machine's ceiling for two processes: the batch split in two (alternate trials) and diagnosed by two plain
    processes at once, no Dask; the wall time of the slower, s. Two processes on two cores are not twice one:
    they share the memory bus and the last-level cache, and on a virtual machine the cores may be one physical
    core's two hyper-threads."""
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    ready, go, seconds = context.Semaphore(0), context.Event(), context.Queue()
    children = [context.Process(target=half_batch, args=(tasks[i::2], out / f"half{i}", ready, go, seconds))
                for i in range(2)]
    for child in children:
        child.start()
    for _ in children:
        ready.acquire()
    go.set()
    slower = max(seconds.get() for _ in children)
    for child in children:
        child.join()
    return slower


def batch(paths: list[Path], out: Path) -> list[dict]:
    """Diagnose ``paths`` one after another here, then on a 2-worker local cluster, and print the times, the
    ratio and the workers' memory (each row's ``peak_rss_mb``: its worker's peak so far, after the first half of
    the batch's rows and after all)."""
    tasks = name_trials(expand_trials(paths))
    job = DiagnoseJob()
    warm_up()
    start = time.perf_counter()
    serial = run_batch(job, tasks, out / "serial").rows
    serial_s = time.perf_counter() - start
    start = time.perf_counter()
    with open_client(LOCAL, 2, quiet=True) as client:
        client.run(warm_up)
        ready_s = time.perf_counter() - start
        start = time.perf_counter()
        parallel = run_batch(job, tasks, out / "cluster", client).rows
        cluster_s = time.perf_counter() - start
    pair_s = plain_pair(tasks, out / "pair")
    same = findings(parallel) == findings(serial)
    print(f"diagnose {len(tasks)} recordings: serial {serial_s:.1f} s, 2-worker local cluster {cluster_s:.1f} s "
          f"(after {ready_s:.1f} s starting it and loading the kernels), ratio {serial_s / cluster_s:.2f}x (target "
          f">= 1.8x); CPU of the tasks: serial {sum(r['cpu_s'] for r in serial):.1f} s, cluster "
          f"{sum(r['cpu_s'] for r in parallel):.1f} s; rows identical: {same}, errors: "
          f"{sum(r['status'] != 'ok' for r in parallel)}")
    print(f"the machine's ceiling: two plain processes (no Dask) on half the batch each {pair_s:.1f} s, ratio "
          f"{serial_s / pair_s:.2f}x; the cluster reaches {pair_s / cluster_s:.2f} of it")
    half, full = worker_peak_rss_mb(parallel[: len(parallel) // 2]), worker_peak_rss_mb(parallel)
    print("peak RSS per worker after half / all of the batch, MB: "
          + ", ".join(f"{half.get(w, float('nan')):.0f} / {full[w]:.0f}" for w in sorted(full)))
    return serial


def ensemble(boats: int, out: Path) -> None:
    """A zigzag ensemble (75 s, boats drawn ±30 %) on a 2-worker local cluster against this process's threaded
    kernel (one after another), streamed to disk; rows compared."""
    spec = EnsembleSpec("zigzag-20-20", boats, seed=1, duration_s=75.0)
    chunks = ensemble_chunks(spec)
    warm_up = EnsembleSpec("zigzag-20-20", 2, seed=1, duration_s=75.0, chunk_boats=1)
    run_ensemble(warm_up, out / "warm-up")  # the kernels loaded from numba's cache, as in a long run
    start = time.perf_counter()
    serial = run_ensemble(spec, out / "serial")
    serial_s = time.perf_counter() - start
    with open_client(LOCAL, 2, quiet=True) as client:
        run_ensemble(warm_up, out / "warm-up", client, force=True)
        start = time.perf_counter()
        rows = run_ensemble(spec, out / "cluster", client)
        cluster_s = time.perf_counter() - start
    files = sorted((out / "cluster").glob("chunk-*.csv"))
    same = all((out / "serial" / f.name).read_bytes() == f.read_bytes() for f in files)
    disk_mb = sum(f.stat().st_size for f in files) / 1e6
    print(f"zigzag ensemble {boats} boats x 75 s in {len(chunks)} chunks of {chunks[0][2]}: this process (numba "
          f"threads) {serial_s:.1f} s, 2-worker local cluster {cluster_s:.1f} s ({boats / cluster_s:.0f} boats/s), "
          f"ratio {serial_s / cluster_s:.2f}x (CPU of the chunks {sum(r['cpu_s'] for r in serial):.1f} s here, "
          f"{sum(r['cpu_s'] for r in rows):.1f} s on the cluster); files identical: {same}; {disk_mb:.1f} MB on "
          f"disk; peak RSS per worker {max(r['peak_rss_mb'] for r in rows):.0f} MB (target < 1 GB); boats with "
          f"all 42 features {sum(r['finite_feature_rows'] for r in rows)}")


def busy_child(boats: int) -> None:
    """(In a child process, its OpenMP wait policy set by the parent.) The ensemble at numba's default thread
    count (one per core), on 1 thread (and on 2 unless that is the default), each the best of 4 interleaved rounds,
    as JSON on stdout."""
    import numba

    from boat_twin.fleet.ensemble import boat_draws
    from boat_twin.vessel.scenarios import Zigzag
    from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

    config = TwinConfig()
    angle = math.radians(20.0)
    zigzag = Zigzag(config.vessel, angle, angle, duration_s=75.0, decision_rate_hz=OUTPUT_RATE_HZ)
    vessels, _ = boat_draws(EnsembleSpec("zigzag-20-20", boats, config=config), 0, boats)
    simulate(config.vessel, zigzag, boats=vessels[:64])  # the threaded kernels loaded
    settings = (("default", numba.get_num_threads()), ("1 thread", 1))
    if numba.get_num_threads() != 2:
        settings += (("2 threads", 2),)
    times = dict.fromkeys((label for label, _ in settings), math.inf)
    for _ in range(4):  # rounds, the settings interleaved: the other jobs' load drifts between runs
        for label, threads in settings:
            numba.set_num_threads(threads)
            start = time.perf_counter()
            simulate(config.vessel, zigzag, boats=vessels)
            times[label] = min(times[label], time.perf_counter() - start)
    print(json.dumps({"default threads": numba.config.NUMBA_NUM_THREADS, "seconds": times}))


def busy(boats: int) -> None:
    """The ensemble beside a busy loop on one core: the default (passive waiting) and OpenMP's own active
    waiting, each in a fresh process (the runtime reads its policy once)."""
    loop = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    limit_s: float | None = None
    try:
        for policy in ("PASSIVE", "ACTIVE"):
            env = {**os.environ, "OMP_WAIT_POLICY": policy}
            start = time.perf_counter()
            try:
                out = subprocess.run([sys.executable, __file__, "--busy-child", str(boats)], env=env, check=True,
                                     capture_output=True, text=True, timeout=limit_s).stdout
            except subprocess.TimeoutExpired:
                print(f"beside a busy loop, OMP_WAIT_POLICY {policy}: not done in {limit_s or 0:.0f} s, 3x the passive "
                      "run's time (stopped)")
                continue
            limit_s = 3.0 * (time.perf_counter() - start)
            measured = json.loads(out.splitlines()[-1])
            times = measured["seconds"]
            best = min(times.values())
            label = "default (passive)" if policy == "PASSIVE" else "active waiting (numba's own default)"
            print(f"beside a busy loop, zigzag ensemble {boats} boats x 75 s, OMP_WAIT_POLICY {label}: "
                  + f"(default: {measured['default threads']} threads) "
                  + ", ".join(f"{k} {v:.2f} s" for k, v in times.items())
                  + f"; default / best {times['default'] / best:.2f} (target <= 1.10)")
    finally:
        loop.kill()
        loop.wait()


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def loopback(paths: list[Path], serial: list[dict], out: Path) -> None:
    """The batch on a scheduler and two workers started as separate processes on 127.0.0.1."""
    from distributed import Client

    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    started = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                 "--port", str(port), "--no-dashboard"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        started += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                      "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    for _ in range(2)]
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
            start = time.perf_counter()
            rows = run_batch(DiagnoseJob(), name_trials(expand_trials(paths)), out, client).rows
            elapsed = time.perf_counter() - start
        print(f"loopback scheduler + 2 worker processes: {len(rows)} recordings in {elapsed:.1f} s, on "
              f"{len({r['worker'] for r in rows})} workers; rows identical to the serial run: "
              f"{findings(rows) == findings(serial)}")
    finally:
        for process in reversed(started):
            process.terminate()
        for process in started:
            process.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=8, help="recordings diagnosed (issue's target: 40)")
    parser.add_argument("--duration", type=float, default=150.0, help="length of each recording, s")
    parser.add_argument("--boats", type=int, default=6000, help="zigzag ensemble size (issue's target: 100000)")
    parser.add_argument("--busy-boats", type=int, default=2000, help="ensemble size beside the busy loop")
    parser.add_argument("--parts", default="batch,loopback,ensemble,busy",
                        help="which parts to run, comma-separated (default: all)")
    parser.add_argument("--busy-child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.busy_child is not None:
        busy_child(args.busy_child)
        return
    print(f"sizes: {args.recordings} recordings of {args.duration:g} s, ensemble {args.boats} boats, busy-loop "
          f"ensemble {args.busy_boats} boats; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    parts = args.parts.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if "batch" in parts or "loopback" in parts:
            (folder / "recordings").mkdir()
            paths = recordings(folder / "recordings", args.recordings, args.duration)
            serial = batch(paths, folder / "batch")
            if "loopback" in parts:
                loopback(paths, serial, folder / "loopback")
        if "ensemble" in parts:
            ensemble(args.boats, folder / "ensemble")
    if "busy" in parts:
        busy(args.busy_boats)
    print(f"load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
