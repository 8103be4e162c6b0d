"""Helpers of the node tests: boat_twin nodes as separate processes, an in-process probe, wall-clock deadlines.

Every process of a test session shares one private ROS_DOMAIN_ID with localhost-only discovery, so parallel
sessions on one machine (or a developer's own ROS graph) never see each other's topics; pytest-xdist workers of
one run get distinct domains. The nodes' ROS logs go to a ROS_HOME of this test process, removed when it exits
(unless ROS_HOME is set).
"""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def private_domain_id() -> int:
    """A ROS domain for this test process within 1-101 (the ids whose ports stay below Linux's ephemeral range,
    per the ROS 2 "domain ID" guide; 0 is left to a developer's own graph): one per pytest-xdist worker of a run,
    a run chosen by its id (or this process's when not under xdist)."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    run = zlib.crc32(os.environ.get("PYTEST_XDIST_TESTRUNUID", str(os.getpid())).encode())
    return 1 + (run % (101 // workers)) * workers + worker


os.environ["ROS_DOMAIN_ID"] = str(private_domain_id())
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
if "ROS_HOME" not in os.environ:
    os.environ["ROS_HOME"] = tempfile.mkdtemp(prefix="boat_twin_ros_")
    atexit.register(shutil.rmtree, os.environ["ROS_HOME"], ignore_errors=True)

import rclpy  # noqa: E402  (the environment above must be set first)
from rclpy.executors import SingleThreadedExecutor  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
START_TIMEOUT_S = 90.0
"""Wall-clock time a node gets to come up (imports and the first JIT compile on a loaded 2-core machine)."""


def executable(name: str) -> str:
    """The console script ``name`` installed next to this Python (the venv's bin/)."""
    path = Path(sys.executable).parent / name
    return str(path) if path.exists() else (shutil.which(name) or name)


class NodeProcess:
    """A node started as its console script with ``--ros-args`` (``remaps``: ``-r`` pairs such as
    ``{"__ns": "/boat1"}``); stdout and stderr kept in files."""

    def __init__(self, name: str, params: dict[str, Any] | None = None, log_dir: Path | None = None,
                 remaps: dict[str, str] | None = None) -> None:
        args = [executable(name), "--ros-args"]
        for key, value in (remaps or {}).items():
            args += ["-r", f"{key}:={value}"]
        for key, value in (params or {}).items():
            text = str(value).lower() if isinstance(value, bool) else str(value)
            args += ["-p", f"{key}:={text}"]
        self.log_dir = Path(log_dir or os.environ["ROS_HOME"])
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.stderr_path = self.log_dir / f"{name}.{os.getpid()}.{time.monotonic_ns()}.err"
        with self.stderr_path.open("w") as stderr:
            self.process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=stderr)

    def stop(self, timeout_s: float = 20.0) -> int:
        """SIGINT (Ctrl-C), then wait; killed if it does not end. Returns the exit code."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode

    def wait(self, timeout_s: float) -> int:
        """Wait for the process to end by itself; returns its exit code."""
        return self.process.wait(timeout_s)

    @property
    def stderr(self) -> str:
        """What the node wrote on stderr so far."""
        return self.stderr_path.read_text()


@contextmanager
def nodes(*specs: tuple[Any, ...], log_dir: Path | None = None) -> Iterator[list[NodeProcess]]:
    """Start each ``(executable, parameters[, remaps])``; stop them all however the test ends."""
    started: list[NodeProcess] = []
    try:
        for name, params, *remaps in specs:
            started.append(NodeProcess(name, params, log_dir, *remaps))
        yield started
    finally:
        for proc in started:
            proc.stop()


class Probe:
    """An in-process rclpy node that subscribes, publishes and waits on wall-clock deadlines."""

    def __init__(self, name: str = "probe", **node_kwargs: Any) -> None:
        rclpy.init()
        self.node = rclpy.create_node(name, **node_kwargs)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)

    def spin_until(self, done: Callable[[], bool], timeout_s: float, step: Callable[[], None] | None = None) -> bool:
        """Spin until ``done()`` or the deadline (wall clock); ``step()`` runs between spins. Returns done()."""
        deadline = time.monotonic() + timeout_s
        while not done() and time.monotonic() < deadline:
            if step is not None:
                step()
            self.executor.spin_once(timeout_sec=0.02)
        return bool(done())

    def spin_for(self, duration_s: float, step: Callable[[], None] | None = None) -> None:
        """Spin for ``duration_s`` of wall time."""
        self.spin_until(lambda: False, duration_s, step)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown()


@contextmanager
def probe(name: str = "probe", **node_kwargs: Any) -> Iterator[Probe]:
    """A :class:`Probe` shut down however the test ends."""
    p = Probe(name, **node_kwargs)
    try:
        yield p
    finally:
        p.close()

