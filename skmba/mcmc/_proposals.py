"""The proposals of a chain's independence moves, fitted to its burn-in.

:class:`skmba.mcmc._chain.Chain` proposes, besides its random walk, from
:class:`TProposal`, a Student-t whose location and scale matrix are the
moments of the latest half of the burn-in (:func:`window_moments`, pooled
over blocks of steps by :func:`merge_moments`). For a labelled target (a
finite mixture sampled with its component) it also proposes the label, from
:func:`label_proposal`, and draws labels with :func:`draw_label`.

Why these shapes and constants (the measurements behind ``T_DF`` and
``T_VARIANCE_FACTOR``): docs/internals.rst, section skmba.mcmc._chain.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._proposals import TProposal, label_proposal
>>> proposal = TProposal.of(np.zeros(2), np.eye(2))
>>> proposal.draw(np.random.default_rng(0), 5).shape
(5, 2)
>>> label_proposal(np.array([1.0, 0.0]))
array([0.95, 0.05])
"""

import numpy as np
from scipy import linalg

#: The independence proposal is a Student-t with T_DF degrees of freedom and
#: T_VARIANCE_FACTOR times the covariance of (part of) the burn-in as its
#: scale matrix. Heavy tails keep a proposal narrower than the target from
#: trapping the chains in the target's tails.
T_VARIANCE_FACTOR = 1.5
T_DF = 5.0
#: Share of the uniform distribution in the label proposal of a labelled
#: target's independence moves, so that every label stays reachable.
LABEL_UNIFORM_SHARE = 0.1
# Regularisation ``epsilon I`` added to the empirical covariance (the caller
# works in standardised units, in which this is negligible).
_EPSILON = 1e-10


class TProposal:
    """The Student-t of the independence moves, of location ``mean``, scale
    matrix ``chol chol'`` and ``T_DF`` degrees of freedom."""

    def __init__(self, mean, chol):
        self.mean, self.chol = mean, chol

    @classmethod
    def of(cls, mean, cov):
        """The proposal for a target of mean ``mean`` and covariance
        ``cov``: scale matrix ``T_VARIANCE_FACTOR cov``."""
        chol = linalg.cholesky(T_VARIANCE_FACTOR * cov, lower=True, check_finite=False)
        return cls(mean, chol)

    def logpdf(self, thetas):
        """Log density up to a constant at ``thetas`` (m, r): (m,)."""
        z = linalg.solve_triangular(
            self.chol, (thetas - self.mean).T, lower=True, check_finite=False
        )
        return -0.5 * (T_DF + z.shape[0]) * np.log1p(np.sum(z**2, axis=0) / T_DF)

    def draw(self, rng, m):
        """``m`` draws (m, r)."""
        z = rng.standard_normal((m, self.mean.size))
        w = rng.chisquare(T_DF, m) / T_DF
        return self.mean + (z @ self.chol.T) / np.sqrt(w)[:, None]


def merge_moments(counts, means, m2s):
    """Pooled mean and sum of squared deviations of several blocks (Chan et al.)."""
    n = counts.sum()
    mean = counts @ means / n
    dev = means - mean
    m2 = m2s.sum(axis=0) + np.einsum("b,bi,bj->ij", counts, dev, dev)
    return n, mean, m2


def window_moments(counts, means, m2s, accepts):
    """Mean and covariance (``+ epsilon I``) of a window of burn-in blocks.

    None when the window holds too few accepted moves (``max(10, 2 r)``).
    """
    r = means.shape[1]
    if accepts.sum() < max(10, 2 * r):
        return None
    n, mean, m2 = merge_moments(counts, means, m2s)
    return mean, (m2 / (n - 1) + _EPSILON * np.eye(r))


def label_proposal(conditionals):
    """The label proposal: the mean of the labels' conditional
    probabilities ``p(k | theta)`` at a window's Gibbs updates (a
    Rao-Blackwell estimate of their marginal ones), mixed with a uniform
    share :data:`LABEL_UNIFORM_SHARE`."""
    share = LABEL_UNIFORM_SHARE
    return (1.0 - share) * conditionals + share / len(conditionals)


def draw_label(probs, u):
    """The label of probabilities ``probs`` that the uniform ``u`` picks."""
    cumulative = np.cumsum(probs)
    k = int(np.searchsorted(cumulative, u * cumulative[-1], side="right"))
    return min(k, len(probs) - 1)
