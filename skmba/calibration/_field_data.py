"""Checks of the field data ``X`` (design variables) and ``y``, alone and
against the simulations and the prior.

- alone: shapes, sizes and finiteness before scikit-learn's own checks, so
  that the message names the argument and the fix (:func:`check_field_data`);
  NaN in ``y`` marks a reading that was not taken
  (:func:`measured_field_data`); NaN in ``X`` and inf anywhere are errors;
- where tables meet: simulation tables matched to the field data and the
  prior by name (:func:`named_simulations`);
- ``fit``'s two forms of the simulations (:func:`simulation_tables`);
- against the simulations: each response on both sides (units, sign, a
  stuck sensor, logger codes; :func:`check_responses`), field inputs
  outside the simulated region and a prior the simulations miss
  (:func:`check_simulation_design`).

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._field_data import check_field_data
>>> check_field_data(np.zeros((3, 1)), np.zeros((2, 1)), "constant")
Traceback (most recent call last):
...
ValueError: X and y have 3 and 2 rows: y must hold one row of observed responses per row of field inputs X.
"""  # noqa: E501

from collections.abc import Mapping

import numpy as np
from sklearn.metrics import r2_score
from sklearn.utils import check_array

from skmba._core.columns import match_columns
from skmba._core.regression import n_regression_terms
from skmba._core.warn import warn
from skmba.calibration._simulations import (
    Simulations,
    as_array,
    check_2d,
    check_finite_rows,
    check_not_sliced,
)
from skmba.exceptions import FieldDataWarning


def check_field_data(X, y, discrepancy_regression):
    """Shapes, size and finiteness of the field data, before sklearn's checks.

    Sparse or non-numeric data are left to ``validate_data``.
    """
    check_2d(X, "X", "(n_samples, n_features)")
    X, y = as_array(X), as_array(y)
    if X is None or y is None:
        return
    if y.ndim not in (1, 2):
        raise ValueError(
            f"y must be an array of shape (n_samples,) or (n_samples, q), "
            f"got shape {y.shape}."
        )
    n, d = X.shape
    if len(y) != n:
        raise ValueError(
            f"X and y have {n} and {len(y)} rows: y must hold one "
            "row of observed responses per row of field inputs X."
        )
    p_d = n_regression_terms(discrepancy_regression, d)
    if n <= p_d:
        raise ValueError(
            f"X has {n} sample(s) (n_samples={n}): module 2 needs more field "
            f"observations than the {p_d} term(s) of discrepancy_regression="
            f"{discrepancy_regression!r} with {d} design variable(s). "
            "Add observations, or use a lower-order discrepancy_regression."
        )
    if X.dtype.kind in "biuf":  # others: validate_data names them
        check_finite_rows(
            X,
            "Input X",
            "the inputs of every observation must be known; remove these rows "
            "of X and y.",
        )
    if y.dtype.kind in "biuf":
        infinite = np.flatnonzero(np.any(np.isinf(y.reshape(n, -1)), axis=1))
        if infinite.size:
            raise ValueError(
                f"Input y contains inf in rows {infinite[:10].tolist()}: an "
                "infinite reading is not a measurement. Set it to NaN (not "
                "measured: the other responses of the row are still used) or "
                "correct it."
            )


def measured_field_data(X, Y, discrepancy_regression, names=None, reported=0):
    """The field data without rows where nothing was measured.

    NaN in ``Y`` marks an entry that was not measured (a sensor out); the
    modules use the measured entries. A row with no measured response is
    dropped with a warning (not for the first ``reported`` rows: an earlier
    batch's, already reported); a response measured fewer times than the
    discrepancy's regression has terms is an error naming it.

    Returns
    -------
    X, Y : ndarray
        The rows with at least one measured response.
    """
    measured = np.isfinite(Y)
    p_d = n_regression_terms(discrepancy_regression, X.shape[1])
    counts = measured.sum(axis=0)
    short = np.flatnonzero(counts <= p_d)
    if short.size:
        j = short[0]
        label = f"response {names[j]!r}" if names else f"response {j} (column {j})"
        raise ValueError(
            f"{label} of y is measured {counts[j]} time(s): module 2 needs more "
            f"measurements of each response than the {p_d} term(s) of "
            f"discrepancy_regression={discrepancy_regression!r}. Remove the "
            "response from y (and from the simulations) or measure it more."
        )
    empty = ~measured.any(axis=1)
    rows = np.flatnonzero(empty[reported:]) + reported
    if rows.size:
        warn(
            f"{rows.size} row(s) of y have no measured response (all NaN), rows "
            f"{rows[:10].tolist()}{' ...' if rows.size > 10 else ''}: they are "
            "left out, with their rows of X.",
            UserWarning,
        )
    return X[~empty], Y[~empty]


def warn_few_distinct_inputs(X, discrepancy_regression):
    """Warn when the field inputs cannot inform theta beyond the mean."""
    p_d = n_regression_terms(discrepancy_regression, X.shape[1])
    n_distinct = len(np.unique(X, axis=0))
    if n_distinct <= p_d:
        warn(
            f"X has {n_distinct} distinct row(s): with discrepancy_regression="
            f"{discrepancy_regression!r} ({p_d} term(s)) the unknown mean "
            "of the discrepancy absorbs any offset there, so the field data "
            "carry no information on theta and its posterior is the prior. "
            "Observe the system at more distinct inputs.",
            UserWarning,
        )


def checked_field_y(y):
    """The field observations ``y`` as a float array, NaN allowed (a reading
    not taken), after scikit-learn's checks of everything else.

    Raises
    ------
    ValueError
        When ``y`` is None, or not finite where it is not NaN.

    Examples
    --------
    >>> checked_field_y([1.0, float("nan")]).tolist()
    [1.0, nan]
    """
    if y is None:
        raise ValueError(
            "ModularBayesCalibrator requires y to be passed, but the target y "
            "is None: pass the field observations."
        )
    return check_array(
        y, ensure_2d=False, dtype=float, ensure_all_finite="allow-nan", input_name="y"
    )


def measured_r2(Y, pred, sample_weight=None):
    """scikit-learn's R² averaged uniformly over the columns of ``Y`` (s, q),
    each over its measured (finite) entries only; a column with fewer than
    two readings in these rows is left out of the average.

    Examples
    --------
    >>> import numpy as np
    >>> Y = np.array([[1.0, 2.0], [2.0, np.nan], [3.0, 4.0]])
    >>> measured_r2(Y, np.array([[1.0, 2.0], [2.0, 9.0], [3.0, 4.0]]))
    1.0
    """
    w = None if sample_weight is None else np.asarray(sample_weight, dtype=float)
    scores = []
    for j in range(Y.shape[1]):
        m = np.isfinite(Y[:, j])
        if m.sum() < 2:  # R² needs a spread: a response without it is left out
            continue
        scores.append(
            r2_score(Y[m, j], pred[m, j], sample_weight=None if w is None else w[m])
        )
    if not scores:
        raise ValueError(
            "y has fewer than two readings of every response in these rows: "
            "R² is not defined. Score on more rows (or with fewer gaps)."
        )
    return float(np.mean(scores))


def field_order(y):
    """``n q``, the order of the field block, from ``y`` before its checks.

    0 when ``y`` is not array-like (the checks of ``fit`` then say why).

    Examples
    --------
    >>> field_order([[1.0, 2.0], [3.0, float("nan")]]), field_order(None)
    (4, 0)
    """
    if y is None:
        return 0
    try:
        return int(np.asarray(y).size)  # no cast: complex y warns if cast
    except (TypeError, ValueError):
        return 0


# Share of the prior mass that must lie in the simulated range of theta
# (less: error), and share that may lie outside it without a warning (the
# simulator's own design leaves out 1e-3 per unbounded parameter).
_PRIOR_MASS_ERROR = 0.01


_PRIOR_MASS_WARNING = 0.02


#: Field data whose typical magnitude differs from their simulations' (over
#: the same inputs) by more than this factor, either way, are in other units.
MAGNITUDE_FACTOR = 5.0
#: A field response whose spread (interquartile range) is below this share
#: of what the design variables move its simulations by over the same
#: inputs varies far less than it can.
SPREAD_SHARE = 0.05
#: A reading this many widths of the simulated range beyond it is a single
#: slip or a logger's "no reading" code.
OUTLIER_WIDTHS = 3.0
#: Values that data loggers write for "no reading".
LOGGER_CODES = (-99999.0, -9999.0, -999.0, -32768.0, 32767.0, 9999.0, 99999.0)
#: Simulations within the field inputs' box needed to compare spreads there.
MIN_NEAR_RUNS = 10


def check_responses(X, Y, X_sim, theta_sim, y_sim, names=None, rows=None):
    """Each field response against its simulations, on both sides.

    Warns (:class:`~skmba.exceptions.FieldDataWarning`), naming the response
    and the likely cause, when its finite readings

    * hold single readings more than :data:`OUTLIER_WIDTHS` simulated widths
      beyond the simulated range, or a logger code (:data:`LOGGER_CODES`)
      outside it (named by row: mark them missing with NaN), and, without
      those,
    * are constant (a stuck sensor),
    * have the opposite sign of simulations that have one sign, at their size
      (a sign convention),
    * differ in typical magnitude (median of ``log |y|``) from one-signed
      simulations over the same inputs by more than :data:`MAGNITUDE_FACTOR`
      either way, or, for simulations of both signs, lie farther beyond
      their range than its width (units),
    * spread less than :data:`SPREAD_SHARE` of what the design variables
      move the simulations by over the field inputs (a stuck or slipping
      sensor, or units): the ``x`` part of a least-squares plane of the
      runs in ``[x, theta]``, so that the spread of the simulations over the
      prior of ``theta`` does not count (the readings come from one theta).

    "The same inputs" are the runs whose design variables lie in the box of
    the field inputs (when there are :data:`MIN_NEAR_RUNS` of them; else
    all runs, and no spread test). ``names`` name the responses and ``rows``
    the rows of ``Y`` (default: their positions).

    Examples
    --------
    >>> import warnings
    >>> X_sim = np.linspace(0.0, 1.0, 20)[:, None]
    >>> theta_sim = np.tile([2.0, 3.0], 10)[:, None]
    >>> y_sim = 1.0 + X_sim
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_responses(X_sim[::2], y_sim[::2] / 1000, X_sim, theta_sim, y_sim)
    >>> "units" in str(caught[0].message)
    True
    """
    near = _runs_near(X, X_sim)
    rows = np.arange(len(Y)) if rows is None else np.asarray(rows)
    for j in range(Y.shape[1]):
        finite = np.isfinite(Y[:, j])
        sims = y_sim[:, j][np.isfinite(y_sim[:, j])]
        if not finite.any() or sims.size < 2 or np.ptp(sims) <= 0:
            continue
        label = _response_label(names, j, Y.shape[1])
        far = finite & _far_outside(Y[:, j], sims)
        if 0 < far.sum() <= finite.sum() // 2:
            _warn_single_readings(label, rows[far], Y[far, j], sims)
            finite &= ~far
        obs = Y[finite, j]
        if obs.size >= 3 and np.ptp(obs) == 0:
            warn(
                f"The observations of {label} are all {obs[0]:.6g}: a sensor "
                "stuck at one value? Its readings carry no information; mark "
                "them missing (NaN) or leave the response out.",
                FieldDataWarning,
            )
            continue
        runs = near & np.isfinite(y_sim[:, j])
        local = y_sim[runs, j] if near.sum() >= MIN_NEAR_RUNS else sims
        cause = _scale_or_sign(obs, local, sims)
        if cause is None and near.sum() >= MIN_NEAR_RUNS:
            moved = _input_spread(X[finite], X_sim[runs], theta_sim[runs], local)
            cause = _spread(obs, moved)
        if cause is not None:
            warn(f"The observations of {label} {cause}", FieldDataWarning)


def _runs_near(X, X_sim):
    """The simulation runs whose design variables lie in the box of ``X``."""
    lo, hi = X.min(axis=0), X.max(axis=0)
    if np.any(hi <= lo):  # field inputs that do not vary: no box
        return np.zeros(len(X_sim), dtype=bool)
    return np.all((X_sim >= lo) & (X_sim <= hi), axis=1)


def _far_outside(y, sims):
    """Readings more than :data:`OUTLIER_WIDTHS` simulated widths beyond the
    simulated range, or a logger code anywhere outside it."""
    lo, hi = sims.min(), sims.max()
    width = hi - lo
    with np.errstate(invalid="ignore"):
        far = (y < lo - OUTLIER_WIDTHS * width) | (y > hi + OUTLIER_WIDTHS * width)
        code = np.isin(y, LOGGER_CODES) & ((y < lo) | (y > hi))
    return far | code


def _response_label(names, j, q):
    if names is not None:
        return f"response {names[j]!r} (column {j} of y)"
    return "the response" if q == 1 else f"response {j} (column {j} of y)"


def _warn_single_readings(label, rows, values, sims):
    codes = [v for v in values if v in LOGGER_CODES]
    what = (
        f"a logger's 'no reading' code ({codes[0]:.6g})"
        if codes
        else "slips in single readings"
    )
    shown = ", ".join(
        f"{r}: {v:.6g}" for r, v in zip(rows[:8], values[:8], strict=True)
    )
    warn(
        f"{len(rows)} reading(s) of {label} lie far outside its simulated "
        f"range [{sims.min():.4g}, {sims.max():.4g}] (row: value {shown}"
        f"{' ...' if len(rows) > 8 else ''}): {what}? Mark them missing "
        "(NaN): the noise estimate and every band would otherwise take them "
        "in.",
        FieldDataWarning,
    )


def _scale_or_sign(obs, local, sims):
    """The message of a sign or unit slip of ``obs`` against the simulations
    (``local``: over the same inputs), or None."""
    positive, negative = np.mean(local > 0), np.mean(local < 0)
    if max(positive, negative) >= 0.95:  # simulations of one sign
        sign = 1.0 if positive >= negative else -1.0
        # A reversed sign: most readings of the other sign, and of the size
        # of the simulations (a discrepancy rarely mirrors the model).
        mirrored = abs(np.log(abs(np.median(obs)) / np.median(np.abs(local))))
        if np.mean(sign * obs < 0) >= 0.75 and mirrored < np.log(3.0):
            return (
                f"have the opposite sign of its simulations (median "
                f"{np.median(obs):.4g} against {np.median(local):.4g}): a sign "
                "convention, or a model that predicts the wrong sign here? Check "
                "the sign of y against y_sim or the simulator."
            )
        size = np.abs(obs[obs != 0])
        if size.size == 0:
            return None
        ratio = np.exp(np.median(np.log(size)) - np.median(np.log(np.abs(local))))
        if ratio > MAGNITUDE_FACTOR or ratio < 1.0 / MAGNITUDE_FACTOR:
            return (
                f"are typically {ratio:.3g} times the size of its simulations "
                f"over the same inputs (median {np.median(obs):.4g} against "
                f"{np.median(local):.4g}): other units (m against mm, strain "
                "against microstrain, kN against N)? Check the units of y "
                "against y_sim or the simulator."
            )
        return None
    lo, hi = sims.min(), sims.max()
    median = float(np.median(obs))
    if max(lo - median, median - hi) > hi - lo:
        return (
            f"lie far outside the range of its simulations [{lo:.4g}, "
            f"{hi:.4g}] (median {median:.4g}): other units (mm against m, kN "
            "against N)? Check the units of y against y_sim or the simulator."
        )
    return None


def _input_spread(X, X_runs, theta_runs, y_runs):
    """The interquartile range over the field inputs ``X`` of what the design
    variables move the simulations ``y_runs`` by: the ``x`` part of their
    least-squares plane in ``[x, theta]`` (standardised columns), at ``X``.

    With theta in the plane, the runs' spread over the prior of theta is not
    counted: the readings of one structure come from one theta (measured on
    the bridge year: docs/monitoring_data.rst). None with fewer than two
    runs per coefficient of the plane, whose slopes would be noise.
    """
    Z = np.column_stack([X_runs, theta_runs])
    if len(Z) < 2 * (1 + Z.shape[1]):
        return None
    mean, sd = Z.mean(axis=0), Z.std(axis=0)
    sd[sd == 0] = 1.0
    A = np.column_stack([np.ones(len(Z)), (Z - mean) / sd])
    slopes = np.linalg.lstsq(A, y_runs, rcond=None)[0][1:] / sd
    return _iqr(X @ slopes[: X.shape[1]])


def _iqr(a):
    return np.subtract(*np.percentile(a, [75, 25]))


def _spread(obs, moved):
    """The message of a response that varies far less than the design
    variables move its simulations (``moved``, :func:`_input_spread`; None:
    not known), or None."""
    if moved is None or moved <= 0:
        return None
    q_obs = _iqr(obs)
    if obs.size < 5 or q_obs >= SPREAD_SHARE * moved:
        return None
    return (
        f"spread {q_obs / moved:.2g} times as much as the design variables move "
        "its simulations over the same inputs (interquartile ranges): a sensor "
        "stuck or slipping, or other units? Check the readings and their units "
        "against y_sim."
    )


def _constant_columns(A):
    spread = np.ptp(A, axis=0)
    return np.flatnonzero(spread <= 1e-12 * np.abs(A).max(axis=0))


def check_simulation_design(X, prior, sims, names=None):
    """Whether the simulations can support an emulator and the prior.

    ``names`` (the columns of a DataFrame ``X``) name the design variables
    in the warning on observation inputs outside the simulations.
    """
    n_sim = len(sims.X)
    fixed = _constant_columns(sims.theta)
    if fixed.size:
        raise ValueError(
            f"theta_sim column(s) {fixed.tolist()} are constant (e.g. "
            f"theta[{fixed[0]}] = {sims.theta[0, fixed[0]]:.6g} in every "
            "run): the simulations carry no information on how the model "
            "depends on theta. Vary each parameter over the prior's range "
            "in the simulations."
        )
    fixed = _constant_columns(sims.y)
    if fixed.size:
        raise ValueError(
            f"y_sim column(s) {fixed.tolist()} are constant over the "
            "simulations: a response that does not change with theta or x "
            "carries no information on theta. Remove these responses from "
            "y and y_sim."
        )
    _check_prior_coverage(prior, sims.theta, n_sim)
    # The same margin for the observation inputs: a Latin hypercube over
    # the range of X (the simulator's design) stops short of its ends.
    lo, hi = sims.X.min(axis=0), sims.X.max(axis=0)
    margin = (1.0 / max(n_sim - 1, 1) + 1e-9) * (hi - lo)
    below, above = X < lo - margin, X > hi + margin
    outside = np.any(below | above, axis=1)
    if np.any(outside):
        parts = []
        for j in np.flatnonzero(np.any(below | above, axis=0)):
            label = f"{names[j]!r}" if names is not None else f"column {j}"
            parts.append(
                f"{label}: {int(np.sum(below[:, j] | above[:, j]))} at "
                f"[{X[:, j].min():.4g}, {X[:, j].max():.4g}] against simulations "
                f"over [{lo[j]:.4g}, {hi[j]:.4g}]"
            )
        warn(
            f"{int(outside.sum())} observation input(s) lie outside the range "
            "of the simulations (widened by one mean spacing of the runs), in "
            f"the design variable(s) {'; '.join(parts)}: the emulator "
            "extrapolates there. Extend the simulation design to cover X.",
            FieldDataWarning,
        )


def _check_prior_coverage(prior, theta_sim, n_sim):
    """The prior's mass on the simulated range of theta.

    The range is widened by one mean spacing of the runs at each end: a
    space-filling design leaves about that much uncovered at the edges,
    where the emulator extrapolates harmlessly.
    """
    lo, hi = theta_sim.min(axis=0), theta_sim.max(axis=0)
    margin = (hi - lo) / max(n_sim - 1, 1)
    inside = prior.mass_inside(lo - margin, hi + margin)
    box = ", ".join(
        f"theta[{j}] in [{a:.4g}, {b:.4g}]"
        for j, (a, b) in enumerate(zip(lo, hi, strict=True))
    )
    if inside < _PRIOR_MASS_ERROR:
        raise ValueError(
            f"The prior puts {inside:.2%} of its mass on the simulated range "
            f"of theta_sim ({box}): the simulations miss the prior, and the "
            "emulator would extrapolate over all of it. Simulate over the "
            "prior's support (e.g. let the calibrator run the simulator), "
            "or correct the prior (are its units those of theta_sim?)."
        )
    if 1.0 - inside > _PRIOR_MASS_WARNING:
        warn(
            f"{1.0 - inside:.1%} of the prior mass lies outside the simulated "
            f"range of theta_sim ({box}): the emulator extrapolates there, "
            "and module 2 integrates it over the whole prior. Extend the "
            "simulations to cover the prior, or narrow the prior.",
            UserWarning,
        )


def check_same_index(X, y, names=("X", "y")):
    """Refuse pandas ``X`` and ``y`` whose row indexes differ.

    Rows are paired by position; two tables whose indexes say otherwise (a
    table sorted the other way, rows dropped from one) would be paired
    wrongly without a word. Arrays, or one table and one array, are paired
    by position.

    Examples
    --------
    >>> import pandas as pd
    >>> X = pd.DataFrame({"T": [1.0, 2.0]}, index=[10, 11])
    >>> check_same_index(X, pd.Series([0.5, 0.7], index=[11, 10]))
    Traceback (most recent call last):
    ...
    ValueError: X and y have the same row labels in another order: ...
    """
    first, second = pandas_index(X), pandas_index(y)
    if first is None or second is None or first.equals(second):
        return
    a, b = names
    if len(first) == len(second) and set(first) == set(second):
        how = "the same row labels in another order"
    else:
        shown = ", ".join(str(v) for v in list(first.difference(second))[:5])
        how = f"different row labels ({a} has {shown or 'none'} that {b} lacks)"
    raise ValueError(
        f"{a} and {b} have {how}: rows are paired by position, which these "
        f"indexes contradict. Align them first, e.g. {b} = {b}.loc[{a}.index] "
        f"(or {a}.reset_index(drop=True) and {b}.reset_index(drop=True) when "
        "position is what pairs them)."
    )


def pandas_index(A):
    """The row index of a pandas object ``A``, else None (a list's ``index``
    method is no index)."""
    index = getattr(A, "index", None)
    return index if callable(getattr(index, "equals", None)) else None


def row_labels(index, n):
    """The labels of ``n`` rows: a pandas ``index``, else 0, 1, ..."""
    return np.asarray(index) if index is not None else np.arange(n)


def prior_names(prior):
    """The parameter names of a dict prior (its keys), else None."""
    return [str(name) for name in prior] if isinstance(prior, Mapping) else None


def named_simulations(X_sim, theta_sim, y_sim, *, features, parameters, responses):
    """The simulation tables with their columns in the field data's order.

    ``features``, ``parameters`` and ``responses`` are the names of the
    columns of ``X``, of the prior and of ``y`` (None: unnamed); a
    DataFrame is reordered to them and arrays are left as they are (see
    :func:`~skmba._core.columns.match_columns`).
    """
    return (
        match_columns(X_sim, features, "X_sim", "the columns of X"),
        match_columns(theta_sim, parameters, "theta_sim", "the keys of prior"),
        match_columns(y_sim, responses, "y_sim", "the columns of y"),
    )


def simulation_tables(X, X_sim, theta_sim, y_sim, simulations):
    """``fit``'s simulations as ``(X_sim, theta_sim, y_sim)``, from the three
    tables or one :class:`~skmba.calibration._simulations.Simulations`.

    Raises
    ------
    ValueError, TypeError
        Both forms at once, another type than ``Simulations``, or tables
        that scikit-learn's cross-validation has sliced.
    """
    if simulations is None:
        check_not_sliced(X, X_sim)
        return X_sim, theta_sim, y_sim
    if not isinstance(simulations, Simulations):
        raise TypeError(
            "simulations must be a skmba.calibration.Simulations(X_sim, "
            f"theta_sim, y_sim), got {type(simulations).__name__}."
        )
    if any(a is not None for a in (X_sim, theta_sim, y_sim)):
        raise ValueError(
            "Pass the simulations either as simulations=Simulations(...) "
            "or as X_sim, theta_sim and y_sim, not both."
        )
    return simulations.X_sim, simulations.theta_sim, simulations.y_sim
