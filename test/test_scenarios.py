"""The named scenarios at a length the user gives: ``random`` draws its commands over the whole run (it held the
600 s draw's last command for the rest of an hour), the same draw as the natural length where they overlap."""

from __future__ import annotations

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.vessel.scenarios import CommandProfile, make_scenario


def test_a_random_hour_changes_its_commands_to_the_end() -> None:
    vessel = TwinConfig().vessel
    hour = make_scenario("random", vessel, np.random.default_rng(4), duration_s=3600.0)
    natural = make_scenario("random", vessel, np.random.default_rng(4))
    assert isinstance(hour, CommandProfile) and isinstance(natural, CommandProfile)
    assert hour.duration_s == 3600.0 and natural.duration_s == 600.0
    assert hour.times_s[-1] > 3600.0 - 25.0  # a new command within the last hold (5-25 s)
    assert np.all(np.diff(hour.times_s) <= 25.0)
    late = hour.values[hour.times_s > 1800.0]
    assert len({tuple(row) for row in late}) > 50  # ~120 draws in the second half hour
    shared = natural.times_s.size
    np.testing.assert_array_equal(hour.times_s[:shared], natural.times_s)
    np.testing.assert_array_equal(hour.values[:shared], natural.values)
