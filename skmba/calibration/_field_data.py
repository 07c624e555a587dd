"""Checks of the field data ``X`` (design variables) and ``y``, alone and
against the simulations and the prior.

- alone: shapes, sizes and finiteness before scikit-learn's own checks, so
  that the message names the argument and the fix (:func:`check_field_data`);
  NaN in ``y`` marks a reading that was not taken
  (:func:`measured_field_data`); NaN in ``X`` and inf anywhere are errors;
- where tables meet: simulation tables matched to the field data and the
  prior by name (:func:`named_simulations`);
- ``fit``'s two forms of the simulations (:func:`simulation_tables`);
- against the simulations: field inputs outside the simulated region and
  a prior the simulations miss (:func:`check_simulation_design`); each
  response on both sides (units, sign, a stuck sensor, logger codes) is
  :func:`skmba.calibration._response_checks.check_responses`'s.

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
