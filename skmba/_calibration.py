"""ModularBayesCalibrator: the four modules of the modular Bayesian approach."""

import warnings
from numbers import Integral

import numpy as np
from joblib import Parallel, delayed
from scipy import optimize, stats
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, clone
from sklearn.gaussian_process.kernels import Kernel
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_array, check_is_fitted, validate_data
from threadpoolctl import threadpool_limits

from skmba._discrepancy import DISCREPANCY_OPTIMIZERS, DiscrepancyFit
from skmba._gp import MultiResponseGP, default_kernel
from skmba._integration import integrate_emulator
from skmba._linalg import FactorizationError
from skmba._posterior import GlobalModel
from skmba._priors import check_prior
from skmba._regression import check_regression, regression_basis
from skmba._sampling import check_diagnostics, run_chains

MODULE2_VARIANCES = ("total", "conditional")
INTEGRATIONS = ("auto", "quadrature", "qmc")
SAMPLERS = ("auto", "quadrature", "mcmc")
_N_PREDICT_DRAWS = 200  # posterior draws used by the module-4 predictions (MCMC)
_N_PREDICT_NODES = 41  # quadrature nodes used by them (one parameter)


def _check_simulator_output(Y, n, q, first_run):
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1 and (q in (None, 1)):
        Y = Y.reshape(-1, 1)
    if Y.ndim != 2 or Y.shape[0] != n or (q is not None and Y.shape[1] != q):
        expected = f"({n}, {q if q is not None else 'q'})"
        raise ValueError(
            f"simulator returned an array of shape {np.shape(Y)} for runs "
            f"{first_run}..{first_run + n - 1}; it must return {expected}: one row "
            "per run and one column per response."
        )
    bad = ~np.all(np.isfinite(Y), axis=1)
    if np.any(bad):
        runs = (np.flatnonzero(bad) + first_run).tolist()[:10]
        raise ValueError(
            f"simulator returned non-finite values (NaN or inf) for runs {runs}. "
            "Fix the model for these inputs or narrow the prior / input range."
        )
    return Y


def run_simulator(simulator, X, theta, q=None):
    """Run ``simulator(X, theta)`` and check what it returns.

    When the batch call raises, the runs are retried one by one so that the
    error names the failing run and its inputs.

    Examples
    --------
    >>> import numpy as np
    >>> run_simulator(lambda X, t: X * t, np.ones((2, 1)), np.full((2, 1), 3.0))
    array([[3.],
           [3.]])
    """
    try:
        Y = simulator(X, theta)
    except Exception as batch_error:
        for i in range(len(X)):
            try:
                simulator(X[i : i + 1], theta[i : i + 1])
            except Exception as exc:
                raise RuntimeError(
                    f"simulator raised {type(exc).__name__} at run {i} with "
                    f"X={X[i].tolist()}, theta={theta[i].tolist()}: {exc}"
                ) from exc
        raise RuntimeError(
            f"simulator raised {type(batch_error).__name__} on the batch of "
            f"{len(X)} runs but on none of them alone: {batch_error}"
        ) from batch_error
    return _check_simulator_output(Y, len(X), q, 0)


class ModularBayesCalibrator(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """Bayesian calibration of a computer model with model discrepancy.

    Implements the modular Bayesian approach (MBA) of Kennedy & O'Hagan
    (2001) and Arendt et al. (2012) for several responses and parameters,
    as in thesis chapter 4, for the calibration equation::

        y_e(x) = y_m(x, theta*) + delta(x) + eps,   eps ~ N(0, Lambda)

    * Module 1 fits a noise-free :class:`~skmba.MultiResponseGP` emulator
      ``model_gp_`` to the simulations ``[X_sim, theta_sim] -> y_sim``.
    * Module 2 integrates the emulator over the prior of ``theta`` at the
      field inputs (Gauss-Legendre on the prior quantiles for one parameter,
      scrambled Sobol points for several; Eqs. 4.14-4.17), then fits the
      discrepancy GP (full ``discrepancy_sigma2_``) and the per-response
      noise ``noise_`` by maximum likelihood (Eq. 4.19).
    * Module 3 gives the posterior of ``theta`` (Eq. 4.30, regression
      coefficients integrated out) through the Schur complement of the
      fixed simulation block: by adaptive quadrature for one parameter or by
      Metropolis-Hastings chains (parallel through joblib) for any number.
    * Module 4 predicts the field process, the model and the discrepancy by
      the laws of total expectation and variance over the posterior.

    Inputs, parameters and responses are standardised internally with the
    simulation data as reference (thesis appendix C.2); every fitted attribute
    and prediction is in user units unless stated otherwise.

    Parameters
    ----------
    simulator : callable, default=None
        ``simulator(X, theta) -> Y`` with ``X`` (n, d), ``theta`` (n, r) taken
        row by row and ``Y`` (n, q). When given, ``fit`` runs it on a Latin
        hypercube over the range of ``X`` times the prior's support (its
        0.999 central interval for unbounded priors). It must be picklable to
        pickle the estimator; it is not needed after ``fit``.
    prior : list of frozen scipy.stats distributions, frozen multivariate_normal \
            or object with ``logpdf``/``rvs``, default=None
        Prior of the ``r`` calibration parameters. None means uniform over the
        range of ``theta_sim`` (only with precomputed simulations).
    n_simulations : int, default=None
        Runs of ``simulator`` (default ``10 * (d + r)``).
    model_kernel, discrepancy_kernel : sklearn Kernel, default=None
        Correlations of the emulator and of the discrepancy (unit diagonal).
        None: anisotropic :class:`~skmba.kernels.Gauss` scaled to the data.
        They act on standardised inputs.
    regression, discrepancy_regression : {"constant", "linear", "quadratic"}
        Mean bases of the emulator and of the discrepancy.
    noise : bool, default=True
        Estimate the per-response measurement noise. False fixes it at a
        negligible nugget (noise-free field data).
    integration : {"auto", "quadrature", "qmc"}, default="auto"
        Module-2 integration rule: "quadrature" (Gauss-Legendre on prior
        quantiles, one parameter only), "qmc" (scrambled Sobol points), or
        "auto" (quadrature for one parameter, qmc otherwise).
    sampler : {"auto", "quadrature", "mcmc"}, default="auto"
        Module-3 posterior: "quadrature" (one parameter), "mcmc", or "auto".
    n_chains : int, default=4
    n_samples : int, default=5000
        Draws per chain kept after burn-in (MCMC), or the number of draws
        ``theta_samples_`` resampled from the quadrature posterior.
    burn_in : int, default=1000
        Draws per chain discarded; the proposal adapts during burn-in only.
    n_jobs : int, default=None
        Parallel chains, module-2 node blocks and module-4 predictions,
        through joblib (so ``joblib.parallel_config(backend="dask")`` works).
        During ``fit`` and the predictions BLAS is held to one thread: the
        parallelism is joblib's.
    random_state : int, RandomState instance or None, default=None
        The same seed gives the same result for any ``n_jobs``.
    n_integration_nodes : int, default=None
        Module-2 nodes (default 32 for quadrature, 256 for qmc).
    module2_variance : {"total", "conditional"}, default="total"
        "conditional" uses Eq. 4.15 as printed: the emulator's conditional
        covariance averaged over the prior. "total" adds the spread of the
        emulator mean over the prior (law of total variance). The default is
        "total": without the spread, module 2 attributes the effect of the
        unknown theta on the field data to the discrepancy and noise, which
        then absorb the signal that identifies theta (see the tests on the
        cantilever problems).
    n_restarts_optimizer : int, default=2
        Random restarts of the module-1 and module-2 likelihood maximisation.
    discrepancy_optimizer : {"fmin_l_bfgs_b", "differential_evolution"}
        Module-2 optimiser; differential evolution is a global search (the
        analogue of the thesis' genetic algorithm) followed by L-BFGS-B.
    emulator_alpha : float, default=1e-8
        Nugget of the emulator's correlation matrix.

    Attributes
    ----------
    model_gp_ : MultiResponseGP
        Module-1 emulator, fitted on standardised inputs and responses
        (``(X - X_mean_) / X_scale_`` etc.); use :meth:`predict_model` for user
        units.
    discrepancy_kernel_ : sklearn Kernel
        Fitted discrepancy correlation (on standardised inputs).
    discrepancy_sigma2_ : ndarray of shape (q, q)
        Discrepancy covariance in squared response units.
    discrepancy_beta_ : ndarray of shape (p_d, q)
        Discrepancy regression coefficients, in response units, of the basis
        evaluated on the standardised inputs.
    noise_ : ndarray of shape (q,)
        Measurement-noise variances in squared response units.
    theta_samples_ : ndarray of shape (n_draws, r)
        Posterior draws (pooled chains after burn-in, or draws from the
        quadrature posterior).
    theta_mean_ : ndarray of shape (r,)
    theta_cov_ : ndarray of shape (r, r)
    acceptance_rate_, rhat_, ess_ : ndarray
        MCMC diagnostics (n_chains,), (r,), (r,); only with MCMC.
    theta_nodes_, theta_weights_ : ndarray
        The posterior quadrature (only with quadrature).
    prior_ : skmba._priors.Prior
    X_sim_, theta_sim_, y_sim_ : ndarray
        The simulations used (given and run).
    X_mean_, X_scale_, theta_mean_sim_, theta_scale_, y_mean_, y_scale_ : ndarray
        The standardisation (simulation data as reference).
    n_features_in_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import stats
    >>> from skmba import ModularBayesCalibrator
    >>> def model(X, theta):
    ...     return np.column_stack([theta[:, 0] * X[:, 0], theta[:, 0] + X[:, 0]])
    >>> X = np.linspace(0, 1, 12)[:, None]
    >>> y = model(X, np.full((12, 1), 2.0)) + 0.05 * np.sin(6 * X)
    >>> cal = ModularBayesCalibrator(
    ...     model, [stats.uniform(1, 2)], n_simulations=30, random_state=0
    ... ).fit(X, y)
    >>> bool(abs(cal.theta_mean_[0] - 2.0) < 0.1)
    True
    """

    def __init__(
        self,
        simulator=None,
        prior=None,
        *,
        n_simulations=None,
        model_kernel=None,
        discrepancy_kernel=None,
        regression="constant",
        discrepancy_regression="constant",
        noise=True,
        integration="auto",
        sampler="auto",
        n_chains=4,
        n_samples=5000,
        burn_in=1000,
        n_jobs=None,
        random_state=None,
        n_integration_nodes=None,
        module2_variance="total",
        n_restarts_optimizer=2,
        discrepancy_optimizer="fmin_l_bfgs_b",
        emulator_alpha=1e-8,
    ):
        self.simulator = simulator
        self.prior = prior
        self.n_simulations = n_simulations
        self.model_kernel = model_kernel
        self.discrepancy_kernel = discrepancy_kernel
        self.regression = regression
        self.discrepancy_regression = discrepancy_regression
        self.noise = noise
        self.integration = integration
        self.sampler = sampler
        self.n_chains = n_chains
        self.n_samples = n_samples
        self.burn_in = burn_in
        self.n_jobs = n_jobs
        self.random_state = random_state
        self.n_integration_nodes = n_integration_nodes
        self.module2_variance = module2_variance
        self.n_restarts_optimizer = n_restarts_optimizer
        self.discrepancy_optimizer = discrepancy_optimizer
        self.emulator_alpha = emulator_alpha

    # ------------------------------------------------------------ checks
    def _check_params(self):
        check_regression(self.regression)
        check_regression(self.discrepancy_regression)
        for name, value, allowed in (
            ("integration", self.integration, INTEGRATIONS),
            ("sampler", self.sampler, SAMPLERS),
            ("module2_variance", self.module2_variance, MODULE2_VARIANCES),
            (
                "discrepancy_optimizer",
                self.discrepancy_optimizer,
                DISCREPANCY_OPTIMIZERS,
            ),
        ):
            if value not in allowed:
                raise ValueError(
                    f"{name}={value!r} is not supported; use one of {allowed}."
                )
        for name in ("n_chains", "n_samples"):
            value = getattr(self, name)
            if not isinstance(value, Integral) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}.")
        for name in ("burn_in", "n_restarts_optimizer"):
            value = getattr(self, name)
            if not isinstance(value, Integral) or value < 0:
                raise ValueError(
                    f"{name} must be a non-negative integer, got {value!r}."
                )
        for name in ("n_simulations", "n_integration_nodes"):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, Integral) or value < 2):
                raise ValueError(
                    f"{name} must be an integer >= 2 or None, got {value!r}."
                )
        for name in ("model_kernel", "discrepancy_kernel"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, Kernel):
                raise TypeError(
                    f"{name} must be an sklearn Kernel or None, got "
                    f"{type(value).__name__}."
                )
        if self.simulator is not None and not callable(self.simulator):
            raise TypeError(
                "simulator must be a callable simulator(X, theta) -> Y, got "
                f"{type(self.simulator).__name__}."
            )
        if not np.isfinite(self.emulator_alpha) or self.emulator_alpha < 0:
            raise ValueError(
                f"emulator_alpha must be >= 0 and finite, got {self.emulator_alpha!r}."
            )

    def _simulations(self, X, q, rng, X_sim, theta_sim, y_sim):
        """Given and simulated runs, checked and stacked."""
        parts = []
        given = [a is not None for a in (X_sim, theta_sim, y_sim)]
        if any(given) and not all(given):
            raise ValueError(
                "Pass X_sim, theta_sim and y_sim together (a precomputed "
                "simulation dataset), or none of them."
            )
        if all(given):
            X_sim = check_array(X_sim, input_name="X_sim")
            theta_sim = check_array(theta_sim, input_name="theta_sim")
            y_sim = check_array(y_sim, input_name="y_sim", ensure_2d=False)
            y_sim = y_sim.reshape(len(y_sim), -1)
            if not len(X_sim) == len(theta_sim) == len(y_sim):
                raise ValueError(
                    "X_sim, theta_sim and y_sim must have the same number of rows, "
                    f"got {len(X_sim)}, {len(theta_sim)} and {len(y_sim)}."
                )
            if X_sim.shape[1] != X.shape[1]:
                raise ValueError(
                    f"X_sim has {X_sim.shape[1]} columns but X has {X.shape[1]}: "
                    "the simulations must use the same design variables."
                )
            if y_sim.shape[1] != q:
                raise ValueError(
                    f"y_sim has {y_sim.shape[1]} responses but y has {q}: the "
                    "simulated and observed responses must be the same, in the "
                    "same order."
                )
            parts.append((X_sim, theta_sim, y_sim))
        if self.simulator is not None:
            prior = self.prior_
            n_sim = self.n_simulations or 10 * (X.shape[1] + prior.dim)
            lo_x, hi_x = X.min(axis=0), X.max(axis=0)
            if parts:
                lo_x = np.minimum(lo_x, parts[0][0].min(axis=0))
                hi_x = np.maximum(hi_x, parts[0][0].max(axis=0))
            bounds = prior.bounds(0.999)
            d, r = X.shape[1], prior.dim
            u = stats.qmc.LatinHypercube(d=d + r, seed=rng.randint(2**31 - 1)).random(
                n_sim
            )
            X_run = lo_x + (hi_x - lo_x) * u[:, :d]
            theta_run = bounds[:, 0] + (bounds[:, 1] - bounds[:, 0]) * u[:, d:]
            y_run = run_simulator(self.simulator, X_run, theta_run, q)
            parts.append((X_run, theta_run, y_run))
        if not parts:
            raise ValueError(
                "No simulations: pass a simulator (and a prior) to the "
                "constructor, or X_sim, theta_sim and y_sim to fit."
            )
        X_sim, theta_sim, y_sim = (np.vstack(p) for p in zip(*parts, strict=True))
        return X_sim, theta_sim, y_sim

    # -------------------------------------------------------------- fit
    def fit(self, X, y, *, X_sim=None, theta_sim=None, y_sim=None):
        """Run modules 1-3 (module 4 runs at prediction time).

        Parameters
        ----------
        X : array-like of shape (n, d)
            Field inputs (design variables) of the observations.
        y : array-like of shape (n,) or (n, q)
            Field observations.
        X_sim, theta_sim, y_sim : array-like, optional
            A precomputed simulation dataset: inputs (N, d), parameters
            (N, r) and responses (N, q).

        Returns
        -------
        self
        """
        # Parallelism comes from joblib (n_jobs). Multithreaded BLAS on the
        # small and medium matrices here mostly adds synchronisation, and
        # numpy and scipy may each carry their own OpenBLAS pool, so that two
        # "2-thread" pools compete for 2 cores (measured: 2-10x slower).
        with threadpool_limits(limits=1, user_api="blas"):
            return self._fit(X, y, X_sim, theta_sim, y_sim)

    def _fit(self, X, y, X_sim, theta_sim, y_sim):
        self._check_params()
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True)
        X = X.astype(float)
        self._y_ndim = np.ndim(y)
        Y = np.asarray(y, dtype=float).reshape(len(X), -1)
        q = Y.shape[1]
        rng = check_random_state(self.random_state)
        if self.prior is None:
            if theta_sim is None:
                raise ValueError(
                    "prior is required when the simulations are run by the "
                    "simulator: pass e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
                )
            t = check_array(theta_sim, input_name="theta_sim")
            self.prior_ = check_prior(
                [
                    stats.uniform(lo, hi - lo)
                    for lo, hi in zip(t.min(0), t.max(0), strict=True)
                ]
            )
        else:
            n_par = None if theta_sim is None else np.shape(theta_sim)[1]
            self.prior_ = check_prior(self.prior, n_par)
        X_sim, theta_sim, y_sim = self._simulations(X, q, rng, X_sim, theta_sim, y_sim)
        if theta_sim.shape[1] != self.prior_.dim:
            raise ValueError(
                f"theta_sim has {theta_sim.shape[1]} columns but the prior has "
                f"{self.prior_.dim} parameters."
            )
        if len(X_sim) < 3:
            raise ValueError(
                f"{len(X_sim)} simulations are too few to fit an emulator; "
                "provide at least 10 per input dimension."
            )
        lo, hi = X_sim.min(axis=0), X_sim.max(axis=0)
        outside = np.any(
            (X < lo - 1e-9 * (hi - lo)) | (X > hi + 1e-9 * (hi - lo)), axis=1
        )
        if np.any(outside):
            warnings.warn(
                f"{int(outside.sum())} observation input(s) lie outside the range "
                "of the simulations: the emulator extrapolates there. Extend the "
                "simulation design to cover X.",
                UserWarning,
                stacklevel=2,
            )
        seeds = rng.randint(2**31 - 1, size=4)
        Z_sim, Ys_sim = self._fit_emulator(X_sim, theta_sim, y_sim, seeds[0])
        state = self.model_gp_._fit_state
        Xs_obs = self._std_x(X)
        Ys_obs = (Y - self.y_mean_) / self.y_scale_

        # Module 2: integrate the emulator over the prior, then fit the
        # discrepancy and the noise.
        mean_bar, V_bar = self._integrated_emulator(Xs_obs, seeds[1])
        disc = self._fit_discrepancy(Xs_obs, Ys_obs - mean_bar, V_bar, seeds[2])
        self.discrepancy_kernel_ = disc.kernel_
        self.discrepancy_sigma2_ = disc.sigma2 * np.outer(self.y_scale_, self.y_scale_)
        self.discrepancy_beta_ = disc.beta * self.y_scale_
        self.noise_ = disc.noise * self.y_scale_**2

        # Module 3: the posterior of theta.
        self._global = GlobalModel(
            state,
            Z_sim,
            Ys_sim,
            self.model_gp_.kernel_,
            self.regression,
            Xs_obs,
            Ys_obs,
            disc.kernel_,
            self.discrepancy_regression,
            disc.sigma2,
            disc.noise,
        )
        sampler = self.sampler
        if sampler == "auto":
            sampler = "quadrature" if self.prior_.dim == 1 else "mcmc"
        if sampler == "quadrature" and self.prior_.dim != 1:
            raise ValueError(
                f"sampler='quadrature' needs one parameter, the prior has "
                f"{self.prior_.dim}; use sampler='mcmc'."
            )
        for name in (
            "acceptance_rate_",
            "rhat_",
            "ess_",
            "theta_nodes_",
            "theta_weights_",
        ):
            if hasattr(self, name):
                delattr(self, name)
        if sampler == "quadrature":
            self._posterior_by_quadrature(np.random.RandomState(seeds[3]))
        else:
            self._posterior_by_mcmc(seeds[3])
        if sampler == "quadrature":
            nodes, weights = self.theta_nodes_, self.theta_weights_
            self.theta_mean_ = weights @ nodes
            centred = nodes - self.theta_mean_
            self.theta_cov_ = (centred * weights[:, None]).T @ centred
        else:
            self.theta_mean_ = self.theta_samples_.mean(axis=0)
            self.theta_cov_ = np.atleast_2d(np.cov(self.theta_samples_.T))
        return self

    # ------------------------------------------------- module steps
    def _fit_emulator(self, X_sim, theta_sim, y_sim, seed):
        """Standardise with the simulations as reference; fit module 1.

        Sets ``X_sim_``, ``theta_sim_``, ``y_sim_``, the standardisation
        (``X_mean_``, ``X_scale_``, ``theta_mean_sim_``, ``theta_scale_``,
        ``y_mean_``, ``y_scale_``; appendix C.2) and ``model_gp_``. Returns the
        standardised simulation inputs ``[X, theta]`` and responses.
        """
        self.X_sim_, self.theta_sim_, self.y_sim_ = X_sim, theta_sim, y_sim

        def centre_scale(A):
            scale = A.std(axis=0)
            return A.mean(axis=0), np.where(scale > 0, scale, 1.0)

        self.X_mean_, self.X_scale_ = centre_scale(X_sim)
        self.theta_mean_sim_, self.theta_scale_ = centre_scale(theta_sim)
        self.y_mean_, self.y_scale_ = centre_scale(y_sim)
        Z_sim = np.hstack([self._std_x(X_sim), self._std_theta(theta_sim)])
        Ys_sim = (y_sim - self.y_mean_) / self.y_scale_
        kernel_m = (
            default_kernel(Z_sim) if self.model_kernel is None else self.model_kernel
        )
        self.model_gp_ = MultiResponseGP(
            kernel_m,
            regression=self.regression,
            alpha=self.emulator_alpha,
            n_restarts_optimizer=self.n_restarts_optimizer,
            normalize_y=False,
            random_state=seed,
            response_nugget=1e-8,
        ).fit(Z_sim, Ys_sim)
        if self.model_gp_._fit_state is None or not np.all(self.model_gp_._active):
            raise ValueError(
                "A simulated response is constant over the simulations: it "
                "carries no information on theta. Remove it from y and y_sim."
            )
        self._Z_sim = Z_sim
        return Z_sim, Ys_sim

    def _integrated_emulator(self, Xs, seed):
        """Module 2, Eqs. 4.14-4.17 at standardised inputs ``Xs`` (n, d).

        Returns the prior-integrated mean (n, q) and the covariance
        (nq, nq; ``module2_variance`` decides whether the spread of the mean
        is added), repaired to be positive definite.
        """
        state = self.model_gp_._fit_state
        nodes, weights = self._integration_nodes(seed)
        mean_bar, corr_bar, spread = integrate_emulator(
            state,
            self.model_gp_.kernel_,
            self.regression,
            self._Z_sim,
            Xs,
            self._std_theta(nodes),
            weights,
            n_jobs=self.n_jobs,
        )
        V_bar = np.kron(state.sigma2, corr_bar)
        if self.module2_variance == "total":
            V_bar = V_bar + spread
        return mean_bar, self._repair_psd(V_bar)

    def _fit_discrepancy(self, Xs, residual, V_bar, seed):
        """Module 2, Eq. 4.19: discrepancy GP and noise by maximum likelihood.

        ``residual`` is the standardised field data minus the integrated
        emulator mean; returns the optimised :class:`DiscrepancyFit`.
        """
        kernel_d = (
            default_kernel(Xs)
            if self.discrepancy_kernel is None
            else clone(self.discrepancy_kernel)
        )
        H_d = regression_basis(Xs, self.discrepancy_regression)
        disc = DiscrepancyFit(kernel_d, Xs, residual, H_d, V_bar)
        if not self.noise:
            disc.fix_noise(1e-10)
        return disc.optimize(
            optimizer=self.discrepancy_optimizer,
            n_restarts=self.n_restarts_optimizer,
            random_state=seed,
        )

    # ----------------------------------------------------------- helpers
    def _std_x(self, X):
        return (X - self.X_mean_) / self.X_scale_

    def _std_theta(self, theta):
        return (theta - self.theta_mean_sim_) / self.theta_scale_

    def _integration_nodes(self, seed):
        r = self.prior_.dim
        rule = self.integration
        if rule == "auto":
            rule = "quadrature" if r == 1 else "qmc"
        if rule == "quadrature" and r != 1:
            raise ValueError(
                f"integration='quadrature' needs one parameter, the prior has {r}; "
                "use integration='qmc'."
            )
        n = self.n_integration_nodes or (32 if rule == "quadrature" else 256)
        return self.prior_.integration_nodes(n, random_state=seed)

    @staticmethod
    def _repair_psd(V):
        """Symmetrise; add the smallest jitter that makes V positive definite.

        The integrated covariance is positive semi-definite in exact
        arithmetic; round-off (or a kernel that is not positive definite)
        can break that. The jitter is ``max(0, -lambda_min) + 1e-10 * mean
        variance`` on the diagonal, with a warning when it exceeds round-off.
        """
        V = 0.5 * (V + V.T)
        smallest = np.linalg.eigvalsh(V)[0]
        scale = np.trace(V) / len(V)
        jitter = max(0.0, -smallest) + 1e-10 * scale
        if -smallest > 1e-8 * scale:
            warnings.warn(
                "The prior-integrated emulator covariance was not positive "
                f"definite (smallest eigenvalue {smallest:.3g}); a jitter of "
                f"{jitter:.3g} was added. Consider another model kernel "
                "(Gauss, Exp) or more integration nodes.",
                UserWarning,
                stacklevel=3,
            )
        return V + jitter * np.eye(len(V))

    def log_posterior(self, theta):
        """Module-3 log posterior of ``theta`` (user units), up to a constant.

        ``log p(theta) + log p(Y | theta, D, phi)`` with the regression
        coefficients integrated out (Eq. 4.30); ``-inf`` outside the prior's
        support or where the global covariance cannot be factored.

        Parameters
        ----------
        theta : array-like of shape (r,) or (m, r)

        Returns
        -------
        float or ndarray of shape (m,)
        """
        check_is_fitted(self, "theta_mean_")
        theta = np.asarray(theta, dtype=float)
        single = theta.ndim == 1
        theta = np.atleast_2d(theta)
        if theta.shape[1] != self.prior_.dim:
            raise ValueError(
                f"theta has {theta.shape[1]} values per row; the prior has "
                f"{self.prior_.dim} parameters."
            )
        out = np.array([self._log_posterior_one(t) for t in theta])
        return float(out[0]) if single else out

    def _log_posterior_one(self, theta):
        log_prior = float(np.ravel(self.prior_.logpdf(theta[None, :]))[0])
        if not np.isfinite(log_prior):
            return -np.inf
        try:
            return log_prior + self._global.log_likelihood(self._std_theta(theta))
        except FactorizationError:
            return -np.inf

    def _sampling_coordinates(self):
        """Set up the MCMC coordinates ``u``.

        Parameters whose prior is (practically) positive (stiffnesses,
        moduli, areas) are sampled as ``log theta``: posterior ridges such as
        ``E I = const`` are curved in ``theta`` but straight in
        ``log theta``, which random-walk proposals follow far better. Then
        ``u`` is standardised with the simulated parameters.
        """
        # Log coordinates where the prior puts at most 1e-6 of its mass on
        # non-positive values (the support, when finite; else the lower end
        # of the central 1 - 2e-6 interval): truncating that mass is then
        # negligible.
        lower = self.prior_.bounds(1.0 - 2e-6)[:, 0]
        self._log_dims = np.asarray(lower >= 0) & np.all(self.theta_sim_ > 0, axis=0)
        u = self.theta_sim_.copy()
        u[:, self._log_dims] = np.log(u[:, self._log_dims])
        self._u_mean = u.mean(axis=0)
        scale = u.std(axis=0)
        self._u_scale = np.where(scale > 0, scale, 1.0)

    def _to_u(self, theta):
        u = np.array(theta, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            u[..., self._log_dims] = np.log(u[..., self._log_dims])
        return (u - self._u_mean) / self._u_scale

    def _from_u(self, u):
        theta = np.asarray(u, dtype=float) * self._u_scale + self._u_mean
        theta[..., self._log_dims] = np.exp(theta[..., self._log_dims])
        return theta

    def _log_density_u(self, u):
        """Log posterior density of the sampling coordinates (with Jacobian)."""
        theta = self._from_u(u)
        if not np.all(np.isfinite(theta)):
            return -np.inf
        jacobian = np.sum(np.log(theta[self._log_dims]))
        return self._log_posterior_one(theta) + jacobian

    def _posterior_by_quadrature(self, rng):
        """Adaptive Gauss-Legendre quadrature of the 1-D posterior.

        A first rule over the prior's 0.9999 interval locates the mass, a
        second one over the region holding all but 1e-12 of it resolves it.
        """
        lo, hi = self.prior_.bounds(0.9999)[0]
        nodes_gl, weights_gl = np.polynomial.legendre.leggauss(201)
        for _ in range(2):
            t = 0.5 * (hi - lo) * nodes_gl + 0.5 * (hi + lo)
            logp = np.array([self._log_posterior_one(np.array([v])) for v in t])
            if not np.any(np.isfinite(logp)):
                raise FactorizationError(
                    "The posterior is zero (or could not be evaluated) at every "
                    "quadrature node: check the prior's support against theta_sim."
                )
            w = weights_gl * np.exp(logp - np.max(logp))
            w = w / w.sum()
            mass = np.cumsum(w)
            inside = np.flatnonzero((mass > 1e-12) & (mass < 1 - 1e-12))
            i0 = max((inside[0] if inside.size else np.argmax(w)) - 2, 0)
            i1 = min((inside[-1] if inside.size else np.argmax(w)) + 2, len(t) - 1)
            lo, hi = t[i0], t[i1]
        self.theta_nodes_ = t[:, None]
        self.theta_weights_ = w
        # Draws by inverse-CDF sampling of the piecewise-linear posterior CDF.
        cdf = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]))])
        cdf = cdf / cdf[-1]
        u = (np.arange(self.n_samples) + rng.uniform()) / self.n_samples
        self.theta_samples_ = np.interp(u, cdf, t)[:, None]
        # Module 4 integrates over the posterior with a smaller rule on the
        # same interval (each node costs a factorisation at prediction time).
        x, v = np.polynomial.legendre.leggauss(_N_PREDICT_NODES)
        nodes = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
        logp = np.array([self._log_posterior_one(np.array([u])) for u in nodes])
        v = v * np.exp(logp - np.max(logp))
        self._pred_thetas = nodes[:, None]
        self._pred_weights = v / v.sum()

    def _laplace(self, starts):
        """Posterior mode and covariance (Laplace) in the sampling coordinates.

        The mode maximises the log posterior from the given starts
        (Nelder-Mead: the log posterior is cheap and has no gradient here);
        the covariance is the inverse of a central finite-difference Hessian
        whose steps follow the posterior's own scale. Both only initialise the
        Metropolis-Hastings chains.
        """

        def negative(t):
            value = self._log_density_u(t)
            return -value if np.isfinite(value) else 1e300

        best = min(
            (
                optimize.minimize(
                    negative,
                    start,
                    method="Nelder-Mead",
                    options={"xatol": 1e-8, "fatol": 1e-10, "maxiter": 4000},
                )
                for start in starts
            ),
            key=lambda res: res.fun,
        )
        mode = best.x
        r = mode.size
        step = np.full(r, 1e-3)
        cov = np.eye(r) * 1e-2
        for _ in range(3):
            H = np.empty((r, r))
            f0 = negative(mode)
            for i in range(r):
                for j in range(i, r):
                    ei = np.eye(r)[i] * step[i]
                    ej = np.eye(r)[j] * step[j]
                    H[i, j] = H[j, i] = (
                        negative(mode + ei + ej)
                        - negative(mode + ei - ej)
                        - negative(mode - ei + ej)
                        + negative(mode - ei - ej)
                    ) / (4 * step[i] * step[j])
            values, vectors = np.linalg.eigh(0.5 * (H + H.T))
            if np.all(values > 0) and np.all(np.isfinite(values)) and f0 < 1e300:
                cov = (vectors / values) @ vectors.T
                step = 0.1 * np.sqrt(np.diag(cov))
            else:
                step = step * 10.0
        return mode, cov

    def _posterior_by_mcmc(self, seed):
        rng = np.random.RandomState(seed)
        r = self.prior_.dim
        # Starts: the best of many prior draws, refined to the mode; the
        # chains then start overdispersed around it with a Laplace proposal.
        candidates = self.prior_.rvs(50 * self.n_chains, random_state=rng)
        logp = np.array([self._log_posterior_one(c) for c in candidates])
        order = np.argsort(logp)[::-1][: self.n_chains]
        if not np.all(np.isfinite(logp[order])):
            raise FactorizationError(
                "Fewer than n_chains prior draws have a finite posterior: check "
                "the prior's support against theta_sim."
            )
        self._sampling_coordinates()
        mode, cov = self._laplace(self._to_u(candidates[order[:2]]))
        root = np.linalg.cholesky(cov + 1e-12 * np.trace(cov) * np.eye(r))
        starts = []
        while len(starts) < self.n_chains:
            start = mode + 1.5 * root @ rng.standard_normal(r)
            if np.isfinite(self._log_density_u(start)):
                starts.append(start)
        result = run_chains(
            self._log_density_u,
            np.array(starts),
            n_samples=self.n_samples,
            burn_in=self.burn_in,
            proposal_cov=(2.38**2 / r) * cov,
            adapt=True,
            n_jobs=self.n_jobs,
            random_state=rng.randint(2**31 - 1),
        )
        self.theta_samples_ = self._from_u(result.pooled)
        self.acceptance_rate_ = result.acceptance_rate
        self.rhat_ = result.rhat
        self.ess_ = result.ess
        check_diagnostics(result)
        step = max(1, len(self.theta_samples_) // _N_PREDICT_DRAWS)
        self._pred_thetas = self.theta_samples_[::step][:_N_PREDICT_DRAWS]
        self._pred_weights = np.full(
            len(self._pred_thetas), 1.0 / len(self._pred_thetas)
        )

    # ---------------------------------------------------------- module 4
    def _predict_component(self, X, component, return_std):
        check_is_fitted(self, "theta_mean_")
        X = validate_data(self, X, reset=False).astype(float)
        Xs = self._std_x(X)
        thetas = self._std_theta(self._pred_thetas)
        w = self._pred_weights
        gm = self._global

        def one(theta):
            return gm.predict(theta, Xs, component, return_var=return_std)

        with threadpool_limits(limits=1, user_api="blas"):
            results = Parallel(n_jobs=self.n_jobs)(delayed(one)(t) for t in thetas)
        if return_std:
            means = np.stack([m for m, _ in results])
            variances = np.stack([v for _, v in results])
        else:
            means = np.stack(results)
        mean = np.tensordot(w, means, axes=1)
        offset = 0.0 if component == "discrepancy" else self.y_mean_
        mean_user = mean * self.y_scale_ + offset
        if self._y_ndim == 1:
            mean_user = mean_user[:, 0]
        if not return_std:
            return mean_user
        # Law of total variance over the posterior (Eqs. 4.34, 4.41).
        var = np.tensordot(w, variances, axes=1) + np.tensordot(
            w, (means - mean) ** 2, axes=1
        )
        std = np.sqrt(var) * self.y_scale_
        if self._y_ndim == 1:
            std = std[:, 0]
        return mean_user, std

    def predict(self, X, return_std=False):
        """Calibrated prediction of a new field measurement (module 4).

        The mean and standard deviation of ``y_e(x) = y_m(x, theta) + delta(x)
        + eps`` averaged over the posterior of ``theta`` (laws of total
        expectation and variance, Eqs. 4.35-4.41); the standard deviation
        includes the measurement noise.

        Parameters
        ----------
        X : array-like of shape (s, d)
        return_std : bool, default=False

        Returns
        -------
        mean : ndarray of shape (s,) or (s, q)
        std : ndarray, same shape (only when ``return_std``)
        """
        return self._predict_component(X, "observation", return_std)

    def predict_reality(self, X, return_std=False):
        """Prediction of the true process ``y_m(x, theta) + delta(x)`` (no noise)."""
        return self._predict_component(X, "reality", return_std)

    def predict_model(self, X, return_std=False):
        """Prediction of the model output ``y_m(x, theta)`` over the posterior.

        Conditional on all data (simulations and field data) at each
        ``theta``, then averaged over the posterior (Eqs. 4.33-4.34).
        """
        return self._predict_component(X, "model", return_std)

    def predict_discrepancy(self, X, return_std=False):
        """Prediction of the discrepancy ``delta(x)`` over the posterior.

        The conditional moments of ``delta`` given all data at each
        ``theta`` (Eqs. 4.42-4.43, with the global model), averaged over the
        posterior. ``predict_model + predict_discrepancy`` equals
        :meth:`predict_reality` in the mean.
        """
        return self._predict_component(X, "discrepancy", return_std)
