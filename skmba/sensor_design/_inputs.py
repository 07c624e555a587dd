"""The sensor designer's inputs, checked: prior, priors of the data, design.

:class:`~skmba.PreposteriorDesigner` turns its parameters and the
simulations into what the fast preposterior analysis needs, here, before
any emulator is fitted: the prior of ``theta`` and the layout of ``X``
(:func:`designer_prior`), the priors the synthetic field data are drawn
from (:func:`synthetic_data_priors`), the planned field inputs
(:func:`field_design`).

Examples
--------
>>> import numpy as np
>>> field_design(None, 4, np.array([[0.0], [10.0]]), seed=0).shape
(4, 1)
"""

import numpy as np
from scipy import stats
from sklearn.utils import check_array

from skmba.calibration._simulations import RUNS_PER_INPUT
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._theta import check_prior
from skmba.sensor_design._replicates import check_design_priors

#: Field design points when neither ``X_design`` nor ``n_design`` is given
#: (section 6.3).
DEFAULT_N_DESIGN = 25


def given_prior(prior, calibrator):
    """The designer's ``prior``, else its calibrator's (None if neither)."""
    if prior is None and calibrator is not None:
        return calibrator.prior
    return prior


def designer_prior(prior, calibrator, X):
    """The checked prior, and the number ``d`` of design variables of ``X``.

    ``X`` holds the design variables, then the ``r`` parameters; the prior
    is ``prior`` or else the calibrator's, and the simulated parameters must
    overlap its support.
    """
    prior = given_prior(prior, calibrator)
    if prior is None:
        raise ValueError(
            "prior is required: pass the prior of the calibration parameters, "
            "e.g. prior=[scipy.stats.uniform(lo, hi - lo)]."
        )
    prior = check_prior(prior)
    N, r = len(X), prior.dim
    d = X.shape[1] - r
    if d < 1:
        raise ValueError(
            f"X has {X.shape[1]} columns (n_features={X.shape[1]}) but the "
            f"prior has {r} parameters: X "
            "must hold the design variables first and the r calibration "
            "parameters as its last r columns."
        )
    if N < 2 * (d + r) + 1:
        raise ValueError(
            f"{N} simulations (n_samples={N}) are too few for {d + r} inputs: "
            "the emulator "
            f"needs at least {2 * (d + r) + 1}, and about "
            f"{RUNS_PER_INPUT * (d + r)} are recommended."
        )
    theta_sim = X[:, d:]
    support = prior.bounds(0.999)
    if np.any(theta_sim.max(axis=0) < support[:, 0]) or np.any(
        theta_sim.min(axis=0) > support[:, 1]
    ):
        raise ValueError(
            "The simulated parameters (last r columns of X) do not overlap the "
            "prior's support: simulate over the prior's range."
        )
    return prior, d


def synthetic_data_priors(designer, d, q, y_scale):
    """The priors of the synthetic data: ranges (plug-in) or a Hyperprior.

    From the designer's ``discrepancy_uncertainty``, ``discrepancy_prior``,
    ``noise_prior`` and ``prior_units``.
    """
    if designer.discrepancy_uncertainty == "plug-in":
        return check_design_priors(
            designer.discrepancy_prior,
            designer.noise_prior,
            designer.prior_units,
            d,
            q,
            y_scale,
        )
    for name, default in (("noise_prior", None), ("prior_units", "standardised")):
        value = getattr(designer, name)
        if value != default:
            raise ValueError(
                f"{name}={value!r} belongs to discrepancy_uncertainty='plug-in'; "
                "with 'propagate' the noise prior is discrepancy_prior['noise'] "
                "and every prior is in standardised units: leave "
                f"{name} at {default!r}."
            )
    prior = Hyperprior.from_spec(designer.discrepancy_prior)
    prior.scales(q)
    return prior


def field_design(X_design, n_design, X_sim, seed):
    """The planned field inputs: ``X_design`` checked, or a Latin hypercube
    of ``n_design`` points (None: :data:`DEFAULT_N_DESIGN`) over the range of
    the simulated design variables."""
    d = X_sim.shape[1]
    lo, hi = X_sim.min(axis=0), X_sim.max(axis=0)
    if X_design is None:
        n_design = DEFAULT_N_DESIGN if n_design is None else n_design
        u = stats.qmc.LatinHypercube(d=d, seed=seed).random(n_design)
        return lo + (hi - lo) * u
    X_design = check_array(X_design, input_name="X_design")
    if X_design.shape[1] != d:
        raise ValueError(
            f"X_design has {X_design.shape[1]} columns but the simulations "
            f"have {d} design variables."
        )
    tol = 1e-9 * np.maximum(hi - lo, 1.0)
    if np.any(X_design < lo - tol) or np.any(X_design > hi + tol):
        raise ValueError(
            "X_design lies outside the range of the simulated design "
            f"variables [{lo.tolist()}, {hi.tolist()}]: the emulator would "
            "extrapolate. Keep X_design inside it or extend the simulations."
        )
    return X_design
