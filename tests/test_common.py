"""scikit-learn's estimator checks on every public estimator."""

import warnings

import numpy as np
import pytest
from scipy import stats
from sklearn.utils.estimator_checks import (
    check_dataframe_column_names_consistency,
    parametrize_with_checks,
)

from skmba import ModularBayesCalibrator, MultiResponseGP, PreposteriorDesigner


def scaled_sum_model(X, theta):
    """A small simulator for any number of inputs: theta * sum(X)."""
    return X.sum(axis=1, keepdims=True) * theta[:, :1]


SMALL_CALIBRATOR = ModularBayesCalibrator(
    scaled_sum_model,
    [stats.uniform(0.5, 2.0)],
    n_simulations=30,
    n_samples=200,
    burn_in=100,
    n_restarts_optimizer=0,
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


@parametrize_with_checks(
    [MultiResponseGP(), MultiResponseGP(noise=True), SMALL_CALIBRATOR, SMALL_DESIGNER],
    expected_failed_checks=expected_failed_checks,
)
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
