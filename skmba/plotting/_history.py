"""The posterior of the calibration parameters over time: :func:`plot_theta_history`.

One panel per parameter: the posterior mean after each update of a
monitored structure (``partial_fit``) and its 95 % interval as a band,
against the label of the update's last reading (its time), with the true
value and dated events (a repair, a damage) when given.

Examples
--------
>>> import numpy as np
>>> from skmba.plotting._history import _history_columns
>>> table = np.zeros(3, dtype=[("until", int), ("n_readings", int),
...     ("n_means", int), ("E_mean", float), ("E_sd", float),
...     ("E_2.5%", float), ("E_97.5%", float)])
>>> _history_columns(table)[1]
['E']
"""

import numpy as np

from skmba.plotting._common import (
    axes_grid,
    axis_label,
    check_true_value,
    labels,
    not_fitted_or_other,
    unit_labels,
)

__all__ = ["plot_theta_history"]

_SUFFIXES = ("_mean", "_2.5%", "_97.5%")


def plot_theta_history(
    history_or_calibrator,
    *,
    true_value=None,
    events=None,
    names=None,
    units=None,
    ax=None,
):
    """Plot the posterior of each parameter after each update, over time.

    Parameters
    ----------
    history_or_calibrator : ModularBayesCalibrator, DataFrame or structured array
        A calibrator fitted by ``fit`` and ``partial_fit``, or its
        ``theta_history_``.
    true_value : array-like of shape (r,), default=None
        Drawn as a horizontal line per parameter.
    events : dict, default=None
        ``{label: time}``: dated events (a damage, a repair) drawn as
        vertical lines, in the units of the history's index.
    names : list of str, default=None
        Parameter names for the panels; by default the history's.
    units : list of str, default=None
    ax : array of Axes, default=None
        One Axes per parameter; None creates a figure.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import pandas as pd
    >>> from skmba.plotting import plot_theta_history
    >>> history = pd.DataFrame(
    ...     {"E_mean": [30.0, 31.0], "E_2.5%": [25.0, 29.0], "E_97.5%": [36.0, 33.0]},
    ...     index=pd.to_datetime(["2025-01-31", "2025-02-28"]))
    >>> fig = plot_theta_history(history, true_value=[31.5], units=["GPa"])
    >>> fig.axes[0].get_ylabel()
    'E [GPa]'
    """
    table = history_or_calibrator
    if not _is_table(table):
        table = getattr(history_or_calibrator, "theta_history_", None)
        if table is None:
            raise not_fitted_or_other(
                history_or_calibrator,
                "ModularBayesCalibrator (or its theta_history_)",
                "plot_theta_history",
                "call fit or partial_fit",
            )
    times, recorded = _history_columns(table)
    r = len(recorded)
    shown = labels(names if names is not None else recorded, r, "θ", "parameters")
    unit = unit_labels(units, r, "parameters")
    truth = check_true_value(true_value, r)
    axes = axes_grid(ax, (r, 1), (7.0, 2.2 * r), sharex=True).ravel()
    for j, name in enumerate(recorded):
        mean, low, high = (np.asarray(table[name + s], dtype=float) for s in _SUFFIXES)
        a = axes[j]
        a.fill_between(times, low, high, color="C0", alpha=0.3, label="95 % interval")
        a.plot(times, mean, "o-", color="C0", ms=3, label="posterior mean")
        if truth is not None:
            a.axhline(truth[j], color="k", ls="--", lw=1, label="true value")
        for k, (event, when) in enumerate((events or {}).items()):
            a.axvline(when, color=f"C{k + 3}", lw=1.5, label=str(event))
        a.set_ylabel(axis_label(shown[j], unit[j]))
    axes[0].legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("until")
    return axes[0].figure


def _is_table(obj):
    """A pandas DataFrame or a structured numpy array."""
    return hasattr(obj, "columns") or getattr(
        getattr(obj, "dtype", None), "names", None
    )


def _history_columns(table):
    """The times (index, or the ``until`` field) and the parameters of a
    ``theta_history_`` table.

    Raises
    ------
    ValueError
        When the table has no ``<name>_mean``, ``_2.5%`` and ``_97.5%``
        columns.
    """
    if hasattr(table, "columns"):
        columns, times = [str(c) for c in table.columns], table.index
    else:
        columns, times = list(table.dtype.names), table["until"]
    names = [
        c[: -len("_mean")]
        for c in columns
        if c.endswith("_mean")
        and all(c[: -len("_mean")] + s in columns for s in _SUFFIXES)
    ]
    if not names:
        raise ValueError(
            "The history has no <name>_mean, <name>_2.5% and <name>_97.5% "
            "columns: pass a calibrator's theta_history_."
        )
    return times, names
