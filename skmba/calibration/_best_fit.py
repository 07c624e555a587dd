"""The best-fit estimand: theta projected from reality's posterior.

With ``estimand="best_fit"`` the calibrator reports the parameter values
that bring the model closest to reality at the field inputs::

    theta_L2 = argmin_theta  sum_j c_j || (zeta(x_j) - y_m(x_j, theta)) / s ||^2

(Tuo & Wu 2015's L2 calibration, here over the distinct field inputs
``x_j``, each weighted by its number of readings ``c_j``, and every response
in the simulations' spread ``s``). Its posterior is the image of reality's
posterior ``zeta`` under that map (Bayesian projected calibration, Xie &
Xu 2021): :func:`best_fit_draws` draws ``zeta`` at the ``x_j`` from
module 4's posterior (one Gaussian per pair of theta and module-2 draw of
the rule, mixed by the rule's weights), and solves each draw's least
squares against the emulator's mean by damped Gauss-Newton
(:func:`project`), within the simulated range of theta. Reality's
posterior is the same under both estimands: only theta's reading of it
changes. Why and how well: docs/validity.rst (section "The best-fit
estimand").

Everything here is in standardised units.
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg

from skmba._core.validation import seed_sequence
from skmba._core.warn import warn
from skmba.calibration._module4_prediction import conditional_moments
from skmba.calibration._summary import parameter_names
from skmba.mcmc._posterior import PosteriorResult

#: The estimands of ``ModularBayesCalibrator(estimand=...)``.
ESTIMANDS = ("physical", "best_fit")
#: Draws of reality, and of the best fit, per fit.
N_BEST_FIT_DRAWS = 2000
#: Independent batches whose spread gives the Monte Carlo errors.
N_BATCHES = 20
#: Gauss-Newton: the most iterations, and the step (standardised theta)
#: below which a draw has converged.
MAX_ITERATIONS = 50
STEP_TOL = 1e-8
#: A restarted draw's fit replaces its first one when its sum of squares is
#: lower by more than this (relative): ties, as along a flat valley, keep
#: the first.
COST_RTOL = 1e-6
#: The share of draws at an end of the simulated range above which a
#: parameter's best fit warns.
AT_BOUND_SHARE = 0.01
#: Curvature ratio of the least squares (smallest over largest eigenvalue
#: of J'J, standardised theta) below which the best fit is not unique: the
#: model's responses at the field inputs do not tell that direction apart
#: (sensitivity under 3 % of the steepest direction's). Measured: 5e-5 on
#: section 4.7.3's E and I, which act through E I only (the emulator's
#: error makes it nonzero); 0.05-0.2 on the monitored bridge's E and bearing
#: stiffness.
FLAT_RATIO = 1e-3
#: Forward-difference step of the emulator's Jacobian (standardised theta).
JACOBIAN_STEP = 1e-6


@dataclass(frozen=True)
class BestFit:
    """Draws of the best-fit theta and their summaries (standardised).

    Attributes
    ----------
    samples : ndarray of shape (m, r)
    at_bound : ndarray of shape (r,)
        The share of draws whose best fit lies on an end of the simulated
        range (the least squares would go beyond it).
    batch_estimates : ndarray of shape (N_BATCHES, 4, r)
        Mean, sd, 2.5 % and 97.5 % quantiles of each independent batch.
    unconverged : float
        The share of draws whose search :data:`MAX_ITERATIONS` ended.
    flat : ndarray of shape (r,) or None
        The direction (unit, standardised theta) along which the least
        squares is flat at the median best fit, when its curvature there is
        below :data:`FLAT_RATIO` of the steepest; None otherwise.
    """

    samples: np.ndarray
    at_bound: np.ndarray
    batch_estimates: np.ndarray
    unconverged: float = 0.0
    flat: np.ndarray | None = None

    @property
    def mcse(self):
        """Monte Carlo standard errors (4, r): mean, sd, 2.5 %, 97.5 %, from
        the spread of the batches' estimates."""
        b = self.batch_estimates
        return b.std(axis=0, ddof=1) / np.sqrt(len(b))


def reality_draws(mixture, rule, Xs, n_draws, rng):
    """``n_draws`` joint draws of reality at ``Xs`` (n_draws, s, q) and the
    rule entries they come from: entries picked by their weights, one
    Gaussian draw each (each entry's moments computed once)."""
    s, q = len(Xs), mixture.q
    picked = rng.choice(len(rule.weights), size=n_draws, p=rule.weights)
    z = rng.standard_normal((n_draws, s * q))
    out = np.empty((n_draws, s, q))
    for i in np.unique(picked):
        model = mixture.base if rule.draws is None else mixture.models[rule.draws[i]]
        mean, cov = conditional_moments(model, rule.thetas[i], Xs, "reality", full=True)
        root = _square_root(cov)
        rows = picked == i
        # Rows of the covariance are response-slowest (k s + a).
        deviations = (z[rows] @ root.T).reshape(-1, q, s).transpose(0, 2, 1)
        out[rows] = mean + deviations
    return out, picked


def _square_root(cov):
    """A factor ``F`` with ``F F' = cov``: Cholesky's, or the symmetric one
    where the covariance is singular to rounding (the data pin reality
    down along some direction)."""
    try:
        return linalg.cholesky(cov, lower=True, check_finite=False)
    except linalg.LinAlgError:
        values, vectors = linalg.eigh(cov, check_finite=False)
        return vectors * np.sqrt(np.clip(values, 0.0, None))


def project(emulator, Xs, weights, targets, start, bounds):
    """The weighted least-squares fit of the emulator's mean to each target.

    Parameters
    ----------
    emulator : Emulator
    Xs : ndarray of shape (s, d)
    weights : ndarray of shape (s,)
    targets : ndarray of shape (m, s, q)
    start : ndarray of shape (m, r)
    bounds : ndarray of shape (r, 2)

    Returns
    -------
    theta : ndarray of shape (m, r)
        Each target's minimiser within ``bounds`` (damped Gauss-Newton,
        projected on the box, all targets together).
    converged : ndarray of bool, shape (m,)
        Whether its last step was below :data:`STEP_TOL` (else
        :data:`MAX_ITERATIONS` ended it, as along a flat valley).
    """
    m, r = start.shape
    root_w = np.sqrt(weights)[None, :, None]
    theta = np.clip(start, bounds[:, 0], bounds[:, 1])

    damping = np.full(m, 1e-3)
    res = _residuals_at(emulator, Xs, root_w, targets, theta[:, None])[:, 0]
    cost = np.sum(res**2, axis=1)
    active = np.ones(m, dtype=bool)
    for _ in range(MAX_ITERATIONS):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        t = theta[idx]
        shifted = t[:, None, :] + JACOBIAN_STEP * np.eye(r)[None]
        jac_res = _residuals_at(emulator, Xs, root_w, targets[idx], shifted)
        J = (jac_res - res[idx][:, None, :]) / JACOBIAN_STEP  # (k, r, sq)
        JtJ = J @ np.swapaxes(J, 1, 2)
        g = J @ res[idx][:, :, None]
        scale = np.diagonal(JtJ, axis1=1, axis2=2)
        A = JtJ + (damping[idx] * np.maximum(scale, 1e-300).max(axis=1))[
            :, None, None
        ] * np.eye(r)
        step = -np.linalg.solve(A, g)[..., 0]
        trial = np.clip(t + step, bounds[:, 0], bounds[:, 1])
        trial_res = _residuals_at(emulator, Xs, root_w, targets[idx], trial[:, None])
        trial_res = trial_res[:, 0]
        trial_cost = np.sum(trial_res**2, axis=1)
        better = trial_cost <= cost[idx]
        moved = np.max(np.abs(trial - t), axis=1)
        keep = idx[better]
        theta[keep], res[keep], cost[keep] = (
            trial[better],
            trial_res[better],
            trial_cost[better],
        )
        damping[keep] = np.maximum(damping[keep] / 3.0, 1e-9)
        damping[idx[~better]] *= 4.0
        # At the minimum the step vanishes, whether or not rounding let it
        # lower the cost; a step the damping cannot make useful ends too.
        done = (moved < STEP_TOL) | (damping[idx] > 1e8)
        active[idx[done]] = False
    return theta, ~active


def _residuals_at(emulator, Xs, root_w, targets, thetas):
    """Weighted residuals (k, j, s q) of the emulator's mean at the
    ``thetas`` (k, j, r), target ``k`` for all ``j``."""
    k, j, r = thetas.shape
    mean = emulator.kriging_mean(Xs, thetas.reshape(-1, r))
    mean = mean.reshape(k, j, *mean.shape[1:])
    return ((mean - targets[:, None]) * root_w[None]).reshape(k, j, -1)


def best_fit_draws(mixture, rule, emulator, Xs, weights, bounds, random_state=None):
    """The posterior of the best-fit theta, as draws (:class:`BestFit`).

    Parameters
    ----------
    mixture : ModelMixture
        Module 3's global model over the module-2 draws.
    rule : PredictionRule
        Module 4's rule, its ``thetas`` standardised.
    emulator : Emulator
    Xs : ndarray of shape (s, d)
        The distinct field inputs (standardised).
    weights : ndarray of shape (s,)
        Their numbers of readings.
    bounds : ndarray of shape (r, 2)
        The range of theta searched (standardised).
    random_state : int, SeedSequence or None

    Returns
    -------
    BestFit
    """
    rng = np.random.default_rng(seed_sequence(random_state))
    weights = np.asarray(weights, float) / np.sum(weights)
    zeta, picked = reality_draws(mixture, rule, Xs, N_BEST_FIT_DRAWS, rng)
    # Each draw starts at the theta of its reality: nearby where the data
    # identify theta, and a start the data support where not.
    samples, converged = project(
        emulator, Xs, weights, zeta, rule.thetas[picked], bounds
    )
    # A draw that started far out in a wide module-3 posterior may still be
    # on its way, or may have stopped in another local minimum (the
    # monitored bridge, where a stiff bearing is nearly a fixed one: about
    # 1 % of the draws): each also starts at the median of those that
    # arrived, next to its own minimum, and keeps the better of the two.
    if converged.any():
        centre = np.tile(np.median(samples[converged], axis=0), (len(samples), 1))
        again, settled = project(emulator, Xs, weights, zeta, centre, bounds)
        cost = [_cost(emulator, Xs, weights, zeta, t) for t in (samples, again)]
        better = (cost[1] < cost[0] * (1.0 - COST_RTOL)) | ~converged
        samples[better], converged[better] = again[better], settled[better]
    # The draws are independent: every N_BATCHES-th one forms a batch.
    estimates = np.stack([_summaries(samples[b::N_BATCHES]) for b in range(N_BATCHES)])
    tol = 1e-9 * (bounds[:, 1] - bounds[:, 0])
    at_bound = np.mean(
        (samples <= bounds[:, 0] + tol) | (samples >= bounds[:, 1] - tol), axis=0
    )
    flat = _flat_direction(emulator, Xs, weights, np.median(samples, axis=0))
    return BestFit(samples, at_bound, estimates, float(np.mean(~converged)), flat)


def _cost(emulator, Xs, weights, targets, thetas):
    """Each target's weighted sum of squares at its theta (m,)."""
    root_w = np.sqrt(weights)[None, :, None]
    res = _residuals_at(emulator, Xs, root_w, targets, thetas[:, None])[:, 0]
    return np.sum(res**2, axis=1)


def _flat_direction(emulator, Xs, weights, theta):
    """The direction of least curvature of the least squares at ``theta``
    (r,), when it is below :data:`FLAT_RATIO` of the largest; else None."""
    r = theta.size
    if r == 1:
        return None
    root_w = np.sqrt(weights)[None, :, None]
    target = emulator.kriging_mean(Xs, theta[None])  # the residual's origin
    shifted = theta[None, None, :] + JACOBIAN_STEP * np.eye(r)[None]
    J = (_residuals_at(emulator, Xs, root_w, target, shifted)[0]) / JACOBIAN_STEP
    values, vectors = np.linalg.eigh(J @ J.T)
    if values[0] > FLAT_RATIO * values[-1]:
        return None
    return vectors[:, 0]


def _summaries(theta):
    """Mean, sd, 2.5 % and 97.5 % quantiles (4, r) of draws (m, r)."""
    lo, hi = np.quantile(theta, [0.025, 0.975], axis=0)
    return np.stack([theta.mean(axis=0), theta.std(axis=0, ddof=1), lo, hi])


@dataclass(frozen=True)
class BestFitResult:
    """The best fit of a calibration, in user units.

    Attributes
    ----------
    posterior : PosteriorResult
        Its draws, mean and covariance (method ``"best_fit"``).
    mcse : ndarray of shape (4, r)
        Monte Carlo errors of the mean, sd, 2.5 % and 97.5 % quantiles.
    """

    posterior: PosteriorResult
    mcse: np.ndarray


def best_fit_of(inputs, module3, readings, seed):
    """The :class:`BestFitResult` of fitted modules 1-3.

    ``inputs`` is the pipeline's ``ModuleInputs``, ``module3`` its
    ``Module3Result`` (mixture and module 4's rule), ``readings`` the field
    readings behind ``inputs.Xs`` (their counts weigh the inputs). The
    search range is the simulations' range of theta: the emulator is not
    trusted beyond it, and a best fit pinned at its end warns.
    """
    scaler, rule = inputs.scaler, module3.rule
    theta_sim = scaler.theta(inputs.sims.theta)
    bounds = np.column_stack([theta_sim.min(axis=0), theta_sim.max(axis=0)])
    best = best_fit_draws(
        module3.log_post.model,
        replace(rule, thetas=scaler.theta(rule.thetas)),
        inputs.emulator,
        inputs.Xs,
        readings.counts.max(axis=1),
        bounds,
        random_state=seed,
    )
    samples = best.samples * scaler.theta_scale + scaler.theta_offset
    names = parameter_names(inputs.prior)
    for name, share in zip(names, best.at_bound, strict=True):
        if share > AT_BOUND_SHARE:
            warn(
                f"The best fit of {name} lies at an end of the simulated range "
                f"in {share:.0%} of its draws: the model comes closest to "
                "reality beyond the simulations. Run simulations over a wider "
                f"range of {name}.",
                UserWarning,
            )
    if best.flat is not None:
        moves = ", ".join(
            f"{name} {'+' if v > 0 else '-'}{abs(v):.2f}"
            for name, v in zip(names, best.flat, strict=True)
            if abs(v) > 0.05
        )
        warn(
            "The best fit is not unique: at the field inputs the model's "
            f"responses hardly change along ({moves}) (in the simulations' "
            "spread of each parameter); along that direction its draws follow "
            "module 3's posterior, not the data. Fix one of these parameters, "
            "or measure a response that tells them apart.",
            UserWarning,
        )
    elif best.unconverged > AT_BOUND_SHARE:
        warn(
            f"The least squares of {best.unconverged:.0%} of the best fit's "
            f"draws did not converge in {MAX_ITERATIONS} iterations.",
            UserWarning,
        )
    return BestFitResult(
        PosteriorResult.from_draws("best_fit", samples),
        best.mcse * np.abs(scaler.theta_scale),
    )
