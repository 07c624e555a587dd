"""The sensor designer's inputs, checked: prior, priors of the data, design.

:class:`~skmba.PreposteriorDesigner` turns its parameters and the
simulations into what the fast preposterior analysis needs, here, before
any emulator is fitted: the prior of ``theta`` and the layout of ``X``
(:func:`designer_prior`), the priors the synthetic field data are drawn
from (:func:`synthetic_data_priors`), the planned field inputs
(:func:`field_design`).

Examples
--------
>>> import numpy as np
>>> field_design(None, 4, np.array([[0.0], [10.0]]), seed=0).shape
(4, 1)
"""

import numbers

import numpy as np
from scipy import stats
from sklearn.utils import check_array

from skmba._core.validation import (
    Boolean,
    Count,
    InstanceOf,
    NJobs,
    Options,
    Real,
    validate_parameter_table,
)
from skmba._core.warn import warn
from skmba.calibration._estimator import ModularBayesCalibrator
from skmba.calibration._settings import DISCREPANCY_UNCERTAINTIES, CalibrationSettings
from skmba.calibration._settings import PARAMETER_TABLE as CALIBRATION_TABLE
from skmba.calibration._simulations import RUNS_PER_INPUT, nonfinite_rows
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._table_6_2 import (
    DEFAULT_DISCREPANCY_PRIOR,
    DEFAULT_NOISE_PRIOR,
    check_interval,
)
from skmba.priors._theta import check_prior

PRIOR_UNITS = ("standardised", "user")

SEARCHES = ("exhaustive", "greedy", "genetic")
CRITERIA = ("trace", "det", "max_eig")

#: The designer's parameter table (checked at the start of ``fit`` by
#: :func:`~skmba._core.validation.validate_parameter_table`).
PARAMETER_TABLE = {
    "prior": "no_validation",  # check_prior, in fit
    "calibrator": [
        InstanceOf(
            ModularBayesCalibrator,
            what="a ModularBayesCalibrator",
            hint="a template of the MBA settings",
            allow_none=True,
        )
    ],
    "discrepancy_prior": "no_validation",  # check_design_priors, in fit
    "discrepancy_uncertainty": [Options(DISCREPANCY_UNCERTAINTIES)],
    "noise_prior": "no_validation",
    "X_design": "no_validation",  # check_array, in fit
    "n_design": [Count(minimum=2, allow_none=True)],
    "n_mc": [Count(minimum=1)],
    "search": [Options(SEARCHES)],
    "max_responses": "no_validation",  # check_max_size, in fit
    "criterion": [Options(CRITERIA)],
    "fast": [Boolean()],
    "n_jobs": [NJobs()],
    "random_state": "no_validation",  # check_random_state, in fit
    "population_size": [Count(minimum=2)],
    "n_generations": [Count(minimum=1)],
    "verbose": [Count(minimum=0)],
    "prior_units": [Options(PRIOR_UNITS)],
    "module2_max_iter": [Count(minimum=1, allow_none=True)],
    "max_warning_rate": [
        Real(
            minimum=0,
            maximum=1,
            hint="e.g. 0.1; None ranks every subset",
            allow_none=True,
        )
    ],
}

#: Field design points when neither ``X_design`` nor ``n_design`` is given
#: (section 6.3).
DEFAULT_N_DESIGN = 25


def calibration_settings(calibrator, n_jobs):
    """The MBA settings of the designer's ``calibrator`` template (None:
    the defaults), checked, with the designer's ``n_jobs``."""
    template = calibrator or ModularBayesCalibrator()
    params = {**template.get_params(deep=False), "n_jobs": n_jobs}
    params.update(prior=None, simulator=None)
    validate_parameter_table(CALIBRATION_TABLE, params, type(template).__name__)
    if params["estimand"] != "physical":
        raise ValueError(
            f"calibrator has estimand={params['estimand']!r}: the designer "
            "ranks sensors by the posterior variance of the physical "
            'parameters only. Pass a calibrator with estimand="physical".'
        )
    return CalibrationSettings.from_params(params)


def given_prior(prior, calibrator):
    """The designer's ``prior``, else its calibrator's (None if neither)."""
    if prior is None and calibrator is not None:
        return calibrator.prior
    return prior


def designer_prior(prior, calibrator, X):
    """The checked prior, and the number ``d`` of design variables of ``X``.

    ``X`` holds the design variables, then the ``r`` parameters; the prior
    is ``prior`` or else the calibrator's, and the simulated parameters must
    overlap its support.
    """
    prior = given_prior(prior, calibrator)
    if prior is None:
        raise ValueError(
            "prior is required: pass the prior of the calibration parameters, "
            "e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
        )
    prior = check_prior(prior)
    N, r = len(X), prior.dim
    d = X.shape[1] - r
    if d < 1:
        raise ValueError(
            f"X has {X.shape[1]} columns (n_features={X.shape[1]}) but the "
            f"prior has {r} parameters: X "
            "must hold the design variables first and the r calibration "
            "parameters as its last r columns."
        )
    if N < 2 * (d + r) + 1:
        raise ValueError(
            f"{N} simulations (n_samples={N}) are too few for {d + r} inputs: "
            "the emulator "
            f"needs at least {2 * (d + r) + 1}, and about "
            f"{RUNS_PER_INPUT * (d + r)} are recommended."
        )
    theta_sim = X[:, d:]
    support = prior.bounds(0.999)
    if np.any(theta_sim.max(axis=0) < support[:, 0]) or np.any(
        theta_sim.min(axis=0) > support[:, 1]
    ):
        raise ValueError(
            "The simulated parameters (last r columns of X) do not overlap the "
            "prior's support: simulate over the prior's range."
        )
    return prior, d


def synthetic_data_priors(params, d, q, y_scale):
    """The priors of the synthetic data: ranges (plug-in) or a Hyperprior.

    From the designer's parameters ``params`` (``get_params()``):
    ``discrepancy_uncertainty``, ``discrepancy_prior``, ``noise_prior`` and
    ``prior_units``.
    """
    if params["discrepancy_uncertainty"] == "plug-in":
        return check_design_priors(
            params["discrepancy_prior"],
            params["noise_prior"],
            params["prior_units"],
            d,
            q,
            y_scale,
        )
    for name, default in (("noise_prior", None), ("prior_units", "standardised")):
        value = params[name]
        if value != default:
            raise ValueError(
                f"{name}={value!r} belongs to discrepancy_uncertainty='plug-in'; "
                "with 'propagate' the noise prior is discrepancy_prior['noise'] "
                "and every prior is in standardised units: leave "
                f"{name} at {default!r}."
            )
    prior = Hyperprior.from_spec(params["discrepancy_prior"])
    prior.scales(q)
    return prior


def field_design(X_design, n_design, X_sim, seed):
    """The planned field inputs: ``X_design`` checked, or a Latin hypercube
    of ``n_design`` points (None: :data:`DEFAULT_N_DESIGN`) over the range of
    the simulated design variables."""
    d = X_sim.shape[1]
    lo, hi = X_sim.min(axis=0), X_sim.max(axis=0)
    if X_design is None:
        n_design = DEFAULT_N_DESIGN if n_design is None else n_design
        u = stats.qmc.LatinHypercube(d=d, seed=seed).random(n_design)
        return lo + (hi - lo) * u
    # C order: a table matched by name is column-major, and the same design
    # must give the same bits whatever its layout.
    X_design = check_array(X_design, input_name="X_design", order="C")
    if X_design.shape[1] != d:
        raise ValueError(
            f"X_design has {X_design.shape[1]} columns but the simulations "
            f"have {d} design variables."
        )
    tol = 1e-9 * np.maximum(hi - lo, 1.0)
    if np.any(X_design < lo - tol) or np.any(X_design > hi + tol):
        raise ValueError(
            "X_design lies outside the range of the simulated design "
            f"variables [{lo.tolist()}, {hi.tolist()}]: the emulator would "
            "extrapolate. Keep X_design inside it or extend the simulations."
        )
    return X_design


def check_design_priors(discrepancy_prior, noise_prior, prior_units, d, q, y_scale):
    """The designer's priors of the discrepancy and the noise, checked.

    Returns a dict of ``(low, high)`` arrays in standardised units (keys
    ``roughness``, ``variance``, ``mean``, ``noise``) and the ``correlation``
    matrix or ``"random"``.
    """
    given = {} if discrepancy_prior is None else discrepancy_prior
    if not isinstance(given, dict):
        raise TypeError(
            "discrepancy_prior must be a dict with keys among "
            f"{sorted(DEFAULT_DISCREPANCY_PRIOR)}, got {type(given).__name__}."
        )
    unknown = set(given) - set(DEFAULT_DISCREPANCY_PRIOR)
    if unknown:
        raise ValueError(
            f"discrepancy_prior has unknown keys {sorted(unknown)}; use "
            f"{sorted(DEFAULT_DISCREPANCY_PRIOR)}."
        )
    spec = {**DEFAULT_DISCREPANCY_PRIOR, **given}
    out = {
        "roughness": check_interval(
            spec["roughness"], "discrepancy_prior['roughness']", d, lower=0.0
        ),
        "variance": check_interval(
            spec["variance"], "discrepancy_prior['variance']", q, lower=0.0
        ),
        "mean": check_interval(spec["mean"], "discrepancy_prior['mean']", q),
        "noise": check_interval(
            DEFAULT_NOISE_PRIOR if noise_prior is None else noise_prior,
            "noise_prior",
            q,
            lower=0.0,
        ),
    }
    if np.any(out["roughness"][0] <= 0):
        raise ValueError("discrepancy_prior['roughness'] must be > 0.")
    corr = spec["correlation"]
    if isinstance(corr, str):
        if corr not in ("random", "independent"):
            raise ValueError(
                "discrepancy_prior['correlation'] must be 'random', "
                f"'independent' or a number in (-1/(q-1), 1), got {corr!r}."
            )
        if corr == "independent":
            corr = np.eye(q)
    elif isinstance(corr, numbers.Real):
        low = -1.0 / (q - 1) if q > 1 else -1.0
        if not low < corr < 1.0:
            raise ValueError(
                f"discrepancy_prior['correlation']={corr} gives a matrix that "
                f"is not positive definite; use a number in ({low:.3g}, 1)."
            )
        corr = np.full((q, q), float(corr))
        np.fill_diagonal(corr, 1.0)
    else:
        raise TypeError(
            "discrepancy_prior['correlation'] must be 'random', 'independent' "
            f"or a number, got {corr!r}."
        )
    out["correlation"] = corr
    if prior_units == "user":
        # Response units -> the standardised units used internally.
        for key, power in (("variance", 2), ("noise", 2), ("mean", 1)):
            lo, hi = out[key]
            out[key] = (lo / y_scale**power, hi / y_scale**power)
    return out


def without_failed_runs(X, y):
    """``X`` and ``y`` without the runs whose responses hold NaN or inf (failed
    simulator runs), which are left out with a warning, as the calibrator
    does; every run failed is an error. Data that are not numbers are left to
    scikit-learn's checks."""
    try:
        Y = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        return X, y
    if Y.ndim not in (1, 2) or len(Y) == 0:
        return X, y
    failed = nonfinite_rows(Y.reshape(len(Y), -1))
    if not failed.size:
        return X, y
    if failed.size == len(Y):
        raise ValueError(
            "Input y contains NaN or infinity in every run: the responses of "
            "every simulation failed. Pass the successful runs."
        )
    keep = np.setdiff1d(np.arange(len(Y)), failed)
    warn(
        f"{failed.size} of {len(Y)} simulation runs hold NaN or inf in y (failed "
        f"runs, rows {failed[:10].tolist()}{' ...' if failed.size > 10 else ''}): "
        "they are left out, as ModularBayesCalibrator does.",
        UserWarning,
    )

    def rows(A):
        return A.iloc[keep] if hasattr(A, "iloc") else np.asarray(A)[keep]

    return rows(X), rows(y)
