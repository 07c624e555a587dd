"""Thesis section 4.7.7: Gaussian priors on one and two parameters.

The physics of the problem: see tests/thesis/_helpers.py.
"""

import numpy as np
import pytest
from scipy import optimize, stats

from skmba.datasets import make_cantilever

from ._helpers import (
    check_E_and_I_posterior,
    credible_interval,
    effective_modulus,
    fit,
    fit_E_and_I,
    inside,
    relative_error,
)


def test_477_gaussian_prior_one_parameter():
    data = make_cantilever(prior="gaussian", random_state=0)
    assert isinstance(data.prior[0].dist, type(stats.norm))
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.05
    assert inside(effective_modulus(data), credible_interval(cal))


@pytest.mark.slow
def test_477_bivariate_gaussian_prior():
    # Eq. 4.54 is deliberately wrong: its means are 24 % (E) and 30 % (I)
    # below the truth, 1.7 and 3 prior sd. The data fix E I; along the
    # ridge the prior decides, and its mode there is E +8.6 %, I -10.7 %
    # (computed below). The posterior must sit between that mode and the
    # truth, contain the truth, and keep E I within 10 % (measured -6.6 %:
    # the wrong prior also pulls E I down within its 5 % uncertainty).
    data, cal = fit_E_and_I(0, prior="gaussian")
    assert abs(check_E_and_I_posterior(cal, data)) < 0.10
    mean, cov = data.prior.mean, data.prior.cov
    c = np.prod(data.theta_true)

    def prior_on_ridge(E):
        z = (np.array([E, c / E]) - mean) / np.sqrt(np.diag(cov))
        return z @ z

    E_mode = optimize.minimize_scalar(
        prior_on_ridge, bounds=(4e4, 1e5), method="bounded"
    ).x
    mode = np.array([E_mode, c / E_mode])
    lo, hi = np.minimum(mode, data.theta_true), np.maximum(mode, data.theta_true)
    width = hi - lo
    assert np.all((cal.theta_mean_ > lo - 0.25 * width) & (cal.theta_mean_ < hi))
