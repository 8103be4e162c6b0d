"""The online identifier fed from live topics: latest commands held, one update per GNSS velocity sample.

Used by the ``identifier`` node (and usable by any other live front end); the maths is in
:class:`~boat_twin.ident.online.OnlineThrustSpeedIdentifier`, which bag replay feeds too.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.ident.online import OnlineThrustSpeedIdentifier, SteadyCriteria, SteadySegment
from boat_twin.validation import THRUST_LIMIT_N
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.propulsion import surge_thrust_N
from boat_twin.vessel.resistance import PowerSeriesResistance

COMMAND_LIMITS = (THRUST_LIMIT_N, THRUST_LIMIT_N, math.pi, math.pi)
"""Largest magnitude of each held command (thrust N, steering rad): the bounds every trial reader applies."""
SPEED_LIMIT_MPS = 343.0
"""Largest GNSS speed taken in, m/s (the speed of sound in air, as the trial readers)."""


class LiveIdentifier:
    """Holds the last command of each outboard; turns each velocity fix into an identifier sample."""

    def __init__(self, order: int = 3, memory_s: float = 3600.0, criteria: SteadyCriteria | None = None,
                 vessel: VesselParams | None = None) -> None:
        self.order = order
        self.vessel = vessel if vessel is not None and vessel.propulsion is not None else None
        """A boat whose propulsion section says how its commands (a table's unit, rev/s; its rudders' angles)
        become surge thrust (:func:`~boat_twin.vessel.propulsion.surge_thrust_N`); None: commands in N."""
        self.memory_s = memory_s
        self.criteria = criteria or SteadyCriteria()
        """Steady-state criteria (window, thrust tolerance): fixed live, where the boat is not known in advance."""
        self.reset()

    def reset(self) -> None:
        """Forget everything (a new trial)."""
        self.core = OnlineThrustSpeedIdentifier(self.order, memory_s=self.memory_s, criteria=self.criteria)
        single = self.vessel is not None and self.vessel.propulsion is not None and \
            len(self.vessel.propulsion.thrusters) == 1
        self.commands = np.array([math.nan, 0.0 if single else math.nan, 0.0, 0.0])  # one thruster: no second
        self.max_speed_mps = 0.0
        self.first_stamp_ns: int | None = None
        self.rejected = 0
        """Samples refused (non-finite, or beyond :data:`COMMAND_LIMITS` / :data:`SPEED_LIMIT_MPS`)."""
        self.recoveries = 0
        """Times the fit became non-finite and was restarted from the held commands."""

    def set_command(self, index: int, value: float) -> None:
        """Command 0 thrust_left_N, 1 thrust_right_N, 2 angle_left_rad, 3 angle_right_rad (held). A value that
        is not finite or beyond :data:`COMMAND_LIMITS` is refused (counted in :attr:`rejected`; the last valid
        command stays held)."""
        if not (math.isfinite(value) and abs(value) <= COMMAND_LIMITS[index]):
            self.rejected += 1
            return
        self.commands[index] = value

    def on_velocity(self, stamp_ns: int, vel_east_mps: float, vel_north_mps: float) -> SteadySegment | None:
        """One GNSS velocity sample (header stamp in integer ns): surge thrust Σ T·cos δ of the held commands
        (through the boat's thrust maps and rudders when it has a propulsion section) against speed over ground.
        Time runs from the first sample, so seconds are exact to the ns.
        Returns the constant-thrust segment this sample closed, if any (accepted or not)."""
        speed = math.hypot(vel_east_mps, vel_north_mps)
        if not (math.isfinite(speed) and speed <= SPEED_LIMIT_MPS):
            self.rejected += 1
            return None
        if self.first_stamp_ns is None:
            self.first_stamp_ns = stamp_ns
        stamp_s = (stamp_ns - self.first_stamp_ns) * 1e-9
        left, right, angle_left, angle_right = self.commands
        thrust = float(left * math.cos(angle_left) + right * math.cos(angle_right)) if self.vessel is None else \
            float(surge_thrust_N(self.vessel, self.commands[:2], self.commands[2:], speed))
        self.max_speed_mps = max(self.max_speed_mps, speed)
        segment = self.core.update(stamp_s, thrust, speed)
        if not self._finite():  # never publish NaN forever: start the fit again from here
            self.core = OnlineThrustSpeedIdentifier(self.order, memory_s=self.memory_s, criteria=self.criteria)
            self.recoveries += 1
        return segment

    def _finite(self) -> bool:
        resistance = self.core.resistance()
        dynamic = self.core.dynamic()
        return (resistance is None or bool(np.all(np.isfinite(resistance[0])))) and (
            dynamic is None or math.isfinite(float(dynamic["mass_kg"])))

    def coefficients(self) -> tuple[list[str], list[float]]:
        """Labels and values to publish: c_0..c_N of Fc in N/(m/s)^i, then the effective mass, kg (NaN: not yet)."""
        resistance = self.core.resistance()
        dynamic = self.core.dynamic()
        coef = [math.nan] * (self.order + 1) if resistance is None else [float(c) for c in resistance[0]]
        mass = math.nan if dynamic is None else float(dynamic["mass_kg"])
        return [f"c{i}_N_per_mps{i}" for i in range(self.order + 1)] + ["effective_mass_kg"], coef + [mass]

    def status(self) -> dict[str, Any]:
        """Fit quality and counters, for diagnostics (``steady_points_needed``: N + 2 for a curve of order N;
        ``held_commands``: thrust left/right N, angle left/right rad, null before the first)."""
        held = [float(c) if math.isfinite(c) else None for c in self.commands]
        return {**self.core.snapshot(), "steady_points_needed": self.order + 2, "held_commands": held,
                "rejected_samples": self.rejected, "recoveries": self.recoveries}

    def model(self) -> dict[str, Any] | None:
        """The identified model as the simulator loads it (``--model``); None before N + 2 steady points."""
        resistance = self.core.resistance()
        if resistance is None:
            return None
        top = max(self.max_speed_mps, max(s.speed_mps for s in self.core.steady_points))
        model: dict[str, Any] = {"resistance": PowerSeriesResistance(tuple(resistance[0]), top).to_dict()}
        dynamic = self.core.dynamic()
        if dynamic is not None:
            model["effective_mass_kg"] = float(dynamic["mass_kg"])
        return model

    def save(self, path: Path) -> bool:
        """Write the model YAML to ``path`` (atomically, its directory created); False if nothing to save yet."""
        from boat_twin.files import atomic_write_yaml

        model = self.model()
        if model is None:
            return False
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_yaml(path, {"vessel": model})
        return True
