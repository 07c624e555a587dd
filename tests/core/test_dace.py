"""The machinery shared by the DACE families (skmba._core.dace).

The families' values and gradients are checked in ``tests/test_kernels.py``;
here, the pieces of the base class on their own.
"""

import numpy as np
import pytest
from sklearn.gaussian_process.kernels import Kernel

from skmba._core.dace import DACECorrelation, ExponentialProfile, leave_one_out_products
from skmba.kernels import Cubic, Exp, Gauss, GeneralizedExp, Linear, Spherical, Spline


def test_leave_one_out_products_equal_the_direct_products_with_zeros():
    rng = np.random.default_rng(0)
    R = rng.uniform(size=(4, 5, 3))
    R[0, 1, 2] = 0.0
    R[2, 3, :2] = 0.0  # two zero factors: every product is zero
    got = leave_one_out_products(R)
    want = np.stack(
        [np.prod(np.delete(R, j, axis=-1), axis=-1) for j in range(R.shape[-1])],
        axis=-1,
    )
    np.testing.assert_allclose(got, want, rtol=1e-15, atol=0)
    # One dimension: the empty product.
    np.testing.assert_array_equal(leave_one_out_products(R[..., :1]), 1.0)


@pytest.mark.parametrize(
    "family", [Exp, GeneralizedExp, Gauss, Linear, Spherical, Cubic, Spline]
)
def test_every_family_is_a_dace_correlation(family):
    kernel = family()
    assert isinstance(kernel, DACECorrelation)
    assert isinstance(kernel, ExponentialProfile) == (
        family in (Exp, GeneralizedExp, Gauss)
    )


@pytest.mark.parametrize(
    "kernel",
    [
        Gauss(),
        Gauss(roughness=[0.5, 2.0, 1.0]),
        Exp(roughness=[0.5, 2.0, 1.0], roughness_bounds="fixed"),
        GeneralizedExp(roughness=[0.5, 2.0, 1.0], power=1.5),
        GeneralizedExp(roughness=2.0, power=1.5, power_bounds="fixed"),
        Spline(roughness=[0.3, 0.4, 0.2]),
        Gauss(roughness=[2.0]),  # one element: scikit-learn makes it a scalar
        Gauss(roughness=[0.5, 2.0, 1.0], roughness_bounds="fixed"),  # a list
    ],
)
def test_clone_with_theta_is_scikit_learns_clone_to_the_bit(kernel):
    """The shortcut (a shallow copy with copied arrays) gives what
    ``sklearn.base.clone`` followed by ``theta = ...`` gives: the same
    parameters, hyperparameters and values, and a copy that shares no
    array with the original."""
    X = np.random.default_rng(1).uniform(size=(7, 3))
    theta = kernel.theta - 0.25  # within every family's bounds
    ours = kernel.clone_with_theta(theta)
    theirs = Kernel.clone_with_theta(kernel, theta)
    assert type(ours) is type(theirs)
    assert repr(ours) == repr(theirs)
    mine, ref = ours.get_params(), theirs.get_params()
    assert sorted(mine) == sorted(ref)
    for name, value in ref.items():
        assert type(mine[name]) is type(value), name
        np.testing.assert_array_equal(mine[name], value, err_msg=name)
    np.testing.assert_array_equal(ours.theta, theirs.theta)
    np.testing.assert_array_equal(ours.bounds, theirs.bounds)
    assert ours.hyperparameters == theirs.hyperparameters
    K, dK = ours(X, eval_gradient=True)
    K_ref, dK_ref = theirs(X, eval_gradient=True)
    np.testing.assert_array_equal(K, K_ref)
    np.testing.assert_array_equal(dK, dK_ref)
    for name, value in vars(ours).items():
        if isinstance(value, np.ndarray):
            assert not np.shares_memory(value, getattr(kernel, name)), name
        elif isinstance(value, list):
            assert value is not getattr(kernel, name), name
    with pytest.raises(ValueError, match="theta has"):
        kernel.clone_with_theta(np.zeros(len(theta) + 1))


def test_hyperparameters_are_scikit_learns_in_its_order():
    kernel = GeneralizedExp(roughness=[1.0, 2.0])
    assert kernel.hyperparameters == Kernel.hyperparameters.fget(kernel)
    assert [h.name for h in kernel.hyperparameters] == ["power", "roughness"]
