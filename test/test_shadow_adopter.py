"""The one adoption rule of the live twin (boat_twin/shadow/adopter.py), on scalar models."""

from __future__ import annotations

import math

import numpy as np

from boat_twin.shadow.adopter import MAX_WAIT_PERIODS, Adopter, hotelling_rejects


class Scalar(Adopter[float]):
    """A model that is one number; physical within [0.5, 2]."""

    def _physical(self, model: float) -> bool:
        return 0.5 <= model <= 2.0

    def _describe(self, back_to: float, replaced: float) -> str:
        return f"back to {back_to} from {replaced}"


def differ(fit: float, model: float) -> bool:
    return abs(fit - model) > 0.1


def test_a_rejecting_physical_better_candidate_is_adopted_and_the_old_model_comes_back_when_it_predicts_better():
    lines: list[str] = []
    adopter = Scalar(1.0, period_s=10.0, margin=0.1, log=lines.append)
    truth = 1.5
    score = lambda model: (model - truth) ** 2 + 0.01  # noqa: E731
    standing = adopter.cycle(1.05, score(1.0), score, rejects=differ, margin=0.1, revert_why=lambda a, b: "")
    assert standing.standing and standing.changed is None and adopter.current == 1.0
    unphysical = adopter.cycle(3.0, score(1.0), score, rejects=differ, margin=0.1, revert_why=lambda a, b: "")
    assert not unphysical.standing and unphysical.changed is None and adopter.current == 1.0
    adopted = adopter.cycle(1.5, score(1.0), score, rejects=differ, margin=0.1, revert_why=lambda a, b: "")
    assert adopted.changed == "adopted" and adopter.current == 1.5 and adopter.previous == [1.0]
    assert math.isclose(adopted.score, 0.01) and adopter.swaps == 1
    truth = 1.0  # the boat is the old one again: no fit, the replaced model predicts better
    reverted = adopter.cycle(None, score(1.5), score, rejects=differ, margin=0.1,
                             revert_why=lambda now, before: f"{now:.2f} -> {before:.2f}")
    assert reverted.changed == "reverted" and adopter.current == 1.0 and not adopter.previous
    assert lines == ["back to 1.0 from 1.5: 0.26 -> 0.01"] and adopter.swaps == 2


def test_a_fit_rejecting_the_replaced_model_keeps_it_away():
    adopter = Scalar(1.5, period_s=10.0, margin=0.1)
    adopter.previous = [1.0]
    score = lambda model: (model - 1.0) ** 2  # noqa: E731
    outcome = adopter.cycle(1.5, score(1.5), score, rejects=differ, margin=0.1, revert_why=lambda a, b: "")
    assert outcome.changed is None and adopter.current == 1.5


def test_the_schedule_backs_off_to_its_limit_and_restarts():
    adopter = Scalar(1.0, period_s=10.0, margin=0.1)
    assert not adopter._scheduled(0.0)  # no first time yet
    adopter._next_s = 5.0
    assert not adopter._scheduled(4.0) and adopter._scheduled(5.0) and not adopter._scheduled(14.0)
    for _ in range(5):
        adopter.back_off()
    assert adopter.wait_s == MAX_WAIT_PERIODS * 10.0
    adopter.reset()
    assert adopter.wait_s == 10.0 and math.isnan(adopter._next_s)


def test_hotelling_rejects_a_distant_model_only_with_enough_clusters():
    cov = np.eye(2) * 0.01
    assert hotelling_rejects(np.array([1.0, 1.0]), cov, clusters=20)
    assert not hotelling_rejects(np.array([0.01, 0.0]), cov, clusters=20)
    assert not hotelling_rejects(np.array([1.0, 1.0]), cov, clusters=3)  # g <= q + 1: cannot be judged
    assert not hotelling_rejects(np.array([1.0, 1.0]), np.full((2, 2), np.nan), clusters=20)


def test_the_adapters_models_are_keyword_only_and_frozen():
    import dataclasses

    import pytest

    from boat_twin.shadow.adapt import SurgeModel
    from boat_twin.shadow.turning import TurningModel

    with pytest.raises(TypeError):
        SurgeModel(1300.0, 1.0)  # type: ignore[misc]  # a reordered field would silently mis-assign
    with pytest.raises(TypeError):
        TurningModel({"m22_kg": 1.0})  # type: ignore[misc]
    model = SurgeModel(mass_kg=1300.0, resistance_factor=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        model.mass_kg = 1.0  # type: ignore[misc]
