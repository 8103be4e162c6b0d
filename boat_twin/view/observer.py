"""A live twin (:class:`~boat_twin.shadow.session.Shadow`) shown in a :class:`~boat_twin.view.stream.TwinView`,
read from outside: its innovations through its ``on_innovation`` hook (chained to any already set), its state, model
and latest diagnosis through their public attributes after each sample. The front ends (``follow``, the ``shadow``
node) call :meth:`ShadowView.sample` after each :meth:`Shadow.add` and :meth:`ShadowView.log_line` with each log
line."""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import pymap3d

from boat_twin.shadow.turning import LIVE_KEYS
from boat_twin.view.stream import TwinView

if TYPE_CHECKING:
    from boat_twin.shadow.rolling import RollingResult
    from boat_twin.shadow.session import Shadow
    from boat_twin.shadow.sync import Innovation

POSE_PERIOD_S = 0.1
"""The frames and the twin's state are sent at most this often (stream time), s."""
MODEL_PERIOD_S = 1.0
"""The model is sent this often (stream time), s."""


class Pacer:
    """Holds a replay to ``speed`` stream seconds per wall second (0: as fast as it runs); never sleeps to catch
    up a replay that is behind, and starts afresh when the stream's clock jumps."""

    def __init__(self, speed: float) -> None:
        self.speed = speed
        self._start: tuple[float, float] | None = None

    def wait(self, t_s: float) -> None:
        """Sleep until stream time ``t_s`` is due."""
        if self.speed <= 0.0 or not math.isfinite(t_s):
            return
        now = time.monotonic()
        if self._start is None or t_s < self._start[0]:
            self._start = (t_s, now)
        delay = self._start[1] + (t_s - self._start[0]) / self.speed - now
        if delay > 0.0:
            time.sleep(delay)


class ShadowView:
    """Sends what a Shadow measures, predicts and finds to ``view`` (see the module docstring)."""

    def __init__(self, view: TwinView, pacer: Pacer | None = None) -> None:
        self.view = view
        self.pacer = pacer
        self.shadow: Shadow | None = None
        self._position: dict[str, tuple[float, float]] = {}
        """The latest GNSS fix's east/north innovation pair: channel → (t_s, predicted m)."""
        self._boat: tuple[float, float, float] = (math.nan, math.nan, math.nan)
        """The boat's measured east m, north m (the latest fix) and ENU yaw rad (the latest IMU heading)."""
        self._next_pose_s = -math.inf
        self._next_model_s = -math.inf
        self._runs = 0

    def attach(self, shadow: Shadow) -> None:
        """Watch ``shadow`` (its innovation hook chained: one set before keeps being called)."""
        self.shadow = shadow
        before = shadow.on_innovation

        def both(item: Innovation) -> None:
            if before is not None:
                before(item)
            self.innovation(item)

        shadow.on_innovation = both

    def log_line(self, line: str) -> None:
        """A line of the Shadow's log, at the twin's time."""
        t_s = self.shadow.twin.t_s if self.shadow is not None else 0.0
        self.view.log(t_s, line)

    def sample(self, kind: str, t_s: float, values: tuple[float, ...]) -> None:
        """After the Shadow took one sample: the measured fix, the frames, the model and a new diagnosis."""
        shadow = self.shadow
        if shadow is None:
            return
        if self.pacer is not None:
            self.pacer.wait(t_s)
        if kind == "gnss_fix" and all(math.isfinite(v) for v in values[:2]):
            gnss = shadow.twin.config.gnss
            self.view.fix("boat", t_s, values[0], values[1], values[2] if len(values) > 2 else 0.0,
                          self._boat[2], (gnss.horizontal_stdev_m, gnss.vertical_stdev_m))
        twin_t = shadow.twin.t_s
        if math.isfinite(twin_t) and twin_t >= self._next_pose_s and shadow.twin.state is not None:
            self._next_pose_s = twin_t + POSE_PERIOD_S
            east, north, yaw = (float(x) for x in shadow.twin.state[:3])
            self.view.poses(twin_t, {"boat": self._boat, "twin": (east, north, yaw)})
        if math.isfinite(twin_t) and twin_t >= self._next_model_s:
            self._next_model_s = twin_t + MODEL_PERIOD_S
            self.view.model(twin_t, model_values(shadow))
        latest = shadow.rolling.latest
        if shadow.rolling.runs != self._runs and latest is not None:
            self._runs = shadow.rolling.runs
            text, level = verdict(latest)
            self.view.log(latest.t_s, text, level)

    def innovation(self, item: Innovation) -> None:
        """One innovation to its plot; a fix's east/north pair also places the twin's predicted fix on the map."""
        self.view.innovation(item.t_s, item.channel, item.measured, item.predicted, item.stdev, item.value)
        if item.channel == "heading_rad":
            self._boat = (self._boat[0], self._boat[1], item.measured)
        if item.channel not in ("east_m", "north_m"):
            return
        self._position[item.channel] = (item.t_s, item.predicted)
        if item.channel == "east_m":
            self._boat = (item.measured, self._boat[1], self._boat[2])
            return
        self._boat = (self._boat[0], item.measured, self._boat[2])
        east = self._position.get("east_m")
        twin = self.shadow.twin if self.shadow is not None else None
        if east is None or east[0] != item.t_s or twin is None or twin.origin is None:
            return
        lat, lon, alt = pymap3d.enu2geodetic(east[1], item.predicted, 0.0, *twin.origin)
        yaw = float(twin.state[2]) if twin.state is not None else math.nan
        self.view.fix("twin", item.t_s, float(lat), float(lon), float(alt), yaw)

    def finish(self) -> None:
        """The last model and verdict (end of a recording)."""
        shadow = self.shadow
        if shadow is not None and math.isfinite(shadow.twin.t_s):
            self.view.model(shadow.twin.t_s, model_values(shadow))


def model_values(shadow: Shadow) -> dict[str, float | None]:
    """The adapted model as the view's ``/twin/model`` (:data:`~boat_twin.view.stream.MODEL_SCHEMA`)."""
    surge = shadow.adapter.current
    values: dict[str, float | None] = {
        "mass_kg": float(surge.mass_kg), "mass_low_kg": float(surge.mass_ci95_kg[0]),
        "mass_high_kg": float(surge.mass_ci95_kg[1]), "resistance_factor": float(surge.resistance_factor),
        "resistance_factor_low": float(surge.factor_ci95[0]), "resistance_factor_high": float(surge.factor_ci95[1]),
        "speed_innovation_ratio": _finite(shadow.speed_ratio()),
        "yaw_rate_innovation_ratio": _finite(shadow.innovation_ratio("yaw_rate_radps")),
    }
    turning: dict[str, Any] = shadow.turning.to_dict(shadow.twin.config.vessel)
    for key in LIVE_KEYS:
        ratio = turning["relative_to_configured"][key]
        configured = turning["coefficients"][key] / ratio if ratio else math.nan
        low, high = turning["ci95"].get(key, (math.nan, math.nan))
        values[f"{key}_ratio"] = _finite(ratio)
        values[f"{key}_ratio_low"] = _finite(low / configured)
        values[f"{key}_ratio_high"] = _finite(high / configured)
    return values


def verdict(result: RollingResult) -> tuple[str, str]:
    """A rolling diagnosis as one log line and its level (Warning when it names a cause or holds unexplained)."""
    span = f"{result.span_s[0]:.0f}-{result.span_s[1]:.0f} s"
    if result.error:
        return f"diagnosis {span}: not run ({result.error})", "Info"
    if result.unexplained:
        return (f"diagnosis {span}: unexplained: the twin misfits and no catalogue cause explains it", "Warning")
    if result.causes:
        named = ", ".join(f"{c.name} {c.size:.3g} {c.size_unit}" for c in result.causes)
        return f"diagnosis {span}: {named}", "Warning"
    withheld = (f" (withheld: {', '.join(c.name for c in result.withheld)})" if result.withheld else "")
    state = "misfit, structure left" if result.structure_left else "no cause"
    return f"diagnosis {span}: {state}{withheld}", "Info"


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
