"""The calibrator's settings: one frozen value, built once from ``get_params()``.

:class:`CalibrationSettings` is the one translation of
:class:`~skmba.ModularBayesCalibrator`'s parameters into what the modules
need, grouped by module: :class:`EmulatorSettings` (module 1),
:class:`IntegrationSettings` (module 2's prior integral),
:class:`DiscrepancySettings` (module 2's discrepancy and noise) and
:class:`SamplerSettings` (module 3). The pipeline
(:mod:`skmba.calibration._pipeline`) and the sensor designer read it; no
function below the estimators takes an estimator.

Examples
--------
>>> from skmba import ModularBayesCalibrator
>>> from skmba.calibration._settings import CalibrationSettings
>>> params = ModularBayesCalibrator(noise=False).get_params(deep=False)
>>> settings = CalibrationSettings.from_params(params)
>>> settings.discrepancy.noise, settings.sampler.n_chains
(False, 4)
>>> sorted(settings.emulator.kwargs())
['alpha', 'kernel', 'n_restarts_optimizer', 'regression']
"""

from dataclasses import dataclass, fields

from sklearn.gaussian_process.kernels import Kernel

from skmba._core.regression import REGRESSIONS
from skmba._core.validation import (
    Boolean,
    Callable,
    Count,
    InstanceOf,
    NJobs,
    Options,
    Real,
)
from skmba.calibration._best_fit import ESTIMANDS
from skmba.calibration._module2_plug_in import DISCREPANCY_OPTIMIZERS
from skmba.calibration._module2_prior_integral import INTEGRATIONS, MODULE2_VARIANCES
from skmba.calibration._module3_posterior import SAMPLERS

#: Module-2 treatments: the hyperparameters integrated out of module 3
#: (default), or the thesis' plug-in of their estimate.
DISCREPANCY_UNCERTAINTIES = ("propagate", "plug-in")

_KERNEL = InstanceOf(Kernel, what="an sklearn Kernel", allow_none=True)

#: The calibrator's parameter table (checked at the start of ``fit`` by
#: :func:`~skmba._core.validation.validate_parameter_table`).
PARAMETER_TABLE = {
    "simulator": [
        Callable(what="a callable simulator(X, theta) -> Y", allow_none=True)
    ],
    "prior": "no_validation",  # check_prior, in fit
    "n_simulations": [Count(minimum=2, allow_none=True)],
    "model_kernel": [_KERNEL],
    "discrepancy_kernel": [_KERNEL],
    "regression": [Options(REGRESSIONS, hint="thesis Table 3.1")],
    "discrepancy_regression": [Options(REGRESSIONS, hint="thesis Table 3.1")],
    "noise": [Boolean()],
    "integration": [Options(INTEGRATIONS)],
    "sampler": [Options(SAMPLERS)],
    "n_chains": [Count(minimum=1)],
    "n_samples": [Count(minimum=1)],
    "target_ess": [
        Real(minimum=1, hint="e.g. 2000; None: n_samples draws", allow_none=True)
    ],
    "burn_in": [Count(minimum=0)],
    "n_jobs": [NJobs()],
    "random_state": "no_validation",  # check_random_state, in fit
    "n_integration_nodes": [Count(minimum=2, allow_none=True)],
    "module2_variance": [Options(MODULE2_VARIANCES)],
    "n_restarts_optimizer": [Count(minimum=0)],
    "discrepancy_optimizer": [Options(DISCREPANCY_OPTIMIZERS)],
    "discrepancy_uncertainty": [Options(DISCREPANCY_UNCERTAINTIES)],
    "estimand": [Options(ESTIMANDS, hint="docs/validity.rst: the best-fit estimand")],
    "discrepancy_prior": "no_validation",  # module2_prior, in fit
    "discrepancy_tol": [
        Options(("auto",)),
        Real(
            minimum=1e-4,
            hint="posterior sds, e.g. 0.05; smaller costs more draws",
            allow_none=True,
        ),
    ],
    "emulator_alpha": [Real(minimum=0, hint="the emulator's nugget, e.g. 1e-8")],
    "bin_width": "no_validation",  # check_bin_width, in fit (one per input)
    "verbose": [Count(minimum=0)],
}


class KeywordGroup:
    """A frozen group of settings that a module function takes as keywords."""

    def kwargs(self):
        """The settings as a dict of keyword arguments (values not copied)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class EmulatorSettings(KeywordGroup):
    """Module 1: the keywords of
    :func:`~skmba.calibration._module1_emulator.fit_emulator`."""

    kernel: object
    regression: str
    alpha: float
    n_restarts_optimizer: int


@dataclass(frozen=True)
class IntegrationSettings(KeywordGroup):
    """Module 2, the emulator over the prior: the keywords of
    :func:`~skmba.calibration._module2_prior_integral.integrate_over_prior`."""

    rule: str
    n_nodes: int | None
    variance: str
    n_jobs: int | None


@dataclass(frozen=True)
class DiscrepancySettings(KeywordGroup):
    """Module 2, the discrepancy and noise: the keywords of
    :func:`~skmba.calibration._module2_plug_in.fit_discrepancy`."""

    kernel: object
    regression: str
    noise: bool
    optimizer: str
    n_restarts: int


@dataclass(frozen=True)
class SamplerSettings(KeywordGroup):
    """Module 3, the posterior of theta: the sampler and its chains."""

    sampler: str
    n_chains: int
    n_samples: int
    burn_in: int
    target_ess: float | None
    n_jobs: int | None


@dataclass(frozen=True)
class CalibrationSettings:
    """The settings of one calibration, complete when constructed.

    Parameters
    ----------
    simulator : callable or None
    n_simulations : int or None
    verbose : int
    discrepancy_uncertainty : {"propagate", "plug-in"}
    discrepancy_prior : dict or None
        As given; :func:`~skmba.calibration._fit_setup.module2_prior` checks
        it against the data.
    discrepancy_tol : "auto", float or None
        Monte Carlo tolerance of the integral over module 2's
        hyperparameters, in posterior sds of theta; None: module 2's 16
        draws; "auto": 0.05 where it applies (one parameter), else 16
        draws; a number applies with any number of parameters.
    estimand : {"physical", "best_fit"}
        What theta's posterior is of (:mod:`~skmba.calibration._best_fit`).
    n_jobs : int or None
    bin_width : float, ndarray or None
        As given; :func:`~skmba.calibration._field_replicates.check_bin_width`
        checks it against the field inputs.
    emulator, integration, discrepancy, sampler
        The settings of each module.
    """

    simulator: object
    n_simulations: int | None
    verbose: int
    discrepancy_uncertainty: str
    discrepancy_prior: dict | None
    discrepancy_tol: str | float | None
    estimand: str
    n_jobs: int | None
    bin_width: object
    emulator: EmulatorSettings
    integration: IntegrationSettings
    discrepancy: DiscrepancySettings
    sampler: SamplerSettings

    @classmethod
    def from_params(cls, params):
        """The settings from a calibrator's ``get_params(deep=False)``."""
        p = params
        return cls(
            simulator=p["simulator"],
            n_simulations=p["n_simulations"],
            verbose=p["verbose"],
            discrepancy_uncertainty=p["discrepancy_uncertainty"],
            discrepancy_prior=p["discrepancy_prior"],
            discrepancy_tol=p["discrepancy_tol"],
            estimand=p["estimand"],
            n_jobs=p["n_jobs"],
            bin_width=p["bin_width"],
            emulator=EmulatorSettings(
                kernel=p["model_kernel"],
                regression=p["regression"],
                alpha=p["emulator_alpha"],
                n_restarts_optimizer=p["n_restarts_optimizer"],
            ),
            integration=IntegrationSettings(
                rule=p["integration"],
                n_nodes=p["n_integration_nodes"],
                variance=p["module2_variance"],
                n_jobs=p["n_jobs"],
            ),
            discrepancy=DiscrepancySettings(
                kernel=p["discrepancy_kernel"],
                regression=p["discrepancy_regression"],
                noise=p["noise"],
                optimizer=p["discrepancy_optimizer"],
                n_restarts=p["n_restarts_optimizer"],
            ),
            sampler=SamplerSettings(
                sampler=p["sampler"],
                n_chains=p["n_chains"],
                n_samples=p["n_samples"],
                burn_in=p["burn_in"],
                target_ess=p["target_ess"],
                n_jobs=p["n_jobs"],
            ),
        )

    @property
    def propagate(self):
        """Whether module 2's uncertainty is carried into module 3."""
        return self.discrepancy_uncertainty == "propagate"
