"""The draws of phi from several proposals: each weighted against the
proposals' mixture in the shares drawn (the balance heuristic), one
proposal's weights unchanged, and the influence-fitted proposal at the
influence-weighted draws' moments."""

import numpy as np
from scipy import special, stats

from skmba.calibration._module2_posterior import proposal_log_density
from skmba.calibration._module2_proposal_mixture import (
    DrawBlocks,
    influence_proposal,
)


def _blocks(V, log_p, columns, source):
    empty = np.zeros((3, len(V)))
    return DrawBlocks(V, log_p, np.column_stack(columns), source, empty, empty)


def test_draws_are_weighted_against_the_mixture_of_their_proposals():
    rng = np.random.default_rng(0)
    V = rng.normal(size=(12, 2))
    log_p = stats.multivariate_normal(np.zeros(2)).logpdf(V)
    first = (np.zeros(2), np.eye(2))
    second = (np.ones(2), 0.5 * np.eye(2))
    q1 = proposal_log_density(*first, V, log_p, 0.125)
    q2 = proposal_log_density(*second, V, log_p, 0.125)
    # One proposal: its own weights, bit for bit.
    one = _blocks(V, log_p, [q1], np.zeros(12, int))
    np.testing.assert_array_equal(one.log_w, log_p - q1)
    # A proposal added but not yet drawn from changes nothing.
    added = one.with_proposal(*second, 0.125)
    np.testing.assert_allclose(added.log_w, log_p - q1, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(added.log_q[:, 1], q2)
    # 4 draws of the first and 8 of the second: q = (4 q1 + 8 q2) / 12.
    source = np.r_[np.zeros(4, int), np.ones(8, int)]
    both = _blocks(V, log_p, [q1, q2], source)
    mixture = special.logsumexp(np.column_stack([q1, q2]), b=[[4 / 12, 8 / 12]], axis=1)
    np.testing.assert_allclose(both.log_w, log_p - mixture, rtol=1e-14)
    # Blocks added keep the columns and the sources.
    more = both.add(V[:2], log_p[:2], np.column_stack([q1, q2])[:2], [1, 1],
                    np.zeros((3, 2)), np.zeros((3, 2)))  # fmt: skip
    assert more.log_q.shape == (14, 2) and np.sum(more.source == 1) == 10


def test_the_influence_proposal_is_at_the_influence_weighted_moments():
    rng = np.random.default_rng(1)
    V = rng.normal(size=(400, 2))
    share = np.full(400, 1 / 400)
    # Only the draws with a positive first coordinate influence the summary.
    influence = np.where(V[:, :1] > 0, 1.0, 0.0) * np.ones((1, 4))
    mean, cov = influence_proposal(V, share, influence, np.ones(4))
    right = V[V[:, 0] > 0]
    np.testing.assert_allclose(mean, right.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(cov, np.cov(right.T), rtol=1e-12)
    # No draw with both a share and an influence (or an unknown influence):
    # no proposal.
    assert influence_proposal(V, share, 0.0 * influence, np.ones(4)) is None
    assert influence_proposal(V, share, np.full((400, 4), np.nan), np.ones(4)) is None
    # Influence on a few draws only (Kish size below 2 (m + 1) = 6): no
    # covariance to fit, no proposal; with seven, one.
    for n, expected in ((5, None), (7, "a proposal")):
        few = np.zeros((400, 4))
        few[:n] = 1.0
        made = influence_proposal(V, share, few, np.ones(4))
        assert (made is None) == (expected is None)
