"""The default prior of the module-2 hyperparameters (skmba.priors._hyperprior)."""

import numpy as np
import pytest
from scipy import integrate, stats

from skmba.kernels import Exp, Gauss, GeneralizedExp, Spherical
from skmba.priors._hyperprior import Hyperprior, PriorUnits, lkj_correlation


@pytest.mark.parametrize(("q", "eta"), [(2, 1.0), (3, 2.0), (4, 1.0), (5, 2.0)])
def test_lkj_marginals_are_beta(q, eta):
    # Each correlation of LKJ(eta) is 2 Beta(eta - 1 + q/2) - 1 (LKJ 2009).
    rng = np.random.default_rng(0)
    draws = np.array([lkj_correlation(q, eta, rng) for _ in range(3000)])
    a = eta - 1 + q / 2
    for i, j in [(0, 1), (q - 2, q - 1), (0, q - 1)]:
        x = 0.5 * (draws[:, i, j] + 1.0)
        assert stats.kstest(x, stats.beta(a, a).cdf).pvalue > 1e-3
    assert np.all(np.linalg.eigvalsh(draws) > 0)


def test_correlation_density_is_lkj_for_two_responses():
    # q = 2: rho = z / sqrt(1 + z^2) with rho ~ 2 Beta(eta, eta) - 1; the
    # density of z is that of rho times d rho / d z = (1 + z^2)^-1.5.
    prior = Hyperprior(correlation_eta=2.0)
    z = np.linspace(-4, 4, 9)
    rho = z / np.sqrt(1 + z**2)
    ref = stats.beta(2, 2).logpdf(0.5 * (rho + 1)) - np.log(2) - 1.5 * np.log1p(z**2)
    ours = np.array([prior.log_correlation(np.array([v]), 2)[0] for v in z])
    assert np.ptp(ours - ref) < 1e-12


def test_correlation_density_gradient_and_normalisation():
    prior = Hyperprior(correlation_eta=1.5)
    z = np.array([0.3, -1.2, 0.7])  # q = 3
    _, grad = prior.log_correlation(z, 3)
    h = 1e-6
    num = [
        (prior.log_correlation(z + e, 3)[0] - prior.log_correlation(z - e, 3)[0])
        / (2 * h)
        for e in np.eye(3) * h
    ]
    np.testing.assert_allclose(grad, num, rtol=1e-6)
    # q = 2 density integrates to a constant that matches LKJ's: 1 over rho.
    total = integrate.quad(
        lambda t: np.exp(
            Hyperprior(correlation_eta=1.0).log_correlation(np.array([t]), 2)[0]
        ),
        -np.inf,
        np.inf,
    )[0]
    assert total == pytest.approx(2.0)  # the length of (-1, 1)


def test_log_sd_is_half_normal_in_log_coordinates():
    prior = Hyperprior(sd_scale=0.7)
    t = np.array([-2.0, 0.1])
    value, grad = prior.log_sd(t)
    ref = np.sum(stats.halfnorm(scale=0.7).logpdf(np.exp(t)) + t)
    # Up to the normalising constant of the half-normal.
    const = 2 * (np.log(np.sqrt(2 / np.pi) / 0.7))
    assert value + const == pytest.approx(ref)
    np.testing.assert_allclose(grad, 1 - np.exp(2 * t) / 0.49)


def test_draws_follow_the_prior():
    prior = Hyperprior()
    rng = np.random.default_rng(0)
    draws = [prior.rvs(2, 3, random_state=rng) for _ in range(400)]
    sd = np.array([d["sd"] for d in draws]).ravel()
    assert stats.kstest(sd, stats.halfnorm(scale=0.5).cdf).pvalue > 1e-3
    rough = np.array([d["roughness"] for d in draws]).ravel()
    assert stats.kstest(rough, stats.loguniform(0.1, 9.0).cdf).pvalue > 1e-3
    noise = np.array([d["noise"] for d in draws]).ravel()
    assert stats.kstest(noise, stats.loguniform(1e-6, 1.0).cdf).pvalue > 1e-3
    assert prior.sd_quantile(0.95)[0] == pytest.approx(0.5 * 1.959964, rel=1e-6)
    per_response = Hyperprior(sd_scale=[0.5, 0.01])
    np.testing.assert_allclose(
        per_response.sd_quantile(0.95, 2), [0.98, 0.0196], rtol=1e-4
    )
    with pytest.raises(ValueError, match="has 2 values for 3 responses"):
        per_response.rvs(1, 3, random_state=0)


def test_same_seed_same_draw():
    a, b = Hyperprior().rvs(1, 2, random_state=3), Hyperprior().rvs(1, 2, 3)
    assert all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize(
    ("spec", "error", "match"),
    [
        ([1], TypeError, "must be None or a dict"),
        ({"variance": (0.01, 20)}, ValueError, "belong to discrepancy_uncertainty"),
        ({"sd_scale": -1.0}, ValueError, "sd_scale.*positive"),
        ({"sd_scale": [[0.5]]}, ValueError, "sd_scale.*1-D array"),
        ({"correlation_eta": 0.0}, ValueError, "correlation_eta.*positive"),
        ({"noise": (1.0, 0.1)}, ValueError, r"noise.*0 < low < high"),
        ({"roughness": (0.0, 9.0)}, ValueError, r"roughness.*0 < low < high"),
    ],
)
def test_bad_spec(spec, error, match):
    with pytest.raises(error, match=match):
        Hyperprior.from_spec(spec)


def test_roughness_none_means_the_kernels_own_bounds():
    """discrepancy_prior={'roughness': None}, the remedy an earlier error
    message recommended, failed with 'not enough values to unpack'."""
    import warnings

    from skmba import ModularBayesCalibrator, PreposteriorDesigner
    from skmba.datasets import make_cantilever

    prior = Hyperprior.from_spec({"roughness": None})
    assert prior.roughness is None
    with pytest.raises(ValueError, match="needs the kernel's roughness_bounds"):
        prior.rvs(d=1, q=2, random_state=0)
    draw = prior.rvs(d=2, q=1, random_state=0, roughness_bounds=(1e-3, [1e-2, 1e3]))
    assert 1e-3 <= draw["roughness"][0] <= 1e-2 and 1e-3 <= draw["roughness"][1] <= 1e3
    data = make_cantilever(30, 10, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(
            prior=data.prior,
            discrepancy_prior={"roughness": None},
            n_restarts_optimizer=0,
            random_state=0,
        ).fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
        designer = PreposteriorDesigner(
            data.prior,
            calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
            discrepancy_uncertainty="propagate",
            discrepancy_prior={"roughness": None},
            n_design=5,
            n_mc=2,
            random_state=0,
        ).fit(np.hstack([data.X_sim, data.theta_sim]), data.y_sim)
    assert np.all(np.isfinite(cal.theta_mean_)) and np.all(
        np.isfinite(designer.scores_)
    )


# -------------------------------------------------- the prior's units


@pytest.mark.parametrize(
    ("kernel", "power"),
    [
        (Gauss(), 2.0),
        (Exp(), 1.0),
        (GeneralizedExp(power=1.5), 1.5),
        (Spherical(), 1.0),
    ],
)
def test_roughness_in_module2_units_gives_the_same_correlation(kernel, power):
    # A roughness stated on inputs scaled by the field inputs' sd, carried to
    # the simulations' standardisation, is the same correlation function.
    assert kernel.roughness_power == power
    rng = np.random.default_rng(0)
    x_user = rng.uniform(10.0, 30.0, size=(7, 1))
    field_sd, sim_sd = 4.0, 11.0
    units = PriorUnits(input_ratio=(sim_sd / field_sd,), response_ratio=(1.0,))
    omega = 0.7
    in_field = kernel.set_params(roughness=omega)(x_user / field_sd)
    moved = units.roughness(omega, kernel.roughness_power)
    in_module2 = kernel.set_params(roughness=float(moved[0]))(x_user / sim_sd)
    np.testing.assert_allclose(in_module2, in_field, rtol=1e-12, atol=1e-15)


def test_prior_in_units_scales_sizes_and_ranges():
    units = PriorUnits(input_ratio=(2.0, 0.5), response_ratio=(3.0, 0.1))
    prior = Hyperprior(sd_scale=(0.5, 0.2)).in_units(units)
    np.testing.assert_allclose(prior.scales(2), [1.5, 0.02])
    np.testing.assert_allclose(prior.noise_bounds(2), [[9e-6, 9.0], [1e-8, 1e-2]])
    lo, hi = prior.roughness_bounds(2, power=2.0)
    np.testing.assert_allclose(lo, [0.4, 0.025])
    np.testing.assert_allclose(hi, [36.0, 2.25])
    one = prior.restrict([1])
    np.testing.assert_allclose(one.scales(1), [0.02])
    np.testing.assert_allclose(one.noise_bounds(1), [[1e-8, 1e-2]])
    # The half-normal density of the sd is the field one's, moved: the
    # densities of log sd agree at corresponding points.
    field = Hyperprior(sd_scale=(0.5, 0.2))
    log_sd = np.log([0.3, 0.05])
    moved = log_sd + np.log([3.0, 0.1])
    assert prior.log_sd_normalised(moved) == pytest.approx(
        field.log_sd_normalised(log_sd), rel=1e-12
    )
    # A draw: roughness and noise inside the moved ranges.
    draw = prior.rvs(2, 2, random_state=0)
    assert np.all((draw["roughness"] >= lo) & (draw["roughness"] <= hi))
    bounds = prior.noise_bounds(2)
    assert np.all((draw["noise"] >= bounds[:, 0]) & (draw["noise"] <= bounds[:, 1]))


@pytest.mark.parametrize(
    "ratio", [(0.0,), (-1.0,), (np.nan,), (np.inf,), ((1.0, 2.0),)]
)
def test_prior_units_must_be_positive_and_finite(ratio):
    with pytest.raises(ValueError, match="input_ratio"):
        PriorUnits(input_ratio=ratio, response_ratio=(1.0,))
