"""Posterior of the calibration parameters: :func:`plot_posterior`.

A corner figure: each parameter's posterior histogram against its prior
density, credible interval and true value on the diagonal, the pairwise
draws below it and the posterior correlations above it (thesis Figs. 4.13,
4.22, 4.33).

Examples
--------
>>> import numpy as np
>>> from skmba.plotting._posterior import _axis_limits
>>> draws = np.array([[0.0, 10.0], [1.0, 30.0]])
>>> lo, hi = _axis_limits(draws, None, None, "posterior")
>>> lo.tolist(), hi.tolist()
([-0.03, 9.4], [1.03, 30.6])
"""

import numbers

import numpy as np

from skmba.plotting._common import (
    axes_grid,
    axis_label,
    check_true_value,
    labels,
    not_fitted_or_other,
    recorded_names,
    short_number,
    unit_labels,
)
from skmba.plotting._draws import (
    DrawnPrior,
    arviz_groups,
    posterior_chains,
    prior_draws,
)
from skmba.priors._theta import GaussianPrior, check_prior

__all__ = ["plot_posterior"]

_MAX_SCATTER = 2000  # posterior draws shown in a pairwise scatter
# With limits="auto", a posterior spanning less than this share of the
# prior's central 99 % interval gets an axis range of its own.
_NARROW = 0.05


def plot_posterior(
    samples_or_calibrator,
    *,
    prior=None,
    true_value=None,
    names=None,
    units=None,
    bins=40,
    kind="scatter",
    limits="auto",
    ax=None,
):
    """Plot the posterior of the calibration parameters against the prior.

    On the diagonal, the histogram of each parameter's posterior draws with
    the prior density, the 95 % credible interval and the true value
    (thesis Figs. 4.13, 4.26, 4.32); below it, the pairwise scatter (or 2-D
    histogram) of the draws with the true value marked (Figs. 4.22, 4.33);
    above it, the posterior correlation coefficients. The titles give the
    posterior mean and 95 % credible interval.

    Parameters
    ----------
    samples_or_calibrator : ModularBayesCalibrator, InferenceData or \
            array-like of shape (n, r)
        A fitted calibrator (its ``theta_samples_``, ``prior_`` and
        ``parameter_names_``), an ArviZ object such as the calibrator's
        :meth:`~skmba.ModularBayesCalibrator.to_inference_data` (the
        variables of its ``posterior`` group, of dimensions ``(chain,
        draw)``, are the parameters; its ``prior`` group, when it has the
        same variables, gives the prior's draws), or posterior draws.
    prior : prior, default=None
        A list of frozen ``scipy.stats`` distributions, a frozen
        ``multivariate_normal`` or an ``skmba`` prior, whose marginal
        densities are drawn; None uses the calibrator's, or the ArviZ
        object's prior draws, if any. The marginals of a prior given only
        by ``logpdf``/``rvs`` (``r > 1``) or by draws are histograms of its
        draws.
    true_value : array-like of shape (r,), default=None
        The true parameters, when known.
    names : list of str, default=None
        Names of the ``r`` parameters; None takes the calibrator's
        ``parameter_names_`` or the ArviZ object's variable names, else
        ``θ0, θ1, ...`` for an array.
    units : list of str, default=None
        Units of the ``r`` parameters.
    bins : int, default=40
        Histogram bins per parameter.
    kind : {"scatter", "hist2d"}, default="scatter"
        Off-diagonal panels: a scatter of at most 2000 draws (evenly
        thinned), or a 2-D histogram of all draws.
    limits : {"auto", "prior", "posterior"}, default="auto"
        Axis range of each parameter: the draws and the true value
        ("posterior"), and also the prior's central 99 % interval ("prior"),
        so that the posterior is seen against what was known before the
        data. "auto" is "prior" for the parameters whose draws span at least
        5 % of that interval and "posterior" for the others, whose histogram
        would be a needle (the prior density is still drawn over the range).
    ax : Axes or array of Axes of shape (r, r), default=None
        Where to draw; None creates a figure.

    Returns
    -------
    fig : Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from scipy import stats
    >>> from skmba.plotting import plot_posterior
    >>> rng = np.random.default_rng(0)
    >>> draws = rng.multivariate_normal([70e3, 6.8e8], [[4e6, -3e11],
    ...                                                 [-3e11, 1e17]], 1000)
    >>> prior = [stats.uniform(20e3, 80e3), stats.uniform(2.25e8, 9e8)]
    >>> fig = plot_posterior(draws, prior=prior, true_value=[70e3, 6.75e8],
    ...                      names=["E", "I"], units=["MPa", "mm$^4$"])
    >>> len(fig.axes)
    4
    >>> fig.axes[2].get_xlabel()
    'E [MPa]'

    From an ArviZ object, named by its variables:

    >>> import arviz
    >>> idata = arviz.from_dict(posterior={"E": draws[:, 0].reshape(2, 500),
    ...                                    "I": draws[:, 1].reshape(2, 500)})
    >>> fig = plot_posterior(idata)
    >>> fig.axes[2].get_xlabel(), fig.axes[3].get_xlabel()
    ('E', 'I')
    """
    samples, prior, source_names = _samples_and_prior(samples_or_calibrator, prior)
    r = samples.shape[1]
    names = labels(source_names if names is None else names, r, "θ", "parameters")
    units = unit_labels(units, r, "parameters")
    true_value = _check_options(r, kind, limits, true_value, bins)
    axes = axes_grid(ax, (r, r), (4.8 + 2.4 * (r - 1), 3.4 + 2.4 * (r - 1)))
    axis_limits = _axis_limits(samples, prior, true_value, limits)
    _draw_marginals(axes, samples, prior, true_value, names, bins, axis_limits)
    _draw_pairs(axes, samples, true_value, kind, bins, axis_limits)
    _write_correlations(axes, samples, names)
    for i in range(r):
        for j in range(i + 1):
            axes[i, j].set_xlabel(axis_label(names[j], units[j]) if i == r - 1 else "")
            if j == 0 and i > 0:
                axes[i, j].set_ylabel(axis_label(names[i], units[i]))
    handles, legend_labels = axes[0, 0].get_legend_handles_labels()
    if r > 1:
        axes[0, r - 1].legend(
            handles, legend_labels, loc="upper center", fontsize="small"
        )
    else:
        axes[0, 0].legend(fontsize="small")
    return axes[0, 0].figure


def _samples_and_prior(samples_or_calibrator, prior):
    """Posterior draws (n, r), the prior (or None) and the parameter names
    (or None) from any input."""
    obj = samples_or_calibrator
    names = None
    groups = arviz_groups(obj)
    if groups is not None:
        chains, names, _ = posterior_chains(groups)
        samples = chains.reshape(-1, chains.shape[2])
        if prior is None:
            drawn = prior_draws(groups, names)
            prior = None if drawn is None else DrawnPrior(drawn)
    elif hasattr(obj, "theta_samples_"):
        samples = np.asarray(obj.theta_samples_, dtype=float)
        if prior is None:
            prior = getattr(obj, "prior_", None)
        samples = samples.reshape(len(samples), -1)
        names = recorded_names(obj, "parameter_names_", samples.shape[1], "parameters")
    elif callable(getattr(obj, "fit", None)):
        raise not_fitted_or_other(
            obj, "ModularBayesCalibrator", "plot_posterior", "call fit"
        )
    else:
        try:
            samples = np.asarray(obj, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(
                "plot_posterior needs a fitted ModularBayesCalibrator, an ArviZ "
                "InferenceData or an array of posterior draws of shape (n, r); "
                f"got {type(obj).__name__}."
            ) from None
    if samples.ndim == 1:
        samples = samples[:, None]
    if samples.ndim != 2 or len(samples) < 2:
        raise ValueError(
            f"posterior draws must have shape (n, r) with n >= 2; got {samples.shape}."
        )
    if prior is not None and not isinstance(prior, DrawnPrior):
        prior = check_prior(prior, n_parameters=samples.shape[1])
    return samples, prior, names


def _check_options(r, kind, limits, true_value, bins):
    """Check the options of :func:`plot_posterior`; the true value as (r,)."""
    if kind not in ("scatter", "hist2d"):
        raise ValueError(f"kind must be 'scatter' or 'hist2d', got {kind!r}.")
    if limits not in ("auto", "prior", "posterior"):
        raise ValueError(
            f"limits must be 'auto', 'prior' or 'posterior', got {limits!r}."
        )
    true_value = check_true_value(true_value, r, " (one per parameter)")
    if isinstance(bins, bool) or not isinstance(bins, numbers.Integral) or bins < 1:
        raise ValueError(f"bins must be a positive integer, got {bins!r}.")
    return true_value


def _axis_limits(samples, prior, true_value, limits):
    """Lower and upper axis limits (r,) of the parameters.

    The draws and the true value, and the prior's central 99 % where asked
    (or, with "auto", where the posterior is not too narrow to be seen
    against it), padded by 3 %.
    """
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    if true_value is not None:
        lo, hi = np.minimum(lo, true_value), np.maximum(hi, true_value)
    if prior is not None and limits != "posterior":
        bounds = prior.bounds(0.99)
        wide = np.ones(len(lo), dtype=bool)
        if limits == "auto":
            wide = (hi - lo) >= _NARROW * (bounds[:, 1] - bounds[:, 0])
        lo = np.where(wide, np.minimum(lo, bounds[:, 0]), lo)
        hi = np.where(wide, np.maximum(hi, bounds[:, 1]), hi)
    pad = 0.03 * np.where(hi > lo, hi - lo, np.abs(hi) + 1.0)
    return lo - pad, hi + pad


def _draw_marginals(axes, samples, prior, true_value, names, bins, axis_limits):
    """The diagonal: histogram, credible interval, prior and true value."""
    r = samples.shape[1]
    lo, hi = axis_limits
    mean = samples.mean(axis=0)
    interval = np.quantile(samples, [0.025, 0.975], axis=0)
    prior_draws = None
    for i in range(r):
        a = axes[i, i]
        a.hist(
            samples[:, i],
            bins=bins,
            density=True,
            color="C0",
            alpha=0.6,
            label="posterior",
        )
        for value, label in zip(
            interval[:, i], ("95 % credible interval", None), strict=True
        ):
            a.axvline(value, color="C0", linestyle=":", linewidth=1.2, label=label)
        if prior is not None:
            prior_draws = _draw_prior_marginal(
                a, prior, i, (lo[i], hi[i]), bins, prior_draws
            )
        if true_value is not None:
            a.axvline(
                true_value[i], color="k", linestyle="--", linewidth=1.5, label="true"
            )
        a.set_xlim(lo[i], hi[i])
        a.set_title(
            f"{names[i]}: mean {short_number(mean[i])}\n95 % interval "
            f"[{short_number(interval[0, i])}, {short_number(interval[1, i])}]",
            fontsize="small",
        )
        if r > 1:
            a.set_yticks([])
        else:
            a.set_ylabel("density")


def _draw_prior_marginal(a, prior, i, axis_range, bins, prior_draws):
    """The prior of parameter ``i``: its density, or a histogram of draws.

    ``prior_draws`` are the prior's draws when already made (else None);
    returns them, so that a prior known only by its draws is sampled once.
    """
    # Over the axis and the prior's support, so that the curve stays whole
    # if the axis is widened afterwards.
    span = prior.bounds(0.9999)[i]
    grid = np.union1d(np.linspace(*axis_range, 400), np.linspace(*span, 400))
    density = _prior_marginal(prior, i, grid)
    if density is not None:
        a.plot(grid, density, color="C1", linewidth=1.8, label="prior")
        return prior_draws
    if prior_draws is None:
        prior_draws = prior.rvs(20000, random_state=0)
    a.hist(
        prior_draws[:, i],
        bins=bins,
        range=axis_range,
        density=True,
        histtype="step",
        color="C1",
        linewidth=1.5,
        label="prior (draws)",
    )
    return prior_draws


def _prior_marginal(prior, j, grid):
    """Marginal prior density of parameter ``j`` on ``grid`` (None: unknown)."""
    if isinstance(prior, DrawnPrior):
        return None
    if prior.dim == 1:
        return np.exp(prior.logpdf(grid[:, None]))
    distributions = getattr(prior, "distributions", None)
    if distributions is not None:
        return distributions[j].pdf(grid)
    if isinstance(prior, GaussianPrior):
        mean, sd = prior.mean()[j], np.sqrt(prior.cov()[j, j])
        return np.exp(-0.5 * ((grid - mean) / sd) ** 2) / (sd * np.sqrt(2 * np.pi))
    return None


def _draw_pairs(axes, samples, true_value, kind, bins, axis_limits):
    """Below the diagonal: the draws of each pair, with the true value."""
    n, r = samples.shape
    lo, hi = axis_limits
    for i in range(r):
        for j in range(i):
            b = axes[i, j]
            if kind == "scatter":
                step = -(-n // _MAX_SCATTER)  # ceil
                b.plot(
                    samples[::step, j],
                    samples[::step, i],
                    ".",
                    color="C0",
                    markersize=2,
                    alpha=0.4,
                    label="posterior draws",
                )
            else:
                b.hist2d(
                    samples[:, j],
                    samples[:, i],
                    bins=bins,
                    range=[[lo[j], hi[j]], [lo[i], hi[i]]],
                    cmap="Blues",
                )
            if true_value is not None:
                b.axvline(true_value[j], color="k", linestyle="--", linewidth=1)
                b.axhline(true_value[i], color="k", linestyle="--", linewidth=1)
                b.plot(
                    true_value[j],
                    true_value[i],
                    "x",
                    color="C3",
                    markersize=9,
                    markeredgewidth=2,
                    label="true",
                )
            b.set_xlim(lo[j], hi[j])
            b.set_ylim(lo[i], hi[i])


def _write_correlations(axes, samples, names):
    """Above the diagonal: the posterior correlation of each pair, as text."""
    r = samples.shape[1]
    for i in range(r):
        for j in range(i + 1, r):
            c = axes[i, j]
            c.set_axis_off()
            rho = np.corrcoef(samples[:, i], samples[:, j])[0, 1]
            c.text(
                0.5,
                0.2,
                f"corr({names[i]}, {names[j]})\n= {rho:.2f}",
                ha="center",
                va="center",
                transform=c.transAxes,
            )
