"""The saved Foxglove layout of the twin's view (config/foxglove/twin_layout.json), built with the foxglove-sdk's
layouts API from the view's own topic names, so that the two cannot drift apart (``test_view.py`` checks the
saved file against it). Regenerate: ``.venv/bin/python -m boat_twin.view.layout > config/foxglove/twin_layout.json``.

Left, top to bottom: the Map (the boat's measured fixes, blue, and the twin's predicted ones, orange, the map
following the boat) and the 3-D scene (the two hulls in the local ENU frame ``map``, the camera following the
boat). Right: the speed innovations between their ±2σ band, the yaw-rate innovations between theirs, the mass
with its 95 % interval, the resistance factor and the turning coefficients relative to the configured boat with
the intervals, and the Log of the diagnosis verdicts and the twin's log lines."""

from __future__ import annotations

import json
from typing import Any

from boat_twin.view.address import require_sdk
from boat_twin.view.stream import COLORS, FRAME_MAP, FRAMES, TOPICS

BAND_COLOR = "#7f7f7f"


def _hex(rgba: tuple[float, float, float, float]) -> str:
    return "#" + "".join(f"{round(c * 255):02x}" for c in rgba[:3])


def twin_layout() -> Any:
    """The layout (a ``foxglove.layouts.Layout``)."""
    require_sdk()
    import foxglove.layouts as fl

    from boat_twin.shadow.turning import LIVE_KEYS

    def band(topic: str, label: str) -> Any:
        path = f"{TOPICS['innovations']}/{topic}"
        return fl.PlotPanel(title=label, config=fl.PlotConfig(paths=[
            fl.PlotSeries(value=f"{path}.innovation", label="innovation (measured - predicted)", show_line=False),
            fl.PlotSeries(value=f"{path}.band_low", label="-2 sigma stated", color=BAND_COLOR, line_style="dashed"),
            fl.PlotSeries(value=f"{path}.band_high", label="+2 sigma stated", color=BAND_COLOR,
                          line_style="dashed"),
        ], show_legend=True, legend_display="top"))

    def interval(key: str, label: str, suffixes: tuple[str, str, str]) -> list[Any]:
        model = TOPICS["model"]
        value, low, high = (f"{model}.{key}{s}" for s in suffixes)
        return [fl.PlotSeries(value=value, label=label),
                fl.PlotSeries(value=low, label=f"{label} 95 % low", line_style="dotted"),
                fl.PlotSeries(value=high, label=f"{label} 95 % high", line_style="dotted")]

    boat_fix, twin_fix = TOPICS["boat_fix"], TOPICS["twin_fix"]
    map_panel = fl.MapPanel(title="measured (blue) and predicted (orange) track", config=fl.MapConfig(
        follow_topic=boat_fix, zoom_level=17,
        topic_colors={boat_fix: _hex(COLORS["boat"]), twin_fix: _hex(COLORS["twin"])},
        topic_config={boat_fix: fl.MapTopicSettings(history_mode="all", show_heading=True),
                      twin_fix: fl.MapTopicSettings(history_mode="all", show_heading=True)}))
    scene_panel = fl.ThreeDeePanel(title="boat and twin, local ENU", config=fl.ThreeDeeConfig(
        follow_tf=FRAMES["boat"], fixed_frame=FRAME_MAP, follow_mode="follow-position",
        topics={TOPICS["scene"]: fl.BaseRendererSceneUpdateTopicSettings(visible=True)}))
    mass = fl.PlotPanel(title="mass, kg (adopted, 95 % interval)", config=fl.PlotConfig(
        paths=interval("mass", "mass", ("_kg", "_low_kg", "_high_kg")), show_legend=True, legend_display="top"))
    factors = fl.PlotPanel(title="resistance and turning coefficients / configured", config=fl.PlotConfig(
        paths=interval("resistance_factor", "resistance", ("", "_low", "_high"))
        + [fl.PlotSeries(value=f"{TOPICS['model']}.{key}_ratio", label=key) for key in LIVE_KEYS],
        show_legend=True, legend_display="top"))
    log_panel = fl.LogPanel(title="diagnosis verdicts and twin log", config=fl.LogConfig(
        topic_to_render=TOPICS["log"]))
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=1, content=fl.SplitContainer(direction="column", items=[
            fl.SplitItem(proportion=3, content=map_panel),
            fl.SplitItem(proportion=2, content=scene_panel)])),
        fl.SplitItem(proportion=1, content=fl.SplitContainer(direction="column", items=[
            fl.SplitItem(content=band("speed_mps", "speed innovation, m/s, and its ±2σ band")),
            fl.SplitItem(content=band("yaw_rate_radps", "yaw-rate innovation, rad/s, and its ±2σ band")),
            fl.SplitItem(content=mass),
            fl.SplitItem(content=factors),
            fl.SplitItem(content=log_panel)])),
    ]))


def layout_json() -> str:
    """The layout as the saved file holds it (indented, a final newline)."""
    data: dict[str, Any] = json.loads(twin_layout().to_json())
    return json.dumps(data, indent=2) + "\n"


if __name__ == "__main__":
    print(layout_json(), end="")
