"""Why 95 % intervals of new observations cover a little less: the noise.

A diagnostic of issue 13's open target (new-observation coverage 0.94-0.96):
for each seed of a validity case (``benchmarks/_validity_cases.py``) the
calibrator is fitted with the defaults, and, besides the coverage of fresh
noisy observations at held-out inputs (as in ``validity.py``), it prints

* the module-2 mode of the noise variance over the true one (``noise_``);
* the noise variance the predictions use, ``var(predict) -
  var(predict_reality)`` (median over the held-out inputs), over the true;
* the fitted discrepancy roughness,

and the same with the discrepancy roughness capped (``--roughness-cap``),
then the coverage that a known noise level estimated with ``nu`` degrees of
freedom would give, ``P(|t_nu| <= 1.96)``, for comparison.

With ``--pure-noise``, module 2 alone (``fit_hyperposterior`` of
``skmba._hyperposterior``, the default prior) on data that are pure noise around
a constant (one response, 25 readings, no emulator): the noise variances'
posterior mean over the true one, and the coverage of new observations
that adding it gives, ``P(|Z| <= 1.96 sqrt(mean / true))``, with the
discrepancy prior as it is and practically switched off (``sd_scale``
1e-3), against the conjugate ideal (a flat mean and a log-uniform noise
prior, no discrepancy: ``P(|t_24| <= 1.96 sqrt(24 / 22))``). It tells the
share of the shortfall that the discrepancy prior takes: where the truth
has no discrepancy, it explains part of the noise.

Usage::

    python benchmarks/new_observation_noise.py --case a1 --n-seeds 40 --n-jobs 2
    python benchmarks/new_observation_noise.py --pure-noise --n-seeds 200 --n-jobs 2
"""

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import stats

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from validity import N_TEST, Z_LEVEL, cases, held_out_inputs  # noqa: E402

from skmba import ModularBayesCalibrator  # noqa: E402
from skmba._hyperposterior import fit_hyperposterior  # noqa: E402
from skmba._hyperprior import Hyperprior  # noqa: E402


def run_replicate(name, seed, discrepancy_prior=None):
    """Fit one seed; the coverage of new observations and the noise ratios."""
    spec = cases()[name]
    case = spec.build(seed)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(
            prior=case.prior, random_state=seed, discrepancy_prior=discrepancy_prior
        )
        cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                y_sim=case.y_sim)  # fmt: skip
        X_test = held_out_inputs(spec.X_bounds, N_TEST)
        truth = case.reality_fn(X_test)
        rng = np.random.default_rng([int(seed), 99])  # as validity.py
        y_new = truth + rng.normal(size=truth.shape) * case.noise_sd
        mean, std = cal.predict(X_test, return_std=True)
        _, std_reality = cal.predict_reality(X_test, return_std=True)
    true_var = case.noise_sd**2
    return {
        "covered": float(np.mean(np.abs(y_new - mean) <= Z_LEVEL * std)),
        "mode_ratio": np.asarray(cal.noise_) / true_var,
        "predictive_ratio": np.median(std**2 - std_reality**2, axis=0) / true_var,
        "roughness": np.atleast_1d(cal.discrepancy_kernel_.roughness),
    }


#: The pure-noise probe: readings, their noise variance (standardised
#: units, as a 30 dB response) and the mean they vary around.
PURE_NOISE = {"n": 25, "noise": 1e-3, "mean": 0.3}


def pure_noise_replicate(seed, sd_scale):
    """Module 2 on pure noise: posterior mean and mode of the noise over the
    true variance."""
    n, true_var = PURE_NOISE["n"], PURE_NOISE["noise"]
    rng = np.random.default_rng(seed)
    X = np.sort(rng.uniform(-1.7, 1.7, n))[:, None]
    y = PURE_NOISE["mean"] + rng.normal(size=(n, 1)) * np.sqrt(true_var)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        draws = fit_hyperposterior(
            X,
            y,
            np.zeros((n, n)),
            prior=Hyperprior(sd_scale=sd_scale),
            random_state=seed,
        )
    return float(draws.noise_mean[0]) / true_var, float(draws.mode.noise[0]) / true_var


def pure_noise(n_seeds, n_jobs):
    """Print the pure-noise probe (see the module docstring)."""
    for sd_scale in (Hyperprior().sd_scale, 1e-3):
        ratios = np.array(
            Parallel(n_jobs=n_jobs)(
                delayed(pure_noise_replicate)(seed, sd_scale) for seed in range(n_seeds)
            )
        )
        coverage = np.mean(2 * stats.norm.cdf(Z_LEVEL * np.sqrt(ratios[:, 0])) - 1)
        print(
            f"sd_scale {sd_scale:g}: noise posterior mean / true: mean "
            f"{ratios[:, 0].mean():.3f}, median {np.median(ratios[:, 0]):.3f}; "
            f"mode / true: median {np.median(ratios[:, 1]):.3f}; new-observation "
            f"coverage {coverage:.4f} ({n_seeds} seeds)"
        )
    nu = PURE_NOISE["n"] - 1
    ideal = 1 - 2 * stats.t.sf(Z_LEVEL * np.sqrt(nu / (nu - 2)), nu)
    print(
        f"conjugate ideal (nu = {nu}): mean {nu / (nu - 2):.3f}, coverage {ideal:.4f}"
    )


def summary_line(label, records):
    med = {k: np.median([r[k] for r in records], axis=0) for k in records[0]}
    cover = np.mean([r["covered"] for r in records])
    return (
        f"{label:>18s}: new-observation coverage {cover:.4f}; noise_/true "
        f"{np.round(med['mode_ratio'], 3)}; predictive noise/true "
        f"{np.round(med['predictive_ratio'], 3)}; roughness "
        f"{np.round(med['roughness'], 2)} (medians over {len(records)} seeds)"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--case", default="a1", help="a case of validity.py")
    parser.add_argument("--n-seeds", type=int, default=20, help="seeds")
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel seeds")
    parser.add_argument(
        "--roughness-cap",
        type=float,
        default=3.0,
        help="upper end of the roughness prior of the second run",
    )
    parser.add_argument(
        "--pure-noise",
        action="store_true",
        help="module 2 alone on pure noise, with and without the discrepancy",
    )
    args = parser.parse_args(argv)
    if args.pure_noise:
        pure_noise(args.n_seeds, args.n_jobs)
        return
    settings = {
        "default": None,
        f"roughness <= {args.roughness_cap:g}": {
            "roughness": (0.1, args.roughness_cap)
        },
    }
    for label, prior in settings.items():
        records = Parallel(n_jobs=args.n_jobs)(
            delayed(run_replicate)(args.case, seed, prior)
            for seed in range(args.n_seeds)
        )
        print(summary_line(label, records))
    t = {nu: round(1 - 2 * stats.t.sf(Z_LEVEL, nu), 4) for nu in (15, 20, 25)}
    print(f"P(|t_nu| <= {Z_LEVEL:.2f}) for nu = 15, 20, 25: {t}")


if __name__ == "__main__":
    main()
