"""Module 3 by quadrature: the posterior of one calibration parameter.

:func:`posterior_by_quadrature` integrates a one-parameter
:class:`~skmba.calibration._module3_posterior.LogPosterior` by adaptive
Gauss-Legendre passes and returns its
:class:`~skmba.mcmc._posterior.PosteriorResult` (the rule, and draws by
inverse-CDF sampling). Several parameters go through the chains of
:func:`~skmba.calibration._module3_posterior.posterior_by_mcmc`.

Examples
--------
A normal log posterior of mean 1 and sd 0.5 under a wide uniform prior:

>>> import numpy as np
>>> from scipy import stats
>>> from skmba.calibration._module3_quadrature import posterior_by_quadrature
>>> class Normal:
...     class prior:
...         @staticmethod
...         def bounds(mass):
...             return np.array([[-10.0, 10.0]])
...     @staticmethod
...     def batch(t):
...         return stats.norm(1.0, 0.5).logpdf(t[:, 0])
>>> result = posterior_by_quadrature(Normal(), 1000, random_state=0)
>>> np.round(result.mean, 6), np.round(np.sqrt(result.cov), 6)
(array([1.]), array([[0.5]]))
"""

import time

import numpy as np

from skmba._core.validation import seed_sequence
from skmba._core.warn import warn
from skmba.mcmc._posterior import PosteriorResult

# Nodes per pass, most passes, and the nodes that must carry the mass for
# the posterior to count as resolved.
_QUADRATURE_NODES = 201
_QUADRATURE_PASSES = 8
_RESOLVED_NODES = 40


def _quadrature_pass(log_posterior, lo, hi):
    """One Gauss-Legendre pass: nodes, density, normalised weights."""
    nodes_gl, weights_gl = np.polynomial.legendre.leggauss(_QUADRATURE_NODES)
    t = 0.5 * (hi - lo) * nodes_gl + 0.5 * (hi + lo)
    logp = log_posterior.batch(t[:, None])
    if not np.any(np.isfinite(logp)):
        log_posterior.raise_unevaluable(t)
    density = np.exp(logp - np.max(logp))
    w = weights_gl * density
    return t, density, w / w.sum()


def posterior_by_quadrature(log_posterior, n_samples, random_state=None, say=None):
    """Adaptive Gauss-Legendre quadrature of a one-parameter posterior.

    A first 201-node rule over the prior's 0.9999 interval locates the
    mass; each further pass puts the rule on the region that holds all
    but 1e-12 of the mass found by the previous one, until that region
    spans at least 40 nodes (for a Gaussian posterior, a node spacing
    below 0.4 standard deviations): at least two passes, at most eight.
    A posterior still unresolved after eight passes is reported by a
    warning. Draws come by inverse-CDF sampling of the posterior CDF,
    integrated from the density at the nodes by the trapezoidal rule.

    Parameters
    ----------
    log_posterior : LogPosterior
    n_samples : int
        Draws to return.
    random_state : int, SeedSequence or None
        Seed of the one uniform that offsets the stratified draws (see
        :func:`~skmba._core.validation.seed_sequence`).
    say : callable, default=None
        Progress messages.

    Returns
    -------
    PosteriorResult
    """
    say = say or (lambda message: None)
    lo, hi = log_posterior.prior.bounds(0.9999)[0]
    for sweep in range(_QUADRATURE_PASSES):
        started = time.perf_counter()
        interval = f"[{lo:.6g}, {hi:.6g}]"
        t, density, w = _quadrature_pass(log_posterior, lo, hi)
        mass = np.cumsum(w)
        inside = np.flatnonzero((mass > 1e-12) & (mass < 1 - 1e-12))
        i0 = max((inside[0] if inside.size else np.argmax(w)) - 2, 0)
        i1 = min((inside[-1] if inside.size else np.argmax(w)) + 2, len(t) - 1)
        lo, hi = t[i0], t[i1]
        say(
            f"module 3: quadrature pass {sweep + 1} ({len(t)} nodes on "
            f"{interval}, {inside.size} carry the mass) in "
            f"{time.perf_counter() - started:.1f} s"
        )
        if sweep >= 1 and inside.size >= _RESOLVED_NODES:
            break
    else:
        warn(
            f"The posterior of theta is narrower than the quadrature resolved "
            f"after {_QUADRATURE_PASSES} passes (its mass lies on {inside.size} "
            f"of {len(t)} nodes around {t[np.argmax(w)]:.8g}): theta_cov_ "
            "and the spread of theta_samples_ are underestimated. Check the "
            "simulations and the noise estimate (noise_), or use "
            "sampler='mcmc'.",
            UserWarning,
        )
    cdf = np.concatenate(
        [[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(t))]
    )
    cdf = cdf / cdf[-1]
    rng = np.random.default_rng(seed_sequence(random_state))
    u = (np.arange(n_samples) + rng.uniform()) / n_samples
    samples = np.interp(u, cdf, t)[:, None]
    return PosteriorResult.from_rule(samples, t[:, None], w, (lo, hi))
