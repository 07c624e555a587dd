"""Criteria of a preposterior sensor design.

:func:`plot_criterion_by_size` (best and worst criterion per number of
sensors, thesis Fig. 6.7a), :func:`plot_criterion_vs_bias` (criterion
against identification bias, Figs. 6.3, 6.4, 6.6),
:func:`plot_convergence` (running criterion over the Monte Carlo loop,
Fig. 6.5) and :func:`plot_warning_rate` (criterion against the predicted
rate of the calibrator's identifiability warning), from a fitted
:class:`~skmba.PreposteriorDesigner`.

Examples
--------
>>> import numpy as np
>>> from skmba.plotting._sensor_design import _best_by_size, _subset_label
>>> subsets = [(0,), (1,), (0, 1)]
>>> _best_by_size(subsets, np.array([2.0, 1.0, 0.5]))
{1: 1, 2: 2}
>>> _subset_label(subsets[2], ["left", "right"])
'left, right'
"""

import textwrap

import numpy as np

from skmba._core.columns import response_index
from skmba.plotting._common import (
    import_pyplot,
    labels,
    not_fitted_or_other,
    recorded_names,
    single_axes,
)

__all__ = [
    "plot_convergence",
    "plot_criterion_by_size",
    "plot_criterion_vs_bias",
    "plot_warning_rate",
]

# The most configurations plot_convergence draws by default.
_MAX_CURVES = 5


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
        Names of the ``q`` responses; None takes the designer's
        ``response_names_`` when it has them, else ``y0, y1, ...``.
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
    names = _response_names(designer, names, q)
    ax = single_axes(ax, (6.4, 4.4))
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
    subsets : list of tuple of int or str, default=None
        The responses of each configuration, as 0-based indices or names:
        points are then coloured by the number of sensors. Names are those
        of the designer's ``response_names_`` when ``scores`` is a designer,
        else those of ``names``.
    names : list of str, default=None
        Names of the responses, for the labels; None takes the designer's
        ``response_names_`` when ``scores`` is a designer that has them,
        else ``y0, y1, ...``.
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
    scores, bias, subsets, names = _configurations(
        scores, bias, subsets, names, annotate
    )
    ax = single_axes(ax, (6.4, 4.6))
    if subsets is None:
        ax.scatter(bias, scores, marker="x", color="C0", label="configurations")
    else:
        _scatter_by_size(ax, bias, scores, subsets)
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
    subsets : list of tuple of int or str, default=None
        The configurations to draw, as 0-based response indices or names of
        the designer's ``response_names_`` (the columns of a DataFrame
        ``y``), in any order; by default the best one of each size, at most
        5 (sizes evenly spread).
    names : list of str, default=None
        Names of the ``q`` responses; None takes the designer's
        ``response_names_`` when it has them, else ``y0, y1, ...``.
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
    names = _response_names(designer, names, q)
    running = np.asarray(designer.convergence_, dtype=float)
    if running.ndim != 2 or running.shape[1] != len(all_subsets):
        raise ValueError(
            f"convergence_ has shape {running.shape}; expected (n_mc, "
            f"{len(all_subsets)})."
        )
    if subsets is None:
        chosen = _best_of_spread_sizes(all_subsets, scores)
    else:
        recorded = recorded_names(designer, "response_names_", q, "responses")
        chosen = _indices_of(_by_index(subsets, recorded, q), all_subsets)
    ax = single_axes(ax, (6.4, 4.2))
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


def plot_warning_rate(designer, *, parameter=None, names=None, ax=None):
    """Scatter the preposterior criterion against the predicted warning rate.

    Each point is a scored sensor subset: its criterion (``scores_``, lower
    is better) against the share of replicates on which the calibrator's
    :class:`~skmba.exceptions.NonIdentifiabilityWarning` would name a
    parameter (``warning_rate_``; the largest over the parameters unless
    ``parameter`` picks one), with bars of two Monte Carlo standard errors
    (``warning_rate_mcse_``). A low criterion on the right is a precise
    interval the data cannot vouch for; the subsets worth installing sit
    at the bottom left. With the designer's ``max_warning_rate`` a dashed
    line marks it; the best subset overall and ``best_subset_`` are
    labelled.

    Parameters
    ----------
    designer : PreposteriorDesigner
        Fitted (``subsets_``, ``scores_``, ``warning_rate_``,
        ``warning_rate_mcse_``, ``best_subset_``).
    parameter : int or str, default=None
        The parameter whose rate to plot (index, or name from the prior);
        None plots the largest rate over the parameters.
    names : list of str, default=None
        Names of the ``q`` responses; None takes the designer's
        ``response_names_`` when it has them, else ``y0, y1, ...``.
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
    >>> from skmba.plotting import plot_warning_rate
    >>> designer = SimpleNamespace(
    ...     subsets_=[(0,), (1,), (0, 1)], scores_=np.array([0.5, 0.3, 0.1]),
    ...     n_responses_=2, warning_rate_=np.array([[0.5], [0.25], [0.75]]),
    ...     warning_rate_mcse_=np.array([[0.25], [0.2], [0.2]]),
    ...     best_subset_=(1,), max_warning_rate=0.3)
    >>> ax = plot_warning_rate(designer, names=["A", "B"])
    >>> sorted(t.get_text() for t in ax.texts)
    ['A, B (lowest criterion)', 'B (best_subset_)']
    """
    extra = ("warning_rate_", "warning_rate_mcse_", "best_subset_")
    subsets, scores, q = _designer_arrays(designer, extra)
    names = _response_names(designer, names, q)
    rate, mcse, label = _rates_of(designer, parameter, len(subsets))
    ax = single_axes(ax, (6.4, 4.6))
    ax.errorbar(rate, scores, xerr=2 * mcse, fmt="none", ecolor="0.6", lw=0.8, zorder=1)
    _scatter_by_size(ax, rate, scores, subsets)
    bound = getattr(designer, "max_warning_rate", None)
    if bound is not None:
        ax.axvline(bound, color="k", ls="--", lw=1, label="max_warning_rate")
    marks = {subsets[int(np.argmin(scores))]: ["lowest criterion"]}
    marks.setdefault(tuple(designer.best_subset_), []).append("best_subset_")
    for subset, texts in marks.items():
        k = subsets.index(subset)
        ax.annotate(
            f"{_subset_label(subset, names)} ({', '.join(texts)})",
            (rate[k], scores[k]),
            xytext=(4, 4),
            textcoords="offset points",
            fontsize="x-small",
        )
    ax.set_xlim(-0.05, 1.05)
    ax.set_xlabel(f"predicted warning rate{label}")
    ax.set_ylabel(_criterion_label(designer))
    ax.legend(fontsize="small")
    return ax


def _response_names(designer, names, q):
    """The ``q`` response labels: ``names``, the designer's
    ``response_names_`` when it has them, or ``y0, y1, ...``."""
    if names is None:
        names = recorded_names(designer, "response_names_", q, "responses")
    return labels(names, q, "y", "responses")


def _subset_label(subset, names, width=None):
    """The names of a subset's responses, wrapped at ``width`` characters."""
    text = ", ".join(names[k] for k in subset)
    if width:
        text = "\n".join(textwrap.wrap(text, width=width))
    return text


def _designer_arrays(designer, extra=()):
    """A fitted designer's subsets, scores (n_subsets,) and response count."""
    attributes = ("subsets_", "scores_", "n_responses_", *extra)
    missing = [a for a in attributes if getattr(designer, a, None) is None]
    if missing and callable(getattr(designer, "fit", None)):
        raise not_fitted_or_other(
            designer, "PreposteriorDesigner", "this plot", "call fit"
        )
    if missing:
        raise TypeError(
            f"Expected a fitted PreposteriorDesigner with the attributes "
            f"{', '.join(attributes)}; got an object of type "
            f"{type(designer).__name__}."
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


def _configurations(scores, bias, subsets, names, annotate):
    """Checked scores, bias, subsets and names of plot_criterion_vs_bias."""
    q = None
    if hasattr(scores, "scores_"):
        designer = scores
        designer_subsets, scores, q = _designer_arrays(designer)
        if subsets is None:
            subsets = designer_subsets
        else:
            recorded = recorded_names(designer, "response_names_", q, "responses")
            subsets = _by_index(subsets, recorded, q)
        names = _response_names(designer, names, q)
    elif subsets is not None:
        given = None if names is None else [str(n) for n in names]
        subsets = _by_index(subsets, given, None if given is None else len(given))
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
        largest = max(max(s) for s in subsets)
        if q is None:
            q = largest + 1 if names is None else len(names)
        if largest >= q:
            raise ValueError(
                f"subsets use response {largest} but there are {q} responses (names)."
            )
        names = labels(names, q, "y", "responses")
    elif annotate:
        raise ValueError("annotate=True needs the subsets.")
    return scores, bias, subsets, names


def _scatter_by_size(ax, bias, scores, subsets):
    """The configurations, one colour per number of sensors."""
    sizes = np.array([len(s) for s in subsets])
    levels = np.unique(sizes)
    cmap = import_pyplot().get_cmap("viridis")
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


def _best_of_spread_sizes(subsets, scores):
    """Indices of the best subset of each size, at most five sizes evenly
    spread from the smallest to the largest."""
    best = _best_by_size(subsets, scores)
    sizes = list(best)
    if len(sizes) > _MAX_CURVES:
        spread = np.linspace(0, len(sizes) - 1, _MAX_CURVES)
        sizes = [sizes[i] for i in np.unique(np.round(spread).astype(int))]
    return [best[s] for s in sizes]


def _by_index(subsets, names, q):
    """``subsets`` with each response name replaced by its 0-based index.

    Names are resolved by :func:`~skmba._core.columns.response_index` against
    ``names`` (the designer's ``response_names_``, or the ``names`` given
    with plain scores, when ``q`` is None); integers are left to the
    caller's checks.
    """
    resolved = []
    for subset in subsets:
        if isinstance(subset, str) or not np.iterable(subset):
            raise TypeError(
                "subsets must be a list of tuples of response indices or "
                f"names, e.g. [(0,), (0, 2)] or [('tip',)]; got the entry "
                f"{subset!r}."
            )
        if names is None and q is None and any(isinstance(k, str) for k in subset):
            # Plain scores without names= (a designer without names gets
            # response_index's message).
            raise ValueError(
                f"subsets entry {tuple(subset)!r} names responses, but there "
                "are no response names: pass names= (the names of the "
                "responses, in order), or give 0-based indices."
            )
        try:
            resolved.append(
                tuple(
                    response_index(k, names, q) if isinstance(k, str) else k
                    for k in subset
                )
            )
        except ValueError as error:
            raise ValueError(f"subsets entry {tuple(subset)!r}: {error}") from None
    return resolved


def _indices_of(subsets, evaluated):
    """Index in ``evaluated`` of each subset (its indices in any order)."""
    lookup = {frozenset(s): i for i, s in enumerate(evaluated)}
    chosen = []
    for subset in subsets:
        try:
            key = frozenset(int(k) for k in subset)
        except TypeError:
            raise TypeError(
                "subsets must be a list of tuples of response indices or "
                f"names, e.g. [(0,), (0, 2)]; got the entry {subset!r}."
            ) from None
        if key not in lookup:
            raise ValueError(
                f"subset {tuple(subset)} was not evaluated by the designer."
            )
        chosen.append(lookup[key])
    return chosen


def _rates_of(designer, parameter, n_subsets):
    """The warning rate to plot per subset, its standard error and the axis
    label's suffix: of ``parameter`` (index or prior name), or the largest
    over the parameters with the error of that one."""
    rate = np.asarray(designer.warning_rate_, dtype=float).reshape(n_subsets, -1)
    mcse = np.asarray(designer.warning_rate_mcse_, dtype=float).reshape(rate.shape)
    r = rate.shape[1]
    if parameter is None:
        pick = np.argmax(rate, axis=1)
        suffix = "" if r == 1 else " (largest over the parameters)"
    else:
        prior = getattr(designer, "prior_", None)
        given = list(getattr(prior, "names", None) or [])
        if isinstance(parameter, str) and parameter in given:
            j = given.index(parameter)
        elif isinstance(parameter, (int, np.integer)) and 0 <= parameter < r:
            j = int(parameter)
        else:
            choices = given or list(range(r))
            raise ValueError(
                f"parameter must be one of {choices} (a 0-based index or a "
                f"name of the prior), got {parameter!r}."
            )
        pick = np.full(n_subsets, j)
        suffix = f" of {given[j] if given else f'θ{j}'}"
    rows = np.arange(n_subsets)
    return rate[rows, pick], mcse[rows, pick], suffix
