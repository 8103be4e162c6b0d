"""Reproduction of Dyda & Chumakova (2021): their power-series fits of Table 1 and Fisher statistic, and ours.

Everything here is in the table's own units: speed v in knots, thrust F in kgf (the paper prints no units;
see :func:`boat_twin.data.dyda2021_table1`), so coefficients are in kgf/kn^i.

The paper's Fisher statistic (the formula under its Table 7) is

    F_calc = [Σ_j (F_mj − mean(F_m))² / m] · (n − m − 1) / Σ_j (F_j − F_mj)²

with m = 1 "factor" and n = 36 "experiments", while the sums run over all 37 rows of Table 1 (the row
(0, 0) included). Read that way it gives Table 7's 314.76 (N = 1) and 228.98 (N = 3) from the printed
coefficients; the printed 315.3 for N = 5 does not follow from the printed N = 5 coefficients.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.polynomial import polynomial

from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_COEFFICIENTS, PAPER_FISHER, PAPER_ORDERS, TABLE_MODEL_VALUES, TABLE_NUMBERS
from boat_twin.ident.steady import OrderSelection, fit_power_series, select_order

FISHER_N = 36
"""n in the paper's (n − m − 1) factor ("n = 36 – количество экспериментов"; Table 1 has 37 rows)."""

FISHER_M = 1
"""m in the paper's formula ("m = 1 – количество факторов")."""

FISHER_TOLERANCE = 0.05
"""Agreement with Table 7 is judged to its last printed digit: |ours − printed| ≤ 0.05."""

PRINT_TOLERANCE = 1e-6
"""Relative deviation above which a printed model value counts as a misprint (the tables print ~10 digits)."""


def fisher_statistic(
    force: np.ndarray, model_force: np.ndarray, m: int = FISHER_M, n: int = FISHER_N
) -> float:
    """The paper's F_calc = [Σ(F_m − mean F_m)²/m]·(n − m − 1)/Σ(F − F_m)², sums over all given rows."""
    f = np.asarray(force, dtype=float)
    fm = np.asarray(model_force, dtype=float)
    explained = float(np.sum((fm - fm.mean()) ** 2))
    residual = float(np.sum((f - fm) ** 2))
    return explained / m * (n - m - 1) / residual


def paper_model_values(order: int) -> np.ndarray:
    """F_m in kgf at Table 1's speeds from the paper's own coefficients of order ``order`` (1, 3 or 5)."""
    speed_kn, _ = dyda2021_table1()
    return polynomial.polyval(speed_kn, PAPER_COEFFICIENTS[order])


def check_printed_tables() -> dict[int, dict[str, Any]]:
    """Compare Tables 2, 4, 6 as printed with the values the printed coefficients give.

    Per order: the table number, the largest relative deviation and the rows deviating by more than
    :data:`PRINT_TOLERANCE` (speed in kn, printed and recomputed kgf).
    """
    speed_kn, _ = dyda2021_table1()
    out: dict[int, dict[str, Any]] = {}
    for order in PAPER_ORDERS:
        ours = paper_model_values(order)
        printed = np.asarray(TABLE_MODEL_VALUES[order])
        rel = np.abs(printed - ours) / np.maximum(np.abs(ours), 1.0)
        rows = np.flatnonzero(rel > PRINT_TOLERANCE)
        out[order] = {
            "table": TABLE_NUMBERS[order],
            "max_rel_dev": float(rel.max()),
            "max_rel_dev_without_misprints": float(np.delete(rel, rows).max()),
            "misprints": [
                {
                    "speed_kn": float(speed_kn[j]),
                    "printed_kgf": float(printed[j]),
                    "recomputed_kgf": float(ours[j]),
                }
                for j in rows
            ],
        }
    return out


def reproduce(
    monotone: bool = False, order: int | None = None, max_order: int = 8, through_origin: bool = False
) -> dict[str, Any]:
    """Everything ``boat-twin identify --table dyda2021`` reports, as a JSON-ready dict (kn, kgf).

    ``paper``: Fisher statistic recomputed from the paper's coefficients next to Table 7, RMSE of the paper's
    fits, the check of Tables 2/4/6. ``fits``: least-squares fits N = 1..``max_order`` (plus ``order`` if
    higher) with the paper's Fisher statistic for each; ``selected_order`` by CV/BIC, or ``order`` if given.
    ``monotone`` and ``through_origin`` as in :func:`~boat_twin.ident.steady.fit_power_series`.
    """
    speed_kn, thrust_kgf = dyda2021_table1()
    selection: OrderSelection = select_order(
        speed_kn, thrust_kgf, max_order, monotone, force_unit="kgf", through_origin=through_origin
    )
    fits = list(selection.fits)
    if order is not None and order not in {f.order for f in fits}:
        fits.append(fit_power_series(speed_kn, thrust_kgf, order, monotone, through_origin))
    fisher, rmse = {}, {}
    for n in PAPER_ORDERS:
        model = paper_model_values(n)
        fisher[str(n)] = fisher_statistic(thrust_kgf, model)
        rmse[str(n)] = float(np.sqrt(np.mean((thrust_kgf - model) ** 2)))
    fit_dicts = []
    for fit in fits:
        entry = fit.to_dict()
        entry["fisher"] = fisher_statistic(thrust_kgf, fit.predict(speed_kn))
        fit_dicts.append(entry)
    return {
        "data": {
            "source": "Dyda & Chumakova (2021), Table 1",
            "rows": int(speed_kn.size),
            "units": {"speed": "kn", "force": "kgf", "coefficients": "kgf/kn^i"},
        },
        "paper": {
            "coefficients": {str(n): list(PAPER_COEFFICIENTS[n]) for n in PAPER_ORDERS},
            "fisher": fisher,
            "fisher_printed": {str(n): v for n, v in PAPER_FISHER.items()},
            "fisher_agrees": {
                str(n): abs(fisher[str(n)] - PAPER_FISHER[n]) <= FISHER_TOLERANCE for n in PAPER_ORDERS
            },
            "fisher_formula": {"m": FISHER_M, "n": FISHER_N, "rows_summed": int(speed_kn.size)},
            "rmse": rmse,
            "tables": {str(n): v for n, v in check_printed_tables().items()},
        },
        "fits": fit_dicts,
        "selected_order": order if order is not None else selection.selected_order,
        "selection_reason": f"N = {order}: set by --order" if order is not None else selection.reason,
        "monotone": monotone,
        "through_origin": through_origin,
    }
