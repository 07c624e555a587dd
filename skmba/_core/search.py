"""Searches for the minimum of an objective with an analytic gradient.

* :func:`preconditioned_minimum`: L-BFGS-B, which goes on in coordinates
  whitened by the Hessian when it has not converged in
  :data:`PRECONDITION_AFTER` iterations (module 2's mode,
  :mod:`~skmba.calibration._module2_posterior`).
* :func:`gradient_hessian`: the Hessian by central differences of the
  gradient (the preconditioner, and module 2's Laplace covariance).

Measurements: ``docs/internals.rst`` (skmba._core.search).
"""

import numpy as np
from scipy import optimize

#: Step of the finite-difference Hessian (of the analytic gradient), in the
#: objective's coordinates.
HESSIAN_STEP = 1e-4
#: L-BFGS-B iterations of a search before it goes on in coordinates
#: whitened by the Hessian where it stands. On the bridge year's module 2
#: (15 hyperparameters), 156-213 evaluations to within 0.03 nats of the
#: mode against 629-951 that stopped 1.7-2.5 nats short of it; the
#: searches of the cantilever cases converge in 9-50 and are the same as
#: before, bit for bit (docs/internals.rst).
PRECONDITION_AFTER = 60
#: The whitening's smallest curvature, relative to its largest: a condition
#: number of at most 1e4 left to L-BFGS-B (the bridge year's Hessian at the
#: mode: 4e7). 1e-3 and 1e-6 left the bridge's searches 0.3-0.4 nats apart.
CURVATURE_FLOOR = 1e-4


def gradient_hessian(objective, v, step=HESSIAN_STEP):
    """The Hessian at ``v`` of ``objective`` (which returns the value and
    the gradient): central differences of the gradient, ``2 len(v)``
    evaluations; not symmetrised."""
    m = len(v)
    H = np.empty((m, m))
    for j in range(m):
        e = np.zeros(m)
        e[j] = step
        H[:, j] = (objective(v + e)[1] - objective(v - e)[1]) / (2 * step)
    return H


def preconditioned_minimum(objective, v0):
    """The minimum of ``objective`` (value and gradient) from ``v0``.

    L-BFGS-B; a search still going after :data:`PRECONDITION_AFTER`
    iterations goes on in coordinates ``z``, ``v = v1 + M z``, whitened by
    the Hessian at the point ``v1`` it reached (its eigenvalues in absolute
    value, floored at :data:`CURVATURE_FLOOR` of the largest). On a ridge,
    where the curvatures span decades, L-BFGS-B alone crawls and stops on
    its relative reduction short of the minimum.

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x`` and ``fun`` in the coordinates of ``v0``; ``nfev`` counts
        both stages and the Hessian.
    """
    first = optimize.minimize(
        objective,
        v0,
        jac=True,
        method="L-BFGS-B",
        options={"maxiter": PRECONDITION_AFTER},
    )
    if first.nit < PRECONDITION_AFTER or not first.fun < 1e300:
        return first
    v1 = first.x
    H = gradient_hessian(objective, v1)
    if not np.all(np.isfinite(H)):
        return first
    values, vectors = np.linalg.eigh(0.5 * (H + H.T))
    curvature = np.abs(values)
    M = vectors / np.sqrt(np.maximum(curvature, CURVATURE_FLOOR * curvature.max()))

    def whitened(z):
        value, gradient = objective(v1 + M @ z)
        return value, M.T @ gradient

    second = optimize.minimize(whitened, np.zeros(len(v1)), jac=True, method="L-BFGS-B")
    nfev = first.nfev + 2 * len(v1) + second.nfev
    if not second.fun < first.fun:
        first.nfev = nfev
        return first
    second.x, second.nfev = v1 + M @ second.x, nfev
    return second
