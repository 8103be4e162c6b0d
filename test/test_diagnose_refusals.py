"""What the diagnosis says when it cannot judge or finds no cause: the missing signal named in the refusal, and a
text verdict that never reads like an all-clear while structure is left unexplained; a validation without
positions that says so."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.diagnose import hidden
from boat_twin.diagnose.report import text_report
from boat_twin.errors import InputError
from boat_twin.io.bags import read_trial
from boat_twin.twin.replay import SIGNALS, cut_windows


def test_a_trial_without_imu_names_the_missing_signals(tmp_path: Path) -> None:
    trial = read_trial(hidden.write_trial(tmp_path / "t.mcap", TwinConfig(), "random", 3, 200.0))
    cut_windows(trial)  # the whole trial: enough windows
    blank = np.full(trial.t_s.size, np.nan)
    no_imu = replace(trial, heading_rad=blank, yaw_rate_radps=blank)
    with pytest.raises(InputError, match=r"no yaw rate \(imu angular velocity\) and no heading \(imu orientation\)"):
        cut_windows(no_imu)


def _result(verdict: list, unexplained: bool) -> dict:
    rmse = {s: 0.1 for s in ("speed_mps", *SIGNALS, "position_m")}
    signature = [{"signal": "yaw_rate_radps", "misfit": 3.2, "heldout_r2": 0.6, "correlated_with": ["steering"],
                  "worst_time_s": 120.0}] if unexplained else []
    return {"trial": "t.mcap", "windows": {"count": 10, "length_s": 20.0}, "baseline": {"rmse": rmse},
            "extended": {"rmse": rmse}, "verdict": verdict, "ambiguous": None, "candidates": [],
            "unexplained": unexplained, "signature": signature, "extended_model": None}


def test_an_unexplained_result_never_reads_like_an_all_clear() -> None:
    text = text_report(_result([], True))  # type: ignore[arg-type]
    assert "verdict     UNEXPLAINED" in text and "no significant discrepancy" not in text
    assert "no significant discrepancy" in text_report(_result([], False))  # type: ignore[arg-type]
    named = [{"effect": "gyro_bias", "parameters": {"bias_radps": 0.01}, "ci95": {"bias_radps": [0.009, 0.011]},
              "gain": {"yaw_rate_radps": 0.5}}]
    assert "PARTLY UNEXPLAINED" in text_report(_result(named, True))  # type: ignore[arg-type]


def test_a_manoeuvring_validation_without_positions_says_so_without_numpy_warnings(tmp_path: Path) -> None:
    """`identify --manoeuvring --validate` on a trial whose GNSS gave velocity but no position: no track figure
    (None, printed as "no GNSS positions"), no RuntimeWarning from a mean of nothing."""
    import warnings

    from boat_twin.ident.manoeuvring import validate

    trial = read_trial(hidden.write_trial(tmp_path / "z.mcap", TwinConfig(), "zigzag", 4, 120.0))
    blank = np.full(trial.t_s.size, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check = validate(replace(trial, east_m=blank, north_m=blank), TwinConfig())
    assert check["track_rmse_m"] is None and np.isfinite(check["heading_rmse_deg"])
