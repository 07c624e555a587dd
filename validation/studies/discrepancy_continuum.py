"""A continuum of discrepancies from a1 to c3, and designs beyond one input,
two responses and two parameters (issue 31, item 5).

Part 1, the continuum (cells labelled ``continuum <size> c3 / <alpha> deg /
<snr> dB``): on the cantilever's a1 design, reality is the model at E* =
70 GPa plus a discrepancy of ``size`` times c3's (0.315 of the response,
rms) in the direction ``alpha`` between ``s_in``, the model's sensitivity
to E (inside the span of theta's sensitivities: it mimics a change of E;
``alpha = 0`` at size 1 is c3), and ``s_out``, a half-sine bump in F
orthogonal to it over the field inputs (outside the span, 90 deg); see
:func:`validation.continuum_cases.case_continuum`. Grid: size 0 (a1);
sizes 0.05, 0.25 and 1 at 0, 45 and 90 deg, at 30 dB; size 1 at 0 and 90
deg at 10 and 50 dB. Per seed, the calibrator with its defaults
(``random_state`` the seed) and with ``estimand="best_fit"``. Printed per
cell: how often the physical 95 % interval covers E* and the best fit's
covers E_eff (the least-squares fit of the exact model to the noise-free
reality at the field inputs, each response in its simulations' spread,
within the simulated range, by ``scipy.optimize.least_squares``), with
Wilson 95 % intervals; the rms z of each with a bootstrap 95 % interval;
the warning rate of the default fit (Wilson) and the median of its
``identifiability_`` with the order-statistic 95 % interval; the median
E_eff; how often the best fit's interval covers the emulator-mean best fit
of :func:`validation.studies.best_fit.best_fit_truth` (the estimand as the
calibrator defines it, through the emulator) and the median distance
between the two best fits, in best-fit sds.

Part 2, the larger designs (``design <name>``, from
:data:`validation.continuum_cases.DESIGN_CASES`): two inputs, four
responses, three parameters. Per case, the default fit's coverage of
theta* per parameter (Wilson), rms z (bootstrap), the warning rate, how
often the warning named exactly the parameters the design confounds, and
how often each parameter was named.

The same seed gives the same data and fits whatever ``--n-jobs``; BLAS is
limited to one thread per fit; warnings are captured per fit.

Usage::

    PYTHONPATH=. python -m validation.studies.discrepancy_continuum \\
        --n-seeds 20 --design-seeds 40 --n-jobs 1 [--only "continuum 1 c3 / 0 deg"]

(``--only``: comma-separated substrings of the labels). Quoted in
``docs/validity.rst`` ("A continuum of discrepancies").
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import threadpoolctl
from joblib import Parallel, delayed
from scipy import optimize, stats

from skmba import ModularBayesCalibrator
from skmba.datasets import CantileverModel
from skmba.exceptions import NonIdentifiabilityWarning
from validation.continuum_cases import DESIGN_CASES, case_continuum
from validation.statistics import LEVEL, rms, wilson_interval
from validation.studies.best_fit import best_fit_truth

#: (size in c3's units, alpha in degrees, SNR in dB) of part 1.
CELLS = [
    (0.0, 0.0, 30.0),
    *[(s, a, 30.0) for s in (0.05, 0.25, 1.0) for a in (0.0, 45.0, 90.0)],
    *[(1.0, a, snr) for a in (0.0, 90.0) for snr in (10.0, 50.0)],
]


def cell_label(cell):
    size, alpha, snr = cell
    return f"continuum {size:g} c3 / {alpha:g} deg / {snr:g} dB"


def design_label(name):
    return f"design {name}"


# --------------------------------------------------------------------------
# one fit, one replicate
# --------------------------------------------------------------------------


def fit(data, seed, estimand="physical"):
    """The fitted calibrator and the indices of the parameters its
    :class:`NonIdentifiabilityWarning` named."""
    cal = ModularBayesCalibrator(
        prior=data.prior, random_state=seed, estimand=estimand, n_jobs=1
    )
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        cal.fit(data.X, data.y, X_sim=data.X_sim, theta_sim=data.theta_sim,
                y_sim=data.y_sim)  # fmt: skip
    texts = [
        str(m.message) for m in w if issubclass(m.category, NonIdentifiabilityWarning)
    ]
    names = cal.parameter_names_
    named = tuple(j for j, n in enumerate(names) if any(f"{n} (" in t for t in texts))
    return cal, named


def scores(cal, truth):
    """Whether the central 95 % interval covers ``truth``, and its z-score."""
    tail = (1 - LEVEL) / 2
    low, high = np.quantile(cal.theta_samples_, [tail, 1 - tail], axis=0)
    sd = np.sqrt(np.diag(cal.theta_cov_))
    truth = np.asarray(truth, dtype=float)
    return (low <= truth) & (truth <= high), (cal.theta_mean_ - truth) / sd


def exact_best_fit(X, reality, y_scale, bounds):
    """E_eff: the least-squares fit of the exact cantilever model to
    ``reality`` at ``X`` (each response divided by ``y_scale``) within
    ``bounds`` = (lo, hi), from the best of a 201-point grid."""
    model, target = CantileverModel(), reality(X)

    def residuals(E):
        return ((model(X, [E[0]]) - target) / y_scale).ravel()

    grid = np.linspace(bounds[0], bounds[1], 201)
    start = grid[np.argmin([np.sum(residuals([E]) ** 2) for E in grid])]
    return optimize.least_squares(
        residuals, [start], bounds=bounds, x_scale=[start], xtol=1e-14
    ).x[0]


def continuum_replicate(cell, seed):
    """One seed of a continuum cell: a dict of scalars."""
    size, alpha, snr = cell
    data = case_continuum(seed, size=size, alpha_deg=alpha, snr_db=snr)
    physical, named = fit(data, seed)
    best, _ = fit(data, seed, "best_fit")
    theta_sim = np.asarray(best.theta_sim_, dtype=float)[:, 0]
    bounds = (theta_sim.min(), theta_sim.max())
    E_eff = exact_best_fit(data.X, data.reality_fn, best.y_scale_, bounds)
    emulator_fit = best_fit_truth(best, data.X, data.reality_fn(data.X))[0]
    phys_cov, phys_z = scores(physical, data.theta_true)
    best_cov, best_z = scores(best, [E_eff])
    emulator_cov, _ = scores(best, [emulator_fit])
    return {
        "physical_covered": bool(phys_cov[0]),
        "physical_z": float(phys_z[0]),
        "best_covered": bool(best_cov[0]),
        "best_z": float(best_z[0]),
        "warned": bool(named),
        "identifiability": float(physical.identifiability_[0]),
        "E_eff": float(E_eff),
        "emulator_covered": bool(emulator_cov[0]),
        "emulator_shift": float(
            abs(emulator_fit - E_eff) / np.sqrt(best.theta_cov_[0, 0])
        ),
    }


def design_replicate(name, seed):
    """One seed of a larger design: per-parameter arrays and the names."""
    data = DESIGN_CASES[name].build(seed)
    cal, named = fit(data, seed)
    covered, z = scores(cal, data.theta_true)
    return {
        "covered": covered,
        "z": z,
        "named": named,
        "identifiability": np.asarray(cal.identifiability_, dtype=float),
    }


# --------------------------------------------------------------------------
# summaries
# --------------------------------------------------------------------------


def rms_interval(z, n_boot=2000):
    """The rms of ``z`` and its percentile-bootstrap 95 % interval (seeded)."""
    z = np.asarray(z, dtype=float)
    rng = np.random.default_rng(0)
    boot = rms(z[rng.integers(0, len(z), size=(n_boot, len(z)))].T)
    lo, hi = np.quantile(boot, [(1 - LEVEL) / 2, (1 + LEVEL) / 2])
    return float(rms(z)), float(lo), float(hi)


def median_interval(values):
    """The median and its distribution-free (order-statistic) 95 % interval."""
    values = np.asarray(values, dtype=float)
    med = float(np.median(values))
    ci = stats.quantile_test(values, q=med, p=0.5).confidence_interval(LEVEL)
    return med, float(ci.low), float(ci.high)


def fmt_count(k, n):
    lo, hi = wilson_interval(k, n)
    return f"{k}/{n} [{lo:.2f}, {hi:.2f}]"


def fmt_rms(z):
    value, lo, hi = rms_interval(z)
    return f"{value:.2f} [{lo:.2f}, {hi:.2f}]"


def continuum_line(cell, results):
    """One cell's line of part 1."""
    table = {k: np.array([r[k] for r in results]) for k in results[0]}
    n = len(results)
    med, lo, hi = median_interval(table["identifiability"])
    return (
        f"{cell_label(cell):34s} E* covered "
        f"{fmt_count(table['physical_covered'].sum(), n)} rms z "
        f"{fmt_rms(table['physical_z'])} | E_eff "
        f"{np.median(table['E_eff']) / 1e3:.2f} GPa covered "
        f"{fmt_count(table['best_covered'].sum(), n)} rms z "
        f"{fmt_rms(table['best_z'])} | warned {fmt_count(table['warned'].sum(), n)}"
        f" identifiability_ {med:.3f} [{lo:.3f}, {hi:.3f}] | emulator-mean best "
        f"fit covered {fmt_count(table['emulator_covered'].sum(), n)}, "
        f"{np.median(table['emulator_shift']):.2f} sd from E_eff (median)"
    )


def design_lines(name, results):
    """A larger design's lines of part 2."""
    spec = DESIGN_CASES[name]
    n = len(results)
    warned = sum(bool(r["named"]) for r in results)
    right = sum(set(r["named"]) == set(spec.confounded) for r in results)
    lines = [
        f"{design_label(name)}: {spec.description}; should name "
        f"{[spec.parameter_names[j] for j in spec.confounded] or 'none'}: warned "
        f"{fmt_count(warned, n)}, named exactly those {fmt_count(right, n)}"
    ]
    covered = np.array([r["covered"] for r in results])
    z = np.array([r["z"] for r in results])
    ratio = np.array([r["identifiability"] for r in results])
    for j, pname in enumerate(spec.parameter_names):
        times = sum(j in r["named"] for r in results)
        med, lo, hi = median_interval(ratio[:, j])
        lines.append(
            f"  {pname:10s} theta* covered {fmt_count(covered[:, j].sum(), n)} rms z "
            f"{fmt_rms(z[:, j])} mean z {z[:, j].mean():+.2f}; named {times}/{n}; "
            f"identifiability_ {med:.3f} [{lo:.3f}, {hi:.3f}]"
        )
    return lines


def selected(labels, only):
    """The labels containing one of ``only``'s comma-separated substrings."""
    if only is None:
        return list(labels)
    return [lab for lab in labels if any(p in lab for p in only.split(","))]


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m validation.studies.discrepancy_continuum",
        description=__doc__.split("\n")[0],
    )
    parser.add_argument("--n-seeds", type=int, default=20, help="per continuum cell")
    parser.add_argument("--design-seeds", type=int, default=40, help="per design")
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--only", default=None, help="substrings of the labels")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    cells = [c for c in CELLS if selected([cell_label(c)], args.only)]
    names = [n for n in DESIGN_CASES if selected([design_label(n)], args.only)]
    tasks = [(continuum_replicate, c, s) for c in cells for s in range(args.n_seeds)]
    tasks += [(design_replicate, n, s) for n in names for s in range(args.design_seeds)]
    out = Parallel(n_jobs=args.n_jobs)(delayed(f)(key, s) for f, key, s in tasks)
    print(f"defaults, random_state = seed; {args.n_seeds} seeds per continuum "
          f"cell, {args.design_seeds} per design")  # fmt: skip
    for k, cell in enumerate(cells):
        print(continuum_line(cell, out[k * args.n_seeds : (k + 1) * args.n_seeds]))
    rest = out[len(cells) * args.n_seeds :]
    for k, name in enumerate(names):
        chunk = rest[k * args.design_seeds : (k + 1) * args.design_seeds]
        print("\n".join(design_lines(name, chunk)))
    print(f"wall time {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
