"""Priors of the calibration parameters theta.

Module 2 and the posterior of :mod:`skmba` need five things from the prior
``p(θ)`` of the ``r`` calibration parameters: its log-density (for MCMC),
random draws, bounds (for designing simulations and bounding the sampler),
nodes and weights for expectations ``E_prior[f(θ)]`` (the integrals of
Module 2, see :mod:`skmba._integration`) and a map from the unit cube to
``θ`` (for space-filling designs). :func:`check_prior` turns what the user
gives into a :class:`Prior` with that interface:

* a list of ``r`` frozen continuous univariate ``scipy.stats``
  distributions, independent of each other (a single frozen distribution
  is accepted as ``r = 1``): :class:`IndependentPrior`;
* a frozen ``scipy.stats.multivariate_normal``: :class:`GaussianPrior`;
* any object with ``logpdf`` and ``rvs`` methods (optionally ``dim`` and
  ``ppf``), such as a frozen ``scipy.stats.multivariate_t`` or a user
  class: :class:`GenericPrior`.

Every method is vectorised over the rows of ``theta``, of shape ``(m, r)``.
A 1-D ``theta`` is read as follows, so that the result is always 1-D with
one entry per point, never a scalar: for ``r > 1`` a vector of length
``r`` is one point (result of shape ``(1,)``); for ``r = 1`` a vector of
length ``m`` is ``m`` points (result of shape ``(m,)``) and a scalar is one
point.

Examples
--------
>>> from scipy.stats import norm, uniform
>>> from skmba._priors import check_prior
>>> prior = check_prior([uniform(20e3, 80e3), norm(0.05, 0.01)])
>>> prior
IndependentPrior([uniform(loc=20000, scale=80000), norm(loc=0.05, scale=0.01)])
>>> prior.dim
2
>>> prior.bounds().round(4)
array([[2.000e+04, 1.000e+05],
       [1.710e-02, 8.290e-02]])
>>> prior.rvs(3, random_state=0).shape
(3, 2)
"""

import math
import numbers
import warnings

import numpy as np
from numpy.polynomial.legendre import leggauss
from scipy import linalg, stats
from scipy.stats import qmc
from sklearn.utils import check_random_state

#: Points of the unit cube are kept in ``[_U_EPS, 1 - _U_EPS]`` before a
#: quantile function is applied, so that unbounded priors give finite nodes.
_U_EPS = 1e-12

#: Number of fixed-seed draws behind the bounds, mean and covariance of a
#: :class:`GenericPrior`, and the seed used for them.
_N_GENERIC_DRAWS = 20000
_GENERIC_SEED = 0

_LOG_2PI = math.log(2.0 * math.pi)

_PRIOR_FORMS = (
    "a list of frozen continuous scipy.stats distributions, one per "
    "parameter (e.g. [uniform(20e3, 80e3), norm(50e3, 1e4)]), a frozen "
    "scipy.stats.multivariate_normal(mean, cov), or an object with logpdf "
    "and rvs methods"
)

_MVN_FROZEN = type(stats.multivariate_normal(mean=[0.0]))

_ENTRY_FORM = (
    "a frozen continuous scipy.stats distribution such as uniform(20e3, 80e3) "
    "or norm(50e3, 1e4)"
)


def _is_frozen_univariate(obj):
    """Whether ``obj`` is a frozen ``scipy.stats`` univariate distribution."""
    return isinstance(
        getattr(obj, "dist", None), (stats.rv_continuous, stats.rv_discrete)
    )


def _is_multivariate_generator(obj):
    """Whether ``obj`` is an unfrozen multivariate ``scipy.stats`` object.

    The class is private in scipy, so it is recognised by name.
    """
    return any(c.__name__ == "multi_rv_generic" for c in type(obj).__mro__)


def _describe_univariate(dist):
    """``norm(loc=0, scale=1)``-style text for a frozen distribution."""
    names = []
    shapes = dist.dist.shapes
    if shapes:
        names = [s.strip() for s in shapes.split(",")]
    names = [*names, "loc", "scale"]
    parts = [f"{name}={value:g}" for name, value in zip(names, dist.args, strict=False)]
    parts += [f"{name}={value:g}" for name, value in dist.kwds.items()]
    return f"{dist.dist.name}({', '.join(parts)})"


def _safe_describe(dist):
    try:
        return _describe_univariate(dist)
    except (TypeError, ValueError):
        return repr(dist)


def _check_univariate(dist, where):
    """Validate one frozen continuous univariate distribution.

    ``where`` names it in messages, e.g. ``"prior"`` or ``"prior[1]"``.
    """
    if dist is None:
        raise TypeError(f"{where} is None; each entry must be {_ENTRY_FORM}.")
    if isinstance(dist, type):
        raise TypeError(
            f"{where} is the class {dist.__name__}, not a distribution; "
            f"each entry must be {_ENTRY_FORM}."
        )
    if isinstance(dist, (stats.rv_continuous, stats.rv_discrete)):
        name = getattr(dist, "name", type(dist).__name__)
        raise TypeError(
            f"{where} is the unfrozen distribution scipy.stats.{name}; freeze "
            f"it with its parameters, e.g. {name}(loc=..., scale=...) (or "
            f"{name}() for the default ones)."
        )
    if _is_frozen_univariate(dist) and isinstance(dist.dist, stats.rv_discrete):
        raise TypeError(
            f"{where} is the discrete distribution {_safe_describe(dist)}; "
            "calibration parameters are continuous: use a continuous "
            "distribution such as uniform or norm."
        )
    if not _is_frozen_univariate(dist):
        if not callable(getattr(dist, "logpdf", None)):
            raise TypeError(
                f"{where} of type {type(dist).__name__} has no logpdf method; "
                f"each entry must be {_ENTRY_FORM}."
            )
        raise TypeError(
            f"{where} of type {type(dist).__name__} is not a frozen "
            f"scipy.stats univariate distribution; each entry must be "
            f"{_ENTRY_FORM}. For a joint prior of your own, pass a single "
            "object with logpdf and rvs methods instead of a list."
        )
    values = [*dist.args, *dist.kwds.values()]
    for value in values:
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"{where} has a non-numeric parameter {value!r}; give numbers."
            ) from None
        if array.size != 1:
            raise ValueError(
                f"{where} has a parameter with {array.size} values; it must "
                "describe one parameter: use a list with one distribution per "
                "parameter instead of vector-valued arguments."
            )
        if not np.isfinite(array).all():
            raise ValueError(
                f"{where}, {_describe_univariate(dist)}, has non-finite "
                "parameters; give finite loc, scale and shape parameters."
            )
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        q25, q75 = np.asarray(dist.ppf([0.25, 0.75]), dtype=float)
    if not (np.isfinite(q25) and np.isfinite(q75) and q75 > q25):
        raise ValueError(
            f"{where}, {_describe_univariate(dist)}, has zero width or invalid "
            "parameters (the scale must be > 0 and shape parameters within "
            "their domain). A parameter known exactly is not calibrated: fix "
            "it as an input instead, or give its prior a positive width."
        )
    return dist


def _check_rng(random_state):
    """A RandomState or Generator from an int, None, RandomState or Generator."""
    if isinstance(random_state, np.random.Generator):
        return random_state
    if isinstance(random_state, bool):
        raise ValueError(
            "random_state must be an int, None, a numpy RandomState or a "
            f"numpy Generator; got {random_state!r}."
        )
    return check_random_state(random_state)


def _check_count(n, name="n"):
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise ValueError(f"{name} must be a positive integer; got {n!r}.")
    return int(n)


def _check_coverage(coverage):
    if not (isinstance(coverage, numbers.Real) and 0.0 < coverage < 1.0):
        raise ValueError(
            f"coverage must be a probability strictly between 0 and 1; got "
            f"{coverage!r}."
        )
    return float(coverage)


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
    if isinstance(random_state, numbers.Integral):
        random_state = int(random_state)
    elif isinstance(random_state, np.random.RandomState):
        # scipy's Sobol cannot spawn from a RandomState: seed a Generator
        random_state = np.random.default_rng(random_state.randint(2**31))
    m = max(0, math.ceil(math.log2(n)))
    try:
        engine = qmc.Sobol(d=d, scramble=True, rng=random_state)
    except TypeError:  # scipy < 1.15 names it seed
        engine = qmc.Sobol(d=d, scramble=True, seed=random_state)
    return engine.random_base2(m)


class Prior:
    """Base class of the priors of the calibration parameters.

    Do not instantiate it: use :func:`check_prior`, or one of
    :class:`IndependentPrior`, :class:`GaussianPrior` and
    :class:`GenericPrior`. All share this interface.
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
        try:
            x = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"{name} must be an array of numbers of shape (m, {self.dim})."
            ) from None
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
        n = _check_count(n)
        return self._rvs(n, _check_rng(random_state))

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
        return self._bounds(_check_coverage(coverage))

    def _is_gaussian_1d(self):
        """Whether this is a one-parameter normal prior."""
        if isinstance(self, GaussianPrior):
            return True
        dists = getattr(self, "distributions", [])
        return len(dists) == 1 and getattr(dists[0].dist, "name", "") == "norm"

    def integration_nodes(self, n, random_state=None):
        """Nodes and weights for expectations over the prior.

        ``E_prior[f(θ)] ≈ sum_k weights[k] * f(nodes[k])``. With one
        parameter and a quantile function (:class:`IndependentPrior`,
        :class:`GaussianPrior`), this is the prior-quantile Gauss-Legendre
        rule (Gauss-Hermite for a normal prior):
        ``E[f(θ)] = ∫_0^1 f(ppf(u)) du`` is computed with the
        ``n``-point Gauss-Legendre rule mapped to ``(0, 1)`` (nodes
        ``ppf(u_k)``, weights half the Gauss-Legendre ones), exact when
        ``f∘ppf`` is a polynomial of degree ``< 2n`` (e.g. moments of a
        uniform prior) and slower for heavy tails, where ``ppf`` is
        unbounded. With several parameters, ``n`` is rounded up to a power
        of two and the nodes are a scrambled Sobol sequence mapped by
        :meth:`transform`, with equal weights. A :class:`GenericPrior`
        uses ``n`` draws of :meth:`rvs` with equal weights (Monte Carlo).

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
        n = _check_count(n)
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
        :class:`IndependentPrior` (product of marginal CDF differences) and
        one-parameter :class:`GaussianPrior`; otherwise the fraction of 20000
        draws with the fixed seed 0 inside the box (standard error below
        0.004), so the result is reproducible.

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
        >>> from skmba._priors import check_prior
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
        return self.rvs(_N_GENERIC_DRAWS, random_state=_GENERIC_SEED)

    def _mass_inside(self, lower, upper):
        draws = self._box_draws()
        inside = np.all((draws >= lower) & (draws <= upper), axis=1)
        return inside.mean()


class IndependentPrior(Prior):
    """Independent frozen univariate ``scipy.stats`` distributions.

    Parameters
    ----------
    distributions : list of frozen scipy.stats continuous distributions
        One per calibration parameter.

    Notes
    -----
    :meth:`bounds` returns the support of a parameter when it is a finite
    interval (uniform, beta, truncated normal...) and the central
    ``coverage`` interval otherwise (including half-bounded supports such
    as the lognormal's). :meth:`mean` and :meth:`cov` are the marginal
    means and variances (NaN or inf for, e.g., a Cauchy prior).

    Examples
    --------
    >>> from scipy.stats import norm, uniform
    >>> from skmba._priors import IndependentPrior
    >>> prior = IndependentPrior([uniform(0, 2), norm(1, 0.5)])
    >>> prior.logpdf([[1.0, 1.0], [3.0, 1.0]]).round(4)
    array([-0.9189,    -inf])
    >>> prior.mean(), prior.cov()
    (array([1., 1.]), array([[0.3333, 0.    ],
           [0.    , 0.25  ]]))
    >>> prior.transform([[0.5, 0.5]])
    array([[1., 1.]])
    """

    _quantile_nodes = True

    def __init__(self, distributions):
        if not isinstance(distributions, (list, tuple)) or not distributions:
            raise ValueError(
                "prior must be a non-empty list of frozen scipy.stats "
                "distributions, one per parameter."
            )
        self.distributions = [
            _check_univariate(d, f"prior[{i}]") for i, d in enumerate(distributions)
        ]
        self._dim = len(self.distributions)

    def __repr__(self):
        inner = ", ".join(_describe_univariate(d) for d in self.distributions)
        return f"IndependentPrior([{inner}])"

    def _logpdf(self, theta):
        out = np.zeros(len(theta))
        for j, dist in enumerate(self.distributions):
            out = out + dist.logpdf(theta[:, j])
        return out

    def _rvs(self, n, rng):
        columns = [
            np.asarray(d.rvs(size=n, random_state=rng), dtype=float).reshape(n)
            for d in self.distributions
        ]
        return np.column_stack(columns)

    def _bounds(self, coverage):
        tail = (1.0 - coverage) / 2.0
        out = np.empty((self.dim, 2))
        for j, dist in enumerate(self.distributions):
            low, high = (float(v) for v in dist.support())
            if np.isfinite(low) and np.isfinite(high):
                out[j] = low, high
            else:
                out[j] = dist.ppf([tail, 1.0 - tail])
        return out

    def _transform(self, u):
        columns = [d.ppf(u[:, j]) for j, d in enumerate(self.distributions)]
        return np.column_stack(columns).astype(float)

    def _mean_value(self):
        return [d.mean() for d in self.distributions]

    def _mass_inside(self, lower, upper):
        mass = 1.0
        for j, dist in enumerate(self.distributions):
            if upper[j] < lower[j]:
                return 0.0
            mass *= float(dist.cdf(upper[j]) - dist.cdf(lower[j]))
        return mass

    def _cov_value(self):
        return np.diag([d.var() for d in self.distributions])


class GaussianPrior(Prior):
    """Multivariate normal prior, from a frozen ``multivariate_normal``.

    Parameters
    ----------
    distribution : frozen scipy.stats.multivariate_normal
        With a finite mean and a finite, positive-definite covariance.

    Notes
    -----
    :meth:`transform` maps ``u`` to ``mean + L norm.ppf(u)`` with ``L`` the
    lower Cholesky factor of the covariance; :meth:`bounds` are the central
    ``coverage`` intervals of the marginals.

    Examples
    --------
    >>> from scipy.stats import multivariate_normal
    >>> from skmba._priors import GaussianPrior
    >>> prior = GaussianPrior(multivariate_normal([0.0, 1.0], [[1.0, 0.5], [0.5, 2.0]]))
    >>> prior.logpdf([0.0, 1.0]).round(4)
    array([-2.1177])
    >>> prior.bounds(0.95).round(3)
    array([[-1.96 ,  1.96 ],
           [-1.772,  3.772]])
    """

    _quantile_nodes = True

    def __init__(self, distribution):
        if not isinstance(distribution, _MVN_FROZEN):
            raise TypeError(
                "prior must be a frozen scipy.stats.multivariate_normal(mean, "
                f"cov) for a GaussianPrior; got {type(distribution).__name__}."
            )
        mean = np.asarray(distribution.mean, dtype=float).ravel()
        cov = np.atleast_2d(np.asarray(distribution.cov, dtype=float))
        if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
            raise ValueError(
                "prior, a multivariate_normal, has non-finite parameters; give "
                "a finite mean and covariance."
            )
        try:
            chol = linalg.cholesky(cov, lower=True)
        except linalg.LinAlgError:
            chol = None
        if chol is None or not np.all(np.diag(chol) > 0.0):
            raise ValueError(
                "prior, a multivariate_normal, has a singular covariance (zero "
                "width in some direction); give a positive-definite covariance, "
                "or fix the parameters known exactly as inputs instead."
            )
        self.distribution = distribution
        self._mean = mean
        self._cov = cov
        self._chol = chol
        self._dim = len(mean)
        self._log_norm = 0.5 * self._dim * _LOG_2PI + np.sum(np.log(np.diag(chol)))

    def __repr__(self):
        kwargs = {"separator": ", ", "precision": 6, "max_line_width": 10**6}
        mean = np.array2string(self._mean, **kwargs)
        rows = ", ".join(np.array2string(row, **kwargs) for row in self._cov)
        cov = f"[{rows}]"
        return f"GaussianPrior(mean={mean}, cov={cov})"

    def _logpdf(self, theta):
        z = linalg.solve_triangular(
            self._chol, (theta - self._mean).T, lower=True, check_finite=False
        )
        return -0.5 * np.sum(z**2, axis=0) - self._log_norm

    def _rvs(self, n, rng):
        return self._mean + rng.standard_normal((n, self.dim)) @ self._chol.T

    def _bounds(self, coverage):
        half = stats.norm.ppf(0.5 + coverage / 2.0) * np.sqrt(np.diag(self._cov))
        return np.column_stack([self._mean - half, self._mean + half])

    def _transform(self, u):
        return self._mean + stats.norm.ppf(u) @ self._chol.T

    def _mean_value(self):
        return self._mean

    def _mass_inside(self, lower, upper):
        if self.dim == 1:
            sd = float(np.sqrt(self._cov[0, 0]))
            if upper[0] < lower[0]:
                return 0.0
            cdf = stats.norm.cdf([lower[0], upper[0]], loc=self._mean[0], scale=sd)
            return float(cdf[1] - cdf[0])
        return super()._mass_inside(lower, upper)

    def _cov_value(self):
        return self._cov


class GenericPrior(Prior):
    """Prior given by any object with ``logpdf`` and ``rvs`` methods.

    Parameters
    ----------
    distribution : object
        With ``logpdf(theta)``, taking an ``(m, r)`` array and returning
        ``m`` log-densities, and ``rvs(size=n, random_state=rng)``,
        returning ``(n, r)`` draws (``(n,)`` accepted when ``r = 1``);
        ``rng`` is a numpy ``RandomState`` or ``Generator``. Optional: an
        integer ``dim`` and ``ppf(u)``, mapping ``(m, r)`` points of the
        unit cube to ``(m, r)`` values of ``θ`` distributed as the prior
        when ``u`` is uniform (used by :meth:`transform`).
    dim : int, optional
        The number of parameters; by default ``distribution.dim``, else the
        width of a draw.

    Notes
    -----
    Nothing but draws is known of such a prior, so :meth:`bounds` are
    empirical quantiles, and :meth:`mean` and :meth:`cov` sample moments, of
    20000 draws with the fixed seed 0 (made once, then cached);
    :meth:`integration_nodes` is plain Monte Carlo with ``n`` draws and
    equal weights (error ``O(n^-1/2)``); :meth:`transform` needs ``ppf``
    and raises NotImplementedError otherwise.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.stats import multivariate_t
    >>> from skmba._priors import GenericPrior
    >>> prior = GenericPrior(multivariate_t([0.0, 0.0], np.eye(2), df=5))
    >>> prior.dim, prior.rvs(4, random_state=0).shape
    (2, (4, 2))
    >>> float(prior.logpdf([0.0, 0.0])[0]) > float(prior.logpdf([3.0, 0.0])[0])
    True
    """

    def __init__(self, distribution, dim=None):
        if callable(getattr(distribution, "icdf", None)) and not callable(
            getattr(distribution, "rvs", None)
        ):
            raise TypeError(
                f"prior of type {type(distribution).__name__} is one of scipy's "
                "new distribution objects, which are not supported; use the "
                "frozen classic ones instead, e.g. scipy.stats.norm(loc, scale)."
            )
        for method in ("logpdf", "rvs"):
            if not callable(getattr(distribution, method, None)):
                raise TypeError(
                    f"prior of type {type(distribution).__name__} has no "
                    f"{method} method; prior must be {_PRIOR_FORMS}."
                )
        self.distribution = distribution
        own = getattr(distribution, "dim", None)
        if own is not None and not (
            isinstance(own, numbers.Integral) and not isinstance(own, bool)
        ):
            own = None  # e.g. a method, not the documented integer
        if dim is not None and own is not None and int(own) != dim:
            raise ValueError(
                f"prior has dim={own} but {dim} parameters were expected; give "
                f"a prior over exactly {dim} parameters."
            )
        if dim is None and own is not None:
            dim = int(own)
        self._dim = dim
        # One small draw checks rvs and logpdf, and gives dim if unknown.
        draws = self._call_rvs(2, np.random.RandomState(_GENERIC_SEED))
        try:
            logp = np.asarray(self._logpdf(draws), dtype=float)
        except Exception as error:
            raise ValueError(
                f"prior's logpdf failed on two draws of its rvs, of shape "
                f"(2, {self._dim}): {error}"
            ) from error
        if logp.size != 2 or np.isnan(logp).any() or np.isposinf(logp).any():
            raise ValueError(
                f"prior's logpdf returned {logp.ravel()!r} for two draws of its "
                f"rvs, of shape (2, {self._dim}); it must return one finite value "
                "or -inf per row."
            )
        self._draws = None

    def __repr__(self):
        return f"GenericPrior({self.distribution!r}, dim={self.dim})"

    def _call_rvs(self, n, rng):
        draws = np.asarray(self.distribution.rvs(size=n, random_state=rng), dtype=float)
        if self._dim is None:
            if draws.ndim == 1 and len(draws) == n:
                self._dim = 1
            elif draws.ndim == 2 and len(draws) == n and draws.shape[1] >= 1:
                self._dim = draws.shape[1]
            else:
                raise ValueError(
                    f"prior's rvs(size={n}) returned shape {draws.shape}; it "
                    f"must return ({n}, r)."
                )
        if draws.size != n * self._dim or (draws.ndim == 2 and len(draws) != n):
            raise ValueError(
                f"prior's rvs(size={n}) returned shape {draws.shape}; it must "
                f"return ({n}, {self._dim})."
            )
        return draws.reshape(n, self._dim)

    def _box_draws(self):
        return self._fixed_draws()

    def _fixed_draws(self):
        if self._draws is None:
            self._draws = self._call_rvs(
                _N_GENERIC_DRAWS, np.random.RandomState(_GENERIC_SEED)
            )
        return self._draws

    def _logpdf(self, theta):
        return self.distribution.logpdf(theta)

    def _rvs(self, n, rng):
        return self._call_rvs(n, rng)

    def _bounds(self, coverage):
        tail = (1.0 - coverage) / 2.0
        return np.quantile(self._fixed_draws(), [tail, 1.0 - tail], axis=0).T

    def _transform(self, u):
        ppf = getattr(self.distribution, "ppf", None)
        if not callable(ppf):
            raise NotImplementedError(
                f"transform needs the prior's quantile function, and "
                f"{type(self.distribution).__name__} has no ppf method: add a "
                "ppf(u) method mapping (m, r) points of the unit cube to theta, "
                "or give the prior as a list of frozen scipy.stats "
                "distributions or a multivariate_normal."
            )
        theta = np.asarray(ppf(u), dtype=float)
        if theta.size != u.size:
            raise ValueError(
                f"prior's ppf returned shape {theta.shape} for points of shape "
                f"{u.shape}; it must return the same shape."
            )
        return theta.reshape(u.shape)

    def _mean_value(self):
        return np.mean(self._fixed_draws(), axis=0)

    def _cov_value(self):
        return np.cov(self._fixed_draws(), rowvar=False)


def check_prior(prior, n_parameters=None):
    """Validate a prior of the calibration parameters and wrap it.

    Parameters
    ----------
    prior : list, frozen distribution, multivariate_normal, object or Prior
        A list (or tuple) of frozen continuous ``scipy.stats`` univariate
        distributions, independent, one per parameter; a single one (one
        parameter); a frozen ``scipy.stats.multivariate_normal``; any
        object with ``logpdf`` and ``rvs`` methods (see
        :class:`GenericPrior`); or a :class:`Prior`, returned as is.
    n_parameters : int, optional
        The number of calibration parameters expected; checked when given.

    Returns
    -------
    prior : Prior
        An :class:`IndependentPrior`, :class:`GaussianPrior` or
        :class:`GenericPrior`.

    Raises
    ------
    TypeError
        If ``prior`` is None, a class, an unfrozen or discrete distribution,
        or lacks ``logpdf``/``rvs``.
    ValueError
        If ``prior`` is an empty list, has non-finite parameters or zero
        width, or its number of parameters differs from ``n_parameters``.

    Examples
    --------
    >>> from scipy.stats import multivariate_normal, norm, uniform
    >>> from skmba._priors import check_prior
    >>> check_prior(norm(50e3, 1e4))
    IndependentPrior([norm(loc=50000, scale=10000)])
    >>> check_prior(multivariate_normal([1.0, 2.0], [[1.0, 0.0], [0.0, 4.0]]))
    GaussianPrior(mean=[1., 2.], cov=[[1., 0.], [0., 4.]])
    >>> check_prior([uniform(0, 1)], n_parameters=2)
    Traceback (most recent call last):
    ...
    ValueError: prior has 1 distribution(s) but there are 2 calibration parameters; ...
    """
    if n_parameters is not None and (
        isinstance(n_parameters, bool)
        or not isinstance(n_parameters, numbers.Integral)
        or n_parameters < 1
    ):
        raise ValueError(
            f"n_parameters must be a positive integer or None; got {n_parameters!r}."
        )
    if prior is None:
        raise TypeError(f"prior is None; give the prior of theta as {_PRIOR_FORMS}.")
    if isinstance(prior, Prior):
        result = prior
    elif isinstance(prior, type):
        raise TypeError(
            f"prior is the class {prior.__name__}, not a distribution; give "
            f"an instance: {_PRIOR_FORMS}."
        )
    elif isinstance(prior, (list, tuple)):
        if not prior:
            raise ValueError(
                "prior is an empty list; give one frozen scipy.stats "
                "distribution per calibration parameter."
            )
        if n_parameters is not None and len(prior) != n_parameters:
            raise ValueError(
                f"prior has {len(prior)} distribution(s) but there are "
                f"{n_parameters} calibration parameters; give one distribution "
                "per parameter."
            )
        result = IndependentPrior(list(prior))
    elif isinstance(prior, (stats.rv_continuous, stats.rv_discrete)) or (
        _is_frozen_univariate(prior)
    ):
        result = IndependentPrior([_check_univariate(prior, "prior")])
    elif _is_multivariate_generator(prior):
        name = getattr(prior, "__class__", type(prior)).__name__.removesuffix("_gen")
        raise TypeError(
            f"prior is the unfrozen distribution scipy.stats.{name}; freeze it "
            f"with its parameters, e.g. {name}(mean=..., cov=...)."
        )
    elif isinstance(prior, _MVN_FROZEN):
        result = GaussianPrior(prior)
    else:
        result = GenericPrior(prior)
    if n_parameters is not None and result.dim != n_parameters:
        raise ValueError(
            f"prior is over {result.dim} parameter(s) but there are "
            f"{n_parameters} calibration parameters; give a prior of dimension "
            f"{n_parameters}."
        )
    return result
