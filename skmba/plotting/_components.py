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

from skmba.plotting._common import (
    as_2d_response,
    as_inputs,
    axes_grid,
    axis_label,
    draw_band,
    labels,
    predict_with_std,
    unit_labels,
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


def plot_calibrated_components(
    calibrator,
    X,
    *,
    X_obs=None,
    y_obs=None,
    y_true=None,
    discrepancy_true=None,
    names=None,
    units=None,
    input_name=None,
    ax=None,
):
    """Plot the model, discrepancy and observation predictions (module 4).

    Columns: the model ``predict_model``, the discrepancy
    ``predict_discrepancy`` and a new observation ``predict`` (model +
    discrepancy + noise) of a fitted calibrator, each with its 95 % band
    over the posterior of ``theta``; rows: responses (thesis Figs. 4.14 and
    5.9). The observations are drawn on the model and observation panels,
    and their residuals from the model mean on the discrepancy panels.

    Parameters
    ----------
    calibrator : ModularBayesCalibrator
        Fitted, with one design variable.
    X : array-like of shape (s,) or (s, 1)
        Grid of the design variable.
    X_obs : array-like of shape (n, 1), default=None
        Observed design variable (with ``y_obs``).
    y_obs : array-like of shape (n,) or (n, q), default=None
        Observations.
    y_true : array-like of shape (s, q) or callable, default=None
        The noise-free true process at ``X`` (or a function of ``X``
        returning it, such as ``make_cantilever(...).reality``), drawn on
        the observation panels.
    discrepancy_true : array-like of shape (s, q) or callable, default=None
        The true discrepancy at ``X`` (or a function of ``X``), drawn on the
        discrepancy panels.
    names, units : list of str, default=None
        Names and units of the ``q`` responses.
    input_name : str, default=None
        Label of the design variable (with its unit).
    ax : array of Axes of shape (q, 3), default=None
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
    """
    X = _check_calibrator_and_grid(calibrator, X)
    predictions = [predict_with_std(calibrator, m, X) for m, _, _ in COMPONENTS]
    q = predictions[0][0].shape[1]
    names = labels(names, q, "y", "responses")
    units = unit_labels(units, q, "responses")
    y_true = _values_at(y_true, X, q, "y_true")
    truths = (None, _values_at(discrepancy_true, X, q, "discrepancy_true"), y_true)
    observed = _observations(calibrator, X_obs, y_obs, q)
    axes = axes_grid(ax, (q, 3), (12.0, 0.8 + 2.8 * q), sharex=True)
    order = np.argsort(X[:, 0])
    x = X[order, 0]
    for k in range(q):
        for j, (mean, std) in enumerate(predictions):
            a = axes[k, j]
            draw_band(
                a, x, mean[order, k], std[order, k], COMPONENTS[j][2], "95 % band"
            )
            truth = None if truths[j] is None else truths[j][order, k]
            _draw_overlays(a, j, x, truth, observed, k)
            if k == 0:
                a.set_title(COMPONENTS[j][1])
                a.legend(fontsize="small")
            if k == q - 1:
                a.set_xlabel(input_name or "x0")
            a.set_ylabel(axis_label(names[k], units[k]))
    return axes[0, 0].figure


def _check_calibrator_and_grid(calibrator, X):
    """``X`` as an (s, 1) array, for a calibrator of one design variable."""
    methods = [method for method, _, _ in COMPONENTS]
    if not all(callable(getattr(calibrator, m, None)) for m in methods):
        raise TypeError(
            "calibrator must be a fitted ModularBayesCalibrator (with "
            f"{', '.join(methods)}); got {type(calibrator).__name__}."
        )
    X = as_inputs(X)
    n_features = getattr(calibrator, "n_features_in_", X.shape[1])
    if X.shape[1] != 1 or n_features != 1:
        raise ValueError(
            "plot_calibrated_components draws one design variable; the "
            f"calibrator has {n_features} and X has {X.shape[1]} columns."
        )
    return X


def _values_at(values, X, q, name):
    """An array (len(X), q) from an array or a callable of ``X``."""
    if values is None:
        return None
    if callable(values):
        values = values(X)
    return as_2d_response(values, len(X), q, name)


def _observations(calibrator, X_obs, y_obs, q):
    """The observed inputs (n,), responses (n, q) and their residuals from the
    model mean (n, q); three None without observations."""
    if (X_obs is None) != (y_obs is None):
        raise ValueError("Give X_obs and y_obs together.")
    if X_obs is None:
        return None, None, None
    X_obs = as_inputs(X_obs, "X_obs")
    y_obs = as_2d_response(y_obs, len(X_obs), q, "y_obs")
    residuals = y_obs - as_2d_response(
        calibrator.predict_model(X_obs), len(X_obs), q, "predict_model"
    )
    return X_obs[:, 0], y_obs, residuals


def _draw_overlays(a, column, x, truth, observed, k):
    """What the band of response ``k`` in ``column`` is compared with.

    The discrepancy panel (column 1) shows the true discrepancy and the
    residuals of the observations; the model and observation panels show
    the observations, and the observation panel the true process.
    """
    x_obs, y_obs, residuals = observed
    if column == 1:
        if truth is not None:
            a.plot(x, truth, "k--", label="true discrepancy")
        if residuals is not None:
            a.plot(
                x_obs,
                residuals[:, k],
                **{**_OBSERVATION_STYLE, "markerfacecolor": "none"},
                label="observations - model mean",
            )
        return
    if x_obs is not None:
        a.plot(x_obs, y_obs[:, k], **_OBSERVATION_STYLE, label="observations")
    if truth is not None:
        a.plot(x, truth, "k--", label="true process (no noise)")
