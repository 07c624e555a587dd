"""The arguments of :func:`skmba.mcmc._run.run_chains`, checked.

Each returns its argument in the form the chains use (a float array of
starts, one log density per chain, the Cholesky factor of each chain's
first random-walk proposal, the independence probability, the moments of
an earlier run) or raises a ``TypeError`` or ``ValueError`` that names the
argument and what it must be.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._checks import check_starts
>>> check_starts([[0.0, 1.0]]).shape
(1, 2)
>>> check_starts([0.0, 1.0])
Traceback (most recent call last):
...
ValueError: starts must be a 2-D array of shape (n_chains, r) ...
"""

import numpy as np
from scipy import linalg

from skmba.mcmc._chain import OPTIMAL_SCALE


def check_starts(starts):
    """``starts`` as a finite float array of shape (n_chains, r)."""
    starts = np.array(starts, dtype=float)
    if starts.ndim != 2 or starts.shape[0] < 1 or starts.shape[1] < 1:
        raise ValueError(
            "starts must be a 2-D array of shape (n_chains, r) with at least one "
            f"chain and one parameter, got shape {starts.shape}; use "
            "starts.reshape(1, -1) for a single chain"
        )
    if not np.all(np.isfinite(starts)):
        raise ValueError("starts must be finite")
    return starts


def per_chain(log_density, n_chains):
    """One log-density callable per chain."""
    if callable(log_density):
        return [log_density] * n_chains
    try:
        densities = list(log_density)
    except TypeError:
        raise TypeError(
            "log_density must be callable or a sequence of callables (one per "
            f"chain), got {log_density!r}"
        ) from None
    if len(densities) != n_chains or not all(callable(f) for f in densities):
        raise TypeError(
            f"log_density must be callable or a sequence of {n_chains} callables "
            f"(one per row of starts), got {len(densities)} entries"
        )
    return densities


def proposal_chols(proposal_cov, n_chains, r):
    """Lower Cholesky factor of each chain's initial proposal covariance."""
    if proposal_cov is None:
        proposal_cov = np.broadcast_to(OPTIMAL_SCALE / r * np.eye(r), (n_chains, r, r))
    else:
        proposal_cov = np.asarray(proposal_cov, dtype=float)
        if proposal_cov.shape == (r, r):
            proposal_cov = np.broadcast_to(proposal_cov, (n_chains, r, r))
        elif proposal_cov.shape != (n_chains, r, r):
            raise ValueError(
                f"proposal_cov must have shape ({r}, {r}) or ({n_chains}, {r}, {r}), "
                f"got {proposal_cov.shape}"
            )
    chols = []
    for c in range(n_chains):
        cov = proposal_cov[c]
        if not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T):
            raise ValueError("proposal_cov must be finite and symmetric")
        try:
            chols.append(linalg.cholesky(cov, lower=True))
        except linalg.LinAlgError:
            raise ValueError("proposal_cov must be positive definite") from None
    return chols


def check_independence(independence):
    """``independence`` as a float in [0, 1)."""
    if isinstance(independence, bool | np.bool_) or not isinstance(
        independence, int | float | np.integer | np.floating
    ):
        raise TypeError(
            f"independence must be a number in [0, 1), got {independence!r}"
        )
    if not 0.0 <= independence < 1.0:
        raise ValueError(
            f"independence must be in [0, 1), got {independence!r}: it is the "
            "probability of an independence move; some random-walk moves "
            "must remain (0 for the random walk alone)"
        )
    return float(independence)


def check_moments(moments, r):
    """``moments`` as a float mean (r,) and covariance (r, r), or None."""
    if moments is None:
        return None
    try:
        mean, cov = moments
    except (TypeError, ValueError):
        raise ValueError(
            "moments must be a pair (mean, cov) of the target's mean and "
            f"covariance, got {moments!r}"
        ) from None
    mean = np.atleast_1d(np.asarray(mean, dtype=float))
    cov = np.atleast_2d(np.asarray(cov, dtype=float))
    if mean.shape != (r,) or cov.shape != (r, r):
        raise ValueError(
            f"moments must be a mean of shape ({r},) and a covariance of shape "
            f"({r}, {r}) for starts with {r} columns; got shapes {mean.shape} "
            f"and {cov.shape}"
        )
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        raise ValueError("moments must be finite (mean and covariance).")
    return mean, cov


def check_points(points, r):
    """``points`` as a finite float array (m, r) with m >= 2, or None."""
    if points is None:
        return None
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != r or len(points) < 2:
        raise ValueError(
            f"proposal_points must be an array of shape (m, {r}) with at least "
            f"two rows for starts with {r} columns; got shape {points.shape}"
        )
    if not np.all(np.isfinite(points)):
        raise ValueError("proposal_points must be finite.")
    return points
