"""Module 2 with its uncertainty: the posterior of the hyperparameters.

The default treatment (``discrepancy_uncertainty="propagate"``). The discrepancy and
noise hyperparameters ``phi`` get the documented prior of
:mod:`skmba.priors._hyperprior`; module 2 finds the mode of their restricted (REML)
posterior given the field data with theta integrated over its prior (the integrated
emulator of :mod:`skmba.calibration._module2_prior_integral`), and a Laplace
approximation ``q(phi)`` around it, in coordinates where every hyperparameter is
unbounded (bounded ones through a logit).

Module 3 then integrates ``phi`` out instead of plugging the mode in::

    p(theta | data) ∝ p(theta) ∫ p(data | theta, phi) p(phi) d phi
                    ≈ p(theta) sum_k w_k p(data | theta, phi_k),

an importance-sampling estimate with ``K`` fixed draws ``phi_k`` of a
defensive proposal, three quarters a Student-t version of ``q`` (scrambled
Halton points, 5 degrees of freedom) and one quarter the prior itself, and
weights ``w_k ∝ p(phi_k) / proposal(phi_k)``.
The same draws serve every theta, so the estimate is a smooth function of
theta; ``q`` only sets its precision (any ``q`` gives the right answer as
``K`` grows), never its target. :func:`fit_hyperposterior` returns the
:class:`HyperposteriorDraws`. :class:`HyperparameterCoordinates` gives the
coordinates of ``phi``, ``log p(phi)`` in them and the component of each
point: the pieces of that target, the joint posterior of theta and ``phi``
(checked against it in ``validation/studies/joint_reference.py``).

Examples
--------
>>> import numpy as np
>>> from skmba.priors._hyperprior import Hyperprior
>>> from skmba.kernels import Gauss
>>> X = np.linspace(-1.7, 1.7, 12)[:, None]
>>> Y = np.column_stack([np.sin(2 * X[:, 0]), 0.1 * X[:, 0]])
>>> draws = fit_hyperposterior(X, Y, np.zeros((24, 24)), prior=Hyperprior(),
...                            n_draws=8, random_state=0)
>>> len(draws.components), draws.log_weights.shape
(8, (8,))
"""

from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from scipy import special, stats
from scipy.stats import qmc

from skmba._core.linalg import FactorizationError, proposal_covariance
from skmba._core.progress import as_progress, start_reporter
from skmba._core.regression import regression_basis
from skmba._core.search import gradient_hessian, preconditioned_minimum
from skmba._core.threads import BlasTask
from skmba._core.validation import seed_sequence
from skmba.calibration._module2_kernel import bounded_kernel, discrepancy_kernel
from skmba.calibration._module2_plug_in import DiscrepancyFit, check_module2_memory
from skmba.priors._hyperprior import lkj_correlation

#: Degrees of freedom of the Student-t importance proposal.
PROPOSAL_DF = 5.0
#: Draws of the hyperparameters that module 3 mixes over, by default.
N_HYPER_DRAWS = 16
#: Share of the proposal (and of the draws) that is the prior itself.
PRIOR_SHARE = 0.25
#: Draws of the importance estimate of the noise variances' posterior mean,
#: and the joblib tasks they are evaluated in (on a day's update of the
#: monitored bridge: 0.22 s in one process, 0.15 s with ``n_jobs=2``).
N_NOISE_DRAWS = 512
NOISE_TASKS = 4
# Variance given to a flat direction of the Laplace approximation.
_FLAT_VARIANCE = 4.0


@dataclass(frozen=True)
class DiscrepancyComponent:
    """One value of the module-2 hyperparameters (standardised units)."""

    kernel_: object
    sigma2: np.ndarray
    noise: np.ndarray
    regression: str


@dataclass(frozen=True)
class HyperposteriorDraws:
    """The module-2 posterior of the hyperparameters, for module 3.

    Attributes
    ----------
    mode : DiscrepancyEstimate
        At the posterior mode (``kernel_``, ``sigma2``, ``noise``, ``beta``):
        the fitted attributes of the calibrator.
    components : list of DiscrepancyComponent
        The draws ``phi_k``.
    log_weights : ndarray of shape (K,)
        ``log p(phi_k) - log q(phi_k)``, normalised to sum to one.
    laplace_cov : ndarray or None
        Covariance of the Laplace approximation (unbounded coordinates);
        None for the plug-in (:meth:`plug_in`).
    noise_mean : ndarray of shape (q,) or None
        Posterior mean of the noise variances, an importance estimate with
        :data:`N_NOISE_DRAWS` draws of the same proposal weighted by the
        module-2 posterior: the noise a new observation adds. The ``K``
        draws module 3 mixes over give it poorly (their likelihood weights
        at any theta fall on a few draws near the mode), and the mode
        underestimates it (the noise posterior is skewed to the right).
    noise_ess : float or None
        Effective sample size of that estimate (Kish).
    draw_coordinates : ndarray of shape (K, m) or None
        The draws ``phi_k`` in the unbounded coordinates ``v`` of
        :class:`HyperparameterCoordinates` (those of ``laplace_cov``);
        None for the plug-in.
    mode_coordinates : ndarray of shape (m,) or None
        The mode in those coordinates; None for the plug-in.
    coordinates : object or None
        Those coordinates and module 2's restricted likelihood
        (:class:`HyperparameterCoordinates`); None for the plug-in.
    """

    mode: DiscrepancyFit
    components: list
    log_weights: np.ndarray
    laplace_cov: np.ndarray | None
    noise_mean: np.ndarray | None
    noise_ess: float | None
    draw_coordinates: np.ndarray | None = None
    mode_coordinates: np.ndarray | None = None
    coordinates: object = None

    @property
    def regression(self):
        return self.mode.regression

    @classmethod
    def plug_in(cls, fit):
        """The plug-in of a module-2 estimate ``fit``: one draw, weight one."""
        component = DiscrepancyComponent(
            fit.kernel_, fit.sigma2, fit.noise, fit.regression
        )
        return cls(fit, [component], np.zeros(1), None, None, None)


class _Coordinates:
    """Unbounded coordinates ``v`` of the packed parameters ``p`` of a fit.

    Kernel hyperparameters and log noise variances, bounded, go through a
    logit (``p = lo + (hi - lo) expit(v)``); fixed ones (``lo == hi``) are
    left out of ``v``; the log discrepancy sds and the correlation entries
    are already unbounded.
    """

    def __init__(self, fit, prior):
        k, q = fit.n_kernel, fit.q
        bounds = fit.bounds()
        self.size = len(bounds)
        self.lo, self.hi = bounds[:, 0].copy(), bounds[:, 1].copy()
        self.lo[k + q :], self.hi[k + q :] = -np.inf, np.inf
        self.bounded = np.isfinite(self.lo) & (self.hi > self.lo)
        self.free = self.bounded | ~np.isfinite(self.lo)
        self.fit, self.prior, self.k, self.q = fit, prior, k, q

    def to_p(self, v):
        p = self.lo.copy()
        full = np.zeros(self.size)
        full[self.free] = v
        s = special.expit(full)
        b = self.bounded
        p[b] = self.lo[b] + (self.hi[b] - self.lo[b]) * s[b]
        unb = self.free & ~self.bounded
        p[unb] = full[unb]
        return p, s

    def to_v(self, p):
        p = np.asarray(p, dtype=float)
        width = np.where(self.bounded, self.hi - self.lo, 1.0)
        s = np.clip((p - np.where(self.bounded, self.lo, 0.0)) / width, 1e-6, 1 - 1e-6)
        v = np.where(self.bounded, special.logit(s), p)
        return v[self.free]

    def log_posterior(self, v, eval_gradient=True):
        """Restricted log likelihood + log prior + log Jacobian, in ``v``."""
        p, s = self.to_p(v)
        k, q = self.k, self.q
        try:
            out = self.fit.evaluate(p, eval_gradient)
        except FactorizationError:
            return (-np.inf, np.zeros(len(v))) if eval_gradient else -np.inf
        ll, grad = out if eval_gradient else (out, None)
        lp_sd, g_sd = self.prior.log_sd(p[k + q : k + 2 * q])
        lp_z, g_z = self.prior.log_correlation(p[k + 2 * q :], q)
        width = self.hi - self.lo
        jac = np.where(self.bounded, width * s * (1 - s), 1.0)
        log_jac = np.sum(np.log(jac[self.bounded]))
        value = ll + lp_sd + lp_z + log_jac
        if not eval_gradient:
            return value
        grad = grad.copy()
        grad[k + q : k + 2 * q] += g_sd
        grad[k + 2 * q :] += g_z
        grad = grad * jac + np.where(self.bounded, 1.0 - 2.0 * s, 0.0)
        return value, grad[self.free]

    def log_prior_normalised(self, v):
        """``log p(phi)`` in ``v``, normalised (for a defensive mixture)."""
        p, s = self.to_p(v)
        k, q = self.k, self.q
        value = self.prior.log_sd_normalised(p[k + q : k + 2 * q])
        value += self.prior.log_correlation_normalised(p[k + 2 * q :], q)
        return value + float(np.sum(np.log((s * (1 - s))[self.bounded])))

    def component(self, v):
        """The :class:`DiscrepancyComponent` of ``v``."""
        fit = self.fit
        theta, lam, L = fit.unpack(self.to_p(v)[0])
        kern = fit.kernel.clone_with_theta(theta) if fit.n_kernel else fit.kernel
        return DiscrepancyComponent(kern, L @ L.T, lam, fit.regression)

    def coordinates_of(self, component):
        """``v`` of a :class:`DiscrepancyComponent` (the inverse of
        :meth:`component`; bounded coordinates within 1e-6 of a bound, in
        the logit's scale, are put there)."""
        fit = self.fit
        theta = component.kernel_.theta if fit.n_kernel else np.zeros(0)
        L = np.linalg.cholesky(np.asarray(component.sigma2, dtype=float))
        return self.to_v(fit.pack(theta, np.asarray(component.noise, float), L))

    def prior_draw(self, rng):
        """``v`` of one draw of the prior."""
        k, q = self.k, self.q
        p = self.lo.copy()
        b = self.bounded
        p[b] = rng.uniform(self.lo[b], self.hi[b])
        sd = np.abs(rng.normal(0, self.prior.scales(q), q))
        p[k + q : k + 2 * q] = np.log(sd)
        L = np.linalg.cholesky(lkj_correlation(q, self.prior.correlation_eta, rng))
        p[k + 2 * q :] = (L / np.diag(L)[:, None])[np.tril_indices(q, -1)]
        return self.to_v(p)

    def objective(self, v):
        # Line searches may step to hyperparameters whose exponentials
        # overflow: the value is then non-finite and handled here.
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            value, grad = self.log_posterior(v)
        if not np.isfinite(value):
            return 1e300, np.zeros_like(v)
        return -value, -grad


def clamped_inverse(H):
    """The inverse of a Hessian ``H`` of ``-log posterior`` as a covariance:
    flat or non-convex directions (eigenvalues below ``1 / 4``) get the
    wide, finite variance 4 (the unbounded coordinates' scale)."""
    values, vectors = np.linalg.eigh(0.5 * (H + H.T))
    inv = np.where(
        values > 1.0 / _FLAT_VARIANCE, 1.0 / np.maximum(values, 1e-300), _FLAT_VARIANCE
    )
    return (vectors * inv) @ vectors.T


def _laplace_cov(coords, v):
    """Inverse of the finite-difference Hessian of ``-log posterior`` at ``v``."""
    return clamped_inverse(gradient_hessian(coords.objective, v))


def halton_student_t(mean, cov, n, seed):
    """``n`` draws of the Student-t with :data:`PROPOSAL_DF` degrees of
    freedom, location ``mean`` and scale matrix ``cov``, from scrambled
    Halton points (the normal and chi-square parts by inverse CDF)."""
    m = len(mean)
    halton = qmc.Halton(m + 1, scramble=True, seed=np.random.default_rng(seed))
    u = np.clip(halton.random(n), 1e-12, 1 - 1e-12)
    chi2 = stats.chi2.ppf(u[:, m], PROPOSAL_DF)
    z = stats.norm.ppf(u[:, :m]) * np.sqrt(PROPOSAL_DF / chi2)[:, None]
    root = np.linalg.cholesky(cov + 1e-12 * np.eye(m))
    return mean + z @ root.T


def proposal_draws(coords, mode, cov, n_draws, seed, prior_share=PRIOR_SHARE):
    """Draws of the defensive proposal, their log prior and log proposal
    densities (the log importance weights for the prior are the difference).

    The proposal ``q = (1 - a) t + a p`` mixes the Student-t around the mode
    (scrambled Halton) with the prior ``p`` itself (share ``a`` =
    ``prior_share``, its draws stratified between both): the weights
    ``p / q`` are then at most ``1 / a``, and the prior's draws reach
    hyperparameters far from the mode, where the mode of an approximate
    module 2 may be wrong (Hesterberg 1995, Technometrics 37).
    """
    cov = proposal_covariance(cov)
    t_seed, p_seed = seed.spawn(2)
    n_prior = round(prior_share * n_draws)
    rng = np.random.default_rng(p_seed)
    draws = np.vstack(
        [halton_student_t(mode, cov, n_draws - n_prior, t_seed)]
        + [coords.prior_draw(rng) for _ in range(n_prior)]
    )
    log_p = np.array([coords.log_prior_normalised(v) for v in draws])
    return draws, log_p, proposal_log_density(mode, cov, draws, log_p, prior_share)


def proposal_log_density(mode, cov, V, log_p, prior_share=PRIOR_SHARE):
    """``log q`` of :func:`proposal_draws`' defensive proposal around
    ``mode`` with scale ``cov`` at the rows of ``V``, whose log prior
    densities are ``log_p``."""
    cov = proposal_covariance(cov)
    log_t = np.atleast_1d(stats.multivariate_t(mode, cov, df=PROPOSAL_DF).logpdf(V))
    return np.logaddexp(np.log1p(-prior_share) + log_t, np.log(prior_share) + log_p)


def _log_posteriors(coords, draws):
    """``coords.log_posterior`` (no gradient) at the rows of ``draws``."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return [coords.log_posterior(v, eval_gradient=False) for v in draws]


def _noise_posterior_mean(coords, mode, cov, seed, n_jobs=None):
    """Posterior mean of the noise variances and its effective sample size.

    Self-normalised importance sampling with :data:`N_NOISE_DRAWS` draws of
    the defensive proposal of :func:`proposal_draws`, weighted by the
    module-2 posterior (restricted likelihood, prior and Jacobian), which
    is evaluated in :data:`NOISE_TASKS` joblib tasks of ``n_jobs`` (each
    draw on its own: the same values for any ``n_jobs``).
    """
    draws, _, log_q = proposal_draws(coords, mode, cov, N_NOISE_DRAWS, seed)
    task = BlasTask(_log_posteriors, len(coords.fit.V_fixed), n_jobs)
    with task.held():
        parts = Parallel(n_jobs=n_jobs)(
            delayed(task)(coords, chunk) for chunk in np.array_split(draws, NOISE_TASKS)
        )
    log_post = np.concatenate(parts)
    log_w = np.where(np.isfinite(log_post), log_post - log_q, -np.inf)
    w = np.exp(log_w - special.logsumexp(log_w))
    noise = np.array([coords.fit.unpack(coords.to_p(v)[0])[1] for v in draws])
    return w @ noise, float(1.0 / np.sum(w**2))


def _posterior_coordinates(
    X_e, residual, V_fixed, prior, kernel, regression, noise, replicates=None
):
    """The restricted likelihood of module 2 under ``prior``, in the
    unbounded coordinates of :class:`_Coordinates`."""
    kernel_d = discrepancy_kernel(kernel, X_e)
    if "roughness" in kernel_d.get_params():
        kernel_d = bounded_kernel(kernel, X_e, prior.roughness, prior.units)
    check_module2_memory(kernel_d, residual)
    H_d = regression_basis(X_e, regression)
    q = residual.shape[1]
    prior.scales(q)  # one sd_scale per response, or one
    fit = DiscrepancyFit(
        kernel_d,
        X_e,
        residual,
        H_d,
        V_fixed,
        None,
        regression=regression,
        restricted=True,
        unit_scale=True,
        fixed_noise=None if noise else 1e-10,
        log_noise_bounds=np.log(prior.noise_bounds(q)) if noise else None,
        free_sd=True,
        replicates=replicates,
    )
    return _Coordinates(fit, prior)


@dataclass(frozen=True)
class HyperparameterCoordinates:
    """The module-2 hyperparameters ``phi`` in unbounded coordinates ``v``.

    What a sampler over theta and ``phi`` together needs (the joint
    posterior ``p(theta, phi | data)`` that module 3's mixture integrates
    over ``phi``): the coordinates of :func:`fit_hyperposterior`'s draws
    (``HyperposteriorDraws.draw_coordinates``) and Laplace approximation,
    ``log p(phi)`` in them and the component of each ``v``. Build it with
    :meth:`from_field_data`, from the arguments of
    :func:`fit_hyperposterior`; the coordinates and the prior depend on the
    residual only through its shape (module 2's likelihood, which uses it,
    is not part of this).

    Attributes
    ----------
    coordinates : object
        The coordinates and the restricted likelihood behind them (this
        module's own).
    size : int
        The number of free hyperparameters, the length of ``v``.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.priors._hyperprior import Hyperprior
    >>> X = np.linspace(-1.7, 1.7, 12)[:, None]
    >>> space = HyperparameterCoordinates.from_field_data(
    ...     X, np.zeros((12, 2)), np.zeros((24, 24)), prior=Hyperprior())
    >>> space.size  # roughness, 2 noise variances, 2 sds, 1 correlation
    6
    >>> component = space.component(np.zeros(6))
    >>> bool(np.allclose(space.coordinates_of(component), 0.0))
    True
    """

    coordinates: object

    @classmethod
    def from_field_data(
        cls,
        X_e,
        residual,
        V_fixed,
        *,
        prior,
        kernel=None,
        regression="constant",
        noise=True,
        replicates=None,
    ):
        """The coordinates of :func:`fit_hyperposterior` for its arguments."""
        return cls(
            _posterior_coordinates(
                X_e, residual, V_fixed, prior, kernel, regression, noise, replicates
            )
        )

    @property
    def size(self):
        return int(np.sum(self.coordinates.free))

    def log_prior(self, v):
        """``log p(phi)`` at ``v``: normalised, with the Jacobian of ``v``."""
        return float(self.coordinates.log_prior_normalised(np.asarray(v, float)))

    def component(self, v):
        """The :class:`DiscrepancyComponent` of ``v`` (standardised units),
        as :func:`fit_hyperposterior` builds its draws."""
        return self.coordinates.component(np.asarray(v, dtype=float))

    def coordinates_of(self, component):
        """``v`` of a component (``kernel_``, ``sigma2``, ``noise``): the
        inverse of :meth:`component`."""
        return self.coordinates.coordinates_of(component)


def _posterior_mode(coords, n_restarts, noise, seed, progress, start=None):
    """The mode of the module-2 posterior: L-BFGS-B, preconditioned when it
    crawls (:func:`~skmba._core.search.preconditioned_minimum`), from the
    default start (or ``start``, coordinates of an earlier mode) and
    ``n_restarts`` random ones (kernel and noise uniform in their bounds);
    the best ``scipy.optimize`` result."""
    fit, k, q = coords.fit, coords.k, coords.q
    rng = np.random.default_rng(seed)
    p0 = fit.start()
    starts = [coords.to_v(p0) if start is None else np.asarray(start, float)]
    for _ in range(n_restarts):
        p = p0.copy()
        p[:k] = rng.uniform(coords.lo[:k], coords.hi[:k])
        if noise:
            p[k : k + q] = rng.uniform(coords.lo[k : k + q], coords.hi[k : k + q])
        starts.append(coords.to_v(p))
    progress = as_progress(progress)
    best = None
    with progress.bar(len(starts), "module 2: discrepancy", unit="start") as bar:
        report = start_reporter(progress, bar, "module 2")
        for j, v0 in enumerate(starts, 1):
            res = preconditioned_minimum(coords.objective, v0)
            report(j, len(starts), float(res.fun))
            if best is None or res.fun < best.fun:
                best = res
    if not best.fun < 1e300:
        raise FactorizationError(
            "The module-2 posterior could not be evaluated at any start: the "
            "field-data covariance is singular. Check the field data (are "
            "there duplicated rows?) or use another discrepancy kernel."
        )
    return best


def fit_hyperposterior(
    X_e,
    residual,
    V_fixed,
    *,
    prior,
    kernel=None,
    regression="constant",
    noise=True,
    n_restarts=0,
    n_draws=N_HYPER_DRAWS,
    random_state=None,
    progress=None,
    noise_mean=True,
    replicates=None,
    start=None,
    n_jobs=None,
):
    """Module 2b with its uncertainty: mode, Laplace and draws of ``phi``.

    Parameters
    ----------
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    residual : ndarray of shape (n, q)
        Standardised field data minus the prior-integrated emulator mean.
    V_fixed : ndarray of shape (n q, n q)
        The prior-integrated emulator covariance.
    prior : Hyperprior
    kernel : sklearn Kernel or None
        Discrepancy correlation (see
        :func:`~skmba.calibration._module2_kernel.discrepancy_kernel`); the kernels of
        :mod:`skmba.kernels` get the prior's roughness range as bounds.
    regression : {"constant", "linear", "quadratic"}
    noise : bool
        Estimate the noise; False holds it at a negligible nugget.
    n_restarts : int
        Random restarts of the mode search.
    n_draws : int
        ``K``, the draws module 3 mixes over (a power of two).
    random_state : int, SeedSequence or None
    progress : skmba._core.progress.Progress, default=None
    noise_mean : bool, default=True
        Estimate the noise variances' posterior mean (what predictions of
        new observations add); False skips it (``noise_mean`` and
        ``noise_ess`` are then None), for a pass that does not predict.
    replicates : ReplicateTerms, default=None
        The rows of ``residual`` are means of repeated readings
        (:class:`~skmba.calibration._field_replicates.ReplicateTerms`).
    start : ndarray, default=None
        Coordinates (``HyperposteriorDraws.mode_coordinates``) of an earlier
        mode to start the search at (an update with more readings).
    n_jobs : int, default=None
        joblib workers of the noise variances' posterior mean (the same
        values for any number).

    Returns
    -------
    HyperposteriorDraws
    """
    coords = _posterior_coordinates(
        X_e, residual, V_fixed, prior, kernel, regression, noise, replicates
    )
    mode_seed, draw_seed, noise_seed = seed_sequence(random_state).spawn(3)
    best = _posterior_mode(coords, n_restarts, noise, mode_seed, progress, start)
    fit = coords.fit
    mode = fit.estimate(coords.to_p(best.x)[0])
    cov = _laplace_cov(coords, best.x)
    draws, log_p, log_q = proposal_draws(coords, best.x, cov, n_draws, draw_seed)
    log_w = log_p - log_q
    log_w -= special.logsumexp(log_w)
    components = [coords.component(v) for v in draws]
    noise = (
        _noise_posterior_mean(coords, best.x, cov, noise_seed, n_jobs)
        if noise_mean
        else (None, None)
    )
    return HyperposteriorDraws(
        mode,
        components,
        log_w,
        cov,
        *noise,
        draws,
        best.x,
        HyperparameterCoordinates(coords),
    )


def propagated_module2(integrated, *, first_pass, posterior, integrate, second_pass):
    """The propagated module 2, in two passes; the calibrator's and the
    sensor designer's.

    1. ``first_pass(integrated)``: draws of the hyperparameters given the
       field data, with theta integrated over its prior (``integrated``, the
       prior-integrated emulator);
    2. ``posterior(draws)``: the posterior of theta over those draws (module
       3 by MCMC or quadrature for the calibrator, importance quadrature for
       the designer);
    3. ``integrate(posterior)``: the emulator integrated over that posterior,
       a closer proposal than the prior for the hyperparameters' draws;
    4. ``second_pass(...)``: the draws again, from that integral: the draws
       module 3 mixes over.

    Returns the second pass's draws and the first pass's posterior.
    """
    first = posterior(first_pass(integrated))
    return second_pass(integrate(first)), first
