"""Tests of the likelihood evaluators' gradients in :mod:`skmba.gp._likelihood`."""

import numpy as np
import pytest

from skmba._core.regression import regression_basis
from skmba.gp._likelihood import (
    GradientContraction,
    NoiseFreeLikelihood,
    NoisyLikelihood,
)
from skmba.gp._search import correlation
from skmba.kernels import (
    Cubic,
    Exp,
    Gauss,
    GeneralizedExp,
    Linear,
    Spherical,
    Spline,
)

FAMILIES = [Exp, GeneralizedExp, Gauss, Linear, Spherical, Cubic, Spline]


def make_kernel(cls, roughness):
    if cls is GeneralizedExp:
        return cls(roughness=roughness, power=1.5)
    return cls(roughness=roughness)


def problem(n=40, d=3, q=3, seed=5):
    rng = np.random.default_rng(seed)
    X = rng.uniform(size=(n, d))
    Y = np.column_stack(
        [np.sin(3 * X[:, 0]) + X[:, 1], np.cos(2 * X[:, 1]) * X[:, 2], X[:, 0] ** 2]
    )[:, :q] + 0.05 * rng.normal(size=(n, q))
    return X, regression_basis(X, "linear"), Y


@pytest.mark.parametrize("cls", FAMILIES, ids=lambda c: c.__name__)
@pytest.mark.parametrize(
    "roughness", [2.0, [1.5, 3.0, 2.5]], ids=["isotropic", "anisotropic"]
)
@pytest.mark.parametrize("model", ["noise-free", "ridge", "log-nugget", "noisy"])
def test_per_dimension_gradient_equals_the_stacked_gradient(cls, roughness, model):
    # The gradient contracted one hyperparameter at a time (no N x N x
    # n_theta array) is the one of sklearn's stacked dR.
    X, H, Y = problem()
    kernel = make_kernel(cls, roughness)
    nugget = 0.05  # keeps the (not positive definite) Cubic factorable
    R, contraction = correlation(kernel, X, nugget, eval_gradient=True)
    assert isinstance(contraction, GradientContraction)
    K, stacked = kernel(X, eval_gradient=True)
    np.testing.assert_array_equal(R, K + nugget * np.eye(len(X)))
    if model == "log-nugget":
        R = R + 0.3 * np.eye(len(X))
        contraction = contraction.with_diagonal(0.3)
        diagonal = 0.3 * np.eye(len(X))[:, :, None]
        stacked = np.concatenate([stacked, diagonal], axis=2)
    if model == "noisy":
        sigma2 = np.array([[1.0, 0.3, 0.1], [0.3, 0.8, -0.2], [0.1, -0.2, 0.5]])
        lam = np.array([0.05, 0.1, 0.02])
        got = NoisyLikelihood(R, H, Y, sigma2, lam, contraction).grad_kernel
        want = NoisyLikelihood(R, H, Y, sigma2, lam, stacked).grad_kernel
    else:
        ridge = 0.01 if model == "ridge" else 0.0
        got = NoiseFreeLikelihood(R, H, Y, contraction, ridge=ridge).gradient
        want = NoiseFreeLikelihood(R, H, Y, stacked, ridge=ridge).gradient
    assert got.shape == want.shape == (kernel.n_dims + (model == "log-nugget"),)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_gradient_contraction_of_a_stacked_array_is_the_weighted_trace():
    rng = np.random.default_rng(6)
    dR = rng.normal(size=(5, 5, 2))
    dR += dR.transpose(1, 0, 2)
    weight = rng.normal(size=(5, 5))
    contraction = GradientContraction(
        lambda w: np.einsum("ij,ijk->k", w, dR), n_dims=2
    ).with_diagonal(2.0)
    assert contraction.n_dims == 3
    want = [np.sum(weight * dR[:, :, 0]), np.sum(weight * dR[:, :, 1])]
    np.testing.assert_allclose(
        contraction(weight), [*want, 2.0 * np.trace(weight)], rtol=1e-13
    )
