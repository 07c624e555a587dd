"""Markov chain Monte Carlo for any log-density, with convergence diagnostics.

This module knows nothing about Gaussian processes: it samples a function
``log_density(theta) -> float`` of a 1-D parameter vector.

* :func:`run_chains` runs several random-walk Metropolis-Hastings chains in
  parallel (:class:`joblib.Parallel` over chains). During burn-in the Gaussian
  proposal adapts (Haario et al. 2001 covariance adaptation plus a
  Robbins-Monro global scale tuned towards the optimal acceptance rate); it is
  frozen at the end of burn-in, so the kept draws come from a Markov chain
  with a fixed kernel. The draws are bit-identical for any ``n_jobs``.
* :func:`split_rhat`, :func:`ess_bulk` and :func:`rank_normalize` are the
  rank-normalised split-R-hat and bulk effective sample size of Vehtari,
  Gelman, Simpson, Carpenter & Bürkner (2021), "Rank-normalization, folding,
  and localization: an improved R-hat for assessing convergence of MCMC",
  *Bayesian Analysis* 16(2), 667-718.
* :func:`check_diagnostics` warns when a run has not converged and says what
  to change.

Examples
--------
>>> import numpy as np
>>> from skmba._sampling import run_chains
>>> def log_density(theta):
...     return -0.5 * float(theta @ theta)
>>> result = run_chains(log_density, np.zeros((2, 2)), n_samples=500,
...                     burn_in=200, random_state=0)
>>> result.samples.shape
(2, 500, 2)
>>> result.pooled.shape
(1000, 2)
>>> bool(np.all(np.abs(result.pooled.mean(axis=0)) < 0.5))
True
"""

import math
import time
import warnings
from dataclasses import dataclass
from numbers import Integral

import numpy as np
from joblib import Parallel, delayed
from scipy import fft, linalg, stats
from threadpoolctl import threadpool_limits

# Optimal scaling of a random-walk proposal for a Gaussian target in r
# dimensions (Gelman, Roberts & Gilks 1996): proposal covariance
# 2.38^2 / r times the target covariance.
_OPTIMAL_SCALE = 2.38**2
# Optimal acceptance rates of random-walk Metropolis: 0.44 in one dimension,
# 0.234 asymptotically in many (Roberts, Gelman & Gilks 1997).
_TARGET_ACCEPTANCE_1D = 0.44
_TARGET_ACCEPTANCE = 0.234
# The proposal covariance is re-estimated every this many burn-in steps.
_ADAPT_INTERVAL = 50
# Regularisation ``epsilon I`` added to the empirical covariance (the caller
# works in standardised units, in which this is negligible).
_EPSILON = 1e-10
# Robbins-Monro gain on the log scale factor at burn-in step t: (t + 1)^-0.5.
_GAIN_EXPONENT = 0.5
# Number of steps per block of pre-drawn random numbers after burn-in.
_BLOCK = 1024


@dataclass
class ChainResult:
    """Draws of several Markov chains after burn-in.

    Attributes
    ----------
    samples : ndarray of shape (n_chains, n_samples, r)
        Draws kept after burn-in.
    log_density : ndarray of shape (n_chains, n_samples)
        ``log_density`` at each draw.
    acceptance_rate : ndarray of shape (n_chains,)
        Fraction of accepted proposals after burn-in.
    proposal_cov : ndarray of shape (n_chains, r, r)
        Covariance of the Gaussian random-walk proposal used after burn-in
        (including the adapted scale factor).

    Examples
    --------
    >>> import numpy as np
    >>> from skmba._sampling import run_chains
    >>> result = run_chains(lambda t: -0.5 * float(t @ t), np.zeros((4, 1)),
    ...                     n_samples=1000, burn_in=500, random_state=0)
    >>> result.samples.shape, result.acceptance_rate.shape
    ((4, 1000, 1), (4,))
    >>> bool(result.rhat[0] < 1.05), bool(result.ess[0] > 400)
    (True, True)
    """

    samples: np.ndarray
    log_density: np.ndarray
    acceptance_rate: np.ndarray
    proposal_cov: np.ndarray

    @property
    def n_chains(self):
        """Number of chains."""
        return self.samples.shape[0]

    @property
    def pooled(self):
        """All draws, chain after chain: ndarray of shape (n_chains * n_samples, r)."""
        return self.samples.reshape(-1, self.samples.shape[-1])

    @property
    def rhat(self):
        """:func:`split_rhat` of each parameter: ndarray of shape (r,)."""
        return np.array(
            [split_rhat(self.samples[:, :, j]) for j in range(self.samples.shape[-1])]
        )

    @property
    def ess(self):
        """:func:`ess_bulk` of each parameter: ndarray of shape (r,)."""
        return np.array(
            [ess_bulk(self.samples[:, :, j]) for j in range(self.samples.shape[-1])]
        )


def run_chains(
    log_density,
    starts,
    *,
    n_samples,
    burn_in,
    proposal_cov=None,
    adapt=True,
    n_jobs=None,
    random_state=None,
    verbose=0,
):
    """Run adaptive random-walk Metropolis-Hastings chains in parallel.

    Each chain proposes ``theta + sqrt(lambda) L z`` with ``z`` standard
    normal and ``L L' = C`` and accepts with probability
    ``min(1, p(proposal) / p(theta))``.

    With ``adapt=True``, during burn-in only:

    * the scale factor ``lambda`` (initially 1) follows the Robbins-Monro
      recursion ``log lambda += (t + 1)^-0.5 (alpha_t - alpha*)``, where
      ``alpha_t`` is the acceptance probability of step ``t`` and ``alpha*``
      is 0.234 (0.44 when r = 1);
    * every 50 steps from step 100 on, the covariance becomes
      ``C = (2.38^2 / r) (S + 1e-10 I)`` (Haario, Saksman & Tamminen 2001),
      where ``S`` is the empirical covariance of the burn-in draws of the
      latest half of the burn-in so far (earlier draws, still in transit from
      the start, are forgotten). ``C`` is only updated when that window holds
      at least ``max(10, 2 r)`` accepted moves.

    Both are frozen at the end of burn-in: the kept draws come from a Markov
    chain with a fixed kernel, whose covariance ``lambda C`` is returned in
    ``proposal_cov``.

    Parameters
    ----------
    log_density : callable or sequence of n_chains callables
        ``log_density(theta) -> float`` for ``theta`` an ndarray of shape
        (r,), which it must not modify, up to an additive constant. ``-inf``
        means zero density: the proposal is rejected. It must be picklable
        (``cloudpickle``) when ``n_jobs`` runs chains in other processes.
        A sequence gives each chain its own callable (all computing the same
        density), e.g. objects with their own caches, which then stay
        private to a chain under a thread-based joblib backend.
    starts : array_like of shape (n_chains, r)
        Starting point of each chain; each must have a finite log-density.
        Dispersed starts make :attr:`ChainResult.rhat` meaningful.
    n_samples : int
        Number of draws kept per chain, after burn-in.
    burn_in : int
        Number of initial steps per chain, discarded (and used for adaptation).
    proposal_cov : array_like of shape (r, r) or (n_chains, r, r), default=None
        Initial (or, with ``adapt=False``, fixed) proposal covariance. The
        default ``(2.38^2 / r) I`` is the optimal random-walk proposal for a
        target with unit variances: the caller is expected to work in
        standardised units (parameters of order one).
    adapt : bool, default=True
        Adapt the proposal during burn-in; ``False`` keeps ``proposal_cov``.
    n_jobs : int, default=None
        Number of chains run at the same time by :class:`joblib.Parallel`
        (default backend, so :func:`joblib.parallel_config` applies). Each
        chain holds BLAS to one thread, so that its arithmetic, hence its
        draws, do not depend on the backend or on the number of cores.
    random_state : int, RandomState, Generator or None, default=None
        Source of the entropy of :class:`numpy.random.SeedSequence`, whose
        ``spawn(n_chains)`` children seed the chains: an int is used as is, a
        ``RandomState`` or ``Generator`` gives one random integer, ``None``
        fresh entropy. Results do not depend on ``n_jobs``.
    verbose : int, default=0
        Verbosity of :class:`joblib.Parallel`; from 2 on, each chain also
        prints (to the standard output of the process that runs it) the end
        of its burn-in with the adapted scale factor, every quarter of its
        draws and its acceptance rate.

    Returns
    -------
    result : ChainResult

    Raises
    ------
    ValueError
        If a start has a zero (``-inf`` log) density, or an argument is
        invalid.
    RuntimeError
        If ``log_density`` raises (the original exception is chained and its
        message repeated, with the chain index) or returns NaN or ``+inf``.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba._sampling import run_chains
    >>> scales = np.array([10.0, 0.1])
    >>> def log_density(theta):
    ...     return -0.5 * float(np.sum((theta / scales) ** 2))
    >>> starts = np.random.default_rng(0).normal(size=(4, 2)) * scales
    >>> result = run_chains(log_density, starts, n_samples=2000, burn_in=1000,
    ...                     random_state=0)
    >>> np.round(result.pooled.std(axis=0) / scales, 1)
    array([1., 1.])
    >>> bool(np.all((result.acceptance_rate > 0.15)
    ...             & (result.acceptance_rate < 0.5)))
    True
    """
    starts = np.array(starts, dtype=float)
    if starts.ndim != 2 or starts.shape[0] < 1 or starts.shape[1] < 1:
        raise ValueError(
            "starts must be a 2-D array of shape (n_chains, r) with at least one "
            f"chain and one parameter, got shape {starts.shape}; use "
            "starts.reshape(1, -1) for a single chain"
        )
    if not np.all(np.isfinite(starts)):
        raise ValueError("starts must be finite")
    n_chains, r = starts.shape
    densities = _per_chain(log_density, n_chains)
    n_samples = _check_count(n_samples, "n_samples", minimum=1)
    burn_in = _check_count(burn_in, "burn_in", minimum=0)

    if proposal_cov is None:
        proposal_cov = np.broadcast_to(_OPTIMAL_SCALE / r * np.eye(r), (n_chains, r, r))
    else:
        proposal_cov = np.asarray(proposal_cov, dtype=float)
        if proposal_cov.shape == (r, r):
            proposal_cov = np.broadcast_to(proposal_cov, (n_chains, r, r))
        elif proposal_cov.shape != (n_chains, r, r):
            raise ValueError(
                f"proposal_cov must have shape ({r}, {r}) or ({n_chains}, {r}, {r}), "
                f"got {proposal_cov.shape}"
            )
    chols = []
    for c in range(n_chains):
        cov = proposal_cov[c]
        if not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T):
            raise ValueError("proposal_cov must be finite and symmetric")
        try:
            chols.append(linalg.cholesky(cov, lower=True))
        except linalg.LinAlgError:
            raise ValueError("proposal_cov must be positive definite") from None

    start_values = []
    for c in range(n_chains):
        value = _evaluate(densities[c], starts[c].copy(), c)
        if value == -np.inf:
            raise ValueError(
                f"starts[{c}] has zero density (log_density = -inf); every "
                "row of starts must lie inside the support of the target"
            )
        start_values.append(value)

    seeds = np.random.SeedSequence(_entropy(random_state)).spawn(n_chains)
    outputs = Parallel(n_jobs=n_jobs, verbose=verbose)(
        delayed(_run_chain)(
            densities[c],
            starts[c],
            start_values[c],
            chols[c],
            n_samples=n_samples,
            burn_in=burn_in,
            adapt=bool(adapt),
            seed=seeds[c],
            chain=c,
            verbose=verbose,
        )
        for c in range(n_chains)
    )
    samples, values, acceptance, covs = zip(*outputs, strict=True)
    return ChainResult(
        samples=np.stack(samples),
        log_density=np.stack(values),
        acceptance_rate=np.array(acceptance),
        proposal_cov=np.stack(covs),
    )


def _per_chain(log_density, n_chains):
    """One log-density callable per chain."""
    if callable(log_density):
        return [log_density] * n_chains
    try:
        densities = list(log_density)
    except TypeError:
        raise TypeError(
            "log_density must be callable or a sequence of callables (one per "
            f"chain), got {log_density!r}"
        ) from None
    if len(densities) != n_chains or not all(callable(f) for f in densities):
        raise TypeError(
            f"log_density must be callable or a sequence of {n_chains} callables "
            f"(one per row of starts), got {len(densities)} entries"
        )
    return densities


def _check_count(value, name, *, minimum):
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _entropy(random_state):
    """Entropy of the chains' SeedSequence from ``random_state``."""
    if random_state is None:
        return None
    if isinstance(random_state, np.random.Generator):
        return int(random_state.integers(2**63))
    if isinstance(random_state, np.random.RandomState):
        return int(random_state.randint(2**63, dtype=np.int64))
    if isinstance(random_state, Integral) and not isinstance(random_state, bool):
        if random_state < 0:
            raise ValueError(f"random_state must be non-negative, got {random_state}")
        return int(random_state)
    raise ValueError(
        "random_state must be None, a non-negative int, a numpy RandomState or a "
        f"numpy Generator, got {random_state!r}"
    )


def _evaluate(log_density, theta, chain):
    """``log_density(theta)`` as a float, errors naming the chain."""
    try:
        value = float(log_density(theta))
    except Exception as exc:
        raise RuntimeError(
            f"log_density raised {type(exc).__name__} in chain {chain} at "
            f"theta={theta!r}: {exc}"
        ) from exc
    if value != value or value == math.inf:
        raise RuntimeError(
            f"log_density returned {value} in chain {chain} at theta={theta!r}; "
            "it must return a finite float or -inf (zero density)"
        )
    return value


def _merge_moments(counts, means, m2s):
    """Pooled mean and sum of squared deviations of several blocks (Chan et al.)."""
    n = counts.sum()
    mean = counts @ means / n
    dev = means - mean
    m2 = m2s.sum(axis=0) + np.einsum("b,bi,bj->ij", counts, dev, dev)
    return n, mean, m2


def _run_chain(*args, **kwargs):
    """One chain: adaptive burn-in, then ``n_samples`` draws with a fixed kernel.

    Arguments as :func:`_run_chain_body`. BLAS is held to one thread: the
    chain's arithmetic is then the same in any worker (process or thread) of
    any joblib backend.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_chain_body(*args, **kwargs)


def _run_chain_body(
    log_density,
    start,
    start_value,
    chol,
    *,
    n_samples,
    burn_in,
    adapt,
    seed,
    chain,
    verbose,
):
    started = time.perf_counter()
    rng = np.random.default_rng(seed)
    r = start.size
    theta = start.copy()
    logp = start_value
    target = _TARGET_ACCEPTANCE_1D if r == 1 else _TARGET_ACCEPTANCE
    log_scale = 0.0
    exp = math.exp

    # Burn-in, in blocks of _ADAPT_INTERVAL steps with a fixed shape L.
    n_blocks = -(-burn_in // _ADAPT_INTERVAL)
    counts = np.zeros(n_blocks)
    means = np.zeros((n_blocks, r))
    m2s = np.zeros((n_blocks, r, r))
    accepts = np.zeros(n_blocks, dtype=int)
    step = 0
    for b in range(n_blocks):
        m = min(_ADAPT_INTERVAL, burn_in - step)
        increments = rng.standard_normal((m, r)) @ chol.T
        log_u = np.log(rng.random(m))
        block = np.empty((m, r))
        n_accept = 0
        for i in range(m):
            proposal = theta + exp(0.5 * log_scale) * increments[i]
            value = _evaluate(log_density, proposal, chain)
            diff = value - logp
            if log_u[i] < diff:
                theta = proposal
                logp = value
                n_accept += 1
            if adapt:
                alpha = 1.0 if diff >= 0.0 else exp(diff)
                log_scale += (step + 1) ** -_GAIN_EXPONENT * (alpha - target)
            block[i] = theta
            step += 1
        counts[b] = m
        means[b] = block.mean(axis=0)
        dev = block - means[b]
        m2s[b] = dev.T @ dev
        accepts[b] = n_accept
        if adapt and step >= 2 * _ADAPT_INTERVAL and step < burn_in:
            first = (b + 1) // 2
            if accepts[first : b + 1].sum() >= max(10, 2 * r):
                n, _, m2 = _merge_moments(
                    counts[first : b + 1], means[first : b + 1], m2s[first : b + 1]
                )
                cov = _OPTIMAL_SCALE / r * (m2 / (n - 1) + _EPSILON * np.eye(r))
                try:
                    chol = linalg.cholesky(cov, lower=True, check_finite=False)
                except linalg.LinAlgError:
                    pass  # keep the previous shape

    # Fixed kernel after burn-in.
    if verbose >= 2:
        print(
            f"chain {chain}: burn-in of {burn_in} steps done in "
            f"{time.perf_counter() - started:.1f} s, scale factor "
            f"{exp(log_scale):.3g}",
            flush=True,
        )
    chol = exp(0.5 * log_scale) * chol
    quarters = {(k * n_samples) // 4 for k in range(1, 4)} - {0}
    samples = np.empty((n_samples, r))
    values = np.empty(n_samples)
    n_accept = 0
    step = 0
    while step < n_samples:
        m = min(_BLOCK, n_samples - step)
        increments = rng.standard_normal((m, r)) @ chol.T
        log_u = np.log(rng.random(m))
        for i in range(m):
            proposal = theta + increments[i]
            value = _evaluate(log_density, proposal, chain)
            if log_u[i] < value - logp:
                theta = proposal
                logp = value
                n_accept += 1
            samples[step] = theta
            values[step] = logp
            step += 1
            if verbose >= 2 and step in quarters:
                print(
                    f"chain {chain}: {step}/{n_samples} draws "
                    f"({time.perf_counter() - started:.1f} s)",
                    flush=True,
                )
    acceptance = n_accept / n_samples
    if verbose >= 2:
        print(
            f"chain {chain}: {n_samples} draws done in "
            f"{time.perf_counter() - started:.1f} s, acceptance {acceptance:.3f}",
            flush=True,
        )
    return samples, values, acceptance, chol @ chol.T


# ---------------------------------------------------------------------------
# Diagnostics (Vehtari et al. 2021)


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
    >>> from skmba._sampling import rank_normalize
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
    >>> from skmba._sampling import split_rhat
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
    """Effective sample size of chains (n_chains, n) with Geyer's estimator."""
    m, n = chains.shape
    acov = _autocovariance(chains)
    within = acov[:, 0].mean() * n / (n - 1)
    var_plus = within * (n - 1) / n
    if m > 1:
        var_plus += chains.mean(axis=1).var(ddof=1)
    rho = 1.0 - (within - acov.mean(axis=0)) / var_plus
    rho[0] = 1.0
    # Geyer's initial monotone sequence: sums of adjacent pairs of
    # autocorrelations, truncated before the first negative one and made
    # non-increasing.
    n_pairs = n // 2
    pairs = rho[0 : 2 * n_pairs : 2] + rho[1 : 2 * n_pairs : 2]
    negative = np.flatnonzero(pairs < 0.0)
    if negative.size:
        pairs = pairs[: negative[0]]
    pairs = np.minimum.accumulate(pairs)
    tau = 2.0 * pairs.sum() - 1.0
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
    (Geyer's initial monotone sequence estimator). ``tau`` is bounded below by
    ``1 / log10(M N)``.

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
    >>> from skmba._sampling import ess_bulk
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


def check_diagnostics(result, rhat_threshold=1.01, min_ess=400, *, names=None):
    """Warn when chains have not converged or are too short.

    One :class:`UserWarning` per problem: parameters whose
    :func:`split_rhat` exceeds ``rhat_threshold`` (or cannot be computed), and
    parameters whose :func:`ess_bulk` is below ``min_ess``.

    Parameters
    ----------
    result : ChainResult
        Output of :func:`run_chains`.
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
    >>> from skmba._sampling import check_diagnostics, run_chains
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
        warnings.warn(message, UserWarning, stacklevel=2)
    return messages
