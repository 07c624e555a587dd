"""The proposals of a chain's independence moves, fitted to its burn-in.

:class:`skmba.mcmc._chain.Chain` proposes, besides its random walk, from
:class:`TProposal`, a Student-t whose location and scale matrix are the
moments of the latest half of the burn-in (:func:`window_moments`, pooled
over blocks of steps by :func:`merge_moments`). After the burn-in, chains
that pool their windows share :func:`shared_proposal`: a :class:`TMixture`
of Student-ts on the components of a Gaussian mixture fitted to the
windows' points, with a defensive share of the pooled moments' Student-t
(that Student-t alone where one component fits best). For a labelled
target (a finite mixture sampled with its component) a chain also proposes
the label, from :func:`label_proposal`, and draws labels with
:func:`draw_label`.

Why these shapes and constants (the measurements behind ``T_DF``,
``T_VARIANCE_FACTOR`` and ``DEFENSIVE_SHARE``): docs/internals.rst,
section skmba.mcmc._chain.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._proposals import TProposal, label_proposal
>>> proposal = TProposal.of(np.zeros(2), np.eye(2))
>>> proposal.draw(np.random.default_rng(0), 5).shape
(5, 2)
>>> label_proposal(np.array([1.0, 0.0]))
array([0.95, 0.05])
"""

import warnings

import numpy as np
from scipy import linalg
from scipy.special import logsumexp
from sklearn.exceptions import ConvergenceWarning
from sklearn.mixture import GaussianMixture

#: The independence proposal is a Student-t with T_DF degrees of freedom and
#: T_VARIANCE_FACTOR times the covariance of (part of) the burn-in as its
#: scale matrix. Heavy tails keep a proposal narrower than the target from
#: trapping the chains in the target's tails.
T_VARIANCE_FACTOR = 1.5
T_DF = 5.0
#: Share of the uniform distribution in the label proposal of a labelled
#: target's independence moves, so that every label stays reachable.
LABEL_UNIFORM_SHARE = 0.1
#: The shared proposal's defensive component: a share DEFENSIVE_SHARE of the
#: Student-t of the pooled moments with DEFENSIVE_SCALE times its scale
#: (sds). The other components may miss a tail of the target; this one's
#: density far out is ``DEFENSIVE_SHARE * DEFENSIVE_SCALE**T_DF`` (9.6)
#: times the single Student-t's, so the chains leave a tail at least as
#: readily as with it.
DEFENSIVE_SHARE = 0.3
DEFENSIVE_SCALE = 2.0
#: Most components of the shared proposal's Gaussian mixture (chosen by BIC
#: from one up), and the fewest window points per free parameter of the
#: mixture (``r + r (r + 1) / 2 + 1`` per component).
MAX_COMPONENTS = 8
POINTS_PER_PARAMETER = 10
# The variance added to each mixture component's, in the coordinates that
# whiten the windows' covariance: no component narrower than 3 % of the
# target's sd, even where a chain repeated one point for many steps.
_MIXTURE_FLOOR = 1e-3
# Regularisation ``epsilon I`` added to the empirical covariance (the caller
# works in standardised units, in which this is negligible).
_EPSILON = 1e-10


class TProposal:
    """The Student-t of the independence moves, of location ``mean``, scale
    matrix ``chol chol'`` and ``T_DF`` degrees of freedom."""

    def __init__(self, mean, chol):
        self.mean, self.chol = mean, chol

    @classmethod
    def of(cls, mean, cov):
        """The proposal for a target of mean ``mean`` and covariance
        ``cov``: scale matrix ``T_VARIANCE_FACTOR cov``."""
        chol = linalg.cholesky(T_VARIANCE_FACTOR * cov, lower=True, check_finite=False)
        return cls(mean, chol)

    def logpdf(self, thetas):
        """Log density up to a constant at ``thetas`` (m, r): (m,)."""
        z = linalg.solve_triangular(
            self.chol, (thetas - self.mean).T, lower=True, check_finite=False
        )
        return -0.5 * (T_DF + z.shape[0]) * np.log1p(np.sum(z**2, axis=0) / T_DF)

    def draw(self, rng, m):
        """``m`` draws (m, r)."""
        z = rng.standard_normal((m, self.mean.size))
        w = rng.chisquare(T_DF, m) / T_DF
        return self.mean + (z @ self.chol.T) / np.sqrt(w)[:, None]


class TMixture:
    """A mixture of :class:`TProposal` Student-ts of weights ``weights``
    (summing to one): the chains' shared proposal (:func:`shared_proposal`).

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.mcmc._proposals import TMixture, TProposal
    >>> one = TProposal.of(np.zeros(1), np.eye(1))
    >>> two = TMixture(np.array([0.5, 0.5]), [one, one])
    >>> x = np.linspace(-3.0, 3.0, 5)[:, None]
    >>> bool(np.ptp(two.logpdf(x) - one.logpdf(x)) < 1e-12)  # the same shape
    True
    """

    def __init__(self, weights, components):
        self.weights, self.components = weights, components
        # TProposal.logpdf leaves out the log determinant of the scale,
        # which differs between the components.
        self._log_weights = np.log(weights) - np.array(
            [np.sum(np.log(np.diag(c.chol))) for c in components]
        )

    def logpdf(self, thetas):
        """Log density up to a constant at ``thetas`` (m, r): (m,)."""
        parts = np.stack([c.logpdf(thetas) for c in self.components])
        return logsumexp(parts + self._log_weights[:, None], axis=0)

    def draw(self, rng, m):
        """``m`` draws (m, r): a component each, then its draw."""
        which = rng.choice(len(self.weights), size=m, p=self.weights)
        out = np.empty((m, self.components[0].mean.size))
        for j, component in enumerate(self.components):
            picked = which == j
            if picked.any():
                out[picked] = component.draw(rng, int(picked.sum()))
        return out


def shared_proposal(points, mean, cov):
    """The chains' shared independence proposal after their burn-ins.

    ``points`` (m, r) are the points of the latest halves of the chains'
    burn-ins, one per step, ``mean`` and ``cov`` their moments
    (:func:`window_moments`). A Gaussian mixture of one to
    :data:`MAX_COMPONENTS` components (fewer with few points) is fitted to
    the points, in the coordinates that whiten ``cov``, and chosen by BIC.
    One component: the Student-t of ``mean`` and ``cov``
    (:class:`TProposal`). Several: a :class:`TMixture` of that Student-t
    widened :data:`DEFENSIVE_SCALE` times (weight :data:`DEFENSIVE_SHARE`)
    and one Student-t per component (location its mean, scale matrix
    ``T_VARIANCE_FACTOR`` times its covariance).
    The fit is seeded, so the proposal depends on the points alone.
    Raises :class:`scipy.linalg.LinAlgError` when ``cov`` is not positive
    definite.
    """
    union = TProposal.of(mean, cov)
    r = mean.size
    chol = linalg.cholesky(cov, lower=True, check_finite=False)
    z = linalg.solve_triangular(chol, (points - mean).T, lower=True).T
    per_component = r + r * (r + 1) // 2 + 1
    k_max = min(MAX_COMPONENTS, len(points) // (POINTS_PER_PARAMETER * per_component))
    best, best_bic = None, np.inf
    with warnings.catch_warnings():
        # A mixture whose EM stopped early is still a proposal.
        warnings.simplefilter("ignore", ConvergenceWarning)
        for k in range(1, k_max + 1):
            mixture = GaussianMixture(
                k, init_params="k-means++", reg_covar=_MIXTURE_FLOOR, random_state=0
            ).fit(z)
            bic = mixture.bic(z)
            if bic < best_bic:
                best, best_bic = mixture, bic
    if best is None or best.n_components == 1:
        return union
    components = [TProposal.of(mean, DEFENSIVE_SCALE**2 * cov)] + [
        TProposal.of(mean + chol @ m, chol @ c @ chol.T)
        for m, c in zip(best.means_, best.covariances_, strict=True)
    ]
    weights = np.concatenate(
        [[DEFENSIVE_SHARE], (1.0 - DEFENSIVE_SHARE) * best.weights_]
    )
    return TMixture(weights / weights.sum(), components)


def merge_moments(counts, means, m2s):
    """Pooled mean and sum of squared deviations of several blocks (Chan et al.)."""
    n = counts.sum()
    mean = counts @ means / n
    dev = means - mean
    m2 = m2s.sum(axis=0) + np.einsum("b,bi,bj->ij", counts, dev, dev)
    return n, mean, m2


def points_moments(points):
    """Mean and covariance (``+ epsilon I``) of points (m, r), one per row."""
    r = points.shape[1]
    cov = np.cov(points, rowvar=False).reshape(r, r)
    return points.mean(axis=0), cov + _EPSILON * np.eye(r)


def window_moments(counts, means, m2s, accepts):
    """Mean and covariance (``+ epsilon I``) of a window of burn-in blocks.

    None when the window holds too few accepted moves (``max(10, 2 r)``).
    """
    r = means.shape[1]
    if accepts.sum() < max(10, 2 * r):
        return None
    n, mean, m2 = merge_moments(counts, means, m2s)
    return mean, (m2 / (n - 1) + _EPSILON * np.eye(r))


def label_proposal(conditionals):
    """The label proposal: the mean of the labels' conditional
    probabilities ``p(k | theta)`` at a window's Gibbs updates (a
    Rao-Blackwell estimate of their marginal ones), mixed with a uniform
    share :data:`LABEL_UNIFORM_SHARE`."""
    share = LABEL_UNIFORM_SHARE
    return (1.0 - share) * conditionals + share / len(conditionals)


def draw_label(probs, u):
    """The label of probabilities ``probs`` that the uniform ``u`` picks."""
    cumulative = np.cumsum(probs)
    k = int(np.searchsorted(cumulative, u * cumulative[-1], side="right"))
    return min(k, len(probs) - 1)
