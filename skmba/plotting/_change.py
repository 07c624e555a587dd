"""A structure's control chart over time: :func:`plot_change_history`.

The relative change of each parameter per batch of readings (a
:meth:`~skmba.ChangeDetector.scan`) as bands, drawn by
:func:`~skmba.plotting.plot_theta_history`, over the evidence of each batch
against the reference: ``-log10`` of its p-value with the alarm threshold
``-log10 alpha``, alarms marked.

Examples
--------
>>> from skmba.plotting._change import _threshold
>>> round(float(_threshold(0.05)), 3)
1.301
"""

import numpy as np

from skmba.plotting._common import axes_grid
from skmba.plotting._history import plot_theta_history

__all__ = ["plot_change_history"]


def plot_change_history(scan, *, alpha=0.05, true_change=None, events=None, ax=None):
    """Plot the relative change of each parameter per batch and the alarms.

    Parameters
    ----------
    scan : DataFrame or structured array
        :meth:`ChangeDetector.scan`'s table.
    alpha : float, default=0.05
        The detector's false-alarm rate: the threshold line.
    true_change : array-like of shape (r,), default=None
        A known relative change per parameter (a simulation), drawn as a
        horizontal line.
    events : dict, default=None
        ``{label: time}``: dated events (a damage, a repair), vertical lines.
    ax : array of Axes, default=None
        ``r + 1`` Axes: one per parameter, then the evidence; None creates a
        figure.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import pandas as pd
    >>> from skmba.plotting import plot_change_history
    >>> scan = pd.DataFrame(
    ...     {"p_value": [0.4, 1e-6], "E_mean": [0.0, -0.01],
    ...      "E_2.5%": [-0.002, -0.012], "E_97.5%": [0.002, -0.008]},
    ...     index=pd.to_datetime(["2025-01-01", "2025-01-08"]))
    >>> fig = plot_change_history(scan)
    >>> fig.axes[1].get_ylabel()
    '-log10 p'
    """
    if "p_value" not in _columns(scan):
        raise ValueError(
            "scan has no p_value column: pass the table of ChangeDetector.scan."
        )
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), e.g. 0.05; got {alpha!r}.")
    r = sum(c.endswith("_mean") for c in _columns(scan))
    axes = axes_grid(ax, (r + 1, 1), (7.0, 2.0 * (r + 1)), sharex=True).ravel()
    plot_theta_history(scan, true_value=true_change, events=events, ax=axes[:r])
    for a in axes[:r]:
        a.set_ylabel(a.get_ylabel() + " change")
        a.set_xlabel("")
    times = scan.index if hasattr(scan, "index") else scan["from"]
    p = np.asarray(scan["p_value"], dtype=float)
    evidence = -np.log10(np.maximum(p, np.finfo(float).tiny))
    alarm = p < alpha
    a = axes[r]
    a.plot(times, evidence, "o-", color="C0", ms=3, label="batch")
    a.plot(np.asarray(times)[alarm], evidence[alarm], "o", color="C3", label="alarm")
    a.axhline(_threshold(alpha), color="C3", ls="--", lw=1, label=f"alpha = {alpha:g}")
    for k, when in enumerate((events or {}).values()):
        a.axvline(when, color=f"C{k + 3}", lw=1.5)
    a.set_yscale("symlog", linthresh=10.0)
    a.set_ylabel("-log10 p")
    a.set_xlabel("batch from")
    a.legend(loc="best", fontsize="small")
    return axes[0].figure


def _columns(table):
    if hasattr(table, "columns"):
        return [str(c) for c in table.columns]
    return list(getattr(getattr(table, "dtype", None), "names", None) or ())


def _threshold(alpha):
    """The alarm line: ``-log10 alpha``."""
    return -np.log10(alpha)
