"""Adaptive Metropolis-Hastings chains for any log-density.

This module knows nothing about Gaussian processes: it samples a function
``log_density(theta) -> float`` of a 1-D parameter vector.
:func:`run_chains` runs several chains in parallel (:class:`joblib.Parallel`
over chains); the draws are bit-identical for any ``n_jobs``. The
convergence diagnostics of the draws are in :mod:`skmba.mcmc._diagnostics`.

The chains' kernel (an adaptive random walk with, optionally, independence
moves from a Student-t fitted to the burn-in, after it from a mixture of
Student-ts fitted to all the chains' burn-ins, whose proposals a
``log_density.batch`` method evaluates together) is :mod:`skmba.mcmc._chain`.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._run import run_chains
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
from dataclasses import dataclass

import numpy as np
from joblib import delayed
from scipy import linalg

from skmba._core.progress import Progress, results_as_ready
from skmba._core.threads import blas_threads
from skmba._core.validation import check_count, seed_sequence
from skmba.mcmc._chain import MIN_ADAPTIVE_BURN_IN, Chain
from skmba.mcmc._checks import (
    check_independence,
    check_moments,
    check_points,
    check_starts,
    per_chain,
    proposal_chols,
)
from skmba.mcmc._diagnostics import ess_bulk, split_rhat
from skmba.mcmc._proposals import points_moments, shared_proposal, window_moments
from skmba.mcmc._target import evaluate

# With a progress bar, the chains run in about this many segments, after
# each of which the parent process updates the bar (the draws do not depend
# on the segments).
_PROGRESS_SEGMENTS = 20


@dataclass
class ChainResult:
    """Draws of several Markov chains after burn-in.

    Attributes
    ----------
    samples : ndarray of shape (n_chains, n_samples, r)
        Draws kept after burn-in.
    log_density : ndarray of shape (n_chains, n_samples) or None
        ``log_density`` at each draw (None when not kept).
    acceptance_rate : ndarray of shape (n_chains,)
        Fraction of accepted proposals after burn-in.
    proposal_cov : ndarray of shape (n_chains, r, r)
        Covariance of the Gaussian random-walk proposal used after burn-in
        (including the adapted scale factor).
    independence_rate : ndarray of shape (n_chains,)
        Fraction of accepted independence proposals after burn-in (NaN
        when the chain made none): near one where the independence
        proposal fits the target.
    labels : ndarray of shape (n_chains, n_samples) or None
        For a labelled target (a mixture, :mod:`skmba.mcmc._chain`), the
        component of each draw: a draw of ``p(k | theta)`` at the draw's
        theta. None otherwise.
    blobs : ndarray of shape (n_chains, n_samples, ...) or None
        With ``keep_blobs``, the target's blob at each draw.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._run import run_chains
    >>> result = run_chains(lambda t: -0.5 * float(t @ t), np.zeros((4, 1)),
    ...                     n_samples=1000, burn_in=500, random_state=0)
    >>> result.samples.shape, result.acceptance_rate.shape
    ((4, 1000, 1), (4,))
    >>> bool(result.rhat[0] < 1.05), bool(result.ess[0] > 400)
    (True, True)
    """

    samples: np.ndarray
    log_density: np.ndarray | None
    acceptance_rate: np.ndarray
    proposal_cov: np.ndarray
    independence_rate: np.ndarray | None = None
    labels: np.ndarray | None = None
    blobs: np.ndarray | None = None

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
    keep_log_density=True,
    moments=None,
    stopping=None,
    keep_blobs=False,
    proposal_points=None,
):
    """Run adaptive Metropolis-Hastings chains in parallel.

    The proposals, their adaptation during burn-in and their freezing
    afterwards are those of :mod:`skmba.mcmc._chain`, described in full in
    docs/internals.rst, section skmba.mcmc._chain.

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
        proposals of a block in one call. A callable with ``n_labels`` > 1
        is a labelled target, a mixture sampled with its component
        (:mod:`skmba.mcmc._chain`); it also has ``labelled`` and ``components``
        methods, and ``log_density`` of the result is the mixture's.
    starts : array_like of shape (n_chains, r)
        Starting point of each chain; each must have a finite log-density.
        Dispersed starts make :attr:`ChainResult.rhat` meaningful.
    n_samples : int
        Number of draws kept per chain, after burn-in (with ``stopping``,
        the most).
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
        fitted to the chain's burn-in (:mod:`skmba.mcmc._chain`), instead of
        a random-walk move. Independence moves start halfway through the
        burn-in, once the latest half of the burn-in so far holds
        ``max(10, 2 r)`` accepted moves (without burn-in, never; with
        ``moments``, at the first step). After a burn-in of at least 100
        steps, several chains share one proposal, fitted to the latest
        halves of all their burn-ins (a Student-t, or a mixture of them
        where the points cluster: :func:`~skmba.mcmc._proposals.shared_proposal`),
        so that a chain whose own window missed part of the target does not
        propose short of it. 0.9 makes
        successive draws of a unimodal target nearly independent, at one
        evaluation per step.
    n_jobs : int, default=None
        Number of chains run at the same time by :class:`joblib.Parallel`
        (default backend, so :func:`joblib.parallel_config` applies).
    blas_order : int, default=0
        Order of the largest matrix ``log_density`` factors. It sets the
        BLAS threads of each chain by the package's policy
        (:func:`skmba._core.threads.blas_threads`): one below
        :data:`~skmba._core.threads.SMALL_ORDER`, so that a chain's arithmetic,
        hence its draws, do not depend on the backend, ``n_jobs`` or the
        number of cores; above it, each chain's share of the cores (a
        factorisation's last bits, and so a chain's path, may then differ
        between ``n_jobs`` settings).
    random_state : int, RandomState, Generator, SeedSequence or None
        Source of the :class:`numpy.random.SeedSequence` (see
        :func:`~skmba._core.validation.seed_sequence`) whose ``spawn(n_chains)``
        children seed the chains. Results do not depend on ``n_jobs``.
    verbose : int, default=0
        0 prints nothing; 1 shows a progress bar of the steps of all chains
        (on standard error, see :mod:`skmba._core.progress`); 2 also a line per
        chain at the end of its burn-in (time, adapted scale factor) and of
        its draws (time, acceptance rate). With a bar, the chains run in
        about 20 segments each, and the parent process updates the bar as
        each segment returns (also from joblib workers); the draws are the
        same as in one piece.
    progress : skmba._core.progress.Progress, default=None
        Where to report, instead of ``Progress(verbose)`` (the estimators
        pass theirs, so that lines carry their name).
    keep_log_density : bool, default=True
        Return the log density at the draws; False saves, for a labelled
        target, its evaluation at the distinct draws after sampling
        (:attr:`ChainResult.log_density` is then None).
    moments : tuple of (ndarray of shape (r,), ndarray of shape (r, r)), \
default=None
        The target's mean and covariance known from an earlier run (e.g.
        draws of a nearby target). With ``independence`` > 0, independence
        moves then start at the first step, from the Student-t of these
        moments, instead of halfway through the burn-in; from there on the
        proposal is fitted to the burn-in as usual. A chain started near
        the target then mixes from its first steps, and a shorter burn-in
        serves. The moments need only be roughly right (how roughly:
        docs/internals.rst, section skmba.mcmc._run); chains they leave
        unmixed show in the diagnostics. A covariance that is not positive
        definite is not used (the moves then start halfway, as without).
    stopping : skmba.mcmc._stopping.EssTarget, default=None
        A rule that ends the draws of all chains before ``n_samples``, at the
        first of its checkpoints where the draws so far meet it (all chains
        stop together). The draws are the first draws of the run without
        it. None: ``n_samples`` draws.
    keep_blobs : bool, default=False
        Keep the target's blobs at the draws (after emcee's): extra values
        that the target computes with its log density (e.g. a mixture's
        components), from its methods ``with_blob(theta) -> (value, blob)``
        and ``batch_with_blobs(thetas) -> (values, blobs)``, which the draws
        then call instead of the plain ones (their values must be the same,
        bit for bit). :attr:`ChainResult.blobs` holds them, at the cost of
        one more evaluation per chain (the point where its draws begin).
        Not for a labelled target.
    proposal_points : array_like of shape (m, r), default=None
        Draws of (nearly) the target known from elsewhere, in the chains'
        coordinates (e.g. an earlier run's draws reweighted to it): the
        proposal that the chains share after their burn-in is fitted to
        them together with the burn-ins' windows, so that a short burn-in
        does not leave it short of points. Used where the chains share
        a proposal (several chains, ``independence`` > 0, a burn-in of at
        least 100 steps); the draws still follow the target exactly, since
        the proposal is fixed before the first draw.

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
    starts = check_starts(starts)
    n_chains, r = starts.shape
    densities = per_chain(log_density, n_chains)
    n_samples = check_count(n_samples, "n_samples")
    burn_in = check_count(burn_in, "burn_in", minimum=0)
    chols = proposal_chols(proposal_cov, n_chains, r)
    independence = check_independence(independence)
    _check_blobs(densities, keep_blobs)
    proposal_points = check_points(proposal_points, r)
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
        keep_log_density=bool(keep_log_density),
        moments=check_moments(moments, r),
        stopping=stopping,
        keep_blobs=bool(keep_blobs),
        proposal_points=proposal_points,
    )


def _check_blobs(densities, keep_blobs):
    """A target whose blobs are kept must have the methods that give them."""
    if not keep_blobs:
        return
    for density in densities:
        if int(getattr(density, "n_labels", 1)) > 1:
            raise ValueError(
                "keep_blobs=True is not available for a labelled target: "
                "sample the mixture itself (n_labels=1) to keep its blobs."
            )
        missing = [
            name
            for name in ("with_blob", "batch_with_blobs")
            if not callable(getattr(density, name, None))
        ]
        if missing:
            raise TypeError(
                f"keep_blobs=True needs log_density methods {missing}: give the "
                "target with_blob(theta) -> (value, blob) and "
                "batch_with_blobs(thetas) -> (values, blobs), or keep_blobs=False."
            )


def _run_parallel(
    chains,
    *,
    n_samples,
    burn_in,
    adapt,
    independence,
    n_jobs,
    blas_order,
    progress,
    keep_log_density,
    moments=None,
    stopping=None,
    keep_blobs=False,
    proposal_points=None,
):
    """Run each chain's ``(log_density, start, start_value, chol, seed)``.

    Each chain is a :class:`~skmba.mcmc._chain.Chain` advanced by :func:`_advance` in
    :class:`joblib.Parallel` tasks: in one segment without a progress bar,
    else in about ``_PROGRESS_SEGMENTS`` segments, the bar being updated as
    each returns, at the checkpoints of ``stopping`` and at the end of the
    burn-in, where the chains get one independence proposal fitted to all
    their burn-ins (:func:`_share_proposal`). The draws depend on the
    seeds only, not on the segments nor on where they run. Returns the
    stacked :class:`ChainResult`.
    """
    densities, states = [], []
    for c, (density, start, start_value, chol, seed) in enumerate(chains):
        densities.append(density)
        states.append(
            Chain(
                start,
                start_value,
                chol,
                seed,
                n_samples=n_samples,
                burn_in=burn_in,
                adapt=adapt,
                independence=independence,
                chain=c,
                n_labels=int(getattr(density, "n_labels", 1)),
                keep_log_density=keep_log_density,
                moments=moments,
                keep_blobs=keep_blobs,
            )
        )
    _advance_in_segments(
        densities, states, n_jobs, blas_order, progress, stopping, proposal_points
    )
    return _stacked_result(states, keep_log_density)


def _advance_in_segments(
    densities, states, n_jobs, blas_order, progress, stopping=None, points=None
):
    """Run the chains ``states`` to their end, replacing each by the state
    its last task returned; the bar moves as each segment returns. At each
    checkpoint of ``stopping`` that its rule finds met, the chains stop
    there (:meth:`~skmba.mcmc._chain.Chain.stop`); one that is not met adds
    the checkpoint the rule predicts (:meth:`~skmba.mcmc._stopping.EssTarget.
    judge`) when it comes before the next one."""
    total, burn_in = states[0].total, states[0].burn_in
    segment = -(-total // _PROGRESS_SEGMENTS) if progress.enabled else total
    checks = set() if stopping is None else set(stopping.checkpoints(burn_in, total))
    shared = _shares_proposal(states)
    ends = sorted(
        {*range(segment, total, segment), *checks, *([burn_in] * shared), total}
    )
    done = [0] * len(states)
    # The chains' limit held here too: a thread-based backend runs them in
    # this process (see skmba._core.threads.BlasTask).
    with (
        progress.bar(
            len(states) * total, f"MCMC: {len(states)} chain(s)", unit="step"
        ) as bar,
        blas_threads(blas_order, n_jobs),
    ):
        while ends:
            until = ends.pop(0)
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
            if shared and until == burn_in:
                _share_proposal(states, points)
            if until not in checks:
                continue
            met, predicted = stopping.judge(
                np.stack([state.samples[: state.drawn] for state in states])
            )
            if met:
                _stop(densities, states, n_jobs, blas_order)
                bar.update(len(states) * total - sum(done))
                progress.detail(
                    f"chains stopped after {until - burn_in} draws each: the "
                    f"target ESS {stopping.ess:g} is reached"
                )
                return
            following = min(c for c in (*checks, total) if c > until)
            if predicted is not None and until < burn_in + predicted < following:
                checks.add(burn_in + predicted)
                ends = sorted({*ends, burn_in + predicted})


def _shares_proposal(states):
    """Whether the chains' draws propose from one proposal, fitted to the
    latest half of all their burn-ins (several chains with independence
    moves and a burn-in long enough to adapt)."""
    first = states[0]
    return (
        len(states) > 1
        and first.independence > 0.0
        and first.burn_in >= MIN_ADAPTIVE_BURN_IN
    )


def _share_proposal(states, extra=None):
    """Give every chain the independence proposal fitted to the latest
    halves of their burn-ins together, and to the ``extra`` points
    (``proposal_points``) with them
    (:func:`~skmba.mcmc._proposals.shared_proposal`); each chain keeps its
    own when too few moves were accepted there (see
    :func:`~skmba.mcmc._proposals.window_moments`) or their covariance is
    not positive definite."""
    blocks = [state.window_blocks() for state in states]
    moments = window_moments(
        *(np.concatenate(parts) for parts in zip(*blocks, strict=True))
    )
    if moments is None:
        return
    points = np.concatenate([state.window_path() for state in states])
    if extra is not None:
        points = np.concatenate([points, extra])
        moments = points_moments(points)
    try:
        proposal = shared_proposal(points, *moments)
    except linalg.LinAlgError:
        return
    for state in states:
        state.share_proposal(proposal)


def _stop(densities, states, n_jobs, blas_order):
    """:meth:`~skmba.mcmc._chain.Chain.stop` on every chain: here, or as
    joblib tasks where a labelled chain evaluates its target at its draws."""
    if not any(state.labelled and state.keep_log_density for state in states):
        for state in states:
            state.stop(None)
        return
    tasks = (
        delayed(_stop_task)(density, state, blas_order, n_jobs)
        for density, state in zip(densities, states, strict=True)
    )
    states[:] = list(results_as_ready(tasks, n_jobs))


def _stop_task(log_density, state, blas_order=0, n_jobs=None):
    """``state.stop(log_density)`` under the chains' BLAS threads; returns it."""
    with blas_threads(blas_order, n_jobs):
        state.stop(log_density)
    return state


def _stacked_result(states, keep_log_density):
    """The :class:`ChainResult` of the finished chains ``states``."""
    return ChainResult(
        samples=np.stack([state.samples for state in states]),
        log_density=(
            np.stack([state.values for state in states]) if keep_log_density else None
        ),
        acceptance_rate=np.array(
            [state.n_accept / state.n_samples for state in states]
        ),
        proposal_cov=np.stack([state.chol @ state.chol.T for state in states]),
        independence_rate=np.array([state.independence_rate for state in states]),
        labels=(
            np.stack([state.labels for state in states])
            if all(state.labelled for state in states)
            else None
        ),
        blobs=(
            np.stack([state.blobs for state in states])
            if states[0].keep_blobs
            else None
        ),
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


def _start_values(densities, starts):
    """The log-density at each start, which must not be ``-inf``."""
    start_values = []
    for c in range(len(starts)):
        value = evaluate(densities[c], starts[c].copy(), c)
        if value == -np.inf:
            raise ValueError(
                f"starts[{c}] has zero density (log_density = -inf); every "
                "row of starts must lie inside the support of the target"
            )
        start_values.append(value)
    return start_values


def _advance(log_density, state, until, blas_order=0, n_jobs=None):
    """Run ``state`` (a :class:`~skmba.mcmc._chain.Chain`) on to step ``until``; return
    it.

    BLAS threads by :func:`~skmba._core.threads.blas_threads` for a density
    that factors matrices of order ``blas_order``, as one of the tasks of
    ``Parallel(n_jobs)``.
    """
    with blas_threads(blas_order, n_jobs):
        state.advance(log_density, until)
    return state
