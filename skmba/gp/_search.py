"""Maximum-likelihood search of the hyperparameters of MultiResponseGP.

The concentrated likelihood (``beta`` and ``Sigma2`` in closed form, thesis
Eq. 3.19, :class:`~skmba.gp._likelihood.NoiseFreeLikelihood`) is maximised over
the kernel's log-hyperparameters, and for the start of a noisy fit also over
a log noise-to-signal ratio ``tau``, with L-BFGS-B (or the user's optimizer)
from the kernel's values and random restarts; each L-BFGS-B run, on the
likelihood per observation and with its stopping rule, is
:func:`skmba.gp._lbfgsb.minimize_lbfgsb`. While the correlation matrix
is numerically singular the nugget is escalated: multiplied by 10 (from
1e-12 when it is 0), never beyond 1e-6, with one warning (see "Nugget
escalation" in the User Guide). Above ``WARM_START_ABOVE`` samples the search
and its restarts run on a random subsample first, and the full-size search
refines that optimum from one start (:func:`subsample_warm_start`).

Warnings point at the caller of ``MultiResponseGP.fit`` (through
:func:`skmba._core.warn.warn`).

Examples
--------
>>> import numpy as np
>>> from skmba.gp._search import LikelihoodProblem, fit_noise_free
>>> from skmba.kernels import Gauss
>>> X = np.linspace(0, 1, 8).reshape(-1, 1)
>>> problem = LikelihoodProblem(X, np.ones((8, 1)), np.sin(3 * X), nugget=1e-10)
>>> kernel, fit = fit_noise_free(problem, Gauss(roughness=1.0))
>>> fit.beta.shape, fit.sigma2.shape
((1, 1), (1, 1))
"""

import warnings
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from skmba._core.dace import DACECorrelation
from skmba._core.linalg import FactorizationError, smallest_pivot
from skmba._core.validation import random_state_instance
from skmba._core.warn import warn
from skmba.gp._lbfgsb import blocked, minimize_lbfgsb
from skmba.gp._likelihood import (
    R_REMEDY,
    R_WHAT,
    GradientContraction,
    NoiseFreeLikelihood,
)

# Noise variances, relative to each response's variance, and tau (noise to
# signal ratio of the proportional-noise start) stay within these log bounds.
LOG_NOISE_BOUNDS = (np.log(1e-8), np.log(10.0))
# Nugget escalation for numerically singular correlation matrices: the nugget
# is multiplied by _NUGGET_GROWTH (starting from _FIRST_NUGGET when alpha=0),
# never beyond _MAX_ALPHA (in units of the process variance, i.e. of the
# standardised responses).
_NUGGET_GROWTH = 10.0
_FIRST_NUGGET = 1e-12
_MAX_ALPHA = 1e-6
# A Cholesky factor whose smallest pivot is within this factor of
# max(nugget, N eps) is held positive definite by the nugget (or rounding)
# alone.
_PIVOT_MARGIN = 100.0
# An L-BFGS-B line search that fails with a projected gradient below this
# fraction of (1 + |log-likelihood|) stopped at the rounding floor of the
# likelihood (nearly singular R), not away from the optimum.
_FLAT_GRADIENT = 1e-4


#: Fits on more than WARM_START_ABOVE samples start from the hyperparameters
#: fitted (with the restarts) on WARM_START_SAMPLES of them, drawn at random
#: (:func:`subsample_warm_start`).
WARM_START_ABOVE = 2000
WARM_START_SAMPLES = 1000


#: Random restarts of the kernel hyperparameters are drawn log-uniformly
#: within this many log units of the starting values (a factor 100 either
#: way), and within the bounds (the rejected variant, restarts across the
#: whole bounds: docs/internals.rst, section skmba.gp._search).
RESTART_SPAN = np.log(100.0)


def correlation(kernel, X, nugget, eval_gradient):
    """Correlation of the training inputs ``X`` (+ ``nugget``) and its gradient.

    For the DACE kernels the gradient is a
    :class:`~skmba.gp._likelihood.GradientContraction`, computed one
    hyperparameter at a time when the likelihood contracts it, so that no
    (N, N, n_theta) array is allocated; other kernels give sklearn's
    stacked gradient.
    """
    if isinstance(kernel, DACECorrelation):
        R = kernel._correlation(X, X)
        dR = None
        if eval_gradient:
            dR = GradientContraction(
                lambda weight: kernel._weighted_log_gradient(X, R, weight),
                kernel.n_dims,
            )
    elif eval_gradient:
        R, dR = kernel(X, eval_gradient=True)
    else:
        R, dR = kernel(X), None
    R[np.diag_indices(len(X))] += nugget
    return R, dR


@dataclass
class LikelihoodProblem:
    """Training data, nugget and search settings of one fit (internal units).

    ``X`` (N, d), ``H`` (N, p) and ``Y`` (N, q) are the inputs, the
    regression basis and the standardised non-constant responses.
    ``nugget`` is the one in use: the search raises it while the correlation
    matrix is numerically singular; ``alpha`` is the user's (for messages).
    ``on_start``, when given, is called after each start of a likelihood
    search as ``on_start(k, n, fun)`` (start ``k`` of ``n``, its minimum of
    ``-loglik``), for progress reports. The other fields are
    ``MultiResponseGP``'s settings.
    """

    X: np.ndarray
    H: np.ndarray
    Y: np.ndarray
    nugget: float
    alpha: float | None = None
    ridge: float = 0.0
    optimizer: object = "fmin_l_bfgs_b"
    n_restarts: int = 0
    random_state: object = None
    on_start: object = None

    def __post_init__(self):
        if self.alpha is None:
            self.alpha = self.nugget

    def correlation(self, kernel, eval_gradient):
        """Training correlation with the nugget in use, and its gradient."""
        return correlation(kernel, self.X, self.nugget, eval_gradient)


class Search(NamedTuple):
    """Outcome of :func:`run_optimizer`."""

    x: np.ndarray | None
    failures: list
    notes: list
    flat: bool | None


def next_nugget(nugget):
    """The next nugget of the escalation, or None beyond ``_MAX_ALPHA``."""
    if nugget >= _MAX_ALPHA * (1.0 - 1e-9):
        return None
    return min(max(nugget * _NUGGET_GROWTH, _FIRST_NUGGET), _MAX_ALPHA)


def _projected_gradient(res, bounds):
    """Gradient of an L-BFGS-B result with the components blocked by a bound
    removed (those at a bound that point out of the box)."""
    grad = np.asarray(res.jac, dtype=float)
    return np.where(blocked(np.asarray(res.x, dtype=float), grad, bounds), 0.0, grad)


def negative_objective(evaluate, params, eval_gradient, failures, errors, gradient):
    """``-loglik`` (and ``-gradient``) of ``evaluate(params, eval_gradient)``.

    A failure among ``errors`` is appended to ``failures`` and gives
    ``+inf`` (and a zero gradient), which L-BFGS-B treats as a rejected step.
    ``gradient`` names the fit's attribute holding the gradient.
    """
    try:
        fit = evaluate(params, eval_gradient)
    except errors as exc:
        failures.append(exc)
        return (np.inf, np.zeros_like(params)) if eval_gradient else np.inf
    if eval_gradient:
        return -fit.log_likelihood, -getattr(fit, gradient)
    return -fit.log_likelihood


def run_optimizer(
    objective, starts, bounds, optimizer, failures, on_start=None, n_observations=1
):
    """Minimise ``objective`` from each start.

    ``optimizer`` is a callable ``optimizer(objective, start, bounds) ->
    (x, fun)``, otherwise L-BFGS-B is used on the objective per observation
    (``n_observations``, i.e. ``N q``) with the stopping rule of
    :func:`~skmba.gp._lbfgsb.minimize_lbfgsb`. ``failures`` is the list the
    objective appends factorisation errors to. ``on_start(k, n, fun)``, when
    given, is called after start ``k`` (1-based) of ``n``, for progress
    reports. Returns a :class:`Search`: the
    best point (None when the objective could not be evaluated from any
    start), the failures recorded during the run that found it (all of them
    when none did), that run's L-BFGS-B non-convergence messages, and whether
    it ended with a flat projected gradient (None for a callable optimizer).
    """
    best = Search(None, list(failures), [], None)
    best_fun = np.inf
    for k, start in enumerate(starts, 1):
        mark = len(failures)
        notes, flat = [], None
        if callable(optimizer):
            x, fun = optimizer(objective, start, bounds)
        else:
            res = minimize_lbfgsb(objective, start, bounds, n_observations)
            x, fun = res.x, res.fun
            flat = bool(
                np.all(
                    np.abs(_projected_gradient(res, bounds))
                    <= _FLAT_GRADIENT * (1.0 + abs(res.fun))
                )
            )
            if not res.success and np.isfinite(res.fun) and not flat:
                notes.append(res.message)
        fun = float(fun)
        if on_start is not None:
            on_start(k, len(starts), fun)
        if np.isfinite(fun) and (best.x is None or fun < best_fun):
            best = Search(np.asarray(x, dtype=float), failures[mark:], notes, flat)
            best_fun = fun
    if best.x is None:
        return Search(None, list(failures), [], None)
    return best


def warn_not_converged(notes):
    """One ``ConvergenceWarning`` per L-BFGS-B message in ``notes``."""
    for note in notes:
        warn(
            "L-BFGS-B did not fully converge while fitting "
            f"MultiResponseGP ({note}). Consider more "
            "n_restarts_optimizer, other kernel bounds or a larger "
            "alpha.",
            ConvergenceWarning,
        )


class _Concentrated:
    """The concentrated likelihood over ``theta`` (and ``log tau``).

    Covariance ``Sigma2 ⊗ (R + (nugget + tau) I)``; ``tau`` (a noise to
    signal ratio shared by all responses) is a parameter when
    ``with_nugget`` is True, and is 0 otherwise.
    """

    def __init__(self, problem, kernel, with_nugget):
        self.problem = problem
        self.kernel = kernel
        self.with_nugget = with_nugget
        self.n_kernel = kernel.n_dims
        self.failures = []
        # (params, fit) of the latest evaluation of the search: the fit at
        # its optimum is then not computed again (one N x N Cholesky less).
        self.latest = None

    def likelihood(self, params, eval_gradient):
        n_kernel, problem = self.n_kernel, self.problem
        k = self.kernel.clone_with_theta(params[:n_kernel]) if n_kernel else self.kernel
        R, dR = problem.correlation(k, eval_gradient)
        if self.with_nugget:
            n = len(problem.X)
            tau = np.exp(params[n_kernel])
            R[np.diag_indices(n)] += tau
            if isinstance(dR, GradientContraction):
                dR = dR.with_diagonal(tau)
            elif eval_gradient:
                dtau = np.zeros((n, n, 1))
                dtau[np.arange(n), np.arange(n), 0] = tau
                dR = np.concatenate([dR, dtau], axis=2)
        return NoiseFreeLikelihood(R, problem.H, problem.Y, dR, ridge=problem.ridge)

    def _evaluate(self, params, eval_gradient):
        """:meth:`likelihood`, remembered as ``latest`` (the previous one
        dropped first: no two N x N factors at once)."""
        self.latest = None
        fit = self.likelihood(params, eval_gradient)
        self.latest = (np.array(params, dtype=float), fit)
        return fit

    def objective(self, params, eval_gradient=True):
        return negative_objective(
            self._evaluate,
            params,
            eval_gradient,
            self.failures,
            FactorizationError,
            "gradient",
        )

    def starts(self):
        """Initial point, bounds, starting points and whether to search."""
        n_kernel, problem = self.n_kernel, self.problem
        x0 = self.kernel.theta
        bounds = self.kernel.bounds if n_kernel else np.zeros((0, 2))
        if self.with_nugget:
            x0 = np.append(x0, np.log(0.1))
            bounds = np.vstack([bounds, LOG_NOISE_BOUNDS])
        free_kernel = problem.optimizer is not None and n_kernel > 0
        if not free_kernel:
            bounds[:n_kernel] = x0[:n_kernel, None]
        search = free_kernel or self.with_nugget
        starts = [x0]
        if search:
            rng = random_state_instance(problem.random_state)
            for _ in range(problem.n_restarts):
                start = x0.copy()
                if free_kernel:
                    start[:n_kernel] = rng.uniform(
                        np.maximum(bounds[:n_kernel, 0], x0[:n_kernel] - RESTART_SPAN),
                        np.minimum(bounds[:n_kernel, 1], x0[:n_kernel] + RESTART_SPAN),
                    )
                if self.with_nugget:
                    start[n_kernel] = rng.uniform(np.log(1e-4), 0.0)
                starts.append(start)
        return x0, bounds, starts, search

    def search(self, x0, bounds, starts, search):
        """One search at the current nugget: ``(x, fit, found, notes, flat)``."""
        self.failures.clear()
        self.latest = None
        notes = []
        if search:
            x, found, notes, flat = run_optimizer(
                self.objective,
                starts,
                bounds,
                self.problem.optimizer,
                self.failures,
                on_start=self.problem.on_start,
                n_observations=self.problem.Y.size,
            )
        else:
            x, found, flat = x0, [], None
        fit = None
        if self.latest is not None and np.array_equal(self.latest[0], x):
            fit = self.latest[1]
        elif x is not None:
            try:
                fit = self.likelihood(x, False)
            except FactorizationError as exc:
                found.append(exc)
        self.latest = None
        return x, fit, found, notes, flat


def _singular_error(alpha, nugget):
    """The error when R cannot be factored even at the largest nugget."""
    tried = (
        f"the nugget is escalated from alpha={alpha:.3g} up to {_MAX_ALPHA:.0e}"
        if alpha < _MAX_ALPHA
        else f"an alpha >= {_MAX_ALPHA:.0e} is not escalated"
    )
    return FactorizationError(
        f"The {R_WHAT} is numerically singular even with the "
        f"nugget alpha={nugget:.3g} ({tried}): its Cholesky "
        "factorisation fails. Remedies: remove duplicated or "
        "nearly duplicated input points, use a rougher kernel "
        "(Exp, Matern, a larger lower bound on the roughness) "
        "or a positive definite one (not Cubic), fit with "
        "noise=True, or set a larger alpha explicitly.",
        what=R_WHAT,
    )


def _escalate(target, x0, bounds, starts, search):
    """Search, raising ``problem.nugget`` while R is numerically singular.

    The search was stopped by failed factorisations of R when it ended away
    from a stationary point, or where only the nugget keeps R positive
    definite. Returns ``(x, fit, notes, reason)``, ``reason`` being None
    when the nugget was not raised.
    """
    problem = target.problem
    n = len(problem.X)
    nugget, reason = problem.nugget, None
    while True:
        problem.nugget = nugget
        x, fit, found, notes, flat = target.search(x0, bounds, starts, search)
        r_failed = any(getattr(e, "what", None) == R_WHAT for e in found)
        stopped = (
            fit is not None
            and r_failed
            and (
                flat is False
                or smallest_pivot(fit.C)
                <= _PIVOT_MARGIN * max(nugget, n * np.finfo(float).eps)
            )
        )
        if fit is not None and not stopped:
            return x, fit, notes, reason
        if not r_failed:
            # e.g. a singular Sigma2 or H: a larger nugget cannot help.
            raise FactorizationError(
                "The likelihood could not be evaluated at any starting "
                f"point. Last error: {found[-1] if found else 'none recorded'}"
            )
        if reason is None:
            reason = (
                "the likelihood search was stopped by failed Cholesky factorisations"
                if stopped
                else "its Cholesky factorisation failed"
            )
        following = next_nugget(nugget)
        if following is None:
            if fit is None:
                raise _singular_error(problem.alpha, nugget) from found[-1]
            notes.append(
                "the likelihood search is still stopped by a numerically "
                f"singular correlation matrix at the largest nugget "
                f"alpha={nugget:.3g}; {R_REMEDY}"
            )
            return x, fit, notes, reason
        nugget = following
        if fit is not None:
            starts = [x]  # resume from the best point so far


def fit_concentrated(problem, kernel, with_nugget):
    """Maximise the likelihood with beta and Sigma2 concentrated out.

    Covariance ``Sigma2 ⊗ (R + (nugget + tau) I)``; ``tau`` (a noise to
    signal ratio shared by all responses) is optimised in log space when
    ``with_nugget`` is True, and is 0 otherwise. ``problem.nugget`` is
    escalated while ``R`` is numerically singular. Returns the fitted kernel,
    ``tau`` and the :class:`~skmba.gp._likelihood.NoiseFreeLikelihood` at the
    optimum.
    """
    target = _Concentrated(problem, kernel, with_nugget)
    x, fit, notes, reason = _escalate(target, *target.starts())
    warn_not_converged(notes)
    if problem.nugget != problem.alpha:
        warn(
            f"The {R_WHAT} was numerically singular with the nugget "
            f"alpha={problem.alpha:.3g} ({reason}), so the nugget was raised to "
            f"nugget_={problem.nugget:.3g} (escalation by 10x up to "
            f"{_MAX_ALPHA:.0e}). The GP now smooths the training data at "
            "that fraction of the process variance instead of interpolating "
            f"them exactly. Set alpha={problem.nugget:.3g} to skip the refits, "
            "or remove nearly duplicated inputs or use a rougher kernel.",
            UserWarning,
        )
    n_kernel = target.n_kernel
    fitted = kernel.clone_with_theta(x[:n_kernel]) if n_kernel else kernel
    tau = float(np.exp(x[n_kernel])) if with_nugget else 0.0
    return fitted, tau, fit


def subsample_warm_start(problem, kernel, fit_path):
    """Start a large fit from the hyperparameters fitted on a subsample.

    Above ``WARM_START_ABOVE`` samples, the search (with its random
    restarts) runs first on ``WARM_START_SAMPLES`` samples drawn without
    replacement with ``problem.random_state``; the full-size search then
    starts once, from that fit's kernel, so the costly N x N evaluations
    only refine an optimum. Returns the kernel to start from and the
    problem to fit: unchanged for smaller problems, a fixed kernel
    (``optimizer=None``) or a subsample whose fit fails (the full search
    then runs as usual). The subsample fit's warnings are dropped: the full
    fit gives its own; ``problem.on_start`` reports the subsample's starts
    (the restarts), not the single full-size one.
    """
    n = len(problem.X)
    if n <= WARM_START_ABOVE or problem.optimizer is None or kernel.n_dims == 0:
        return kernel, problem
    rng = random_state_instance(problem.random_state)
    rows = np.sort(rng.choice(n, WARM_START_SAMPLES, replace=False))
    sample = replace(
        problem,
        X=problem.X[rows],
        H=problem.H[rows],
        Y=problem.Y[rows],
        random_state=rng,
    )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted, _ = fit_path(sample, kernel)
    except (FactorizationError, np.linalg.LinAlgError):
        return kernel, problem
    return fitted, replace(problem, n_restarts=0, on_start=None)


def fit_noise_free(problem, kernel):
    """Fit ``Sigma2 ⊗ R``: the fitted kernel and its ``NoiseFreeLikelihood``."""
    fitted, _, fit = fit_concentrated(problem, kernel, False)
    return fitted, fit
