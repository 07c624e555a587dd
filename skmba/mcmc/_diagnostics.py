"""Convergence diagnostics of Markov chains (Vehtari et al. 2021).

This module knows nothing about how the draws were made: it reads arrays of
shape ``(n_chains, n_draws)`` of one parameter.

* :func:`split_rhat`, :func:`ess_bulk` and :func:`rank_normalize` are the
  rank-normalised split-R-hat and bulk effective sample size of Vehtari,
  Gelman, Simpson, Carpenter & Bürkner (2021), "Rank-normalization, folding,
  and localization: an improved R-hat for assessing convergence of MCMC",
  *Bayesian Analysis* 16(2), 667-718.
* :func:`ess_tail` is their tail effective sample size, the smaller of the
  effective sample sizes of the 5 % and 95 % quantiles' indicators: what
  sets the Monte Carlo error of an interval's ends.
* :func:`check_diagnostics` warns when a run of
  :func:`skmba.mcmc._run.run_chains` has not converged and says what to
  change.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._diagnostics import ess_bulk, split_rhat
>>> draws = np.random.default_rng(0).normal(size=(4, 1000))
>>> bool(split_rhat(draws) < 1.01), bool(ess_bulk(draws) > 3000)
(True, True)
"""

import math

import numpy as np
from scipy import fft, stats

from skmba._core.warn import warn


def rank_normalize(x):
    """Rank-normalise draws: normal scores of their pooled ranks.

    All ``S`` values of ``x`` are ranked together (average ranks for ties,
    :func:`scipy.stats.rankdata`) and mapped to
    ``Phi^-1((rank - 3/8) / (S + 1/4))`` (Blom's normal scores).

    Parameters
    ----------
    x : array_like
        Draws, of any shape (typically (n_chains, n_draws)).

    Returns
    -------
    z : ndarray of the shape of ``x``

    Examples
    --------
    >>> from skmba.mcmc._diagnostics import rank_normalize
    >>> z = rank_normalize([[1.0, 5.0], [2.0, 2.0]])
    >>> z.shape
    (2, 2)
    >>> bool(z[1, 0] == z[1, 1]), bool(z[0, 0] < z[1, 0] < z[0, 1])
    (True, True)
    """
    x = np.asarray(x, dtype=float)
    ranks = stats.rankdata(x, method="average", axis=None).reshape(x.shape)
    return stats.norm.ppf((ranks - 0.375) / (x.size + 0.25))


def _as_chains(chains):
    chains = np.asarray(chains, dtype=float)
    if chains.ndim == 1:
        chains = chains[np.newaxis]
    if chains.ndim != 2:
        raise ValueError(
            f"chains must have shape (n_chains, n_draws), got {chains.shape}"
        )
    return chains


def _split(chains):
    """Halve each chain (dropping the middle draw of an odd-length chain)."""
    half = chains.shape[1] // 2
    return np.concatenate([chains[:, :half], chains[:, chains.shape[1] - half :]])


def _rhat(chains):
    """Potential scale reduction of chains (n_chains, n) (Gelman et al. BDA3)."""
    n = chains.shape[1]
    within = chains.var(axis=1, ddof=1).mean()
    between = n * chains.mean(axis=1).var(ddof=1)
    if within == 0.0:
        return math.inf if between > 0.0 else math.nan
    return math.sqrt(((n - 1) / n * within + between / n) / within)


def _rhat_bulk(chains):
    """R-hat of the rank-normalised split chains."""
    return _rhat(rank_normalize(_split(chains)))


def _rhat_folded(chains):
    """R-hat of the rank-normalised split chains folded about the median."""
    split = _split(chains)
    return _rhat(rank_normalize(np.abs(split - np.median(split))))


def _usable(chains):
    return chains.shape[1] >= 4 and np.all(np.isfinite(chains)) and np.ptp(chains) > 0


def split_rhat(chains):
    """Rank-normalised split-R-hat of one parameter.

    Each chain is split into halves (the middle draw of an odd-length chain
    is dropped), so that a trend within a chain shows as a disagreement
    between halves. Two potential scale reduction factors
    ``sqrt(var_plus / W)`` are computed on the split chains, with ``W`` the
    mean within-chain variance and ``var_plus = (n-1)/n W + B/n`` (``B/n``
    the variance of the chain means): the *bulk* R-hat of the rank-normalised
    draws (:func:`rank_normalize`), which detects chains with different
    locations, and the *folded* R-hat of the rank-normalised absolute
    deviations from the median of all draws, which detects chains with
    different scales. Following Vehtari et al. (2021), the larger of the two
    is returned; values above 1.01 indicate that the chains have not mixed.
    With two chains or more this equals ``arviz.rhat(chains, method="rank")``
    to rounding; for a single chain ArviZ returns NaN while this compares
    its two halves.

    Parameters
    ----------
    chains : array_like of shape (n_chains, n_draws)
        Draws of one parameter (a 1-D array is a single chain).

    Returns
    -------
    rhat : float
        NaN when there are fewer than 4 draws per chain, non-finite draws or
        all draws are equal; ``inf`` when every split chain is constant but
        they differ.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import split_rhat
    >>> rng = np.random.default_rng(0)
    >>> draws = rng.normal(size=(4, 1000))
    >>> bool(split_rhat(draws) < 1.01)
    True
    >>> draws[0] += 2.0
    >>> bool(split_rhat(draws) > 1.1)
    True
    """
    chains = _as_chains(chains)
    if not _usable(chains):
        return math.nan
    return max(_rhat_bulk(chains), _rhat_folded(chains))


def _autocovariance(chains):
    """Biased autocovariances of each chain at lags 0 to n-1, by FFT."""
    n = chains.shape[1]
    centred = chains - chains.mean(axis=1, keepdims=True)
    size = fft.next_fast_len(2 * n)
    spectrum = fft.rfft(centred, n=size, axis=1)
    return fft.irfft(spectrum * spectrum.conj(), n=size, axis=1)[:, :n] / n


def _ess(chains):
    """Effective sample size of chains (n_chains, n) with Geyer's estimator.

    A line-by-line transcription of Stan's ``compute_effective_sample_size``
    (as in ArviZ's ``_ess``), so that the values agree with both.
    """
    m, n = chains.shape
    acov = _autocovariance(chains)
    within = acov[:, 0].mean() * n / (n - 1)
    var_plus = within * (n - 1) / n
    if m > 1:
        var_plus += chains.mean(axis=1).var(ddof=1)
    rho = 1.0 - (within - acov.mean(axis=0)) / var_plus
    rho[0] = 1.0
    if np.isnan(rho).any():
        return math.nan
    # Geyer's initial positive sequence: pairs rho_2k + rho_2k+1 are kept
    # up to the first negative one (lags up to n - 2).
    kept = np.zeros(n)
    kept[:2] = rho[:2]
    even, odd = 1.0, rho[1]
    t = 1
    while t < n - 3 and even + odd > 0.0:
        even, odd = rho[t + 1], rho[t + 2]
        if even + odd >= 0.0:
            kept[t + 1], kept[t + 2] = even, odd
        t += 2
    max_t = t - 2
    # Stan's tail term: the last even lag, when positive, counts once.
    if even > 0.0:
        kept[max_t + 1] = even
    # Geyer's initial monotone sequence: each pair no larger than the last.
    t = 1
    while t <= max_t - 2:
        if kept[t + 1] + kept[t + 2] > kept[t - 1] + kept[t]:
            kept[t + 1] = kept[t + 2] = (kept[t - 1] + kept[t]) / 2.0
        t += 2
    tau = -1.0 + 2.0 * kept[: max_t + 1].sum() + kept[max_t + 1 : max_t + 2].sum()
    # As Stan does, bound the ESS by m n log10(m n) for antithetic chains.
    tau = max(tau, 1.0 / math.log10(m * n))
    return m * n / tau


def ess_bulk(chains):
    """Bulk effective sample size of one parameter.

    The effective sample size of the rank-normalised (:func:`rank_normalize`)
    split chains (see :func:`split_rhat`): ``M N / tau`` for ``M`` split chains
    of ``N`` draws, with the integrated autocorrelation time
    ``tau = -1 + 2 sum_k P_k``. The autocorrelations combine all chains,
    ``rho_t = 1 - (W - mean_m acov_m(t)) / var_plus`` (Vehtari et al. 2021,
    Eq. 10), from autocovariances computed by FFT; ``P_k = rho_2k + rho_2k+1``
    are summed up to the first negative ``P_k`` and made non-increasing
    (Geyer's initial monotone sequence estimator), and the last even-lag
    autocorrelation, when positive, is added once (Stan's tail term).
    ``tau`` is bounded below by ``1 / log10(M N)``. The result equals
    ``arviz.ess(chains, method="bulk")`` (ArviZ 0.x) and Stan's bulk ESS to
    rounding (checked in ``tests/mcmc/test_diagnostics.py``).

    Parameters
    ----------
    chains : array_like of shape (n_chains, n_draws)
        Draws of one parameter (a 1-D array is a single chain).

    Returns
    -------
    ess : float
        NaN when there are fewer than 4 draws per chain, non-finite draws or
        all draws are equal.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import ess_bulk
    >>> rng = np.random.default_rng(0)
    >>> bool(3600 < ess_bulk(rng.normal(size=(4, 1000))) < 4400)
    True
    >>> walk = np.cumsum(rng.normal(size=(4, 1000)), axis=1)
    >>> bool(ess_bulk(walk) < 100)
    True
    """
    chains = _as_chains(chains)
    if not _usable(chains):
        return math.nan
    return _ess(rank_normalize(_split(chains)))


def ess_tail(chains):
    """Tail effective sample size of one parameter.

    The smaller of the effective sample sizes of ``I(x <= q_0.05)`` and
    ``I(x <= q_0.95)`` over the split chains (see :func:`split_rhat`),
    ``q_p`` the ``p`` quantile of all draws (Vehtari et al. 2021, section
    4.3): the draws' worth for the ends of an interval, which a sampler
    that moves slowly through the tails has fewer of than its bulk ESS
    says. Equals ``arviz.ess(chains, method="tail")`` (ArviZ 0.x) to
    rounding (checked in ``tests/mcmc/test_diagnostics.py``).

    Parameters
    ----------
    chains : array_like of shape (n_chains, n_draws)
        Draws of one parameter (a 1-D array is a single chain).

    Returns
    -------
    ess : float
        NaN as for :func:`ess_bulk`.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import ess_tail
    >>> rng = np.random.default_rng(0)
    >>> bool(3400 < ess_tail(rng.normal(size=(4, 1000))) < 4600)
    True
    """
    chains = _as_chains(chains)
    if not _usable(chains):
        return math.nan
    split = _split(chains)
    low, high = np.quantile(chains, [0.05, 0.95])
    return min(_ess((split <= low).astype(float)), _ess((split <= high).astype(float)))


def ess_mean(chains):
    """Effective sample size of one parameter's mean.

    That of the draws themselves over the split chains, without the rank
    normalisation of :func:`ess_bulk` (same argument, NaN in the same
    cases): what sets the Monte Carlo error ``sd / sqrt(ess_mean)`` of the
    posterior mean, and below the bulk ESS for a heavy-tailed parameter,
    whose rare far draws move the mean. Equals ``arviz.ess(chains,
    method="mean")`` (ArviZ 0.x) to rounding.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import ess_mean
    >>> rng = np.random.default_rng(0)
    >>> bool(3600 < ess_mean(rng.normal(size=(4, 1000))) < 4400)
    True
    """
    chains = _as_chains(chains)
    if not _usable(chains):
        return math.nan
    return _ess(_split(chains))


def ess_sd(chains):
    """Effective sample size of one parameter's sd: :func:`ess_mean` of the
    squared deviations from the mean of all draws. Equals
    ``arviz.ess(chains, method="sd")`` (ArviZ 0.x) to rounding.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import ess_sd
    >>> rng = np.random.default_rng(0)
    >>> bool(3400 < ess_sd(rng.normal(size=(4, 1000))) < 4600)
    True
    """
    chains = _as_chains(chains)
    if not _usable(chains):
        return math.nan
    return ess_mean((chains - chains.mean()) ** 2)


#: The largest split R-hat of converged chains (Vehtari et al. 2021).
MAX_RHAT = 1.01
#: The smallest bulk ESS that :func:`check_diagnostics` accepts.
MIN_ESS = 400


def check_diagnostics(result, rhat_threshold=MAX_RHAT, min_ess=MIN_ESS, *, names=None):
    """Warn when chains have not converged or are too short.

    One :class:`UserWarning` per problem: parameters whose
    :func:`split_rhat` exceeds ``rhat_threshold`` (or cannot be computed), and
    parameters whose :func:`ess_bulk` is below ``min_ess``.

    Parameters
    ----------
    result : skmba.mcmc._run.ChainResult
        Output of :func:`skmba.mcmc._run.run_chains`; only its ``samples``,
        ``rhat`` and ``ess`` are read.
    rhat_threshold : float, default=1.01
        Largest acceptable R-hat.
    min_ess : float, default=400
        Smallest acceptable bulk effective sample size.
    names : sequence of str, default=None
        Parameter names used in the messages; ``theta[j]`` by default.

    Returns
    -------
    messages : list of str
        The warning messages; empty when all is well.

    Examples
    --------
    >>> import warnings
    >>> import numpy as np
    >>> from skmba.mcmc._diagnostics import check_diagnostics
    >>> from skmba.mcmc._run import run_chains
    >>> result = run_chains(lambda t: -0.5 * float(t @ t), np.zeros((2, 1)),
    ...                     n_samples=50, burn_in=10, random_state=0)
    >>> with warnings.catch_warnings(record=True):
    ...     warnings.simplefilter("always")
    ...     messages = check_diagnostics(result)
    >>> any("n_samples" in message for message in messages)
    True
    """
    r = result.samples.shape[-1]
    if names is None:
        names = [f"theta[{j}]" for j in range(r)]
    elif len(names) != r:
        raise ValueError(f"names must have {r} entries, got {len(names)}")
    messages = []
    rhat = result.rhat
    bad = [j for j in range(r) if not rhat[j] <= rhat_threshold]
    if bad:
        listed = ", ".join(f"{names[j]} ({rhat[j]:.3g})" for j in bad)
        messages.append(
            f"R-hat above {rhat_threshold} for {listed}: the chains have not "
            "mixed. Run a longer burn_in and more samples (n_samples), or more "
            "chains from dispersed starts, and check that the posterior is not "
            "multimodal."
        )
    ess = result.ess
    bad = [j for j in range(r) if not ess[j] >= min_ess]
    if bad:
        listed = ", ".join(f"{names[j]} ({ess[j]:.0f})" for j in bad)
        messages.append(
            f"Bulk effective sample size below {min_ess} for {listed}: draw "
            "more samples (n_samples) or more chains; a longer burn_in lets "
            "the proposal adapt better."
        )
    for message in messages:
        warn(message, UserWarning)
    return messages
