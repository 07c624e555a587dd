"""One L-BFGS-B run of the likelihood search, and when it stops.

:func:`minimize_lbfgsb` is what :func:`skmba.gp._search.run_optimizer` runs
from each start unless the user passes an optimizer. Two things differ from
calling ``scipy.optimize.minimize(method="L-BFGS-B")`` on ``-loglik``:

* L-BFGS-B sees the negative log-likelihood per observation (divided by
  ``N q``), whose curvature in the log-hyperparameters is of order one, so
  that its first step (along the gradient, with the identity for a Hessian)
  is of order one too instead of reaching for the bounds;
* the run stops once the quasi-Newton estimate of the log-likelihood still
  to be gained, ``g' H^-1 g / 2`` (the Newton decrement, with ``H^-1``
  built from the iterates' secant pairs as L-BFGS does), is at most
  ``GAIN_TOL`` nats. scipy's own tests stay, but its relative reduction
  test asks for changes below the round-off of a likelihood with a small
  nugget, which only failed line searches then end.

Why, and the measurements: docs/internals.rst, section skmba.gp._lbfgsb.

Examples
--------
>>> import numpy as np
>>> from skmba.gp._lbfgsb import minimize_lbfgsb
>>> def objective(x):  # -loglik of 100 observations, maximum at x = 1
...     return 50.0 * (x[0] - 1.0) ** 2, np.array([100.0 * (x[0] - 1.0)])
>>> res = minimize_lbfgsb(objective, np.array([3.0]), np.array([[-5.0, 5.0]]), 100)
>>> bool(res.success), bool(abs(res.x[0] - 1.0) < 1e-2)
(True, True)
"""

from typing import NamedTuple

import numpy as np
from scipy import optimize

#: The search ends once the predicted gain in log-likelihood, in nats, is at
#: most this: the hyperparameters are then within sqrt(2 GAIN_TOL) = 0.045
#: asymptotic standard errors of the maximum (docs/internals.rst, section
#: skmba.gp._lbfgsb).
GAIN_TOL = 1e-3
# Secant pairs kept for the inverse Hessian (scipy's L-BFGS-B keeps 10).
_MEMORY = 10


class LbfgsbResult(NamedTuple):
    """Outcome of :func:`minimize_lbfgsb`, in the objective's units."""

    x: np.ndarray
    fun: float
    jac: np.ndarray
    success: bool
    message: str


class _Converged(Exception):
    """Ends an L-BFGS-B run from its callback: the predicted gain is small."""


def blocked(x, grad, bounds):
    """Components of ``x`` held by a bound: at it, with the descent direction
    ``-grad`` pointing out of the box."""
    lower = x <= bounds[:, 0] + 1e-10 * (1.0 + np.abs(bounds[:, 0]))
    upper = x >= bounds[:, 1] - 1e-10 * (1.0 + np.abs(bounds[:, 1]))
    return (lower & (grad > 0)) | (upper & (grad < 0))


def inverse_hessian_product(grad, pairs):
    """``H^-1 grad`` by the L-BFGS two-loop recursion over secant ``pairs``
    ``(s, y)`` (oldest first), scaled by ``s'y / y'y`` of the newest."""
    r = np.array(grad, dtype=float)
    history = []
    for s, y in reversed(pairs):
        rho = 1.0 / (y @ s)
        a = rho * (s @ r)
        r -= a * y
        history.append((rho, a, s, y))
    s, y = pairs[-1]
    r *= (s @ y) / (y @ y)
    for rho, a, s, y in reversed(history):
        r += (a - rho * (y @ r)) * s
    return r


def predicted_gain(x, grad, bounds, pairs):
    """``g' H^-1 g / 2`` over the components no bound holds."""
    held = blocked(x, grad, bounds)
    free = np.where(held, 0.0, grad)
    step = np.where(held, 0.0, inverse_hessian_product(free, pairs))
    return 0.5 * float(free @ step)


class _Run:
    """The objective L-BFGS-B sees (per observation) and its stopping rule.

    ``objective(x) -> (fun, grad)`` is ``-loglik`` and its gradient in
    nats; ``last`` is the latest evaluation in those units, which is the
    iterate when the callback runs (a line search ends on the point it
    accepts).
    """

    def __init__(self, objective, bounds, n_observations):
        self.objective = objective
        self.bounds = bounds
        self.scale = float(max(n_observations, 1))
        self.last = None
        self.iterate = None
        self.pairs = []

    def __call__(self, x):
        fun, grad = self.objective(x)
        grad = np.asarray(grad, dtype=float)
        self.last = (np.array(x, dtype=float), float(fun), grad)
        return fun / self.scale, grad / self.scale

    def callback(self, xk):
        """After each iteration: a secant pair, then the stopping test."""
        if self.last is None or not np.array_equal(self.last[0], xk):
            return  # not the iterate: no test (never seen)
        x, _, grad = self.last
        if self.iterate is not None:
            s, y = x - self.iterate[0], grad - self.iterate[2]
            # the curvature condition, as L-BFGS-B's own update
            if s @ y > np.finfo(float).eps * (y @ y):
                self.pairs = [*self.pairs, (s, y)][-_MEMORY:]
        self.iterate = self.last
        if self.pairs:
            gain = predicted_gain(x, grad, self.bounds, self.pairs)
            if 0.0 <= gain <= GAIN_TOL:
                raise _Converged


def minimize_lbfgsb(objective, start, bounds, n_observations):
    """Minimise ``objective`` (``-loglik`` of ``n_observations`` scalar
    observations, with its gradient) from ``start`` within ``bounds``.

    Returns a :class:`LbfgsbResult` in the units of ``objective``;
    ``success`` is True when the predicted gain reached ``GAIN_TOL`` or when
    scipy reports convergence.
    """
    run = _Run(objective, np.asarray(bounds, dtype=float), n_observations)
    try:
        res = optimize.minimize(
            run,
            start,
            method="L-BFGS-B",
            jac=True,
            bounds=bounds,
            callback=run.callback,
        )
    except _Converged:
        x, fun, grad = run.last
        return LbfgsbResult(x, fun, grad, True, "predicted gain below GAIN_TOL")
    return LbfgsbResult(
        np.asarray(res.x, dtype=float),
        float(res.fun) * run.scale,
        np.asarray(res.jac, dtype=float) * run.scale,
        bool(res.success),
        str(res.message),
    )
