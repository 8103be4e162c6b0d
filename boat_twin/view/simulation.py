"""A simulated boat in the view: the simulation is the twin, so its true track goes to ``/twin/fix`` and its hull
to the ``twin`` frame, and what its GNSS receiver measured to ``/boat/fix``. ``simulate --foxglove`` replays a
batch run (:func:`show_trial`); the ``simulator`` node and ``simulate --mavlink --foxglove`` call
:meth:`SimulationView.tick` each tick."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pymap3d

from boat_twin.frames import wrap_pi
from boat_twin.io import messages
from boat_twin.view.stream import TwinView

if TYPE_CHECKING:
    from boat_twin.config import TwinConfig
    from boat_twin.twin.sea_trial import CompactTrial
    from boat_twin.view.observer import Pacer


class SimulationView:
    """The true state and the GNSS fixes of one simulated boat, to ``view``."""

    def __init__(self, view: TwinView, config: TwinConfig) -> None:
        self.view = view
        g = config.gnss
        self.origin = (g.origin_lat_deg, g.origin_lon_deg, g.origin_alt_m)
        self.stdev_m = (g.horizontal_stdev_m, g.vertical_stdev_m)

    def truth(self, t_s: float, east_m: float, north_m: float, yaw_rad: float) -> None:
        """The boat's true pose (ENU about the GNSS origin)."""
        lat, lon, alt = pymap3d.enu2geodetic(east_m, north_m, 0.0, *self.origin)
        self.view.fix("twin", t_s, float(lat), float(lon), float(alt), yaw_rad)
        self.view.poses(t_s, {"twin": (east_m, north_m, float(wrap_pi(np.array(yaw_rad))))})

    def tick(self, items: list[messages.Message], t_s: float, state: np.ndarray) -> None:
        """One live tick (the simulator node, ``simulate --mavlink``): its GNSS fixes among ``items`` and the
        boat's true pose at ``t_s`` from ``state`` (the twin's state row: east m, north m, yaw rad first)."""
        self.messages(items)
        east, north, yaw = (float(x) for x in state[:3])
        self.truth(t_s, east, north, yaw)

    def messages(self, items: list[messages.Message]) -> None:
        """The GNSS fixes among one tick's messages (topic, stamp ns, message)."""
        for topic, stamp_ns, msg in items:
            if topic == messages.TOPIC_GNSS_FIX and math.isfinite(msg.latitude):
                self.view.fix("boat", stamp_ns * 1e-9, msg.latitude, msg.longitude, msg.altitude,
                              stdev_m=self.stdev_m)


def show_trial(view: TwinView, trial: CompactTrial, pacer: Pacer) -> None:
    """A batch simulation replayed into ``view`` at the pacer's speed, truth and fixes in time order."""
    from boat_twin.twin.sea_trial import compact_trial_messages

    sim = SimulationView(view, trial.config)
    truth = trial.truth
    i = 0
    for item in compact_trial_messages(trial, truth=False):
        t_s = item[1] * 1e-9
        while i < truth.t_s.size and truth.t_s[i] <= t_s:
            pacer.wait(float(truth.t_s[i]))
            sim.truth(float(truth.t_s[i]), float(truth.east_m[i]), float(truth.north_m[i]), float(truth.yaw_rad[i]))
            i += 1
        sim.messages([item])
    for k in range(i, truth.t_s.size):
        pacer.wait(float(truth.t_s[k]))
        sim.truth(float(truth.t_s[k]), float(truth.east_m[k]), float(truth.north_m[k]), float(truth.yaw_rad[k]))
