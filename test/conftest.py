"""Suite-wide test configuration: the `ros_nodes` and `slow` markers, the real logs beside the clone, and a
MAVLink log the twin writes itself.

Tests of a module that starts ROS 2 nodes (it imports ``test/rosnodes.py``) are marked ``ros_nodes``. `make test`
runs the rest on every core (pytest-xdist) and these afterwards, apart: a live recorder that shares the cores with
the CPU-bound tests lags the simulated clock and records commands late (test/liverun.py, REAL_TIME_FACTOR).
The node tests mostly wait on their processes, so they run in two pytest-xdist workers of their own, a module
each at a time (``--dist loadfile``: a module's node fixture starts once), each worker on its own ROS domain
(test/rosnodes.py), in the order of :data:`NODE_MODULE_ORDER`.

"""

from __future__ import annotations

import faulthandler
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("BOAT_TWIN_SHARED_DATA", ROOT.parent / "shared" / "data"))
"""Real third-party data beside the clone (never copied into it)."""

BLAS_THREADS = "1"
"""BLAS threads per test process (set before numpy loads OpenBLAS, unless the environment chose): `make test` runs
one pytest worker per core, so threads inside each only oversubscribe the cores (the fleet's workers avoid it the
same way: boat_twin.threads.single_thread_environment). On the busy 2-core machine OpenBLAS's spinning threads cost
20x the CPU of one thread per SVD in the output-error fit's least squares (0.116 s against 0.0056 s for an
18000 x 14 Jacobian), and `boat-twin identify` of the shipped sample took 34.1 s of CPU on the default threads,
15.9 s on one, with the same --json output byte for byte (docs/architecture.md, "A test")."""
for _variable in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, BLAS_THREADS)


NODE_MODULE_ORDER = (
    "test_ros_live.py",
    "test_node_stop.py", "test_node_simulator.py", "test_node_player.py", "test_node_clock.py", "test_node_start.py",
    "test_ros_live_current.py", "test_node_identifier.py", "test_node_shadow.py", "test_node_campaign.py",
)
"""Node modules collected first, in this order (any other module follows): the live staircase (100 s of recording
at 10x real time, then identify and diagnose it) takes one worker while the other runs modules of a node or two
at a time (about 100 s); then the longest (the live manoeuvring run, 70 s) and those that load the cores for
seconds (the identifier fed a trial, bag_player → shadow, the campaign's ten nodes at once): beside the
staircase's recording they kept the recorder from the cores, which stamps commands late (the identifier's
effective mass came out 27 % high, 1735 kg); last the short modules, for the worker that frees first. xdist
hands a worker its next module before the current one ends, so the long ones go early."""


WATCHDOG_GRACE_S = 120.0
"""Time past pytest-timeout's ``--timeout`` after which a test still running is ended by the watchdog below, s."""
WATCHDOG_FILE = "watchdog-stacks.txt"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """A watchdog in C under pytest-timeout (``make test`` passes ``--timeout``), whose SIGALRM fails a hung test
    only where the main thread gets back to Python: a test (setup, call and teardown) still running
    WATCHDOG_GRACE_S later has every thread's stack written to WATCHDOG_FILE in its worker's temporary directory
    (printed at the end of the run) and its worker ended, which pytest-xdist reports as a crash naming the test."""
    limit = item.config.getoption("timeout", None)
    if not limit:
        yield
        return
    path = item.config._tmp_path_factory.getbasetemp() / WATCHDOG_FILE
    deadline_s = float(limit) + WATCHDOG_GRACE_S
    with open(path, "w") as stacks:
        stacks.write(f"{item.nodeid} still running after {deadline_s:g} s:\n")
        stacks.flush()
        faulthandler.dump_traceback_later(deadline_s, exit=True, file=stacks)
        try:
            yield
        finally:
            faulthandler.cancel_dump_traceback_later()
    path.unlink()


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter, config: pytest.Config) -> None:
    for path in sorted(config._tmp_path_factory.getbasetemp().rglob(WATCHDOG_FILE)):
        terminalreporter.write_sep("=", f"watchdog: {path}")
        terminalreporter.write(path.read_text())


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "ros_nodes: starts ROS 2 node processes (run apart from the rest)")
    config.addinivalue_line("markers", "slow: a long study (minutes on 2 cores); `make test` runs it in CI only "
                                       "(CI=true, or `make test SLOW=1`)")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        module = getattr(item, "module", None)
        if module is not None and "rosnodes" in vars(module):
            item.add_marker(pytest.mark.ros_nodes)
    order = {name: rank for rank, name in enumerate(NODE_MODULE_ORDER)}
    items.sort(key=lambda item: order.get(item.path.name, len(order)))  # stable: the order within a module stays


def shared_data(relative: str) -> Path:
    """``../shared/data/relative`` (a file or folder of real third-party data); the test skips where it is absent,
    or fails when ``BOAT_TWIN_REQUIRE_SHARED_DATA=1``."""
    path = SHARED_DATA / relative
    if not path.exists():
        reason = (f"real data not found: {path} (third-party data stays beside the clone in ../shared/data, "
                  "or where BOAT_TWIN_SHARED_DATA says)")
        if os.environ.get("BOAT_TWIN_REQUIRE_SHARED_DATA") == "1":
            pytest.fail(f"{reason}; BOAT_TWIN_REQUIRE_SHARED_DATA=1 requires it")
        pytest.skip(reason)
    return path


@pytest.fixture(scope="session")
def ardusub_logs() -> Path:
    """The ArduSub sample logs (small.tlog, small.BIN) of clydemcqueen/ardusub_log_tools (MIT licence; see
    SOURCE.md there): a real autopilot's logs, for the MAVLink import."""
    return shared_data("ardusub_log_tools")


@pytest.fixture(scope="session")
def own_tlog(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 10 s MAVLink telemetry log written by the twin itself (the MAVLink boat of ``simulate --tlog``), for tests
    that need a .tlog file and not a real autopilot's."""
    from boat_twin.config import TwinConfig
    from boat_twin.link.mavlink_boat import MavlinkBoat
    from boat_twin.twin.live import LiveTwin

    path = tmp_path_factory.mktemp("own_tlog") / "twin.tlog"
    with MavlinkBoat(LiveTwin(TwinConfig(), seed=0, epoch_s=1.7e9), None, tlog=path) as link:
        link.step(500)
    return path


@pytest.fixture(scope="session")
def accel_stop_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 40 s accel-stop trial of the default twin (seed 0) as an MCAP bag without truth topics: the small valid
    input the hostile-input tests start from."""
    import numpy as np

    from boat_twin.config import TwinConfig
    from boat_twin.io.bags import write_bag
    from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
    from boat_twin.vessel.scenarios import make_scenario

    scenario = make_scenario("accel-stop", TwinConfig().vessel, np.random.default_rng(0), duration_s=40.0)
    path = tmp_path_factory.mktemp("bags") / "trial.mcap"
    write_bag(path, trial_messages(run_sea_trial(TwinConfig(), scenario, seed=0), truth=False))
    return path
