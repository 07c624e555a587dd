"""Coverage of the best-fit estimand: does its 95 % interval cover the best fit?

For each case and seed, the calibrator is fitted with
``estimand="best_fit"`` (otherwise the defaults). The true best fit is the
least-squares fit of the emulator's mean to the noise-free reality at the
field inputs, each response in its simulations' spread, within the
simulated range: the estimand as the calibrator defines it, computed here
with ``scipy.optimize.least_squares`` from the fitted calibrator's public
attributes (``model_gp_`` and the standardisation), not with the package's
own Gauss-Newton. Printed per case: how often the central 95 % interval
covers it, with its Wilson interval; the rms and mean z-score; the median
Monte Carlo error of the mean in posterior sds; and the rms z-score of
reality's posterior at (up to 100 of) the distinct field inputs, against
the noise-free reality: the best fit is as calibrated as that posterior.
With ``--physical`` each seed is also fitted with the default
``estimand="physical"``: its coverage of the same best fit, the median
ratio of the sds, and the median distance between the two means in
physical posterior sds.

For the cantilever cases (a1, c1, c3) reality is in the model's family:
the best fit is the effective modulus E*/(1 + 3 E* I/(K* L)) (E* on a1),
up to the emulator's error.

Usage::

    python -m validation.studies.best_fit --cases a1,c1,c3,freq,freq0 \
        --n-seeds 50 --n-jobs 2 --physical

``freq0`` is the suite's freq case without its discrepancy (reality is the
model at theta*), where the two estimands are the same parameter;
``bridge`` a year of :func:`skmba.datasets.make_bridge_monitoring` with the
monitoring guide's settings (2 degC bins, ``--bridge-bin-width``, 1,000
draws after 300), its truth computed at every reading's own input.

The results are in ``docs/validity.rst`` (section "The best-fit estimand").
"""

import argparse
import time
import warnings
from types import SimpleNamespace

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import optimize
from scipy.stats import qmc

from skmba import ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from validation.cases import case_freq
from validation.statistics import LEVEL, rms, wilson_interval
from validation.suite import registry


def best_fit_truth(cal, X, reality):
    """The least-squares fit of ``cal``'s emulator mean to ``reality`` (n, q)
    at the distinct rows of ``X``, within the simulated range (user units)."""
    X = np.asarray(X, dtype=float)
    inputs, first, counts = np.unique(X, axis=0, return_index=True, return_counts=True)
    target = np.asarray(reality, float).reshape(len(X), -1)[first] - cal.y_mean_
    target = target / cal.y_scale_
    Xs = (inputs - cal.X_mean_) / cal.X_scale_
    root_w = np.sqrt(counts / counts.sum())[:, None]
    t_sim = (np.asarray(cal.theta_sim_, float) - cal.theta_offset_) / cal.theta_scale_
    lo, hi = t_sim.min(axis=0), t_sim.max(axis=0)

    def residuals(t):
        points = np.hstack([Xs, np.repeat(t[None], len(Xs), axis=0)])
        return ((cal.model_gp_.predict(points) - target) * root_w).ravel()

    # The global minimum: the best of a grid over the simulated range (a
    # stiff bearing is nearly a fixed one: the bridge has a second minimum).
    if len(lo) <= 2:
        axes = [np.linspace(a, b, 41) for a, b in zip(lo, hi, strict=True)]
        grid = np.stack(np.meshgrid(*axes), axis=-1).reshape(-1, len(lo))
    else:
        grid = lo + (hi - lo) * qmc.Sobol(len(lo), seed=0).random(512)
    start = grid[np.argmin([np.sum(residuals(t) ** 2) for t in grid])]
    fit = optimize.least_squares(residuals, start, bounds=(lo, hi), xtol=1e-12)
    return fit.x * cal.theta_scale_ + cal.theta_offset_


def _fit(case, seed, estimand):
    cal = ModularBayesCalibrator(
        prior=case.prior, random_state=seed, estimand=estimand, **case.params
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal.fit(
            case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim, y_sim=case.y_sim
        )
    return cal


def _interval(cal):
    tail = (1 - LEVEL) / 2
    return np.quantile(cal.theta_samples_, [tail, 1 - tail], axis=0)


def _case(name, seed, bin_width=2.0):
    """The data, the noise-free reality at the field inputs and the
    calibrator's settings of a case (``bin_width``: the bridge's)."""
    if name == "bridge":  # a year of readings, the monitoring guide's settings
        data = make_bridge_monitoring(random_state=seed)
        y = np.asarray(data.y_obs, dtype=float)
        kept = np.isfinite(y).any(axis=1)
        return SimpleNamespace(
            X=np.asarray(data.X_obs, dtype=float)[kept],
            y=y[kept],
            X_sim=data.X_sim,
            theta_sim=data.theta_sim,
            y_sim=data.y_sim,
            prior=data.prior,
            reality=np.asarray(data.y_obs_true, dtype=float)[kept],
            params=dict(bin_width=bin_width, n_samples=1000, burn_in=300),
        )
    case = case_freq(seed, amplitude=0.0) if name == "freq0" else None
    case = case or registry()[name].build(seed)
    reality = case.reality_fn(np.asarray(case.X, dtype=float))
    return SimpleNamespace(**case._asdict(), reality=reality, params={})


def replicate(name, seed, physical, bin_width=2.0):
    """One seed: a dict of per-parameter arrays."""
    case = _case(name, seed, bin_width)
    with threadpoolctl.threadpool_limits(1):
        cal = _fit(case, seed, "best_fit")
        truth = best_fit_truth(cal, case.X, case.reality)
        out = _scores(cal, truth)
        out["mcse"] = cal.theta_mcse_[0] / out["sd"]
        out["reality_z"] = _reality_z(cal, case)
        if physical:
            other = _scores(_fit(case, seed, "physical"), truth)
            out["physical_covered"] = other["covered"]
            out["sd_ratio"] = out["sd"] / other["sd"]
            out["mean_shift"] = np.abs(out["mean"] - other["mean"]) / other["sd"]
    out["truth"] = truth
    return out


def _reality_z(cal, case, n_points=100):
    """The rms z-score of reality's posterior against the noise-free
    reality, over at most ``n_points`` distinct field inputs (r,)-shaped
    as a scalar: what the best fit reads its interval from."""
    X = np.asarray(case.X, dtype=float)
    _, first = np.unique(X, axis=0, return_index=True)
    rows = first[:: max(1, len(first) // n_points)]
    mean, std = cal.predict_reality(X[rows], return_std=True)
    truth = np.asarray(case.reality, dtype=float).reshape(len(X), -1)[rows]
    z = (np.reshape(mean, truth.shape) - truth) / np.reshape(std, truth.shape)
    return np.full(cal.theta_mean_.shape, rms(z.ravel()))


def _scores(cal, truth):
    low, high = _interval(cal)
    sd = np.sqrt(np.diag(cal.theta_cov_))
    return {
        "covered": (low <= truth) & (truth <= high),
        "z": (cal.theta_mean_ - truth) / sd,
        "sd": sd,
        "mean": cal.theta_mean_,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="a1,c1,c3,freq,freq0")
    parser.add_argument("--n-seeds", type=int, default=50)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--physical", action="store_true")
    parser.add_argument("--bridge-bin-width", type=float, default=2.0)
    args = parser.parse_args(argv)
    for name in args.cases.split(","):
        started = time.perf_counter()
        out = Parallel(n_jobs=args.n_jobs)(
            delayed(replicate)(name, s, args.physical, args.bridge_bin_width)
            for s in range(args.n_seeds)
        )
        table = {k: np.array([o[k] for o in out]) for k in out[0]}
        n = len(out)
        print(f"{name}: {n} seeds, {time.perf_counter() - started:.0f} s")
        for j in range(table["z"].shape[1]):
            k = int(table["covered"][:, j].sum())
            lo, hi = wilson_interval(k, n)
            line = (
                f"  parameter {j}: best fit {np.median(table['truth'][:, j]):.6g} "
                f"(median); covered {k}/{n} [{lo:.3f}, {hi:.3f}]; rms z "
                f"{rms(table['z'][:, j]):.2f}, mean z {table['z'][:, j].mean():+.2f}; "
                f"MC error of the mean {np.median(table['mcse'][:, j]):.3f} sd; "
                f"reality's rms z {rms(table['reality_z'][:, j]):.2f}"
            )
            if args.physical:
                kp = int(table["physical_covered"][:, j].sum())
                line += (
                    f"; physical covers it {kp}/{n}, sd best / physical "
                    f"{np.median(table['sd_ratio'][:, j]):.3f} (median), means "
                    f"{np.median(table['mean_shift'][:, j]):.2f} physical sds apart "
                    "(median)"
                )
            print(line, flush=True)


if __name__ == "__main__":
    main()
