"""The bridge year that the monitoring tests share (``test_partial_fit.py``,
``test_module3_update.py``): ``make_bridge_monitoring(random_state=0)`` as
tables, its simulations, short-chain settings, and a call that keeps the
identifiability warning quiet."""

import warnings

import numpy as np
import pytest
from scipy import stats

from skmba.datasets import make_bridge_monitoring
from skmba.exceptions import NonIdentifiabilityWarning

pytest.importorskip("pandas")  # the year as time-indexed tables

DATA = make_bridge_monitoring(random_state=0)
FRAME = DATA.frame
X, Y = FRAME[["temperature"]], FRAME[list(DATA.response_names)]
SIMS = dict(X_sim=DATA.X_sim, theta_sim=DATA.theta_sim, y_sim=DATA.y_sim)
# Short chains and 2 degC bins (about 25 distinct inputs): seconds per fit.
FAST = dict(bin_width=2.0, n_samples=1000, burn_in=300, random_state=0)
# Chains long enough for a comparison to 0.1 posterior sd: 20,000 draws.
LONG = dict(n_samples=5000, burn_in=1000, target_ess=None)


def quiet(call, *args, **kwargs):
    """``call(*args, **kwargs)`` without the identifiability warning: E and
    the bearings are confounded with the discrepancy on a temperature-only
    design (said by that warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        return call(*args, **kwargs)


def sd_error(samples, ess):
    """Standard error of a sample sd relative to it, per column:
    ``sqrt((kurtosis - 1) / (4 ess))`` (the delta method on the sample
    variance; the bearing stiffness's heavy tail makes it large)."""
    kurtosis = stats.kurtosis(samples, fisher=False)
    return np.sqrt((kurtosis - 1.0) / (4.0 * ess))
