"""Determinism and scale-out of ModularBayesCalibrator.

The same ``random_state`` must give bit-identical results whatever runs the
parallel work: ``n_jobs`` 1, 2 or -1 (loky processes), joblib's threading
backend, or a Dask cluster through ``joblib.parallel_config(backend="dask")``.
Chains are seeded per chain (SeedSequence children), module-2 node blocks
are fixed by the problem, and every task holds BLAS to one thread.
"""

import warnings

import joblib
import numpy as np
import pytest

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever

ONE = make_cantilever(n_simulations=30, n_observations=10, random_state=0)
TWO = make_cantilever(
    n_simulations=40, n_observations=12, parameters=("E", "I"), random_state=0
)
SMALL = dict(n_restarts_optimizer=0, random_state=7)
CHAINS = dict(n_chains=3, n_samples=150, burn_in=150)
SETTINGS = {
    # one parameter: module-2 Gauss-Legendre nodes, posterior by quadrature
    "quadrature": (ONE, SMALL),
    # two parameters: module-2 Sobol nodes in blocks, three MCMC chains
    "mcmc": (TWO, {**SMALL, **CHAINS}),
}


def fit(data, **params):
    cal = ModularBayesCalibrator(prior=data.prior, **params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # short chains: diagnostics warn
        return cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )


def outcome(cal, data):
    """Everything that must be bit-identical."""
    X = data.X_obs[:4]
    out = {
        "theta_samples_": cal.theta_samples_,
        "theta_mean_": cal.theta_mean_,
        "theta_cov_": cal.theta_cov_,
        "noise_": cal.noise_,
        "discrepancy_sigma2_": cal.discrepancy_sigma2_,
    }
    out["predict"] = np.stack(cal.predict(X, return_std=True))
    out["predict_model"] = np.stack(cal.predict_model(X, return_std=True))
    if hasattr(cal, "theta_chains_"):
        out["theta_chains_"] = cal.theta_chains_
        out["acceptance_rate_"] = cal.acceptance_rate_
    return out


def assert_identical(a, b):
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


@pytest.fixture(scope="module", params=sorted(SETTINGS))
def reference(request):
    """The serial fit of each setting: (data, params, outcome)."""
    data, params = SETTINGS[request.param]
    cal = fit(data, n_jobs=1, **params)
    return data, params, outcome(cal, data)


@pytest.mark.parametrize("n_jobs", [2, -1])
def test_same_seed_same_bits_for_any_n_jobs(reference, n_jobs):
    data, params, expected = reference
    assert_identical(outcome(fit(data, n_jobs=n_jobs, **params), data), expected)


def test_same_seed_same_bits_with_threads(reference):
    # Threads share the fitted objects: each chain and prediction task must
    # work on its own factorisation cache (else results depend on timing).
    data, params, expected = reference
    with joblib.parallel_config(backend="threading", n_jobs=3):
        assert_identical(outcome(fit(data, **params), data), expected)


def test_other_seed_other_draws(reference):
    data, params, expected = reference
    other = outcome(fit(data, n_jobs=1, **{**params, "random_state": 8}), data)
    assert not np.array_equal(other["theta_samples_"], expected["theta_samples_"])


def test_chains_are_seeded_per_chain_not_by_order():
    # Chain c draws from the c-th child of the seed whatever the number of
    # workers: the pooled draws are the chains in chain order.
    data, params = SETTINGS["mcmc"]
    cal = fit(data, n_jobs=-1, **params)
    r = len(data.theta_true)
    assert cal.theta_chains_.shape == (3, 150, r)
    np.testing.assert_array_equal(cal.theta_samples_, cal.theta_chains_.reshape(-1, r))
    assert len({chain.tobytes() for chain in cal.theta_chains_}) == 3


@pytest.fixture(scope="module")
def dask_client():
    """A dask client on a local cluster of threads in this process.

    Threads start in about a second and need no pickling of the test module;
    tasks still go through dask's scheduler.
    """
    distributed = pytest.importorskip(
        "distributed",
        reason="dask.distributed is not installed (pip install 'skmba[dask]')",
    )
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=False,
            dashboard_address=None,
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client


def on_dask(client, run):
    """``run()`` under joblib's dask backend; returns its result and tasks."""
    from distributed import get_task_stream

    with get_task_stream(client) as tasks, joblib.parallel_config(backend="dask"):
        result = run()
    return result, tasks.data


def test_dask_cluster_gives_the_default_backends_results(dask_client):
    data, params = SETTINGS["mcmc"]
    expected = outcome(fit(data, **params), data)
    result, tasks = on_dask(dask_client, lambda: outcome(fit(data, **params), data))
    # The chains, module-2 blocks and predictions ran as dask tasks.
    assert len(tasks) >= params["n_chains"]
    assert_identical(result, expected)


def test_dask_cluster_runs_the_designers_replicates(dask_client):
    """FPA replicates and subsets on dask equal the default backend's."""
    from skmba import PreposteriorDesigner

    data = make_cantilever(
        30, responses=("tip_displacement", "mid_displacement"), random_state=0
    )
    X = np.hstack([data.X_sim, data.theta_sim])

    def designer():
        return PreposteriorDesigner(
            data.prior,
            calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
            n_design=6,
            n_mc=4,
            n_jobs=2,
            random_state=0,
        ).fit(X, data.y_sim)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = designer()
        result, tasks = on_dask(dask_client, designer)
    assert len(tasks) >= 4
    np.testing.assert_array_equal(result.scores_, expected.scores_)
    np.testing.assert_array_equal(result.theta_draws_, expected.theta_draws_)
    np.testing.assert_array_equal(result.convergence_, expected.convergence_)
