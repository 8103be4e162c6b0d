"""Problems 1 and 2, their inversion, the tow load, the convergence study and reported non-convergence."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from boat_twin.cable import (
    CableSolveError,
    case_from_dict,
    continuous_depth,
    convergence_study,
    load_case,
    solve_depth,
    solve_length,
    tow_load,
    tow_speed_for_depth,
    with_overrides,
)

CONFIG = Path(__file__).resolve().parents[1] / "config" / "cable"
BASE = {
    "tow_speed_mps": 1.5,
    "current": {"depth_m": [0.0, 100.0, 400.0], "speed_mps": [0.3, 0.1, 0.0]},
    "cable": {"length_m": 300.0, "diameter_m": 0.02, "weight_in_water_Npm": 30.0, "segment_length_m": 0.5},
    "vehicle": {"weight_in_water_N": 1000.0, "a_m": 1.0, "b_m": 0.65, "d_m": 0.35, "cx": 0.8},
}


def make_case(cable: dict | None = None, vehicle: dict | None = None, **top: object) -> object:
    data = copy.deepcopy(BASE)
    data["cable"].update(cable or {})
    data["vehicle"].update(vehicle or {})
    data.update(top)
    return case_from_dict(data, "test")


@pytest.mark.parametrize("drag", [{"model": "sphere"}, {"model": "normal_tangential"}])
@pytest.mark.parametrize("depth", [37.3, 150.0, 271.9])
def test_problem_2_inverts_problem_1(drag: dict, depth: float) -> None:
    case = make_case(cable={"segment_length_m": 2.0, "drag": drag})
    p2 = solve_length(case, depth)
    assert p2.node_depth_m[-1] == pytest.approx(0.0, abs=1e-9)
    p1 = solve_depth(case, p2.length_m)
    assert p1.vehicle_depth_m == pytest.approx(depth, rel=1e-6)
    assert p1.top_tension_N == pytest.approx(p2.top_tension_N, rel=1e-6)
    assert p1.vehicle_offset_m == pytest.approx(p2.vehicle_offset_m, rel=1e-6)


def test_problem_2_length_is_not_quantized_to_the_link_length() -> None:
    case = make_case(cable={"segment_length_m": 10.0})
    lengths = [solve_length(case, h).length_m for h in (100.0, 100.5, 101.0)]
    assert all(b > a for a, b in zip(lengths, lengths[1:], strict=False))
    assert any(abs(x / 10.0 - round(x / 10.0)) > 1e-3 for x in lengths)


def test_solution_geometry_is_consistent() -> None:
    sol = solve_depth(make_case(cable={"length_m": 123.45}))
    assert sol.length_m == pytest.approx(123.45)
    assert sol.node_x_m[-1] == 0.0 and sol.node_depth_m[-1] == pytest.approx(0.0, abs=1e-9)
    steps = np.hypot(np.diff(sol.node_x_m), np.diff(sol.node_depth_m))
    np.testing.assert_allclose(steps, sol.link_length_m, rtol=1e-12)
    assert np.all(np.diff(sol.link_tension_N) > 0.0)  # weight and drag only add up toward the boat
    x, z = sol.tow_frame_xz()
    assert x[-1] == pytest.approx(-sol.vehicle_offset_m) and z[-1] == pytest.approx(-sol.vehicle_depth_m)


def test_tow_load_components() -> None:
    case = make_case()
    load = tow_load(case, 2.0)
    sol = solve_depth(with_overrides(case, tow_speed_mps=2.0))
    assert load.tension_N == pytest.approx(math.hypot(load.horizontal_N, load.vertical_N))
    assert load.vertical_N == pytest.approx(1000.0 + 30.0 * 300.0)  # no lift: all weights hang on the boat
    assert load.horizontal_N == pytest.approx(sol.top_aft_N)
    assert tow_load(case, 2.5).horizontal_N > load.horizontal_N > tow_load(case, 1.0).horizontal_N
    still = tow_load(make_case(current=0.0), 0.0)
    assert still.horizontal_N == pytest.approx(0.0, abs=1e-9) and still.tension_N == pytest.approx(10000.0)


def test_tow_speed_for_depth_reproduces_the_paper_188_m() -> None:
    case = load_case(CONFIG / "babanin2025_table1.yaml")
    speed = tow_speed_for_depth(case, 188.0)
    at_speed = solve_depth(with_overrides(case, tow_speed_mps=speed))
    assert at_speed.vehicle_depth_m == pytest.approx(188.0, abs=1e-6)
    assert speed == pytest.approx(case.tow_speed_mps, abs=1e-3)  # the shipped case carries that speed


def test_convergence_study_is_first_order_toward_the_ode() -> None:
    case = load_case(CONFIG / "babanin2025_table1.yaml")
    study = convergence_study(case)
    assert [row.segment_length_m for row in study.rows] == [5.0, 2.5, 1.25, 0.625]
    errors = [abs(row.depth_error_m) for row in study.rows]
    assert all(b < a for a, b in zip(errors, errors[1:], strict=False))
    assert study.depth_order == pytest.approx(1.0, abs=0.05)
    assert study.length_order == pytest.approx(1.0, abs=0.05)
    assert study.rows[0].segment_length_m > study.segment_for_tolerance_m > study.rows[-1].segment_length_m
    assert abs(study.check_depth_error_m) / study.reference_depth_m < 1.05e-3
    assert study.reference_depth_m == pytest.approx(continuous_depth(case, 300.0).vehicle_depth_m, rel=1e-9)


def test_shipped_cases_load_and_solve() -> None:
    for name in ("default", "babanin2025_table1", "babanin2025_table2"):
        case = load_case(CONFIG / f"{name}.yaml")
        if case.cable.length_m is not None:
            assert 0.0 < solve_depth(case).vehicle_depth_m < case.cable.length_m
        if case.target_depth_m is not None:
            assert solve_length(case).length_m > case.target_depth_m


def test_lift_beyond_weight_is_reported_not_solved() -> None:
    case = make_case(cable={"length_m": 100.0, "weight_in_water_Npm": 1.0}, vehicle={"cy": 5.0},
                     tow_speed_mps=3.0)
    with pytest.raises(CableSolveError, match="lift exceeds"):
        solve_depth(case)


def test_no_attack_angle_in_the_table_is_reported() -> None:
    case = make_case(vehicle={"cx": {"alpha_deg": [0.0, 10.0], "value": [0.1, 0.1]}})
    with pytest.raises(CableSolveError, match="attack angle"):
        solve_depth(case)


def test_problem_2_beyond_the_winch_is_reported() -> None:
    case = make_case(cable={"winch_capacity_m": 200.0, "length_m": 150.0})
    assert solve_length(case, 150.0).length_m < 200.0
    with pytest.raises(CableSolveError, match="winch capacity"):
        solve_length(case, 250.0)
