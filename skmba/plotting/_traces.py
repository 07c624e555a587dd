"""MCMC trace plots: :func:`plot_traces`.

One panel per calibration parameter, one line per chain, with the
rank-normalised split R-hat of the parameter in the panel's title (thesis
Fig. 4.21).

Examples
--------
>>> from types import SimpleNamespace
>>> import numpy as np
>>> from skmba.plotting._traces import _chains_of
>>> fitted = SimpleNamespace(theta_chains_=np.zeros((4, 300, 2)))
>>> chains, names = _chains_of(fitted)
>>> chains.shape, names
((4, 300, 2), None)
"""

import numpy as np

from skmba.mcmc._diagnostics import split_rhat
from skmba.plotting._common import (
    axes_grid,
    axis_label,
    check_true_value,
    labels,
    not_fitted_or_other,
    recorded_names,
    unit_labels,
)
from skmba.plotting._draws import arviz_groups, posterior_chains

__all__ = ["plot_traces"]


def plot_traces(
    chains_or_calibrator, *, names=None, units=None, true_value=None, ax=None
):
    """Plot MCMC trace plots: one panel per parameter, one line per chain.

    Well-mixed chains overlap as stationary noise around the same level
    (thesis Fig. 4.21); a chain stuck apart, a trend or long excursions
    mean that more burn-in or more draws are needed. Each panel's title
    gives the rank-normalised split R-hat (below 1.01 when mixed).

    Parameters
    ----------
    chains_or_calibrator : ModularBayesCalibrator, InferenceData or \
            array-like of shape (n_chains, n_draws, r)
        A calibrator fitted with ``sampler="mcmc"`` (its ``theta_chains_``
        and ``parameter_names_``), an ArviZ object such as the calibrator's
        :meth:`~skmba.ModularBayesCalibrator.to_inference_data` (the
        variables of its ``posterior`` group, of dimensions ``(chain,
        draw)``, are the parameters) or the draws of each chain after
        burn-in.
    names : list of str, default=None
        Names of the ``r`` parameters; None takes the calibrator's
        ``parameter_names_`` or the ArviZ object's variable names, else
        ``θ0, θ1, ...`` for an array.
    units : list of str, default=None
        Units of the ``r`` parameters.
    true_value : array-like of shape (r,), default=None
        The true parameters, drawn as horizontal lines.
    ax : Axes or array of Axes of shape (r,), default=None
        Where to draw; None creates a figure.

    Returns
    -------
    fig : Figure

    Raises
    ------
    ValueError
        If the calibrator (or its ArviZ object) has no chains (one
        parameter, quadrature posterior) or the array is not 3-D.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skmba.plotting import plot_traces
    >>> chains = np.random.default_rng(0).normal(size=(4, 300, 2))
    >>> fig = plot_traces(chains, names=["E", "I"])
    >>> len(fig.axes), len(fig.axes[0].lines)
    (2, 4)

    From an ArviZ object, named by its variables:

    >>> import arviz
    >>> idata = arviz.from_dict(posterior={"E": chains[..., 0], "I": chains[..., 1]})
    >>> fig = plot_traces(idata)
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['E', 'I']
    """
    chains, source_names = _chains_of(chains_or_calibrator)
    n_chains, n_draws, r = chains.shape
    names = labels(source_names if names is None else names, r, "θ", "parameters")
    units = unit_labels(units, r, "parameters")
    true_value = check_true_value(true_value, r)
    axes = axes_grid(ax, (r, 1), (8.0, 0.8 + 2.2 * r), sharex=True)[:, 0]
    draws = np.arange(1, n_draws + 1)
    for p, a in enumerate(axes):
        for c in range(n_chains):
            a.plot(
                draws,
                chains[c, :, p],
                linewidth=0.6,
                alpha=0.75,
                color=f"C{c % 10}",
                label=f"chain {c + 1}",
            )
        if true_value is not None:
            a.axhline(true_value[p], color="k", linestyle="--", label="true")
        a.set_ylabel(axis_label(names[p], units[p]))
        a.set_title(
            f"{names[p]}: split R-hat = {split_rhat(chains[:, :, p]):.3f}",
            fontsize="small",
        )
        a.set_xlim(1, n_draws)
    axes[-1].set_xlabel("draw (after burn-in)")
    axes[0].legend(fontsize="small", ncols=min(n_chains + 1, 6), loc="upper right")
    return axes[0].figure


def _chains_of(chains_or_calibrator):
    """The chains (n_chains, n_draws, r) of a fitted calibrator, an ArviZ
    object or an array, and the parameter names (None for an array)."""
    obj = chains_or_calibrator
    names = None
    groups = arviz_groups(obj)
    if groups is not None:
        chains, names, sampler = posterior_chains(groups)
        if sampler.startswith("quadrature"):
            raise ValueError(
                "This posterior was computed by quadrature (one parameter): its "
                "draws are independent, not a Markov chain, and have no trace. "
                "Fit with sampler='mcmc' to get chains, or plot the posterior "
                "with plot_posterior."
            )
    elif hasattr(obj, "theta_chains_"):
        chains = obj.theta_chains_
    elif hasattr(obj, "theta_nodes_"):
        raise ValueError(
            "This calibrator has no MCMC chains: its one-parameter posterior "
            "was computed by quadrature. Fit it with sampler='mcmc' to get "
            "chains, or plot the posterior with plot_posterior."
        )
    elif hasattr(obj, "theta_samples_"):
        raise ValueError(
            "This calibrator has no theta_chains_ attribute: pass the chains "
            "as an array of shape (n_chains, n_draws, r) instead."
        )
    elif callable(getattr(obj, "fit", None)):
        raise not_fitted_or_other(
            obj,
            "ModularBayesCalibrator",
            "plot_traces",
            "call fit with sampler='mcmc'",
        )
    else:
        chains = obj
    try:
        chains = np.asarray(chains, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            "plot_traces needs a fitted ModularBayesCalibrator, an ArviZ "
            "InferenceData or an array of shape (n_chains, n_draws, r); got "
            f"{type(obj).__name__}."
        ) from None
    if chains.ndim != 3:
        raise ValueError(
            f"chains must have shape (n_chains, n_draws, r); got {chains.shape}."
        )
    if hasattr(obj, "theta_chains_"):
        names = recorded_names(obj, "parameter_names_", chains.shape[2], "parameters")
    return chains, names
