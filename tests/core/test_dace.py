"""The machinery shared by the DACE families (skmba._core.dace).

The families' values and gradients are checked in ``tests/test_kernels.py``;
here, the pieces of the base class on their own.
"""

import numpy as np
import pytest

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
