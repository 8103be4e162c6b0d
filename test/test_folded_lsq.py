"""The least squares on the folded triangle of [f J] (boat_twin/folded_lsq.py) against scipy's on the whole
vectors, and the output-error surge fit's streamed covariance against the whole-Jacobian jackknife."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares
from test_ident_output_error import run_boat, short_holds

from boat_twin.folded_lsq import TriangleFold, folded_least_squares
from boat_twin.ident import output_error
from boat_twin.ident.jackknife import jackknife_covariance
from boat_twin.ident.output_error import ResistanceBasis, _cluster_covariance, _Problem, fit_surge, split_segments


def decay(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    return x[0] * np.exp(-x[1] * t) + x[2] * np.sin(x[3] * t)


def decay_jacobian(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.exp(-x[1] * t), -x[0] * t * np.exp(-x[1] * t), np.sin(x[3] * t),
                            x[2] * t * np.cos(x[3] * t)])


@pytest.mark.parametrize("x_scale", ["jac", 1.0])
def test_the_folded_fit_takes_scipy_s_steps_on_the_whole_vectors(x_scale) -> None:
    """A bounded nonlinear fit (one bound active at the solution) of 30,000 rows, folded in four parts:
    the same solution and the same number of evaluations as ``least_squares`` given the whole f and J."""
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 20.0, 30_000)
    truth = np.array([2.0, 0.3, 0.5, 1.7])
    y = decay(truth, t) + rng.normal(0.0, 0.05, t.size)
    lower, upper = np.array([0.0, 0.0, 0.0, 0.0]), np.array([10.0, 0.25, 5.0, 5.0])  # the decay rate held at 0.25
    x0 = np.array([1.0, 0.1, 0.2, 1.5])

    whole = least_squares(lambda x: decay(x, t) - y, x0, jac=lambda x: decay_jacobian(x, t), bounds=(lower, upper),
                          method="trf", x_scale=x_scale)

    def triangle(x: np.ndarray) -> np.ndarray:
        fold = TriangleFold(x.size + 1)
        for rows in np.array_split(np.arange(t.size), 4):  # four parts of 7,500 rows
            fold.add(np.column_stack([decay(x, t[rows]) - y[rows], decay_jacobian(x, t[rows])]))
        return fold.square()

    folded = folded_least_squares(lambda x: float(np.linalg.norm(decay(x, t) - y)), triangle, x0, lower, upper,
                                  x_scale=x_scale)
    assert folded.nfev == whole.nfev
    np.testing.assert_allclose(folded.x, whole.x, rtol=1e-9)
    np.testing.assert_array_equal(folded.active_mask, whole.active_mask)
    assert whole.active_mask[1] == 1  # the bound is met: the reflective steps were exercised


def test_the_surge_fit_s_streamed_covariance_is_the_whole_jacobian_s_jackknife(monkeypatch) -> None:
    """Two recordings of an independent boat cut into three segments: the cluster-robust covariance from the
    segments' rows streamed twice (the information, then each cluster's shift) equals the jackknife of the whole
    stacked Jacobian; the rows simulated 700 at a time (clusters across the chunks' bounds) are the whole
    simulation's, bit for bit. (The baseline basis: a spline basis' terms span a, b's directions too, and the
    jackknife's spread along such exact dependencies is rounding, in either order of sums.)"""
    rng = np.random.default_rng(11)
    first, _ = run_boat(short_holds(rng, 300.0), 20.0, rng)
    second, _ = run_boat(short_holds(rng, 200.0), 20.0, rng)
    keep = np.r_[0:1200, 1500:second.t_s.size]  # a 30 s gap in the second: three segments
    second = type(second)(second.t_s[keep], second.thrust_N[keep], second.speed_mps[keep])
    records = [first, second]
    basis = ResistanceBasis()
    fit = fit_surge(records, basis)
    segments = split_segments(records)
    assert len(segments) == 3
    problem = _Problem(records, segments, basis, fit.top_speed_mps, None)
    x = problem.pack(fit.coefficients, fit.mass_kg, 1.0, fit.initial_speeds_mps)
    rows = list(problem.segment_rows(x))
    residual = np.concatenate([r for _, _, r, _ in rows])
    jac = np.vstack([j for _, _, _, j in rows])
    monkeypatch.setattr(output_error, "FOLD_ROWS", 700)
    chunked = list(problem.segment_rows(x))
    assert len(chunked) > 2 * len(rows)
    np.testing.assert_array_equal(np.vstack([j for _, _, _, j in chunked]), jac)
    np.testing.assert_array_equal(np.concatenate([r for _, _, r, _ in chunked]), residual)
    free = np.ones(x.size, dtype=bool)
    prior = np.zeros((int(free.sum()),) * 2)
    streamed, information, clusters, cluster_s = _cluster_covariance(problem, x, residual, free, prior)
    labels = np.concatenate([np.floor((r.t_s[g.start:g.stop] - r.t_s[g.start]) / cluster_s).astype(int) + 1000 * k
                             for k, (g, r) in enumerate((g, records[g.record]) for g in segments)])
    whole, groups = jackknife_covariance(jac[:, free], residual, labels)
    assert clusters == groups
    np.testing.assert_allclose(information, jac[:, free].T @ jac[:, free], rtol=1e-10)
    scale = np.sqrt(np.outer(np.diag(whole), np.diag(whole)))
    assert np.max(np.abs(streamed - whole) / scale) < 1e-9
    np.testing.assert_allclose(np.diag(streamed), np.diag(whole), rtol=1e-9)
