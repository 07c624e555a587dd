"""Module-2 integrals of the emulator over the prior against closed forms.

For a Gauss kernel (product over inputs) and a Gaussian or uniform prior on
theta, the integrals of the cross-correlations in Eqs. 4.14 and 4.17 have
closed forms; the numerical rule (prior-quantile Gauss-Legendre) must match.
"""

import warnings

import numpy as np
import pytest
from scipy import special, stats

from skmba import MultiResponseGP
from skmba.calibration._module1_emulator import Emulator
from skmba.calibration._module2_prior_integral import (
    integrate_emulator,
    one_parameter_rule,
    repair_psd,
    weighted_moments,
)
from skmba.kernels import Gauss
from skmba.priors._theta import check_prior

W_X, W_T = 1.5, 0.8  # roughness of x and of theta


@pytest.fixture(scope="module")
def emulator():
    rng = np.random.default_rng(0)
    Z = rng.uniform(-1, 1, size=(25, 2))  # [x, theta]
    Y = np.column_stack([np.sin(2 * Z[:, 0]) * Z[:, 1], Z[:, 0] + Z[:, 1] ** 2])
    gp = MultiResponseGP(
        Gauss(roughness=[W_X, W_T]), optimizer=None, normalize_y=False, alpha=1e-8
    ).fit(Z, Y)
    return gp, Z, Y


def theta_factor(theta_j, prior):
    """∫ exp(-w (θ - θ_j)^2) p(θ) dθ."""
    if prior.dist.name == "norm":
        mu, s = prior.mean(), prior.std()
        a = 1 + 2 * W_T * s**2
        return np.exp(-W_T * (mu - theta_j) ** 2 / a) / np.sqrt(a)
    lo, hi = prior.support()
    root = np.sqrt(W_T)
    return (
        np.sqrt(np.pi / W_T)
        / (2 * (hi - lo))
        * (special.erf(root * (hi - theta_j)) - special.erf(root * (lo - theta_j)))
    )


def pair_factor(a, b, prior):
    """∫ exp(-w (θ - a)^2 - w (θ - b)^2) N(θ; mu, s^2) dθ (Gaussian prior)."""
    mu, s = prior.mean(), prior.std()
    c = 1 + 4 * W_T * s**2
    mid = 0.5 * (a + b)
    return np.exp(-W_T * (a - b) ** 2 / 2 - 2 * W_T * (mu - mid) ** 2 / c) / np.sqrt(c)


@pytest.mark.parametrize("prior", [stats.norm(0.1, 0.3), stats.uniform(-0.8, 1.5)])
def test_integrated_mean_matches_closed_form(emulator, prior):
    gp, Z, Y = emulator
    state = gp.likelihood_
    X_e = np.array([[-0.5], [0.0], [0.4]])
    nodes, weights = check_prior([prior]).integration_nodes(64)
    mean, _, _ = integrate_emulator(Emulator(gp, Z, Y, "constant"), X_e, nodes, weights)
    # m_bar = beta + (∫ r)' R^-1 E with constant regression (Eq. 4.14)
    r_x = np.exp(-W_X * (X_e - Z[:, 0]) ** 2)  # (n, N)
    r_int = r_x * theta_factor(Z[:, 1], prior)
    g = state.gls
    exact = g.beta[0] + r_int @ np.linalg.solve(state.C.T, g.residual)
    np.testing.assert_allclose(mean, exact, rtol=1e-6, atol=1e-8)


def _solve_extended(A, B):
    """``A^-1 B`` for a symmetric positive definite ``A`` by a Cholesky
    factorisation in numpy's extended precision (80-bit on x86 Linux).

    The reference of the closed forms below: ``R`` (25 points, Gauss kernel,
    nugget 1e-8) has a condition number of about 1e8, so a float64
    reference is off by a few 1e-10 (an explicit inverse by 1.5e-9 on an
    AMD EPYC), as much as the rule under test; against a 50-digit mpmath
    solve the rule's values were within 3.5e-10.
    """
    A = np.asarray(A, dtype=np.longdouble)
    x = np.array(B, dtype=np.longdouble)
    n = len(A)
    L = np.zeros_like(A)
    for j in range(n):
        L[j, j] = np.sqrt(A[j, j] - L[j, :j] @ L[j, :j])
        L[j + 1 :, j] = (A[j + 1 :, j] - L[j + 1 :, :j] @ L[j, :j]) / L[j, j]
    for j in range(n):  # L y = B
        x[j] = (x[j] - L[j, :j] @ x[:j]) / L[j, j]
    for j in reversed(range(n)):  # L' x = y
        x[j] = (x[j] - L[j + 1 :, j] @ x[j + 1 :]) / L[j, j]
    return x


def test_integrated_correlation_matches_closed_form(emulator):
    gp, Z, Y = emulator
    prior = stats.norm(0.1, 0.3)
    X_e = np.array([[-0.5], [0.4]])
    nodes, weights = check_prior([prior]).integration_nodes(64)
    _, corr, _ = integrate_emulator(Emulator(gp, Z, Y, "constant"), X_e, nodes, weights)
    R = gp.kernel_(Z) + 1e-8 * np.eye(len(Z))
    one = np.ones(len(Z))
    Ri_one = _solve_extended(R, one)
    W = 1.0 / (one @ Ri_one)
    r_x = np.exp(-W_X * (X_e - Z[:, 0]) ** 2)
    m = r_x * theta_factor(Z[:, 1], prior)  # ∫ r(x_i, θ) p dθ
    for i in range(2):
        for j in range(2):
            J = np.outer(r_x[i], r_x[j]) * pair_factor(
                Z[:, 1][:, None], Z[:, 1][None, :], prior
            )
            exact = (
                np.exp(-W_X * (X_e[i, 0] - X_e[j, 0]) ** 2)
                - np.trace(_solve_extended(R, J))
                + W * (1 - Ri_one @ m[i] - Ri_one @ m[j] + Ri_one @ J @ Ri_one)
            )
            assert corr[i, j] == pytest.approx(float(exact), rel=1e-6, abs=1e-9)


def test_blocks_and_jobs_do_not_change_the_result(emulator):
    gp, Z, Y = emulator
    nodes, weights = check_prior([stats.uniform(-1, 2)]).integration_nodes(40)
    X_e = np.array([[0.3], [-0.2]])
    args = (Emulator(gp, Z, Y, "constant"), X_e, nodes, weights)
    a = integrate_emulator(*args, block=64)
    b = integrate_emulator(*args, block=7, n_jobs=2)
    for u, v in zip(a, b, strict=True):
        np.testing.assert_allclose(u, v, rtol=1e-12, atol=1e-14)


def test_many_field_inputs_use_smaller_blocks(emulator, monkeypatch):
    # The blocks shrink with n (memory) but the result does not change.
    import skmba.calibration._module2_prior_integral as integration

    gp, Z, Y = emulator
    nodes, weights = check_prior([stats.uniform(-1, 2)]).integration_nodes(40)
    X_e = np.linspace(-0.9, 0.9, 12)[:, None]
    args = (Emulator(gp, Z, Y, "constant"), X_e, nodes, weights)
    full = integrate_emulator(*args)
    assert integration.nodes_per_block(12) == 64
    monkeypatch.setattr(integration, "BLOCK_BYTES", 3 * 8 * 12**2 * 5)
    assert integration.nodes_per_block(12) == 5
    small = integrate_emulator(*args, n_jobs=2)
    for u, v in zip(full, small, strict=True):
        np.testing.assert_allclose(u, v, rtol=1e-12, atol=1e-14)


def test_weighted_moments_spread_is_the_law_of_total_variance():
    rng = np.random.default_rng(1)
    values = rng.normal(size=(500, 3, 2))
    weights = np.full(500, 1 / 500)
    mean, spread = weighted_moments(values, weights)
    flat = values.transpose(0, 2, 1).reshape(500, -1)
    np.testing.assert_allclose(spread, np.cov(flat.T, bias=True), atol=1e-12)
    np.testing.assert_allclose(mean, values.mean(axis=0))


def test_one_parameter_rule_resolves_auto_and_refuses_quadrature():
    assert one_parameter_rule("integration", "auto", 1, several="qmc") == "quadrature"
    assert one_parameter_rule("integration", "auto", 3, several="qmc") == "qmc"
    with pytest.raises(ValueError, match="needs one parameter, the prior has 2"):
        one_parameter_rule("sampler", "quadrature", 2, several="mcmc")


def test_repair_psd_adds_the_smallest_jitter_and_warns():
    V = np.array([[1.0, 1.0], [1.0, 1.0 - 1e-3]])  # one negative eigenvalue
    with pytest.warns(UserWarning, match="not positive definite"):
        fixed = repair_psd(V)
    assert np.linalg.eigvalsh(fixed)[0] > 0
    np.testing.assert_allclose(fixed, V + np.eye(2) * (fixed[0, 0] - 1.0))


def test_repair_psd_measures_round_off_against_the_cancelled_terms():
    """A covariance far smaller than the terms it is the difference of
    (the emulator integrated over a narrow posterior) is repaired without a
    warning when its negative eigenvalue is round-off of those terms."""
    V = 1e-7 * np.array([[1.0, 1.0], [1.0, 1.0 - 1e-5]])  # eigenvalue ~ -5e-13
    with pytest.warns(UserWarning, match="not positive definite"):
        repair_psd(V)  # against its own mean variance, 1e-7: not round-off
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fixed = repair_psd(V, magnitude=1.0)  # against terms of size 1: it is
    assert np.linalg.eigvalsh(fixed)[0] > 0
    with pytest.warns(UserWarning, match="not positive definite"):
        repair_psd(V * 1e7 * [[1.0, 1.0], [1.0, 0.999]], magnitude=1.0)


@pytest.mark.parametrize("block_bytes", [None, 8 * 30 * 4 * 3])
def test_prior_units_on_a_linear_model(monkeypatch, block_bytes):
    # A model linear in x and theta is reproduced exactly by an emulator with
    # a linear regression: the spread over the distinct field inputs and a
    # uniform prior is sqrt(a^2 var(x) + b^2 var(theta)), var(theta) = 1/3
    # for U(1, 3); the input ratio is the simulations' sd over the distinct
    # field inputs' (repeats do not count), in any block size.
    import skmba.calibration._module2_prior_integral as integration
    from skmba.calibration._module1_emulator import Standardizer, fit_emulator

    if block_bytes is not None:
        monkeypatch.setattr(integration, "BLOCK_BYTES", block_bytes)
    rng = np.random.default_rng(0)
    X_sim, theta_sim = rng.uniform(0, 20, (30, 1)), rng.uniform(1, 3, (30, 1))
    coef = np.array([[2.0, -1.0], [3.0, 5.0]])  # rows x, theta
    y_sim = np.hstack([X_sim, theta_sim]) @ coef
    scaler = Standardizer.from_simulations(X_sim, theta_sim, y_sim)
    emulator = fit_emulator(
        scaler, X_sim, theta_sim, y_sim, regression="linear", n_restarts_optimizer=0
    )
    X_field = np.array([[4.0], [6.0], [6.0], [6.0], [9.0], [13.0]])
    prior = check_prior([stats.uniform(1, 2)])
    units = integration.prior_units(emulator, scaler, prior, scaler.x(X_field))
    distinct = np.array([4.0, 6.0, 9.0, 13.0])
    assert units.input_ratio[0] == pytest.approx(
        scaler.X_scale[0] / distinct.std(), rel=1e-12
    )
    spread = np.sqrt(coef[0] ** 2 * distinct.var() + coef[1] ** 2 / 3.0)
    np.testing.assert_allclose(
        np.asarray(units.response_ratio) * scaler.y_scale, spread, rtol=1e-7
    )


def test_prior_units_of_constant_inputs_and_responses_are_one():
    # A field input that does not vary and a response the model does not vary
    # at the field inputs (it follows that input) keep module 2's own units
    # (ratio 1) rather than a zero scale.
    from skmba.calibration._module1_emulator import Standardizer, fit_emulator
    from skmba.calibration._module2_prior_integral import prior_units

    rng = np.random.default_rng(1)
    X_sim, theta_sim = rng.uniform(0, 1, (20, 2)), rng.uniform(0, 1, (20, 1))
    y_sim = np.column_stack([X_sim[:, 0] + theta_sim[:, 0], X_sim[:, 1]])
    scaler = Standardizer.from_simulations(X_sim, theta_sim, y_sim)
    emulator = fit_emulator(
        scaler, X_sim, theta_sim, y_sim, regression="linear", n_restarts_optimizer=0
    )
    X_field = np.column_stack([np.linspace(0, 1, 5), np.full(5, 0.5)])
    units = prior_units(
        emulator, scaler, check_prior([stats.uniform(0, 1)]), scaler.x(X_field)
    )
    assert units.input_ratio[1] == 1.0 and units.response_ratio[1] == 1.0
    assert units.input_ratio[0] != 1.0 and units.response_ratio[0] != 1.0
