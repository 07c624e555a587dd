"""Posterior moments of a few parameters by two-stage importance quadrature.

The sensor designer needs the posterior mean and covariance of ``theta`` for
thousands of (replicate, subset) pairs, too many for Markov chains. Both
moments are ratios of integrals over the prior,

    E[f(θ) | y] = ∫ f(θ) L(θ) p(θ) dθ / ∫ L(θ) p(θ) dθ,

computed in two stages, knowing nothing of where ``L`` comes from:

1. the prior's own rule (:meth:`skmba.priors._theta.Prior.integration_nodes`:
   Gauss-Legendre on the prior quantiles for one parameter, scrambled Sobol
   points for several), shared by every call so that its likelihood pieces
   can be computed once;
2. when the data are informative, the posterior occupies a few stage-1
   nodes at most and stage 1 cannot resolve its width; the moments are then
   recomputed with a Gaussian importance rule centred on the stage-1
   moments (widened, and with a width floor of one stage-1 node spacing):
   Gauss-Hermite nodes for one parameter, randomised quasi-Monte Carlo
   normal points for several, weighted by ``p(θ) L(θ) / q(θ)``.

Examples
--------
>>> import numpy as np
>>> from scipy import stats
>>> from skmba.priors._theta import check_prior
>>> prior = check_prior([stats.uniform(-5, 10)])
>>> nodes, weights = prior.integration_nodes(33)
>>> def log_lik(t):  # a narrow Gaussian likelihood at 1 with sd 0.05
...     return -0.5 * ((t[:, 0] - 1.0) / 0.05) ** 2
>>> mean, cov = posterior_moments(log_lik, prior, nodes, weights, log_lik(nodes))
>>> round(float(mean[0]), 6), round(float(np.sqrt(cov[0, 0])), 6)
(1.0, 0.05)
"""

from functools import cache

import numpy as np
from scipy import stats

from skmba._core.linalg import proposal_covariance

#: Stage 2 runs when the stage-1 weights' effective number of nodes is
#: below this fraction of the number of nodes.
CONCENTRATION = 0.25


def _normalised(log_w):
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    top = np.max(log_w)
    if not np.isfinite(top):
        return None
    w = np.exp(log_w - top)
    return w / w.sum()


def _moments(nodes, w):
    mean = w @ nodes
    centred = nodes - mean
    cov = (centred * w[:, None]).T @ centred
    return mean, 0.5 * (cov + cov.T)


@cache
def _hermite_rule(n):
    """Gauss-Hermite nodes and normalised weights of ``N(0, 1)`` (read-only:
    every stage 2 of one parameter asks for the same ``n``)."""
    x, w = np.polynomial.hermite_e.hermegauss(n)
    w = w / w.sum()
    x.flags.writeable = w.flags.writeable = False
    return x, w


def gaussian_rule(mean, cov, n, random_state=None):
    """Nodes of ``N(mean, cov)``, their log-density and weights summing to one.

    Gauss-Hermite for one parameter; for several, ``n`` (rounded up to a power
    of two) scrambled Sobol points mapped to the normal, equal weights.

    Examples
    --------
    >>> import numpy as np
    >>> x, log_q, w = gaussian_rule(np.zeros(1), np.eye(1), 5)
    >>> round(float(w @ x[:, 0] ** 2), 12)
    1.0
    """
    r = len(mean)
    cov = proposal_covariance(cov)
    if r == 1:
        x, weights = _hermite_rule(n)
        sd = np.sqrt(cov[0, 0])
        nodes = mean[0] + sd * x[:, None]
    else:
        m = 1 << int(np.ceil(np.log2(n)))
        rng = np.random.default_rng(random_state)  # a seed, its list or None
        u = stats.qmc.Sobol(r, scramble=True, seed=rng).random(m)
        z = stats.norm.ppf(np.clip(u, 1e-12, 1.0 - 1e-12))
        nodes = mean + z @ np.linalg.cholesky(cov).T
        weights = np.full(m, 1.0 / m)
    log_q = stats.multivariate_normal(mean, cov, allow_singular=False).logpdf(nodes)
    return nodes, np.atleast_1d(log_q), weights


def posterior_moments(
    log_likelihood,
    prior,
    nodes,
    weights,
    log_lik_nodes,
    *,
    n_refine=24,
    max_refinements=4,
    seed=None,
    return_rule=False,
):
    """Posterior mean and covariance of ``theta`` by two-stage quadrature.

    Parameters
    ----------
    log_likelihood : callable
        ``log_likelihood(thetas) -> ndarray (k,)`` for thetas (k, r), used at
        the stage-2 nodes; ``-inf`` where the likelihood is zero.
    prior : skmba.priors._theta.Prior
    nodes, weights : ndarray of shape (k, r) and (k,)
        The prior's stage-1 rule (``prior.integration_nodes``).
    log_lik_nodes : ndarray of shape (k,)
        ``log_likelihood(nodes)``, computed by the caller (often shared).
    n_refine : int, default=24
        Stage-2 nodes (a power of two is used for several parameters).
    max_refinements : int, default=4
        Stage 2 is repeated, centred on the latest moments, while the
        weights stay concentrated on a few nodes.
    seed : int or None
        Seed of the stage-2 Sobol scrambling (several parameters).
    return_rule : bool, default=False
        Also return the posterior rule the moments come from.

    Returns
    -------
    mean : ndarray of shape (r,)
    cov : ndarray of shape (r, r)
        Posterior moments; the prior's when the likelihood vanishes at every
        stage-1 node (no information).
    rule : tuple of ndarray (k, r) and (k,)
        Only with ``return_rule``: the nodes and posterior weights (summing
        to one) of the last stage; the prior's rule when the likelihood
        vanishes.
    """
    w = _normalised(np.log(weights) + log_lik_nodes)
    if w is None:
        out = prior.mean(), prior.cov()
        return (*out, (nodes, weights / weights.sum())) if return_rule else out
    mean, cov = _moments(nodes, w)
    rule_nodes = nodes
    r = nodes.shape[1]
    # Width floor: the spacing of the stage-1 nodes along each axis, so that
    # a posterior narrower than one node spacing is still bracketed.
    floor = np.ptp(nodes, axis=0) / len(nodes) ** (1.0 / r)
    for refinement in range(max_refinements):
        if 1.0 / np.sum(w**2) >= CONCENTRATION * len(w):
            break
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        scale = np.maximum(1.5 * sd, floor)
        safe = np.where(sd > 0, sd, 1.0)
        corr = np.clip(cov / np.outer(safe, safe), -0.95, 0.95)
        corr[(sd == 0)[:, None] | (sd == 0)[None, :]] = 0.0
        corr[np.eye(r, dtype=bool)] = 1.0
        x, log_q, w_rule = gaussian_rule(
            mean,
            corr * np.outer(scale, scale),
            n_refine,
            random_state=None
            if seed is None
            else np.random.default_rng([seed, refinement]),
        )
        w_new = _normalised(
            np.log(w_rule) + prior.logpdf(x) + log_likelihood(x) - log_q
        )
        if w_new is None:
            break
        w, rule_nodes, (mean, cov) = w_new, x, _moments(x, w_new)
        floor = floor / 8.0
    return (mean, cov, (rule_nodes, w)) if return_rule else (mean, cov)
