"""Pieces of the fast preposterior analysis (skmba._preposterior) on their own.

The designer end to end is tested in ``tests/test_sensor_design.py``.
"""

import warnings
from types import SimpleNamespace

import pytest
from sklearn.exceptions import ConvergenceWarning

from skmba._preposterior import warn_replicate_problems


def test_replicate_problems_are_counted_in_their_warnings():
    reps = [SimpleNamespace(n_unconverged=u, n_repaired=r) for u, r in [(2, 0), (1, 3)]]
    with pytest.warns(ConvergenceWarning, match="3 module-2 likelihood.* of the 2 "):
        with pytest.warns(UserWarning, match="3 posterior-integrated emulator"):
            warn_replicate_problems(reps)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_replicate_problems([SimpleNamespace(n_unconverged=0, n_repaired=0)])
