"""Is a daily update that reweights the last chains' draws worth its ESS?

``partial_fit`` reweights the last MCMC run's draws to the new posterior
when their Kish share allows (:mod:`skmba.mcmc._reweight`), and reports as
its ESS the run's times that share. This study checks that claim on the
monitoring data set against long chains on the same update.

Per seed ``s``: ``make_bridge_monitoring(random_state=s)``, the calibrator's
defaults with ``bin_width=2`` and ``random_state=s``, ``fit`` on the first
364 days, then four versions of the last day's update from that same fit
(the same module 2, so only module 3 differs):

- ``reweighted``: ``partial_fit`` as shipped;
- ``chains``: the same update with the reweighting refused (its share
  threshold set above one in the worker), the chains of the defaults, as
  shipped: started from the refused reweighting's draws, which also fit
  their proposal, after the short burn-in, when those hold enough
  effective draws (:func:`skmba.mcmc._reweight.starts_chains`);
- ``full burn-in``: the same, the chains started from the last
  posterior's draws after the full burn-in (before 2026-11-30);
- ``reference``: as ``full burn-in`` with 4 chains of
  ``--reference-draws`` draws (fixed length).

For the mean and the sd of each parameter, ``z = (estimate - reference) /
sqrt(se^2 + se_ref^2)``, with ``se`` of two kinds: from each run's reported
``ess_`` (the mean's ``sd / sqrt(ess)``, the sd's ``sd sqrt((kurtosis - 1) /
(4 ess))``, the kurtosis of the reference's draws), and from its draws
(ArviZ's ``mcse`` of chains; the delta method of self-normalised importance
sampling for the reweighted nodes). Printed: how many updates reweighted,
their Kish shares and ESS, the time of each version, and per quantity the
rms z of the reweighted updates with the range honest errors give
(chi-squared with one degree of freedom per seed), and over every seed the
rms z of both chains' versions, their draws per chain, largest R-hat and
time.

``--days n`` updates with the last ``n`` days instead (the fit on the days
before), and ``--fit-days f`` fits the first ``f`` days and updates with
the ``n`` after them (spring's first warm days move the posterior most and
lower the weights' Kish share); ``--share s`` sets the reweighted
version's threshold (the shipped ``REWEIGHT_SHARE`` by default), to ask
whether draws below the shipped share are still worth their reported ESS.

Usage::

    python -m validation.studies.update_reweighting --n-seeds 20 --n-jobs 2
    python -m validation.studies.update_reweighting --n-seeds 20 \
        --fit-days 120 --days 7 --share 0.2 --n-jobs 2

The result is quoted in ``docs/internals.rst`` (section
skmba.mcmc._reweight).
"""

import argparse
import pickle
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import stats

import skmba.calibration._module3_update as update_module
import skmba.mcmc._reweight as reweight_module
from skmba import ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from skmba.mcmc._reweight import REWEIGHT_SHARE
from validation.statistics import rms_band

DAY = 24
QUANTITIES = ("mean", "sd")


def _summary(cal, seconds):
    """What a version of the update gave: moments, ESS, draws, how, time."""
    return {
        "mean": np.asarray(cal.theta_mean_, float),
        "sd": np.sqrt(np.diag(cal.theta_cov_)),
        "ess": np.broadcast_to(np.asarray(cal.ess_, float), cal.theta_mean_.shape),
        "samples": np.asarray(cal.theta_samples_, float),
        "chains": getattr(cal, "theta_chains_", None),
        "nodes": getattr(cal, "theta_nodes_", None),
        "weights": getattr(cal, "theta_weights_", None),
        "reweighted": not hasattr(cal, "theta_chains_"),
        "rhat": float(np.max(getattr(cal, "rhat_", np.nan))),
        "share": (
            float(1.0 / np.sum(cal.theta_weights_**2) / len(cal.theta_weights_))
            if hasattr(cal, "theta_weights_")
            else np.nan
        ),
        "seconds": seconds,
    }


def _seed(seed, reference_draws, days=1, share=None, fit_days=None):
    """The four versions of one seed's update with ``days`` days after the
    first ``fit_days`` (None: the year's last ``days``); ``share``: the
    reweighted version's threshold (None: the shipped one)."""
    data = make_bridge_monitoring(random_state=seed)
    frame = data.frame
    X, Y = frame[["temperature"]], frame[list(data.response_names)]
    end = len(frame) - days * DAY if fit_days is None else fit_days * DAY
    year, day = slice(0, end), slice(end, end + days * DAY)
    cal = ModularBayesCalibrator(prior=data.prior, bin_width=2.0, random_state=seed)
    out = {}
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # identifiability: said in the docs
        cal.fit(
            X[year],
            Y[year],
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
        )
        fitted = pickle.dumps(cal)
        shipped = reweight_module.REWEIGHT_SHARE
        starts = update_module.starts_chains
        long = {"n_samples": reference_draws, "target_ess": None}
        # (parameters, share threshold, whether a refused reweighting may
        # start the chains)
        versions = {
            "reweighted": ({}, shipped if share is None else share, True),
            "chains": ({}, 2.0, True),
            "full burn-in": ({}, 2.0, False),
            "reference": (long, 2.0, False),
        }
        weighted, shares = update_module.weighted, []

        def recorded(*args, **kwargs):  # the Kish share, the same in every version
            posterior, kish = weighted(*args, **kwargs)
            shares.append(kish)
            return posterior, kish

        update_module.weighted = recorded
        try:
            for name, (params, threshold, from_weights) in versions.items():
                reweight_module.REWEIGHT_SHARE = threshold  # above one: chains
                update_module.starts_chains = starts if from_weights else _never
                update = pickle.loads(fitted).set_params(**params)
                started = time.perf_counter()
                update.partial_fit(X[day], Y[day])
                out[name] = _summary(update, time.perf_counter() - started)
        finally:
            reweight_module.REWEIGHT_SHARE = shipped
            update_module.starts_chains = starts
            update_module.weighted = weighted
    out["share"] = shares[0] if shares else np.nan
    return out


def _never(posterior):
    """No refused reweighting starts the chains (the full burn-in from the
    last posterior's draws, as before 2026-11-30)."""
    return False


def _ess_errors(run, kurtosis):
    """Standard errors (2, r) of a run's mean and sd from its ``ess_``."""
    return np.array(
        [
            run["sd"] / np.sqrt(run["ess"]),
            run["sd"] * np.sqrt((kurtosis - 1.0) / (4.0 * run["ess"])),
        ]
    )


def _mcse(run):
    """Standard errors (2, r) of a run's mean and sd from its draws:
    ArviZ's ``mcse`` of chains; for weighted nodes, the delta method of
    self-normalised importance sampling (nodes taken as independent)."""
    if run["chains"] is not None:
        import arviz

        chains = run["chains"]
        return np.array(
            [
                [float(arviz.mcse(chains[:, :, j], method=m)) for j in range(2)]
                for m in ("mean", "sd")
            ]
        )
    w, x = run["weights"], run["nodes"]
    centred = x - run["mean"]
    se_mean = np.sqrt(np.sum(w[:, None] ** 2 * centred**2, axis=0))
    se_var = np.sqrt(
        np.sum(w[:, None] ** 2 * (centred**2 - run["sd"] ** 2) ** 2, axis=0)
    )
    return np.array([se_mean, se_var / (2.0 * run["sd"])])


def _z(run, ref, errors):
    """z (2, r) of a run's mean and sd against the reference's."""
    kurtosis = stats.kurtosis(ref["samples"], axis=0, fisher=False)
    if errors == "ess":
        se = np.hypot(_ess_errors(run, kurtosis), _ess_errors(ref, kurtosis))
    else:
        se = np.hypot(_mcse(run), _mcse(ref))
    values = np.array([run["mean"], run["sd"]])
    return (values - np.array([ref["mean"], ref["sd"]])) / se


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--reference-draws", type=int, default=20_000)
    parser.add_argument("--days", type=int, default=1, help="days in the update")
    parser.add_argument(
        "--fit-days", type=int, default=None, help="days fitted before the update"
    )
    parser.add_argument(
        "--share", type=float, default=None, help="the reweighted version's threshold"
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(_seed)(s, args.reference_draws, args.days, args.share, args.fit_days)
        for s in range(args.n_seeds)
    )
    reweighted = [r for r in results if r["reweighted"]["reweighted"]]
    shares = np.array([r["reweighted"]["share"] for r in reweighted])
    ess = np.array([r["reweighted"]["ess"].min() for r in reweighted])
    seconds = {
        name: np.array([r[name]["seconds"] for r in results])
        for name in ("reweighted", "chains", "full burn-in", "reference")
    }
    threshold = reweight_module.REWEIGHT_SHARE if args.share is None else args.share
    print(
        f"bridge year, 2 degC bins, defaults, updated with {args.days} day(s) "
        + ("at the year's end" if args.fit_days is None else f"after {args.fit_days}")
        + f", reweighted from a Kish share of {threshold:g}; "
        f"{args.n_seeds} seeds, "
        f"{time.perf_counter() - started:.0f} s; reference: 4 chains of "
        f"{args.reference_draws} draws"
    )
    print(
        f"reweighted: {len(reweighted)}/{len(results)} updates; Kish share "
        f"{shares.min():.2f}-{shares.max():.2f} (sorted: "
        f"{', '.join(f'{v:.2f}' for v in np.sort(shares))}), ESS "
        f"{ess.min():.0f}-{ess.max():.0f}"
        if reweighted
        else f"reweighted: 0/{len(results)} updates"
    )
    print(
        "update time (median, s): "
        + ", ".join(f"{k} {np.median(v):.1f}" for k, v in seconds.items())
    )
    _chains_table(results)
    n = len(reweighted)
    if not n:
        return
    band = rms_band(n)
    print(
        "rms z of the estimates against the reference's (95 % range if the "
        f"errors are honest: [{band[0]:.2f}, {band[1]:.2f}]), with errors from "
        "the reported ess_ and from the draws (delta method for the "
        "reweighted nodes, ArviZ's mcse for chains)"
    )
    print("parameter | quantity | reweighted: ess_, mcse | chains: ess_, mcse")
    z = {
        (name, errors): np.array(
            [_z(r[name], r["reference"], errors) for r in reweighted]
        )
        for name in ("reweighted", "chains")
        for errors in ("ess", "mcse")
    }  # (n, 2, r) each
    names = make_bridge_monitoring(random_state=0).parameter_names
    for j, name in enumerate(names):
        for i, quantity in enumerate(QUANTITIES):
            rms = [np.sqrt(np.mean(v[:, i, j] ** 2)) for v in z.values()]
            print(
                f"{name} | {quantity} | {rms[0]:.2f}, {rms[1]:.2f} | "
                f"{rms[2]:.2f}, {rms[3]:.2f}"
            )


def _chains_table(results):
    """Both chains' versions against the reference, over every seed."""
    band = rms_band(len(results))
    print(
        "chains (as shipped) and full burn-in against the reference over all "
        f"{len(results)} seeds, rms z with errors from ArviZ's mcse (95 % range "
        f"if honest: [{band[0]:.2f}, {band[1]:.2f}])"
    )
    versions = ("chains", "full burn-in")
    for name in versions:
        runs = [r[name] for r in results]
        draws = [run["chains"].shape[1] for run in runs]
        print(
            f"{name}: draws per chain median {np.median(draws):.0f} "
            f"({min(draws)}-{max(draws)}), largest R-hat "
            f"{max(run['rhat'] for run in runs):.4f}, median "
            f"{np.median([run['seconds'] for run in runs]):.1f} s"
        )
    z = {
        name: np.array([_z(r[name], r["reference"], "mcse") for r in results])
        for name in versions
    }
    # Where too few effective draws were left the shipped chains take the
    # old path, bit for bit: the refused reweighting placed the others.
    placed = np.array(
        [
            not np.array_equal(r["chains"]["mean"], r["full burn-in"]["mean"])
            for r in results
        ]
    )
    low = rms_band(max(1, int(placed.sum())))
    print(
        f"the refused reweighting placed the chains in {placed.sum()} of "
        f"{len(results)} updates (rms z over those, range "
        f"[{low[0]:.2f}, {low[1]:.2f}]: the last two columns)"
    )
    # Where the shipped calibrator itself runs placed chains: a share below
    # its threshold (the others it reweights).
    natural = placed & (np.array([r["share"] for r in results]) < REWEIGHT_SHARE)
    if not natural.any():
        print(f"none of those below the Kish share {REWEIGHT_SHARE}")
    else:
        _natural_line(z, natural)
    names = make_bridge_monitoring(random_state=0).parameter_names
    print("parameter | quantity | chains | full burn-in | placed: chains, full burn-in")
    for j, name in enumerate(names):
        for i, quantity in enumerate(QUANTITIES):
            rms = [np.sqrt(np.mean(v[:, i, j] ** 2)) for v in z.values()]
            rms += [np.sqrt(np.mean(v[placed, i, j] ** 2)) for v in z.values()]
            print(
                f"{name} | {quantity} | {rms[0]:.2f} | {rms[1]:.2f} | "
                f"{rms[2]:.2f}, {rms[3]:.2f}"
            )


def _natural_line(z, natural):
    """rms z of both chains' versions over the updates whose chains the
    shipped calibrator itself runs, placed (a share below its threshold)."""
    band = rms_band(max(1, int(natural.sum())))
    rms = {name: np.sqrt(np.mean(v[natural] ** 2, axis=0)) for name, v in z.items()}
    print(
        f"of those, {natural.sum()} below the Kish share {REWEIGHT_SHARE} (the "
        "shipped calibrator's chain days): rms z of chains and full burn-in "
        f"per parameter, range [{band[0]:.2f}, {band[1]:.2f}]: "
        + "; ".join(
            f"{q} {rms['chains'][i].round(2)}, {rms['full burn-in'][i].round(2)}"
            for i, q in enumerate(QUANTITIES)
        )
    )


if __name__ == "__main__":
    main()
