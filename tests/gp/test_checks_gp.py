"""Checks of MultiResponseGP's training data and fitted hyperparameters."""

import warnings

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from skmba.gp._checks import warn_at_bounds


def test_noise_on_either_bound_warns_with_its_meaning():
    bounds = np.array([[1e-8, 10.0], [2e-8, 20.0], [4e-8, 40.0]])
    values = np.array([1e-8, 1.0, 40.0])  # lower bound, inside, upper bound
    with pytest.warns(ConvergenceWarning) as record:
        warn_at_bounds(None, noise=([0, 3, 5], values, bounds))
    messages = [str(w.message) for w in record]
    assert len(messages) == 2
    assert messages[0].startswith(
        "The fitted noise variance of response 0 (1e-08) is at the lower bound "
        "1e-08 of its search"
    )
    assert "the data look noise-free for this response" in messages[0]
    assert messages[1].startswith(
        "The fitted noise variance of response 5 (40) is at the upper bound 40 "
        "of its search"
    )
    assert "looks like noise alone" in messages[1]
    assert all(w.filename == __file__ for w in record)
    # inside the bounds: silent
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_at_bounds(None, noise=([1], values[1:2], bounds[1:2]))
