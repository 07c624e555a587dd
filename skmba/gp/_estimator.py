"""Multi-response Gaussian process regression (thesis chapter 3).

:class:`MultiResponseGP` is the estimator: its parameters, ``fit`` and
``log_marginal_likelihood``; :func:`default_kernel` is its kernel when none
is given (the calibration modules use it too). ``predict`` and ``sample_y``
come from :mod:`skmba.gp._predict`; the likelihood and predictive moments
are in :mod:`skmba.gp._likelihood`, the hyperparameter search and the
nugget escalation in :mod:`skmba.gp._search` (its L-BFGS-B runs in
:mod:`skmba.gp._lbfgsb`), the noisy fit in
:mod:`skmba.gp._noisy` and the checks of the training data in
:mod:`skmba.gp._checks`.

Examples
--------
>>> import numpy as np
>>> from skmba.gp._estimator import MultiResponseGP, default_kernel
>>> X = np.linspace(0, 1, 10).reshape(-1, 1)
>>> gp = MultiResponseGP(default_kernel(X)).fit(X, np.sin(4 * X[:, 0]))
>>> gp.predict([[0.5]]).shape
(1,)
"""

from contextlib import contextmanager
from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, clone
from sklearn.gaussian_process.kernels import Kernel
from sklearn.utils.validation import check_is_fitted, validate_data

from skmba._core.columns import column_names
from skmba._core.regression import REGRESSIONS, n_regression_terms, regression_basis
from skmba._core.threads import blas_threads
from skmba._core.validation import (
    Boolean,
    Callable,
    Count,
    InstanceOf,
    Options,
    Real,
    validate_parameter_table,
)
from skmba._core.warn import warn
from skmba.gp._checks import (
    check_covariance_size,
    check_fit_memory,
    check_magnitudes,
    check_rows,
    check_sample_size,
    warn_at_bounds,
)
from skmba.gp._likelihood import NoiseFreeLikelihood, NoisyLikelihood
from skmba.gp._noisy import fit_noisy, noise_bounds
from skmba.gp._predict import PredictionMixin
from skmba.gp._search import (
    LikelihoodProblem,
    correlation,
    fit_noise_free,
    subsample_warm_start,
)
from skmba.kernels import Gauss, check_correlation


def default_kernel(X):
    """Anisotropic Gauss correlation scaled to the spread of ``X``.

    The starting roughness is ``10 / range_j^2`` per input (correlation
    ``exp(-1)`` across a third of the range), with bounds ``1e-4 /
    range_j^2`` to ``1e4 / range_j^2``. Measurements and rejected variants:
    docs/internals.rst, section skmba.gp._estimator.

    Examples
    --------
    >>> import numpy as np
    >>> default_kernel(np.array([[0.0, 0.0], [2.0, 10.0]]))
    Gauss(roughness=[2.5, 0.1])
    """
    span = np.ptp(X, axis=0)
    span = np.where(span > 0, span, 1.0)
    unit = 1.0 / span**2
    return Gauss(
        roughness=10.0 * unit,
        roughness_bounds=np.column_stack([1e-4 * unit, 1e4 * unit]),
    )


class MultiResponseGP(PredictionMixin, MultiOutputMixin, RegressorMixin, BaseEstimator):
    """Multi-response Gaussian process with covariance ``Sigma2 ⊗ R``.

    The ``q`` responses share one correlation ``R(omega)`` over the inputs and
    have a full ``q x q`` covariance ``Sigma2`` (thesis Eq. 3.7), optional
    per-response noise ``Lambda`` (Eq. 3.35) and a polynomial mean
    ``H(x) beta`` (Table 3.1)::

        vec(Y) ~ N((I_q ⊗ H) vec(beta), Sigma2 ⊗ (R + alpha I) [+ Lambda ⊗ I])

    ``beta`` is the generalised least-squares estimate; without noise
    ``Sigma2`` is concentrated out (``E' R^-1 E / N``, Eq. 4.6), so one
    ``N x N`` Cholesky serves any ``q``; with noise ``Sigma2`` and ``Lambda``
    are estimated jointly through a Kronecker eigendecomposition
    (``O(N^3 + q^3)``). The kernel hyperparameters maximise the likelihood,
    with analytic gradients and restarts. Above 2000 samples the search and
    its restarts run first on 1000 samples drawn with ``random_state``, and
    the full-size search starts once from that optimum (fewer ``N x N``
    factorisations).

    Read more in the :ref:`User Guide <user-guide-gp>`.

    Parameters
    ----------
    kernel : sklearn Kernel, default=None
        Correlation function: any kernel with unit diagonal, e.g. the DACE
        families of :mod:`skmba.kernels` or sklearn's ``RBF``/``Matern`` and
        products of them. ``None`` uses an anisotropic :class:`~skmba.kernels.Gauss`
        whose starting roughness is ``10 / range_j^2`` per input with bounds
        ``1e-4 / range_j^2`` to ``1e4 / range_j^2``, so that raw inputs in
        any units start alike. Variances are not part of the kernel: they
        are ``sigma2_`` (and ``noise_``). A fitted kernel hyperparameter on
        a bound of its search gives a ``ConvergenceWarning``.
    regression : {"constant", "linear", "quadratic"}, default="constant"
        Polynomial mean (regpoly0/1/2).
    noise : bool, default=False
        Estimate one noise variance per response (``noise_``), searched
        between 1e-8 and 10 times the response's variance. Without it the
        GP interpolates the training data (deterministic simulators). A
        noise variance on a bound gives a ``ConvergenceWarning``: at the
        lower bound the data look noise-free for that response (consider
        ``noise=False``).
    alpha : float, default=1e-10
        Nugget added to the diagonal of the correlation matrix, in units of
        correlation (i.e. as a fraction of the process variance). When the
        correlation matrix is numerically singular (many close points, very
        smooth kernels) it is raised automatically, at most to 1e-6, with a
        warning (:ref:`gp-nugget-escalation`); the value used is ``nugget_``.
        A value above 1e-6 is used as given.
    optimizer : "fmin_l_bfgs_b", callable or None, default="fmin_l_bfgs_b"
        As in sklearn's ``GaussianProcessRegressor``: a callable is called as
        ``optimizer(obj_func, initial_theta, bounds)`` and returns
        ``(theta_opt, func_min)``; ``obj_func(theta, eval_gradient=True)``
        returns the negative log-likelihood and its gradient. With ``None``
        the kernel is kept fixed; ``Sigma2`` and ``noise_`` are still
        estimated (with L-BFGS-B when ``noise=True``).
    n_restarts_optimizer : int, default=0
        Number of extra starts, drawn log-uniformly within a factor 100 of
        the kernel's starting hyperparameters (and within their bounds), and
        within the noise bounds.
    normalize_y : bool, default=True
        Standardise each response (mean and standard deviation) internally.
        All fitted attributes and predictions are in the units of ``y``. The
        model does not depend on it (it is equivariant to shifting and
        scaling each response) except through ``response_nugget``; with
        False each response is only scaled by a power of two (exact), the
        one nearest to its standard deviation.
        Responses that are constant are predicted exactly (zero variance)
        and take no part in the likelihood.
    random_state : int, RandomState, Generator, SeedSequence or None, default=None
        Seeds the restarts and the subsample of large fits (and nothing
        else).
    response_nugget : float, default=0.0
        Added to the diagonal of the estimated ``Sigma2``, as a fraction of the
        mean response variance. Without noise, responses that are exact
        linear combinations of others (strains driven by one load, a
        displacement and a rotation of the same beam) make ``E' R^-1 E``
        singular; a small nugget (e.g. 1e-8) lets them be emulated jointly.

    Attributes
    ----------
    kernel_ : sklearn Kernel
        The kernel with the fitted hyperparameters.
    beta_ : ndarray of shape (p, q)
        Regression coefficients in the units of ``y`` (``p`` basis terms of
        ``regression`` in the order of Eq. 3.2).
    sigma2_ : ndarray of shape (q, q)
        Cross-response process covariance, in squared units of ``y``.
    noise_ : ndarray of shape (q,)
        Noise variance of each response (only when ``noise=True``).
    log_marginal_likelihood_value_ : float
        The maximised log-likelihood of ``y`` (in its own units), with ``beta``
        at its GLS estimate and, without noise, ``Sigma2`` concentrated out;
        ``+inf`` when every response is constant (predicted exactly).
    nugget_ : float
        The nugget actually used: ``alpha``, or the escalated value when the
        correlation matrix was numerically singular
        (:ref:`gp-nugget-escalation`).
    active_responses_ : ndarray of bool of shape (q,)
        Which responses vary, and so take part in the likelihood; the others
        are constant and predicted exactly.
    likelihood_ : object or None
        The factorised likelihood at the fitted hyperparameters, in internal
        units (the active responses, standardised), which the calibration
        modules reuse. It offers ``log_likelihood``, ``beta`` and
        ``sigma2``; its factors (without noise the Cholesky factor ``C`` of
        the correlation matrix and the generalised least squares ``gls``,
        with noise the Kronecker eigendecomposition ``ke``); and the
        predictive equations ``predict(r_cross, h_star, r_star, full_cov)``
        and ``expand_covariance(factors)``. None when every response is
        constant.
    X_train_ : ndarray of shape (N, d)
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when ``X`` has feature names.
    response_names_ : list of str or None
        The column names of ``y`` when it is a pandas DataFrame, else None
        (:func:`skmba.plotting.plot_gp_prediction` labels the responses by
        them).

    See Also
    --------
    sklearn.gaussian_process.GaussianProcessRegressor : one variance per
        fit, independent outputs.
    ModularBayesCalibrator : uses it to emulate the model and to model the
        discrepancy.
    skmba.kernels : the DACE correlation families.

    References
    ----------
    Thesis chapter 3 and appendix C; Lophaven, Nielsen and Søndergaard (2002),
    DACE: a Matlab kriging toolbox.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba import MultiResponseGP
    >>> X = np.linspace(0, 1, 12).reshape(-1, 1)
    >>> y = np.column_stack([np.sin(4 * X[:, 0]), np.cos(4 * X[:, 0])])
    >>> gp = MultiResponseGP().fit(X, y)
    >>> gp.sigma2_.shape, gp.beta_.shape
    ((2, 2), (1, 2))
    >>> mean, std = gp.predict([[0.55]], return_std=True)
    >>> bool(np.allclose(mean, [[np.sin(2.2), np.cos(2.2)]], atol=1e-3))
    True
    >>> bool(np.all(std < 1e-2))
    True
    """

    _parameter_table: ClassVar[dict] = {
        "kernel": [
            InstanceOf(
                Kernel,
                what="an sklearn Kernel",
                hint="e.g. skmba.kernels.Gauss()",
                allow_none=True,
            )
        ],
        "regression": [Options(REGRESSIONS, hint="thesis Table 3.1")],
        "noise": [Boolean()],
        "alpha": [Real(minimum=0, hint="the nugget, e.g. 1e-10")],
        "optimizer": [Options(("fmin_l_bfgs_b",), allow_none=True), Callable()],
        "n_restarts_optimizer": [Count(minimum=0)],
        "normalize_y": [Boolean()],
        "random_state": "no_validation",  # check_random_state, in fit
        "response_nugget": [Real(minimum=0, hint="e.g. 1e-8")],
    }

    def __init__(
        self,
        kernel=None,
        *,
        regression="constant",
        noise=False,
        alpha=1e-10,
        optimizer="fmin_l_bfgs_b",
        n_restarts_optimizer=0,
        normalize_y=True,
        random_state=None,
        response_nugget=0.0,
    ):
        self.kernel = kernel
        self.regression = regression
        self.noise = noise
        self.alpha = alpha
        self.optimizer = optimizer
        self.n_restarts_optimizer = n_restarts_optimizer
        self.normalize_y = normalize_y
        self.random_state = random_state
        self.response_nugget = response_nugget

    # ------------------------------------------------------------------ fit
    def fit(self, X, y):
        """Fit the Gaussian process by maximum likelihood.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,) or (n_samples, n_responses)

        Returns
        -------
        self : MultiResponseGP

        Raises
        ------
        ValueError
            On invalid data or parameters (see :ref:`gp-input-checks`); a
            ``FactorizationError`` (a ``numpy.linalg.LinAlgError``, so a
            ``ValueError``) when a matrix cannot be factored even after the
            nugget escalation.
        TypeError
            On parameters of the wrong type.
        MemoryError
            Before allocating, when the ``N x N`` matrices do not fit in the
            available memory.

        After a failed fit the estimator is unfitted (any previous fit is
        discarded), so that it cannot mix old and new state.
        """
        with self._fitting(X):
            return self._fit(X, y)

    def _fit_reporting(self, X, y, on_start):
        """:meth:`fit`, calling ``on_start(k, n, fun)`` after each start of
        the likelihood search (see
        :class:`~skmba.gp._search.LikelihoodProblem`): the emulator's
        progress bar (:func:`~skmba.calibration._module1_emulator.fit_emulator`)."""
        with self._fitting(X):
            return self._fit(X, y, on_start)

    @contextmanager
    def _fitting(self, X):
        """BLAS threads by the number of samples; after a failure, no
        fitted state.

        A context manager rather than a wrapper: :meth:`fit` and
        :meth:`_fit_reporting` share it.
        """
        # The package's thread policy (skmba._core.threads): one BLAS thread for
        # smaller designs, all the process's threads from SMALL_ORDER samples
        # on, where the N x N factorisations dominate (measurements:
        # docs/internals.rst, section skmba._core.threads).
        with blas_threads(len(X) if hasattr(X, "__len__") else 0):
            try:
                yield
            except BaseException:
                # No mix of a previous fit and a failed one: unfitted, so
                # predict raises NotFittedError instead of answering wrongly.
                params = self.get_params(deep=False)
                for name in [k for k in vars(self) if k not in params]:
                    delattr(self, name)
                raise

    def _fit(self, X, y, on_start=None):
        validate_parameter_table(
            self._parameter_table, self.get_params(deep=False), type(self).__name__
        )
        names = column_names(y)
        X, Y = self._validate_training_data(X, y)
        self.response_names_ = names
        n = X.shape[0]
        kernel, H, p = self._check_design(X, Y)
        self.X_train_ = X
        self._H = H
        self.nugget_ = float(self.alpha)
        Ya = self._standardise(Y)
        q = Ya.shape[1]
        self._ridge = (
            self.response_nugget * float(np.mean(Ya.var(axis=0))) if q else 0.0
        )
        if not self.noise and self._ridge == 0:
            check_covariance_size(n, q, p, self.regression)

        if q == 0:
            self._fit_constant(kernel)
        else:
            self._fit_hyperparameters(X, H, Ya, kernel, on_start)
        self._set_user_attributes(Y.shape[1], p)
        return self

    def _check_design(self, X, Y):
        """The checks of the training data that come before any fitting.

        Returns the kernel to fit (a clone of ``kernel``, or the default),
        the regression matrix ``H`` and its number of terms ``p``.
        """
        n, d = X.shape
        check_magnitudes(X, Y)
        p = n_regression_terms(self.regression, d)
        check_sample_size(n, d, p, self.regression)
        H = regression_basis(X, self.regression)
        check_rows(X, Y, H, self.regression, self.noise)
        kernel = default_kernel(X) if self.kernel is None else clone(self.kernel)
        check_correlation(kernel, X)
        check_fit_memory(kernel, n, self.noise)
        return kernel, H, p

    def _fit_constant(self, kernel):
        """Every response is constant: nothing to fit, all predicted exactly."""
        warn(
            "All responses are constant: the GP predicts them exactly and "
            "the kernel is not fitted.",
            UserWarning,
        )
        self.kernel_ = kernel
        self.likelihood_ = None
        self.log_marginal_likelihood_value_ = np.inf

    def _fit_hyperparameters(self, X, H, Ya, kernel, on_start):
        """Maximise the likelihood of the standardised active responses
        ``Ya``; warn when a hyperparameter ends on a bound of its search."""
        problem = LikelihoodProblem(
            X,
            H,
            Ya,
            nugget=self.nugget_,
            alpha=self.alpha,
            ridge=self._ridge,
            optimizer=self.optimizer,
            n_restarts=self.n_restarts_optimizer,
            random_state=self.random_state,
            on_start=on_start,
        )
        fit_path = fit_noisy if self.noise else fit_noise_free
        kernel, problem = subsample_warm_start(problem, kernel, fit_path)
        self.kernel_, self.likelihood_ = fit_path(problem, kernel)
        self.nugget_ = problem.nugget
        noise = None
        if self.noise:  # in the units of y
            variance = self._y_std[self.active_responses_] ** 2
            noise = (
                np.flatnonzero(self.active_responses_),
                self.likelihood_.ke.lam * variance,
                noise_bounds(Ya) * variance[:, None],
            )
        searched = self.kernel_ if self.optimizer is not None else None
        warn_at_bounds(searched, noise=noise)

    def _validate_training_data(self, X, y):
        """sklearn's checks; X as float and y as an (n, q) float array."""
        y_ndim = np.asarray(y).ndim
        if y_ndim > 2:
            raise ValueError(
                f"y has {y_ndim} dimensions; pass y of shape (n_samples,) or "
                "(n_samples, n_responses)."
            )
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True)
        X = X.astype(float, copy=False)
        self._y_ndim = y.ndim
        return X, np.asarray(y, dtype=float).reshape(len(y), -1)

    def _standardise(self, Y):
        """The active responses of ``Y`` in internal units (Appendix C.2).

        Constant responses are set aside (``active_responses_``) and
        predicted exactly.
        """
        spread = np.ptp(Y, axis=0)
        active = spread > 1e-12 * np.maximum(np.abs(Y).max(axis=0), 1e-300)
        self.active_responses_ = active
        self._constant = Y[0].copy()
        # scaled by the peak first: no underflow of tiny responses' squares
        peak = np.abs(Y).max(axis=0)
        peak = np.where(peak > 0, peak, 1.0)
        std = (Y / peak).std(axis=0) * peak
        if self.normalize_y:
            self._y_mean = Y.mean(axis=0)
            self._y_std = np.where(active, std, 1.0)
        else:
            # Power-of-two scales: exact in floating point, they leave the
            # model unchanged (it is equivariant to rescaling each response)
            # and keep the squares of huge or tiny responses within float64.
            self._y_mean = np.zeros(Y.shape[1])
            with np.errstate(divide="ignore"):
                exponent = np.round(np.log2(std))
            self._y_std = np.where(active, 2.0**exponent, 1.0)
        self._Y = ((Y - self._y_mean) / self._y_std)[:, active]
        return self._Y

    def _set_user_attributes(self, q_total, p):
        """Fitted attributes in the units of y (constant responses exact)."""
        active, std, mean = self.active_responses_, self._y_std, self._y_mean
        beta = np.zeros((p, q_total))
        sigma2 = np.zeros((q_total, q_total))
        beta[0, ~active] = self._constant[~active]
        state = self.likelihood_
        if state is not None:
            beta[:, active] = state.beta * std[active]
            beta[0, active] += mean[active]
            idx = np.flatnonzero(active)
            sigma2[np.ix_(idx, idx)] = state.sigma2 * np.outer(std[idx], std[idx])
            self.log_marginal_likelihood_value_ = float(
                state.log_likelihood - len(self.X_train_) * np.sum(np.log(std[idx]))
            )
        self.beta_ = beta
        self.sigma2_ = sigma2
        if self.noise:
            noise = np.zeros(q_total)
            if state is not None:
                noise[active] = state.ke.lam * std[active] ** 2
            self.noise_ = noise

    def log_marginal_likelihood(
        self, theta=None, eval_gradient=False, clone_kernel=True
    ):
        """Log-likelihood of the training responses for kernel hyperparameters.

        Parameters
        ----------
        theta : array-like of shape (n_kernel_params,), default=None
            Log-transformed kernel hyperparameters (``kernel_.theta``). None
            returns ``log_marginal_likelihood_value_``. Without noise,
            ``beta`` and ``Sigma2`` are concentrated out (profile likelihood);
            with ``noise=True`` they are held at ``beta``'s GLS estimate and the
            fitted ``sigma2_`` and ``noise_``.
        eval_gradient : bool, default=False
            Also return the gradient with respect to ``theta``.
        clone_kernel : bool, default=True
            Accepted for compatibility with sklearn; the fitted kernel is
            never modified.

        Returns
        -------
        log_likelihood : float
        log_likelihood_gradient : ndarray of shape (n_kernel_params,)
            Only when ``eval_gradient`` is True.
        """
        check_is_fitted(self)
        if theta is None:
            if eval_gradient:
                raise ValueError("Gradient can only be evaluated for theta!=None")
            return self.log_marginal_likelihood_value_
        if self.likelihood_ is None:
            raise ValueError(
                "All responses are constant: the likelihood does not depend on "
                "the kernel."
            )
        theta = np.asarray(theta, dtype=float)
        if theta.shape != self.kernel_.theta.shape or not np.all(np.isfinite(theta)):
            raise ValueError(
                f"theta must be a finite array of shape {self.kernel_.theta.shape} "
                "(the log-hyperparameters kernel_.theta), got shape "
                f"{theta.shape}."
            )
        kernel = self.kernel_.clone_with_theta(theta)
        R, dR = correlation(kernel, self.X_train_, self.nugget_, eval_gradient)
        if self.noise:
            state = self.likelihood_
            fit = NoisyLikelihood(R, self._H, self._Y, state.sigma2, state.ke.lam, dR)
            grad = fit.grad_kernel
        else:
            fit = NoiseFreeLikelihood(R, self._H, self._Y, dR, ridge=self._ridge)
            grad = fit.gradient
        shift = len(self.X_train_) * np.sum(np.log(self._y_std[self.active_responses_]))
        value = fit.log_likelihood - shift
        return (value, grad) if eval_gradient else value
