"""Theta's grids for the integral over module 2's hyperparameters.

The pieces of :func:`~skmba.calibration._module2_converged.converge` that
concern theta alone:

- :class:`ThetaGrid`: a trapezoid rule over one parameter, a lattice cut at
  the prior's 0.9999 interval, refined, subdivided or extended with its
  nodes kept;
- :class:`ThetaGrids`: the coarse grid where each draw's likelihood is
  evaluated and the fine one of the integral;
- :class:`GridEvaluator`: ``log p(data | theta_j, phi_k)`` on the coarse
  nodes (one stack of factorisations) and carried to the fine ones by a
  cubic spline; :func:`spline_error` checks the spline at the midpoints;
- :func:`grid_problems`, :func:`grid_summaries`, :func:`density_cdf`: what
  the grids need, and the posterior summaries on them.

Measurements: ``docs/internals.rst`` (skmba.calibration._module2_converged).
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy import interpolate, special

from skmba._core.linalg import FactorizationError
from skmba.calibration._module2_posterior import HyperposteriorDraws
from skmba.calibration._module3_mixture import ModelMixture

#: Largest error of the spline, in log likelihood, at a coarse midpoint
#: within :data:`_RELEVANT` of its draw's largest log posterior, above which
#: the coarse grid is refined (1 % of the density there).
SPLINE_TOL = 0.01
#: Largest range of a draw's log likelihood over the coarse nodes that is
#: splined (wider ranges, where the spline's slopes could overflow, are
#: evaluated at every fine node; their weight sits at one node anyway).
_SPLINE_SPAN = 1e100
#: Log posterior below a draw's largest where its spline is not checked.
_RELEVANT = 25.0
#: Draws checked against the spline: those carrying the most weight.
_N_CHECKED = 32
#: The interval whose ends the error covers.
INTERVAL = (0.025, 0.975)
#: Posterior mass within a coarse spacing of a grid end (not the prior's)
#: that extends the grid: a tail of 1e-5 at 20 sds moves the variance by
#: 4e-3 of itself, the sd by 0.002 sds, a 25th of ``AUTO_TOL`` (measured
#: against 1e-7 on a1, c1 and freq, seeds 0-2: the sd within 6e-4 sds,
#: 10-55 % fewer coarse nodes; docs/internals.rst).
_END_MASS = 1e-5
#: Posterior weight of draws whose conditional posterior of theta is
#: narrower than half the grid's spacing, above which the grid is refined
#: (at half a spacing the trapezoid rule's relative error on a Gaussian is
#: ``exp(-pi^2 / 2)``, 0.7 %).
_NARROW_SHARE = 0.01


@dataclass(frozen=True)
class ThetaGrid:
    """A trapezoid grid over one parameter (user units): a lattice of
    spacing ``step``, whose end intervals may be shorter where it stops at
    the prior's 0.9999 interval.

    Attributes
    ----------
    nodes : ndarray of shape (J,)
    log_weights : ndarray of shape (J,)
        ``log`` of the trapezoid weight times the prior density.
    support : tuple
        The prior's 0.9999 interval: ends at it are not extended.
    step : float
        The lattice's spacing.
    """

    nodes: np.ndarray
    log_weights: np.ndarray
    support: tuple
    step: float

    @classmethod
    def build(cls, prior, nodes, step, support=None):
        """The trapezoid rule of the increasing ``nodes``."""
        nodes = np.asarray(nodes, dtype=float)
        support = support or tuple(prior.bounds(0.9999)[0])
        with np.errstate(divide="ignore"):
            log_prior = np.ravel(prior.logpdf(nodes[:, None]))
        return cls(nodes, np.log(_trapezoid(nodes)) + log_prior, support, float(step))

    @property
    def spacings(self):
        """The trapezoid rule's weight of each node: a node's posterior
        weight over it is the density there."""
        return _trapezoid(self.nodes)

    def cdfs(self, P):
        """The CDFs at the nodes (J, K) of the trapezoid posteriors whose
        node weights are the columns of ``P`` (J, K)."""
        f = P / self.spacings[:, None]
        steps = 0.5 * (f[1:] + f[:-1]) * np.diff(self.nodes)[:, None]
        cdf = np.vstack([np.zeros((1, P.shape[1])), np.cumsum(steps, axis=0)])
        return cdf / cdf[-1]

    def at(self, x, rows):
        """The rows (J, ...) linearly interpolated at ``x`` (held at the
        ends beyond them), as :func:`numpy.interp` does for one column."""
        t = self.nodes
        i = min(max(int(np.searchsorted(t, x)), 1), len(t) - 1)
        frac = min(max((x - t[i - 1]) / (t[i] - t[i - 1]), 0.0), 1.0)
        return rows[i - 1] + frac * (rows[i] - rows[i - 1])

    @classmethod
    def around(cls, prior, mean, sd, half_width, spacing):
        """The first grid: ``half_width`` sds each side of ``mean``,
        ``spacing`` sds apart, inside the prior's 0.9999 interval."""
        support = tuple(prior.bounds(0.9999)[0])
        step = spacing * sd
        half = math.ceil(half_width / spacing)
        lattice = mean + step * np.arange(-half, half + 1)
        nodes = _clipped(lattice, *support, step)
        return cls.build(prior, nodes, step, support)

    def refined(self, prior):
        """The grid with a node between each two (the old nodes kept)."""
        t = self.nodes
        nodes = np.empty(2 * len(t) - 1)
        nodes[::2], nodes[1::2] = t, 0.5 * (t[1:] + t[:-1])
        return self.build(prior, nodes, 0.5 * self.step, self.support)

    def subdivided(self, prior, factor):
        """``factor`` equal spacings in each of the grid's (its nodes kept)."""
        t = self.nodes
        inner = t[:-1, None] + np.diff(t)[:, None] * (np.arange(factor) / factor)
        return self.build(
            prior, np.r_[inner.ravel(), t[-1]], self.step / factor, self.support
        )

    def extended(self, prior, lower, upper):
        """The grid extended on its lattice by a quarter of its width at the
        flagged ends, within the prior's 0.9999 interval; and the numbers of
        nodes added below and above (the old nodes are kept between)."""
        t, h = self.nodes, self.step
        # the width in whole steps first: a quarter of 12 steps is 3 nodes,
        # not 3 or 4 as the rounding of the nodes' coordinates falls
        n_add = max(math.ceil(0.25 * round((t[-1] - t[0]) / h)), 1)
        below = t[0] - h * np.arange(n_add, 0, -1) if lower else t[:0]
        above = t[-1] + h * np.arange(1, n_add + 1) if upper else t[:0]
        lo, hi = self.support
        below, above = _clipped(below, lo, np.inf, h), _clipped(above, -np.inf, hi, h)
        nodes = np.r_[below, t, above]
        return self.build(prior, nodes, h, self.support), len(below), len(above)


def _trapezoid(nodes):
    """The trapezoid rule's weights of the increasing ``nodes``."""
    return 0.5 * (np.diff(nodes, prepend=nodes[0]) + np.diff(nodes, append=nodes[-1]))


def _clipped(points, lo, hi, step):
    """The increasing ``points`` inside ``(lo, hi)``, with ``lo`` (``hi``) in
    place of those at or beyond it, and of the nearest inside when that is
    within a quarter step of it."""
    inside = points[(points > lo) & (points < hi)]
    low = len(points) > 0 and points[0] <= lo
    high = len(points) > 0 and points[-1] >= hi
    if low and len(inside) and inside[0] - lo < 0.25 * step:
        inside = inside[1:]
    if high and len(inside) and hi - inside[-1] < 0.25 * step:
        inside = inside[:-1]
    return np.r_[[lo] if low else [], inside, [hi] if high else []]


class GridEvaluator:
    """``log p(data | theta_j, phi_k)`` on a grid for draws ``v_k``."""

    def __init__(self, base, space, scaler):
        self.base, self.space, self.scaler = base, space, scaler
        # Each draw's component and global model, built once: a draw is
        # evaluated again when the grids change and by the checks, and the
        # fitted mixture keeps the models of the draws returned. The cache
        # holds those and the few hundred others evaluated (a first round
        # redrawn, the marginal mode's search): on a1, 2,232 models for
        # 2,048 draws, within the six fixed parts per draw of MAX_DRAWS that
        # the calibrator's memory check counts (check_global_memory).
        self._components, self._models = {}, {}

    def components(self, V):
        """The :class:`DiscrepancyComponent` of each draw of ``V``."""
        out = []
        for v in V:
            key = v.tobytes()
            if key not in self._components:
                self._components[key] = self.space.component(v)
            out.append(self._components[key])
        return out

    def models(self, V):
        """The global model of each draw of ``V`` (``base.with_discrepancy``)."""
        out = []
        for v, component in zip(V, self.components(V), strict=True):
            key = v.tobytes()
            if key not in self._models:
                self._models[key] = self.base.with_discrepancy(component)
            out.append(self._models[key])
        return out

    def mixture(self, V):
        draws = HyperposteriorDraws(
            None, self.components(V), np.zeros(len(V)), None, None, None
        )
        return ModelMixture(self.base, draws, self.models(V))

    def __call__(self, V, nodes):
        """(J, K): ``-inf`` where a factorisation fails or gives no number
        (a NaN: no weight, rather than a NaN posterior)."""
        mixture = self.mixture(np.atleast_2d(V))
        thetas = self.scaler.theta(np.asarray(nodes, float)[:, None])
        try:
            out = mixture.batch_component_log_likelihoods(thetas)
        except FactorizationError:  # a rank-deficient regression somewhere
            out = np.full((len(thetas), len(mixture.models)), -np.inf)
            for j, theta in enumerate(thetas):
                try:
                    out[j] = mixture.batch_component_log_likelihoods(theta[None])[0]
                except FactorizationError:
                    continue
        return np.where(np.isnan(out), -np.inf, out)

    def splined(self, V, L, grids):
        """The draws' log likelihoods ``L`` on the coarse nodes carried to the
        fine ones by a cubic spline; evaluated there for a draw with a failed
        factorisation (no spline through ``-inf``) or whose spline overflows."""
        V, L = np.atleast_2d(V), np.asarray(L)
        with np.errstate(over="ignore", invalid="ignore"):
            span = np.ptp(L, axis=0)
        ok = np.all(np.isfinite(L), axis=0) & (span < _SPLINE_SPAN)
        out = np.empty((len(grids.fine.nodes), L.shape[1]))
        if ok.any():
            spline = interpolate.CubicSpline(grids.coarse.nodes, L[:, ok], axis=0)
            with np.errstate(over="ignore", invalid="ignore"):
                out[:, ok] = spline(grids.fine.nodes)
            ok[ok] = np.all(np.isfinite(out[:, ok]), axis=0)
        if not ok.all():
            out[:, ~ok] = self(V[~ok], grids.fine.nodes)
        return out

    def log_marginal(self, V, grids):
        """``log p(phi) + log ∫ p(theta) p(data | theta, phi) d theta`` (K,)."""
        V = np.atleast_2d(V)
        L = self.splined(V, self(V, grids.coarse.nodes), grids)
        log_prior = np.array([self.space.log_prior(v) for v in V])
        with np.errstate(invalid="ignore"):
            return (
                special.logsumexp(L + grids.fine.log_weights[:, None], axis=0)
                + log_prior
            )


@dataclass(frozen=True)
class ThetaGrids:
    """The nodes where the likelihood is evaluated (``coarse``) and those of
    the integral (``fine``, ``factor`` spacings per coarse one, the coarse
    nodes among them)."""

    coarse: ThetaGrid
    fine: ThetaGrid
    factor: int

    @classmethod
    def of(cls, prior, coarse, factor):
        return cls(coarse, coarse.subdivided(prior, factor), factor)


def grid_problems(A, grid, weights, span=1):
    """Whether the grid needs refining (a draw with weight whose conditional
    posterior is narrower than half a spacing) or extending (mass on the
    ``span`` nodes at an end that is not the prior's)."""
    t = grid.nodes
    Z = special.logsumexp(A, axis=0)
    share = np.exp(Z - special.logsumexp(Z))
    heavy = share > 0.01 / len(share)
    P = np.exp(A[:, heavy] - Z[heavy])
    mu = t @ P
    sd = np.sqrt(np.maximum((t**2) @ P - mu**2, 0.0))
    narrow = float(np.sum(share[heavy][sd < 0.5 * grid.step])) > _NARROW_SHARE
    lower = weights[:span].sum() > _END_MASS and t[0] > grid.support[0]
    upper = weights[-span:].sum() > _END_MASS and t[-1] < grid.support[1]
    return narrow, lower, upper


def density_cdf(w, grid):
    """The CDF at the nodes of the trapezoid posterior with weights ``w``."""
    return grid.cdfs(w[:, None])[:, 0]


def grid_summaries(log_joint, grid):
    """Mean, sd and 95 % interval ends of the grid posterior of the columns
    ``log_joint`` (J, K) sum over, and its normalised node weights."""
    log_mass = special.logsumexp(log_joint, axis=1)
    w = np.exp(log_mass - special.logsumexp(log_mass))
    t = grid.nodes
    mean = w @ t
    sd = math.sqrt(max(w @ (t - mean) ** 2, 0.0))
    return np.r_[mean, sd, np.interp(INTERVAL, density_cdf(w, grid), t)], w


def spline_error(draws, grids, A, evaluate, prior):
    """The spline's largest error at the coarse midpoints, for the
    :data:`_N_CHECKED` draws of most weight, where their log posterior is
    within :data:`_RELEVANT` of its largest (0 with one coarse spacing)."""
    nodes = grids.coarse.nodes
    Z = special.logsumexp(A, axis=0)
    heavy = np.argsort(Z)[::-1][:_N_CHECKED]
    heavy = heavy[np.all(np.isfinite(draws.L[:, heavy]), axis=0)]
    if len(heavy) == 0 or len(nodes) < 2:
        return 0.0
    mid = 0.5 * (nodes[1:] + nodes[:-1])
    exact = evaluate(draws.V[heavy], mid)
    splined = interpolate.CubicSpline(nodes, draws.L[:, heavy], axis=0)(mid)
    with np.errstate(divide="ignore"):
        log_post = exact + np.ravel(prior.logpdf(mid[:, None]))[:, None]
    top = np.nanmax(log_post, axis=0)
    relevant = np.isfinite(exact) & (log_post >= top - _RELEVANT)
    return float(np.max(np.abs(exact - splined)[relevant], initial=0.0))
