"""Module 3/4 global model: the Schur-complement path equals the dense formulas."""

import numpy as np
import pytest

from skmba import MultiResponseGP
from skmba._posterior import GlobalModel
from skmba._regression import regression_basis
from skmba.kernels import Exp, Gauss


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(0)
    N, n = 14, 6
    X_m = rng.uniform(-1, 1, size=(N, 2))  # one design variable, one parameter
    Y_m = np.column_stack(
        [np.sin(2 * X_m[:, 0]) * X_m[:, 1], X_m[:, 0] + 0.5 * X_m[:, 1] ** 2]
    )
    gp = MultiResponseGP(
        Exp(roughness=[1.5, 0.8]),
        regression="linear",
        alpha=1e-6,
        optimizer=None,
        normalize_y=False,
    ).fit(X_m, Y_m)
    X_e = rng.uniform(-1, 1, size=(n, 1))
    Y_e = np.column_stack([np.sin(2 * X_e[:, 0]) * 0.3, X_e[:, 0] + 0.1]) + 0.05
    A = rng.normal(size=(2, 2))
    sigma2_d = 0.1 * (A @ A.T + np.eye(2))
    noise = np.array([0.01, 0.02])
    gm = GlobalModel(
        gp._fit_state,
        X_m,
        Y_m,
        gp.kernel_,
        "linear",
        X_e,
        Y_e,
        Gauss(roughness=2.0),
        "constant",
        sigma2_d,
        noise,
        nugget=gp.alpha_,
    )
    return gp, gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise


def dense_global(problem, theta, component=None, X_star=None):
    """V_Y, H_Y, Y of Eqs. 4.22-4.29 assembled densely (and module 4)."""
    gp, _gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise = problem
    km, kd = gp.kernel_, Gauss(roughness=2.0)
    S_m = gp._fit_state.sigma2
    q, N, n = 2, len(X_m), len(X_e)
    P_e = np.hstack([X_e, np.full((n, 1), theta)])
    R_mm = km(X_m) + 1e-6 * np.eye(N)
    A = np.kron(S_m, R_mm)
    B = np.kron(S_m, km(X_m, P_e))
    # The nugget is on the whole model correlation R(D), field points too.
    D = (
        np.kron(S_m, km(P_e) + 1e-6 * np.eye(n))
        + np.kron(sigma2_d, kd(X_e))
        + np.kron(np.diag(noise), np.eye(n))
    )
    V = np.block([[A, B], [B.T, D]])
    H_m, H_me = regression_basis(X_m, "linear"), regression_basis(P_e, "linear")
    H_d = regression_basis(X_e, "constant")
    I = np.eye(q)
    H = np.block(
        [
            [np.kron(I, H_m), np.zeros((N * q, q))],
            [np.kron(I, H_me), np.kron(I, H_d)],
        ]
    )
    y = np.concatenate([Y_m.T.ravel(), Y_e.T.ravel()])
    Vi = np.linalg.inv(V)
    W = np.linalg.inv(H.T @ Vi @ H)
    beta = W @ H.T @ Vi @ y
    r = y - H @ beta
    M, P = len(y), H.shape[1]
    ll = -0.5 * (
        (M - P) * np.log(2 * np.pi)
        + np.linalg.slogdet(V)[1]
        - np.linalg.slogdet(W)[1]
        + r @ Vi @ r
    )
    if component is None:
        return ll
    s = len(X_star)
    P_s = np.hstack([X_star, np.full((s, 1), theta)])
    cov_top = np.kron(S_m, km(X_m, P_s))
    cov_bot_m = np.kron(S_m, km(P_e, P_s))
    cov_bot_d = np.kron(sigma2_d, kd(X_e, X_star))
    zeros = np.zeros_like(cov_top)
    h_m = np.kron(I, regression_basis(P_s, "linear"))
    h_d = np.kron(I, regression_basis(X_star, "constant"))
    if component == "model":
        Vs = np.vstack([cov_top, cov_bot_m])
        h = np.hstack([h_m, np.zeros_like(h_d)])
        prior = np.kron(S_m, km(P_s))
    elif component == "discrepancy":
        Vs = np.vstack([zeros, cov_bot_d])
        h = np.hstack([np.zeros_like(h_m), h_d])
        prior = np.kron(sigma2_d, kd(X_star))
    else:
        Vs = np.vstack([cov_top, cov_bot_m + cov_bot_d])
        h = np.hstack([h_m, h_d])
        prior = np.kron(S_m, km(P_s)) + np.kron(sigma2_d, kd(X_star))
        if component == "observation":
            prior = prior + np.kron(np.diag(noise), np.eye(s))
    mean = h @ beta + Vs.T @ Vi @ r
    U = h.T - H.T @ Vi @ Vs
    cov = prior - Vs.T @ Vi @ Vs + U.T @ W @ U
    return mean.reshape(q, s).T, np.diag(cov).reshape(q, s).T


@pytest.mark.parametrize("theta", [-0.7, 0.1, 0.9])
def test_schur_log_likelihood_equals_dense_eq_4_30(problem, theta):
    gm = problem[1]
    assert gm.log_likelihood(np.array([theta])) == pytest.approx(
        dense_global(problem, theta), rel=1e-8, abs=1e-8
    )


@pytest.mark.parametrize(
    "component", ["model", "discrepancy", "reality", "observation"]
)
def test_conditional_predictions_equal_dense_kriging(problem, component):
    gm = problem[1]
    X_star = np.array([[-0.5], [0.2], [0.75]])
    mean_d, var_d = dense_global(problem, 0.3, component, X_star)
    mean, var = gm.predict(np.array([0.3]), X_star, component)
    np.testing.assert_allclose(mean, mean_d, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(var, var_d, rtol=1e-7, atol=1e-10)


def test_components_add_up(problem):
    gm = problem[1]
    X_star = np.array([[-0.2], [0.4]])
    theta = np.array([0.5])
    m = gm.predict(theta, X_star, "model", return_var=False)
    d = gm.predict(theta, X_star, "discrepancy", return_var=False)
    total = gm.predict(theta, X_star, "reality", return_var=False)
    np.testing.assert_allclose(m + d, total, rtol=1e-10, atol=1e-12)


def _three_response_problem():
    rng = np.random.default_rng(3)
    N, n, q = 16, 5, 3
    X_m = rng.uniform(-1, 1, size=(N, 2))
    Y_m = np.column_stack(
        [
            np.sin(2 * X_m[:, 0]) * X_m[:, 1],
            X_m[:, 0] + 0.5 * X_m[:, 1] ** 2,
            np.cos(X_m[:, 0] + X_m[:, 1]),
        ]
    )
    gp = MultiResponseGP(
        Exp(roughness=[1.5, 0.8]),
        regression="linear",
        alpha=1e-6,
        optimizer=None,
        normalize_y=False,
    ).fit(X_m, Y_m)
    X_e = rng.uniform(-1, 1, size=(n, 1))
    Y_e = rng.normal(size=(n, q))
    A = rng.normal(size=(q, q))
    sigma2_d = 0.1 * (A @ A.T + np.eye(q))
    noise = np.array([0.01, 0.02, 0.005])
    return gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise


@pytest.mark.parametrize("subset", [(0,), (2,), (0, 2), (1, 2), (0, 1, 2)])
def test_subset_likelihood_equals_global_model_of_the_subset(subset):
    """The batched subset path equals GlobalModel on the restricted data."""
    from types import SimpleNamespace

    from scipy import linalg

    from skmba._posterior import FieldDesignEmulator, SubsetLikelihood

    gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise = _three_response_problem()
    state = gp._fit_state
    idx = list(subset)
    kd = Gauss(roughness=2.0)
    design = FieldDesignEmulator(
        state, X_m, Y_m, gp.kernel_, "linear", X_e, nugget=gp.alpha_
    )
    H_d = regression_basis(X_e, "constant")
    like = SubsetLikelihood(design, idx, Y_e, kd(X_e), H_d, sigma2_d, noise)
    thetas = np.array([[-0.7], [0.1], [0.9]])
    batched = like.log_likelihood(design.pieces(thetas))
    sub_sigma2 = state.sigma2[np.ix_(idx, idx)]
    restricted = SimpleNamespace(
        C=state.C,
        gls=state.gls,
        sigma2=sub_sigma2,
        sigma2_chol=linalg.cholesky(sub_sigma2, lower=True),
    )
    gm = GlobalModel(
        restricted,
        X_m,
        Y_m[:, idx],
        gp.kernel_,
        "linear",
        X_e,
        Y_e[:, idx],
        kd,
        "constant",
        sigma2_d[np.ix_(idx, idx)],
        noise[idx],
        nugget=gp.alpha_,
    )
    reference = np.array([gm.log_likelihood(t) for t in thetas])
    np.testing.assert_allclose(batched, reference, rtol=1e-8, atol=1e-8)


def test_subset_likelihood_marks_non_positive_definite_theta():
    """A Schur complement that is not positive definite gives -inf there."""
    from skmba._posterior import FieldDesignEmulator, SubsetLikelihood

    gp, X_m, Y_m, X_e, Y_e, sigma2_d, noise = _three_response_problem()
    design = FieldDesignEmulator(
        gp._fit_state, X_m, Y_m, gp.kernel_, "linear", X_e, nugget=gp.alpha_
    )
    H_d = regression_basis(X_e, "constant")
    like = SubsetLikelihood(
        design, [0, 1], Y_e, Gauss(roughness=2.0)(X_e), H_d, sigma2_d, noise
    )
    pieces = list(design.pieces(np.array([[0.0], [0.5]])))
    pieces[0] = pieces[0].copy()
    pieces[0][1] -= 50.0 * np.eye(len(X_e))  # break the second theta only
    out = like.log_likelihood(tuple(pieces))
    assert np.isfinite(out[0]) and out[1] == -np.inf
