"""Module 4: conditional kriging moments equal the dense formulas."""

import numpy as np
import pytest

from skmba.calibration._module4_prediction import PredictionRule, conditional_moments


@pytest.mark.parametrize(
    "component", ["model", "discrepancy", "reality", "observation"]
)
@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_conditional_predictions_equal_dense_kriging(
    request, dense_global, component, data
):
    problem = request.getfixturevalue(data)
    gm = problem[1]
    X_star = np.array([[-0.5], [0.2], [0.75]])
    mean_d, var_d = dense_global(problem, 0.3, component, X_star)
    mean, var = conditional_moments(gm, np.array([0.3]), X_star, component)
    # Equal to round-off (about 1e-14 measured, gapped or not).
    np.testing.assert_allclose(mean, mean_d, rtol=1e-10, atol=0)
    np.testing.assert_allclose(var, var_d, rtol=1e-10, atol=0)


def test_components_add_up(problem):
    gm = problem[1]
    X_star = np.array([[-0.2], [0.4]])
    theta = np.array([0.5])
    m = conditional_moments(gm, theta, X_star, "model", return_var=False)
    d = conditional_moments(gm, theta, X_star, "discrepancy", return_var=False)
    total = conditional_moments(gm, theta, X_star, "reality", return_var=False)
    np.testing.assert_allclose(m + d, total, rtol=1e-10, atol=1e-12)


def test_equal_weight_rule_thins_the_draws():
    draws = np.arange(1000.0)[:, None]
    rule = PredictionRule.equal_weights(draws)
    assert len(rule.thetas) == 200 and rule.weights.sum() == pytest.approx(1.0)
    np.testing.assert_array_equal(rule.thetas[:3, 0], [0.0, 5.0, 10.0])
