"""Tests of MultiResponseGP: known answers, identities and the sklearn API."""

import pickle
import warnings

import numpy as np
import pytest
from scipy.optimize import minimize
from sklearn.base import clone
from sklearn.gaussian_process.kernels import RBF, Matern, WhiteKernel
from sklearn.metrics import r2_score
from sklearn.model_selection import GridSearchCV, KFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from skmba import MultiResponseGP
from skmba._likelihood import NoisyLikelihood, maximise_noise_and_sigma2
from skmba._linalg import FactorizationError, symmetric_eigh
from skmba._regression import regression_basis
from skmba.kernels import Cubic, Exp, Gauss, Linear, Spherical

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
    [Gauss(roughness=[1.0, 2.0]), Exp(roughness=0.7), Matern(length_scale=[0.5, 0.8])],
    ids=["gauss", "exp", "matern"],
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
@pytest.mark.parametrize(
    ("params", "exception", "match"),
    [
        ({"regression": "cubic"}, ValueError, "regression"),
        ({"alpha": -1.0}, ValueError, "alpha"),
        ({"alpha": "big"}, TypeError, "alpha"),
        ({"n_restarts_optimizer": -1}, ValueError, "n_restarts_optimizer"),
        ({"optimizer": "adam"}, ValueError, "optimizer"),
        ({"kernel": "rbf"}, TypeError, "kernel"),
        ({"kernel": RBF() + WhiteKernel()}, ValueError, "unit diagonal"),
    ],
)
def test_bad_parameters_raise(params, exception, match):
    X = np.linspace(0, 1, 8).reshape(-1, 2)
    with pytest.raises(exception, match=match):
        MultiResponseGP(**params).fit(X, X.sum(axis=1))


def test_bad_data_raise():
    X = np.random.default_rng(14).uniform(size=(10, 2))
    y = X.sum(axis=1)
    gp = MultiResponseGP()
    with pytest.raises(ValueError, match="NaN"):
        gp.fit(np.where(X > 0.9, np.nan, X), y)
    with pytest.raises(ValueError, match="infinity"):
        gp.fit(X, np.where(y > 1.5, np.inf, y))
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        gp.fit(X, y[:-1])
    with pytest.raises(ValueError, match="3 dimensions"):
        gp.fit(X, y.reshape(10, 1, 1))
    with pytest.raises(ValueError, match="too few for regression='quadratic'"):
        MultiResponseGP(regression="quadratic").fit(X[:6], y[:6])
    gp.fit(X, y)
    with pytest.raises(ValueError, match="features"):
        gp.predict(np.ones((3, 3)))
    with pytest.raises(RuntimeError, match="return_std or return_cov"):
        gp.predict(X, return_std=True, return_cov=True)


def test_duplicate_inputs_without_nugget_name_the_remedy():
    X = np.repeat(np.linspace(0, 1, 6), 2).reshape(-1, 1)
    y = np.sin(3 * X[:, 0])
    with pytest.raises(FactorizationError, match="alpha"):
        MultiResponseGP(Gauss(roughness=1.0), alpha=0.0, optimizer=None).fit(X, y)
    # a nugget or a noise term handles them
    assert (
        MultiResponseGP(Gauss(roughness=1.0), alpha=1e-6).fit(X, y).score(X, y) > 0.99
    )
    MultiResponseGP(Gauss(roughness=1.0), noise=True).fit(X, y)


def test_linearly_dependent_responses_name_the_remedy():
    rng = np.random.default_rng(15)
    X = rng.uniform(size=(15, 2))
    y = X[:, 0] + np.sin(X[:, 1])
    Y = np.column_stack([y, 2 * y + 1])
    with pytest.raises(FactorizationError, match="redundant responses"):
        MultiResponseGP(Gauss(roughness=[1.0, 1.0]), optimizer=None).fit(X, Y)
    gp = MultiResponseGP(Gauss(roughness=[1.0, 1.0]), noise=True).fit(X, Y)
    assert gp.score(X, Y) > 0.99
