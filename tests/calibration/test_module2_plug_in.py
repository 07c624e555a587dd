"""Module-2 discrepancy likelihood: gradients, fixed noise, optimisers."""

import numpy as np
import pytest

from skmba.calibration import _module2_plug_in
from skmba.calibration._module2_plug_in import DiscrepancyFit
from skmba.kernels import Gauss


@pytest.fixture
def problem():
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(15, 2))
    Y = np.column_stack([np.sin(3 * X[:, 0]), X[:, 1] ** 2, X[:, 0]])
    Y = Y + 0.05 * rng.normal(size=Y.shape)
    A = rng.normal(size=(45, 45))
    V_fixed = 0.01 * (A @ A.T) / 45
    return X, Y, V_fixed


def assert_gradient_is_the_likelihood_slope(fit, x, h=1e-6):
    """Analytic gradient against central finite differences at ``x``."""
    _, grad = fit.evaluate(x)
    numeric = [
        (fit.evaluate(x + h * e, False) - fit.evaluate(x - h * e, False)) / (2 * h)
        for e in np.eye(x.size)
    ]
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-6)


def test_gradient_matches_finite_differences(problem):
    X, Y, V_fixed = problem
    fit = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed)
    x = fit.start() + 0.1 * np.random.default_rng(1).normal(size=fit.start().size)
    assert_gradient_is_the_likelihood_slope(fit, x)


@pytest.mark.parametrize("restricted", [False, True])
def test_the_gradient_of_many_field_values_takes_the_inverse_from_potri(
    monkeypatch, restricted
):
    """From INVERSE_BY_POTRI field values on, V^-1 comes from potri: the
    same gradient as the two triangular solves, and the slope of the
    likelihood."""
    rng = np.random.default_rng(3)
    n, q = 30, 9  # 270 field values
    assert n * q >= _module2_plug_in.INVERSE_BY_POTRI
    X = np.sort(rng.uniform(size=(n, 1)), axis=0)
    Y = np.sin(3 * X) * rng.normal(size=q) + 0.1 * rng.normal(size=(n, q))
    A = rng.normal(size=(n * q, 40))
    fit = DiscrepancyFit(
        Gauss([1.0]), X, Y, np.ones((n, 1)), 0.01 * A @ A.T / 40, restricted=restricted
    )
    x = fit.start() + 0.1 * rng.normal(size=fit.start().size)
    ll, grad = fit.evaluate(x)
    monkeypatch.setattr(_module2_plug_in, "INVERSE_BY_POTRI", n * q + 1)
    ll_solves, grad_solves = fit.evaluate(x)
    assert ll == ll_solves
    np.testing.assert_allclose(grad, grad_solves, rtol=1e-10, atol=1e-10)
    monkeypatch.undo()
    assert_gradient_is_the_likelihood_slope(fit, x, h=1e-5)


def test_optimum_is_stationary_and_noise_can_be_fixed(problem):
    X, Y, V_fixed = problem
    fit = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed)
    est = fit.optimize(n_restarts=1, random_state=0)
    assert est.sigma2.shape == (3, 3) and est.beta.shape == (1, 3)
    assert np.all(np.linalg.eigvalsh(est.sigma2) > 0)
    start = fit.start()
    ll_start = fit.evaluate(start, False)
    assert est.log_likelihood >= ll_start
    assert est.log_likelihood == fit.evaluate(est.params, False)
    fixed = DiscrepancyFit(
        Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed, fixed_noise=1e-6
    )
    held = fixed.optimize(random_state=0)
    np.testing.assert_allclose(held.noise, 1e-6 * fixed.scale**2, rtol=1e-10)
    assert held.log_likelihood <= est.log_likelihood + 1e-8


def test_differential_evolution_and_bad_optimizer(problem):
    X, Y, V_fixed = problem
    # one response keeps the global search small (4 parameters)
    V1 = V_fixed[:15, :15]
    fit = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y[:, :1], np.ones((15, 1)), V1)
    best = fit.optimize(optimizer="differential_evolution", random_state=0)
    local = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y[:, :1], np.ones((15, 1)), V1)
    near = local.optimize(random_state=0)
    assert np.isfinite(best.log_likelihood)
    assert best.log_likelihood >= near.log_likelihood - 1e-3 * abs(near.log_likelihood)
    with pytest.raises(ValueError, match="discrepancy optimizer"):
        fit.optimize(optimizer="adam")


def test_pack_inverts_unpack_and_covers_any_covariance(problem):
    X, Y, V_fixed = problem
    fit = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed)
    rng = np.random.default_rng(2)
    A = rng.normal(size=(3, 3))
    sigma2 = A @ A.T + 0.1 * np.eye(3)  # correlations up to about 0.9
    L = np.linalg.cholesky(sigma2)
    lam = np.array([0.01, 0.02, 0.03])
    params = fit.pack(np.log([1.0, 2.0]), lam, L)
    theta, lam_back, L_back = fit.unpack(params)
    np.testing.assert_allclose(L_back @ L_back.T, sigma2, rtol=1e-12)
    np.testing.assert_allclose(lam_back, lam, rtol=1e-12)
    np.testing.assert_allclose(fit.pack(theta, lam_back, L_back), params)


def test_variance_bounds_hold_exactly_with_a_free_correlation(problem):
    X, Y, V_fixed = problem
    low, high = np.array([0.05, 0.2, 0.01]), np.array([0.1, 5.0, 0.02])
    fit = DiscrepancyFit(
        Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed, (low, high)
    )
    est = fit.optimize(n_restarts=1, random_state=0)
    variances = np.diag(est.sigma2)
    assert np.all(variances >= low * (1 - 1e-9)) and np.all(variances <= high * 1.001)
    # The lower end is each response's own part: Sigma_d - diag(low) is PSD.
    assert np.linalg.eigvalsh(est.sigma2 - np.diag(low))[0] > -1e-12
    # The gradient is still the likelihood's, with the floor in place.
    x = est.params + 0.05 * np.random.default_rng(3).normal(size=est.params.size)
    assert_gradient_is_the_likelihood_slope(fit, x)
    # The unbounded maximum is at least as likely as the bounded one.
    plain = DiscrepancyFit(Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed)
    unbounded = plain.optimize(n_restarts=1, random_state=0)
    assert unbounded.log_likelihood >= est.log_likelihood - 1e-8


def _with_gaps(Y):
    """``Y`` with a few entries unmeasured (NaN), no response left empty."""
    Y = Y.copy()
    Y[[0, 3, 3, 7, 11], [0, 1, 2, 0, 2]] = np.nan
    return Y


def _dense_log_likelihood(fit, x, restricted):
    """The (restricted) Gaussian log-likelihood of the measured entries of
    vec(Y), from the dense covariance restricted to them."""
    theta, lam, L = fit.unpack(x)
    n, q = fit.n, fit.q
    R = fit.kernel.clone_with_theta(theta)(fit.X)
    V = fit.V_fixed + np.kron(L @ L.T, R) + np.kron(np.diag(lam), np.eye(n))
    keep = np.isfinite(fit.Y.T.ravel())
    V, y = V[np.ix_(keep, keep)], fit.Y.T.ravel()[keep]
    Xr = np.kron(np.eye(q), fit.H)[keep]
    Vi_X = np.linalg.solve(V, Xr)
    beta = np.linalg.solve(Xr.T @ Vi_X, Vi_X.T @ y)
    r = y - Xr @ beta
    _, logdet = np.linalg.slogdet(V)
    ll = -0.5 * (keep.sum() * np.log(2 * np.pi) + logdet + r @ np.linalg.solve(V, r))
    if restricted:
        _, logdet_w = np.linalg.slogdet(Xr.T @ Vi_X)
        ll -= 0.5 * (logdet_w - Xr.shape[1] * np.log(2 * np.pi))
    return ll


@pytest.mark.parametrize("restricted", [False, True])
def test_unmeasured_entries_give_the_likelihood_of_the_measured_ones(
    problem, restricted
):
    X, Y, V_fixed = problem
    fit = DiscrepancyFit(
        Gauss([1.0, 2.0]),
        X,
        _with_gaps(Y),
        np.ones((15, 1)),
        V_fixed,
        restricted=restricted,
    )
    assert fit.observed.size == Y.size - 5
    x = fit.start() + 0.1 * np.random.default_rng(2).normal(size=fit.start().size)
    assert fit.evaluate(x, False) == pytest.approx(
        _dense_log_likelihood(fit, x, restricted), rel=1e-10
    )
    assert_gradient_is_the_likelihood_slope(fit, x)
    full = DiscrepancyFit(
        Gauss([1.0, 2.0]), X, Y, np.ones((15, 1)), V_fixed, restricted=restricted
    )
    assert full.evaluate(x, False) == pytest.approx(
        _dense_log_likelihood(full, x, restricted), rel=1e-10
    )
