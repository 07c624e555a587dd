"""The Monte Carlo error of module 3's mixture over module 2's fixed draws.

With several calibration parameters (and ``discrepancy_tol=None``) the
calibrator mixes 16 draws of the discrepancy and noise hyperparameters,
estimates the error of that mixture from the draws themselves
(``theta_mcse_``, :mod:`skmba.calibration._module3_mixture_error`) and warns
above its tolerance. Per case and data seed, the default calibrator refitted
with ``random_state`` 0..R-1 on the same data gives the spread the draws
actually cause (with the chains' own error in it); this prints, per
parameter and summary (mean, sd, 2.5 % and 97.5 % ends), pooled over the
seeds:

- ``spread``: the median over the seeds of the refits' sd of the summary,
  in posterior sds;
- ``reported``: the median reported error, in posterior sds;
- ``rms z``: of each refit's deviation from its seed's refits' mean over
  its reported error, scaled by ``sqrt(R / (R - 1))`` (1 for honest errors;
  more where they read low);
- ``warned``: the share of fits that warned, and of the seeds whose refits
  spread by more than the tolerance (0.1 posterior sds, 0.15 for the ends)
  in some summary.

Besides the suite's cases, ``473`` is section 4.7.3's cantilever (E and
I, 170 simulations, 70 observations) and ``bridge`` January-May of the
monitoring data set with 2 degC bins. ``--fixed`` sets
``discrepancy_tol=None``, for the one-parameter cases (whose default
integrates the hyperparameters to a tolerance).

Usage::

    python -m validation.studies.fixed_draws_error --cases a2,b2,sbc_a2 \\
        --n-seeds 4 --refits 5 --n-jobs 2
    python -m validation.studies.fixed_draws_error --cases a1,c1,freq \\
        --n-seeds 4 --refits 5 --fixed --n-jobs 2
    python -m validation.studies.fixed_draws_error --cases 473,bridge \\
        --n-seeds 1 --refits 6 --n-jobs 2

Quoted in ``docs/validity.rst`` ("Module 2's 16 draws").
"""

from __future__ import annotations

import argparse
import time
import warnings
from types import SimpleNamespace

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from skmba.calibration._module2_converged import tolerances
from skmba.calibration._module3_mixture_error import MIXTURE_TOL
from skmba.calibration._summary import parameter_names
from skmba.datasets import make_bridge_monitoring, make_cantilever
from skmba.priors._theta import check_prior
from validation.suite import registry

SUMMARIES = ("mean", "sd", "2.5%", "97.5%")
#: Days of the monitoring data set in the ``"bridge"`` case (January-May).
BRIDGE_DAYS = 151
#: The start of the warning of a mixture over fixed draws above its tolerance.
WARNING = "Theta's posterior mixes"


def build_case(name, seed):
    """A case of the suite, or ``"473"`` (section 4.7.3's cantilever: E and
    I, 170 simulations, 70 observations) or ``"bridge"`` (January-May of
    the monitoring data set, 2 degC bins): the case and its estimator's
    extra parameters."""
    if name == "473":
        data = make_cantilever(
            n_simulations=170,
            n_observations=70,
            parameters=("E", "I"),
            random_state=seed,
        )
        X, y = data.X_obs, data.y_obs
    elif name == "bridge":
        data = make_bridge_monitoring(random_state=seed)
        rows = slice(0, 24 * BRIDGE_DAYS)
        X = data.frame[["temperature"]].iloc[rows]
        y = data.frame[list(data.response_names)].iloc[rows]
    else:
        return registry()[name].build(seed), {}
    case = SimpleNamespace(
        prior=data.prior,
        X=X,
        y=y,
        X_sim=data.X_sim,
        theta_sim=data.theta_sim,
        y_sim=data.y_sim,
        parameter_names=parameter_names(check_prior(data.prior)),
    )
    return case, {"bin_width": 2.0} if name == "bridge" else {}


def fit_refit(name, seed, random_state, tol="auto"):
    """One fit with ``discrepancy_tol=tol`` (the default: fixed draws with
    several parameters): summaries (4, r), ``theta_mcse_``, warned, seconds."""
    case, extra = build_case(name, seed)
    started = time.perf_counter()
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        cal = ModularBayesCalibrator(
            prior=case.prior,
            random_state=random_state,
            n_jobs=1,
            discrepancy_tol=tol,
            **extra,
        ).fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    samples = cal.theta_samples_
    values = np.vstack(
        [
            cal.theta_mean_,
            np.sqrt(np.diag(cal.theta_cov_)),
            np.quantile(samples, [0.025, 0.975], axis=0),
        ]
    )
    return {
        "values": values,
        "mcse": np.asarray(cal.theta_mcse_, float),
        "warned": any(str(m.message).startswith(WARNING) for m in w),
        "seconds": time.perf_counter() - started,
    }


def case_rows(name, fits_by_seed):
    """The printed rows of one case: per parameter, each summary's spread,
    reported error and rms z, and the warning shares."""
    limit = tolerances(MIXTURE_TOL)
    first = next(iter(fits_by_seed.values()))
    r = first[0]["values"].shape[1]
    names = (
        registry()[name].parameter_names
        if name in registry()
        else build_case(name, 0)[0].parameter_names
    )
    lines = []
    for j in range(r):
        spread, reported, z, spread_over = [], [], [], []
        for fits in fits_by_seed.values():
            values = np.array([f["values"][:, j] for f in fits])
            mcse = np.array([f["mcse"][:, j] for f in fits])
            n, sd = len(fits), values[:, 1].mean()
            spread.append(values.std(axis=0, ddof=1) / sd)
            reported.append(np.median(mcse, axis=0) / sd)
            with np.errstate(divide="ignore", invalid="ignore"):
                z.append((values - values.mean(axis=0)) / mcse * np.sqrt(n / (n - 1)))
            spread_over.append(bool(np.any(spread[-1] > limit)))
        z = np.concatenate(z)
        finite = np.isfinite(z)
        rms = np.sqrt(np.nansum(np.where(finite, z, 0.0) ** 2, 0) / finite.sum(0))
        lines.append(
            f"{name:7s} {names[j]:4s} spread {_vector(np.median(spread, 0))}  "
            f"reported {_vector(np.median(reported, 0))}  rms z {_vector(rms)}  "
            f"seeds spread over the tolerance {sum(spread_over)}/{len(spread_over)}"
        )
    fits = [f for fits in fits_by_seed.values() for f in fits]
    seconds = [f["seconds"] for f in fits]
    lines.append(
        f"{name:7s} warned {sum(f['warned'] for f in fits)}/{len(fits)} fits; "
        f"{min(seconds):.1f}-{max(seconds):.1f} s per fit"
    )
    return lines


def _vector(x):
    return "[" + " ".join(f"{v:.3f}" for v in x) + "]"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="a2,b2,sbc_a2")
    parser.add_argument("--n-seeds", type=int, default=4)
    parser.add_argument("--refits", type=int, default=5)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument(
        "--fixed",
        action="store_true",
        help="discrepancy_tol=None: fixed draws also for one parameter",
    )
    args = parser.parse_args(argv)
    tasks = [
        (name, seed, k)
        for name in args.cases.split(",")
        for seed in range(args.n_seeds)
        for k in range(args.refits)
    ]
    tol = None if args.fixed else "auto"
    fits = Parallel(n_jobs=args.n_jobs)(delayed(fit_refit)(*t, tol) for t in tasks)
    print(f"columns: {', '.join(SUMMARIES)}; tolerance {MIXTURE_TOL:g} (ends 0.15)")
    for name in args.cases.split(","):
        by_seed = {}
        for (n, seed, _), fit in zip(tasks, fits, strict=True):
            if n == name:
                by_seed.setdefault(seed, []).append(fit)
        print("\n".join(case_rows(name, by_seed)))


if __name__ == "__main__":
    main()
