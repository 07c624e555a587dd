"""The sensor designer's input checks (skmba.sensor_design._inputs).

The designer's own tests (tests/sensor_design/test_estimator_sensor_design.py) check the
messages through ``fit``; these check the functions' results.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from skmba import PreposteriorDesigner
from skmba.priors._hyperprior import Hyperprior
from skmba.sensor_design._inputs import (
    DEFAULT_N_DESIGN,
    designer_prior,
    field_design,
    synthetic_data_priors,
)


def test_designer_prior_splits_X_and_takes_the_calibrators_prior():
    prior = [stats.uniform(1.0, 2.0)]
    X = np.column_stack([np.linspace(0, 1, 12), np.linspace(1, 3, 12)])
    checked, d = designer_prior(None, SimpleNamespace(prior=prior), X)
    assert d == 1 and checked.dim == 1
    np.testing.assert_allclose(checked.bounds()[0], [1.0, 3.0])
    with pytest.raises(ValueError, match="about 20 are recommended"):
        designer_prior(prior, None, X[:4])


def test_field_design_fills_the_simulated_range():
    X_sim = np.array([[0.0, 10.0], [2.0, 30.0], [1.0, 20.0]])
    design = field_design(None, None, X_sim, seed=0)
    assert design.shape == (DEFAULT_N_DESIGN, 2)
    assert np.all((design >= [0.0, 10.0]) & (design <= [2.0, 30.0]))
    # Latin hypercube: one point per stratum of each variable.
    strata = np.floor((design - [0.0, 10.0]) / [2.0, 20.0] * DEFAULT_N_DESIGN)
    for column in strata.T:
        assert sorted(column) == list(range(DEFAULT_N_DESIGN))
    given = [[1.0, 15.0]]
    np.testing.assert_array_equal(field_design(given, 7, X_sim, seed=0), given)


def test_synthetic_data_priors_by_treatment():
    params = PreposteriorDesigner(
        discrepancy_uncertainty="propagate",
        discrepancy_prior={"sd_scale": [0.5, 0.1]},
    ).get_params()
    prior = synthetic_data_priors(params, d=1, q=2, y_scale=np.ones(2))
    assert isinstance(prior, Hyperprior)
    np.testing.assert_allclose(prior.scales(2), [0.5, 0.1])
    params.update(
        discrepancy_uncertainty="plug-in", discrepancy_prior={"variance": (0.01, 2.0)}
    )
    ranges = synthetic_data_priors(params, d=1, q=2, y_scale=np.ones(2))
    np.testing.assert_allclose(ranges["variance"][1], [2.0, 2.0])
