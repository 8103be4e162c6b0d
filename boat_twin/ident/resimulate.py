"""Closing the loop: re-simulate a trial's recorded commands with the identified model and compare the speed.

The identified model (``{"resistance": ..., "effective_mass_kg": ...}``, what ``model.yaml`` holds) overrides
the default boat through :func:`~boat_twin.vessel.params.params_from_dict`, as ``boat-twin simulate --model``
loads it. The trial's commands, held from one sample to the next (before the first command: the first),
drive :func:`~boat_twin.vessel.simulate.simulate` in calm water from the speed measured at the first sample, in
calm air or, where the trial measured a true wind (an anemometer), in that wind as it was measured, held over
each :data:`WIND_HOLD_S` (a known input, as the identification and the diagnosis take it); the simulated speed
over ground is compared with the GNSS speed over ground sample by sample.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from boat_twin.drawn_line import drawn_series
from boat_twin.errors import InputError
from boat_twin.io.trial import COMMAND_ROLES, Trial
from boat_twin.signal_noise import white_noise_stdev
from boat_twin.twin.replay import measured_wind_mps
from boat_twin.vessel.environment import WindTrack
from boat_twin.vessel.params import VesselParams, params_from_dict
from boat_twin.vessel.scenarios import CommandProfile
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate, simulate_chunks

WIND_HOLD_S = 20.0
"""A measured wind is held at its mean over each stretch of this length in the re-simulation, s: the diagnosis'
window (:func:`~boat_twin.twin.replay.cut_windows`' default), so both meet the wind alike."""


@dataclass(frozen=True)
class Resimulation:
    """Measured and re-simulated speed over ground at the trial's samples with a measured speed (SI)."""

    t_s: np.ndarray
    """Trial time of the compared samples, s."""
    measured_mps: np.ndarray
    """GNSS speed over ground, m/s."""
    simulated_mps: np.ndarray
    """Speed over ground of the re-simulation with the identified model, m/s."""
    speed_noise_mps: float
    """GNSS speed noise estimated from the trial itself: robust spread of the second differences / √6, m/s."""
    effective_mass_kg: float
    """Surge mass with added mass the re-simulation used, kg."""
    mass_source: str
    """Where the effective mass came from: ``identified``, ``boat file``, or why it is not identified."""
    wind_mps: tuple[float, float] | None = None
    """The trial's mean measured true wind (east, north), m/s; None: calm air. The re-simulation ran in the wind
    as measured (held over each :data:`WIND_HOLD_S`)."""

    @property
    def error_mps(self) -> np.ndarray:
        """Re-simulated minus measured speed, m/s."""
        return self.simulated_mps - self.measured_mps

    def to_dict(self) -> dict[str, Any]:
        """The ``"resimulation"`` entry of ``identify --json``."""
        err = self.error_mps
        rmse = float(np.sqrt(np.mean(err**2)))
        mean_speed = float(np.mean(self.measured_mps))
        return {
            "speed_rmse_mps": rmse,
            "speed_nrmse": rmse / mean_speed if mean_speed > 0.0 else None,
            "speed_bias_mps": float(np.mean(err)),
            "speed_max_abs_error_mps": float(np.max(np.abs(err))),
            "mean_speed_mps": mean_speed,
            "speed_noise_mps": self.speed_noise_mps,
            "samples": int(self.t_s.size),
            "duration_s": float(self.t_s[-1] - self.t_s[0]),
            "initial_speed_mps": float(self.measured_mps[0]),
            "effective_mass_kg": self.effective_mass_kg,
            "mass_source": self.mass_source,
            "conditions": ("calm water and air" if self.wind_mps is None else
                           f"calm water, the trial's measured wind (held over each {WIND_HOLD_S:g} s)")
                          + "; vessel parameters other than the identified ones: the identified twin's (twin.yaml), "
                            "else the default boat",
        } | ({} if self.wind_mps is None else {"wind_east_north_mps": list(self.wind_mps)})


def _held_commands(trial: Trial, first: int) -> np.ndarray:
    """Commands from sample ``first`` on; a command not yet received there takes its first received value."""
    commands = trial.commands[first:].copy()
    for j, role in enumerate(COMMAND_ROLES):
        known = np.flatnonzero(np.isfinite(commands[:, j]))
        if known.size == 0:
            raise InputError(f"{trial.metadata.source}: no {role} command while GNSS speed was recorded: "
                             "cannot re-simulate")
        commands[: known[0], j] = commands[known[0], j]
        if known.size != commands.shape[0] - known[0]:
            at = trial.t_s[first + known[0] + int(np.argmin(np.isfinite(commands[known[0]:, j])))]
            raise InputError(f"{trial.metadata.source}: {role} command is NaN at t = {at:.1f} s: cannot re-simulate")
    return commands


def resimulate(trial: Trial, model: dict[str, Any], base: VesselParams | None = None,
               mass_source: str = "identified") -> Resimulation:
    """Simulate ``trial``'s commands with ``model`` (identified model dict) over ``base`` (default boat);
    ``mass_source`` says where the model's effective mass came from (reported with the error).

    Starts at the first sample with a measured speed, heading straight ahead at that speed, in calm water and in
    the trial's measured wind (held over each :data:`WIND_HOLD_S`; calm air without an anemometer).
    """
    base = base or VesselParams()
    params = params_from_dict(model, "identified model", base)
    speed = trial.speed_mps
    measured = np.flatnonzero(np.isfinite(speed))
    if measured.size < 2:
        raise InputError(f"{trial.metadata.source}: fewer than 2 GNSS speed samples: nothing to re-simulate")
    first = int(measured[0])
    t_rel = trial.t_s[first:] - trial.t_s[first]
    profile = CommandProfile("trial commands", t_rel, _held_commands(trial, first), float(t_rel[-1]),
                             float(speed[first]))
    wind = measured_wind_mps(trial)
    if wind is None or trial.wind_east_mps is None or trial.wind_north_mps is None:
        truth = simulate(params, profile).truth()
        times, speeds = truth.t_s, np.hypot(truth.vel_east_mps, truth.vel_north_mps)
    else:
        # the whole record (before the first speed too: a vane known only then is held from there)
        track = WindTrack(trial.t_s - trial.t_s[first], trial.wind_east_mps, trial.wind_north_mps)
        parts = [chunk.truth() for chunk in simulate_chunks(params, profile, chunk_ticks=int(round(
            WIND_HOLD_S * OUTPUT_RATE_HZ)), wind_track=track)]
        times = np.concatenate([p.t_s for p in parts])
        speeds = np.concatenate([np.hypot(p.vel_east_mps, p.vel_north_mps) for p in parts])
    simulated = np.interp(t_rel, times, speeds)
    keep = np.isfinite(speed[first:])
    return Resimulation(
        t_s=trial.t_s[first:][keep],
        measured_mps=speed[first:][keep],
        simulated_mps=simulated[keep],
        speed_noise_mps=white_noise_stdev(speed[first:]),
        effective_mass_kg=params.mass_kg * (1.0 + params.surge_added_mass_ratio),
        mass_source=mass_source if "effective_mass_kg" in model else "the base boat's (none identified)",
        wind_mps=wind,
    )


def resimulation_figure(resim: Resimulation) -> Figure:
    """Measured vs re-simulated speed over time, and their difference."""
    summary = resim.to_dict()
    fig = Figure(figsize=(9, 6))
    ax_v, ax_e = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    t_s, measured, simulated, error = drawn_series(resim.t_s, resim.measured_mps, resim.simulated_mps,
                                                   resim.error_mps)
    ax_v.plot(t_s, measured, lw=0.5, color="0.55", label="measured (GNSS speed over ground)")
    ax_v.plot(t_s, simulated, lw=1.2, color="tab:orange", label="re-simulated, identified model")
    ax_v.set_ylabel("speed, m/s")
    ax_v.set_title("measured vs re-simulated speed")
    ax_v.legend(loc="upper left")
    ax_e.plot(t_s, error, lw=0.5, color="tab:red")
    ax_e.axhline(0.0, color="0.3", lw=0.8)
    ax_e.set_ylabel("re-simulated − measured, m/s")
    ax_e.set_xlabel("time, s")
    relative = f" ({summary['speed_nrmse']:.1%} of the mean speed)" if summary["speed_nrmse"] is not None else ""
    ax_e.set_title(
        f"RMSE {summary['speed_rmse_mps']:.3f} m/s{relative}; "
        f"GNSS speed noise {summary['speed_noise_mps']:.3f} m/s",
        fontsize=9,
    )
    return fig
