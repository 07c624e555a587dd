"""One chain's kernel (skmba.mcmc._chain, _proposals): the independence
proposal against scipy's multivariate t, and the moments of a burn-in window."""

import numpy as np
from scipy import stats

from skmba.mcmc._proposals import T_DF, T_VARIANCE_FACTOR, TProposal, window_moments

MEAN = np.array([1.0, -2.0])
COV = np.array([[2.0, 0.6], [0.6, 0.5]])


def test_the_proposal_is_the_documented_multivariate_t():
    proposal = TProposal.of(MEAN, COV)
    reference = stats.multivariate_t(MEAN, T_VARIANCE_FACTOR * COV, df=T_DF)
    points = np.random.default_rng(0).normal(size=(50, 2)) * 3
    # The log density up to a constant: its differences are scipy's.
    ours = proposal.logpdf(points)
    theirs = reference.logpdf(points)
    np.testing.assert_allclose(ours - ours[0], theirs - theirs[0], atol=1e-10)
    # Its draws: mean and covariance df / (df - 2) times the scale matrix,
    # within 4 standard errors on 200,000 draws; a KS test on a projection.
    draws = proposal.draw(np.random.default_rng(1), 200_000)
    scale = T_VARIANCE_FACTOR * COV
    cov = T_DF / (T_DF - 2) * scale
    se = np.sqrt(np.diag(cov) / len(draws))
    assert np.all(np.abs(draws.mean(axis=0) - MEAN) < 4 * se)
    np.testing.assert_allclose(np.cov(draws.T), cov, rtol=0.03)
    z = (draws[:, 0] - MEAN[0]) / np.sqrt(scale[0, 0])
    assert stats.kstest(z[:5000], stats.t(T_DF).cdf).pvalue > 0.01


def test_window_moments_pool_the_blocks():
    rng = np.random.default_rng(2)
    blocks = [rng.normal(size=(n, 2)) for n in (50, 50, 30)]
    counts = np.array([len(b) for b in blocks], dtype=float)
    means = np.array([b.mean(axis=0) for b in blocks])
    m2s = np.array([(b - b.mean(axis=0)).T @ (b - b.mean(axis=0)) for b in blocks])
    mean, cov = window_moments(counts, means, m2s, np.array([20, 20, 20]))
    pooled = np.vstack(blocks)
    np.testing.assert_allclose(mean, pooled.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(cov, np.cov(pooled.T) + 1e-10 * np.eye(2), rtol=1e-12)
    # Too few accepted moves in the window: no moments.
    assert window_moments(counts, means, m2s, np.array([3, 3, 3])) is None
