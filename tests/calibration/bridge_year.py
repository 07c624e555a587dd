"""The bridge year that the monitoring tests share (``test_partial_fit.py``,
``test_module3_update.py``): ``make_bridge_monitoring(random_state=0)`` as
tables, its simulations, short-chain settings, and a call that keeps the
identifiability warning quiet."""

import warnings

import pytest

from skmba.datasets import make_bridge_monitoring
from skmba.exceptions import NonIdentifiabilityWarning

pytest.importorskip("pandas")  # the year as time-indexed tables

DATA = make_bridge_monitoring(random_state=0)
FRAME = DATA.frame
X, Y = FRAME[["temperature"]], FRAME[list(DATA.response_names)]
SIMS = dict(X_sim=DATA.X_sim, theta_sim=DATA.theta_sim, y_sim=DATA.y_sim)
# Short chains and 2 degC bins (about 25 distinct inputs): seconds per fit.
FAST = dict(bin_width=2.0, n_samples=1000, burn_in=300, random_state=0)


def quiet(call, *args, **kwargs):
    """``call(*args, **kwargs)`` without the identifiability warning: E and
    the bearings are confounded with the discrepancy on a temperature-only
    design (said by that warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        return call(*args, **kwargs)
