"""Is the designer's quadrature over theta fine enough for large designs?

``PreposteriorDesigner`` computes each (subset, replicate) posterior of
theta by a two-stage quadrature (:mod:`skmba.sensor_design._posterior_moments`)
whose first stage is the prior's rule of ``PRIOR_NODES`` nodes
(:mod:`skmba.sensor_design._replicates`), 33 Gauss-Legendre nodes for one
parameter. This study refits the same designer, on the same replicates,
with more stage-1 nodes and compares what a user reads: the scores and the
best subset of each size.

Set-up: the nine strain gauges of ``make_truss_bridge(30, random_state=0)``
(one parameter), all 511 subsets, ``--n-mc`` replicates, ``random_state=0``,
for each ``--n-design`` (field temperatures) and each ``--nodes`` count.
The largest count is the reference. Printed per design size and node count:
the fit's time; against the reference, the rms and the largest relative
change of the scores, the largest change in units of the score's own Monte
Carlo standard error (``scores_mcse_``), the Spearman correlation of the
scores, and the sizes whose best subset differs.

``--dense-check K`` instead checks single posteriors: one fit per design
size with 4 replicates in this process, and at every K-th (subset,
replicate) pair the designer's posterior mean and variance of theta
against a dense grid of 2,001 points over the prior's nodes' span (the
pairs whose posterior the grid resolves, ten points per sd or more).
Printed: the rms and largest error of the mean in posterior sds and of
the variance relative to the grid's.

Usage::

    python -m validation.studies.designer_quadrature --n-design 12,60 \\
        --nodes 33,129,257 --n-mc 20 --n-jobs 2
    python -m validation.studies.designer_quadrature --n-design 12,60 \\
        --dense-check 10

The result is quoted in ``docs/sensor_design.rst`` (section "Phases 1 and
2, and fast").
"""

import argparse
import time
import warnings

import numpy as np
from scipy import stats

import skmba.sensor_design._replicates as replicates_module
import skmba.sensor_design._scoring as scoring_module
from skmba import ModularBayesCalibrator, PreposteriorDesigner
from skmba.datasets import make_truss_bridge

GAUGES = ("SA", "SB", "SC", "SD", "SE", "SF", "SG", "SH", "SI")


def truss_designer(n_design, n_mc, n_jobs, **options):
    """The studies' designer on the nine truss gauges (one search per
    replicate, ``random_state=0``; ``options``: other designer parameters)
    and the truss's data."""
    data = make_truss_bridge(30, sensors=list(GAUGES), random_state=0)
    designer = PreposteriorDesigner(
        data.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        n_design=n_design,
        n_mc=n_mc,
        n_jobs=n_jobs,
        random_state=0,
        **options,
    )
    return designer, data


def _fit(n_design, n_nodes, n_mc, n_jobs):
    """The designer fitted with ``n_nodes`` stage-1 nodes, and its time."""
    designer, data = truss_designer(n_design, n_mc, n_jobs)
    saved = dict(replicates_module.PRIOR_NODES)
    replicates_module.PRIOR_NODES["one"] = n_nodes  # read in the main process
    started = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            designer.fit(np.hstack([data.X_sim, data.theta_sim]), data.y_sim)
    finally:
        replicates_module.PRIOR_NODES.update(saved)
    return designer, time.perf_counter() - started


def _best_by_size(designer):
    """The best subset of each size."""
    sizes = np.array([len(s) for s in designer.subsets_])
    return {
        int(k): designer.subsets_[
            np.flatnonzero(sizes == k)[np.argmin(designer.scores_[sizes == k])]
        ]
        for k in np.unique(sizes)
    }


def compare(designer, reference):
    """Scores of ``designer`` against ``reference`` (same subsets, same
    replicates): rms and largest relative change, largest change in
    reference standard errors, Spearman correlation, sizes whose best subset
    differs."""
    s, ref = designer.scores_, reference.scores_
    relative = s / ref - 1.0
    best, best_ref = _best_by_size(designer), _best_by_size(reference)
    return {
        "rms": float(np.sqrt(np.mean(relative**2))),
        "max": float(np.max(np.abs(relative))),
        "in_mcse": float(np.max(np.abs(s - ref) / reference.scores_mcse_)),
        "spearman": float(stats.spearmanr(s, ref).statistic),
        "sizes": [k for k in best if best[k] != best_ref[k]],
    }


def dense_check(n_design, every):
    """Errors (pairs, 2) of the mean (in sds) and of the variance (relative)
    of every ``every``-th posterior of a 4-replicate fit, against a grid."""
    moments = scoring_module.posterior_moments
    calls, errors = [0], []

    def checked(log_likelihood, prior, nodes, weights, at_nodes, **kwargs):
        mean, cov = moments(log_likelihood, prior, nodes, weights, at_nodes, **kwargs)
        calls[0] += 1
        if (calls[0] - 1) % every == 0:
            grid = np.linspace(nodes.min(), nodes.max(), 2001)[:, None]
            # in chunks: at 60 temperatures one stack of 2,001 would take GiBs
            log_p = np.concatenate(
                [log_likelihood(grid[i : i + 100]) for i in range(0, len(grid), 100)]
            ) + prior.logpdf(grid)
            w = np.exp(log_p - log_p.max())
            w /= w.sum()
            mu = w @ grid[:, 0]
            var = w @ (grid[:, 0] - mu) ** 2
            if 10 * (grid[1, 0] - grid[0, 0]) < np.sqrt(var):
                errors.append(((mean[0] - mu) / np.sqrt(var), cov[0, 0] / var - 1))
        return mean, cov

    scoring_module.posterior_moments = checked
    try:
        _fit(n_design, replicates_module.PRIOR_NODES["one"], 4, 1)
    finally:
        scoring_module.posterior_moments = moments
    return np.array(errors), calls[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-design", default="12,60")
    parser.add_argument("--nodes", default="33,129,257")
    parser.add_argument("--n-mc", type=int, default=20)
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--dense-check", type=int, default=None)
    args = parser.parse_args(argv)
    if args.dense_check is not None:
        print(
            "n_design | pairs checked | mean error (sds): rms, largest | "
            "variance error: rms, largest"
        )
        for n_design in (int(k) for k in args.n_design.split(",")):
            e, n = dense_check(n_design, args.dense_check)
            rms, top = np.sqrt(np.mean(e**2, axis=0)), np.max(np.abs(e), axis=0)
            print(
                f"{n_design} | {len(e)} of {n} | {rms[0]:.4f}, {top[0]:.3f} | "
                f"{rms[1]:.4f}, {top[1]:.3f}",
                flush=True,
            )
        return
    counts = sorted(int(k) for k in args.nodes.split(","))
    print(
        f"truss, 9 gauges, 511 subsets x {args.n_mc} replicates, n_jobs="
        f"{args.n_jobs}; reference: {counts[-1]} stage-1 nodes"
    )
    print(
        "n_design | nodes | fit s | scores vs reference: rms rel, max rel, "
        "max in mcse, Spearman | sizes with another best subset"
    )
    for n_design in (int(k) for k in args.n_design.split(",")):
        fits = {k: _fit(n_design, k, args.n_mc, args.n_jobs) for k in counts}
        reference = fits[counts[-1]][0]
        for k, (designer, seconds) in fits.items():
            c = compare(designer, reference)
            print(
                f"{n_design} | {k} | {seconds:.1f} | {c['rms']:.4f}, "
                f"{c['max']:.4f}, {c['in_mcse']:.2f}, {c['spearman']:.4f} | "
                f"{c['sizes'] or '-'}",
                flush=True,
            )


if __name__ == "__main__":
    main()
