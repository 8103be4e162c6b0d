"""The live twin's timing on made-up clocks: the command watchdog, the faster-than-real-time schedule."""

from __future__ import annotations

import pytest

from boat_twin.twin.pacing import DEFAULT_COMMAND_TIMEOUT_S, CommandWatchdog, RateMeter, TickSchedule


def test_the_watchdog_lapses_once_per_silence_and_rearms_on_a_command() -> None:
    dog = CommandWatchdog(1.0)
    assert not dog.check(100.0) and dog.age_s(100.0) is None  # never commanded: nothing to stop
    dog.heard(10.0)
    assert not dog.check(10.9)
    assert dog.check(11.0) and dog.lapsed  # at the timeout
    assert not dog.check(11.1) and not dog.check(50.0)  # once per lapse
    dog.heard(60.0)
    assert not dog.lapsed and not dog.check(60.5)
    assert dog.check(61.2) and dog.lapses == 2
    assert dog.age_s(61.5) == pytest.approx(1.5)
    with pytest.raises(ValueError):
        CommandWatchdog(0.0)
    assert DEFAULT_COMMAND_TIMEOUT_S == 1.0


def test_the_schedule_runs_the_ticks_that_are_due_and_catches_up_a_late_wake_up() -> None:
    schedule = TickSchedule(tick_s=0.1, factor=50.0)  # a tick every 2 ms of wall time
    assert schedule.due(0.0) == 1
    schedule.ran(1)
    assert schedule.due(0.001) == 0  # the next is at 2 ms
    assert schedule.due(0.002) == 1
    schedule.ran(1)
    assert schedule.due(0.0105) == 4  # woke 6.5 ms late: ticks 2, 3, 4, 5 are due
    schedule.ran(4)
    assert schedule.late_ticks == 3 and schedule.slowed_s == 0.0
    assert schedule.ticks * schedule.tick_s / 0.0105 == pytest.approx(57.1, abs=0.1)


def test_a_long_stall_slows_the_clock_instead_of_a_burst() -> None:
    schedule = TickSchedule(tick_s=0.1, factor=50.0, max_catch_up_s=0.05)
    schedule.ran(schedule.due(0.0))
    n = schedule.due(1.0)  # one wall second without the CPU: 500 ticks behind
    assert n == 26  # 50 ms of catch-up (25 ticks) and the one due now
    assert schedule.slowed_s == pytest.approx(1.0 - 0.002 - 0.05)
    schedule.ran(n)
    assert schedule.due(1.0) == 0 and schedule.due(1.002) == 1  # back on a schedule moved by the stall


def test_a_restarted_schedule_does_not_catch_up_the_pause() -> None:
    schedule = TickSchedule(tick_s=0.1, factor=10.0)
    schedule.ran(schedule.due(0.0))
    schedule.restart()  # paused here, resumed 30 s later
    assert schedule.due(30.0) == 1
    schedule.ran(1)
    assert schedule.due(30.005) == 0 and schedule.slowed_s == 0.0 and schedule.late_ticks == 0


def test_the_rate_meter_gives_simulated_over_wall_seconds() -> None:
    meter = RateMeter()
    assert meter.factor(10.0, 0.0) is None
    assert meter.factor(12.0, 100.0) == pytest.approx(50.0)
    assert meter.factor(12.0, 120.0) is None  # no wall time passed
