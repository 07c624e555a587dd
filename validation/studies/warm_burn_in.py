"""Does the second pass's chains need the burn-in of 1000 steps?

With the propagated module 2 the chains of the second pass start from the
first pass's draws, whose moments fit the independence proposal before the
first step (an update's chains likewise start from the last posterior's
draws), and after the burn-in they propose from a Student-t fitted to all
the chains' burn-ins together. The calibrator burns them in
``WARM_BURN_IN_SHARE`` of ``burn_in`` (250 of 1000). This study measures
whether they sample the same posterior as after 1000 steps and as long
chains.

Per case and seed, the suite's data (``validation.suite.registry()``; or
``473``, the thesis' section 4.7.3 set-up on ``make_cantilever``'s seed)
are fitted with the calibrator's defaults and the same ``random_state``,
the second pass's chains after ``--short`` burn-in steps (the default's
250: the calibrator as it runs, which runs the chains again after 1000
when their R-hat would warn) or after 1000 (set in the study's wrapper of
``run_chains``, without that fallback) and,
with ``--reference-draws R``, a reference of 4 chains of R draws after
2000 (fixed length). Modules 1 and 2 and the first pass (500 burn-in
steps) are the same in every fit (checked: module 2's estimate must
agree), so the second passes are samplers of one posterior. For each parameter's
mean, sd, 2.5 % and 97.5 % points, ``z = (a - b) / sqrt(mcse_a^2 +
mcse_b^2)`` (ArviZ's ``mcse`` from each run's chains). Printed: per case
and quantity the rms z of the short burn-in against 1000 and of each
against the reference, with the 95 % range honest errors give
(chi-squared, one degree of freedom per seed and parameter); the seeds
where the two differ most; per version the R-hat warnings, the draws kept,
the second pass's steps and the times.

With ``--update s`` the study asks the same of an update's chains, which
start from the last posterior's draws on fewer readings and burn in
``burn_in``: each seed is fitted with the defaults on the first share
``s`` of its field data (the same fit in every version), then
``partial_fit`` with the rest, whose chains (when the reweighted draws do
not do) burn in ``--short`` steps, 1000 or those of the reference, every
version forced and without a fallback. Seeds whose update reweighted are
left out.

Usage::

    python -m validation.studies.warm_burn_in --cases a2,b2,sbc_a2 \
        --n-seeds 40 --reference-draws 20000 --n-jobs 2
    python -m validation.studies.warm_burn_in --cases a2,b2 --update 0.25 \
        --n-seeds 40 --reference-draws 20000 --n-jobs 2

The results (per-chain proposals, where 250 steps were not enough, and
the pooled proposal, where they are) are quoted in ``docs/internals.rst``
(section skmba.mcmc._chain).
"""

import argparse
import time
import warnings
from unittest.mock import patch

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

import skmba.calibration._module3_posterior as posterior_module
from skmba import ModularBayesCalibrator
from skmba.calibration._module3_fit import WARM_BURN_IN_SHARE
from skmba.datasets import make_cantilever
from skmba.mcmc._run import run_chains
from validation.statistics import rms_band
from validation.studies.ess_target import QUANTITIES, chain_estimates
from validation.suite import registry

LONG = ModularBayesCalibrator().burn_in  # the burn-in from the mode (1000)
SHORT = round(WARM_BURN_IN_SHARE * LONG)  # the second pass's (250)


def _data(case, seed):
    """(prior, X, y, X_sim, theta_sim, y_sim) of a suite case, or of the
    thesis' 4.7.3 set-up (``"473"``: ``make_cantilever`` with E and I)."""
    if case == "473":
        d = make_cantilever(
            n_simulations=170,
            n_observations=70,
            parameters=("E", "I"),
            random_state=seed,
        )
        return d.prior, d.X_obs, d.y_obs, d.X_sim, d.theta_sim, d.y_sim
    c = registry()[case].build(seed)
    return c.prior, c.X, c.y, c.X_sim, c.theta_sim, c.y_sim


def one_fit(case, seed, version, reference_draws, update_share=None):
    """One fit of ``case`` on seed ``seed``: ``version`` a burn-in, or
    "reference" (4 chains of ``reference_draws`` after 2000, fixed length).

    With ``update_share``: a fit with the defaults on that share of the
    field data, the same in every version, then ``partial_fit`` with the
    rest, whose chains (when the reweighted draws do not do) are the ones
    the version sets.
    """
    prior, X, y, X_sim, theta_sim, y_sim = _data(case, seed)
    sims = {"X_sim": X_sim, "theta_sim": theta_sim, "y_sim": y_sim}
    params = {}  # the defaults: the first pass burns in 500 steps in every fit
    if version == "reference" and update_share is None:
        params = {"burn_in": 2000, "n_samples": reference_draws, "target_ess": None}
    cal = ModularBayesCalibrator(prior=prior, random_state=seed, **params)
    runs = []  # (steps, burn-in) of each run of the second pass's chains
    # The default (SHORT) as the calibrator runs it, with its fallback to
    # the full burn-in; any other version burns in that many steps (2000
    # for the reference), without the fallback. An update's chains burn in
    # ``burn_in``: every version of an update is forced.
    forced = {"reference": 2000}.get(version, version)
    if version == SHORT and update_share is None:
        forced = None

    def recorded(*args, **kwargs):
        # The second pass (an update) keeps its log density; a first pass not.
        second_pass = kwargs["keep_log_density"]
        if second_pass and forced is not None:
            kwargs["burn_in"] = forced
            if version == "reference" and update_share is not None:
                kwargs.update(n_samples=reference_draws, stopping=None)
        result = run_chains(*args, **kwargs)
        if second_pass:
            n_chains, n_draws = result.samples.shape[:2]
            runs.append((n_chains * (n_draws + kwargs["burn_in"]), kwargs["burn_in"]))
        return result

    with (
        threadpoolctl.threadpool_limits(1),
        warnings.catch_warnings(record=True),
    ):
        warnings.simplefilter("always")
        if update_share is not None:
            k = max(2, round(update_share * len(X)))
            cal.fit(X[:k], y[:k], **sims)
            X, y, sims = X[k:], y[k:], {}
        with (
            patch.object(posterior_module, "run_chains", recorded),
            patch.object(
                posterior_module,
                "_mixed",
                posterior_module._mixed if forced is None else (lambda *args: True),
            ),
        ):
            started = time.perf_counter()
            (cal.fit if update_share is None else cal.partial_fit)(X, y, **sims)
            seconds = time.perf_counter() - started
    if not runs:  # an update whose reweighted draws did: nothing to compare
        return {"estimates": None, "runs": 0, "seconds": seconds}
    chains = cal.theta_chains_
    # The second pass's runs: two when a module-2 draw left out weighed
    # something at the posterior draws (the chains ran again over every one).
    return {
        "estimates": chain_estimates(chains),
        "rhat": float(np.max(cal.rhat_)),
        "draws": chains.shape[1],
        "steps": sum(steps for steps, _ in runs),
        "runs": len(runs),
        "fell_back": len({burn_in for _, burn_in in runs}) > 1,
        "seconds": seconds,
        "module2": np.asarray(cal.discrepancy_sigma2_, float),
    }


def _z(fits, against):
    """(n_seeds, 4, r): each quantity's difference over the combined Monte
    Carlo errors of the two fits."""
    return np.array(
        [
            (a["estimates"][0] - b["estimates"][0])
            / np.sqrt(a["estimates"][1] ** 2 + b["estimates"][1] ** 2)
            for a, b in zip(fits, against, strict=True)
        ]
    )


def _rms_line(label, z):
    """rms z per quantity, with the range honest errors give (chi-squared,
    one degree of freedom per seed and parameter)."""
    n = z.shape[0] * z.shape[2]
    band = rms_band(n)
    rms = np.sqrt(np.mean(z**2, axis=(0, 2)))
    return (
        f"  rms z, {label} (95 % range if honest: [{band[0]:.2f}, {band[1]:.2f}]): "
        + ", ".join(f"{q} {v:.2f}" for q, v in zip(QUANTITIES, rms, strict=True))
    )


def _report(case, fits, short, seeds):
    """Print one case's lines from its fits (version: list over ``seeds``)."""
    quick, long = fits[short], fits[LONG]
    reference = fits.get("reference")
    moved = max(
        float(np.max(np.abs(f["module2"] - a["module2"])))
        for version in fits.values()
        for f, a in zip(version, quick, strict=True)
    )
    print(
        f"{case}: {len(quick)} seeds; module 2 the same in every fit (largest "
        f"difference {moved:.1e})"
    )
    sd_ratio = np.array(
        [
            a["estimates"][0][1] / b["estimates"][0][1]
            for a, b in zip(quick, long, strict=True)
        ]
    )
    z = _z(quick, long)
    for i, (seed, a, b) in enumerate(zip(seeds, quick, long, strict=True)):
        far = np.max(np.abs(z[i]))
        if far > 3 or np.any(np.abs(sd_ratio[i] - 1) > 0.1):
            line = (
                f"  seed {seed}: largest |z| {far:.1f}, sd ratio "
                f"{np.array2string(sd_ratio[i], precision=3)}, R-hat "
                f"{a['rhat']:.3f} ({short}) and {b['rhat']:.3f} ({LONG}), draws "
                f"{a['draws']} and {b['draws']}"
            )
            if reference is not None:
                ref = reference[i]["estimates"]
                line += "; sd over the reference's: " + ", ".join(
                    np.array2string(f[i]["estimates"][0][1] / ref[0][1], precision=3)
                    for f in (quick, long)
                )
            print(line)
    for label, version in fits.items():
        seconds = np.array([f["seconds"] for f in version])
        fell_back = sum(f["fell_back"] for f in version)
        again = sum(f["runs"] - f["fell_back"] > 1 for f in version)
        print(
            f"  burn_in={label}: chains ran in "
            f"{sum(f['runs'] > 0 for f in version)}/{len(version)}, R-hat > 1.01 in "
            f"{sum(f['rhat'] > 1.01 for f in version)}/{len(version)}, chains "
            f"run again after {LONG} steps in {fell_back} and over every "
            f"module-2 draw in {again}; draws kept per "
            f"chain {min(f['draws'] for f in version)}-"
            f"{max(f['draws'] for f in version)}; steps of the second pass median "
            f"{np.median([f['steps'] for f in version]):.0f}; fit median "
            f"{np.median(seconds):.1f} s [{seconds.min():.1f}, {seconds.max():.1f}]"
        )
    print(
        _rms_line(f"{short} against {LONG}", z)
        + f"; sd ratio: median {np.median(sd_ratio):.3f} "
        f"[{sd_ratio.min():.3f}, {sd_ratio.max():.3f}]"
    )
    if reference is not None:
        for label in (short, LONG):
            z_ref = _z(fits[label], reference)
            print(_rms_line(f"{label} against the reference", z_ref))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="473,a2,b2")
    parser.add_argument("--n-seeds", type=int, default=10)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument(
        "--short", type=int, default=SHORT, help="the short burn-in (the default's)"
    )
    parser.add_argument(
        "--update",
        type=float,
        default=None,
        help="fit this share of the field data, then time and compare the update",
    )
    parser.add_argument(
        "--reference-draws",
        type=int,
        default=0,
        help="draws per chain of a third, long fit (0: none)",
    )
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", FutureWarning)  # ArviZ 0.x announces 1.0
    cases = args.cases.split(",")
    versions = (args.short, LONG) + (("reference",) if args.reference_draws else ())
    started = time.perf_counter()
    jobs = [(c, s, v) for c in cases for s in range(args.n_seeds) for v in versions]
    # The reference fits are the longest: first, so that the workers end together.
    jobs.sort(key=lambda job: job[2] != "reference")
    out = Parallel(n_jobs=args.n_jobs)(
        delayed(one_fit)(*job, args.reference_draws, args.update) for job in jobs
    )
    fits = dict(zip(jobs, out, strict=True))
    print(
        f"burn-in study: {args.n_seeds} seeds of {args.cases}, burn_in={args.short} "
        f"against {LONG}"
        + (
            f", reference 4 chains of {args.reference_draws} draws after 2000"
            if args.reference_draws
            else ""
        )
        + (
            ""
            if args.update is None
            else f"; the chains of an update after a fit on {args.update:g} of "
            "the field data"
        )
        + f"; {time.perf_counter() - started:.0f} s on {args.n_jobs} job(s)"
    )
    for case in cases:
        # Seeds whose update reweighted the last draws ran no chains.
        seeds = [s for s in range(args.n_seeds) if fits[(case, s, LONG)]["runs"] > 0]
        if len(seeds) < args.n_seeds:
            print(f"{case}: {args.n_seeds - len(seeds)} updates ran no chains")
        by_version = {v: [fits[(case, s, v)] for s in seeds] for v in versions}
        _report(case, by_version, args.short, seeds)


if __name__ == "__main__":
    main()
