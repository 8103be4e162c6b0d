"""PNG figures of the cable: shape beside the current profile, and the convergence study (matplotlib Agg)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator

from boat_twin.cable.case import CableCase
from boat_twin.cable.convergence import ConvergenceStudy
from boat_twin.cable.problems import CableSolution


def shape_figure(case: CableCase, solution: CableSolution) -> Figure:
    """The cable shape (depth vs distance astern of the tow point) and V_T(Y) beside it, same depth axis."""
    fig = Figure(figsize=(10, 5.5))
    FigureCanvasAgg(fig)
    ax, ax_cur = fig.subplots(1, 2, sharey=True, gridspec_kw={"width_ratios": [3, 1]})
    ax.plot(solution.node_x_m, solution.node_depth_m, "-", color="tab:blue", lw=1.5, label="cable")
    ax.plot(solution.node_x_m[0], solution.vehicle_depth_m, "o", color="tab:red", ms=8, label="vehicle")
    ax.plot(0.0, 0.0, "^", color="k", ms=9, label="tow point")
    ax.set_xlabel("distance astern of the tow point, m")
    ax.set_ylabel("depth, m")
    ax.set_title(f"{case.name}: L = {solution.length_m:.2f} m, depth {solution.vehicle_depth_m:.2f} m, "
                 f"T_top = {solution.top_tension_N:.0f} N at {math.degrees(solution.top_angle_rad):.1f}°")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right")
    depth = np.linspace(0.0, max(solution.vehicle_depth_m, max(case.current.depth_m)) * 1.05, 200)
    ax_cur.plot(case.current.speed_at(depth), depth, color="tab:green")
    ax_cur.axvline(0.0, color="k", lw=0.5)
    ax_cur.set_xlabel("head current V_T, m/s")
    ax_cur.xaxis.set_major_locator(MaxNLocator(4))
    ax_cur.set_title(f"tow {solution.tow_speed_mps:.2f} m/s")
    ax_cur.grid(True, alpha=0.3)
    ax.invert_yaxis()
    fig.tight_layout()
    return fig


def _two_and_five(x: float, _: object = None) -> str:
    """Minor tick label of a log axis: 2·10^k and 5·10^k written plainly, the others blank (no crowding)."""
    if x <= 0:
        return ""
    return f"{x:g}" if round(x / 10 ** math.floor(math.log10(x)), 6) in (2.0, 5.0) else ""


def convergence_figure(study: ConvergenceStudy) -> Figure:
    """|error| of depth and length against the ODE, log-log over the link length l."""
    fig = Figure(figsize=(6.5, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    seg = np.array([row.segment_length_m for row in study.rows])
    ax.loglog(seg, [abs(row.depth_error_m) for row in study.rows], "o-", label="|depth error| (problem 1)")
    ax.loglog(seg, [abs(row.length_error_m) for row in study.rows], "s-", label="|length error| (problem 2)")
    ax.axhline(study.tolerance * study.reference_depth_m, color="gray", ls="--",
               label=f"{study.tolerance:.1%} of depth")
    for axis in (ax.xaxis, ax.yaxis):  # 0.1, 2, 5 — not 10^-1, 2×10^0
        axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
        axis.set_minor_formatter(FuncFormatter(_two_and_five))
    ax.set_xlabel("link length l, m")
    ax.set_ylabel("error against the continuous cable, m")
    ax.set_title(f"{study.case_name}: observed order {study.depth_order or float('nan'):.3f}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig
