"""Are chains stopped at a target ESS worth what their ESS says?

``ModularBayesCalibrator(target_ess=2000)`` ends its chains at the first
checkpoint where every parameter's bulk and tail effective sample size reach
the target. Stopping on an estimate can flatter it (the first checkpoint
where a noisy ESS crosses the line). This study checks the Monte Carlo
errors the stopped draws imply against the error they actually have.

The thesis' 4.7.3 set-up (two parameters, E and I; ``make_cantilever``
seed 0) is fitted with the plug-in module 2 and no optimiser restarts, so
that modules 1 and 2 give the same posterior for every ``random_state`` and
only the chains differ. A reference run (4 chains of ``--reference-draws``
draws, fixed length) gives each quantity's value; then, per seed, a fit
with ``target_ess`` gives the posterior mean, sd, 2.5 % and 97.5 % points of
each parameter and their Monte Carlo standard errors (ArviZ's ``mcse``:
``mean``, ``sd`` and ``quantile``, from the draws' own ESS). Printed: the
draws kept per chain, and per quantity ``rms z``, ``z = (estimate -
reference) / sqrt(mcse^2 + mcse_ref^2)``, with its 95 % interval
(chi-squared with one degree of freedom per seed): near 1 when the errors
are honest, above when the stopped chains claim more than they hold.

Usage::

    python -m validation.studies.ess_target --n-seeds 40 --n-jobs 2

The result is quoted in ``docs/internals.rst`` (section skmba.mcmc._stopping).
"""

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever
from validation.statistics import rms_band

QUANTITIES = ("mean", "sd", "2.5%", "97.5%")


def _fit(seed, target_ess, n_samples):
    data = make_cantilever(
        n_simulations=170, n_observations=70, parameters=("E", "I"), random_state=0
    )
    cal = ModularBayesCalibrator(
        prior=data.prior,
        discrepancy_uncertainty="plug-in",
        n_restarts_optimizer=0,
        n_samples=n_samples,
        target_ess=target_ess,
        random_state=seed,
    )
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        started = time.perf_counter()
        cal.fit(
            data.X_obs,
            data.y_obs,
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
        elapsed = time.perf_counter() - started
    # Module 2's estimate: each response's noise and discrepancy variance.
    module2 = np.concatenate([cal.noise_, np.diag(cal.discrepancy_sigma2_)])
    return (
        chain_estimates(cal.theta_chains_),
        cal.theta_chains_.shape[1],
        elapsed,
        module2,
    )


def chain_estimates(chains):
    """(values, mcses): arrays of shape (4, r), rows :data:`QUANTITIES`."""
    import arviz

    values, errors = [], []
    for j in range(chains.shape[-1]):
        x = chains[:, :, j]
        values.append([x.mean(), x.std(ddof=1), *np.quantile(x, [0.025, 0.975])])
        errors.append(
            [
                float(arviz.mcse(x, method="mean")),
                float(arviz.mcse(x, method="sd")),
                float(arviz.mcse(x, method="quantile", prob=0.025)),
                float(arviz.mcse(x, method="quantile", prob=0.975)),
            ]
        )
    return np.array(values).T, np.array(errors).T


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=40)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--target-ess", type=float, default=2000)
    parser.add_argument("--reference-draws", type=int, default=50_000)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    warnings.simplefilter("ignore", FutureWarning)  # ArviZ 0.x announces 1.0
    jobs = [delayed(_fit)(10**6, None, args.reference_draws)]
    jobs += [delayed(_fit)(s, args.target_ess, 5000) for s in range(args.n_seeds)]
    out = Parallel(n_jobs=args.n_jobs)(jobs)
    (ref, ref_se), _, ref_time, ref_module2 = out[0]
    runs = out[1:]
    draws = np.array([r[1] for r in runs])
    times = np.array([r[2] for r in runs])
    # Modules 1-2 must not depend on the seed, or the spread is not the chains'.
    moved = max(np.max(np.abs(r[3] / ref_module2 - 1)) for r in runs)
    print(
        f"4.7.3 plug-in, target_ess={args.target_ess:g}, {args.n_seeds} seeds, "
        f"{time.perf_counter() - started:.0f} s; reference: 4 chains of "
        f"{args.reference_draws} draws ({ref_time:.0f} s)"
    )
    print(
        f"draws kept per chain: {np.min(draws)}-{np.max(draws)} (median "
        f"{np.median(draws):.0f}); fit {np.min(times):.1f}-{np.max(times):.1f} s "
        "(one BLAS thread, chains in turn); module 2's noise and discrepancy "
        f"variances over the seeds within {moved:.1e} (relative) of the "
        "reference's"
    )
    z = np.array(
        [(v - ref) / np.sqrt(se**2 + ref_se**2) for (v, se), *_ in runs]
    )  # (n_seeds, 4, r)
    n = len(runs)
    # Honest errors: n rms z^2 is chi-squared with n degrees of freedom.
    band = rms_band(n)
    print(
        f"parameter | quantity | rms z (95 % range if honest: [{band[0]:.2f}, "
        f"{band[1]:.2f}]) | mean mcse / posterior sd"
    )
    for j, name in enumerate(["E", "I"]):
        for i, quantity in enumerate(QUANTITIES):
            rms = np.sqrt(np.mean(z[:, i, j] ** 2))
            se = np.mean([r[0][1][i, j] for r in runs]) / ref[1, j]
            print(f"{name} | {quantity} | {rms:.2f} | {se:.3f}")


if __name__ == "__main__":
    main()
