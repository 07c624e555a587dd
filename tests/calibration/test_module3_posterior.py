"""Module 3: the Schur-complement global model equals the dense Eq. 4.30,
with every field entry measured and with gaps (NaN entries left out)."""

import copy
import dataclasses
import warnings

import numpy as np
import pytest


@pytest.mark.parametrize("theta", [-0.7, 0.1, 0.9])
@pytest.mark.parametrize("data", ["problem", "gapped_problem"])
def test_schur_log_likelihood_equals_dense_eq_4_30(request, dense_global, theta, data):
    problem = request.getfixturevalue(data)
    gm = problem[1]
    assert gm.log_likelihood(np.array([theta])) == pytest.approx(
        dense_global(problem, theta), rel=1e-8, abs=1e-8
    )


def test_gaps_leave_out_their_entries(problem, gapped_problem):
    full, gapped = problem[1], gapped_problem[1]
    assert full.observed is None and full.n_observed == 12
    assert gapped.n_observed == 9
    # entries (2, 0), (5, 0) and (0, 1) are vec positions 2, 5 and 6 + 0
    np.testing.assert_array_equal(gapped.observed, [0, 1, 3, 4, 7, 8, 9, 10, 11])
    assert gapped.log_likelihood(np.array([0.2])) != pytest.approx(
        full.log_likelihood(np.array([0.2]))
    )


def test_field_correlation_is_the_correlation_at_every_theta(problem):
    # All field points share theta: with a stationary kernel the model
    # correlation among them does not depend on it, bit for bit.
    gm = problem[1]
    assert gm.R_ee is not None
    for theta in (-0.9, 0.2, 0.7):
        cond = gm.emulator.conditional(gm.X_e, np.array([[theta]]))
        np.testing.assert_array_equal(cond.prior_correlation()[0], gm.R_ee)
        np.testing.assert_array_equal(
            cond.correlation(prior=gm.R_ee), cond.correlation()
        )


def test_field_correlation_of_a_non_stationary_kernel_is_none(problem):
    from sklearn.gaussian_process.kernels import DotProduct

    emulator = problem[1].emulator
    gp = copy.copy(emulator.gp)
    gp.kernel_ = DotProduct()
    emulator = dataclasses.replace(emulator, gp=gp)
    assert emulator.field_correlation(problem[1].X_e) is None


def _two_parameter_fit(capsys=None, **params):
    from skmba import ModularBayesCalibrator
    from skmba.datasets import make_cantilever

    data = make_cantilever(30, 12, parameters=("E", "I"), random_state=3)
    cal = ModularBayesCalibrator(
        prior=data.prior,
        n_chains=2,
        n_samples=150,
        burn_in=150,
        n_restarts_optimizer=0,
        random_state=0,
        **params,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
    return cal


def test_chains_leave_out_idle_draws_and_run_again_when_they_matter(
    monkeypatch, capsys
):
    import skmba.calibration._module3_posterior as posterior

    pruned = _two_parameter_fit(verbose=1)
    said = capsys.readouterr().err
    assert "module-2 draws with weight near the posterior" in said
    # The draws left out weigh nothing at the posterior draws: the log
    # posterior the chains kept (over the draws kept) is the full one.
    draws = pruned.theta_samples_[::7]
    np.testing.assert_allclose(
        pruned.theta_log_posterior_.ravel()[::7],
        pruned.log_posterior(draws),
        rtol=0,
        atol=1e-6,
    )
    # Over every draw, the chains sample the same posterior (their paths
    # differ: the labels of the draws left out are proposed too).
    monkeypatch.setattr(posterior, "_without_idle_draws", lambda lp, *args: (lp, None))
    every = _two_parameter_fit()
    var = [np.diag(cal.theta_cov_) / cal.ess_ for cal in (every, pruned)]
    se = np.sqrt(var[0] + var[1])
    assert np.all(np.abs(every.theta_mean_ - pruned.theta_mean_) < 4 * se)
    # Should a draw left out weigh something at a posterior draw, the chains
    # run again over every draw.
    monkeypatch.undo()
    monkeypatch.setattr(posterior, "_IDLE_CHECK_WEIGHT", -1.0)
    again = _two_parameter_fit(verbose=1)
    assert "the chains run again over all" in capsys.readouterr().err
    np.testing.assert_array_equal(again.theta_samples_, every.theta_samples_)


def test_log_density_of_many_points_equals_one_at_a_time():
    cal = _two_parameter_fit()
    lp = cal._log_posterior
    rng = np.random.default_rng(0)
    thetas = cal.theta_samples_[rng.choice(len(cal.theta_samples_), 20)]
    # Some points outside the prior's support, one not even finite.
    thetas[3] = cal.prior_.bounds(0.999999)[:, 1] * 10.0
    U = lp.to_u(thetas)
    U[5] = np.nan
    batch = lp.log_density_u_batch(U)
    each = np.array([lp.log_density_u(u) for u in U])
    assert batch[3] == batch[5] == -np.inf
    np.testing.assert_allclose(batch, each, rtol=1e-12)
    assert np.isfinite(batch).sum() == 18
    # In user units (the quadrature's passes): the prior and the likelihood,
    # without the sampling coordinates' Jacobian.
    thetas[5] = np.nan
    in_units = lp.batch(thetas)
    each = [lp(t) if np.all(np.isfinite(t)) else -np.inf for t in thetas]
    np.testing.assert_allclose(in_units, each, rtol=1e-12)
    # The Jacobian by central differences of from_u, one coordinate at a
    # time (u_scale's constant dropped, as by the log density).
    h = 1e-6
    slopes = [
        (lp.from_u(U + h * e)[:, j] - lp.from_u(U - h * e)[:, j]) / (2 * h)
        for j, e in enumerate(np.eye(U.shape[1]))
    ]
    with np.errstate(invalid="ignore"):
        jacobian = np.sum(np.log(slopes), axis=0) - np.sum(
            np.log(lp.coordinates.u_scale)
        )
    finite = np.isfinite(batch)
    np.testing.assert_allclose(
        in_units[finite] + jacobian[finite], batch[finite], rtol=1e-8
    )
    assert in_units[3] == in_units[5] == -np.inf


def test_the_log_density_with_its_components_is_the_same_value():
    """What the chains evaluate when they keep each draw's components: the
    log density of the plain call, bit for bit (one point and a batch, with
    points outside the support), and components whose sum is it."""
    cal = _two_parameter_fit()
    lp = cal._log_posterior
    thetas = cal.theta_samples_[::20][:12].copy()
    thetas[3] = cal.prior_.bounds(0.999999)[:, 1] * 10.0
    U = lp.to_u(thetas)
    U[5] = np.nan
    values, components = lp.log_density_u_batch_with_components(U)
    np.testing.assert_array_equal(values, lp.log_density_u_batch(U))
    assert components.shape == (12, len(lp.model.models))
    assert np.all(components[[3, 5]] == -np.inf)
    finite = np.isfinite(values)
    np.testing.assert_allclose(
        np.logaddexp.reduce(components[finite], axis=1), values[finite], rtol=1e-12
    )
    np.testing.assert_allclose(
        components[finite], lp.log_density_u_components(U)[finite], rtol=1e-12
    )
    for u, joint in zip(U, components, strict=True):
        value, one = lp.log_density_u_with_components(u)
        assert value == lp.log_density_u(u)
        np.testing.assert_allclose(one, joint, rtol=1e-9)


def test_chains_keep_each_draw_s_module_2_weights():
    """The second pass's chains keep p(phi_k | theta, data) at every draw
    from their own evaluations: the weights at the draws evaluated again
    (zero for the draws they left out as idle), and the same draws as
    without them."""
    from skmba.calibration._module3_mixture import draw_weights_of
    from skmba.calibration._module3_posterior import posterior_by_mcmc

    lp = _two_parameter_fit()._log_posterior
    kwargs = dict(n_chains=2, n_samples=300, burn_in=200, random_state=1)
    with warnings.catch_warnings():  # short chains: R-hat and ESS warn
        warnings.simplefilter("ignore")
        posterior = posterior_by_mcmc(lp, **kwargs)
    weights = posterior.draw_weights
    K = len(lp.model.models)
    assert weights.shape == (len(posterior.samples), K)
    again = draw_weights_of(
        lp.model.batch_component_log_likelihoods(lp.scaler.theta(posterior.samples))
    )
    np.testing.assert_allclose(weights, again, rtol=0, atol=1e-8)
    assert np.any(weights.max(axis=0) == 0.0)  # some draws left out
    plain = posterior_by_mcmc(lp, check=False, **kwargs)
    assert plain.draw_weights is None
    np.testing.assert_array_equal(plain.samples, posterior.samples)


def test_module_2_draws_sampled_with_theta_follow_their_conditional_weights(
    monkeypatch,
):
    """Joint chains over the mixture of module-2 draws sample (theta, k):
    each label is a draw of p(phi_k | theta, data), so the labels'
    frequencies match the mean of those probabilities at the draws (within
    4 standard errors), and module 4 predicts with the sampled labels. (The
    chains are kept joint however they mix: the property does not depend
    on it.)"""
    import skmba.mcmc._chain
    from skmba.calibration._module3_posterior import posterior_by_mcmc

    monkeypatch.setattr(skmba.mcmc._chain, "_JOINT_MIN_ACCEPTANCE", 0.0)

    lp = _two_parameter_fit()._log_posterior
    posterior = posterior_by_mcmc(
        lp, n_chains=4, n_samples=500, burn_in=300, random_state=0, joint=True
    )
    labels = posterior.labels.ravel()
    K = len(lp.model.models)
    assert labels.shape == (len(posterior.samples),) and labels.max() < K
    thetas = lp.scaler.theta(posterior.samples[::4])
    values = lp.model.batch_component_log_likelihoods(thetas)
    weights = np.exp(values - np.logaddexp.reduce(values, axis=1)[:, None])
    expected = weights.mean(axis=0)
    share = np.bincount(labels, minlength=K) / len(labels)
    se = np.sqrt(expected * (1 - expected) / np.min(posterior.ess)) + 1e-3
    assert np.all(np.abs(share - expected) < 4 * se)
