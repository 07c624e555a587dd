"""One adaptive Metropolis-Hastings chain: its kernel and its state.

:func:`skmba.mcmc._run.run_chains` runs several :class:`Chain` objects in
parallel; this module holds what one chain does, step by step.

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
:attr:`skmba.mcmc._run.ChainResult.proposal_cov`.

With ``independence=p > 0`` the chains also make independence moves
(Metropolis-Hastings with a proposal ``g`` that does not depend on the
current point; Tierney 1994): at each step, with probability ``p``, the
proposal ``y`` is drawn from ``g``, a Student-t of 5 degrees of freedom
whose location and scale matrix are the mean and 1.5 times the covariance
of the latest half of the chain's burn-in (so far), and accepted with
probability ``min(1, p(y) g(x) / (p(x) g(y)))``; with probability
``1 - p`` the step is the random walk above. Independence moves begin
halfway through the burn-in, after a random walk alone has adapted (or at
the first step, from the target's mean and covariance known from an
earlier run, ``moments``); ``g`` is then re-estimated every 50 steps and
frozen at the end of burn-in.
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

A *labelled* target is a finite mixture ``p(theta) = sum_k p(theta, k)``
(``n_labels`` > 1; the calibrator's posterior over its module-2 draws)
whose joint density ``p(theta, k)`` costs one K-th of ``p(theta)``. The
chain then samples ``(theta, k)`` (data augmentation; Tanner & Wong 1987):

* at the start of each burn-in block (every ``_ADAPT_INTERVAL`` steps), a
  Gibbs update draws ``k`` from ``p(k | theta)``, which takes all K
  components at one theta;
* random-walk moves change ``theta`` at fixed ``k``;
* independence moves propose ``k`` too, from the mean of the conditional
  probabilities ``p(k | theta)`` of the Gibbs updates in the latest half
  of the burn-in (a Rao-Blackwell estimate of the labels' marginal
  probabilities) mixed with a uniform share
  :data:`_LABEL_UNIFORM_SHARE`, so that every label stays reachable, and
  are accepted with the joint ratio ``p(y, k') g(x) q(k) / (p(x, k) g(y)
  q(k'))``;
* without a label proposal after burn-in (``independence=0``), the Gibbs
  updates go on every ``_ADAPT_INTERVAL`` steps.

Each step then evaluates one component instead of ``n_labels``, and the
draws of ``theta`` follow the mixture; their log density, the mixture's,
is computed at the end, at the distinct draws only. The joint proposal
ignores how ``p(k | theta)`` changes with theta, so the chain mixes as well
as one on the mixture only where it changes little: on the 4.7.3
cantilever (K = 12 draws with weight, 4 chains of 1000 draws after 500)
bulk ESS 1466 against 1367, at about a third of the cost per step; on the
validity suite's a2 design (4 chains of 5000 draws after 1000) R-hat
above 1.01 in 13 of 50 seeds and bulk ESS 88-216 where the chains on the
mixture reach 2900-4000. A chain whose independence moves were accepted
less often than :data:`_JOINT_MIN_ACCEPTANCE` in the burn-in therefore
falls back to the mixture at :data:`_JOINT_CHECK` of it, which catches
the worst cases only; the calibrator samples jointly only where mixing
matters little (the first pass of its propagated module 2, which only
locates the posterior). A label proposal from the frequencies of the
sampled labels instead of the Gibbs updates' conditional probabilities
gave an ESS of 455 on 4.7.3: the chains visit few labels in a window. The
target provides ``labelled(thetas, labels) -> values`` (the joint log
densities), ``components(theta) -> values`` (of shape (n_labels,)) and
``batch`` (the mixture's).

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

# Optimal scaling of a random-walk proposal for a Gaussian target in r
# dimensions (Gelman, Roberts & Gilks 1996): proposal covariance
# 2.38^2 / r times the target covariance.
OPTIMAL_SCALE = 2.38**2
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
#: Share of the uniform distribution in the label proposal of a labelled
#: target's independence moves (see the module docstring).
_LABEL_UNIFORM_SHARE = 0.1
# A labelled chain whose independence moves of the burn-in were accepted
# less often than _JOINT_MIN_ACCEPTANCE (after at least _JOINT_MIN_MOVES of
# them) falls back to the mixture itself at _JOINT_CHECK of the burn-in.
# On the validity suite's a2 design the joint chains that mixed worst had
# acceptance rates of 0.12-0.28; on 4.7.3, where they mix as well as the
# mixture's, 0.4-0.5. Chains just above the threshold can still mix
# poorly (a2 seed 8: R-hat 1.05 with the fallback), hence joint sampling
# only where mixing matters little.
_JOINT_MIN_ACCEPTANCE = 0.3
_JOINT_MIN_MOVES = 20
_JOINT_CHECK = 0.75


def evaluate(log_density, theta, chain):
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
    unused), with the proposed ``labels`` of a labelled target; ``label_u``
    are the uniforms of a labelled target's label proposals and Gibbs
    updates (None otherwise). ``next`` is the first step not yet made.
    """

    increments: np.ndarray
    log_u: np.ndarray
    independent: np.ndarray
    proposals: np.ndarray
    values: np.ndarray
    g_values: np.ndarray
    labels: np.ndarray
    label_u: np.ndarray | None
    next: int = 0


def _checked_values(method, name, n, chain, *args):
    """``method(*args)`` as ``n`` log densities, errors naming ``name`` and
    the chain."""
    try:
        values = np.asarray(method(*args), dtype=float)
    except Exception as exc:
        raise RuntimeError(
            f"log_density.{name} raised {type(exc).__name__} in chain {chain} at "
            f"{n} points: {exc}"
        ) from exc
    if values.shape != (n,) or np.any(np.isnan(values) | (values == np.inf)):
        raise RuntimeError(
            f"log_density.{name} returned {values!r} in chain {chain}; it must "
            f"return {n} finite floats or -inf (zero density)"
        )
    return values


def _evaluate_batch(log_density, thetas, chain):
    """``log_density`` at each row of ``thetas``, in one call to its
    ``batch`` method when it has one."""
    batch = getattr(log_density, "batch", None)
    if batch is None:
        return np.array([evaluate(log_density, t.copy(), chain) for t in thetas])
    return _checked_values(batch, "batch", len(thetas), chain, thetas)


def _evaluate_labelled(log_density, thetas, labels, chain):
    """The joint log density of a labelled target at ``(thetas[b], labels[b])``."""
    return _checked_values(
        log_density.labelled, "labelled", len(thetas), chain, thetas, labels
    )


def _draw_label(probs, u):
    """The label of probabilities ``probs`` that the uniform ``u`` picks."""
    cumulative = np.cumsum(probs)
    k = int(np.searchsorted(cumulative, u * cumulative[-1], side="right"))
    return min(k, len(probs) - 1)


class Chain:
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
        n_labels=1,
        keep_log_density=True,
        moments=None,
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
                drawn = np.minimum(picked, self.n_labels - 1)
                labels[independent] = drawn
                values[independent] = _evaluate_labelled(
                    log_density, proposals[independent], drawn, self.chain
                )
                g_values[independent] = self.proposal.logpdf(
                    proposals[independent]
                ) + np.log(self.label_probs[drawn])
            elif k:
                values[independent] = _evaluate_batch(
                    log_density, proposals[independent], self.chain
                )
                g_values[independent] = self.proposal.logpdf(proposals[independent])
        return _Block(
            increments, log_u, independent, proposals, values, g_values, labels, label_u
        )

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
                if self.labelled:
                    self.label = int(block.labels[i])
                return True, None
            return False, None
        proposal = theta + scale * block.increments[i]
        if self.labelled:
            value = _evaluate_labelled(
                log_density, proposal[None, :], np.array([self.label]), self.chain
            )[0]
        else:
            value = evaluate(log_density, proposal, self.chain)
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
        if self.labelled:
            if step > 0:  # the first block's label is drawn by advance
                self._gibbs_label(log_density, self.rng.random())
            self.label_conditionals[b] = self.conditional
        block = self._block(log_density, m, self.chol)
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
        step += m
        self.burned = step
        self.counts[b] = m
        self.means[b] = path.mean(axis=0)
        dev = path - self.means[b]
        self.m2s[b] = dev.T @ dev
        self.accepts[b] = n_accept
        if self.labelled and step >= _JOINT_CHECK * self.burn_in:
            self._check_joint(log_density)
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
            if self.labelled and self.proposal is not None:
                self._set_label_proposal(self.label_conditionals[window].mean(axis=0))

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
            self.proposal = _TProposal.of(mean, cov)
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
        share = _LABEL_UNIFORM_SHARE
        self.label_probs = (1.0 - share) * conditionals + share / self.n_labels
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
        self.label = _draw_label(self.conditional, u)
        self.logp, self.glogp = float(values[self.label]), None

    def _marginal_values(self, log_density):
        """The mixture's log density at the kept draws of a labelled chain
        (the joint one was kept while sampling), evaluated once per distinct
        draw: a rejected move repeats the previous draw."""
        samples = self.samples
        new = np.ones(len(samples), dtype=bool)
        new[1:] = np.any(samples[1:] != samples[:-1], axis=1)
        values = _evaluate_batch(log_density, samples[new], self.chain)
        self.values = values[np.cumsum(new) - 1]

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
            # Without label proposals, Gibbs updates move the label.
            gibbs = self.labelled and (
                self.label_probs is None or not self.independence
            )
            for i in range(block.next, stop):
                if gibbs and step % _ADAPT_INTERVAL == 0:
                    self._gibbs_label(log_density, block.label_u[i])
                accepted, _ = self._step(log_density, block, i)
                self.n_accept += accepted
                if block.independent[i]:
                    self.n_independent += 1
                    self.n_independent_accept += accepted
                samples[step] = self.theta
                values[step] = self.logp
                self.labels[step] = self.label if self.labelled else 0
                step += 1
            block.next = stop
            if stop == len(block.log_u):
                self.pending = None
        self.drawn = step
        if self.labelled and self.keep_log_density and step == self.n_samples:
            self._marginal_values(log_density)


def _window_moments(counts, means, m2s, accepts):
    """Mean and covariance (``+ epsilon I``) of a window of burn-in blocks.

    None when the window holds too few accepted moves (``max(10, 2 r)``).
    """
    r = means.shape[1]
    if accepts.sum() < max(10, 2 * r):
        return None
    n, mean, m2 = _merge_moments(counts, means, m2s)
    return mean, (m2 / (n - 1) + _EPSILON * np.eye(r))
