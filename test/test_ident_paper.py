"""Dyda & Chumakova (2021) reproduced: Tables 2/4/6, the Fisher statistic of Table 7, the LSQ optimum, CLI."""

import json

import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_FISHER
from boat_twin.ident.paper import (
    check_printed_tables,
    fisher_statistic,
    paper_model_values,
    reproduce,
)
from boat_twin.vessel.params import load_params


@pytest.fixture(scope="module")
def result() -> dict:
    return reproduce()


@pytest.mark.parametrize(("order", "printed"), [(1, 314.76), (3, 228.98)])
def test_fisher_statistic_matches_table7(order: int, printed: float) -> None:
    _, thrust = dyda2021_table1()
    assert fisher_statistic(thrust, paper_model_values(order)) == pytest.approx(printed, abs=0.05)


def test_fisher_statistic_is_the_papers_formula() -> None:
    f = np.array([1.0, 2.0, 4.0])
    fm = np.array([1.5, 2.0, 3.5])
    by_hand = ((fm - fm.mean()) ** 2).sum() / 1 * (36 - 1 - 1) / ((f - fm) ** 2).sum()
    assert fisher_statistic(f, fm) == pytest.approx(by_hand, rel=1e-12)


def test_fisher_for_order5_does_not_follow_from_printed_coefficients(result: dict) -> None:
    paper = result["paper"]
    assert paper["fisher_agrees"] == {"1": True, "3": True, "5": False}
    assert abs(paper["fisher"]["5"] - PAPER_FISHER[5]) > 10.0


def test_printed_model_values_follow_from_printed_coefficients() -> None:
    tables = check_printed_tables()
    assert tables[1]["misprints"] == [] and tables[5]["misprints"] == []
    assert tables[1]["max_rel_dev"] < 1e-9 and tables[5]["max_rel_dev"] < 1e-6
    assert tables[3]["max_rel_dev_without_misprints"] < 1e-8
    (bad,) = tables[3]["misprints"]  # Table 4 at 14.5 kn prints 74.1092228: a "0" after the point is missing
    assert bad["speed_kn"] == 14.5
    assert bad["recomputed_kgf"] == pytest.approx(74.01092228, abs=1e-7)


def test_least_squares_optimum_beats_the_papers_fits(result: dict) -> None:
    speed, thrust = dyda2021_table1()
    fits = {f["order"]: f for f in result["fits"]}
    for order in (1, 3, 5):
        assert fits[order]["rmse"] < result["paper"]["rmse"][str(order)]
        np.testing.assert_allclose(
            fits[order]["coefficients"], np.polynomial.polynomial.polyfit(speed, thrust, order), rtol=1e-8
        )
    assert result["paper"]["rmse"]["5"] > result["paper"]["rmse"]["1"]  # the paper's N = 5 is not better


def test_selected_order_follows_the_stated_rule(result: dict) -> None:
    fits = result["fits"]
    best_cv = min(f["cv_rmse"] for f in fits)
    kept = [f for f in fits if f["cv_rmse"] <= 2.0 * best_cv]
    best_bic = min(f["bic"] for f in kept)
    expected = min(f["order"] for f in kept if f["bic"] <= best_bic + 2.0)
    assert result["selected_order"] == expected
    assert f"N = {expected}" in result["selection_reason"]


def test_cli_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "--table", "dyda2021", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["paper"]["fisher"]) == {"1", "3", "5"} and set(out["paper"]["rmse"]) == {"1", "3", "5"}
    for fit in out["fits"]:
        assert {"order", "coefficients", "stderr", "rmse", "aic", "bic", "cv_rmse", "monotone"} <= set(fit)
        assert len(fit["coefficients"]) == len(fit["stderr"]) == fit["order"] + 1
    assert out["selected_order"] in {f["order"] for f in out["fits"]}
    assert out["si"]["max_speed_mps"] == pytest.approx(18 * 1852 / 3600)


def test_cli_text_report_and_outputs(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(["identify", "--table", "dyda2021", "--monotone", "--order", "3", "--out", str(tmp_path)]) == 0
    )
    text = capsys.readouterr().out
    assert "314.76" in text and "228.98" in text and "315.30" in text and "NO" in text
    for name in ("report.txt", "identify.json", "model.yaml", "fits.png", "residuals.png"):
        assert (tmp_path / name).stat().st_size > 0
    params = load_params(tmp_path / "model.yaml")
    u = np.linspace(0.0, 9.26, 50)
    force = params.resistance.force_N(u)
    assert np.all(np.diff(force) >= -1e-6) and force[-1] == pytest.approx(120 * 9.80665, rel=0.05)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["identify"], "give a TRIAL (bag, .mcap, .tlog, .BIN, .csv) or --table dyda2021"),
        (["identify", "--table", "dyda2021", "--order", "0"], "--order must be from 1 to 12"),
        (["identify", "--table", "dyda2021", "--order", "40"], "--order must be from 1 to 12"),
        (["identify", "--table", "dyda2021", "--max-order", "0"], "--max-order must be from 1 to 12"),
    ],
)
def test_cli_bad_input_is_one_line_and_exit_2(argv, message, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
