"""Cable physics against independent references: still water, catenary, critical angle, MoorPy, eq. 3."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from boat_twin.cable.body import body_equilibrium
from boat_twin.cable.case import case_from_dict
from boat_twin.cable.continuous import continuous_depth, continuous_length
from boat_twin.cable.drag import NormalTangentialDrag, SphereDrag
from boat_twin.cable.links import CHUNK_LINKS, link_lengths, march
from boat_twin.cable.problems import solve_depth

RHO = 1025.0
BASE = {
    "water_density_kgpm3": RHO,
    "tow_speed_mps": 1.5,
    "current": {"depth_m": [0.0, 100.0, 400.0], "speed_mps": [0.3, 0.1, 0.0]},
    "cable": {"length_m": 300.0, "diameter_m": 0.02, "weight_in_water_Npm": 30.0, "segment_length_m": 0.5,
              "drag": {"model": "sphere", "cx": 0.47}},
    "vehicle": {"weight_in_water_N": 1000.0, "a_m": 1.0, "b_m": 0.65, "d_m": 0.35, "cx": 0.8, "cy": 0.0},
}


def make_case(**changes: dict) -> object:
    """BASE with sections updated: make_case(cable={"length_m": 50}, tow_speed_mps=0.0)."""
    data = copy.deepcopy(BASE)
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict) and "model" not in value:
            data[key].update(value)
        else:
            data[key] = value
    return case_from_dict(data, "test")


NT = {"model": "normal_tangential", "cn": 1.5, "ct": 0.02}


@pytest.mark.parametrize("drag", [{"model": "sphere", "cx": 0.47}, NT])
def test_still_water_hangs_vertical(drag: dict) -> None:
    case = make_case(tow_speed_mps=0.0, current=0.0, cable={"length_m": 123.4, "drag": drag})
    sol = solve_depth(case)
    assert sol.vehicle_depth_m == pytest.approx(123.4, rel=1e-12)
    assert np.max(np.abs(sol.node_x_m)) < 1e-9
    assert sol.top_tension_N == pytest.approx(1000.0 + 30.0 * 123.4, rel=1e-12)
    assert math.degrees(sol.top_angle_rad) == pytest.approx(90.0)
    assert math.degrees(sol.body.alpha_rad) == pytest.approx(90.0)


def _sequential_sphere(case: object, depth_m: float, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's recurrence (eqs. 1-10) written out link by link, independent of links.march."""
    body = body_equilibrium(case.vehicle, RHO, case.flow_mps(depth_m))
    tx, ty = body.pull_aft_N, body.pull_down_N
    y, x, ys, xs = depth_m, 0.0, [], []
    for length in lengths:
        beta = math.atan2(ty, tx)
        y -= length * math.sin(beta)
        x += length * math.cos(beta)
        v = case.tow_speed_mps + float(np.interp(y, [0.0, 100.0, 400.0], [0.3, 0.1, 0.0]))
        tx += 0.47 * RHO * v * v / 2.0 * 0.02 * length
        ty += 30.0 * length
        ys.append(y)
        xs.append(x)
    return np.array(ys), np.array(xs)


def test_vectorized_march_equals_the_sequential_recurrence() -> None:
    case = make_case()
    lengths = link_lengths(250.3, 0.2)
    body = body_equilibrium(case.vehicle, RHO, case.flow_mps(220.0))
    marched = march(case.loading(), body.pull_aft_N, body.pull_down_N, 220.0, lengths)
    ref_y, ref_x = _sequential_sphere(case, 220.0, lengths)
    assert lengths.size == 1252 > CHUNK_LINKS and lengths[-1] == pytest.approx(0.1)
    np.testing.assert_allclose(marched.node_depth_m, ref_y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(marched.node_forward_m, ref_x, rtol=0, atol=1e-9)
    wild_guess = np.linspace(-1.0, 1.5, lengths.size)
    again = march(case.loading(), body.pull_aft_N, body.pull_down_N, 220.0, lengths, wild_guess)
    np.testing.assert_allclose(again.node_depth_m, ref_y, rtol=0, atol=1e-9)


def test_normal_tangential_drag_limits() -> None:
    law = NormalTangentialDrag(cn=1.3, ct=0.025)
    v, d = 2.0, 0.03
    q = 0.5 * RHO * v * v
    aft, down = law.per_length(RHO, d, np.array([v, v]), np.array([math.pi / 2, 0.0]))
    assert aft[0] == pytest.approx(q * 1.3 * d) and down[0] == pytest.approx(0.0, abs=1e-9)
    assert aft[1] == pytest.approx(q * 0.025 * math.pi * d) and down[1] == pytest.approx(0.0, abs=1e-12)
    beta = math.radians(30.0)
    aft, down = law.per_length(RHO, d, np.array([v]), np.array([beta]))
    normal, tangential = q * 1.3 * d * math.sin(beta) ** 2, q * 0.025 * math.pi * d * math.cos(beta) ** 2
    tangent = np.array([-math.cos(beta), -math.sin(beta)])  # up the cable, (aft, down)
    assert np.dot([aft[0], down[0]], -tangent) == pytest.approx(tangential)
    assert np.dot([aft[0], down[0]], [math.sin(beta), -math.cos(beta)]) == pytest.approx(normal)
    s_aft, s_down = SphereDrag(0.47).per_length(RHO, d, np.array([-v]), np.array([beta]))
    assert s_aft[0] == pytest.approx(-0.47 * q * d) and s_down[0] == 0.0


def _catenary(h: float, v0: float, w: float, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = h / w
    x = a * (np.arcsinh((v0 + w * s) / h) - np.arcsinh(v0 / h))
    z = a * (np.sqrt(1.0 + ((v0 + w * s) / h) ** 2) - np.sqrt(1.0 + (v0 / h) ** 2))
    return x, z


def _dragless(segment: float) -> object:
    return make_case(tow_speed_mps=2.0, current=0.0,
                     cable={"segment_length_m": segment, "drag": {"model": "sphere", "cx": 0.0}})


def test_dragless_links_converge_to_the_catenary() -> None:
    errors = []
    for segment in (2.0, 1.0, 0.5):
        sol = solve_depth(_dragless(segment))
        h, v0 = sol.body.drag_N, 1000.0
        assert h > 100.0  # the vehicle's drag is the horizontal pull
        s = np.concatenate(([0.0], np.cumsum(sol.link_length_m)))
        x, z = _catenary(h, v0, 30.0, s)
        forward = sol.node_x_m[0] - sol.node_x_m
        rise = sol.vehicle_depth_m - sol.node_depth_m
        errors.append(max(np.max(np.abs(forward - x)), np.max(np.abs(rise - z))))
        assert sol.top_aft_N == pytest.approx(h, rel=1e-12)
        assert sol.top_down_N == pytest.approx(v0 + 30.0 * 300.0, rel=1e-12)
    assert errors[-1] < 0.5
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert 1.8 < coarse / fine < 2.2  # first order in l


def test_continuous_reference_is_the_catenary() -> None:
    case = _dragless(1.0)
    ref = continuous_depth(case, 300.0)
    x, z = _catenary(ref.body.drag_N, 1000.0, 30.0, ref.arc_m)
    np.testing.assert_allclose(ref.forward_m, x, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ref.vehicle_depth_m - ref.depth_m, z, rtol=0, atol=1e-6)
    assert ref.depth_m[-1] == pytest.approx(0.0, abs=1e-8)


def test_tensions_match_moorpy_catenary() -> None:
    catenary = pytest.importorskip("moorpy.Catenary").catenary

    def moorpy_tensions(offset_m: float, depth_m: float) -> tuple[float, float]:
        f_ah, f_av, f_bh, f_bv, _info = catenary(offset_m, depth_m, 300.0, 1e15, 30.0, CB=-1000.0,
                                                 Tol=1e-10, MaxIter=200)
        return math.hypot(f_ah, f_av), math.hypot(f_bh, f_bv)

    ref = continuous_depth(_dragless(1.0), 300.0)
    bottom, top = moorpy_tensions(ref.vehicle_offset_m, ref.vehicle_depth_m)
    assert ref.top_tension_N == pytest.approx(top, rel=1e-6)
    assert math.hypot(ref.pull_aft_N[0], ref.pull_down_N[0]) == pytest.approx(bottom, rel=1e-6)
    gaps = []
    for segment in (0.5, 0.25):
        links = solve_depth(_dragless(segment))
        bottom, top = moorpy_tensions(links.vehicle_offset_m, links.vehicle_depth_m)
        assert links.top_tension_N == pytest.approx(top, rel=1e-3)
        gaps.append(abs(links.link_tension_N[0] / bottom - 1.0))
    assert gaps[1] < 5e-3 and 1.8 < gaps[0] / gaps[1] < 2.2  # the links' geometry converges in l


def test_normal_drag_cable_tends_to_the_critical_angle() -> None:
    w, cn, d, u = 10.0, 1.5, 0.02, 2.0
    case = make_case(tow_speed_mps=u, current=0.0,
                     cable={"length_m": 1500.0, "weight_in_water_Npm": w, "segment_length_m": 0.5,
                            "drag": {"model": "normal_tangential", "cn": cn, "ct": 0.0}},
                     vehicle={"weight_in_water_N": 100.0, "d_m": 0.2})
    r = 0.5 * RHO * cn * d * u * u
    critical = math.acos((-w + math.sqrt(w * w + 4.0 * r * r)) / (2.0 * r))
    sol = solve_depth(case)
    assert abs(sol.link_angle_rad[0] - critical) > math.radians(5.0)  # starts far from it
    np.testing.assert_allclose(sol.link_angle_rad[-1000:], critical, rtol=0, atol=1e-6)
    ref = continuous_length(case, 200.0)
    assert math.atan2(ref.pull_down_N[-1], ref.pull_aft_N[-1]) == pytest.approx(critical, abs=1e-6)


def test_attack_angle_solves_equation_3_with_a_as_the_weight_arm() -> None:
    case = make_case()
    v = 1.7
    q = 0.5 * RHO * v * v * 0.35**2
    body = body_equilibrium(case.vehicle, RHO, v)
    assert math.tan(body.alpha_rad) == pytest.approx(1000.0 * 1.0 / (0.65 * 0.8 * q), rel=1e-10)
    swapped = make_case(vehicle={"a_m": 0.65, "b_m": 1.0})
    alpha = body_equilibrium(swapped.vehicle, RHO, v).alpha_rad
    assert math.tan(alpha) == pytest.approx(1000.0 * 0.65 / (1.0 * 0.8 * q), rel=1e-10)
    table = make_case(vehicle={"cx": {"alpha_deg": [0, 45, 90], "value": [0.5, 1.5, 0.9]},
                               "cy": {"alpha_deg": [-10, 90], "value": [-0.2, 0.8]}})
    body = body_equilibrium(table.vehicle, RHO, v)
    assert table.vehicle.moment_Nm(RHO, v, body.alpha_rad) == pytest.approx(0.0, abs=1e-9)
    assert body.drag_N == pytest.approx(table.vehicle.cx.at(body.alpha_rad) * q)
    assert body.pull_down_N == pytest.approx(1000.0 - table.vehicle.cy.at(body.alpha_rad) * q)


def test_current_sign_convention_head_current_adds_to_tow_speed() -> None:
    head = solve_depth(make_case(tow_speed_mps=1.5, current=0.5))
    faster = solve_depth(make_case(tow_speed_mps=2.0, current=0.0))
    still = solve_depth(make_case(tow_speed_mps=1.5, current=0.0))
    assert head.vehicle_depth_m == pytest.approx(faster.vehicle_depth_m, rel=1e-10)
    assert head.vehicle_depth_m < still.vehicle_depth_m - 10.0
    following = solve_depth(make_case(tow_speed_mps=1.5, current=-0.5))
    assert following.vehicle_depth_m > still.vehicle_depth_m + 10.0
