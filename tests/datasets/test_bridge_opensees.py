"""The monitored bridge in OpenSees (skmba.datasets.OpenSeesBridgeModel)."""

import warnings

import numpy as np
import pytest

from skmba import ModularBayesCalibrator
from skmba.datasets import BridgeModel, OpenSeesBridgeModel, make_bridge_monitoring
from skmba.datasets._bridge_model import youngs_modulus_at
from skmba.datasets._bridge_opensees import OPENSEES_EXTRA, check_opensees

try:
    check_opensees()
    REASON = None
except ImportError as error:  # the reason is printed in pytest's summary (-ra)
    REASON = f"OpenSeesPy cannot be imported: {OPENSEES_EXTRA}. ({error})"
needs_opensees = pytest.mark.skipif(REASON is not None, reason=REASON or "")


class EveryTwentiethFails:
    """The OpenSees simulator whose runs 20, 40, ... (counted over its calls)
    get a negative Young's modulus: OpenSees then finds negative
    eigenvalues, and the run's frequencies are NaN."""

    def __init__(self, model):
        self.model = model

    def __call__(self, X, theta):
        X, theta = np.asarray(X, float), np.asarray(theta, float)
        E = youngs_modulus_at(theta[:, 0], X[:, 0])
        sign = np.where(np.arange(1, len(X) + 1) % 20 == 0, -1.0, 1.0)
        states = np.column_stack([sign * E * self.model.second_moment, theta[:, 1]])
        return self.model.timed_states(states)[0]


@needs_opensees
def test_frequencies_agree_with_the_numpy_model():
    # The same deck (elements, consistent mass, bearings): to 1e-6 relative
    # (measured: 3e-10), at several temperatures, moduli and bearings,
    # pinned ends included.
    X = np.array([[20.0], [-5.0], [10.0], [30.0]])
    theta = np.array([[35e9, 3e9], [30e9, 1e9], [40e9, np.inf], [25e9, 5e8]])
    model = OpenSeesBridgeModel(n_jobs=2)
    frequencies, seconds = model.timed_states(
        np.column_stack([youngs_modulus_at(theta[:, 0], X[:, 0]) * 2.0, theta[:, 1]])
    )
    reference = BridgeModel()(X, theta)
    np.testing.assert_allclose(model(X, theta), reference, rtol=1e-6)
    np.testing.assert_allclose(frequencies, reference, rtol=1e-6)
    assert np.all(seconds > 0) and np.all(seconds < 5)


@needs_opensees
def test_a_failed_analysis_is_recorded_and_the_rest_kept():
    data = make_bridge_monitoring(24, 40, n_modes=2, random_state=0)
    simulator = EveryTwentiethFails(OpenSeesBridgeModel(n_modes=2, n_jobs=2))
    cal = ModularBayesCalibrator(
        simulator=simulator,
        prior=data.prior,
        n_simulations=40,
        n_chains=2,
        n_samples=200,
        burn_in=200,
        random_state=0,
    )
    X, y = data.X_obs, data.y_obs
    keep = np.isfinite(y).all(axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the two failures, identifiability
        cal.fit(X[keep], y[keep])
    assert len(cal.simulation_failures_) == 2
    assert len(cal.X_sim_) == 38 and np.all(np.isfinite(cal.y_sim_))
    lo, hi = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
    assert lo < hi and np.all(np.isfinite(cal.theta_mean_))


def test_without_opensees_the_error_names_the_extra(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_opensees(name, *args, **kwargs):
        if name.startswith("openseespy"):
            raise ImportError("No module named 'openseespy'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_opensees)
    with pytest.raises(ImportError, match=r"skmba\[opensees\].*libblas3"):
        OpenSeesBridgeModel()([[20.0]], [35e9, 3e9])
