"""ModularBayesCalibrator: the four modules of the modular Bayesian approach."""

import copy
import time
import warnings
from numbers import Integral, Real

import numpy as np
from joblib import Parallel, delayed, effective_n_jobs
from scipy import optimize, sparse, stats
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, clone
from sklearn.gaussian_process.kernels import Kernel
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_array, check_is_fitted, validate_data
from threadpoolctl import threadpool_limits

from skmba._discrepancy import (
    DISCREPANCY_OPTIMIZERS,
    DiscrepancyFit,
    bound_roughness,
    check_discrepancy_ranges,
)
from skmba._gp import MultiResponseGP, default_kernel
from skmba._integration import integrate_emulator, nodes_per_block
from skmba._linalg import FactorizationError, check_memory
from skmba._posterior import GlobalModel
from skmba._priors import check_prior
from skmba._regression import REGRESSIONS, n_regression_terms, regression_basis
from skmba._sampling import check_diagnostics, run_chains

MODULE2_VARIANCES = ("total", "conditional")
INTEGRATIONS = ("auto", "quadrature", "qmc")
SAMPLERS = ("auto", "quadrature", "mcmc")
_N_PREDICT_DRAWS = 200  # posterior draws used by the module-4 predictions (MCMC)
_N_PREDICT_NODES = 41  # quadrature nodes used by them (one parameter)
_PREDICT_CHUNK = 10  # posterior draws per module-4 task
# One-parameter posterior quadrature: nodes per pass, most passes, and the
# nodes that must carry the mass for the posterior to count as resolved.
_QUADRATURE_NODES = 201
_QUADRATURE_PASSES = 8
_RESOLVED_NODES = 40
# Share of the prior mass that must lie in the simulated range of theta
# (less: error), and share that may lie outside it without a warning (the
# simulator's own design leaves out 1e-3 per unbounded parameter).
_PRIOR_MASS_ERROR = 0.01
_PRIOR_MASS_WARNING = 0.02
_FLOAT = 8  # bytes per float64
_FEWER_FIELD_DATA = (
    "Use fewer field observations or responses (average repeated "
    "measurements, or calibrate on a subset of the responses), or a smaller "
    "n_jobs."
)


def _nonfinite_runs(Y):
    """Indices of the rows of ``Y`` with a NaN or an infinity."""
    return np.flatnonzero(~np.all(np.isfinite(Y), axis=1))


def _check_simulator_output(Y, n, q, first_run, check_finite=True):
    try:
        Y = np.asarray(Y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"simulator returned a {type(Y).__name__} that is not an array of "
            f"numbers ({exc}); it must return a float array of shape "
            f"({n}, {q if q is not None else 'q'}): one row per run and one "
            "column per response."
        ) from exc
    if Y.ndim == 1 and (q in (None, 1)):
        Y = Y.reshape(-1, 1)
    if Y.ndim != 2 or Y.shape[0] != n or (q is not None and Y.shape[1] != q):
        expected = f"({n}, {q if q is not None else 'q'})"
        raise ValueError(
            f"simulator returned an array of shape {np.shape(Y)} for runs "
            f"{first_run}..{first_run + n - 1}; it must return {expected}: one row "
            "per run and one column per response."
        )
    bad = _nonfinite_runs(Y)
    if check_finite and bad.size:
        runs = (bad + first_run).tolist()[:10]
        raise ValueError(
            f"simulator returned non-finite values (NaN or inf) for runs {runs}. "
            "Fix the model for these inputs or narrow the prior / input range."
        )
    return Y


def run_simulator(simulator, X, theta, q=None, *, check_finite=True):
    """Run ``simulator(X, theta)`` and check what it returns.

    When the batch call raises, the runs are retried one by one so that the
    error names the failing run and its inputs; the original exception is
    chained (``__cause__``). ``check_finite=False`` leaves NaN and inf in
    the output for the caller to report.

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
                    f"simulator raised {type(exc).__name__} at run {i} (of "
                    f"{len(X)}) with X={X[i].tolist()}, theta={theta[i].tolist()}: "
                    f"{exc}. Fix the simulator for these inputs, or run the "
                    "simulations yourself and pass the successful ones to "
                    "fit(X, y, X_sim=..., theta_sim=..., y_sim=...)."
                ) from exc
        raise RuntimeError(
            f"simulator raised {type(batch_error).__name__} on the batch of "
            f"{len(X)} runs but on none of them alone: {batch_error}. Check "
            "that it handles arrays of several rows (X of shape (n, d), theta "
            "of shape (n, r))."
        ) from batch_error
    return _check_simulator_output(Y, len(X), q, 0, check_finite=check_finite)


def _as_array(A):
    """``np.asarray(A)``, or None for what ``check_array`` should report.

    Sparse matrices and ragged or otherwise unconvertible input are left to
    scikit-learn's ``check_array``/``validate_data`` and their messages.
    """
    if A is None or sparse.issparse(A):
        return None
    try:
        return np.asarray(A)
    except (TypeError, ValueError):
        return None


def _check_2d(A, name, shape):
    """``A`` must be a 2-D array; the message says how to reshape a vector."""
    A = _as_array(A)
    if A is None:
        return
    ndim = A.ndim
    if ndim != 2:
        fix = (
            f"use {name}.reshape(-1, 1) for a single column"
            if ndim == 1
            else "pass one row per sample"
        )
        raise ValueError(
            f"{name} must be a 2-D array of shape {shape}, got {ndim}-D with "
            f"shape {A.shape}; {fix}."
        )


def _check_finite_rows(A, name):
    bad = _nonfinite_runs(A)
    if bad.size:
        raise ValueError(
            f"{name} contains NaN or inf in rows {bad[:10].tolist()}"
            f"{' (and more)' if bad.size > 10 else ''}: drop these rows (failed "
            "simulation runs) from X_sim, theta_sim and y_sim alike."
        )


def _predict_chunk(global_model, thetas, Xs, component, return_std):
    """Module-4 conditional moments at several posterior draws (one task).

    A shallow copy gives the task its own factorisation cache, so that tasks
    sharing the model under a thread-based backend cannot see each other's;
    BLAS is held to one thread so that the bits do not depend on the worker.
    """
    model = copy.copy(global_model)
    with threadpool_limits(limits=1, user_api="blas"):
        return [
            model.predict(theta, Xs, component, return_var=return_std)
            for theta in thetas
        ]


class _ChainTarget:
    """Log density of the MCMC coordinates for one chain (picklable).

    Each chain gets its own shallow copy of the global model, hence its own
    factorisation cache (see :func:`_predict_chunk`).
    """

    def __init__(self, calibrator):
        self.calibrator = calibrator
        self.global_model = copy.copy(calibrator._global)

    def __call__(self, u):
        return self.calibrator._log_density_u(u, self.global_model)


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
      noise ``noise_`` by maximum likelihood (Eq. 4.19), within the ranges
      of the discrepancy hyperparameters of thesis Table 6.2
      (``discrepancy_prior``).
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
        0.999 central interval for unbounded priors). It is the user's: to
        pickle the estimator it must be picklable (a module-level function
        or an instance of a module-level class, not a lambda or a local
        function). It is not needed after ``fit``: ``set_params(
        simulator=None)`` keeps a fitted calibrator working (see Notes).
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
        Metropolis-Hastings chains (MCMC only), run in parallel.
    n_samples : int, default=5000
        Draws per chain kept after burn-in (MCMC), or the number of draws
        ``theta_samples_`` resampled from the quadrature posterior.
    burn_in : int, default=1000
        Draws per chain discarded; the proposal adapts during burn-in only.
    n_jobs : int, default=None
        Parallel chains, module-2 node blocks and module-4 predictions,
        through joblib (so ``joblib.parallel_config(backend="dask")`` works,
        see Notes). ``None`` means 1 unless a joblib context says otherwise,
        ``-1`` all cores; 0 is invalid. During ``fit`` and the predictions
        BLAS is held to one thread: the parallelism is joblib's.
    random_state : int, RandomState instance or None, default=None
        The same seed gives bit-identical results for any ``n_jobs`` and
        joblib backend.
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
    discrepancy_prior : dict, default=None
        Ranges of the discrepancy hyperparameters, a uniform prior whose
        maximum a posteriori module 2 finds (the likelihood maximised inside
        them), in the standardised units of the simulations (inputs and
        responses centred and scaled by their spread over the simulations)::

            {"roughness": (0.1, 9.0),   # per design variable
             "variance": (1e-2, 20.0)}  # diagonal of Sigma_d, per response

        None means these values, thesis Table 6.2 (also the default prior of
        :class:`~skmba.PreposteriorDesigner`). Each range is ``(low, high)``
        of scalars or of arrays (one value per design variable or response);
        a missing key takes Table 6.2's range and ``None`` removes it:
        ``"roughness": None`` keeps the discrepancy kernel's own
        ``roughness_bounds``, ``"variance": None`` lets the variances go to
        zero (the plain maximum likelihood). The lower end of ``"variance"``
        is held as each response's own part of the discrepancy, which a
        correlation between responses cannot cancel: ``Sigma_d - diag(low)``
        is positive semi-definite. A kernel whose roughness is ``"fixed"``
        keeps it. See Notes for why the default has a lower end.
    emulator_alpha : float, default=1e-8
        Nugget of the emulator's correlation matrix, at the simulations and
        at the field inputs of the module-3 likelihood alike (the model term
        of the global covariance is ``Sigma2_m ⊗ (R + alpha I)``).
    verbose : int, default=0
        Progress messages, printed to standard output with the prefix
        ``[ModularBayesCalibrator]``. 0 is silent. 1 prints a line when
        module 1 is done (its time), when module 2 is done (its time and the
        noise variances), for each quadrature pass or, with MCMC, when the
        chains start and for each chain (acceptance rate), and when module 3
        is done (time, posterior mean and, for MCMC, R-hat and ESS). 2 and
        more also make joblib report its tasks and each chain print the end
        of its burn-in and every quarter of its draws; these lines come from
        the process that runs the chain, which for process-based joblib
        backends is a worker, not the Python session.

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
    theta_chains_ : ndarray of shape (n_chains, n_samples, r)
        The MCMC draws after burn-in chain by chain, in user units, for trace
        plots; ``theta_samples_`` is ``theta_chains_.reshape(-1, r)``. Only
        with MCMC.
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

    Notes
    -----
    **Discrepancy and identifiability.** When the model at some ``theta``
    reproduces the field data exactly, the discrepancy and ``theta`` are
    confounded: on the thesis' cantilever the support spring changes the tip
    displacement and the energy by the same fraction, so a fixed-support
    beam with a 3 % softer modulus explains both with no discrepancy. The
    plain maximum likelihood then sets the discrepancy variance to about
    zero (or the discrepancies of the responses perfectly correlated), and
    module 3 returns that modulus with a posterior sd of tens of MPa,
    excluding the true one: the credible interval ignores that the model is
    known to be an idealisation (Brynjarsdottir & O'Hagan, 2014, "Learning
    about physical parameters: the importance of model discrepancy",
    Inverse Problems 30). The default lower end of the discrepancy variance,
    1 % of each response's simulated variance (Table 6.2), says that the
    model is not exact; on the cantilever it widens the posterior sd of E
    to about 3 % and the interval contains the true modulus (see
    ``tests/test_calibration.py``). The width of the posterior then depends
    on this range, which is prior knowledge: set it from what is known of
    the model's errors, or pass ``{"variance": None}`` for the plain
    maximum likelihood. ``verbose=1`` reports the fitted discrepancy
    variances against the range.

    **Run time.** Module 1 factors the N x N correlation of the N
    simulations (``n_simulations`` runs and/or the rows of ``X_sim``) once
    per likelihood evaluation, O(N^3), for ``1 + n_restarts_optimizer``
    optimisations. Module 2 evaluates the emulator at n x
    ``n_integration_nodes`` points (n observations) and factors an nq x nq
    matrix (q responses) per likelihood evaluation. Module 3 factors an
    nq x nq Schur complement per posterior evaluation: 201 per quadrature
    pass (2 to 8 passes, see ``verbose``) + 41 for the one-parameter
    quadrature, ``n_chains * (burn_in +
    n_samples)`` for MCMC, whose chains run in parallel (``n_jobs``). Each
    module-4 prediction costs one such evaluation per posterior draw it
    averages over (41 quadrature nodes or 200 MCMC draws). To bound the run
    time, lower ``n_samples`` and ``burn_in`` (linear in the MCMC time),
    ``n_chains`` (linear beyond ``n_jobs`` cores), ``n_integration_nodes``
    and ``n_restarts_optimizer``; ``n_simulations`` enters the module-1 time
    cubically. ``verbose=1`` prints the time of each module.

    **Parallel and distributed runs.** All parallel work (MCMC chains,
    module-2 node blocks, module-4 draws) goes through :mod:`joblib`, so a
    Dask cluster runs it without other changes (``pip install
    "skmba[dask]"``)::

        from dask.distributed import Client
        from joblib import parallel_config

        client = Client("tcp://scheduler:8786")  # the cluster's scheduler
        with parallel_config(backend="dask"):
            calibrator.fit(X, y)

    The workers need ``skmba`` and whatever the simulator imports. Results
    do not depend on the backend nor on ``n_jobs``: each chain is seeded by
    its own child of a :class:`numpy.random.SeedSequence` (not by the order
    of execution), module-2 nodes are cut into blocks of a fixed size, and
    every task holds BLAS to one thread. The simulator itself runs in the
    calling process, once, on all design points.

    **Persistence.** A fitted calibrator survives ``pickle`` and
    ``joblib.dump``/``joblib.load`` with identical predictions and
    ``log_posterior``: its fitted state is arrays, kernels, the prior and
    plain objects (no lambdas, closures or open files). Pickling the
    estimator also pickles its parameters, including ``simulator``; when
    the simulator cannot be pickled (a lambda, a wrapper around a solver
    process), call ``set_params(simulator=None)`` first: the predictions
    and ``log_posterior`` do not use it.

    **Checks.** ``fit`` rejects invalid data and parameters with a
    ValueError or TypeError that names the argument and the fix: NaN or inf
    in any array (the rows are listed), wrong shapes, fewer field
    observations than discrepancy regression terms, too few simulations for
    the emulator's regression, constant columns of ``theta_sim`` or of the
    simulated responses, unknown option strings, non-positive sizes, priors
    of the wrong dimension or zero width, and a prior with less than 1 % of
    its mass on the simulated range of theta. It warns (``UserWarning``)
    when the field inputs have no more distinct rows than the discrepancy
    has regression terms (e.g. all observations at one load with a
    constant discrepancy mean: the posterior is then the prior), when
    observation inputs lie outside the range of the simulations, when more
    than 2 % of the prior mass lies outside the simulated range of theta
    (the emulator extrapolates there), and when MCMC diagnostics are poor.
    Both ranges are widened at each end by one mean spacing of the runs,
    ``(max - min) / (N - 1)``: a space-filling design stops about that
    short of the ends of its range. A simulator that raises gives a
    RuntimeError naming the failing run and its inputs, with the original
    exception chained. When ``fit`` fails after the simulator ran, its runs
    are kept in ``X_sim_``, ``theta_sim_`` and ``y_sim_`` (and the error
    says so), so that a week of simulations is not lost: pass them back
    with ``fit(X, y, X_sim=..., theta_sim=..., y_sim=...)`` after
    ``set_params(simulator=None)``.

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
        discrepancy_prior=None,
        emulator_alpha=1e-8,
        verbose=0,
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
        self.discrepancy_prior = discrepancy_prior
        self.emulator_alpha = emulator_alpha
        self.verbose = verbose

    # ------------------------------------------------------------ checks
    def _check_params(self):
        for name in ("regression", "discrepancy_regression"):
            value = getattr(self, name)
            if not isinstance(value, str) or value not in REGRESSIONS:
                raise ValueError(
                    f"{name}={value!r} is not supported; use one of "
                    f"{REGRESSIONS} (thesis Table 3.1)."
                )
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
            if not isinstance(value, str) or value not in allowed:
                raise ValueError(
                    f"{name}={value!r} is not supported; use one of {allowed}."
                )

        def is_int(value):
            return isinstance(value, Integral) and not isinstance(value, bool)

        for name in ("n_chains", "n_samples"):
            value = getattr(self, name)
            if not is_int(value) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}.")
        for name in ("burn_in", "n_restarts_optimizer", "verbose"):
            value = getattr(self, name)
            if not is_int(value) or value < 0:
                raise ValueError(
                    f"{name} must be a non-negative integer, got {value!r}."
                )
        for name in ("n_simulations", "n_integration_nodes"):
            value = getattr(self, name)
            if value is not None and (not is_int(value) or value < 2):
                raise ValueError(
                    f"{name} must be an integer >= 2 or None, got {value!r}."
                )
        if self.n_jobs is not None and (not is_int(self.n_jobs) or self.n_jobs == 0):
            raise ValueError(
                f"n_jobs must be None, a positive integer (number of parallel "
                f"tasks) or a negative one (-1: all cores), got {self.n_jobs!r}."
            )
        if not isinstance(self.noise, (bool, np.bool_)):
            raise TypeError(
                f"noise must be True or False, got {type(self.noise).__name__}."
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
        alpha = self.emulator_alpha
        if (
            isinstance(alpha, bool)
            or not isinstance(alpha, Real)
            or not np.isfinite(alpha)
            or alpha < 0
        ):
            raise ValueError(
                f"emulator_alpha must be a finite float >= 0 (the emulator's "
                f"nugget, e.g. 1e-8), got {alpha!r}."
            )

    def _check_field_data(self, X, y):
        """Shapes, size and finiteness of the field data, before sklearn's checks.

        Sparse or non-numeric data are left to ``validate_data``.
        """
        _check_2d(X, "X", "(n_samples, n_features)")
        X, y = _as_array(X), _as_array(y)
        if X is None or y is None:
            return
        if y.ndim not in (1, 2):
            raise ValueError(
                f"y must be an array of shape (n_samples,) or (n_samples, q), "
                f"got shape {y.shape}."
            )
        n, d = X.shape
        if len(y) != n:
            raise ValueError(
                f"X and y have {n} and {len(y)} rows: y must hold one "
                "row of observed responses per row of field inputs X."
            )
        p_d = n_regression_terms(self.discrepancy_regression, d)
        if n <= p_d:
            raise ValueError(
                f"X has {n} sample(s) (n_samples={n}): module 2 needs more field "
                f"observations than the {p_d} term(s) of discrepancy_regression="
                f"{self.discrepancy_regression!r} with {d} design variable(s). "
                "Add observations, or use a lower-order discrepancy_regression."
            )
        for name, A in (("X", X), ("y", y)):
            if A.dtype.kind not in "biuf":
                continue  # complex, text or objects: validate_data names it
            bad = _nonfinite_runs(A.reshape(n, -1))
            if bad.size:
                raise ValueError(
                    f"Input {name} contains NaN or inf in rows {bad[:10].tolist()}"
                    f"{' (and more)' if bad.size > 10 else ''}: remove these "
                    "observations (the same rows of X and y) or impute them."
                )

    def _given_simulations(self, X, q, X_sim, theta_sim, y_sim):
        """The precomputed simulation dataset, checked; None when not given."""
        given = [a is not None for a in (X_sim, theta_sim, y_sim)]
        if not any(given):
            return None
        if not all(given):
            raise ValueError(
                "Pass X_sim, theta_sim and y_sim together (a precomputed "
                "simulation dataset), or none of them."
            )
        _check_2d(X_sim, "X_sim", "(n_simulations, d)")
        _check_2d(theta_sim, "theta_sim", "(n_simulations, r)")
        y_array = _as_array(y_sim)
        if y_array is not None and y_array.ndim not in (1, 2):
            raise ValueError(
                f"y_sim must be an array of shape (n_simulations, q), got shape "
                f"{y_array.shape}."
            )
        arrays = {}
        for name, A in (("X_sim", X_sim), ("theta_sim", theta_sim), ("y_sim", y_sim)):
            A = check_array(
                A,
                input_name=name,
                ensure_2d=False,
                ensure_all_finite=False,
                ensure_min_samples=0,
                dtype=float,
            )
            arrays[name] = A if A.ndim == 2 else A.reshape(-1, 1)
        X_sim, theta_sim, y_sim = arrays["X_sim"], arrays["theta_sim"], arrays["y_sim"]
        if not len(X_sim) == len(theta_sim) == len(y_sim):
            raise ValueError(
                "X_sim, theta_sim and y_sim must have the same number of rows, "
                f"got {len(X_sim)}, {len(theta_sim)} and {len(y_sim)}."
            )
        if len(X_sim) == 0:
            raise ValueError(
                "X_sim, theta_sim and y_sim are empty (0 simulations): pass the "
                "simulation dataset, or None and a simulator."
            )
        for name, A in arrays.items():
            _check_finite_rows(A, name)
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
        return X_sim, theta_sim, y_sim

    def _simulations(self, X, q, rng, given):
        """Given and simulated runs, stacked; stores them in ``X_sim_`` etc."""
        parts = [] if given is None else [given]
        n_run = 0
        k = X.shape[1] + self.prior_.dim
        n_sim = 0
        if self.simulator is not None:
            n_sim = self.n_simulations or 10 * k
        n_total = n_sim + (0 if given is None else len(given[0]))
        p_m = n_regression_terms(self.regression, k)
        needed = max(3, p_m + 1)
        if n_total and n_total < needed:
            raise ValueError(
                f"{n_total} simulations are too few to fit an emulator: "
                f"regression={self.regression!r} on d + r = {k} inputs needs at "
                f"least {needed}; provide about 10 per input ({10 * k}) with "
                "n_simulations or X_sim, theta_sim and y_sim."
            )
        if self.simulator is not None:
            prior = self.prior_
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
            started = time.perf_counter()
            y_run = run_simulator(
                self.simulator, X_run, theta_run, q, check_finite=False
            )
            self._say(
                f"simulator: {n_sim} runs in {time.perf_counter() - started:.1f} s"
            )
            parts.append((X_run, theta_run, y_run))
            n_run = n_sim
        if not parts:
            raise ValueError(
                "No simulations: pass a simulator (and a prior) to the "
                "constructor, or X_sim, theta_sim and y_sim to fit."
            )
        X_sim, theta_sim, y_sim = (np.vstack(p) for p in zip(*parts, strict=True))
        # Keep the runs before anything else can fail (see fit).
        self.X_sim_, self.theta_sim_, self.y_sim_ = X_sim, theta_sim, y_sim
        self._simulator_runs = n_run
        bad = _nonfinite_runs(y_sim[len(y_sim) - n_run :])
        if bad.size:
            first = bad[0]
            rows = (bad + len(y_sim) - n_run).tolist()
            raise ValueError(
                f"simulator returned non-finite values (NaN or inf) for "
                f"{bad.size} of {n_run} runs, e.g. run {first} with "
                f"X={X_run[first].tolist()}, theta={theta_run[first].tolist()}. "
                "Fix the model for these inputs or narrow the prior / input "
                f"range; or drop rows {rows[:10]}{' ...' if len(rows) > 10 else ''}"
                " of X_sim_, theta_sim_ and y_sim_ (which keep all runs) and "
                "pass the rest to fit(X, y, X_sim=..., theta_sim=..., y_sim=...) "
                "with simulator=None."
            )
        return X_sim, theta_sim, y_sim

    def _check_simulation_design(self, X, X_sim, theta_sim, y_sim):
        """Whether the simulations can support an emulator and the prior."""
        n_sim = len(X_sim)

        def constant(A):
            spread = np.ptp(A, axis=0)
            return np.flatnonzero(spread <= 1e-12 * np.abs(A).max(axis=0))

        fixed = constant(theta_sim)
        if fixed.size:
            raise ValueError(
                f"theta_sim column(s) {fixed.tolist()} are constant (e.g. "
                f"theta[{fixed[0]}] = {theta_sim[0, fixed[0]]:.6g} in every "
                "run): the simulations carry no information on how the model "
                "depends on theta. Vary each parameter over the prior's range "
                "in the simulations."
            )
        fixed = constant(y_sim)
        if fixed.size:
            raise ValueError(
                f"y_sim column(s) {fixed.tolist()} are constant over the "
                "simulations: a response that does not change with theta or x "
                "carries no information on theta. Remove these responses from "
                "y and y_sim."
            )
        # The simulated range, widened by one mean spacing of the runs at each
        # end: a space-filling design leaves about that much uncovered at the
        # edges, where the emulator extrapolates harmlessly.
        lo, hi = theta_sim.min(axis=0), theta_sim.max(axis=0)
        margin = (hi - lo) / max(n_sim - 1, 1)
        inside = self.prior_.mass_inside(lo - margin, hi + margin)
        box = ", ".join(
            f"theta[{j}] in [{a:.4g}, {b:.4g}]"
            for j, (a, b) in enumerate(zip(lo, hi, strict=True))
        )
        if inside < _PRIOR_MASS_ERROR:
            raise ValueError(
                f"The prior puts {inside:.2%} of its mass on the simulated range "
                f"of theta_sim ({box}): the simulations miss the prior, and the "
                "emulator would extrapolate over all of it. Simulate over the "
                "prior's support (e.g. let the calibrator run the simulator), "
                "or correct the prior (are its units those of theta_sim?)."
            )
        if 1.0 - inside > _PRIOR_MASS_WARNING:
            warnings.warn(
                f"{1.0 - inside:.1%} of the prior mass lies outside the simulated "
                f"range of theta_sim ({box}): the emulator extrapolates there, "
                "and module 2 integrates it over the whole prior. Extend the "
                "simulations to cover the prior, or narrow the prior.",
                UserWarning,
                stacklevel=4,
            )
        # The same margin for the observation inputs: a Latin hypercube over
        # the range of X (the simulator's design) stops short of its ends.
        lo, hi = X_sim.min(axis=0), X_sim.max(axis=0)
        margin = (1.0 / max(n_sim - 1, 1) + 1e-9) * (hi - lo)
        outside = np.any((X < lo - margin) | (X > hi + margin), axis=1)
        if np.any(outside):
            warnings.warn(
                f"{int(outside.sum())} observation input(s) lie outside the range "
                "of the simulations (widened by one mean spacing of the runs): "
                "the emulator extrapolates there. Extend the simulation design "
                "to cover X.",
                UserWarning,
                stacklevel=4,
            )

    def _n_workers(self):
        """Tasks joblib runs at the same time (``n_jobs`` and its context)."""
        return max(1, effective_n_jobs(self.n_jobs))

    def _check_global_memory(self, N, n, q):
        """Room for the module-3 global model, before it is built.

        About six nq x nq matrices (the fixed part and, per factorisation,
        the Schur complement, its Kronecker term and Cholesky factor), plus
        the (N, n) cross-correlations and the (N q, P) whitened regression;
        each parallel chain holds its own factorisation.
        """
        P = q * (
            n_regression_terms(self.regression, self._Z_sim.shape[1])
            + n_regression_terms(self.discrepancy_regression, self.n_features_in_)
        )
        jobs = self._n_workers() if self.prior_.dim > 1 else 1
        needed = _FLOAT * (
            (3 + 3 * jobs) * (n * q) ** 2 + 2 * jobs * N * n + 2 * N * q * P
        )
        check_memory(
            needed,
            f"The module-3 global model ({N} simulations and {n} field "
            f"observations x {q} responses)",
            _FEWER_FIELD_DATA,
        )

    def _say(self, message):
        """Progress message when ``verbose > 0`` (see the class docstring)."""
        if self.verbose > 0:
            print(f"[ModularBayesCalibrator] {message}", flush=True)

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

        Raises
        ------
        ValueError, TypeError
            Invalid data or parameters; the message names the argument and
            the fix (see the class Notes).
        RuntimeError
            The simulator raised; the message names the run and its inputs
            and the simulator's exception is chained.

        Warns
        -----
        UserWarning
            Observation inputs outside the range of the simulations; more
            than 2 % of the prior mass outside the simulated range of theta;
            poor MCMC diagnostics (R-hat, effective sample size).
        """
        # Parallelism comes from joblib (n_jobs). Multithreaded BLAS on the
        # small and medium matrices here mostly adds synchronisation, and
        # numpy and scipy may each carry their own OpenBLAS pool, so that two
        # "2-thread" pools compete for 2 cores (measured: 2-10x slower).
        self._simulator_runs = 0
        try:
            with threadpool_limits(limits=1, user_api="blas"):
                return self._fit(X, y, X_sim, theta_sim, y_sim)
        except Exception as exc:
            if self._simulator_runs and hasattr(exc, "add_note"):
                exc.add_note(
                    f"The {self._simulator_runs} simulator runs of this fit are "
                    "kept in X_sim_, theta_sim_ and y_sim_ (with any precomputed "
                    "simulations): after fixing the problem, call "
                    "set_params(simulator=None) and fit(X, y, X_sim=X_sim_, "
                    "theta_sim=theta_sim_, y_sim=y_sim_) so as not to run the "
                    "simulator again."
                )
            raise

    def _fit(self, X, y, X_sim, theta_sim, y_sim):
        self._check_params()
        self._check_field_data(X, y)
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True)
        X = X.astype(float)
        n = len(X)
        p_d = n_regression_terms(self.discrepancy_regression, X.shape[1])
        n_distinct = len(np.unique(X, axis=0))
        if n_distinct <= p_d:
            warnings.warn(
                f"X has {n_distinct} distinct row(s): with discrepancy_regression="
                f"{self.discrepancy_regression!r} ({p_d} term(s)) the unknown mean "
                "of the discrepancy absorbs any offset there, so the field data "
                "carry no information on theta and its posterior is the prior. "
                "Observe the system at more distinct inputs.",
                UserWarning,
                stacklevel=3,
            )
        self._y_ndim = np.ndim(y)
        Y = np.asarray(y, dtype=float).reshape(n, -1)
        q = Y.shape[1]
        # Before any simulation runs: a bad range must not waste them.
        check_discrepancy_ranges(self.discrepancy_prior, X.shape[1], q)
        rng = check_random_state(self.random_state)
        given = self._given_simulations(X, q, X_sim, theta_sim, y_sim)
        if self.prior is None:
            if given is None:
                raise ValueError(
                    "prior is required when the simulations are run by the "
                    "simulator: pass e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
                )
            t = given[1]
            self.prior_ = check_prior(
                [
                    stats.uniform(lo, hi - lo)
                    for lo, hi in zip(t.min(0), t.max(0), strict=True)
                ]
            )
        else:
            n_par = None if given is None else given[1].shape[1]
            self.prior_ = check_prior(self.prior, n_par)
        if self.prior_.dim != 1:
            for name, other in (("integration", "qmc"), ("sampler", "mcmc")):
                if getattr(self, name) == "quadrature":
                    raise ValueError(
                        f"{name}='quadrature' needs one parameter, the prior has "
                        f"{self.prior_.dim}; use {name}={other!r} (or 'auto')."
                    )
        X_sim, theta_sim, y_sim = self._simulations(X, q, rng, given)
        if theta_sim.shape[1] != self.prior_.dim:
            raise ValueError(
                f"theta_sim has {theta_sim.shape[1]} columns but the prior has "
                f"{self.prior_.dim} parameters."
            )
        self._check_simulation_design(X, X_sim, theta_sim, y_sim)
        seeds = rng.randint(2**31 - 1, size=4)

        # Module 1: the emulator.
        started = time.perf_counter()
        Z_sim, Ys_sim = self._fit_emulator(X_sim, theta_sim, y_sim, seeds[0])
        state = self.model_gp_._fit_state
        Xs_obs = self._std_x(X)
        Ys_obs = (Y - self.y_mean_) / self.y_scale_
        self._say(
            f"module 1 done in {time.perf_counter() - started:.1f} s: emulator of "
            f"{len(X_sim)} simulations, {Z_sim.shape[1]} inputs, {q} response(s)"
        )

        # Module 2: integrate the emulator over the prior, then fit the
        # discrepancy and the noise.
        started = time.perf_counter()
        mean_bar, V_bar = self._integrated_emulator(Xs_obs, seeds[1])
        disc = self._fit_discrepancy(Xs_obs, Ys_obs - mean_bar, V_bar, seeds[2])
        self.discrepancy_kernel_ = disc.kernel_
        self.discrepancy_sigma2_ = disc.sigma2 * np.outer(self.y_scale_, self.y_scale_)
        self.discrepancy_beta_ = disc.beta * self.y_scale_
        self.noise_ = disc.noise * self.y_scale_**2
        self._say(
            f"module 2 done in {time.perf_counter() - started:.1f} s: noise "
            f"variances {np.array2string(self.noise_, precision=3)}, "
            "discrepancy variances / simulated variances "
            f"{np.array2string(np.diag(disc.sigma2), precision=3)} "
            f"(range {self._variance_range_text(X.shape[1], q)})"
        )

        # Module 3: the posterior of theta.
        started = time.perf_counter()
        self._check_global_memory(len(Z_sim), n, q)
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
            nugget=self.model_gp_.alpha_,
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
            "theta_chains_",
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
        summary = (
            f"module 3 done in {time.perf_counter() - started:.1f} s ({sampler}): "
            f"posterior mean {np.array2string(self.theta_mean_, precision=5)}, "
            f"sd {np.array2string(np.sqrt(np.diag(self.theta_cov_)), precision=3)}"
        )
        if sampler == "mcmc":
            summary += (
                f", R-hat {np.array2string(self.rhat_, precision=3)}, bulk ESS "
                f"{np.array2string(self.ess_, precision=0)}"
            )
        self._say(summary)
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
        n, N, q = len(Xs), len(self._Z_sim), len(state.sigma2)
        block = nodes_per_block(n)
        jobs = min(self._n_workers(), -(-len(nodes) // block))
        # Blocks in flight (three (k, n, n) correlation temporaries and the
        # (N, k n) cross-correlations each), the node means, and the nq x nq
        # covariance with its spread and repair copies.
        needed = _FLOAT * (
            jobs * (3 * block * n * n + 2 * N * block * n)
            + len(nodes) * n * q
            + 4 * (n * q) ** 2
        )
        check_memory(
            needed,
            f"Module 2 (the emulator integrated over the prior at {n} field "
            f"inputs x {q} responses, {len(nodes)} nodes)",
            _FEWER_FIELD_DATA,
        )
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

    def _fit_discrepancy(
        self,
        Xs,
        residual,
        V_bar,
        seed,
        start=None,
        max_iter=None,
        responses=None,
        ranges=None,
    ):
        """Module 2, Eq. 4.19: discrepancy GP and noise by maximum likelihood.

        ``residual`` is the standardised field data minus the integrated
        emulator mean; returns the optimised :class:`DiscrepancyFit`.
        The likelihood is maximised within the ranges of
        ``discrepancy_prior``. ``start`` is an optional callable ``start(fit)
        -> packed parameters`` giving the first starting point (the sensor
        designer passes the hyperparameters that generated its synthetic
        data); ``max_iter`` bounds the optimiser's iterations per start;
        ``responses`` lists the responses (columns of the simulations) that
        ``residual`` holds, None for all; ``ranges`` replaces those of
        ``discrepancy_prior`` (a dict as returned by
        :func:`~skmba._discrepancy.check_discrepancy_ranges`, for all
        responses).
        """
        kernel_d = (
            default_kernel(Xs)
            if self.discrepancy_kernel is None
            else clone(self.discrepancy_kernel)
        )
        if ranges is None:
            ranges = check_discrepancy_ranges(
                self.discrepancy_prior, Xs.shape[1], len(self.y_scale_)
            )
        if ranges["roughness"] is not None:
            kernel_d = bound_roughness(kernel_d, *ranges["roughness"])
        variance = ranges["variance"]
        if variance is not None and responses is not None:
            variance = tuple(v[list(responses)] for v in variance)
        H_d = regression_basis(Xs, self.discrepancy_regression)
        nq = residual.size
        q = residual.shape[1]
        n_params = kernel_d.n_dims + q + q * (q + 1) // 2
        # Each likelihood evaluation holds about eight nq x nq matrices (the
        # covariance, its Cholesky factor and inverse, the gradient weights
        # and their reshapes).
        check_memory(
            _FLOAT * 8 * nq**2,
            f"The module-2 likelihood (a {nq} x {nq} field-data covariance, "
            f"{n_params} parameters)",
            _FEWER_FIELD_DATA,
        )
        disc = DiscrepancyFit(kernel_d, Xs, residual, H_d, V_bar, variance)
        if not self.noise:
            disc.fix_noise(1e-10)
        return disc.optimize(
            optimizer=self.discrepancy_optimizer,
            n_restarts=self.n_restarts_optimizer,
            random_state=seed,
            start=None if start is None else start(disc),
            max_iter=max_iter,
        )

    # ----------------------------------------------------------- helpers
    def _variance_range_text(self, d, q):
        variance = check_discrepancy_ranges(self.discrepancy_prior, d, q)["variance"]
        if variance is None:
            return "none"
        lo, hi = (np.array2string(v, precision=3) for v in variance)
        return f"{lo} to {hi}"

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

    def _log_posterior_one(self, theta, global_model=None):
        log_prior = float(np.ravel(self.prior_.logpdf(theta[None, :]))[0])
        if not np.isfinite(log_prior):
            return -np.inf
        model = self._global if global_model is None else global_model
        try:
            return log_prior + model.log_likelihood(self._std_theta(theta))
        except FactorizationError:
            return -np.inf

    def _raise_unevaluable(self, thetas):
        """The posterior is -inf at every node: say why, with the cause."""
        middle = np.array([thetas[len(thetas) // 2]])
        try:
            self._global.log_likelihood(self._std_theta(middle))
        except FactorizationError as exc:
            raise FactorizationError(
                f"The module-3 likelihood could not be evaluated at any "
                f"quadrature node (at theta={middle[0]:.6g}: {exc}) The "
                f"noise variances are {np.array2string(self.noise_, precision=3)}; "
                "when they sit at their lower bound (noise-free field data), "
                "raise emulator_alpha, or remove responses that are exact "
                "multiples of others in the simulations."
            ) from exc
        raise FactorizationError(
            "The posterior is zero at every quadrature node: the prior gives "
            "no mass there. Check the prior's support against theta_sim."
        )

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

    def _log_density_u(self, u, global_model=None):
        """Log posterior density of the sampling coordinates (with Jacobian)."""
        theta = self._from_u(u)
        if not np.all(np.isfinite(theta)):
            return -np.inf
        jacobian = np.sum(np.log(theta[self._log_dims]))
        return self._log_posterior_one(theta, global_model) + jacobian

    def _posterior_by_quadrature(self, rng):
        """Adaptive Gauss-Legendre quadrature of the 1-D posterior.

        A first 201-node rule over the prior's 0.9999 interval locates the
        mass; each further pass puts the rule on the region that holds all
        but 1e-12 of the mass found by the previous one, until that region
        spans at least 40 nodes (for a Gaussian posterior, a node spacing
        below 0.4 standard deviations): at least two passes, at most eight.
        Narrow posteriors (many simulations, little noise) need more than
        two; a posterior still unresolved after eight passes is reported by
        a warning.
        """
        lo, hi = self.prior_.bounds(0.9999)[0]
        nodes_gl, weights_gl = np.polynomial.legendre.leggauss(_QUADRATURE_NODES)
        for sweep in range(_QUADRATURE_PASSES):
            started = time.perf_counter()
            interval = f"[{lo:.6g}, {hi:.6g}]"
            t = 0.5 * (hi - lo) * nodes_gl + 0.5 * (hi + lo)
            logp = np.array([self._log_posterior_one(np.array([v])) for v in t])
            if not np.any(np.isfinite(logp)):
                self._raise_unevaluable(t)
            density = np.exp(logp - np.max(logp))
            w = weights_gl * density
            w = w / w.sum()
            mass = np.cumsum(w)
            inside = np.flatnonzero((mass > 1e-12) & (mass < 1 - 1e-12))
            i0 = max((inside[0] if inside.size else np.argmax(w)) - 2, 0)
            i1 = min((inside[-1] if inside.size else np.argmax(w)) + 2, len(t) - 1)
            lo, hi = t[i0], t[i1]
            resolved = inside.size >= _RESOLVED_NODES
            self._say(
                f"module 3: quadrature pass {sweep + 1} ({len(t)} nodes on "
                f"{interval}, {inside.size} carry the mass) in "
                f"{time.perf_counter() - started:.1f} s"
            )
            if sweep >= 1 and resolved:
                break
        else:
            warnings.warn(
                f"The posterior of theta is narrower than the quadrature resolved "
                f"after {_QUADRATURE_PASSES} passes (its mass lies on {inside.size} "
                f"of {len(t)} nodes around {t[np.argmax(w)]:.8g}): theta_cov_ "
                "and the spread of theta_samples_ are underestimated. Check the "
                "simulations and the noise estimate (noise_), or use "
                "sampler='mcmc'.",
                UserWarning,
                stacklevel=3,
            )
        self.theta_nodes_ = t[:, None]
        self.theta_weights_ = w
        # Draws by inverse-CDF sampling of the posterior CDF, integrated from
        # the density at the nodes by the trapezoidal rule (linear between).
        cdf = np.concatenate(
            [[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(t))]
        )
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
        started = time.perf_counter()
        mode, cov = self._laplace(self._to_u(candidates[order[:2]]))
        root = np.linalg.cholesky(cov + 1e-12 * np.trace(cov) * np.eye(r))
        starts = []
        while len(starts) < self.n_chains:
            start = mode + 1.5 * root @ rng.standard_normal(r)
            if np.isfinite(self._log_density_u(start)):
                starts.append(start)
        self._say(
            f"module 3: posterior mode found in {time.perf_counter() - started:.1f} "
            f"s; running {self.n_chains} chain(s) of {self.burn_in} burn-in + "
            f"{self.n_samples} steps"
        )
        result = run_chains(
            [_ChainTarget(self) for _ in range(self.n_chains)],
            np.array(starts),
            n_samples=self.n_samples,
            burn_in=self.burn_in,
            proposal_cov=(2.38**2 / r) * cov,
            adapt=True,
            n_jobs=self.n_jobs,
            random_state=rng.randint(2**31 - 1),
            verbose=self.verbose if self.verbose >= 2 else 0,
        )
        self.theta_chains_ = self._from_u(result.samples)
        self.theta_samples_ = self.theta_chains_.reshape(-1, r)
        self.acceptance_rate_ = result.acceptance_rate
        self.rhat_ = result.rhat
        self.ess_ = result.ess
        for c, chain in enumerate(self.theta_chains_):
            self._say(
                f"module 3: chain {c} done: acceptance {result.acceptance_rate[c]:.2f}"
                f", mean {np.array2string(chain.mean(axis=0), precision=5)}"
            )
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
        s, q, n, N = len(Xs), gm.q, gm.n, gm.N
        # Per posterior draw in flight: the (N q, s q) and (n q, s q)
        # whitened cross-covariances (and copies), the (N, s) kernels and
        # the (P, s q) regression terms; then the moments of all draws.
        per_draw = 2 * N * s + N * q * s * q + 3 * n * q * s * q + 3 * gm.P * s * q
        needed = _FLOAT * (
            min(self._n_workers(), len(thetas)) * per_draw + 5 * len(thetas) * s * q
        )
        check_memory(
            needed,
            f"The prediction at {s} points ({len(thetas)} posterior draws)",
            "Predict at fewer points per call (split X into batches of rows), "
            "or use a smaller n_jobs.",
        )
        with threadpool_limits(limits=1, user_api="blas"):
            chunks = Parallel(n_jobs=self.n_jobs)(
                delayed(_predict_chunk)(
                    self._global,
                    thetas[i : i + _PREDICT_CHUNK],
                    Xs,
                    component,
                    return_std,
                )
                for i in range(0, len(thetas), _PREDICT_CHUNK)
            )
        results = [moments for chunk in chunks for moments in chunk]
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
