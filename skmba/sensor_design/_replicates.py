"""The Monte Carlo replicates of the fast preposterior analysis (chapter 6).

Step 2a of the FPA for one replicate (:func:`draw_replicate`): synthetic
field data drawn from the priors of theta, the emulator, the discrepancy
and the noise, and module 2 on them, with the calibrator's two treatments:
``"plug-in"`` (the thesis: data from the uniform priors of Table 6.2,
module 2's estimate as one draw of weight one) and ``"propagate"`` (data
from the calibrator's default hyperprior; module 2's draws in two passes,
:func:`~skmba.calibration._module2_posterior.propagated_module2`, as the
calibrator does). :func:`subset_draws`, :func:`likelihoods` and :func:`mixed` give a
replicate's module-3 likelihood for a response subset, which
:mod:`skmba.sensor_design._scoring` turns into posterior moments.
:class:`MonteCarloContext` is what every task needs.
"""

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import special, stats
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from skmba._core.regression import regression_basis
from skmba._core.validation import int_seed
from skmba._core.warn import warn
from skmba.calibration._module2_kernel import discrepancy_kernel
from skmba.calibration._module2_plug_in import fit_discrepancy
from skmba.calibration._module2_posterior import (
    HyperposteriorDraws,
    fit_hyperposterior,
    propagated_module2,
)
from skmba.calibration._module2_prior_integral import (
    integrate_over_prior,
    integrate_over_rule,
    prior_units,
)
from skmba.priors._hyperprior import Hyperprior
from skmba.sensor_design._posterior_moments import posterior_moments
from skmba.sensor_design._subset_likelihood import (
    FieldDesignEmulator,
    SubsetLikelihood,
)

#: Nodes of the prior's stage-1 rule (:mod:`~skmba.sensor_design.
#: _posterior_moments`), shared by every subset and replicate: Gauss-Legendre
#: for one parameter, scrambled Sobol points for several. Where the design is
#: large, the likelihood's small wiggles in theta (the emulator's) outrun 33
#: nodes: ``validation/studies/designer_quadrature.py`` measures it.
PRIOR_NODES = {"one": 33, "several": 64}


@dataclass(frozen=True)
class MonteCarloContext:
    """What every Monte Carlo task needs; shipped once per task by joblib.

    Complete when constructed: :meth:`build` makes it from step 1's pieces.
    """

    scaler: object
    design: object  # FieldDesignEmulator at the field design
    prior: object
    priors: object  # the plug-in ranges (a dict) or a Hyperprior (propagate)
    module2: object  # the calibrator's DiscrepancySettings
    fast: bool
    module2_max_iter: int | None
    integrated: object  # the emulator integrated over the prior
    kernel_d: object  # the discrepancy correlation the data are drawn with
    nodes: np.ndarray  # the prior's integration rule (user units)
    weights: np.ndarray
    pieces: object  # the design's emulator pieces at the nodes
    probe_prior: object  # the plug-in calibrator's probe (a Hyperprior)

    @classmethod
    def build(cls, settings, emulator, scaler, X_design, prior, priors, seeds, **kw):
        """Step 1 at the design: the prior-integrated emulator, the discrepancy
        kernel, the priors in the design's units (as the calibrator's, see
        :func:`~skmba.calibration._module2_prior_integral.prior_units`) and
        the prior's rule (``seeds``: of the integral and the rule); ``kw``:
        ``fast``, ``module2_max_iter`` and ``user_units`` (the plug-in's
        response ranges are already in module 2's units)."""
        Xs = scaler.x(X_design)
        design = FieldDesignEmulator(emulator, Xs)
        integrated = integrate_over_prior(
            emulator,
            scaler,
            prior,
            Xs,
            **settings.integration.kwargs(),
            random_state=seeds[0],
        )
        kernel_d = discrepancy_kernel(settings.discrepancy.kernel, Xs)
        if "roughness" not in kernel_d.get_params():
            raise TypeError(
                "The calibrator's discrepancy_kernel has no 'roughness' "
                "hyperparameter for discrepancy_prior to draw: use a kernel of "
                "skmba.kernels (e.g. Gauss())."
            )
        units = prior_units(emulator, scaler, prior, Xs)
        user_units = kw.pop("user_units", False)
        if isinstance(priors, Hyperprior):
            priors = priors.in_units(units)
        else:
            priors = _ranges_in_units(
                priors, units, kernel_d.roughness_power, user_units
            )
        n_nodes = PRIOR_NODES["one" if prior.dim == 1 else "several"]
        nodes, weights = prior.integration_nodes(n_nodes, random_state=seeds[1])
        pieces = design.pieces(scaler.theta(nodes))
        return cls(
            scaler,
            design,
            prior,
            priors,
            settings.discrepancy,
            integrated=integrated,
            kernel_d=kernel_d,
            nodes=nodes,
            weights=weights,
            pieces=pieces,
            probe_prior=Hyperprior(units=units),
            **kw,
        )

    @property
    def hyperprior(self):
        """The Hyperprior of the propagated module 2, else None (plug-in)."""
        return self.priors if isinstance(self.priors, Hyperprior) else None

    @property
    def emulator(self):
        return self.design.emulator

    @property
    def Xs(self):
        return self.design.X_e

    @property
    def n(self):
        return self.design.n

    @property
    def q(self):
        return self.design.q

    @property
    def H_d(self):
        return regression_basis(self.Xs, self.module2.regression)

    def std_theta(self, theta):
        return self.scaler.theta(theta)


def _ranges_in_units(ranges, units, power, user_units):
    """The plug-in's ranges (:func:`~skmba.sensor_design._inputs.
    check_design_priors`) in module 2's units: the roughness always (it is
    stated for the field design), the responses' unless ``user_units``."""
    out = dict(ranges)
    out["roughness"] = tuple(units.roughness(b, power) for b in ranges["roughness"])
    if not user_units:
        for key, power_y in (("variance", 2), ("noise", 2), ("mean", 1)):
            out[key] = tuple(units.response(b, power_y) for b in ranges[key])
    return out


class Replicate:
    """One Monte Carlo replicate: the draws, the data and module 2."""

    def __init__(self, theta, Y_e, seed):
        self.theta, self.Y_e, self.seed = theta, Y_e, seed
        # Module 2's draws (HyperposteriorDraws; the plug-in is one draw),
        # fitted with phase 1 when ``fast``, else per subset.
        self.draws = None
        self.truth = None
        self.n_unconverged = 0
        self.n_repaired = 0  # covariances of the second pass given a jitter


def mask(subset):
    """A subset as the integer whose bits are its responses."""
    return sum(1 << int(a) for a in subset)


def _root(A):
    """A square root ``B`` with ``B B^T = A`` of a covariance (eigh, clipped)."""
    values, vectors = np.linalg.eigh(0.5 * (A + A.T))
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def draw_replicate(ctx, sequence):
    """Step 2a (and 2b in phase 1): synthetic field data and module 2."""
    rng = np.random.default_rng(sequence)
    n, q = ctx.n, ctx.q
    theta = ctx.prior.rvs(1, random_state=rng)[0]
    Z = np.hstack([ctx.Xs, np.tile(ctx.std_theta(theta), (n, 1))])
    Y_m = ctx.emulator.gp.sample_y(Z, 1, random_state=int_seed(sequence)).reshape(n, q)
    if ctx.hyperprior is not None:
        delta, noise, truth = _draw_from_hyperprior(ctx, rng)
    else:
        delta, noise, truth = _draw_from_ranges(ctx, rng)
    eps = rng.standard_normal((n, q)) * np.sqrt(noise)
    rep = Replicate(theta, Y_m + delta + eps, int_seed(sequence))
    rep.truth = truth
    if ctx.fast and ctx.hyperprior is not None:
        rep.draws = _fit_module2_draws(ctx, rep, range(q))
    elif ctx.fast:
        rep.draws = HyperposteriorDraws.plug_in(_fit_module2(ctx, rep, range(q)))
    return rep


def _draw_from_ranges(ctx, rng):
    """Discrepancy and noise variance from the uniform priors (Table 6.2)."""
    p = ctx.priors
    n, q = ctx.n, ctx.q
    roughness = rng.uniform(*p["roughness"])
    R_d = clone(ctx.kernel_d).set_params(roughness=roughness)(ctx.Xs)
    sd = np.sqrt(rng.uniform(*p["variance"]))
    corr = p["correlation"]
    if isinstance(corr, str) and corr == "random":
        corr = np.atleast_2d(
            stats.wishart(df=q + 1, scale=np.eye(q)).rvs(random_state=rng)
        )
        d = np.sqrt(np.diag(corr))
        corr = corr / np.outer(d, d)
    sigma2_d = corr * np.outer(sd, sd)
    H_d = ctx.H_d
    beta = rng.uniform(*p["mean"], size=(H_d.shape[1], q))  # per response
    delta = H_d @ beta + _root(R_d) @ rng.standard_normal((n, q)) @ _root(sigma2_d).T
    noise = rng.uniform(*p["noise"])
    return delta, noise, (roughness, sigma2_d, noise)


def _draw_from_hyperprior(ctx, rng):
    """Discrepancy and noise variance from the calibrator's hyperprior.

    The discrepancy's mean has a flat prior, integrated out by the
    restricted likelihood of module 2 and by module 3, whose posteriors do
    not depend on it: it is drawn as zero.
    """
    n, q = ctx.n, ctx.q
    bounds = np.asarray(ctx.kernel_d.roughness_bounds, dtype=float)
    draw = ctx.hyperprior.rvs(
        ctx.Xs.shape[1],
        q,
        random_state=rng,
        roughness_bounds=(bounds[..., 0], bounds[..., 1]),
        power=ctx.kernel_d.roughness_power,
    )
    R_d = clone(ctx.kernel_d).set_params(roughness=draw["roughness"])(ctx.Xs)
    sigma2_d = draw["correlation"] * np.outer(draw["sd"], draw["sd"])
    delta = _root(R_d) @ rng.standard_normal((n, q)) @ _root(sigma2_d).T
    return delta, draw["noise"], (draw["roughness"], sigma2_d, draw["noise"])


def _fit_module2(ctx, rep, responses):
    """Discrepancy and noise of the responses by maximum likelihood."""
    idx = list(responses)
    integrated = ctx.integrated.restrict(idx)
    residual = rep.Y_e[:, idx] - integrated.mean
    seed = int_seed(np.random.SeedSequence([rep.seed, 1, mask(idx)]))
    roughness, sigma2_d, noise = rep.truth

    def start(fit):
        # The hyperparameters that generated the replicate: the natural
        # first start of the search for their maximum-likelihood estimate.
        kernel = clone(ctx.kernel_d).set_params(roughness=roughness)
        S = sigma2_d[np.ix_(idx, idx)]
        L = np.linalg.cholesky(
            S + 1e-8 * np.diag(np.diag(S)) + 1e-12 * np.eye(len(idx))
        )
        return fit.pack(kernel.theta, np.maximum(noise[idx], 1e-300), L)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        disc = fit_discrepancy(
            ctx.Xs,
            residual,
            integrated.cov,
            **ctx.module2.kwargs(),
            ranges={key: ctx.priors[key] for key in ("roughness", "variance")},
            random_state=seed,
            start=start,
            max_iter=ctx.module2_max_iter,
            responses=idx,
        )
    rep.n_unconverged += sum(issubclass(w.category, ConvergenceWarning) for w in caught)
    return disc


def _fit_module2_draws(ctx, rep, responses):
    """The module-2 hyperposterior draws of the responses (propagate).

    As the calibrator's default: the hyperposterior
    (:func:`~skmba.calibration._module2_posterior.fit_hyperposterior`, the hyperprior
    restricted to ``responses``) with the emulator integrated over the prior
    of theta; then, a second pass, again with the emulator integrated over
    the first pass's posterior of theta from these responses.
    """
    idx = list(responses)
    prior = ctx.hyperprior.restrict(idx)
    first, second, moments = np.random.SeedSequence([rep.seed, 1, mask(idx)]).spawn(3)

    def hyperposterior(integrated, seed):
        return fit_hyperposterior(
            ctx.Xs,
            rep.Y_e[:, idx] - integrated.mean,
            integrated.cov,
            prior=prior,
            kernel=ctx.module2.kernel,
            regression=ctx.module2.regression,
            noise=ctx.module2.noise,
            n_restarts=ctx.module2.n_restarts,
            random_state=seed,
            # The designer predicts no new observation: the noise
            # variances' posterior mean (512 evaluations) would go unused.
            noise_mean=False,
        )

    def posterior(draws):
        likes, log_w = likelihoods(ctx, rep, idx, draws)
        *_, (nodes, weights) = posterior_moments(
            lambda thetas: mixed(
                likes, log_w, ctx.design.pieces(ctx.std_theta(thetas))
            ),
            ctx.prior,
            ctx.nodes,
            ctx.weights,
            mixed(likes, log_w, ctx.pieces),
            seed=int_seed(moments),
            return_rule=True,
        )
        return nodes, weights

    def over_posterior(rule):
        nodes, weights = rule
        keep = weights > 0
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            integrated = integrate_over_rule(
                ctx.emulator, ctx.Xs, ctx.std_theta(nodes[keep]), weights[keep]
            )
        rep.n_repaired += len(caught)  # reported once by the designer (phase 1)
        return integrated

    draws, _ = propagated_module2(
        ctx.integrated,
        first_pass=lambda integrated: hyperposterior(integrated.restrict(idx), first),
        posterior=posterior,
        integrate=over_posterior,
        second_pass=lambda integrated: hyperposterior(integrated.restrict(idx), second),
    )
    return draws


def warn_replicate_problems(replicates):
    """Warn about the replicates' module-2 fits that did not fully converge
    and the second-pass covariances that needed a jitter (their counts)."""
    unconverged = sum(rep.n_unconverged for rep in replicates)
    if unconverged:
        warn(
            f"{unconverged} module-2 likelihood maximisations of the "
            f"{len(replicates)} replicates did not fully converge; their "
            "estimates are used as they are. More restarts (calibrator "
            "n_restarts_optimizer) make them more robust.",
            ConvergenceWarning,
        )
    repaired = sum(rep.n_repaired for rep in replicates)
    if repaired:
        warn(
            f"{repaired} posterior-integrated emulator covariances of the "
            "second module-2 pass (discrepancy_uncertainty='propagate') "
            "were not positive definite and got a jitter, usually a "
            "round-off effect of a narrow posterior of theta.",
            UserWarning,
        )


def _embedded(sigma2_d, noise, subset, q):
    """A subset's discrepancy covariance and noise in ``q x q`` arrays."""
    full = np.zeros((q, q))
    full[np.ix_(subset, subset)] = sigma2_d
    noise_full = np.ones(q)
    noise_full[list(subset)] = noise
    return full, noise_full


def subset_draws(ctx, rep, subset):
    """Module 2's draws for a subset: the replicate's (``fast``: fitted on
    all responses in phase 1) or fitted on the subset's responses."""
    if ctx.fast:
        return rep.draws
    if ctx.hyperprior is not None:
        return _fit_module2_draws(ctx, rep, subset)
    return HyperposteriorDraws.plug_in(_fit_module2(ctx, rep, subset))


def likelihoods(ctx, rep, idx, draws):
    """One :class:`SubsetLikelihood` per draw of module 2, and the log weights.

    A draw fitted on the subset alone (``q_S x q_S``) is embedded in the
    ``q x q`` arrays the likelihood restricts.
    """
    likes = []
    for c in draws.components:
        sigma2_d, noise = c.sigma2, c.noise
        if len(sigma2_d) != ctx.q:
            sigma2_d, noise = _embedded(sigma2_d, noise, idx, ctx.q)
        likes.append(
            SubsetLikelihood(
                ctx.design, idx, rep.Y_e, c.kernel_(ctx.Xs), ctx.H_d, sigma2_d, noise
            )
        )
    return likes, draws.log_weights


def mixed(likes, log_weights, pieces):
    """``log sum_k w_k L_k`` at the emulator ``pieces`` of some thetas."""
    if len(likes) == 1:
        return likes[0].log_likelihood(pieces)
    values = np.array([like.log_likelihood(pieces) for like in likes])
    with np.errstate(invalid="ignore"):  # -inf + finite weights
        return special.logsumexp(values + log_weights[:, None], axis=0)
