"""Tests for the DACE correlation kernels in :mod:`skmba.kernels`."""

import math
import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import (
    RBF,
    ConstantKernel,
    ExpSineSquared,
    Hyperparameter,
    Matern,
    RationalQuadratic,
    WhiteKernel,
)

from skmba.kernels import (
    Cubic,
    Exp,
    Gauss,
    GeneralizedExp,
    Linear,
    Spherical,
    Spline,
    check_correlation,
)

FAMILIES = [Exp, GeneralizedExp, Gauss, Linear, Spherical, Cubic, Spline]
COMPACT = [Linear, Spherical, Cubic, Spline]
# Product form: each 1-D profile below is positive definite on the real line,
# so the tensor product is positive definite in any dimension (Schur product
# theorem).  Linear and Spline are only guaranteed PD in 1-D when used as
# radial functions of the Euclidean distance (Spherical up to 3-D); Cubic is
# not PD even in 1-D (see test_cubic_is_not_positive_definite).
POSITIVE_DEFINITE = [Exp, GeneralizedExp, Gauss, Linear, Spherical, Spline]
POWER = 1.5  # power used for GeneralizedExp wherever a family is generic


def make_kernel(cls, roughness=1.0, **kwargs):
    if cls is GeneralizedExp:
        kwargs.setdefault("power", POWER)
    return cls(roughness=roughness, **kwargs)


def ids(cls):
    return cls.__name__


# --- independent scalar reference of thesis Table 3.2 / Eq. (3.6) -----------
def reference_1d(name, w, delta, p=POWER):
    a = abs(delta)
    if name == "Exp":
        return math.exp(-w * a)
    if name == "GeneralizedExp":
        return math.exp(-w * a**p)
    if name == "Gauss":
        return math.exp(-w * delta * delta)
    if name == "Linear":
        return max(0.0, 1.0 - w * a)
    if name == "Spherical":
        z = min(1.0, w * a)
        return 1.0 - 1.5 * z + 0.5 * z**3
    if name == "Cubic":
        z = min(1.0, w * a)
        return 1.0 - 3.0 * z**2 + 2.0 * z**3
    if name == "Spline":
        z = w * a
        if z <= 0.2:
            return 1.0 - 15.0 * z**2 + 30.0 * z**3
        if z < 1.0:
            return 1.25 * (1.0 - z) ** 3
        return 0.0
    raise AssertionError(name)


def reference_kernel(name, X, Y, roughness, p=POWER):
    d = X.shape[1]
    w = np.broadcast_to(np.asarray(roughness, dtype=float), (d,))
    K = np.empty((X.shape[0], Y.shape[0]))
    for i in range(X.shape[0]):
        for k in range(Y.shape[0]):
            r = 1.0
            for j in range(d):
                r *= reference_1d(name, w[j], X[i, j] - Y[k, j], p)
            K[i, k] = r
    return K


def fd_gradient(kernel, X, h=1e-6):
    """Central finite differences of K(X) in log-hyperparameter space."""
    theta = kernel.theta
    grad = np.empty((X.shape[0], X.shape[0], theta.size))
    for i in range(theta.size):
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        Kp = kernel.clone_with_theta(tp)(X)
        Km = kernel.clone_with_theta(tm)(X)
        grad[:, :, i] = (Kp - Km) / (2 * h)
    return grad


def assert_gradient_matches_fd(kernel, X):
    K, grad = kernel(X, eval_gradient=True)
    np.testing.assert_allclose(K, kernel(X), rtol=1e-14, atol=0)
    assert grad.shape == (X.shape[0], X.shape[0], kernel.n_dims)
    np.testing.assert_allclose(grad, fd_gradient(kernel, X), rtol=1e-5, atol=1e-8)
    return grad


def kink_free_points(cls, roughness, n, d, rng):
    """Random points whose scaled distances stay away from 1 and 0.2."""
    w = np.broadcast_to(np.asarray(roughness, dtype=float), (d,))
    while True:
        X = rng.uniform(0.0, 1.5, size=(n, d))
        zeta = np.abs(X[:, None, :] - X[None, :, :]) * w
        off = ~np.eye(n, dtype=bool)
        z = zeta[off]
        if np.all(np.abs(z - 1.0) > 1e-3) and np.all(np.abs(z - 0.2) > 1e-3):
            return X


# --- values -----------------------------------------------------------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
@pytest.mark.parametrize(
    "d, roughness",
    [(1, 1.3), (1, [2.2]), (3, 0.9), (3, [0.6, 1.7, 3.1])],
    ids=["1d-iso", "1d-len1", "3d-iso", "3d-aniso"],
)
def test_values_match_table(cls, d, roughness):
    rng = np.random.default_rng(0)
    X = rng.uniform(0.0, 2.0, size=(7, d))
    Y = rng.uniform(0.0, 2.0, size=(5, d))
    kernel = make_kernel(cls, roughness)
    expected = reference_kernel(cls.__name__, X, Y, roughness)
    np.testing.assert_allclose(kernel(X, Y), expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(
        kernel(X), reference_kernel(cls.__name__, X, X, roughness), atol=1e-15
    )
    if cls in COMPACT:
        # The sample must exercise the region beyond the support (ζ > 1).
        w = np.broadcast_to(np.asarray(roughness, dtype=float), (d,))
        zeta = np.abs(X[:, None, :] - Y[None, :, :]) * w
        assert np.any(zeta > 1.0) and np.any(zeta < 1.0)
        assert np.any(expected == 0.0)


@pytest.mark.parametrize("cls", COMPACT, ids=ids)
def test_compact_support(cls):
    w = 2.0
    X = np.array([[0.0], [0.5], [0.75], [5.0]])  # ζ = 0, 1, 1.5, 10 from 0
    K = cls(roughness=w)(X[:1], X)
    np.testing.assert_array_equal(K[0, 1:], 0.0)
    assert K[0, 0] == 1.0
    # Just inside the support the correlation is positive and small.
    inside = cls(roughness=w)(np.array([[0.0]]), np.array([[0.49]]))[0, 0]
    assert 0.0 < inside < 0.05


def test_spline_breakpoint_continuity():
    eps = 1e-7
    kernel = Spline(roughness=1.0)
    zero = np.array([[0.0]])

    def value(z):
        return kernel(zero, np.array([[z]]))[0, 0]

    # Value at the breakpoint from both branches: 1 - 0.6 + 0.24 = 1.25 * 0.8³.
    assert value(0.2) == pytest.approx(0.64, rel=1e-14)
    assert value(0.2 + 1e-12) == pytest.approx(0.64, rel=1e-10)
    # One-sided slopes agree: -30ζ + 90ζ² = -3.75 (1 - ζ)² = -2.4 at ζ = 0.2.
    left = (value(0.2) - value(0.2 - eps)) / eps
    right = (value(0.2 + eps) - value(0.2)) / eps
    assert left == pytest.approx(-2.4, rel=1e-5)
    assert right == pytest.approx(-2.4, rel=1e-5)
    # ... and so does the analytic log-roughness derivative ζ ς'(ζ).
    X = np.array([[0.0], [0.2 - 1e-9], [0.2 + 1e-9]])
    _, grad = kernel(X, eval_gradient=True)
    np.testing.assert_allclose(grad[0, 1:, 0], 0.2 * -2.4, rtol=1e-6)


def test_linear_kink_uses_outside_derivative():
    # Pairs exactly at the edge of the support (ζ = 1) get zero gradient,
    # the one-sided derivative from outside the support.
    X = np.array([[0.0], [0.5], [1.0]])
    K, grad = Linear(roughness=1.0)(X, eval_gradient=True)
    assert K[0, 2] == 0.0
    assert grad[0, 2, 0] == 0.0
    assert grad[0, 1, 0] == pytest.approx(-0.5)  # ω ∂(1 - ω|Δ|)/∂ω = -ζ
    # Exp: ∂K/∂log ω vanishes at Δ = 0 (the diagonal).
    _, grad = Exp(roughness=3.0)(X, eval_gradient=True)
    np.testing.assert_array_equal(np.diag(grad[:, :, 0]), 0.0)


# --- correlation properties -------------------------------------------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
@pytest.mark.parametrize("roughness", [0.8, [0.5, 1.0, 4.0]], ids=["iso", "aniso"])
def test_unit_diagonal_and_symmetry(cls, roughness):
    rng = np.random.default_rng(1)
    X = rng.normal(size=(12, 3))
    kernel = make_kernel(cls, roughness)
    K = kernel(X)
    np.testing.assert_array_equal(np.diag(K), 1.0)
    np.testing.assert_array_equal(kernel.diag(X), 1.0)
    np.testing.assert_array_equal(K, K.T)
    assert np.all(K >= 0.0) and np.all(K <= 1.0)
    assert kernel.is_stationary()
    # Cross-correlation is the transpose of the swapped call.
    Y = rng.normal(size=(4, 3))
    assert kernel(X, Y).shape == (12, 4)
    np.testing.assert_allclose(kernel(X, Y), kernel(Y, X).T, atol=1e-15)


@pytest.mark.parametrize("cls", POSITIVE_DEFINITE, ids=ids)
@pytest.mark.parametrize("d", [1, 3])
def test_positive_semidefinite(cls, d):
    rng = np.random.default_rng(2)
    for _ in range(5):
        X = rng.uniform(0.0, 3.0, size=(40, d))
        roughness = rng.uniform(0.3, 3.0, size=d) if d > 1 else rng.uniform(0.3, 3)
        K = make_kernel(cls, roughness)(X)
        assert np.linalg.eigvalsh(K).min() >= -1e-10


def test_cubic_is_not_positive_definite():
    # The DACE cubic profile has a sign-changing Fourier transform; a dense
    # 1-D grid already yields a clearly negative eigenvalue.
    X = np.linspace(0.0, 3.0, 31)[:, None]
    assert np.linalg.eigvalsh(Cubic(roughness=1.0)(X)).min() < -0.05


# --- gradients --------------------------------------------------------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
@pytest.mark.parametrize(
    "d, roughness",
    [(1, 1.3), (3, 0.9), (3, [0.6, 1.7, 3.1])],
    ids=["1d-iso", "3d-iso", "3d-aniso"],
)
def test_gradient_matches_finite_differences(cls, d, roughness):
    rng = np.random.default_rng(3)
    kernel = make_kernel(cls, roughness)
    X = kink_free_points(cls, roughness, 9, d, rng)
    grad = assert_gradient_matches_fd(kernel, X)
    n_roughness = d if np.ndim(roughness) else 1
    n_power = 1 if cls is GeneralizedExp else 0
    assert grad.shape[2] == n_roughness + n_power
    # Gradients are symmetric and vanish on the diagonal (K_ii = 1 always).
    np.testing.assert_allclose(grad, grad.transpose(1, 0, 2), atol=1e-15)
    np.testing.assert_array_equal(grad[np.arange(9), np.arange(9)], 0.0)
    if cls is not GeneralizedExp:
        assert np.all(grad <= 0.0)  # rougher ⇒ less correlated


@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
@pytest.mark.parametrize("roughness", [1.0, [1.0, 2.0]], ids=["iso", "aniso"])
def test_fixed_roughness_gives_no_slice(cls, roughness):
    X = np.random.default_rng(4).uniform(size=(6, 2))
    kwargs = {"power_bounds": "fixed"} if cls is GeneralizedExp else {}
    kernel = make_kernel(cls, roughness, roughness_bounds="fixed", **kwargs)
    K, grad = kernel(X, eval_gradient=True)
    assert grad.shape == (6, 6, 0)
    assert kernel.n_dims == 0 and kernel.theta.shape == (0,)
    np.testing.assert_array_equal(K, kernel(X))


@pytest.mark.parametrize("roughness", [0.7, [0.5, 2.0]], ids=["iso", "aniso"])
def test_generalized_exp_power_gradient(roughness):
    rng = np.random.default_rng(5)
    X = rng.uniform(0.0, 2.0, size=(8, 2))
    X[3] = X[1] + [0.0, 0.5]  # a zero difference in one dimension: 0·log 0
    for power in [0.5, 1.0, 1.5, 1.9]:
        kernel = GeneralizedExp(roughness=roughness, power=power)
        names = [hp.name for hp in kernel.hyperparameters]
        assert names == ["power", "roughness"]  # theta order: power first
        grad = assert_gradient_matches_fd(kernel, X)
        assert np.all(np.isfinite(grad))
        # power alone (roughness fixed) gives exactly the first slice
        only_power = GeneralizedExp(
            roughness=roughness, roughness_bounds="fixed", power=power
        )
        _, grad_p = only_power(X, eval_gradient=True)
        np.testing.assert_allclose(grad_p, grad[:, :, :1], rtol=1e-14)
        # roughness alone (power fixed) gives the remaining slices
        only_w = GeneralizedExp(roughness=roughness, power=power, power_bounds="fixed")
        _, grad_w = only_w(X, eval_gradient=True)
        np.testing.assert_allclose(grad_w, grad[:, :, 1:], rtol=1e-14)


@pytest.mark.parametrize("cls", [Exp, Gauss], ids=ids)
def test_generalized_exp_reduces_to_exp_and_gauss(cls):
    X = np.random.default_rng(6).normal(size=(6, 2))
    power = 1.0 if cls is Exp else 2.0
    np.testing.assert_allclose(
        GeneralizedExp(roughness=[0.4, 1.1], power=power)(X),
        cls(roughness=[0.4, 1.1])(X),
        rtol=1e-13,
    )


# --- relation to sklearn's RBF ----------------------------------------------
@pytest.mark.parametrize("roughness", [0.7, [0.5, 2.0, 0.1]], ids=["iso", "aniso"])
def test_gauss_equals_rbf(roughness):
    X = np.random.default_rng(7).normal(size=(10, 3))
    Y = np.random.default_rng(8).normal(size=(4, 3))
    length_scale = 1.0 / np.sqrt(2.0 * np.asarray(roughness))
    gauss, rbf = Gauss(roughness=roughness), RBF(length_scale=length_scale)
    np.testing.assert_allclose(gauss(X, Y), rbf(X, Y), rtol=1e-12)
    K_g, grad_g = gauss(X, eval_gradient=True)
    K_r, grad_r = rbf(X, eval_gradient=True)
    np.testing.assert_allclose(K_g, K_r, rtol=1e-12)
    # log ω = -log 2 - 2 log l  ⇒  ∂/∂log ω = -½ ∂/∂log l
    np.testing.assert_allclose(grad_g, -0.5 * grad_r, rtol=1e-10, atol=1e-15)


def test_exp_equals_matern_half_in_1d():
    X = np.random.default_rng(9).normal(size=(8, 1))
    np.testing.assert_allclose(
        Exp(roughness=2.5)(X), Matern(length_scale=0.4, nu=0.5)(X), rtol=1e-12
    )


# --- scikit-learn API -------------------------------------------------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
def test_params_clone_and_theta(cls):
    kernel = make_kernel(cls, [2.0, 3.0], roughness_bounds=(1e-3, 1e3))
    params = kernel.get_params()
    expected_keys = {"roughness", "roughness_bounds"}
    if cls is GeneralizedExp:
        expected_keys |= {"power", "power_bounds"}
    assert set(params) == expected_keys
    cloned = clone(kernel)
    assert cloned == kernel and cloned is not kernel
    assert kernel.anisotropic and not make_kernel(cls, [2.0]).anisotropic

    hp = kernel.hyperparameter_roughness
    assert hp == Hyperparameter("roughness", "numeric", (1e-3, 1e3), 2)
    assert make_kernel(cls).hyperparameter_roughness == Hyperparameter(
        "roughness", "numeric", (1e-5, 1e5)
    )
    log_roughness = np.log([2.0, 3.0])
    if cls is GeneralizedExp:
        assert kernel.hyperparameter_power == Hyperparameter(
            "power", "numeric", (1e-2, 2.0)
        )
        np.testing.assert_allclose(kernel.theta, [np.log(POWER), *log_roughness])
        np.testing.assert_allclose(
            kernel.bounds, np.log([[1e-2, 2.0], [1e-3, 1e3], [1e-3, 1e3]])
        )
    else:
        assert [h.name for h in kernel.hyperparameters] == ["roughness"]
        np.testing.assert_allclose(kernel.theta, log_roughness)
        np.testing.assert_allclose(kernel.bounds, np.log([[1e-3, 1e3]] * 2))

    new_theta = kernel.theta + 0.25
    other = kernel.clone_with_theta(new_theta)
    np.testing.assert_allclose(other.theta, new_theta)
    np.testing.assert_allclose(other.roughness, np.exp(0.25) * np.array([2.0, 3.0]))
    np.testing.assert_allclose(kernel.theta[-2:], log_roughness)  # untouched

    kernel.set_params(roughness=5.0)
    assert kernel.roughness == 5.0 and not kernel.anisotropic
    assert kernel.n_dims == (2 if cls is GeneralizedExp else 1)


@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
def test_pickle_round_trip(cls):
    X = np.random.default_rng(10).normal(size=(5, 2))
    kernel = make_kernel(cls, [0.3, 1.2])
    restored = pickle.loads(pickle.dumps(kernel))
    assert restored == kernel
    np.testing.assert_array_equal(restored(X), kernel(X))


def test_repr():
    assert repr(Gauss()) == "Gauss(roughness=1)"
    assert repr(Gauss(roughness=[1, 2])) == "Gauss(roughness=[1, 2])"
    assert repr(Exp(roughness=0.123456)) == "Exp(roughness=0.123)"
    assert repr(Spline(roughness=[2.5])) == "Spline(roughness=2.5)"
    assert (
        repr(GeneralizedExp(roughness=1, power=1.5))
        == "GeneralizedExp(roughness=1, power=1.5)"
    )
    assert repr(Gauss() * RBF()) == "Gauss(roughness=1) * RBF(length_scale=1)"


@pytest.mark.parametrize(
    "kernel",
    [
        Gauss(roughness=0.8) * RBF(length_scale=1.5),
        Gauss(roughness=[1.0, 2.0]) * RBF(),
        Exp(roughness=0.5) * Matern(length_scale=[1.0, 0.7], nu=1.5),
        Gauss() * Exp(roughness=[0.4, 0.9]),
        Spline(roughness=0.3) * GeneralizedExp(power=1.2),
    ],
    ids=repr,
)
def test_products_with_sklearn_kernels(kernel):
    rng = np.random.default_rng(11)
    X = kink_free_points(Spline, 0.3, 8, 2, rng)
    assert kernel(X).shape == (8, 8)
    assert_gradient_matches_fd(kernel, X)
    check_correlation(kernel, X)


def test_grid_search_style_nested_params():
    gpr = GaussianProcessRegressor(kernel=Gauss(roughness=1.0))
    gpr.set_params(kernel__roughness=3.0)
    assert gpr.get_params()["kernel__roughness"] == 3.0
    product = Gauss() * Exp()
    product.set_params(k2__roughness=0.5)
    assert product.k2.roughness == 0.5


def test_gaussian_process_regressor_fit_matches_rbf():
    # Same model, different parametrisation: identical optimal likelihood.
    rng = np.random.default_rng(12)
    X = rng.uniform(0.0, 5.0, size=(20, 1))
    y = np.sin(X[:, 0])
    gauss = GaussianProcessRegressor(Gauss(), alpha=1e-8).fit(X, y)
    rbf = GaussianProcessRegressor(RBF(), alpha=1e-8).fit(X, y)
    lml_g = gauss.log_marginal_likelihood_value_
    assert lml_g == pytest.approx(rbf.log_marginal_likelihood_value_, rel=1e-5)
    length_scale = rbf.kernel_.length_scale
    assert gauss.kernel_.roughness == pytest.approx(0.5 / length_scale**2, rel=1e-3)


# --- errors -----------------------------------------------------------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
def test_errors(cls):
    X = np.zeros((3, 2))
    with pytest.raises(ValueError, match="Y is None"):
        make_kernel(cls)(X, X, eval_gradient=True)
    with pytest.raises(ValueError, match="roughness"):
        make_kernel(cls, [1.0, 2.0, 3.0])(X)
    with pytest.raises(ValueError, match="roughness"):
        make_kernel(cls, -1.0)(X)
    with pytest.raises(ValueError, match="columns"):
        make_kernel(cls)(X, np.zeros((2, 3)))


@pytest.mark.parametrize("power", [0.0, -0.5, 2.5, np.nan, [1.0, 1.5]])
def test_power_out_of_range(power):
    kernel = GeneralizedExp(power=power)  # __init__ only stores
    with pytest.raises(ValueError, match="power"):
        kernel(np.zeros((2, 1)))


def test_power_upper_limit_allowed():
    X = np.array([[0.0], [1.0]])
    K = GeneralizedExp(power=2.0).clone_with_theta(np.log([2.0, 1.0]))(X)
    assert K[0, 1] == pytest.approx(math.exp(-1.0))


# --- check_correlation ------------------------------------------------------
@pytest.mark.parametrize(
    "kernel",
    [make_kernel(cls, [0.5, 2.0]) for cls in FAMILIES]
    + [
        RBF(),
        Matern(nu=2.5),
        RationalQuadratic(),
        ExpSineSquared(),
        Gauss() * Matern(),
        Spline() * RBF([1.0, 3.0]),
    ],
    ids=repr,
)
def test_check_correlation_passes(kernel):
    X = np.random.default_rng(13).normal(size=(6, 2))
    assert check_correlation(kernel, X) is None


@pytest.mark.parametrize(
    "kernel",
    [ConstantKernel(2.0) * RBF(), RBF() + WhiteKernel(), Gauss() + Exp()],
    ids=repr,
)
def test_check_correlation_rejects_non_correlations(kernel):
    X = np.random.default_rng(14).normal(size=(6, 2))
    with pytest.raises(ValueError, match=r"unit diagonal.*sigma2_"):
        check_correlation(kernel, X)


@pytest.mark.parametrize("kernel", ["rbf", RBF, lambda X, Y=None: X @ X.T, None])
def test_check_correlation_type_error(kernel):
    with pytest.raises(TypeError, match="Kernel"):
        check_correlation(kernel, np.zeros((2, 1)))


# --- per-dimension evaluation (large likelihoods, issue 15) -----------------
@pytest.mark.parametrize("cls", FAMILIES, ids=ids)
@pytest.mark.parametrize(
    "roughness", [1.3, [0.6, 1.7, 3.1]], ids=["isotropic", "anisotropic"]
)
def test_per_dimension_evaluation_equals_the_stacked_one(cls, roughness):
    rng = np.random.default_rng(11)
    X = rng.uniform(0.0, 1.5, size=(40, 3))
    X_new = rng.uniform(0.0, 1.5, size=(25, 3))
    kernel = make_kernel(cls, roughness)
    K, grad = kernel(X, eval_gradient=True)
    # The same operations in the same order: bit for bit.
    np.testing.assert_array_equal(kernel(X), K)
    stacked_cross = kernel._from_differences(np.abs(X[:, None, :] - X_new[None]))
    np.testing.assert_array_equal(kernel(X, X_new), stacked_cross)
    weight = rng.normal(size=(40, 40))
    weight += weight.T
    contracted = np.einsum("ij,ijk->k", weight, grad)
    got = kernel._weighted_log_gradient(X, K, weight)
    np.testing.assert_allclose(got, contracted, rtol=1e-12, atol=0)
    # The diagonal of K (where a nugget goes) is not used.
    with_nugget = kernel._weighted_log_gradient(X, K + 0.1 * np.eye(40), weight)
    np.testing.assert_allclose(with_nugget, got, rtol=1e-14, atol=0)


@pytest.mark.parametrize("fixed", ["roughness", "power"])
def test_per_dimension_gradient_skips_fixed_hyperparameters(fixed):
    rng = np.random.default_rng(12)
    X = rng.uniform(size=(20, 2))
    kernel = GeneralizedExp(
        roughness=[1.0, 2.0], power=1.5, **{f"{fixed}_bounds": "fixed"}
    )
    K, grad = kernel(X, eval_gradient=True)
    weight = rng.normal(size=(20, 20))
    got = kernel._weighted_log_gradient(X, K, weight + weight.T)
    want = np.einsum("ij,ijk->k", weight + weight.T, grad)
    assert got.shape == (kernel.n_dims,)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_leave_one_out_product_is_recomputed_where_a_factor_is_zero():
    # K / R_j cannot give prod_{k != j} R_k where R_j is 0; the entries where
    # the derivative does not vanish (a rounding zero near the edge of the
    # support) are recomputed from the other factors.
    rng = np.random.default_rng(13)
    X = rng.uniform(0.0, 0.5, size=(6, 3))
    kernel = Spherical(roughness=[1.0, 1.5, 0.7])
    roughness = np.array(kernel.roughness)
    K = kernel(X)
    zeta = np.abs(X[:, 1, None] - X[None, :, 1]) * roughness[1]
    R_1 = Spherical._profile(zeta)
    R_1[2, 4] = R_1[4, 2] = 0.0  # as if rounded to zero
    dprofile = Spherical._profile_derivative(zeta)
    others = kernel._others(X, 1, roughness, K, R_1, dprofile)
    want = Spherical(roughness=roughness[[0, 2]])(X[:, [0, 2]])
    np.testing.assert_allclose(others, want, rtol=1e-14, atol=0)
