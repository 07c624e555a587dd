"""Modules 1-3 of the MBA run in order, from a calibration's settings.

The calibrator's ``fit`` checks the data and the simulations, then calls
:func:`run_modules` with its
:class:`~skmba.calibration._settings.CalibrationSettings`:

1. module 1, the emulator (:mod:`skmba.calibration._module1_emulator`);
2. module 2, the emulator over the prior
   (:mod:`skmba.calibration._module2_prior_integral`), then the discrepancy
   and noise, plugged in (:mod:`skmba.calibration._module2_plug_in`) or
   propagated in two passes (:func:`~skmba.calibration._module2_posterior.
   propagated_module2`); either way a
   :class:`~skmba.calibration._module2_posterior.HyperposteriorDraws`, the
   plug-in being one draw of weight one;
3. module 3, :func:`~skmba.calibration._module3_fit.fit_module3`: the global
   model over those draws
   (:class:`~skmba.calibration._module3_mixture.ModelMixture`, always), the
   posterior of theta (:mod:`skmba.calibration._module3_posterior`) and
   module 4's rule over it.

It returns a :class:`ModulesResult`;
:func:`~skmba.calibration._fitted.fitted_attributes` turns it into the
calibrator's public fitted attributes.

Examples
--------
>>> from skmba import ModularBayesCalibrator
>>> from skmba.calibration._settings import CalibrationSettings
>>> settings = CalibrationSettings.from_params(ModularBayesCalibrator().get_params())
>>> settings.propagate
True
"""

import time
from dataclasses import dataclass
from functools import cached_property, partial

import numpy as np

from skmba._core.warn import warn
from skmba.calibration._best_fit import best_fit_of
from skmba.calibration._module1_emulator import Standardizer, fit_emulator
from skmba.calibration._module2_converged import (
    AUTO_MAX_ENTRIES,
    AUTO_TOL,
    MAX_DRAWS,
    converge,
)
from skmba.calibration._module2_converged_nodes import converge_nodes
from skmba.calibration._module2_plug_in import fit_discrepancy
from skmba.calibration._module2_posterior import (
    HyperposteriorDraws,
    fit_hyperposterior,
    propagated_module2,
)
from skmba.calibration._module2_prior_integral import (
    integrate_over_prior,
    integrate_over_rule,
    prior_units,
)
from skmba.calibration._module3_fit import (
    Module3Result,
    check_global_memory,
    fit_module3,
    sampler_of,
)
from skmba.calibration._module3_identifiability import identifiability
from skmba.calibration._module3_likelihood import GlobalModel
from skmba.calibration._module3_mixture import ModelMixture
from skmba.calibration._module3_posterior import LogPosterior
from skmba.calibration._module4_prediction import PredictionRule
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._table_6_2 import ranges_text

#: An update searches module 2's mode from the last mode alone, without the
#: settings' random restarts, until its field data hold this share more
#: measured values than when the restarts last ran: a batch small beside
#: the readings before it moves the mode, it does not make another one the
#: best (docs/monitoring.rst, "Costs").
RESTART_GROWTH = 0.1


@dataclass(frozen=True)
class ModuleInputs:
    """What modules 2 and 3 share once module 1 is done.

    ``Xs`` and ``Ys`` are the field data in the standardised units of
    ``scaler`` (the simulations' spread): the means of the readings at
    their distinct inputs, with ``replicates`` (a
    :class:`~skmba.calibration._field_replicates.ReplicateTerms`) when some
    mean holds several readings. ``warm``: the :class:`WarmStart` of an
    earlier fit of the same calibration on fewer readings, whose module-2
    mode and module-3 draws start this one's searches (``partial_fit``).
    """

    settings: object
    prior: object
    sims: object
    scaler: Standardizer
    emulator: object
    Xs: np.ndarray
    Ys: np.ndarray
    progress: object
    replicates: object = None
    warm: object = None

    @cached_property
    def n_values(self):
        """The measured values behind the field data (readings, not means)."""
        if self.replicates is not None:
            return int(self.replicates.counts.sum())
        return int(np.isfinite(self.Ys).sum())

    @cached_property
    def restarts(self):
        """Module 2's random restarts: the settings', or none in an update
        whose data grew by less than :data:`RESTART_GROWTH` since they last
        ran."""
        warm = self.warm
        if warm is not None and self.n_values < (1 + RESTART_GROWTH) * warm.searched:
            return 0
        return self.settings.discrepancy.n_restarts

    @cached_property
    def units(self):
        """The field data's units of the discrepancy prior (a
        :class:`~skmba.priors._hyperprior.PriorUnits`): the field inputs'
        spread and the model's spread over them and the prior of theta,
        relative to the simulations'."""
        return prior_units(self.emulator, self.scaler, self.prior, self.Xs)


@dataclass(frozen=True)
class ModulesResult:
    """The fitted modules 1-3 of one calibration."""

    inputs: ModuleInputs
    module2: HyperposteriorDraws
    module3: Module3Result
    identifiability: object
    best_fit: object = None  # a BestFitResult with estimand="best_fit"


@dataclass(frozen=True)
class WarmStart:
    """What an update with more readings takes from the last fit
    (``partial_fit``): the prior, the simulations and module 1, kept; the
    module-2 draws and module-3 posterior, to start from. No settings (the
    simulator need not outlive ``fit``) and no earlier warm start."""

    prior: object
    sims: object
    scaler: Standardizer
    emulator: object
    module2: HyperposteriorDraws
    module3: Module3Result
    searched: int

    @classmethod
    def of(cls, result):
        """The warm start of a :class:`ModulesResult`. ``searched``: the
        measured values when module 2's restarts last ran."""
        i = result.inputs
        searched = i.n_values
        if i.warm is not None and i.restarts == 0:
            searched = i.warm.searched
        return cls(
            i.prior,
            i.sims,
            i.scaler,
            i.emulator,
            result.module2,
            result.module3,
            searched,
        )


def _module1(settings, sims, seed, progress):
    """Module 1: the standardisation and the emulator of the simulations."""
    started = time.perf_counter()
    scaler = Standardizer.from_simulations(sims.X, sims.theta, sims.y)
    emulator = fit_emulator(
        scaler,
        sims.X,
        sims.theta,
        sims.y,
        **settings.emulator.kwargs(),
        random_state=seed,
        progress=progress,
    )
    progress.info(
        f"module 1 done in {time.perf_counter() - started:.1f} s: emulator of "
        f"{len(sims.X)} simulations, {emulator.Z.shape[1]} inputs, "
        f"{sims.y.shape[1]} response(s)"
    )
    return scaler, emulator


def run_modules(
    settings, readings, sims, prior, module2_spec, seeds, progress, warm=None
):
    """Modules 1-3: a :class:`ModulesResult`.

    ``readings`` is the field data as a
    :class:`~skmba.calibration._field_replicates.FieldReadings`;
    ``module2_spec`` is :func:`module2_prior`'s result; ``seeds`` the seven
    seeds of module 1, the prior integral, module 2 (first pass), module 3
    (first pass), the second passes of modules 2 and 3, and the best fit
    (with ``estimand="best_fit"``). ``warm``, the
    :class:`WarmStart` of an earlier fit on part of the readings, lends its
    module 1 (emulator and standardisation) and starts modules 2 and 3
    where it ended.
    """
    if warm is None:
        scaler, emulator = _module1(settings, sims, seeds[0], progress)
    else:
        scaler, emulator = warm.scaler, warm.emulator
    inputs = ModuleInputs(
        settings,
        prior,
        sims,
        scaler,
        emulator,
        scaler.x(readings.X),
        scaler.y(readings.Y),
        progress,
        readings.terms(scaler.y_scale),
        warm,
    )
    started = time.perf_counter()
    propagate = isinstance(module2_spec, Hyperprior)
    # The emulator over the prior: module 2's first pass (not run in an
    # update, which starts from the last posterior) and the plug-in.
    integrated = None
    if warm is None or not propagate:
        integrated = integrate_over_prior(
            emulator,
            scaler,
            prior,
            inputs.Xs,
            **settings.integration.kwargs(),
            random_state=seeds[1],
        )
    if propagate:
        hyperprior = module2_spec.in_units(inputs.units)
        module2, module3 = _propagated(inputs, integrated, hyperprior, seeds)
    else:
        if settings.discrepancy_tol not in (None, "auto"):
            warn(
                "discrepancy_tol is not applied with "
                'discrepancy_uncertainty="plug-in": the hyperparameters are '
                'plugged in, not integrated out; use "propagate".',
                UserWarning,
            )
        module2 = _plug_in(inputs, integrated, module2_spec, seeds[2], started)
        earlier = None if inputs.warm is None else inputs.warm.module3.posterior
        module3 = fit_module3(inputs, module2, seeds[3], earlier=earlier)
        hyperprior = Hyperprior(units=inputs.units)
    posterior = module3.posterior
    scale = np.outer(scaler.theta_scale, scaler.theta_scale)
    probe = identifiability(
        module3.log_post.model.base,
        scaler.theta(posterior.mean),
        posterior.cov / scale if propagate else None,
        hyperprior,
    )
    best_fit = None
    if settings.estimand == "best_fit":
        best_fit = best_fit_of(inputs, module3, readings, seeds[6])
    return ModulesResult(inputs, module2, module3, probe, best_fit)


def _plug_in(inputs, integrated, ranges, seed, started):
    """Module 2 by maximum likelihood: one draw of weight one."""
    disc = fit_discrepancy(
        inputs.Xs,
        inputs.Ys - integrated.mean,
        integrated.cov,
        **{**inputs.settings.discrepancy.kwargs(), "n_restarts": inputs.restarts},
        ranges=ranges,
        units=inputs.units,
        random_state=seed,
        progress=inputs.progress,
        replicates=inputs.replicates,
        start=None if inputs.warm is None else _warm_plug_in(inputs.warm),
    )
    _say_module2(inputs, started, disc, f"plug-in, range {ranges_text(ranges)}")
    return HyperposteriorDraws.plug_in(disc)


def _warm_plug_in(warm):
    """``fit_discrepancy``'s start at an earlier fit's estimate."""
    est = warm.module2.mode

    def start(fit):
        try:
            L = np.linalg.cholesky(est.sigma2 - np.diag(fit.floor))
        except np.linalg.LinAlgError:  # at a variance floor: the usual start
            return fit.start()
        return fit.pack(est.kernel_.theta, np.asarray(est.noise, float), L)

    return start


def _propagated(inputs, integrated, hyperprior, seeds):
    """Module 2 with its uncertainty, and module 3 over its draws."""

    def first_posterior(draws):
        return fit_module3(inputs, draws, seeds[3], first_pass=True)

    def over_posterior(module3):
        # The rule of a posterior (41 quadrature nodes or 200 draws) has no
        # more nodes than the prior's of the first pass, whose memory was
        # checked.
        rule = module3.rule
        return integrate_over_rule(
            inputs.emulator,
            inputs.Xs,
            inputs.scaler.theta(rule.thetas),
            rule.weights,
            n_jobs=inputs.settings.n_jobs,
        )

    tol = _tolerance(inputs)
    converged = tol is not None

    def second_pass(integrated, label="2nd pass"):
        return _draws(inputs, integrated, hyperprior, seeds[4], label, not converged)

    if inputs.warm is None:
        draws, first = propagated_module2(
            integrated,
            first_pass=lambda i: _draws(
                inputs, i, hyperprior, seeds[2], "1st pass", False
            ),
            posterior=first_posterior,
            integrate=over_posterior,
            second_pass=second_pass,
        )
    else:  # the last update's posterior tells where this one is: no 1st pass
        first = inputs.warm.module3
        draws = second_pass(over_posterior(first), "update, over the last posterior")
    if converged:
        return _converged(inputs, draws, first.posterior, tol, seeds[5])
    return draws, fit_module3(inputs, draws, seeds[5], earlier=first.posterior)


def _tolerance(inputs):
    """The tolerance of the integral over the hyperparameters, or None (16
    draws): ``discrepancy_tol`` (a number: one parameter with its
    quadrature, or several), :data:`AUTO_TOL` for ``"auto"`` (one
    parameter, quadrature, at most :data:`AUTO_MAX_ENTRIES` field
    entries); a warning when it is set to a number but cannot apply."""
    tol, sampler = inputs.settings.discrepancy_tol, sampler_of(inputs)
    several = inputs.prior.dim > 1
    if tol is None or (sampler != "quadrature" and not (several and tol != "auto")):
        if tol not in (None, "auto"):
            warn(
                f"discrepancy_tol={tol:g} is not applied: it needs several "
                f"calibration parameters, or one with its quadrature (here "
                f'one, sampler "{sampler}"); module 3 mixes 16 draws of the '
                "hyperparameters instead, and theta_mcse_ is their error as "
                "the draws see it.",
                UserWarning,
            )
        return None
    if tol != "auto":
        return tol
    entries = int(np.sum(np.isfinite(inputs.Ys)))
    if entries > AUTO_MAX_ENTRIES:
        inputs.progress.info(
            f'module 2: discrepancy_tol="auto" mixes 16 draws for {entries} '
            f"field entries (the integral to a tolerance is applied up to "
            f"{AUTO_MAX_ENTRIES}; set discrepancy_tol to ask for it)"
        )
        return None
    return AUTO_TOL


def _converged(inputs, module2, first, tol, seed):
    """The integral over the hyperparameters to the calibrator's tolerance,
    module 3's posterior and module 4's pairs: on a grid for one parameter
    (:func:`~skmba.calibration._module2_converged.converge`), at weighted
    importance nodes for several
    (:func:`~skmba.calibration._module2_converged_nodes.converge_nodes`)."""
    started = time.perf_counter()
    settings = inputs.settings
    base = GlobalModel(
        inputs.emulator, inputs.Xs, inputs.Ys, module2.mode, inputs.replicates
    )
    (n, _), q = inputs.Xs.shape, inputs.Ys.shape[1]
    check_global_memory(inputs.emulator.N, n, q, base.P, 1, MAX_DRAWS)
    log_post = LogPosterior(inputs.prior, base, inputs.scaler, inputs.sims.theta)
    if inputs.prior.dim > 1:
        integrate = partial(converge_nodes, log_post=log_post)
    else:
        integrate = partial(converge, scaler=inputs.scaler, prior=inputs.prior)
    result = integrate(
        module2,
        base,
        first=first,
        tol=tol,
        n_samples=settings.sampler.n_samples,
        random_state=seed,
        say=inputs.progress.info,
    )
    log_post = log_post.with_model(ModelMixture(base, result.draws, result.models))
    rule = PredictionRule(result.rule_thetas, result.rule_weights, result.rule_draws)
    inputs.progress.info(result.posterior.summary(time.perf_counter() - started))
    return result.draws, Module3Result(log_post, result.posterior, rule, result.error)


def _draws(inputs, integrated, prior, seed, label, predicts=True):
    """One pass of the propagated module 2 (:func:`fit_hyperposterior`); the
    noise variances' posterior mean only for the pass that ``predicts``."""
    started = time.perf_counter()
    settings = inputs.settings.discrepancy
    draws = fit_hyperposterior(
        inputs.Xs,
        inputs.Ys - integrated.mean,
        integrated.cov,
        prior=prior,
        kernel=settings.kernel,
        regression=settings.regression,
        noise=settings.noise,
        n_restarts=inputs.restarts,
        random_state=seed,
        progress=inputs.progress,
        noise_mean=predicts,
        replicates=inputs.replicates,
        start=(None if inputs.warm is None else inputs.warm.module2.mode_coordinates),
        n_jobs=inputs.settings.n_jobs,
    )
    how = f"{label}: posterior mode; {len(draws.components)} draws"
    _say_module2(inputs, started, draws.mode, how)
    return draws


def _say_module2(inputs, started, disc, how):
    inputs.progress.info(
        f"module 2 done in {time.perf_counter() - started:.1f} s: noise "
        "variances "
        f"{np.array2string(disc.noise * inputs.scaler.y_scale**2, precision=3)}"
        ", discrepancy variances / simulated variances "
        f"{np.array2string(np.diag(disc.sigma2), precision=3)} ({how})"
    )
