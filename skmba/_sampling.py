"""Adaptive Metropolis-Hastings chains for any log-density.

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

With ``independence=p > 0`` the chains also make independence moves
(Metropolis-Hastings with a proposal ``g`` that does not depend on the
current point; Tierney 1994): at each step, with probability ``p``, the
proposal ``y`` is drawn from ``g``, a Student-t of 5 degrees of freedom
whose location and scale matrix are the mean and 1.5 times the covariance
of the latest half of the chain's burn-in (so far), and accepted with
probability ``min(1, p(y) g(x) / (p(x) g(y)))``; with probability
``1 - p`` the step is the random walk above. Independence moves begin
halfway through the burn-in, after a random walk alone has adapted; ``g``
is then re-estimated every 50 steps and frozen at the end of burn-in.
Where ``g`` is close to the target, most independence proposals are
accepted and successive draws are nearly independent. Effective draws per
step (4 chains of 5000 draws after 2000 burn-in, 0.9 independence moves
against the random walk alone): 0.54 against 0.11 on a 2-D Gaussian of
correlation 0.98, 0.36 against 0.10 on a 2-D Student-t of 3 degrees of
freedom, and 0.06-0.08 against 0.03-0.04 on a banana that ``g`` fits
poorly. The random-walk steps keep the chain moving
locally where ``g`` is poor (its tails, a curved ridge). The independence
proposals do not depend on the chain's position, so those of a block of
steps are drawn first and their densities computed together: a
``log_density`` with a ``batch`` method (``batch(thetas) -> values`` for
``thetas`` of shape (m, r)) evaluates them as one vectorised call.

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
from joblib import delayed
from scipy import linalg

from skmba._diagnostics import ess_bulk, split_rhat
from skmba._progress import Progress, results_as_ready
from skmba._threads import blas_threads
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
# Number of steps per block of pre-drawn random numbers (and of independence
# proposals evaluated together) after burn-in.
_BLOCK = 1024
# With a progress bar, the chains run in about this many segments, after
# each of which the parent process updates the bar (the draws do not depend
# on the segments).
_PROGRESS_SEGMENTS = 20
# The independence proposal is a Student-t with _T_DF degrees of freedom and
# _T_VARIANCE_FACTOR times the covariance of (part of) the burn-in as its
# scale matrix. In a prototype with the proposal fitted to long runs (4
# chains of 5000 draws, 9 in 10 steps independence moves), effective draws
# per step were 0.70 with factor 1.0 and 0.57 with 1.5 on a 2-D Gaussian,
# 0.04 and 0.11 on a banana, 0.52 and 0.39 on a t3: 1.5 gives up a little
# where the proposal fits for much more where it does not. Heavy tails keep
# a proposal narrower than the target from trapping the chains in the
# target's tails.
_T_VARIANCE_FACTOR = 1.5
_T_DF = 5.0
# Independence moves begin this far into the burn-in: the first part is a
# random walk whose scale and shape adapt at full speed (its Robbins-Monro
# recursion runs on random-walk steps only). A Student-t fitted to a window
# in which a badly scaled start has not yet moved along some direction
# would be as narrow as the window there, and its draws would keep it so
# (a start 1e5 times off in scale stayed so for 2000 steps).
_INDEPENDENCE_START = 0.5


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
    independence_rate : ndarray of shape (n_chains,)
        Fraction of accepted independence proposals after burn-in (NaN
        when the chain made none): near one where the independence
        proposal fits the target.

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
    independence_rate: np.ndarray | None = None

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
    independence=0.0,
    n_jobs=None,
    blas_order=0,
    random_state=None,
    verbose=0,
    progress=None,
):
    """Run adaptive Metropolis-Hastings chains in parallel.

    The proposals, their adaptation during burn-in and their freezing
    afterwards are described in the module docstring
    (:mod:`skmba._sampling`).

    Parameters
    ----------
    log_density : callable or sequence of n_chains callables
        ``log_density(theta) -> float`` for ``theta`` an ndarray of shape
        (r,), which it must not modify, up to an additive constant. ``-inf``
        means zero density: the proposal is rejected. It must be picklable
        (``cloudpickle``) when ``n_jobs`` runs chains in other processes.
        A sequence gives each chain its own callable (all computing the same
        density), e.g. objects with their own caches, which then stay
        private to a chain under a thread-based joblib backend. A callable
        with a ``batch`` method (``batch(thetas) -> values``, ``thetas`` of
        shape (m, r), ``values`` of shape (m,)) gets the independence
        proposals of a block in one call.
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
    independence : float in [0, 1), default=0.0
        Probability that a step is an independence move, from a Student-t
        fitted to the chain's burn-in (module docstring), instead of a
        random-walk move. Independence moves start halfway through the
        burn-in, once the latest half of the burn-in so far holds
        ``max(10, 2 r)`` accepted moves (without burn-in, never). 0.9
        makes successive draws of a unimodal target nearly independent, at
        one evaluation per step.
    n_jobs : int, default=None
        Number of chains run at the same time by :class:`joblib.Parallel`
        (default backend, so :func:`joblib.parallel_config` applies).
    blas_order : int, default=0
        Order of the largest matrix ``log_density`` factors. It sets the
        BLAS threads of each chain by the package's policy
        (:func:`skmba._threads.blas_threads`): one below
        :data:`~skmba._threads.SMALL_ORDER`, so that a chain's arithmetic,
        hence its draws, do not depend on the backend, ``n_jobs`` or the
        number of cores; above it, each chain's share of the cores (a
        factorisation's last bits, and so a chain's path, may then differ
        between ``n_jobs`` settings).
    random_state : int, RandomState, Generator, SeedSequence or None
        Source of the :class:`numpy.random.SeedSequence` (see
        :func:`~skmba._validation.seed_sequence`) whose ``spawn(n_chains)``
        children seed the chains. Results do not depend on ``n_jobs``.
    verbose : int, default=0
        0 prints nothing; 1 shows a progress bar of the steps of all chains
        (on standard error, see :mod:`skmba._progress`); 2 also a line per
        chain at the end of its burn-in (time, adapted scale factor) and of
        its draws (time, acceptance rate). With a bar, the chains run in
        about 20 segments each, and the parent process updates the bar as
        each segment returns (also from joblib workers); the draws are the
        same as in one piece.
    progress : skmba._progress.Progress, default=None
        Where to report, instead of ``Progress(verbose)`` (the estimators
        pass theirs, so that lines carry their name).

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

    Independence moves make nearly independent draws of a target that a
    Student-t fits; the draws follow the same target:

    >>> fast = run_chains(lambda t: -0.5 * float(t @ t), np.zeros((2, 2)),
    ...                   n_samples=500, burn_in=200, random_state=0,
    ...                   independence=0.9)
    >>> bool(np.all(fast.ess > 1.5 * result.ess))
    True
    """
    starts = _check_starts(starts)
    n_chains, r = starts.shape
    densities = _per_chain(log_density, n_chains)
    n_samples = check_count(n_samples, "n_samples")
    burn_in = check_count(burn_in, "burn_in", minimum=0)
    chols = _proposal_chols(proposal_cov, n_chains, r)
    independence = _check_independence(independence)
    start_values = _start_values(densities, starts)
    seeds = seed_sequence(random_state).spawn(n_chains)
    return _run_parallel(
        zip(densities, starts, start_values, chols, seeds, strict=True),
        n_samples=n_samples,
        burn_in=burn_in,
        adapt=bool(adapt),
        independence=independence,
        n_jobs=n_jobs,
        blas_order=int(blas_order),
        progress=Progress(verbose) if progress is None else progress,
    )


def _run_parallel(
    chains, *, n_samples, burn_in, adapt, independence, n_jobs, blas_order, progress
):
    """Run each chain's ``(log_density, start, start_value, chol, seed)``.

    Each chain is a :class:`_Chain` advanced by :func:`_advance` in
    :class:`joblib.Parallel` tasks: in one segment without a progress bar,
    else in about ``_PROGRESS_SEGMENTS`` segments, the bar being updated as
    each returns. A chain's draws depend on its seed only, not on the
    segments nor on where they run. Returns the stacked
    :class:`ChainResult`.
    """
    densities, states = [], []
    for c, (density, start, start_value, chol, seed) in enumerate(chains):
        densities.append(density)
        states.append(
            _Chain(
                start,
                start_value,
                chol,
                seed,
                n_samples=n_samples,
                burn_in=burn_in,
                adapt=adapt,
                independence=independence,
                chain=c,
            )
        )
    total = burn_in + n_samples
    segment = -(-total // _PROGRESS_SEGMENTS) if progress.enabled else total
    done = [0] * len(states)
    # The chains' limit held here too: a thread-based backend runs them in
    # this process (see skmba._threads.BlasTask).
    with (
        progress.bar(
            len(states) * total, f"MCMC: {len(states)} chain(s)", unit="step"
        ) as bar,
        blas_threads(blas_order, n_jobs),
    ):
        until = 0
        while until < total:
            until = min(total, until + segment)
            active = [c for c in range(len(states)) if done[c] < until]
            tasks = (
                delayed(_advance)(densities[c], states[c], until, blas_order, n_jobs)
                for c in active
            )
            for c, state in zip(active, results_as_ready(tasks, n_jobs), strict=True):
                states[c] = state
                bar.update(state.steps - done[c])
                _report_chain(progress, state, done[c])
                done[c] = state.steps
    return ChainResult(
        samples=np.stack([state.samples for state in states]),
        log_density=np.stack([state.values for state in states]),
        acceptance_rate=np.array([state.n_accept / n_samples for state in states]),
        proposal_cov=np.stack([state.chol @ state.chol.T for state in states]),
        independence_rate=np.array([state.independence_rate for state in states]),
    )


def _report_chain(progress, state, before):
    """Detail lines when a segment ended a chain's burn-in or its draws."""
    if state.burn_in and before < state.burn_in <= state.steps:
        progress.detail(
            f"chain {state.chain}: burn-in of {state.burn_in} steps done in "
            f"{state.seconds_burn_in:.1f} s, scale factor "
            f"{math.exp(state.log_scale):.3g}"
        )
    if before < state.total == state.steps:
        progress.detail(
            f"chain {state.chain}: {state.n_samples} draws done in "
            f"{state.seconds:.1f} s, acceptance "
            f"{state.n_accept / state.n_samples:.3f} (independence moves "
            f"{state.independence_rate:.3f})"
        )


def _check_independence(independence):
    """``independence`` as a float in [0, 1)."""
    if isinstance(independence, bool | np.bool_) or not isinstance(
        independence, int | float | np.integer | np.floating
    ):
        raise TypeError(
            f"independence must be a number in [0, 1), got {independence!r}"
        )
    if not 0.0 <= independence < 1.0:
        raise ValueError(
            f"independence must be in [0, 1), got {independence!r}: it is the "
            "probability of an independence move; some random-walk moves "
            "must remain (0 for the random walk alone)"
        )
    return float(independence)


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


def _advance(log_density, state, until, blas_order=0, n_jobs=None):
    """Run ``state`` (a :class:`_Chain`) on to step ``until``; return it.

    BLAS threads by :func:`~skmba._threads.blas_threads` for a density
    that factors matrices of order ``blas_order``, as one of the tasks of
    ``Parallel(n_jobs)``.
    """
    with blas_threads(blas_order, n_jobs):
        state.advance(log_density, until)
    return state


class _TProposal:
    """The Student-t of the independence moves, of location ``mean``, scale
    matrix ``chol chol'`` and ``_T_DF`` degrees of freedom."""

    def __init__(self, mean, chol):
        self.mean, self.chol = mean, chol

    @classmethod
    def of(cls, mean, cov):
        """The proposal for a target of mean ``mean`` and covariance
        ``cov``: scale matrix ``_T_VARIANCE_FACTOR cov``."""
        chol = linalg.cholesky(_T_VARIANCE_FACTOR * cov, lower=True, check_finite=False)
        return cls(mean, chol)

    def logpdf(self, thetas):
        """Log density up to a constant at ``thetas`` (m, r): (m,)."""
        z = linalg.solve_triangular(
            self.chol, (thetas - self.mean).T, lower=True, check_finite=False
        )
        return -0.5 * (_T_DF + z.shape[0]) * np.log1p(np.sum(z**2, axis=0) / _T_DF)

    def draw(self, rng, m):
        """``m`` draws (m, r)."""
        z = rng.standard_normal((m, self.mean.size))
        w = rng.chisquare(_T_DF, m) / _T_DF
        return self.mean + (z @ self.chol.T) / np.sqrt(w)[:, None]


@dataclass
class _Block:
    """The random numbers of a block of steps, drawn before its first step.

    ``increments`` are the random-walk increments (before the scale factor
    of burn-in), ``log_u`` the log uniforms of the acceptance tests.
    ``independent`` marks the steps that are independence moves; their
    proposals, the target's and the proposal's log densities there are in
    ``proposals``, ``values`` and ``g_values`` (rows of the other steps
    unused). ``next`` is the first step not yet made.
    """

    increments: np.ndarray
    log_u: np.ndarray
    independent: np.ndarray
    proposals: np.ndarray
    values: np.ndarray
    g_values: np.ndarray
    next: int = 0


def _evaluate_batch(log_density, thetas, chain):
    """``log_density`` at each row of ``thetas``, in one call to its
    ``batch`` method when it has one."""
    batch = getattr(log_density, "batch", None)
    if batch is None:
        return np.array([_evaluate(log_density, t.copy(), chain) for t in thetas])
    try:
        values = np.asarray(batch(thetas), dtype=float)
    except Exception as exc:
        raise RuntimeError(
            f"log_density.batch raised {type(exc).__name__} in chain {chain} at "
            f"{len(thetas)} points: {exc}"
        ) from exc
    if values.shape != (len(thetas),) or np.any(np.isnan(values) | (values == np.inf)):
        raise RuntimeError(
            f"log_density.batch returned {values!r} in chain {chain}; it must "
            f"return {len(thetas)} finite floats or -inf (zero density)"
        )
    return values


class _Chain:
    """One chain between segments of its run: position, adaptation, draws.

    :meth:`advance` runs the adaptive burn-in in blocks of
    ``_ADAPT_INTERVAL`` steps, then ``n_samples`` draws with the frozen
    kernel in blocks of ``_BLOCK`` steps (a block that a segment leaves
    unfinished is kept in ``pending``). The random numbers and the
    independence proposals of a block, with their densities, are computed
    before its first step. The generator and all the state travel with
    the object, so that a chain run in several segments, in any processes,
    gives the draws of one run.
    """

    def __init__(
        self,
        start,
        start_value,
        chol,
        seed,
        *,
        n_samples,
        burn_in,
        adapt,
        chain,
        independence=0.0,
    ):
        r = start.size
        self.chain = chain
        self.n_samples, self.burn_in, self.adapt = n_samples, burn_in, adapt
        self.independence = independence
        self.rng = np.random.default_rng(seed)
        self.theta, self.logp, self.chol = start.copy(), start_value, chol
        self.proposal = None  # the independence proposal (_TProposal)
        self.glogp = None  # its log density at theta (None: not computed)
        self.log_scale = 0.0
        self.rw_steps = 0  # random-walk steps of the burn-in (Robbins-Monro)
        n_blocks = -(-burn_in // _ADAPT_INTERVAL)
        self.counts = np.zeros(n_blocks)
        self.means = np.zeros((n_blocks, r))
        self.m2s = np.zeros((n_blocks, r, r))
        self.accepts = np.zeros(n_blocks, dtype=int)
        self.burned = 0  # burn-in steps done
        self.frozen = False  # the kernel is fixed (burn-in over)
        self.samples = np.empty((n_samples, r))
        self.values = np.empty(n_samples)
        self.n_accept = 0
        self.n_independent = self.n_independent_accept = 0  # after burn-in
        self.drawn = 0  # draws kept
        self.pending = None  # the _Block of the draws under way
        self.seconds = self.seconds_burn_in = 0.0

    @property
    def total(self):
        """Steps of the whole run: burn-in and draws."""
        return self.burn_in + self.n_samples

    @property
    def steps(self):
        """Steps done so far."""
        return self.burned + self.drawn

    @property
    def independence_rate(self):
        """Acceptance rate of the independence moves after burn-in."""
        if self.n_independent == 0:
            return math.nan
        return self.n_independent_accept / self.n_independent

    def advance(self, log_density, until):
        """Steps up to ``until`` (burn-in blocks are not split)."""
        started = time.perf_counter()
        while self.burned < self.burn_in and self.steps < until:
            self._burn_in_block(log_density)
        if self.burned == self.burn_in and not self.frozen:
            self.chol = math.exp(0.5 * self.log_scale) * self.chol
            self.frozen = True
            self.seconds_burn_in = self.seconds + time.perf_counter() - started
        if self.frozen and self.steps < until:
            self._draws(log_density, until - self.steps)
        self.seconds += time.perf_counter() - started

    def _block(self, log_density, m, chol):
        """The :class:`_Block` of the next ``m`` steps.

        The generator's draws for the random walk alone (no independence
        proposal yet, or ``independence=0``) are those of a plain
        random-walk chain.
        """
        r = self.theta.size
        increments = self.rng.standard_normal((m, r)) @ chol.T
        log_u = np.log(self.rng.random(m))
        independent = np.zeros(m, dtype=bool)
        proposals = np.empty((m, r))
        values = g_values = np.empty(m)
        if self.proposal is not None and self.independence > 0.0:
            independent = self.rng.random(m) < self.independence
            k = int(independent.sum())
            proposals[independent] = self.proposal.draw(self.rng, k)
            values, g_values = np.empty(m), np.empty(m)
            if k:
                values[independent] = _evaluate_batch(
                    log_density, proposals[independent], self.chain
                )
                g_values[independent] = self.proposal.logpdf(proposals[independent])
        return _Block(increments, log_u, independent, proposals, values, g_values)

    def _step(self, log_density, block, i, scale=1.0):
        """Step ``i`` of ``block`` from ``self.theta``.

        Returns whether the move was accepted and, for a random-walk move,
        its acceptance probability (the Robbins-Monro recursion's estimate;
        None for an independence move).
        """
        theta, logp = self.theta, self.logp
        if block.independent[i]:
            if self.glogp is None:
                self.glogp = float(self.proposal.logpdf(theta[None, :])[0])
            value, g_value = block.values[i], block.g_values[i]
            if block.log_u[i] < (value - logp) - (g_value - self.glogp):
                self.theta, self.logp = block.proposals[i].copy(), value
                self.glogp = g_value
                return True, None
            return False, None
        proposal = theta + scale * block.increments[i]
        value = _evaluate(log_density, proposal, self.chain)
        diff = value - logp
        alpha = 1.0 if diff >= 0.0 else math.exp(diff)
        if block.log_u[i] < diff:
            self.theta, self.logp, self.glogp = proposal, value, None
            return True, alpha
        return False, alpha

    def _burn_in_block(self, log_density):
        """One block of burn-in, then the adaptation of the proposals.

        The random-walk covariance and the independence proposal are
        adapted every ``_ADAPT_INTERVAL`` steps from step
        ``2 * _ADAPT_INTERVAL`` on, from the latest half of the blocks
        (:func:`_window_moments`).
        """
        r = self.theta.size
        target = _TARGET_ACCEPTANCE_1D if r == 1 else _TARGET_ACCEPTANCE
        b, step = self.burned // _ADAPT_INTERVAL, self.burned
        m = min(_ADAPT_INTERVAL, self.burn_in - step)
        block = self._block(log_density, m, self.chol)
        path = np.empty((m, r))
        n_accept = 0
        for i in range(m):
            accepted, alpha = self._step(
                log_density, block, i, math.exp(0.5 * self.log_scale)
            )
            n_accept += accepted
            if self.adapt and alpha is not None:
                self.rw_steps += 1
                self.log_scale += self.rw_steps**-_GAIN_EXPONENT * (alpha - target)
            path[i] = self.theta
        step += m
        self.burned = step
        self.counts[b] = m
        self.means[b] = path.mean(axis=0)
        dev = path - self.means[b]
        self.m2s[b] = dev.T @ dev
        self.accepts[b] = n_accept
        if step < 2 * _ADAPT_INTERVAL:
            return
        window = slice((b + 1) // 2, b + 1)
        moments = _window_moments(
            self.counts[window],
            self.means[window],
            self.m2s[window],
            self.accepts[window],
        )
        if moments is None:
            return
        if self.adapt and step < self.burn_in:
            self._adapt(*moments)
        if self.independence > 0.0 and step >= _INDEPENDENCE_START * self.burn_in:
            self._set_proposal(*moments)

    def _adapt(self, mean, cov):
        """The random-walk proposal from a window's moments; kept as it is
        when ``cov`` is not positive definite."""
        r = mean.size
        try:
            self.chol = linalg.cholesky(
                _OPTIMAL_SCALE / r * cov, lower=True, check_finite=False
            )
        except linalg.LinAlgError:
            return  # keep the previous shape

    def _set_proposal(self, mean, cov):
        """The independence proposal from a window's moments; kept as it is
        when ``cov`` is not positive definite."""
        try:
            self.proposal = _TProposal.of(mean, cov)
        except linalg.LinAlgError:
            return
        self.glogp = None

    def _draws(self, log_density, n_steps):
        """``n_steps`` more draws with the frozen kernel.

        Blocks of ``_BLOCK`` steps (of the draws still to make) are drawn
        as if the chain ran in one piece.
        """
        samples, values = self.samples, self.values
        step, end = self.drawn, min(self.n_samples, self.drawn + n_steps)
        while step < end:
            if self.pending is None:
                m = min(_BLOCK, self.n_samples - step)
                self.pending = self._block(log_density, m, self.chol)
            block = self.pending
            stop = min(len(block.log_u), block.next + end - step)
            for i in range(block.next, stop):
                accepted, _ = self._step(log_density, block, i)
                self.n_accept += accepted
                if block.independent[i]:
                    self.n_independent += 1
                    self.n_independent_accept += accepted
                samples[step] = self.theta
                values[step] = self.logp
                step += 1
            block.next = stop
            if stop == len(block.log_u):
                self.pending = None
        self.drawn = step


def _window_moments(counts, means, m2s, accepts):
    """Mean and covariance (``+ epsilon I``) of a window of burn-in blocks.

    None when the window holds too few accepted moves (``max(10, 2 r)``).
    """
    r = means.shape[1]
    if accepts.sum() < max(10, 2 * r):
        return None
    n, mean, m2 = _merge_moments(counts, means, m2s)
    return mean, (m2 / (n - 1) + _EPSILON * np.eye(r))
