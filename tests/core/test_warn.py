"""Every warning of skmba points at the user's line (skmba._core.warn)."""

import ast
import warnings
from pathlib import Path

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

import skmba
from skmba import ModularBayesCalibrator, MultiResponseGP
from skmba._core.warn import PACKAGE_DIR, warn
from skmba.datasets import make_cantilever
from skmba.gp._checks import warn_at_bounds

SKMBA_FILES = sorted(Path(skmba.__file__).parent.rglob("*.py"))


def _ours(record):
    """The warnings of the kinds skmba issues (not a dependency's deprecations)."""
    kinds = (UserWarning, ConvergenceWarning)  # and their subclasses
    return [w for w in record if issubclass(w.category, kinds)]


def test_the_package_folder_is_skmba():
    assert PACKAGE_DIR == str(Path(skmba.__file__).parent) + "/"


def test_a_warning_from_a_helper_points_at_its_caller():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        warn("called from a test")  # this line
        warn_at_bounds(None, noise=([0], np.array([1e-12]), np.array([[1e-12, 1.0]])))
    assert [w.filename for w in record] == [__file__, __file__]
    assert record[0].category is UserWarning


@pytest.mark.parametrize("path", SKMBA_FILES, ids=lambda p: p.name)
def test_no_module_warns_but_through_the_helper(path):
    """No ``warnings.warn`` and no literal ``stacklevel`` outside the helper."""
    if path.name == "warn.py" and path.parent.name == "_core":
        return
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            func = node.func
            name = getattr(func, "attr", getattr(func, "id", None))
            owner = getattr(getattr(func, "value", None), "id", None)
            assert not (name == "warn" and owner == "warnings"), (path, node.lineno)
            assert "stacklevel" not in [k.arg for k in node.keywords], (
                path,
                node.lineno,
            )


def _fit_bad_field_data():
    """A calibrator fit on field data with several slips at once."""
    data = make_cantilever(n_simulations=12, n_observations=8, random_state=0)
    X = data.X_obs.copy()
    X[0] = data.X_bounds[0][1] * 3.0  # far outside the simulated loads
    y = data.y_obs * 1000.0  # metres -> millimetres against the simulations
    y[1] = np.nan  # a row with no reading
    cal = ModularBayesCalibrator(
        prior=data.prior,
        discrepancy_uncertainty="plug-in",
        n_samples=200,
        n_restarts_optimizer=0,
        random_state=0,
    )
    cal.fit(X, y, X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)


def _fit_failing_simulator():
    data = make_cantilever(n_simulations=40, n_observations=10, random_state=0)
    model = data.simulator

    def simulator(X, theta):
        Y = model(X, theta)
        Y[::7] = np.nan  # one run in seven fails
        return Y

    ModularBayesCalibrator(
        simulator,
        prior=data.prior,
        n_simulations=30,
        discrepancy_uncertainty="plug-in",
        n_samples=200,
        n_restarts_optimizer=0,
        random_state=0,
    ).fit(data.X_obs, data.y_obs)


def _fit_gp_at_bounds():
    # The response ignores input 1: its roughness falls to the lower bound.
    X = np.random.default_rng(0).uniform(0, 1, size=(30, 2))
    MultiResponseGP().fit(X, np.sin(6 * X[:, 0]))


@pytest.mark.parametrize(
    ("call", "n_warnings"),
    [
        # too few runs, two responses out of range, one input outside, a NaN row
        (_fit_bad_field_data, 5),
        # the failed runs listed; E confounded with the spring (the cantilever)
        (_fit_failing_simulator, 2),
        (_fit_gp_at_bounds, 1),  # a roughness held by its bound
    ],
)
def test_warnings_on_user_input_point_at_the_callers_line(call, n_warnings):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        call()
    ours = _ours(record)
    where = {(Path(w.filename).name, str(w.message)[:60]) for w in ours}
    assert len(where) == n_warnings, where
    assert {w.filename for w in ours} == {__file__}, where
