"""Does the designer predict the calibrator's identifiability warning?

Issue 31 asks the sensor designer to say, before any measurement, which
response subsets will let the calibrator identify theta. For each subset
:class:`~skmba.PreposteriorDesigner` applies the calibrator's diagnosis to
every Monte Carlo replicate (``identifiability_``, ``warning_rate_``); it
predicts a warning where ``warning_rate_`` is at least one half. This study
checks the prediction against the calibrator itself, under the same
module-2 treatment (the calibrator's default, ``"propagate"``), on field
data drawn from the priors the designer assumes (E* or theta* from its
prior, one discrepancy function and the noise from the calibrator's
default hyperprior, as in :mod:`validation.sbc_cases`), at the designer's
field design:

1. ``cantilever``: the fixed-support beam of section 4.7 (E only) with its
   five candidate responses (tip displacement A, energy B, tip rotation
   C, mid-span D and quarter-span E displacement), 54 simulations, a
   Latin hypercube of 25 forces; every subset of at most three responses.
   Per (subset, seed): does the calibrator warn, and did the designer
   predict it?
2. ``freq + offset`` (:func:`validation.cases.case_freq_offset`'s model,
   simulations and prior): one response, two parameters, the frequency
   identifiable and the offset absorbed by the discrepancy's constant
   mean. Per (parameter, seed): does the warning name the parameter, and
   did the designer predict it (``warning_rate_`` at least one half)?

It prints the agreement with its Wilson 95 % interval, and per subset the
designer's warning rate beside the calibrator's observed one.

Usage::

    python -m validation.studies.designer_identifiability --n-seeds 20 --n-jobs 2

Quoted in ``docs/validity.rst`` ("Predicting the warning").
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed

from skmba import PreposteriorDesigner
from skmba.calibration._module3_identifiability import IDENTIFIABILITY_THRESHOLD
from skmba.datasets import make_cantilever
from skmba.exceptions import NonIdentifiabilityWarning
from validation.cases import (
    CANTILEVER_X_BOUNDS,
    UNIT_X_BOUNDS,
    case_freq_offset,
    offset_model,
)
from validation.sbc_cases import draw_field_data
from validation.statistics import wilson_interval
from validation.studies.designer_vs_calibrator import fit_subset

RESPONSES = (
    "tip_displacement",
    "energy",
    "tip_rotation",
    "mid_displacement",
    "quarter_displacement",
)
LETTERS = "ABCDE"
N_SIM, N_DESIGN, MAX_SIZE = 54, 25, 3
OFFSET_NAMES = ("frequency", "offset")


class Problem:
    """A design's simulations, prior, model and input bounds (fixed over
    seeds)."""

    def __init__(self, name):
        self.name = name
        if name == "cantilever":
            data = make_cantilever(
                N_SIM,
                N_DESIGN,
                responses=RESPONSES,
                spring_stiffness=np.inf,
                snr_db=None,
                random_state=0,
            )
            self.model, self.bounds = data.simulator, CANTILEVER_X_BOUNDS
            self.max_size = MAX_SIZE
        else:
            data = case_freq_offset(0)
            self.model, self.bounds = offset_model, UNIT_X_BOUNDS
            self.max_size = None
        self.X_sim, self.theta_sim = data.X_sim, data.theta_sim
        self.y_sim, self.prior = data.y_sim, data.prior

    def subsets(self):
        q = self.y_sim.shape[1]
        top = self.max_size or q
        return [
            s for k in range(1, top + 1) for s in itertools.combinations(range(q), k)
        ]

    def theta(self, seed):
        rng = np.random.default_rng([int(seed), 2])
        return np.array([p.rvs(random_state=rng) for p in self.prior])


def run_designer(problem, n_mc, n_jobs):
    """The designer's prediction: ``{subset: (warning rates, median
    ratios)}``, per parameter, and its field design."""
    X = np.hstack([problem.X_sim, problem.theta_sim])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        designer = PreposteriorDesigner(
            problem.prior,
            discrepancy_uncertainty="propagate",  # the calibrator's default
            n_design=N_DESIGN,
            max_responses=problem.max_size,
            n_mc=n_mc,
            n_jobs=n_jobs,
            random_state=0,
        ).fit(X, problem.y_sim)
    out = {
        s: (rate, ratio)
        for s, rate, ratio in zip(
            designer.subsets_,
            designer.warning_rate_,
            designer.identifiability_,
            strict=True,
        )
    }
    return out, designer.X_design_


def one_seed(problem, seed, X_field):
    """Per subset: the parameters the calibrator's warning names (never
    raises: a failed fit is recorded)."""
    theta = problem.theta(seed)
    _, y, _ = draw_field_data(
        seed, problem.model, theta, X_field, problem.prior, problem.bounds
    )
    out = []
    with threadpoolctl.threadpool_limits(1):
        for subset in problem.subsets():
            cols = list(subset)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    cal = fit_subset(problem, X_field, y, cols, seed)
                except Exception as exc:  # a failed fit is a result
                    out.append({"subset": subset, "error": repr(exc)})
                    continue
            warned = any(
                issubclass(w.category, NonIdentifiabilityWarning) for w in caught
            )
            named = tuple(
                np.flatnonzero(cal.identifiability_ < IDENTIFIABILITY_THRESHOLD)
            )
            out.append(
                {"subset": subset, "warned": warned, "named": named, "error": ""}
            )
    return out


def cantilever_table(records, predicted):
    """Per subset: predicted and observed warning rates; the agreement."""
    lines = [
        f"{'subset':<8}{'predicted rate':>15}{'predicts':>10}{'warned':>9}"
        f"{'Wilson 95 %':>16}{'agree':>7}",
        "-" * 65,
    ]
    total = agree = 0
    for subset, (rates, _) in predicted.items():
        rate = rates[0]  # E only
        ok = [r for r in records if r["subset"] == subset and not r["error"]]
        k = sum(r["warned"] for r in ok)
        warns = rate >= 0.5
        same = sum(r["warned"] == warns for r in ok)
        total, agree = total + len(ok), agree + same
        low, high = wilson_interval(k, len(ok))
        name = "".join(LETTERS[i] for i in subset)
        lines.append(
            f"{name:<8}{rate:>15.2f}{'warn' if warns else 'quiet':>10}"
            f"{f'{k}/{len(ok)}':>9}{f'[{low:.2f}, {high:.2f}]':>16}{same:>7}"
        )
    lines.append(_agreement(agree, total, "subset"))
    return "\n".join(lines), agree, total


def offset_table(records, predicted):
    """Per parameter: the designer's warning rate and median ratio, how
    often the warning named it; the agreement over (parameter, seed)
    pairs."""
    ((rates, ratio),) = predicted.values()
    ok = [r for r in records if not r["error"]]
    lines = []
    total = agree = 0
    for j, name in enumerate(OFFSET_NAMES):
        flagged = rates[j] >= 0.5
        k = sum(j in r["named"] for r in ok)
        same = sum((j in r["named"]) == flagged for r in ok)
        total, agree = total + len(ok), agree + same
        low, high = wilson_interval(k, len(ok))
        lines.append(
            f"{name:<10} predicted rate {rates[j]:.2f} (identifiability "
            f"{ratio[j]:.3f}: {'names' if flagged else 'quiet'}); named "
            f"{k}/{len(ok)} [{low:.2f}, {high:.2f}]; agree {same}/{len(ok)}"
        )
    lines.append(_agreement(agree, total, "parameter"))
    return "\n".join(lines), agree, total


def _agreement(agree, total, what):
    """The agreement line: its count, rate and Wilson 95 % interval."""
    low, high = wilson_interval(agree, total)
    return (
        f"agreement over ({what}, seed) pairs: {agree}/{total} = "
        f"{agree / total:.3f} [{low:.3f}, {high:.3f}]"
    )


def run(design, n_seeds, n_mc, n_jobs, first_seed=0):
    """The study on one design; returns (printed table, agree, total, failed)."""
    problem = Problem(design)
    predicted, X_field = run_designer(problem, n_mc, n_jobs)
    seeds = range(first_seed, first_seed + n_seeds)
    parts = Parallel(n_jobs=n_jobs)(
        delayed(one_seed)(problem, seed, X_field) for seed in seeds
    )
    records = [r for part in parts for r in part]
    failed = sum(bool(r["error"]) for r in records)
    if design == "cantilever":
        text, agree, total = cantilever_table(records, predicted)
    else:
        text, agree, total = offset_table(records, predicted)
    return text, agree, total, failed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-seeds", type=int, default=20)
    parser.add_argument("--n-mc", type=int, default=50)
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--designs", default="cantilever,offset")
    args = parser.parse_args(argv)
    for design in args.designs.split(","):
        started = time.perf_counter()
        text, _, _, failed = run(design, args.n_seeds, args.n_mc, args.n_jobs)
        print(f"\n== {design}: {args.n_seeds} seeds, designer n_mc={args.n_mc} ==")
        print(text)
        print(f"failed fits: {failed}; {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
