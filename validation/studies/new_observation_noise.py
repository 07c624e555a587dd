"""Why 95 % intervals of new observations cover a little less: the noise.

A diagnostic of issue 13's target for new observations (coverage
0.94-0.96). For each seed of a case (``--case``, a name of
:func:`validation.suite.registry`) the calibrator is fitted with the
defaults and, besides the exact coverage of new observations at the
held-out inputs (as in ``python -m validation``), it prints the module-2
mode of the noise variance over the true one (``noise_``), the noise
variance the predictions use (``var(predict) - var(predict_reality)``,
median over the held-out inputs) over the true, and the fitted discrepancy
roughness; then the same with the roughness capped (``--roughness-cap``),
and ``P(|t_nu| <= 1.96)`` for comparison. Modes:

- ``--pure-noise``: module 2 alone (``fit_hyperposterior`` with the default
  prior) on pure noise around a constant (one response, 25 readings, no
  emulator), with the discrepancy prior as it is and practically off
  (``sd_scale`` 1e-3), against the conjugate ideal: the share of the
  shortfall that the discrepancy prior takes;
- ``--ideal`` (no fits): the Student-t interval of a method that knows the
  reality and estimates only the noise, exact at 95 % over seeds, and how
  many of the suite's seeded fresh observations it holds (the "one draw"
  estimate's own luck);
- ``--emulator`` (a1, a2, whose reality is the model at theta*): the
  emulator's error and plug-in sd at the held-out inputs and theta*, over
  the noise sd.

Usage::

    python -m validation.studies.new_observation_noise --case a1 --n-seeds 40
    python -m validation.studies.new_observation_noise --case a1 --n-seeds 50 --ideal
    python -m validation.studies.new_observation_noise --pure-noise --n-seeds 200

(``--emulator`` likewise; ``--n-jobs 2`` for two processes). The results
are in ``docs/validity.rst`` ("Where the shortfall comes from", "New
observations, measured exactly").
"""

import argparse
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import stats

from skmba import ModularBayesCalibrator
from skmba.calibration._module2_posterior import fit_hyperposterior
from skmba.priors._hyperprior import Hyperprior
from validation.statistics import (
    LEVEL,
    Z_LEVEL,
    fresh_observations,
    observation_coverage,
)
from validation.suite import N_TEST, held_out_inputs, registry


def run_replicate(name, seed, discrepancy_prior=None):
    """Fit one seed; the coverage of new observations and the noise ratios."""
    spec = registry()[name]
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
        mean, std = cal.predict(X_test, return_std=True)
        _, std_reality = cal.predict_reality(X_test, return_std=True)
    true_var = case.noise_sd**2
    covered = observation_coverage(mean, std, truth, case.noise_sd)
    return {
        "covered": float(np.mean(covered)),
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
    """Print the pure-noise probe (``--pure-noise``).

    Per ``sd_scale`` of the discrepancy prior (the default's, and 1e-3: the
    discrepancy practically off), the noise variance's posterior mean and
    mode over the true one, and the coverage of new observations that
    adding the mean gives, ``P(|Z| <= 1.96 sqrt(mean / true))``; then the
    conjugate ideal (a flat mean and a log-uniform noise prior, no
    discrepancy): ``P(|t_24| <= 1.96 sqrt(24 / 22))``.
    """
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


#: The cases whose reality is the model at theta* (the emulator check).
MODEL_IS_REALITY = ("a1", "a2")


def emulator_replicate(name, seed):
    """The emulator at the held-out inputs and theta*, against the model.

    For a case whose reality is the model at theta* (``MODEL_IS_REALITY``):
    the rms of the emulator's error and of its plug-in sd (module 1,
    ``model_gp_`` on the standardised inputs), each over the noise sd, and
    the rms of their ratio, per response.
    """
    if name not in MODEL_IS_REALITY:
        raise ValueError(f"--emulator needs one of {MODEL_IS_REALITY}, got {name!r}")
    spec = registry()[name]
    case = spec.build(seed)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ModularBayesCalibrator(prior=case.prior, random_state=seed)
        cal.fit(case.X, case.y, X_sim=case.X_sim, theta_sim=case.theta_sim,
                y_sim=case.y_sim)  # fmt: skip
    X_test = held_out_inputs(spec.X_bounds, N_TEST)
    theta = np.tile(np.ravel(case.theta_true), (len(X_test), 1))
    offset = np.r_[cal.X_mean_, cal.theta_offset_]
    scale = np.r_[cal.X_scale_, cal.theta_scale_]
    mean, sd = cal.model_gp_.predict((np.c_[X_test, theta] - offset) / scale,
                                     return_std=True)  # fmt: skip
    error = mean * cal.y_scale_ + cal.y_mean_ - case.reality_fn(X_test)
    sd = sd * cal.y_scale_

    def rms(a):
        return np.sqrt(np.mean(a**2, axis=0))

    return rms(error) / case.noise_sd, rms(sd) / case.noise_sd, rms(error / sd)


def ideal_reference(name, n_seeds):
    """What a method that knows the reality and estimates only the noise gets.

    Per seed of case ``name``: the Student-t interval ``truth +- t s`` of
    ``level``, with ``s^2`` the mean square of the field data's noise
    (``nu`` = readings degrees of freedom). Under a log-uniform noise prior
    it is the exact posterior predictive interval, so over seeds it holds
    new observations at exactly ``level``. Returns its expected coverage
    (mean over seeds of the closed form) and the share of the suite's
    seeded fresh observations (one per held-out input, as the "one draw"
    estimate of ``python -m validation``) it holds, per response.
    """
    spec = registry()[name]
    expected, drawn = [], []
    for seed in range(n_seeds):
        case = spec.build(seed)
        noise = (case.y - case.reality_fn(case.X)) / case.noise_sd
        nu = np.sum(np.isfinite(noise), axis=0)
        s = np.sqrt(np.nanmean(noise**2, axis=0))
        half = stats.t.ppf(0.5 + LEVEL / 2, nu) * s * case.noise_sd
        truth = case.reality_fn(held_out_inputs(spec.X_bounds, N_TEST))
        sd = np.broadcast_to(case.noise_sd, truth.shape)
        expected.append(observation_coverage(truth, half / Z_LEVEL, truth, sd))
        y_new = fresh_observations(truth, case.noise_sd, seed)
        drawn.append(np.abs(y_new - truth) <= half)
    return np.mean(expected, axis=(0, 1)), np.mean(drawn, axis=(0, 1))


def _parser():
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.new_observation_noise",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--case", default="a1", help="a case of python -m validation")
    parser.add_argument("--n-seeds", type=int, default=20, help="seeds")
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel seeds")
    parser.add_argument(
        "--roughness-cap",
        type=float,
        default=3.0,
        help="upper end of the roughness prior of the second run",
    )
    parser.add_argument(
        "--emulator",
        action="store_true",
        help="the emulator's error and sd at theta* (a1, a2)",
    )
    parser.add_argument(
        "--ideal",
        action="store_true",
        help="the known-reality t-interval on the case's seeds (no fits)",
    )
    parser.add_argument(
        "--pure-noise",
        action="store_true",
        help="module 2 alone on pure noise, with and without the discrepancy",
    )
    return parser


def print_emulator(case, n_seeds, n_jobs):
    """Print the ``--emulator`` check (medians over seeds, per response)."""
    out = np.array(
        Parallel(n_jobs=n_jobs)(
            delayed(emulator_replicate)(case, seed) for seed in range(n_seeds)
        )
    )
    error, sd, z = np.median(out, axis=0)
    print(
        f"{case}, {n_seeds} seeds, emulator at theta* (medians over "
        f"seeds, per response): rms error / noise sd {np.round(error, 4)}; "
        f"rms plug-in sd / noise sd {np.round(sd, 4)}; rms error / sd "
        f"{np.round(z, 3)}; largest rms error / noise sd "
        f"{np.round(out[:, 0].max(axis=0), 3)}"
    )


def print_ideal(case, n_seeds):
    """Print the ``--ideal`` reference (no fits)."""
    expected, drawn = ideal_reference(case, n_seeds)
    print(
        f"{case}, {n_seeds} seeds, known reality, t-interval: expected "
        f"coverage {np.round(expected, 4)} (mean {expected.mean():.4f}); "
        f"share of the one-draw fresh observations {np.round(drawn, 4)} "
        f"(mean {drawn.mean():.4f})"
    )


def print_default_and_capped(case, n_seeds, n_jobs, roughness_cap):
    """Print the fits with the default prior and with a capped roughness."""
    settings = {
        "default": None,
        f"roughness <= {roughness_cap:g}": {"roughness": (0.1, roughness_cap)},
    }
    for label, prior in settings.items():
        records = Parallel(n_jobs=n_jobs)(
            delayed(run_replicate)(case, seed, prior) for seed in range(n_seeds)
        )
        print(summary_line(label, records))
    t = {nu: round(1 - 2 * stats.t.sf(Z_LEVEL, nu), 4) for nu in (15, 20, 25)}
    print(f"P(|t_nu| <= {Z_LEVEL:.2f}) for nu = 15, 20, 25: {t}")


def main(argv=None):
    args = _parser().parse_args(argv)
    if args.pure_noise:
        pure_noise(args.n_seeds, args.n_jobs)
    elif args.emulator:
        print_emulator(args.case, args.n_seeds, args.n_jobs)
    elif args.ideal:
        print_ideal(args.case, args.n_seeds)
    else:
        print_default_and_capped(
            args.case, args.n_seeds, args.n_jobs, args.roughness_cap
        )


if __name__ == "__main__":
    main()
