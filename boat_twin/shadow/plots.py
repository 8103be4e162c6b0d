"""The plots of ``boat-twin follow``: speed innovations against their noise band, the surge model converging with
its 95 % intervals, and the causes the rolling diagnosis held over time."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from boat_twin.shadow.follow import FollowResult
from boat_twin.shadow.turning import LIVE_KEYS

CHANNEL_LABELS = {"speed_mps": ("speed", "m/s", 1.0), "yaw_rate_radps": ("yaw rate", "deg/s", 180.0 / np.pi)}
"""Innovation channel → (name, unit drawn, scale from SI to it)."""


def innovation_figure(result: FollowResult) -> Figure:
    """Each signal's innovations (measured − predicted) over time with the ±2σ band the twin states, and every
    signal's ratio (RMS over the last minute / stated noise) per timeline entry."""
    channels = [c for c in CHANNEL_LABELS if c in result.innovations] or ["speed_mps"]
    traces = result.innovations or {"speed_mps": result.speed_innovations}
    fig = Figure(figsize=(9, 3 + 2.5 * len(channels)))
    axes = fig.subplots(len(channels) + 1, 1, sharex=True)
    for ax, channel in zip(axes, channels, strict=False):
        name, unit, scale = CHANNEL_LABELS[channel]
        data = traces[channel]
        t, value, stdev = data.T * np.array([[1.0], [scale], [scale]]) if data.size else np.zeros((3, 0))
        ax.plot(t, value, ".", ms=1, color="tab:blue", label=f"{name} innovation")
        ax.fill_between(t, -2 * stdev, 2 * stdev, color="tab:gray", alpha=0.3, label="±2σ stated (sensor + twin)")
        ax.set_ylabel(f"{name} innovation, {unit}")
        ax.legend(loc="upper right", fontsize="small")
    bottom = axes[-1]
    entries = _entries(result)
    times = [e["t_s"] for e in entries]
    for i, channel in enumerate(channels):
        key = channel.rsplit("_", 1)[0] + "_innovation_ratio"
        ratios = [np.nan if e.get(key) is None else e[key] for e in entries]
        bottom.plot(times, ratios, "o-", color=f"C{i + 3}", label=f"{CHANNEL_LABELS[channel][0]}: RMS over the last "
                    "minute / stated noise")
    bottom.axhline(1.5, color="k", ls="--", lw=1, label="1.5× (misfit above)")
    bottom.set_ylim(bottom=0.0)
    bottom.set_ylabel("innovation ratio, -")
    bottom.set_xlabel("trial time, s")
    bottom.legend(loc="best", fontsize="small")
    fig.tight_layout()
    return fig


def model_figure(result: FollowResult, configured_mass_kg: float) -> Figure:
    """Mass and resistance factor of the adopted model and of each fit, with the fits' 95 % intervals; the turning
    coefficients adopted over the configured boat's, and each turning fit's with its interval."""
    fig = Figure(figsize=(9, 9))
    axes = fig.subplots(3, 1, sharex=True)
    end_s = _end_s(result)
    t = np.array([m["t_s"] for m in result.models] + [end_s])
    final = result.final.get("model", {}).get("surge")
    for ax, key, ci, label in ((axes[0], "mass_kg", "mass_ci95_kg", "mass, kg"),
                               (axes[1], "resistance_factor", "resistance_factor_ci95", "resistance ×, -")):
        steps = [m["surge"][key] for m in result.models]
        adopted = np.array(steps + [final[key] if final else (steps or [np.nan])[-1]], dtype=float)
        ax.step(t, adopted, where="post", color="tab:blue", marker=".", label="adopted (at each minute, the end)")
        fits = [(m["t_s"], m["latest_fit"]) for m in result.models if m["latest_fit"] is not None]
        if fits:
            ft = np.array([f[0] for f in fits])
            value = np.array([f[1][key] for f in fits], dtype=float)
            low = np.array([f[1][ci][0] for f in fits], dtype=float)
            high = np.array([f[1][ci][1] for f in fits], dtype=float)
            _fits_with_intervals(ax, ft, value, low, high)
        ax.set_ylabel(label)
        ax.legend(loc="upper right", fontsize="small")
    axes[0].axhline(configured_mass_kg, color="k", ls=":", lw=1)
    axes[1].axhline(1.0, color="k", ls=":", lw=1)
    _turning_axes(axes[2], result)
    axes[2].set_xlim(0.0, end_s)  # the whole trial
    axes[2].set_xlabel("trial time, s")
    fig.tight_layout()
    return fig


def _fits_with_intervals(ax: Axes, t: np.ndarray, value: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """Fits with their 95 % intervals; a fit without one (NaN: the value held, the data did not fix it) as its
    estimate alone, drawn and labelled so."""
    bounded = np.isfinite(low) & np.isfinite(high)
    if bounded.any():
        ax.errorbar(t[bounded], value[bounded], yerr=[value[bounded] - low[bounded], high[bounded] - value[bounded]],
                    fmt=".", color="tab:orange", capsize=2, label="latest fit, 95 % interval")
    if (~bounded).any():
        ax.plot(t[~bounded], value[~bounded], "x", color="tab:orange", ms=6,
                label="latest fit, held (no interval)")


def _turning_axes(ax: Axes, result: FollowResult) -> None:
    """Each live turning coefficient over the configured boat's: adopted (steps) and fitted (95 % intervals)."""
    t = np.array([m["t_s"] for m in result.models])
    fits: dict[float, dict[str, Any]] = {}
    for m in result.models:  # a fit shows once, at the first entry after it
        fit = m["turning"]["latest_fit"]
        if fit is not None and fit not in fits.values():
            fits[m["t_s"]] = fit
    for i, key in enumerate(LIVE_KEYS):
        color = f"C{i}"
        adopted = [m["turning"]["relative_to_configured"][key] for m in result.models]
        ax.step(t, adopted, where="post", color=color, marker=".", label=key)
        ft = np.array(list(fits)) + 2.0 * (i - 2)  # side by side
        ratio = np.array([f["relative_to_configured"][key] for f in fits.values()], dtype=float)
        configured = np.array([f["coefficients"][key] / f["relative_to_configured"][key] for f in fits.values()])
        low = np.array([f["ci95"][key][0] for f in fits.values()], dtype=float) / configured
        high = np.array([f["ci95"][key][1] for f in fits.values()], dtype=float) / configured
        ax.errorbar(ft, ratio, yerr=[ratio - low, high - ratio], fmt=".", color=color, capsize=2)
    ax.axhline(1.0, color="k", ls=":", lw=1)
    ax.set_ylabel("turning coefficient ×, -")
    ax.legend(loc="best", fontsize="small", ncol=2, title="adopted (steps), fits (bars)")


def cause_figure(result: FollowResult) -> Figure:
    """Which causes the rolling diagnosis held at each timeline entry."""
    fig = Figure(figsize=(9, 3))
    ax = fig.subplots()
    entries = _entries(result)
    names = sorted({c for e in entries for c in e["causes"]} | {"unexplained"})
    for row, name in enumerate(names):
        held = [e["t_s"] for e in entries if (name in e["causes"]) or (name == "unexplained" and e["unexplained"])]
        ax.plot(held, [row] * len(held), "s", ms=6)
    ax.set_yticks(range(len(names)), names)
    ax.set_xlim(0.0, _end_s(result))  # the whole trial, also where nothing was held
    ax.set_xlabel("trial time, s")
    ax.set_title("causes held by the rolling diagnosis")
    fig.tight_layout()
    return fig


def _end_s(result: FollowResult) -> float:
    """The trial's last time the twin reached, s (at least 1 s: an axis of a positive span)."""
    return max([e["t_s"] for e in result.timeline] + [result.final.get("t_s", 0.0), 1.0])


def _entries(result: FollowResult) -> list[dict[str, Any]]:
    """The timeline's entries, then the state at the trial's end (when later than the last entry)."""
    last = result.timeline[-1]["t_s"] if result.timeline else -np.inf
    final = result.final
    return [*result.timeline, final] if "causes" in final and final.get("t_s", -np.inf) > last else result.timeline
