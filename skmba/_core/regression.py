"""Polynomial regression bases of the DACE toolbox (thesis Table 3.1, Eq. 3.2).

The prior mean of every Gaussian process in :mod:`skmba` is ``H(x) beta`` with
``H`` one of three nested polynomial bases:

============  =====  ======================  ==========================
name          order  number of terms ``p``    basis functions
============  =====  ======================  ==========================
"constant"    0      1                       1
"linear"      1      d + 1                   1, x_1, ..., x_d
"quadratic"   2      (d + 1)(d + 2) / 2      linear terms, then x_i x_j
                                             for i <= j in the order of
                                             Eq. 3.2
============  =====  ======================  ==========================

Examples
--------
>>> import numpy as np
>>> from skmba._core.regression import regression_basis
>>> regression_basis(np.array([[1.0, 2.0]]), "quadratic")
array([[1., 1., 2., 1., 2., 4.]])
"""

import numpy as np

REGRESSIONS = ("constant", "linear", "quadratic")


def check_regression(regression):
    """Validate a regression name and return it.

    Parameters
    ----------
    regression : str
        One of ``"constant"``, ``"linear"`` or ``"quadratic"``.

    Returns
    -------
    regression : str

    Examples
    --------
    >>> check_regression("linear")
    'linear'
    """
    if not isinstance(regression, str) or regression not in REGRESSIONS:
        raise ValueError(
            f"regression={regression!r} is not supported; use one of "
            f"{', '.join(repr(r) for r in REGRESSIONS)} (thesis Table 3.1)."
        )
    return regression


def n_regression_terms(regression, n_features):
    """Number of basis functions ``p`` of a regression family in ``d`` inputs.

    Parameters
    ----------
    regression : {"constant", "linear", "quadratic"}
    n_features : int
        Number of input dimensions ``d``.

    Returns
    -------
    p : int

    Examples
    --------
    >>> [n_regression_terms(r, 3) for r in ("constant", "linear", "quadratic")]
    [1, 4, 10]
    """
    check_regression(regression)
    d = int(n_features)
    return {"constant": 1, "linear": d + 1, "quadratic": (d + 1) * (d + 2) // 2}[
        regression
    ]


def regression_basis(X, regression):
    """Evaluate the regression matrix ``H(X)`` (thesis Eqs. 3.1-3.2).

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
    regression : {"constant", "linear", "quadratic"}

    Returns
    -------
    H : ndarray of shape (n_samples, p)
        Columns ordered as in Eq. 3.2: the constant, the linear terms
        ``x_1 .. x_d``, then ``x_1 x_1, x_1 x_2, ..., x_1 x_d, x_2 x_2, ...,
        x_d x_d``.

    Examples
    --------
    >>> import numpy as np
    >>> regression_basis(np.array([[2.0], [3.0]]), "linear")
    array([[1., 2.],
           [1., 3.]])
    """
    check_regression(regression)
    X = np.asarray(X, dtype=float)
    n, d = X.shape
    columns = [np.ones((n, 1))]
    if regression in ("linear", "quadratic"):
        columns.append(X)
    if regression == "quadratic":
        rows, cols = np.triu_indices(d)
        columns.append(X[:, rows] * X[:, cols])
    return np.hstack(columns)
