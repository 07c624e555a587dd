"""Predictions of a fitted MultiResponseGP: :class:`PredictionMixin`.

:class:`~skmba.gp._estimator.MultiResponseGP` inherits ``predict`` and
``sample_y`` from :class:`PredictionMixin`. They read what ``fit`` leaves
(``likelihood_``, ``kernel_``, ``X_train_``, ``active_responses_`` and the
scales of the responses) and change none of it: the predictive moments in
internal units come from the likelihood's ``predict`` and
``expand_covariance`` (:mod:`skmba.gp._likelihood`), and are turned back
into the units of ``y`` here. Means and standard deviations are computed in
batches of points (:data:`PREDICT_BATCH_BYTES`); the joint covariance in
one piece, after a memory check.

Examples
--------
>>> import numpy as np
>>> from skmba.gp import MultiResponseGP
>>> X = np.linspace(0, 1, 10).reshape(-1, 1)
>>> gp = MultiResponseGP().fit(X, np.sin(4 * X[:, 0]))
>>> gp.sample_y([[0.5], [0.6]], n_samples=3).shape
(2, 3)
"""

import numpy as np
from sklearn.utils.validation import check_is_fitted, validate_data

from skmba._core.linalg import check_memory
from skmba._core.regression import regression_basis
from skmba._core.validation import Count, random_state_instance
from skmba._core.warn import warn

#: Mean and standard deviation are predicted in batches of points whose
#: cross-correlations with the training points (and the few arrays of that
#: size the prediction makes: PREDICT_ARRAYS in all) take at most this many
#: bytes.
PREDICT_BATCH_BYTES = 2**28
PREDICT_ARRAYS = 6


class PredictionMixin:
    """``predict`` and ``sample_y`` of a fitted
    :class:`~skmba.gp._estimator.MultiResponseGP`.

    A mixin rather than functions of the estimator: the methods are the
    estimator's own (documented with it, found by ``score``), and read the
    fitted state that its ``fit`` sets.
    """

    def _predict_internal(self, X, full_cov, n_copies=3):
        """Mean (s, q) and variance (s, q) or covariance (s, q, s, q), user units.

        ``n_copies`` is the number of (s q) x (s q) arrays the caller keeps
        alive at once with the joint covariance (memory check).
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False).astype(float, copy=False)
        s = len(X)
        q = self.active_responses_.size
        if full_cov:
            check_memory(
                8.0 * n_copies * (s * q) ** 2,
                f"The joint predictive covariance of {s} points x {q} responses "
                f"({s * q} x {s * q} entries, {n_copies} arrays)",
                "Request it for fewer points at a time, or use return_std=True "
                "for the marginal standard deviations (computed in batches).",
            )
            return self._predict_batch(X, True)
        n_train = len(self.X_train_)
        batch = max(1, int(PREDICT_BATCH_BYTES // (8 * n_train * PREDICT_ARRAYS)))
        if s <= batch:
            mean, var = self._predict_batch(X, False)
        else:
            parts = [
                self._predict_batch(X[i : i + batch], False) for i in range(0, s, batch)
            ]
            mean = np.concatenate([m for m, _ in parts])
            var = np.concatenate([v for _, v in parts])
        return mean, self._clip_variance(var)

    def _predict_batch(self, X, full_cov):
        """Moments at validated points ``X`` (one batch)."""
        s = len(X)
        q = self.active_responses_.size
        mean = np.tile(self._constant, (s, 1))
        cov = np.zeros((s, q, s, q)) if full_cov else np.zeros((s, q))
        state = self.likelihood_
        if state is not None:
            idx = np.flatnonzero(self.active_responses_)
            std = self._y_std[idx]
            r_cross = self.kernel_(self.X_train_, X)
            r_star = self.kernel_(X) if full_cov else self.kernel_.diag(X)
            h_star = regression_basis(X, self.regression)
            m, factors = state.predict(r_cross, h_star, r_star, full_cov)
            mean[:, idx] = m * std + self._y_mean[idx]
            c = state.expand_covariance(factors)
            if full_cov:
                cov[np.ix_(range(s), idx, range(s), idx)] = (
                    c * np.einsum("k,l->kl", std, std)[None, :, None, :]
                )
            else:
                cov[:, idx] = c * std**2
        return mean, cov

    @staticmethod
    def _clip_variance(var):
        negative = var < 0
        if np.any(var < -1e-8 * max(float(np.abs(var).max()), 1e-300)):
            warn(
                "Predicted variances smaller than 0 were set to 0: the "
                "correlation matrix is ill-conditioned. Consider a larger alpha.",
                UserWarning,
            )
        var[negative] = 0.0
        return var

    def _shape_output(self, array):
        """Drop the response axis when y was 1-D."""
        if self._y_ndim == 1:
            return array[:, 0] if array.ndim == 2 else array[:, 0, :, 0]
        return array

    def predict(self, X, return_std=False, return_cov=False):
        """Predict the latent process with the universal-kriging variance.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        return_std : bool, default=False
            Also return the predictive standard deviation: the
            universal-kriging one of the latent (noise-free) process,
            including the uncertainty of ``beta`` (Eqs. 3.33 and 3.40). Add
            ``noise_`` to the variance to predict a new noisy measurement.
        return_cov : bool, default=False
            Also return the joint predictive covariance. Its layout: for 1-D
            training ``y``, shape (n_samples, n_samples); for 2-D ``y``, shape
            (n_samples, q, n_samples, q) with ``cov[a, k, b, l] =
            Cov(y_k(x_a), y_l(x_b))`` (cross-response covariances included);
            ``cov.reshape(n_samples * q, -1)`` orders points slowest.

        Returns
        -------
        y_mean : ndarray of shape (n_samples,) or (n_samples, q)
        y_std : ndarray, same shape as ``y_mean``
            Only when ``return_std`` is True.
        y_cov : ndarray
            Only when ``return_cov`` is True.

        Raises
        ------
        MemoryError
            With ``return_cov=True``, before allocating, when the
            ``(n_samples q)^2`` covariance (and its temporaries) does not fit
            in the available memory. Means and standard deviations are
            computed in batches and need no such check.
        """
        if return_std and return_cov:
            raise RuntimeError(
                "At most one of return_std or return_cov can be requested."
            )
        mean, var = self._predict_internal(X, full_cov=return_cov)
        mean = self._shape_output(mean)
        if return_std:
            return mean, self._shape_output(np.sqrt(var))
        if return_cov:
            return mean, self._shape_output(var)
        return mean

    def sample_y(self, X, n_samples=1, random_state=0):
        """Draw joint samples of the latent process at ``X``.

        Parameters
        ----------
        X : array-like of shape (n_points, n_features)
        n_samples : int, default=1
        random_state : int, RandomState, Generator, SeedSequence or None, default=0
            Seeds the draws.

        Returns
        -------
        y_samples : ndarray of shape (n_points, n_samples) or (n_points, q, n_samples)
            Samples drawn from the joint predictive distribution, including
            the correlation between responses.

        Raises
        ------
        ValueError
            When ``n_samples`` is not a positive integer.
        MemoryError
            Before allocating, when the ``(n_points q)^2`` joint covariance,
            its eigenvectors and their scaled copy do not fit in the
            available memory.
        """
        if not Count().accepts(n_samples):
            raise ValueError(
                "n_samples must be a positive integer (the number of joint "
                f"draws), got {n_samples!r}; e.g. n_samples=1."
            )
        rng = random_state_instance(random_state)
        # covariance, its eigenvectors and their scaled copy
        mean, cov = self._predict_internal(X, full_cov=True, n_copies=4)
        s, q = mean.shape
        cov = cov.reshape(s * q, s * q)
        # eigh tolerates the positive semi-definite covariances of noise-free
        # GPs at training points, where a Cholesky would fail.
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        root = vectors * np.sqrt(np.clip(values, 0.0, None))
        draws = mean.ravel()[:, None] + root @ rng.standard_normal((s * q, n_samples))
        draws = draws.reshape(s, q, n_samples)
        return draws[:, 0, :] if self._y_ndim == 1 else draws
