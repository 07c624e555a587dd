"""Priors of the calibration parameters theta.

Module 2 and the posterior of :mod:`skmba` need five things from the prior ``p(θ)`` of
the ``r`` calibration parameters: its log-density (for MCMC), random draws, bounds (for
designing simulations and bounding the sampler), nodes and weights for expectations
``E_prior[f(θ)]`` (the integrals of Module 2, see
:mod:`skmba.calibration._module2_prior_integral`) and a map from the unit cube to ``θ``
(for space-filling designs). :func:`check_prior` turns what the user gives into a
:class:`Prior` with that interface:

* a list of ``r`` frozen continuous univariate ``scipy.stats``
  distributions, independent of each other (a single frozen distribution
  is accepted as ``r = 1``): :class:`IndependentPrior`; a dict ``{name:
  distribution}`` is the same with named parameters (``prior.names``);
* a frozen ``scipy.stats.multivariate_normal``: :class:`GaussianPrior`;
* any object with ``logpdf`` and ``rvs`` methods (optionally ``dim`` and
  ``ppf``), such as a frozen ``scipy.stats.multivariate_t`` or a user
  class: :class:`GenericPrior`.

Every prior has ``names``: the parameter names of a dict prior, in its
order, else None (the calibrator then calls them ``theta0, theta1, ...``).
The interface itself, and how a 1-D ``theta`` is read (one point, or ``m``
points when ``r = 1``), are those of the base class
:class:`~skmba.priors._base.Prior`; the checks of what the user gives are in
:mod:`skmba.priors._checks`.

Examples
--------
>>> from scipy.stats import norm, uniform
>>> from skmba.priors._theta import check_prior
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

import numbers
from collections.abc import Mapping

import numpy as np
from scipy import linalg, stats

from skmba._core.linalg import LOG_2PI
from skmba.priors._base import FIXED_SEED, N_FIXED_DRAWS, Prior
from skmba.priors._checks import (
    PRIOR_FORMS,
    check_parameter_names,
    check_univariate,
    describe_univariate,
    is_frozen_univariate,
    is_multivariate_generator,
)

__all__ = [
    "GaussianPrior",
    "GenericPrior",
    "IndependentPrior",
    "Prior",
    "check_prior",
]

_MVN_FROZEN = type(stats.multivariate_normal(mean=[0.0]))


class IndependentPrior(Prior):
    """Independent frozen univariate ``scipy.stats`` distributions.

    Parameters
    ----------
    distributions : list of frozen scipy.stats continuous distributions
        One per calibration parameter.
    names : sequence of str, default=None
        The parameter names (the keys of a dict prior), or None.

    Attributes
    ----------
    names : tuple of str or None

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
    >>> from skmba.priors import IndependentPrior
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

    def __init__(self, distributions, names=None):
        if not isinstance(distributions, (list, tuple)) or not distributions:
            raise ValueError(
                "prior must be a non-empty list of frozen scipy.stats "
                "distributions, one per parameter."
            )
        self.names = check_parameter_names(names, len(distributions))
        where = [f"prior[{i}]" for i in range(len(distributions))]
        if self.names is not None:
            where = [f"prior[{name!r}]" for name in self.names]
        self.distributions = [
            check_univariate(d, w) for d, w in zip(distributions, where, strict=True)
        ]
        self._dim = len(self.distributions)

    def __repr__(self):
        inner = ", ".join(describe_univariate(d) for d in self.distributions)
        if self.names is not None:
            return f"IndependentPrior([{inner}], names={list(self.names)!r})"
        return f"IndependentPrior([{inner}])"

    def _is_gaussian_1d(self):
        dists = self.distributions
        return len(dists) == 1 and getattr(dists[0].dist, "name", "") == "norm"

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

    def _support(self):
        return np.array([[float(v) for v in d.support()] for d in self.distributions])

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
    >>> from skmba.priors import GaussianPrior
    >>> prior = GaussianPrior(multivariate_normal([0.0, 1.0], [[1.0, 0.5], [0.5, 2.0]]))
    >>> prior.logpdf([0.0, 1.0]).round(4)
    array([-2.1177])
    >>> prior.bounds(0.95).round(3)
    array([[-1.96 ,  1.96 ],
           [-1.772,  3.772]])
    """

    _quantile_nodes = True
    #: Unnamed parameters (see the module docstring).
    names = None

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
        self._log_norm = 0.5 * self._dim * LOG_2PI + np.sum(np.log(np.diag(chol)))

    def __repr__(self):
        kwargs = {"separator": ", ", "precision": 6, "max_line_width": 10**6}
        mean = np.array2string(self._mean, **kwargs)
        rows = ", ".join(np.array2string(row, **kwargs) for row in self._cov)
        cov = f"[{rows}]"
        return f"GaussianPrior(mean={mean}, cov={cov})"

    def _is_gaussian_1d(self):
        return True

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
    >>> from skmba.priors import GenericPrior
    >>> prior = GenericPrior(multivariate_t([0.0, 0.0], np.eye(2), df=5))
    >>> prior.dim, prior.rvs(4, random_state=0).shape
    (2, (4, 2))
    >>> float(prior.logpdf([0.0, 0.0])[0]) > float(prior.logpdf([3.0, 0.0])[0])
    True
    """

    #: Unnamed parameters (see the module docstring).
    names = None

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
                    f"{method} method; prior must be {PRIOR_FORMS}."
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
        draws = self._call_rvs(2, np.random.RandomState(FIXED_SEED))
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
                N_FIXED_DRAWS, np.random.RandomState(FIXED_SEED)
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
    prior : list, dict, frozen distribution, multivariate_normal, object or Prior
        A list (or tuple) of frozen continuous ``scipy.stats`` univariate
        distributions, independent, one per parameter; a dict ``{name:
        distribution}`` of them, which also names the parameters (kept as
        ``names``, in the dict's order); a single one (one
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
    >>> from skmba.priors._theta import check_prior
    >>> check_prior(norm(50e3, 1e4))
    IndependentPrior([norm(loc=50000, scale=10000)])
    >>> check_prior(multivariate_normal([1.0, 2.0], [[1.0, 0.0], [0.0, 4.0]]))
    GaussianPrior(mean=[1., 2.], cov=[[1., 0.], [0., 4.]])
    >>> check_prior({"E": uniform(20e3, 80e3), "I": norm(2.0, 0.1)}).names
    ('E', 'I')
    >>> check_prior([uniform(0, 1)], n_parameters=2)
    Traceback (most recent call last):
    ...
    ValueError: prior has 1 distribution(s) but there are 2 calibration parameters; ...
    """
    _check_n_parameters(n_parameters)
    if prior is None:
        raise TypeError(f"prior is None; give the prior of theta as {PRIOR_FORMS}.")
    if isinstance(prior, Prior):
        result = prior
    elif isinstance(prior, type):
        raise TypeError(
            f"prior is the class {prior.__name__}, not a distribution; give "
            f"an instance: {PRIOR_FORMS}."
        )
    elif isinstance(prior, (list, tuple)):
        result = _independent_from_list(prior, n_parameters)
    elif isinstance(prior, Mapping):
        result = _independent_from_list(
            list(prior.values()), n_parameters, names=list(prior.keys())
        )
    elif isinstance(prior, (stats.rv_continuous, stats.rv_discrete)) or (
        is_frozen_univariate(prior)
    ):
        result = IndependentPrior([check_univariate(prior, "prior")])
    elif is_multivariate_generator(prior):
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


def _check_n_parameters(n_parameters):
    """Raise unless ``n_parameters`` is None or a positive integer."""
    if n_parameters is not None and (
        isinstance(n_parameters, bool)
        or not isinstance(n_parameters, numbers.Integral)
        or n_parameters < 1
    ):
        raise ValueError(
            f"n_parameters must be a positive integer or None; got {n_parameters!r}."
        )


def _independent_from_list(prior, n_parameters, names=None):
    """An :class:`IndependentPrior` from a list of distributions, one a parameter."""
    if not prior:
        raise ValueError(
            f"prior is an empty {'list' if names is None else 'dict'}; give one "
            "frozen scipy.stats distribution per calibration parameter."
        )
    if n_parameters is not None and len(prior) != n_parameters:
        raise ValueError(
            f"prior has {len(prior)} distribution(s) but there are "
            f"{n_parameters} calibration parameters; give one distribution "
            "per parameter."
        )
    return IndependentPrior(list(prior), names=names)
