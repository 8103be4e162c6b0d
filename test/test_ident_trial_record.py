"""Offline identification reads a trial with the live twin's surge physics (ident/trial_record.py): thrust
requests delivered by the configured engines (η·P/u) through the steering actuator, the surge along the heading
at the GNSS latency, the sway-yaw coupling. Checked on a boat test/independent.py integrates, not the twin."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from independent import boat_trial

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.output_error import SurgeRecord, identify_surge
from boat_twin.ident.pipeline import trial_samples
from boat_twin.ident.trial_record import trial_record
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
