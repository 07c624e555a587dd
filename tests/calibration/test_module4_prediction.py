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


@pytest.mark.parametrize(
    "component", ["model", "discrepancy", "reality", "observation"]
)
@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_joint_covariance_equals_dense_kriging(request, dense_global, component, data):
    problem = request.getfixturevalue(data)
    X_star = np.array([[-0.5], [0.2], [0.75]])
    mean_d, cov_d = dense_global(problem, 0.3, component, X_star, full=True)
    mean, cov = conditional_moments(
        problem[1], np.array([0.3]), X_star, component, full=True
    )
    np.testing.assert_allclose(mean, mean_d, rtol=1e-10, atol=0)
    np.testing.assert_allclose(cov, cov_d, rtol=1e-9, atol=1e-12 * np.abs(cov_d).max())


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


@pytest.fixture(scope="module")
def bridge_month():
    import warnings

    from skmba import ModularBayesCalibrator
    from skmba.datasets import make_bridge_monitoring

    data = make_bridge_monitoring(n_hours=24 * 30, random_state=0)
    sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim)
    fits = []
    for y, y_sim in ((data.y_obs, data.y_sim), (data.y_obs[:, 0], data.y_sim[:, 0])):
        cal = ModularBayesCalibrator(
            prior=data.prior,
            discrepancy_uncertainty="plug-in",
            bin_width=1.0,
            n_samples=500,
            burn_in=200,
            random_state=0,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # E is confounded (temperature only)
            fits.append(cal.fit(data.X_obs, y, y_sim=y_sim, **sims))
    return fits


@pytest.mark.parametrize(
    "method", ["predict", "predict_reality", "predict_model", "predict_discrepancy"]
)
def test_calibrator_joint_covariance_has_the_std_on_its_diagonal(bridge_month, method):
    # Over the posterior draws: the law of total covariance, whose diagonal
    # is the law of total variance of return_std.
    X = np.array([[-3.0], [0.5], [7.5]])
    multi, single = bridge_month
    mean, std = getattr(multi, method)(X, return_std=True)
    mean_c, cov = getattr(multi, method)(X, return_cov=True)
    assert cov.shape == (3, 4, 3, 4)
    np.testing.assert_array_equal(mean_c, mean)
    # Equal up to the round-off of the prior variance minus its reduction by
    # the data, a small difference of large terms: bounded by 1e-13 of the
    # model's prior variance in user units (1e-17 to 1e-16 of it measured;
    # reality's variance is 1e-7 to 1e-5 of it at these inputs).
    prior = np.diag(multi.model_gp_.sigma2_) * np.var(multi.y_sim_, axis=0)
    np.testing.assert_allclose(
        np.einsum("akak->ak", cov), std**2, rtol=1e-7, atol=1e-13 * prior.max()
    )
    flat = cov.reshape(12, 12)
    np.testing.assert_allclose(flat, flat.T, rtol=0, atol=1e-12 * np.abs(flat).max())
    assert np.linalg.eigvalsh(flat).min() > -1e-9 * np.abs(flat).max()
    # 1-D y: (s, s)
    _, std1 = getattr(single, method)(X, return_std=True)
    _, cov1 = getattr(single, method)(X, return_cov=True)
    assert cov1.shape == (3, 3)
    prior1 = single.model_gp_.sigma2_[0, 0] * np.var(single.y_sim_)
    np.testing.assert_allclose(np.diag(cov1), std1**2, rtol=1e-7, atol=1e-13 * prior1)
    with pytest.raises(RuntimeError, match="At most one"):
        getattr(multi, method)(X, return_std=True, return_cov=True)
