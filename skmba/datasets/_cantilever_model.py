"""Closed-form cantilever beam of the thesis: the model and the reality.

The *model* ``y^m(x, theta)`` is an Euler-Bernoulli cantilever with a fixed
support, loaded at the tip by a force F and a moment M; the *reality*
``y^e(x)`` is the same beam whose support is a rotational spring of
stiffness ``K*``, at the true parameters. Both are picklable callables used
by :func:`~skmba.datasets.make_cantilever`, whose Notes give the formulas.

Units throughout are N, mm and MPa (N/mm²): forces in N, moments in N·mm,
lengths and displacements in mm, rotations in rad, Young's modulus in MPa,
second moment of area in mm⁴ and deformation energy in N·mm.

Examples
--------
>>> from skmba.datasets._cantilever_model import CantileverModel, CantileverReality
>>> model = CantileverModel(response_names=("tip_rotation",))
>>> round(float(model([[10e3]], [[70e3]])[0, 0]), 6)  # F L^2 / (2 E I)
0.000952
>>> reality = CantileverReality(response_names=("tip_rotation",))
>>> round(float(reality([[10e3]])[0, 0]), 6)  # ... + F L / K*
0.000972
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["RESPONSES", "RESPONSE_UNITS", "CantileverModel", "CantileverReality"]

#: Responses in the order of Table 6.1 of the thesis (letters A to E).
RESPONSES = (
    "tip_displacement",  # A: displacement at point A (beam tip, x = L)
    "energy",  # B: deformation energy of the beam
    "tip_rotation",  # C: rotation angle at point A (beam tip)
    "mid_displacement",  # D: displacement at point B (mid-span, x = L/2)
    "quarter_displacement",  # E: displacement at point C (quarter-span, x = L/4)
)
RESPONSE_UNITS = {
    "tip_displacement": "mm",
    "energy": "N*mm",
    "tip_rotation": "rad",
    "mid_displacement": "mm",
    "quarter_displacement": "mm",
}


def _beam_responses(force, moment, E, I, length, spring_stiffness, names):
    """Closed-form responses of a tip-loaded cantilever on a rotational spring.

    All inputs broadcast; ``spring_stiffness = inf`` gives the fixed support.
    Returns an array of shape ``(n, len(names))``.
    """
    L = length
    EI = E * I
    support_moment = force * L + moment
    phi = support_moment / spring_stiffness  # rigid rotation of the support

    def w(x):
        return (force * x**2 * (3.0 * L - x) / 6.0 + moment * x**2 / 2.0) / EI + (
            phi * x
        )

    out = {}
    for name in names:
        if name == "tip_displacement":
            out[name] = w(L)
        elif name == "mid_displacement":
            out[name] = w(L / 2.0)
        elif name == "quarter_displacement":
            out[name] = w(L / 4.0)
        elif name == "tip_rotation":
            out[name] = (force * L**2 / 2.0 + moment * L) / EI + phi
        elif name == "energy":
            bending = (
                force**2 * L**3 / 3.0 + force * moment * L**2 + moment**2 * L
            ) / (2.0 * EI)
            out[name] = bending + support_moment**2 / (2.0 * spring_stiffness)
        else:  # pragma: no cover - names are validated upstream
            raise ValueError(f"unknown response {name!r}")
    return np.column_stack([np.broadcast_to(out[n], np.shape(force)) for n in names])


def _loads(X, design_variable_names):
    """Tip force and moment of each row of the checked design matrix ``X``.

    Without ``"moment"`` among the design variables the moment is zero.
    """
    n_columns = len(design_variable_names)
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != n_columns:
        raise ValueError(
            f"X must be a 2-D array with {n_columns} column(s) "
            f"{design_variable_names}, got shape {X.shape}"
        )
    force = X[:, 0]
    if "moment" in design_variable_names:
        moment = X[:, 1]
    else:
        moment = np.zeros_like(force)
    return force, moment


@dataclass(frozen=True)
class CantileverModel:
    """Fixed-support cantilever model ``y^m(x, theta)`` (the simulator).

    A picklable callable: ``model(X, theta)`` returns the responses of an
    Euler-Bernoulli cantilever with a fixed support, row by row.

    Parameters
    ----------
    response_names : tuple of str, default=("tip_displacement", "energy")
        Responses (columns of the output), see :func:`make_cantilever`.
    design_variable_names : tuple of str, default=("force",)
        Columns of ``X``: ``("force",)`` or ``("force", "moment")``.
    parameter_names : tuple of str, default=("E",)
        Columns of ``theta``: ``("E",)`` or ``("E", "I")``.
    length : float, default=3000.0
        Beam length ``L`` [mm].
    I : float, default=6.75e8
        Second moment of area [mm⁴] used when ``"I"`` is not a calibration
        parameter (Table 4.1).

    Examples
    --------
    >>> model = CantileverModel()
    >>> y = model([[10e3]], [[70e3]])  # F L^3/(3EI), F^2 L^3/(6EI)
    >>> [round(float(v), 3) for v in y[0]]
    [1.905, 9523.81]
    """

    response_names: tuple = ("tip_displacement", "energy")
    design_variable_names: tuple = ("force",)
    parameter_names: tuple = ("E",)
    length: float = 3000.0
    I: float = 6.75e8

    def __call__(self, X, theta):
        """Evaluate the model.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Design variables (force [N] and optionally moment [N·mm]).
        theta : array-like of shape (n, r) or (r,)
            Calibration parameters (E [MPa] and optionally I [mm⁴]), one row
            per row of ``X``; a 1-D ``theta`` is used for every row.

        Returns
        -------
        Y : ndarray of shape (n, q)
        """
        force, moment = _loads(X, self.design_variable_names)
        n, r = force.shape[0], len(self.parameter_names)
        theta = np.asarray(theta, dtype=float)
        if theta.ndim == 1 and theta.shape[0] == r:
            theta = np.broadcast_to(theta, (n, r))
        if theta.ndim != 2 or theta.shape != (n, r):
            raise ValueError(
                f"theta must have shape ({n}, {r}) or ({r},) for "
                f"parameters {self.parameter_names}, got shape {theta.shape}"
            )
        E = theta[:, 0]
        I = theta[:, 1] if r == 2 else self.I
        return _beam_responses(
            force, moment, E, I, self.length, np.inf, self.response_names
        )


@dataclass(frozen=True)
class CantileverReality:
    """Spring-supported cantilever ``y^e(x)`` at the true parameters.

    A picklable callable: ``reality(X)`` returns the noise-free responses of
    the cantilever whose support is a rotational spring of stiffness
    ``spring_stiffness`` (``inf`` recovers the fixed-support model).

    Parameters
    ----------
    response_names : tuple of str, default=("tip_displacement", "energy")
        Responses (columns of the output), see :func:`make_cantilever`.
    design_variable_names : tuple of str, default=("force",)
        Columns of ``X``: ``("force",)`` or ``("force", "moment")``.
    E : float, default=70e3
        True Young's modulus ``E*`` [MPa].
    I : float, default=6.75e8
        True second moment of area ``I*`` [mm⁴].
    spring_stiffness : float, default=1.5e12
        Rotational stiffness ``K*`` of the support [N·mm/rad].
    length : float, default=3000.0
        Beam length ``L`` [mm].

    Examples
    --------
    >>> reality = CantileverReality()
    >>> y = reality([[10e3]])  # model + F L^2/K*, + (F L)^2/(2 K*)
    >>> [round(float(v), 3) for v in y[0]]
    [1.965, 9823.81]
    """

    response_names: tuple = ("tip_displacement", "energy")
    design_variable_names: tuple = ("force",)
    E: float = 70.0e3
    I: float = 6.75e8
    spring_stiffness: float = 1.5e12
    length: float = 3000.0

    def __call__(self, X):
        """Evaluate the reality.

        Parameters
        ----------
        X : array-like of shape (n, d)
            Design variables (force [N] and optionally moment [N·mm]).

        Returns
        -------
        Y : ndarray of shape (n, q)
        """
        force, moment = _loads(X, self.design_variable_names)
        return _beam_responses(
            force,
            moment,
            self.E,
            self.I,
            self.length,
            self.spring_stiffness,
            self.response_names,
        )
