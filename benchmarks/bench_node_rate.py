"""The simulator node faster than real time: the real-time factor achieved on /clock, against the one asked.

Run: make bench   (or: .venv/bin/python benchmarks/bench_node_rate.py [seconds per factor])
The simulator runs as its console script (publish_clock:=true, real_time_factor 10, 50, 100) with a subscriber
on every sensor topic (what a recorder costs it), then at 50 with subscribers on robot_localization's three
topics only (the simulator makes no message nobody subscribes to). The factor achieved is the simulated time
advanced on /clock per wall second, over a window after start-up. The reference, measured in the same run, is
one tick's CPU time in-process without ROS (dynamics, sensor models, messages and their CDR bytes): 100 ms /
that cost is the factor one core could give if publishing were free. Also printed: the simulator's CPU share
(from /proc), the ceiling that share implies (simulated seconds per CPU second of the simulator: the factor it
would reach with a whole core; on a machine shared with other jobs the achieved factor falls below the asked
one when the simulator gets less CPU than asked / ceiling), the machine's load average, and the simulator's
own /diagnostics figures (tick overruns, clock slowed). Printed, not asserted.
"""

import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))

import rosnodes  # noqa: E402  (sets a private ROS domain before rclpy loads)
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402

from boat_twin.config import TwinConfig  # noqa: E402
from boat_twin.io import messages  # noqa: E402
from boat_twin.nodes.conventions import message_class  # noqa: E402
from boat_twin.twin.live import LiveTwin  # noqa: E402

FACTORS = (10.0, 50.0, 100.0)
EKF_TOPICS = (messages.TOPIC_IMU_DATA, messages.TOPIC_GNSS_FIX, messages.TOPIC_GNSS_VEL_COV)
"""What a robot_localization set-up subscribes to (config/ros/robot_localization.yaml)."""


def tick_cost_ms(n: int = 2000) -> float:
    """In-process CPU time of one tick with its messages restamped and serialized, ms (best of 3; CPU time, so
    that other jobs on the machine do not count)."""
    twin = LiveTwin(TwinConfig(), seed=0)
    twin.set_command(0, 500.0)
    twin.set_command(1, 500.0)
    best = float("inf")
    for _ in range(3):
        start = time.process_time()
        for _ in range(n // 3):
            for topic, _stamp, msg in messages.restamped(twin.tick(), 0):
                messages.serialize(msg, messages.TOPICS[topic])
        best = min(best, (time.process_time() - start) / (n // 3) * 1e3)
    return best


def cpu_s(pid: int) -> float:
    """User + system CPU time of a process, s."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(factor: float, window_s: float, topics: tuple[str, ...] | None = None) -> dict:
    """The run at ``factor`` with a subscriber on ``topics`` (None: every sensor topic)."""
    params = {"publish_clock": True, "real_time_factor": factor, "seed": 1}
    with rosnodes.nodes(("simulator", params)) as (sim,), rosnodes.probe("bench") as probe:
        clocks: list[tuple[float, float]] = []
        diagnostics: dict[str, dict] = {}
        probe.node.create_subscription(Clock, "/clock", lambda m: clocks.append(
            (time.monotonic(), m.clock.sec + m.clock.nanosec * 1e-9)), QoSProfile(depth=10))
        probe.node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: diagnostics.update(
            {s.name: {kv.key: json.loads(kv.value) for kv in s.values} for s in m.status}), 10)
        for topic, msgtype in {**messages.TOPICS, **messages.LIVE_TOPICS}.items():
            cls = message_class(msgtype)
            listened = topic not in messages.COMMAND_TOPICS if topics is None else topic in topics
            if cls is not None and listened:
                probe.node.create_subscription(cls, topic, lambda _raw: None, QoSProfile(depth=10), raw=True)
        assert probe.spin_until(lambda: len(clocks) > 20, rosnodes.START_TIMEOUT_S), "no /clock"
        probe.spin_for(2.0)  # warm-up
        first, cpu0 = clocks[-1], cpu_s(sim.process.pid)
        probe.spin_for(window_s)
        last, cpu1 = clocks[-1], cpu_s(sim.process.pid)
    status = diagnostics.get("simulator: simulation", {})
    return {"achieved": (last[1] - first[1]) / (last[0] - first[0]), "cpu": (cpu1 - cpu0) / (last[0] - first[0]),
            "overruns": status.get("tick_overruns"), "slowed_s": status.get("clock_slowed_s")}


def main() -> None:
    window_s = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    cost = tick_cost_ms()
    print(f"reference: one tick in-process (no ROS) {cost:.2f} ms of CPU -> at most {100.0 / cost:.0f}x on one core")
    print(f"{'subscribers':>12} {'asked':>6} {'achieved':>9} {'ratio':>6} {'sim CPU':>8} {'ceiling':>8} {'load':>5} "
          f"{'overruns':>9} {'slowed s':>9}")
    runs = [("every topic", factor, None) for factor in FACTORS] + [("ekf's three", 50.0, EKF_TOPICS)]
    for label, factor, topics in runs:
        r = measure(factor, window_s, topics)
        print(f"{label:>12} {factor:6.0f} {r['achieved']:9.1f} {r['achieved'] / factor:6.2f} {r['cpu']:8.0%} "
              f"{r['achieved'] / r['cpu']:7.0f}x {os.getloadavg()[0]:5.1f} {r['overruns']!s:>9} {r['slowed_s']!s:>9}")


if __name__ == "__main__":
    main()
