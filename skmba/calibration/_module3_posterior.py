"""Module 3 of the modular Bayesian approach: the posterior of theta.

The likelihood of the field data and the simulations given ``theta`` is that of
:class:`~skmba.calibration._module3_likelihood.GlobalModel` (Eq. 4.30, through the Schur
complement), or of a :class:`~skmba.calibration._module3_mixture.ModelMixture` over
module-2 draws. :class:`LogPosterior` adds the prior in user units (picklable, one per
chain), and :func:`posterior_by_mcmc` (any number of parameters) returns a
:class:`PosteriorResult`; one parameter goes by quadrature
(:func:`~skmba.calibration._module3_quadrature.posterior_by_quadrature`).

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._module3_posterior import PosteriorResult
>>> result = PosteriorResult.from_draws("mcmc", np.array([[1.0], [3.0]]))
>>> result.mean, result.cov
(array([2.]), array([[2.]]))
"""

import copy
import time
from dataclasses import replace

import numpy as np

from skmba._core.linalg import (
    FactorizationError,
)
from skmba._core.progress import as_progress
from skmba._core.validation import seed_sequence
from skmba.calibration._module3_coordinates import SamplingCoordinates
from skmba.calibration._module3_mixture import IDLE_CHECK_THETAS, draw_weights_of
from skmba.mcmc._diagnostics import MAX_RHAT, check_diagnostics, split_rhat
from skmba.mcmc._posterior import PosteriorResult, laplace
from skmba.mcmc._run import run_chains
from skmba.mcmc._stopping import EssTarget

SAMPLERS = ("auto", "quadrature", "mcmc")


class LogPosterior:
    """The module-3 log posterior of theta in user units (picklable).

    ``log p(theta) + log p(Y | theta, D, phi)``; ``-inf`` outside the
    prior's support or where the global covariance cannot be factored.

    It also holds the MCMC coordinates ``u`` of theta
    (:class:`~skmba.calibration._module3_coordinates.SamplingCoordinates`,
    standardised with the simulated parameters), in which the chains
    evaluate it with the Jacobian.

    Parameters
    ----------
    prior : skmba prior object
    model : ModelMixture
        The global model over module 2's draws (one draw for the plug-in).
    scaler : Standardizer
    theta_sim : ndarray of shape (N, r)
        The simulated parameters (user units), the scale of ``u``.
    """

    def __init__(self, prior, model, scaler, theta_sim):
        self.prior, self.model, self.scaler = prior, model, scaler
        self.coordinates = SamplingCoordinates.of(prior, theta_sim)

    def with_own_cache(self):
        """A copy whose global model has its own factorisation cache.

        Chains and prediction tasks that share the model under a
        thread-based joblib backend then cannot see each other's cache.
        """
        other = copy.copy(self)
        other.model = copy.copy(self.model)
        return other

    def __call__(self, theta, model=None):
        """Log posterior at one ``theta`` of shape (r,).

        ``model`` replaces the global model (one draw of a mixture).
        """
        return self._at(theta, model)[0]

    def _at(self, theta, model=None, components=False):
        """The log posterior at ``theta`` and, with ``components``, the joint
        log density of ``theta`` and each module-2 draw of the mixture (K,;
        None without)."""
        model = self.model if model is None else model
        joint = np.full(len(model.models), -np.inf) if components else None
        log_prior = float(np.ravel(self.prior.logpdf(theta[None, :]))[0])
        if not np.isfinite(log_prior):
            return -np.inf, joint
        t = self.scaler.theta(theta)
        try:
            if not components:
                return log_prior + model.log_likelihood(t), None
            log_likelihood, parts = model.log_likelihood_with_components(t)
        except FactorizationError:
            return -np.inf, joint
        return log_prior + log_likelihood, log_prior + parts

    def with_model(self, model):
        """A copy with another global model (e.g. a restricted mixture)."""
        other = copy.copy(self)
        other.model = model
        return other

    def to_u(self, theta):
        """Sampling coordinates of ``theta`` (..., r)."""
        return self.coordinates.to_u(theta)

    def from_u(self, u):
        """``theta`` of sampling coordinates ``u`` (..., r)."""
        return self.coordinates.from_u(u)

    def log_jacobian(self, theta):
        """``log |d theta / d u|`` at ``theta`` up to a constant."""
        return self.coordinates.log_jacobian(theta)

    def log_density_u(self, u, model=None):
        """Log posterior density of the sampling coordinates (with Jacobian)."""
        theta = self.from_u(u)
        if not np.all(np.isfinite(theta)):
            return -np.inf
        return self(theta, model) + self.log_jacobian(theta)

    def log_density_u_with_components(self, u):
        """:meth:`log_density_u` and, as :meth:`log_density_u_components`,
        the joint log density of ``u`` and each module-2 draw (K,): the same
        value, bit for bit, from the same evaluation."""
        theta = self.from_u(u)
        if not np.all(np.isfinite(theta)):
            return -np.inf, np.full(len(self.model.models), -np.inf)
        value, joint = self._at(theta, components=True)
        jacobian = self.log_jacobian(theta)
        return value + jacobian, joint + jacobian

    def log_density_u_batch(self, U):
        """:meth:`log_density_u` at the rows of ``U`` (m, r): (m,).

        The likelihoods of all the points inside the prior's support are
        evaluated together (:meth:`GlobalModel.log_likelihoods`).
        """
        return self._log_density_rows(U, self.model.log_likelihoods)

    def log_density_u_batch_with_components(self, U):
        """:meth:`log_density_u_batch` (m,) and :meth:`log_density_u_components`
        (m, K) from the same evaluation, the first bit for bit."""
        K = len(self.model.models)
        out = self._log_density_rows(
            U, self.model.log_likelihoods_with_components, width=1 + K
        )
        return out[:, 0], out[:, 1:]

    def log_density_u_components(self, U):
        """Over a :class:`~skmba.calibration._module3_mixture.ModelMixture`, the joint
        log density of ``u`` and each module-2 draw ``k`` at the rows of ``U`` (m, r):
        (m, K); their ``logsumexp`` over ``k`` is :meth:`log_density_u`."""
        K = len(self.model.models)
        return self._log_density_rows(
            U, self.model.batch_component_log_likelihoods, width=K
        )

    def log_density_u_labelled(self, U, labels):
        """Over a mixture, the joint log density of ``U[b]`` and the module-2
        draw ``labels[b]`` (m,)."""
        return self._log_density_rows(
            U, self.model.labelled_log_likelihoods, np.asarray(labels, dtype=int)
        )

    def batch(self, theta):
        """:meth:`__call__` at the rows of ``theta`` (m, r; one theta of
        shape (r,) is one row) in user units: (m,), the likelihoods inside
        the prior's support evaluated together."""
        return self._log_posterior_rows(
            np.atleast_2d(theta), self.model.log_likelihoods
        )

    def _log_density_rows(self, U, likelihoods, labels=None, width=None):
        """The log density of the rows of ``U`` (:meth:`_log_posterior_rows`
        and the Jacobian of the sampling coordinates)."""
        return self._log_posterior_rows(
            self.from_u(U), likelihoods, labels, width, jacobian=True
        )

    def _log_posterior_rows(
        self, theta, likelihoods, labels=None, width=None, jacobian=False
    ):
        """The log posterior of the rows of ``theta`` with the log likelihoods
        ``likelihoods(thetas[, labels])`` of the rows inside the prior's
        support, evaluated together; one by one when the batch raises
        (a rank-deficient regression at some theta gets -inf)."""
        shape = (len(theta),) if width is None else (len(theta), width)
        out = np.full(shape, -np.inf)
        log_prior = np.full(len(theta), -np.inf)
        finite = np.all(np.isfinite(theta), axis=1)
        if finite.any():
            log_prior[finite] = np.ravel(self.prior.logpdf(theta[finite]))
        inside = np.isfinite(log_prior)
        if not inside.any():
            return out
        t = self.scaler.theta(theta[inside])
        extra = () if labels is None else (labels[inside],)
        try:
            values = likelihoods(t, *extra)
        except FactorizationError:
            values = np.full((len(t), *shape[1:]), -np.inf)
            for i in range(len(t)):
                try:
                    row = (e[i : i + 1] for e in extra)
                    values[i] = likelihoods(t[i : i + 1], *row)[0]
                except FactorizationError:
                    continue
        offset = log_prior[inside]
        if jacobian:
            offset = offset + self.log_jacobian(theta[inside])
        out[inside] = values + (offset if width is None else offset[:, None])
        return out

    def raise_unevaluable(self, thetas):
        """The posterior is -inf at every node: say why, with the cause."""
        middle = np.array([thetas[len(thetas) // 2]])
        try:
            self.model.log_likelihood(self.scaler.theta(middle))
        except FactorizationError as exc:
            noise = self.model.noise * self.scaler.y_scale**2
            raise FactorizationError(
                f"The module-3 likelihood could not be evaluated at any "
                f"quadrature node (at theta={middle[0]:.6g}: {exc}) The "
                f"noise variances are {np.array2string(noise, precision=3)}; "
                "when they sit at their lower bound (noise-free field data), "
                "raise emulator_alpha, or remove responses that are exact "
                "multiples of others in the simulations."
            ) from exc
        raise FactorizationError(
            "The posterior is zero at every quadrature node: the prior gives "
            "no mass there. Check the prior's support against theta_sim."
        )


class _ChainTarget:
    """Log density of the MCMC coordinates for one chain (picklable).

    With ``joint`` over a mixture of module-2 draws, the chain samples theta
    and the draw together (:mod:`skmba.mcmc._chain`, labelled targets):
    ``n_labels`` draws, the joint density of a theta and a draw
    (:meth:`labelled`) and of a theta and every draw (:meth:`components`).
    """

    def __init__(self, log_posterior, joint=False):
        self.log_posterior = log_posterior.with_own_cache()
        self.n_labels = len(log_posterior.model.models) if joint else 1

    def __call__(self, u):
        return self.log_posterior.log_density_u(u)

    def batch(self, U):
        """Log density at the rows of ``U`` (m, r), evaluated together."""
        return self.log_posterior.log_density_u_batch(U)

    def with_blob(self, u):
        """Log density at ``u`` and, its blob, the joint log density of
        ``u`` and each module-2 draw (K,)."""
        return self.log_posterior.log_density_u_with_components(u)

    def batch_with_blobs(self, U):
        """:meth:`batch` and the blobs of :meth:`with_blob` (m, K)."""
        return self.log_posterior.log_density_u_batch_with_components(U)

    def labelled(self, U, labels):
        """Joint log density of ``U[b]`` and module-2 draw ``labels[b]``."""
        return self.log_posterior.log_density_u_labelled(U, labels)

    def components(self, u):
        """Joint log density of ``u`` (r,) and each module-2 draw (K,)."""
        return self.log_posterior.log_density_u_components(u[None, :])[0]


def _chain_starts(log_posterior, n_chains, rng, earlier=None):
    """Overdispersed starts around the mode, the mode and its Laplace covariance.

    The best of many prior draws, refined to the mode; the chains then start
    around it with a Laplace proposal. Over a mixture of module-2 draws,
    the mode and its Laplace covariance are those of the global model at
    the module-2 mode (``model.base``), K times cheaper to evaluate: they
    only place the starts and the first proposal, which the burn-in adapts.
    With ``earlier`` (draws of an earlier run on the same posterior, in user
    units), the starts are around their mean and covariance instead, with
    no mode search.
    """
    if earlier is not None:
        U = log_posterior.to_u(np.asarray(earlier, dtype=float))
        mode, cov = U.mean(axis=0), np.atleast_2d(np.cov(U, rowvar=False))
    else:
        search = log_posterior.with_model(log_posterior.model.base)
        candidates = search.prior.rvs(50 * n_chains, random_state=rng)
        logp = search.log_density_u_batch(search.to_u(candidates))
        order = np.argsort(logp)[::-1][:n_chains]
        if not np.all(np.isfinite(logp[order])):
            raise FactorizationError(
                "Fewer than n_chains prior draws have a finite posterior: check "
                "the prior's support against theta_sim."
            )
        mode, cov = laplace(search.log_density_u, search.to_u(candidates[order[:2]]))
    r = mode.size
    root = np.linalg.cholesky(cov + 1e-12 * np.trace(cov) * np.eye(r))
    starts = []
    while len(starts) < n_chains:
        start = mode + 1.5 * root @ rng.standard_normal(r)
        if np.isfinite(log_posterior.log_density_u(start)):
            starts.append(start)
    return np.array(starts), mode, cov


#: Probability of an independence move per MCMC step (:mod:`skmba.mcmc._run`):
#: the posteriors of theta are mostly unimodal and close to a Student-t in
#: the sampling coordinates, where independence moves give nearly
#: independent draws; one step in ten stays a random walk for the tails and
#: curved ridges.
INDEPENDENCE = 0.9

#: Weight of a left-out module-2 draw at a posterior draw above which the
#: chains are run again over every draw.
_IDLE_CHECK_WEIGHT = 1e-6


def _without_idle_draws(log_posterior, mode, cov, starts):
    """The log posterior over the module-2 draws that matter near the mode.

    Over a mixture of module-2 draws, most of the cost per theta is one
    factorisation per draw, and draws whose weight ``p(phi_k | theta, data)``
    is negligible around the posterior (typically the draws of the prior
    itself, which the defensive proposal adds) change nothing. They are left
    out when their weight stays below
    :data:`~skmba.calibration._module3_mixture.IDLE_WEIGHT` at the mode, at
    the chains' starts and three Laplace standard deviations from the mode
    along each principal axis. Returns the log posterior for the chains and
    the indices of the draws kept (None: ``log_posterior`` itself, when every
    draw is kept, as the plug-in's one draw always is).
    """
    model = log_posterior.model
    values, vectors = np.linalg.eigh(cov)
    axes = (3.0 * np.sqrt(np.clip(values, 0.0, None)) * vectors).T
    points = np.vstack([mode, starts, mode + axes, mode - axes])
    thetas = [log_posterior.scaler.theta(t) for t in log_posterior.from_u(points)]
    restricted, kept = model.restricted([t for t in thetas if np.all(np.isfinite(t))])
    if restricted is model:
        return log_posterior, None
    return log_posterior.with_model(restricted), kept


def _idle_weight(log_posterior, kept, samples, n_jobs=None):
    """The largest weight of the draws left out, at thinned posterior draws
    (evaluated in ``n_jobs`` joblib tasks)."""
    model = log_posterior.model
    left_out = np.setdiff1d(np.arange(len(model.models)), kept)
    step = max(1, len(samples) // IDLE_CHECK_THETAS)
    thetas = log_posterior.scaler.theta(samples[::step])
    weights = draw_weights_of(model.spread_component_log_likelihoods(thetas, n_jobs))
    return float(np.max(weights[:, left_out]))


def posterior_by_mcmc(
    log_posterior,
    *,
    n_chains,
    n_samples,
    burn_in,
    n_jobs=None,
    random_state=None,
    progress=None,
    check=True,
    earlier=None,
    joint=False,
    target_ess=None,
    fallback_burn_in=None,
    earlier_fits_proposal=False,
):
    """Metropolis-Hastings chains on the sampling coordinates.

    Parameters
    ----------
    log_posterior : LogPosterior
    n_chains, n_samples, burn_in : int
    n_jobs : int, default=None
        Chains in parallel through joblib.
    random_state : int, SeedSequence or None
        Seeds the starts and, through a second child, the chains.
    progress : skmba._core.progress.Progress, default=None
        Step lines (the start of the chains, each chain's acceptance) and
        the sampler's bar and detail lines; None is silent.
    check : bool, default=True
        Warn about poor diagnostics (R-hat, ESS) and compute the log
        posterior at the draws; both off for a pilot run (the first pass).
    earlier : ndarray of shape (m, r), default=None
        Draws of an earlier run on (nearly) the same posterior, in user
        units (the propagated module 2's first pass): the chains start
        around their moments, without a mode search.
    joint : bool, default=False
        Over a mixture of module-2 draws, sample theta with the draw (a
        labelled target, :mod:`skmba.mcmc._chain`): one draw's likelihood per
        step instead of all, but slow to mix where ``p(phi_k | theta,
        data)`` changes over the posterior; chains whose burn-in shows it
        fall back to the mixture. For the propagated module 2's first
        pass, which only locates the posterior.
    target_ess : float, default=None
        End the draws once every parameter's bulk and tail ESS reach it and
        its R-hat is at most 1.01 (:class:`~skmba.mcmc._stopping.EssTarget`);
        ``n_samples`` is then the most. None: ``n_samples`` draws.
    fallback_burn_in : int, default=None
        A longer burn-in for chains started from ``earlier`` after a short
        ``burn_in`` (the second pass): when their draws would warn of R-hat
        above 1.01 for theta, the chains run again after this many steps
        (the draws of a run with this burn-in).
    earlier_fits_proposal : bool, default=False
        ``earlier`` are (resampled weighted) draws of this very posterior,
        e.g. an update's refused reweighting: the chains' shared proposal
        after the burn-in is fitted to them as well as to the burn-ins
        (``proposal_points`` of :func:`~skmba.mcmc._run.run_chains`).

    Returns
    -------
    PosteriorResult
    """
    progress = as_progress(progress)
    say = progress.info
    starts_seed, chains_seed = seed_sequence(random_state).spawn(2)
    rng = np.random.default_rng(starts_seed)
    started = time.perf_counter()
    starts, mode, cov = _chain_starts(log_posterior, n_chains, rng, earlier)
    r = starts.shape[1]
    where = f"posterior mode found in {time.perf_counter() - started:.1f} s"
    if earlier_fits_proposal:
        where = "starts from a refused reweighting's draws, which also fit the proposal"
    elif earlier is not None:
        where = "starts from earlier draws (the first pass's or the last posterior's)"
    until = "" if target_ess is None else f" at most, until ESS {target_ess:g}"
    say(
        f"module 3: {where}; running {n_chains} chain(s) of {burn_in} burn-in + "
        f"{n_samples} steps{until}"
    )
    chain_posterior, kept = _without_idle_draws(log_posterior, mode, cov, starts)

    def sample(target):
        result = run(target, burn_in)
        if fallback_burn_in is not None and not _mixed(log_posterior, result):
            say(
                f"module 3: the chains after {burn_in} burn-in steps have not "
                f"mixed; they run again after {fallback_burn_in}"
            )
            result = run(target, fallback_burn_in)
        return result

    def run(target, burn_in):
        # A copy: spawning the chains' seeds advances a SeedSequence, and a
        # second run must draw what the first drew.
        return run_chains(
            [_ChainTarget(target, joint) for _ in range(n_chains)],
            starts,
            n_samples=n_samples,
            burn_in=burn_in,
            proposal_cov=(2.38**2 / r) * cov,
            adapt=True,
            independence=INDEPENDENCE,
            n_jobs=n_jobs,
            blas_order=log_posterior.model.n * log_posterior.model.q,
            random_state=copy.deepcopy(chains_seed),
            progress=progress,
            keep_log_density=check,
            # An earlier run's draws fit the independence proposal at once.
            moments=None if earlier is None else (mode, cov),
            proposal_points=(
                log_posterior.to_u(np.asarray(earlier, dtype=float))
                if earlier_fits_proposal
                else None
            ),
            stopping=None if target_ess is None else EssTarget(target_ess),
            # each draw's p(phi_k | theta, data), for the error of a mixture
            keep_blobs=check and not joint and len(log_posterior.model.models) > 1,
        )

    result = sample(chain_posterior)
    if chain_posterior is not log_posterior:
        result, kept = _checked_idle_draws(
            log_posterior, sample, result, kept, n_jobs, say
        )
    return _mcmc_result(log_posterior, result, kept, check, say)


def _mixed(log_posterior, result):
    """Whether the chains' draws of theta pass the R-hat check that
    :func:`~skmba.mcmc._diagnostics.check_diagnostics` warns about (a short
    run's low ESS is not the burn-in's doing)."""
    chains = log_posterior.from_u(result.samples)
    return all(split_rhat(chains[:, :, j]) <= MAX_RHAT for j in range(chains.shape[-1]))


def _checked_idle_draws(log_posterior, sample, result, kept, n_jobs, say):
    """The chains again over every module-2 draw when a draw left out
    weighs more than :data:`_IDLE_CHECK_WEIGHT` at the posterior draws."""
    n_draws = len(log_posterior.model.models)
    r = result.samples.shape[-1]
    idle = _idle_weight(
        log_posterior,
        kept,
        log_posterior.from_u(result.samples.reshape(-1, r)),
        n_jobs,
    )
    if idle > _IDLE_CHECK_WEIGHT:
        say(
            f"module 3: a module-2 draw left out weighs {idle:.2g} at a "
            f"posterior draw; the chains run again over all {n_draws} draws"
        )
        return sample(log_posterior), None
    say(
        f"module 3: the chains used the {len(kept)} of {n_draws} "
        "module-2 draws with weight near the posterior (the others "
        f"weigh at most {idle:.1g} at the posterior draws)"
    )
    return result, kept


def _mcmc_result(log_posterior, result, kept, check, say):
    """The :class:`PosteriorResult` of the chains' ``result`` (sampling
    coordinates) in user units, with its diagnostics checked when ``check``."""
    r = result.samples.shape[-1]
    chains = log_posterior.from_u(result.samples)
    # Diagnostics of theta itself: the folded part of the rank R-hat is not
    # invariant to the log coordinates (and ArviZ sees theta).
    on_theta = replace(result, samples=chains)
    # The chains' log density is of the sampling coordinates u: take off the
    # Jacobian of the log coordinates to get the log posterior of theta.
    labels = result.labels
    if labels is not None and kept is not None:
        labels = kept[labels]  # the indices of the draws in the whole mixture
    draw_weights = None
    if result.blobs is not None:
        shares = draw_weights_of(result.blobs.reshape(-1, result.blobs.shape[-1]))
        draw_weights = np.zeros((len(shares), len(log_posterior.model.models)))
        draw_weights[:, slice(None) if kept is None else kept] = shares
    log_density = None
    if result.log_density is not None:
        log_density = result.log_density - log_posterior.log_jacobian(chains)
    for c, chain in enumerate(chains):
        say(
            f"module 3: chain {c} done: acceptance {result.acceptance_rate[c]:.2f}"
            f", mean {np.array2string(chain.mean(axis=0), precision=5)}"
        )
    if check:
        check_diagnostics(on_theta)
    return PosteriorResult.from_draws(
        "mcmc",
        chains.reshape(-1, r),
        chains=chains,
        acceptance_rate=result.acceptance_rate,
        rhat=on_theta.rhat,
        ess=on_theta.ess,
        log_density=log_density,
        labels=labels,
        draw_weights=draw_weights,
    )
