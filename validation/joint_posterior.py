"""The joint posterior of theta and the module-2 hyperparameters, for checks.

The default calibrator integrates the discrepancy and noise hyperparameters
``phi`` out of module 3 by importance sampling; its target, for a fitted
emulator, is the joint posterior ``p(theta, phi | data) ∝ p(theta) p(phi)
p(data | theta, phi)``. This module samples that target on a fitted
calibrator's own pieces:

- :func:`fit_default`: the default calibrator on a replicate of the suite;
- :func:`calibrator_log_posterior`, :func:`hyperparameter_space`: its prior
  of theta in the sampling coordinates ``u``, and the unbounded
  coordinates ``v`` of ``phi``
  (:class:`~skmba.calibration._module2_posterior.HyperparameterCoordinates`),
  both checked against the calibrator;
- :class:`JointTarget`: the joint log density at ``(u, v)``;
  :class:`Component`: a global model's hyperparameters, for ``v``;
- :func:`joint_starts`, :func:`sample_joint`: the chains
  (:func:`skmba.mcmc._run.run_chains`), lengthened until converged;
  :func:`sd_mcse`: the Monte Carlo error of an sd of draws;
- :func:`conditional_posterior`, :func:`rao_blackwell`: for one parameter,
  theta given each sampled ``v`` by quadrature, whose mixture estimates the
  posterior of theta with far less Monte Carlo error than the draws of
  theta themselves (where ``phi`` sets how wide theta is, the chains
  explore the wide conditionals slowly).

Callers: ``validation/studies/joint_reference.py`` and
``tests/validation/test_joint_reference.py``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from skmba import ModularBayesCalibrator
from skmba.calibration._module1_emulator import Standardizer
from skmba.calibration._module2_posterior import HyperparameterCoordinates
from skmba.calibration._module3_posterior import LogPosterior
from skmba.mcmc import ess_bulk, split_rhat
from skmba.mcmc._posterior import laplace
from skmba.mcmc._run import run_chains
from skmba.priors._hyperprior import Hyperprior

N_CHAINS = 4
TARGET_ESS = 1000  # bulk ESS of every theta, at least
RHAT_FLAG = 1.01  # split R-hat of every coordinate, at most
N_SAMPLES = 30_000  # draws per chain of the first run
BURN_IN = 5000  # steps per chain and run, adapting the proposal
MAX_SAMPLES = 100_000  # per chain: the lengthening stops here
INDEPENDENCE = 0.9  # share of independence moves after half the burn-in
# Conditional quadrature: Gauss-Legendre nodes per pass, most passes, nodes
# that must carry the mass (those of the calibrator's own quadrature).
NODES, PASSES, RESOLVED = 201, 8, 40


class JointTarget:
    """``log p(theta, phi | data)`` + const at ``x = (u, v)`` (picklable).

    ``log p(theta)`` in the sampling coordinates ``u`` of ``log_posterior``
    (a :class:`~skmba.calibration._module3_posterior.LogPosterior`, with the
    Jacobian of ``u``), ``log p(phi)`` in the coordinates ``v`` of ``space``
    (with its Jacobian) and the module-3 likelihood of the global model at
    ``component(v)``; ``-inf`` where either prior or the likelihood is zero.
    """

    def __init__(self, log_posterior, space):
        self.log_posterior = log_posterior.with_own_cache()
        self.base = self.log_posterior.model.base
        self.space = space
        self.r = len(log_posterior.coordinates.u_mean)

    @property
    def size(self):
        return self.r + self.space.size

    def model(self, v):
        """The global model at the hyperparameters ``v``."""
        return self.base.with_discrepancy(self.space.component(v))

    def __call__(self, x):
        u, v = x[: self.r], x[self.r :]
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            log_prior_v = self.space.log_prior(v)
            if not np.isfinite(log_prior_v):
                return -np.inf
            value = self.log_posterior.log_density_u(u, self.model(v))
        return value + log_prior_v if np.isfinite(value) else -np.inf


# --------------------------------------------------------------------------
# the calibrator's pieces
# --------------------------------------------------------------------------


def fit_default(case, random_state):
    """The default calibrator on one replicate, as the validity suite fits it."""
    cal = ModularBayesCalibrator(prior=case.prior, random_state=random_state, n_jobs=1)
    return cal.fit(
        case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
    )


def hyperparameter_space(cal):
    """The coordinates of the calibrator's module-2 hyperparameters.

    Built as its :func:`fit_hyperposterior` builds them (the coordinates
    depend on the residual and the integrated covariance only through their
    shapes), and checked: every module-2 draw of its mixture is reproduced
    by ``component(coordinates_of(draw))``.
    """
    base = cal.global_model_.base
    n, q = base.Y_e.shape
    space = HyperparameterCoordinates.from_field_data(
        base.X_e,
        np.zeros((n, q)),
        np.zeros((n * q, n * q)),
        prior=Hyperprior.from_spec(cal.discrepancy_prior).in_units(
            cal.discrepancy_prior_units_
        ),
        kernel=cal.discrepancy_kernel,
        regression=cal.discrepancy_regression,
        noise=cal.noise,
    )
    for model in cal.global_model_.models:
        v = space.coordinates_of(Component(model))
        again = space.component(v)
        ok = np.allclose(again.sigma2, model.sigma2_d, rtol=1e-8, atol=1e-14)
        ok &= np.allclose(again.noise, model.noise, rtol=1e-8, atol=1e-14)
        ok &= np.allclose(again.kernel_.theta, model.kernel_d.theta, atol=1e-8)
        if not ok:
            raise RuntimeError("the module-2 coordinates are not the calibrator's")
    return space


class Component:
    """The module-2 hyperparameters of a global model (``kernel_``,
    ``sigma2``, ``noise``), as ``coordinates_of`` takes them."""

    def __init__(self, model):
        self.kernel_, self.sigma2 = model.kernel_d, model.sigma2_d
        self.noise = model.noise


def joint_starts(cal, target, n_chains, rng):
    """Starts ``(u, v)`` of the chains and an initial proposal covariance.

    Chain 0 starts at the posterior mean of theta and the module-2 mode;
    the others at posterior draws of theta (``theta_samples_``), each with
    a module-2 draw of the mixture picked with probability ``p(phi_k |
    theta, data)``. The proposal is the Laplace covariance at the joint
    mode found from chain 0's start (the burn-in adapts it).
    """
    lp, mixture, space = target.log_posterior, cal.global_model_, target.space

    def start(theta, model):
        return np.r_[lp.to_u(theta), space.coordinates_of(Component(model))]

    starts = [start(cal.theta_mean_, mixture.base)]
    while len(starts) < n_chains:
        theta = cal.theta_samples_[rng.integers(len(cal.theta_samples_))]
        weights = mixture.draw_weights(lp.scaler.theta(theta))
        x = start(theta, mixture.models[rng.choice(len(weights), p=weights)])
        if np.isfinite(target(x)):
            starts.append(x)
    _, cov = laplace(target, [starts[0]])
    if not np.all(np.isfinite(cov)):
        cov = 0.01 * np.eye(len(starts[0]))
    return np.array(starts), cov


def calibrator_log_posterior(cal):
    """The calibrator's module-3 log posterior (prior, coordinates ``u``),
    rebuilt from its fitted attributes and checked against
    :meth:`~skmba.ModularBayesCalibrator.log_posterior` at its posterior mean."""
    scaler = Standardizer.from_simulations(cal.X_sim_, cal.theta_sim_, cal.y_sim_)
    log_post = LogPosterior(cal.prior_, cal.global_model_, scaler, cal.theta_sim_)
    if not np.isclose(
        log_post(cal.theta_mean_), cal.log_posterior(cal.theta_mean_), rtol=1e-12
    ):
        raise RuntimeError("the rebuilt log posterior is not the calibrator's")
    return log_post


# --------------------------------------------------------------------------
# the chains
# --------------------------------------------------------------------------


def sample_joint(
    log_density,
    starts,
    proposal_cov,
    *,
    n_samples=N_SAMPLES,
    burn_in=BURN_IN,
    target_ess=TARGET_ESS,
    watch=None,
    independence=INDEPENDENCE,
    max_samples=MAX_SAMPLES,
    random_state=0,
):
    """Adaptive Metropolis-Hastings chains, lengthened until converged.

    :func:`~skmba.mcmc._run.run_chains` from ``starts`` with the proposal
    ``2.38^2 / d proposal_cov``, adapted during ``burn_in``. While a
    coordinate in ``watch`` (default: all) has a bulk ESS short of
    ``target_ess`` or any coordinate a split R-hat above :data:`RHAT_FLAG`
    (``target_ess`` None: one run), each chain goes on from its last draw
    with its adapted proposal, the pooled moments for the independence
    moves and another burn-in, for 1.2 times the draws the ESS asks (twice
    as many for R-hat); the draws of all runs are kept, at most
    ``max_samples`` per chain.

    Returns a dict: ``samples`` (n_chains, n, d), ``rhat`` and ``ess`` of
    every coordinate (:func:`skmba.mcmc.split_rhat`,
    :func:`skmba.mcmc.ess_bulk`), ``acceptance`` (per chain, over the
    draws), ``runs`` and ``burn_in`` (per run).
    """
    starts = np.asarray(starts, dtype=float)
    d = starts.shape[1]
    watch = np.arange(d) if watch is None else np.asarray(watch)
    cov, moments = (2.38**2 / d) * proposal_cov, None
    parts, accepted = [], 0.0
    for seed in np.random.SeedSequence(random_state).spawn(8):
        result = run_chains(
            log_density,
            starts,
            n_samples=n_samples,
            burn_in=burn_in,
            proposal_cov=cov,
            adapt=True,
            independence=independence,
            n_jobs=1,
            random_state=seed,
            keep_log_density=False,
            moments=moments,
        )
        parts.append(result.samples)
        accepted = accepted + result.acceptance_rate * n_samples
        samples = np.concatenate(parts, axis=1)
        rhat = np.array([split_rhat(samples[:, :, j]) for j in range(d)])
        ess = np.array([ess_bulk(samples[:, :, j]) for j in range(d)])
        total = samples.shape[1]
        factor = max(
            (target_ess or 0) / max(np.min(ess[watch]), 1.0),
            2.0 if np.max(rhat) > RHAT_FLAG else 0.0,
        )
        if target_ess is None or factor <= 1.0 or total >= max_samples:
            break
        more = total * (1.2 * factor - 1.0)
        n_samples = min(max_samples - total, 100 * math.ceil(more / 100))
        starts, cov = result.samples[:, -1], result.proposal_cov
        pooled = samples.reshape(-1, d)
        moments = (pooled.mean(axis=0), np.cov(pooled, rowvar=False))
    return {
        "samples": samples,
        "rhat": rhat,
        "ess": ess,
        "acceptance": accepted / samples.shape[1],
        "runs": len(parts),
        "burn_in": burn_in,
    }


def sd_mcse(chains, n_batches=10):
    """Monte Carlo standard error of the sd of the pooled ``chains`` (n_chains, n).

    Batch means of the squared deviations from the pooled mean,
    ``n_batches`` consecutive batches per chain, and the delta method
    (``se(sd) = se(var) / (2 sd)``).
    """
    chains = np.asarray(chains, dtype=float)
    sq = (chains - chains.mean()) ** 2
    n = sq.shape[1] // n_batches * n_batches
    means = sq[:, :n].reshape(len(sq), n_batches, -1).mean(axis=2).ravel()
    return float(np.std(means, ddof=1) / np.sqrt(len(means)) / (2 * chains.std()))


# --------------------------------------------------------------------------
# one parameter: theta given phi by quadrature
# --------------------------------------------------------------------------


@functools.cache
def _gauss_legendre(n):
    """The ``n``-node Gauss-Legendre rule (an eigenproblem: computed once)."""
    return np.polynomial.legendre.leggauss(n)


def conditional_posterior(log_posterior, model, n_draws, offset=0.5):
    """``p(theta | phi, data)`` of one parameter, by adaptive quadrature.

    ``∝ p(theta) p(data | theta, phi)`` with ``model`` the global model at
    ``phi``: the calibrator's Gauss-Legendre rule (:data:`NODES` nodes on
    the prior's 0.9999 interval, then on the region that holds all but
    1e-12 of the mass, until :data:`RESOLVED` nodes carry it), its
    likelihoods evaluated together. Returns the mean, the variance and
    ``n_draws`` stratified draws (inverse CDF at ``(i + offset) /
    n_draws``).
    """
    prior, scaler = log_posterior.prior, log_posterior.scaler
    lo, hi = prior.bounds(0.9999)[0]
    x, w = _gauss_legendre(NODES)
    for sweep in range(PASSES):
        t = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
        log_p = np.ravel(prior.logpdf(t[:, None]))
        inside = np.isfinite(log_p)
        log_p[inside] += model.log_likelihoods(scaler.theta(t[inside, None]))
        density = np.exp(log_p - np.max(log_p))
        weights = w * density / np.sum(w * density)
        mass = np.cumsum(weights)
        carry = np.flatnonzero((mass > 1e-12) & (mass < 1 - 1e-12))
        peak = np.argmax(weights)
        lo = t[max((carry[0] if carry.size else peak) - 2, 0)]
        hi = t[min((carry[-1] if carry.size else peak) + 2, NODES - 1)]
        if sweep >= 1 and carry.size >= RESOLVED:
            break
    mean = weights @ t
    cdf = np.concatenate(
        [[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(t))]
    )
    draws = np.interp((np.arange(n_draws) + offset) / n_draws, cdf / cdf[-1], t)
    return mean, weights @ (t - mean) ** 2, draws


def rao_blackwell(log_posterior, target, v_chains, n_draws=16, rng=None):
    """The posterior of one theta from the chains' draws of ``v`` (n_chains,
    m, size): the mixture of :func:`conditional_posterior` at each.

    Returns a dict: ``mean``, ``sd`` (by the law of total variance),
    ``lo``, ``hi`` (the central 95 % interval of ``n_draws`` stratified
    draws per ``v``) and ``sd_mcse`` (batch means of each chain's
    contributions to the variance, as :func:`sd_mcse`).
    """
    rng = np.random.default_rng(rng)
    n_chains, m = v_chains.shape[:2]
    moments = np.empty((n_chains, m, 2))
    draws = []
    for c in range(n_chains):
        for i in range(m):
            mean, var, d = conditional_posterior(
                log_posterior, target.model(v_chains[c, i]), n_draws, rng.uniform()
            )
            moments[c, i] = mean, var
            draws.append(d)
    mu = moments[..., 0].mean()
    share = moments[..., 1] + (moments[..., 0] - mu) ** 2
    sd = math.sqrt(share.mean())
    batches = share[:, : m // 10 * 10].reshape(n_chains, 10, -1).mean(axis=2).ravel()
    lo, hi = np.quantile(np.concatenate(draws), [0.025, 0.975])
    return {
        "mean": np.array([mu]),
        "sd": np.array([sd]),
        "lo": np.array([lo]),
        "hi": np.array([hi]),
        "sd_mcse": np.array(
            [np.std(batches, ddof=1) / np.sqrt(batches.size) / (2 * sd)]
        ),
    }
