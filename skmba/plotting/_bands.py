"""Prediction bands of a Gaussian process: :func:`plot_gp_prediction`.

Along one input, the mean and the 95 % band of each response with the
training data; for several inputs, along each of them with the others held
fixed, or, for two inputs, filled contours of the mean and of the band's
half-width over the plane.

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
    recorded_names,
    unit_labels,
)
from skmba.plotting._slices import (
    check_fixed,
    design_slices,
    plane_grid,
    slice_label,
    varied_inputs,
)

__all__ = ["plot_gp_prediction"]


def plot_gp_prediction(
    gp,
    X,
    *,
    vary=None,
    fixed=None,
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

    Along one input, the mean with the band ``mean ± 1.96 std`` and the
    training data, one panel per response. For several inputs, the same
    along each varied input with the others held fixed (a slice): one
    column of panels per varied input. For two inputs both spanned by
    ``X`` (and ``vary=None``), per response two filled-contour panels over
    the plane: the mean and the half-width ``1.96 std`` of the 95 % band,
    with the training inputs marked.

    Parameters
    ----------
    gp : estimator
        A fitted :class:`~skmba.MultiResponseGP`, or any regressor with
        ``predict(X, return_std=True)`` (a fitted
        :class:`~skmba.ModularBayesCalibrator` draws its calibrated
        prediction). The band of a ``MultiResponseGP`` is that of the latent
        (noise-free) process unless ``include_noise``.
    X : array-like of shape (s,) or (s, d)
        Where to predict. One input: a grid (any order). Several inputs:
        points whose columns give the values of each varied input and
        whose ranges give the default fixed values (their middles); for a
        plane, a flattened grid (its values are used) or scattered points
        (a regular 50 x 50 grid over their bounding box).
    vary : None, "all", int, str or list, default=None
        The inputs to draw along (indices, or names in ``input_names``),
        one column of panels each, the other inputs held at ``fixed``.
        None: the inputs that ``X`` spans and ``fixed`` does not hold, or
        the plane of contours when there are two inputs and ``X`` spans
        both. ``"all"``: every input that ``X`` spans.
    fixed : dict, default=None
        ``{input (index or name): value}``: where the inputs not varied
        are held. By default, the middle of their range in ``X`` (so a
        slice given as ``X`` is drawn as it is).
    X_train : array-like of shape (n, d), default=None
        Training inputs to mark (projected on the varied input of a slice).
    y_train : array-like of shape (n,) or (n, q), default=None
        Training responses, drawn as points along the varied input (needs
        ``X_train``). Without them, the training inputs are marked along
        the bottom of the panels.
    response : int or str, default=None
        Only this response (its index, or its name in ``names``); None
        draws all.
    include_noise : bool, default=False
        Add the fitted noise variance ``gp.noise_`` to the variance, for a
        band of a new (noisy) measurement.
    names, units : list of str, default=None
        Names and units of the ``q`` responses; None takes the
        ``response_names_`` of a ``gp`` fitted on a DataFrame ``y``.
    input_names : list of str, default=None
        Labels of the inputs (with their units), e.g. ``["force [N]"]``;
        None takes the ``feature_names_in_`` of a ``gp`` fitted on a
        DataFrame, else ``x0, x1, ...``.
    ax : Axes or array of Axes, default=None
        Where to draw: an array of shape (n_responses_drawn, n_varied) for
        slices or (n_responses_drawn, 2) for a plane. None creates a figure.

    Returns
    -------
    ax_or_fig : Axes or Figure
        The Axes when one panel is drawn (one slice and one response),
        otherwise the Figure.

    Raises
    ------
    ValueError
        If ``X`` has another number of columns than ``gp`` has inputs, or
        spans none of the inputs to vary.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skmba import MultiResponseGP
    >>> from skmba.plotting import plot_gp_prediction
    >>> X = np.linspace(0, 1, 10)[:, None]
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

    Three inputs, along the second one with the others held:

    >>> X3 = np.random.default_rng(0).uniform(size=(30, 3))
    >>> y3 = np.sin(3 * X3[:, 0]) + X3[:, 1] ** 2 + X3[:, 2]
    >>> gp3 = MultiResponseGP(random_state=0).fit(X3, y3)
    >>> ax = plot_gp_prediction(gp3, X3, vary=1, fixed={0: 0.5, 2: 0.1})
    >>> print(ax.get_xlabel())
    x1
    (x0 = 0.5, x2 = 0.1)
    """
    X = _check_gp_and_inputs(gp, X)
    d = X.shape[1]
    import_pyplot()
    if input_names is None:
        input_names = recorded_names(gp, "feature_names_in_", d, "inputs")
    input_names = labels(input_names, d, "x", "inputs")
    fixed = check_fixed(fixed, input_names)
    varied = varied_inputs(X, vary, fixed, input_names, plane=True)
    if varied == "plane":
        u0, u1, points = plane_grid(X)
        slices = None
    else:
        slices = design_slices(X, varied, fixed)
        points = np.vstack([s.points for s in slices])
    mean, std = _predicted_bands(gp, points, include_noise)
    q = mean.shape[1]
    if names is None:
        names = recorded_names(gp, "response_names_", q, "responses")
    names = labels(names, q, "y", "responses")
    units = unit_labels(units, q, "responses")
    drawn = _drawn_responses(response, names)
    X_train, y_train = _training_data(X_train, y_train, d, q)
    response_labels = [
        axis_label(name, unit) for name, unit in zip(names, units, strict=True)
    ]
    if slices is None:
        shape = (len(u1), len(u0))
        grids = (u0, u1, mean.reshape(*shape, q), std.reshape(*shape, q))
        return _draw_over_plane(
            ax, grids, drawn, X_train, names, response_labels, input_names
        )
    band_label = "95 % band, new measurement" if include_noise else "95 % band"
    ends = np.cumsum([len(s.points) for s in slices])[:-1]
    bands = list(zip(np.split(mean, ends), np.split(std, ends), strict=True))
    return _draw_along_inputs(
        ax,
        slices,
        bands,
        drawn,
        (X_train, y_train),
        response_labels,
        input_names,
        band_label,
    )


def _check_gp_and_inputs(gp, X):
    """``X`` as an (s, d) array, for a ``gp`` that can predict."""
    if not callable(getattr(gp, "predict", None)):
        raise TypeError(
            "gp must be a fitted regressor with predict(X, return_std=True), "
            f"such as skmba.MultiResponseGP; got {type(gp).__name__}."
        )
    X = as_inputs(X)
    # Set by every fitted scikit-learn estimator; other regressors are taken
    # at their word that X fits them.
    n_features = getattr(gp, "n_features_in_", None)
    if n_features is not None and X.shape[1] != n_features:
        raise ValueError(
            f"X has {X.shape[1]} columns but the GP was fitted on {n_features} "
            f"input{'s' * (n_features != 1)}: give a value of every input (see "
            "vary and fixed)."
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


def _draw_along_inputs(
    ax, slices, bands, drawn, training, response_labels, input_names, band_label
):
    """Panels (drawn responses, slices): the band along each varied input."""
    n, m = len(drawn), len(slices)
    new_figure = ax is None
    share = {"sharex": "col", "sharey": "row"} if m > 1 else {"sharex": True}
    axes = axes_grid(ax, (n, m), (6.4 if m == 1 else 4.4 * m, 1.0 + 2.6 * n), **share)
    projected = len(input_names) > 1
    for c, (design_slice, (mean, std)) in enumerate(zip(slices, bands, strict=True)):
        x = design_slice.x
        for row, k in enumerate(drawn):
            a = axes[row, c]
            draw_band(a, x, mean[:, k], std[:, k], "C0", band_label)
            _mark_training(a, *training, k, design_slice.vary, projected)
            if c == 0 or not new_figure:
                a.set_ylabel(response_labels[k])
            if not new_figure or row == n - 1:  # a new figure shares x
                a.set_xlabel(slice_label(design_slice, input_names))
            if m == 1 or (row == 0 and c == 0):
                a.legend(fontsize="small")
    return axes[0, 0] if n == 1 and m == 1 else axes[0, 0].figure


def _mark_training(a, X_train, y_train, k, j, projected):
    """Training points of response ``k`` along input ``j``, or ticks at the
    training inputs; ``projected`` when the other inputs vary among them."""
    suffix = " (projected)" if projected else ""
    if y_train is not None:
        a.plot(
            X_train[:, j],
            y_train[:, k],
            "o",
            color="C3",
            markersize=4,
            label="training data" + suffix,
        )
    elif X_train is not None:
        a.plot(
            X_train[:, j],
            np.zeros(len(X_train)),
            "|",
            color="C3",
            markersize=10,
            transform=a.get_xaxis_transform(),
            label="training inputs" + suffix,
        )


def _draw_over_plane(ax, grids, drawn, X_train, names, response_labels, inputs):
    """Per drawn response, contours of the mean and of the band half-width.

    ``grids`` are the axes ``u0`` (n0,), ``u1`` (n1,) of a rectangular grid
    and the mean and std (n1, n0, q) on it: contours of gridded values need
    no triangulation.
    """
    u0, u1, mean, std = grids
    axes = axes_grid(ax, (len(drawn), 2), (9.0, 0.6 + 3.4 * len(drawn)))
    for row, k in zip(axes, drawn, strict=True):
        panels = (
            (mean[:, :, k], f"{names[k]}: mean", "viridis"),
            (Z95 * std[:, :, k], f"{names[k]}: 95 % half-width", "YlOrRd"),
        )
        for a, (values, title, cmap) in zip(row, panels, strict=True):
            filled = a.contourf(u0, u1, values, levels=15, cmap=cmap)
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
    import_pyplot().setp(axes, xlim=(u0[0], u0[-1]), ylim=(u1[0], u1[-1]))
    return axes[0, 0].figure
