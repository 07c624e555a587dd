"""Does the sensor designer predict the calibrator? (issue 13)

The fast preposterior analysis of :class:`~skmba.PreposteriorDesigner`
predicts, for each subset of the responses, the posterior variance of theta
that the calibration will have, averaged over data drawn from its priors.
This study checks that prediction against the calibrator itself, under the
same module-2 treatment, the default (``discrepancy_uncertainty=
"propagate"``):

1. the cantilever of section 4.7 with three responses (tip displacement,
   energy, tip rotation) and 54 simulations;
2. per seed, E* from its prior and field data drawn from the priors the
   designer assumes, the calibrator's default hyperprior of the
   discrepancy and the noise (one discrepancy function and the noise drawn
   as in the SBC cases of :mod:`validation.sbc_cases`), the model being the
   fixed-support beam itself;
3. for each of the 7 subsets, ``ModularBayesCalibrator()`` on those
   responses: its posterior variance of E, whether its 95 % interval
   covers E*, and z;
4. the designer with the same treatment and ``--n-mc`` replicates, whose
   Latin hypercube of 25 forces is the field design of step 2: its
   expected posterior variance per subset and the Monte Carlo standard
   error of it (the jackknife of ``scores_mcse_``).

It prints per subset the calibrator's coverage (Wilson interval), rms z,
mean posterior variance with its standard error over the seeds, the
designer's expected variance with its standard error, and their difference
in units of the combined standard error; then the distributions of the
per-replicate posterior sd (median, 90 % quantile) of both, compared by a
two-sample Kolmogorov-Smirnov test (the variances are heavy-tailed: a
replicate with a large noise drawn from its log-uniform prior learns almost
nothing, so the mean variance converges slowly).

Usage::

    python -m validation.studies.designer_vs_calibrator --n-seeds 30 --n-jobs 2

The results (100 seeds) are in ``docs/validity.rst`` ("The designer against
the calibrator").
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import stats

from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.datasets import make_cantilever
from validation.cases import CANTILEVER_X_BOUNDS
from validation.sbc_cases import draw_field_data
from validation.statistics import rms, wilson_interval

RESPONSES = ("tip_displacement", "energy", "tip_rotation")
LETTERS = "ABC"
N_SIM, N_OBS = 54, 25
LEVEL = 0.95


def problem():
    """The simulations, the field design and the prior (fixed over seeds)."""
    return make_cantilever(
        N_SIM,
        N_OBS,
        responses=RESPONSES,
        spring_stiffness=np.inf,
        snr_db=None,
        random_state=0,
    )


def subsets():
    q = len(RESPONSES)
    return [s for k in range(1, q + 1) for s in itertools.combinations(range(q), k)]


def fit_subset(problem, X_field, y, cols, seed):
    """``ModularBayesCalibrator()`` (defaults, one job) on the responses
    ``cols`` of the field data ``y`` and of ``problem``'s simulations."""
    return ModularBayesCalibrator(prior=problem.prior, random_state=seed, n_jobs=1).fit(
        X_field,
        y[:, cols],
        X_sim=problem.X_sim,
        theta_sim=problem.theta_sim,
        y_sim=problem.y_sim[:, cols],
    )


def one_seed(seed, X_field):
    """E*, then per subset: posterior variance, covered, z (never raises)."""
    data = problem()
    lo, hi = data.prior[0].support()
    rng = np.random.default_rng([int(seed), 2])
    theta = np.array([lo + (hi - lo) * rng.uniform()])
    _, y, _ = draw_field_data(
        seed, data.simulator, theta, X_field, data.prior, CANTILEVER_X_BOUNDS
    )
    out = []
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for subset in subsets():
            cols = list(subset)
            try:
                cal = fit_subset(data, X_field, y, cols, seed)
            except Exception as exc:  # a failed fit is a result
                out.append({"subset": subset, "error": f"{type(exc).__name__}: {exc}"})
                continue
            q_lo, q_hi = np.quantile(
                cal.theta_samples_[:, 0], [(1 - LEVEL) / 2, (1 + LEVEL) / 2]
            )
            var = float(cal.theta_cov_[0, 0])
            out.append(
                {
                    "subset": subset,
                    "var": var,
                    "covered": bool(q_lo <= theta[0] <= q_hi),
                    "z": float((cal.theta_mean_[0] - theta[0]) / np.sqrt(var)),
                    "error": "",
                }
            )
    return out


def run_designer(n_mc, n_jobs):
    data = problem()
    X = np.hstack([data.X_sim, data.theta_sim])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer = PreposteriorDesigner(
            data.prior,
            discrepancy_uncertainty="propagate",  # the calibrator's default
            n_design=N_OBS,
            n_mc=n_mc,
            n_jobs=n_jobs,
            random_state=0,
        ).fit(X, data.y_sim)
    prior_var = float(data.prior[0].var())
    expected = designer.preposterior_cov_[:, 0, 0]
    # One parameter: each score is a variance ratio, the running means of
    # convergence_ give back every replicate's posterior variance.
    se = designer.scores_mcse_ * prior_var
    counts = np.arange(1, n_mc + 1)[:, None]
    per_replicate = np.diff(designer.convergence_ * counts, axis=0, prepend=0.0)
    per_replicate = per_replicate * prior_var
    out = {
        s: (expected[j], se[j], per_replicate[:, j])
        for j, s in enumerate(designer.subsets_)
    }
    return out, designer.X_design_


def table(records, designed, n_seeds):
    by_subset = {s: [] for s in subsets()}
    for rec in records:
        by_subset[rec["subset"]].append(rec)
    lines = [
        f"{'subset':<7}{'n':>4}  {'covered':<8}{'Wilson 95 %':<15}{'rms z':>6}  "
        f"{'calibrator var [GPa^2]':<24}{'designer var [GPa^2]':<24}{'diff/se':>8}",
        "-" * 98,
    ]
    worst = 0.0
    for subset, recs in by_subset.items():
        ok = [r for r in recs if not r["error"]]
        n = len(ok)
        k = sum(r["covered"] for r in ok)
        low, high = wilson_interval(k, n)
        var = np.array([r["var"] for r in ok]) / 1e6  # MPa^2 -> GPa^2
        mean, se = var.mean(), var.std(ddof=1) / np.sqrt(n)
        d_mean, d_se = (v / 1e6 for v in designed[subset][:2])
        diff = (d_mean - mean) / np.hypot(se, d_se)
        worst = max(worst, abs(diff))
        name = "".join(LETTERS[i] for i in subset)
        failed = f" ({len(recs) - n} failed)" if len(recs) > n else ""
        lines.append(
            f"{name:<7}{n:>4}  {f'{k}/{n}':<8}{f'[{low:.2f}, {high:.2f}]':<15}"
            f"{rms([r['z'] for r in ok]):>6.2f}  "
            f"{f'{mean:.3g} ± {se:.2g}':<24}{f'{d_mean:.3g} ± {d_se:.2g}':<24}"
            f"{diff:>+8.2f}{failed}"
        )
    lines += [
        "",
        "posterior sd of E per replicate [GPa]: median and 90 % quantile, and "
        "the two-sample KS p-value",
        f"{'subset':<7}{'calibrator':<16}{'designer':<16}{'KS p':>6}",
    ]
    for subset, recs in by_subset.items():
        sd_cal = np.sqrt([r["var"] for r in recs if not r["error"]]) / 1e3
        sd_des = np.sqrt(np.clip(designed[subset][2], 0.0, None)) / 1e3
        ks = stats.ks_2samp(sd_cal, sd_des).pvalue
        name = "".join(LETTERS[i] for i in subset)
        cal_q = np.quantile(sd_cal, [0.5, 0.9])
        des_q = np.quantile(sd_des, [0.5, 0.9])
        lines.append(
            f"{name:<7}{f'{cal_q[0]:.2f}, {cal_q[1]:.2f}':<16}"
            f"{f'{des_q[0]:.2f}, {des_q[1]:.2f}':<16}{ks:>6.2f}"
        )
    lines.append("")
    lines.append(
        f"largest |designer - calibrator| / combined se: {worst:.2f} "
        f"({n_seeds} seeds; A tip displacement, B energy, C tip rotation)"
    )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.designer_vs_calibrator",
        description=__doc__.splitlines()[0],
    )
    parser.add_argument("--n-seeds", type=int, default=30)
    parser.add_argument("--n-mc", type=int, default=100)
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    designed, X_field = run_designer(args.n_mc, args.n_jobs)
    designer_seconds = time.perf_counter() - started
    results = Parallel(n_jobs=args.n_jobs, batch_size=1)(
        delayed(one_seed)(seed, X_field) for seed in range(args.n_seeds)
    )
    records = [rec for result in results for rec in result]
    print(table(records, designed, args.n_seeds))
    print(
        f"designer {designer_seconds:.0f} s (n_mc={args.n_mc}); total "
        f"{time.perf_counter() - started:.0f} s, n_jobs={args.n_jobs}"
    )


if __name__ == "__main__":
    main()
