"""One adaptive Metropolis-Hastings chain: its kernel and its state.

:func:`skmba.mcmc._run.run_chains` runs several :class:`Chain` objects in
parallel; this module holds what one chain does, step by step:

* a random walk ``theta + sqrt(lambda) L z`` (``L L' = C``), whose scale
  ``lambda`` (a Robbins-Monro recursion) and covariance ``C`` (Haario,
  Saksman & Tamminen 2001) adapt during burn-in and are frozen after it;
* with ``independence=p > 0``, independence moves (Tierney 1994) from the
  Student-t of :mod:`skmba.mcmc._proposals`, fitted to the latest half of
  the burn-in (after it, when several chains run, a mixture fitted to the
  latest halves of all their burn-ins: :meth:`Chain.share_proposal`), whose
  proposals a block evaluates together;
* for a labelled target (a finite mixture, ``n_labels`` > 1), the sampling
  of ``(theta, k)`` with Gibbs updates of the label (Tanner & Wong 1987),
  and the fallback to the mixture when the joint chain mixes poorly.

The target is evaluated through :mod:`skmba.mcmc._target`. The algorithm in
full, and the measurements and rejected variants behind its constants:
docs/internals.rst, section skmba.mcmc._chain.

Examples
--------
One chain on a standard normal, advanced in two segments (as
:func:`skmba.mcmc._run.run_chains` does with a progress bar): the draws
are those of one run.

>>> import numpy as np
>>> from skmba.mcmc._chain import Chain
>>> def log_density(theta):
...     return -0.5 * float(theta @ theta)
>>> def run(segments):
...     chain = Chain(np.zeros(2), 0.0, np.eye(2), 0, n_samples=400,
...                   burn_in=200, adapt=True, chain=0, independence=0.9)
...     for until in segments:
...         chain.advance(log_density, until)
...     return chain
>>> one, two = run([600]), run([250, 600])
>>> bool(np.array_equal(one.samples, two.samples))
True
>>> bool(0.5 < one.independence_rate <= 1.0)
True
"""

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skmba.mcmc._proposals import (
    TProposal,
    draw_label,
    label_proposal,
    window_moments,
)
from skmba.mcmc._stopping import CHECK_EVERY, STOP_GRID
from skmba.mcmc._target import (
    evaluate,
    evaluate_batch,
    evaluate_batch_with_blobs,
    evaluate_labelled,
    evaluate_with_blob,
)

# Optimal scaling of a random-walk proposal for a Gaussian target in r
# dimensions (Gelman, Roberts & Gilks 1996): proposal covariance
# 2.38^2 / r times the target covariance.
OPTIMAL_SCALE = 2.38**2
# Optimal acceptance rates of random-walk Metropolis: 0.44 in one dimension,
# 0.234 asymptotically in many (Roberts, Gelman & Gilks 1997).
_TARGET_ACCEPTANCE_1D = 0.44
_TARGET_ACCEPTANCE = 0.234
# The proposal covariance is re-estimated every this many burn-in steps.
ADAPT_INTERVAL = 50
#: The first burn-in step at which the proposals adapt to the chain's draws
#: (the window of the latest half then holds a whole block): a shorter
#: burn-in adapts nothing, and its chains share no proposal.
MIN_ADAPTIVE_BURN_IN = 2 * ADAPT_INTERVAL
# Robbins-Monro gain on the log scale factor at burn-in step t: (t + 1)^-0.5.
_GAIN_EXPONENT = 0.5
# Steps per block of pre-drawn random numbers after burn-in (the ESS target's
# checkpoint spacing); its proposals are evaluated in groups of STOP_GRID
# steps as the chain reaches them, so a stop on that grid leaves none unused
# (blocks of 1024 evaluated at once left a quarter of 4.7.3's unused).
_BLOCK = CHECK_EVERY
# Independence moves begin this far into the burn-in: the first part is a
# random walk whose scale and shape adapt at full speed (its Robbins-Monro
# recursion runs on random-walk steps only). A Student-t fitted to a window
# in which a badly scaled start has not yet moved along some direction
# would be as narrow as the window there, and its draws would keep it so.
_INDEPENDENCE_START = 0.5
# A labelled chain whose independence moves of the burn-in were accepted
# less often than _JOINT_MIN_ACCEPTANCE (after at least _JOINT_MIN_MOVES of
# them) falls back to the mixture itself at _JOINT_CHECK of the burn-in.
# The acceptance rates behind the threshold: docs/internals.rst, section
# skmba.mcmc._chain.
_JOINT_MIN_ACCEPTANCE = 0.3
_JOINT_MIN_MOVES = 20
_JOINT_CHECK = 0.75


@dataclass
class _Block:
    """The random numbers of a block of steps, drawn before its first step.

    ``increments`` are the random-walk increments (before the scale factor
    of burn-in), ``log_u`` the log uniforms of the acceptance tests.
    ``independent`` marks the steps that are independence moves; their
    proposals, the target's and the proposal's log densities there are in
    ``proposals``, ``values`` and ``g_values`` (rows of the other steps
    unused), with the proposed ``labels`` of a labelled target and, for a
    chain that keeps its target's blobs, their ``blobs`` (None otherwise);
    ``label_u`` are the uniforms of a labelled target's label proposals and
    Gibbs updates (None otherwise). ``next`` is the first step not yet made,
    ``evaluated`` the first whose proposal's densities are not yet computed
    (:meth:`Chain._evaluate`).
    """

    increments: np.ndarray
    log_u: np.ndarray
    independent: np.ndarray
    proposals: np.ndarray
    values: np.ndarray
    g_values: np.ndarray
    labels: np.ndarray
    label_u: np.ndarray | None
    blobs: np.ndarray | None = None
    next: int = 0
    evaluated: int = 0


class Chain:
    """One chain between segments of its run: position, adaptation, draws.

    :meth:`advance` runs the adaptive burn-in in blocks of
    ``ADAPT_INTERVAL`` steps, then ``n_samples`` draws with the frozen
    kernel in blocks of ``_BLOCK`` steps (a block that a segment leaves
    unfinished is kept in ``pending``). The random numbers and the
    independence proposals of a block are drawn before its first step, and
    the proposals' densities computed in groups of ``STOP_GRID`` steps
    (:meth:`_evaluate`). The generator and all the state travel with
    the object, so that a chain run in several segments, in any processes,
    gives the draws of one run. With ``keep_blobs`` the draws' evaluations
    go through the target's ``with_blob`` and ``batch_with_blobs``, and
    ``blobs`` keeps the blob of each draw (the same values and path).
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
        n_labels=1,
        keep_log_density=True,
        moments=None,
        keep_blobs=False,
    ):
        r = start.size
        self.chain = chain
        self.n_samples, self.burn_in, self.adapt = n_samples, burn_in, adapt
        self.independence = independence
        self.rng = np.random.default_rng(seed)
        self.theta, self.logp, self.chol = start.copy(), start_value, chol
        self.proposal = None  # the independence proposal (TProposal, TMixture)
        self.glogp = None  # its log density at theta (None: not computed)
        self.log_scale = 0.0
        self.rw_steps = 0  # random-walk steps of the burn-in (Robbins-Monro)
        n_blocks = -(-burn_in // ADAPT_INTERVAL)
        self.counts = np.zeros(n_blocks)
        self.means = np.zeros((n_blocks, r))
        self.m2s = np.zeros((n_blocks, r, r))
        self.accepts = np.zeros(n_blocks, dtype=int)
        self.path = np.empty((burn_in, r))  # the burn-in's points
        self.burned = 0  # burn-in steps done
        self.frozen = False  # the kernel is fixed (burn-in over)
        self.samples = np.empty((n_samples, r))
        self.values = np.empty(n_samples)
        self.n_accept = 0
        self.n_independent = self.n_independent_accept = 0  # after burn-in
        self.drawn = 0  # draws kept
        self.pending = None  # the _Block of the draws under way
        self.seconds = self.seconds_burn_in = 0.0
        # A labelled target: the label of the current point (None: not yet
        # drawn), the label proposal, p(k | theta) at the latest Gibbs update
        # and at the one of each burn-in block, and the labels of the draws.
        self.n_labels = n_labels
        self.keep_log_density = keep_log_density
        self.label = None
        self.label_probs = None
        self.conditional = None
        self.label_conditionals = np.zeros((n_blocks, n_labels))
        self.joint = True  # False: fell back to the mixture (_check_joint)
        self.burn_independent = np.zeros(2, dtype=int)  # moves, accepted
        self.labels = np.zeros(n_samples, dtype=int)
        # The target's blobs at the draws (keep_blobs): that of the current
        # point once the draws began (None: not known), and of each draw
        # (made at the first draw, when their shape is known).
        self.keep_blobs = keep_blobs
        self.blob = None
        self.blobs = None
        if moments is not None and independence > 0.0:
            # Independence moves from the first step, from the target's
            # moments known from an earlier run (until the burn-in's own).
            self._set_proposal(*moments)
            if self.labelled and self.proposal is not None:
                self._set_label_proposal(np.full(n_labels, 1.0 / n_labels))

    @property
    def labelled(self):
        """The target is a mixture sampled with its labels (until the chain
        falls back to the mixture itself, see :meth:`_check_joint`)."""
        return self.n_labels > 1 and self.joint

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
        if self.labelled and self.label is None:
            self._gibbs_label(log_density, self.rng.random())
        while self.burned < self.burn_in and self.steps < until:
            self._burn_in_block(log_density)
        if self.burned == self.burn_in and not self.frozen:
            self.chol = math.exp(0.5 * self.log_scale) * self.chol
            self.frozen = True
            self.seconds_burn_in = self.seconds + time.perf_counter() - started
        if self.frozen and self.steps < until:
            self._draws(log_density, until - self.steps)
        self.seconds += time.perf_counter() - started

    def stop(self, log_density):
        """End the draws where they are (a run stopped by a rule, e.g.
        :class:`~skmba.mcmc._stopping.EssTarget`): the kept arrays are cut
        to the draws made, which are the first draws of the longer run."""
        m = self.drawn
        if m == self.n_samples:
            return
        self.n_samples = m
        self.samples, self.values = self.samples[:m], self.values[:m]
        self.labels = self.labels[:m]
        if self.blobs is not None:
            self.blobs = self.blobs[:m]
        self.pending = None
        if self.labelled and self.keep_log_density:
            self._marginal_values(log_density)

    def _block(self, m, chol):
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
        labels = np.zeros(m, dtype=int)
        label_u = self.rng.random(m) if self.labelled else None
        if self.proposal is not None and self.independence > 0.0:
            independent = self.rng.random(m) < self.independence
            k = int(independent.sum())
            proposals[independent] = self.proposal.draw(self.rng, k)
            values, g_values = np.empty(m), np.empty(m)
            if k and self.labelled:
                picked = np.searchsorted(
                    np.cumsum(self.label_probs), label_u[independent], side="right"
                )
                labels[independent] = np.minimum(picked, self.n_labels - 1)
        return _Block(
            increments, log_u, independent, proposals, values, g_values, labels, label_u
        )

    def _evaluate(self, log_density, block, until):
        """The target's and the proposal's log densities at the independence
        proposals of ``block``'s steps before ``until``, in groups of
        ``STOP_GRID`` steps (a group is evaluated whole, together, the first
        time a step of it is reached): the same groups whatever the
        segments, and none past a stop on the grid."""
        while block.evaluated < until:
            start = block.evaluated
            block.evaluated = min(len(block.log_u), start + STOP_GRID)
            steps = start + np.flatnonzero(block.independent[start : block.evaluated])
            if len(steps):
                self._evaluate_steps(log_density, block, steps)

    def _evaluate_steps(self, log_density, block, steps):
        """:meth:`_evaluate` for the independence moves ``steps`` of ``block``."""
        points = block.proposals[steps]
        g_values = self.proposal.logpdf(points)
        if self.labelled:
            drawn = block.labels[steps]
            block.values[steps] = evaluate_labelled(
                log_density, points, drawn, self.chain
            )
            g_values = g_values + np.log(self.label_probs[drawn])
        elif self.keep_blobs and self.frozen:
            block.values[steps], drawn = evaluate_batch_with_blobs(
                log_density, points, self.chain
            )
            if block.blobs is None:
                block.blobs = np.empty((len(block.log_u), *drawn.shape[1:]))
            block.blobs[steps] = drawn
        else:
            block.values[steps] = evaluate_batch(log_density, points, self.chain)
        block.g_values[steps] = g_values

    def _step(self, log_density, block, i, scale=1.0):
        """Step ``i`` of ``block`` from ``self.theta``.

        Returns whether the move was accepted and, for a random-walk move,
        its acceptance probability (the Robbins-Monro recursion's estimate;
        None for an independence move).
        """
        theta, logp = self.theta, self.logp
        if block.independent[i]:
            if self.glogp is None:
                self.glogp = self._proposal_logpdf(theta)
            value, g_value = block.values[i], block.g_values[i]
            if block.log_u[i] < (value - logp) - (g_value - self.glogp):
                self.theta, self.logp = block.proposals[i].copy(), value
                self.glogp = g_value
                self.blob = None if block.blobs is None else block.blobs[i]
                if self.labelled:
                    self.label = int(block.labels[i])
                return True, None
            return False, None
        proposal = theta + scale * block.increments[i]
        blob = None
        if self.labelled:
            value = evaluate_labelled(
                log_density, proposal[None, :], np.array([self.label]), self.chain
            )[0]
        elif self.keep_blobs and self.frozen:
            value, blob = evaluate_with_blob(log_density, proposal, self.chain)
        else:
            value = evaluate(log_density, proposal, self.chain)
        diff = value - logp
        alpha = 1.0 if diff >= 0.0 else math.exp(diff)
        if block.log_u[i] < diff:
            self.theta, self.logp, self.glogp = proposal, value, None
            self.blob = blob
            return True, alpha
        return False, alpha

    def _burn_in_block(self, log_density):
        """One block of burn-in, then the adaptation of the proposals.

        The random-walk covariance and the independence proposal are
        adapted every ``ADAPT_INTERVAL`` steps from step
        ``MIN_ADAPTIVE_BURN_IN`` on, from the latest half of the blocks
        (:func:`~skmba.mcmc._proposals.window_moments`).
        """
        r = self.theta.size
        target = _TARGET_ACCEPTANCE_1D if r == 1 else _TARGET_ACCEPTANCE
        b, step = self.burned // ADAPT_INTERVAL, self.burned
        m = min(ADAPT_INTERVAL, self.burn_in - step)
        if self.labelled:
            if step > 0:  # the first block's label is drawn by advance
                self._gibbs_label(log_density, self.rng.random())
            self.label_conditionals[b] = self.conditional
        block = self._block(m, self.chol)
        self._evaluate(log_density, block, m)
        path = np.empty((m, r))
        n_accept = 0
        # The joint check judges the proposals fitted to the burn-in, not
        # those of the moments given (see _check_joint).
        fitted = step >= _INDEPENDENCE_START * self.burn_in
        for i in range(m):
            accepted, alpha = self._step(
                log_density, block, i, math.exp(0.5 * self.log_scale)
            )
            n_accept += accepted
            if block.independent[i] and fitted:
                self.burn_independent += (1, accepted)
            if self.adapt and alpha is not None:
                self.rw_steps += 1
                self.log_scale += self.rw_steps**-_GAIN_EXPONENT * (alpha - target)
            path[i] = self.theta
        self.path[step : step + m] = path
        step += m
        self.burned = step
        self.counts[b] = m
        self.means[b] = path.mean(axis=0)
        dev = path - self.means[b]
        self.m2s[b] = dev.T @ dev
        self.accepts[b] = n_accept
        if self.labelled and step >= _JOINT_CHECK * self.burn_in:
            self._check_joint(log_density)
        if step < MIN_ADAPTIVE_BURN_IN:
            return
        window = self._window()
        moments = window_moments(*self.window_blocks())
        if moments is None:
            return
        if self.adapt and step < self.burn_in:
            self._adapt(*moments)
        if self.independence > 0.0 and step >= _INDEPENDENCE_START * self.burn_in:
            self._set_proposal(*moments)
            if self.labelled and self.proposal is not None:
                self._set_label_proposal(self.label_conditionals[window].mean(axis=0))

    def window_blocks(self):
        """The latest half of the burn-in blocks so far: their step counts,
        means, sums of squared deviations and accepted moves (the arrays
        :func:`~skmba.mcmc._proposals.window_moments` pools)."""
        window = self._window()
        return (
            self.counts[window],
            self.means[window],
            self.m2s[window],
            self.accepts[window],
        )

    def window_path(self):
        """The points of the latest half of the burn-in so far, one per step
        (a rejected move repeats the point before it)."""
        return self.path[self._window().start * ADAPT_INTERVAL : self.burned]

    def share_proposal(self, proposal):
        """The independence proposal of the draws, fitted to the chains'
        burn-ins together (:func:`skmba.mcmc._run.run_chains`), set between
        the burn-in and the first draw."""
        if not self.frozen or self.drawn or self.pending is not None:
            raise RuntimeError(
                f"chain {self.chain}: the shared proposal must be set after the "
                "burn-in and before the first draw"
            )
        if self.independence <= 0.0:
            return
        self.proposal, self.glogp = proposal, None
        if self.labelled and self.label_probs is None:
            # A chain whose own windows never held enough accepted moves for
            # a Student-t has no label proposal either: that of its window.
            self._set_label_proposal(
                self.label_conditionals[self._window()].mean(axis=0)
            )

    def _window(self):
        """The slice of the burn-in blocks in the latest half so far."""
        b = -(-self.burned // ADAPT_INTERVAL) - 1
        return slice((b + 1) // 2, b + 1)

    def _adapt(self, mean, cov):
        """The random-walk proposal from a window's moments; kept as it is
        when ``cov`` is not positive definite."""
        r = mean.size
        try:
            self.chol = linalg.cholesky(
                OPTIMAL_SCALE / r * cov, lower=True, check_finite=False
            )
        except linalg.LinAlgError:
            return  # keep the previous shape

    def _set_proposal(self, mean, cov):
        """The independence proposal from a window's moments; kept as it is
        when ``cov`` is not positive definite."""
        try:
            self.proposal = TProposal.of(mean, cov)
        except linalg.LinAlgError:
            return
        self.glogp = None

    def _check_joint(self, log_density):
        """Fall back to the mixture when the joint chain mixes poorly.

        Sampling the label with theta is cheap per step but mixes well only
        where ``p(k | theta)`` changes little over the posterior (the joint
        independence proposal ignores how it changes). When the independence
        moves of the burn-in so far, from the proposals fitted to it (the
        first ones, of ``moments``, propose labels uniformly and are not
        counted), were accepted less often than
        :data:`_JOINT_MIN_ACCEPTANCE`, the chain samples the mixture itself
        from here on (every component at each step); the kernel after
        burn-in is then the mixture's, fixed like any other.
        """
        moves, accepted = self.burn_independent
        if moves < _JOINT_MIN_MOVES or accepted >= _JOINT_MIN_ACCEPTANCE * moves:
            return
        self.joint = False
        self.logp = evaluate(log_density, self.theta.copy(), self.chain)
        self.glogp, self.label, self.label_probs = None, None, None

    def _set_label_proposal(self, conditionals):
        """The label proposal: the mean of the labels' conditional
        probabilities ``p(k | theta)`` at the window's Gibbs updates (a
        Rao-Blackwell estimate of their marginal ones), mixed with a uniform
        share."""
        self.label_probs = label_proposal(conditionals)
        self.glogp = None

    def _proposal_logpdf(self, theta):
        """Log density of the independence proposal at the current point."""
        if not self.labelled:
            return float(self.proposal.logpdf(theta[None, :])[0])
        value = self.proposal.logpdf(theta[None, :])[0]
        return float(value) + math.log(self.label_probs[self.label])

    def _gibbs_label(self, log_density, u):
        """Draw the label from ``p(k | theta)`` (a Gibbs update), with the
        uniform ``u``; the current point's log density becomes the joint one."""
        try:
            values = np.asarray(log_density.components(self.theta.copy()), dtype=float)
        except Exception as exc:
            raise RuntimeError(
                f"log_density.components raised {type(exc).__name__} in chain "
                f"{self.chain} at theta={self.theta!r}: {exc}"
            ) from exc
        if values.shape != (self.n_labels,) or not np.any(np.isfinite(values)):
            raise RuntimeError(
                f"log_density.components returned {values!r} in chain "
                f"{self.chain}; it must return {self.n_labels} floats, one finite"
            )
        w = np.exp(values - np.max(values))
        self.conditional = w / w.sum()
        self.label = draw_label(self.conditional, u)
        self.logp, self.glogp = float(values[self.label]), None

    def _marginal_values(self, log_density):
        """The mixture's log density at the kept draws of a labelled chain
        (the joint one was kept while sampling), evaluated once per distinct
        draw: a rejected move repeats the previous draw."""
        samples = self.samples
        new = np.ones(len(samples), dtype=bool)
        new[1:] = np.any(samples[1:] != samples[:-1], axis=1)
        values = evaluate_batch(log_density, samples[new], self.chain)
        self.values = values[np.cumsum(new) - 1]

    def _draws(self, log_density, n_steps):
        """``n_steps`` more draws with the frozen kernel.

        Blocks of ``_BLOCK`` steps (of the draws still to make) are drawn
        as if the chain ran in one piece.
        """
        samples, values = self.samples, self.values
        step, end = self.drawn, min(self.n_samples, self.drawn + n_steps)
        if self.keep_blobs and self.blob is None:
            # the point the burn-in left (its own evaluation kept no blob)
            point = self.theta.copy()
            self.blob = evaluate_with_blob(log_density, point, self.chain)[1]
        if self.keep_blobs and self.blobs is None:
            self.blobs = np.empty((self.n_samples, *self.blob.shape))
        while step < end:
            if self.pending is None:
                m = min(_BLOCK, self.n_samples - step)
                self.pending = self._block(m, self.chol)
            block = self.pending
            stop = min(len(block.log_u), block.next + end - step)
            self._evaluate(log_density, block, stop)
            # Without label proposals, Gibbs updates move the label.
            gibbs = self.labelled and (
                self.label_probs is None or not self.independence
            )
            for i in range(block.next, stop):
                if gibbs and step % ADAPT_INTERVAL == 0:
                    self._gibbs_label(log_density, block.label_u[i])
                accepted, _ = self._step(log_density, block, i)
                self.n_accept += accepted
                if block.independent[i]:
                    self.n_independent += 1
                    self.n_independent_accept += accepted
                samples[step] = self.theta
                values[step] = self.logp
                self.labels[step] = self.label if self.labelled else 0
                if self.keep_blobs:
                    self.blobs[step] = self.blob
                step += 1
            block.next = stop
            if stop == len(block.log_u):
                self.pending = None
        self.drawn = step
        if self.labelled and self.keep_log_density and step == self.n_samples:
            self._marginal_values(log_density)
