"""Module 3 with the module-2 hyperparameters integrated out.

:class:`ModelMixture` is the global model of :mod:`skmba._posterior` at
each draw ``phi_k`` of :func:`~skmba._hyperposterior.fit_hyperposterior`,
with the likelihood ``log sum_k w_k p(data | theta, phi_k)``. It has the
interface of :class:`~skmba._posterior.GlobalModel` that
:class:`~skmba._posterior.LogPosterior` and the predictions use; the
emulator given the simulations is computed once per theta for all draws.
Module 4 predicts with one draw per posterior theta, picked with
probability ``p(phi_k | theta, data)`` (:meth:`ModelMixture.draw_weights`).

Examples
--------
``tests/test_mixture.py`` checks the mixture against its components.
"""

import copy

import numpy as np
from scipy import linalg, special

from skmba._linalg import LOG_2PI, FactorizationError


class ModelMixture:
    """Global models over draws of the module-2 hyperparameters.

    Parameters
    ----------
    base : GlobalModel
        The global model at the mode of the hyperparameters.
    draws : HyperposteriorDraws
    """

    def __init__(self, base, draws):
        self.base = base
        self.models = [base.with_discrepancy(c) for c in draws.components]
        self.log_weights = np.asarray(draws.log_weights, dtype=float)
        self._S_fixed = None  # the stacked fixed parts, made on first use
        for name in ("N", "n", "q", "P", "X_e", "noise", "emulator"):
            setattr(self, name, getattr(base, name))

    def __copy__(self):
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other.models = [copy.copy(m) for m in self.models]
        other.base = copy.copy(self.base)
        return other

    def component_log_likelihoods(self, theta):
        """``log w_k + log p(data | theta, phi_k)`` for every draw ``k``.

        All draws at once (stacked Cholesky, triangular solves and QR); one
        by one when a draw's covariance cannot be factored.
        """
        theta = np.asarray(theta, dtype=float).ravel()
        conditional = self.base.conditional(theta)
        try:
            return self.log_weights + self._stacked(conditional)
        except (np.linalg.LinAlgError, FactorizationError):
            return self._one_by_one(theta, conditional)

    def _stacked(self, conditional):
        """The log likelihood of every draw, factored as a stack."""
        base = self.base
        if self._S_fixed is None:
            self._S_fixed = np.stack([m.S_fixed for m in self.models])
        cond, model_term = conditional
        L = np.linalg.cholesky(self._S_fixed + model_term)
        X_bot, y_bot = base.field_data(cond)
        W = linalg.solve_triangular(
            L, np.column_stack([X_bot, y_bot])[None], lower=True
        )
        K, P = len(L), base.P
        stacked = np.concatenate(
            [np.broadcast_to(base.G_top, (K, *base.G_top.shape)), W[:, :, :P]], axis=1
        )
        Q, G = np.linalg.qr(stacked)
        diag = np.abs(np.diagonal(G, axis1=1, axis2=2))
        if np.any(diag.min(axis=1) <= 1e-10 * diag.max(axis=1)):
            raise FactorizationError("rank deficient")
        rhs = np.concatenate(
            [np.broadcast_to(base.b_top, (K, len(base.b_top))), W[:, :, P]], axis=1
        )
        proj = np.einsum("kmp,km->kp", Q, rhs)
        rss = base.rss_top_perp + np.sum(rhs**2, axis=1) - np.sum(proj**2, axis=1)
        log_det_S = 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)
        M = base.N * self.q + base.n_observed
        return -0.5 * (
            (M - P) * LOG_2PI
            + base.log_det_A
            + log_det_S
            + 2.0 * np.sum(np.log(diag), axis=1)
            + rss
        )

    def _one_by_one(self, theta, conditional):
        out = np.full(len(self.models), -np.inf)
        for k, model in enumerate(self.models):
            try:
                out[k] = model.whiten(theta, conditional).log_likelihood
            except FactorizationError:
                continue
        if not np.any(np.isfinite(out)):
            # Say why, with the mode's own error.
            self.base.whiten(theta, conditional)
        return self.log_weights + out

    def log_likelihood(self, theta):
        """``log sum_k w_k p(data | theta, phi_k)``."""
        return float(special.logsumexp(self.component_log_likelihoods(theta)))

    def draw_weights(self, theta):
        """``p(phi_k | theta, data)`` over the draws (sums to one)."""
        values = self.component_log_likelihoods(theta)
        return np.exp(values - special.logsumexp(values))

    def effective_draws(self, theta):
        """Kish's effective number of draws at ``theta`` (1 to ``K``)."""
        w = self.draw_weights(theta)
        return float(1.0 / np.sum(w**2))
