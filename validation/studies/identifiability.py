"""How often the identifiability diagnosis warns, and whether it should.

Issue 31 asks that the diagnosis (``identifiability_`` and its
:class:`~skmba.exceptions.NonIdentifiabilityWarning`) stay quiet on an
identifiable design at any signal-to-noise ratio and flag the designs
whose interval is set by the discrepancy prior, naming the right
parameter, and that it not move with ``random_state``. Per variant and
seed, the calibrator with its defaults (``random_state`` the seed) is fitted
to a replicate of :mod:`validation.cases`, and the study records which
parameters the warning names and ``identifiability_``:

- ``freq`` (theta sets a frequency: identifiable) with no discrepancy and
  with 0.1 x^2, at 10, 30 and 50 dB: it should not warn;
- ``a1``, ``b1``, ``c1``, ``c3`` (E confounded with a discrepancy shaped
  like its effect) and ``a2``, ``b2`` (both parameters), at 30 dB: it
  should warn, naming those parameters;
- ``freq + offset`` (freq's frequency and an additive offset, which the
  discrepancy's constant mean absorbs), with no discrepancy and with
  0.1 x^2, at 30 dB: it should warn for the offset only.

The warning rate is printed with its Wilson 95 % interval. ``--stability
N`` also refits seed 0's data of ``freq`` (no discrepancy, 50 dB) and of
``a1`` with ``random_state`` 0..N-1 and prints the coefficient of
variation of ``identifiability_`` over the refits.

Usage::

    python -m validation.studies.identifiability --n-seeds 30 --n-jobs 2 \\
        --stability 10

Quoted in ``docs/validity.rst`` ("Does the warning mean what it says?").
"""

from __future__ import annotations

import argparse
import time
import warnings
from functools import partial

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import ModularBayesCalibrator
from skmba.exceptions import NonIdentifiabilityWarning
from validation.cases import CASES, case_freq, case_freq_offset
from validation.statistics import wilson_interval

#: (label, builder, indices of the parameters the warning should name).
VARIANTS = [
    *[
        (
            f"freq, {name}, {snr:g} dB",
            partial(case_freq, amplitude=amplitude, snr_db=snr),
            (),
        )
        for name, amplitude in (("no discrepancy", 0.0), ("0.1 x^2", 0.1))
        for snr in (10.0, 30.0, 50.0)
    ],
    *[
        (case, CASES[case].build, tuple(range(len(CASES[case].parameter_names))))
        for case in ("a1", "b1", "c1", "c3", "a2", "b2")
    ],
    # Two parameters, one confounded: the offset, not the frequency.
    *[
        (f"freq + offset, {name}", partial(case_freq_offset, amplitude=a), (1,))
        for name, a in (("no discrepancy", 0.0), ("0.1 x^2", 0.1))
    ],
]
#: Seed-0 data refitted with other calibrator seeds (``--stability``).
STABILITY = {
    "freq, no discrepancy, 50 dB": VARIANTS[2][1],
    "a1": CASES["a1"].build,
}


def fit(builder, seed, random_state):
    """``identifiability_``, the indices of the parameters the warning named
    and the parameters' names."""
    data = builder(seed)
    cal = ModularBayesCalibrator(prior=data.prior, random_state=random_state, n_jobs=1)
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        cal.fit(data.X, data.y, X_sim=data.X_sim, theta_sim=data.theta_sim,
                y_sim=data.y_sim)  # fmt: skip
    names = cal.parameter_names_
    texts = [
        str(m.message) for m in w if issubclass(m.category, NonIdentifiabilityWarning)
    ]
    named = tuple(j for j, n in enumerate(names) if any(f"{n} (" in t for t in texts))
    return np.asarray(cal.identifiability_, dtype=float), named, tuple(names)


def _rate_line(label, results, expected):
    """One variant's line: warning rate (Wilson 95 %), right names, ratio."""
    n = len(results)
    warned = sum(bool(named) for _, named, _ in results)
    lo, hi = wilson_interval(warned, n)
    names = results[0][2]
    right = sum(set(named) == set(expected) for _, named, _ in results)
    ratio = np.array([values for values, _, _ in results])
    med = ", ".join(
        f"{name} {np.median(ratio[:, j]):.3g} [{ratio[:, j].min():.3g}, "
        f"{ratio[:, j].max():.3g}]"
        for j, name in enumerate(names)
    )
    should = "should warn" if expected else "should not"
    return (
        f"{label:32s} {should:11s} warned {warned:3d}/{n} "
        f"[{lo:.2f}, {hi:.2f}]  named right {right:3d}/{n}  "
        f"identifiability_ median [min, max]: {med}"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.identifiability",
        description=__doc__.split("\n")[0],
    )
    parser.add_argument("--n-seeds", type=int, default=30)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--stability", type=int, default=0, metavar="N")
    parser.add_argument(
        "--only", default=None, help="comma-separated labels' prefixes (e.g. freq)"
    )
    args = parser.parse_args(argv)
    variants = [
        v
        for v in VARIANTS
        if args.only is None or any(v[0].startswith(p) for p in args.only.split(","))
    ]
    started = time.perf_counter()
    tasks = [(v, seed) for v in variants for seed in range(args.n_seeds)]
    out = Parallel(n_jobs=args.n_jobs)(
        delayed(fit)(v[1], seed, seed) for v, seed in tasks
    )
    print(f"{args.n_seeds} seeds per variant, defaults, random_state = seed")
    for k, (label, _, expected) in enumerate(variants):
        results = out[k * args.n_seeds : (k + 1) * args.n_seeds]
        print(_rate_line(label, results, expected))
    if args.stability:
        print(f"seed 0's data, random_state 0..{args.stability - 1}:")
        for label, builder in STABILITY.items():
            refits = Parallel(n_jobs=args.n_jobs)(
                delayed(fit)(builder, 0, rs) for rs in range(args.stability)
            )
            ratio = np.array([values for values, _, _ in refits])
            cv = ratio.std(axis=0, ddof=1) / ratio.mean(axis=0)
            print(
                f"  {label:30s} identifiability_ mean {ratio.mean(axis=0)}, "
                f"coefficient of variation {cv}"
            )
    print(f"wall time {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
