"""Module 4 of the modular Bayesian approach: predictions over the posterior.

At each ``theta`` the model output, the discrepancy, their sum (the true process) and a
new observation are jointly Gaussian with all data (simulations and field data, thesis
Eqs. 4.33-4.45, with the global model of :mod:`skmba.calibration._module3_posterior`);
:func:`conditional_moments` gives their kriging moments from the block-whitened global
model. Averaged over the posterior of ``theta`` by the laws of total expectation and
variance (:func:`predict_component`), on a :class:`PredictionRule`: a quadrature rule
for one parameter, thinned MCMC draws otherwise.

Everything here is in standardised units.

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._module4_prediction import PredictionRule
>>> rule = PredictionRule.equal_weights(np.arange(10.0)[:, None], 5)
>>> rule.thetas.ravel(), rule.weights
(array([0., 2., 4., 6., 8.]), array([0.2, 0.2, 0.2, 0.2, 0.2]))
"""

import copy
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from scipy import linalg
from sklearn.utils.validation import check_is_fitted, validate_data

from skmba._core.linalg import (
    FLOAT_BYTES,
    FactorizationError,
    check_memory,
    kron_sum,
    n_workers,
    observed_rows,
)
from skmba._core.regression import regression_basis
from skmba._core.threads import BlasTask
from skmba._core.validation import seed_sequence
from skmba.calibration._field_data import (
    check_same_index,
    checked_field_y,
    measured_r2,
)
from skmba.calibration._module3_mixture import draw_weights_of
from skmba.mcmc._reweight import systematic_indices

COMPONENTS = ("model", "discrepancy", "reality", "observation")
_N_PREDICT_DRAWS = 200  # posterior draws used by the predictions (MCMC)
_N_PREDICT_NODES = 41  # quadrature nodes used by them (one parameter)
_PREDICT_CHUNK = 10  # posterior draws per task


@dataclass(frozen=True)
class PredictionRule:
    """Posterior values of theta (user units) and their weights.

    Attributes
    ----------
    thetas : ndarray of shape (m, r)
    weights : ndarray of shape (m,)
        Non-negative, summing to one.
    """

    thetas: np.ndarray
    weights: np.ndarray
    draws: np.ndarray | None = None  # module-2 draw per theta (None: the mode)

    @classmethod
    def equal_weights(cls, samples, n_draws=_N_PREDICT_DRAWS):
        """At most ``n_draws`` evenly thinned draws, equally weighted."""
        step = max(1, len(samples) // n_draws)
        thetas = samples[::step][:n_draws]
        return cls(thetas, np.full(len(thetas), 1.0 / len(thetas)))

    @classmethod
    def quadrature(cls, log_posterior, interval, n_nodes=_N_PREDICT_NODES):
        """Gauss-Legendre on ``interval`` weighted by the posterior density.

        A smaller rule than the posterior's own: each node costs a
        factorisation at prediction time.
        """
        lo, hi = interval
        x, v = np.polynomial.legendre.leggauss(n_nodes)
        nodes = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
        logp = log_posterior.batch(nodes[:, None])
        v = v * np.exp(logp - np.max(logp))
        return cls(nodes[:, None], v / v.sum())


def prediction_rule(
    posterior,
    log_posterior,
    random_state=None,
    with_draws=True,
    n_jobs=None,
    node_draw_weights=None,
    return_draw_weights=False,
):
    """The module-4 rule of a
    :class:`~skmba.mcmc._posterior.PosteriorResult`.

    Over a :class:`~skmba.calibration._module3_mixture.ModelMixture`, each ``theta`` of
    the rule comes with the module-2 draws ``phi_k``: every draw with its weight
    ``p(phi_k | theta, data)`` for a quadrature rule (draws below 1e-4 of their node's
    weight left out), one draw per ``theta`` picked with that probability (systematic
    sampling, seeded by ``random_state``) for MCMC and reweighted draws. MCMC's
    thetas are evenly thinned draws; reweighted ones are drawn from the weighted
    nodes (systematic resampling, the same seed). ``with_draws=False`` leaves the
    draws out (a rule that only integrates over theta, as the propagated module 2's
    first pass). The weights at the rule's thetas are computed in ``n_jobs`` joblib
    tasks, or read from ``node_draw_weights`` (M, K), the weights at a reweighted
    posterior's nodes when the reweighting computed them. ``return_draw_weights``
    also returns the rule's thetas and weights before the draws are picked, and the
    draws' weights there ((m, K); None without draws), from which
    :func:`~skmba.calibration._module3_mixture_error.mixture_errors` estimates the
    Monte Carlo error of the mixture over the draws.
    """
    mixture = log_posterior.model
    rng = np.random.default_rng(seed_sequence(random_state))
    at_nodes = None  # the rule's thetas as rows of a reweighted posterior's nodes
    if posterior.method == "quadrature":
        rule = PredictionRule.quadrature(log_posterior, posterior.interval)
    elif posterior.method == "reweighted":
        at_nodes = systematic_indices(posterior.weights, _N_PREDICT_DRAWS, rng)
        rule = PredictionRule.equal_weights(posterior.nodes[at_nodes])
    else:
        rule = PredictionRule.equal_weights(posterior.samples)
    if not with_draws:
        return (rule, rule, None) if return_draw_weights else rule
    if at_nodes is not None and node_draw_weights is not None:
        given = node_draw_weights[at_nodes]
    else:
        given = draw_weights_at(
            mixture, log_posterior.scaler.theta(rule.thetas), n_jobs
        )
    if posterior.method == "quadrature":
        keep = given >= 1e-4 * given.max(axis=1, keepdims=True)
        i, k = np.nonzero(keep)
        weights = rule.weights[i] * given[i, k]
        picked = PredictionRule(rule.thetas[i], weights / weights.sum(), k)
    else:
        u = (np.arange(len(given)) + rng.uniform()) / len(given)
        cdf = np.cumsum(given, axis=1)
        draws = (cdf < rng.permutation(u)[:, None]).sum(axis=1)
        picked = PredictionRule(
            rule.thetas, rule.weights, np.minimum(draws, cdf.shape[1] - 1)
        )
    return (picked, rule, given) if return_draw_weights else picked


def draw_weights_at(mixture, thetas, n_jobs=None):
    """``p(phi_k | theta, data)`` (m, K) at the rows of ``thetas``
    (standardised), evaluated together (in ``n_jobs`` joblib tasks); one by
    one (raising, saying why) when some theta has no draw that can be
    evaluated."""
    try:
        values = mixture.spread_component_log_likelihoods(thetas, n_jobs)
    except FactorizationError:
        values = None
    if values is None or not np.all(np.isfinite(values).any(axis=1)):
        return np.array([mixture.draw_weights(t) for t in thetas])
    return draw_weights_of(values)


def conditional_moments(model, theta, X, component, return_var=True, full=False):
    """Moments at ``X`` (s, d) given ``theta`` (standardised) and all data.

    Parameters
    ----------
    model : GlobalModel
    theta : ndarray of shape (r,)
    X : ndarray of shape (s, d)
    component : {"model", "discrepancy", "reality", "observation"}
        ``reality`` is the true process ``y_m + delta``; ``observation``
        adds the measurement noise (a new field measurement, Eq. 4.36).
    return_var : bool
        Also return the marginal variances.
    full : bool
        Return the joint covariance instead of the variances.

    Returns
    -------
    mean : ndarray of shape (s, q)
    var : ndarray of shape (s, q), or (s q, s q) when ``full``
        Only when ``return_var`` is True. The joint covariance orders its
        rows response-slowest (``k s + a`` for response ``k`` at ``X[a]``).
    """
    w = model.whiten(theta)
    q, s = model.q, len(X)
    with_model = component in ("model", "reality", "observation")
    with_delta = component in ("discrepancy", "reality", "observation")
    P_s = np.hstack([X, np.repeat(w.theta.reshape(1, -1), s, axis=0)])
    # Cross-covariances with the data, whitened block by block. The
    # simulations' block is L_A^-1 (Sigma_m ⊗ r_ms) = L_sm' ⊗ K_ms, used
    # through its Kronecker products and never formed: its products with the
    # residual, the regression and itself are q-by-q times N-by-s ones.
    P = model.P
    top_mean = np.zeros(s * q)
    top_regression = np.zeros((P, s * q))
    terms = []  # the field block's cross-covariance, sum of A ⊗ B
    h_m = np.zeros((s, model.p_m))
    h_d = np.zeros((s, model.p_d))
    prior_diag = np.zeros((s, q))
    K_ms = None
    if with_model:
        K_ms = linalg.solve_triangular(
            model.C_m, model.kernel_m(model.X_m, P_s), lower=True
        )
        resid = w.resid_top.reshape(q, model.N).T  # (N, q)
        top_mean = (K_ms.T @ resid @ model.L_sm.T).T.ravel()
        # X_top = L_sm^-1 ⊗ C_m^-1 H_m: its product is I ⊗ (C_m^-1 H_m)' K_ms.
        block = model.H_m_white.T @ K_ms
        top_regression[: model.p_m * q] = np.kron(np.eye(q), block)
        terms.append((model.sigma2_m, model.kernel_m(w.P_e, P_s) - w.Rt.T @ K_ms))
        h_m = regression_basis(P_s, model.regression_m)
        prior_diag += np.outer(model.kernel_m.diag(P_s), np.diag(model.sigma2_m))
    if with_delta:
        terms.append((model.sigma2_d, model.kernel_d(model.X_e, X)))
        h_d = regression_basis(X, model.regression_d)
        prior_diag += np.outer(model.kernel_d.diag(X), np.diag(model.sigma2_d))
    if component == "observation":
        prior_diag += model.noise
    bot = linalg.solve_triangular(
        w.L_S, observed_rows(kron_sum(*terms), model.observed), lower=True
    )
    h = np.hstack([np.kron(np.eye(q), h_m), np.kron(np.eye(q), h_d)])  # (sq, P)
    mean = h @ w.beta + top_mean + bot.T @ w.resid_bot
    mean = mean.reshape(q, s).T
    if not return_var:
        return mean
    U = h.T - top_regression - w.X_bot.T @ bot  # (P, sq)
    Ut = linalg.solve_triangular(w.G, U, trans="T")
    if full:
        # The model's prior less the simulations' reduction in one product:
        # Sigma_m ⊗ (R_m(P_s) - K_ms' K_ms).
        reduced = None if K_ms is None else model.kernel_m(P_s) - K_ms.T @ K_ms
        cov = _prior_covariance(model, reduced, X, with_delta, component)
        cov -= bot.T @ bot
        cov += Ut.T @ Ut
        return mean, 0.5 * (cov + cov.T)
    reduction = np.sum(bot**2, axis=0)
    if K_ms is not None:
        reduction += np.outer(np.diag(model.sigma2_m), np.sum(K_ms**2, axis=0)).ravel()
    var = prior_diag.T.ravel() - reduction + np.sum(Ut**2, axis=0)
    return mean, np.clip(var.reshape(q, s).T, 0.0, None)


def _prior_covariance(model, model_term, X, with_delta, component):
    """A component's covariance (s q, s q) at ``X``, response-slowest, from
    the model's correlation term ``model_term`` (s, s; None: no model) and the
    discrepancy's and noise's priors."""
    s, q = len(X), model.q
    terms = [] if model_term is None else [(model.sigma2_m, model_term)]
    if with_delta:
        terms.append((model.sigma2_d, model.kernel_d(X)))
    cov = kron_sum(*terms)
    if component == "observation":
        cov[np.diag_indices(s * q)] += np.repeat(model.noise, s)
    return cov


def _predict_chunk(models, thetas, Xs, component, return_std):
    """Conditional moments at several posterior draws (one task).

    A shallow copy gives the task its own factorisation cache, so that tasks
    sharing the model under a thread-based backend cannot see each other's.
    Run as a :class:`~skmba._core.threads.BlasTask` of the field block's order.
    """
    own = {}
    return [
        conditional_moments(
            own.setdefault(id(model), copy.copy(model)),
            theta,
            Xs,
            component,
            return_var=return_std,
        )
        for model, theta in zip(models, thetas, strict=True)
    ]


def predict_component(model, rule, Xs, component, *, return_std, n_jobs=None):
    """Posterior-averaged moments of a component at ``Xs`` (standardised).

    Parameters
    ----------
    model : ModelMixture
        The global model over module 2's draws; ``rule.draws`` picks one
        per theta.
    rule : PredictionRule
        Its ``thetas`` already standardised.
    Xs : ndarray of shape (s, d)
    component : {"model", "discrepancy", "reality", "observation"}
    return_std : bool
    n_jobs : int, default=None
        Posterior draws in parallel through joblib.

    Returns
    -------
    mean : ndarray of shape (s, q)
    var : ndarray of shape (s, q) or None
        Law of total variance over the posterior (Eqs. 4.34, 4.41).
    """
    thetas, w = rule.thetas, rule.weights
    if component == "observation":
        # A new observation is the reality plus noise independent of it:
        # its variance adds the noise variances' posterior mean (over the
        # module-2 hyperparameters, see ``model.predictive_noise``).
        mean, var = predict_component(
            model, rule, Xs, "reality", return_std=return_std, n_jobs=n_jobs
        )
        return mean, None if var is None else var + model.predictive_noise
    if rule.draws is None:  # a rule without draws: the module-2 mode
        models = [model.base] * len(thetas)
    else:
        models = [model.models[k] for k in rule.draws]
    s, q, n, N = len(Xs), model.q, model.n, model.N
    # Per posterior draw in flight: the (N q, s q) and (n q, s q)
    # whitened cross-covariances (and copies), the (N, s) kernels and
    # the (P, s q) regression terms; then the moments of all draws.
    per_draw = 2 * N * s + N * q * s * q + 3 * n * q * s * q + 3 * model.P * s * q
    needed = FLOAT_BYTES * (
        min(n_workers(n_jobs), len(thetas)) * per_draw + 5 * len(thetas) * s * q
    )
    check_memory(
        needed,
        f"The prediction at {s} points ({len(thetas)} posterior draws)",
        "Predict at fewer points per call (split X into batches of rows), "
        "or use a smaller n_jobs.",
    )
    task = BlasTask(_predict_chunk, n * q, n_jobs)
    with task.held():
        chunks = Parallel(n_jobs=n_jobs)(
            delayed(task)(
                models[i : i + _PREDICT_CHUNK],
                thetas[i : i + _PREDICT_CHUNK],
                Xs,
                component,
                return_std,
            )
            for i in range(0, len(thetas), _PREDICT_CHUNK)
        )
    results = [moments for chunk in chunks for moments in chunk]
    if not return_std:
        return np.tensordot(w, np.stack(results), axes=1), None
    means = np.stack([m for m, _ in results])
    variances = np.stack([v for _, v in results])
    mean = np.tensordot(w, means, axes=1)
    var = np.tensordot(w, variances, axes=1) + np.tensordot(
        w, (means - mean) ** 2, axes=1
    )
    return mean, var


def _covariance_chunk(models, thetas, weights, Xs, component):
    """The means of several posterior draws and their covariances' weighted sum."""
    own, means, total = {}, [], 0.0
    for model, theta, weight in zip(models, thetas, weights, strict=True):
        mean, cov = conditional_moments(
            own.setdefault(id(model), copy.copy(model)), theta, Xs, component, full=True
        )
        means.append(mean)
        total = total + weight * cov
    return means, total


def predict_covariance(model, rule, Xs, component, *, n_jobs=None):
    """Posterior-averaged mean and joint covariance of a component at ``Xs``.

    As :func:`predict_component`, with the law of total covariance over the
    rule: ``sum_k w_k (C_k + (m_k - m)(m_k - m)^T)``.

    Returns
    -------
    mean : ndarray of shape (s, q)
    cov : ndarray of shape (s q, s q)
        Response-slowest (row ``k s + a`` for response ``k`` at ``Xs[a]``).
    """
    if component == "observation":
        mean, cov = predict_covariance(model, rule, Xs, "reality", n_jobs=n_jobs)
        noise = np.broadcast_to(model.predictive_noise, (model.q,))
        return mean, cov + np.diag(np.repeat(noise, len(Xs)))
    thetas, w = rule.thetas, rule.weights
    if rule.draws is None:
        models = [model.base] * len(thetas)
    else:
        models = [model.models[k] for k in rule.draws]
    sq = len(Xs) * model.q
    check_memory(
        FLOAT_BYTES * (min(n_workers(n_jobs), len(thetas)) * 4 + 2) * sq * sq,
        f"The joint covariance at {len(Xs)} points",
        "Ask for it at fewer points per call.",
    )
    task = BlasTask(_covariance_chunk, model.n * model.q, n_jobs)
    with task.held():
        chunks = Parallel(n_jobs=n_jobs)(
            delayed(task)(
                models[i : i + _PREDICT_CHUNK],
                thetas[i : i + _PREDICT_CHUNK],
                w[i : i + _PREDICT_CHUNK],
                Xs,
                component,
            )
            for i in range(0, len(thetas), _PREDICT_CHUNK)
        )
    means = np.stack([m for chunk_means, _ in chunks for m in chunk_means])
    mean = np.tensordot(w, means, axes=1)
    spread = (means - mean).transpose(0, 2, 1).reshape(len(thetas), sq)
    cov = sum(c for _, c in chunks) + (spread.T * w) @ spread
    return mean, cov


class CalibratedPredictionMixin:
    """Module 4 as methods of :class:`~skmba.ModularBayesCalibrator`.

    The predictions of the observed process, the true process, the model
    and the discrepancy, each averaged over the posterior by
    :func:`predict_component`, from what the calibrator's ``fit`` stored:
    the global model ``global_model_``, the scaler and the module-4 rule.
    """

    def _predict_component(self, X, component, return_std, return_cov=False):
        check_is_fitted(self, "theta_mean_")
        if return_std and return_cov:
            raise RuntimeError(
                "At most one of return_std or return_cov can be requested."
            )
        X = validate_data(self, X, reset=False).astype(float)
        scaler, rule = self._scaler, self._prediction_rule
        rule = PredictionRule(scaler.theta(rule.thetas), rule.weights, rule.draws)
        if return_cov:
            mean, cov = predict_covariance(
                self.global_model_, rule, scaler.x(X), component, n_jobs=self.n_jobs
            )
            std = None
        else:
            mean, var = predict_component(
                self.global_model_,
                rule,
                scaler.x(X),
                component,
                return_std=return_std,
                n_jobs=self.n_jobs,
            )
            std = None if var is None else np.sqrt(var) * scaler.y_scale
        mean = scaler.y_to_user(mean, centred=component != "discrepancy")
        if self._y_ndim == 1:
            mean = mean[:, 0]
            std = None if std is None else std[:, 0]
        if return_cov:
            return mean, self._user_covariance(cov, len(X))
        return mean if std is None else (mean, std)

    def _user_covariance(self, cov, s):
        """A response-slowest covariance (s q, s q) in user units: (s, q, s, q),
        or (s, s) for a 1-D ``y``."""
        scale = np.asarray(self._scaler.y_scale, dtype=float)
        q = len(scale)
        cov = cov.reshape(q, s, q, s).transpose(1, 0, 3, 2)
        cov = cov * scale[None, :, None, None] * scale[None, None, None, :]
        return cov[:, 0, :, 0] if self._y_ndim == 1 else cov

    def predict(self, X, return_std=False, return_cov=False):
        """Calibrated prediction of a new field measurement (module 4).

        The mean and standard deviation of ``y_e(x) = y_m(x, theta) + delta(x)
        + eps`` averaged over the posterior of ``theta`` (laws of total
        expectation and variance, Eqs. 4.35-4.41); the standard deviation
        includes the measurement noise.

        Parameters
        ----------
        X : array-like of shape (s, d)
        return_std : bool, default=False
        return_cov : bool, default=False
            Return the joint covariance instead (law of total covariance over
            the posterior). Its layout is :class:`~skmba.MultiResponseGP`'s:
            (s, s) for a 1-D ``y``, else (s, q, s, q) with ``cov[a, k, b, l]
            = Cov(y_k(x_a), y_l(x_b))``. Its size, ``(s q)^2``, is checked
            against the free memory before it is allocated.

        Returns
        -------
        mean : ndarray of shape (s,) or (s, q)
        std : ndarray, same shape (only when ``return_std``)
        cov : ndarray (only when ``return_cov``)
        """
        return self._predict_component(X, "observation", return_std, return_cov)

    def predict_reality(self, X, return_std=False, return_cov=False):
        """Prediction of the true process ``y_m(x, theta) + delta(x)`` (no noise).

        ``return_std`` and ``return_cov`` as in :meth:`predict`.
        """
        return self._predict_component(X, "reality", return_std, return_cov)

    def predict_model(self, X, return_std=False, return_cov=False):
        """Prediction of the model output ``y_m(x, theta)`` over the posterior.

        Conditional on all data (simulations and field data) at each
        ``theta``, then averaged over the posterior (Eqs. 4.33-4.34).
        ``return_std`` and ``return_cov`` as in :meth:`predict`.
        """
        return self._predict_component(X, "model", return_std, return_cov)

    def predict_discrepancy(self, X, return_std=False, return_cov=False):
        """Prediction of the discrepancy ``delta(x)`` over the posterior.

        The conditional moments of ``delta`` given all data at each
        ``theta`` (Eqs. 4.42-4.43, with the global model), averaged over the
        posterior. ``predict_model + predict_discrepancy`` equals
        :meth:`predict_reality` in the mean. ``return_std`` and
        ``return_cov`` as in :meth:`predict`.
        """
        return self._predict_component(X, "discrepancy", return_std, return_cov)

    def score(self, X, y, sample_weight=None):
        """R² of :meth:`predict` on ``y``, over the measured entries.

        scikit-learn's ``r2_score`` averaged uniformly over the responses;
        NaN in ``y`` (readings not taken) are left out response by response,
        so that field data with gaps can be scored.

        Parameters
        ----------
        X : array-like of shape (s, d)
        y : array-like of shape (s,) or (s, q)
        sample_weight : array-like of shape (s,), default=None

        Returns
        -------
        float
        """
        check_same_index(X, y)
        y = checked_field_y(y)
        pred = np.asarray(self.predict(X), dtype=float).reshape(len(y), -1)
        return measured_r2(y.reshape(len(y), -1), pred, sample_weight)
