"""When chains have drawn enough: a target effective sample size.

:class:`EssTarget` is the rule by which :func:`skmba.mcmc._run.run_chains`
ends its draws before ``n_samples``: at fixed checkpoints (every
:attr:`EssTarget.every` draws per chain, the same whatever the segments or
the processes of the run), the draws so far are judged, and the chains stop
at the first checkpoint where every parameter's bulk and tail effective
sample size (:func:`~skmba.mcmc._diagnostics.ess_bulk`,
:func:`~skmba.mcmc._diagnostics.ess_tail`) reach the target and its split
R-hat is at most :attr:`EssTarget.max_rhat`. A checkpoint that falls short
predicts where the target will be met (:meth:`EssTarget.predicted`, on a
grid of :attr:`EssTarget.grid` draws), which is judged too when it comes
before the next checkpoint. Stopped there, a chain's draws
are the first draws of a run that went on: the rule chooses a length, it
does not change a draw. Why the calibrator stops at 2000 is in
docs/internals.rst (section skmba.mcmc._stopping).

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._stopping import EssTarget
>>> rule = EssTarget(ess=1000, every=250)
>>> rule.checkpoints(burn_in=100, total=1100)
[350, 600, 850]
>>> draws = np.random.default_rng(0).normal(size=(4, 300, 2))
>>> rule.met(draws), EssTarget(ess=1000).met(draws[:, :200])
(True, False)
"""

from dataclasses import dataclass

import numpy as np

from skmba.mcmc._diagnostics import ess_bulk, ess_tail, split_rhat

#: Draws per chain between checkpoints (:attr:`EssTarget.every`'s
#: default); the chains' blocks of random numbers have this length too
#: (:mod:`skmba.mcmc._chain`).
CHECK_EVERY = 250
#: Draws per chain between the places where a run may stop: a checkpoint
#: predicted between two regular ones (:meth:`EssTarget.predicted`) falls
#: on this grid, and the chains evaluate their independence proposals in
#: groups of this many steps, so that a stop wastes no evaluated proposal.
STOP_GRID = 50


@dataclass(frozen=True)
class EssTarget:
    """Stop the draws once they are worth ``ess`` independent draws.

    Parameters
    ----------
    ess : float
        The bulk and tail effective sample size each parameter must reach
        (all chains together).
    max_rhat : float, default=1.01
        The split R-hat each parameter must not exceed (Vehtari et al.
        2021's threshold).
    every : int, default=250
        Draws per chain between checkpoints; the first checkpoint is after
        ``every`` draws.
    grid : int, default=50
        Draws per chain between the places where :meth:`predicted` may put
        a checkpoint (a divisor of ``every``).
    """

    ess: float
    max_rhat: float = 1.01
    every: int = CHECK_EVERY
    grid: int = STOP_GRID

    def checkpoints(self, burn_in, total):
        """The steps (burn-in included) after which the draws are judged;
        none at ``total``, where the chains end anyway."""
        return list(range(burn_in + self.every, total, self.every))

    def diagnostics(self, draws):
        """Bulk ESS, tail ESS and split R-hat per parameter of ``draws`` of
        shape (n_chains, n_draws, r): three arrays of shape (r,)."""
        columns = [draws[:, :, j] for j in range(draws.shape[-1])]
        return (
            np.array([ess_bulk(c) for c in columns]),
            np.array([ess_tail(c) for c in columns]),
            np.array([split_rhat(c) for c in columns]),
        )

    def met(self, draws):
        """Whether ``draws`` (n_chains, n_draws, r) meet the target (NaN
        diagnostics, e.g. of a parameter that never moved, do not)."""
        return self.judge(draws)[0]

    def judge(self, draws):
        """Whether ``draws`` (n_chains, n_draws, r) meet the target, and the
        draws per chain at which they are predicted to (:meth:`predicted`;
        None when met)."""
        bulk, tail, rhat = self.diagnostics(draws)
        if (
            np.all(bulk >= self.ess)
            and np.all(tail >= self.ess)
            and np.all(rhat <= self.max_rhat)
        ):
            return True, None
        return False, self.predicted(draws.shape[1], bulk, tail, rhat)

    def predicted(self, n_draws, bulk, tail, rhat):
        """Where the target is predicted to be met, from the diagnostics of
        ``n_draws`` draws per chain: the effective sample sizes grown in
        proportion to the draws, rounded up to the :attr:`grid`; None where
        R-hat is above :attr:`max_rhat` or a diagnostic is NaN (no
        prediction: the next checkpoint judges).

        Examples
        --------
        >>> rule = EssTarget(ess=2000)
        >>> bulk, tail, rhat = np.array([1932.0]), np.array([2269.0]), np.array([1.002])
        >>> rule.predicted(1250, bulk, tail, rhat)
        1300
        """
        ess = np.concatenate([bulk, tail])
        if not (np.all(np.isfinite(ess)) and np.all(ess > 0)):
            return None
        if not np.all(rhat <= self.max_rhat):
            return None
        needed = n_draws * self.ess / float(np.min(ess))
        return int(-(-needed // self.grid) * self.grid)
