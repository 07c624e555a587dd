"""ModularBayesCalibrator: the estimator that runs the four MBA modules.

``fit`` checks the data, collects the simulations
(:mod:`skmba.calibration._simulations`) and runs module 1
(:mod:`skmba.calibration._module1_emulator`), module 2
(:mod:`skmba.calibration._module2_prior_integral`,
:mod:`skmba.calibration._module2_plug_in`) and module 3
(:mod:`skmba.calibration._module3_posterior`); the predictions are module 4
(:mod:`skmba.calibration._module4_prediction`). The estimator only orchestrates: the
numerics live in those modules, and the fitted attributes are set in one place, at the
end of ``fit``.

Examples
--------
>>> from skmba import ModularBayesCalibrator
>>> ModularBayesCalibrator(n_chains=2).n_chains
2
"""

from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.utils.validation import validate_data

from skmba._core.progress import Progress
from skmba._core.threads import blas_threads
from skmba._core.validation import int_seed, seed_sequence, validate_parameter_table
from skmba.calibration._field_data import (
    check_same_index,
    check_simulation_design,
    field_order,
    simulation_tables,
)
from skmba.calibration._field_replicates import (
    FieldReadings,
    appended_readings,
    check_bin_width,
)
from skmba.calibration._fit_setup import (
    checked_field_data,
    module2_prior,
    prior_and_simulations,
    warn_field_size,
)
from skmba.calibration._fitted import OPTIONAL_FITTED, fitted_attributes
from skmba.calibration._module3_density import PosteriorDensityMixin
from skmba.calibration._module3_identifiability import warn_if_confounded
from skmba.calibration._module4_prediction import CalibratedPredictionMixin
from skmba.calibration._pipeline import WarmStart, run_modules
from skmba.calibration._response_checks import check_responses
from skmba.calibration._sensitivity import PriorSensitivityMixin
from skmba.calibration._settings import PARAMETER_TABLE, CalibrationSettings
from skmba.calibration._simulations import kept_simulator_runs
from skmba.calibration._summary import (
    CalibrationSummaryMixin,
    history_row,
    history_table,
    parameter_names,
)


class ModularBayesCalibrator(
    CalibratedPredictionMixin,
    PosteriorDensityMixin,
    CalibrationSummaryMixin,
    PriorSensitivityMixin,
    MultiOutputMixin,
    RegressorMixin,
    BaseEstimator,
):
    """Bayesian calibration of a computer model with model discrepancy.

    Read more in the :ref:`User Guide <user-guide-calibration>`.

    The modular Bayesian approach (MBA, thesis chapter 4) for
    ``y_e(x) = y_m(x, theta*) + delta(x) + eps``: module 1 emulates the
    simulations, module 2 fits the discrepancy and the noise, module 3 gives
    the posterior of ``theta`` and module 4 predicts the model, the
    discrepancy and reality over it. Everything is standardised internally
    (appendix C.2) and reported in user units.

    Parameters
    ----------
    simulator : callable, default=None
        ``simulator(X, theta) -> Y`` on blocks of runs (``X`` (n, d),
        ``theta`` (n, r), ``Y`` (n, q)), run on a Latin hypercube over the
        range of ``X`` times the prior's 0.999 interval. Failed runs (an
        exception, NaN or inf) are left out and listed in
        ``simulation_failures_``. Not needed after ``fit`` (User Guide).
    prior : list or dict of frozen scipy.stats distributions, frozen \
            multivariate_normal or object with ``logpdf``/``rvs``, default=None
        Prior of the ``r`` calibration parameters. A dict ``{name:
        distribution}`` also names them (``parameter_names_``). None means
        uniform over the range of ``theta_sim`` (only with precomputed
        simulations).
    n_simulations : int, default=None
        Runs of ``simulator`` (default ``10 * (d + r)``).
    model_kernel, discrepancy_kernel : sklearn Kernel, default=None
        Correlations of the emulator and of the discrepancy (unit diagonal,
        checked: ``ConstantKernel(2.0) * RBF()`` is an error, the variances
        are estimated separately). None: anisotropic
        :class:`~skmba.kernels.Gauss` scaled to the data. They act on
        standardised inputs; scikit-learn kernels keep their own bounds.
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
        Draws per chain kept after burn-in (MCMC; with ``target_ess``, the
        most), or the number of draws ``theta_samples_`` resampled from the
        quadrature posterior.
    target_ess : float or None, default=2000
        MCMC: the chains stop at the first checkpoint (every 250 draws, and
        where a checkpoint that fell short predicts it) where every
        parameter's bulk and tail effective sample size reach it and its
        R-hat is at most 1.01; None: always ``n_samples`` draws. Ask
        for more (with a larger ``n_samples``) for finer interval ends.
    burn_in : int, default=1000
        Draws per chain discarded; the proposal adapts during burn-in only.
        The second pass of the propagated module 2, whose chains start from
        the first pass's draws, burns in a quarter of it.
    n_jobs : int, default=None
        Parallel chains, module-2 node blocks and module-4 predictions
        through joblib (also on Dask); ``-1`` all cores.
    random_state : int, RandomState, Generator, SeedSequence or None
        The same seed gives bit-identical results for any ``n_jobs`` and
        joblib backend.
    n_integration_nodes : int, default=None
        Module-2 nodes (default 32 for quadrature, 256 for qmc).
    module2_variance : {"total", "conditional"}, default="total"
        "conditional": Eq. 4.15 as printed; "total" adds the spread of the
        emulator mean over the prior (total variance; why: User Guide).
    n_restarts_optimizer : int, default=2
        Random restarts of the module-1 and module-2 likelihood maximisation.
        An update (:meth:`partial_fit`) starts module 2 at the last mode
        and runs them again once the field data hold a tenth more values
        than when they last ran.
    discrepancy_optimizer : {"fmin_l_bfgs_b", "differential_evolution"}
        Module-2 optimiser; differential evolution is a global search (the
        analogue of the thesis' genetic algorithm) followed by L-BFGS-B.
    discrepancy_uncertainty : {"propagate", "plug-in"}, default="propagate"
        Module-2 treatment. "propagate": the discrepancy and noise
        hyperparameters get the prior of ``discrepancy_prior``, module 2
        finds their restricted-likelihood posterior (mode and Laplace
        approximation) and module 3 integrates them out, so that theta's
        interval carries their uncertainty: over 16 draws of module 2's
        posterior, or, for one parameter, to ``discrepancy_tol``. "plug-in":
        the thesis' MBA, their estimate within the ranges of
        ``discrepancy_prior`` plugged into modules 3 and 4. The User Guide
        ("How honest are the intervals?") compares the two.
    discrepancy_prior : dict, default=None
        In the field data's terms: inputs scaled by their sd over the field
        inputs, responses by the model's spread over those and the prior of
        theta (``discrepancy_prior_summary()`` shows it in user units). With
        "propagate", the prior (None: these defaults; a missing key keeps
        its default)::

            {"sd_scale": 0.5,           # half-normal scale of each sd
             "correlation_eta": 2.0,    # LKJ prior of the correlation
             "roughness": (0.1, 9.0),   # log-uniform, thesis Table 6.2
             "noise": (1e-6, 1.0)}      # log-uniform noise variance

        With "plug-in", ranges ``(low, high)`` (scalars or arrays; None
        removes one) of a uniform prior whose maximum module 2 finds:
        ``{"roughness": (0.1, 9.0), "variance": (1e-2, 20.0)}`` (thesis
        Table 6.2; ``"variance"`` is the diagonal of Sigma_d, its lower end
        each response's own part of the discrepancy).
    discrepancy_tol : "auto", float or None, default="auto"
        With "propagate": integrate the hyperparameters out until the Monte
        Carlo errors of theta's posterior mean and sd are below this many
        posterior sds (the 95 % ends: 1.5 times that), in blocks of 128 draws,
        at most 4096; theta on a grid (one parameter) or at weighted
        importance nodes (several); reported by ``summary()``. "auto": 0.05
        with one parameter, reproducible whatever ``random_state`` (User
        Guide); 16 draws with several. None: 16 draws, moving with it.
    estimand : {"physical", "best_fit"}, default="physical"
        What theta's posterior (``theta_samples_``, ``theta_mean_``,
        ``theta_cov_``, ``theta_mcse_``, ``summary()``) is of. "physical":
        the true parameter of Kennedy & O'Hagan's model, confounded with a
        discrepancy that mimics its effect (``fit`` warns). "best_fit": the
        theta that brings the model closest to reality, in least squares
        over the field inputs (each response in its simulations' spread),
        within the simulated range: reality's posterior projected on the
        model (User Guide, "Which estimand?"); no confounding warning.
    emulator_alpha : float, default=1e-8
        Nugget of the emulator's correlation matrix at the simulations (not
        at the field inputs, where the model is the simulator's output).
    bin_width : float or array-like of shape (d,), default=None
        Readings repeated at the same inputs always enter modules 2-4 as
        their mean and count (exact). A width (units of ``X``, e.g. 0.5 °C)
        also averages readings whose inputs fall in one bin ``floor(x / w)``
        at their mean input, an approximation that bounds the cost of a
        year of monitoring (User Guide, "Monitoring over time").
    verbose : int, default=0
        Progress on standard error, prefixed ``[ModularBayesCalibrator]``:
        0 prints nothing; 1 shows progress bars (simulator runs, restarts,
        MCMC steps, also in joblib workers) and a line per module; 2 also
        detail lines (each restart, chain). Results do not depend on it.

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
        Measurement-noise variances in squared response units: the module-2
        estimate (under ``"propagate"`` the posterior mode, about 12 % below
        the mean on 20-30 readings; ``predict`` adds the mean, User Guide).
    theta_samples_ : ndarray of shape (n_draws, r)
        Posterior draws (pooled chains after burn-in, or draws from the
        quadrature posterior; with ``estimand="best_fit"``, of the best fit,
        while ``theta_chains_`` and ``theta_nodes_`` stay module 3's).
    theta_chains_ : ndarray of shape (n_chains, n_kept, r)
        The MCMC draws after burn-in chain by chain (``n_kept`` at most
        ``n_samples``, fewer when ``target_ess`` stopped them), in user
        units; ``theta_samples_`` is ``theta_chains_.reshape(-1, r)``.
    theta_log_posterior_ : ndarray of shape (n_chains, n_kept)
        :meth:`log_posterior` at each draw of ``theta_chains_``; only with
        MCMC.
    theta_mean_ : ndarray of shape (r,)
    theta_cov_ : ndarray of shape (r, r)
    acceptance_rate_, rhat_, ess_ : ndarray
        MCMC diagnostics (n_chains,), (r,), (r,); only with MCMC: ArviZ's
        rank-normalised split ``rhat`` and bulk ``ess`` (User Guide). After
        an update that reweighted the last run's draws, ``ess_`` alone: the
        smallest of the run's bulk, tail, mean and sd ESS (at most its
        nodes) times the weights' Kish share.
    theta_mcse_ : ndarray of shape (4, r)
        Monte Carlo errors of the posterior mean, sd, 2.5 % and 97.5 % ends
        from the integral over the hyperparameters: to ``discrepancy_tol``;
        over module 2's 16 fixed draws (``discrepancy_tol=None``, and the
        default with several parameters), as the draws themselves see it,
        which reads low where a few of them carry the posterior (``fit``
        warns above 0.1 posterior sds, 0.15 for the ends); NaN for the
        plug-in.
    estimand_ : {"physical", "best_fit"}
        What ``theta_samples_``, ``theta_mean_`` and ``theta_cov_`` are of.
    discrepancy_draws_ : int
        Draws of the hyperparameters module 3 integrates over.
    discrepancy_prior_units_ : PriorUnits
        The terms ``discrepancy_prior`` is stated in, relative to the
        standardised units: ``input_ratio`` (d,), ``response_ratio`` (q,).
    identifiability_ : ndarray of shape (r,)
        Per parameter given the others, the share of its posterior sd the
        data account for (linearised, without a discrepancy), at most 1; the
        plug-in's: the share a plausible discrepancy would leave. Below 1/3
        ``fit`` warns (:class:`~skmba.exceptions.NonIdentifiabilityWarning`).
    parameter_names_ : list of str
        The names of the calibration parameters: the keys of a dict prior
        (or, without a prior, the columns of a ``theta_sim`` DataFrame),
        else ``theta0, theta1, ...``.
    response_names_ : list of str or None
        The column names of ``y`` when it is a pandas DataFrame, else None.
    feature_names_in_ : ndarray of shape (d,)
        The column names of ``X`` when it is a DataFrame with string column
        names (scikit-learn's rule); only then.
    X_obs_, y_obs_ : ndarray
        The field data of ``fit`` (for :meth:`to_inference_data`), without
        the rows that had no measured response; NaN where a reading was not
        taken. After :meth:`partial_fit`, every batch's.
    theta_history_ : pandas.DataFrame or numpy structured array
        The posterior after each :meth:`fit` or :meth:`partial_fit`, one row
        per call indexed by the label of its last reading (``until``: a
        timestamp for a time-indexed ``y``): ``n_readings``, ``n_means``
        (distinct inputs or bins) and ``<parameter>_mean``, ``_sd``,
        ``_2.5%``, ``_97.5%``.
    theta_nodes_, theta_weights_ : ndarray
        The posterior's weighted nodes: the quadrature (one parameter), the
        importance nodes (``discrepancy_tol`` with several), or the last
        MCMC run's thinned draws reweighted by an update (:meth:`partial_fit`);
        absent with MCMC.
    prior_ : prior object
        The checked prior (one of :mod:`skmba.priors`): ``logpdf``, ``rvs``,
        ``mean``, ``cov``, ``bounds``, ``dim`` and ``names``.
    global_model_ : object
        The module-3 likelihood of Eq. 4.30 (standardised units) over module
        2's draws of the discrepancy and noise hyperparameters (one draw of
        weight one with the plug-in): ``log_likelihood(theta_std)`` takes
        standardised parameters ``(theta - theta_offset_) / theta_scale_``;
        ``models`` holds the global model of each draw and ``base`` the one
        at the module-2 mode.
    X_sim_, theta_sim_, y_sim_ : ndarray
        The simulations used (given and run, the successful ones).
    simulation_failures_ : list of named tuples
        The runs left out: rows of ``y_sim`` with NaN or inf and simulator
        runs that raised or returned NaN or inf, each a named tuple
        ``(source, index, X, theta, error)`` (``pandas.DataFrame`` of the
        list tabulates them); empty when every run succeeded.
    X_mean_, X_scale_, theta_offset_, theta_scale_, y_mean_, y_scale_ : ndarray
        The standardisation (simulation data as reference): the centre and
        the scale of each design variable, parameter and response.
    n_features_in_ : int

    See Also
    --------
    MultiResponseGP : the emulator and discrepancy model.
    PreposteriorDesigner : which responses identify theta best, before
        measuring.
    prior_sensitivity : theta's posterior under other discrepancy priors.

    References
    ----------
    Kennedy & O'Hagan (2001), Bayesian calibration of computer models, JRSS
    B 63(3). Arendt, Apley & Chen (2012), Quantification of model
    uncertainty: calibration, model discrepancy, and identifiability, J.
    Mech. Des. 134(10). Thesis chapter 4 and appendix B.

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

    _parameter_table: ClassVar[dict] = PARAMETER_TABLE

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
        target_ess=2000,
        burn_in=1000,
        n_jobs=None,
        random_state=None,
        n_integration_nodes=None,
        module2_variance="total",
        n_restarts_optimizer=2,
        discrepancy_optimizer="fmin_l_bfgs_b",
        discrepancy_uncertainty="propagate",
        discrepancy_prior=None,
        discrepancy_tol="auto",
        estimand="physical",
        emulator_alpha=1e-8,
        bin_width=None,
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
        self.target_ess = target_ess
        self.burn_in = burn_in
        self.n_jobs = n_jobs
        self.random_state = random_state
        self.n_integration_nodes = n_integration_nodes
        self.module2_variance = module2_variance
        self.n_restarts_optimizer = n_restarts_optimizer
        self.discrepancy_optimizer = discrepancy_optimizer
        self.discrepancy_uncertainty = discrepancy_uncertainty
        self.discrepancy_prior = discrepancy_prior
        self.discrepancy_tol = discrepancy_tol
        self.estimand = estimand
        self.emulator_alpha = emulator_alpha
        self.bin_width = bin_width
        self.verbose = verbose

    # -------------------------------------------------------------- fit
    def fit(self, X, y, *, X_sim=None, theta_sim=None, y_sim=None, simulations=None):
        """Run modules 1-3 (module 4 runs at prediction time).

        Parameters
        ----------
        X : array-like or DataFrame of shape (n, d)
            Field inputs (design variables) of the observations.
        y : array-like or DataFrame of shape (n,) or (n, q)
            Field observations. NaN marks a reading that was not taken (a
            sensor out): modules 2-4 use the measured entries, and a row
            with no measured response is left out with a warning.
        X_sim, theta_sim, y_sim : array-like or DataFrame, optional
            A precomputed simulation dataset: inputs (N, d), parameters
            (N, r) and responses (N, q). DataFrames are matched by column
            name to ``X``, to the keys of a dict ``prior`` and to ``y`` when
            those are named (their order may differ; different names are a
            ValueError listing both); arrays by position. Rows of ``y_sim``
            with NaN or inf (failed runs) are left out and listed in
            ``simulation_failures_``. Under scikit-learn's cross-validation,
            which slices fit parameters with as many rows as ``X``, pass
            ``simulations`` instead.
        simulations : Simulations, optional
            The same dataset as one object
            (:class:`skmba.calibration.Simulations`), which cross-validation
            passes to every fold whole.

        Returns
        -------
        self

        Raises
        ------
        ValueError, TypeError
            Invalid data or parameters; the message names the argument and
            the fix.
        RuntimeError
            The simulator failed on every run; the message names one and its
            inputs and the simulator's exception is chained.

        Warns
        -----
        NonIdentifiabilityWarning
            A parameter the data cannot tell from the discrepancy (see
            ``identifiability_``).
        UserWarning
            Rows of ``y`` without any reading (left out); failed simulation
            runs (their count and errors); observation inputs outside the
            range of the simulations; more than 2 % of the prior mass outside
            the simulated range of theta; poor MCMC diagnostics.
        """
        tables = simulation_tables(X, X_sim, theta_sim, y_sim, simulations)
        return self._run(X, y, tables, warm=None)

    def partial_fit(
        self, X, y, *, X_sim=None, theta_sim=None, y_sim=None, simulations=None
    ):
        """Add a batch of field readings of the same structure and update.

        The first call is :meth:`fit`; each later one appends the batch to
        the readings so far, keeps module 1 (simulations, emulator) and runs
        modules 2-3 on all the readings, started where the last update ended.
        Their cost grows with the distinct inputs (``bin_width``), not the
        readings; the result is :meth:`fit`'s on all the batches up to
        module 3's Monte Carlo error. ``theta_history_`` records each call.

        Module 2's search starts at the last mode, without random restarts
        until the field data hold a tenth more measured values than when
        they last ran. With MCMC, module 3 first reweights the last run's
        draws (thinned to about one per effective draw) to the new
        posterior, one likelihood per draw; it runs chains instead when that
        run's diagnostics were warned about, the weights' Kish share is below
        one half, or the ESS would fall below 400 (User Guide, "Monitoring
        over time").

        Parameters
        ----------
        X : array-like or DataFrame of shape (n, d)
            The batch's field inputs; a table needs the first batch's columns.
        y : array-like or DataFrame of shape (n,) or (n, q)
            The batch's readings (NaN: not taken); a table needs the first
            batch's columns, in any order. Its row labels (e.g. timestamps)
            label the update in ``theta_history_``.
        X_sim, theta_sim, y_sim, simulations : optional
            The simulations, as in :meth:`fit`; on the first call only.

        Returns
        -------
        self

        Raises
        ------
        ValueError
            Simulations after the first call; other columns than the first's.
        """
        sims = dict(X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)
        if not hasattr(self, "_modules"):
            return self.fit(X, y, **sims, simulations=simulations)
        if any(a is not None for a in (*sims.values(), simulations)):
            raise ValueError(
                "partial_fit keeps the simulations and the emulator of its first "
                "call: pass simulations to the first call only, or call fit to "
                "start again with other simulations."
            )
        check_same_index(X, y)
        validate_data(self, X, reset=False, skip_check_array=True)  # names, width
        X, y = appended_readings(self._readings_log, X, y)
        return self._run(X, y, (None,) * 3, warm=self._modules)

    def _run(self, X, y, tables, warm):
        """Modules 1-3 on the readings ``X``, ``y`` (module 1 from ``warm``,
        an earlier result, when given); sets the fitted attributes. BLAS
        threads by the package's policy (:mod:`skmba._core.threads`)."""
        partial = {}
        try:
            with blas_threads(field_order(y)):
                fitted = self._fit(X, y, *tables, partial, warm)
        except Exception as exc:
            kept = kept_simulator_runs(partial.get("simulations"), exc)
            for name, value in kept.items():
                setattr(self, name, value)
            raise
        self._readings_log = (X, y)
        self._set_fitted(**fitted, continued=warm is not None)
        if self.estimand_ == "physical":  # the best fit is what the data tell
            warn_if_confounded(self.identifiability_, self.parameter_names_)
        return self

    def _fit(self, X, y, X_sim, theta_sim, y_sim, partial, warm):
        """Modules 1-3; returns what :meth:`_set_fitted` stores."""
        validate_parameter_table(
            self._parameter_table, self.get_params(deep=False), type(self).__name__
        )
        settings = CalibrationSettings.from_params(self.get_params(deep=False))
        # An update's earlier rows were checked by their own call.
        reported = 0 if warm is None else len(self._readings_log[0])
        X, Y, y_ndim, responses, tables, rows = checked_field_data(
            self, X, y, (X_sim, theta_sim, y_sim), reported
        )
        width = check_bin_width(settings.bin_width, X.shape[1])
        readings = FieldReadings.from_readings(X, Y, width)
        warn_field_size(int(np.isfinite(readings.Y).sum()), len(Y), settings)
        # Before any simulation runs: a bad range must not waste them.
        module2_spec = module2_prior(settings, X, Y.shape[1])
        # One child of the seed per random step: the simulation design, then
        # modules 1-3 (run_modules) and the best fit. A child depends on its
        # index only: adding one left the others' draws as they were.
        seeds = [int_seed(c) for c in seed_sequence(self.random_state).spawn(8)]
        progress = Progress(self.verbose, "ModularBayesCalibrator")
        if warm is None:
            named = (responses, tables)
            prior, sims = prior_and_simulations(
                settings, self.prior, X, Y.shape[1], named, seeds[0], progress
            )
            partial["simulations"] = sims
        else:
            prior, sims = warm.prior, warm.sims
        check_simulation_design(
            X, prior, sims, getattr(self, "feature_names_in_", None)
        )
        check_responses(X, Y, sims.X, sims.theta, sims.y, responses, rows)
        result = run_modules(
            settings, readings, sims, prior, module2_spec, seeds[1:], progress, warm
        )
        return dict(
            X=X,
            Y=Y,
            y_ndim=y_ndim,
            responses=responses,
            sims=sims,
            result=result,
            update=(rows[-1], readings),
        )

    def _set_fitted(self, X, Y, y_ndim, responses, sims, result, update, continued):
        """Every fitted attribute, in one place."""
        for name in OPTIONAL_FITTED:
            self.__dict__.pop(name, None)
        self.prior_ = result.inputs.prior
        self.parameter_names_ = parameter_names(self.prior_)
        self.response_names_ = responses
        self.X_obs_, self.y_obs_ = X, Y[:, 0] if y_ndim == 1 else Y
        self.X_sim_, self.theta_sim_, self.y_sim_ = sims.X, sims.theta, sims.y
        self.simulation_failures_ = list(sims.failures)
        for name, value in fitted_attributes(result).items():
            setattr(self, name, value)
        self._y_ndim, self._scaler = y_ndim, result.inputs.scaler
        self._log_posterior = result.module3.log_post
        self._prediction_rule = result.module3.rule
        self._modules = WarmStart.of(result)  # for partial_fit
        earlier = self._history if continued else []  # fit starts the record
        posterior = result.module3.posterior
        if result.best_fit is not None:
            posterior = result.best_fit.posterior
        self._history = [*earlier, history_row(*update, posterior)]
        self.theta_history_ = history_table(self._history, self.parameter_names_)
