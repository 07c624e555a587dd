"""Module 2, steps 3-5: the discrepancy GP and the noise by maximum likelihood.

Given the prior-integrated emulator at the field inputs (mean ``m_bar`` and covariance
``V_bar``, see :mod:`skmba.calibration._module2_prior_integral`), the field data obey
(thesis Eqs. 4.18-4.21)::

    vec(Y_e) ~ N(vec(m_bar) + (I_q ⊗ H_d) vec(beta_d),
                 V_bar + Sigma_d ⊗ R_d(omega_d) + Lambda ⊗ I_n)

``beta_d`` is the GLS estimate; ``omega_d`` (the discrepancy kernel),
``Sigma_d`` (full q x q) and ``Lambda`` (diagonal, in log space) maximise the
likelihood with analytic gradients, from the starting point and random
restarts, or by scipy's differential evolution followed by L-BFGS-B (the
analogue of the thesis' genetic algorithm, appendix C.1.3). ``V_bar`` has no
Kronecker structure, so each evaluation factors the ``nq x nq`` covariance
once.

``Sigma_d = diag(low) + diag(s) C diag(s)``: ``low`` is the lower end of the
range of the discrepancy variances, held as a part of each response's own
that no correlation can cancel, and ``s`` and ``C`` are free: ``log s``, and
the Cholesky factor of the correlation ``C`` with rows ``w_i / |w_i|``,
``w_i = (z_i1, ..., z_i,i-1, 1)`` and free ``z`` (every correlation matrix is
reached). Bounds on ``s`` make the diagonal of ``Sigma_d`` lie exactly in the
range. Thesis Table 6.2 gives the default ranges
(:data:`~skmba.priors._table_6_2.TABLE_6_2_RANGES`): a uniform prior on the
hyperparameters, whose maximum a posteriori is the likelihood maximised inside
them. Why a lower end: docs/internals.rst, section
skmba.calibration._module2_plug_in.

:func:`fit_discrepancy` runs it (the calibrator's plug-in and the designer's
replicates); :class:`DiscrepancyFit` is the likelihood,
:class:`DiscrepancyEstimate` its maximiser.
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize
from sklearn.exceptions import ConvergenceWarning

from skmba._core.linalg import (
    FEWER_FIELD_DATA,
    FLOAT_BYTES,
    LOG_2PI,
    FactorizationError,
    check_memory,
    cholesky,
    cholesky_inverse,
    log_det_from_cholesky,
    observed_block,
    observed_entries,
    observed_rows,
)
from skmba._core.progress import as_progress, start_reporter
from skmba._core.regression import regression_basis
from skmba._core.validation import seed_sequence
from skmba._core.warn import warn
from skmba.calibration._field_replicates import noise_diagonal
from skmba.calibration._module2_kernel import bounded_kernel

DISCREPANCY_OPTIMIZERS = ("fmin_l_bfgs_b", "differential_evolution")
_LOG_REL_NOISE = (np.log(1e-8), np.log(10.0))
# Without a variance range: standard deviations within these multiples of
# each residual's standard deviation.
_LOG_REL_SD = (np.log(1e-5), np.log(1e2))
_CORR_FREE = (-1e2, 1e2)
#: From this many field values on, the gradient's ``V^-1`` comes from LAPACK
#: potri (``2 m^3 / 3`` flops) rather than two triangular solves against the
#: identity (``2 m^3``), which OpenBLAS runs as fast below it (one thread:
#: 0.74 against 0.68 ms at 216 values, 7.9 against 5.1 ms at 540;
#: docs/internals.rst, section skmba.calibration._module2_plug_in).
INVERSE_BY_POTRI = 256


@dataclass(frozen=True)
class DiscrepancyEstimate:
    """Module 2's discrepancy and noise at one value of the hyperparameters.

    Attributes
    ----------
    kernel_ : sklearn Kernel
        The discrepancy correlation with its fitted hyperparameters.
    sigma2 : ndarray of shape (q, q)
        Discrepancy covariance between the responses.
    noise : ndarray of shape (q,)
        Noise variances.
    beta : ndarray of shape (p, q)
        Regression coefficients of the discrepancy's mean (GLS).
    regression : str or None
    log_likelihood : float
        The (restricted) log likelihood there.
    params : ndarray
        The packed parameters (:meth:`DiscrepancyFit.pack`).
    """

    kernel_: object
    sigma2: np.ndarray
    noise: np.ndarray
    beta: np.ndarray
    regression: str | None
    log_likelihood: float
    params: np.ndarray


class DiscrepancyFit:
    """Maximum-likelihood discrepancy GP and noise on top of a fixed covariance.

    Parameters
    ----------
    kernel : sklearn Kernel
        Discrepancy correlation (its ``theta`` is optimised within its
        bounds).
    X : ndarray of shape (n, d)
    Y : ndarray of shape (n, q)
        Field data minus the integrated emulator mean; NaN marks an entry
        that was not measured (the likelihood is that of the others).
    H : ndarray of shape (n, p)
        Discrepancy regression matrix.
    V_fixed : ndarray of shape (n q, n q)
        The integrated emulator covariance (``vec`` response-slowest).
    variance_bounds : pair of ndarray of shape (q,), default=None
        ``(low, high)`` of the discrepancy variances (diagonal of
        ``Sigma_d``), in the units of ``Y``; ``low`` may be 0. ``low`` is
        held as an independent part of each response's discrepancy (see the
        module docstring). None means no floor and standard deviations up to
        100 times each column's of ``Y``: the plain maximum likelihood.
    regression : str, default=None
        The name of the regression of ``H`` (recorded in the estimate).
    restricted : bool, default=False
        The restricted (REML) likelihood instead of the plain one.
    unit_scale : bool, default=False
        Parameters in the units of ``Y`` (a prior is stated in them) rather
        than relative to each column's spread.
    fixed_noise : float, default=None
        Hold the noise at this many times each response's variance.
    log_noise_bounds : pair of float or array of shape (q, 2), default=None
        Bounds of the log relative noise variances, for all responses or
        per response (None: 1e-8 to 10).
    free_sd : bool, default=False
        No bounds on the log discrepancy standard deviations (a prior
        bounds them instead).
    replicates : ReplicateTerms, default=None
        Rows of ``Y`` that are means of repeated readings: see
        :class:`~skmba.calibration._field_replicates.ReplicateTerms`.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Gauss
    >>> X = np.linspace(0, 1, 15)[:, None]
    >>> Y = np.column_stack([np.sin(4 * X[:, 0]), X[:, 0]])
    >>> fit = DiscrepancyFit(Gauss(), X, Y, np.ones((15, 1)), np.zeros((30, 30)))
    >>> fit.optimize(random_state=0).sigma2.shape
    (2, 2)
    """

    def __init__(
        self,
        kernel,
        X,
        Y,
        H,
        V_fixed,
        variance_bounds=None,
        *,
        regression=None,
        restricted=False,
        unit_scale=False,
        fixed_noise=None,
        log_noise_bounds=None,
        free_sd=False,
        replicates=None,
    ):
        self.kernel, self.X, self.Y, self.H, self.V_fixed = kernel, X, Y, H, V_fixed
        self.replicates = replicates
        self.regression = regression
        self.restricted = restricted
        self.n, self.q = Y.shape
        self.observed = observed_entries(Y)
        # The measured rows of the regression and the data (fixed).
        self._X_obs = observed_rows(np.kron(np.eye(self.q), H), self.observed)
        self._y_obs = observed_rows(Y.T.ravel(), self.observed)
        self.scale = np.maximum(
            np.nanstd(Y, axis=0), 1e-8 * max(np.nanmax(np.abs(Y)), 1e-300)
        )
        if unit_scale:  # parameters in the units of Y (a prior is set in them)
            self.scale = np.ones(self.q)
        self.rows, self.cols = np.tril_indices(self.q, -1)
        self.n_kernel = kernel.n_dims
        self.fixed_noise = None if fixed_noise is None else float(fixed_noise)
        self.log_sd_bounds = np.tile(_LOG_REL_SD, (self.q, 1))
        if free_sd:
            self.log_sd_bounds[:] = (-np.inf, np.inf)
        self.log_noise_bounds = np.broadcast_to(
            _LOG_REL_NOISE if log_noise_bounds is None else log_noise_bounds,
            (self.q, 2),
        ).astype(float)
        self.floor = np.zeros(self.q)
        if variance_bounds is not None:
            lo, hi = (np.broadcast_to(v, (self.q,)) for v in variance_bounds)
            self.floor = np.array(lo, dtype=float)
            # The free part s^2 spans [0, high - low]; its log needs a bottom.
            top = 0.5 * np.log(np.maximum(hi - lo, 0.0) / self.scale**2 + 1e-300)
            self.log_sd_bounds[:, 1] = np.maximum(top, _LOG_REL_SD[0])

    # ------------------------------------------------------- parameters
    # params = [kernel theta (k), log relative noise (q), log relative
    # discrepancy sd (q), correlation-factor z (q (q - 1) / 2, row-major)]
    def _correlation_factor(self, z):
        """Unit-row lower-triangular factor of the correlation, and |w_i|."""
        W = np.eye(self.q)
        W[self.rows, self.cols] = z
        norms = np.linalg.norm(W, axis=1)
        return W / norms[:, None], norms

    def unpack(self, params):
        k, q = self.n_kernel, self.q
        theta = params[:k]
        lam = np.exp(params[k : k + q]) * self.scale**2
        sd = np.exp(params[k + q : k + 2 * q]) * self.scale
        U, _ = self._correlation_factor(params[k + 2 * q :])
        return theta, lam, U * sd[:, None]

    def pack(self, theta, lam, L):
        """Inverse of :meth:`unpack` for any lower-triangular ``L`` with a
        positive diagonal (``Sigma_d = diag(floor) + L L'``)."""
        L = np.asarray(L, dtype=float)
        sd = np.linalg.norm(L, axis=1)
        z = (L / np.diag(L)[:, None])[self.rows, self.cols]
        return np.concatenate(
            [theta, np.log(lam / self.scale**2), np.log(sd / self.scale), z]
        )

    def bounds(self):
        parts = [self.kernel.bounds if self.n_kernel else np.zeros((0, 2))]
        noise = self.log_noise_bounds
        if self.fixed_noise is not None:
            noise = np.full((self.q, 2), np.log(self.fixed_noise))
        parts += [
            noise,
            self.log_sd_bounds,
            np.tile(_CORR_FREE, (len(self.rows), 1)),
        ]
        return np.vstack(parts)

    # ------------------------------------------------------- likelihood
    def evaluate(self, params, eval_gradient=True):
        """Log-likelihood (and gradient in ``params``) with GLS ``beta``.

        With ``restricted=True`` the restricted likelihood (REML: ``beta``
        integrated out under a flat prior, which adds ``-log|X' V^-1 X| / 2``
        and removes the low bias of the maximum-likelihood variances).
        """
        n, q = self.n, self.q
        theta, lam, L = self.unpack(params)
        k = self.kernel.clone_with_theta(theta) if self.n_kernel else self.kernel
        if eval_gradient:
            R, dR = k(self.X, eval_gradient=True)
        else:
            R, dR = k(self.X), None
        sigma2 = L @ L.T + np.diag(self.floor)
        reps = self.replicates
        # V_fixed + Sigma_d ⊗ R + the noise, built in place (one n q x n q array).
        V = np.kron(sigma2, R)
        V += self.V_fixed
        V.flat[:: n * q + 1] += noise_diagonal(lam, n, reps)
        obs = self.observed
        C = cholesky(
            observed_block(V, obs),
            what="field-data covariance of module 2",
            remedy="Use another discrepancy kernel or a larger noise lower bound.",
        )
        y = self._y_obs
        m = len(y)
        # C is a Cholesky factor (finite): no finiteness checks in the solves.
        Xw = linalg.solve_triangular(C, self._X_obs, lower=True, check_finite=False)
        yw = linalg.solve_triangular(C, y, lower=True, check_finite=False)
        Q, G = linalg.qr(Xw, mode="economic", check_finite=False)
        beta = linalg.solve_triangular(G, Q.T @ yw, check_finite=False)
        rw = yw - Xw @ beta
        ll = -0.5 * (m * LOG_2PI + log_det_from_cholesky(C) + rw @ rw)
        if self.restricted:
            ll -= 0.5 * (2.0 * np.sum(np.log(np.abs(np.diag(G)))) - len(G) * LOG_2PI)
        if reps is not None:
            factor, g_factor = reps.log_factor(lam, eval_gradient=True)
            ll += factor
        self.last = (k, sigma2, lam, beta.reshape(q, -1).T)
        if not eval_gradient:
            return ll
        alpha = linalg.solve_triangular(
            C, rw, lower=True, trans="T", check_finite=False
        )
        if m >= INVERSE_BY_POTRI:
            Vinv = cholesky_inverse(C, what="field-data covariance of module 2")
        else:
            Vinv = linalg.cho_solve((C, True), np.eye(m), check_finite=False)
        if self.restricted:  # V^-1 -> V^-1 - V^-1 X (X' V^-1 X)^-1 X' V^-1
            W = linalg.solve_triangular(C, Q, lower=True, trans="T", check_finite=False)
            Vinv -= W @ W.T
        # d ll = tr(K dV) / 2 over the observed block; the unobserved rows
        # and columns of K are zero.
        K = np.outer(alpha, alpha) - Vinv
        if obs is not None:
            K_full = np.zeros((n * q, n * q))
            K_full[np.ix_(obs, obs)] = K
            K = K_full
        K = K.reshape(q, n, q, n)
        M = np.einsum("ab,aibj->ij", sigma2, K)
        g_kernel = 0.5 * (dR.reshape(n * n, -1).T @ M.ravel())
        g_sigma = 0.5 * np.einsum("aibj,ij->ab", K, R)
        # Chain rule through L = diag(sd) U, U_i = w_i / |w_i| (see unpack).
        g_L = np.tril(2.0 * g_sigma @ L)
        g_log_sd = np.einsum("ij,ij->i", g_L, L)
        U, norms = self._correlation_factor(params[self.n_kernel + 2 * q :])
        sd = np.exp(params[self.n_kernel + q : self.n_kernel + 2 * q]) * self.scale
        g_U = g_L * sd[:, None]
        g_W = (g_U - np.einsum("ij,ij->i", g_U, U)[:, None] * U) / norms[:, None]
        if reps is None:
            g_lam = 0.5 * np.einsum("aiai->a", K) * lam
        else:  # d V / d log lam_a = diag(lam_a / counts) on block a
            per_mean = reps.noise_diagonal(lam).reshape(q, n)
            g_lam = 0.5 * np.einsum("aiai,ai->a", K, per_mean) + g_factor
        return ll, np.concatenate(
            [g_kernel, g_lam, g_log_sd, g_W[self.rows, self.cols]]
        )

    def _objective(self, params, eval_gradient=True):
        try:
            out = self.evaluate(params, eval_gradient)
        except FactorizationError:
            return (np.inf, np.zeros_like(params)) if eval_gradient else np.inf
        if eval_gradient:
            return -out[0], -out[1]
        return -out

    def start(self):
        """Starting point: discrepancy and noise share the residual variance.

        With unmeasured entries, each response's own variance (no
        correlation between responses).
        """
        if self.observed is None:
            cov = np.atleast_2d(np.cov(self.Y, rowvar=False, bias=True))
        else:
            cov = np.diag(np.nanvar(self.Y, axis=0))
        L0 = np.linalg.cholesky(0.5 * cov + 1e-3 * np.diag(self.scale**2))
        relative = 0.1 if self.fixed_noise is None else self.fixed_noise
        start = self.pack(self.kernel.theta, relative * self.scale**2, L0)
        return np.clip(start, *self.bounds().T)

    def optimize(
        self,
        *,
        optimizer="fmin_l_bfgs_b",
        n_restarts=0,
        random_state=None,
        start=None,
        max_iter=None,
        on_start=None,
    ):
        """Maximise the likelihood; returns the :class:`DiscrepancyEstimate`.

        ``start`` (packed parameters, see :meth:`pack`)
        replaces the default starting point of :meth:`start`; it is clipped
        to the bounds. ``max_iter`` bounds the L-BFGS-B iterations of each
        start (None: scipy's default); reaching it is not warned about, the
        caller asked for it. ``on_start(k, n, fun)``, when given, is called
        after the L-BFGS-B run from start ``k`` of ``n`` (``fun`` its
        minimum of ``-loglik``), for progress reports.
        """
        rng = np.random.default_rng(seed_sequence(random_state))
        bounds = self.bounds()
        x0 = self.start() if start is None else np.clip(start, *bounds.T)
        starts = self._starts(x0, bounds, n_restarts, rng)
        if optimizer == "differential_evolution":
            starts = [self._global_start(bounds, rng)]
        elif optimizer != "fmin_l_bfgs_b":
            raise ValueError(
                f"discrepancy optimizer={optimizer!r} is not supported; use one "
                f"of {DISCREPANCY_OPTIMIZERS}."
            )
        best = None
        for k, s in enumerate(starts, 1):
            res = self._local_search(s, bounds, max_iter)
            if on_start is not None:
                on_start(k, len(starts), float(res.fun))
            if best is None or res.fun < best.fun:
                best = res
        if not np.isfinite(best.fun):
            raise FactorizationError(
                "The module-2 likelihood could not be evaluated at any start: the "
                "field-data covariance is singular. Check the field data (are "
                "there duplicated rows?) or use another discrepancy kernel."
            )
        return self.estimate(best.x)

    def _starts(self, x0, bounds, n_restarts, rng):
        """``x0`` and ``n_restarts`` random starts: kernel hyperparameters
        uniform within their bounds, log relative noise in [log 1e-4, 0]."""
        starts = [x0]
        for _ in range(n_restarts):
            s = x0.copy()
            if self.n_kernel:
                kb = bounds[: self.n_kernel]
                s[: self.n_kernel] = rng.uniform(kb[:, 0], kb[:, 1])
            if self.fixed_noise is None:
                s[self.n_kernel : self.n_kernel + self.q] = rng.uniform(
                    np.log(1e-4), 0.0, self.q
                )
            starts.append(s)
        return starts

    def _global_start(self, bounds, rng):
        """The start found by differential evolution over the bounds (the
        correlation factors within +-3)."""
        box = bounds.copy()
        box[~np.isfinite(box)] = 0.0
        box[self.n_kernel + 2 * self.q :] = (-3.0, 3.0)  # correlations z
        result = optimize.differential_evolution(
            lambda p: self._objective(p, eval_gradient=False),
            box,
            seed=int(rng.integers(2**31 - 1)),
            polish=False,
            tol=1e-6,
            maxiter=300,
        )
        return result.x

    def _local_search(self, start, bounds, max_iter):
        """L-BFGS-B from ``start``; a run that stops short of convergence
        (not at the caller's ``max_iter``) warns."""
        res = optimize.minimize(
            self._objective,
            start,
            jac=True,
            method="L-BFGS-B",
            bounds=bounds,
            options={} if max_iter is None else {"maxiter": max_iter},
        )
        capped = max_iter is not None and res.nit >= max_iter
        if not res.success and np.isfinite(res.fun) and not capped:
            warn(
                f"The discrepancy likelihood did not fully converge ({res.message}).",
                ConvergenceWarning,
            )
        return res

    def estimate(self, params):
        """The :class:`DiscrepancyEstimate` at the packed ``params``."""
        log_likelihood = self.evaluate(params, eval_gradient=False)
        kernel_, sigma2, noise, beta = self.last
        return DiscrepancyEstimate(
            kernel_, sigma2, noise, beta, self.regression, log_likelihood, params
        )


def check_module2_memory(kernel, residual):
    """Room for the module-2 likelihood of ``residual`` (n, q), before it runs.

    Each likelihood evaluation holds about eight nq x nq matrices (the
    covariance, its Cholesky factor and inverse, the gradient weights and
    their reshapes).
    """
    nq, q = residual.size, residual.shape[1]
    n_params = kernel.n_dims + q + q * (q + 1) // 2
    check_memory(
        FLOAT_BYTES * 8 * nq**2,
        f"The module-2 likelihood (a {nq} x {nq} field-data covariance, "
        f"{n_params} parameters)",
        FEWER_FIELD_DATA,
    )


def fit_discrepancy(
    X_e,
    residual,
    V_fixed,
    *,
    kernel=None,
    regression="constant",
    ranges=None,
    units=None,
    noise=True,
    optimizer="fmin_l_bfgs_b",
    n_restarts=0,
    random_state=None,
    start=None,
    max_iter=None,
    responses=None,
    progress=None,
    replicates=None,
):
    """Module 2b (Eq. 4.19): discrepancy GP and noise by maximum likelihood.

    Parameters
    ----------
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    residual : ndarray of shape (n, q)
        Standardised field data minus the prior-integrated emulator mean.
    V_fixed : ndarray of shape (n q, n q)
        The prior-integrated emulator covariance.
    kernel : sklearn Kernel or None
        Discrepancy correlation (see
        :func:`~skmba.calibration._module2_kernel.discrepancy_kernel`).
    regression : {"constant", "linear", "quadratic"}
    ranges : dict or None
        As returned by
        :func:`~skmba.priors._table_6_2.check_discrepancy_ranges` (for all
        responses); the likelihood is maximised within them.
    units : PriorUnits, default=None
        The units ``ranges`` are stated in
        (:class:`~skmba.priors._hyperprior.PriorUnits`, for all responses);
        None: those of ``X_e`` and ``residual``.
    noise : bool
        Estimate the noise; False holds it at a negligible nugget.
    optimizer : {"fmin_l_bfgs_b", "differential_evolution"}
    n_restarts : int
    random_state : int or None
    start : callable, default=None
        ``start(fit) -> packed parameters``: the first starting point (the
        sensor designer passes the hyperparameters that generated its
        synthetic data).
    max_iter : int, default=None
        Bound on the optimiser's iterations per start.
    responses : sequence of int, default=None
        The responses (columns of the simulations) that ``residual`` holds,
        to restrict the variance ranges; None for all.
    progress : skmba._core.progress.Progress, default=None
        A bar of the optimiser's starts and, as detail lines, the
        log-likelihood each reaches; None is silent.
    replicates : ReplicateTerms, default=None
        As :class:`DiscrepancyFit`'s.

    Returns
    -------
    DiscrepancyFit
        The optimised fit (``kernel_``, ``sigma2``, ``noise``, ``beta``).
    """
    kernel_d = bounded_kernel(
        kernel, X_e, None if ranges is None else ranges["roughness"], units
    )
    variance = None if ranges is None else ranges["variance"]
    if variance is not None and units is not None:
        variance = tuple(units.response(v, 2) for v in variance)
    if variance is not None and responses is not None:
        variance = tuple(v[list(responses)] for v in variance)
    check_module2_memory(kernel_d, residual)
    H_d = regression_basis(X_e, regression)
    disc = DiscrepancyFit(
        kernel_d,
        X_e,
        residual,
        H_d,
        V_fixed,
        variance,
        regression=regression,
        fixed_noise=None if noise else 1e-10,
        replicates=replicates,
    )
    progress = as_progress(progress)
    n_starts = 1 if optimizer == "differential_evolution" else n_restarts + 1
    with progress.bar(n_starts, "module 2: discrepancy", unit="start") as bar:
        return disc.optimize(
            optimizer=optimizer,
            n_restarts=n_restarts,
            random_state=random_state,
            start=None if start is None else start(disc),
            max_iter=max_iter,
            on_start=start_reporter(progress, bar, "module 2"),
        )
