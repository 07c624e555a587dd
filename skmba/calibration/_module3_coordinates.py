"""The coordinates in which module 3's chains sample theta.

:class:`SamplingCoordinates` maps theta (user units) to ``u`` and back,
with the log Jacobian of the map: log coordinates for (practically)
positive parameters, soft ends (:func:`soft_ends`) for a finite support,
then a standardisation by the simulated parameters.
:class:`~skmba.calibration._module3_posterior.LogPosterior` holds one. Why
soft ends and not a logit: docs/internals.rst, section
skmba.calibration._module3_coordinates.

Examples
--------
>>> import numpy as np
>>> from scipy import stats
>>> from skmba.calibration._module3_coordinates import SamplingCoordinates
>>> from skmba.priors._theta import check_prior
>>> prior = check_prior([stats.uniform(1.0, 2.0), stats.norm()])
>>> coordinates = SamplingCoordinates.of(prior, prior.rvs(20, random_state=0))
>>> coordinates.log_dims, coordinates.bounded_dims
(array([ True, False]), array([ True, False]))
>>> theta = np.array([[2.0, 0.5]])
>>> bool(np.allclose(coordinates.from_u(coordinates.to_u(theta)), theta))
True
"""

from dataclasses import dataclass

import numpy as np

#: The scale of the soft ends of a finite support, as a share of its width
#: (:func:`soft_ends`): farther than a few times it from both ends, the
#: sampling coordinate is the parameter itself (or its log).
EDGE_SHARE = 0.02


def soft_ends(x, low, width):
    """``v`` of ``x`` in ``(a, b) = (low, low + width)``, and ``log dx/dv``.

    ``y = b - s g((b - x) / s)``, ``v = a + s g((y - a) / s)`` with ``g(t)
    = log(exp(t) - 1)``, the inverse of the softplus, and ``s`` =
    :data:`EDGE_SHARE` times the width: ``v = x`` to within ``s exp(-d /
    s)`` at a distance ``d`` from the ends, which go to minus and plus
    infinity. ``dx/dv = (1 - exp(-(y - a) / s)) (1 - exp(-(b - x) / s))``.
    """
    scale = EDGE_SHARE * width
    high = low + width
    t_high = (high - x) / scale
    log_high = np.log(-np.expm1(-t_high))  # log(1 - exp(-t))
    y = high - scale * (t_high + log_high)
    t_low = (y - low) / scale
    log_low = np.log(-np.expm1(-t_low))
    return low + scale * (t_low + log_low), log_low + log_high


@dataclass(frozen=True)
class SamplingCoordinates:
    """theta (user units) to the chains' coordinates ``u`` and back (frozen).

    Parameters whose prior is (practically) positive (stiffnesses, moduli,
    areas) are sampled as ``log theta``, where posterior ridges such as
    ``E I = const`` are straight and random-walk proposals follow them far
    better: where the prior puts at most 1e-6 of its mass on non-positive
    values (the support, when finite; else the lower end of the central 1 -
    2e-6 interval), truncating that mass being negligible. A parameter
    whose support is a finite interval ``[a, b]`` (a uniform or log-uniform
    prior; of ``log theta`` in log coordinates, but for ``a = 0``, which
    they already send to minus infinity) has soft ends
    (:func:`soft_ends`): the coordinate is the parameter (or its log)
    farther than a few :data:`EDGE_SHARE` widths from both ends, which it
    pushes to infinity, so that a posterior reaching an end (a parameter
    the data leave near its prior) falls off smoothly there instead of at a
    wall the chains' proposals do not see. Then ``u`` is standardised with
    the simulated parameters (each coordinate with those that have one).

    Attributes
    ----------
    log_dims, bounded_dims : ndarray of bool, shape (r,)
        The parameters in log coordinates and those with soft ends.
    support : ndarray of shape (r, 2)
        The prior's support (user units).
    low, width : ndarray of shape (r,)
        The soft ends' ``a`` and ``b - a`` (of ``log theta`` in log
        coordinates); 0 and 1 elsewhere.
    u_mean, u_scale : ndarray of shape (r,)
        The standardisation.
    """

    log_dims: np.ndarray
    bounded_dims: np.ndarray
    support: np.ndarray
    low: np.ndarray
    width: np.ndarray
    u_mean: np.ndarray
    u_scale: np.ndarray

    @classmethod
    def of(cls, prior, theta_sim):
        """The coordinates of ``prior``, standardised by ``theta_sim`` (N, r)."""
        support = prior.support()
        lower = prior.bounds(1.0 - 2e-6)[:, 0]
        log_dims = (lower >= 0) & np.all(theta_sim > 0, axis=0)
        # Soft ends on a finite support, but for [0, b] in log coordinates,
        # whose lower end is already at minus infinity (b stays a wall).
        bounded = np.all(np.isfinite(support), axis=1) & ~(
            log_dims & (support[:, 0] <= 0)
        )
        # The support's ends in the coordinates whose ends are pushed away.
        with np.errstate(divide="ignore", invalid="ignore"):
            ends = np.where(log_dims[:, None], np.log(support), support)
        low = np.where(bounded, ends[:, 0], 0.0)
        width = np.where(bounded, np.ptp(ends, axis=1), 1.0)
        unscaled = cls(log_dims, bounded, support, low, width, 0.0, 1.0)
        # Simulations on a support's end (or outside it) have no u there:
        # each coordinate is standardised with the simulations that have
        # one (none: left as it is).
        u = unscaled.to_u(theta_sim)
        finite = np.isfinite(u)
        count = np.maximum(finite.sum(axis=0), 1)
        mean = np.where(finite, u, 0.0).sum(axis=0) / count
        spread = np.square(np.where(finite, u - mean, 0.0))
        scale = np.sqrt(spread.sum(axis=0) / count)
        return cls(
            log_dims,
            bounded,
            support,
            low,
            width,
            mean,
            np.where(scale > 0, scale, 1.0),
        )

    def _unscaled(self, theta):
        """``v`` of ``theta`` (..., r), before the standardisation, and
        :meth:`log_jacobian` there."""
        v = np.array(theta, dtype=float)
        ends = self.bounded_dims
        with np.errstate(divide="ignore", invalid="ignore"):
            v[..., self.log_dims] = np.log(v[..., self.log_dims])
            log_theta = np.sum(v[..., self.log_dims], axis=-1)
            v[..., ends], log_slope = soft_ends(
                v[..., ends], self.low[ends], self.width[ends]
            )
        return v, log_theta + np.sum(log_slope, axis=-1)

    def to_u(self, theta):
        """Sampling coordinates of ``theta`` (..., r); not finite on or
        outside the ends of a finite support."""
        return (self._unscaled(theta)[0] - self.u_mean) / self.u_scale

    def from_u(self, u):
        """``theta`` of sampling coordinates ``u`` (..., r)."""
        theta = np.asarray(u, dtype=float) * self.u_scale + self.u_mean
        ends = self.bounded_dims
        low, width = self.low[ends], self.width[ends]
        scale = EDGE_SHARE * width
        # x = b - s softplus((b - y) / s), y = a + s softplus((v - a) / s)
        y = low + scale * np.logaddexp(0.0, (theta[..., ends] - low) / scale)
        theta[..., ends] = (
            low + width - scale * np.logaddexp(0.0, (low + width - y) / scale)
        )
        theta[..., self.log_dims] = np.exp(theta[..., self.log_dims])
        # exp(log b) may round past b
        theta[..., ends] = np.clip(
            theta[..., ends], self.support[ends, 0], self.support[ends, 1]
        )
        return theta

    def log_jacobian(self, theta):
        """``log |d theta / d v|`` at ``theta`` (..., r), ``v = u u_scale +
        u_mean`` (the constant ``sum(log u_scale)`` left out): ``log theta``
        summed over the log coordinates, plus the soft ends'
        (:func:`soft_ends`); ``-inf`` on a support's end."""
        return self._unscaled(theta)[1]
