"""Multi-response Gaussian process regression (thesis chapter 3)."""

import warnings
from numbers import Integral, Real
from typing import NamedTuple

import numpy as np
from scipy import optimize
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process.kernels import Kernel
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted, validate_data
from threadpoolctl import threadpool_limits

from skmba._likelihood import (
    R_REMEDY,
    R_WHAT,
    NoiseFreeLikelihood,
    NoisyLikelihood,
    maximise_noise_and_sigma2,
)
from skmba._linalg import (
    FactorizationError,
    check_memory,
    smallest_pivot,
    symmetric_eigh,
)
from skmba._regression import check_regression, n_regression_terms, regression_basis
from skmba.kernels import Gauss, _DACECorrelation, check_correlation

# Noise variances, relative to each response's variance, and tau (noise to
# signal ratio of the proportional-noise start) stay within these log bounds.
_LOG_NOISE_BOUNDS = (np.log(1e-8), np.log(10.0))
# Inner maximisation over (Sigma2, Lambda) of the noisy fit: at most this
# many Levenberg-Marquardt (Fisher scoring) iterations, stopping below this
# relative gain.
_MAX_SCORING_STEPS = 200
_SCORING_TOL = 1e-12
# Nugget escalation for numerically singular correlation matrices: the nugget
# is multiplied by _NUGGET_GROWTH (starting from _FIRST_NUGGET when alpha=0),
# never beyond _MAX_ALPHA (in units of the process variance, i.e. of the
# standardised responses).
_NUGGET_GROWTH = 10.0
_FIRST_NUGGET = 1e-12
_MAX_ALPHA = 1e-6
# A Cholesky factor whose smallest pivot is within this factor of
# max(nugget, N eps) is held positive definite by the nugget (or rounding)
# alone.
_PIVOT_MARGIN = 100.0
# An L-BFGS-B line search that fails with a projected gradient below this
# fraction of (1 + |log-likelihood|) stopped at the rounding floor of the
# likelihood (nearly singular R), not away from the optimum.
_FLAT_GRADIENT = 1e-4
# Inputs and responses beyond this magnitude overflow float64 when squared.
_MAX_MAGNITUDE = 1e150
# Mean and standard deviation are predicted in batches of points whose
# cross-correlations with the training points take at most this many bytes.
_PREDICT_BATCH_BYTES = 2**28


def default_kernel(X):
    """Anisotropic Gauss correlation scaled to the spread of ``X``.

    The starting roughness is ``1 / range_j^2`` per input (correlation
    ``exp(-1)`` across the full range), with bounds ``1e-4`` to ``1e4`` times
    that.

    Examples
    --------
    >>> import numpy as np
    >>> default_kernel(np.array([[0.0, 0.0], [2.0, 10.0]]))
    Gauss(roughness=[0.25, 0.01])
    """
    span = np.ptp(X, axis=0)
    span = np.where(span > 0, span, 1.0)
    start = 1.0 / span**2
    return Gauss(
        roughness=start,
        roughness_bounds=np.column_stack([1e-4 * start, 1e4 * start]),
    )


class _Search(NamedTuple):
    """Outcome of :meth:`MultiResponseGP._run_optimizer`."""

    x: np.ndarray | None
    failures: list
    notes: list
    flat: bool | None


def _next_nugget(nugget):
    """The next nugget of the escalation, or None beyond ``_MAX_ALPHA``."""
    if nugget >= _MAX_ALPHA * (1.0 - 1e-9):
        return None
    return min(max(nugget * _NUGGET_GROWTH, _FIRST_NUGGET), _MAX_ALPHA)


def _projected_gradient(res, bounds):
    """Gradient of an L-BFGS-B result with the components blocked by a bound
    removed (those at a bound that point out of the box)."""
    grad = np.asarray(res.jac, dtype=float)
    x = np.asarray(res.x, dtype=float)
    lower = x <= bounds[:, 0] + 1e-10 * (1.0 + np.abs(bounds[:, 0]))
    upper = x >= bounds[:, 1] - 1e-10 * (1.0 + np.abs(bounds[:, 1]))
    blocked = (lower & (grad > 0)) | (upper & (grad < 0))
    return np.where(blocked, 0.0, grad)


def _check_magnitudes(X, Y):
    """Refuse values whose squares overflow or underflow float64."""
    for name, A, remedy in (
        (
            "X",
            X,
            "Rescale the inputs, e.g. with sklearn.preprocessing.StandardScaler "
            "in a Pipeline.",
        ),
        (
            "y",
            Y,
            "Express the responses in other units (divide y by a constant); "
            "sigma2_ is in squared units of y.",
        ),
    ):
        peak = float(np.max(np.abs(A))) if A.size else 0.0
        if peak > _MAX_MAGNITUDE:
            raise ValueError(
                f"{name} has values up to {peak:.3g} in magnitude, beyond "
                f"{_MAX_MAGNITUDE:.0e}: their squares overflow float64. {remedy}"
            )
    for name, A, effect, remedy in (
        (
            "X column(s)",
            X,
            "the kernel roughness for them overflows float64",
            "Rescale the inputs, e.g. with sklearn.preprocessing.StandardScaler "
            "in a Pipeline, or drop the columns.",
        ),
        (
            "Response(s)",
            Y,
            "their variances underflow float64",
            "Express the responses in other units (multiply y by a constant).",
        ),
    ):
        span = np.ptp(A, axis=0)
        tiny = (span > 0) & (span < 1.0 / _MAX_MAGNITUDE)
        if np.any(tiny):
            raise ValueError(
                f"{name} {np.flatnonzero(tiny).tolist()} vary by less than "
                f"{1.0 / _MAX_MAGNITUDE:.0e} (range {span[tiny].min():.3g}): "
                f"{effect}. {remedy}"
            )


def _check_regression_rank(X, H, regression):
    """ValueError naming the cause when the regression terms are not identifiable."""
    p = H.shape[1]
    scaled = H / np.maximum(np.abs(H).max(axis=0), np.finfo(float).tiny)
    singular = np.linalg.svd(scaled, compute_uv=False)
    rank = int(np.sum(singular > 1e-10 * singular[0]))
    if rank == p:
        return
    constant = np.flatnonzero(np.ptp(X, axis=0) == 0)
    if regression != "constant" and constant.size:
        cause = (
            f"X column(s) {constant.tolist()} are constant, so their "
            f"{regression} terms duplicate the intercept"
        )
    else:
        n_distinct = len(np.unique(X, axis=0))
        cause = (
            f"its {p} terms have rank {rank} on these inputs ({n_distinct} "
            "distinct rows of X; collinear columns also cause this)"
        )
    raise ValueError(
        f"regression={regression!r} cannot be estimated: {cause}. Use a "
        "lower-order regression ('constant' needs only distinct inputs), drop "
        "constant or collinear columns of X, or add distinct input points."
    )


class MultiResponseGP(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """Multi-response Gaussian process with covariance ``Sigma2 ⊗ R``.

    The ``q`` responses share one correlation ``R(omega)`` over the inputs and
    have a full ``q x q`` covariance ``Sigma2`` (thesis Eq. 3.7), optional
    per-response noise ``Lambda`` (Eq. 3.35) and a polynomial mean
    ``H(x) beta`` (Table 3.1)::

        vec(Y) ~ N((I_q ⊗ H) vec(beta), Sigma2 ⊗ (R + alpha I) [+ Lambda ⊗ I])

    Given the roughness ``omega``, ``beta`` is the generalised least-squares
    estimate. Without noise, ``Sigma2 = E' R^-1 E / N`` (the
    maximum-likelihood estimate, Eq. 4.6, rather than the ``1/(N - p)`` of
    Eq. 3.18) is concentrated out, so each likelihood evaluation costs one
    ``N x N`` Cholesky whatever ``q``. With ``noise=True``, ``Sigma2`` and
    ``Lambda`` are optimised jointly with ``omega`` through a Kronecker
    eigendecomposition costing ``O(N^3 + q^3)``. The log-likelihood is
    maximised with analytic gradients from the kernel's initial values and
    ``n_restarts_optimizer`` random starts.

    Parameters
    ----------
    kernel : sklearn Kernel, default=None
        Correlation function: any kernel with unit diagonal, e.g. the DACE
        families of :mod:`skmba.kernels` or sklearn's ``RBF``/``Matern`` and
        products of them. ``None`` uses an anisotropic :class:`~skmba.kernels.Gauss`
        whose starting roughness is ``1 / range_j^2`` per input with bounds
        ``1e-4`` to ``1e4`` times that. Variances are not part of the kernel:
        they are ``sigma2_`` (and ``noise_``).
    regression : {"constant", "linear", "quadratic"}, default="constant"
        Polynomial mean (regpoly0/1/2).
    noise : bool, default=False
        Estimate one noise variance per response (``noise_``). Without it the
        GP interpolates the training data (deterministic simulators).
    alpha : float, default=1e-10
        Nugget added to the diagonal of the correlation matrix, in units of
        correlation (i.e. as a fraction of the process variance). When the
        correlation matrix is numerically singular (many close points, very
        smooth kernels) it is raised automatically, at most to 1e-6, with a
        warning (see Notes); the value used is ``alpha_``. A value above 1e-6
        is used as given.
    optimizer : "fmin_l_bfgs_b", callable or None, default="fmin_l_bfgs_b"
        As in sklearn's ``GaussianProcessRegressor``: a callable is called as
        ``optimizer(obj_func, initial_theta, bounds)`` and returns
        ``(theta_opt, func_min)``; ``obj_func(theta, eval_gradient=True)``
        returns the negative log-likelihood and its gradient. With ``None``
        the kernel is kept fixed; ``Sigma2`` and ``noise_`` are still
        estimated (with L-BFGS-B when ``noise=True``).
    n_restarts_optimizer : int, default=0
        Number of extra starts, drawn log-uniformly within the kernel's
        hyperparameter bounds (and the noise bounds).
    normalize_y : bool, default=True
        Standardise each response (mean and standard deviation) internally.
        All fitted attributes and predictions are in the units of ``y``. The
        model does not depend on it (it is equivariant to shifting and
        scaling each response) except through ``response_nugget``; with
        False each response is only scaled by a power of two (exact), the
        one nearest to its standard deviation.
        Responses that are constant are predicted exactly (zero variance)
        and take no part in the likelihood.
    random_state : int, RandomState instance or None, default=None
        Seeds the restarts (and nothing else).
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
    alpha_ : float
        The nugget actually used: ``alpha``, or the escalated value when the
        correlation matrix was numerically singular (see Notes).
    X_train_ : ndarray of shape (N, d)
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when ``X`` has feature names.

    See Also
    --------
    sklearn.gaussian_process.GaussianProcessRegressor : one variance per
        fit, independent outputs.

    Notes
    -----
    ``predict(..., return_std=True)`` gives the universal-kriging standard
    deviation of the latent (noise-free) process, including the uncertainty
    of ``beta`` (Eqs. 3.33 and 3.40). Add ``noise_`` to the variance to
    predict a new noisy measurement.

    **Nugget escalation.** Many close training points with a smooth kernel
    (e.g. 1000 simulations of a smooth model with ``Gauss``) make the
    correlation matrix ``R`` numerically singular. The fit detects it when
    the Cholesky factorisation of ``R + alpha I`` fails at every starting
    point, or when it failed during the likelihood search and the optimum
    found is held positive definite only by the nugget (the smallest pivot
    ``min_i C_ii^2`` of the factor is below ``100 max(alpha, N eps)``, a
    search stopped by the failures). It then multiplies the nugget by 10
    (starting from 1e-12 when ``alpha=0``), never beyond 1e-6, and fits
    again from the best point so far. One ``UserWarning`` gives the nugget
    used, which is stored in ``alpha_``; with it the GP smooths the training
    data at that fraction of the process variance instead of interpolating
    them exactly. If the factorisation still fails at 1e-6, a
    :class:`~skmba._linalg.FactorizationError` (a ``ValueError``) names the
    remedies; a search still stopped by failures at 1e-6 gives a
    ``ConvergenceWarning``.

    **Input checks.** Besides sklearn's checks (finite values, 2-D ``X``,
    consistent lengths), ``fit`` raises a ``ValueError`` naming the fix for:
    values beyond 1e150 in magnitude; fewer than ``p + 1`` samples; all rows
    of ``X`` identical; regression terms that are not identifiable (e.g. a
    constant column with ``regression="linear"``); and, without noise,
    duplicated rows of ``X`` with different ``y`` (a noise-free GP cannot
    interpolate both) or fewer than ``p + q`` samples for the ``q x q``
    ``Sigma2`` (unless ``response_nugget > 0``). Duplicated rows with equal
    ``y`` only give a ``UserWarning`` (they add nothing to a noise-free fit).
    Constant input columns are harmless with ``regression="constant"``.

    **Memory.** Before allocating, ``fit`` checks that the ``N x N``
    correlation matrix, its gradient and the factorisation workspace (about
    ``8 N^2 (n_hyperparameters + 4 [+ d for the DACE kernels])`` bytes) fit
    in the available memory, and ``predict(..., return_cov=True)`` and
    ``sample_y`` do the same for their ``(s q) x (s q)`` covariance; a
    ``MemoryError`` gives the size and the remedy instead of swapping or
    being killed (:func:`skmba._linalg.check_memory`). Means and standard
    deviations are predicted in batches, so any number of points can be
    predicted.

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
    def _validate_params_(self):
        check_regression(self.regression)
        if not isinstance(self.alpha, Real) or not np.isfinite(self.alpha):
            raise TypeError(f"alpha must be a finite float, got {self.alpha!r}.")
        if self.alpha < 0:
            raise ValueError(
                f"alpha={self.alpha} is negative; the nugget must be >= 0 "
                "(e.g. alpha=1e-10)."
            )
        if (
            not isinstance(self.response_nugget, Real)
            or not np.isfinite(self.response_nugget)
            or self.response_nugget < 0
        ):
            raise ValueError(
                "response_nugget must be a non-negative float, got "
                f"{self.response_nugget!r}."
            )
        if (
            not isinstance(self.n_restarts_optimizer, Integral)
            or self.n_restarts_optimizer < 0
        ):
            raise ValueError(
                "n_restarts_optimizer must be a non-negative integer, got "
                f"{self.n_restarts_optimizer!r}."
            )
        if not (
            self.optimizer is None
            or callable(self.optimizer)
            or self.optimizer == "fmin_l_bfgs_b"
        ):
            raise ValueError(
                f"optimizer={self.optimizer!r} is not supported; use "
                "'fmin_l_bfgs_b', None or a callable."
            )
        if self.kernel is not None and not isinstance(self.kernel, Kernel):
            raise TypeError(
                "kernel must be an sklearn Kernel (e.g. skmba.kernels.Gauss()) "
                f"or None, got {type(self.kernel).__name__}."
            )
        for name in ("noise", "normalize_y"):
            value = getattr(self, name)
            if not isinstance(value, bool | np.bool_):
                raise TypeError(
                    f"{name} must be True or False, got {value!r}. Pass a "
                    f"bool, e.g. {name}=True."
                )

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
            On invalid data or parameters (see the class Notes); a
            :class:`~skmba._linalg.FactorizationError` (a ``ValueError``) when
            a matrix cannot be factored even after the nugget escalation.
        TypeError
            On parameters of the wrong type.
        MemoryError
            Before allocating, when the ``N x N`` matrices do not fit in the
            available memory.

        After a failed fit the estimator is unfitted (any previous fit is
        discarded), so that it cannot mix old and new state.
        """
        # numpy and scipy may each bring an OpenBLAS pool; on few cores the
        # pools compete and small-matrix work slows down 2-20x (measured:
        # the noisy q=16 fit of benchmarks/bench_gp.py, 17 s -> 1 s). The
        # likelihood work here is sequential, so hold BLAS to one thread.
        with threadpool_limits(limits=1, user_api="blas"):
            try:
                return self._fit(X, y)
            except BaseException:
                # No mix of a previous fit and a failed one: unfitted, so
                # predict raises NotFittedError instead of answering wrongly.
                params = self.get_params(deep=False)
                for name in [k for k in vars(self) if k not in params]:
                    delattr(self, name)
                raise

    def _fit(self, X, y):
        self._validate_params_()
        y_ndim = np.asarray(y).ndim
        if y_ndim > 2:
            raise ValueError(
                f"y has {y_ndim} dimensions; pass y of shape (n_samples,) or "
                "(n_samples, n_responses)."
            )
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True)
        X = X.astype(float, copy=False)
        self._y_ndim = y.ndim
        Y = np.asarray(y, dtype=float).reshape(len(y), -1)
        n, d = X.shape
        _check_magnitudes(X, Y)
        p = n_regression_terms(self.regression, d)
        if n <= p:
            raise ValueError(
                f"n_samples={n} is too few for regression={self.regression!r} "
                f"with {d} features: at least {p + 1} samples are needed "
                f"(p={p} regression terms). Add samples or use a lower-order "
                "regression."
            )
        H = regression_basis(X, self.regression)
        self._check_inputs(X, Y, H)
        kernel = default_kernel(X) if self.kernel is None else clone(self.kernel)
        check_correlation(kernel, X)
        n_hyper = kernel.n_dims + int(self.noise)
        n_diff = d if isinstance(kernel, _DACECorrelation) else 0
        check_memory(
            8.0 * n * n * (n_hyper + 4 + n_diff),
            f"Fitting MultiResponseGP to {n} samples (the {n} x {n} correlation "
            f"matrix, its gradient for {n_hyper} hyperparameter(s) and the "
            "factorisation workspace)",
            "Fit on fewer samples (e.g. a space-filling subset of the "
            "simulations) or use a machine with more memory.",
        )
        self.X_train_ = X
        self._H = H
        self.alpha_ = float(self.alpha)

        # Internal standardisation; constant responses are handled exactly.
        spread = np.ptp(Y, axis=0)
        self._active = spread > 1e-12 * np.maximum(np.abs(Y).max(axis=0), 1e-300)
        self._constant = Y[0].copy()
        # scaled by the peak first: no underflow of tiny responses' squares
        peak = np.abs(Y).max(axis=0)
        peak = np.where(peak > 0, peak, 1.0)
        std = (Y / peak).std(axis=0) * peak
        if self.normalize_y:
            self._y_mean = Y.mean(axis=0)
            self._y_std = np.where(self._active, std, 1.0)
        else:
            # Power-of-two scales: exact in floating point, they leave the
            # model unchanged (it is equivariant to rescaling each response)
            # and keep the squares of huge or tiny responses within float64.
            self._y_mean = np.zeros(Y.shape[1])
            with np.errstate(divide="ignore"):
                exponent = np.round(np.log2(std))
            self._y_std = np.where(self._active, 2.0**exponent, 1.0)
        Ya = ((Y - self._y_mean) / self._y_std)[:, self._active]
        self._Y = Ya
        # Scale of the (internal) responses for noise/Sigma2 parametrisation.
        self._scale = Ya.std(axis=0) if Ya.size else np.ones(0)
        q = Ya.shape[1]
        self._ridge = (
            self.response_nugget * float(np.mean(Ya.var(axis=0))) if q else 0.0
        )
        if not self.noise and q > n - p and self._ridge == 0:
            raise ValueError(
                f"n_samples={n} is too few to estimate the {q} x {q} response "
                "covariance sigma2_ of a noise-free fit with "
                f"regression={self.regression!r} (p={p} terms): it needs "
                f"n_samples >= p + q = {p + q}. Add samples, set "
                "response_nugget (e.g. 1e-8), fit fewer responses at once, or "
                "use noise=True."
            )

        if q == 0:
            warnings.warn(
                "All responses are constant: the GP predicts them exactly and "
                "the kernel is not fitted.",
                UserWarning,
                stacklevel=3,
            )
            self.kernel_ = kernel
            self._fit_state = None
            self.log_marginal_likelihood_value_ = np.inf
        elif self.noise:
            self._fit_noisy(kernel, Ya, self._differences(kernel))
        else:
            self._fit_noise_free(kernel, Ya, self._differences(kernel))
        self._set_user_attributes(Y.shape[1], p)
        return self

    def _check_inputs(self, X, Y, H):
        """Identical rows, unidentifiable regression, noise-free duplicates."""
        n = len(X)
        _, first, inverse = np.unique(X, axis=0, return_index=True, return_inverse=True)
        if len(first) == 1:
            raise ValueError(
                f"All {n} rows of X are identical: the GP cannot learn how the "
                "responses vary with the inputs. Provide at least 2 distinct "
                "input points."
            )
        _check_regression_rank(X, H, self.regression)
        if self.noise or len(first) == n:
            return
        source = first[np.reshape(inverse, -1)]  # first occurrence of each row
        dup = np.flatnonzero(source != np.arange(n))
        tol = 1e-8 * np.ptp(Y, axis=0)
        differ = np.any(np.abs(Y[dup] - Y[source[dup]]) > tol, axis=1)
        if np.any(differ):
            i = dup[np.argmax(differ)]
            raise ValueError(
                f"X has {int(differ.sum())} duplicated row(s) with different y "
                f"(e.g. rows {source[i]} and {i}): a noise-free GP "
                "interpolates and cannot pass through both. Fit with "
                "noise=True (measurements, stochastic simulators), or average "
                "the duplicated runs."
            )
        warnings.warn(
            f"X has {dup.size} duplicated row(s) (e.g. rows {source[dup[0]]} and "
            f"{dup[0]}) with equal y: they add no information to a noise-free "
            "GP and make the correlation matrix singular up to the nugget "
            "alpha. Remove them to save time.",
            UserWarning,
            stacklevel=4,
        )

    def _correlation(self, kernel, eval_gradient, differences=None):
        """Training correlation (+ nugget) and its gradient.

        ``differences``, the per-dimension ``|x_i - x_j|`` of the training
        inputs, lets the DACE kernels skip recomputing them at every
        likelihood evaluation.
        """
        X = self.X_train_
        if differences is not None and isinstance(kernel, _DACECorrelation):
            out = kernel._from_differences(differences, eval_gradient)
            R, dR = out if eval_gradient else (out, None)
        elif eval_gradient:
            R, dR = kernel(X, eval_gradient=True)
        else:
            R, dR = kernel(X), None
        R[np.diag_indices(len(X))] += self.alpha_
        return R, dR

    def _differences(self, kernel):
        """Per-dimension |x_i - x_j| for DACE kernels, else None."""
        if not isinstance(kernel, _DACECorrelation):
            return None
        X = self.X_train_
        return np.abs(X[:, np.newaxis, :] - X[np.newaxis, :, :])

    def _run_optimizer(self, objective, starts, bounds, optimizer, failures):
        """Minimise ``objective`` from each start.

        ``failures`` is the list the objective appends factorisation errors
        to. Returns an :class:`_Search`: the best point (None when the
        objective could not be evaluated from any start), the failures
        recorded during the run that found it (all of them when none did),
        that run's L-BFGS-B non-convergence messages, and whether it ended
        with a flat projected gradient (None for a callable optimizer).
        """
        best = _Search(None, list(failures), [], None)
        best_fun = np.inf
        for start in starts:
            mark = len(failures)
            notes, flat = [], None
            if callable(optimizer):
                x, fun = optimizer(objective, start, bounds)
            else:
                res = optimize.minimize(
                    objective, start, method="L-BFGS-B", jac=True, bounds=bounds
                )
                x, fun = res.x, res.fun
                flat = bool(
                    np.all(
                        np.abs(_projected_gradient(res, bounds))
                        <= _FLAT_GRADIENT * (1.0 + abs(res.fun))
                    )
                )
                if not res.success and np.isfinite(res.fun) and not flat:
                    notes.append(str(res.message))
            fun = float(fun)
            if np.isfinite(fun) and (best.x is None or fun < best_fun):
                best = _Search(np.asarray(x, dtype=float), failures[mark:], notes, flat)
                best_fun = fun
        if best.x is None:
            return _Search(None, list(failures), [], None)
        return best

    @staticmethod
    def _warn_not_converged(notes, stacklevel):
        for note in notes:
            warnings.warn(
                "L-BFGS-B did not fully converge while fitting "
                f"MultiResponseGP ({note}). Consider more "
                "n_restarts_optimizer, other kernel bounds or a larger "
                "alpha.",
                ConvergenceWarning,
                stacklevel=stacklevel,
            )

    def _fit_concentrated(self, kernel, Y, with_nugget, differences):
        """Maximise the likelihood with beta and Sigma2 concentrated out.

        Covariance ``Sigma2 ⊗ (R + (alpha_ + tau) I)``; ``tau`` (a noise to
        signal ratio shared by all responses) is optimised in log space when
        ``with_nugget`` is True, and is 0 otherwise. The nugget ``alpha_`` is
        escalated while ``R`` is numerically singular (class Notes). Returns
        the fitted kernel, ``tau`` and the :class:`NoiseFreeLikelihood` at
        the optimum.
        """
        H = self._H
        n_kernel = kernel.n_dims
        n = len(self.X_train_)

        def likelihood(params, eval_gradient):
            k = kernel.clone_with_theta(params[:n_kernel]) if n_kernel else kernel
            R, dR = self._correlation(k, eval_gradient, differences)
            if with_nugget:
                tau = np.exp(params[n_kernel])
                R[np.diag_indices(n)] += tau
                if eval_gradient:
                    dtau = np.zeros((n, n, 1))
                    dtau[np.arange(n), np.arange(n), 0] = tau
                    dR = np.concatenate([dR, dtau], axis=2)
            return NoiseFreeLikelihood(R, H, Y, dR, ridge=self._ridge)

        def objective(params, eval_gradient=True):
            try:
                fit = likelihood(params, eval_gradient)
            except FactorizationError as exc:
                failures.append(exc)
                return (np.inf, np.zeros_like(params)) if eval_gradient else np.inf
            if eval_gradient:
                return -fit.log_likelihood, -fit.gradient
            return -fit.log_likelihood

        failures = []
        x0 = kernel.theta
        bounds = kernel.bounds if n_kernel else np.zeros((0, 2))
        if with_nugget:
            x0 = np.append(x0, np.log(0.1))
            bounds = np.vstack([bounds, _LOG_NOISE_BOUNDS])
        free_kernel = self.optimizer is not None and n_kernel > 0
        if not free_kernel:
            bounds[:n_kernel] = x0[:n_kernel, None]
        search = free_kernel or with_nugget
        starts = [x0]
        if search:
            rng = check_random_state(self.random_state)
            for _ in range(self.n_restarts_optimizer):
                start = x0.copy()
                if free_kernel:
                    start[:n_kernel] = rng.uniform(
                        bounds[:n_kernel, 0], bounds[:n_kernel, 1]
                    )
                if with_nugget:
                    start[n_kernel] = rng.uniform(np.log(1e-4), 0.0)
                starts.append(start)
        optimizer = self.optimizer if callable(self.optimizer) else "fmin_l_bfgs_b"

        nugget, reason = self.alpha_, None
        while True:
            self.alpha_ = nugget
            failures.clear()
            notes = []
            if search:
                x, found, notes, flat = self._run_optimizer(
                    objective, starts, bounds, optimizer, failures
                )
            else:
                x, found, flat = x0, [], None
            fit = None
            if x is not None:
                try:
                    fit = likelihood(x, False)
                except FactorizationError as exc:
                    found.append(exc)
            # The search was stopped by failed factorisations of R when it
            # ended away from a stationary point, or where only the nugget
            # keeps R positive definite.
            r_failed = any(getattr(e, "what", None) == R_WHAT for e in found)
            stopped = (
                fit is not None
                and r_failed
                and (
                    flat is False
                    or smallest_pivot(fit.C)
                    <= _PIVOT_MARGIN * max(nugget, n * np.finfo(float).eps)
                )
            )
            if fit is not None and not stopped:
                break
            if not r_failed:
                # e.g. a singular Sigma2 or H: a larger nugget cannot help.
                raise FactorizationError(
                    "The likelihood could not be evaluated at any starting "
                    f"point. Last error: {found[-1] if found else 'none recorded'}"
                )
            if reason is None:
                reason = (
                    "the likelihood search was stopped by failed Cholesky "
                    "factorisations"
                    if stopped
                    else "its Cholesky factorisation failed"
                )
            following = _next_nugget(nugget)
            if following is None:
                if fit is None:
                    tried = (
                        f"the nugget is escalated from alpha={self.alpha:.3g} up "
                        f"to {_MAX_ALPHA:.0e}"
                        if self.alpha < _MAX_ALPHA
                        else f"an alpha >= {_MAX_ALPHA:.0e} is not escalated"
                    )
                    raise FactorizationError(
                        f"The {R_WHAT} is numerically singular even with the "
                        f"nugget alpha={nugget:.3g} ({tried}): its Cholesky "
                        "factorisation fails. Remedies: remove duplicated or "
                        "nearly duplicated input points, use a rougher kernel "
                        "(Exp, Matern, a larger lower bound on the roughness) "
                        "or a positive definite one (not Cubic), fit with "
                        "noise=True, or set a larger alpha explicitly.",
                        what=R_WHAT,
                    ) from found[-1]
                notes.append(
                    "the likelihood search is still stopped by a numerically "
                    f"singular correlation matrix at the largest nugget "
                    f"alpha={nugget:.3g}; {R_REMEDY}"
                )
                break
            nugget = following
            if fit is not None:
                starts = [x]  # resume from the best point so far
        self._warn_not_converged(notes, stacklevel=6)
        if self.alpha_ != self.alpha:
            warnings.warn(
                f"The {R_WHAT} was numerically singular with the nugget "
                f"alpha={self.alpha:.3g} ({reason}), so the nugget was raised to "
                f"alpha_={self.alpha_:.3g} (escalation by 10x up to "
                f"{_MAX_ALPHA:.0e}). The GP now smooths the training data at "
                "that fraction of the process variance instead of interpolating "
                f"them exactly. Set alpha={self.alpha_:.3g} to skip the refits, "
                "or remove nearly duplicated inputs or use a rougher kernel.",
                UserWarning,
                stacklevel=5,
            )
        fitted = kernel.clone_with_theta(x[:n_kernel]) if n_kernel else kernel
        tau = float(np.exp(x[n_kernel])) if with_nugget else 0.0
        return fitted, tau, fit

    def _fit_noise_free(self, kernel, Y, differences):
        self.kernel_, _, self._fit_state = self._fit_concentrated(
            kernel, Y, False, differences
        )

    def _fit_noisy(self, kernel, Y, differences):
        """Fit ``Sigma2 ⊗ R + Lambda ⊗ I`` on the profile likelihood.

        1. A concentrated fit with noise proportional to ``Sigma2``
           (``V = Sigma2 ⊗ (R + tau I)``): one Cholesky per evaluation, and the
           only step with random restarts. It gives the starting point.
        2. The kernel hyperparameters maximise the profile likelihood
           ``max over (Sigma2, Lambda)``: for each kernel, ``Sigma2`` and
           ``Lambda`` come from Levenberg-Marquardt on the Fisher
           information, on one eigendecomposition of ``R`` (O(N q^2) per
           likelihood, warm-started from the previous kernel, in
           ``Sigma2 = L L'`` coordinates so that the nearly singular
           ``Sigma2`` of strongly correlated responses is reached), and the
           gradient with respect to the kernel is the partial one at that
           maximum (envelope theorem). The optimizer sees only the kernel's
           hyperparameters, whatever ``q``.
        """
        H = self._H
        n_kernel = kernel.n_dims
        try:
            kernel, tau, stage1 = self._fit_concentrated(kernel, Y, True, differences)
            sigma2 = stage1.sigma2
            lam = tau * np.diag(sigma2)
        except FactorizationError:
            # e.g. responses that are exact linear combinations of others make
            # every proportional-noise Sigma2 singular; per-response noise
            # still separates them. Start from the sample covariance instead.
            cov = np.atleast_2d(np.cov(Y, rowvar=False, bias=True))
            sigma2 = 0.9 * cov + 1e-3 * np.diag(self._scale**2)
            lam = 0.1 * self._scale**2
        lam_bounds = np.exp(_LOG_NOISE_BOUNDS) * self._scale[:, None] ** 2
        warm = {"sigma2": sigma2, "lam": np.clip(lam, *lam_bounds.T), "best": -np.inf}
        failures = []

        def profile(k, eval_gradient):
            R, dR = self._correlation(k, eval_gradient, differences)
            eig = symmetric_eigh(R, what=R_WHAT)
            fit, _ = maximise_noise_and_sigma2(
                R,
                H,
                Y,
                warm["sigma2"],
                warm["lam"],
                eig=eig,
                lam_bounds=lam_bounds,
                tol=_SCORING_TOL,
                max_iter=_MAX_SCORING_STEPS,
            )
            # Warm-start the next kernel from the best point so far, not from
            # a line-search trial: a poor kernel can drive Sigma2 to 0, a
            # stationary point of the L L' coordinates.
            if fit.log_likelihood > warm["best"]:
                warm.update(sigma2=fit.sigma2, lam=fit.ke.lam, best=fit.log_likelihood)
            if eval_gradient:
                fit = NoisyLikelihood(R, H, Y, fit.sigma2, fit.ke.lam, dR, eig=eig)
            return fit

        def objective(theta, eval_gradient=True):
            try:
                fit = profile(kernel.clone_with_theta(theta), eval_gradient)
            except (FactorizationError, np.linalg.LinAlgError) as exc:
                failures.append(exc)
                return (np.inf, np.zeros_like(theta)) if eval_gradient else np.inf
            if eval_gradient:
                return -fit.log_likelihood, -fit.grad_kernel
            return -fit.log_likelihood

        if self.optimizer is not None and n_kernel:
            optimizer = self.optimizer if callable(self.optimizer) else "fmin_l_bfgs_b"
            theta, found, notes, _ = self._run_optimizer(
                objective, [kernel.theta], kernel.bounds, optimizer, failures
            )
            if theta is None:
                raise FactorizationError(
                    "The likelihood could not be evaluated at any starting "
                    f"point. Last error: {found[-1] if found else 'none recorded'}",
                    what=getattr(found[-1], "what", None) if found else None,
                )
            self._warn_not_converged(notes, stacklevel=5)
            kernel = kernel.clone_with_theta(theta)
        self.kernel_ = kernel
        self._fit_state = profile(kernel, False)

    def _set_user_attributes(self, q_total, p):
        """Fitted attributes in the units of y (constant responses exact)."""
        active, std, mean = self._active, self._y_std, self._y_mean
        beta = np.zeros((p, q_total))
        sigma2 = np.zeros((q_total, q_total))
        beta[0, ~active] = self._constant[~active]
        state = self._fit_state
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

    # -------------------------------------------------------------- predict
    def _predict_internal(self, X, full_cov, n_copies=3):
        """Mean (s, q) and variance (s, q) or covariance (s, q, s, q), user units.

        ``n_copies`` is the number of (s q) x (s q) arrays the caller keeps
        alive at once with the joint covariance (memory check).
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False).astype(float, copy=False)
        s = len(X)
        q = self._active.size
        if full_cov:
            check_memory(
                8.0 * n_copies * (s * q) ** 2,
                f"The joint predictive covariance of {s} points x {q} responses "
                f"({s * q} x {s * q} entries, {n_copies} arrays)",
                "Request it for fewer points at a time, or use return_std=True "
                "for the marginal standard deviations (computed in batches).",
            )
            return self._predict_batch(X, True)
        n_train, d = self.X_train_.shape
        batch = max(1, int(_PREDICT_BATCH_BYTES // (8 * n_train * (d + 4))))
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
        q = self._active.size
        mean = np.tile(self._constant, (s, 1))
        cov = np.zeros((s, q, s, q)) if full_cov else np.zeros((s, q))
        state = self._fit_state
        if state is not None:
            idx = np.flatnonzero(self._active)
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
            warnings.warn(
                "Predicted variances smaller than 0 were set to 0: the "
                "correlation matrix is ill-conditioned. Consider a larger alpha.",
                UserWarning,
                stacklevel=3,
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
            Also return the predictive standard deviation.
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
        random_state : int, RandomState instance or None, default=0

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
        if (
            not isinstance(n_samples, Integral)
            or isinstance(n_samples, bool | np.bool_)
            or n_samples < 1
        ):
            raise ValueError(
                "n_samples must be a positive integer (the number of joint "
                f"draws), got {n_samples!r}; e.g. n_samples=1."
            )
        rng = check_random_state(random_state)
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
        if self._fit_state is None:
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
        R, dR = self._correlation(kernel, eval_gradient)
        if self.noise:
            state = self._fit_state
            fit = NoisyLikelihood(R, self._H, self._Y, state.sigma2, state.ke.lam, dR)
            grad = fit.grad_kernel
        else:
            fit = NoiseFreeLikelihood(R, self._H, self._Y, dR, ridge=self._ridge)
            grad = fit.gradient
        shift = len(self.X_train_) * np.sum(np.log(self._y_std[self._active]))
        value = fit.log_likelihood - shift
        return (value, grad) if eval_gradient else value
