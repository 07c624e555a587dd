"""Module 3 with the module-2 hyperparameters integrated out.

:class:`ModelMixture` is the global model of :mod:`skmba.calibration._module3_posterior`
at each draw ``phi_k`` of
:func:`~skmba.calibration._module2_posterior.fit_hyperposterior`, with the likelihood
``log sum_k w_k p(data | theta, phi_k)``. It has the interface of
:class:`~skmba.calibration._module3_likelihood.GlobalModel` that
:class:`~skmba.calibration._module3_posterior.LogPosterior` and the predictions use; the
emulator given the simulations is computed once per theta for all draws. Module 4
predicts with one draw per posterior theta, picked with probability ``p(phi_k | theta,
data)`` (:meth:`ModelMixture.draw_weights`).

Examples
--------
``tests/calibration/test_module3_mixture.py`` checks the mixture against its components.
"""

import copy

import numpy as np
from joblib import Parallel, delayed
from scipy import special

from skmba._core.linalg import FactorizationError, n_workers
from skmba._core.threads import BlasTask, stack_map
from skmba.calibration._module3_likelihood import CONDITIONAL_BYTES, stack_chunks
from skmba.calibration._module3_low_rank import (
    fixed_factors,
    low_rank_log_likelihoods,
    max_low_rank,
    model_term_factor,
)

#: A module-2 draw whose weight ``p(phi_k | theta, data)`` stays below this
#: around the posterior of theta is left out of the sampler's mixture
#: (:meth:`ModelMixture.restricted`).
IDLE_WEIGHT = 1e-10
#: Thetas, evenly thinned from a run's draws, at which the draws left out
#: are found or checked idle (the chains' check, an update's reweighting).
IDLE_CHECK_THETAS = 100
#: Thetas of a batch from which the mixture tries the low-rank model term
#: (:mod:`skmba.calibration._module3_low_rank`): below, its Python steps per
#: batch cost more than the factorisations they save.
LOW_RANK_MIN_THETAS = 16
#: Thetas per joblib task of :meth:`ModelMixture.spread_component_log_likelihoods`:
#: fixed by the problem, so that the tasks, hence the bits, do not depend on
#: ``n_jobs``.
TASK_THETAS = 25


class ModelMixture:
    """Global models over draws of the module-2 hyperparameters.

    Parameters
    ----------
    base : GlobalModel
        The global model at the mode of the hyperparameters.
    draws : HyperposteriorDraws
    models : list of GlobalModel, default=None
        ``base.with_discrepancy(c)`` for each component ``c`` of ``draws``,
        when already built (the converged integral builds them as it
        evaluates the draws); None: built here.
    """

    def __init__(self, base, draws, models=None):
        self.base = base
        if models is None:
            models = [base.with_discrepancy(c) for c in draws.components]
        elif len(models) != len(draws.components):
            raise ValueError(
                f"models has {len(models)} entries for {len(draws.components)} "
                "module-2 draws: pass one global model per draw, or None."
            )
        self.models = list(models)
        self.log_weights = np.asarray(draws.log_weights, dtype=float)
        self._S_fixed = None  # the stacked fixed parts, made on first use
        for name in ("N", "n", "q", "P", "X_e", "noise", "emulator"):
            setattr(self, name, getattr(base, name))
        # What a new observation adds: the noise variances' posterior mean;
        # the plugged noise when it was not estimated (the plug-in, or a
        # first pass that does not predict).
        self.predictive_noise = (
            base.predictive_noise
            if draws.noise_mean is None
            else np.asarray(draws.noise_mean, float)
        )

    def __copy__(self):
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other.models = [copy.copy(m) for m in self.models]
        other.base = copy.copy(self.base)
        return other

    def component_log_likelihoods(self, theta):
        """``log w_k + log p(data | theta, phi_k)`` for every draw ``k``.

        Raises
        ------
        FactorizationError
            When no draw can be evaluated at ``theta`` (saying why).
        """
        theta = np.asarray(theta, dtype=float).ravel()
        values = self.batch_component_log_likelihoods(theta[None, :])[0]
        if not np.any(np.isfinite(values)):
            self.base.log_likelihood(theta)  # raises, saying why
            raise FactorizationError(
                "The Schur complement S(theta) is not positive definite at any "
                "module-2 draw."
            )
        return values

    def batch_component_log_likelihoods(self, thetas):
        """``log w_k + log p(data | theta_b, phi_k)`` (B, K) at the rows of
        ``thetas`` (B, r): ``-inf`` where draw ``k``'s Schur complement is
        not positive definite or the regression rank deficient with it.

        The emulator given the simulations is computed once per theta for
        all draws, and the Schur complements of every theta and draw are
        factored as one stack
        (:func:`~skmba.calibration._module3_likelihood.schur_log_likelihoods`);
        a batch of :data:`LOW_RANK_MIN_THETAS` or more whose model terms
        have a small numerical rank goes through the determinant lemma
        instead (:mod:`skmba.calibration._module3_low_rank`; the same values
        within ``m`` times its ``LOW_RANK_TOL`` nats).

        Raises
        ------
        FactorizationError
            When the regression is rank deficient at every draw and theta
            of one stacked factorisation (e.g. at every draw for a single
            theta).
        """
        return self._stacked(thetas, None)

    def spread_component_log_likelihoods(self, thetas, n_jobs=None):
        """:meth:`batch_component_log_likelihoods` in joblib tasks.

        For the checks and module-4 weights at many posterior draws (a
        few hundred thetas times every draw), which would otherwise leave
        all but one core idle. The thetas go in tasks of
        :data:`TASK_THETAS`, the same for any ``n_jobs`` (``None`` or 1:
        one after the other in this process), each under the BLAS threads
        of :class:`~skmba._core.threads.BlasTask`: the values are bit-identical
        for any ``n_jobs`` and backend below its threshold order.
        """
        thetas = np.atleast_2d(thetas)
        groups = [
            thetas[i : i + TASK_THETAS] for i in range(0, len(thetas), TASK_THETAS)
        ]
        task = BlasTask(_component_values, self.n * self.q, n_jobs)
        with task.held():
            if n_workers(n_jobs) <= 1 or len(groups) == 1:
                parts = [task(self, g) for g in groups]
            else:
                parts = Parallel(n_jobs=n_jobs)(delayed(task)(self, g) for g in groups)
        return np.concatenate(parts)

    def labelled_log_likelihoods(self, thetas, labels):
        """``log w_k + log p(data | theta_b, phi_k)`` with ``k = labels[b]``
        (B,): one draw per theta, the joint density of theta and the draw
        that a sampler over both needs (:mod:`skmba.mcmc._chain`).

        Raises
        ------
        FactorizationError
            As :meth:`batch_component_log_likelihoods`.
        """
        labels = np.asarray(labels, dtype=int)
        return self._stacked(thetas, labels)

    def _stacked(self, thetas, labels):
        """Every draw at each theta (``labels`` None: (B, K)), or draw
        ``labels[b]`` at ``thetas[b]`` ((B,)), as stacks of factorisations."""
        base = self.base
        if self._S_fixed is None:
            self._S_fixed = np.stack([mdl.S_fixed for mdl in self.models])
            self._noise_floor = min(mdl.noise_floor for mdl in self.models)
            # Each draw's factor of repeated readings (zeros without them).
            self._factors = np.array([mdl.replicate_factor for mdl in self.models])
            self._fixed = None  # their factors, made for the low-rank path
        K, m = self._S_fixed.shape[:2]
        per_theta = K if labels is None else 1
        out = np.empty((len(thetas), per_theta))
        for group in stack_chunks(len(thetas), 1, m, 0, CONDITIONAL_BYTES):
            cond, terms = base.conditionals(thetas[group])
            rows = base.field_rows(cond)
            if labels is None and len(terms) >= LOW_RANK_MIN_THETAS:
                values = self._low_rank(terms, rows)
                if values is not None:
                    out[group] = values
                    continue

            def factor(chunk, rows=rows, terms=terms, start=group.start):
                Z, T, B = rows[chunk], terms[chunk], chunk.stop - chunk.start
                at = slice(start + chunk.start, start + chunk.stop)
                if labels is None:
                    S = (self._S_fixed[None] + T[:, None]).reshape(B * K, m, m)
                    Z = np.broadcast_to(Z[:, None], (B, K, *Z.shape[1:])).reshape(
                        B * K, *Z.shape[1:]
                    )
                else:
                    S = self._S_fixed[labels[at]] + T
                try:
                    values = base.stacked_log_likelihoods(S, Z, self._noise_floor)
                except FactorizationError:  # at one (theta, draw) of the stack?
                    values = _one_by_one(base, S, Z, self._noise_floor)
                out[at] = values.reshape(B, per_theta)

            # the chunks on the block's idle BLAS threads (same bits)
            stack_map(factor, stack_chunks(len(terms), per_theta, m, base.P + 1))
        if labels is None:
            return self.log_weights + self._factors + out
        return self.log_weights[labels] + self._factors[labels] + out[:, 0]

    def _low_rank(self, terms, rows):
        """Every draw at each theta of ``terms`` through a low-rank model
        term (:mod:`skmba.calibration._module3_low_rank`), or None where it
        does not apply (a model term of high rank, a rank-deficient
        regression or field rows of lower rank: the dense path decides)."""
        if getattr(self, "_fixed", None) is None:  # (pickles of before)
            try:
                self._fixed = fixed_factors(self._S_fixed)
            except np.linalg.LinAlgError:  # a draw's fixed part is not
                self._fixed = False  # positive definite: dense, always
        if self._fixed is False:
            return None
        U = model_term_factor(
            terms, self._noise_floor, max_low_rank(terms.shape[1], rows.shape[2])
        )
        if U is None:
            return None
        factors, log_dets = self._fixed
        halves = np.array_split(np.arange(len(factors)), 2)
        try:
            # the draws on the block's idle BLAS threads (same bits)
            parts = stack_map(
                lambda draws: low_rank_log_likelihoods(
                    factors, log_dets, U, rows, self.base, draws
                ),
                [h for h in halves if h.size],
            )
        except (np.linalg.LinAlgError, FactorizationError):
            return None
        return np.concatenate(parts, axis=1)  # the halves, in order

    def log_likelihood(self, theta):
        """``log sum_k w_k p(data | theta, phi_k)``."""
        return self.log_likelihood_with_components(theta)[0]

    def log_likelihood_with_components(self, theta):
        """:meth:`log_likelihood` and the :meth:`component_log_likelihoods`
        it sums (K,)."""
        values = self.component_log_likelihoods(theta)
        # numpy's reduction: scipy's logsumexp costs more than the sum here.
        return float(np.logaddexp.reduce(values)), values

    def log_likelihoods(self, thetas):
        """:meth:`log_likelihood` at the rows of ``thetas`` (B, r): (B,),
        ``-inf`` where no draw can be evaluated."""
        return self.log_likelihoods_with_components(thetas)[:, 0]

    def log_likelihoods_with_components(self, thetas):
        """:meth:`log_likelihoods` (the first column) and the
        :meth:`batch_component_log_likelihoods` they sum (the others): (B, 1 + K)."""
        values = self.batch_component_log_likelihoods(thetas)
        return np.column_stack([np.logaddexp.reduce(values, axis=1), values])

    def draw_weights(self, theta):
        """``p(phi_k | theta, data)`` over the draws (sums to one)."""
        return draw_weights_of(self.component_log_likelihoods(theta)[None])[0]

    def restricted(self, thetas, tol=IDLE_WEIGHT):
        """The mixture of the draws that carry weight at some of ``thetas``.

        A draw is kept when ``p(phi_k | theta, data)`` exceeds ``tol`` at
        one of ``thetas`` at least (standardised, each of shape (r,)); the
        mixture is returned as it is when every draw is kept (or no theta
        can be evaluated). At each of ``thetas``, the log likelihood of the
        restricted mixture differs from the full one by less than
        ``K tol``.

        Returns
        -------
        mixture : ModelMixture
        kept : ndarray of int
            The indices of the draws kept.
        """
        if len(self.models) == 1:  # one draw (the plug-in) always matters
            return self, np.arange(1)
        weights = []
        for theta in thetas:
            try:
                weights.append(self.draw_weights(theta))
            except FactorizationError:
                continue  # no draw can be evaluated there: no evidence
        if not weights:
            return self, np.arange(len(self.models))
        return self.keeping(np.flatnonzero(np.max(weights, axis=0) > tol))

    def spread_restricted(self, thetas, n_jobs=None, tol=IDLE_WEIGHT):
        """:meth:`restricted` at many ``thetas`` (B, r), their values
        computed as :meth:`spread_component_log_likelihoods` does (a theta
        where no draw can be evaluated gives no evidence).

        Returns
        -------
        mixture : ModelMixture
        kept : ndarray of int
            As :meth:`restricted`.
        values : ndarray of shape (B, K)
            :meth:`spread_component_log_likelihoods` at ``thetas``, every
            draw: computed anyway, for a caller that needs them.

        Raises
        ------
        FactorizationError
            As :meth:`batch_component_log_likelihoods`.
        """
        values = self.spread_component_log_likelihoods(thetas, n_jobs)
        if len(self.models) == 1:
            return self, np.arange(1), values
        if not np.isfinite(values).any():
            return self, np.arange(len(self.models)), values
        weights = draw_weights_of(values)  # zero rows give no evidence
        used, kept = self.keeping(np.flatnonzero(np.max(weights, axis=0) > tol))
        return used, kept, values

    def keeping(self, kept):
        """The mixture of the draws ``kept`` (indices; itself when all are)
        and them."""
        if len(kept) == len(self.models):
            return self, kept
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other.models = [self.models[k] for k in kept]
        other.log_weights = self.log_weights[kept]
        other._S_fixed = None
        return other, kept

    def effective_draws(self, theta):
        """Kish's effective number of draws at ``theta`` (1 to ``K``)."""
        w = self.draw_weights(theta)
        return float(1.0 / np.sum(w**2))


def draw_weights_of(values):
    """``p(phi_k | theta, data)`` from the component log likelihoods
    ``values`` (B, K) of :meth:`ModelMixture.batch_component_log_likelihoods`:
    each row normalised, a row where no draw can be evaluated all zeros."""
    values = np.asarray(values, dtype=float)
    weights = np.zeros(values.shape)
    rows = np.isfinite(values).any(axis=1)
    weights[rows] = special.softmax(values[rows], axis=1)
    return weights


def _one_by_one(base, S, Z, noise_floor):
    """The stack's log likelihoods factored one by one: ``-inf`` where the
    regression is rank deficient (e.g. a draw of the discrepancy's size so
    large, 1e20 times the data's variance, that the field rows vanish
    beside it), as where its Schur complement is not positive definite.

    Raises
    ------
    FactorizationError
        When it is rank deficient at every one.
    """
    out = np.full(len(S), -np.inf)
    error = None
    for i in range(len(S)):
        try:
            out[i] = base.stacked_log_likelihoods(
                S[i : i + 1], Z[i : i + 1], noise_floor
            )[0]
        except FactorizationError as exc:
            error = exc
    if error is not None and not np.isfinite(out).any():
        raise error
    return out


def _component_values(mixture, thetas):
    """A joblib task of :meth:`ModelMixture.spread_component_log_likelihoods`."""
    return mixture.batch_component_log_likelihoods(thetas)
