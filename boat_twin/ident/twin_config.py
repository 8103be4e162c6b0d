"""The identified boat as a complete twin: resistance and mass from the identification, thrust limits from what the
trials commanded, geometry from the user's boat file or carried from the default boat (:func:`similar_boat`).

``boat-twin identify TRIAL --boat BOAT.yaml --out DIR`` writes it as ``DIR/twin.yaml``, which ``simulate --config``
and ``diagnose --config`` load; identify re-simulates the trials with the same vessel.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import SECTIONS
from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.io.trial import Trial
from boat_twin.vessel.params import VesselParams, params_from_dict, similar_boat
from boat_twin.vessel.propulsion import engine_thrust_N
from boat_twin.vessel.resistance import resistance_from_dict

BOAT_FIELDS = tuple(f.name for f in fields(VesselParams) if f.name != "resistance")
"""The vessel facts identify takes from a boat file: any but the resistance (that is what identify measures)."""
IDENTIFIED = ("resistance", "effective_mass_kg")
"""Vessel fields identify measures: a boat file may state them (a twin config serves as one), they are ignored."""


@dataclass(frozen=True)
class BoatFile:
    """The facts a boat file (``--boat``) gives identify, and what it states that identify does not read."""

    facts: dict[str, Any]
    """Vessel field → value, SI (units in the names; docs/model.md): numbers, and the parsed ``propulsion``,
    ``turning`` and ``manoeuvring`` where the file states them."""
    ignored: tuple[str, ...]
    """What identify measures (``vessel.resistance``, ``vessel.effective_mass_kg``) and the twin config's other
    sections (``environment``, ``gnss``, ...), as the file names them."""


def load_boat(path: Path) -> dict[str, Any]:
    """The vessel facts of a boat file (:func:`read_boat_file`), SI."""
    return read_boat_file(path).facts


def read_boat_file(path: Path) -> BoatFile:
    """A boat file: a mapping of vessel fields, or a twin configuration (``simulate --config``'s file: the
    ``vessel:`` section is read), checked as the vessel loader checks them. The resistance and effective mass
    are ignored (identify measures them), as are the config's other sections; both are reported in
    :attr:`BoatFile.ignored`."""
    data = load_yaml(path)
    ignored: list[str] = []
    if isinstance(data, dict) and "vessel" in data:
        for section in data:
            if section not in SECTIONS:
                raise InputError(f"{path}: unknown section '{section}'; sections: {', '.join(SECTIONS)}")
        ignored += [section for section in data if section != "vessel"]
        data = data["vessel"]
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a mapping of vessel facts (length_m, beam_m, ...)")
    for key in data:
        if key not in BOAT_FIELDS and key not in IDENTIFIED:
            raise InputError(f"{path}: unknown vessel field '{key}'; fields: " + ", ".join(BOAT_FIELDS))
    ignored = [f"vessel.{key}" for key in data if key in IDENTIFIED] + ignored
    facts = {key: value for key, value in data.items() if key not in IDENTIFIED}
    parsed = params_from_dict(facts, str(path))  # numbers, signs, the layout and the reference turn's limits
    return BoatFile({key: getattr(parsed, key) for key in facts}, tuple(ignored))


def thrust_seen(trials: list[Trial], read_through: VesselParams) -> dict[str, float]:
    """The largest thrust per engine ahead and astern (N) and the largest thrust power T·|u| per engine (W) the
    trials' commands delivered through the engines ``read_through`` (the envelope the identification read the
    thrust through: a command above it was not delivered, and the fit never saw it), over their known samples."""
    ahead = astern = power = 0.0
    for trial in trials:
        speed = np.abs(trial.speed_mps)
        for command in (trial.thrust_left_N, trial.thrust_right_N):
            thrust = engine_thrust_N(read_through, command, np.where(np.isfinite(speed), speed, 0.0))
            known = np.isfinite(thrust)
            if np.any(known):
                ahead = max(ahead, float(np.max(thrust[known])))
                astern = max(astern, float(-np.min(thrust[known])))
            both = known & np.isfinite(speed)
            if np.any(both):
                power = max(power, float(np.max(thrust[both] * speed[both])))
    return {"ahead_N": ahead, "astern_N": astern, "power_W": power}


def identified_vessel(model: dict[str, Any], given: dict[str, Any], seen: dict[str, float], *,
                      mass_held: bool = False) -> tuple[VesselParams, dict[str, str]]:
    """The vessel of the identified twin and where each of its key facts came from.

    Resistance: the identified fit. Mass: the identified effective mass over (1 + surge added-mass ratio) (with
    ``mass_held`` the boat file's, held in the fit), else the boat file's ``mass_kg``. Geometry: the boat file,
    the rest :func:`similar_boat`. Thrust limits not in the boat file: the similar boat's, raised to the largest
    thrust and thrust power the trials' commands delivered through the engines the fit read them through
    (``seen``: :func:`thrust_seen`), so that the twin delivers every thrust the fit saw at the speed it was seen
    at, and no more.
    """
    base_ratio = given.get("surge_added_mass_ratio", VesselParams().surge_added_mass_ratio)
    if "effective_mass_kg" in model:
        mass = float(model["effective_mass_kg"]) / (1.0 + base_ratio)
        mass_from = "boat file (held: the data do not identify it)" if mass_held else "identified (output-error fit)"
    elif "mass_kg" in given:
        mass, mass_from = given["mass_kg"], "boat file"
    else:
        raise InputError("no mass: the data do not identify it and no boat file (--boat) states mass_kg")
    resistance = resistance_from_dict(model["resistance"], "identified model: resistance")
    facts = {k: v for k, v in given.items() if k != "mass_kg"}
    similar = similar_boat(resistance, mass, facts)
    limits: dict[str, float] = {}
    layout = given.get("propulsion")
    if layout is not None and any(t.command != "newtons" for t in layout.thrusters):
        seen = {"ahead_N": 0.0, "astern_N": 0.0, "power_W": 0.0}  # commands in a table's unit or rev/s: not N
    if "bollard_thrust_N" not in given:
        limits["bollard_thrust_N"] = max(similar.bollard_thrust_N, seen["ahead_N"])
    bollard = limits.get("bollard_thrust_N", similar.bollard_thrust_N)
    if "reverse_thrust_ratio" not in given:
        limits["reverse_thrust_ratio"] = max(similar.reverse_thrust_ratio, seen["astern_N"] / bollard)
    if "engine_power_W" not in given:
        limits["engine_power_W"] = max(similar.engine_power_W, seen["power_W"] / similar.propulsive_efficiency)
    vessel = similar_boat(resistance, mass, {**facts, **limits})
    sources = {"resistance": "identified (output-error fit)", "mass_kg": mass_from}
    sources.update({k: "boat file" for k in facts})
    sources.update({k: "seen in the trials" if v > getattr(similar, k) else "similar boat"
                    for k, v in limits.items()})
    if "turning" not in given:
        sources["turning"] = ("the hull's dimensions (Clarke et al. 1983): no turn stated, or the carried one cannot "
                              "be held" if vessel.turning == "hull" else
                              "the default boat's reference turn carried to this size")
    for name in BOAT_FIELDS:
        sources.setdefault(name, "similar boat (the default boat carried to this size)")
    return vessel, sources
