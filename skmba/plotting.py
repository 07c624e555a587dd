"""Figures for Gaussian processes, calibration and sensor design.

The functions of this module draw what the numbers of :mod:`skmba` mean:
prediction bands of a :class:`~skmba.MultiResponseGP`, the model,
discrepancy and observation components of a calibrated
:class:`~skmba.ModularBayesCalibrator` (thesis Figs. 4.14, 5.9), posteriors
of the calibration parameters against their prior and the truth (Figs.
4.13, 4.22, 4.33), MCMC traces (Fig. 4.21), and the criteria of a
preposterior sensor design (Figs. 6.3, 6.5, 6.7).

matplotlib is an optional dependency (``pip install skmba[plot]``); it is
imported when a function is called, not when :mod:`skmba` is imported.

Conventions:

* 95 % bands are ``mean ± 1.96 std``.
* ``names`` label the responses (or the parameters); by default they are
  ``y0, y1, ...`` (responses), ``θ0, θ1, ...`` (parameters) and ``x0, x1,
  ...`` (inputs), 0-based like the columns they label. ``units`` add
  ``" [unit]"`` to the axis labels.
* ``ax`` is where to draw: an Axes, or an array of Axes for multi-panel
  figures, or None to create a new figure. A function that draws one panel
  returns its Axes; one that draws several returns the Figure.
"""

import numbers
import textwrap

import numpy as np
from sklearn.exceptions import NotFittedError

from skmba._priors import GaussianPrior, check_prior
from skmba._sampling import split_rhat

__all__ = [
    "plot_calibrated_components",
    "plot_convergence",
    "plot_criterion_by_size",
    "plot_criterion_vs_bias",
    "plot_gp_prediction",
    "plot_posterior",
    "plot_traces",
]

# Half-width of a 95 % Gaussian band, in standard deviations.
_Z95 = 1.96

_BAND_ALPHA = 0.3
_MAX_SCATTER = 2000  # posterior draws shown in a pairwise scatter
# With limits="auto", a posterior spanning less than this share of the
# prior's central 99 % interval gets an axis range of its own.
_NARROW = 0.05


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------


def _pyplot():
    """Import ``matplotlib.pyplot``, or say how to install it."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as error:
        raise ImportError(
            "skmba.plotting needs matplotlib, which could not be imported "
            f"({error}). Install it with: pip install skmba[plot]"
        ) from error
    return plt


def _names(names, n, prefix, what):
    """``n`` labels: the given ``names`` (checked) or ``prefix0, prefix1...``."""
    if names is None:
        return [f"{prefix}{k}" for k in range(n)]
    if isinstance(names, str):
        names = [names]
    names = [str(name) for name in names]
    if len(names) != n:
        raise ValueError(f"names has {len(names)} entries but there are {n} {what}.")
    return names


def _units(units, n, what):
    """``n`` unit strings ("" when none)."""
    if units is None:
        return [""] * n
    if isinstance(units, str):
        units = [units]
    units = ["" if unit is None else str(unit) for unit in units]
    if len(units) != n:
        raise ValueError(f"units has {len(units)} entries but there are {n} {what}.")
    return units


def _number(value):
    """A short text for a number: 67843, 0.0123, 6.75e8."""
    if not np.isfinite(value) or value == 0 or 1e-3 <= abs(value) < 1e5:
        return f"{value:.5g}"
    mantissa, exponent = f"{value:.3e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def _label(name, unit):
    return f"{name} [{unit}]" if unit else name


def _axes_grid(ax, shape, figsize, **subplot_kw):
    """An array of Axes of ``shape``: new (ax is None) or the given ones."""
    plt = _pyplot()
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


def _check_fitted_attributes(obj, attributes, what):
    """Raise a clear error when ``obj`` lacks the fitted ``attributes``."""
    missing = [a for a in attributes if getattr(obj, a, None) is None]
    if not missing:
        return
    if callable(getattr(obj, "fit", None)):
        raise NotFittedError(
            f"This {type(obj).__name__} is not fitted (no {', '.join(missing)}): "
            f"call fit before plotting."
        )
    raise TypeError(
        f"Expected {what} with the attributes {', '.join(attributes)}; got an "
        f"object of type {type(obj).__name__}."
    )


def _as_2d_response(y, n, q=None, name="y"):
    """Response values as an (n, q) float array."""
    try:
        y = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers.") from None
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or len(y) != n or (q is not None and y.shape[1] != q):
        expected = f"({n},) or ({n}, {'q' if q is None else q})"
        raise ValueError(f"{name} has shape {y.shape}; expected {expected}.")
    return y


def _as_inputs(X, name="X"):
    try:
        X = np.asarray(X, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers.") from None
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2 or len(X) == 0:
        raise ValueError(f"{name} must have shape (n, d); got {X.shape}.")
    return X


def _predict(estimator, method, X):
    """``estimator.method(X, return_std=True)`` as two (s, q) arrays."""
    mean, std = getattr(estimator, method)(X, return_std=True)
    mean = _as_2d_response(mean, len(X), name=f"{method} mean")
    std = _as_2d_response(std, len(X), mean.shape[1], name=f"{method} std")
    return mean, std


def _band(ax, x, mean, std, color, label):
    """Mean line and 95 % band; returns the band's collection."""
    band = ax.fill_between(
        x,
        mean - _Z95 * std,
        mean + _Z95 * std,
        color=color,
        alpha=_BAND_ALPHA,
        linewidth=0,
        label=label,
    )
    ax.plot(x, mean, color=color, linewidth=1.8, label="mean")
    return band


# --------------------------------------------------------------------------
# Gaussian processes and calibrated predictions
# --------------------------------------------------------------------------


def plot_gp_prediction(
    gp,
    X,
    *,
    X_train=None,
    y_train=None,
    response=None,
    include_noise=False,
    names=None,
    units=None,
    input_names=None,
    ax=None,
):
    """Plot the predictions of a Gaussian process with 95 % bands.

    For one input, the mean with the band ``mean ± 1.96 std`` and the
    training data, one panel per response. For two inputs, per response
    two filled-contour panels: the mean and the half-width ``1.96 std`` of
    the 95 % band, with the training inputs marked.

    Parameters
    ----------
    gp : estimator
        A fitted :class:`~skmba.MultiResponseGP`, or any regressor with
        ``predict(X, return_std=True)``. The band of a ``MultiResponseGP``
        is that of the latent (noise-free) process unless ``include_noise``.
    X : array-like of shape (s,), (s, 1) or (s, 2)
        Where to predict: a 1-D grid (any order), or points of the plane
        (scattered or a flattened grid; contours are drawn on their
        triangulation).
    X_train : array-like of shape (n, d), default=None
        Training inputs to mark.
    y_train : array-like of shape (n,) or (n, q), default=None
        Training responses, drawn as points for one input (needs
        ``X_train``). Without them, the training inputs are marked along
        the bottom of the panels.
    response : int or str, default=None
        Only this response (its index, or its name in ``names``); None
        draws all.
    include_noise : bool, default=False
        Add the fitted noise variance ``gp.noise_`` to the variance, for a
        band of a new (noisy) measurement.
    names, units : list of str, default=None
        Names and units of the ``q`` responses.
    input_names : list of str, default=None
        Labels of the inputs (with their units), e.g. ``["force [N]"]``.
    ax : Axes or array of Axes, default=None
        Where to draw: one Axes per response drawn (one input) or an array
        of shape (n_responses_drawn, 2) (two inputs). None creates a figure.

    Returns
    -------
    ax_or_fig : Axes or Figure
        The Axes when one panel is drawn (one input and one response),
        otherwise the Figure.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skmba import MultiResponseGP
    >>> from skmba.plotting import plot_gp_prediction
    >>> X = np.linspace(0, 1, 8)[:, None]
    >>> y = np.column_stack([np.sin(4 * X[:, 0]), X[:, 0] ** 2])
    >>> gp = MultiResponseGP().fit(X, y)
    >>> fig = plot_gp_prediction(gp, np.linspace(0, 1, 50), X_train=X, y_train=y,
    ...                          names=["sine", "square"])
    >>> len(fig.axes)
    2
    >>> ax = plot_gp_prediction(gp, np.linspace(0, 1, 50), response="square",
    ...                         names=["sine", "square"])
    >>> ax.get_ylabel()
    'square'
    """
    if not callable(getattr(gp, "predict", None)):
        raise TypeError(
            "gp must be a fitted regressor with predict(X, return_std=True), "
            f"such as skmba.MultiResponseGP; got {type(gp).__name__}."
        )
    X = _as_inputs(X)
    d = X.shape[1]
    if d > 2:
        raise ValueError(
            f"plot_gp_prediction draws one or two inputs; X has {d} columns. "
            "Fix the other inputs and wrap the GP, or plot a slice."
        )
    plt = _pyplot()
    mean, std = _predict(gp, "predict", X)
    q = mean.shape[1]
    if include_noise:
        noise = getattr(gp, "noise_", None)
        if noise is None:
            raise ValueError(
                "include_noise=True needs a GP fitted with noise (attribute "
                "noise_, e.g. MultiResponseGP(noise=True))."
            )
        std = np.sqrt(std**2 + np.broadcast_to(np.asarray(noise, dtype=float), (q,)))
    names = _names(names, q, "y", "responses")
    units = _units(units, q, "responses")
    input_names = _names(input_names, d, "x", "inputs")
    if response is None:
        drawn = list(range(q))
    elif isinstance(response, str):
        if response not in names:
            raise ValueError(f"response {response!r} is not one of {names}.")
        drawn = [names.index(response)]
    elif isinstance(response, numbers.Integral) and -q <= response < q:
        drawn = [int(response) % q]
    else:
        raise ValueError(
            f"response must be None, a name or an index in [0, {q}), got {response!r}."
        )
    if X_train is not None:
        X_train = _as_inputs(X_train, "X_train")
        if X_train.shape[1] != d:
            raise ValueError(f"X_train has {X_train.shape[1]} columns but X has {d}.")
    if y_train is not None:
        if X_train is None:
            raise ValueError("y_train needs X_train.")
        y_train = _as_2d_response(y_train, len(X_train), q, "y_train")
    band_label = "95 % band, new measurement" if include_noise else "95 % band"

    if d == 1:
        n = len(drawn)
        new_figure = ax is None
        axes = _axes_grid(ax, (n, 1), (6.4, 1.0 + 2.6 * n), sharex=True)[:, 0]
        order = np.argsort(X[:, 0])
        x = X[order, 0]
        for a, k in zip(axes, drawn, strict=True):
            _band(a, x, mean[order, k], std[order, k], "C0", band_label)
            if y_train is not None:
                a.plot(
                    X_train[:, 0],
                    y_train[:, k],
                    "o",
                    color="C3",
                    markersize=4,
                    label="training data",
                )
            elif X_train is not None:
                a.plot(
                    X_train[:, 0],
                    np.zeros(len(X_train)),
                    "|",
                    color="C3",
                    markersize=10,
                    transform=a.get_xaxis_transform(),
                    label="training inputs",
                )
            a.set_ylabel(_label(names[k], units[k]))
            if not new_figure or a is axes[-1]:  # a new figure shares x
                a.set_xlabel(input_names[0])
            a.legend(fontsize="small")
        return axes[0] if n == 1 else axes[0].figure

    axes = _axes_grid(ax, (len(drawn), 2), (9.0, 0.6 + 3.4 * len(drawn)))
    for row, k in zip(axes, drawn, strict=True):
        panels = (
            (mean[:, k], f"{names[k]}: mean", "viridis"),
            (_Z95 * std[:, k], f"{names[k]}: 95 % half-width", "YlOrRd"),
        )
        for a, (values, title, cmap) in zip(row, panels, strict=True):
            filled = a.tricontourf(X[:, 0], X[:, 1], values, levels=15, cmap=cmap)
            colorbar = a.figure.colorbar(filled, ax=a)
            colorbar.set_label(_label(names[k], units[k]))
            if X_train is not None:
                a.plot(
                    X_train[:, 0],
                    X_train[:, 1],
                    "o",
                    markerfacecolor="white",
                    markeredgecolor="black",
                    markersize=4,
                    label="training inputs",
                )
                a.legend(fontsize="small", loc="upper right")
            a.set_title(title)
            a.set_xlabel(input_names[0])
            a.set_ylabel(input_names[1])
    plt.setp(axes, xlim=(X[:, 0].min(), X[:, 0].max()))
    return axes[0, 0].figure


_COMPONENTS = (
    ("predict_model", "model $y^m(x, \\theta)$", "C0"),
    ("predict_discrepancy", "discrepancy $\\delta(x)$", "C2"),
    ("predict", "observation $y^m + \\delta + \\varepsilon$", "C1"),
)


def _values_at(values, X, q, name):
    """An array (len(X), q) from an array or a callable of ``X``."""
    if values is None:
        return None
    if callable(values):
        values = values(X)
    return _as_2d_response(values, len(X), q, name)


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
    methods = [method for method, _, _ in _COMPONENTS]
    if not all(callable(getattr(calibrator, m, None)) for m in methods):
        raise TypeError(
            "calibrator must be a fitted ModularBayesCalibrator (with "
            f"{', '.join(methods)}); got {type(calibrator).__name__}."
        )
    X = _as_inputs(X)
    n_features = getattr(calibrator, "n_features_in_", X.shape[1])
    if X.shape[1] != 1 or n_features != 1:
        raise ValueError(
            "plot_calibrated_components draws one design variable; the "
            f"calibrator has {n_features} and X has {X.shape[1]} columns."
        )
    predictions = [_predict(calibrator, method, X) for method in methods]
    q = predictions[0][0].shape[1]
    names = _names(names, q, "y", "responses")
    units = _units(units, q, "responses")
    y_true = _values_at(y_true, X, q, "y_true")
    discrepancy_true = _values_at(discrepancy_true, X, q, "discrepancy_true")
    if (X_obs is None) != (y_obs is None):
        raise ValueError("Give X_obs and y_obs together.")
    residuals = None
    if X_obs is not None:
        X_obs = _as_inputs(X_obs, "X_obs")
        y_obs = _as_2d_response(y_obs, len(X_obs), q, "y_obs")
        residuals = y_obs - _as_2d_response(
            calibrator.predict_model(X_obs), len(X_obs), q, "predict_model"
        )
    axes = _axes_grid(ax, (q, 3), (12.0, 0.8 + 2.8 * q), sharex=True)
    order = np.argsort(X[:, 0])
    x = X[order, 0]
    obs_style = {"marker": "D", "linestyle": "", "markersize": 4, "color": "k"}
    for k in range(q):
        for j, ((mean, std), (_, title, color)) in enumerate(
            zip(predictions, _COMPONENTS, strict=True)
        ):
            a = axes[k, j]
            _band(a, x, mean[order, k], std[order, k], color, "95 % band")
            if j == 1 and discrepancy_true is not None:
                a.plot(x, discrepancy_true[order, k], "k--", label="true discrepancy")
            if j == 1 and residuals is not None:
                a.plot(
                    X_obs[:, 0],
                    residuals[:, k],
                    **{**obs_style, "markerfacecolor": "none"},
                    label="observations - model mean",
                )
            if j != 1 and X_obs is not None:
                a.plot(X_obs[:, 0], y_obs[:, k], **obs_style, label="observations")
            if j == 2 and y_true is not None:
                a.plot(x, y_true[order, k], "k--", label="true process (no noise)")
            if k == 0:
                a.set_title(title)
                a.legend(fontsize="small")
            if k == q - 1:
                a.set_xlabel(input_name or "x0")
            a.set_ylabel(_label(names[k], units[k]))
    return axes[0, 0].figure


# --------------------------------------------------------------------------
# posterior of the calibration parameters
# --------------------------------------------------------------------------


def _samples_and_prior(samples_or_calibrator, prior):
    """Posterior draws (n, r) and the prior (or None) from either input."""
    obj = samples_or_calibrator
    if hasattr(obj, "theta_samples_"):
        samples = np.asarray(obj.theta_samples_, dtype=float)
        if prior is None:
            prior = getattr(obj, "prior_", None)
    elif callable(getattr(obj, "fit", None)):
        raise NotFittedError(
            f"This {type(obj).__name__} is not fitted (no theta_samples_): call "
            "fit before plotting its posterior."
        )
    else:
        try:
            samples = np.asarray(obj, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(
                "plot_posterior needs a fitted ModularBayesCalibrator or an "
                "array of posterior draws of shape (n, r); got "
                f"{type(obj).__name__}."
            ) from None
    if samples.ndim == 1:
        samples = samples[:, None]
    if samples.ndim != 2 or len(samples) < 2:
        raise ValueError(
            f"posterior draws must have shape (n, r) with n >= 2; got {samples.shape}."
        )
    if prior is not None:
        prior = check_prior(prior, n_parameters=samples.shape[1])
    return samples, prior


def _prior_marginal(prior, j, grid):
    """Marginal prior density of parameter ``j`` on ``grid`` (None: unknown)."""
    if prior.dim == 1:
        return np.exp(prior.logpdf(grid[:, None]))
    distributions = getattr(prior, "distributions", None)
    if distributions is not None:
        return distributions[j].pdf(grid)
    if isinstance(prior, GaussianPrior):
        mean, sd = prior.mean()[j], np.sqrt(prior.cov()[j, j])
        return np.exp(-0.5 * ((grid - mean) / sd) ** 2) / (sd * np.sqrt(2 * np.pi))
    return None


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
    samples_or_calibrator : ModularBayesCalibrator or array-like of shape (n, r)
        A fitted calibrator (its ``theta_samples_`` and ``prior_`` are used)
        or posterior draws.
    prior : prior, default=None
        A list of frozen ``scipy.stats`` distributions, a frozen
        ``multivariate_normal`` or an ``skmba`` prior, whose marginal
        densities are drawn; None uses the calibrator's, if any. The
        marginals of a prior given only by ``logpdf``/``rvs`` (``r > 1``)
        are histograms of its draws.
    true_value : array-like of shape (r,), default=None
        The true parameters, when known.
    names, units : list of str, default=None
        Names and units of the ``r`` parameters.
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
    """
    samples, prior = _samples_and_prior(samples_or_calibrator, prior)
    n, r = samples.shape
    names = _names(names, r, "θ", "parameters")
    units = _units(units, r, "parameters")
    if kind not in ("scatter", "hist2d"):
        raise ValueError(f"kind must be 'scatter' or 'hist2d', got {kind!r}.")
    if limits not in ("auto", "prior", "posterior"):
        raise ValueError(
            f"limits must be 'auto', 'prior' or 'posterior', got {limits!r}."
        )
    if true_value is not None:
        true_value = np.atleast_1d(np.asarray(true_value, dtype=float))
        if true_value.shape != (r,):
            raise ValueError(
                f"true_value must have {r} entries (one per parameter); got "
                f"shape {true_value.shape}."
            )
    if isinstance(bins, bool) or not isinstance(bins, numbers.Integral) or bins < 1:
        raise ValueError(f"bins must be a positive integer, got {bins!r}.")
    axes = _axes_grid(ax, (r, r), (4.8 + 2.4 * (r - 1), 3.4 + 2.4 * (r - 1)))

    # Ranges: the draws and the true value, and the prior's central 99 %
    # where asked (or, with "auto", where the posterior is not too narrow
    # to be seen against it).
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    if true_value is not None:
        lo, hi = np.minimum(lo, true_value), np.maximum(hi, true_value)
    if prior is not None and limits != "posterior":
        bounds = prior.bounds(0.99)
        wide = np.ones(r, dtype=bool)
        if limits == "auto":
            wide = (hi - lo) >= _NARROW * (bounds[:, 1] - bounds[:, 0])
        lo = np.where(wide, np.minimum(lo, bounds[:, 0]), lo)
        hi = np.where(wide, np.maximum(hi, bounds[:, 1]), hi)
    pad = 0.03 * np.where(hi > lo, hi - lo, np.abs(hi) + 1.0)
    lo, hi = lo - pad, hi + pad
    prior_draws = None
    mean = samples.mean(axis=0)
    interval = np.quantile(samples, [0.025, 0.975], axis=0)

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
            # Over the axis and the prior's support, so that the curve
            # stays whole if the axis is widened afterwards.
            span = prior.bounds(0.9999)[i]
            grid = np.union1d(np.linspace(lo[i], hi[i], 400), np.linspace(*span, 400))
            density = _prior_marginal(prior, i, grid)
            if density is not None:
                a.plot(grid, density, color="C1", linewidth=1.8, label="prior")
            else:
                if prior_draws is None:
                    prior_draws = prior.rvs(20000, random_state=0)
                a.hist(
                    prior_draws[:, i],
                    bins=bins,
                    range=(lo[i], hi[i]),
                    density=True,
                    histtype="step",
                    color="C1",
                    linewidth=1.5,
                    label="prior (draws)",
                )
        if true_value is not None:
            a.axvline(
                true_value[i], color="k", linestyle="--", linewidth=1.5, label="true"
            )
        a.set_xlim(lo[i], hi[i])
        a.set_title(
            f"{names[i]}: mean {_number(mean[i])}\n95 % interval "
            f"[{_number(interval[0, i])}, {_number(interval[1, i])}]",
            fontsize="small",
        )
        if r > 1:
            a.set_yticks([])
        else:
            a.set_ylabel("density")
        for j in range(r):
            if j < i:
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
            elif j > i:
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
    for i in range(r):
        for j in range(i + 1):
            axes[i, j].set_xlabel(_label(names[j], units[j]) if i == r - 1 else "")
            if j == 0 and i > 0:
                axes[i, j].set_ylabel(_label(names[i], units[i]))
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if r > 1:
        axes[0, r - 1].legend(handles, labels, loc="upper center", fontsize="small")
    else:
        axes[0, 0].legend(fontsize="small")
    return axes[0, 0].figure


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
    chains_or_calibrator : ModularBayesCalibrator or array-like of shape \
            (n_chains, n_draws, r)
        A calibrator fitted with ``sampler="mcmc"`` (its ``theta_chains_``)
        or the draws of each chain after burn-in.
    names, units : list of str, default=None
        Names and units of the ``r`` parameters.
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
        If the calibrator has no chains (one parameter, quadrature posterior)
        or the array is not 3-D.

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
    """
    obj = chains_or_calibrator
    if hasattr(obj, "theta_chains_"):
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
        raise NotFittedError(
            f"This {type(obj).__name__} is not fitted: call fit with "
            "sampler='mcmc' before plotting its chains."
        )
    else:
        chains = obj
    try:
        chains = np.asarray(chains, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            "plot_traces needs a fitted ModularBayesCalibrator or an array of "
            f"shape (n_chains, n_draws, r); got {type(obj).__name__}."
        ) from None
    if chains.ndim != 3:
        raise ValueError(
            f"chains must have shape (n_chains, n_draws, r); got {chains.shape}."
        )
    n_chains, n_draws, r = chains.shape
    names = _names(names, r, "θ", "parameters")
    units = _units(units, r, "parameters")
    if true_value is not None:
        true_value = np.atleast_1d(np.asarray(true_value, dtype=float))
        if true_value.shape != (r,):
            raise ValueError(
                f"true_value must have {r} entries; got shape {true_value.shape}."
            )
    axes = _axes_grid(ax, (r, 1), (8.0, 0.8 + 2.2 * r), sharex=True)[:, 0]
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
        a.set_ylabel(_label(names[p], units[p]))
        a.set_title(
            f"{names[p]}: split R-hat = {split_rhat(chains[:, :, p]):.3f}",
            fontsize="small",
        )
        a.set_xlim(1, n_draws)
    axes[-1].set_xlabel("draw (after burn-in)")
    axes[0].legend(fontsize="small", ncols=min(n_chains + 1, 6), loc="upper right")
    return axes[0].figure


# --------------------------------------------------------------------------
# sensor design
# --------------------------------------------------------------------------


def _subset_label(subset, names, width=None):
    text = ", ".join(names[k] for k in subset)
    if width:
        text = "\n".join(textwrap.wrap(text, width=width))
    return text


def _designer_arrays(designer, extra=()):
    _check_fitted_attributes(
        designer,
        ("subsets_", "scores_", "n_responses_", *extra),
        "a fitted PreposteriorDesigner",
    )
    subsets = [tuple(int(k) for k in s) for s in designer.subsets_]
    scores = np.asarray(designer.scores_, dtype=float).reshape(-1)
    if len(scores) != len(subsets):
        raise ValueError(
            f"scores_ has {len(scores)} entries but there are {len(subsets)} subsets."
        )
    return subsets, scores, int(designer.n_responses_)


def _criterion_label(designer):
    criterion = getattr(designer, "criterion", None)
    suffix = f" ({criterion})" if isinstance(criterion, str) else ""
    return f"preposterior criterion{suffix}, lower is better"


def _best_by_size(subsets, scores):
    """{size: index of the best subset of that size}, sizes ascending."""
    sizes = np.array([len(s) for s in subsets])
    best = {}
    for size in np.unique(sizes):
        members = np.flatnonzero(sizes == size)
        best[int(size)] = int(members[np.argmin(scores[members])])
    return best


def plot_criterion_by_size(designer, *, names=None, ax=None):
    """Plot the best and worst criterion against the number of sensors.

    For each subset size, the minimum (dashed, circles) and maximum (solid,
    crosses) preposterior criterion over the evaluated subsets of that size
    (thesis Fig. 6.7a); each minimum is annotated with its subset. Where the
    minimum stops decreasing, more sensors buy little identifiability.

    Parameters
    ----------
    designer : PreposteriorDesigner
        Fitted (``subsets_``, ``scores_``, ``n_responses_``).
    names : list of str, default=None
        Names of the ``q`` responses (``y0, y1, ...``).
    ax : Axes, default=None
        Where to draw; None creates a figure.

    Returns
    -------
    ax : Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from itertools import combinations
    >>> from types import SimpleNamespace
    >>> import numpy as np
    >>> from skmba.plotting import plot_criterion_by_size
    >>> subsets = [s for k in (1, 2, 3) for s in combinations(range(3), k)]
    >>> scores = np.array([3.0, 2.0, 4.0, 1.5, 2.5, 1.8, 1.2])
    >>> designer = SimpleNamespace(subsets_=subsets, scores_=scores,
    ...                            n_responses_=3)
    >>> ax = plot_criterion_by_size(designer, names=["A", "B", "C"])
    >>> [t.get_text() for t in ax.texts]
    ['B', 'A, B', 'A, B, C']
    """
    subsets, scores, q = _designer_arrays(designer)
    names = _names(names, q, "y", "responses")
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    sizes = np.array([len(s) for s in subsets])
    best = _best_by_size(subsets, scores)
    levels = np.array(list(best))
    minima = np.array([scores[best[s]] for s in levels])
    maxima = np.array([scores[sizes == s].max() for s in levels])
    ax.plot(levels, maxima, "-x", color="C3", markersize=8, label="maximum")
    ax.plot(levels, minima, "--o", color="C0", markersize=6, label="minimum (best)")
    for size, value in zip(levels, minima, strict=True):
        ax.annotate(
            _subset_label(subsets[best[size]], names, width=24),
            (size, value),
            xytext=(0, -10),
            textcoords="offset points",
            ha="center",
            va="top",
            fontsize="x-small",
            color="C0",
        )
    ax.set_xticks(levels)
    ax.margins(x=0.12, y=0.15)
    ax.set_xlabel("number of sensors (responses)")
    ax.set_ylabel(_criterion_label(designer))
    ax.legend()
    return ax


def plot_criterion_vs_bias(
    scores, bias, *, subsets=None, names=None, annotate=False, ax=None
):
    """Scatter the preposterior criterion against the identification bias.

    Each point is a sensor configuration: its preposterior criterion
    (before any measurement) against the bias of the calibration made with
    it (thesis Figs. 6.3, 6.4, 6.6). Points along a rising line mean that the
    criterion ranks the configurations right; a point at the top left is a
    good configuration the criterion missed (type II error), one at the
    bottom right a poor configuration it favoured (type I error).

    Parameters
    ----------
    scores : array-like of shape (n_subsets,) or PreposteriorDesigner
        Criterion of each configuration, or a fitted designer (its
        ``scores_``, and ``subsets_`` when ``subsets`` is None).
    bias : array-like of shape (n_subsets,)
        Identification bias of each configuration, e.g. ``|E[θ] − θ*| /
        θ*`` from a calibration with those responses.
    subsets : list of tuple of int, default=None
        The response indices of each configuration: points are then coloured
        by the number of sensors.
    names : list of str, default=None
        Names of the responses, for the labels (``y0, y1, ...``).
    annotate : bool, default=False
        Label each point with its responses (needs ``subsets``).
    ax : Axes, default=None
        Where to draw; None creates a figure.

    Returns
    -------
    ax : Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skmba.plotting import plot_criterion_vs_bias
    >>> ax = plot_criterion_vs_bias([3.0, 2.0, 1.0], [0.05, 0.03, 0.01],
    ...                             subsets=[(0,), (1,), (0, 1)],
    ...                             names=["A", "B"], annotate=True)
    >>> [t.get_text() for t in ax.get_legend().get_texts()]
    ['1 sensor', '2 sensors']
    """
    q = None
    if hasattr(scores, "scores_"):
        designer_subsets, scores, q = _designer_arrays(scores)
        if subsets is None:
            subsets = designer_subsets
    try:
        scores = np.asarray(scores, dtype=float).reshape(-1)
        bias = np.asarray(bias, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError("scores and bias must be arrays of numbers.") from None
    if len(scores) != len(bias):
        raise ValueError(
            f"scores has {len(scores)} entries and bias {len(bias)}; give one "
            "of each per configuration."
        )
    if subsets is not None:
        subsets = [tuple(int(k) for k in s) for s in subsets]
        if len(subsets) != len(scores):
            raise ValueError(
                f"subsets has {len(subsets)} entries but scores {len(scores)}."
            )
        if q is None:
            q = max(max(s) for s in subsets) + 1 if names is None else len(names)
        names = _names(names, q, "y", "responses")
    elif annotate:
        raise ValueError("annotate=True needs the subsets.")
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    if subsets is None:
        ax.scatter(bias, scores, marker="x", color="C0", label="configurations")
    else:
        sizes = np.array([len(s) for s in subsets])
        levels = np.unique(sizes)
        cmap = plt.get_cmap("viridis")
        for n, size in enumerate(levels):
            members = sizes == size
            ax.scatter(
                bias[members],
                scores[members],
                marker="o",
                s=30,
                color=cmap(n / max(len(levels) - 1, 1)),
                edgecolors="k",
                linewidths=0.4,
                label=f"{size} sensor{'s' if size > 1 else ''}",
            )
        if annotate:
            for subset, x, y in zip(subsets, bias, scores, strict=True):
                ax.annotate(
                    "".join(names[k] for k in subset)
                    if all(len(names[k]) == 1 for k in subset)
                    else _subset_label(subset, names),
                    (x, y),
                    xytext=(3, 3),
                    textcoords="offset points",
                    fontsize="x-small",
                )
    ax.set_xlabel("identification bias")
    ax.set_ylabel("preposterior criterion, lower is better")
    ax.legend(fontsize="small")
    return ax


def plot_convergence(designer, *, subsets=None, names=None, ax=None):
    """Plot the running preposterior criterion over the Monte Carlo loop.

    A flat curve means that the number of Monte Carlo replicates
    ``n_mc`` suffices to rank the configurations (thesis Fig. 6.5).

    Parameters
    ----------
    designer : PreposteriorDesigner
        Fitted (``subsets_``, ``scores_``, ``convergence_``,
        ``n_responses_``).
    subsets : list of tuple of int, default=None
        The configurations to draw (as response indices, in any order); by
        default the best one of each size, at most 5 (sizes evenly spread).
    names : list of str, default=None
        Names of the ``q`` responses (``y0, y1, ...``).
    ax : Axes, default=None
        Where to draw; None creates a figure.

    Returns
    -------
    ax : Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from types import SimpleNamespace
    >>> import numpy as np
    >>> from skmba.plotting import plot_convergence
    >>> running = np.array([[2.0, 1.0, 0.5], [2.2, 1.1, 0.6], [2.1, 1.05, 0.55]])
    >>> designer = SimpleNamespace(subsets_=[(0,), (1,), (0, 1)],
    ...                            scores_=running[-1], convergence_=running,
    ...                            n_responses_=2)
    >>> ax = plot_convergence(designer, names=["A", "B"])
    >>> [line.get_label() for line in ax.get_lines()]
    ['B', 'A, B']
    """
    all_subsets, scores, q = _designer_arrays(designer, ("convergence_",))
    names = _names(names, q, "y", "responses")
    running = np.asarray(designer.convergence_, dtype=float)
    if running.ndim != 2 or running.shape[1] != len(all_subsets):
        raise ValueError(
            f"convergence_ has shape {running.shape}; expected (n_mc, "
            f"{len(all_subsets)})."
        )
    if subsets is None:
        best = _best_by_size(all_subsets, scores)
        sizes = list(best)
        if len(sizes) > 5:
            keep = np.unique(np.round(np.linspace(0, len(sizes) - 1, 5)).astype(int))
            sizes = [sizes[i] for i in keep]
        chosen = [best[s] for s in sizes]
    else:
        lookup = {frozenset(s): i for i, s in enumerate(all_subsets)}
        chosen = []
        for subset in subsets:
            try:
                key = frozenset(int(k) for k in subset)
            except TypeError:
                raise TypeError(
                    "subsets must be a list of tuples of response indices, "
                    f"e.g. [(0,), (0, 2)]; got the entry {subset!r}."
                ) from None
            if key not in lookup:
                raise ValueError(
                    f"subset {tuple(subset)} was not evaluated by the designer."
                )
            chosen.append(lookup[key])
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.2), layout="constrained")
    replicates = np.arange(1, len(running) + 1)
    for n, index in enumerate(chosen):
        ax.plot(
            replicates,
            running[:, index],
            color=f"C{n % 10}",
            label=_subset_label(all_subsets[index], names),
        )
    ax.set_xlim(1, max(len(running), 2))
    ax.set_xlabel("Monte Carlo replicates")
    ax.set_ylabel("running " + _criterion_label(designer).split(",")[0])
    ax.legend(fontsize="small", title="responses")
    return ax
