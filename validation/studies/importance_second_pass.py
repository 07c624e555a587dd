"""Could importance sampling replace the second pass's chains (r >= 2)?

With several parameters and the propagated module 2, the calibrator's
second pass samples theta's posterior (a mixture over 16 module-2 draws) by
4 Metropolis-Hastings chains of 1,000 burn-in steps and draws until the
ESS target (2,000), each step one evaluation of the mixture. The chains
start from the first pass's draws. This study asks what the same
evaluations would give as importance sampling from those draws, on the
very log posterior the chains sampled (captured from the fit):

1. ``--n1`` draws from the Student-t fitted to the first pass's draws
   (:class:`~skmba.mcmc._proposals.TProposal`, as the chains' first
   independence proposal);
2. ``--n2`` draws from the Student-t fitted to the weighted first stage;
3. all weighted by the posterior over the two stages' mixture density
   (the balance heuristic), with Kish's ESS of the weights and the Pareto
   shape k of their tail (PSIS, ``arviz.psislw``; above 0.7 the estimate
   is unreliable, Vehtari et al. 2024).

Per fit it prints the chains' steps (burn-in included) and bulk ESS, the
importance evaluations, ESS (and the first stage's) and k, and against the
chains: the difference of the means in posterior sds, in units of the two
estimates' combined Monte Carlo error (``z``), and the ratio of the sds.
A rule that would use importance sampling only when k <= 0.7 and the ESS
is at least a quarter of the evaluations is applied and summarised per
case: the share it accepts, the ESS per evaluation of both samplers, the
rms of ``z`` and the range of the sd ratios over the accepted fits.

Cases: ``473`` (the thesis' 4.7.3 cantilever with E and I, 170
simulations, 70 observations, data seed = seed) and the suite's two-parameter
cases (``a2``, ``b2``, ``sbc_a2``). Each fit uses the calibrator's defaults,
``random_state=seed``, one BLAS thread; fits run in parallel (``--n-jobs``).

Usage::

    python -m validation.studies.importance_second_pass --cases a2,b2,sbc_a2 \\
        --n-seeds 60 --n-jobs 2
    python -m validation.studies.importance_second_pass --cases 473 --n-seeds 6

A measurement for issue 34 (and 30), not a feature: nothing in the package
samples this way.
"""

import argparse
import time
import warnings

import arviz as az
import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

import skmba.calibration._module3_fit as module3_fit
from skmba import ModularBayesCalibrator
from skmba.mcmc._proposals import TProposal
from validation.suite import registry

#: The rule's thresholds: Pareto k and the ESS as a share of the evaluations.
MAX_K = 0.7
MIN_EFFICIENCY = 0.25


def _data(case, seed):
    """The prior, field data and simulations of a case's seed."""
    if case == "473":
        from skmba.datasets import make_cantilever

        d = make_cantilever(
            n_simulations=170, n_observations=70, parameters=("E", "I"),
            random_state=seed,
        )  # fmt: skip
        return d.prior, d.X_obs, d.y_obs, d.X_sim, d.theta_sim, d.y_sim
    c = registry()[case].build(seed)
    return c.prior, c.X, c.y, c.X_sim, c.theta_sim, c.y_sim


def _fit_capturing(case, seed):
    """The default fit, with the second pass's log posterior and the first
    pass's draws (the chains' ``earlier``) captured on the way."""
    captured, original = {}, module3_fit.posterior_by_mcmc

    def spy(log_posterior, **kwargs):
        if kwargs.get("check", True) and kwargs.get("earlier") is not None:
            captured["log_posterior"] = log_posterior
            captured["earlier"] = np.asarray(kwargs["earlier"], dtype=float)
        return original(log_posterior, **kwargs)

    prior, X, y, X_sim, theta_sim, y_sim = _data(case, seed)
    cal = ModularBayesCalibrator(prior=prior, random_state=seed, n_jobs=1)
    module3_fit.posterior_by_mcmc = spy
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            started = time.perf_counter()
            cal.fit(X, y, X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)
            seconds = time.perf_counter() - started
    finally:
        module3_fit.posterior_by_mcmc = original
    warned = any(
        "R-hat" in str(w.message) or "effective sample size" in str(w.message)
        for w in caught
    )
    return cal, captured, seconds, warned


def _weighted_moments(U, log_w):
    """Normalised weights, mean and covariance of ``U`` under ``log_w``."""
    w = np.exp(log_w - np.max(log_w))
    w /= w.sum()
    mean = w @ U
    dev = U - mean
    return w, mean, (dev * w[:, None]).T @ dev


def importance(log_posterior, earlier, n1, n2, seed):
    """Two-stage importance sampling of ``log_posterior`` from ``earlier``
    (user units); returns the ESS, the first stage's ESS, Pareto k, the
    evaluations and theta's weighted mean and sd (user units)."""
    rng = np.random.default_rng(seed)
    U0 = log_posterior.to_u(earlier)
    q1 = TProposal.of(U0.mean(axis=0), np.atleast_2d(np.cov(U0, rowvar=False)))
    A = q1.draw(rng, n1)
    log_pa = log_posterior.log_density_u_batch(A)
    w1, mean, cov = _weighted_moments(A, log_pa - q1.logpdf(A))
    try:
        q2 = TProposal.of(mean, cov)
    except np.linalg.LinAlgError:  # the first stage's weight sits on one draw
        q2 = q1
    B = q2.draw(rng, n2)
    U = np.vstack([A, B])
    log_p = np.concatenate([log_pa, log_posterior.log_density_u_batch(B)])
    log_q = np.logaddexp(np.log(n1) + q1.logpdf(U), np.log(n2) + q2.logpdf(U)) - np.log(
        n1 + n2
    )
    log_w = np.where(np.isfinite(log_p), log_p - log_q, -np.inf)
    _, k = az.psislw(log_w.copy())
    w, _, _ = _weighted_moments(U, log_w)
    theta = log_posterior.from_u(U)
    t_mean = w @ theta
    return {
        "ess": float(1.0 / np.sum(w**2)),
        "ess1": float(1.0 / np.sum(w1**2)),
        "k": float(k),
        "evaluations": len(U),
        "mean": t_mean,
        "sd": np.sqrt(w @ (theta - t_mean) ** 2),
    }


def one(case, seed, n1, n2):
    """One fit and its importance-sampling counterpart, as a dict."""
    with threadpoolctl.threadpool_limits(1):
        cal, captured, fit_seconds, warned = _fit_capturing(case, seed)
        started = time.perf_counter()
        imp = importance(captured["log_posterior"], captured["earlier"], n1, n2, seed)
        is_seconds = time.perf_counter() - started
    chains = cal.theta_chains_
    sd = np.sqrt(np.diag(cal.theta_cov_))
    error = sd * np.sqrt(1.0 / cal.ess_ + 1.0 / imp["ess"])
    return {
        "case": case,
        "seed": seed,
        "warned": warned,
        "steps": chains.shape[0] * (chains.shape[1] + cal.burn_in),
        "mcmc_ess": float(np.min(cal.ess_)),
        "fit_seconds": fit_seconds,
        "is_seconds": is_seconds,
        "diff": (imp["mean"] - cal.theta_mean_) / sd,
        "z": (imp["mean"] - cal.theta_mean_) / error,
        "sd_ratio": imp["sd"] / sd,
        "accepted": imp["k"] <= MAX_K
        and imp["ess"] >= MIN_EFFICIENCY * imp["evaluations"],
        **{k: imp[k] for k in ("ess", "ess1", "k", "evaluations")},
    }


def _line(r):
    return (
        f"{r['case']:7s} {r['seed']:4d}  chains {r['steps']:6d} steps ESS "
        f"{r['mcmc_ess']:6.0f}{' (warned)' if r['warned'] else '':9s}  IS "
        f"{r['evaluations']} ESS {r['ess']:6.0f} (1st {r['ess1']:4.0f}) k "
        f"{r['k']:5.2f} {'ok ' if r['accepted'] else 'NO '} mean diff "
        f"{np.array2string(r['diff'], precision=3)} z "
        f"{np.array2string(r['z'], precision=2)} sd ratio "
        f"{np.array2string(r['sd_ratio'], precision=3)}"
    )


def summary(rows):
    """Per case: accepted share, ESS per evaluation, rms z, sd ratios."""
    lines = []
    for case in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == case]
        ok = [r for r in rs if r["accepted"]]
        chain = np.median([r["mcmc_ess"] / r["steps"] for r in rs])
        line = (
            f"{case}: {len(ok)}/{len(rs)} accepted; ESS per evaluation, "
            f"median: chains {chain:.3f}"
        )
        if ok:
            z = np.concatenate([r["z"] for r in ok])
            ratio = np.concatenate([r["sd_ratio"] for r in ok])
            eff = np.median([r["ess"] / r["evaluations"] for r in ok])
            line += (
                f", importance {eff:.3f} (accepted); over the accepted: rms z "
                f"{np.sqrt(np.mean(z**2)):.2f}, sd ratio {ratio.min():.3f}-"
                f"{ratio.max():.3f}"
            )
        bad = [r for r in rs if not r["accepted"]]
        if bad:
            ratio = np.concatenate([r["sd_ratio"] for r in bad])
            warned = sum(r["warned"] for r in bad)
            line += (
                f"; refused: sd ratio {ratio.min():.3f}-{ratio.max():.3f}, "
                f"{warned} of them with chains that warned"
            )
        lines.append(line)
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="a2,b2,sbc_a2")
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n1", type=int, default=500)
    parser.add_argument("--n2", type=int, default=1500)
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args(argv)
    tasks = [
        (case, seed) for seed in range(args.n_seeds) for case in args.cases.split(",")
    ]
    rows = Parallel(n_jobs=args.n_jobs, batch_size=1)(
        delayed(one)(case, seed, args.n1, args.n2) for case, seed in tasks
    )
    rows.sort(key=lambda r: (args.cases.split(",").index(r["case"]), r["seed"]))
    for r in rows:
        print(_line(r))
    for line in summary(rows):
        print(line)
    return rows


if __name__ == "__main__":
    main()
