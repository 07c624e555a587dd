"""Helpers shared by the figures of :mod:`skmba.plotting`.

The matplotlib import guard, the labels of responses and parameters, the
checks of the arrays the figures are given, the creation of their Axes and
the 95 % band drawn by both the GP and the calibrated-component figures.
The module is private; its names carry no underscore so that the figure
modules can share them.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> from skmba.plotting._common import axes_grid, axis_label, labels, short_number
>>> labels(None, 3, "y", "responses")
['y0', 'y1', 'y2']
>>> axis_label("E", "MPa"), short_number(6.75e8), short_number(0.0123)
('E [MPa]', '6.75e8', '0.0123')
>>> axes_grid(None, (2, 3), (6.0, 4.0)).shape
(2, 3)
"""

import numpy as np
from sklearn.exceptions import NotFittedError

# Half-width of a 95 % Gaussian band, in standard deviations.
Z95 = 1.96

BAND_ALPHA = 0.3


def import_pyplot():
    """Import ``matplotlib.pyplot``, or say how to install it."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as error:
        raise ImportError(
            "skmba.plotting needs matplotlib, which could not be imported "
            f"({error}). Install it with: pip install skmba[plot]"
        ) from error
    return plt


def _as_list(values, n, kind, what, convert):
    """``n`` entries of ``values`` (a string is one entry), converted."""
    if isinstance(values, str):
        values = [values]
    values = [convert(value) for value in values]
    if len(values) != n:
        raise ValueError(f"{kind} has {len(values)} entries but there are {n} {what}.")
    return values


def labels(names, n, prefix, what):
    """``n`` labels: the given ``names`` (checked) or ``prefix0, prefix1...``."""
    if names is None:
        return [f"{prefix}{k}" for k in range(n)]
    return _as_list(names, n, "names", what, str)


def recorded_names(estimator, attribute, n, what):
    """The ``n`` names a fitted estimator recorded in ``attribute``, or None.

    Such attributes (``parameter_names_``, ``response_names_``,
    ``feature_names_in_``) are optional: estimators fitted (and pickled)
    before they were added, fitted without names, or the stand-ins of the
    tests lack them. When present they must have ``n`` entries.
    """
    # Only the absence of the attribute is tolerated, not a wrong length.
    names = getattr(estimator, attribute, None)
    if names is None:
        return None
    names = [str(name) for name in names]
    if len(names) != n:
        raise ValueError(
            f"{type(estimator).__name__}.{attribute} has {len(names)} entries "
            f"but there are {n} {what}."
        )
    return names


def unit_labels(units, n, what):
    """``n`` unit strings ("" when none)."""
    if units is None:
        return [""] * n
    return _as_list(
        units, n, "units", what, lambda unit: "" if unit is None else str(unit)
    )


def short_number(value):
    """A short text for a number: 67843, 0.0123, 6.75e8."""
    if not np.isfinite(value) or value == 0 or 1e-3 <= abs(value) < 1e5:
        return f"{value:.5g}"
    mantissa, exponent = f"{value:.3e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def axis_label(name, unit):
    """``"name [unit]"``, or ``name`` without a unit."""
    return f"{name} [{unit}]" if unit else name


def axes_grid(ax, shape, figsize, **subplot_kw):
    """An array of Axes of ``shape``: new (ax is None) or the given ones."""
    plt = import_pyplot()
    if ax is None:
        _, axes = plt.subplots(
            *shape, figsize=figsize, squeeze=False, layout="constrained", **subplot_kw
        )
        return axes
    axes = np.asarray(ax, dtype=object)
    if axes.size != shape[0] * shape[1]:
        raise ValueError(
            f"ax must hold {shape[0] * shape[1]} Axes (a {shape[0]} x {shape[1]} "
            f"grid) for this figure, got {axes.size}."
        )
    return axes.reshape(shape)


def single_axes(ax, figsize):
    """The given Axes, or the Axes of a new figure of ``figsize``."""
    plt = import_pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def _float_array(values, name):
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers.") from None


def as_2d_response(y, n, q=None, name="y"):
    """Response values as an (n, q) float array."""
    y = _float_array(y, name)
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or len(y) != n or (q is not None and y.shape[1] != q):
        expected = f"({n},) or ({n}, {'q' if q is None else q})"
        raise ValueError(f"{name} has shape {y.shape}; expected {expected}.")
    return y


def as_inputs(X, name="X"):
    """Inputs as a non-empty (n, d) float array (a 1-D array is one input)."""
    X = _float_array(X, name)
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2 or len(X) == 0:
        raise ValueError(f"{name} must have shape (n, d); got {X.shape}.")
    return X


def check_true_value(true_value, r, detail=""):
    """The true parameters as an (r,) array, or None; ``detail`` ends the
    first part of the error message."""
    if true_value is None:
        return None
    true_value = np.atleast_1d(np.asarray(true_value, dtype=float))
    if true_value.shape != (r,):
        raise ValueError(
            f"true_value must have {r} entries{detail}; got shape {true_value.shape}."
        )
    return true_value


def predict_with_std(estimator, method, X):
    """``estimator.method(X, return_std=True)`` as two (s, q) arrays."""
    mean, std = getattr(estimator, method)(X, return_std=True)
    mean = as_2d_response(mean, len(X), name=f"{method} mean")
    std = as_2d_response(std, len(X), mean.shape[1], name=f"{method} std")
    return mean, std


def draw_band(ax, x, mean, std, color, label):
    """Mean line and 95 % band; returns the band's collection."""
    band = ax.fill_between(
        x,
        mean - Z95 * std,
        mean + Z95 * std,
        color=color,
        alpha=BAND_ALPHA,
        linewidth=0,
        label=label,
    )
    ax.plot(x, mean, color=color, linewidth=1.8, label="mean")
    return band


def not_fitted_or_other(estimator, needed, plot, action):
    """The error for an estimator that lacks the fitted attributes a plot
    needs: another kind of fitted estimator (a ``TypeError`` naming the
    kind the plot takes, ``needed``), or one not fitted yet (a
    ``NotFittedError`` saying ``action``)."""
    fitted = [k for k in vars(estimator) if k.endswith("_") and not k.startswith("_")]
    if fitted:
        return TypeError(
            f"{plot} needs a fitted {needed}; got a fitted {type(estimator).__name__}."
        )
    return NotFittedError(
        f"This {type(estimator).__name__} is not fitted: {action} before plotting."
    )
