"""Minimum searches: L-BFGS-B's own result when it converges early, a ridge
searched on in whitened coordinates, and the Hessian of the gradient."""

import numpy as np
from scipy import optimize, stats

from skmba._core.search import (
    PRECONDITION_AFTER,
    gradient_hessian,
    preconditioned_minimum,
)


def _quadratic(curvatures, offset=0.0, seed=0):
    """``offset + (v - c)' A (v - c) / 2`` and its gradient, with ``A``'s
    eigenvalues ``curvatures`` in random directions; ``A`` and ``c``."""
    d = len(curvatures)
    Q = stats.ortho_group.rvs(d, random_state=seed)
    A = (Q * curvatures) @ Q.T
    c = np.random.default_rng(seed).normal(size=d)

    def objective(v):
        r = v - c
        return offset + 0.5 * r @ A @ r, A @ r

    return objective, A, c


def _l_bfgs_b(objective, v0, **options):
    """scipy's L-BFGS-B alone."""
    return optimize.minimize(
        objective, v0, jac=True, method="L-BFGS-B", options=options
    )


def test_a_search_that_converges_early_is_l_bfgs_b_s_own():
    objective, _, c = _quadratic(np.linspace(1.0, 10.0, 6))
    v0 = np.zeros(6)
    own = _l_bfgs_b(objective, v0)
    assert own.nit < PRECONDITION_AFTER
    found = preconditioned_minimum(objective, v0)
    np.testing.assert_array_equal(found.x, own.x)
    assert found.fun == own.fun and found.nfev == own.nfev
    np.testing.assert_allclose(found.x, c, atol=1e-4)


def test_a_ridge_is_searched_on_in_whitened_coordinates():
    """Curvatures over eight decades and a value of -9e4 at the minimum,
    as module 2's posterior on the bridge year: L-BFGS-B alone stops on its
    relative reduction 0.04 above the minimum (measured); whitened by the
    Hessian after PRECONDITION_AFTER iterations, within 0.0022."""
    objective, _, _ = _quadratic(np.logspace(-3.0, 4.7, 15), offset=-9e4, seed=1)
    v0 = np.zeros(15)
    alone = _l_bfgs_b(objective, v0)
    found = preconditioned_minimum(objective, v0)
    assert alone.fun + 9e4 > 0.02
    assert 0.0 <= found.fun + 9e4 < 0.005
    assert found.nfev > PRECONDITION_AFTER  # the whitened stage ran


def test_a_hessian_that_cannot_be_computed_keeps_the_first_stage_s_result():
    objective, _, _ = _quadratic(np.logspace(-3.0, 4.7, 15), offset=-9e4, seed=1)
    v0 = np.zeros(15)
    first = _l_bfgs_b(objective, v0, maxiter=PRECONDITION_AFTER)
    calls = []

    def failing(v):  # no gradient after the first stage's evaluations
        calls.append(v)
        value, gradient = objective(v)
        if len(calls) > first.nfev:
            return value, np.full_like(gradient, np.nan)
        return value, gradient

    found = preconditioned_minimum(failing, v0)
    np.testing.assert_array_equal(found.x, first.x)
    assert found.fun == first.fun and len(calls) == first.nfev + 2 * len(v0)


def test_the_hessian_of_the_gradient_is_the_quadratic_s_matrix():
    objective, A, _ = _quadratic(np.logspace(-1.0, 3.0, 5))
    H = gradient_hessian(objective, np.ones(5))
    np.testing.assert_allclose(H, A, rtol=0, atol=1e-8 * np.abs(A).max())
