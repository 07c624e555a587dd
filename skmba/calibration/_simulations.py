"""The simulation runs: their design, running the simulator, checks.

Module 1 needs simulations ``y_sim = f(X_sim, theta_sim)``. They are given
(a precomputed dataset), run by the calibrator on a Latin hypercube over
the range of the field inputs times the prior's support, or both; the
result is one :class:`SimulationData`. The checks here make sure the runs
can support an emulator and cover the prior and the field inputs.

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._simulations import run_simulator
>>> runs = run_simulator(lambda X, t: X * t, np.ones((2, 1)), np.full((2, 1), 3.0), 1)
>>> runs.y
array([[3.],
       [3.]])
"""

import sys
import time
from collections import Counter
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import sparse, stats
from sklearn.utils.validation import check_array

from skmba._core.columns import match_columns
from skmba._core.progress import as_progress
from skmba._core.regression import n_regression_terms
from skmba._core.warn import warn
from skmba.priors._theta import check_prior


class SimulationFailure(NamedTuple):
    """A simulation run that gave no usable output.

    ``pandas.DataFrame(cal.simulation_failures_)`` tabulates them.

    Attributes
    ----------
    source : {"simulator", "y_sim"}
        A run of the simulator in this fit, or a row of the given ``y_sim``.
    index : int
        The run's row in the simulator's design, or in ``y_sim``.
    X : ndarray of shape (d,)
    theta : ndarray of shape (r,)
    error : str
        The exception (``"ZeroDivisionError: mesh collapsed"``) or
        ``"non-finite output [...]"``.
    """

    source: str
    index: int
    X: np.ndarray
    theta: np.ndarray
    error: str


@dataclass(frozen=True)
class SimulationData:
    """The successful simulation runs in user units, and the failed ones.

    Attributes
    ----------
    X : ndarray of shape (N, d)
    theta : ndarray of shape (N, r)
    y : ndarray of shape (N, q)
    n_simulator_runs : int
        How many of the runs (the last ones) the simulator made in this fit.
    failures : tuple of SimulationFailure
        The runs left out: the given ``y_sim`` rows with NaN or inf, then
        the simulator's failed runs.
    n_simulator_failures : int
        How many of the failures are the simulator's.
    first_exception : Exception or None
        The first exception the simulator raised (chained to an error when
        every run failed).
    """

    X: np.ndarray
    theta: np.ndarray
    y: np.ndarray
    n_simulator_runs: int = 0
    failures: tuple = ()
    n_simulator_failures: int = 0
    first_exception: BaseException | None = None


# ---------------------------------------------------------------- checks
def nonfinite_rows(A):
    """Indices of the rows of ``A`` with a NaN or an infinity.

    Examples
    --------
    >>> nonfinite_rows(np.array([[1.0], [np.nan]]))
    array([1])
    """
    return np.flatnonzero(~np.all(np.isfinite(A), axis=1))


def _rows_text(bad):
    return f"{bad[:10].tolist()}{' (and more)' if bad.size > 10 else ''}"


def check_finite_rows(A, name, fix):
    """Raise a ValueError naming ``name``, the bad rows and ``fix``."""
    bad = nonfinite_rows(A)
    if bad.size:
        raise ValueError(f"{name} contains NaN or inf in rows {_rows_text(bad)}: {fix}")


def as_array(A):
    """``np.asarray(A)``, or None for what ``check_array`` should report.

    Sparse matrices and ragged or otherwise unconvertible input are left to
    scikit-learn's ``check_array``/``validate_data`` and their messages.
    """
    if A is None or sparse.issparse(A):
        return None
    try:
        return np.asarray(A)
    except (TypeError, ValueError):
        return None


def check_2d(A, name, shape):
    """``A`` must be a 2-D array; the message says how to reshape a vector."""
    A = as_array(A)
    if A is None:
        return
    ndim = A.ndim
    if ndim != 2:
        fix = (
            f"use {name}.reshape(-1, 1) for a single column"
            if ndim == 1
            else "pass one row per sample"
        )
        raise ValueError(
            f"{name} must be a 2-D array of shape {shape}, got {ndim}-D with "
            f"shape {A.shape}; {fix}."
        )


# ------------------------------------------------------------- simulator
def _check_simulator_output(Y, n, q, first=0, names=None):
    # A table is matched to the responses by column label, as y_sim is.
    Y = match_columns(Y, names, "the simulator's output", "the columns of y")
    try:
        Y = np.asarray(Y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"simulator returned a {type(Y).__name__} that is not an array of "
            f"numbers ({exc}); it must return a float array of shape "
            f"({n}, {q if q is not None else 'q'}): one row per run and one "
            "column per response."
        ) from exc
    if Y.ndim == 1 and (q in (None, 1)):
        Y = Y.reshape(-1, 1)
    if Y.ndim != 2 or Y.shape[0] != n or (q is not None and Y.shape[1] != q):
        expected = f"({n}, {q if q is not None else 'q'})"
        raise ValueError(
            f"simulator returned an array of shape {np.shape(Y)} for runs "
            f"{first}..{first + n - 1}; it must return {expected}: one row per "
            "run and one "
            "column per response."
        )
    return Y


@dataclass(frozen=True)
class SimulatorRuns:
    """What :func:`run_simulator` got: outputs, NaN rows where runs failed.

    Attributes
    ----------
    y : ndarray of shape (n, q)
        The outputs; the rows of failed runs are NaN.
    errors : dict
        ``{run: exception or message}`` for the failed runs.
    n_calls : int
        Calls of the simulator (1 when the batch succeeds).
    batch_error : Exception or None
        The batch call's exception when it raised.
    """

    y: np.ndarray
    errors: dict
    n_calls: int
    batch_error: BaseException | None


def _output_text(row):
    values = ", ".join(f"{v:.4g}" for v in row[:6])
    return f"non-finite output [{values}{', ...' if len(row) > 6 else ''}]"


def run_simulator(simulator, X, theta, q, names=None):
    """Run ``simulator(X, theta)`` on blocks of runs; keep what succeeds.

    The whole design is one call. When a call raises, its block is halved
    and each half called again, down to single runs: a simulator that fails
    on some runs costs about ``2 log2(n)`` calls per failure, and every
    successful run is kept. A run fails when its call raises alone, or when
    its output row holds NaN or inf. An output of the wrong shape or type
    is an error of the simulator's contract and raises at once.

    Returns
    -------
    SimulatorRuns

    Examples
    --------
    >>> def model(X, t):
    ...     if np.any(t > 2):
    ...         raise ArithmeticError("solver diverged")
    ...     return X * t
    >>> runs = run_simulator(model, np.ones((4, 1)), np.arange(4.0)[:, None], 1)
    >>> runs.y.ravel().tolist(), sorted(runs.errors)
    ([0.0, 1.0, 2.0, nan], [3])
    """
    n = len(X)
    Y = np.full((n, q), np.nan)
    errors = {}
    n_calls = 0
    batch_error = None
    blocks = [np.arange(n)]
    while blocks:
        rows = blocks.pop()
        n_calls += 1
        try:
            out = simulator(X[rows], theta[rows])
        except Exception as exc:
            if len(rows) == n:
                batch_error = exc
            if len(rows) == 1:
                errors[int(rows[0])] = exc
            else:
                half = len(rows) // 2
                blocks += [rows[half:], rows[:half]]
            continue
        Y[rows] = _check_simulator_output(out, len(rows), q, rows[0], names)
    for i in nonfinite_rows(Y):
        errors.setdefault(int(i), _output_text(Y[i]))
    Y[list(errors)] = np.nan
    return SimulatorRuns(Y, dict(sorted(errors.items())), n_calls, batch_error)


# ------------------------------------------------------------ the runs
def _simulation_arrays(X_sim, theta_sim, y_sim):
    """The three simulation tables as 2-D float arrays (C order) with as
    many rows each, at least one."""
    check_2d(X_sim, "X_sim", "(n_simulations, d)")
    check_2d(theta_sim, "theta_sim", "(n_simulations, r)")
    y_array = as_array(y_sim)
    if y_array is not None and y_array.ndim not in (1, 2):
        raise ValueError(
            f"y_sim must be an array of shape (n_simulations, q), got shape "
            f"{y_array.shape}."
        )
    arrays = []
    for name, A in (("X_sim", X_sim), ("theta_sim", theta_sim), ("y_sim", y_sim)):
        A = check_array(
            A,
            input_name=name,
            ensure_2d=False,
            ensure_all_finite=False,
            ensure_min_samples=0,
            dtype=float,
        )
        # C order whatever the input's (a DataFrame gives Fortran order).
        arrays.append(np.ascontiguousarray(A if A.ndim == 2 else A.reshape(-1, 1)))
    X_sim, theta_sim, y_sim = arrays
    if not len(X_sim) == len(theta_sim) == len(y_sim):
        raise ValueError(
            "X_sim, theta_sim and y_sim must have the same number of rows, "
            f"got {len(X_sim)}, {len(theta_sim)} and {len(y_sim)}."
        )
    if len(X_sim) == 0:
        raise ValueError(
            "X_sim, theta_sim and y_sim are empty (0 simulations): pass the "
            "simulation dataset, or None and a simulator."
        )
    return X_sim, theta_sim, y_sim


@dataclass(frozen=True)
class Simulations:
    """A precomputed simulation dataset, kept whole by cross-validation.

    ``fit(X, y, simulations=Simulations(X_sim, theta_sim, y_sim))`` is
    ``fit(X, y, X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)``, except
    that scikit-learn's cross-validation (``GridSearchCV``,
    ``cross_val_score``), which slices every fit parameter with as many rows
    as ``X`` along with the folds, passes this one object to each fold as
    it is.

    Parameters
    ----------
    X_sim : array-like or DataFrame of shape (N, d)
        The design variables of the runs.
    theta_sim : array-like or DataFrame of shape (N, r)
        Their calibration parameters.
    y_sim : array-like or DataFrame of shape (N, q)
        Their responses (NaN rows: failed runs).

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.calibration import Simulations
    >>> sims = Simulations(np.zeros((3, 1)), np.ones((3, 1)), np.ones((3, 2)))
    >>> len(sims.y_sim)
    3
    """

    X_sim: object
    theta_sim: object
    y_sim: object


def check_not_sliced(X, X_sim):
    """Refuse simulation arrays that scikit-learn's cross-validation has
    probably sliced: as many rows as the field data ``X``, in a fit called
    from ``sklearn.model_selection`` (which slices every fit parameter of
    that length with the folds)."""
    if not (hasattr(X_sim, "__len__") and hasattr(X, "__len__")):
        return
    n_runs = len(X_sim)
    if n_runs != len(X):
        return
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith("sklearn.model_selection"):
            raise ValueError(
                f"X_sim, theta_sim and y_sim have as many rows as X ({n_runs}) "
                "in a fit called by scikit-learn's model selection, which "
                "slices every fit parameter of that length with the folds: "
                "each fold would get a fraction of the runs. Pass them as one "
                "object, fit(X, y, simulations=skmba.calibration.Simulations("
                "X_sim, theta_sim, y_sim)), which is passed to every fold whole."
            )
        frame = frame.f_back


def given_simulations(X, q, X_sim, theta_sim, y_sim):
    """The precomputed simulation dataset, checked; None when not given."""
    given = [a is not None for a in (X_sim, theta_sim, y_sim)]
    if not any(given):
        return None
    if not all(given):
        raise ValueError(
            "Pass X_sim, theta_sim and y_sim together (a precomputed "
            "simulation dataset), or none of them."
        )
    X_sim, theta_sim, y_sim = _simulation_arrays(X_sim, theta_sim, y_sim)
    for name, A in (("X_sim", X_sim), ("theta_sim", theta_sim)):
        check_finite_rows(
            A,
            name,
            "the inputs of every run must be known; drop these rows from "
            "X_sim, theta_sim and y_sim alike (a failed run is a NaN row of "
            "y_sim only).",
        )
    if X_sim.shape[1] != X.shape[1]:
        raise ValueError(
            f"X_sim has {X_sim.shape[1]} columns but X has {X.shape[1]}: "
            "the simulations must use the same design variables."
        )
    if y_sim.shape[1] != q:
        raise ValueError(
            f"y_sim has {y_sim.shape[1]} responses but y has {q}: the "
            "simulated and observed responses must be the same, in the "
            "same order."
        )
    failed = nonfinite_rows(y_sim)
    keep = np.setdiff1d(np.arange(len(y_sim)), failed)
    failures = tuple(
        SimulationFailure(
            "y_sim", int(i), X_sim[i], theta_sim[i], _output_text(y_sim[i])
        )
        for i in failed
    )
    return SimulationData(X_sim[keep], theta_sim[keep], y_sim[keep], failures=failures)


#: Runs per emulator input below which a design is called small: the rule
#: of thumb of Loeppky, Sacks and Welch (2009), "Choosing the sample size of
#: a computer experiment: a practical guide", Technometrics 51(4), 366-376.
RUNS_PER_INPUT = 10


def check_design_size(n_total, regression, k, *, failed=None):
    """Enough runs for an emulator on ``k`` inputs with ``regression``.

    An error below what the regression needs; a warning below
    :data:`RUNS_PER_INPUT` runs per input. ``failed``, a text saying which
    runs failed, marks the check after the runs: it then only raises (the
    warning came before the runs) and the error says why runs are missing.
    """
    needed = max(3, n_regression_terms(regression, k) + 1)
    if n_total < needed and (n_total or failed):
        after = "" if failed is None else f" after {failed}"
        raise ValueError(
            f"{n_total} simulations{after} are too few to fit an emulator: "
            f"regression={regression!r} on d + r = {k} inputs needs at "
            f"least {needed}; provide about {RUNS_PER_INPUT} per input "
            f"({RUNS_PER_INPUT * k}) with n_simulations or X_sim, theta_sim "
            "and y_sim."
        )
    if failed is None and n_total and n_total < RUNS_PER_INPUT * k:
        warn(
            f"{n_total} simulations for d + r = {k} emulator inputs are fewer "
            f"than the rule of thumb of {RUNS_PER_INPUT} per input "
            f"({RUNS_PER_INPUT * k}; Loeppky, Sacks and Welch 2009): the "
            "emulator, and the calibration with it, may be poor. Run more "
            "simulations (n_simulations, or more rows of X_sim, theta_sim "
            "and y_sim).",
            UserWarning,
        )


def simulation_design(X, prior, n_runs, given, seed):
    """A Latin hypercube over the range of ``X`` (and of the given runs)
    times the prior's central 0.999 interval."""
    lo_x, hi_x = X.min(axis=0), X.max(axis=0)
    if given is not None:
        lo_x = np.minimum(lo_x, given.X.min(axis=0))
        hi_x = np.maximum(hi_x, given.X.max(axis=0))
    bounds = prior.bounds(0.999)
    d, r = X.shape[1], prior.dim
    u = stats.qmc.LatinHypercube(d=d + r, seed=seed).random(n_runs)
    X_run = lo_x + (hi_x - lo_x) * u[:, :d]
    theta_run = bounds[:, 0] + (bounds[:, 1] - bounds[:, 0]) * u[:, d:]
    return X_run, theta_run


def collect_simulations(
    simulator, X, q, prior, given, n_runs, seed, progress=None, names=None
):
    """The given runs and ``n_runs`` simulator runs, stacked, failures apart.

    The successful runs form the data; the failed ones (see
    :func:`run_simulator`) are listed in ``failures`` for
    :func:`check_failed_runs` to report. ``progress`` (a
    :class:`~skmba._core.progress.Progress`, None is silent) shows a bar of the
    runs around the simulator's calls, then their number and time.
    """
    progress = as_progress(progress)
    parts = [] if given is None else [(given.X, given.theta, given.y)]
    failures = [] if given is None else list(given.failures)
    n_kept = n_failed = 0
    first_exception = None
    if simulator is not None:
        X_run, theta_run = simulation_design(X, prior, n_runs, given, seed)
        started = time.perf_counter()
        with progress.bar(n_runs, "simulator", unit="run") as bar:
            runs = run_simulator(simulator, X_run, theta_run, q, names)
            bar.update(n_runs)
        progress.info(
            f"simulator: {n_runs} runs in {runs.n_calls} call(s), "
            f"{len(runs.errors)} failed, {time.perf_counter() - started:.1f} s"
        )
        for i, error in runs.errors.items():
            if first_exception is None and isinstance(error, BaseException):
                first_exception = error
            text = error if isinstance(error, str) else _exception_text(error)
            failures.append(
                SimulationFailure("simulator", i, X_run[i], theta_run[i], text)
            )
        ok = np.setdiff1d(np.arange(n_runs), list(runs.errors))
        parts.append((X_run[ok], theta_run[ok], runs.y[ok]))
        n_kept, n_failed = len(ok), len(runs.errors)
        if runs.batch_error is not None and not runs.errors:
            warn(
                f"simulator raised {_exception_text(runs.batch_error)} on the "
                f"batch of {n_runs} runs but not on smaller blocks; it was "
                f"called {runs.n_calls} times. Make it handle arrays of many "
                "rows (X of shape (n, d), theta of shape (n, r)), or run it "
                "yourself and pass X_sim, theta_sim and y_sim to fit.",
                UserWarning,
            )
    if not parts:
        raise ValueError(
            "No simulations: pass a simulator (and a prior) to the "
            "constructor, or X_sim, theta_sim and y_sim to fit."
        )
    X_sim, theta_sim, y_sim = (np.vstack(p) for p in zip(*parts, strict=True))
    return SimulationData(
        X_sim,
        theta_sim,
        y_sim,
        n_kept,
        tuple(failures),
        n_failed,
        first_exception,
    )


def kept_simulator_runs(sims, exc):
    """After a failed fit, the simulator runs to keep on the estimator.

    Returns ``{"X_sim_": ..., "theta_sim_": ..., "y_sim_": ...}`` from
    ``sims`` (the fit's :class:`SimulationData`, None when it did not get
    that far) when the simulator ran, and adds to ``exc`` a note saying how
    to refit without running it again; else an empty dict.
    """
    if sims is None or not sims.n_simulator_runs:
        return {}
    exc.add_note(
        f"The {sims.n_simulator_runs} simulator runs of this fit are kept in "
        "X_sim_, theta_sim_ and y_sim_ (with any precomputed simulations): "
        "after fixing the problem, call set_params(simulator=None) and "
        "fit(X, y, X_sim=X_sim_, theta_sim=theta_sim_, y_sim=y_sim_) so as "
        "not to run the simulator again."
    )
    return {"X_sim_": sims.X, "theta_sim_": sims.theta, "y_sim_": sims.y}


def _exception_text(exc):
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def check_failed_runs(sims, regression, k):
    """Report the failed runs: an error when too few runs are left, else a warning.

    Every simulator run failing is a RuntimeError (with the first exception
    chained): the simulator, not the inputs, is then the likely cause.
    Too few runs left for the emulator is the ValueError of
    :func:`check_design_size`; otherwise a UserWarning gives the count and
    the most frequent errors.
    """
    failures = sims.failures
    if not failures:
        return
    n_sim_failed = sims.n_simulator_failures
    n_runs = sims.n_simulator_runs + n_sim_failed
    if n_runs and n_sim_failed == n_runs:
        first = next(f for f in failures if f.source == "simulator")
        raise RuntimeError(
            f"simulator failed on all {n_runs} runs, e.g. run {first.index} "
            f"with X={first.X.tolist()}, theta={first.theta.tolist()}: "
            f"{first.error}. Fix the simulator (call it on a few rows of "
            "X_sim_ and theta_sim_ to see why), or run the simulations "
            "yourself and pass the successful ones to fit(X, y, X_sim=..., "
            "theta_sim=..., y_sim=...)."
        ) from sims.first_exception
    parts = []
    if n_sim_failed:
        parts.append(f"{n_sim_failed} of {n_runs} simulator runs failed")
    n_given = len(failures) - n_sim_failed
    if n_given:
        parts.append(f"{n_given} row(s) of y_sim hold NaN or inf")
    common = Counter(f.error for f in failures).most_common(3)
    errors = "; ".join(f"{count}x {error}" for error, count in common)
    context = f"{' and '.join(parts)} ({errors})"
    check_design_size(len(sims.X), regression, k, failed=context)
    warn(
        f"{context}: the {len(sims.X)} successful runs are used and the "
        "failed ones are listed in simulation_failures_ (inputs and error). "
        "Where failures cluster, the emulator has fewer runs and is less "
        "certain; fix the simulator there or narrow the prior / input "
        "range if they mark a region the model cannot represent.",
        UserWarning,
    )


def checked_prior(prior, given, names=None):
    """The checked prior; uniform over ``theta_sim`` when None, named by
    ``names`` (the columns of a theta_sim table) when given.

    The range is that of the successful runs; when every row of ``y_sim``
    failed, that of all the rows of ``theta_sim``, so that the fit goes on
    to :func:`~skmba.calibration._simulations.check_failed_runs`, which says that too
    few runs remain (or to the simulator's runs, when there is one).
    """
    if prior is not None:
        return check_prior(prior, None if given is None else given.theta.shape[1])
    if given is None:
        raise ValueError(
            "prior is required when the simulations are run by the "
            "simulator: pass e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
        )
    t = given.theta
    if len(t) == 0:  # every row of y_sim failed: their theta are still known
        t = np.array([f.theta for f in given.failures]).reshape(-1, t.shape[1])
    uniforms = [
        stats.uniform(lo, hi - lo) for lo, hi in zip(t.min(0), t.max(0), strict=True)
    ]
    return check_prior(
        uniforms if names is None else dict(zip(names, uniforms, strict=True))
    )
