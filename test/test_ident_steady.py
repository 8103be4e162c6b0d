"""Batch least squares of Fc(v): statistics against definitions, conditioning, monotone option, errors."""

import numpy as np
import pytest
from scipy import optimize

from boat_twin.errors import InputError
from boat_twin.ident.steady import choose_order, fit_power_series, nonmonotone_bands, select_order

P = np.polynomial.polynomial


@pytest.fixture(scope="module")
def points() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    v = np.sort(rng.uniform(0.5, 9.0, 25))
    return v, P.polyval(v, [0.0, 60.0, 4.0, 0.9]) + rng.normal(0.0, 8.0, v.size)


def test_fit_and_statistics_match_their_textbook_definitions(points) -> None:
    v, f = points
    fit = fit_power_series(v, f, 3)
    x = np.vander(v, 4, increasing=True)
    coef, *_ = np.linalg.lstsq(x, f, rcond=None)
    np.testing.assert_allclose(fit.coefficients, coef, rtol=1e-9, atol=1e-9)
    resid = f - x @ coef
    n, k = v.size, 4
    sigma2 = resid @ resid / (n - k)
    np.testing.assert_allclose(fit.covariance, sigma2 * np.linalg.inv(x.T @ x), rtol=1e-7)
    assert fit.sse == pytest.approx(resid @ resid, rel=1e-10)
    assert fit.rmse == pytest.approx(np.sqrt(resid @ resid / n), rel=1e-10)
    assert fit.r2 == pytest.approx(1 - resid @ resid / np.sum((f - f.mean()) ** 2), rel=1e-10)
    assert fit.aic == pytest.approx(n * np.log(resid @ resid / n) + 2 * k, rel=1e-10)
    assert fit.bic == pytest.approx(n * np.log(resid @ resid / n) + k * np.log(n), rel=1e-10)
    t975 = 2.0796  # Student t, 21 degrees of freedom
    np.testing.assert_allclose(fit.ci95[:, 1] - fit.coefficients, t975 * fit.stderr, rtol=1e-4)


def test_leave_one_out_cv_equals_explicit_refits(points) -> None:
    v, f = points
    fit = fit_power_series(v, f, 4)
    errors = []
    for j in range(v.size):
        keep = np.arange(v.size) != j
        c = P.polyfit(v[keep], f[keep], 4)
        errors.append(f[j] - P.polyval(v[j], c))
    assert fit.cv_rmse == pytest.approx(np.sqrt(np.mean(np.square(errors))), rel=1e-8)


def test_high_order_on_many_points_is_well_conditioned() -> None:
    rng = np.random.default_rng(0)
    v = rng.uniform(0.0, 10.0, 100_000)
    true = np.array([0.0, 80.0, -30.0, 9.0, -1.2, 0.08, -0.002, 1e-5, 1e-7])
    fit = fit_power_series(v, P.polyval(v, true) + rng.normal(0.0, 1e-6, v.size), 8)
    np.testing.assert_allclose(fit.coefficients[1:], true[1:], rtol=1e-4)
    assert abs(fit.coefficients[0]) < 1e-5


def test_through_origin_is_least_squares_without_c0(points) -> None:
    v, f = points
    fit = fit_power_series(v, f, 3, through_origin=True)
    coef, *_ = np.linalg.lstsq(np.vander(v, 4, increasing=True)[:, 1:], f, rcond=None)
    assert fit.coefficients[0] == 0.0 and fit.stderr[0] == 0.0
    np.testing.assert_allclose(fit.coefficients[1:], coef, rtol=1e-9)


@pytest.fixture(scope="module")
def hump() -> tuple[np.ndarray, np.ndarray]:
    """A resistance curve with a dip (a noisy planing hump): unconstrained fits decrease somewhere."""
    rng = np.random.default_rng(1)
    v = np.linspace(0.0, 10.0, 40)
    f = np.where(v < 5.0, 10.0 * v, 50.0) + 1.0 + rng.normal(0.0, 2.0, v.size)
    f[(v > 5.0) & (v < 7.0)] -= 8.0
    return v, f


@pytest.mark.parametrize("order", [3, 5, 7])
def test_monotone_fit_is_the_constrained_optimum(hump, order: int) -> None:
    v, f = hump
    free = fit_power_series(v, f, order)
    mono = fit_power_series(v, f, order, monotone=True)
    assert mono.monotone and mono.monotone_constraint
    grid = np.linspace(0.0, 10.0, 20_001)
    slope = P.polyval(grid, P.polyder(mono.coefficients))
    assert slope.min() > -1e-4 * np.abs(slope).max()  # to within the 2001-point constraint grid
    assert mono.predict(0.0) >= -1e-9
    assert mono.sse >= free.sse - 1e-9
    # an independent optimiser on the same constraints finds no better feasible point (with exact gradients:
    # SLSQP's finite differences stopped on a line-search failure at an infeasible point under one BLAS thread)
    g = np.linspace(0.0, 10.0, 2001)
    d = np.column_stack([i * g ** (i - 1) if i else 0 * g for i in range(order + 1)])
    x = np.vander(v, order + 1, increasing=True)
    first = np.eye(order + 1)[:1]
    cons = [{"type": "ineq", "fun": lambda c: d @ c, "jac": lambda c: d},
            {"type": "ineq", "fun": lambda c: c[:1], "jac": lambda c: first}]
    res = optimize.minimize(
        lambda c: np.sum((x @ c - f) ** 2),
        mono.coefficients,
        jac=lambda c: 2.0 * x.T @ (x @ c - f),
        constraints=cons,
        method="SLSQP",
        options={"maxiter": 1000, "ftol": 1e-14},
    )
    assert (d @ res.x).min() > -1e-6 * np.abs(d @ res.x).max() and res.x[0] >= -1e-9  # the reference is feasible
    assert mono.sse <= res.fun * (1 + 1e-6)


def test_non_monotone_bands_are_reported(hump) -> None:
    v, f = hump
    fit = fit_power_series(v, f, 7)
    assert not fit.monotone and fit.nonmonotone_bands
    for lo, hi in fit.nonmonotone_bands:
        mid = np.linspace(lo, hi, 5)[1:-1] if hi > lo else np.array([lo])
        assert np.all(P.polyval(mid, P.polyder(fit.coefficients)) <= 0.0)
    assert nonmonotone_bands(np.array([0.0, 1.0, 1.0]), (0.0, 5.0)) == ()


def test_resistance_model_extrapolates_with_the_quadratic_law(points) -> None:
    v, f = points
    fit = fit_power_series(v, f, 3, monotone=True, through_origin=True)
    model = fit.resistance_model()
    top = v.max()
    assert model.max_speed_mps == top
    assert model.force_N(2 * top) == pytest.approx(4 * fit.predict(top), rel=1e-12)


def test_choose_order_rule() -> None:
    # CV screens out order 4 (over-fit), BIC picks 3 over 2 by more than 2; 5 is within 2 of 3 -> 3
    order, reason = choose_order(
        [(1, 10.0, 50.0), (2, 4.0, 30.0), (3, 3.0, 20.0), (4, 9.0, 10.0), (5, 3.1, 19.0)]
    )
    assert order == 3 and "N = 1, 4 dropped" in reason
    assert choose_order([(1, 1.0, 5.0), (2, 1.1, 1.0)])[0] == 2


def test_select_order_fits_every_allowed_order(points) -> None:
    v, f = points
    sel = select_order(v[:6], f[:6], max_order=8)
    assert [fr.order for fr in sel.fits] == [1, 2, 3, 4]  # n - 2 = 4
    assert sel.selected.order == sel.selected_order


@pytest.mark.parametrize(
    ("speed", "force", "order", "message"),
    [
        ([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0], 3, "order 3 needs at least 5 points"),
        ([1.0, 1.0, 1.0, 2.0, 2.0], [1.0, 2.0, 3.0, 4.0, 5.0], 2, "needs at least 3 distinct speeds"),
        ([1.0, np.nan, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0], 1, "NaN or infinite (first at index 1)"),
        ([1.0, 2.0], [1.0, 2.0, 3.0], 1, "same length"),
        ([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0], 20, "order must be an integer from 0 to 12"),
    ],
)
def test_bad_points_raise_input_error(speed, force, order: int, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        fit_power_series(speed, force, order)
