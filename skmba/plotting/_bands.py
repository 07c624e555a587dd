"""Prediction bands of a Gaussian process: :func:`plot_gp_prediction`.

For one input, the mean and the 95 % band of each response along the
input with the training data; for two inputs, filled contours of the mean
and of the band's half-width over the plane.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> import numpy as np
>>> from sklearn.gaussian_process import GaussianProcessRegressor
>>> from skmba.plotting import plot_gp_prediction
>>> X = np.linspace(0, 1, 6)[:, None]
>>> gp = GaussianProcessRegressor().fit(X, np.cos(3 * X[:, 0]))
>>> ax = plot_gp_prediction(gp, np.linspace(0, 1, 40), X_train=X)
>>> [t.get_text() for t in ax.get_legend().get_texts()]
['95 % band', 'mean', 'training inputs']
"""

import numbers

import numpy as np

from skmba.plotting._common import (
    Z95,
    as_2d_response,
    as_inputs,
    axes_grid,
    axis_label,
    draw_band,
    import_pyplot,
    labels,
    predict_with_std,
    unit_labels,
)

__all__ = ["plot_gp_prediction"]


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
    X = _check_gp_and_inputs(gp, X)
    d = X.shape[1]
    import_pyplot()
    mean, std = _predicted_bands(gp, X, include_noise)
    q = mean.shape[1]
    names = labels(names, q, "y", "responses")
    units = unit_labels(units, q, "responses")
    input_names = labels(input_names, d, "x", "inputs")
    drawn = _drawn_responses(response, names)
    X_train, y_train = _training_data(X_train, y_train, d, q)
    response_labels = [
        axis_label(name, unit) for name, unit in zip(names, units, strict=True)
    ]
    if d == 1:
        band_label = "95 % band, new measurement" if include_noise else "95 % band"
        return _draw_along_input(
            ax,
            X[:, 0],
            (mean, std),
            drawn,
            (X_train, y_train),
            response_labels,
            input_names[0],
            band_label,
        )
    return _draw_over_plane(
        ax, X, (mean, std), drawn, X_train, names, response_labels, input_names
    )


def _check_gp_and_inputs(gp, X):
    """``X`` as an (s, 1) or (s, 2) array, for a ``gp`` that can predict."""
    if not callable(getattr(gp, "predict", None)):
        raise TypeError(
            "gp must be a fitted regressor with predict(X, return_std=True), "
            f"such as skmba.MultiResponseGP; got {type(gp).__name__}."
        )
    X = as_inputs(X)
    d = X.shape[1]
    if d > 2:
        raise ValueError(
            f"plot_gp_prediction draws one or two inputs; X has {d} columns. "
            "Fix the other inputs and wrap the GP, or plot a slice."
        )
    return X


def _predicted_bands(gp, X, include_noise):
    """Mean and std (s, q) at ``X``, with the noise when asked."""
    mean, std = predict_with_std(gp, "predict", X)
    if include_noise:
        noise = getattr(gp, "noise_", None)
        if noise is None:
            raise ValueError(
                "include_noise=True needs a GP fitted with noise (attribute "
                "noise_, e.g. MultiResponseGP(noise=True))."
            )
        q = mean.shape[1]
        std = np.sqrt(std**2 + np.broadcast_to(np.asarray(noise, dtype=float), (q,)))
    return mean, std


def _drawn_responses(response, names):
    """Indices of the responses to draw: all, or the one named or indexed.

    >>> _drawn_responses(None, ["a", "b"]), _drawn_responses("b", ["a", "b"])
    ([0, 1], [1])
    >>> _drawn_responses(-1, ["a", "b"])
    [1]
    """
    q = len(names)
    if response is None:
        return list(range(q))
    if isinstance(response, str):
        if response not in names:
            raise ValueError(f"response {response!r} is not one of {names}.")
        return [names.index(response)]
    if isinstance(response, numbers.Integral) and -q <= response < q:
        return [int(response) % q]
    raise ValueError(
        f"response must be None, a name or an index in [0, {q}), got {response!r}."
    )


def _training_data(X_train, y_train, d, q):
    """The checked training inputs (n, d) and responses (n, q), or None."""
    if X_train is not None:
        X_train = as_inputs(X_train, "X_train")
        if X_train.shape[1] != d:
            raise ValueError(f"X_train has {X_train.shape[1]} columns but X has {d}.")
    if y_train is not None:
        if X_train is None:
            raise ValueError("y_train needs X_train.")
        y_train = as_2d_response(y_train, len(X_train), q, "y_train")
    return X_train, y_train


def _draw_along_input(
    ax, x, bands, drawn, training, response_labels, input_name, band_label
):
    """One panel per drawn response: band along the input, training data."""
    n = len(drawn)
    new_figure = ax is None
    axes = axes_grid(ax, (n, 1), (6.4, 1.0 + 2.6 * n), sharex=True)[:, 0]
    order = np.argsort(x)
    mean, std = bands
    for a, k in zip(axes, drawn, strict=True):
        draw_band(a, x[order], mean[order, k], std[order, k], "C0", band_label)
        _mark_training_along_input(a, *training, k)
        a.set_ylabel(response_labels[k])
        if not new_figure or a is axes[-1]:  # a new figure shares x
            a.set_xlabel(input_name)
        a.legend(fontsize="small")
    return axes[0] if n == 1 else axes[0].figure


def _mark_training_along_input(a, X_train, y_train, k):
    """Training points of response ``k``, or ticks at the training inputs."""
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


def _draw_over_plane(ax, X, bands, drawn, X_train, names, response_labels, inputs):
    """Per drawn response, contours of the mean and of the band half-width."""
    axes = axes_grid(ax, (len(drawn), 2), (9.0, 0.6 + 3.4 * len(drawn)))
    mean, std = bands
    for row, k in zip(axes, drawn, strict=True):
        panels = (
            (mean[:, k], f"{names[k]}: mean", "viridis"),
            (Z95 * std[:, k], f"{names[k]}: 95 % half-width", "YlOrRd"),
        )
        for a, (values, title, cmap) in zip(row, panels, strict=True):
            filled = a.tricontourf(X[:, 0], X[:, 1], values, levels=15, cmap=cmap)
            colorbar = a.figure.colorbar(filled, ax=a)
            colorbar.set_label(response_labels[k])
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
            a.set_xlabel(inputs[0])
            a.set_ylabel(inputs[1])
    import_pyplot().setp(axes, xlim=(X[:, 0].min(), X[:, 0].max()))
    return axes[0, 0].figure
