"""Offline identification reads a trial with the live twin's surge physics (ident/trial_record.py): thrust
requests delivered by the configured engines (η·P/u) through the steering actuator, the surge along the heading
at the GNSS latency, the sway-yaw coupling. Checked on a boat test/independent.py integrates, not the twin."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from independent import boat_trial

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.output_error import ResistanceBasis, SurgeRecord, fit_surge, identify_surge
from boat_twin.ident.pipeline import identify_trials, physical_problems, trial_samples
from boat_twin.ident.trial_record import DELIVERED_THRUST, trial_record
from boat_twin.vessel.params import VesselParams, derive_coefficients

BOAT = replace(VesselParams(), mass_kg=1000.0, engine_power_W=20000.0)
"""Not the configured boat: lighter, smaller engines (η·P/u caps each engine's 2,000 N above 5.5 m/s)."""
LEVELS = (700.0, 2000.0, 1200.0, 2000.0, 400.0, 1600.0, 2000.0, 900.0)
"""Thrust requests per engine, N, each held 25 s: the top ones run into the envelope at speed."""


def _steered(duration_s: float = 200.0, seed: int = 1, **options: object):
    return boat_trial(BOAT, lambda t: LEVELS[int(t // 25.0) % len(LEVELS)],
                      lambda t: (0.35, 0.0, -0.35, 0.0)[int(t // 10.0) % 4], duration_s,
                      np.random.default_rng(seed), engines=True, **options)


def test_a_steered_trial_into_the_envelope_identifies_the_mass_within_its_interval() -> None:
    trial = _steered()
    m11 = derive_coefficients(BOAT).m11_kg
    fitted = identify_surge([trial_record(trial, TwinConfig(vessel=BOAT))]).selected
    low, high = fitted.mass_ci95_kg
    assert low <= m11 <= high and high - low < 0.15 * m11, (fitted.mass_kg, low, high)
    assert 0.8 < fitted.coupling_scale < 1.2  # the coupling m₂₂·v·r is there, at about its own size
    # the commanded record (Σ T·cos δ of the requests, |v|) cannot: its mass is far off or not identified
    commanded = identify_surge([SurgeRecord(*trial_samples(trial))])
    c_low, c_high = commanded.selected.mass_ci95_kg
    assert not (commanded.mass_identified and c_low <= m11 <= c_high)


def test_a_trial_without_heading_keeps_the_speed_and_no_coupling() -> None:
    trial = _steered(40.0)
    config = TwinConfig(vessel=BOAT)
    record = trial_record(trial, config)
    assert record.coupling_N is not None
    trial.heading_rad[:] = np.nan
    trial.yaw_rate_radps[:] = np.nan
    plain = trial_record(trial, config)
    assert plain.coupling_N is None
    np.testing.assert_allclose(plain.speed_mps, trial.speed_mps[-plain.t_s.size:])
    np.testing.assert_allclose(plain.t_s, trial.t_s[-plain.t_s.size:] - config.gnss.latency_s)
    assert np.all(plain.thrust_N <= 2.0 * BOAT.bollard_thrust_N + 1e-9)


@pytest.mark.parametrize("rate_radps", [0.0, 0.3])
def test_the_actuator_and_envelope_are_the_configured_ones(rate_radps: float) -> None:
    """The record's thrust is the configured boat's: an instantaneous actuator turns the full angle at once; the
    envelope caps each engine at η·P/u."""
    trial = _steered(40.0)
    vessel = replace(BOAT, steering_rate_radps=rate_radps)
    record = trial_record(trial, TwinConfig(vessel=vessel))
    u = np.interp(record.t_s, record.t_s, record.speed_mps)
    cap = 2.0 * np.minimum(vessel.bollard_thrust_N, vessel.propulsive_efficiency * vessel.engine_power_W / u)
    assert np.all(record.thrust_N[:-1] <= cap[:-1] * 1.05)
    at_once = trial_record(trial, TwinConfig(vessel=replace(BOAT, steering_rate_radps=0.0)))
    assert np.allclose(record.thrust_N, at_once.thrust_N) == (rate_radps == 0.0)


def test_identify_reads_the_config_of_a_trial_before_the_trial(tmp_path, capsys) -> None:
    from boat_twin.cli import main

    bad = tmp_path / "boat.yaml"
    bad.write_text("vessel:\n  engine_power_W: -5\n")
    assert main(["identify", str(tmp_path / "no_such_trial.mcap"), "--config", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "boat.yaml" in err[0] and "engine_power_W" in err[0]


def test_a_trial_whose_heading_covers_too_few_samples_is_refused_naming_the_file() -> None:
    trial = _steered(40.0)
    trial.heading_rad[2:] = np.nan  # a heading on the first two samples only: nothing to fit along it
    with pytest.raises(InputError, match="fewer than 3 samples with a known thrust, surge and heading"):
        trial_record(trial, TwinConfig(vessel=BOAT))


# What identify reports is what it fitted: the figures draw the records the fit read (Identification.records),
# checked on the data handed to the plot (the lines' arrays), not on pixels.

def _captured_figures(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """The figures the identification's report saves, by file name, instead of written."""
    from boat_twin.ident import report

    figures: dict[str, Any] = {}
    monkeypatch.setattr(report, "atomic_save_figure",
                        lambda path, figure, title=None: figures.__setitem__(Path(path).name, figure))
    return figures


def _assert_plots_the_record(figure: Any, record: SurgeRecord, coupling_scale: float) -> None:
    """trial.png draws ``record``: its speed, its thrust and (when it has one) its coupling times the fitted c."""
    speed_axes, force_axes = figure.axes
    np.testing.assert_array_equal(speed_axes.lines[0].get_xdata(), record.t_s)
    np.testing.assert_array_equal(speed_axes.lines[0].get_ydata(), record.speed_mps)
    np.testing.assert_array_equal(force_axes.lines[0].get_xdata(), record.t_s)
    np.testing.assert_array_equal(force_axes.lines[0].get_ydata(), record.thrust_N)
    assert len(force_axes.lines) == (1 if record.coupling_N is None else 2)
    if record.coupling_N is not None:
        np.testing.assert_allclose(force_axes.lines[1].get_ydata(), coupling_scale * record.coupling_N)


def _far_from_commanded(trial: Any, record: SurgeRecord) -> bool:
    """The commanded record (Σ T·cos δ of the requests) differs from ``record``'s thrust by more than 500 N
    somewhere: a plot of it would show points the fit never saw."""
    t_s, commanded_N, _ = trial_samples(trial)
    return bool(np.max(np.abs(np.interp(record.t_s, t_s, commanded_N) - record.thrust_N)) > 500.0)


def test_the_identify_report_plots_the_record_the_fit_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The report writer of identify --out and of the fleet's batches (ident/report.py) draws the steered
    trial's surge record under the given config, the one the fit read, not the commanded one."""
    from boat_twin.ident.report import write_identify_report

    trial, config = _steered(60.0), TwinConfig(vessel=BOAT)
    figures = _captured_figures(monkeypatch)
    result, found = identify_trials([trial], config=config)
    write_identify_report(tmp_path, result, found, "steered", None)
    record = trial_record(trial, config)
    assert record.coupling_N is not None and _far_from_commanded(trial, record)
    _assert_plots_the_record(figures["trial.png"], record, result["output_error"]["selected"]["coupling_scale"])
    assert {"trial.png", "resistance.png", "resimulation.png"} <= set(figures)


def test_the_demo_plots_the_record_its_identification_fitted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    """make demo identifies as identify does (the built-in boat's record) and draws that record."""
    from boat_twin.cli.demo import identification_summary

    trial = _steered(60.0)
    figures = _captured_figures(monkeypatch)
    summary = identification_summary(trial, tmp_path)
    record = trial_record(trial, TwinConfig())
    assert _far_from_commanded(trial, record)
    fitted = json.loads((tmp_path / "identify" / "identify.json").read_text())["output_error"]["selected"]
    _assert_plots_the_record(figures["trial.png"], record, fitted.get("coupling_scale", 1.0))
    assert f"effective mass {fitted['mass_kg']:.0f} kg" in summary


def test_identify_each_reads_each_trial_with_the_given_config(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    """identify --each --config: each trial is read with that boat (here other engines and a GNSS latency), as
    plain identify reads it; its report draws that record."""
    from boat_twin.cli import main
    from boat_twin.config import load_twin_config
    from boat_twin.io.sources import read_trial_file

    trial_path, config_path = tmp_path / "steered.mcap", tmp_path / "boat.yaml"
    assert main(["simulate", "random", "--duration", "60", "--seed", "40", "--out", str(trial_path)]) == 0
    config_path.write_text("vessel:\n  engine_power_W: 40000\ngnss:\n  latency_s: 0.2\n")
    figures = _captured_figures(monkeypatch)
    assert main(["identify", str(trial_path), "--each", "--config", str(config_path), "--out", str(tmp_path / "o"),
                 "--scheduler", "sync"]) == 0, capsys.readouterr().err
    trial, config = read_trial_file(trial_path), load_twin_config(config_path)
    record = trial_record(trial, config)
    default = trial_record(trial, TwinConfig())
    assert default.t_s.size != record.t_s.size  # the config matters here: the latency shifts the samples
    assert np.max(np.abs(np.interp(record.t_s, default.t_s, default.thrust_N) - record.thrust_N)) > 100.0
    fitted = json.loads((tmp_path / "o" / "steered" / "identify.json").read_text())["output_error"]["selected"]
    _assert_plots_the_record(figures["trial.png"], record, fitted.get("coupling_scale", 1.0))


def test_a_resistance_above_the_delivered_thrust_is_named_as_what_was_checked() -> None:
    """The "not physical" check compares Fc with the largest thrust of the fitted record, the delivered one: the
    message names that thrust, its value and the trial, not "commanded"."""
    trial = _steered(60.0)
    record = trial_record(trial, TwinConfig(vessel=BOAT))
    fit = fit_surge([record], ResistanceBasis(), mass_kg=1050.0)
    fit.coefficients[:] = (1e4, 0.0)  # Fc = 10,000 N·s/m × u: far above any thrust
    (problem,) = [p for p in physical_problems(fit, [], [(record.t_s, record.thrust_N, record.speed_mps)],
                                               DELIVERED_THRUST, ["steered.mcap"]) if "largest" in p]
    top = float(np.max(record.thrust_N))
    assert f"exceeds the largest {DELIVERED_THRUST}: {top:.4g} N in steered.mcap, yet the boat sustained" in problem
    assert "commanded" not in problem
