import numpy as np
import pytest
from scipy.optimize import minimize

import skmba.gp._lbfgsb
from skmba.gp._lbfgsb import (
    GAIN_TOL,
    blocked,
    inverse_hessian_product,
    minimize_lbfgsb,
    predicted_gain,
)


def quadratic(A, centre, scale=1.0):
    """``-loglik = scale (x - c)' A (x - c) / 2`` and its gradient."""

    def objective(x):
        r = x - centre
        return 0.5 * scale * r @ A @ r, scale * A @ r

    return objective


def test_two_loop_recursion_is_exact_along_the_secant_pairs():
    # BFGS updates satisfy the secant equation of the newest pair, H^-1 y = s,
    # and on a one-dimensional quadratic any pair gives the exact inverse.
    rng = np.random.default_rng(0)
    A = np.diag([1.0, 10.0, 100.0])
    pairs = [(s, A @ s) for s in rng.normal(size=(4, 3))]
    s, y = pairs[-1]
    np.testing.assert_allclose(inverse_hessian_product(y, pairs), s, rtol=1e-12)
    one_pair = [(np.ones(1), np.array([4.0]))]
    assert inverse_hessian_product(np.array([6.0]), one_pair) == 1.5


def test_predicted_gain_ignores_components_held_by_a_bound():
    bounds = np.array([[0.0, 1.0], [0.0, 1.0]])
    x = np.array([0.0, 0.5])
    grad = np.array([3.0, 2.0])  # descent -grad leaves the box in x[0]
    assert blocked(x, grad, bounds).tolist() == [True, False]
    assert not blocked(x, -grad, bounds).any()
    pairs = [(np.array([0.0, 1.0]), np.array([0.0, 4.0]))]  # curvature 4
    assert predicted_gain(x, grad, bounds, pairs) == pytest.approx(2.0**2 / 4 / 2)


@pytest.mark.parametrize("n_observations", [1, 100, 100_000])
def test_stops_once_the_true_gain_left_is_below_the_tolerance(n_observations):
    # -loglik of n observations: curvature proportional to n, as a likelihood
    A = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.2], [0.0, 0.2, 0.5]])
    centre = np.array([0.3, -1.0, 2.0])
    objective = quadratic(A, centre, scale=n_observations)
    bounds = np.tile([-10.0, 10.0], (3, 1))
    res = minimize_lbfgsb(objective, np.zeros(3), bounds, n_observations)
    assert res.success
    assert res.fun == objective(res.x)[0]  # in the objective's units
    np.testing.assert_array_equal(res.jac, objective(res.x)[1])
    assert res.fun <= GAIN_TOL


def test_first_step_of_a_per_observation_objective_stays_inside_the_box():
    # Raw -loglik of 10,000 observations has a gradient of order 1e4 at the
    # start: L-BFGS-B's first step (the identity for a Hessian) would reach
    # the bounds; on the per-observation objective it moves by order one.
    n = 10_000
    objective = quadratic(np.eye(2), np.array([1.0, -0.5]), scale=n)
    bounds = np.tile([-9.0, 9.0], (2, 1))
    visited = []

    def recorded(x):
        visited.append(np.array(x))
        return objective(x)

    minimize_lbfgsb(recorded, np.zeros(2), bounds, n)
    assert np.abs(visited[1]).max() < 2.0
    raw = minimize(recorded, np.zeros(2), jac=True, method="L-BFGS-B", bounds=bounds)
    assert raw.nfev > 0 and np.abs(visited[-raw.nfev + 1]).max() == 9.0


def test_runs_stopped_by_scipy_are_returned_in_the_objective_units(monkeypatch):
    # A gain tolerance of zero leaves the stop to scipy's own tests.
    monkeypatch.setattr(skmba.gp._lbfgsb, "GAIN_TOL", -1.0)
    objective = quadratic(np.eye(1), np.array([0.5]), scale=50.0)
    res = minimize_lbfgsb(objective, np.array([3.0]), np.array([[-5.0, 5.0]]), 50)
    assert res.success and "predicted gain" not in res.message
    assert res.fun == pytest.approx(objective(res.x)[0], abs=1e-12)
    assert res.jac == pytest.approx(objective(res.x)[1], abs=1e-9)
