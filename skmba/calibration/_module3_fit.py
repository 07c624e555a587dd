"""Module 3 of a run: the posterior of theta over module 2's draws, and module 4's rule.

:func:`fit_module3` builds the global model over module 2's draws
(:class:`~skmba.calibration._module3_mixture.ModelMixture`) and its log posterior
(:class:`~skmba.calibration._module3_posterior.LogPosterior`). In an update it first
tries the last run's draws reweighted (:mod:`skmba.calibration._module3_update`);
otherwise :func:`sample_posterior` integrates by quadrature (one parameter) or runs
chains, from the first pass's or the last posterior's draws with a shorter burn-in
(:func:`warm_burn_in`). Module 4's rule
(:func:`~skmba.calibration._module4_prediction.prediction_rule`) and the Monte Carlo
error of the module-2 draws
(:func:`~skmba.calibration._module3_mixture_error.fixed_draws_error`) follow.
:func:`~skmba.calibration._pipeline.run_modules` calls it once per pass.
"""

import time
from dataclasses import dataclass, replace

from skmba._core.linalg import FEWER_FIELD_DATA, FLOAT_BYTES, check_memory, n_workers
from skmba._core.regression import n_regression_terms
from skmba.calibration._module2_prior_integral import one_parameter_rule
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.calibration._module3_mixture import ModelMixture
from skmba.calibration._module3_mixture_error import fixed_draws_error
from skmba.calibration._module3_posterior import LogPosterior, posterior_by_mcmc
from skmba.calibration._module3_quadrature import posterior_by_quadrature
from skmba.calibration._module3_update import reweighted_posterior
from skmba.calibration._module4_prediction import prediction_rule
from skmba.mcmc._chain import MIN_ADAPTIVE_BURN_IN

#: The first of the two passes of the propagated module 2 needs only where
#: the posterior is: the chains, MCMC draws (per chain) and burn-in of that
#: pass (at most; fewer when the calibrator's own are).
FIRST_PASS_MCMC = {"n_chains": 2, "n_samples": 250, "burn_in": 500}

#: The second pass's chains, which start from the first pass's draws, burn
#: in this share of ``burn_in`` (250 of the default 1000): they propose from
#: those draws' moments at once and, after the burn-in, from a proposal
#: fitted to all the chains' burn-ins together (:mod:`skmba.mcmc._run`).
#: Measured against long chains: docs/internals.rst, section
#: skmba.mcmc._chain. Chains whose draws would warn of R-hat run again
#: after ``burn_in`` steps: a first pass that located the posterior poorly
#: leaves too little burn-in to adapt. An update's chains, which start from
#: the last posterior's draws on fewer readings, burn in ``burn_in``: after
#: 250 steps one b2 update of 36 gave sds 0.86 of a long reference's (same
#: section).
WARM_BURN_IN_SHARE = 0.25


@dataclass(frozen=True)
class Module3Result:
    """Module 3's log posterior and posterior of theta, and module 4's rule;
    ``error``, the Monte Carlo error of the integral over module 2's
    hyperparameters (a :class:`~skmba.calibration._module2_converged.
    MonteCarloError`), where it is estimated."""

    log_post: LogPosterior
    posterior: object
    rule: object
    error: object = None


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


def fit_module3(inputs, module2, seed, *, first_pass=False, earlier=None):
    """Module 3: the posterior of theta over module 2's draws, and module 4's
    rule over it.

    ``earlier``: the first pass's posterior, whose draws start the second
    pass's chains, or the last update's (reweighted when that does, else
    :func:`sample_posterior`).
    """
    started = time.perf_counter()
    settings, emulator = inputs.settings, inputs.emulator
    (n, d), q = inputs.Xs.shape, inputs.Ys.shape[1]
    P = q * (
        n_regression_terms(settings.emulator.regression, emulator.Z.shape[1])
        + n_regression_terms(settings.discrepancy.regression, d)
    )
    jobs = n_workers(settings.n_jobs) if inputs.prior.dim > 1 else 1
    check_global_memory(emulator.N, n, q, P, jobs, len(module2.components))
    model = ModelMixture(
        GlobalModel(emulator, inputs.Xs, inputs.Ys, module2.mode, inputs.replicates),
        module2,
    )
    log_post = LogPosterior(inputs.prior, model, inputs.scaler, inputs.sims.theta)
    posterior = draw_weights = start = None
    if earlier is not None:  # an update: the last run's draws may do
        posterior, draw_weights, start = reweighted_posterior(
            log_post,
            earlier,
            n_jobs=settings.n_jobs,
            random_state=seed,
            say=inputs.progress.info,
        )
    if posterior is None:
        posterior = sample_posterior(inputs, log_post, seed, first_pass, earlier, start)
    rule, nodes, draw_weights = prediction_rule(
        posterior,
        log_post,
        random_state=seed,
        with_draws=not first_pass,
        n_jobs=settings.n_jobs,
        node_draw_weights=draw_weights,
        return_draw_weights=True,
    )
    inputs.progress.info(posterior.summary(time.perf_counter() - started))
    error = fixed_draws_error(posterior, nodes, draw_weights, log_post, settings.n_jobs)
    if posterior.draw_weights is not None:  # read: not kept with the fit
        posterior = replace(posterior, draw_weights=None)
    return Module3Result(log_post, posterior, rule, error)


def warm_burn_in(burn_in):
    """The second pass's burn-in: :data:`WARM_BURN_IN_SHARE` of
    ``burn_in``, at least the 100 steps in which the chains adapt and pool
    their proposal (:data:`~skmba.mcmc._chain.MIN_ADAPTIVE_BURN_IN`), and
    at most ``burn_in``."""
    return min(burn_in, max(round(WARM_BURN_IN_SHARE * burn_in), MIN_ADAPTIVE_BURN_IN))


def sampler_of(inputs):
    """The sampler of the settings: quadrature (one parameter) or MCMC."""
    s = inputs.settings.sampler
    return one_parameter_rule("sampler", s.sampler, inputs.prior.dim, several="mcmc")


def sample_posterior(inputs, log_post, seed, first_pass, earlier, start=None):
    """The posterior of theta by quadrature (one parameter) or MCMC, the
    chains from ``earlier``'s draws or from ``start``'s (a refused
    reweighting's, which also fit their proposal); from the first pass's or
    ``start``'s they burn in :func:`warm_burn_in` steps."""
    s = inputs.settings.sampler
    if sampler_of(inputs) == "quadrature":
        return posterior_by_quadrature(
            log_post, s.n_samples, random_state=seed, say=inputs.progress.info
        )
    length = {"n_chains": s.n_chains, "n_samples": s.n_samples, "burn_in": s.burn_in}
    if first_pass:
        length = {k: min(v, length[k]) for k, v in FIRST_PASS_MCMC.items()}
    draws = (
        earlier.samples
        if earlier is not None and earlier.method in ("mcmc", "reweighted")
        else None
    )
    if start is not None:
        draws = start.samples
    fallback = None
    if draws is not None and (inputs.warm is None or start is not None):
        length["burn_in"] = warm_burn_in(s.burn_in)
        fallback = s.burn_in if length["burn_in"] < s.burn_in else None
    return posterior_by_mcmc(
        log_post,
        **length,
        target_ess=None if first_pass else s.target_ess,
        n_jobs=s.n_jobs,
        random_state=seed,
        progress=inputs.progress,
        check=not first_pass,
        joint=first_pass,
        earlier=draws,
        fallback_burn_in=fallback,
        earlier_fits_proposal=start is not None,
    )
