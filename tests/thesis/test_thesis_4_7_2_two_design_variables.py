"""Thesis section 4.7.2: two design variables (force and moment).

The physics of the problem: see tests/thesis/_helpers.py.
"""

from skmba.datasets import make_cantilever

from ._helpers import (
    fit,
    relative_error,
)


def test_472_two_design_variables():
    data = make_cantilever(
        n_simulations=100,
        n_observations=40,
        design_variables=("force", "moment"),
        random_state=0,
    )
    cal = fit(data)
    assert abs(relative_error(cal, data)) < 0.05
    assert cal.predict(data.X_obs[:3]).shape == (3, 2)
