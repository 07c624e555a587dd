"""Change detection on the bridge: false alarms, power, and the data-driven baseline.

For each seed, a reference year of :func:`skmba.datasets.make_bridge_monitoring`
(no damage) fits a :class:`skmba.ChangeDetector` (plug-in module 2, a
``--kernel`` discrepancy, Matern 3/2 by default, ``--reference-bin-width``
degC bins in the calibrator, 0.5 by default, ``--bin-width`` degC bins for
the batches, 0.2 by default; docs/change_detection.rst says why) and the
data-driven baseline: each frequency regressed on the temperature (cubic
splines, scikit-learn's ``SplineTransformer`` and ``LinearRegression``), then
the Mahalanobis distance of the residuals under ``MinCovDet``; a batch's
score is the mean squared distance of its complete readings, and its alarm
threshold the ``1 - alpha`` quantile of the scores of every week-long (or
month-long) window of the reference year, one a day.

Then, on other years of the same bridge (other weather and noise):

- no change: 52 one-week and 12 one-month batches per seed;
- a stiffness loss of ``--sizes`` of element 5 (a quarter of the span) from
  the first hour: the same batches, per size.

Printed: the alarm rate of each method at its own threshold with its Wilson
interval (false alarms without damage, detection rates with it); the
detection rate of both at thresholds that give both exactly the same
false-alarm rate on the no-change batches of the run (their empirical
``1 - alpha`` quantiles); how often the detector names the deck's ``E`` as
the changed parameter (largest single-parameter Bayes factor) among its
alarms; its estimate of ``E``'s relative change, and how often its 95 %
interval covers the effective change (:func:`effective_change`: the change
of ``E`` and ``k_bearing`` whose shift of the model best matches the
damage's, at the batch's temperatures; one modulus for the deck cannot
represent one element's loss, so this is the best-fit truth). ``--refit`` also runs
``discrepancy="refit"``; ``--shift emulator`` moves the prediction by a
change with the reference's emulator instead of the simulator (the bridge's
finite element model). Seeds run in parallel (``--n-jobs``), one BLAS
thread each.

Usage::

    python -m validation.studies.change_detection --n-seeds 9 --n-jobs 2

``--first-seed`` starts the reference years elsewhere (a run of more seeds
adds to an earlier one without repeating it); ``--sizes`` with no value runs
the no-change batches only (false alarms); ``--save FILE`` writes every
batch's row (``.npz``, one array per seed, size and length) for re-analysis.

The results are in ``docs/monitoring.rst``.
"""

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy.optimize import least_squares
from sklearn.covariance import MinCovDet
from sklearn.gaussian_process.kernels import Matern
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import SplineTransformer

from skmba import ChangeDetector, ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from validation.statistics import wilson_interval

LENGTHS = {"week": 168, "month": 730}
# The reference's discrepancy kernel: None is the calibrator's default (Gauss).
KERNELS = {"matern1.5": Matern(nu=1.5), "gauss": None}
ELEMENT = 5


class Baseline:
    """Temperature regression of the frequencies, then MinCovDet Mahalanobis."""

    def __init__(self, alpha):
        self.alpha = alpha

    def fit(self, X, Y):
        rows = np.all(np.isfinite(Y), axis=1)
        self.regression = make_pipeline(
            SplineTransformer(n_knots=8, degree=3), LinearRegression()
        ).fit(X[rows], Y[rows])
        self.mcd = MinCovDet(random_state=0).fit(
            Y[rows] - self.regression.predict(X[rows])
        )
        self.thresholds = {}
        for name, n in LENGTHS.items():
            starts = range(0, len(X) - n + 1, 24)
            windows = [(X[i : i + n], Y[i : i + n]) for i in starts]
            scores = [
                self.score(Xw, Yw)
                for Xw, Yw in windows
                if np.all(np.isfinite(Yw), axis=1).any()
            ]
            self.thresholds[name] = np.quantile(scores, 1 - self.alpha)
        return self

    def score(self, X, Y):
        rows = np.all(np.isfinite(Y), axis=1)
        resid = Y[rows] - self.regression.predict(X[rows])
        return float(np.mean(self.mcd.mahalanobis(resid)))


def _batches(data, name):
    """The batches of a year; one whose logger was down throughout (no hour
    with all four frequencies, which the baseline needs) is left out."""
    n = LENGTHS[name]
    for i in range(0, len(data.X_obs) - n + 1, n):
        Y = data.y_obs[i : i + n]
        if np.all(np.isfinite(Y), axis=1).any():
            yield data.X_obs[i : i + n], Y


def effective_change(data, theta_0, X):
    """The relative change of ``theta_0`` whose model shift best matches the
    damage's at the temperatures ``X`` (weighted least squares, noise sds):
    what a detector with unlimited readings and a perfect emulator reports."""
    if data.damage is None:
        return np.zeros(len(theta_0))
    shift = data.damage["reality"](X) - data.reality(X)
    base = data.simulator(X, theta_0)
    sd = np.asarray(data.noise_sd)

    def misfit(delta):
        return ((data.simulator(X, theta_0 * (1 + delta)) - base - shift) / sd).ravel()

    return least_squares(misfit, np.zeros(len(theta_0)), x_scale=0.01).x


def _scores(detectors, baseline, data):
    """Per batch length: rows of (per detector: log(p / alpha), E named,
    E's change, E's interval covers its effective change), baseline's
    score minus its threshold."""
    out = {}
    for name in LENGTHS:
        rows = []
        for X, Y in _batches(data, name):
            row = []
            for det in detectors:
                ev = det.evidence(X, Y)
                truth = effective_change(data, det.theta_reference_, X)[0]
                half = 1.959964 * ev.change_sd[0]
                row += [ev.log_p_value - np.log(det.alpha)]
                row += [float(np.argmax(ev.single_log10_bayes_factors) == 0)]
                row += [
                    ev.change_mean[0],
                    float(abs(ev.change_mean[0] - truth) <= half),
                ]
            rows.append([*row, baseline.score(X, Y) - baseline.thresholds[name]])
        out[name] = np.array(rows)
    return out


def _replicate(seed, sizes, bin_width, alpha, refit, shift, reference):
    """One reference year and its test years: {scenario: {length: scores}}.

    ``reference``: the calibrator's discrepancy kernel (a name of
    :data:`KERNELS`) and its bin width [degC]."""
    ref = make_bridge_monitoring(random_state=seed)
    kernel, reference_bin_width = reference
    cal = ModularBayesCalibrator(
        prior=ref.prior,
        discrepancy_kernel=KERNELS[kernel],
        discrepancy_uncertainty="plug-in",
        bin_width=reference_bin_width,
        random_state=seed,
    )
    kinds = ["carry", "refit"] if refit else ["carry"]
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulator = ref.simulator if shift == "simulator" else None
        first = ChangeDetector(
            cal, alpha=alpha, bin_width=bin_width, simulator=simulator
        ).fit(
            ref.X_obs,
            ref.y_obs,
            X_sim=ref.X_sim,
            theta_sim=ref.theta_sim,
            y_sim=ref.y_sim,
        )
        detectors = [first]
        if refit:
            other = ChangeDetector(
                first.calibrator_, alpha=alpha, bin_width=bin_width, simulator=simulator
            )
            detectors.append(
                other.set_params(discrepancy="refit").fit(ref.X_obs, ref.y_obs)
            )
        baseline = Baseline(alpha).fit(ref.X_obs, ref.y_obs)
        result = {}
        for i, size in enumerate((0.0, *sizes)):
            test = make_bridge_monitoring(
                random_state=10_000 + 100 * seed + i,
                damage_size=size,
                damage_location=ELEMENT,
                damage_start=0,
            )
            result[size] = _scores(detectors, baseline, test)
    return kinds, result


def _rate(flags):
    k, n = int(np.sum(flags)), len(flags)
    lo, hi = wilson_interval(k, n)
    return f"{k}/{n} = {k / n:.3f} [{lo:.3f}, {hi:.3f}]"


def _report(kinds, results, sizes, alpha):
    w = 4  # columns per detector
    for name in LENGTHS:
        print(f"\n{name}-long batches")
        null = np.vstack([r[0.0][name] for r in results])
        cuts = np.quantile(null, alpha, axis=0)  # equal-FAR cuts (low: alarm)
        base_cut = np.quantile(null[:, -1], 1 - alpha)
        print(
            "size | "
            + " | ".join(f"{k}: alarms" for k in kinds)
            + " | baseline: alarms | equal FAR: "
            + " | ".join(kinds)
            + " | baseline | E named (alarms) | E change | E covered"
        )
        for size in (0.0, *sizes):
            s = np.vstack([r[size][name] for r in results])
            cells = [_rate(s[:, w * j] < 0) for j in range(len(kinds))]
            cells.append(_rate(s[:, -1] > 0))
            equal = [
                f"{np.mean(s[:, w * j] < cuts[w * j]):.3f}" for j in range(len(kinds))
            ]
            equal.append(f"{np.mean(s[:, -1] > base_cut):.3f}")
            alarms = s[:, 0] < 0
            named = _rate(s[alarms, 1]) if alarms.any() else "-"
            change = s[:, 2]
            print(
                f"{size:g} | "
                + " | ".join(cells + equal)
                + f" | {named} | {np.mean(change):+.4f} (sd {np.std(change):.4f})"
                + f" | {_rate(s[:, 3])}"
            )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=9)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--save", default=None, metavar="FILE")
    parser.add_argument(
        "--sizes", type=float, nargs="*", default=[0.01, 0.02, 0.05, 0.1]
    )
    parser.add_argument("--bin-width", type=float, default=0.2)
    parser.add_argument("--reference-bin-width", type=float, default=0.5)
    parser.add_argument("--kernel", choices=list(KERNELS), default="matern1.5")
    parser.add_argument("--alpha", type=float, default=0.05)
    parser.add_argument("--refit", action="store_true")
    parser.add_argument(
        "--shift", choices=["simulator", "emulator"], default="simulator"
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    out = Parallel(n_jobs=args.n_jobs)(
        delayed(_replicate)(
            s,
            args.sizes,
            args.bin_width,
            args.alpha,
            args.refit,
            args.shift,
            (args.kernel, args.reference_bin_width),
        )
        for s in range(args.first_seed, args.first_seed + args.n_seeds)
    )
    kinds = out[0][0]
    seeds = f"seeds {args.first_seed}-{args.first_seed + args.n_seeds - 1}"
    print(
        f"{args.n_seeds} reference years ({seeds}), "
        f"{time.perf_counter() - started:.0f} s"
    )
    if args.save:
        np.savez(
            args.save,
            **{
                f"seed{args.first_seed + i}_size{size:g}_{name}": rows
                for i, (_, result) in enumerate(out)
                for size, by_length in result.items()
                for name, rows in by_length.items()
            },
        )
    _report(kinds, [r for _, r in out], args.sizes, args.alpha)


if __name__ == "__main__":
    main()
