"""Progress reporting (skmba._core.progress): verbose 0 silent, 1 bars, 2 details.

Everything goes to standard error; the results do not depend on
``verbose`` (the MCMC chains then run in segments, the designer's phase 2
in (subset chunk, replicate block) tasks).
"""

import re
import warnings

import joblib
import numpy as np
import pytest
from joblib import delayed

import skmba.mcmc._run as sampling
import skmba.sensor_design._scoring as preposterior
from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba._core.progress import Progress, as_progress, results_as_ready
from skmba.datasets import make_cantilever
from skmba.mcmc._run import run_chains

ONE = make_cantilever(n_simulations=30, n_observations=10, random_state=0)
TWO = make_cantilever(
    n_simulations=30, n_observations=10, parameters=("E", "I"), random_state=0
)
MCMC = dict(n_chains=2, n_samples=100, burn_in=100, n_restarts_optimizer=0)
DESIGN_DATA = make_cantilever(
    30, responses=("tip_displacement", "energy", "mid_displacement"), random_state=0
)


def calibrate(data, simulate=False, **params):
    cal = ModularBayesCalibrator(
        data.simulator if simulate else None,
        data.prior,
        random_state=0,
        **{"n_simulations": 30, **params} if simulate else params,
    )
    sims = (
        {}
        if simulate
        else dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # short chains: diagnostics warn
        return cal.fit(data.X_obs, data.y_obs, **sims)


def design(**params):
    X = np.hstack([DESIGN_DATA.X_sim, DESIGN_DATA.theta_sim])
    designer = PreposteriorDesigner(
        DESIGN_DATA.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        n_design=6,
        n_mc=4,
        random_state=0,
        **params,
    )
    return designer.fit(X, DESIGN_DATA.y_sim)


def standard_normal(theta):
    return -0.5 * float(theta @ theta)


# ------------------------------------------------------------- the helper
def test_helper_prints_by_verbose_on_stderr_only(capsys):
    for verbose in (0, 1, 2):
        progress = Progress(verbose, "Name")
        with progress.bar(3, "work", unit="task") as bar:
            bar.update(2)
            progress.info("step done")
            progress.detail("a detail")
            bar.update(1)
        captured = capsys.readouterr()
        assert captured.out == ""
        err = captured.err
        if verbose == 0:
            assert err == ""
            assert bar.n == 3  # the silent bar still counts
            continue
        assert "[Name] work: 100%" in err and "3/3" in err
        assert "[Name] step done\n" in err
        assert ("[Name] a detail" in err) == (verbose == 2)
    assert as_progress(None).verbose == 0


@pytest.mark.parametrize("backend", ["loky", "threading", "multiprocessing"])
def test_results_as_ready_are_joblibs_results_in_order(backend):
    # multiprocessing cannot return a generator: all tasks run, then yield.
    with joblib.parallel_config(backend=backend, n_jobs=2):
        got = list(results_as_ready(delayed(pow)(3, k) for k in range(7)))
    assert got == [3**k for k in range(7)]


# ---------------------------------------------------------- the calibrator
def test_calibrator_at_verbose_zero_prints_nothing(capsys):
    calibrate(ONE, simulate=True)
    calibrate(TWO, **MCMC)
    assert capsys.readouterr() == ("", "")


def test_calibrator_shows_the_simulator_runs_and_each_module(capsys):
    calibrate(ONE, simulate=True, verbose=1)
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert re.search(r"\[ModularBayesCalibrator\] simulator: 100%.* 30/30 ", err)
    assert re.search(r"simulator: 30 runs in 1 call\(s\), 0 failed, [\d.]+ s\n", err)
    assert "[ModularBayesCalibrator] emulator of 30 simulations: 100%" in err
    assert "[ModularBayesCalibrator] module 2: discrepancy: 100%" in err
    assert "module 1 done in" in err and "module 3 done in" in err
    assert "start 1 of 3" not in err  # detail lines need verbose=2


def test_calibrator_verbose_two_reports_each_restart(capsys):
    calibrate(ONE, verbose=2)
    err = capsys.readouterr().err
    for k in (1, 2, 3):  # n_restarts_optimizer=2: three starts each
        assert re.search(rf"emulator: start {k} of 3, log-likelihood -?[\d.]", err)
        assert re.search(rf"module 2: start {k} of 3, log-likelihood -?[\d.]", err)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_mcmc_progress_with_joblib_workers_and_same_draws(capsys, n_jobs):
    # The chains run in joblib workers (n_jobs=2: loky processes); the bar
    # is the parent's, and the draws are those of a silent fit.
    quiet = calibrate(TWO, n_jobs=n_jobs, **MCMC)
    assert capsys.readouterr() == ("", "")
    loud = calibrate(TWO, n_jobs=n_jobs, verbose=1, **MCMC)
    err = capsys.readouterr().err
    assert "[ModularBayesCalibrator] MCMC: 2 chain(s): 100%" in err
    assert "400/400" in err  # 2 chains x (100 burn-in + 100 draws)
    for name in ("theta_chains_", "theta_log_posterior_", "acceptance_rate_"):
        np.testing.assert_array_equal(getattr(loud, name), getattr(quiet, name))


class _Recorder(Progress):
    """A Progress whose bar records its updates."""

    def bar(self, total, desc, unit="it"):
        self.updates, self.total = [], total
        recorder = self

        class Bar:
            n = 0

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                return False

            def update(self, n=1):
                recorder.updates.append(n)

        return Bar()


@pytest.mark.parametrize("backend", ["loky", "threading"])
def test_chains_in_segments_update_the_bar_and_keep_the_draws(backend):
    # 20 segments per chain, aligned to whole burn-in blocks of 50 steps;
    # the segments change nothing in the draws (bit for bit).
    starts = np.array([[0.5, -1.0], [2.0, 0.0], [-1.0, 1.0]])
    kwargs = dict(n_samples=1500, burn_in=500, random_state=3)
    whole = run_chains(standard_normal, starts, n_jobs=1, **kwargs)
    recorder = _Recorder(1)
    with joblib.parallel_config(backend=backend, n_jobs=2):
        parts = run_chains(standard_normal, starts, progress=recorder, **kwargs)
    assert recorder.total == 3 * 2000 == sum(recorder.updates)
    assert len(recorder.updates) == 3 * sampling._PROGRESS_SEGMENTS
    for name in ("samples", "log_density", "acceptance_rate", "proposal_cov"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(whole, name))


# ------------------------------------------------------------ the designer
def test_designer_at_verbose_zero_prints_nothing(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        design()
    assert capsys.readouterr() == ("", "")


def test_designer_shows_both_phases_and_the_estimate_first(capsys, monkeypatch):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        quiet = design()
    capsys.readouterr()
    monkeypatch.setattr(preposterior, "_TASK_EVALUATIONS", 3)  # several tasks
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loud = design(verbose=1)
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert "[PreposteriorDesigner] phase 1: replicates: 100%" in err
    assert "4/4" in err
    assert "[PreposteriorDesigner] phase 2: exhaustive search: 100%" in err
    assert "28/28" in err  # 7 subsets x 4 replicates
    announce = err.index(
        "phase 2: exhaustive search over 7 subsets (of at most 3 of 3 responses) "
        "x 4 replicates = 28 posterior evaluations"
    )
    assert announce < err.index("phase 2: exhaustive search:")  # the bar
    assert re.search(r"phase 2: expected time about \d+ s \(first task", err)
    assert err.index("phase 1: replicates: 100%") < announce
    np.testing.assert_array_equal(loud.scores_, quiet.scores_)
    np.testing.assert_array_equal(loud.convergence_, quiet.convergence_)


def test_a_long_exhaustive_search_warns_whatever_verbose(capsys, monkeypatch):
    monkeypatch.setattr(preposterior, "LONG_SEARCH_SECONDS", 0.0)
    with pytest.warns(UserWarning, match=r"expected to take about .* It goes on") as w:
        design(max_responses=2)
    ours = [x for x in w if "expected to take" in str(x.message)]
    assert len(ours) == 1 and ours[0].filename == __file__
    assert capsys.readouterr().out == ""


def test_designer_greedy_search_bar(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        design(search="greedy", verbose=2)
    err = capsys.readouterr().err
    # greedy scores 3 + 2 + 1 subsets x 4 replicates
    assert "[PreposteriorDesigner] phase 2: greedy search: 100%" in err
    assert "24/24" in err
    assert re.search(r"scored 6 subsets \([\d.]+ s\)", err)
    assert "exhaustive" not in err
