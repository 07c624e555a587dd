"""Modules 1-3 of the MBA run in order with an estimator's settings.

The calibrator's ``fit`` checks the data, then calls :func:`run_modules`: module 1
(:mod:`skmba.calibration._module1_emulator`), module 2
(:mod:`skmba.calibration._module2_prior_integral`,
:mod:`skmba.calibration._module2_plug_in`) and module 3
(:mod:`skmba.calibration._module3_posterior`), and :func:`fitted_attributes` turns the
results into its fitted attributes. :func:`module_settings` is the one translation of
the estimator's parameters into the module functions' arguments, shared with the sensor
designer.

Examples
--------
>>> from skmba import ModularBayesCalibrator
>>> from skmba.calibration._pipeline import module_settings
>>> sorted(module_settings(ModularBayesCalibrator()))
['discrepancy', 'emulator', 'integration']
"""

import time
from collections.abc import Mapping

import numpy as np
from scipy import stats

from skmba._core.columns import match_columns
from skmba._core.linalg import FEWER_FIELD_DATA, FLOAT_BYTES, check_memory, n_workers
from skmba._core.regression import n_regression_terms
from skmba.calibration._module1_emulator import Standardizer, fit_emulator
from skmba.calibration._module2_plug_in import (
    check_discrepancy_ranges,
    fit_discrepancy,
    ranges_text,
)
from skmba.calibration._module2_posterior import fit_hyperposterior
from skmba.calibration._module2_prior_integral import (
    integrate_over_prior,
    integrate_over_rule,
    one_parameter_rule,
)
from skmba.calibration._module3_identifiability import identifiability, robust_interval
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.calibration._module3_mixture import ModelMixture
from skmba.calibration._module3_posterior import (
    LogPosterior,
    posterior_by_mcmc,
    posterior_by_quadrature,
)
from skmba.calibration._module4_prediction import prediction_rule
from skmba.calibration._simulations import check_design_size, collect_simulations
from skmba.calibration._summary import parameter_names
from skmba.kernels import check_correlation
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._theta import check_prior

#: Module-2 treatments: the hyperparameters integrated out of module 3
#: (default), or the thesis' plug-in of their estimate.
DISCREPANCY_UNCERTAINTIES = ("propagate", "plug-in")

#: Fitted attributes that only one posterior method sets.
OPTIONAL_FITTED = (
    "acceptance_rate_",
    "rhat_",
    "ess_",
    "theta_chains_",
    "theta_log_posterior_",
    "theta_nodes_",
    "theta_weights_",
)


def check_global_memory(N, n, q, P, jobs, draws=1):
    """Room for the module-3 global model, before it is built.

    About six nq x nq matrices (the fixed part and, per factorisation,
    the Schur complement, its Kronecker term and Cholesky factor), plus
    the (N, n) cross-correlations and the (N q, P) whitened regression;
    each parallel chain holds its own factorisation. With ``draws`` > 1
    module-2 draws, each has its fixed part, and each factorisation
    stacks all draws.
    """
    needed = FLOAT_BYTES * (
        (3 * draws + 3 * draws * jobs) * (n * q) ** 2 + 2 * jobs * N * n + 2 * N * q * P
    )
    check_memory(
        needed,
        f"The module-3 global model ({N} simulations and {n} field "
        f"observations x {q} responses)",
        FEWER_FIELD_DATA,
    )


def module2_prior(est, X, q):
    """The module-2 prior of the estimator: a Hyperprior, or plug-in ranges.

    Checked before any simulation runs, with the discrepancy kernel: it must
    be a correlation (unit diagonal on the field inputs ``X``). Under the
    plug-in, a kernel without a ``roughness`` (a scikit-learn kernel) keeps
    its own bounds unless a roughness range is given explicitly.
    """
    if est.discrepancy_kernel is not None:
        check_correlation(est.discrepancy_kernel, X, name="discrepancy_kernel")
    if est.discrepancy_uncertainty == "propagate":
        prior = Hyperprior.from_spec(est.discrepancy_prior)
        prior.scales(q)  # one sd_scale per response, or one for all
        return prior
    ranges = check_discrepancy_ranges(est.discrepancy_prior, X.shape[1], q)
    given = est.discrepancy_prior or {}
    kernel = est.discrepancy_kernel
    if (
        "roughness" not in given
        and kernel is not None
        and "roughness" not in kernel.get_params()
    ):
        ranges["roughness"] = None
    return ranges


def simulations_for(est, X, q, prior, given, seed, progress):
    """The given runs and the estimator's simulator runs (Latin hypercube)."""
    k = X.shape[1] + prior.dim
    n_runs = (est.n_simulations or 10 * k) if est.simulator is not None else 0
    check_design_size(
        n_runs + (0 if given is None else len(given.X)), est.regression, k
    )
    return collect_simulations(
        est.simulator, X, q, prior, given, n_runs, seed, progress
    )


def module_settings(cal):
    """A calibrator's MBA settings as keyword arguments of the module functions.

    The one translation of the parameters into the calls of
    :func:`~skmba.calibration._module1_emulator.fit_emulator` (``"emulator"``),
    :func:`~skmba.calibration._module2_prior_integral.integrate_over_prior`
    (``"integration"``) and :func:`~skmba.calibration._module2_plug_in.fit_discrepancy`
    (``"discrepancy"``), shared by the calibrator and the sensor designer.

    Examples
    --------
    >>> from skmba import ModularBayesCalibrator
    >>> module_settings(ModularBayesCalibrator(noise=False))["discrepancy"]["noise"]
    False
    """
    return {
        "emulator": dict(
            kernel=cal.model_kernel,
            regression=cal.regression,
            alpha=cal.emulator_alpha,
            n_restarts_optimizer=cal.n_restarts_optimizer,
        ),
        "integration": dict(
            rule=cal.integration,
            n_nodes=cal.n_integration_nodes,
            variance=cal.module2_variance,
            n_jobs=cal.n_jobs,
        ),
        "discrepancy": dict(
            kernel=cal.discrepancy_kernel,
            regression=cal.discrepancy_regression,
            noise=cal.noise,
            optimizer=cal.discrepancy_optimizer,
            n_restarts=cal.n_restarts_optimizer,
        ),
    }


def run_modules(est, X, Y, sims, prior, ranges, seeds, progress):
    """Modules 1-3 with the estimator's parameters; the fitted pieces."""
    say = progress.info
    q = Y.shape[1]
    started = time.perf_counter()
    scaler = Standardizer.from_simulations(sims.X, sims.theta, sims.y)
    emulator = fit_emulator(
        scaler,
        sims.X,
        sims.theta,
        sims.y,
        **module_settings(est)["emulator"],
        random_state=seeds[0],
        progress=progress,
    )
    say(
        f"module 1 done in {time.perf_counter() - started:.1f} s: emulator of "
        f"{len(sims.X)} simulations, {emulator.Z.shape[1]} inputs, {q} "
        "response(s)"
    )
    Xs, Ys = scaler.x(X), scaler.y(Y)
    disc, draws = _module2(
        est, emulator, scaler, prior, Xs, Ys, ranges, seeds, progress
    )
    propagate = draws is not None
    module3 = _module3(
        est,
        emulator,
        scaler,
        prior,
        sims,
        Xs,
        Ys,
        (disc, draws),
        seeds[3],
        progress,
        first_pass=propagate,
    )
    if propagate:
        # Second pass: module 2 with theta integrated over the first pass's
        # posterior instead of the prior, a closer proposal for its draws.
        rule = module3["rule"]
        # The rule of a posterior (41 quadrature nodes or 200 draws) has no
        # more nodes than the prior's of the first pass, whose memory was
        # checked.
        integrated = integrate_over_rule(
            emulator, Xs, scaler.theta(rule.thetas), rule.weights, n_jobs=est.n_jobs
        )
        disc, draws = _hyperposterior(
            est, Xs, Ys, integrated, ranges, seeds[4], progress, scaler, "2nd pass"
        )
        module3 = _module3(
            est,
            emulator,
            scaler,
            prior,
            sims,
            Xs,
            Ys,
            (disc, draws),
            seeds[5],
            progress,
            earlier=module3["posterior"],
        )
    hyperprior = ranges if isinstance(ranges, Hyperprior) else Hyperprior()
    base = module3["log_post"].model
    base = getattr(base, "base", base)
    module3["identifiability"] = identifiability(
        base, scaler.theta(module3["posterior"].mean), hyperprior
    )
    return dict(scaler=scaler, emulator=emulator, disc=disc, **module3)


def _module2(est, emulator, scaler, prior, Xs, Ys, ranges, seeds, progress):
    """Module 2: the integrated emulator, then the discrepancy and noise."""
    started = time.perf_counter()
    integrated = integrate_over_prior(
        emulator,
        scaler,
        prior,
        Xs,
        **module_settings(est)["integration"],
        random_state=seeds[1],
    )
    if isinstance(ranges, Hyperprior):
        return _hyperposterior(
            est,
            Xs,
            Ys,
            integrated,
            ranges,
            seeds[2],
            progress,
            scaler,
            "1st pass",
            predicts=False,
        )
    disc = fit_discrepancy(
        Xs,
        Ys - integrated.mean,
        integrated.cov,
        **module_settings(est)["discrepancy"],
        ranges=ranges,
        random_state=seeds[2],
        progress=progress,
    )
    _say_module2(
        progress, started, disc, scaler, f"plug-in, range {ranges_text(ranges)}"
    )
    return disc, None


def _say_module2(progress, started, disc, scaler, how):
    progress.info(
        f"module 2 done in {time.perf_counter() - started:.1f} s: noise "
        f"variances {np.array2string(disc.noise * scaler.y_scale**2, precision=3)}"
        ", discrepancy variances / simulated variances "
        f"{np.array2string(np.diag(disc.sigma2), precision=3)} ({how})"
    )


def _hyperposterior(
    est, Xs, Ys, integrated, prior, seed, progress, scaler, label, predicts=True
):
    """Module 2b with its uncertainty (:func:`fit_hyperposterior`); the noise
    variances' posterior mean only for the pass that ``predicts``."""
    started = time.perf_counter()
    settings = module_settings(est)["discrepancy"]
    draws = fit_hyperposterior(
        Xs,
        Ys - integrated.mean,
        integrated.cov,
        prior=prior,
        kernel=settings["kernel"],
        regression=settings["regression"],
        noise=settings["noise"],
        n_restarts=settings["n_restarts"],
        random_state=seed,
        progress=progress,
        noise_mean=predicts,
    )
    how = f"{label}: posterior mode; {len(draws.components)} draws"
    _say_module2(progress, started, draws.mode, scaler, how)
    return draws.mode, draws


#: The first of the two passes of the propagated module 2 needs only where
#: the posterior is: the chains, MCMC draws (per chain) and burn-in of that
#: pass (at most; fewer when the calibrator's own are).
FIRST_PASS_MCMC = {"n_chains": 2, "n_samples": 250, "burn_in": 500}


def _module3(
    est,
    emulator,
    scaler,
    prior,
    sims,
    Xs,
    Ys,
    disc,
    seed,
    progress,
    *,
    first_pass=False,
    earlier=None,
):
    """Module 3: the posterior of theta, and module 4's rule over it.

    ``earlier``: the first pass's posterior (propagated module 2), whose
    MCMC draws start the second pass's chains.
    """
    say = progress.info
    started = time.perf_counter()
    (n, d), q = Xs.shape, Ys.shape[1]
    P = q * (
        n_regression_terms(est.regression, emulator.Z.shape[1])
        + n_regression_terms(est.discrepancy_regression, d)
    )
    jobs = n_workers(est.n_jobs) if prior.dim > 1 else 1
    disc, draws = disc
    n_draws = 1 if draws is None else len(draws.components)
    check_global_memory(emulator.N, n, q, P, jobs, n_draws)
    model = GlobalModel(emulator, Xs, Ys, disc)
    if draws is not None:
        model = ModelMixture(model, draws)
    log_post = LogPosterior(prior, model, scaler, sims.theta)
    sampler = one_parameter_rule("sampler", est.sampler, prior.dim, several="mcmc")
    if sampler == "quadrature":
        posterior = posterior_by_quadrature(
            log_post,
            est.n_samples,
            random_state=seed,
            say=say,
        )
    else:
        length = {
            "n_chains": est.n_chains,
            "n_samples": est.n_samples,
            "burn_in": est.burn_in,
        }
        if first_pass:
            length = {k: min(v, length[k]) for k, v in FIRST_PASS_MCMC.items()}
        posterior = posterior_by_mcmc(
            log_post,
            **length,
            n_jobs=est.n_jobs,
            random_state=seed,
            progress=progress,
            check=not first_pass,
            joint=first_pass,
            earlier=(
                earlier.samples
                if earlier is not None and earlier.method == "mcmc"
                else None
            ),
        )
    rule = prediction_rule(
        posterior,
        log_post,
        random_state=seed,
        with_draws=not first_pass,
        n_jobs=est.n_jobs,
    )
    say(posterior.summary(time.perf_counter() - started))
    return dict(
        log_post=log_post,
        posterior=posterior,
        rule=rule,
    )


def prior_names(prior):
    """The parameter names of a dict prior (its keys), else None."""
    return [str(name) for name in prior] if isinstance(prior, Mapping) else None


def named_simulations(X_sim, theta_sim, y_sim, *, features, parameters, responses):
    """The simulation tables with their columns in the field data's order.

    ``features``, ``parameters`` and ``responses`` are the names of the
    columns of ``X``, of the prior and of ``y`` (None: unnamed); a
    DataFrame is reordered to them and arrays are left as they are (see
    :func:`~skmba._core.columns.match_columns`).
    """
    return (
        match_columns(X_sim, features, "X_sim", "the columns of X"),
        match_columns(theta_sim, parameters, "theta_sim", "the keys of prior"),
        match_columns(y_sim, responses, "y_sim", "the columns of y"),
    )


def checked_prior(prior, given, names=None):
    """The checked prior; uniform over ``theta_sim`` when None, named by
    ``names`` (the columns of a theta_sim table) when given.

    The range is that of the successful runs; when every row of ``y_sim``
    failed, that of all the rows of ``theta_sim``, so that the fit goes on
    to :func:`~skmba.calibration._simulations.check_failed_runs`, which says that too
    few runs remain (or to the simulator's runs, when there is one).
    """
    if prior is not None:
        return check_prior(prior, None if given is None else given.theta.shape[1])
    if given is None:
        raise ValueError(
            "prior is required when the simulations are run by the "
            "simulator: pass e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
        )
    t = given.theta
    if len(t) == 0:  # every row of y_sim failed: their theta are still known
        t = np.array([f.theta for f in given.failures]).reshape(-1, t.shape[1])
    uniforms = [
        stats.uniform(lo, hi - lo) for lo, hi in zip(t.min(0), t.max(0), strict=True)
    ]
    return check_prior(
        uniforms if names is None else dict(zip(names, uniforms, strict=True))
    )


def fitted_attributes(
    X,
    y,
    Y_ndim,
    responses,
    prior,
    sims,
    scaler,
    emulator,
    disc,
    log_post,
    posterior,
    rule,
    identifiability,
):
    """The calibrator's fitted attributes from the pieces of the fit (user units).

    Returns a dict ``{attribute name: value}``; the private entries
    (leading underscore) are what the predictions and ``log_posterior``
    need. The optional attributes (:data:`OPTIONAL_FITTED`) are present
    only for their posterior method.
    """
    out = {"_y_ndim": Y_ndim}
    out["prior_"] = prior
    out["parameter_names_"] = parameter_names(prior)
    out["response_names_"] = responses
    out["X_obs_"], out["y_obs_"] = X, y
    out["X_sim_"], out["theta_sim_"], out["y_sim_"] = sims.X, sims.theta, sims.y
    out["simulation_failures_"] = list(sims.failures)
    out["X_mean_"], out["X_scale_"] = scaler.X_mean, scaler.X_scale
    out["theta_offset_"], out["theta_scale_"] = scaler.theta_offset, scaler.theta_scale
    out["y_mean_"], out["y_scale_"] = scaler.y_mean, scaler.y_scale
    out["model_gp_"] = emulator.gp
    out["discrepancy_kernel_"] = disc.kernel_
    out["discrepancy_sigma2_"] = scaler.y_covariance_to_user(disc.sigma2)
    out["discrepancy_beta_"] = disc.beta * scaler.y_scale
    out["noise_"] = disc.noise * scaler.y_scale**2
    out["theta_samples_"] = posterior.samples
    out["theta_mean_"], out["theta_cov_"] = posterior.mean, posterior.cov
    if posterior.method == "quadrature":
        out["theta_nodes_"], out["theta_weights_"] = posterior.nodes, posterior.weights
    else:
        out["theta_chains_"] = posterior.chains
        out["theta_log_posterior_"] = posterior.log_density
        out["acceptance_rate_"] = posterior.acceptance_rate
        out["rhat_"], out["ess_"] = posterior.rhat, posterior.ess
    out["identifiability_"] = identifiability.ratio
    out["theta_robust_interval_"] = robust_interval(
        posterior.mean, identifiability.probe_sd * scaler.theta_scale, prior
    )
    out["global_model_"] = log_post.model
    out["_scaler"] = scaler
    out["_log_posterior"] = log_post
    out["_prediction_rule"] = rule
    return out
