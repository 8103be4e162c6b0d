"""Case files and their flat-parameter form (what the ROS node declares), without ROS."""

from __future__ import annotations

import array
import dataclasses
import math
from pathlib import Path

import pytest

from boat_twin.cable.case import UNSET_BY_ZERO, case_from_parameters, case_parameters, load_case
from boat_twin.cable.drag import NormalTangentialDrag, drag_from_spec
from boat_twin.errors import InputError

CONFIG = Path(__file__).resolve().parents[1] / "config" / "cable"


@pytest.mark.parametrize("name", ["default", "babanin2025_table1", "babanin2025_table2"])
def test_parameters_round_trip(name: str) -> None:
    case = load_case(CONFIG / f"{name}.yaml")
    flat = case_parameters(case)
    assert all(key in flat for key in UNSET_BY_ZERO)
    assert all(isinstance(v, (float, str, list)) for v in flat.values())
    as_ros = {k: array.array("d", v) if isinstance(v, list) else v for k, v in flat.items()}
    back = case_from_parameters(as_ros, case.source)
    assert back == case


def test_table_coefficients_and_drag_round_trip() -> None:
    case = load_case(CONFIG / "default.yaml")
    flat = case_parameters(case)
    del flat["vehicle.cx"], flat["cable.drag.cx"]
    flat.update({"vehicle.cx.alpha_deg": [0.0, 45.0, 90.0], "vehicle.cx.value": [0.5, 1.0, 1.2],
                 "cable.drag.model": "normal_tangential", "cable.drag.cn": 1.2, "cable.drag.ct": 0.01,
                 "cable.length_m": 0.0})
    back = case_from_parameters(flat)
    assert back.cable.length_m is None
    assert back.cable.drag == NormalTangentialDrag(1.2, 0.01)
    assert back.vehicle.cx.at(math.radians(22.5)) == pytest.approx(0.75)
    assert case_from_parameters(case_parameters(back)) == dataclasses.replace(back, source="parameters")


def test_drag_defaults_are_the_documented_ones() -> None:
    assert drag_from_spec(None).cx == 0.47
    law = drag_from_spec({"model": "normal_tangential"})
    assert 1.2 <= law.cn <= 1.5 and 0.01 <= law.ct <= 0.03


def test_parameter_errors_name_the_field() -> None:
    flat = case_parameters(load_case(CONFIG / "default.yaml"))
    flat["cable.diameter_m"] = -0.01
    with pytest.raises(InputError, match="cable.diameter_m"):
        case_from_parameters(flat, "/cable")
