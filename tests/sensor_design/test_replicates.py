"""Pieces of the fast preposterior analysis (skmba.sensor_design._replicates) on their
own.

The designer end to end is tested in
``tests/sensor_design/test_estimator_sensor_design.py``.
"""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from skmba.sensor_design._replicates import warn_replicate_problems
from skmba.sensor_design._scoring import criterion_value


def test_replicate_problems_are_counted_in_their_warnings():
    reps = [SimpleNamespace(n_unconverged=u, n_repaired=r) for u, r in [(2, 0), (1, 3)]]
    with pytest.warns(ConvergenceWarning, match="3 module-2 likelihood.* of the 2 "):
        with pytest.warns(UserWarning, match="3 posterior-integrated emulator"):
            warn_replicate_problems(reps)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_replicate_problems([SimpleNamespace(n_unconverged=0, n_repaired=0)])


@pytest.mark.parametrize("criterion", ["trace", "det", "max_eig"])
def test_a_stack_of_covariances_is_scored_as_each_one_alone(criterion):
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 5, 3, 3))
    covs = a @ np.swapaxes(a, -1, -2)  # (4, 5) covariances of r = 3
    b = rng.normal(size=(3, 3))
    prior_cov = b @ b.T + np.eye(3)
    stacked = criterion_value(covs, prior_cov, criterion)
    assert stacked.shape == (4, 5)
    one_by_one = [
        [criterion_value(c, prior_cov, criterion) for c in row] for row in covs
    ]
    np.testing.assert_allclose(stacked, one_by_one, rtol=1e-12)
    assert isinstance(criterion_value(covs[0, 0], prior_cov, criterion), float)
