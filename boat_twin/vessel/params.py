"""Vessel parameters: stated physical facts (dataclass, YAML) and the model coefficients derived from them.

The default boat is the seed boat of Dyda & Chumakova (2021): a 6 m, 2.6 m beam, 1.3 t aluminium planing
catamaran with two 40 hp outboards. Every field is a physical fact with its unit and source; the maneuvering
coefficients (added masses, damping) are derived from them in :func:`derive_coefficients`, so nothing in the
equations of motion is a free magic number.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.errors import InputError
from boat_twin.files import atomic_write_yaml, load_yaml
from boat_twin.units import SEAWATER_DENSITY_KGPM3
from boat_twin.validation import THRUST_LIMIT_N
from boat_twin.vessel.actuators import Propulsion, propulsion_from_dict, propulsion_to_dict
from boat_twin.vessel.resistance import (
    ResistanceModel,
    TableResistance,
    dyda2021_resistance,
    resistance_from_dict,
)

WINDAGE_DRAG_COEFFICIENT = 0.8
"""Drag coefficient of a small boat's hull and console above water, -: 0.6-1.0 (Blendermann 1994)."""


SIGNED_FIELDS = ("engine_x_m", "lateral_centre_x_m", "steering_offset_rad", "windage_centre_x_m")
"""Parameters that may be zero or negative (positions and offsets)."""
NON_NEGATIVE_FIELDS = ("frontal_windage_area_m2", "lateral_windage_area_m2", "steering_rate_radps",
                       "thrust_time_constant_s", "command_delay_s")
"""Parameters that may be zero (0 m² of windage: no wind force; a steering rate of 0: outboards that swing
instantly); all others must be positive."""
UPPER_LIMITS = {
    "mass_kg": (1e9, "kg", "a million tonnes: beyond the largest ships"),
    "length_m": (500.0, "m", "beyond the longest ship, 458 m"),
    "beam_m": (500.0, "m", "beyond any ship"),
    "draft_m": (500.0, "m", "beyond any ship"),
    "radius_of_gyration_yaw_m": (500.0, "m", "beyond any ship"),
    "bollard_thrust_N": (THRUST_LIMIT_N, "N", "the thrust bound of every reader"),
    "engine_power_W": (1e9, "W", "a gigawatt: beyond any ship's engine"),
    "turn_speed_mps": (343.0, "m/s", "the speed of sound in air"),
    "turn_diameter_m": (1e5, "m", "100 km: no turning circle"),
    "frontal_windage_area_m2": (1e5, "m²", "beyond any ship"),
    "lateral_windage_area_m2": (1e5, "m²", "beyond any ship"),
}
"""Vessel parameter → (largest value, unit, why): beyond is a unit error (and would overflow the inertia)."""
HULL_POSITIONS = ("engine_x_m", "lateral_centre_x_m", "windage_centre_x_m", "engine_y_m")
"""Positions on the boat (FLU body frame, m): within ±500 m, the bound of ``length_m`` (a point on a boat no longer
than that; checked on its own, since a boat file may give a position before the length it goes with)."""
TURNING_SOURCES = ("reference_turn", "hull")
"""Where the turning coefficients come from (``VesselParams.turning``)."""
NOT_NUMBERS = ("resistance", "manoeuvring", "propulsion", "turning")
"""Fields that are not plain numbers (checked on their own)."""
MANOEUVRING_KEYS = ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "yaw_damping_Nms", "sway_quadratic_Ns2pm2",
                    "yaw_quadratic_Nms2")
"""Coefficients (:class:`ModelCoefficients` fields) that ``VesselParams.manoeuvring`` may set from trials."""


@dataclass(frozen=True)
class VesselParams:
    """Physical facts about the boat. Units are in the names; each docstring gives meaning and source."""

    mass_kg: float = 1300.0
    """Displacement mass, kg. Dyda & Chumakova (2021): 'водоизмещение 1,3 т'."""
    length_m: float = 6.0
    """Hull length, m. Dyda & Chumakova (2021)."""
    beam_m: float = 2.6
    """Overall beam, m. Dyda & Chumakova (2021). Enters through the outboards' offset ``engine_y_m``."""
    draft_m: float = 0.25
    """Draft of each demihull at rest, m (assumed, typical of a 6 m aluminium catamaran at 1.3 t)."""
    radius_of_gyration_yaw_m: float = 1.5
    """Yaw radius of gyration, m: 0.25·L, the usual small-craft value (Fossen 2011, §6.6)."""
    surge_added_mass_ratio: float = 0.05
    """Surge added mass as a fraction of mass, -: 5 % for slender hulls (Fossen 2011, §6.4)."""
    crossflow_drag_coefficient: float = 1.0
    """Cross-flow drag coefficient of the demihulls, -: a flat-bottomed prism, ~1.0 (Hoerner 1965, ch. 3)."""
    lateral_centre_x_m: float = -1.0
    """Centre of lateral resistance from the centre of gravity (forward +), m: aft, because a planing hull's
    wetted area and the outboards' lower units (skegs) lie aft (Faltinsen 2005, §9.2; assumed 1 m)."""
    engine_x_m: float = -2.6
    """Outboards' longitudinal position from the centre of gravity (FLU: forward +), m (transom 0.43·L aft)."""
    engine_y_m: float = 0.9
    """Outboards' lateral offset from the centreline, m: one per demihull, each demihull ~0.8 m wide at the
    sides of the 2.6 m beam, so its centreline is 0.9 m out."""
    engine_power_W: float = 29_830.0
    """Shaft power per outboard, W: 40 hp (Dyda & Chumakova 2021) × 745.7 W/hp."""
    propulsive_efficiency: float = 0.55
    """Propulsive efficiency of an outboard at planing speed, -: 0.5-0.6 (Faltinsen 2005, §9.4)."""
    bollard_thrust_N: float = 2_000.0
    """Static (bollard) thrust per outboard, N: about 5 kgf/hp for a planing propeller (assumed)."""
    reverse_thrust_ratio: float = 0.5
    """Astern thrust available as a fraction of the bollard thrust, -: propellers are ~half as good astern."""
    max_steering_rad: float = math.radians(30.0)
    """Outboard steering limit, rad: ±30°, typical of hydraulic outboard steering."""
    steering_rate_radps: float = math.radians(18.0)
    """Fastest swing of the outboards, rad/s (0: instantaneous, no actuator). Manual hydraulic outboard
    steering turns the wheel (cylinder displacement / helm displacement) times lock to lock: 5.7 in³ / 1.7 in³
    per turn = 3.35 turns for a SeaStar-class outboard cylinder and helm (SeaStar Solutions, Hydraulic Steering
    Selection Guide); at a brisk one turn per second (assumed) the 60° from lock to lock take 3.35 s: 18°/s.
    Autopilot pumps are slower (a 13-15 s hard-over to hard-over is their sizing target, ~4°/s)."""
    thrust_time_constant_s: float = 0.0
    """First-order lag of each engine's thrust behind its command, s (0: none, the thrust follows at once). An
    outboard's engine and propeller spin up in about 1-2 s; an electric thruster's ESC in a fraction of that.
    The lag acts on the commanded thrust; the envelope (bollard thrust, power) then limits it at the speed."""
    command_delay_s: float = 0.0
    """Time between a command being logged and the outboards starting to act on it, s (0: none): a radio
    link, an ESC's or autopilot's processing; 0.3-0.6 s is common. The command log stamps the command when it
    was issued; the boat feels it this much later."""
    turn_speed_mps: float = 6.0
    """Reference turn: speed through water, m/s (11.7 kn: above the flat 8.5-10.5 kn stretch of Table 1)."""
    turn_steering_rad: float = math.radians(20.0)
    """Reference turn: steering angle of both outboards, rad."""
    turn_diameter_m: float = 60.0
    """Reference turn: steady turning diameter, m (10·L at 20°, 6 m/s: thrust vectoring alone turns wide)."""
    turn_drift_rad: float = math.radians(4.0)
    """Reference turn: drift angle, rad (a planing catamaran skids little: 3-6°)."""
    thrust_factor_left: float = 1.0
    """Fraction of its command the left outboard delivers, -: 1 as built; less for a fouled propeller or a
    tired engine (the diagnosis' ``thrust_asymmetry``)."""
    thrust_factor_right: float = 1.0
    """Fraction of its command the right outboard delivers, -."""
    steering_offset_rad: float = 0.0
    """Outboards' real steering angle minus the commanded one, rad (linkage misalignment; positive turns
    the thrust to port like a positive command)."""
    frontal_windage_area_m2: float = 2.6
    """Above-water area seen from ahead, m²: the 2.6 m beam × ~1 m of freeboard and console (assumed)."""
    lateral_windage_area_m2: float = 6.0
    """Above-water area seen from the side, m²: the 6 m length × ~1 m (assumed)."""
    windage_centre_x_m: float = 0.5
    """Centre of the lateral windage forward of the centre of gravity, m (console forward of midships; assumed)."""
    resistance: ResistanceModel = field(default_factory=dyda2021_resistance)
    """Calm-water surge resistance Fc(u); default the measured Table 1 of Dyda & Chumakova (2021)."""
    propulsion: Propulsion | None = None
    """The boat's thrusters and rudders (:mod:`boat_twin.vessel.actuators`); None: the seed boat's layout, two
    steerable outboards commanded in N at (``engine_x_m``, ±``engine_y_m``)."""
    turning: str = "reference_turn"
    """Where the sway and yaw damping come from (:data:`TURNING_SOURCES`): ``reference_turn`` solves the stated
    turn (``turn_*``) of the two outboards; ``hull`` takes Clarke et al. (1983)'s derivatives of the hull's
    length, beam, draft and block coefficient (:func:`hull_coefficients`): any layout, no turn to state."""
    manoeuvring: dict[str, float] = field(default_factory=dict, hash=False)
    """Sway/yaw coefficients identified from trials (keys: :data:`MANOEUVRING_KEYS`, SI, each > 0) that replace
    the ones :func:`derive_coefficients` derives from the reference turn (boat_twin.ident.manoeuvring); empty:
    all derived."""

    def __post_init__(self) -> None:
        for key, value in self.manoeuvring.items():
            if key not in MANOEUVRING_KEYS:
                raise InputError(f"vessel parameter 'manoeuvring': unknown coefficient '{key}' "
                                 f"(expected {', '.join(MANOEUVRING_KEYS)})")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0.0:
                raise InputError(f"vessel parameter 'manoeuvring': '{key}' must be a positive number, got {value!r}")
        if self.turning not in TURNING_SOURCES:
            raise InputError(f"vessel parameter 'turning' must be one of {', '.join(TURNING_SOURCES)}, "
                             f"got {self.turning!r}")
        if self.propulsion is not None and self.turning == "reference_turn" \
                and set(self.manoeuvring) != set(MANOEUVRING_KEYS):
            raise InputError("vessel parameter 'turning': a reference turn is the two outboards' turn; a boat with "
                             "a propulsion section takes turning: hull (or identified manoeuvring coefficients)")
        for f in fields(self):
            if f.name in NOT_NUMBERS:
                continue
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"vessel parameter '{f.name}' must be a finite number, got {value!r}")
            if f.name in NON_NEGATIVE_FIELDS and value < 0.0:
                raise InputError(f"vessel parameter '{f.name}' must not be negative, got {value!r}")
            if f.name not in SIGNED_FIELDS + NON_NEGATIVE_FIELDS and value <= 0.0:
                raise InputError(f"vessel parameter '{f.name}' must be positive, got {value!r}")
            if f.name in UPPER_LIMITS and value > UPPER_LIMITS[f.name][0]:
                limit, unit, why = UPPER_LIMITS[f.name]
                raise InputError(f"vessel parameter '{f.name}' must be <= {limit:g} {unit} ({why}), got {value!r}")
        for name in HULL_POSITIONS:
            if abs(getattr(self, name)) > UPPER_LIMITS["length_m"][0]:
                raise InputError(f"vessel parameter '{name}' must be within ±{UPPER_LIMITS['length_m'][0]:g} m (a "
                                 f"point on a boat no longer than the longest ship), got {getattr(self, name)!r}")
        for name in ("max_steering_rad", "steering_offset_rad"):
            if abs(getattr(self, name)) > math.pi / 2:
                raise InputError(f"vessel parameter '{name}' must be within ±π/2 rad (an outboard turns at most "
                                 f"90° either way), got {getattr(self, name)!r}")
        if self.turn_steering_rad >= self.max_steering_rad + 1e-12:
            raise InputError("vessel parameter 'turn_steering_rad' must not exceed 'max_steering_rad'")
        if self.turn_drift_rad >= math.pi / 4:
            raise InputError("vessel parameter 'turn_drift_rad' must be below 45°")


@dataclass(frozen=True)
class ModelCoefficients:
    """Coefficients of the 3-DOF equations of motion (see :mod:`boat_twin.vessel.dynamics`), SI units."""

    m11_kg: float
    """Surge mass with added mass, kg."""
    m22_kg: float
    """Sway mass with added mass, kg."""
    m33_kgm2: float
    """Yaw inertia with added inertia, kg·m^2."""
    sway_damping_Nspm2: float
    """Sway lift damping a_v in Y = −a_v·|u|·v, N·s²/m² (derived from the reference turn)."""
    lateral_centre_x_m: float
    """Where the sway lift acts, m forward of the centre of gravity."""
    yaw_damping_Nms: float
    """Yaw lift damping a_r in N = −a_r·|u|·r, N·m·s (derived from the reference turn)."""
    sway_quadratic_Ns2pm2: float
    """Cross-flow sway drag Y = −Y_vv·|v|·v, N·s²/m² (½ρ·Cd·2T·L)."""
    yaw_quadratic_Nms2: float
    """Cross-flow yaw drag N = −N_rr·|r|·r, N·m·s² (½ρ·Cd·2T·L⁴/32)."""


def reference_turn_thrust_N(params: VesselParams) -> float:
    """Thrust per outboard that holds the reference turn's speed, N (surge balance of the steady turn)."""
    coeff = _inertia(params)
    u, v, r = _reference_turn_velocities(params)
    return float((params.resistance.force_N(u) - coeff["m22"] * v * r) / (2.0 * math.cos(params.turn_steering_rad)))


def _inertia(params: VesselParams) -> dict[str, float]:
    """Rigid-body plus added masses: surge by ratio, sway and yaw by strip theory over two demihulls."""
    rho = SEAWATER_DENSITY_KGPM3
    # 2-D sway added mass of a vertical plate of draft T at a free surface: ρπT²/2 (Newman 1977, §4.13),
    # per demihull, integrated over the length; the yaw added inertia integrates x² over the same strips.
    sway_added_kg = 2.0 * rho * math.pi * params.draft_m**2 / 2.0 * params.length_m
    yaw_added_kgm2 = sway_added_kg * params.length_m**2 / 12.0
    return {
        "m11": params.mass_kg * (1.0 + params.surge_added_mass_ratio),
        "m22": params.mass_kg + sway_added_kg,
        "m33": params.mass_kg * params.radius_of_gyration_yaw_m**2 + yaw_added_kgm2,
    }


def _reference_turn_velocities(params: VesselParams) -> tuple[float, float, float]:
    """(u, v, r) of the steady reference turn to port: r > 0, the hull skids outward (v < 0)."""
    speed = params.turn_speed_mps
    u = speed * math.cos(params.turn_drift_rad)
    v = -speed * math.sin(params.turn_drift_rad)
    r = speed / (params.turn_diameter_m / 2.0)
    return u, v, r


def derive_coefficients(params: VesselParams) -> ModelCoefficients:
    """Solve the steady reference turn's sway and yaw balances for the two lift-damping coefficients, then
    put in the identified coefficients ``params.manoeuvring`` holds (they replace the derived ones).

    In the steady turn, ``0 = Y_thrust − m11·u·r − a_v·|u|·v − Y_vv·|v|·v`` and
    ``0 = N_thrust − (m22 − m11)·u·v − x_c·a_v·|u|·v − a_r·|u|·r − N_rr·|r|·r`` (the sway lift acts at the
    centre of lateral resistance x_c) with the outboard thrust that holds the surge balance
    (:func:`reference_turn_thrust_N`), steered to port (a negative angle turns the bow to port).
    """
    if set(params.manoeuvring) == set(MANOEUVRING_KEYS):  # all identified: the reference turn plays no part
        return ModelCoefficients(m11_kg=_inertia(params)["m11"], lateral_centre_x_m=params.lateral_centre_x_m,
                                 **params.manoeuvring)
    derived = hull_coefficients(params) if params.turning == "hull" else _derived_coefficients(params)
    return replace(derived, **params.manoeuvring) if params.manoeuvring else derived


CLARKE_RANGE = {"beam_to_draft": (1.5, 6.0), "beam_to_length": (0.1, 0.35), "block": (0.35, 0.9)}
"""Ratios held within these bounds in :func:`hull_coefficients`, -: about the range of the hulls behind Clarke
et al. (1983)'s regression (ships and their models; B/T 2-4, B/L 0.1-0.2, C_B 0.5-0.85), widened to small craft's
proportions; beyond, the formulas' sums can change sign (a wide catamaran's overall B/T of 10 would turn its
yaw damping negative). The derivatives are a start that ``identify --manoeuvring`` replaces."""


HULL_STABILITY_SHARE = 0.5
"""The hull's destabilising sway-yaw moment at most this share of its damping product (assumed), -: see
:func:`hull_coefficients`."""


def hull_coefficients(params: VesselParams) -> ModelCoefficients:
    """Sway and yaw damping from the hull's dimensions: the linear derivatives of Clarke, Gedling & Hine (1983) as
    Fossen's MSS toolbox writes them (``clarke83.m``; Fossen 2021, §6.4), non-dimensional on ½ρL²U, with T/L, B/T,
    B/L and the block coefficient C_B = m/(ρLBT)::

        Y_v' = −π(T/L)²·(1 + 0.4·C_B·B/T)      N_v' = −π(T/L)²·(1/2 + 2.4·T/L)
        N_r' = −π(T/L)²·(1/4 + 0.039·B/T − 0.56·B/L)

    mapped onto this model's terms: a_v = −Y_v'·½ρL² (Y = −a_v·|u|·v), a_r = −N_r'·½ρL⁴ (N = −a_r·|u|·r), and the
    lateral centre x_c such that the model's whole linear moment in v, −(m22 − m11 + x_c·a_v)·u·v, is Clarke's
    N_v'·½ρL³·u·v (the Munk moment is part of the measured N_v). The sway and yaw added masses are Clarke's too,
    −Y_v̇' = π(T/L)²·(1 + 0.16·C_B·B/T − 5.1·(B/L)²) on ½ρL³ and −N_ṙ' = π(T/L)²·(1/12 + 0.017·C_B·B/T − 0.33·B/L)
    on ½ρL⁵ (not below 0); surge added mass and the cross-flow drag are this model's own (:func:`_inertia`,
    :func:`_crossflow`). Clarke's ships are often directionally unstable; a small craft carries skegs, keels or
    engine legs aft that the regression leaves out and is built to run straight, so x_c goes no further forward
    than where the destabilising moment is :data:`HULL_STABILITY_SHARE` of the damping product
    (m11·(m22 − m11 + x_c·a_v) = share·a_v·a_r): stable with a margin (an unstable replay diverges within a
    window, and every small difference becomes a misfit)."""
    rho = SEAWATER_DENSITY_KGPM3
    length, beam, draft = params.length_m, params.beam_m, params.draft_m
    beam_to_draft = min(max(beam / draft, CLARKE_RANGE["beam_to_draft"][0]), CLARKE_RANGE["beam_to_draft"][1])
    beam_to_length = min(max(beam / length, CLARKE_RANGE["beam_to_length"][0]), CLARKE_RANGE["beam_to_length"][1])
    block = min(max(params.mass_kg / (rho * length * beam * draft), CLARKE_RANGE["block"][0]),
                CLARKE_RANGE["block"][1])
    slender = math.pi * (draft / length) ** 2
    half_rho = 0.5 * rho
    sway_added_kg = slender * (1.0 + 0.16 * block * beam_to_draft - 5.1 * beam_to_length**2) * half_rho * length**3
    yaw_added_kgm2 = max(slender * (1.0 / 12.0 + 0.017 * block * beam_to_draft - 0.33 * beam_to_length), 0.0) \
        * half_rho * length**5
    inertia = {"m11": _inertia(params)["m11"], "m22": params.mass_kg + sway_added_kg,
               "m33": params.mass_kg * params.radius_of_gyration_yaw_m**2 + yaw_added_kgm2}
    y_v = -slender * (1.0 + 0.4 * block * beam_to_draft)
    n_v = -slender * (0.5 + 2.4 * draft / length)
    n_r = -slender * (0.25 + 0.039 * beam_to_draft - 0.56 * beam_to_length)
    a_v = -y_v * half_rho * length**2
    a_r = -n_r * half_rho * length**4
    munk = inertia["m22"] - inertia["m11"]
    x_c = min((-n_v * half_rho * length**3 - munk) / a_v,
              (HULL_STABILITY_SHARE * a_v * a_r / inertia["m11"] - munk) / a_v)
    y_vv, n_rr = _crossflow(params)
    return ModelCoefficients(
        m11_kg=inertia["m11"], m22_kg=inertia["m22"], m33_kgm2=inertia["m33"], sway_damping_Nspm2=a_v,
        lateral_centre_x_m=x_c, yaw_damping_Nms=a_r, sway_quadratic_Ns2pm2=y_vv, yaw_quadratic_Nms2=n_rr)


def _crossflow(params: VesselParams) -> tuple[float, float]:
    """Cross-flow drag of the hull: (Y_vv, N_rr) = ½ρ·C_d·2T·(L, L⁴/32) (N·s²/m², N·m·s²)."""
    rho = SEAWATER_DENSITY_KGPM3
    area = 2.0 * params.draft_m * params.length_m
    return (0.5 * rho * params.crossflow_drag_coefficient * area,
            0.5 * rho * params.crossflow_drag_coefficient * 2.0 * params.draft_m * params.length_m**4 / 32.0)


def _derived_coefficients(params: VesselParams) -> ModelCoefficients:
    """The coefficients from the physical facts and the reference turn alone (see :func:`derive_coefficients`)."""
    inertia = _inertia(params)
    y_vv, n_rr = _crossflow(params)
    u, v, r = _reference_turn_velocities(params)
    thrust = reference_turn_thrust_N(params)
    delta = -params.turn_steering_rad
    y_thrust = 2.0 * thrust * math.sin(delta)
    n_thrust = 2.0 * params.engine_x_m * thrust * math.sin(delta)
    a_v = (y_thrust - inertia["m11"] * u * r - y_vv * abs(v) * v) / (abs(u) * v)
    munk = inertia["m22"] - inertia["m11"]
    x_c = params.lateral_centre_x_m
    a_r = (n_thrust - munk * u * v - x_c * a_v * abs(u) * v - n_rr * abs(r) * r) / (abs(u) * r)
    if a_v <= 0.0 or a_r <= 0.0:
        raise InputError(
            "vessel parameters: the reference turn (turn_diameter_m, turn_drift_rad, turn_steering_rad) "
            "cannot be held by this boat (it would need negative hull damping)"
        )
    # Linearized sway-yaw at speed u: stable when det > 0 (both damping terms are positive here).
    if a_v * a_r <= inertia["m11"] * (munk + x_c * a_v):
        raise InputError("vessel parameters: the reference turn makes the hull directionally unstable")
    return ModelCoefficients(
        m11_kg=inertia["m11"],
        m22_kg=inertia["m22"],
        m33_kgm2=inertia["m33"],
        sway_damping_Nspm2=a_v,
        lateral_centre_x_m=x_c,
        yaw_damping_Nms=a_r,
        sway_quadratic_Ns2pm2=y_vv,
        yaw_quadratic_Nms2=n_rr,
    )


def yaw_time_constant_s(params: VesselParams, speed_mps: float) -> float:
    """Yaw time constant at ``speed_mps``: m33 / (a_r·u) of the linearized yaw equation, s."""
    coeff = derive_coefficients(params)
    return coeff.m33_kgm2 / (coeff.yaw_damping_Nms * speed_mps)


def sway_yaw_time_constants_s(params: VesselParams, speed_mps: float) -> tuple[float, float]:
    """Time constants of the coupled sway-yaw motion on a straight course at ``speed_mps``, s (fast, slow).

    The linearized sway and yaw equations (cross-flow terms vanish at v = r = 0)::

        m22·v̇ = −a_v·u·v − m11·u·r
        m33·ṙ = −(m22 − m11 + x_c·a_v)·u·v − a_r·u·r

    form a 2×2 system ẋ = A·x; its eigenvalues λ are real and negative for this stable hull and each
    time constant is −1/λ. The yaw-only m33/(a_r·u) of :func:`yaw_time_constant_s` ignores the coupling.
    """
    coeff = derive_coefficients(params)
    u = speed_mps
    m11, m22, m33, a_v, a_r = coeff.m11_kg, coeff.m22_kg, coeff.m33_kgm2, coeff.sway_damping_Nspm2, \
        coeff.yaw_damping_Nms
    a = np.array([[-a_v * u / m22, -m11 * u / m22],
                  [-(m22 - m11 + coeff.lateral_centre_x_m * a_v) * u / m33, -a_r * u / m33]])
    eigenvalues = np.linalg.eigvals(a)
    times = sorted(float(-1.0 / lam.real) for lam in eigenvalues)
    return times[0], times[1]


def surge_time_constant_s(params: VesselParams, speed_mps: float) -> float:
    """Surge time constant at ``speed_mps``: m11 / (dFc/du), s (central difference, 1 cm/s)."""
    h = 0.01
    slope = float(params.resistance.force_N(speed_mps + h) - params.resistance.force_N(speed_mps - h)) / (2 * h)
    return _inertia(params)["m11"] / slope if slope > 0 else math.inf


def max_thrust_N(params: VesselParams, speed_mps: np.ndarray) -> np.ndarray:
    """Forward thrust available per outboard at speed through water u, N: min(bollard, η·P/|u|)."""
    power_limited = params.propulsive_efficiency * params.engine_power_W / np.maximum(np.abs(speed_mps), 1e-9)
    return np.minimum(params.bollard_thrust_N, power_limited)


TURN_SPEED_SHARE_OF_TOP = 0.8
"""A boat file that states another size and no ``turn_speed_mps``: its manoeuvres start at the Froude-scaled
speed, but not above this share of its top speed (its engines then hold it with a margin), -."""
TURN_FACTS = ("turn_diameter_m", "turn_drift_rad", "turn_steering_rad")
"""The reference turn's facts: a boat file that states one derives its turning from the turn."""
SCALED_LENGTHS = ("draft_m", "radius_of_gyration_yaw_m", "lateral_centre_x_m", "engine_x_m", "turn_diameter_m",
                  "windage_centre_x_m")
"""Facts that are lengths along or under the hull: proportional to the hull length in a similar boat."""
BEAM_FRACTIONS = ("engine_y_m", "frontal_windage_area_m2")
"""Facts proportional to the beam (the outboards' offset; the frontal windage, beam × freeboard ∝ length)."""


def similar_boat(resistance: ResistanceModel, mass_kg: float, given: dict[str, Any] | None = None) -> VesselParams:
    """A boat of ``mass_kg`` geometrically and Froude-similar to the default one, with its own resistance.

    Facts in ``given`` (field → value, as a boat YAML's ``vessel`` section) are kept; every other fact is the
    default boat's carried to this size: the length L from the mass at the same density (L ∝ m^(1/3)) unless
    given, lengths ∝ L (draft, yaw radius of gyration, positions, turn diameter), beam ∝ L unless given and the
    outboards' offset and frontal windage ∝ beam, lateral windage ∝ L², the reference turn's speed Froude-scaled
    (∝ √L: the same Fr = 0.78, so its hull damping derives at the same flow regime; but not above the top speed
    of the resistance model's data, ``max_speed_mps``: a turn is derived where Fc is known), forces ∝ mass (bollard
    thrust), power ∝ mass·√L; ratios and angles unchanged. So the turning coefficients of
    :func:`derive_coefficients` follow the boat instead of the 6 m boat's turn at 6 m/s.
    """
    base = VesselParams()
    given = dict(given or {})
    length = float(given.get("length_m", base.length_m * (mass_kg / base.mass_kg) ** (1.0 / 3.0)))
    scale = length / base.length_m
    beam = float(given.get("beam_m", base.beam_m * scale))
    facts: dict[str, Any] = {f.name: getattr(base, f.name) for f in fields(base)}
    facts.update({name: getattr(base, name) * scale for name in SCALED_LENGTHS})
    facts.update({name: getattr(base, name) * (beam / base.beam_m) for name in BEAM_FRACTIONS})
    facts.update(
        mass_kg=mass_kg, length_m=length, beam_m=beam, resistance=resistance,
        lateral_windage_area_m2=base.lateral_windage_area_m2 * scale**2,
        turn_speed_mps=min(base.turn_speed_mps * math.sqrt(scale), resistance.max_speed_mps),
        bollard_thrust_N=base.bollard_thrust_N * mass_kg / base.mass_kg,
        engine_power_W=base.engine_power_W * mass_kg / base.mass_kg * math.sqrt(scale),
    )
    facts.update(given)
    if not any(name in given for name in TURN_FACTS + ("turning",)) and not _reference_turn_holds(facts):
        facts["turning"] = "hull"  # the carried turn cannot be held by this boat: its hull's own damping
    return VesselParams(**facts)


def _reference_turn_holds(facts: dict[str, Any]) -> bool:
    """Whether a boat of ``facts`` (reference turn, no propulsion section) can hold its reference turn."""
    if facts.get("propulsion") is not None:
        return False
    try:
        _derived_coefficients(VesselParams(**facts))
    except InputError:
        return False
    return True


def params_to_dict(params: VesselParams) -> dict[str, Any]:
    """Plain data for YAML: every fact plus the resistance model's description."""
    data = {f.name: getattr(params, f.name) for f in fields(params) if f.name not in NOT_NUMBERS}
    data["resistance"] = params.resistance.to_dict()
    if params.turning != "reference_turn":
        data["turning"] = params.turning
    if params.propulsion is not None:
        data["propulsion"] = propulsion_to_dict(params.propulsion)
    if params.manoeuvring:
        data["manoeuvring"] = {key: float(value) for key, value in params.manoeuvring.items()}
    return data


def params_from_dict(data: Any, where: str, base: VesselParams | None = None) -> VesselParams:
    """Parameters from plain data (YAML); keys not given keep the values of ``base`` (default boat)."""
    base = base or VesselParams()
    if data is None:
        return base
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a mapping of vessel parameters")
    known = {f.name for f in fields(VesselParams)} | {"effective_mass_kg"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise InputError(f"{where}: unknown vessel parameter '{unknown[0]}'")
    changes: dict[str, Any] = {}
    for key, value in data.items():
        if key == "resistance":
            changes[key] = resistance_from_dict(value, f"{where}: resistance")
        elif key == "manoeuvring":
            if not isinstance(value, dict):
                raise InputError(f"{where}: 'manoeuvring' must be a mapping of coefficients")
            changes[key] = {str(k): _number(v, where, f"manoeuvring: {k}") for k, v in value.items()}
        elif key == "propulsion":
            changes[key] = propulsion_from_dict(value, f"{where}: propulsion")
        elif key == "turning":
            changes[key] = value  # checked by the vessel (one of TURNING_SOURCES)
        elif key == "effective_mass_kg":
            changes["mass_kg"] = _number(value, where, key) / (1.0 + base.surge_added_mass_ratio)
        else:
            changes[key] = _number(value, where, key)
    if "effective_mass_kg" in data:  # an identified model over its base: no boat of another size to carry
        return _replaced(base, changes, where)
    return vessel_with_facts(base, changes, where)


def _replaced(base: VesselParams, changes: dict[str, Any], where: str) -> VesselParams:
    try:
        return replace(base, **changes)
    except InputError as err:
        raise InputError(f"{where}: {err}") from None


def vessel_with_facts(base: VesselParams, facts: dict[str, Any], where: str = "boat file") -> VesselParams:
    """``base`` with a boat file's (parsed) facts over it. Over the built-in boat, facts that state another mass or
    length first carry it to that size (:func:`similar_boat`, its resistance Froude-scaled unless given:
    :func:`froude_scaled_resistance`; its turning the hull's where the carried reference turn cannot hold or a
    propulsion section is given; its manoeuvres' speed within its top speed), so what the file leaves out is
    derived from what it gives, never the 6 m boat's own. A propulsion section without a stated turning takes the
    hull's."""
    if "propulsion" in facts and "turning" not in facts and set(base.manoeuvring) != set(MANOEUVRING_KEYS):
        facts = {**facts, "turning": "hull"}
    if not (base == VesselParams() and _states_another_size(facts)):
        return _replaced(base, facts, where)
    default = VesselParams()
    mass = float(facts.get("mass_kg", default.mass_kg))  # positive and bounded: _states_another_size
    length = float(facts.get("length_m", default.length_m * (mass / default.mass_kg) ** (1.0 / 3.0)))
    resistance = facts.get("resistance") or froude_scaled_resistance(default, mass, length)
    try:
        params = similar_boat(resistance, mass, facts)
        if "turn_speed_mps" not in facts:  # manoeuvres start at a speed this boat can hold
            params = replace(params, turn_speed_mps=min(params.turn_speed_mps,
                                                        TURN_SPEED_SHARE_OF_TOP * top_speed_mps(params)))
        return params
    except InputError as err:
        raise InputError(f"{where}: {err}") from None


def _states_another_size(data: dict[str, Any]) -> bool:
    """Whether a vessel section states a mass or length other than the default boat's (a value beyond its bounds is
    left to the vessel's own check, which names it)."""
    default = VesselParams()
    return any(key in data and isinstance(data[key], (int, float)) and not isinstance(data[key], bool)
               and 0.0 < float(data[key]) <= UPPER_LIMITS[key][0] and float(data[key]) != getattr(default, key)
               for key in ("mass_kg", "length_m"))


def froude_scaled_resistance(base: VesselParams, mass_kg: float, length_m: float) -> TableResistance:
    """``base``'s resistance carried to a geometrically similar boat of ``mass_kg`` and ``length_m`` at equal Froude
    numbers: speeds × √(L/L₀), forces × m/m₀ (the residuary resistance coefficient kept; friction's Reynolds
    effect ignored: a small boat's is a few % higher, Faltinsen 2005, §9.1), N; tabulated at 40 speeds."""
    speeds = np.linspace(0.0, base.resistance.max_speed_mps, 40)
    forces = np.maximum.accumulate(np.asarray(base.resistance.force_N(speeds), dtype=float))
    return TableResistance(tuple(float(u) for u in speeds * math.sqrt(length_m / base.length_m)),
                           tuple(float(f) for f in forces * mass_kg / base.mass_kg))


def _number(value: Any, where: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where}: '{key}' must be a number, got {value!r}")
    return float(value)


def vessel_section(data: Any, where: str) -> Any:
    """The vessel fields of a model or boat file: the mapping itself, or its ``vessel:`` section; a key beside
    ``vessel:`` is refused (it would be dropped without a word: a twin configuration goes to --config)."""
    if isinstance(data, dict) and "vessel" in data:
        beside = sorted(str(key) for key in data if key != "vessel")
        if beside:
            raise InputError(f"{where}: '{beside[0]}' beside 'vessel:' would be ignored: a model or boat file holds "
                             "vessel fields only (put it under vessel:, or give a whole twin configuration as "
                             "--config)")
        return data["vessel"]
    return data


def load_params(path: Path, base: VesselParams | None = None) -> VesselParams:
    """Read vessel parameters (or an identified model's overrides) from a YAML file."""
    return params_from_dict(vessel_section(load_yaml(path), str(path)), str(path), base)


def save_params(params: VesselParams, path: Path) -> None:
    """Write all parameters to ``path`` as YAML (atomically)."""
    atomic_write_yaml(path, {"vessel": params_to_dict(params)})


def describe(params: VesselParams) -> dict[str, float | list[float]]:
    """Derived figures a reader checks for plausibility (docs/model.md)."""
    coeff = derive_coefficients(params)
    top = top_speed_mps(params)
    return {
        **{k: float(v) for k, v in asdict(coeff).items()},
        "reference_turn_thrust_per_engine_N": reference_turn_thrust_N(params),
        "yaw_time_constant_at_turn_speed_s": yaw_time_constant_s(params, params.turn_speed_mps),
        "sway_yaw_time_constants_at_turn_speed_s": list(sway_yaw_time_constants_s(params, params.turn_speed_mps)),
        "surge_time_constant_at_4mps_s": surge_time_constant_s(params, 4.0),
        "top_speed_mps": top,
    }


def available_thrust_N(params: VesselParams, speed_mps: float) -> float:
    """The whole thrust the boat's thrusters give ahead at full setting at speed through water u, N: two outboards'
    envelope (:func:`max_thrust_N`) on the default layout; per thruster of a boat file's propulsion, the envelope
    (newtons), the table's largest thrust (table), or the propeller at the shaft speed of its bollard thrust
    ``bollard_thrust_N`` (propeller)."""
    if params.propulsion is None:
        return float(2.0 * max_thrust_N(params, np.array(speed_mps)))
    total = 0.0
    for thruster in params.propulsion.thrusters:
        if thruster.table is not None:
            total += max(thruster.table.thrust_N)
        elif thruster.propeller is not None:
            full = thruster.propeller.rev_per_s_for(params.bollard_thrust_N)
            total += float(thruster.propeller.thrust(full, speed_mps))
        else:
            total += float(max_thrust_N(params, np.array(speed_mps)))
    return total


def top_speed_mps(params: VesselParams) -> float:
    """Speed where the available thrust (:func:`available_thrust_N`) equals the resistance, m/s (bisection on a
    monotone gap)."""
    lo, hi = 0.1, 60.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        gap = available_thrust_N(params, mid) - params.resistance.force_N(mid)
        lo, hi = (mid, hi) if gap > 0 else (lo, mid)
    return 0.5 * (lo + hi)



HELD_COMMAND_TIME_CONSTANTS = 15.0
"""A thrust command held unchanged longer than this many of the boat's surge response times
(:func:`surge_response_time_s`) is named in a trial's summary, -. The speed settles within 5 of them (e^-5 < 1 %
of a step left); a hold three times longer adds no dynamics to fit, and a helm rarely holds one exact value that
long, while a command stream that stopped (a logger or driver fault) is filled with its last value by the
zero-order hold and looks exactly like it."""


def surge_response_time_s(params: VesselParams) -> float:
    """The boat's slowest surge response: the largest m11·u / Fc(u) over its speeds up to the top speed (50
    speeds), s: the time constant of a linear drag through the origin that gives Fc(u) at u. Unlike m11 /
    (dFc/du) (:func:`surge_time_constant_s`) it stays finite over a resistance hump or plateau."""
    speeds = np.linspace(0.0, top_speed_mps(params), 51)[1:]
    return float(np.max(_inertia(params)["m11"] * speeds / params.resistance.force_N(speeds)))


def held_command_limit_s(params: VesselParams) -> float:
    """Longest thrust hold a trial's summary passes without a word: :data:`HELD_COMMAND_TIME_CONSTANTS` times
    :func:`surge_response_time_s`, s."""
    return HELD_COMMAND_TIME_CONSTANTS * surge_response_time_s(params)
