"""scikit-learn's estimator checks on every public estimator."""

import warnings

import numpy as np
import pytest
from scipy import stats
from sklearn.base import clone
from sklearn.utils.estimator_checks import (
    check_dataframe_column_names_consistency,
    check_estimators_pickle,
    check_fit_idempotent,
    estimator_checks_generator,
)

from skmba import ModularBayesCalibrator, MultiResponseGP, PreposteriorDesigner


def scaled_sum_model(X, theta):
    """A small simulator for any number of inputs: theta * sum(X)."""
    return X.sum(axis=1, keepdims=True) * theta[:, :1]


# Small and fast for the API checks, which test input handling, tags and
# persistence, not the statistics: the thesis' plug-in module 2, one global
# model (this file took 110 s with 16 module-2 draws, 29 s so);
# test_default_integral_api runs the checks that read every fitted
# attribute on the default (module 2 propagated to its tolerance).
SMALL_CALIBRATOR = ModularBayesCalibrator(
    scaled_sum_model,
    [stats.uniform(0.5, 2.0)],
    n_simulations=30,
    n_samples=200,
    burn_in=100,
    n_restarts_optimizer=0,
    discrepancy_uncertainty="plug-in",
    random_state=0,
)


# The checks' random X has its last column read as the parameter; a wide
# prior covers it whatever its values.
SMALL_DESIGNER = PreposteriorDesigner(
    [stats.uniform(-100.0, 200.0)],
    calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
    n_design=5,
    n_mc=2,
    random_state=0,
)


def expected_failed_checks(estimator):
    if isinstance(estimator, ModularBayesCalibrator):
        return {
            "check_regressor_multioutput": (
                "the simulator fixes the number of responses (one here); the "
                "check fits y with several outputs, which the calibrator rejects "
                "with a ValueError naming the mismatch"
            )
        }
    return {}


#: The estimators checked, by the name their tests carry.
CHECKED = {
    "MultiResponseGP()": MultiResponseGP(),
    "MultiResponseGP(noise=True)": MultiResponseGP(noise=True),
    "SMALL_CALIBRATOR": SMALL_CALIBRATOR,
    "SMALL_DESIGNER": SMALL_DESIGNER,
}


def _check_name(check):
    """A check's name and keywords, e.g.
    ``check_estimators_pickle(readonly_memmap=True)``."""
    func = getattr(check, "func", check)
    keywords = getattr(check, "keywords", {})
    args = ",".join(f"{key}={value}" for key, value in sorted(keywords.items()))
    return f"{func.__name__}({args})" if args else func.__name__


def _sklearn_checks():
    """``parametrize_with_checks``' cases with ids that name the estimator
    by :data:`CHECKED`'s key: its own ids print the estimator's repr,
    which holds the prior's and the simulator's memory addresses, so two
    processes (pytest-xdist's workers) would collect different tests."""
    for name, estimator in CHECKED.items():
        for case in estimator_checks_generator(
            estimator,
            legacy=True,
            expected_failed_checks=expected_failed_checks(estimator),
            mark="xfail",
        ):
            # an expected failure comes as a pytest.param with its xfail mark
            (est, check), marks = (
                getattr(case, "values", case),
                getattr(case, "marks", ()),
            )
            yield pytest.param(
                est, check, id=f"{name}-{_check_name(check)}", marks=marks
            )


@pytest.mark.parametrize("estimator, check", list(_sklearn_checks()))
def test_sklearn_compatible_estimator(estimator, check):
    with np.errstate(all="ignore"):
        check(estimator)


# scikit-learn's own check that an estimator fitted on a DataFrame records
# feature_names_in_ and rejects other or reordered names at prediction; it
# is not among parametrize_with_checks' checks (scikit-learn 1.9), so it
# runs here, with pandas from the test extra.
@pytest.mark.parametrize(
    "estimator",
    [MultiResponseGP(), SMALL_CALIBRATOR, SMALL_DESIGNER],
    ids=["MultiResponseGP", "ModularBayesCalibrator", "PreposteriorDesigner"],
)
def test_dataframe_column_names_consistency(estimator):
    pytest.importorskip("pandas")
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # small-design warnings
        check_dataframe_column_names_consistency(type(estimator).__name__, estimator)


@pytest.mark.parametrize(
    "check", [check_fit_idempotent, check_estimators_pickle], ids=lambda c: c.__name__
)
def test_default_integral_api(check):
    # The checks that read every fitted attribute, on the default: module
    # 2's uncertainty propagated by the integral to discrepancy_tol="auto"
    # (its draws, grid and Monte Carlo errors).
    default = ModularBayesCalibrator()
    estimator = clone(SMALL_CALIBRATOR).set_params(
        discrepancy_uncertainty=default.discrepancy_uncertainty,
        discrepancy_tol=default.discrepancy_tol,
    )
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # small-design warnings
        check(type(estimator).__name__, estimator)
