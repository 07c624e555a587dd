"""Tests of MultiResponseGP: known answers, identities and the sklearn API."""

import io
import os
import pickle
import traceback
import types
import warnings

import joblib
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.optimize import minimize
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning, NotFittedError
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel
from sklearn.metrics import r2_score
from sklearn.model_selection import GridSearchCV, KFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

import skmba
from skmba import MultiResponseGP
from skmba._core.linalg import FactorizationError, symmetric_eigh
from skmba._core.regression import regression_basis
from skmba.datasets import make_cantilever
from skmba.gp._likelihood import (
    NoiseFreeLikelihood,
    NoisyLikelihood,
    maximise_noise_and_sigma2,
)
from skmba.gp._search import next_nugget
from skmba.kernels import (
    Cubic,
    Exp,
    Gauss,
    GeneralizedExp,
    Linear,
    Spherical,
    Spline,
)

SIGMA2 = np.array([[4.0, 1.2, -0.8], [1.2, 1.0, 0.3], [-0.8, 0.3, 2.25]])


def two_responses(X):
    return np.column_stack(
        [np.sin(3 * X[:, 0]) + X[:, 1] ** 2, np.cos(2 * X[:, 1]) * X[:, 0]]
    )


def draw_gp(seed, n=250, roughness=(30.0, 10.0), sigma2=SIGMA2, noise=None):
    """A draw of a 2-D-input, 3-response GP with covariance sigma2 ⊗ R."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, 2))
    R = Gauss(roughness=np.array(roughness))(X) + 1e-8 * np.eye(n)
    Z = np.linalg.cholesky(R) @ rng.normal(size=(n, 3)) @ np.linalg.cholesky(sigma2).T
    Z = Z + np.array([1.0, -2.0, 0.5])
    if noise is not None:
        Z = Z + rng.normal(size=Z.shape) * np.sqrt(noise)
    return X, Z


# ---------------------------------------------------------------- dense formulas
def dense_model(gp, X):
    """Dense V, regression matrix and responses (vec stacks responses)."""
    N = len(X)
    R = gp.kernel_(X) + gp.alpha * np.eye(N)
    V = np.kron(gp.sigma2_, R)
    if gp.noise:
        V = V + np.kron(np.diag(gp.noise_), np.eye(N))
    q = gp.sigma2_.shape[0]
    Xreg = np.kron(np.eye(q), regression_basis(X, gp.regression))
    return V, Xreg


def dense_log_likelihood(gp, X, Y):
    V, Xreg = dense_model(gp, X)
    y = Y.T.ravel()
    Vi = np.linalg.inv(V)
    beta = np.linalg.solve(Xreg.T @ Vi @ Xreg, Xreg.T @ Vi @ y)
    r = y - Xreg @ beta
    sign, logdet = np.linalg.slogdet(V)
    assert sign > 0
    return -0.5 * (len(y) * np.log(2 * np.pi) + logdet + r @ Vi @ r), beta


def dense_predict(gp, X, Y, Xs):
    """Universal kriging, Eqs. 3.39-3.40 without the noise at new points."""
    V, Xreg = dense_model(gp, X)
    q = Y.shape[1]
    Vi = np.linalg.inv(V)
    y = Y.T.ravel()
    W = np.linalg.inv(Xreg.T @ Vi @ Xreg)
    beta = W @ Xreg.T @ Vi @ y
    Vs = np.kron(gp.sigma2_, gp.kernel_(X, Xs))
    Vss = np.kron(gp.sigma2_, gp.kernel_(Xs))
    Xs_reg = np.kron(np.eye(q), regression_basis(Xs, gp.regression))
    mean = Xs_reg @ beta + Vs.T @ Vi @ (y - Xreg @ beta)
    U = Xs_reg.T - Xreg.T @ Vi @ Vs
    cov = Vss - Vs.T @ Vi @ Vs + U.T @ W @ U
    s = len(Xs)
    # dense ordering is (response, point); skmba's is (point, response)
    return mean.reshape(q, s).T, cov.reshape(q, s, q, s).transpose(1, 0, 3, 2)


@pytest.mark.parametrize("noise", [False, True])
@pytest.mark.parametrize("regression", ["constant", "linear", "quadratic"])
def test_fast_path_equals_dense_formula(noise, regression):
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(14, 2))
    Y = np.column_stack([two_responses(X), X[:, 0] * np.exp(X[:, 1])])
    Y = Y * [1.0, 10.0, 0.1] + 0.05 * rng.normal(size=Y.shape) * noise
    gp = MultiResponseGP(
        Exp(roughness=[2.0, 3.0]), regression=regression, noise=noise, alpha=1e-6
    ).fit(X, Y)
    ll, beta = dense_log_likelihood(gp, X, Y)
    assert gp.log_marginal_likelihood_value_ == pytest.approx(ll, rel=1e-8)
    np.testing.assert_allclose(gp.beta_.T.ravel(), beta, rtol=1e-8, atol=1e-10)
    Xs = rng.uniform(size=(5, 2))
    mean_dense, cov_dense = dense_predict(gp, X, Y, Xs)
    mean, cov = gp.predict(Xs, return_cov=True)
    np.testing.assert_allclose(mean, mean_dense, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(cov, cov_dense, rtol=1e-8, atol=1e-10)
    _, std = gp.predict(Xs, return_std=True)
    variances = np.einsum("akak->ak", cov_dense)
    np.testing.assert_allclose(std, np.sqrt(variances), rtol=1e-8)


def test_sigma2_is_the_maximum_likelihood_estimate():
    # Documented choice: Sigma2 = E' R^-1 E / N (Eq. 4.6), not 1 / (N - p).
    rng = np.random.default_rng(2)
    X = rng.uniform(size=(20, 1))
    Y = np.column_stack([np.sin(5 * X[:, 0]), X[:, 0] ** 3])
    gp = MultiResponseGP(Gauss(roughness=4.0), regression="linear", alpha=1e-8)
    gp.set_params(optimizer=None).fit(X, Y)
    R = gp.kernel_(X) + 1e-8 * np.eye(20)
    H = regression_basis(X, "linear")
    E = Y - H @ gp.beta_
    np.testing.assert_allclose(gp.sigma2_, E.T @ np.linalg.solve(R, E) / 20, rtol=1e-7)
    # and it maximises the likelihood over Sigma2: perturbing it lowers it
    ll, _ = dense_log_likelihood(gp, X, Y)
    for factor in (0.9, 1.1):
        gp_scaled = clone(gp).fit(X, Y)
        gp_scaled.sigma2_ = gp.sigma2_ * factor
        assert dense_log_likelihood(gp_scaled, X, Y)[0] < ll


# ------------------------------------------------------------------ gradients
@pytest.mark.parametrize(
    "kernel",
    [
        Gauss(roughness=[1.0, 2.0]),
        Exp(roughness=0.7),
        # theta + 0.5 keeps the power within (0, 2]
        GeneralizedExp(roughness=[1.0, 2.0], power=1.0, power_bounds=(0.5, 1.0)),
        Spline(roughness=[0.5, 0.8]),
        Matern(length_scale=[0.5, 0.8]),
    ],
    ids=["gauss", "exp", "generalized-exp", "spline", "matern"],
)
@pytest.mark.parametrize("noise", [False, True])
def test_log_likelihood_gradient_matches_finite_differences(kernel, noise):
    rng = np.random.default_rng(3)
    X = rng.uniform(size=(15, 2))
    Y = two_responses(X) + 0.05 * rng.normal(size=(15, 2))
    gp = MultiResponseGP(kernel, noise=noise, regression="linear", alpha=1e-6)
    gp.fit(X, Y)
    theta = gp.kernel_.theta + 0.5
    _, grad = gp.log_marginal_likelihood(theta, eval_gradient=True)
    h = 1e-5
    numeric = [
        (
            gp.log_marginal_likelihood(theta + h * e)
            - gp.log_marginal_likelihood(theta - h * e)
        )
        / (2 * h)
        for e in np.eye(theta.size)
    ]
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-6)


def test_noisy_gradient_in_sigma2_and_noise_matches_finite_differences():
    rng = np.random.default_rng(4)
    X = rng.uniform(size=(20, 2))
    Y = np.column_stack([two_responses(X), X[:, 0]]) + 0.1 * rng.normal(size=(20, 3))
    H = regression_basis(X, "linear")
    R = Gauss(roughness=[2.0, 1.0])(X) + 1e-8 * np.eye(20)
    A = rng.normal(size=(3, 3))
    S = A @ A.T + np.eye(3)
    lam = np.array([0.05, 0.2, 0.01])

    def value(S_, lam_):
        return NoisyLikelihood(R, H, Y, S_, lam_).log_likelihood

    fit = NoisyLikelihood(R, H, Y, S, lam, dR=np.zeros((20, 20, 0)))
    h = 1e-6
    for a, b in zip(*np.tril_indices(3), strict=True):
        E = np.zeros((3, 3))
        E[a, b] = E[b, a] = h  # symmetric perturbation
        numeric = (value(S + E, lam) - value(S - E, lam)) / (2 * h)
        analytic = fit.grad_sigma2[a, b] * (1 if a == b else 2)
        assert analytic == pytest.approx(numeric, rel=1e-5, abs=1e-7)
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        numeric = (value(S, lam + e) - value(S, lam - e)) / (2 * h)
        assert fit.grad_lam[a] == pytest.approx(numeric, rel=1e-5, abs=1e-7)


def test_noise_and_sigma2_maximisation_reaches_a_stationary_point():
    # Fisher scoring with the kernel fixed: at its result the gradient with
    # respect to Sigma2 and the noise vanishes (or points out of the
    # constraints for a singular Sigma2).
    rng = np.random.default_rng(16)
    X = rng.uniform(size=(60, 2))
    Y = np.column_stack([two_responses(X), X[:, 0]]) + rng.normal(size=(60, 3)) * [
        0.01,
        0.05,
        0.2,
    ]
    H = regression_basis(X, "constant")
    R = Gauss(roughness=[3.0, 2.0])(X) + 1e-8 * np.eye(60)
    eig = symmetric_eigh(R)
    fit, n_iter = maximise_noise_and_sigma2(
        R,
        H,
        Y,
        np.cov(Y.T),
        np.full(3, 0.1),
        eig=eig,
        lam_bounds=np.tile([1e-10, 10.0], (3, 1)),
        tol=1e-14,
        max_iter=200,
    )
    assert n_iter < 200
    final = NoisyLikelihood(R, H, Y, fit.sigma2, fit.ke.lam, dR=np.zeros((60, 60, 0)))
    assert np.abs(final.grad_lam * final.ke.lam).max() < 1e-4
    assert (
        np.abs(final.grad_sigma2 * np.sqrt(np.outer(*[np.diag(fit.sigma2)] * 2))).max()
        < 1e-4
    )


# --------------------------------------------------------------- known answers
@pytest.mark.parametrize(
    ("kernel", "tol"), [(Exp(roughness=[1.0, 1.0]), 1e-9), (Gauss([1.0, 1.0]), 1e-4)]
)
def test_noise_free_interpolation(kernel, tol):
    # Interpolation is exact up to the nugget: alpha * (R^-1 E), which grows
    # with the condition number of R (about 1e13 for the fitted Gauss here).
    rng = np.random.default_rng(5)
    X = rng.uniform(size=(30, 2))
    Y = two_responses(X)
    gp = MultiResponseGP(kernel, alpha=1e-10).fit(X, Y)
    mean, std = gp.predict(X, return_std=True)
    np.testing.assert_allclose(mean, Y, rtol=0, atol=tol * np.abs(Y).max())
    assert std.max() < 1e-3 * Y.std(axis=0).min()
    if isinstance(kernel, Exp):  # Gauss predicts so well that both are ~0
        _, std_between = gp.predict(X[:5] + 0.05, return_std=True)
        assert np.all(std_between > 1e3 * std.max())


def test_smooth_two_response_function_r2():
    rng = np.random.default_rng(6)
    X = rng.uniform(size=(40, 2))
    X_test = rng.uniform(size=(200, 2))
    gp = MultiResponseGP(
        Gauss(roughness=[1.0, 1.0]), n_restarts_optimizer=2, random_state=0
    )
    gp.fit(X, two_responses(X))
    r2 = r2_score(two_responses(X_test), gp.predict(X_test), multioutput="raw_values")
    assert np.all(r2 > 0.99), r2


def test_sigma2_and_roughness_recovered_from_gp_prior_draws():
    # One draw has few effectively independent points, so single Sigma2
    # estimates scatter (up to ~40 % on the off-diagonals here); we check each
    # draw's roughness within 10 % and the mean of 8 draws' Sigma2 within 10 %
    # of the largest standard deviation product.
    estimates, roughness = [], []
    for seed in range(8):
        X, Z = draw_gp(seed)
        gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), alpha=1e-8).fit(X, Z)
        estimates.append(gp.sigma2_)
        roughness.append(gp.kernel_.roughness)
    np.testing.assert_allclose(roughness, np.tile([30.0, 10.0], (8, 1)), rtol=0.1)
    scale = np.sqrt(np.outer(np.diag(SIGMA2), np.diag(SIGMA2)))
    assert np.all(np.abs(np.mean(estimates, axis=0) - SIGMA2) <= 0.1 * scale)


def test_per_response_noise_recovered():
    noise = np.array([0.005, 0.05, 0.5])  # ten times apart
    for seed in range(3):
        X, Z = draw_gp(seed, n=200, noise=noise)
        gp = MultiResponseGP(Gauss(roughness=[5.0, 5.0]), noise=True).fit(X, Z)
        np.testing.assert_allclose(gp.noise_, noise, rtol=0.3)
        np.testing.assert_allclose(gp.kernel_.roughness, [30.0, 10.0], rtol=0.25)


def test_results_are_in_user_units():
    rng = np.random.default_rng(7)
    X = rng.uniform(size=(25, 2))
    Y = two_responses(X) + 0.02 * rng.normal(size=(25, 2))
    scale = np.array([1e3, 1e-3])
    for noise in (False, True):
        a = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), noise=noise).fit(X, Y)
        b = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), noise=noise).fit(X, Y * scale)
        np.testing.assert_allclose(b.kernel_.theta, a.kernel_.theta, rtol=1e-3)
        np.testing.assert_allclose(
            b.sigma2_, a.sigma2_ * np.outer(scale, scale), rtol=1e-3
        )
        np.testing.assert_allclose(b.beta_, a.beta_ * scale, rtol=1e-3, atol=1e-9)
        ma, sa = a.predict(X[:3] + 0.01, return_std=True)
        mb, sb = b.predict(X[:3] + 0.01, return_std=True)
        np.testing.assert_allclose(mb, ma * scale, rtol=1e-4)
        np.testing.assert_allclose(sb, sa * scale, rtol=2e-3)
        if noise:
            np.testing.assert_allclose(b.noise_, a.noise_ * scale**2, rtol=2e-3)
        # normalize_y=False gives the same model up to rounding
        c = MultiResponseGP(
            Gauss(roughness=[1.0, 1.0]), noise=noise, normalize_y=False
        ).fit(X, Y * scale)
        np.testing.assert_allclose(c.sigma2_, b.sigma2_, rtol=1e-2)
        assert c.log_marginal_likelihood_value_ == pytest.approx(
            b.log_marginal_likelihood_value_, rel=1e-4
        )


def test_one_dimensional_y_gives_one_dimensional_outputs():
    X = np.linspace(0, 1, 10).reshape(-1, 1)
    y = np.sin(6 * X[:, 0])
    gp = MultiResponseGP().fit(X, y)
    mean, std = gp.predict(X, return_std=True)
    assert mean.shape == std.shape == (10,)
    assert gp.predict(X, return_cov=True)[1].shape == (10, 10)
    assert gp.sample_y(X, 4).shape == (10, 4)
    assert gp.sigma2_.shape == (1, 1) and gp.beta_.shape == (1, 1)


def test_sample_y_matches_predictive_moments():
    rng = np.random.default_rng(8)
    X = rng.uniform(size=(15, 1))
    Y = np.column_stack([np.sin(4 * X[:, 0]), np.sin(4 * X[:, 0]) + X[:, 0]])
    gp = MultiResponseGP(Gauss(roughness=2.0), noise=True).fit(
        X, Y + 0.05 * rng.normal(size=Y.shape)
    )
    Xs = np.array([[0.25], [0.5], [1.3]])
    samples = gp.sample_y(Xs, n_samples=20000, random_state=0)
    assert samples.shape == (3, 2, 20000)
    mean, cov = gp.predict(Xs, return_cov=True)
    flat = samples.reshape(6, -1)
    np.testing.assert_allclose(flat.mean(axis=1), mean.ravel(), atol=0.05)
    np.testing.assert_allclose(np.cov(flat), cov.reshape(6, 6), atol=0.02 * cov.max())
    assert np.array_equal(samples, gp.sample_y(Xs, n_samples=20000, random_state=0))


def test_constant_response_is_predicted_exactly():
    rng = np.random.default_rng(9)
    X = rng.uniform(size=(20, 2))
    Y = np.column_stack([two_responses(X)[:, 0], np.full(20, 3.5)])
    gp = MultiResponseGP().fit(X, Y)
    mean, std = gp.predict(rng.uniform(size=(5, 2)), return_std=True)
    np.testing.assert_allclose(mean[:, 1], 3.5)
    np.testing.assert_allclose(std[:, 1], 0.0)
    assert gp.sigma2_[1, 1] == 0 and gp.sigma2_[0, 1] == 0
    assert np.all(std[:, 0] > 0)
    with pytest.warns(UserWarning, match="constant"):
        gp_all = MultiResponseGP().fit(X, np.full((20, 2), 1.0))
    np.testing.assert_allclose(gp_all.predict(X[:3]), 1.0)
    # the documented fitted attributes that other modules read
    np.testing.assert_array_equal(gp.active_responses_, [True, False])
    assert isinstance(gp.likelihood_, NoiseFreeLikelihood)
    assert gp.likelihood_.sigma2.shape == (1, 1)  # the active response only
    assert gp_all.likelihood_ is None and not gp_all.active_responses_.any()
    noisy = MultiResponseGP(noise=True).fit(X, Y)
    assert isinstance(noisy.likelihood_, NoisyLikelihood)
    for name in ("_fit_state", "_active", "alpha_"):
        assert not hasattr(gp, name)


def test_optimizer_callable_none_and_restarts():
    rng = np.random.default_rng(10)
    X = rng.uniform(size=(25, 2))
    Y = two_responses(X)
    calls = []

    def my_optimizer(obj_func, initial_theta, bounds):
        calls.append(initial_theta)
        res = minimize(
            obj_func, initial_theta, jac=True, bounds=bounds, method="L-BFGS-B"
        )
        return res.x, res.fun

    kernel = Gauss(roughness=[1.0, 1.0])
    a = MultiResponseGP(
        kernel, optimizer=my_optimizer, n_restarts_optimizer=2, random_state=0
    )
    a.fit(X, Y)
    assert len(calls) == 3
    b = MultiResponseGP(kernel, n_restarts_optimizer=2, random_state=0).fit(X, Y)
    assert a.log_marginal_likelihood_value_ == pytest.approx(
        b.log_marginal_likelihood_value_, rel=1e-6
    )
    fixed = MultiResponseGP(kernel, optimizer=None).fit(X, Y)
    np.testing.assert_array_equal(fixed.kernel_.theta, kernel.theta)
    assert fixed.log_marginal_likelihood_value_ <= b.log_marginal_likelihood_value_
    # restarts never make the optimum worse and are reproducible
    c = MultiResponseGP(kernel, n_restarts_optimizer=2, random_state=0).fit(X, Y)
    assert c.log_marginal_likelihood_value_ == b.log_marginal_likelihood_value_
    fixed_noisy = MultiResponseGP(kernel, optimizer=None, noise=True).fit(X, Y)
    np.testing.assert_array_equal(fixed_noisy.kernel_.theta, kernel.theta)
    assert np.all(fixed_noisy.noise_ > 0)


# ---------------------------------------------------------------- sklearn API
def test_grid_search_over_kernels_on_two_responses():
    rng = np.random.default_rng(11)
    X = rng.uniform(size=(40, 2))
    Y = two_responses(X)
    grid = GridSearchCV(
        MultiResponseGP(),
        {"kernel": [Gauss(), Linear(), Spherical(), Exp(), Cubic()]},
        cv=KFold(3, shuffle=True, random_state=0),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Linear/Cubic may hit their bounds
        grid.fit(X, Y)
    assert isinstance(grid.best_estimator_.kernel_, Gauss)
    assert grid.best_score_ > 0.99
    assert grid.predict(X[:4]).shape == (4, 2)


def test_pipeline_clone_and_pickle():
    rng = np.random.default_rng(12)
    X = rng.uniform(size=(30, 2)) * [1.0, 1000.0]
    Y = two_responses(X / [1.0, 1000.0])
    pipe = Pipeline([("scale", StandardScaler()), ("gp", MultiResponseGP(Gauss()))])
    pipe.set_params(gp__kernel__roughness=0.5)
    pipe.fit(X, Y)
    assert pipe.score(X, Y) > 0.999
    restored = pickle.loads(pickle.dumps(pipe))
    np.testing.assert_array_equal(restored.predict(X[:5]), pipe.predict(X[:5]))
    gp = MultiResponseGP(Exp(roughness=[1.0, 2.0]), noise=True, regression="linear")
    twin = clone(gp)
    assert twin.get_params()["kernel"] is not gp.kernel
    assert repr(twin.get_params()["kernel"]) == repr(gp.kernel)
    gp.fit(X / [1.0, 1000.0], Y + 0.01 * rng.normal(size=Y.shape))
    back = pickle.loads(pickle.dumps(gp))
    m1, s1 = gp.predict(X[:4] / [1.0, 1000.0], return_std=True)
    m2, s2 = back.predict(X[:4] / [1.0, 1000.0], return_std=True)
    np.testing.assert_array_equal(m1, m2)
    np.testing.assert_array_equal(s1, s2)


def test_sklearn_kernels_are_accepted_as_correlations():
    rng = np.random.default_rng(13)
    X = rng.uniform(size=(20, 2))
    Y = two_responses(X)
    for kernel in (RBF([0.5, 0.5]), Matern(0.5, nu=2.5), Gauss() * Matern(nu=1.5)):
        assert MultiResponseGP(kernel).fit(X, Y).score(X, Y) > 0.999


# ------------------------------------------------------------------ bad input
def _bad_data(seed=14, n=12):
    X = np.random.default_rng(seed).uniform(size=(n, 2))
    return X, two_responses(X)


def _with(A, row, col, value):
    A = A.copy()
    A[row, col] = value
    return A


X_BAD, Y_BAD = _bad_data()


def _fit(X=X_BAD, y=Y_BAD, **params):
    return lambda gp: MultiResponseGP(**params).fit(X, y)


# case id -> (action on a fitted GP, exception or warning, message fragment).
# Every message names the argument and, except sklearn's standard checks, the
# fix. Warnings are documented behaviour: the fit goes on.
BAD_INPUT = {
    # non-finite values (sklearn's validation)
    "fit-X-nan": (
        _fit(X=_with(X_BAD, 3, 1, np.nan)),
        ValueError,
        "Input X contains NaN",
    ),
    "fit-X-inf": (
        _fit(X=_with(X_BAD, 0, 0, np.inf)),
        ValueError,
        "X contains infinity",
    ),
    "fit-y-nan": (
        _fit(y=_with(Y_BAD, 2, 0, np.nan)),
        ValueError,
        "Input y contains NaN",
    ),
    "fit-y-inf": (
        _fit(y=_with(Y_BAD, 5, 1, -np.inf)),
        ValueError,
        "y contains infinity",
    ),
    "predict-X-nan": (
        lambda gp: gp.predict(_with(X_BAD, 0, 0, np.nan)),
        ValueError,
        "Input X contains NaN",
    ),
    "predict-X-inf": (
        lambda gp: gp.predict(_with(X_BAD, 0, 1, np.inf)),
        ValueError,
        "X contains infinity",
    ),
    # magnitudes whose squares overflow or underflow float64
    "fit-X-huge": (_fit(X=X_BAD * 1e200), ValueError, r"X has values up to .*Rescale"),
    "fit-X-tiny-range": (
        _fit(X=X_BAD * 1e-200),
        ValueError,
        r"X column\(s\) \[0, 1\] vary by less than 1e-150.*Rescale",
    ),
    "fit-y-huge": (_fit(y=Y_BAD * 1e200), ValueError, "y has values up to .*units"),
    "fit-y-tiny-range": (
        _fit(y=Y_BAD * 1e-200),
        ValueError,
        r"Response\(s\) \[0, 1\] vary by less than 1e-150.*units",
    ),
    # shapes and dimensions
    "fit-X-3d": (_fit(X=X_BAD[:, :, None]), ValueError, "Found array with dim 3"),
    "fit-X-1d": (_fit(X=X_BAD[:, 0]), ValueError, r"(?s)Expected 2D array.*reshape"),
    "fit-y-3d": (_fit(y=Y_BAD[:, :, None]), ValueError, "y has 3 dimensions"),
    "fit-y-rows": (
        _fit(y=Y_BAD[:-1]),
        ValueError,
        r"inconsistent numbers of samples: \[12, 11\]",
    ),
    "predict-features": (
        lambda gp: gp.predict(np.ones((3, 3))),
        ValueError,
        "X has 3 features, but MultiResponseGP is expecting 2",
    ),
    "predict-X-3d": (
        lambda gp: gp.predict(np.ones((3, 2, 1))),
        ValueError,
        "Found array with dim 3",
    ),
    "kernel-roughness-length": (
        _fit(kernel=Gauss(roughness=[1.0, 2.0, 3.0])),
        ValueError,
        "roughness has 3 elements but X has 2 columns",
    ),
    # too little data
    "fit-empty": (_fit(X=X_BAD[:0], y=Y_BAD[:0]), ValueError, r"0 sample\(s\)"),
    "fit-no-features": (_fit(X=X_BAD[:, :0]), ValueError, r"0 feature\(s\)"),
    "fit-single-sample": (
        _fit(X=X_BAD[:1], y=Y_BAD[:1]),
        ValueError,
        "n_samples=1 is too few .* at least 2 samples",
    ),
    "fit-quadratic-too-few": (
        _fit(X=X_BAD[:6], y=Y_BAD[:6], regression="quadratic"),
        ValueError,
        "too few for regression='quadratic'.*lower-order regression",
    ),
    "fit-too-few-for-sigma2": (
        _fit(X=X_BAD[:2], y=Y_BAD[:2]),
        ValueError,
        r"2 x 2 response covariance.*n_samples >= p \+ q = 3.*response_nugget",
    ),
    # constant inputs and responses
    "fit-constant-column-linear": (
        _fit(X=_with(X_BAD, slice(None), 1, 0.5), regression="linear"),
        ValueError,
        r"regression='linear' cannot be estimated: X column\(s\) \[1\] are constant",
    ),
    "fit-collinear-quadratic": (
        _fit(X=np.column_stack([X_BAD[:, 0], 2 * X_BAD[:, 0]]), regression="linear"),
        ValueError,
        "regression='linear' cannot be estimated: its 3 terms have rank 2",
    ),
    "fit-identical-rows": (
        _fit(X=np.tile(X_BAD[:1], (12, 1))),
        ValueError,
        "All 12 rows of X are identical.*at least 2 distinct",
    ),
    "fit-identical-rows-noise": (
        _fit(X=np.tile(X_BAD[:1], (12, 1)), noise=True),
        ValueError,
        "All 12 rows of X are identical",
    ),
    "fit-constant-responses": (
        _fit(y=np.full((12, 2), 4.0)),
        UserWarning,
        "All responses are constant: the GP predicts them exactly",
    ),
    # duplicated inputs without noise
    "fit-duplicates-different-y": (
        _fit(X=np.vstack([X_BAD, X_BAD[:2]]), y=np.vstack([Y_BAD, Y_BAD[:2] + 0.1])),
        ValueError,
        r"2 duplicated row\(s\) with different y .*noise=True",
    ),
    "fit-duplicates-equal-y": (
        _fit(X=np.vstack([X_BAD, X_BAD[:2]]), y=np.vstack([Y_BAD, Y_BAD[:2]])),
        UserWarning,
        r"2 duplicated row\(s\) \(e.g. rows 0 and 12\) with equal y.*Remove them",
    ),
    # options
    "regression-unknown": (
        _fit(regression="cubic"),
        ValueError,
        "regression='cubic' is not supported; use one of 'constant'",
    ),
    "optimizer-unknown": (
        _fit(optimizer="adam"),
        ValueError,
        "optimizer='adam' is not supported; use 'fmin_l_bfgs_b', None",
    ),
    "kernel-not-a-kernel": (
        _fit(kernel="rbf"),
        TypeError,
        r"kernel must be an sklearn Kernel \(e.g. skmba.kernels.Gauss\(\)\)",
    ),
    "noise-not-bool": (_fit(noise="yes"), TypeError, "noise must be True or False"),
    "normalize_y-not-bool": (
        _fit(normalize_y=1),
        TypeError,
        "normalize_y must be True or False",
    ),
    # negative or zero sizes and values
    "n_restarts_optimizer-negative": (
        _fit(n_restarts_optimizer=-1),
        ValueError,
        "n_restarts_optimizer must be a non-negative integer, got -1",
    ),
    "n_restarts_optimizer-float": (
        _fit(n_restarts_optimizer=1.5),
        ValueError,
        "n_restarts_optimizer must be a non-negative integer, got 1.5",
    ),
    "alpha-negative": (
        _fit(alpha=-1.0),
        ValueError,
        r"alpha must be a finite float >= 0 \(the nugget, e.g. 1e-10\), got -1.0",
    ),
    "alpha-nan": (_fit(alpha=np.nan), TypeError, "alpha must be a finite float"),
    "alpha-string": (_fit(alpha="big"), TypeError, "alpha must be a finite float"),
    "response_nugget-negative": (
        _fit(response_nugget=-1e-8),
        ValueError,
        "response_nugget must be a finite float >= 0",
    ),
    "sample_y-n_samples-zero": (
        lambda gp: gp.sample_y(X_BAD[:2], n_samples=0),
        ValueError,
        r"n_samples must be a positive integer .* got 0; e.g. n_samples=1",
    ),
    "sample_y-n_samples-negative": (
        lambda gp: gp.sample_y(X_BAD[:2], n_samples=-3),
        ValueError,
        "n_samples must be a positive integer",
    ),
    "sample_y-n_samples-float": (
        lambda gp: gp.sample_y(X_BAD[:2], n_samples=2.0),
        ValueError,
        "n_samples must be a positive integer",
    ),
    "predict-std-and-cov": (
        lambda gp: gp.predict(X_BAD, return_std=True, return_cov=True),
        RuntimeError,
        "At most one of return_std or return_cov",
    ),
    "log_marginal_likelihood-theta-shape": (
        lambda gp: gp.log_marginal_likelihood([0.0, 1.0, 2.0]),
        ValueError,
        r"theta must be a finite array of shape \(2,\)",
    ),
    "log_marginal_likelihood-gradient-without-theta": (
        lambda gp: gp.log_marginal_likelihood(eval_gradient=True),
        ValueError,
        "Gradient can only be evaluated for theta!=None",
    ),
    "predict-before-fit": (
        lambda gp: MultiResponseGP().predict(X_BAD),
        ValueError,  # NotFittedError is a ValueError
        "not fitted yet. Call 'fit'",
    ),
    # kernels that are not correlations: a clear error (DESIGN.md section 2)
    "kernel-scaled": (
        _fit(kernel=ConstantKernel(2.0) * RBF()),
        ValueError,
        r"unit diagonal .* in \[2, 2\].*RBF\(\) instead of ConstantKernel",
    ),
    "kernel-with-white-noise": (
        _fit(kernel=RBF() + WhiteKernel()),
        ValueError,
        "unit diagonal.*noise=True",
    ),
}


@pytest.fixture(scope="module")
def fitted_gp():
    return MultiResponseGP(Gauss(roughness=[1.0, 1.0])).fit(X_BAD, Y_BAD)


@pytest.mark.parametrize("case", list(BAD_INPUT), ids=list(BAD_INPUT))
def test_bad_input_gives_a_clear_message(case, fitted_gp):
    action, expected, match = BAD_INPUT[case]
    if issubclass(expected, Warning):
        with pytest.warns(expected, match=match):
            action(fitted_gp)
    else:
        with pytest.raises(expected, match=match):
            action(fitted_gp)


def test_failed_refit_leaves_the_estimator_unfitted(fitted_gp):
    gp = clone(fitted_gp).fit(X_BAD, Y_BAD)
    with pytest.raises(ValueError, match="duplicated row"):
        gp.fit(np.vstack([X_BAD, X_BAD[:1]]), np.vstack([Y_BAD, Y_BAD[:1] + 1]))
    with pytest.raises(NotFittedError):
        gp.predict(X_BAD)
    assert gp.get_params() == fitted_gp.get_params()
    assert gp.fit(X_BAD, Y_BAD).score(X_BAD, Y_BAD) > 0.999


def test_constant_input_column_is_harmless_with_constant_regression():
    X = X_BAD.copy()
    X[:, 1] = 0.5
    Y = two_responses(X)
    gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0])).fit(X, Y)
    mean, std = gp.predict(X + 0.01, return_std=True)
    assert np.all(np.isfinite(mean)) and np.all(np.isfinite(std))
    # the constant column carries no likelihood gradient: its roughness stays
    assert gp.kernel_.roughness[1] == 1.0
    np.testing.assert_allclose(gp.predict(X), Y, atol=1e-4)  # nugget-limited


def test_duplicated_inputs_are_replicates_with_noise():
    rng = np.random.default_rng(17)
    X = np.vstack([X_BAD] * 3)
    Y = np.vstack([Y_BAD] * 3) + 0.01 * rng.normal(size=(36, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no duplicate warning with noise=True
        gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), noise=True).fit(X, Y)
    assert np.all((gp.noise_ > 0.3e-4) & (gp.noise_ < 3e-4)), gp.noise_
    _, std = gp.predict(X_BAD, return_std=True)
    assert np.all(std < 0.01)


def test_duplicate_inputs_without_nugget_escalate_it():
    X = np.repeat(np.linspace(0, 1, 6), 2).reshape(-1, 1)
    y = np.sin(3 * X[:, 0])
    gp = MultiResponseGP(Gauss(roughness=1.0), alpha=0.0, optimizer=None)
    with pytest.warns(UserWarning, match="duplicated row"):
        with pytest.warns(UserWarning, match=r"nugget alpha=0 \(its Cholesky"):
            gp.fit(X, y)
    assert 0 < gp.nugget_ <= 1e-6
    assert gp.score(X, y) > 0.99
    # a nugget or a noise term handles them from the start
    with pytest.warns(UserWarning, match="duplicated row"):
        gp = MultiResponseGP(Gauss(roughness=1.0), alpha=1e-6).fit(X, y)
    assert gp.nugget_ == 1e-6
    MultiResponseGP(Gauss(roughness=1.0), noise=True).fit(X, y)


def test_nugget_beyond_the_maximum_names_the_remedy():
    # Cubic is not positive definite: eigenvalues near -0.15 on this grid, far
    # below what the largest nugget (1e-6) can repair.
    X = np.linspace(0, 1, 50).reshape(-1, 1)
    y = np.sin(3 * X[:, 0])
    gp = MultiResponseGP(Cubic(roughness=2.0), optimizer=None)
    with pytest.raises(
        FactorizationError, match="even with the nugget alpha=1e-06"
    ) as info:
        gp.fit(X, y)
    message = str(info.value)
    assert "escalated from alpha=1e-10 up to 1e-06" in message
    assert "rougher kernel" in message and "noise=True" in message


def test_linearly_dependent_responses_name_the_remedy():
    rng = np.random.default_rng(15)
    X = rng.uniform(size=(15, 2))
    y = X[:, 0] + np.sin(X[:, 1])
    Y = np.column_stack([y, 2 * y + 1])
    with pytest.raises(FactorizationError, match="redundant responses"):
        MultiResponseGP(Gauss(roughness=[1.0, 1.0]), optimizer=None).fit(X, Y)
    gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), noise=True).fit(X, Y)
    assert gp.score(X, Y) > 0.99


# ------------------------------------------------------------ ill-conditioning
def test_nugget_escalation_sequence_is_bounded():
    sequence, nugget = [], 1e-10
    while (nugget := next_nugget(nugget)) is not None:
        sequence.append(nugget)
    np.testing.assert_allclose(sequence, [1e-9, 1e-8, 1e-7, 1e-6])
    assert next_nugget(0.0) == 1e-12
    assert next_nugget(5e-7) == 1e-6
    assert next_nugget(1e-6) is None
    assert next_nugget(1e-3) is None  # a large user nugget is used as given


def smooth_1d(n=15, seed=1):
    rng = np.random.default_rng(seed)
    X = np.sort(rng.uniform(size=(n, 1)), axis=0)
    return X, np.column_stack([np.sin(3 * X[:, 0]), np.exp(X[:, 0])])


def test_search_stopped_by_failed_factorisations_escalates_the_nugget():
    # Without a nugget the first L-BFGS-B step (to the smoothest kernel) fails
    # to factor R; L-BFGS-B then reports convergence at its starting point.
    # The fit notices (gradient far from 0) and escalates the nugget instead
    # of keeping the unoptimised kernel.
    X, Y = smooth_1d()
    gp = MultiResponseGP(Gauss(roughness=100.0), alpha=0.0)
    with pytest.warns(UserWarning, match="search was stopped by failed Cholesky"):
        gp.fit(X, Y)
    assert gp.nugget_ == 1e-12
    assert 0.3 < gp.kernel_.roughness < 3.0  # moved from the start (100)
    X_test = np.linspace(0, 1, 50).reshape(-1, 1)
    Y_test = np.column_stack([np.sin(3 * X_test[:, 0]), np.exp(X_test[:, 0])])
    assert r2_score(Y_test, gp.predict(X_test)) > 0.999
    # the fitted state, the likelihood and predictions all use nugget_
    assert gp.log_marginal_likelihood(gp.kernel_.theta) == pytest.approx(
        gp.log_marginal_likelihood_value_, rel=1e-10
    )


def test_search_still_stopped_at_the_maximum_nugget_warns(monkeypatch):
    monkeypatch.setattr(skmba.gp._search, "_MAX_ALPHA", 0.0)
    X, Y = smooth_1d()
    gp = MultiResponseGP(Gauss(roughness=100.0), alpha=0.0)
    with pytest.warns(ConvergenceWarning, match="still stopped by a numerically") as w:
        gp.fit(X, Y)
    assert gp.nugget_ == 0.0
    # warnings from deep in the search point at the caller of fit
    assert {record.filename for record in w} == {__file__}


class _Unconverged:
    """scipy.optimize stand-in whose L-BFGS-B runs all end unconverged (and
    are not stopped by the predicted-gain rule: no callback)."""

    @staticmethod
    def minimize(*args, bounds, callback=None, **kwargs):
        res = minimize(*args, bounds=bounds, **kwargs)
        middle = np.mean(bounds, axis=1)
        res.success, res.message = False, "ABNORMAL (test)"
        res.jac = np.where(res.x <= middle, -1.0, 1.0) * 1e3  # not flat
        return res


@pytest.mark.parametrize("noise", [False, True])
def test_search_warnings_point_at_the_caller_of_fit(noise, monkeypatch):
    X, Y = smooth_1d()
    if not noise:
        with pytest.warns(UserWarning, match="so the nugget was raised to") as w:
            MultiResponseGP(Gauss(roughness=100.0), alpha=0.0).fit(X, Y)
        assert {record.filename for record in w} == {__file__}
    monkeypatch.setattr(skmba.gp._lbfgsb, "optimize", _Unconverged)
    gp = MultiResponseGP(Gauss(roughness=1.0), noise=noise)
    with pytest.warns(ConvergenceWarning, match=r"ABNORMAL \(test\)") as w:
        gp.fit(X, Y)
    # noise=True: stage 1 (concentrated) and stage 2 (profile likelihood);
    # these noise-free data also put the noise variances on their lower bound.
    unconverged = [r for r in w if "ABNORMAL" in str(r.message)]
    assert len(unconverged) == 1 + noise
    at_bound = [r for r in w if "noise variance" in str(r.message)]
    assert len(at_bound) == (2 if noise else 0)
    assert len(w) == len(unconverged) + len(at_bound)
    assert {record.filename for record in w} == {__file__}


def cantilever_split(n_train, n_test=300, **kwargs):
    """Simulations of the cantilever model, inputs [X_sim, theta_sim]."""
    data = make_cantilever(n_train + n_test, random_state=0, **kwargs)
    Z = np.hstack([data.X_sim, data.theta_sim])
    Y = data.y_sim
    return Z[:n_train], Y[:n_train], Z[n_train:], Y[n_train:]


def test_thousand_cantilever_simulations_are_emulated():
    # Force, moment, E and I (sections 4.7.2-4.7.3) over 1,000 LHS runs and
    # three responses; the thesis' implementation became unstable from about
    # 265 simulations (section 4.7.1). One N x N Cholesky per likelihood
    # evaluation: about 3 s here.
    Z, Y, Z_test, Y_test = cantilever_split(
        1000,
        responses=("tip_displacement", "energy", "tip_rotation"),
        design_variables=("force", "moment"),
        parameters=("E", "I"),
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gp = MultiResponseGP().fit(Z, Y)
    assert not [w for w in caught if "numerically singular" in str(w.message)]
    assert gp.nugget_ == 1e-10
    mean, std = gp.predict(Z_test, return_std=True)
    r2 = r2_score(Y_test, mean, multioutput="raw_values")
    assert np.all(r2 > 0.999), r2
    assert np.all(np.isfinite(std)) and np.all(std > 0)
    # honest uncertainty: the errors are of the order of the predicted std
    assert 0.05 < np.median(np.abs(mean - Y_test) / std) < 2.0


def test_thousand_simulations_without_nugget_escalate_it():
    # Section 4.7.1 (force and E) with no nugget, as in the thesis: R cannot
    # be factored at the start; the nugget is escalated with one warning.
    Z, Y, Z_test, Y_test = cantilever_split(1000)
    gp = MultiResponseGP(alpha=0.0)
    with pytest.warns(UserWarning, match=r"raised to nugget_=1e-12") as caught:
        gp.fit(Z, Y)
    escalations = [w for w in caught if "numerically singular" in str(w.message)]
    assert len(escalations) == 1
    assert gp.nugget_ == 1e-12
    r2 = r2_score(Y_test, gp.predict(Z_test), multioutput="raw_values")
    assert np.all(r2 > 0.999), r2


# ----------------------------------------------------------------- persistence
def _callables_in(obj, seen=None):
    """Functions, methods, generators or open files reachable from ``obj``."""
    seen = set() if seen is None else seen
    if id(obj) in seen or isinstance(obj, np.ndarray | str | bytes | int | float):
        return []
    seen.add(id(obj))
    if isinstance(
        obj,
        types.FunctionType
        | types.MethodType
        | types.BuiltinFunctionType
        | types.GeneratorType
        | io.IOBase,
    ):
        return [obj]
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, list | tuple | set):
        children = list(obj)
    elif hasattr(obj, "__dict__"):
        children = list(vars(obj).values())
    else:
        children = []
    return [bad for child in children for bad in _callables_in(child, seen)]


def _gp_outputs(gp, X):
    mean, std = gp.predict(X, return_std=True)
    _, cov = gp.predict(X, return_cov=True)
    value, grad = gp.log_marginal_likelihood(gp.kernel_.theta + 0.1, True)
    return [
        mean,
        std,
        cov,
        gp.sample_y(X, n_samples=5, random_state=3),
        np.array([gp.log_marginal_likelihood(), value]),
        grad,
    ]


@pytest.mark.parametrize("noise", [False, True])
def test_fitted_gp_survives_pickle_and_joblib(noise, tmp_path):
    rng = np.random.default_rng(18)
    X = rng.uniform(size=(25, 2))
    Y = two_responses(X) + 0.01 * noise * rng.normal(size=(25, 2))
    gp = MultiResponseGP(
        Exp(roughness=[1.0, 2.0]), noise=noise, regression="linear"
    ).fit(X, Y)
    assert _callables_in(gp) == []
    X_new = rng.uniform(size=(6, 2))
    expected = _gp_outputs(gp, X_new)
    joblib.dump(gp, tmp_path / "gp.joblib")
    for restored in (
        pickle.loads(pickle.dumps(gp)),
        joblib.load(tmp_path / "gp.joblib"),
    ):
        assert restored.nugget_ == gp.nugget_
        assert repr(restored.kernel_) == repr(gp.kernel_)
        for got, want in zip(_gp_outputs(restored, X_new), expected, strict=True):
            np.testing.assert_array_equal(got, want)


# ---------------------------------------------------------------------- memory
def test_fit_checks_memory_before_allocating(monkeypatch):
    monkeypatch.setattr(skmba._core.linalg, "_available_memory", lambda: 10**6)
    X = np.random.default_rng(19).uniform(size=(400, 2))
    gp = MultiResponseGP()
    with pytest.raises(MemoryError) as info:
        gp.fit(X, two_responses(X))
    message = str(info.value)
    assert message.startswith("Fitting MultiResponseGP to 400 samples (the 400 x 400")
    # 12 arrays of 400 x 400: the DACE gradient is contracted one
    # hyperparameter at a time, whatever their number
    assert "needs 0.014305 GiB of memory, but only 0.000931 GiB is available" in (
        message
    )
    assert "Fit on fewer samples" in message
    assert not hasattr(gp, "X_train_")  # refused before anything was stored
    # sklearn kernels give their stacked (N, N, n_theta) gradient: counted,
    # and the remedy names the kernels that need none.
    gp = MultiResponseGP(RBF(length_scale=[1.0, 1.0]), noise=True)
    with pytest.raises(MemoryError) as info:
        gp.fit(X, two_responses(X))
    message = str(info.value)
    assert "its stacked gradient for 3 hyperparameter(s)" in message
    assert "needs 0.021458 GiB" in message  # 12 + 2 x 3 arrays
    assert "Use a kernel of skmba.kernels (e.g. Gauss or Exp" in message


def test_joint_covariance_checks_memory_and_std_is_batched(monkeypatch):
    X, Y = X_BAD, Y_BAD
    gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0])).fit(X, Y)
    X_new = np.random.default_rng(20).uniform(size=(40, 2))
    mean, std = gp.predict(X_new, return_std=True)
    monkeypatch.setattr(skmba._core.linalg, "_available_memory", lambda: 10**5)
    # (40 points x 2 responses)^2 x 8 bytes x 3 arrays = 0.15 MB > 0.1 MB
    with pytest.raises(MemoryError, match=r"joint predictive covariance of 40 points"):
        gp.predict(X_new, return_cov=True)
    with pytest.raises(MemoryError, match=r"fewer points at a time.*return_std=True"):
        gp.sample_y(X_new, n_samples=2)
    # means and standard deviations need no (s q)^2 array, and come in batches
    monkeypatch.setattr(skmba.gp._predict, "PREDICT_BATCH_BYTES", 8 * 12 * 6 * 7)
    mean_batched, std_batched = gp.predict(X_new, return_std=True)  # 7 per batch
    # Batching changes only the rounding of the triangular solves, which BLAS
    # computes with kernels chosen by the number of columns (and processor):
    # at most cond(R) eps = 7e-9 relative here (cond 3.3e7); measured 1.7e-12
    # for the mean on an AMD EPYC (OpenBLAS' Zen kernels), below 1e-12 in CI.
    np.testing.assert_allclose(mean_batched, mean, rtol=1e-10, atol=1e-14)
    # atol: near training points the variance 1 - r'R^-1 r + ... cancels, so
    # those last bits are amplified.
    np.testing.assert_allclose(std_batched, std, rtol=1e-10, atol=1e-12)


def test_batched_prediction_equals_the_unbatched_one(monkeypatch):
    # A well-conditioned R (fixed rough kernel), so that the comparison sees
    # the batching and not the rounding of an ill-conditioned solve.
    rng = np.random.default_rng(21)
    X = rng.uniform(size=(60, 3))
    Y = np.column_stack([two_responses(X), X[:, 2] ** 2])
    X_new = rng.uniform(size=(23, 3))
    for noise in (False, True):
        kernel = Gauss(roughness=[20.0, 30.0, 25.0])
        gp = MultiResponseGP(kernel, noise=noise, optimizer=None)
        gp.fit(X, Y + 0.01 * rng.normal(size=Y.shape) * noise)
        assert np.linalg.cond(kernel(X)) < 1e4
        mean, std = gp.predict(X_new, return_std=True)  # one batch
        for batch in (1, 5):
            budget = 8 * len(X) * skmba.gp._predict.PREDICT_ARRAYS * batch
            monkeypatch.setattr(skmba.gp._predict, "PREDICT_BATCH_BYTES", budget)
            got_mean, got_std = gp.predict(X_new, return_std=True)
            np.testing.assert_allclose(got_mean, mean, rtol=1e-12, atol=0)
            np.testing.assert_allclose(got_std, std, rtol=1e-12, atol=0)
        monkeypatch.undo()


# ------------------------------------------------------------ large emulators
@pytest.mark.slow  # full N=2500 likelihoods, twice over
def test_large_fit_starts_from_a_subsample_with_fewer_full_evaluations(monkeypatch):
    # N > WARM_START_ABOVE: the search runs on WARM_START_SAMPLES points
    # first, then refines on all of them from that optimum; it reaches the
    # same likelihood with no more N x N evaluations (5 and 5 since the
    # search stops at its predicted gain; the cold search took more before).
    n = 2500
    rng = np.random.default_rng(22)
    X = rng.uniform(size=(n, 2))
    y = np.sin(3 * X[:, 0]) + np.cos(2 * X[:, 1]) * X[:, 0]
    counts = {"full": 0}

    class Counting(NoiseFreeLikelihood):
        def __init__(self, R, *args, **kwargs):
            counts["full"] += len(R) == n
            super().__init__(R, *args, **kwargs)

    monkeypatch.setattr(skmba.gp._search, "NoiseFreeLikelihood", Counting)
    fits = {}
    for above in (2000, n):  # with, then without the warm start
        monkeypatch.setattr(skmba.gp._search, "WARM_START_ABOVE", above)
        counts["full"] = 0
        gp = MultiResponseGP(Exp(roughness=[1.0, 1.0]), random_state=0).fit(X, y)
        fits[above] = (gp.log_marginal_likelihood_value_, counts["full"])
    (warm, n_warm), (cold, n_cold) = fits[2000], fits[n]
    assert warm >= cold - 1e-6 * abs(cold)
    assert n_warm <= n_cold


# ------------------------------------------------------- property-based tests
FINITE = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=False)


@st.composite
def gp_problems(draw):
    n = draw(st.integers(1, 12))
    d = draw(st.integers(1, 3))
    q = draw(st.integers(1, 3))
    X = draw(hnp.arrays(np.float64, (n, d), elements=FINITE))
    Y = draw(hnp.arrays(np.float64, (n, q), elements=FINITE))
    regression = draw(st.sampled_from(["constant", "linear", "quadratic"]))
    return X, Y, regression, draw(st.booleans())


SKMBA_DIR = os.path.dirname(skmba.__file__)


# 100 problems in the default run, 250 with the slow marker (16-28 s).
@settings(max_examples=100, deadline=None, database=None, derandomize=True)
@given(gp_problems())
def test_fit_gives_finite_predictions_or_a_clear_error(problem):
    _finite_predictions_or_a_clear_error(problem)


@pytest.mark.slow
@settings(max_examples=250, deadline=None, database=None, derandomize=True)
@given(gp_problems())
def test_fit_gives_finite_predictions_or_a_clear_error_on_250_problems(problem):
    _finite_predictions_or_a_clear_error(problem)


def _finite_predictions_or_a_clear_error(problem):
    X, Y, regression, noise = problem
    gp = MultiResponseGP(regression=regression, noise=noise, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # documented warnings are allowed
        try:
            gp.fit(X, Y)
        except ValueError as exc:
            # raised by skmba with a message, never a bare LinAlgError
            if isinstance(exc, np.linalg.LinAlgError):
                assert isinstance(exc, FactorizationError), repr(exc)
            origin = traceback.extract_tb(exc.__traceback__)[-1].filename
            assert origin.startswith(SKMBA_DIR), (origin, repr(exc))
            assert len(str(exc)) > 20
            return
        X_new = np.vstack([X, X + 0.37])
        mean, std = gp.predict(X_new, return_std=True)
        draws = gp.sample_y(X[:3], n_samples=2)
    assert mean.shape == std.shape == (2 * len(X), Y.shape[1])
    assert np.all(np.isfinite(mean)) and np.all(np.isfinite(std))
    assert np.all(std >= 0)
    assert draws.shape == (min(3, len(X)), Y.shape[1], 2)
    assert np.all(np.isfinite(draws))
    # +inf only when every response is constant (predicted exactly)
    assert np.isfinite(gp.log_marginal_likelihood_value_) or np.all(np.ptp(Y, 0) == 0)
    assert gp.sigma2_.shape == (Y.shape[1],) * 2 and np.all(np.isfinite(gp.sigma2_))


def test_a_generator_seeds_the_restarts_and_gives_the_same_fit_twice():
    """random_state takes a numpy Generator (issue 14): two fresh Generators
    of one seed give the same restarts, hence the same fit and draws."""
    X = np.linspace(0.0, 1.0, 12).reshape(-1, 1)
    y = np.column_stack([np.sin(6 * X[:, 0]), X[:, 0] ** 2])
    fits = [
        MultiResponseGP(
            n_restarts_optimizer=3, random_state=np.random.default_rng(1)
        ).fit(X, y)
        for _ in range(2)
    ]
    np.testing.assert_array_equal(fits[0].predict(X), fits[1].predict(X))
    draws = [f.sample_y(X, 2, random_state=np.random.default_rng(4)) for f in fits]
    np.testing.assert_array_equal(*draws)


def test_a_roughness_held_by_a_bound_warns_naming_the_input():
    # The response ignores input 1: its roughness falls to the lower bound.
    rng = np.random.default_rng(0)
    X = rng.uniform(0, 1, size=(30, 2))
    y = np.sin(6 * X[:, 0])
    with pytest.warns(
        ConvergenceWarning,
        match=r"The fitted roughness of input 1 \(.*\) is at the lower bound .* the "
        r"responses hardly vary with this input",
    ) as record:
        MultiResponseGP().fit(X, y)
    assert len(record) == 1 and record[0].filename == __file__
    # no search, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        MultiResponseGP(Gauss([1.0, 1e-3]), optimizer=None).fit(X, y)


def test_a_noise_variance_held_by_its_lower_bound_warns_naming_the_response():
    """noise=True on noise-free data: the noise variance of that response
    falls to its lower bound (1e-8 of its variance), which warns naming the
    response (its index in y, past a constant one) and what it means; the
    noisy response, inside its bounds, does not warn."""
    rng = np.random.default_rng(3)
    X = np.linspace(0.0, 1.0, 25).reshape(-1, 1)
    Y = np.column_stack(
        [
            np.ones(25),  # constant: set aside
            np.sin(3 * X[:, 0]) + 0.05 * rng.standard_normal(25),
            np.cos(2 * X[:, 0]),  # noise-free
        ]
    )
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        gp = MultiResponseGP(Gauss(roughness=2.0), noise=True).fit(X, Y)
    noisy = [w for w in record if "noise variance" in str(w.message)]
    assert len(noisy) == 1, [str(w.message) for w in record]
    assert noisy[0].category is ConvergenceWarning
    assert noisy[0].filename == __file__
    message = str(noisy[0].message)
    assert message.startswith(
        f"The fitted noise variance of response 2 ({gp.noise_[2]:.4g}) is at the "
        f"lower bound {1e-8 * np.var(Y[:, 2]):.4g} of its search (the bounds are "
        "1e-08 and 10 times the response's variance): the data look noise-free "
        "for this response. Consider noise=False"
    ), message
    np.testing.assert_allclose(gp.noise_[2], 1e-8 * np.var(Y[:, 2]), rtol=1e-6)
    assert 0.5 < gp.noise_[1] / 0.05**2 < 2.0  # the noise drawn, estimated
    # noise=False on the noise-free response: nothing to warn about
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        MultiResponseGP(Gauss(roughness=2.0), optimizer=None).fit(X, Y[:, 2])


def test_the_default_kernel_follows_the_spread_of_the_inputs():
    """kernel=None scales the Gauss kernel's start and bounds by each input's
    range: inputs in other units (x 1e3 and x 1e-4) give the same fit, with
    the roughness and its bounds scaled by 1 / scale^2."""
    rng = np.random.default_rng(5)
    X = rng.uniform(size=(30, 2))
    Y = two_responses(X)
    X_new = rng.uniform(size=(10, 2))
    scale = np.array([1e3, 1e-4])
    plain = MultiResponseGP().fit(X, Y)
    scaled = MultiResponseGP().fit(X * scale, Y)
    mean, std = plain.predict(X_new, return_std=True)
    mean_s, std_s = scaled.predict(X_new * scale, return_std=True)
    np.testing.assert_allclose(mean_s, mean, rtol=1e-6)  # 1e-8 measured
    # The optimiser stops within 1e-7 of the same roughness; the standard
    # deviation near the data (5e-5 of the response's) amplifies that to
    # 2e-6 (measured), the mean to 1e-8.
    np.testing.assert_allclose(std_s, std, rtol=1e-5)
    np.testing.assert_allclose(
        scaled.kernel_.roughness_bounds,
        plain.kernel_.roughness_bounds / scale[:, None] ** 2,
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        scaled.kernel_.roughness, plain.kernel_.roughness / scale**2, rtol=1e-6
    )
