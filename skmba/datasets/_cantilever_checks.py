"""The arguments of :func:`~skmba.datasets.make_cantilever`, checked.

:func:`check_arguments` checks them in the order of the signature and
returns one frozen :class:`CantileverSettings`, which the steps of
:mod:`skmba.datasets._cantilever` read. The ranges of the design variables
and of the parameters (thesis Tables 4.1-4.3) live here with the names they
are keyed by.

Examples
--------
>>> from skmba.datasets._cantilever_checks import check_arguments
>>> settings = check_arguments(10, 5, "all", "E", "force", "lhs", "uniform",
...                            None, 0, 1.5e12, 70e3, 6.75e8, 3000.0)
>>> settings.parameter_names, settings.theta_bounds.tolist()
(('E',), [[20000.0, 100000.0]])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from skmba._core.validation import check_count
from skmba.datasets._cantilever_model import RESPONSES
from skmba.datasets._design import check_positive, per_response

_PARAMETER_SETS = (("E",), ("E", "I"))
_DESIGN_SETS = (("force",), ("force", "moment"))
_PRIORS = ("uniform", "gaussian")
_DESIGNS = ("lhs", "grid")

#: Sampling ranges: Table 4.1 (F, E), Table 4.2 (M) and Table 4.3 (I).
DESIGN_BOUNDS = {"force": (1.0e3, 10.0e3), "moment": (1.0e6, 30.0e6)}
PARAMETER_BOUNDS = {"E": (20.0e3, 100.0e3), "I": (2.25e8, 11.25e8)}


def _as_tuple(value):
    """``value`` as a tuple: a string or a non-iterable becomes a 1-tuple."""
    if isinstance(value, str):
        return (value,)
    try:
        return tuple(value)
    except TypeError:
        return (value,)


def _check_names(value, argument, allowed):
    """Validate a tuple of response names (``"all"`` or a subset)."""
    value = allowed if isinstance(value, str) and value == "all" else _as_tuple(value)
    bad = [v for v in value if not isinstance(v, str) or v not in allowed]
    if not value or bad or len(set(value)) != len(value):
        raise ValueError(
            f"{argument} must be 'all' or a non-empty sequence of distinct names "
            f"from {allowed}, got {value!r}"
        )
    return value


def _check_choice(value, argument, allowed):
    """Validate a value that must be one of ``allowed``.

    Tuple-valued choices (``allowed`` holds tuples) take any sequence, and a
    single string stands for a 1-tuple.
    """
    if isinstance(allowed[0], tuple):
        value = _as_tuple(value)
    if value not in allowed:
        raise ValueError(f"{argument} must be one of {allowed}, got {value!r}")
    return value


@dataclass(frozen=True, eq=False)
class CantileverSettings:
    """The checked arguments of :func:`~skmba.datasets.make_cantilever`
    and what follows from them."""

    n_simulations: int
    n_observations: int
    response_names: tuple
    parameter_names: tuple
    design_variable_names: tuple
    simulation_design: str
    prior: str
    snr: np.ndarray | None
    n_outliers: int
    spring_stiffness: float
    E_true: float
    I_true: float
    length: float

    @property
    def X_bounds(self):
        """Ranges of the design variables, shape (d, 2)."""
        return np.array([DESIGN_BOUNDS[v] for v in self.design_variable_names])

    @property
    def theta_bounds(self):
        """Ranges of the simulated parameters, shape (r, 2)."""
        return np.array([PARAMETER_BOUNDS[p] for p in self.parameter_names])

    @property
    def theta_true(self):
        """True parameters: E*, and I* when calibrated."""
        return np.array([self.E_true, self.I_true][: len(self.parameter_names)])


def check_arguments(
    n_simulations,
    n_observations,
    responses,
    parameters,
    design_variables,
    simulation_design,
    prior,
    snr_db,
    n_outliers,
    spring_stiffness,
    E_true,
    I_true,
    length,
):
    """Check the arguments of :func:`~skmba.datasets.make_cantilever` (same
    names), in order."""
    n_simulations = check_count(n_simulations, "n_simulations")
    n_observations = check_count(n_observations, "n_observations")
    response_names = _check_names(responses, "responses", RESPONSES)
    parameter_names = _check_choice(parameters, "parameters", _PARAMETER_SETS)
    design_variable_names = _check_choice(
        design_variables, "design_variables", _DESIGN_SETS
    )
    simulation_design = _check_choice(simulation_design, "simulation_design", _DESIGNS)
    prior = _check_choice(prior, "prior", _PRIORS)
    q = len(response_names)
    snr = None if snr_db is None else per_response(snr_db, "snr_db", q)
    n_outliers = check_count(n_outliers, "n_outliers", minimum=0)
    if n_outliers > n_observations:
        raise ValueError(
            f"n_outliers must be between 0 and n_observations={n_observations}, "
            f"got {n_outliers}"
        )
    return CantileverSettings(
        n_simulations,
        n_observations,
        response_names,
        parameter_names,
        design_variable_names,
        simulation_design,
        prior,
        snr,
        n_outliers,
        check_positive(spring_stiffness, "spring_stiffness", allow_inf=True),
        check_positive(E_true, "E_true"),
        check_positive(I_true, "I_true"),
        check_positive(length, "length"),
    )
