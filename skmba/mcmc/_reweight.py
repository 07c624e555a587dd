"""An earlier run's draws reweighted to a posterior that moved little.

When new data change a posterior only a little (a day of readings added to
a year of them), the draws of the last MCMC run on the old posterior are a
proposal for the new one. Thinned to about one draw per effective draw,
the run's draws ``theta_i`` carry the old log posterior ``log p_old``
(stored by the run, up to a constant); their importance weights
``w_i ~ p_new(theta_i) / p_old(theta_i)`` make a weighted sample of the new
posterior (importance sampling over a sequence of posteriors: Gelfand and
Smith 1990, Chopin 2002). One evaluation of ``p_new`` per node replaces
chains that would need several per effective draw.

- :class:`Anchor`: the thinned draws of the last run and their old log
  density, reweighted again by every update until they no longer suffice;
- :func:`weighted`: the weights, their Kish share, and the
  :class:`~skmba.mcmc._posterior.PosteriorResult` they make;
  :func:`accepted`: whether it stands for the new posterior (a share of
  at least :data:`REWEIGHT_SHARE`), else new chains must be run, which a
  refused posterior with enough effective draws may still start
  (:func:`starts_chains`); :func:`reweighted`: both in one call;
- :func:`systematic_indices`: equally weighted draws of weighted nodes.

Why the share and the thinning: docs/internals.rst, section
skmba.mcmc._reweight.

Examples
--------
Draws of N(0, 1) reweighted to N(0.1, 0.9^2): the weighted mean is
within three of its standard errors of 0.1.

>>> import numpy as np
>>> from scipy import stats
>>> from skmba.mcmc._reweight import Anchor, reweighted
>>> old = stats.norm(0.0, 1.0)
>>> x = old.rvs(size=(4000, 1), random_state=0)
>>> anchor = Anchor(x, old.logpdf(x[:, 0]), np.array([4000.0]))
>>> new = stats.norm(0.1, 0.9).logpdf(x[:, 0])
>>> posterior, share = reweighted(anchor, new, random_state=0)
>>> round(share, 2), posterior.method
(0.97, 'reweighted')
>>> bool(abs(posterior.mean[0] - 0.1) < 3 * 0.9 / np.sqrt(share * 4000))
True
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from skmba._core.validation import seed_sequence
from skmba.mcmc._diagnostics import MAX_RHAT, MIN_ESS, ess_mean, ess_sd, ess_tail
from skmba.mcmc._posterior import PosteriorResult

#: The Kish share ``(sum w)^2 / (M sum w^2)`` of the weights below which
#: reweighting is refused and new chains are run: the reweighted draws are
#: then worth at most half the run's effective draws.
REWEIGHT_SHARE = 0.5


@dataclass(frozen=True)
class Anchor:
    """The draws of an MCMC run that later updates reweight.

    Attributes
    ----------
    thetas : ndarray of shape (M, r)
        The run's draws, thinned evenly in every chain to about one per
        effective draw (user units).
    log_density : ndarray of shape (M,)
        The run's log posterior at ``thetas`` (up to a constant): the
        proposal density of the reweighting.
    ess : ndarray of shape (r,)
        Effective draws of ``thetas`` per parameter: the smallest of the
        run's bulk, tail, mean and sd ESS
        (:mod:`skmba.mcmc._diagnostics`), at most ``M``.
    """

    thetas: np.ndarray
    log_density: np.ndarray
    ess: np.ndarray

    @classmethod
    def of(cls, posterior):
        """The anchor of a posterior: its run's thinned draws (MCMC), the
        anchor it was reweighted from (``"reweighted"``), else None: a
        quadrature, a run that did not keep its log density, or one whose
        diagnostics :func:`~skmba.mcmc._diagnostics.check_diagnostics`
        warned about (R-hat above :data:`MAX_RHAT`, ESS below
        :data:`MIN_ESS`): its draws do not stand for its posterior."""
        if posterior.method == "reweighted":
            return posterior.anchor
        if posterior.method != "mcmc" or posterior.log_density is None:
            return None
        chains, log_density = posterior.chains, posterior.log_density
        n_chains, n_draws, r = chains.shape
        bulk = np.asarray(posterior.ess, dtype=float)
        rhat = np.asarray(posterior.rhat, dtype=float)
        if not (np.all(bulk >= MIN_ESS) and np.all(rhat <= MAX_RHAT)):
            return None  # NaN included
        # What the draws are worth for every summary: the bulk, the tails,
        # the mean and the sd (the last two below the bulk for a heavy tail).
        ess = np.array(
            [
                min(b, *(f(chains[:, :, j]) for f in (ess_tail, ess_mean, ess_sd)))
                for j, b in enumerate(bulk)
            ]
        )
        if not np.all(np.isfinite(ess)):
            return None
        per_chain = max(1, math.ceil(float(np.min(ess)) / n_chains))
        step = max(1, math.ceil(n_draws / per_chain))
        thetas = chains[:, ::step].reshape(-1, r)
        return cls(thetas, log_density[:, ::step].ravel(), np.minimum(ess, len(thetas)))


def systematic_indices(weights, n, rng):
    """``n`` indices of nodes with normalised ``weights``, drawn by
    systematic resampling (one uniform, Kitagawa 1996)."""
    u = (np.arange(n) + rng.uniform()) / n
    return np.minimum(np.searchsorted(np.cumsum(weights), u), len(weights) - 1)


def weighted(anchor, log_density, random_state=None):
    """The anchor's draws weighted to a new posterior, however uneven.

    Parameters
    ----------
    anchor : Anchor
    log_density : ndarray of shape (M,)
        The new log posterior at ``anchor.thetas`` (up to a constant;
        ``-inf`` outside its support).
    random_state : int, SeedSequence or None
        Seeds the systematic resampling of ``samples``.

    Returns
    -------
    posterior : PosteriorResult or None
        Method ``"reweighted"``: the weighted moments, ``nodes`` and
        ``weights``, ``samples`` resampled from them (M draws), ``ess`` the
        anchor's times the Kish share, ``anchor``. None when no node has a
        finite density. Whether it stands for the new posterior is
        :func:`accepted`'s call.
    share : float
        The Kish share of the weights (0 without a finite weight).
    """
    log_w = np.asarray(log_density, dtype=float) - anchor.log_density
    finite = np.isfinite(log_w)
    if not finite.any():
        return None, 0.0
    log_w = np.where(finite, log_w, -np.inf)
    w = np.exp(log_w - special.logsumexp(log_w))
    share = float(1.0 / np.sum(w**2) / len(w))
    thetas = anchor.thetas
    rng = np.random.default_rng(seed_sequence(random_state))
    samples = thetas[systematic_indices(w, len(w), rng)]
    mean = w @ thetas
    centred = thetas - mean
    cov = (centred * w[:, None]).T @ centred
    posterior = PosteriorResult(
        "reweighted",
        samples,
        mean,
        cov,
        nodes=thetas,
        weights=w,
        ess=anchor.ess * share,
        anchor=anchor,
    )
    return posterior, share


def starts_chains(posterior):
    """Whether weighted draws (:func:`weighted`) place new chains near the
    new posterior, so that a short burn-in serves: an ESS of at least
    :data:`~skmba.mcmc._diagnostics.MIN_ESS` (measured:
    docs/internals.rst, section skmba.mcmc._reweight)."""
    return posterior is not None and float(np.min(posterior.ess)) >= MIN_ESS


def accepted(posterior, share):
    """Whether weighted draws (:func:`weighted`) stand for the new
    posterior: a Kish share of at least :data:`REWEIGHT_SHARE`, and enough
    effective draws to start chains (:func:`starts_chains`)."""
    return share >= REWEIGHT_SHARE and starts_chains(posterior)


def reweighted(anchor, log_density, random_state=None):
    """The anchor's draws weighted to a new posterior, if they do.

    :func:`weighted`, and its posterior only when :func:`accepted`.

    Returns
    -------
    posterior : PosteriorResult or None
        None when the share is below :data:`REWEIGHT_SHARE`, the ESS below
        :data:`~skmba.mcmc._diagnostics.MIN_ESS`, or no node has a finite
        density.
    share : float
        The Kish share of the weights (0 without a finite weight).
    """
    posterior, share = weighted(anchor, log_density, random_state)
    return (posterior if accepted(posterior, share) else None), share
