"""The draws of ``phi`` of the converged integral and the proposals they
came from.

:func:`~skmba.calibration._module2_converged.converge` draws ``phi`` in
blocks, first from the defensive proposal around the Laplace mode of its
marginal posterior, then (:func:`influence_proposal`) from a second one
fitted to the first draws weighted by their influence on theta's
posterior summaries: where the draws that set the summaries' Monte Carlo
errors lie (on confounded designs, the few draws of large, rough
discrepancies that carry the upper end). :class:`DrawBlocks` weighs every
draw, old and new, against the mixture of the proposals in the shares they
were drawn in (the balance heuristic, Veach & Guibas 1995; adaptive
multiple importance sampling, Cornuet et al. 2012), so the first draws are
kept. Measurements: ``docs/internals.rst``, section
skmba.calibration._module2_converged.
"""

from dataclasses import dataclass

import numpy as np
from scipy import special

from skmba.calibration._module2_posterior import proposal_log_density


@dataclass(frozen=True)
class DrawBlocks:
    """Draws of ``phi`` so far (whole blocks): coordinates ``V`` (K, m),
    their log prior densities ``log_p`` (K,), their log densities under each
    proposal drawn from so far ``log_q`` (K, J), the proposal each came
    from ``source`` (K,), and their log likelihoods on the coarse (``L``)
    and fine (``F``) grids of theta."""

    V: np.ndarray
    log_p: np.ndarray
    log_q: np.ndarray
    source: np.ndarray
    L: np.ndarray
    F: np.ndarray

    @property
    def log_w(self):
        """Log importance weights ``log p - log q``, ``q`` the proposals'
        mixture in the shares of their draws (one proposal: its own)."""
        if self.log_q.shape[1] == 1:
            return self.log_p - self.log_q[:, 0]
        shares = np.bincount(self.source, minlength=self.log_q.shape[1])
        with np.errstate(divide="ignore"):
            log_shares = np.log(shares / len(self.source))
        return self.log_p - special.logsumexp(self.log_q + log_shares, axis=1)

    def add(self, V, log_p, log_q, source, L, F):
        """These draws with more (``log_q`` under every proposal so far)."""
        return DrawBlocks(
            np.vstack([self.V, V]),
            np.r_[self.log_p, log_p],
            np.vstack([self.log_q, log_q]),
            np.r_[self.source, source],
            np.hstack([self.L, L]),
            np.hstack([self.F, F]),
        )

    def with_grids(self, L, F):
        """The same draws with their log likelihoods on other grids."""
        return DrawBlocks(self.V, self.log_p, self.log_q, self.source, L, F)

    def with_proposal(self, mode, cov, prior_share):
        """The same draws with their log densities under one more proposal
        (around ``mode``, scale ``cov``, the prior's share ``prior_share``),
        not yet drawn from."""
        column = proposal_log_density(mode, cov, self.V, self.log_p, prior_share)
        log_q = np.column_stack([self.log_q, column])
        return DrawBlocks(self.V, self.log_p, log_q, self.source, self.L, self.F)


def influence_proposal(V, share, influence, scales):
    """The location and scale matrix of a proposal at the draws ``V`` (K, m)
    weighted by their posterior shares ``share`` (K,) times the size of
    their influences ``influence`` (K, s) on theta's summaries, each over
    its tolerance ``scales`` (s,): the draws' weighted mean and covariance,
    the optimal importance density's moments for those summaries (Owen
    2013, Monte Carlo theory, ch. 9). None when no draw has both, or when
    those weights' Kish effective size is below ``2 (m + 1)``, too few to
    estimate a covariance (as few as one draw can carry them: its moments
    are a point; 21-98 on the cantilever cases' first 512 draws, m = 6).
    """
    size = np.sqrt(np.sum((influence / scales) ** 2, axis=1))
    weights = share * size
    total = np.sum(weights)
    if not (np.isfinite(total) and total > 0.0):
        return None
    weights = weights / total
    if 1.0 / np.sum(weights**2) < 2.0 * (V.shape[1] + 1):
        return None
    mean, cov = draw_moments(V, weights)
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        return None
    return mean, cov


def draw_moments(V, weights):
    """The weighted mean and covariance of the draws ``V`` (K, m) for
    ``weights`` (K,) that sum to one, the covariance divided by ``1 -
    sum w^2`` (unbiased for normalised weights; equal weights give the
    sample covariance)."""
    mean = weights @ V
    centred = V - mean
    cov = (centred * weights[:, None]).T @ centred
    cov /= max(1.0 - np.sum(weights**2), 1e-12)
    return mean, cov
