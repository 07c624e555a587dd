"""Shared fixtures: a small global model and its dense reference formulas."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import special

from skmba import MultiResponseGP
from skmba._core.regression import regression_basis
from skmba.calibration._module1_emulator import Emulator
from skmba.calibration._module2_posterior import (
    DiscrepancyComponent,
    HyperposteriorDraws,
)
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.kernels import Exp, Gauss


def fixed_gp(X_m, Y_m):
    """A GP with a fixed Exp kernel and linear regression on [x, theta]."""
    return MultiResponseGP(
        Exp(roughness=[1.5, 0.8]),
        regression="linear",
        alpha=1e-6,
        optimizer=None,
        normalize_y=False,
    ).fit(X_m, Y_m)


def discrepancy(sigma2_d, noise):
    """The module-2 estimates the global model reads."""
    return SimpleNamespace(
        kernel_=Gauss(roughness=2.0),
        regression="constant",
        sigma2=sigma2_d,
        noise=noise,
    )


def mixture_draws(K=4, seed=0):
    """K module-2 draws of random size, roughness and noise, with random
    weights: a mixture for the global model of ``problem`` (q = 2)."""
    rng = np.random.default_rng(seed)
    comps = []
    for _ in range(K):
        A = rng.normal(size=(2, 2))
        comps.append(
            DiscrepancyComponent(
                Gauss(roughness=rng.uniform(0.5, 3.0)),
                0.05 * (A @ A.T + np.eye(2)),
                rng.uniform(0.005, 0.05, 2),
                "constant",
            )
        )
    log_w = rng.normal(size=K)
    log_w = log_w - special.logsumexp(log_w)
    noise_mean = np.exp(log_w) @ np.array([c.noise for c in comps])
    return HyperposteriorDraws(None, comps, log_w, None, noise_mean, float(K))


@pytest.fixture(scope="session")
def problem():
    """One design variable and one parameter: N=14 runs, n=6 field data."""
    rng = np.random.default_rng(0)
    N, n = 14, 6
    X_m = rng.uniform(-1, 1, size=(N, 2))  # one design variable, one parameter
    Y_m = np.column_stack(
        [np.sin(2 * X_m[:, 0]) * X_m[:, 1], X_m[:, 0] + 0.5 * X_m[:, 1] ** 2]
    )
    gp = fixed_gp(X_m, Y_m)
    X_e = rng.uniform(-1, 1, size=(n, 1))
    Y_e = np.column_stack([np.sin(2 * X_e[:, 0]) * 0.3, X_e[:, 0] + 0.1]) + 0.05
    A = rng.normal(size=(2, 2))
    sigma2_d = 0.1 * (A @ A.T + np.eye(2))
    noise = np.array([0.01, 0.02])
    gm = GlobalModel(
        Emulator(gp, X_m, Y_m, "linear"), X_e, Y_e, discrepancy(sigma2_d, noise)
    )
    return gp, gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise


def _dense_global(problem, theta, component=None, X_star=None, full=False):
    """V_Y, H_Y, Y of Eqs. 4.22-4.29 assembled densely (and module 4; ``full``:
    the joint covariance, response-slowest, instead of the variances)."""
    gp, _gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise = problem
    km, kd = gp.kernel_, Gauss(roughness=2.0)
    S_m = gp.likelihood_.sigma2
    q, N, n = 2, len(X_m), len(X_e)
    P_e = np.hstack([X_e, np.full((n, 1), theta)])
    R_mm = km(X_m) + 1e-6 * np.eye(N)
    A = np.kron(S_m, R_mm)
    B = np.kron(S_m, km(X_m, P_e))
    # The nugget is on the simulations only: the model at the field points
    # is the simulator's output there.
    D = (
        np.kron(S_m, km(P_e))
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
    # Unmeasured field entries (NaN): their rows and columns are left out.
    keep = np.isfinite(y)
    V, H, y = V[np.ix_(keep, keep)], H[keep], y[keep]
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
    Vs = Vs[keep]
    mean = h @ beta + Vs.T @ Vi @ r
    U = h.T - H.T @ Vi @ Vs
    cov = prior - Vs.T @ Vi @ Vs + U.T @ W @ U
    if full:
        return mean.reshape(q, s).T, cov
    return mean.reshape(q, s).T, np.diag(cov).reshape(q, s).T


@pytest.fixture
def gapped_problem(problem):
    """``problem`` with three field entries unmeasured (NaN), one of them
    the only gap of its row; the global model is built on the gapped data."""
    gp, gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise = problem
    Y_e = Y_e.copy()
    Y_e[[0, 2, 5], [1, 0, 0]] = np.nan
    gm = GlobalModel(gm.emulator, X_e, Y_e, discrepancy(sigma2_d, noise))
    return gp, gm, X_m, Y_m, X_e, Y_e, sigma2_d, noise


@pytest.fixture(scope="session")
def dense_global():
    """The dense Eqs. 4.22-4.30 (and module-4 kriging) as a function."""
    return _dense_global
