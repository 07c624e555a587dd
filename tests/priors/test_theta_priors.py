"""Tests of the priors of theta: closed forms, quadrature exactness, checks."""

import numpy as np
import pytest
from scipy import stats

from skmba.priors._theta import (
    GaussianPrior,
    GenericPrior,
    IndependentPrior,
    Prior,
    check_prior,
)

COV = np.array([[4.0, 2.4], [2.4, 9.0]])  # correlation 0.8


def independent():
    return check_prior([stats.uniform(20e3, 80e3), stats.norm(50e3, 1e4)])


def gaussian():
    return check_prior(stats.multivariate_normal([1.0, -2.0], COV))


class ExponentialPair:
    """A user prior: independent exponentials with rates 1 and 2."""

    rates = np.array([1.0, 2.0])

    def logpdf(self, theta):
        theta = np.asarray(theta)
        inside = np.all(theta >= 0.0, axis=1)
        value = np.sum(np.log(self.rates) - self.rates * theta, axis=1)
        return np.where(inside, value, -np.inf)

    def rvs(self, size, random_state):
        return random_state.exponential(1.0 / self.rates, size=(size, 2))


class ExponentialPairWithPpf(ExponentialPair):
    def ppf(self, u):
        return -np.log1p(-np.asarray(u)) / self.rates


class ScalarUserPrior:
    """A one-parameter user prior whose rvs returns shape (n,)."""

    def logpdf(self, theta):
        return stats.norm.logpdf(np.asarray(theta)[:, 0])

    def rvs(self, size, random_state):
        return random_state.standard_normal(size)


# ---------------------------------------------------------------- dispatch


def test_check_prior_dispatch():
    assert isinstance(independent(), IndependentPrior)
    assert isinstance(gaussian(), GaussianPrior)
    assert isinstance(check_prior(stats.norm(0, 1)), IndependentPrior)
    assert isinstance(check_prior((stats.norm(), stats.expon())), IndependentPrior)
    assert isinstance(check_prior(ExponentialPair()), GenericPrior)
    t = check_prior(stats.multivariate_t([0.0, 0.0], np.eye(2), df=5))
    assert isinstance(t, GenericPrior)
    assert t.dim == 2
    assert check_prior(stats.norm(), n_parameters=1).dim == 1
    assert independent().dim == 2
    assert gaussian().dim == 2
    assert check_prior(ScalarUserPrior()).dim == 1
    prior = gaussian()
    assert check_prior(prior, n_parameters=2) is prior
    assert all(isinstance(p, Prior) for p in (independent(), gaussian(), t))


def test_repr_is_readable():
    assert repr(independent()) == (
        "IndependentPrior([uniform(loc=20000, scale=80000), "
        "norm(loc=50000, scale=10000)])"
    )
    assert repr(check_prior(stats.lognorm(0.5, scale=2.0))) == (
        "IndependentPrior([lognorm(s=0.5, scale=2)])"
    )
    assert repr(gaussian()) == (
        "GaussianPrior(mean=[ 1., -2.], cov=[[4. , 2.4], [2.4, 9. ]])"
    )
    assert repr(check_prior(ExponentialPair())).startswith("GenericPrior(<")
    assert repr(check_prior(ExponentialPair())).endswith("dim=2)")


# ---------------------------------------------------------------- logpdf


def test_logpdf_independent_is_sum_of_marginals():
    prior = independent()
    theta = np.column_stack([np.linspace(25e3, 95e3, 7), np.linspace(20e3, 80e3, 7)])
    expected = stats.uniform(20e3, 80e3).logpdf(theta[:, 0]) + stats.norm(
        50e3, 1e4
    ).logpdf(theta[:, 1])
    np.testing.assert_allclose(prior.logpdf(theta), expected, rtol=1e-13)


def test_logpdf_gaussian_matches_scipy():
    prior = gaussian()
    theta = np.random.default_rng(0).normal(size=(9, 2)) * 3.0
    expected = stats.multivariate_normal([1.0, -2.0], COV).logpdf(theta)
    np.testing.assert_allclose(prior.logpdf(theta), expected, rtol=1e-12)


def test_logpdf_one_dimensional_gaussian_matches_norm():
    prior = check_prior(stats.multivariate_normal([3.0], [[4.0]]))
    theta = np.linspace(-5.0, 9.0, 8)
    np.testing.assert_allclose(
        prior.logpdf(theta), stats.norm(3.0, 2.0).logpdf(theta), rtol=1e-12
    )


def test_logpdf_minus_inf_outside_support_never_nan():
    prior = independent()
    theta = np.array(
        [[19e3, 50e3], [101e3, 50e3], [np.inf, 50e3], [50e3, np.inf], [-np.inf, 0]]
    )
    out = prior.logpdf(theta)
    assert np.all(out == -np.inf)
    assert np.isfinite(prior.logpdf([[20e3, 50e3], [100e3, 50e3]])).all()
    # inf - inf inside the Gaussian's quadratic form must not give NaN
    out = gaussian().logpdf([[np.inf, -np.inf], [np.inf, np.inf]])
    assert np.all(out == -np.inf)
    out = check_prior(ExponentialPair()).logpdf([[-1.0, 1.0], [1.0, -1e-9]])
    assert np.all(out == -np.inf)


@pytest.mark.parametrize(
    ("theta", "shape"),
    [
        (np.tile([60e3, 50e3], (5, 1)), (5,)),
        (np.array([60e3, 50e3]), (1,)),  # one row of length r
        ([[60e3, 50e3]], (1,)),
        (np.empty((0, 2)), (0,)),
    ],
)
def test_logpdf_shapes(theta, shape):
    out = independent().logpdf(theta)
    assert out.shape == shape
    np.testing.assert_allclose(
        out, np.full(shape, independent().logpdf([[60e3, 50e3]])[0])
    )


@pytest.mark.parametrize(
    ("theta", "shape"), [(0.5, (1,)), ([0.5], (1,)), ([0.1, 0.5, 0.9], (3,))]
)
def test_logpdf_shapes_one_parameter(theta, shape):
    """With r = 1 a scalar is one point and a vector of length m is m points."""
    prior = check_prior(stats.norm(0.5, 1.0))
    out = prior.logpdf(theta)
    assert out.shape == shape
    np.testing.assert_allclose(
        out, stats.norm(0.5, 1.0).logpdf(np.ravel(theta)), rtol=1e-14
    )
    column = np.reshape(theta, (-1, 1))
    np.testing.assert_array_equal(prior.logpdf(column), out)


@pytest.mark.parametrize(
    "theta",
    [np.zeros(3), np.zeros((4, 3)), np.zeros((2, 2, 2)), 1.0, [[np.nan, 1.0]]],
)
def test_logpdf_rejects_bad_theta(theta):
    with pytest.raises(ValueError, match="theta"):
        gaussian().logpdf(theta)


# ---------------------------------------------------------------- integration


def moment(nodes, weights, k):
    return np.sum(weights * nodes[:, 0] ** k)


def test_integration_nodes_uniform_exact():
    """Gauss-Legendre on the quantile scale: ppf is linear, so exact."""
    a, b = 20e3, 100e3
    prior = check_prior(stats.uniform(a, b - a))
    nodes, weights = prior.integration_nodes(20)
    assert nodes.shape == (20, 1)
    assert weights.shape == (20,)
    for k in (1, 2, 4):
        exact = (b ** (k + 1) - a ** (k + 1)) / ((k + 1) * (b - a))
        np.testing.assert_allclose(moment(nodes, weights, k), exact, rtol=1e-10)
    assert np.all((nodes > a) & (nodes < b))


@pytest.mark.parametrize(
    "prior",
    [stats.norm(3.0, 2.0), stats.multivariate_normal([3.0], [[4.0]])],
    ids=["independent", "gaussian"],
)
def test_integration_nodes_normal(prior):
    """A normal prior uses Gauss-Hermite: exact moments up to degree 2n - 1.

    (The quantile Gauss-Legendre rule converges only algebraically for a
    normal, whose ppf is unbounded: about 6e-4 relative error on E[θ²] with
    64 nodes; Gauss-Hermite is exact.)
    """
    prior = check_prior(prior)
    loc, var = 3.0, 4.0
    nodes, weights = prior.integration_nodes(20)
    np.testing.assert_allclose(moment(nodes, weights, 1), loc, rtol=1e-12)
    centred = nodes[:, 0] - loc
    np.testing.assert_allclose(np.sum(weights * centred**2), var, rtol=1e-12)
    np.testing.assert_allclose(np.sum(weights * centred**4), 3 * var**2, rtol=1e-12)
    x, w = np.polynomial.hermite_e.hermegauss(20)
    np.testing.assert_allclose(nodes[:, 0], loc + 2.0 * x)
    np.testing.assert_allclose(weights, w / w.sum(), rtol=1e-12)


@pytest.mark.parametrize("make", [independent, gaussian])
def test_integration_nodes_several_parameters(make):
    prior = make()
    nodes, weights = prior.integration_nodes(1000, random_state=0)
    assert nodes.shape == (1024, 2)  # rounded up to a power of two
    np.testing.assert_allclose(weights, 1.0 / 1024)
    assert np.isclose(weights.sum(), 1.0, rtol=1e-14)
    assert np.isfinite(nodes).all()
    mean = weights @ nodes
    centred = nodes - mean
    cov = (weights[:, None] * centred).T @ centred
    sd = np.sqrt(np.diag(prior.cov()))
    np.testing.assert_allclose(mean, prior.mean(), rtol=1e-2)
    # relative to the scales, so that a zero covariance is tested too
    np.testing.assert_allclose(
        cov / np.outer(sd, sd), prior.cov() / np.outer(sd, sd), atol=1e-2
    )


def test_integration_nodes_random_state():
    prior = gaussian()
    a = prior.integration_nodes(64, random_state=3)
    b = prior.integration_nodes(64, random_state=3)
    c = prior.integration_nodes(64, random_state=4)
    np.testing.assert_array_equal(a[0], b[0])
    assert not np.allclose(a[0], c[0])
    nodes, _ = prior.integration_nodes(5, random_state=np.random.default_rng(0))
    assert nodes.shape == (8, 2)
    nodes, _ = prior.integration_nodes(1, random_state=np.random.RandomState(0))
    assert nodes.shape == (1, 2)
    # the one-parameter rule is deterministic whatever the seed
    one = check_prior(stats.norm())
    np.testing.assert_array_equal(
        one.integration_nodes(7, random_state=1)[0],
        one.integration_nodes(7, random_state=2)[0],
    )


def test_integration_nodes_generic_is_monte_carlo():
    prior = check_prior(ExponentialPair())
    nodes, weights = prior.integration_nodes(4000, random_state=0)
    assert nodes.shape == (4000, 2)  # no rounding
    np.testing.assert_allclose(weights, 1 / 4000)
    np.testing.assert_array_equal(nodes, prior.rvs(4000, random_state=0))
    # Monte Carlo error of the mean: 4 standard errors
    error = np.abs(weights @ nodes - [1.0, 0.5])
    assert np.all(error < 4 * np.array([1.0, 0.5]) / np.sqrt(4000))


@pytest.mark.parametrize("n", [0, -3, 2.5, True, "4"])
def test_integration_nodes_rejects_bad_n(n):
    with pytest.raises(ValueError, match="n must be"):
        gaussian().integration_nodes(n)


# ---------------------------------------------------------------- transform


def test_transform_independent_and_gaussian():
    u = np.array([[0.1, 0.5], [0.9, 0.25]])
    expected = np.column_stack(
        [stats.uniform(20e3, 80e3).ppf(u[:, 0]), stats.norm(50e3, 1e4).ppf(u[:, 1])]
    )
    np.testing.assert_allclose(independent().transform(u), expected)
    L = np.linalg.cholesky(COV)
    expected = np.array([1.0, -2.0]) + stats.norm.ppf(u) @ L.T
    np.testing.assert_allclose(gaussian().transform(u), expected)
    assert gaussian().transform([0.5, 0.5]).shape == (1, 2)


def test_transform_clips_the_ends_and_rejects_outside():
    theta = check_prior(stats.norm()).transform([0.0, 1.0])
    assert np.isfinite(theta).all()
    np.testing.assert_allclose(theta[:, 0], stats.norm.ppf([1e-12, 1 - 1e-12]))
    with pytest.raises(ValueError, match="unit cube"):
        gaussian().transform([[0.5, 1.2]])


def test_transform_generic():
    with pytest.raises(NotImplementedError, match="ppf"):
        check_prior(ExponentialPair()).transform([[0.5, 0.5]])
    theta = check_prior(ExponentialPairWithPpf()).transform([[0.5, 0.5]])
    np.testing.assert_allclose(theta, [[np.log(2.0), np.log(2.0) / 2]])


# ---------------------------------------------------------------- rvs, moments


@pytest.mark.parametrize("make", [independent, gaussian, lambda: ExponentialPair()])
def test_rvs_shapes_and_determinism(make):
    prior = check_prior(make())
    assert prior.rvs(7, random_state=0).shape == (7, 2)
    assert prior.rvs(1).shape == (1, 2)
    np.testing.assert_array_equal(prior.rvs(5, 1), prior.rvs(5, 1))
    assert not np.allclose(prior.rvs(5, 1), prior.rvs(5, 2))
    a = prior.rvs(5, np.random.default_rng(3))
    np.testing.assert_array_equal(a, prior.rvs(5, np.random.default_rng(3)))
    b = prior.rvs(5, np.random.RandomState(3))
    np.testing.assert_array_equal(b, prior.rvs(5, np.random.RandomState(3)))


def test_rvs_one_parameter_shape():
    assert check_prior(stats.norm()).rvs(4, 0).shape == (4, 1)
    assert check_prior(ScalarUserPrior()).rvs(4, 0).shape == (4, 1)


@pytest.mark.parametrize("random_state", ["a", 1.5, True])
def test_rvs_rejects_bad_random_state(random_state):
    with pytest.raises(ValueError):
        gaussian().rvs(3, random_state=random_state)


@pytest.mark.parametrize("make", [independent, gaussian])
def test_rvs_moments_match_mean_and_cov(make):
    """20000 draws, seed 0: the sample mean within 4 standard errors, the
    sample covariance (scaled by the standard deviations) within 0.05, i.e.
    about 5 standard errors of a variance estimate (sqrt(2 / n) = 0.01)."""
    prior = make()
    n = 20000
    theta = prior.rvs(n, random_state=0)
    sd = np.sqrt(np.diag(prior.cov()))
    assert np.all(np.abs(theta.mean(axis=0) - prior.mean()) < 4 * sd / np.sqrt(n))
    scaled = np.cov(theta, rowvar=False) / np.outer(sd, sd)
    np.testing.assert_allclose(scaled, prior.cov() / np.outer(sd, sd), atol=0.05)


def test_mean_and_cov_closed_forms():
    prior = independent()
    np.testing.assert_allclose(prior.mean(), [60e3, 50e3])
    np.testing.assert_allclose(prior.cov(), np.diag([80e3**2 / 12, 1e8]))
    prior = gaussian()
    np.testing.assert_array_equal(prior.mean(), [1.0, -2.0])
    np.testing.assert_array_equal(prior.cov(), COV)
    assert check_prior(stats.norm(1.0, 3.0)).cov().shape == (1, 1)


# ---------------------------------------------------------------- bounds


def test_bounds():
    np.testing.assert_array_equal(
        check_prior(stats.uniform(20e3, 80e3)).bounds(), [[20e3, 100e3]]
    )
    np.testing.assert_array_equal(
        check_prior(stats.uniform(20e3, 80e3)).bounds(0.5), [[20e3, 100e3]]
    )
    bounds = independent().bounds()
    assert bounds.shape == (2, 2)
    np.testing.assert_allclose(
        bounds[1], stats.norm(50e3, 1e4).ppf([0.0005, 0.9995]), rtol=1e-14
    )
    np.testing.assert_allclose(
        check_prior(stats.norm()).bounds()[0],
        [stats.norm.ppf(0.0005), stats.norm.ppf(0.9995)],
        rtol=1e-14,
    )
    # a half-bounded support uses the central interval at both ends
    np.testing.assert_allclose(
        check_prior(stats.expon()).bounds(0.9)[0], stats.expon.ppf([0.05, 0.95])
    )
    # Gaussian: marginal quantiles
    expected = np.array([1.0, -2.0])[:, None] + np.sqrt(np.diag(COV))[
        :, None
    ] * stats.norm.ppf([0.025, 0.975])
    np.testing.assert_allclose(gaussian().bounds(0.95), expected, rtol=1e-12)


@pytest.mark.parametrize("coverage", [0.0, 1.0, -0.5, 1.5, "0.9"])
def test_bounds_rejects_bad_coverage(coverage):
    with pytest.raises(ValueError, match="coverage"):
        gaussian().bounds(coverage)


# ---------------------------------------------------------------- generic


def test_generic_prior_end_to_end():
    prior = check_prior(ExponentialPair(), n_parameters=2)
    assert prior.dim == 2
    logp = prior.logpdf([[1.0, 0.5], [0.0, 0.0]])
    np.testing.assert_allclose(logp, [np.log(2.0) - 2.0, np.log(2.0)])
    # Moments and bounds from 20000 draws with a fixed seed: deterministic,
    # and within about 5 standard errors of the exact values. Relative
    # standard errors: mean 0.7 %, variance sqrt(8 / n) = 2 % (an
    # exponential has kurtosis 9), correlation 0.7 %, 5 % and 95 %
    # quantiles 3.2 % and 1 % (this seed is 2.2 of them off for the 5 %).
    np.testing.assert_array_equal(prior.mean(), prior.mean())
    np.testing.assert_array_equal(prior.bounds(), prior.bounds())
    np.testing.assert_allclose(prior.mean(), [1.0, 0.5], rtol=0.04)
    sd = np.array([1.0, 0.5])
    np.testing.assert_allclose(prior.cov() / np.outer(sd, sd), np.eye(2), atol=0.1)
    exact = -np.log1p(-np.array([0.05, 0.95]))[None, :] / np.array([[1.0], [2.0]])
    np.testing.assert_allclose(prior.bounds(0.9), exact, rtol=0.15)
    assert np.all(prior.bounds() > 0)
    nodes, _ = prior.integration_nodes(100, random_state=1)
    assert nodes.shape == (100, 2)
    assert np.isfinite(prior.logpdf(nodes)).all()


def test_generic_prior_checks_its_draws():
    class WrongShape(ExponentialPair):
        def rvs(self, size, random_state):
            return np.zeros((size, 3))

    class NanDensity(ExponentialPair):
        def logpdf(self, theta):
            return np.full(len(theta), np.nan)

    with pytest.raises(ValueError, match="prior"):
        check_prior(WrongShape(), n_parameters=2)
    with pytest.raises(ValueError, match="prior"):
        check_prior(NanDensity())

    class Dim3(ExponentialPair):
        dim = 3

    with pytest.raises(ValueError, match="prior"):
        check_prior(Dim3(), n_parameters=2)


# ---------------------------------------------------------------- bad input


class OnlyRvs:
    def rvs(self, size, random_state):
        return np.zeros((size, 1))


BAD_PRIORS = [
    (None, TypeError, "None"),
    ([], ValueError, "empty"),
    ((), ValueError, "empty"),
    (stats.norm, TypeError, "freeze"),
    ([stats.norm, stats.norm(0, 1)], TypeError, "freeze"),
    (stats.multivariate_normal, TypeError, "freeze"),
    (stats.poisson(3.0), TypeError, "discrete"),
    ([stats.norm(), stats.binom(10, 0.5)], TypeError, "discrete"),
    (stats.poisson, TypeError, "freeze"),
    (type(stats.norm), TypeError, "class"),
    ([stats.norm(), 3.0], TypeError, "logpdf"),
    ([stats.norm(), None], TypeError, "None"),
    (5.0, TypeError, "logpdf"),
    ("uniform", TypeError, "logpdf"),
    (OnlyRvs(), TypeError, "logpdf"),
    (stats.Normal(mu=0.0, sigma=1.0), TypeError, "norm"),
    (stats.uniform(5.0, 0.0), ValueError, "zero width"),
    (stats.norm(0.0, 0.0), ValueError, "zero width"),
    ([stats.norm(), stats.uniform(1.0, -1.0)], ValueError, "zero width"),
    (stats.lognorm(-1.0), ValueError, "invalid"),
    (stats.norm(np.inf, 1.0), ValueError, "non-finite"),
    ([stats.uniform(0.0, np.nan)], ValueError, "non-finite"),
    (stats.norm([0.0, 1.0], 1.0), ValueError, "one distribution per"),
    (stats.multivariate_normal([np.nan, 0.0]), ValueError, "non-finite"),
    (
        stats.multivariate_normal(
            [0.0, 0.0], [[1.0, 1.0], [1.0, 1.0]], allow_singular=True
        ),
        ValueError,
        "singular",
    ),
]


@pytest.mark.parametrize(("prior", "error", "words"), BAD_PRIORS)
def test_check_prior_rejects(prior, error, words):
    with pytest.raises(error, match="prior") as info:
        check_prior(prior)
    assert words in str(info.value)


@pytest.mark.parametrize(
    "prior",
    [
        stats.multivariate_normal([0.0, 0.0]),
        [stats.norm(), stats.norm()],
        stats.norm(),
        ExponentialPair(),
        IndependentPrior([stats.norm()]),
    ],
)
def test_check_prior_rejects_wrong_dimension(prior):
    with pytest.raises(ValueError, match=r"prior.*3 calibration parameters"):
        check_prior(prior, n_parameters=3)


@pytest.mark.parametrize("n_parameters", [0, -1, 1.5, True])
def test_check_prior_rejects_bad_n_parameters(n_parameters):
    with pytest.raises(ValueError, match="n_parameters"):
        check_prior(stats.norm(), n_parameters=n_parameters)


# ------------------------------------------------------------- mass_inside


def test_mass_inside_independent_is_exact():
    prior = independent()  # uniform(20e3, 100e3) x norm(50e3, 1e4)
    mass = prior.mass_inside([40e3, 50e3], [120e3, 70e3])
    expected = 0.75 * (stats.norm.cdf(2.0) - 0.5)
    assert mass == pytest.approx(expected, rel=1e-12)
    assert prior.mass_inside([-np.inf, -np.inf], [np.inf, np.inf]) == 1.0
    assert prior.mass_inside([200e3, 0.0], [300e3, 1e6]) == 0.0
    assert prior.mass_inside([60e3, 0.0], [50e3, 1e6]) == 0.0  # empty box


def test_mass_inside_gaussian():
    one = check_prior(stats.multivariate_normal([1.0], [[4.0]]))
    exact = stats.norm.cdf(1.0) - stats.norm.cdf(-1.0)
    assert one.mass_inside([-1.0], [3.0]) == pytest.approx(exact, rel=1e-12)
    # Two correlated parameters: 20000 draws with a fixed seed, within five
    # standard errors (0.0035 here) of scipy's box probability.
    prior = gaussian()
    lower, upper = np.array([0.0, -4.0]), np.array([3.0, 1.0])
    mvn = stats.multivariate_normal([1.0, -2.0], COV)
    exact = (
        mvn.cdf(upper)
        - mvn.cdf([lower[0], upper[1]])
        - mvn.cdf([upper[0], lower[1]])
        + mvn.cdf(lower)
    )
    mass = prior.mass_inside(lower, upper)
    assert mass == prior.mass_inside(lower, upper)  # reproducible
    assert mass == pytest.approx(exact, abs=0.02)


def test_mass_inside_generic_uses_fixed_draws():
    prior = check_prior(ExponentialPair(), n_parameters=2)
    exact = (1 - np.exp(-1.0)) * (1 - np.exp(-2.0 * 0.5))
    mass = prior.mass_inside([0.0, 0.0], [1.0, 0.5])
    assert mass == prior.mass_inside([0.0, 0.0], [1.0, 0.5])
    assert mass == pytest.approx(exact, abs=0.02)


@pytest.mark.parametrize(
    ("lower", "upper", "match"),
    [
        ([0.0], [1.0, 1.0], "must have 2 values"),
        ([0.0, np.nan], [1.0, 1.0], "NaN"),
    ],
)
def test_mass_inside_rejects_bad_boxes(lower, upper, match):
    with pytest.raises(ValueError, match=match):
        independent().mass_inside(lower, upper)


# --- named parameters: a dict prior ------------------------------------------


def test_dict_prior_names_the_parameters_in_order():
    prior = check_prior({"E": stats.uniform(20e3, 80e3), "I": stats.norm(2.0, 0.1)})
    assert isinstance(prior, IndependentPrior)
    assert prior.names == ("E", "I")
    assert prior.dim == 2
    listed = check_prior([stats.uniform(20e3, 80e3), stats.norm(2.0, 0.1)])
    np.testing.assert_array_equal(prior.bounds(), listed.bounds())
    np.testing.assert_array_equal(
        prior.rvs(5, random_state=0), listed.rvs(5, random_state=0)
    )
    assert "names=['E', 'I']" in repr(prior)


def test_unnamed_priors_have_no_names():
    assert independent().names is None
    assert gaussian().names is None
    assert check_prior(stats.norm(0, 1)).names is None
    assert check_prior(stats.multivariate_t([0.0, 0.0], np.eye(2))).names is None


@pytest.mark.parametrize(
    "prior, error, match",
    [
        ({}, ValueError, "empty dict"),
        ({1: stats.norm(0, 1)}, TypeError, "non-empty strings"),
        ({"": stats.norm(0, 1)}, TypeError, "non-empty strings"),
        ({"E": stats.norm}, TypeError, r"prior\['E'\] is the unfrozen"),
    ],
)
def test_dict_prior_errors(prior, error, match):
    with pytest.raises(error, match=match):
        check_prior(prior)


def test_dict_prior_checks_the_number_of_parameters():
    with pytest.raises(ValueError, match="2 calibration parameters"):
        check_prior({"E": stats.norm(0, 1)}, n_parameters=2)


def test_independent_prior_rejects_duplicate_or_miscounted_names():
    with pytest.raises(ValueError, match="twice"):
        IndependentPrior([stats.norm(0, 1), stats.norm(0, 1)], names=["E", "E"])
    with pytest.raises(ValueError, match="1 name"):
        IndependentPrior([stats.norm(0, 1), stats.norm(0, 1)], names=["E"])
