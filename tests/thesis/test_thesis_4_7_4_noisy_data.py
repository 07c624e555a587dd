"""Thesis section 4.7.4: noisy field data.

The physics of the problem: see tests/thesis/_helpers.py.
"""

import numpy as np
import pytest

from skmba.datasets import make_cantilever

from ._helpers import (
    coverage,
    credible_interval,
    fit,
    inside,
    relative_error,
)


# Seed 0 in the default run, all three with the slow marker.
@pytest.mark.parametrize(
    "seed",
    [
        0,
        pytest.param(1, marks=pytest.mark.slow),
        pytest.param(2, marks=pytest.mark.slow),
    ],
)
def test_474_noisy_data(seed):
    data = make_cantilever(
        n_simulations=100, n_observations=35, snr_db=18.0, random_state=seed
    )
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.10
    assert inside(data.theta_true[0], credible_interval(cal))
    ratio = cal.noise_ / data.noise_variance
    assert np.all((ratio > 1 / 3) & (ratio < 3)), ratio  # the right order
    assert np.all(coverage(cal, data, seed) >= 0.85)
