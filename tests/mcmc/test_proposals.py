"""The independence proposals: the Student-t and the chains' shared mixture."""

import numpy as np
import pytest
from scipy import linalg, stats
from scipy.special import logsumexp

from skmba.mcmc._proposals import (
    DEFENSIVE_SCALE,
    DEFENSIVE_SHARE,
    MAX_COMPONENTS,
    T_DF,
    T_VARIANCE_FACTOR,
    TMixture,
    TProposal,
    shared_proposal,
)

MEANS = np.array([[-3.0, 0.5], [0.0, 0.0], [2.0, -1.0]])
COVS = np.array(
    [[[1.0, 0.3], [0.3, 0.5]], [[0.2, 0.0], [0.0, 2.0]], [[0.7, -0.4], [-0.4, 0.6]]]
)
WEIGHTS = np.array([0.2, 0.5, 0.3])


def _mixture():
    return TMixture(
        WEIGHTS, [TProposal.of(m, c) for m, c in zip(MEANS, COVS, strict=True)]
    )


def test_the_mixture_density_is_that_of_its_student_ts_up_to_a_constant():
    points = np.random.default_rng(0).normal(scale=3.0, size=(50, 2))
    exact = logsumexp(
        [
            np.log(w)
            + stats.multivariate_t(m, T_VARIANCE_FACTOR * c, df=T_DF).logpdf(points)
            for w, m, c in zip(WEIGHTS, MEANS, COVS, strict=True)
        ],
        axis=0,
    )
    difference = _mixture().logpdf(points) - exact
    np.testing.assert_allclose(difference, difference[0], atol=1e-10)


def test_the_mixture_draws_follow_its_density():
    # One dimension, where the mixture's CDF is a sum of scaled t CDFs.
    means, sds, weights = (
        np.array([-4.0, 1.0]),
        np.array([0.5, 2.0]),
        np.array([0.3, 0.7]),
    )
    mixture = TMixture(
        weights,
        [
            TProposal.of(np.array([m]), np.array([[s**2]]))
            for m, s in zip(means, sds, strict=True)
        ],
    )
    draws = mixture.draw(np.random.default_rng(1), 20000)[:, 0]
    scales = np.sqrt(T_VARIANCE_FACTOR) * sds

    def cdf(x):
        return sum(
            w * stats.t.cdf((x - m) / s, T_DF)
            for w, m, s in zip(weights, means, scales, strict=True)
        )

    assert stats.kstest(draws, cdf).pvalue > 0.01
    # A wrong component choice shows in the share left of the gap.
    share = np.mean(draws < -1.5)
    assert abs(share - cdf(-1.5)) < 4 * np.sqrt(0.3 * 0.7 / draws.size)


def test_one_gaussian_gives_the_student_t_of_the_moments():
    rng = np.random.default_rng(2)
    points = rng.multivariate_normal([1.0, -2.0], [[1.0, 0.8], [0.8, 1.0]], size=2000)
    mean, cov = points.mean(axis=0), np.cov(points, rowvar=False)
    proposal = shared_proposal(points, mean, cov)
    assert isinstance(proposal, TProposal)
    np.testing.assert_array_equal(proposal.mean, mean)
    np.testing.assert_allclose(proposal.chol @ proposal.chol.T, T_VARIANCE_FACTOR * cov)


def _two_clusters(n=2000, seed=3):
    rng = np.random.default_rng(seed)
    left = rng.normal([-3.0, 0.0], 0.5, size=(int(0.3 * n), 2))
    right = rng.normal([3.0, 1.0], 0.5, size=(n - len(left), 2))
    points = np.vstack([left, right])
    return points, points.mean(axis=0), np.cov(points, rowvar=False)


def test_two_clusters_give_a_mixture_with_the_defensive_student_t():
    points, mean, cov = _two_clusters()
    proposal = shared_proposal(points, mean, cov)
    assert isinstance(proposal, TMixture)
    assert 3 <= len(proposal.components) <= MAX_COMPONENTS + 1
    # The first component is the Student-t of the moments, widened, at its
    # share.
    union = TProposal.of(mean, cov)
    np.testing.assert_array_equal(proposal.components[0].mean, union.mean)
    np.testing.assert_allclose(
        proposal.components[0].chol, DEFENSIVE_SCALE * union.chol
    )
    assert proposal.weights[0] == pytest.approx(DEFENSIVE_SHARE)
    assert proposal.weights.sum() == pytest.approx(1.0)
    # The other components sit on the clusters, with their weights.
    centres = np.array([c.mean for c in proposal.components[1:]])
    on_left = centres[:, 0] < 0
    assert on_left.any() and (~on_left).any()
    left_share = proposal.weights[1:][on_left].sum() / (1.0 - DEFENSIVE_SHARE)
    assert left_share == pytest.approx(0.3, abs=0.03)
    # Between the clusters it proposes less than the Student-t alone.
    gap = np.array([[0.0, 0.5]])
    assert proposal.logpdf(gap)[0] - proposal.logpdf(centres[:1])[0] < (
        union.logpdf(gap)[0] - union.logpdf(centres[:1])[0]
    )


def test_far_out_the_mixture_proposes_more_than_the_student_t_alone():
    # Both as normalised densities (a one-component mixture is the
    # Student-t with its normalisation).
    points, mean, cov = _two_clusters()
    proposal = shared_proposal(points, mean, cov)
    alone = TMixture(np.ones(1), [TProposal.of(mean, cov)])
    sd = np.sqrt(np.diag(cov))
    for direction in ([1.0, 0.0], [0.0, 1.0], [-1.0, 1.0]):
        far = mean + 100.0 * sd * np.array(direction)
        ratio = np.exp(proposal.logpdf(far[None])[0] - alone.logpdf(far[None])[0])
        # the defensive component's share alone, the others' tails adding
        assert ratio > 0.99 * DEFENSIVE_SHARE * DEFENSIVE_SCALE**T_DF


def test_the_fit_depends_on_the_points_alone():
    points, mean, cov = _two_clusters()
    one, two = shared_proposal(points, mean, cov), shared_proposal(points, mean, cov)
    np.testing.assert_array_equal(one.weights, two.weights)
    for a, b in zip(one.components, two.components, strict=True):
        np.testing.assert_array_equal(a.mean, b.mean)
        np.testing.assert_array_equal(a.chol, b.chol)


def test_few_points_fit_one_component():
    # Two dimensions: six free parameters per component, ten points each.
    points, mean, cov = _two_clusters(n=59)
    assert isinstance(shared_proposal(points, mean, cov), TProposal)
    points, mean, cov = _two_clusters(n=120)
    assert isinstance(shared_proposal(points, mean, cov), TMixture)


def test_a_singular_covariance_raises():
    points = np.zeros((100, 2))
    with pytest.raises(linalg.LinAlgError):
        shared_proposal(points, np.zeros(2), np.zeros((2, 2)))
