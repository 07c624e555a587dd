"""Components of a calibrated prediction: :func:`plot_calibrated_components`.

The model, the discrepancy and a new observation predicted by a fitted
:class:`~skmba.ModularBayesCalibrator` (module 4), each with its 95 % band
over the posterior of ``theta``, against the observations and, when known,
the true process (thesis Figs. 4.14, 5.9).

Examples
--------
>>> from skmba.plotting._components import COMPONENTS
>>> [method for method, _, _ in COMPONENTS]
['predict_model', 'predict_discrepancy', 'predict']
"""

import numpy as np
from sklearn.utils.validation import check_is_fitted

from skmba.plotting._common import (
    as_2d_response,
    as_inputs,
    axes_grid,
    axis_label,
    draw_band,
    labels,
    predict_with_std,
    recorded_names,
    unit_labels,
)
from skmba.plotting._slices import (
    check_fixed,
    design_slices,
    slice_label,
    varied_inputs,
)

__all__ = ["plot_calibrated_components"]

# The panels of a row, left to right: the calibrator's method, the title
# and the colour of the band.
COMPONENTS = (
    ("predict_model", "model $y^m(x, \\theta)$", "C0"),
    ("predict_discrepancy", "discrepancy $\\delta(x)$", "C2"),
    ("predict", "observation $y^m + \\delta + \\varepsilon$", "C1"),
)

_OBSERVATION_STYLE = {"marker": "D", "linestyle": "", "markersize": 4, "color": "k"}

# Points along each design variable when X is None.
_N_POINTS = 50


def plot_calibrated_components(
    calibrator,
    X=None,
    *,
    vary=None,
    fixed=None,
    X_obs=None,
    y_obs=None,
    y_true=None,
    discrepancy_true=None,
    names=None,
    units=None,
    input_name=None,
    input_names=None,
    ax=None,
):
    """Plot the model, discrepancy and observation predictions (module 4).

    Columns: the model ``predict_model``, the discrepancy
    ``predict_discrepancy`` and a new observation ``predict`` (model +
    discrepancy + noise) of a fitted calibrator, each with its 95 % band
    over the posterior of ``theta``; rows: responses (thesis Figs. 4.14 and
    5.9). The observations are drawn on the model and observation panels,
    and their residuals from the model mean on the discrepancy panels.

    With several design variables, the predictions are drawn along one of
    them with the others held fixed (a slice), by default at the middle of
    their range; with ``vary=None`` or ``"all"``, one block of rows (one
    row per response) per design variable.

    Parameters
    ----------
    calibrator : ModularBayesCalibrator
        Fitted.
    X : array-like of shape (s,) or (s, d), default=None
        Where to predict: the grid of the design variable (one design
        variable), or points whose columns give the values of each varied
        design variable and whose ranges give the default fixed values
        (their middles). None: 50 points over the range of each design
        variable in the field data (``calibrator.X_obs_``).
    vary : None, "all", int, str or list, default=None
        The design variables to draw along (indices, or names in
        ``input_names``), one block of rows each. None: those that ``X``
        spans and ``fixed`` does not hold; ``"all"``: every one ``X`` spans.
    fixed : dict, default=None
        ``{design variable (index or name): value}``: where those not
        varied are held; by default the middle of their range in ``X``.
        The held values are written under the abscissa's label.
    X_obs : array-like of shape (n, d), default=None
        Observed design variables (with ``y_obs``). With several design
        variables they are drawn projected on the varied one ("projected"
        in the legend): they were observed elsewhere along the others.
    y_obs : array-like of shape (n,) or (n, q), default=None
        Observations.
    y_true : array-like of shape (s, q) or callable, default=None
        The noise-free true process at ``X`` (or a function of ``X``
        returning it, such as ``make_cantilever(...).reality``), drawn on
        the observation panels. With several design variables, an array
        only when ``X`` is itself the slice drawn.
    discrepancy_true : array-like of shape (s, q) or callable, default=None
        The true discrepancy at ``X`` (or a function of ``X``), drawn on the
        discrepancy panels; arrays as for ``y_true``.
    names, units : list of str, default=None
        Names and units of the ``q`` responses; None takes the calibrator's
        ``response_names_`` when it has them, else ``y0, y1, ...``.
    input_name : str, default=None
        Label of the design variable (with its unit) of a calibrator with
        one design variable; the same as ``input_names=[input_name]``.
    input_names : list of str, default=None
        Labels of the ``d`` design variables (with their units); None takes
        the calibrator's ``feature_names_in_`` (fitted on a DataFrame), else
        ``x0, x1, ...``.
    ax : array of Axes of shape (n_varied * q, 3), default=None
        Where to draw; None creates a figure.

    Returns
    -------
    fig : Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skmba import ModularBayesCalibrator
    >>> from skmba.datasets import make_cantilever
    >>> from skmba.plotting import plot_calibrated_components
    >>> data = make_cantilever(40, 12, random_state=2)
    >>> cal = ModularBayesCalibrator(prior=data.prior, n_restarts_optimizer=0,
    ...                              n_samples=500, random_state=0)
    >>> cal = cal.fit(data.X_obs, data.y_obs, X_sim=data.X_sim,
    ...               theta_sim=data.theta_sim, y_sim=data.y_sim)
    >>> fig = plot_calibrated_components(
    ...     cal, np.linspace(1e3, 1e4, 30), X_obs=data.X_obs, y_obs=data.y_obs,
    ...     y_true=data.reality, names=data.response_names,
    ...     units=data.response_units, input_name="force [N]")
    >>> len(fig.axes)
    6

    With two design variables, along the force at a chosen moment:

    >>> data2 = make_cantilever(40, 12, design_variables=("force", "moment"),
    ...                         random_state=2)
    >>> cal2 = ModularBayesCalibrator(prior=data2.prior, n_restarts_optimizer=0,
    ...                               n_samples=500, random_state=0)
    >>> cal2 = cal2.fit(data2.X_obs, data2.y_obs, X_sim=data2.X_sim,
    ...                 theta_sim=data2.theta_sim, y_sim=data2.y_sim)
    >>> fig = plot_calibrated_components(
    ...     cal2, vary="force", fixed={"moment": 2e7},
    ...     input_names=["force", "moment"])
    >>> print(fig.axes[-1].get_xlabel())
    force
    (moment = 2e7)
    """
    _check_calibrator(calibrator)
    X = _grid(calibrator, X)
    d = X.shape[1]
    input_names = _input_names(calibrator, input_name, input_names, d)
    fixed = check_fixed(fixed, input_names)
    slices = design_slices(X, varied_inputs(X, vary, fixed, input_names), fixed)
    points = np.vstack([s.points for s in slices])
    predictions = [predict_with_std(calibrator, m, points) for m, _, _ in COMPONENTS]
    q = predictions[0][0].shape[1]
    if names is None:
        names = recorded_names(calibrator, "response_names_", q, "responses")
    names = labels(names, q, "y", "responses")
    units = unit_labels(units, q, "responses")
    truths = (
        None,
        _values_on(discrepancy_true, X, slices, q, "discrepancy_true"),
        _values_on(y_true, X, slices, q, "y_true"),
    )
    observed = _observations(calibrator, X_obs, y_obs, q, d)
    n_rows = len(slices) * q
    axes = axes_grid(
        ax, (n_rows, 3), (12.0, 0.8 + 2.8 * n_rows), sharex=len(slices) == 1
    )
    _draw_rows(axes, slices, predictions, truths, observed, (names, units, input_names))
    return axes[0, 0].figure


def _draw_rows(axes, slices, predictions, truths, observed, axis_names):
    """One row of three panels per response and slice: the bands of
    ``predictions`` (mean, std of each component), with ``truths`` and the
    ``observed`` data; ``axis_names`` are the names and units of the responses
    and the names of the design variables."""
    names, units, input_names = axis_names
    q = predictions[0][0].shape[1]
    start = 0
    for b, design_slice in enumerate(slices):
        rows = slice(start, start + len(design_slice.points))
        start = rows.stop
        j = design_slice.vary
        for k in range(q):
            row = b * q + k
            for c, (mean, std) in enumerate(predictions):
                a = axes[row, c]
                draw_band(
                    a,
                    design_slice.x,
                    mean[rows, k],
                    std[rows, k],
                    COMPONENTS[c][2],
                    "95 % band",
                )
                truth = None if truths[c] is None else truths[c][b][:, k]
                _draw_overlays(a, c, design_slice.x, truth, observed, k, j)
                if row == 0:
                    a.set_title(COMPONENTS[c][1])
                    a.legend(fontsize="small")
                if k == q - 1:
                    a.set_xlabel(slice_label(design_slice, input_names))
                a.set_ylabel(axis_label(names[k], units[k]))


def _check_calibrator(calibrator):
    """A fitted calibrator with the three prediction methods."""
    methods = [method for method, _, _ in COMPONENTS]
    if not all(callable(getattr(calibrator, m, None)) for m in methods):
        raise TypeError(
            "calibrator must be a fitted ModularBayesCalibrator (with "
            f"{', '.join(methods)}); got {type(calibrator).__name__}."
        )
    check_is_fitted(calibrator)


def _grid(calibrator, X):
    """``X`` as an (s, d) array; by default points over the field data."""
    if X is None:
        if not hasattr(calibrator, "X_obs_"):
            raise ValueError(
                f"This {type(calibrator).__name__} keeps no field data (X_obs_): "
                "give X, the points to predict at."
            )
        X_obs = as_inputs(calibrator.X_obs_, "X_obs_")
        lo, hi = X_obs.min(axis=0), X_obs.max(axis=0)
        return np.linspace(lo, hi, _N_POINTS)
    X = as_inputs(X)
    n_features = calibrator.n_features_in_
    if X.shape[1] != n_features:
        raise ValueError(
            f"X has {X.shape[1]} columns but the calibrator has {n_features} "
            f"design variable{'s' * (n_features != 1)}: give a value of each "
            "(see vary and fixed)."
        )
    return X


def _input_names(calibrator, input_name, input_names, d):
    """The ``d`` labels of the design variables."""
    if input_name is not None:
        if input_names is not None:
            raise ValueError("Give input_name or input_names, not both.")
        if d != 1:
            raise ValueError(
                f"input_name labels one design variable; the calibrator has {d}: "
                "give input_names."
            )
        input_names = [input_name]
    if input_names is None:
        input_names = recorded_names(calibrator, "feature_names_in_", d, "inputs")
    return labels(input_names, d, "x", "design variables")


def _values_on(values, X, slices, q, name):
    """Per slice, an array (s_b, q): from a callable of the points, or from
    an array at ``X`` when the slices are rows of ``X``."""
    if values is None:
        return None
    if callable(values):
        return [
            as_2d_response(values(s.points), len(s.points), q, name) for s in slices
        ]
    values = as_2d_response(values, len(X), q, name)
    if any(s.order is None for s in slices):
        raise ValueError(
            f"{name} is given at X, but the points drawn are not the rows of X "
            "(several design variables, X not a slice along the varied one): "
            f"give {name} as a function of X."
        )
    return [values[s.order] for s in slices]


def _observations(calibrator, X_obs, y_obs, q, d):
    """The observed design variables (n, d), responses (n, q) and their
    residuals from the model mean (n, q); three None without observations."""
    if (X_obs is None) != (y_obs is None):
        raise ValueError("Give X_obs and y_obs together.")
    if X_obs is None:
        return None, None, None
    X_obs = as_inputs(X_obs, "X_obs")
    if X_obs.shape[1] != d:
        raise ValueError(f"X_obs has {X_obs.shape[1]} columns but X has {d}.")
    y_obs = as_2d_response(y_obs, len(X_obs), q, "y_obs")
    residuals = y_obs - as_2d_response(
        calibrator.predict_model(X_obs), len(X_obs), q, "predict_model"
    )
    return X_obs, y_obs, residuals


def _draw_overlays(a, column, x, truth, observed, k, j):
    """What the band of response ``k`` in ``column`` is compared with, along
    design variable ``j``.

    The discrepancy panel (column 1) shows the true discrepancy and the
    residuals of the observations; the model and observation panels show
    the observations, and the observation panel the true process. With
    several design variables the observations are projected on ``j``.
    """
    X_obs, y_obs, residuals = observed
    suffix = "" if X_obs is None or X_obs.shape[1] == 1 else " (projected)"
    if column == 1:
        if truth is not None:
            a.plot(x, truth, "k--", label="true discrepancy")
        if residuals is not None:
            a.plot(
                X_obs[:, j],
                residuals[:, k],
                **{**_OBSERVATION_STYLE, "markerfacecolor": "none"},
                label="observations - model mean" + suffix,
            )
        return
    if X_obs is not None:
        a.plot(
            X_obs[:, j],
            y_obs[:, k],
            **_OBSERVATION_STYLE,
            label="observations" + suffix,
        )
    if truth is not None:
        a.plot(x, truth, "k--", label="true process (no noise)")
