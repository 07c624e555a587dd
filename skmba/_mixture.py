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
from scipy import special

from skmba._linalg import LOG_2PI, FactorizationError, stacked_whitening

#: A module-2 draw whose weight ``p(phi_k | theta, data)`` stays below this
#: around the posterior of theta is left out of the sampler's mixture
#: (:meth:`ModelMixture.restricted`).
IDLE_WEIGHT = 1e-10


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
        # What a new observation adds: the noise variances' posterior mean.
        self.predictive_noise = np.asarray(draws.noise_mean, dtype=float)

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
        """The log likelihood of every draw, factored as a stack.

        One stacked Cholesky factorisation
        (:func:`~skmba._linalg.stacked_whitening`) gives both ``L_k`` and
        the whitened field rows ``L_k^-1 Z`` (``Z`` the field rows of the
        regression and data); the smallest eigenvalue of every ``S_k`` is at
        least the smallest noise variance (the other terms are positive
        semi-definite).
        """
        base = self.base
        cond, model_term = conditional
        X_bot, y_bot = base.field_data(cond)
        Z = np.column_stack([X_bot, y_bot])
        P = base.P
        if self._S_fixed is None:
            self._S_fixed = np.stack([mdl.S_fixed for mdl in self.models])
            self._noise_floor = min(float(np.min(mdl.noise)) for mdl in self.models)
        K = len(self._S_fixed)
        try:
            L, W = stacked_whitening(self._S_fixed + model_term, Z, self._noise_floor)
        except np.linalg.LinAlgError as exc:
            raise FactorizationError(str(exc)) from exc
        # R factor of [[G_top, b_top], [W_X, w_y]]: its leading P x P block
        # is that of the whitened regression, its last diagonal entry the
        # norm of the residual beyond the simulations' own (rss_top_perp).
        top = np.column_stack([base.G_top, base.b_top])
        stacked = np.concatenate([np.broadcast_to(top, (K, *top.shape)), W], axis=1)
        R = np.linalg.qr(stacked, mode="r")
        diag = np.abs(np.diagonal(R[:, :P, :P], axis1=1, axis2=2))
        if np.any(diag.min(axis=1) <= 1e-10 * diag.max(axis=1)):
            raise FactorizationError("rank deficient")
        rss = base.rss_top_perp + R[:, P, P] ** 2
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
        # numpy's reduction: scipy's logsumexp costs more than the sum here.
        return float(np.logaddexp.reduce(self.component_log_likelihoods(theta)))

    def draw_weights(self, theta):
        """``p(phi_k | theta, data)`` over the draws (sums to one)."""
        values = self.component_log_likelihoods(theta)
        return np.exp(values - special.logsumexp(values))

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
        weights = []
        for theta in thetas:
            try:
                weights.append(self.draw_weights(theta))
            except FactorizationError:
                continue  # no draw can be evaluated there: no evidence
        if not weights:
            return self, np.arange(len(self.models))
        kept = np.flatnonzero(np.max(weights, axis=0) > tol)
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
