"""The evidence of a batch for a change: each formula equals its dense
definition (scipy's multivariate normal, the GLS estimate), the score test
rejects at its nominal rate when nothing changed, and Gauss-Newton finds a
nonlinear change that the first-order estimate misses."""

import numpy as np
import pytest
from scipy import stats

from skmba._core.linalg import FactorizationError
from skmba.calibration._change_evidence import change_evidence
from validation.statistics import wilson_interval

RNG = np.random.default_rng(0)
M, R, TAU = 12, 3, 0.2
_A = RNG.normal(size=(M, M))
SIGMA = _A @ _A.T / M + 0.5 * np.eye(M)
G = RNG.normal(size=(M, R))


def _linear(G):
    return lambda delta: G @ delta


def test_bayes_factor_is_the_ratio_of_the_two_marginal_densities():
    r = G @ np.array([0.3, -0.1, 0.0]) + RNG.multivariate_normal(np.zeros(M), SIGMA)
    ev = change_evidence(r, SIGMA, _linear(G), R, TAU)
    changed = stats.multivariate_normal(np.zeros(M), SIGMA + TAU**2 * G @ G.T)
    unchanged = stats.multivariate_normal(np.zeros(M), SIGMA)
    dense = (changed.logpdf(r) - unchanged.logpdf(r)) / np.log(10)
    assert ev.log10_bayes_factor == pytest.approx(dense, rel=1e-10)
    for j in range(R):
        g = G[:, j : j + 1]
        alone = stats.multivariate_normal(np.zeros(M), SIGMA + TAU**2 * g @ g.T)
        dense_j = (alone.logpdf(r) - unchanged.logpdf(r)) / np.log(10)
        assert ev.single_log10_bayes_factors[j] == pytest.approx(dense_j, rel=1e-10)


def test_score_test_and_posterior_equal_the_gls_formulas():
    r = RNG.multivariate_normal(np.zeros(M), SIGMA)
    ev = change_evidence(r, SIGMA, _linear(G), R, TAU)
    W = np.linalg.solve(SIGMA, np.eye(M))  # dense reference only
    A, b = G.T @ W @ G, G.T @ W @ r
    gls = np.linalg.solve(A, b)
    assert ev.statistic == pytest.approx(gls @ A @ gls, rel=1e-9)
    assert ev.degrees == R
    assert ev.p_value == pytest.approx(stats.chi2.sf(gls @ A @ gls, R), rel=1e-9)
    V = np.linalg.inv(A + np.eye(R) / TAU**2)
    np.testing.assert_allclose(ev.change_mean, V @ b, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(ev.change_cov, V, rtol=1e-7)
    assert ev.residual_statistic == pytest.approx(r @ W @ r, rel=1e-9)
    fitted = r - G @ gls
    assert ev.misfit_statistic == pytest.approx(fitted @ W @ fitted, rel=1e-8)
    assert ev.misfit_p_value == pytest.approx(
        stats.chi2.sf(fitted @ W @ fitted, M - R), rel=1e-8
    )
    assert ev.n_means == M


def test_a_parameter_the_batch_cannot_see_drops_from_the_test():
    G0 = G.copy()
    G0[:, 2] = 0.0
    r = RNG.multivariate_normal(np.zeros(M), SIGMA)
    ev = change_evidence(r, SIGMA, _linear(G0), R, TAU)
    assert ev.degrees == R - 1
    # Its posterior is its prior, its Bayes factor alone 1.
    assert ev.change_sd[2] == pytest.approx(TAU, rel=1e-9)
    assert ev.single_log10_bayes_factors[2] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_no_change_alarms_at_the_nominal_rate():
    n, alpha = 4000, 0.05
    rng = np.random.default_rng(1)
    draws = rng.multivariate_normal(np.zeros(M), SIGMA, size=n)
    p = np.array([change_evidence(r, SIGMA, _linear(G), R, TAU).p_value for r in draws])
    low, high = wilson_interval(int(np.sum(p < alpha)), n, level=0.99)
    assert low <= alpha <= high
    # and the p-values are uniform
    assert stats.kstest(p, "uniform").pvalue > 0.01


def test_gauss_newton_finds_a_nonlinear_change():
    # Frequencies go as the square root of a stiffness: a 10 % loss moves
    # them by 5.13 %, which the first-order estimate reads as 10.26 %.
    g = np.linspace(1.0, 2.0, M)

    def eta(delta):
        return g * (np.sqrt(1.0 + delta[0]) - 1.0)

    r = eta(np.array([-0.1]))
    ev = change_evidence(r, 1e-10 * np.eye(M), eta, 1, 1.0)
    assert ev.change_mean[0] == pytest.approx(-0.1, abs=1e-6)


def test_a_singular_covariance_names_the_fix():
    with pytest.raises(FactorizationError, match="bin_width"):
        change_evidence(np.zeros(2), np.zeros((2, 2)), _linear(G[:2]), R, TAU)
