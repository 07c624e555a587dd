"""A posterior's draws and moments, and its Laplace approximation.

Samplers know no GP: :class:`PosteriorResult` holds what a sampler (MCMC
chains, a one-parameter quadrature, an earlier run's draws reweighted)
made of a posterior, in user units,
and :func:`laplace` finds the mode and Laplace covariance of any log
density, which place the chains' starts and first proposal. Module 3
(:mod:`skmba.calibration._module3_posterior`) fills both.
"""

from dataclasses import dataclass

import numpy as np
from scipy import optimize


@dataclass(frozen=True)
class PosteriorResult:
    """Module 3's posterior of theta, in user units.

    Attributes
    ----------
    method : {"quadrature", "mcmc", "reweighted"}
    samples : ndarray of shape (m, r)
        Draws (pooled chains after burn-in, or resampled from the quadrature
        or the reweighted draws).
    mean : ndarray of shape (r,)
    cov : ndarray of shape (r, r)
    nodes, weights : ndarray or None
        The quadrature rule (one parameter), or the reweighted draws, and
        their normalised weights.
    interval : tuple or None
        The interval that holds the quadrature posterior's mass.
    chains : ndarray of shape (n_chains, n_samples, r) or None
    acceptance_rate, rhat, ess : ndarray or None
        MCMC diagnostics; ``ess`` also of reweighted draws.
    log_density : ndarray of shape (n_chains, n_samples) or None
        The log posterior (:class:`LogPosterior`, user units, up to a
        constant) at each draw of ``chains``; MCMC only (None for a first
        pass run without it).
    labels : ndarray of shape (n_chains, n_samples) or None
        Over a mixture of module-2 draws, the draw that the chains sampled
        with each theta (a draw of ``p(phi_k | theta, data)``); MCMC only.
    draw_weights : ndarray of shape (m, K) or None
        Over a mixture of module-2 draws, ``p(phi_k | theta, data)`` at each
        of ``samples`` (zero for the draws the chains left out as idle),
        from the chains' own evaluations; MCMC with its diagnostics checked
        only (what module 3 needs until it has estimated the draws' Monte
        Carlo error, then dropped).
    anchor : skmba.mcmc._reweight.Anchor or None
        Reweighted only: the run whose draws were reweighted (the next
        update reweights them again).
    """

    method: str
    samples: np.ndarray
    mean: np.ndarray
    cov: np.ndarray
    nodes: np.ndarray | None = None
    weights: np.ndarray | None = None
    interval: tuple | None = None
    chains: np.ndarray | None = None
    acceptance_rate: np.ndarray | None = None
    rhat: np.ndarray | None = None
    ess: np.ndarray | None = None
    log_density: np.ndarray | None = None
    labels: np.ndarray | None = None
    anchor: object | None = None
    draw_weights: np.ndarray | None = None

    def summary(self, seconds):
        """One line for the progress log: method, time, mean, sd, diagnostics."""
        text = (
            f"module 3 done in {seconds:.1f} s ({self.method}): "
            f"posterior mean {np.array2string(self.mean, precision=5)}, "
            f"sd {np.array2string(np.sqrt(np.diag(self.cov)), precision=3)}"
        )
        if self.method == "reweighted":
            text += f", ESS {np.array2string(self.ess, precision=0)}"
        if self.method == "mcmc":
            text += (
                f", R-hat {np.array2string(self.rhat, precision=3)}, bulk ESS "
                f"{np.array2string(self.ess, precision=0)}"
            )
        return text

    @classmethod
    def from_draws(cls, method, samples, **extra):
        """Moments from equally weighted draws."""
        mean = samples.mean(axis=0)
        return cls(method, samples, mean, np.atleast_2d(np.cov(samples.T)), **extra)

    @classmethod
    def from_rule(cls, samples, nodes, weights, interval):
        """Moments from a quadrature rule."""
        mean = weights @ nodes
        centred = nodes - mean
        cov = (centred * weights[:, None]).T @ centred
        return cls(
            "quadrature",
            samples,
            mean,
            cov,
            nodes=nodes,
            weights=weights,
            interval=interval,
        )


#: Tolerances of the search for the mode (sampling coordinates, standardised
#: by the simulated parameters; log density): it only places the chains'
#: starts and the steps of the Hessian (measured: docs/internals.rst,
#: section skmba.mcmc._posterior).
_MODE_XATOL = 1e-3


_MODE_FATOL = 1e-4


def laplace(log_density, starts):
    """Posterior mode and covariance (Laplace) of ``log_density``.

    The mode maximises the log density from the given starts (Nelder-Mead:
    the log posterior is cheap and has no gradient here); the covariance is
    the inverse of a central finite-difference Hessian whose steps follow
    the posterior's own scale. Both only initialise the Metropolis-Hastings
    chains.

    Examples
    --------
    >>> mode, cov = laplace(lambda u: -0.5 * float(u @ u), [np.array([1.0])])
    >>> np.round(mode, 4), np.round(cov, 3)
    (array([0.]), array([[1.]]))
    """

    def negative(t):
        value = log_density(t)
        return -value if np.isfinite(value) else 1e300

    best = min(
        (
            optimize.minimize(
                negative,
                start,
                method="Nelder-Mead",
                options={"xatol": _MODE_XATOL, "fatol": _MODE_FATOL, "maxiter": 4000},
            )
            for start in starts
        ),
        key=lambda res: res.fun,
    )
    mode = best.x
    step = np.full(mode.size, 1e-3)
    cov = np.eye(mode.size) * 1e-2
    for _ in range(3):
        H = _hessian(negative, mode, step)
        values, vectors = np.linalg.eigh(0.5 * (H + H.T))
        if (
            np.all(values > 0)
            and np.all(np.isfinite(values))
            and negative(mode) < 1e300
        ):
            cov = (vectors / values) @ vectors.T
            step = 0.1 * np.sqrt(np.diag(cov))
        else:
            step = step * 10.0
    return mode, cov


def _hessian(f, x, step):
    """Central finite-difference Hessian of ``f`` at ``x``."""
    r = x.size
    H = np.empty((r, r))
    for i in range(r):
        for j in range(i, r):
            ei = np.eye(r)[i] * step[i]
            ej = np.eye(r)[j] * step[j]
            H[i, j] = H[j, i] = (
                f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)
            ) / (4 * step[i] * step[j])
    return H
