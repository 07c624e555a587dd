"""Random-walk Metropolis-Hastings chains for any log-density.

This module knows nothing about Gaussian processes: it samples a function
``log_density(theta) -> float`` of a 1-D parameter vector.
:func:`run_chains` runs several chains in parallel (:class:`joblib.Parallel`
over chains); the draws are bit-identical for any ``n_jobs``. The
convergence diagnostics of the draws are in :mod:`skmba._diagnostics`.

Each chain proposes ``theta + sqrt(lambda) L z`` with ``z`` standard normal
and ``L L' = C``, and accepts with probability
``min(1, p(proposal) / p(theta))``. With ``adapt=True``, during burn-in only:

* the scale factor ``lambda`` (initially 1) follows the Robbins-Monro
  recursion ``log lambda += (t + 1)^-0.5 (alpha_t - alpha*)``, where
  ``alpha_t`` is the acceptance probability of step ``t`` and ``alpha*`` is
  0.234 (0.44 when r = 1);
* every 50 steps from step 100 on, the covariance becomes
  ``C = (2.38^2 / r) (S + 1e-10 I)`` (Haario, Saksman & Tamminen 2001),
  where ``S`` is the empirical covariance of the burn-in draws of the latest
  half of the burn-in so far (earlier draws, still in transit from the
  start, are forgotten). ``C`` is only updated when that window holds at
  least ``max(10, 2 r)`` accepted moves.

Both are frozen at the end of burn-in: the kept draws come from a Markov
chain with a fixed kernel, whose covariance ``lambda C`` is returned in
:attr:`ChainResult.proposal_cov`.

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
>>> result.samples.shape, result.pooled.shape
((4, 2000, 2), (8000, 2))
>>> np.round(result.pooled.std(axis=0) / scales, 1)
array([1., 1.])
>>> bool(np.all((result.acceptance_rate > 0.15)
...             & (result.acceptance_rate < 0.5)))
True
"""

import math
import time
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from scipy import linalg
from threadpoolctl import threadpool_limits

from skmba._diagnostics import ess_bulk, split_rhat
from skmba._validation import check_count, seed_sequence

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

    The proposal, its adaptation during burn-in and its freezing afterwards
    are described in the module docstring (:mod:`skmba._sampling`).

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
    random_state : int, RandomState, Generator, SeedSequence or None
        Source of the :class:`numpy.random.SeedSequence` (see
        :func:`~skmba._validation.seed_sequence`) whose ``spawn(n_chains)``
        children seed the chains. Results do not depend on ``n_jobs``.
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
    >>> result = run_chains(lambda t: -0.5 * float(t @ t), np.zeros((2, 2)),
    ...                     n_samples=500, burn_in=200, random_state=0)
    >>> result.samples.shape, result.proposal_cov.shape
    ((2, 500, 2), (2, 2, 2))
    """
    starts = _check_starts(starts)
    n_chains, r = starts.shape
    densities = _per_chain(log_density, n_chains)
    n_samples = check_count(n_samples, "n_samples")
    burn_in = check_count(burn_in, "burn_in", minimum=0)
    chols = _proposal_chols(proposal_cov, n_chains, r)
    start_values = _start_values(densities, starts)
    seeds = seed_sequence(random_state).spawn(n_chains)
    return _run_parallel(
        zip(densities, starts, start_values, chols, seeds, strict=True),
        n_samples=n_samples,
        burn_in=burn_in,
        adapt=bool(adapt),
        n_jobs=n_jobs,
        verbose=verbose,
    )


def _run_parallel(chains, *, n_samples, burn_in, adapt, n_jobs, verbose):
    """Run each chain's ``(log_density, start, start_value, chol, seed)``.

    The chains are run by :class:`joblib.Parallel` and their outputs stacked
    into a :class:`ChainResult`.
    """
    outputs = Parallel(n_jobs=n_jobs, verbose=verbose)(
        delayed(_run_chain)(
            density,
            start,
            start_value,
            chol,
            n_samples=n_samples,
            burn_in=burn_in,
            adapt=adapt,
            seed=seed,
            chain=c,
            verbose=verbose,
        )
        for c, (density, start, start_value, chol, seed) in enumerate(chains)
    )
    samples, values, acceptance, covs = zip(*outputs, strict=True)
    return ChainResult(
        samples=np.stack(samples),
        log_density=np.stack(values),
        acceptance_rate=np.array(acceptance),
        proposal_cov=np.stack(covs),
    )


def _check_starts(starts):
    """``starts`` as a finite float array of shape (n_chains, r)."""
    starts = np.array(starts, dtype=float)
    if starts.ndim != 2 or starts.shape[0] < 1 or starts.shape[1] < 1:
        raise ValueError(
            "starts must be a 2-D array of shape (n_chains, r) with at least one "
            f"chain and one parameter, got shape {starts.shape}; use "
            "starts.reshape(1, -1) for a single chain"
        )
    if not np.all(np.isfinite(starts)):
        raise ValueError("starts must be finite")
    return starts


def _proposal_chols(proposal_cov, n_chains, r):
    """Lower Cholesky factor of each chain's initial proposal covariance."""
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
    return chols


def _start_values(densities, starts):
    """The log-density at each start, which must not be ``-inf``."""
    start_values = []
    for c in range(len(starts)):
        value = _evaluate(densities[c], starts[c].copy(), c)
        if value == -np.inf:
            raise ValueError(
                f"starts[{c}] has zero density (log_density = -inf); every "
                "row of starts must lie inside the support of the target"
            )
        start_values.append(value)
    return start_values


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
    """Burn-in (:func:`_burn_in`), then draws with the frozen kernel."""
    started = time.perf_counter()
    rng = np.random.default_rng(seed)
    theta, logp, chol, log_scale = _burn_in(
        log_density,
        start.copy(),
        start_value,
        chol,
        rng,
        burn_in=burn_in,
        adapt=adapt,
        chain=chain,
    )
    if verbose >= 2:
        print(
            f"chain {chain}: burn-in of {burn_in} steps done in "
            f"{time.perf_counter() - started:.1f} s, scale factor "
            f"{math.exp(log_scale):.3g}",
            flush=True,
        )
    chol = math.exp(0.5 * log_scale) * chol
    samples, values, n_accept = _fixed_kernel_draws(
        log_density,
        theta,
        logp,
        chol,
        rng,
        n_samples=n_samples,
        chain=chain,
        started=started if verbose >= 2 else None,
    )
    acceptance = n_accept / n_samples
    if verbose >= 2:
        print(
            f"chain {chain}: {n_samples} draws done in "
            f"{time.perf_counter() - started:.1f} s, acceptance {acceptance:.3f}",
            flush=True,
        )
    return samples, values, acceptance, chol @ chol.T


def _burn_in(log_density, theta, logp, chol, rng, *, burn_in, adapt, chain):
    """``burn_in`` steps in blocks of ``_ADAPT_INTERVAL`` with a fixed shape L.

    Returns the last state ``theta`` and its ``logp``, the adapted Cholesky
    factor and the adapted log scale factor.
    """
    r = theta.size
    target = _TARGET_ACCEPTANCE_1D if r == 1 else _TARGET_ACCEPTANCE
    log_scale = 0.0
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
        block, theta, logp, log_scale, n_accept = _burn_in_block(
            log_density,
            theta,
            logp,
            increments,
            log_u,
            log_scale,
            step=step,
            target=target if adapt else None,
            chain=chain,
        )
        step += m
        counts[b] = m
        means[b] = block.mean(axis=0)
        dev = block - means[b]
        m2s[b] = dev.T @ dev
        accepts[b] = n_accept
        if adapt and step >= 2 * _ADAPT_INTERVAL and step < burn_in:
            first = (b + 1) // 2
            window = slice(first, b + 1)
            chol = _adapted_chol(
                chol, counts[window], means[window], m2s[window], accepts[window]
            )
    return theta, logp, chol, log_scale


def _burn_in_block(
    log_density, theta, logp, increments, log_u, log_scale, *, step, target, chain
):
    """One block of burn-in steps from burn-in step ``step`` on.

    ``target`` is the acceptance rate towards which the log scale factor is
    tuned, or None not to adapt it. Returns the block's states, the last
    state and its ``logp``, the log scale factor and the number of accepted
    moves.
    """
    m, r = increments.shape
    block = np.empty((m, r))
    n_accept = 0
    for i in range(m):
        proposal = theta + math.exp(0.5 * log_scale) * increments[i]
        value = _evaluate(log_density, proposal, chain)
        diff = value - logp
        if log_u[i] < diff:
            theta = proposal
            logp = value
            n_accept += 1
        if target is not None:
            alpha = 1.0 if diff >= 0.0 else math.exp(diff)
            log_scale += (step + i + 1) ** -_GAIN_EXPONENT * (alpha - target)
        block[i] = theta
    return block, theta, logp, log_scale, n_accept


def _adapted_chol(chol, counts, means, m2s, accepts):
    """Haario covariance of the window of blocks, or ``chol`` kept as is.

    ``chol`` is kept when the window holds too few accepted moves or its
    covariance is not positive definite.
    """
    r = means.shape[1]
    if accepts.sum() < max(10, 2 * r):
        return chol
    n, _, m2 = _merge_moments(counts, means, m2s)
    cov = _OPTIMAL_SCALE / r * (m2 / (n - 1) + _EPSILON * np.eye(r))
    try:
        return linalg.cholesky(cov, lower=True, check_finite=False)
    except linalg.LinAlgError:
        return chol  # keep the previous shape


def _fixed_kernel_draws(
    log_density, theta, logp, chol, rng, *, n_samples, chain, started
):
    """``n_samples`` steps with the frozen proposal factor ``chol``.

    Random numbers are drawn in blocks of ``_BLOCK`` steps. With ``started``
    (a :func:`time.perf_counter` value) progress is printed every quarter.
    Returns the draws, their log-densities and the number of accepted moves.
    """
    r = theta.size
    quarters = set()
    if started is not None:
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
            if step in quarters:
                print(
                    f"chain {chain}: {step}/{n_samples} draws "
                    f"({time.perf_counter() - started:.1f} s)",
                    flush=True,
                )
    return samples, values, n_accept
