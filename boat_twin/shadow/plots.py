"""The plots of ``boat-twin follow``: speed innovations against their noise band, the surge model converging with
its 95 % intervals, and the causes the rolling diagnosis held over time."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from boat_twin.shadow.follow import FollowResult
from boat_twin.shadow.turning import LIVE_KEYS


def innovation_figure(result: FollowResult) -> Figure:
    """Speed innovations (measured − predicted) over time with the ±2σ band the twin states, and the ratio."""
    fig = Figure(figsize=(9, 6))
    top, bottom = fig.subplots(2, 1, sharex=True)
    t, value, stdev = result.speed_innovations.T if result.speed_innovations.size else (np.zeros((3, 0)))
    top.plot(t, value, ".", ms=1, color="tab:blue", label="speed innovation")
    top.fill_between(t, -2 * stdev, 2 * stdev, color="tab:gray", alpha=0.3, label="±2σ stated (sensor + twin)")
    top.set_ylabel("speed innovation, m/s")
    top.legend(loc="upper right")
    times = [e["t_s"] for e in result.timeline]
    ratios = [np.nan if e["speed_innovation_ratio"] is None else e["speed_innovation_ratio"] for e in result.timeline]
    bottom.plot(times, ratios, "o-", color="tab:red", label="RMS over the last minute / stated noise")
    bottom.axhline(1.5, color="k", ls="--", lw=1, label="1.5× (target)")
    bottom.set_ylabel("ratio, -")
    bottom.set_xlabel("trial time, s")
    bottom.legend(loc="upper right")
    fig.tight_layout()
    return fig


def model_figure(result: FollowResult, configured_mass_kg: float) -> Figure:
    """Mass and resistance factor of the adopted model and of each fit, with the fits' 95 % intervals; the turning
    coefficients adopted over the configured boat's, and each turning fit's with its interval."""
    fig = Figure(figsize=(9, 9))
    axes = fig.subplots(3, 1, sharex=True)
    t = np.array([m["t_s"] for m in result.models])
    for ax, key, ci, label in ((axes[0], "mass_kg", "mass_ci95_kg", "mass, kg"),
                               (axes[1], "resistance_factor", "resistance_factor_ci95", "resistance ×, -")):
        adopted = np.array([m["surge"][key] for m in result.models], dtype=float)
        ax.step(t, adopted, where="post", color="tab:blue", label="adopted")
        fits = [(m["t_s"], m["latest_fit"]) for m in result.models if m["latest_fit"] is not None]
        if fits:
            ft = np.array([f[0] for f in fits])
            value = np.array([f[1][key] for f in fits], dtype=float)
            low = np.array([f[1][ci][0] for f in fits], dtype=float)
            high = np.array([f[1][ci][1] for f in fits], dtype=float)
            ax.errorbar(ft, value, yerr=[value - low, high - value], fmt=".", color="tab:orange", capsize=2,
                        label="latest fit, 95 % interval")
        ax.set_ylabel(label)
        ax.legend(loc="upper right")
    axes[0].axhline(configured_mass_kg, color="k", ls=":", lw=1)
    axes[1].axhline(1.0, color="k", ls=":", lw=1)
    _turning_axes(axes[2], result)
    axes[2].set_xlabel("trial time, s")
    fig.tight_layout()
    return fig


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
        ax.step(t, adopted, where="post", color=color, label=key)
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
    names = sorted({c for e in result.timeline for c in e["causes"]} | {"unexplained"})
    for row, name in enumerate(names):
        held = [e["t_s"] for e in result.timeline
                if (name in e["causes"]) or (name == "unexplained" and e["unexplained"])]
        ax.plot(held, [row] * len(held), "s", ms=6)
    ax.set_yticks(range(len(names)), names)
    ax.set_xlabel("trial time, s")
    ax.set_title("causes held by the rolling diagnosis")
    fig.tight_layout()
    return fig
