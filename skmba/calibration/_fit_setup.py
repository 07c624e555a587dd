"""What ``fit`` settles before the modules run, from the settings.

- :func:`warn_field_size`: a warning, before anything runs, when the field
  data make modules 2-3 long;
- :func:`module2_prior`: the module-2 prior (propagated) or ranges
  (plug-in), checked before any simulation runs;
- :func:`prior_and_simulations` (with :func:`simulations_for`): the checked
  prior of theta and the simulations, given and run;
- :func:`checked_field_data`: the field data checked, their row labels and
  the simulation tables matched to them by name.

:func:`~skmba.calibration._pipeline.run_modules` then runs modules 1-3.
"""

import numpy as np
from sklearn.utils.validation import check_consistent_length, validate_data

from skmba._core.columns import column_names
from skmba._core.linalg import FLOAT_BYTES
from skmba._core.progress import duration_text
from skmba._core.warn import warn
from skmba.calibration._field_data import (
    check_field_data,
    check_same_index,
    checked_field_y,
    measured_field_data,
    named_simulations,
    pandas_index,
    prior_names,
    row_labels,
    warn_few_distinct_inputs,
)
from skmba.calibration._module2_posterior import N_HYPER_DRAWS
from skmba.calibration._module2_prior_integral import one_parameter_rule
from skmba.calibration._simulations import (
    check_design_size,
    check_failed_runs,
    checked_prior,
    collect_simulations,
    given_simulations,
)
from skmba.kernels import check_correlation
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._table_6_2 import check_discrepancy_ranges

#: Measured field values (entries of y) above which ``fit`` warns about its
#: cost before it starts.
FIELD_VALUES_WARNING = 500
#: The reference of the time estimate: the cantilever's defaults with 200
#: measured values (100 readings of 2 responses) took 12.4 s on two cores
#: (50 values: 1.1 s, 100: 2.8 s); the time grows as the cube beyond.
REFERENCE_FIELD_FIT = (200, 12.4)


def warn_field_size(n_values, n_readings, settings):
    """Warn before a fit whose ``n_values`` measured field values (means at
    the distinct inputs of ``n_readings`` rows) make modules 2-3 long: their
    ``m x m`` factorisations, ``m = n_values``, cost ``m^3``, thousands of
    them."""
    if n_values <= FIELD_VALUES_WARNING:
        return
    seconds = REFERENCE_FIELD_FIT[1] * (n_values / REFERENCE_FIELD_FIT[0]) ** 3
    draws = N_HYPER_DRAWS if settings.propagate else 1
    gib = FLOAT_BYTES * 6 * draws * n_values**2 / 2**30  # as check_global_memory
    warn(
        f"{n_readings} field readings hold {n_values} measured values at "
        "distinct inputs (readings repeated at one input count once): modules "
        f"2-3 factor {n_values} x {n_values} matrices thousands of times, at a "
        f"cost growing as the cube of that number (200 values take about "
        f"{REFERENCE_FIELD_FIT[1]:.0f} s on two cores): expect of the order "
        f"of {duration_text(seconds)} and {gib:.1f} GiB. Average close inputs "
        "with bin_width (e.g. 0.5 degC of temperature), or subsample the "
        "readings before fitting.",
        UserWarning,
    )


def module2_prior(settings, X, q):
    """The module-2 prior of the settings: a Hyperprior, or plug-in ranges.

    Checked before any simulation runs, with the discrepancy kernel: it must
    be a correlation (unit diagonal on the field inputs ``X``). Under the
    plug-in, a kernel without a ``roughness`` (a scikit-learn kernel) keeps
    its own bounds unless a roughness range is given explicitly.
    """
    kernel = settings.discrepancy.kernel
    if kernel is not None:
        check_correlation(kernel, X, name="discrepancy_kernel")
    if settings.propagate:
        prior = Hyperprior.from_spec(settings.discrepancy_prior)
        prior.scales(q)  # one sd_scale per response, or one for all
        return prior
    ranges = check_discrepancy_ranges(settings.discrepancy_prior, X.shape[1], q)
    given = settings.discrepancy_prior or {}
    if (
        "roughness" not in given
        and kernel is not None
        and "roughness" not in kernel.get_params()
    ):
        ranges["roughness"] = None
    return ranges


def simulations_for(settings, X, q, prior, given, seed, progress, names=None):
    """The given runs and the simulator's runs (Latin hypercube); a table
    output of the simulator is matched to the responses ``names``."""
    k = X.shape[1] + prior.dim
    simulator = settings.simulator
    n_runs = (settings.n_simulations or 10 * k) if simulator is not None else 0
    check_design_size(
        n_runs + (0 if given is None else len(given.X)),
        settings.emulator.regression,
        k,
    )
    return collect_simulations(
        simulator, X, q, prior, given, n_runs, seed, progress, names
    )


def prior_and_simulations(settings, prior, X, q, named, seed, progress):
    """The checked ``prior`` and the simulations, given and run, for field
    inputs ``X`` and ``q`` responses.

    ``named`` is ``(responses, tables)``: the responses' names and the
    simulation tables matched to the field data
    (:func:`~skmba.calibration._field_data.named_simulations`).
    """
    responses, tables = named
    given = given_simulations(X, q, *tables)
    prior = checked_prior(prior, given, names=column_names(tables[1]))
    for name, value, other in (
        ("integration", settings.integration.rule, "qmc"),
        ("sampler", settings.sampler.sampler, "mcmc"),
    ):
        one_parameter_rule(name, value, prior.dim, several=other)
    sims = simulations_for(settings, X, q, prior, given, seed, progress, responses)
    check_failed_runs(sims, settings.emulator.regression, X.shape[1] + prior.dim)
    if sims.theta.shape[1] != prior.dim:
        raise ValueError(
            f"theta_sim has {sims.theta.shape[1]} columns but the prior has "
            f"{prior.dim} parameters."
        )
    return prior, sims


def checked_field_data(estimator, X, y, simulations, reported):
    """The field data of ``estimator.fit`` checked (the measured rows, C
    order; rows before ``reported`` without a warning), the labels of those
    rows, and the simulation tables matched to them by name. ``estimator``
    for scikit-learn's ``validate_data`` (feature names and count) and its
    ``discrepancy_regression`` and ``prior``."""
    check_field_data(X, y, estimator.discrepancy_regression)
    check_same_index(X, y)
    index = pandas_index(y)
    features, responses = column_names(X), column_names(y)
    X = validate_data(estimator, X)
    y = checked_field_y(y)  # NaN allowed: a reading not taken
    labels = row_labels(index, len(y))
    check_consistent_length(X, y)
    # Tables of simulations are matched to the field data and the prior
    # by their column labels (arrays by position).
    tables = named_simulations(
        *simulations,
        features=features,
        parameters=prior_names(estimator.prior),
        responses=responses,
    )
    # C order whatever the input's (a DataFrame gives Fortran order): the
    # same bits as from an array.
    X = np.ascontiguousarray(X, dtype=float)
    Y = np.ascontiguousarray(y, dtype=float).reshape(len(X), -1)
    kept = np.isfinite(Y).any(axis=1)
    X, Y = measured_field_data(
        X, Y, estimator.discrepancy_regression, responses, reported
    )
    warn_few_distinct_inputs(X, estimator.discrepancy_regression)
    return X, Y, np.ndim(y), responses, tables, labels[kept]
