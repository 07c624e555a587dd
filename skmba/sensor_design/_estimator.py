"""PreposteriorDesigner: which sensors identify theta best (thesis chapter 6).

The estimator orchestrates the fast preposterior analysis: step 1 (the
emulator and the prior-integrated emulator at the design,
:class:`~skmba.sensor_design._replicates.MonteCarloContext`), phase 1 of
step 2 (the replicates, :func:`~skmba.sensor_design._replicates.
draw_replicate`), phase 2 (the subsets' posterior moments as the search asks
for them, :mod:`skmba.sensor_design._scoring` and
:mod:`skmba.sensor_design._subset_search`) and step 3 (the scores). The
method is explained in the user guide, "Sensor design by preposterior
analysis".
"""

import time
from typing import ClassVar

import numpy as np
from joblib import delayed
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted, validate_data

from skmba._core.columns import (
    column_names,
    match_columns,
    parameters_last,
    response_index,
)
from skmba._core.progress import Progress, results_as_ready
from skmba._core.threads import BlasTask, blas_threads
from skmba._core.validation import int_seed, seed_sequence, validate_parameter_table
from skmba.calibration._field_data import check_same_index, prior_names
from skmba.calibration._module1_emulator import Standardizer, fit_emulator
from skmba.sensor_design._inputs import (
    PARAMETER_TABLE,
    calibration_settings,
    designer_prior,
    field_design,
    given_prior,
    synthetic_data_priors,
    without_failed_runs,
)
from skmba.sensor_design._replicates import (
    MonteCarloContext,
    draw_replicate,
    warn_replicate_problems,
)
from skmba.sensor_design._scoring import (
    criterion_value,
    design_scores,
    design_table,
    phase2,
)
from skmba.sensor_design._subset_search import SearchSettings, check_max_size


class PreposteriorDesigner(BaseEstimator):
    """Choose the sensors that identify the calibration parameters best.

    The fast preposterior analysis (FPA) of thesis chapter 6, after Arendt
    et al. (2016): from simulations only, before measuring, it scores each
    subset ``S`` of the ``q`` simulated responses by the expected posterior
    covariance of ``theta`` that the modular Bayesian approach
    (:class:`~skmba.ModularBayesCalibrator`) would reach with field data of
    those responses,

        score(S) = || mean_i V[theta | Y_e^(i)(S), D_m] ||      (Eq. 6.3)

    over Monte Carlo replicates ``i`` of synthetic field data drawn from the
    priors of ``theta``, the discrepancy and the noise. Lower is better.

    Parameters
    ----------
    prior : list or dict of frozen scipy.stats distributions, frozen \
            multivariate_normal or object with ``logpdf``/``rvs``, default=None
        Prior of the ``r`` calibration parameters. Their columns in ``X``
        (:meth:`fit`) are the last ``r`` ones, except that a dict ``{name:
        distribution}`` with a DataFrame ``X`` finds them by its keys,
        wherever they are. A correlated prior (e.g. a frozen
        ``multivariate_normal``) whitens the ``criterion``. None takes the
        ``calibrator``'s prior.
    calibrator : ModularBayesCalibrator, default=None
        Template of the MBA settings used (model and discrepancy kernels and
        regressions, ``module2_variance``, ``emulator_alpha``,
        ``n_restarts_optimizer``, ``discrepancy_optimizer``,
        ``n_integration_nodes``, ``noise``). It is cloned, never fitted.
        None means ``ModularBayesCalibrator()``. Its
        ``discrepancy_uncertainty`` and ``discrepancy_prior`` are not used:
        the designer's own parameters of those names set them. The
        discrepancy kernel must have a ``roughness`` hyperparameter (the
        kernels of :mod:`skmba.kernels`), which ``discrepancy_prior`` draws.
    discrepancy_prior : dict, default=None
        With ``discrepancy_uncertainty="propagate"``, the calibrator's
        hyperprior (keys ``sd_scale``, ``correlation_eta``, ``roughness``,
        ``noise``; None: its defaults), in the design's terms as the
        calibrator's. With ``"plug-in"``, uniform priors of the discrepancy
        GP, with inputs scaled by their sd over the field design and
        responses by the model's spread over it and the prior, as thesis
        Table 6.2's (the default)::

            {"roughness": (0.1, 9.0),      # per design variable
             "variance": (1e-2, 20.0),     # diagonal of Sigma_d, per response
             "mean": (-5.0, 5.0),          # regression coefficients
             "correlation": "random"}

        Each interval is ``(low, high)`` of scalars or of arrays (one value per
        design variable for ``roughness``, per response for ``variance``),
        e.g. ``{"variance": (0.01, [20, 20, 0.1, 20, 20])}`` lowers the
        largest discrepancy variance of the third response (section 6.3).
        ``correlation`` is ``"random"`` (a Wishart matrix with ``q + 1``
        degrees of freedom scaled to unit diagonal, so that each correlation
        is uniform on ``(-1, 1)``), ``"independent"``, or a number ``rho``
        (equal correlation between every pair of responses). Missing keys take
        the defaults. The module-2 fits of the replicates maximise the
        likelihood within the ``roughness`` and ``variance`` ranges (the
        maximum a posteriori under this prior, as the calibrator does with
        its own ``discrepancy_prior``, which the designer does not use).
    discrepancy_uncertainty : {"plug-in", "propagate"}, default="plug-in"
        The module-2 treatment whose calibrations the scores predict.
        ``"plug-in"``: the thesis' FPA, with synthetic data from the uniform
        priors ``discrepancy_prior`` and ``noise_prior`` (Table 6.2) and
        module 2's estimates plugged into module 3, as
        ``ModularBayesCalibrator(discrepancy_uncertainty="plug-in")``.
        ``"propagate"``: synthetic data from the calibrator's default prior
        of the discrepancy and the noise (``discrepancy_prior`` then takes
        its keys ``sd_scale``, ``correlation_eta``, ``roughness``, ``noise``;
        see :ref:`module-2-uncertainty`), and module 3 mixing over module 2's
        hyperposterior draws, as the calibrator's default does: the scores
        predict the default calibrator. About ``N_HYPER_DRAWS`` (16) times
        slower in phase 2. The ``calibrator``'s own setting is not used.
    noise_prior : (low, high), default=None
        Uniform prior of each response's noise variance, relative to the
        response's variance in the simulations (scalars or arrays of length
        ``q``). None means ``(0, 1e-4)`` (Table 6.2).
    X_design : array-like or DataFrame of shape (n, d), default=None
        The planned field inputs (design variables). It must lie inside the
        range of the simulations. A DataFrame is matched by column label to
        the design-variable columns of a table ``X`` (its order may differ).
    n_design : int, default=None
        When ``X_design`` is None, a Latin hypercube of ``n_design`` points
        over the range of the simulated design variables (None means 25, as
        in section 6.3).
    n_mc : int, default=100
        Monte Carlo replicates (100 in section 6.4; ``convergence_`` shows
        whether that is enough).
    search : {"exhaustive", "greedy", "genetic"}, default="exhaustive"
        ``"exhaustive"`` scores all ``2^q - 1`` subsets (of at most
        ``max_responses`` responses); ``"greedy"`` forward selection scores
        ``q + (q - 1) + ...`` subsets; ``"genetic"`` runs a binary genetic
        algorithm (``population_size``, ``n_generations``). Every search also
        scores the ``q`` single responses, for ``ranking_``.
    max_responses : int, default=None
        Largest number of sensors in a subset (None: all ``q``).
    criterion : {"trace", "det", "max_eig"}, default="trace"
        Norm of the preposterior covariance ``C`` whitened by the prior
        covariance, so that parameters of different units are comparable
        and a score of 1 means "no better than the prior": each parameter
        is scaled by its prior standard deviation, then ``S = L^-1 C L^-T``
        with ``L`` the Cholesky factor of the prior correlation matrix. The
        score is the trace of ``S`` over ``r``, the determinant of ``S`` to
        the power ``1/r`` (geometric mean of its eigenvalues) or its largest
        eigenvalue: each is exactly 1 at the prior, correlated or not. With
        independent parameters ``S`` is ``C`` scaled by the prior standard
        deviations (the trace criterion is then the mean of the
        posterior-to-prior variance ratios); for one parameter all three
        are the posterior-to-prior variance ratio.
    fast : bool, default=True
        Estimate the discrepancy hyperparameters once per replicate with all
        responses and reuse them, restricted, for every subset (phase 1 /
        phase 2 of section 6.2.2). False re-estimates them for every subset
        and replicate (Arendt et al.), much slower.
    n_jobs : int, default=None
        Monte Carlo replicates run in parallel through joblib, so that
        ``joblib.parallel_config(backend="dask")`` runs them on a Dask
        cluster.
    random_state : int, RandomState, Generator, SeedSequence or None
        Seeds are derived per replicate, so results do not depend on
        ``n_jobs``.
    population_size : int, default=20
        Genetic search only.
    n_generations : int, default=20
        Genetic search only (it also stops after 5 generations without
        improvement).
    verbose : int, default=0
        Progress on standard error, prefixed ``[PreposteriorDesigner]``: 0
        prints nothing; 1 shows progress bars (the emulator's restarts, the
        replicates of phase 1, the (subset, replicate) posterior
        evaluations of phase 2, also when joblib workers run them) and a
        line per step, with, before phase 2 of an exhaustive search, its
        number of subsets and evaluations and, after its first task, the
        expected time; 2 also detail lines. Results do not depend on it.
        An exhaustive search expected to take more than
        ``LONG_SEARCH_SECONDS`` (10 minutes) warns, whatever ``verbose``.
    prior_units : {"standardised", "user"}, default="standardised"
        Units of the ``variance`` and ``mean`` of ``discrepancy_prior`` and of
        ``noise_prior``. ``"standardised"``: relative to each response's
        spread in the model over the field design and the prior (variances
        as fractions of its square), so that the same prior means the same
        *relative* discrepancy for every sensor. ``"user"``: in the units of
        ``y`` (squared for variances), e.g. "up to 0.5 mm of discrepancy on
        every displacement gauge". The roughness is always relative to the
        field design's inputs.
    module2_max_iter : int or None, default=200
        Largest number of L-BFGS-B iterations of each module-2 fit (phase 1,
        or every subset with ``fast=False``). Each fit starts from the
        hyperparameters that generated its replicate, the natural guess of
        their estimate; with many correlated responses the likelihood is
        badly scaled and full convergence can take thousands of evaluations
        for a small gain. None runs to convergence: slower, and most scores
        a little higher (the user guide's "Run time" measures both).
    max_warning_rate : float in [0, 1], default=None
        Rank first the subsets predicted to identify theta: no parameter's
        ``warning_rate_`` above this. ``best_subset_`` is the best of them
        (none: of all, with a warning), greedy and genetic searches prefer
        them, ``summary()`` lists them first. None ranks by score alone.

    Attributes
    ----------
    subsets_ : list of tuple
        The scored response subsets (0-based indices), smallest first.
    preposterior_cov_ : ndarray of shape (n_subsets, r, r)
        Mean posterior covariance of ``theta`` over the replicates, in user
        units, for each subset.
    scores_ : ndarray of shape (n_subsets,)
        The criterion of each subset; lower is better.
    scores_mcse_ : ndarray of shape (n_subsets,)
        Monte Carlo standard error of each score: the jackknife over the
        replicates (see :meth:`summary`); NaN when ``n_mc=1``.
    best_subset_ : tuple
        The subset with the lowest score (of ``identified_``, if any).
    support_ : ndarray of shape (q,), dtype=bool
        Mask of ``best_subset_`` over the responses.
    ranking_ : ndarray of shape (q,)
        Rank of each response scored alone (1 = the most informative single
        sensor).
    convergence_ : ndarray of shape (n_mc, n_subsets)
        Running criterion of each subset after 1, 2, ..., ``n_mc``
        replicates (thesis Fig. 6.5).
    expected_error_ : ndarray of shape (n_subsets, r)
        Root mean square, over the replicates, of the posterior mean minus the
        ``theta`` that generated the data: the expected identification error
        (bias and spread) of each subset, in user units.
    identifiability_ : ndarray of shape (n_subsets, r)
        The calibrator's ``identifiability_`` per subset: the median over
        the replicates of its rule applied to each replicate's data.
    warning_rate_ : ndarray of shape (n_subsets, r)
        Share of the replicates on which the calibrator's
        :class:`~skmba.exceptions.NonIdentifiabilityWarning` would name
        each parameter (``identifiability_`` below 1/3 there).
    warning_rate_mcse_ : ndarray of shape (n_subsets, r)
        Its binomial standard error, ``sqrt(p (1 - p) / n_mc)`` (0 where all
        replicates agree: within ``3 / n_mc`` of 0 or 1 at 95 % then).
    identified_ : ndarray of shape (n_subsets,), dtype=bool
        Subsets within ``max_warning_rate`` for every parameter (all when
        it is None).
    theta_draws_ : ndarray of shape (n_mc, r)
        The replicates' ``theta``.
    X_design_ : ndarray of shape (n, d)
    model_gp_ : MultiResponseGP
        The module-1 emulator (standardised units).
    prior_ : skmba prior object
    n_responses_ : int
    response_names_ : list of str or None
        The column names of ``y`` when it is a pandas DataFrame (used by
        :meth:`summary`, :meth:`score_subset` and the ``subsets`` of the
        plots of :mod:`skmba.plotting`), else None.
    n_features_in_ : int
    feature_names_in_ : ndarray of str of shape (d + r,)
        The column names of ``X``, design variables first and calibration
        parameters last: with a dict ``prior`` the parameter columns are
        found by name and moved last, so this need not be the order of the
        DataFrame's columns. Only when ``X`` is a DataFrame with string
        column names.

    See Also
    --------
    ModularBayesCalibrator : the MBA whose identifiability is predicted.

    Notes
    -----
    Phase 2 restricts the phase-1 discrepancy covariance and noise to the
    subset, which is what the multi-response GP implies for a subset of its
    responses. The posterior moments of ``theta`` come from the module-3
    likelihood (Eq. 4.30, regression coefficients integrated out) by
    quadrature over the prior, refined by Gaussian importance quadrature
    where the posterior is narrow (:mod:`skmba.sensor_design._posterior_moments`); the
    likelihood of all subsets shares the emulator terms at each ``theta``.
    The run time grows as ``n_mc`` times the number of subsets: bound it with
    ``n_mc``, ``max_responses`` or ``search="greedy"``.

    References
    ----------
    Arendt, Apley, Chen (2016), A preposterior analysis to predict
    identifiability in the experimental calibration of computer models, IIE
    Transactions 48(1). Thesis chapter 6.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba import ModularBayesCalibrator, PreposteriorDesigner
    >>> from skmba.datasets import make_cantilever
    >>> data = make_cantilever(
    ...     30, responses=("tip_displacement", "mid_displacement"), random_state=0
    ... )
    >>> X = np.hstack([data.X_sim, data.theta_sim])
    >>> designer = PreposteriorDesigner(
    ...     data.prior,
    ...     calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
    ...     n_design=8,
    ...     n_mc=4,
    ...     random_state=0,
    ... ).fit(X, data.y_sim)
    >>> designer.subsets_
    [(0,), (1,), (0, 1)]
    >>> designer.preposterior_cov_.shape
    (3, 1, 1)
    """

    _parameter_table: ClassVar[dict] = PARAMETER_TABLE

    def __init__(
        self,
        prior=None,
        *,
        calibrator=None,
        discrepancy_prior=None,
        discrepancy_uncertainty="plug-in",
        noise_prior=None,
        X_design=None,
        n_design=None,
        n_mc=100,
        search="exhaustive",
        max_responses=None,
        criterion="trace",
        fast=True,
        n_jobs=None,
        random_state=None,
        population_size=20,
        n_generations=20,
        verbose=0,
        prior_units="standardised",
        module2_max_iter=200,
        max_warning_rate=None,
    ):
        self.prior = prior
        self.calibrator = calibrator
        self.discrepancy_prior = discrepancy_prior
        self.discrepancy_uncertainty = discrepancy_uncertainty
        self.noise_prior = noise_prior
        self.X_design = X_design
        self.n_design = n_design
        self.n_mc = n_mc
        self.search = search
        self.max_responses = max_responses
        self.criterion = criterion
        self.fast = fast
        self.n_jobs = n_jobs
        self.random_state = random_state
        self.population_size = population_size
        self.n_generations = n_generations
        self.verbose = verbose
        self.prior_units = prior_units
        self.module2_max_iter = module2_max_iter
        self.max_warning_rate = max_warning_rate

    # -------------------------------------------------------------- fit
    def fit(self, X, y):
        """Run the fast preposterior analysis.

        Parameters
        ----------
        X : array-like or DataFrame of shape (N, d + r)
            Simulation inputs: the ``d`` design variables, then the ``r``
            calibration parameters (the last ``r`` columns). With a
            DataFrame and a dict prior, the parameter columns are those
            named by the prior's keys, wherever they are; the others are
            the design variables.
        y : array-like of shape (N,) or (N, q)
            Simulated responses. No field data is needed.

        Returns
        -------
        self
        """
        # BLAS threads by the package's policy (skmba._core.threads): one for the
        # designer's own small blocks, the emulator's fit by its size and the
        # replicates as joblib tasks.
        with blas_threads(0):
            return self._fit(X, y)

    def _fit(self, X, y):
        started = time.perf_counter()
        validate_parameter_table(
            self._parameter_table, self.get_params(deep=False), type(self).__name__
        )
        names = column_names(y)
        X, Y, columns = self._simulations(X, y)
        prior, d = designer_prior(self.prior, self.calibrator, X)
        q = Y.shape[1]
        max_size = check_max_size(self.max_responses, q)
        # One child of the seed per random step: module 1, module 2a, the
        # design (and the genetic search), the nodes, the replicates.
        children = seed_sequence(self.random_state).spawn(5)
        seeds = [int_seed(c) for c in children[:4]]
        settings = calibration_settings(self.calibrator, self.n_jobs)
        X_sim, theta_sim = X[:, :d], X[:, d:]

        # Step 1: emulator, design, priors, prior-integrated emulator.
        scaler = Standardizer.from_simulations(X_sim, theta_sim, Y)
        emulator = fit_emulator(
            scaler,
            X_sim,
            theta_sim,
            Y,
            **settings.emulator.kwargs(),
            random_state=seeds[0],
            progress=self._progress(),
        )
        priors = synthetic_data_priors(self.get_params(), d, q, scaler.y_scale)
        X_design = self._field_design(columns, X_sim, seeds[2])
        ctx = MonteCarloContext.build(
            settings,
            emulator,
            scaler,
            X_design,
            prior,
            priors,
            (seeds[1], seeds[3]),
            fast=self.fast,
            module2_max_iter=self.module2_max_iter,
            user_units=self.prior_units == "user",
        )
        prior_cov = prior.cov()
        self._log("step 1: emulator and prior-integrated emulator", started)

        # Step 2, phase 1: replicates and (fast) their discrepancy estimates.
        replicates = self._phase1(ctx, children[4].spawn(self.n_mc))
        self._log(f"phase 1: {self.n_mc} replicates", started)

        # Phase 2: posterior moments for the subsets the search asks for.
        search = SearchSettings(
            self.search, max_size, self.population_size, self.n_generations, seeds[2]
        )
        results = phase2(
            ctx,
            replicates,
            lambda means: criterion_value(means, prior_cov, self.criterion),
            search,
            n_jobs=self.n_jobs,
            progress=self._progress(),
            started=started,
            max_warning_rate=self.max_warning_rate,
        )

        # Step 3: preposterior covariance and its norm.
        self._set_fitted(
            results, replicates, prior, prior_cov, q, X_design, emulator.gp, names
        )
        warn_replicate_problems(replicates)
        self._log(f"done: best subset {self.best_subset_}", started)
        return self

    def _simulations(self, X, y):
        """The simulations checked: parameters last, C-ordered float arrays,
        and the column labels of a table ``X`` in that order (else None)."""
        check_same_index(X, y)
        # A table's parameter columns are found by the prior's names.
        X = parameters_last(X, prior_names(given_prior(self.prior, self.calibrator)))
        columns = column_names(X)
        X, y = without_failed_runs(X, y)
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True)
        # C order whatever the input's (a DataFrame gives Fortran order): the
        # same bits as from an array.
        X = np.ascontiguousarray(X, dtype=float)
        return X, np.ascontiguousarray(y, dtype=float).reshape(len(X), -1), columns

    def _field_design(self, columns, X_sim, seed):
        """The planned field inputs; a table ``X_design`` matched by name to
        the design columns of a table ``X`` (``columns``, parameters last)."""
        names = None if columns is None else columns[: X_sim.shape[1]]
        X_design = match_columns(
            self.X_design, names, "X_design", "the design-variable columns of X"
        )
        return field_design(X_design, self.n_design, X_sim, seed)

    def _phase1(self, ctx, sequences):
        """Step 2, phase 1: the replicates (and, with ``fast``, their module
        2) in joblib tasks, one per seed sequence, in the order of
        ``sequences``."""
        replicates = []
        task = BlasTask(draw_replicate, ctx.n * ctx.q, self.n_jobs)
        tasks = (delayed(task)(ctx, s) for s in sequences)
        with (
            self._progress().bar(
                self.n_mc, "phase 1: replicates", unit="replicate"
            ) as bar,
            task.held(),
        ):
            for rep in results_as_ready(tasks, self.n_jobs):
                replicates.append(rep)
                bar.update(1)
        return replicates

    def _set_fitted(
        self, results, replicates, prior, prior_cov, q, X_design, gp, names=None
    ):
        """Step 3 and every fitted attribute, in one place."""
        self.prior_ = prior
        self.X_design_ = X_design
        self.model_gp_ = gp
        self.n_responses_ = q
        self.response_names_ = names
        scores = design_scores(
            results, replicates, prior_cov, self.criterion, q, self.max_warning_rate
        )
        for name, value in scores.items():
            setattr(self, f"{name}_", value)

    def _progress(self):
        """Where ``fit`` reports, by ``verbose`` (:mod:`skmba._core.progress`)."""
        return Progress(self.verbose, "PreposteriorDesigner")

    def _log(self, message, started):
        elapsed = time.perf_counter() - started
        self._progress().info(f"{message} ({elapsed:.1f} s)")

    def summary(self, response_names=None):
        """The scored sensor subsets, best (lowest score) first.

        Parameters
        ----------
        response_names : sequence of str, default=None
            Names of the ``q`` responses; None takes ``response_names_``
            when the designer records them, else ``y0, y1, ...``.

        Returns
        -------
        pandas.DataFrame or numpy structured array
            One row per subset of ``subsets_``, indexed by rank (1 = best;
            a first field ``rank`` without pandas), with the columns
            ``subset`` (the response names joined by ", "),
            ``n_responses``, ``score`` (``scores_``), ``mcse``
            (``scores_mcse_``), with ``max_warning_rate`` ``identified``
            (``identified_``, those subsets first) and, per parameter,
            ``warning_rate[<name>]`` and ``warning_rate_mcse[<name>]``
            (names from the prior, else ``theta0``, ...). ``mcse`` is the
            jackknife over the ``n_mc`` replicates: with ``s_(i)`` the
            criterion of the mean posterior covariance without replicate
            ``i``, ``sqrt((n_mc - 1) / n_mc * sum_i (s_(i) - mean
            s_(.))**2)``; for ``criterion="trace"`` the standard error of
            the mean of the per-replicate criteria. Two subsets see the
            same replicates, so the difference of their scores is usually
            known better than these errors suggest.
        """
        check_is_fitted(self, "scores_")
        q = self.n_responses_
        names = response_names
        if names is None:
            recorded = getattr(self, "response_names_", None)
            names = recorded if recorded is not None else [f"y{k}" for k in range(q)]
        names = [str(name) for name in names]
        if len(names) != q:
            raise ValueError(
                f"response_names has {len(names)} names but the designer scored "
                f"{q} responses; give one name per response."
            )
        r = self.warning_rate_.shape[1]
        parameters = self.prior_.names or [f"theta{j}" for j in range(r)]
        return design_table(
            names,
            self.subsets_,
            self.scores_,
            self.scores_mcse_,
            (self.warning_rate_, self.warning_rate_mcse_),
            parameters,
            None if self.max_warning_rate is None else self.identified_,
        )

    def score_subset(self, subset):
        """The criterion of a scored subset (lower is better).

        Parameters
        ----------
        subset : sequence of int or str
            0-based response indices, or response names (``response_names_``,
            the columns of a DataFrame ``y``).

        Returns
        -------
        float
        """
        check_is_fitted(self, "scores_")
        names, q = self.response_names_, self.n_responses_
        key = tuple(sorted(response_index(i, names, q) for i in subset))
        if key not in self.subsets_:
            raise ValueError(
                f"subset {key} was not scored; the search scored {len(self.subsets_)} "
                "subsets (see subsets_). Use search='exhaustive' to score all."
            )
        return float(self.scores_[self.subsets_.index(key)])
