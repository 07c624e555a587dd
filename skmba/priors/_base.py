"""The interface shared by the priors of the calibration parameters.

:class:`Prior` gives the five things Module 2 and the posterior need from
the prior ``p(θ)`` of the ``r`` calibration parameters (its log-density,
draws, bounds, integration nodes and a map from the unit cube) on top of a
few private methods each concrete prior of :mod:`skmba.priors._theta` defines
(``_logpdf``, ``_rvs``, ``_bounds``, ``_transform``, ``_mean_value``,
``_cov_value``, and optionally ``_mass_inside``).

Every method is vectorised over the rows of ``theta``, of shape ``(m, r)``.
A 1-D ``theta`` is read as follows, so that the result is always 1-D with
one entry per point, never a scalar: for ``r > 1`` a vector of length
``r`` is one point (result of shape ``(1,)``); for ``r = 1`` a vector of
length ``m`` is ``m`` points (result of shape ``(m,)``) and a scalar is one
point.

Examples
--------
>>> from scipy.stats import norm
>>> from skmba.priors._base import Prior
>>> from skmba.priors._theta import check_prior
>>> prior = check_prior(norm(0.0, 1.0))
>>> isinstance(prior, Prior)
True
>>> prior.logpdf([0.0, 1.0]).shape, prior.logpdf(0.0).shape
((2,), (1,))
>>> nodes, weights = prior.integration_nodes(5)
>>> nodes.shape, round(float(weights.sum()), 12)
((5, 1), 1.0)
"""

import math
import numbers

import numpy as np
from numpy.polynomial.legendre import leggauss
from scipy.stats import qmc

from skmba._core.validation import check_count, seed_sequence
from skmba.priors._checks import as_float_array, check_coverage, check_rng

#: Points of the unit cube are kept in ``[_U_EPS, 1 - _U_EPS]`` before a
#: quantile function is applied, so that unbounded priors give finite nodes.
_U_EPS = 1e-12

#: Number of fixed-seed draws behind the Monte Carlo box masses of
#: :meth:`Prior.mass_inside`, and the bounds, mean and covariance of a
#: :class:`skmba.priors._theta.GenericPrior`, and the seed used for them.
N_FIXED_DRAWS = 20000
FIXED_SEED = 0


def _sobol(d, n, random_state):
    """``2**ceil(log2(n))`` scrambled Sobol points in ``(0, 1)^d``."""
    if not (
        random_state is None
        or isinstance(random_state, (np.random.RandomState, np.random.Generator))
        or (isinstance(random_state, numbers.Integral) and random_state >= 0)
    ) or isinstance(random_state, bool):
        raise ValueError(
            "random_state must be a non-negative int, None, a numpy "
            f"RandomState or a numpy Generator; got {random_state!r}."
        )
    random_state = np.random.default_rng(seed_sequence(random_state))
    m = max(0, math.ceil(math.log2(n)))
    try:
        engine = qmc.Sobol(d=d, scramble=True, rng=random_state)
    except TypeError:  # scipy < 1.15 names it seed
        engine = qmc.Sobol(d=d, scramble=True, seed=random_state)
    return engine.random_base2(m)


class Prior:
    """Base class of the priors of the calibration parameters.

    Do not instantiate it: use one of :class:`~skmba.priors.IndependentPrior`,
    :class:`~skmba.priors.GaussianPrior` and :class:`~skmba.priors.GenericPrior`
    (what an estimator's ``prior=`` becomes once checked, by
    ``check_prior`` of :mod:`skmba.priors._theta`). All share this interface.
    """

    #: Whether :meth:`integration_nodes` uses quadrature or quasi-Monte Carlo
    #: through :meth:`transform` (True) or plain Monte Carlo (False).
    _quantile_nodes = False

    @property
    def dim(self):
        """int : The number ``r`` of calibration parameters."""
        return self._dim

    def _as_points(self, x, name="theta"):
        """``x`` as a float array of shape (m, r) (see the module docstring)."""
        x = as_float_array(
            x, f"{name} must be an array of numbers of shape (m, {self.dim})."
        )
        r = self.dim
        if x.ndim == 0 and r == 1:
            x = x.reshape(1, 1)
        elif x.ndim == 1 and r == 1:
            x = x[:, None]
        elif x.ndim == 1 and x.shape[0] == r:
            x = x[None, :]
        elif x.ndim != 2 or x.shape[1] != r:
            raise ValueError(
                f"{name} must have shape (m, {r}) (or ({r},) for one point); "
                f"got shape {x.shape}."
            )
        if np.isnan(x).any():
            raise ValueError(f"{name} contains NaN.")
        return x

    def _as_unit(self, u):
        u = self._as_points(u, name="u")
        if (u < 0.0).any() or (u > 1.0).any():
            raise ValueError("u must lie in the unit cube [0, 1]^r.")
        return np.clip(u, _U_EPS, 1.0 - _U_EPS)

    def logpdf(self, theta):
        """Log prior density at the rows of ``theta``.

        Parameters
        ----------
        theta : array-like of shape (m, r) or (r,)
            Points; a 1-D array is read as in the module docstring.

        Returns
        -------
        logpdf : ndarray of shape (m,)
            ``-inf`` outside the support, never NaN.
        """
        theta = self._as_points(theta)
        with np.errstate(invalid="ignore"):
            out = np.asarray(self._logpdf(theta), dtype=float)
        if out.size != len(theta):
            raise ValueError(
                f"the prior's logpdf returned {out.size} values for "
                f"{len(theta)} points; it must return one value per row of "
                f"an (m, {self.dim}) array."
            )
        out = out.reshape(len(theta))
        return np.where(np.isnan(out), -np.inf, out)

    def rvs(self, n, random_state=None):
        """Random draws from the prior.

        Parameters
        ----------
        n : int
            Number of draws.
        random_state : int, RandomState, Generator or None, default=None
            Seed or generator; an int gives the same draws on every call.

        Returns
        -------
        theta : ndarray of shape (n, r)
        """
        n = check_count(n, "n")
        return self._rvs(n, check_rng(random_state))

    def bounds(self, coverage=0.999):
        """Box containing the prior mass, for designs and for MCMC.

        Parameters
        ----------
        coverage : float, default=0.999
            Probability of the central interval used, in each dimension,
            when the support is not a finite interval.

        Returns
        -------
        bounds : ndarray of shape (r, 2)
            Lower and upper bound of each parameter.
        """
        return self._bounds(check_coverage(coverage))

    def support(self):
        """The ends of each parameter's support.

        Returns
        -------
        support : ndarray of shape (r, 2)
            Lower and upper end of each parameter's support, ``-inf`` and
            ``inf`` where it is unbounded (or, for a
            :class:`~skmba.priors.GenericPrior`, not known).
        """
        return self._support()

    def _support(self):
        return np.tile([-np.inf, np.inf], (self.dim, 1))

    def _is_gaussian_1d(self):
        """Whether this is a one-parameter normal prior (see subclasses)."""
        return False

    def integration_nodes(self, n, random_state=None):
        """Nodes and weights for expectations over the prior.

        ``E_prior[f(θ)] ≈ sum_k weights[k] * f(nodes[k])``. With one
        parameter and a quantile function
        (:class:`~skmba.priors.IndependentPrior`,
        :class:`~skmba.priors.GaussianPrior`), this is the prior-quantile
        Gauss-Legendre rule (Gauss-Hermite for a normal prior):
        ``E[f(θ)] = ∫_0^1 f(ppf(u)) du`` is computed with the
        ``n``-point Gauss-Legendre rule mapped to ``(0, 1)`` (nodes
        ``ppf(u_k)``, weights half the Gauss-Legendre ones), exact when
        ``f∘ppf`` is a polynomial of degree ``< 2n`` (e.g. moments of a
        uniform prior) and slower for heavy tails, where ``ppf`` is
        unbounded. With several parameters, ``n`` is rounded up to a power
        of two and the nodes are a scrambled Sobol sequence mapped by
        :meth:`transform`, with equal weights. A
        :class:`~skmba.priors.GenericPrior` uses ``n`` draws of :meth:`rvs`
        with equal weights (Monte Carlo).

        Parameters
        ----------
        n : int
            Number of nodes (rounded up to a power of two for Sobol nodes).
        random_state : int, RandomState, Generator or None, default=None
            Seed of the Sobol scrambling or of the Monte Carlo draws; an int
            gives the same nodes on every call. Unused by the deterministic
            one-parameter rule.

        Returns
        -------
        nodes : ndarray of shape (k, r)
        weights : ndarray of shape (k,)
            Positive, summing to one.
        """
        n = check_count(n, "n")
        if not self._quantile_nodes:
            nodes = self.rvs(n, random_state=random_state)
        elif self.dim == 1 and self._is_gaussian_1d():
            # Gauss-Hermite (probabilists'): exact for polynomials of degree
            # < 2n times the Gaussian, where the quantile rule converges
            # slowly because the normal ppf is unbounded.
            x, w = np.polynomial.hermite_e.hermegauss(n)
            mean, sd = float(self.mean()[0]), float(np.sqrt(self.cov()[0, 0]))
            return (mean + sd * x)[:, None], w / np.sum(w)
        elif self.dim == 1:
            x, w = leggauss(n)
            u = np.clip((x + 1.0) / 2.0, _U_EPS, 1.0 - _U_EPS)
            nodes = self._transform(u[:, None])
            return nodes, w / np.sum(w)
        else:
            u = np.clip(_sobol(self.dim, n, random_state), _U_EPS, 1.0 - _U_EPS)
            nodes = self._transform(u)
        weights = np.full(len(nodes), 1.0 / len(nodes))
        return nodes, weights

    def transform(self, u):
        """Map points of the unit cube to ``θ`` with the prior's quantiles.

        Uniform points ``u`` give points ``θ`` distributed as the prior, so
        space-filling designs on the cube become designs over the prior.
        ``u`` is clipped to ``[1e-12, 1 - 1e-12]`` first, so that unbounded
        priors give finite points.

        Parameters
        ----------
        u : array-like of shape (m, r) or (r,)
            Points of ``[0, 1]^r``.

        Returns
        -------
        theta : ndarray of shape (m, r)
        """
        return self._transform(self._as_unit(u))

    def mean(self):
        """Prior mean of ``θ``.

        Returns
        -------
        mean : ndarray of shape (r,)
        """
        return np.array(self._mean_value(), dtype=float).reshape(self.dim)

    def cov(self):
        """Prior covariance of ``θ``.

        Returns
        -------
        cov : ndarray of shape (r, r)
        """
        cov = np.array(self._cov_value(), dtype=float)
        return cov.reshape(self.dim, self.dim)

    def mass_inside(self, lower, upper):
        """Prior probability of the box ``lower <= θ <= upper``.

        Used to check that simulations cover the prior. Exact for
        :class:`~skmba.priors.IndependentPrior` (product of marginal CDF
        differences) and one-parameter :class:`~skmba.priors.GaussianPrior`;
        otherwise the fraction of 20000 draws with the fixed seed 0 inside
        the box (standard error below 0.004), so the result is reproducible.

        Parameters
        ----------
        lower, upper : array-like of shape (r,)
            Corners of the box (``-inf``/``inf`` allowed).

        Returns
        -------
        mass : float
            In ``[0, 1]``.

        Examples
        --------
        >>> from scipy.stats import norm, uniform
        >>> from skmba.priors._theta import check_prior
        >>> prior = check_prior([uniform(0, 2), norm(0, 1)])
        >>> round(prior.mass_inside([1.0, 0.0], [3.0, 10.0]), 4)
        0.25
        """
        lower = np.asarray(lower, dtype=float).reshape(-1)
        upper = np.asarray(upper, dtype=float).reshape(-1)
        if lower.shape != (self.dim,) or upper.shape != (self.dim,):
            raise ValueError(
                f"lower and upper must have {self.dim} values (one per "
                f"parameter); got {lower.size} and {upper.size}."
            )
        if np.isnan(lower).any() or np.isnan(upper).any():
            raise ValueError("lower and upper must not contain NaN.")
        return float(np.clip(self._mass_inside(lower, upper), 0.0, 1.0))

    def _box_draws(self):
        return self.rvs(N_FIXED_DRAWS, random_state=FIXED_SEED)

    def _mass_inside(self, lower, upper):
        draws = self._box_draws()
        inside = np.all((draws >= lower) & (draws <= upper), axis=1)
        return inside.mean()
