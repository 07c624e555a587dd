"""The simulation runs: the simulator's failed runs, NaN rows of y_sim, checks."""

import warnings

import numpy as np
import pytest

from skmba import ModularBayesCalibrator
from skmba.calibration._response_checks import check_responses
from skmba.calibration._simulations import (
    SimulationData,
    SimulationFailure,
    check_failed_runs,
    given_simulations,
    run_simulator,
)
from skmba.datasets import make_cantilever
from skmba.exceptions import NonIdentifiabilityWarning


def _counting(fail):
    """A simulator ``y = X theta`` that fails where ``fail(X, theta)`` (raises
    when its value is "raise", else returns NaN), counting its calls."""
    calls = []

    def simulator(X, theta):
        calls.append(len(X))
        how = fail(X, theta)
        if np.any(how == "raise"):
            raise ArithmeticError("solver diverged")
        out = X * theta
        out[how == "nan"] = np.nan
        return out

    return simulator, calls


def test_run_simulator_keeps_every_successful_run_in_few_calls():
    n = 64
    X, theta = np.ones((n, 1)), np.arange(n, dtype=float)[:, None]
    failing = {5: "raise", 40: "raise", 41: "nan", 63: "nan"}

    def fail(X, theta):
        return np.array([failing.get(int(t), "") for t in theta[:, 0]])[:, None]

    simulator, calls = _counting(fail)
    runs = run_simulator(simulator, X, theta, 1)
    assert sorted(runs.errors) == [5, 40, 41, 63]
    assert isinstance(runs.errors[5], ArithmeticError)
    assert runs.errors[41].startswith("non-finite output")
    ok = np.setdiff1d(np.arange(n), list(failing))
    np.testing.assert_array_equal(runs.y[ok, 0], theta[ok, 0])
    assert np.all(np.isnan(runs.y[list(failing), 0]))
    # Halving: about 2 log2(64) = 12 calls per raising run, not one per run;
    # every call is a contiguous block and no run is simulated twice
    # successfully.
    assert runs.n_calls == len(calls) <= 1 + 2 * 2 * np.log2(n)
    assert isinstance(runs.batch_error, ArithmeticError)


def test_run_simulator_calls_once_when_nothing_raises():
    simulator, calls = _counting(lambda X, t: np.where(t > 2, "nan", ""))
    runs = run_simulator(simulator, np.ones((4, 1)), np.arange(4.0)[:, None], 1)
    assert calls == [4] and runs.n_calls == 1 and runs.batch_error is None
    assert list(runs.errors) == [3]


def test_wrong_output_shape_is_an_error_of_the_contract():
    def simulator(X, theta):
        if len(X) > 2:
            raise MemoryError("batch too large")
        return np.ones((len(X), 3))

    with pytest.raises(ValueError, match=r"shape \(2, 3\) for runs 0..1; it must"):
        run_simulator(simulator, np.ones((4, 1)), np.ones((4, 1)), 2)


def test_nan_rows_of_y_sim_are_failures_nan_inputs_are_errors():
    X = np.arange(5.0)[:, None]
    y = np.column_stack([X[:, 0], X[:, 0] ** 2])
    y_sim = y.copy()
    y_sim[[1, 3], [0, 1]] = [np.nan, np.inf]
    sims = given_simulations(X, 2, X, X + 1, y_sim)
    np.testing.assert_array_equal(sims.y, y[[0, 2, 4]])
    np.testing.assert_array_equal(sims.X[:, 0], [0, 2, 4])
    assert [(f.source, f.index) for f in sims.failures] == [("y_sim", 1), ("y_sim", 3)]
    assert sims.failures[1].theta.tolist() == [4.0]
    assert "inf" in sims.failures[1].error
    theta_sim = X + 1
    theta_sim[2] = np.nan
    with pytest.raises(ValueError, match=r"theta_sim contains NaN .* rows \[2\]: "):
        given_simulations(X, 2, X, theta_sim, y)


def _sims_with_failures(n_ok, n_failed):
    failures = tuple(
        SimulationFailure(
            "simulator",
            i,
            np.zeros(1),
            np.zeros(1),
            "ArithmeticError: solver diverged",
        )
        for i in range(n_failed)
    )
    ok = np.linspace(0, 1, n_ok)[:, None]
    return SimulationData(ok, ok, ok, n_ok, failures, n_failed, ArithmeticError())


def test_check_failed_runs_warns_with_the_count_and_fails_when_too_few_remain():
    with pytest.warns(UserWarning, match=r"3 of 23 simulator runs failed \(3x "):
        check_failed_runs(_sims_with_failures(20, 3), "constant", 2)
    with pytest.raises(
        ValueError,
        match=r"2 simulations after 18 of 20 simulator runs failed .* too few to fit "
        r"an emulator: .* needs at least 3",
    ):
        check_failed_runs(_sims_with_failures(2, 18), "constant", 2)
    with pytest.raises(RuntimeError, match=r"simulator failed on all 5 runs") as info:
        check_failed_runs(_sims_with_failures(0, 5), "constant", 2)
    assert isinstance(info.value.__cause__, ArithmeticError)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_failed_runs(_sims_with_failures(20, 0), "constant", 2)


def test_a_simulator_failing_on_a_fifth_of_the_runs_still_recovers_E():
    """The cantilever whose reality is the model (no spring): a simulator
    that raises on one tenth of the runs and returns NaN on another tenth,
    scattered over the design. The other 80 % are kept and counted, and E
    is recovered as from a simulator that never fails."""
    data = make_cantilever(
        n_simulations=70,
        n_observations=25,
        snr_db=30,
        spring_stiffness=np.inf,
        random_state=0,
    )

    def fate(theta):
        # A scattered fifth of the runs, by the phase of E.
        phase = np.sin(1e3 * theta[:, 0])
        return np.where(phase > 0.951, "raise", np.where(phase > 0.809, "nan", ""))

    def flaky(X, theta):
        how = fate(theta)
        if np.any(how == "raise"):
            raise ArithmeticError("solver diverged")
        out = data.simulator(X, theta)
        out[how == "nan"] = np.nan
        return out

    params = dict(prior=data.prior, n_simulations=100, random_state=1)
    with pytest.warns(UserWarning, match=r"\d+ of 100 simulator runs failed") as rec:
        # E is confounded with the discrepancy on this design (a1 of the
        # validity suite): the warning is expected and not the point here.
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        cal = ModularBayesCalibrator(flaky, **params).fit(data.X_obs, data.y_obs)
    failures = cal.simulation_failures_
    design = np.vstack([f.theta for f in failures])
    assert np.all(fate(design) != "")
    n_raised = sum(f.error == "ArithmeticError: solver diverged" for f in failures)
    assert n_raised >= 5 and len(failures) - n_raised >= 5
    assert 12 <= len(failures) <= 30
    assert len(cal.X_sim_) == 100 - len(failures)
    assert np.all(fate(cal.theta_sim_) == "")
    assert f"{len(failures)} of 100 simulator runs failed" in str(rec[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = ModularBayesCalibrator(data.simulator, **params).fit(
            data.X_obs, data.y_obs
        )
    lo, hi = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
    assert lo < data.theta_true[0] < hi
    assert abs(cal.theta_mean_[0] - clean.theta_mean_[0]) < 0.5 * np.sqrt(
        clean.theta_cov_[0, 0]
    )


def test_a_unit_slip_is_named_by_the_response_name():
    y_sim = np.column_stack([np.linspace(1.0, 2.0, 20), np.linspace(-3.0, 3.0, 20)])
    y = y_sim[::2].copy()
    y[:, 1] *= 1000.0  # the second gauge in another unit
    y[3, 1] = np.nan  # a gap does not hide it
    with pytest.warns(
        UserWarning,
        match=r"The observations of response 'energy' \(column 1 of y\) lie far "
        r"outside the range of its simulations",
    ) as record:
        X_sim = np.linspace(0.0, 1.0, 20)[:, None]
        theta_sim = np.tile([2.0, 3.0], 10)[:, None]
        check_responses(X_sim[::2], y, X_sim, theta_sim, y_sim, ["tip", "energy"])
    assert len(record) == 1


def test_cross_validation_keeps_the_simulations_whole_or_says_it_would_not():
    """GridSearchCV slices fit parameters with as many rows as X: simulations
    of that size are refused there with the remedy, and Simulations(...)
    reaches every fold whole."""
    from sklearn.model_selection import GridSearchCV

    from skmba.calibration import Simulations

    data = make_cantilever(24, 24, random_state=0)
    cal = ModularBayesCalibrator(
        prior=data.prior,
        discrepancy_uncertainty="plug-in",
        n_restarts_optimizer=0,
        n_samples=200,
        random_state=0,
    )
    search = GridSearchCV(cal, {"noise": [True]}, cv=2, error_score="raise")
    arrays = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonIdentifiabilityWarning)
        with pytest.raises(
            ValueError, match=r"slices every fit parameter.*Simulations"
        ):
            search.fit(data.X_obs, data.y_obs, **arrays)
        whole = Simulations(data.X_sim, data.theta_sim, data.y_sim)
        search.fit(data.X_obs, data.y_obs, simulations=whole)
        # outside model selection, the same arrays are simply used
        cal.fit(data.X_obs, data.y_obs, **arrays)
    assert len(search.best_estimator_.X_sim_) == 24
    with pytest.raises(TypeError, match=r"skmba\.calibration\.Simulations"):
        cal.fit(data.X_obs, data.y_obs, simulations=tuple(arrays.values()))
    with pytest.raises(ValueError, match="not both"):
        cal.fit(data.X_obs, data.y_obs, simulations=whole, X_sim=data.X_sim)
