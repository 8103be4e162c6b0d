"""The view's channels and the two sinks they go to: a live Foxglove WebSocket server and an MCAP recording, both
of the foxglove-sdk, on a context of their own. Positions as ``foxglove.LocationFix`` (the Map panel), the boat
and the twin as ``foxglove.SceneUpdate`` entities locked to their frames and ``foxglove.FrameTransforms`` from
``map`` (the local ENU frame about the first fix), the innovations and the model as JSON (plots by field name),
verdicts and log lines as ``foxglove.Log``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.frames import quaternion_xyzw
from boat_twin.view.address import require_sdk

FRAME_MAP = "map"
"""The local ENU frame (x east, y north, z up) about the twin's first fix."""
FRAMES = {"boat": "boat", "twin": "twin"}
"""Which → the body frame (x forward, y left, z up) of the measured boat and of the twin's predicted one."""
TOPICS = {
    "boat_fix": "/boat/fix",
    "twin_fix": "/twin/fix",
    "scene": "/scene",
    "transforms": "/tf",
    "innovations": "/twin/innovations",
    "model": "/twin/model",
    "log": "/twin/log",
}
"""Role → topic. ``/twin/innovations/<channel>`` per innovation channel (speed_mps, yaw_rate_radps, ...)."""
COLORS = {"boat": (0.12, 0.47, 0.71, 1.0), "twin": (1.0, 0.5, 0.05, 0.6)}
"""RGBA of the measured boat (blue) and the twin (orange, translucent) on the map and in 3-D."""
SCENE_PERIOD_S = 1.0
"""The scene's entities are sent again this often (stream time), s, for a client that connects late."""
HULL_HEIGHT_M = 0.8
"""Height of the box drawn for the hull, m (the length and beam are the vessel's)."""

INNOVATION_SCHEMA: dict[str, Any] = {
    "title": "boat_twin.Innovation",
    "type": "object",
    "properties": {
        "t_s": {"type": "number", "description": "sample stamp, s"},
        "innovation": {"type": "number", "description": "measured - predicted (SI unit of the channel)"},
        "stdev": {"type": "number", "description": "stated standard deviation sqrt(P + R)"},
        "band_low": {"type": "number", "description": "-2 stdev"},
        "band_high": {"type": "number", "description": "+2 stdev"},
        "measured": {"type": "number"},
        "predicted": {"type": "number"},
    },
}
"""One innovation against its noise band (the Plot panel draws ``.innovation`` between ``.band_low`` and
``.band_high``)."""
MODEL_SCHEMA: dict[str, Any] = {
    "title": "boat_twin.TwinModel",
    "type": "object",
    "properties": {name: {"type": ["number", "null"]} for name in (
        "t_s", "mass_kg", "mass_low_kg", "mass_high_kg", "resistance_factor", "resistance_factor_low",
        "resistance_factor_high", "speed_innovation_ratio", "yaw_rate_innovation_ratio")},
    "additionalProperties": {"type": ["number", "null"]},
}
"""The adapted model: the surge model with its 95 % interval, each live turning coefficient relative to the
configured boat's (``<key>_ratio``, ``_low``, ``_high``), the innovation ratios; null where not known."""


class TwinView:
    """Foxglove channels on their own context, sent to a live server (``address``) and/or an MCAP file
    (``mcap``); times are stream seconds, stamped ``epoch_s`` + t."""

    def __init__(self, address: tuple[str, int] | None = None, mcap: Path | None = None, epoch_s: float = 0.0,
                 hull_m: tuple[float, float] = (6.0, 2.6), name: str = "boat_twin",
                 innovation_channels: tuple[str, ...] = ()) -> None:
        """``innovation_channels``: the innovation channels opened at once (a shadow twin's), with the others,
        before a client can ask for them: a channel the SDK opens while a client is connected can be advertised
        before the server takes a subscription to it ("unknown channel"), and that client never gets it."""
        foxglove = require_sdk()
        from foxglove import channels

        self._fg = foxglove
        self.epoch_s = epoch_s
        self.hull_m = hull_m
        self.context = foxglove.Context()
        self.server: Any = None
        self.host = address[0] if address is not None else ""
        self.writer: Any = None
        if mcap is not None:
            try:
                self.writer = foxglove.open_mcap(mcap, allow_overwrite=True, context=self.context)
            except Exception as err:  # noqa: BLE001 - the SDK's own error type; one line
                raise InputError(f"{mcap}: cannot record the view ({err})") from None
        if address is not None:
            try:
                self.server = foxglove.start_server(name=name, host=address[0], port=address[1],
                                                    context=self.context)
            except Exception as err:  # noqa: BLE001 - a port in use, an address not of this machine: one line
                self.close()
                raise InputError(f"--foxglove {address[0]}:{address[1]}: cannot start the server ({err})") from None
        ctx = self.context
        self._fix = {which: channels.LocationFixChannel(TOPICS[f"{which}_fix"], context=ctx) for which in FRAMES}
        self._scene = channels.SceneUpdateChannel(TOPICS["scene"], context=ctx)
        self._tf = channels.FrameTransformsChannel(TOPICS["transforms"], context=ctx)
        self._log = channels.LogChannel(TOPICS["log"], context=ctx)
        self._model = foxglove.Channel(TOPICS["model"], schema=MODEL_SCHEMA, context=ctx)
        self._innovations: dict[str, Any] = {}
        for channel in innovation_channels:
            self._innovation_channel(channel)
        self._next_scene_s = -math.inf

    @property
    def url(self) -> str | None:
        """ws://HOST:PORT of the live server (the port it bound: port 0 picks a free one); None without one."""
        if self.server is None:
            return None
        host = self.host if ":" not in self.host else f"[{self.host}]"
        return f"ws://{host}:{self.server.port}"

    # --- messages ----------------------------------------------------------------------------------------
    def _time(self, t_s: float) -> tuple[Any, int]:
        ns = int(round((self.epoch_s + t_s) * 1e9))
        return self._fg.messages.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000), max(ns, 0)

    def fix(self, which: str, t_s: float, lat_deg: float, lon_deg: float, alt_m: float = 0.0,
            yaw_rad: float = math.nan, stdev_m: tuple[float, float] = (math.nan, math.nan)) -> None:
        """A position of the measured boat (``which`` "boat") or of the twin ("twin") on the map; ``yaw_rad`` ENU
        (counter-clockwise from east), ``stdev_m`` the horizontal and vertical standard deviations when known."""
        m = self._fg.messages
        stamp, ns = self._time(t_s)
        known = all(math.isfinite(s) for s in stdev_m)
        horizontal, vertical = (stdev_m[0] ** 2, stdev_m[1] ** 2) if known else (0.0, 0.0)
        self._fix[which].log(m.LocationFix(
            timestamp=stamp, frame_id=FRAMES[which], latitude=lat_deg, longitude=lon_deg, altitude=alt_m,
            position_covariance=[horizontal, 0.0, 0.0, 0.0, horizontal, 0.0, 0.0, 0.0, vertical],
            position_covariance_type=(m.LocationFixPositionCovarianceType.DiagonalKnown if known
                                      else m.LocationFixPositionCovarianceType.Unknown),
            heading=(math.pi / 2.0 - yaw_rad) % (2.0 * math.pi) if math.isfinite(yaw_rad) else None,
            color=m.Color(r=COLORS[which][0], g=COLORS[which][1], b=COLORS[which][2], a=COLORS[which][3]),
        ), log_time=ns)

    def poses(self, t_s: float, poses: dict[str, tuple[float, float, float]]) -> None:
        """The frames of ``poses`` (which → east m, north m, ENU yaw rad) in ``map``; the hulls drawn in them."""
        m = self._fg.messages
        stamp, ns = self._time(t_s)
        transforms, shown = [], []
        for which, (east, north, yaw) in poses.items():
            if not all(math.isfinite(x) for x in (east, north, yaw)):
                continue
            shown.append(which)
            q = quaternion_xyzw(np.zeros(1), np.zeros(1), np.array([yaw]))[0].tolist()
            transforms.append(m.FrameTransform(
                timestamp=stamp, parent_frame_id=FRAME_MAP, child_frame_id=FRAMES[which],
                translation=m.Vector3(x=east, y=north, z=0.0), rotation=m.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])))
        if not transforms:
            return
        self._tf.log(m.FrameTransforms(transforms=transforms), log_time=ns)
        if t_s >= self._next_scene_s:
            self._next_scene_s = t_s + SCENE_PERIOD_S
            self._scene.log(m.SceneUpdate(entities=[self._hull(which, stamp) for which in shown]), log_time=ns)

    def _hull(self, which: str, stamp: Any) -> Any:
        """The hull as a box with an arrow along its heading, locked to its body frame."""
        m = self._fg.messages
        length, beam = self.hull_m
        color = m.Color(r=COLORS[which][0], g=COLORS[which][1], b=COLORS[which][2], a=COLORS[which][3])
        identity = m.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        return m.SceneEntity(
            timestamp=stamp, frame_id=FRAMES[which], id=which, frame_locked=True,
            cubes=[m.CubePrimitive(pose=m.Pose(position=m.Vector3(x=0.0, y=0.0, z=HULL_HEIGHT_M / 2),
                                               orientation=identity),
                                   size=m.Vector3(x=length, y=beam, z=HULL_HEIGHT_M), color=color)],
            arrows=[m.ArrowPrimitive(pose=m.Pose(position=m.Vector3(x=length / 2, y=0.0, z=HULL_HEIGHT_M),
                                                 orientation=identity),
                                     shaft_length=length / 2, shaft_diameter=0.2, head_length=1.0,
                                     head_diameter=0.6, color=color)],
            texts=[m.TextPrimitive(pose=m.Pose(position=m.Vector3(x=0.0, y=0.0, z=2 * HULL_HEIGHT_M),
                                               orientation=identity),
                                   billboard=True, font_size=14.0, scale_invariant=True, color=color,
                                   text=which)])

    def innovation(self, t_s: float, channel: str, measured: float, predicted: float, stdev: float,
                   value: float) -> None:
        """One innovation (``value`` = measured − predicted, angles wrapped) with its ±2σ band."""
        _, ns = self._time(t_s)
        self._innovation_channel(channel).log(_json({
            "t_s": t_s, "innovation": value, "stdev": stdev, "band_low": -2.0 * stdev, "band_high": 2.0 * stdev,
            "measured": measured, "predicted": predicted}), log_time=ns)

    def _innovation_channel(self, channel: str) -> Any:
        """The Foxglove channel of one innovation channel (opened on first use)."""
        if channel not in self._innovations:
            self._innovations[channel] = self._fg.Channel(f"{TOPICS['innovations']}/{channel}",
                                                          schema=INNOVATION_SCHEMA, context=self.context)
        return self._innovations[channel]

    def model(self, t_s: float, values: dict[str, float | None]) -> None:
        """The adapted model (:data:`MODEL_SCHEMA`)."""
        _, ns = self._time(t_s)
        self._model.log(_json({"t_s": t_s, **values}), log_time=ns)

    def log(self, t_s: float, text: str, level: str = "Info") -> None:
        """One log entry (``level``: Debug, Info, Warning, Error)."""
        m = self._fg.messages
        stamp, ns = self._time(t_s if math.isfinite(t_s) else 0.0)
        self._log.log(m.Log(timestamp=stamp, level=getattr(m.LogLevel, level), message=text, name="boat_twin"),
                      log_time=ns)

    def close(self) -> None:
        """Finish the MCAP and stop the server (idempotent)."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        if self.server is not None:
            self.server.stop()
            self.server = None


def _json(values: dict[str, Any]) -> dict[str, Any]:
    """``values`` with non-finite numbers as null (JSON has no NaN)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()}
