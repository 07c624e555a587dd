"""Slices of the design space, for figures of several design variables.

A prediction over ``d`` design variables is drawn along one of them with
the others held fixed: a *slice*. :func:`varied_inputs` decides which
design variables get a slice (or, for two of them, a plane of contours),
:func:`design_slices` builds the points of each slice and
:func:`slice_label` writes its axis label with the fixed values.

The points of a slice are built from the ranges of ``X``, never
triangulated: a slice is a line in the design space, on which a Delaunay
triangulation (what ``tricontourf`` does) is singular.

Examples
--------
>>> import numpy as np
>>> from skmba.plotting._slices import design_slices, varied_inputs
>>> X = np.array([[0.0, 10.0], [1.0, 30.0], [2.0, 20.0]])
>>> varied_inputs(X, None, {}, ["a", "b"])
[0, 1]
>>> first, second = design_slices(X, [0, 1], {1: 25.0})
>>> first.points.tolist()
[[0.0, 25.0], [1.0, 25.0], [2.0, 25.0]]
>>> second.points[:, 0].tolist(), second.x.tolist()
([1.0, 1.0, 1.0], [10.0, 20.0, 30.0])
"""

import numbers
from typing import NamedTuple

import numpy as np

from skmba.plotting._common import short_number

# Points per axis of a plane of contours over scattered inputs.
PLANE_POINTS = 50


class DesignSlice(NamedTuple):
    """The points of one slice, sorted along the design variable ``vary``.

    ``order`` holds the rows of ``X`` the points are, when they are rows of
    ``X`` (``X`` itself a slice along ``vary``), else None.
    """

    vary: int
    points: np.ndarray
    order: np.ndarray | None

    @property
    def x(self):
        """The values of the varied design variable (s,)."""
        return self.points[:, self.vary]


def input_index(key, input_names):
    """The index of a design variable given by index or by name.

    >>> input_index("b", ["a", "b"]), input_index(-1, ["a", "b"])
    (1, 1)
    """
    d = len(input_names)
    if isinstance(key, str):
        if key not in input_names:
            raise ValueError(
                f"{key!r} is not a design variable; they are {input_names}."
            )
        return input_names.index(key)
    if isinstance(key, numbers.Integral) and not isinstance(key, bool):
        if -d <= key < d:
            return int(key) % d
    raise ValueError(
        f"A design variable is an index in [0, {d}) or one of the names "
        f"{input_names}; got {key!r}."
    )


def check_fixed(fixed, input_names):
    """``fixed`` as a dict {index: value} of the held design variables.

    >>> check_fixed({"b": 2}, ["a", "b"])
    {1: 2.0}
    """
    if fixed is None:
        return {}
    if not hasattr(fixed, "items"):
        raise TypeError(
            "fixed must be a dict {design variable (index or name): value}, "
            f"e.g. {{1: 0.5}}; got {type(fixed).__name__}."
        )
    checked = {}
    for key, value in fixed.items():
        index = input_index(key, input_names)
        if index in checked:
            raise ValueError(f"fixed gives {input_names[index]!r} twice.")
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise TypeError(
                f"fixed[{key!r}] must be a number, got {value!r}."
            ) from None
        if not np.isfinite(value):
            raise ValueError(f"fixed[{key!r}] must be finite, got {value}.")
        checked[index] = value
    return checked


def varied_inputs(X, vary, fixed, input_names, *, plane=False):
    """The design variables to draw along, or ``"plane"``.

    Parameters
    ----------
    X : ndarray of shape (s, d)
    vary : None, "all", int, str or list of int or str
        None: the design variables that ``X`` spans and ``fixed`` does not
        hold (all of them for ``d == 1``), or ``"plane"`` when ``plane``
        and ``X`` spans both of two design variables. ``"all"``: every
        design variable that ``X`` spans. Otherwise those given.
    fixed : dict {int: float}
    input_names : list of str
    plane : bool, default=False
        Whether contours over two design variables are drawable.

    Returns
    -------
    list of int or "plane"
    """
    d = X.shape[1]
    spans = np.ptp(X, axis=0) > 0
    if d == 1:
        chosen = [0] if vary is None or vary == "all" else None
    elif vary is None:
        chosen = [j for j in range(d) if spans[j] and j not in fixed]
        if plane and d == 2 and chosen == [0, 1]:
            return "plane"
    elif isinstance(vary, str) and vary == "all":
        chosen = [j for j in range(d) if spans[j]]
    else:
        chosen = None
    if chosen is None:
        keys = [vary] if isinstance(vary, (str, numbers.Integral)) else list(vary)
        chosen = [input_index(key, input_names) for key in keys]
        if len(set(chosen)) != len(chosen) or not chosen:
            raise ValueError(f"vary must name distinct design variables; got {vary!r}.")
        if len(chosen) == 1 and chosen[0] in fixed and d > 1:
            raise ValueError(
                f"{input_names[chosen[0]]!r} is both varied and fixed; drop it "
                "from fixed."
            )
        flat = [input_names[j] for j in chosen if not spans[j] and d > 1]
        if flat:
            raise ValueError(
                f"X holds {', '.join(map(repr, flat))} at one value: give X a "
                "range of values of each varied design variable."
            )
    if not chosen:
        raise ValueError(
            "X spans no range of a design variable that fixed does not hold: "
            "give X (s, d) points that span the design variables to draw along."
        )
    return chosen


def design_slices(X, varied, fixed):
    """One :class:`DesignSlice` per varied design variable.

    Along design variable ``j``, the points take the values of ``X[:, j]``
    and hold each other design variable at its ``fixed`` value, by default
    the middle of its range in ``X``. When ``X`` is itself a slice along
    ``j`` (the others constant, at their fixed values), the points are its
    rows sorted along ``j``.
    """
    d = X.shape[1]
    held = (X.min(axis=0) + X.max(axis=0)) / 2
    for k, value in fixed.items():
        held[k] = value
    slices = []
    for j in varied:
        others = np.arange(d) != j
        if np.all(X[:, others] == held[others]):
            order = np.argsort(X[:, j], kind="stable")
            slices.append(DesignSlice(j, X[order], order))
            continue
        x = np.unique(X[:, j])
        points = np.tile(held, (len(x), 1))
        points[:, j] = x
        slices.append(DesignSlice(j, points, None))
    return slices


def plane_grid(X):
    """The axes of a rectangular grid over two design variables.

    The unique values of each column when ``X`` holds every combination of
    them (a flattened grid), else :data:`PLANE_POINTS` evenly spaced values
    over the range of each column. Returns ``(u0, u1, points)`` with the
    points ``(len(u0) * len(u1), 2)`` in the row-major order of
    ``np.meshgrid(u0, u1)``.

    >>> X = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0], [1.0, 2.0]])
    >>> u0, u1, points = plane_grid(X)
    >>> u0.tolist(), u1.tolist(), points[1].tolist()
    ([0.0, 1.0], [0.0, 2.0], [1.0, 0.0])
    """
    u0, u1 = np.unique(X[:, 0]), np.unique(X[:, 1])
    if len(np.unique(X, axis=0)) != len(u0) * len(u1):
        u0 = np.linspace(u0[0], u0[-1], PLANE_POINTS)
        u1 = np.linspace(u1[0], u1[-1], PLANE_POINTS)
    grid = np.meshgrid(u0, u1)
    return u0, u1, np.column_stack([g.ravel() for g in grid])


def slice_label(design_slice, input_names):
    """The abscissa's label: the varied design variable, then the held ones.

    >>> s = DesignSlice(0, np.array([[0.0, 2.5e7], [1.0, 2.5e7]]), None)
    >>> print(slice_label(s, ["force [N]", "moment [N*mm]"]))
    force [N]
    (moment [N*mm] = 2.5e7)
    """
    j, point = design_slice.vary, design_slice.points[0]
    held = [
        f"{name} = {short_number(point[k])}"
        for k, name in enumerate(input_names)
        if k != j
    ]
    if not held:
        return input_names[j]
    return f"{input_names[j]}\n({', '.join(held)})"
