"""Thesis section 4.7.6: outliers in the field data.

The physics of the problem: see tests/thesis/_helpers.py.
"""

import numpy as np

from skmba.datasets import make_cantilever

from ._helpers import (
    fit,
)


def test_476_outliers_fall_outside_the_predictive_interval():
    # Judged over three seeds, each outlier beyond the 95 % predictive
    # interval of the response it corrupts (measured on seeds 0-4: 3.9 to
    # 4.4 standard deviations). With the discrepancy variance free to vanish
    # (the former module 2), the discrepancy GP interpolated them in one seed
    # of three.
    for seed in range(3):
        data = make_cantilever(
            n_simulations=100,
            n_observations=40,
            snr_db=[4.38, 71.6],
            n_outliers=2,
            random_state=seed,
        )
        cal = fit(data)
        idx = data.outlier_indices
        mean, std = cal.predict(data.X_obs[idx], return_std=True)
        z = np.abs(data.y_obs[idx] - mean) / std
        assert np.all(z.max(axis=1) > 3.0), (seed, z)
