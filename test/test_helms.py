"""The compiled closed-loop kernel (the helm deciding inside numba) runs a trial exactly as the Python step loop
asking the scenario's helm: same states, derivatives, steering, commands and command stamps, bit for bit, with
a command delay, a slow helm, per-boat coefficients, on numba's threads and in chunks of ticks."""

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring_trials import draw_boat
from boat_twin.vessel import dynamics
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.helms import ENGINE_TURN, ZIGZAG
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import EngineTurningCircle, Zigzag, make_scenario
from boat_twin.vessel.simulate import SimulationRecord, simulate, simulate_chunks

PARAMS = VesselParams()
ANGLE = math.radians(20.0)


def _same(compiled: SimulationRecord, reference: SimulationRecord) -> None:
    for name in ("t_s", "states", "derivatives", "steering_rad", "commands", "command_issued_s"):
        np.testing.assert_array_equal(getattr(compiled, name), getattr(reference, name), err_msg=name)


def _both(params: VesselParams, scenario: Any, **kwargs: Any) -> tuple[SimulationRecord, SimulationRecord]:
    return simulate(params, scenario, **kwargs), simulate(params, scenario, compiled_helm=False, **kwargs)


@pytest.mark.parametrize(("delay_s", "rate_hz"), [(0.0, 0.0), (0.25, 0.0), (0.13, 10.0)])
def test_a_compiled_zigzag_is_the_python_helms_trial_bit_for_bit(delay_s: float, rate_hz: float) -> None:
    params = replace(PARAMS, command_delay_s=delay_s, thrust_time_constant_s=0.4)
    zigzag = Zigzag(params, ANGLE, ANGLE, approach_s=3.0, duration_s=25.0, decision_rate_hz=rate_hz)
    compiled, reference = _both(params, zigzag, environment=Environment(0.3, -0.2, 4.0, 2.0))
    _same(compiled, reference)
    assert compiled.command_issued_s is not None
    flips = np.flatnonzero(np.diff(compiled.commands[:, 0, 2]) != 0.0)
    assert flips.size >= 2  # the trial zigzags: the helm's decisions were exercised
    off_tick = compiled.command_issued_s[:, 0] != compiled.t_s
    assert off_tick.any() == (rate_hz == 0.0)  # a step helm reverses between ticks, a 10 Hz one on them


def test_a_compiled_engine_turning_circle_is_the_python_helms_trial() -> None:
    scenario = EngineTurningCircle(PARAMS, execute_s=2.0, duration_s=20.0)
    compiled, reference = _both(PARAMS, scenario)
    _same(compiled, reference)
    assert np.ptp(compiled.commands[:, 0, 0]) > 10.0  # the thrust followed the speed


def test_an_ensemble_on_threads_and_in_chunks_is_the_python_helms_each_boat_alone() -> None:
    config = TwinConfig()
    boats = [draw_boat(config, np.random.default_rng([5, i]))[0].vessel for i in range(dynamics.PARALLEL_MIN_BOATS)]
    params = config.vessel
    zigzag = Zigzag(params, ANGLE, ANGLE, approach_s=2.0, duration_s=12.0)
    whole = simulate(params, zigzag, boats=boats)  # the threaded kernel
    chunks = list(simulate_chunks(params, zigzag, boats=boats[:3], chunk_ticks=7))
    for name in ("states", "commands", "command_issued_s"):
        joined = np.concatenate([getattr(c, name) for c in chunks])
        np.testing.assert_array_equal(joined, getattr(whole, name)[:, :3], err_msg=name)
    for b in (0, 41):
        alone = simulate(params, zigzag, boats=boats[b:b + 1], compiled_helm=False)
        np.testing.assert_array_equal(whole.states[:, b], alone.states[:, 0])
        np.testing.assert_array_equal(whole.commands[:, b], alone.commands[:, 0])


def test_the_registered_closed_loop_scenarios_have_compiled_helms() -> None:
    zigzag = Zigzag(PARAMS, ANGLE, ANGLE)
    assert zigzag.compiled_helm().kind == ZIGZAG
    assert EngineTurningCircle(PARAMS).compiled_helm().kind == ENGINE_TURN


def test_the_prange_form_on_one_thread_is_the_plain_loop_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """Open-loop runs of PRANGE_MIN_BOAT_TICKS boat-ticks or more take the prange kernel (faster on one thread),
    a live twin's tick the plain loop: the same arithmetic."""
    scenario = make_scenario("random", PARAMS, np.random.default_rng(2), duration_s=30.0)
    pranged = simulate(PARAMS, scenario, initial_states=np.zeros((3, 6)))
    monkeypatch.setattr(dynamics, "PRANGE_MIN_BOAT_TICKS", 10**9)
    plain = simulate(PARAMS, scenario, initial_states=np.zeros((3, 6)))
    for name in ("states", "derivatives", "steering_rad"):
        np.testing.assert_array_equal(getattr(pranged, name), getattr(plain, name), err_msg=name)
