"""Posterior moments by two-stage (prior, then Gaussian) importance quadrature."""

import numpy as np
import pytest
from scipy import stats

from skmba.priors._theta import check_prior
from skmba.sensor_design._posterior_moments import gaussian_rule, posterior_moments


@pytest.mark.parametrize("sd", [3.0, 0.5, 0.05, 0.005, 5e-4])
def test_one_parameter_matches_the_truncated_normal(sd):
    """Uniform prior x Gaussian likelihood = truncated normal, at any width."""
    prior = check_prior([stats.uniform(-5, 10)])
    nodes, weights = prior.integration_nodes(33)

    def log_lik(t):
        return -0.5 * ((t[:, 0] - 1.234) / sd) ** 2

    mean, cov = posterior_moments(log_lik, prior, nodes, weights, log_lik(nodes))
    ref = stats.truncnorm((-5 - 1.234) / sd, (5 - 1.234) / sd, loc=1.234, scale=sd)
    assert mean[0] == pytest.approx(ref.mean(), abs=1e-6 * sd)
    assert np.sqrt(cov[0, 0]) == pytest.approx(ref.std(), rel=1e-6)


def test_two_correlated_parameters():
    prior = check_prior([stats.uniform(-5, 10), stats.uniform(0, 4)])
    nodes, weights = prior.integration_nodes(64, random_state=0)
    C = 0.0025 * np.array([[1.0, -0.8], [-0.8, 1.0]])
    mu = np.array([1.0, 2.0])
    P = np.linalg.inv(C)  # test reference only

    def log_lik(t):
        d = t - mu
        return -0.5 * np.einsum("ki,ij,kj->k", d, P, d)

    mean, cov = posterior_moments(
        log_lik, prior, nodes, weights, log_lik(nodes), n_refine=128, seed=1
    )
    np.testing.assert_allclose(mean, mu, atol=0.1 * np.sqrt(0.0025))
    np.testing.assert_allclose(cov, C, rtol=0.05, atol=0.02 * 0.0025)


@pytest.mark.parametrize("sd", [3.0, 0.005])
def test_rule_returned_is_the_one_of_the_moments(sd):
    """return_rule: the nodes and weights whose moments are returned, for a
    wide posterior (stage 1, the prior's nodes) and a narrow one (stage 2)."""
    prior = check_prior([stats.uniform(-5, 10)])
    nodes, weights = prior.integration_nodes(33)

    def log_lik(t):
        return -0.5 * ((t[:, 0] - 1.234) / sd) ** 2

    mean, cov, (x, w) = posterior_moments(
        log_lik, prior, nodes, weights, log_lik(nodes), return_rule=True
    )
    assert w.sum() == pytest.approx(1.0) and np.all(w >= 0)
    assert (x is nodes) == (sd == 3.0)
    np.testing.assert_allclose(w @ x, mean, rtol=1e-12)
    np.testing.assert_allclose(w @ (x - mean) ** 2, cov[0], rtol=1e-10)
    vanishing = np.full(len(nodes), -np.inf)
    *_, (x, w) = posterior_moments(
        None, prior, nodes, weights, vanishing, return_rule=True
    )
    assert x is nodes and w == pytest.approx(weights / weights.sum())


def test_flat_or_vanishing_likelihood_returns_the_prior():
    prior = check_prior([stats.uniform(2, 4)])
    nodes, weights = prior.integration_nodes(33)
    flat = np.zeros(len(nodes))
    mean, cov = posterior_moments(
        lambda t: np.zeros(len(t)), prior, nodes, weights, flat
    )
    assert mean[0] == pytest.approx(4.0) and cov[0, 0] == pytest.approx(16 / 12)
    gone = np.full(len(nodes), -np.inf)
    mean, cov = posterior_moments(None, prior, nodes, weights, gone)
    assert mean[0] == pytest.approx(4.0) and cov[0, 0] == pytest.approx(16 / 12)


@pytest.mark.parametrize("r", [1, 3])
def test_gaussian_rule_moments(r):
    mean = np.arange(1.0, r + 1)
    A = np.random.default_rng(0).normal(size=(r, r))
    cov = A @ A.T + r * np.eye(r)
    x, log_q, w = gaussian_rule(mean, cov, 512 if r > 1 else 9, random_state=0)
    np.testing.assert_allclose(w.sum(), 1.0)
    np.testing.assert_allclose(w @ x, mean, atol=0.05 if r > 1 else 1e-12)
    c = (x - w @ x).T * w @ (x - w @ x)
    np.testing.assert_allclose(c, cov, rtol=0.1 if r > 1 else 1e-12)
    np.testing.assert_allclose(
        log_q, stats.multivariate_normal(mean, cov).logpdf(x).reshape(-1)
    )


@pytest.mark.parametrize("r", [1, 2])
def test_a_singular_proposal_covariance_gives_a_rule_not_a_scipy_error(r):
    """A posterior concentrated on a ridge (rank-deficient covariance) once
    ended in scipy's 'allow_singular is False' error."""
    cov = np.zeros((r, r)) if r == 1 else np.ones((r, r))
    nodes, log_q, weights = gaussian_rule(np.ones(r), cov, 8, random_state=0)
    assert np.all(np.isfinite(nodes)) and np.all(np.isfinite(log_q))
    assert weights.sum() == pytest.approx(1.0)
