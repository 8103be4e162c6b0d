"""The Imbens-Kolesár degrees of freedom of cluster-robust intervals (boat_twin.ident.jackknife) and the
manoeuvring fit's use of them, checked against cases with a known answer and by simulation."""

from __future__ import annotations

import numpy as np
import pytest

from boat_twin.ident.jackknife import cluster_degrees_of_freedom, cluster_squares, jackknife_covariance


def _squares(design: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return design.T @ design, cluster_squares(design, labels)


def test_equal_clusters_give_one_less_than_their_number() -> None:
    labels = np.repeat(np.arange(10), 50)
    information, squares = _squares(np.ones((500, 1)), labels)  # a mean over 10 equal clusters: exactly G − 1
    assert cluster_degrees_of_freedom(information, squares) == pytest.approx([9.0])


@pytest.mark.parametrize("holding", [2, 3, 5])
def test_a_coefficient_carried_by_few_clusters_gets_about_their_number_less_one(holding: int) -> None:
    rng = np.random.default_rng(0)
    labels = np.repeat(np.arange(10), 50)
    design = np.column_stack([np.ones(500), rng.normal(size=500)])
    design[labels >= holding, 1] = 0.0  # the slope is seen in the first ``holding`` clusters only
    dof = cluster_degrees_of_freedom(*_squares(design, labels))
    assert dof[0] == pytest.approx(9.0, abs=0.1)
    assert dof[1] == pytest.approx(holding - 1.0, abs=0.6)


def test_with_those_degrees_of_freedom_the_jackknife_interval_holds_the_truth_95_percent() -> None:
    """A slope seen in 3 of 12 clusters, cluster effects in the errors: the t interval with G − p = 10 degrees of
    freedom under-covers, with the Imbens-Kolesár figure (about 2) it holds."""
    from scipy.special import stdtrit

    rng = np.random.default_rng(1)
    labels = np.repeat(np.arange(12), 30)
    design = np.column_stack([np.ones(360), rng.normal(size=360)])
    design[labels >= 3, 1] = 0.0
    dof = cluster_degrees_of_freedom(*_squares(design, labels))[1]
    held = {"G - p": 0, "Imbens-Kolesár": 0}
    draws = 2000
    for _ in range(draws):
        errors = rng.normal(size=12)[labels] + rng.normal(size=360)
        beta, *_ = np.linalg.lstsq(design, design @ np.array([1.0, 2.0]) + errors, rcond=None)
        residual = design @ np.array([1.0, 2.0]) + errors - design @ beta
        cov, groups = jackknife_covariance(design, residual, labels)
        se = float(np.sqrt(cov[1, 1]))
        held["G - p"] += abs(beta[1] - 2.0) <= stdtrit(groups - 2, 0.975) * se
        held["Imbens-Kolesár"] += abs(beta[1] - 2.0) <= stdtrit(dof, 0.975) * se
    assert held["G - p"] / draws < 0.93, held
    assert held["Imbens-Kolesár"] / draws >= 0.94, held
