"""Timing of a live twin: when to tick (the wall-clock schedule of a faster-than-real-time run), how well the
schedule was kept, and the command watchdog. Pure Python on given times, so front ends (the simulator node,
a MAVLink link) share it and tests drive it with made-up clocks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

DEFAULT_COMMAND_TIMEOUT_S = 1.0
"""Command watchdog default, s: the thruster plugin of VRX (the Virtual RobotX simulator, whose thrust-in-N
convention the command topics follow) zeroes a thruster 1.0 s after its last command (``cmdTimeout``). That is
ten ticks of the 10 Hz twin and four of the ``player``'s re-sends (every 0.25 s), so three lost messages in a
row do not stop the boat."""
MAX_CATCH_UP_S = 0.05
"""Wall-clock lag behind the schedule that a faster-than-real-time run catches up by ticking back to back, s;
beyond it the schedule moves (the simulated clock slows down rather than skip ticks or burst)."""


class CommandWatchdog:
    """Says when the commands have gone stale: nothing heard for ``timeout_s`` since the last one.

    Armed by the first command (a boat nobody has commanded is already at zero thrust); :meth:`check` is True
    exactly once per lapse, at the first check after the timeout, so the caller zeroes the thrust and warns once.
    A new command re-arms it. Times are seconds on one clock of the caller's choice (the simulator's).
    """

    def __init__(self, timeout_s: float) -> None:
        if not timeout_s > 0.0:
            raise ValueError(f"timeout_s must be > 0, got {timeout_s}")
        self.timeout_s = timeout_s
        self.last_s: float | None = None
        self.lapsed = False
        self.lapses = 0

    def heard(self, now_s: float) -> None:
        """A command arrived at ``now_s``."""
        self.last_s = now_s
        self.lapsed = False

    def age_s(self, now_s: float) -> float | None:
        """Seconds since the last command (None: none yet)."""
        return None if self.last_s is None else now_s - self.last_s

    def check(self, now_s: float) -> bool:
        """True when the commands lapse at ``now_s`` (once per lapse)."""
        age = self.age_s(now_s)
        if age is None or self.lapsed or age < self.timeout_s:
            return False
        self.lapsed = True
        self.lapses += 1
        return True


@dataclass
class TickSchedule:
    """Ticks of ``tick_s`` simulated seconds run ``factor`` times faster than the wall clock.

    :meth:`due` says how many ticks to run at a wall time: those whose scheduled wall time has come. When the
    caller falls behind by more than ``max_catch_up_s`` of wall time (a busy machine), the schedule is moved
    so that the simulated clock slows down instead of running a long burst; :attr:`slowed_s` adds up the wall
    time lost that way and :attr:`late_ticks` counts the ticks run back to back to catch up.
    """

    tick_s: float
    factor: float
    max_catch_up_s: float = MAX_CATCH_UP_S
    start_wall_s: float | None = None
    ticks: int = 0
    late_ticks: int = 0
    slowed_s: float = 0.0

    @property
    def wall_period_s(self) -> float:
        """Wall time between ticks, s."""
        return self.tick_s / self.factor

    def due(self, wall_s: float) -> int:
        """Number of ticks to run now (0 or more); the caller runs them and then calls :meth:`ran`."""
        if self.start_wall_s is None:
            self.start_wall_s = wall_s
            return 1
        behind_s = wall_s - self.start_wall_s - self.ticks * self.wall_period_s
        if behind_s > self.max_catch_up_s:
            self.slowed_s += behind_s - self.max_catch_up_s
            self.start_wall_s += behind_s - self.max_catch_up_s
            behind_s = self.max_catch_up_s
        n = math.floor(behind_s / self.wall_period_s + 1e-9) + 1 if behind_s >= 0.0 else 0
        self.late_ticks += max(n - 1, 0)
        return n

    def ran(self, n: int) -> None:
        """``n`` ticks were run."""
        self.ticks += n

    def restart(self) -> None:
        """Start the schedule afresh at the next :meth:`due` (after a pause or a reset: nothing to catch up)."""
        self.start_wall_s = None
        self.ticks = 0


class RateMeter:
    """Real-time factor achieved over the last window: simulated seconds advanced per wall second."""

    def __init__(self) -> None:
        self._mark: tuple[float, float] | None = None

    def factor(self, wall_s: float, sim_s: float) -> float | None:
        """Simulated over wall time since the previous call (None on the first call or no wall time)."""
        mark, self._mark = self._mark, (wall_s, sim_s)
        if mark is None or wall_s <= mark[0]:
            return None
        return (sim_s - mark[1]) / (wall_s - mark[0])
