"""Noisy fit of MultiResponseGP: ``Sigma2 ⊗ R + Lambda ⊗ I`` by profile likelihood.

1. A concentrated fit with noise proportional to ``Sigma2``
   (``V = Sigma2 ⊗ (R + tau I)``, :func:`~skmba.gp._search.fit_concentrated`):
   one Cholesky per evaluation, and the only step with random restarts. It
   gives the starting point.
2. The kernel hyperparameters maximise the profile likelihood ``max over
   (Sigma2, Lambda)``: for each kernel, ``Sigma2`` and ``Lambda`` come from
   Levenberg-Marquardt on the Fisher information
   (:func:`~skmba.gp._likelihood.maximise_noise_and_sigma2`), on one
   eigendecomposition of ``R`` (O(N q^2) per likelihood, warm-started from
   the best point so far, in ``Sigma2 = L L'`` coordinates so that the
   nearly singular ``Sigma2`` of strongly correlated responses is reached),
   and the gradient with respect to the kernel is the partial one at that
   maximum (envelope theorem). The optimizer sees only the kernel's
   hyperparameters, whatever ``q``.

Examples
--------
>>> import numpy as np
>>> from skmba.gp._noisy import fit_noisy
>>> from skmba.gp._search import LikelihoodProblem
>>> from skmba.kernels import Gauss
>>> rng = np.random.default_rng(0)
>>> X = np.linspace(0, 1, 20).reshape(-1, 1)
>>> Y = np.sin(3 * X) + 0.1 * rng.normal(size=(20, 1))
>>> problem = LikelihoodProblem(X, np.ones((20, 1)), Y / Y.std(), nugget=1e-10)
>>> kernel, fit = fit_noisy(problem, Gauss(roughness=1.0))
>>> bool(0 < fit.ke.lam[0] < 0.5)
True
"""

import numpy as np

from skmba._core.linalg import FactorizationError, symmetric_eigh
from skmba.gp._likelihood import R_WHAT, NoisyLikelihood, maximise_noise_and_sigma2
from skmba.gp._search import (
    LOG_NOISE_BOUNDS,
    fit_concentrated,
    negative_objective,
    run_optimizer,
    warn_not_converged,
)

# Inner maximisation over (Sigma2, Lambda) of the noisy fit: at most this
# many Levenberg-Marquardt (Fisher scoring) iterations, stopping below this
# relative gain.
_MAX_SCORING_STEPS = 200
_SCORING_TOL = 1e-12


class _ProfileLikelihood:
    """The likelihood maximised over ``(Sigma2, Lambda)`` for each kernel.

    Each maximisation is warm-started from the best point so far, not from
    a line-search trial: a poor kernel can drive Sigma2 to 0, a stationary
    point of the ``L L'`` coordinates.
    """

    def __init__(self, problem, kernel, sigma2, lam, lam_bounds):
        self.problem = problem
        self.kernel = kernel
        self.lam_bounds = lam_bounds
        self.warm = {"sigma2": sigma2, "lam": lam, "best": -np.inf}
        self.failures = []

    def __call__(self, kernel, eval_gradient):
        """The :class:`~skmba.gp._likelihood.NoisyLikelihood` at the inner maximum."""
        problem, warm = self.problem, self.warm
        R, dR = problem.correlation(kernel, eval_gradient)
        eig = symmetric_eigh(R, what=R_WHAT)
        fit, _ = maximise_noise_and_sigma2(
            R,
            problem.H,
            problem.Y,
            warm["sigma2"],
            warm["lam"],
            eig=eig,
            lam_bounds=self.lam_bounds,
            tol=_SCORING_TOL,
            max_iter=_MAX_SCORING_STEPS,
        )
        if fit.log_likelihood > warm["best"]:
            warm.update(sigma2=fit.sigma2, lam=fit.ke.lam, best=fit.log_likelihood)
        if eval_gradient:
            fit = NoisyLikelihood(
                R, problem.H, problem.Y, fit.sigma2, fit.ke.lam, dR, eig=eig
            )
        return fit

    def objective(self, theta, eval_gradient=True):
        """Negative profile log-likelihood of the kernel at ``theta``."""
        return negative_objective(
            lambda t, g: self(self.kernel.clone_with_theta(t), g),
            theta,
            eval_gradient,
            self.failures,
            (FactorizationError, np.linalg.LinAlgError),
            "grad_kernel",
        )


def noise_bounds(Y):
    """Search bounds of each response's noise variance, shape (q, 2).

    ``LOG_NOISE_BOUNDS`` relative to each response's variance: from 1e-8
    (the data are all but noise-free) to 10 times it (all noise).

    Examples
    --------
    >>> import numpy as np
    >>> noise_bounds(np.array([[0.0, 0.0], [2.0, 20.0]])).round(12).tolist()
    [[1e-08, 10.0], [1e-06, 1000.0]]
    """
    return np.exp(LOG_NOISE_BOUNDS) * Y.std(axis=0)[:, None] ** 2


def fit_noisy(problem, kernel):
    """Fit ``Sigma2 ⊗ R + Lambda ⊗ I`` on the profile likelihood (module doc).

    Returns the fitted kernel and the
    :class:`~skmba.gp._likelihood.NoisyLikelihood` at the optimum;
    ``problem.nugget`` may have been escalated by the first stage.
    """
    Y = problem.Y
    scale = Y.std(axis=0)
    try:
        kernel, tau, stage1 = fit_concentrated(problem, kernel, True)
        sigma2 = stage1.sigma2
        lam = tau * np.diag(sigma2)
    except FactorizationError:
        # e.g. responses that are exact linear combinations of others make
        # every proportional-noise Sigma2 singular; per-response noise
        # still separates them. Start from the sample covariance instead.
        cov = np.atleast_2d(np.cov(Y, rowvar=False, bias=True))
        sigma2 = 0.9 * cov + 1e-3 * np.diag(scale**2)
        lam = 0.1 * scale**2
    lam_bounds = noise_bounds(Y)
    lam = np.clip(lam, *lam_bounds.T)
    profile = _ProfileLikelihood(problem, kernel, sigma2, lam, lam_bounds)
    if problem.optimizer is not None and kernel.n_dims:
        theta, found, notes, _ = run_optimizer(
            profile.objective,
            [kernel.theta],
            kernel.bounds,
            problem.optimizer,
            profile.failures,
            n_observations=Y.size,
        )
        if theta is None:
            raise FactorizationError(
                "The likelihood could not be evaluated at any starting "
                f"point. Last error: {found[-1] if found else 'none recorded'}",
                what=getattr(found[-1], "what", None) if found else None,
            )
        warn_not_converged(notes)
        kernel = kernel.clone_with_theta(theta)
    return kernel, profile(kernel, False)
