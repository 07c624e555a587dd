"""Is an update's reported Monte Carlo error the spread over chain seeds?

ArviZ's ``mcse`` of a run of chains says how far its mean and sd would
move with other seeds. This study checks that directly, on one target at
a time and with no reference: an update's module 3 (its module 2 fixed) is
run again with many chain seeds, and the spread of the estimates is set
against the errors the runs report. (``update_reweighting`` compares each
update with long chains instead: one run per update, the reference's error
added.)

Per data seed ``s``: ``make_bridge_monitoring(random_state=s)``, the
defaults with ``bin_width=2`` and ``random_state=s``, ``fit`` on the first
``--fit-days`` days, then ``partial_fit`` with the next ``--days`` days,
the reweighting refused (its share threshold set above one). Module 3's
inputs are kept from that call, and its chains
(``skmba.calibration._module3_fit.sample_posterior``) run again with
``--chain-seeds`` seeds in each version:

- ``placed``: as shipped, started from the refused reweighting's draws,
  which also fit the proposal, after the short burn-in (where those draws
  hold ``MIN_ESS`` effective draws, else as the next version);
- ``last posterior``: started from the last posterior's draws after the
  full burn-in (the path before 2026-11-30).

``--fixed-draws n`` runs ``n`` draws per chain instead of stopping at the
ESS target, to see what the stopping rule does to the errors.

Printed: per version, parameter and quantity (mean, sd), the pooled ratio
of the spread to ArviZ's ``mcse`` over all data seeds with its 95 %
interval (:func:`validation.statistics.spread_ratio`: one when the errors
are honest), for ``placed`` also over the data seeds whose chains the
refused reweighting placed, the ratio per data seed, the draws per chain
and the time per run; per data seed, the Kish share that refused the
reweighting.

Usage::

    python -m validation.studies.update_chain_spread --n-seeds 10 \
        --chain-seeds 30 --n-jobs 2

The result is quoted in ``docs/internals.rst`` (section
skmba.mcmc._reweight).
"""

import argparse
import time
import warnings
from dataclasses import replace
from unittest.mock import patch

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

import skmba.calibration._module3_fit as module3_fit
import skmba.calibration._module3_update as update_module
import skmba.mcmc._reweight as reweight_module
from skmba import ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from validation.statistics import spread_ratio

DAY = 24
QUANTITIES = ("mean", "sd")
VERSIONS = ("placed", "last posterior")


def captured_update(seed, fit_days, days):
    """Module 3's inputs of seed ``seed``'s update with the reweighting
    refused: the arguments of ``_module3_fit.sample_posterior`` (the last of them
    the refused reweighting that places the chains, or None) and the
    reweighting's Kish share (NaN where the fit's chains warned and left no
    draws to reweight)."""
    data = make_bridge_monitoring(random_state=seed)
    frame = data.frame
    X, Y = frame[["temperature"]], frame[list(data.response_names)]
    first, batch = (
        slice(0, fit_days * DAY),
        slice(fit_days * DAY, (fit_days + days) * DAY),
    )
    cal = ModularBayesCalibrator(prior=data.prior, bin_width=2.0, random_state=seed)
    cal.fit(
        X[first], Y[first], X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim
    )
    kept, shares = {}, []
    posterior, weighted = module3_fit.sample_posterior, update_module.weighted

    def keep(*args):
        if not args[3]:  # module 3's own chains, not a first pass's
            kept["args"] = args
        return posterior(*args)

    def recorded(*args, **kwargs):
        result, share = weighted(*args, **kwargs)
        shares.append(share)
        return result, share

    with (
        patch.object(module3_fit, "sample_posterior", keep),
        patch.object(update_module, "weighted", recorded),
        patch.object(reweight_module, "REWEIGHT_SHARE", 2.0),  # above one: chains
    ):
        cal.partial_fit(X[batch], Y[batch])
    # No share: the fit's chains warned, so no anchor to reweight.
    return kept["args"], shares[0] if shares else np.nan


def one_seed(seed, fit_days, days, chain_seeds, fixed_draws=None, versions=VERSIONS):
    """Each version's estimates and ArviZ errors over ``chain_seeds`` runs of
    seed ``seed``'s update: ``{version: {"estimates", "errors"}}`` (K, 2, r)
    for the mean and sd, ``"draws"`` and ``"seconds"`` (K,); ``"share"``
    and ``"from_weights"`` (whether the refused reweighting places the
    chains)."""
    import arviz

    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability: said in the docs
        (inputs, log_post, _, _, earlier, start), share = captured_update(
            seed, fit_days, days
        )
        if fixed_draws is not None:
            sampler = replace(
                inputs.settings.sampler, n_samples=fixed_draws, target_ess=None
            )
            inputs = replace(inputs, settings=replace(inputs.settings, sampler=sampler))
        out = {"share": share, "from_weights": start is not None}
        # Runs by whether the refused reweighting places them: without its
        # draws, both versions are one run (the same seeds, the same bits).
        done = {}
        for version in versions:
            placed = start if version == "placed" else None
            if (placed is not None) in done:
                out[version] = done[placed is not None]
                continue
            runs = []
            for k in range(chain_seeds):
                started = time.perf_counter()
                posterior = module3_fit.sample_posterior(
                    inputs,
                    log_post,
                    10_000 + k,
                    False,
                    earlier,
                    placed,
                )
                seconds = time.perf_counter() - started
                chains = posterior.chains
                r = chains.shape[-1]
                flat = chains.reshape(-1, r)
                runs.append(
                    (
                        [flat.mean(axis=0), flat.std(axis=0, ddof=1)],
                        [
                            [
                                float(arviz.mcse(chains[:, :, j], method=m))
                                for j in range(r)
                            ]
                            for m in QUANTITIES
                        ],
                        chains.shape[1],
                        seconds,
                    )
                )
            out[version] = done[placed is not None] = {
                key: np.array([run[i] for run in runs])
                for i, key in enumerate(("estimates", "errors", "draws", "seconds"))
            }
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=10, help="data seeds")
    parser.add_argument("--chain-seeds", type=int, default=30)
    parser.add_argument("--fit-days", type=int, default=31)
    parser.add_argument("--days", type=int, default=60, help="days in the update")
    parser.add_argument("--fixed-draws", type=int, default=None)
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(one_seed)(
            s, args.fit_days, args.days, args.chain_seeds, args.fixed_draws
        )
        for s in range(args.n_seeds)
    )
    length = (
        "the ESS target's stop"
        if args.fixed_draws is None
        else f"{args.fixed_draws} draws per chain"
    )
    print(
        f"bridge year, 2 degC bins, defaults, updated with {args.days} days after "
        f"{args.fit_days}, the reweighting refused; {args.n_seeds} data seeds x "
        f"{args.chain_seeds} chain seeds, {length}; "
        f"{time.perf_counter() - started:.0f} s"
    )
    print(
        "Kish shares: "
        + ", ".join(f"{r['share']:.2f}" for r in results)
        + f"; placed in {sum(r['from_weights'] for r in results)} of {len(results)}"
    )
    names = make_bridge_monitoring(random_state=0).parameter_names
    for version in VERSIONS:
        runs = [r[version] for r in results]
        draws = np.concatenate([run["draws"] for run in runs])
        seconds = np.concatenate([run["seconds"] for run in runs])
        print(
            f"{version}: draws per chain median {np.median(draws):.0f} "
            f"({draws.min()}-{draws.max()}), {np.median(seconds):.1f} s per run "
            "(one BLAS thread)"
        )
        estimates = np.stack([run["estimates"] for run in runs])  # (S, K, 2, r)
        errors = np.stack([run["errors"] for run in runs])
        ratio, lower, upper = spread_ratio(estimates, errors)
        per_seed = np.array(
            [
                spread_ratio(x[None], e[None])[0]
                for x, e in zip(estimates, errors, strict=True)
            ]
        )  # (S, 2, r)
        # Where too few effective draws were left, "placed" is the old path:
        # the data seeds whose chains the refused reweighting placed, apart.
        placed = np.array([r["from_weights"] for r in results])
        apart = version == "placed" and 0 < placed.sum() < len(placed)
        if apart:
            only = spread_ratio(estimates[placed], errors[placed])
        for j, name in enumerate(names):
            for i, quantity in enumerate(QUANTITIES):
                print(
                    f"  {name} {quantity}: spread / mcse {ratio[i, j]:.2f} "
                    f"[{lower[i, j]:.2f}, {upper[i, j]:.2f}]"
                    + (
                        f" ({only[0][i, j]:.2f} [{only[1][i, j]:.2f}, "
                        f"{only[2][i, j]:.2f}] over the {placed.sum()} placed)"
                        if apart
                        else ""
                    )
                    + "; per data seed "
                    + " ".join(f"{v:.2f}" for v in per_seed[:, i, j])
                )


if __name__ == "__main__":
    main()
