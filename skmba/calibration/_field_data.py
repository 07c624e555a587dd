"""Checks of the field observations ``X`` (design variables) and ``y``.

Shapes, sizes and finiteness before scikit-learn's own checks, so that the
message names the argument and the fix. NaN in ``y`` marks a reading that
was not taken (:func:`measured_field_data`); NaN in ``X`` and inf anywhere
are errors.

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._field_data import check_field_data
>>> check_field_data(np.zeros((3, 1)), np.zeros((2, 1)), "constant")
Traceback (most recent call last):
...
ValueError: X and y have 3 and 2 rows: y must hold one row of observed responses per row of field inputs X.
"""  # noqa: E501

import numpy as np
from sklearn.metrics import r2_score
from sklearn.utils import check_array

from skmba._core.regression import n_regression_terms
from skmba._core.warn import warn
from skmba.calibration._simulations import as_array, check_2d, check_finite_rows


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


def measured_field_data(X, Y, discrepancy_regression, names=None):
    """The field data without rows where nothing was measured.

    NaN in ``Y`` marks an entry that was not measured (a sensor out); the
    modules use the measured entries. A row with no measured response is
    dropped with a warning; a response measured fewer times than the
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
    if empty.any():
        rows = np.flatnonzero(empty)
        warn(
            f"{rows.size} row(s) of y have no measured response (all NaN), rows "
            f"{rows[:10].tolist()}{' ...' if rows.size > 10 else ''}: they are "
            "left out, with their rows of X.",
            UserWarning,
        )
        X, Y = X[~empty], Y[~empty]
    return X, Y


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
    each over its measured (finite) entries only.

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
        scores.append(
            r2_score(Y[m, j], pred[m, j], sample_weight=None if w is None else w[m])
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
