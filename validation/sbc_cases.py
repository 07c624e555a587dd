"""Simulation-based calibration with everything drawn from the default priors.

The SBC cases of issue 13: per seed, theta* from the case's prior, the
discrepancy and noise hyperparameters from the calibrator's documented
default prior (:class:`skmba.priors._hyperprior.Hyperprior`), one discrepancy
function from the Gaussian process they define, and the noise. The field
data are then distributed exactly as the calibrator's default model says,
so that the ranks of theta* among its posterior draws are uniform when the
inference is right (Talts et al. 2018).

The prior is in the calibrator's terms of the field data: each design
variable centred and scaled by its (population) standard deviation over the
distinct field inputs, each response scaled by the spread of the model's
response over the field inputs and the prior of theta (the prior's
32-node integration rule, as the calibrator's
:func:`~skmba.calibration._module2_prior_integral.prior_units`, which
measures it on the emulator; here it is measured on the model itself, so
the two are computed independently). The discrepancy is ``GP(0, Sigma_d ⊗
R_d)`` with ``Sigma_d = diag(sd) C diag(sd)`` and ``R_d = prod_j
exp(-roughness_j (xs_j - xs'_j)^2)`` (:class:`skmba.kernels.Gauss`) on
those standardised inputs; its mean has a flat prior, under which the
posterior does not depend on it, so it is drawn as zero. It is drawn once
on a fine grid of the design variable and interpolated, so the field data
and the held-out inputs of the predictive checks see one function.

``sbc_a1`` and ``sbc_a2`` are the designs a1 and a2 of
:mod:`validation.cases` (the same simulations and field inputs).
``SBC_CASES`` is read by :func:`validation.suite.registry`;
:func:`draw_field_data` also by ``validation.studies.designer_vs_calibrator``.
"""

from __future__ import annotations

import numpy as np
from scipy import interpolate

from skmba.calibration._module2_prior_integral import UNITS_NODES, UNITS_SEED
from skmba.datasets import make_cantilever
from skmba.priors import IndependentPrior
from skmba.priors._hyperprior import Hyperprior
from validation.cases import (
    A2_BOUNDS,
    A2_SIZES,
    CANTILEVER_SIZES,
    CANTILEVER_X_BOUNDS,
    UNIT_X_BOUNDS,
    Case,
    CaseSpec,
    _lhs,
    _rng,
    _uniform_prior,
    quadratic_model,
)

GRID = 400  # points of the discrepancy draw over the design variable's range


def field_units(model, X, prior):
    """The prior's units in user units: the sd of each design variable over
    the distinct field inputs ``X`` and, per response, the spread of
    ``model`` over them and the prior's integration rule (``prior``: a list
    of frozen scipy distributions)."""
    X = np.unique(np.asarray(X, dtype=float), axis=0)
    spread_x = X.std(axis=0)
    nodes, weights = IndependentPrior(prior).integration_nodes(
        UNITS_NODES, random_state=UNITS_SEED
    )
    n = len(X)
    outputs = np.asarray(
        model(np.tile(X, (len(nodes), 1)), np.repeat(nodes, n, axis=0)), dtype=float
    ).reshape(len(nodes), n, -1)
    w = weights[:, None, None] / n
    centre = np.sum(w * outputs, axis=(0, 1))
    spread_y = np.sqrt(np.sum(w * (outputs - centre) ** 2, axis=(0, 1)))
    return X.mean(axis=0), spread_x, spread_y


class DrawnReality:
    """``model(X, theta*) + delta(X)`` with ``delta`` drawn on a grid (picklable)."""

    def __init__(self, model, theta, bounds, delta_grid):
        self.model, self.theta = model, np.asarray(theta, dtype=float)
        self.grid = np.linspace(*bounds[0], GRID)
        self.delta_grid = delta_grid

    def __call__(self, X):
        X = np.asarray(X, dtype=float)
        spline = interpolate.CubicSpline(self.grid, self.delta_grid, axis=0)
        theta = np.tile(self.theta, (len(X), 1))
        return np.asarray(self.model(X, theta), dtype=float) + spline(X[:, 0])


def draw_field_data(seed, model, theta, X, prior, bounds):
    """Hyperparameters, a discrepancy function and noise from the default prior.

    Returns the reality (a :class:`DrawnReality`), the noisy observations at
    ``X`` and the noise sd per response, in user units.
    """
    x_mean, x_scale, y_scale = field_units(model, X, prior)
    q = len(y_scale)
    draw = Hyperprior().rvs(X.shape[1], q, random_state=_rng(seed, 3))
    grid = np.linspace(*bounds[0], GRID)
    xs = (grid - x_mean[0]) / x_scale[0]
    R = np.exp(-draw["roughness"][0] * (xs[:, None] - xs[None, :]) ** 2)
    sigma = draw["correlation"] * np.outer(draw["sd"], draw["sd"])
    # Eigen-decompositions with the tiny negative eigenvalues of a smooth
    # correlation on a fine grid set to zero: an exact draw up to round-off.
    values, vectors = np.linalg.eigh(R)
    root_R = vectors * np.sqrt(np.clip(values, 0.0, None))
    values, vectors = np.linalg.eigh(sigma)
    root_S = vectors * np.sqrt(np.clip(values, 0.0, None))
    z = _rng(seed, 4).standard_normal((GRID, q))
    delta_grid = (root_R @ z @ root_S.T) * y_scale  # user units
    reality = DrawnReality(model, theta, bounds, delta_grid)
    noise_sd = np.sqrt(draw["noise"]) * y_scale
    y = reality(X) + _rng(seed, 1).normal(size=(len(X), q)) * noise_sd
    return reality, y, noise_sd


def case_sbc_a1(seed):
    """sbc_a1: the a1 cantilever, E* and a discrepancy from the priors."""
    n_sim, n_obs = CANTILEVER_SIZES
    data = make_cantilever(
        n_sim, n_obs, spring_stiffness=np.inf, snr_db=None, random_state=int(seed)
    )
    lo, hi = data.prior[0].support()
    theta = np.array([lo + (hi - lo) * _rng(seed, 2).uniform()])
    reality, y, noise_sd = draw_field_data(
        seed, data.simulator, theta, data.X_obs, data.prior, CANTILEVER_X_BOUNDS
    )
    return Case(
        data.X_obs,
        y,
        data.X_sim,
        data.theta_sim,
        data.y_sim,
        data.prior,
        theta,
        reality,
        noise_sd,
    )


def case_sbc_a2(seed):
    """sbc_a2: the a2 pair, theta* and a discrepancy from the priors."""
    n_sim, n_obs = A2_SIZES
    rng = _rng(seed, 0)
    design = _lhs(n_sim, np.vstack([UNIT_X_BOUNDS, A2_BOUNDS]), rng)
    X_sim, theta_sim = design[:, :1], design[:, 1:]
    X = _lhs(n_obs, UNIT_X_BOUNDS, rng)
    lo, hi = A2_BOUNDS[:, 0], A2_BOUNDS[:, 1]
    theta = lo + (hi - lo) * _rng(seed, 2).uniform(size=2)
    y_sim = quadratic_model(X_sim, theta_sim)
    reality, y, noise_sd = draw_field_data(
        seed, quadratic_model, theta, X, _uniform_prior(A2_BOUNDS), UNIT_X_BOUNDS
    )
    return Case(
        X,
        y,
        X_sim,
        theta_sim,
        y_sim,
        _uniform_prior(A2_BOUNDS),
        theta,
        reality,
        noise_sd,
    )


SBC_CASES = {
    "sbc_a1": CaseSpec(
        case_sbc_a1,
        CANTILEVER_X_BOUNDS,
        ("E",),
        "a1 design; E*, discrepancy hyperparameters, discrepancy and noise "
        "drawn from the default priors",
    ),
    "sbc_a2": CaseSpec(
        case_sbc_a2,
        UNIT_X_BOUNDS,
        ("t1", "t2"),
        "a2 design; theta*, discrepancy hyperparameters, discrepancy and noise "
        "drawn from the default priors",
    ),
}
