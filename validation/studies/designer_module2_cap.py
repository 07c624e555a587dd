"""Does the designer's cap on module 2's iterations move its scores?

Phase 1 of ``PreposteriorDesigner`` fits module 2 once per replicate by
L-BFGS-B from the hyperparameters that generated the replicate, for at most
``module2_max_iter`` iterations (200 by default). On the nine-gauge truss
(55 hyperparameters: a 9 x 9 discrepancy covariance, nine noise variances,
one roughness) every search reaches the cap; without it a search stops
after 700-3,200 evaluations. This study refits the same designer, on the
same replicates, with each cap of ``--max-iter`` (``None``: to convergence,
the reference) and compares what a user reads: the scores and the best
subset of each size.

Set-up: the nine strain gauges of ``make_truss_bridge(30, random_state=0)``,
all 511 subsets, ``calibrator=ModularBayesCalibrator(n_restarts_optimizer=0)``
(one search per replicate), ``--n-mc`` replicates, ``random_state=0``, for
each ``--n-design``. Printed per design size and cap: the fit's time and
phase 1's; against the reference (the same replicates: the differences are
paired), the rms and largest relative change of the scores, the median and
largest change in units of the reference score's Monte Carlo standard error
(``scores_mcse_``), their mean change in those units (a shift common to the
subsets, which more replicates do not average away), the Spearman
correlation of the scores, and the sizes whose best subset differs.

Usage::

    python -m validation.studies.designer_module2_cap --n-design 12 \\
        --max-iter 50,100,200,None --n-mc 40 --n-jobs 2

The result is quoted in ``docs/sensor_design.rst`` (section "Run time").
"""

import argparse
import io
import re
import time
import warnings
from contextlib import redirect_stderr

import numpy as np

from validation.studies.designer_quadrature import compare, truss_designer


def _fit(n_design, max_iter, n_mc, n_jobs):
    """The designer fitted with ``module2_max_iter=max_iter``, its time and
    phase 1's (from its ``verbose=1`` lines)."""
    designer, data = truss_designer(
        n_design, n_mc, n_jobs, verbose=1, module2_max_iter=max_iter
    )
    log = io.StringIO()
    started = time.perf_counter()
    with warnings.catch_warnings(), redirect_stderr(log):
        warnings.simplefilter("ignore")
        designer.fit(np.hstack([data.X_sim, data.theta_sim]), data.y_sim)
    seconds = time.perf_counter() - started
    marks = {}
    for line in log.getvalue().splitlines():
        for step in ("step 1", "phase 1"):
            match = re.search(rf"\] {step}\b.*\(([0-9.]+) s\)\s*$", line)
            if match:
                marks[step] = float(match.group(1))
    return designer, seconds, marks["phase 1"] - marks["step 1"]


def shift(designer, reference):
    """Median, largest and mean change of the scores in the reference's
    Monte Carlo standard errors."""
    z = (designer.scores_ - reference.scores_) / reference.scores_mcse_
    return float(np.median(np.abs(z))), float(np.max(np.abs(z))), float(np.mean(z))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-design", default="12")
    parser.add_argument("--max-iter", default="50,100,200,None")
    parser.add_argument("--n-mc", type=int, default=40)
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args(argv)
    caps = [None if k == "None" else int(k) for k in args.max_iter.split(",")]
    if None not in caps:
        caps.append(None)
    print(
        f"truss, 9 gauges, 511 subsets x {args.n_mc} replicates, n_jobs="
        f"{args.n_jobs}; reference: module 2 to convergence (None)"
    )
    print(
        "n_design | cap | fit s | phase 1 s | scores vs reference: rms rel, "
        "max rel | in mcse: median, max, mean | Spearman | sizes with "
        "another best subset"
    )
    for n_design in (int(k) for k in args.n_design.split(",")):
        fits = {cap: _fit(n_design, cap, args.n_mc, args.n_jobs) for cap in caps}
        reference = fits[None][0]
        for cap, (designer, seconds, phase1) in fits.items():
            c = compare(designer, reference)
            median, top, mean = shift(designer, reference)
            print(
                f"{n_design} | {cap} | {seconds:.1f} | {phase1:.1f} | "
                f"{c['rms']:.4f}, {c['max']:.4f} | {median:.2f}, {top:.2f}, "
                f"{mean:+.2f} | {c['spearman']:.4f} | {c['sizes'] or '-'}",
                flush=True,
            )


if __name__ == "__main__":
    main()
