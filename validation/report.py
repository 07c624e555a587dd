"""The output of the validity suite: printed tables, files, rank histograms.

- :func:`format_tables`: the two tables that ``python -m validation`` prints
  (results, details) and the warning messages, from
  :func:`validation.statistics.summarise`;
- :func:`provenance`: the header line of the stored files (git commit,
  date, command);
- :func:`save_records`: ``replicates.csv`` (replicate x parameter, after
  that header line) and ``replicates.npz`` (per-case arrays);
- :func:`plot_ranks` and :func:`combined_ranks`: the rank histograms
  ``validity_ranks.png``, of one run or of several (``--combine``).

Callers: :mod:`validation.__main__` and ``tests/validation/test_suite.py``.
"""

from __future__ import annotations

import csv
import datetime
import subprocess
from collections import Counter
from pathlib import Path

import numpy as np
from scipy import stats

from validation.statistics import N_RANK, RECORD_ARRAYS, rank_histogram, rank_tests
from validation.suite import registry

ROOT = Path(__file__).resolve().parents[1]

_RESULTS_HEAD = (
    f"{'case':<7} {'seeds':>5}  {'theta* covered':<14} "
    f"{'Wilson 95 %':<27} {'rms z':<11} {'SBC chi2 p':<16} "
    f"{'KS p':<16} {'ECDF 95 %':<10} {'reality':>7} {'new obs':>7}  warnings (seeds)"
)
_DETAILS_HEAD = (
    f"{'case':<7} {'mean z':<13} {'post. sd: median [max]':<34} "
    f"{'sd ~ prior':<10} {'noise_/true (median)':<21} "
    f"{'identifiability_':<17} "
    f"{'reality, new obs: 95 % CI':<27} {'one draw':<8} fit [s]"
)


def _band(inside):
    """``in``/``out`` per parameter: the rank ECDF inside its 95 % band."""
    words = {True: "in", False: "out"}
    return ", ".join(words.get(v, "-") if v == v else "-" for v in inside)


def _join(values, fmt):
    return ", ".join(format(v, fmt) for v in np.atleast_1d(values))


# --------------------------------------------------------------------------
# tables
# --------------------------------------------------------------------------


def _results_row(name, s):
    """One row of the results table."""
    if not s["n_ok"]:
        return f"{name:<7} {s['n']:>5}  all fits failed: {dict(s['errors'])}"
    n = s["n_ok"]
    covered = ", ".join(f"{k}/{n}" for k in s["covered"])
    wilson = ", ".join(f"[{lo:.2f}, {hi:.2f}]" for lo, hi in s["wilson"])
    warned = ", ".join(f"{c} {k}" for c, k in sorted(s["warnings"].items()))
    failed = f" (+{s['n_failed']} failed)" if s["n_failed"] else ""
    return (
        f"{name:<7} {n:>5}  {covered:<14} {wilson:<27} "
        f"{_join(s['rms_z'], '.2f'):<11} {_join(s['chi2_p'], '.2g'):<16} "
        f"{_join(s['ks_p'], '.2g'):<16} {_band(s['ecdf_inside']):<10} "
        f"{s['cover_reality']:>7.3f} "
        f"{s['cover_obs']:>7.3f}  {warned or '-'}{failed}"
    )


def _details_row(name, s):
    """One row of the details table (cases with at least one fit)."""
    sd_text = ", ".join(
        f"{m:.3g} [{x:.3g}]"
        for m, x in zip(s["theta_sd"], s["theta_sd_max"], strict=True)
    )
    ident = s["identifiability"]
    ident = "-" if np.all(np.isnan(ident)) else _join(ident, ".3g")
    ci = ", ".join(f"[{lo:.3f}, {hi:.3f}]" for lo, hi in s["cover_ci"])
    return (
        f"{name:<7} {_join(s['mean_z'], '+.2f'):<13} "
        f"{sd_text:<34} {_join(s['prior_like'], 'd'):<10} "
        f"{_join(s['noise_ratio'], '.2f'):<21} {ident:<17} "
        f"{ci:<27} {s['cover_obs_draw']:<8.3f} {s['fit_seconds']:.1f}"
    )


def format_tables(summary):
    """The two printed tables (results, details) as one string."""
    lines = [_RESULTS_HEAD, "-" * len(_RESULTS_HEAD)]
    lines += [_results_row(name, s) for name, s in summary.items()]
    lines += ["", _DETAILS_HEAD, "-" * len(_DETAILS_HEAD)]
    lines += [_details_row(name, s) for name, s in summary.items() if s["n_ok"]]
    messages = Counter()
    for s in summary.values():
        messages.update(s["messages"])
    if messages:
        lines += ["", "warning messages (replicates; numbers as #, first 90 chars):"]
        lines += [f"  {k:>4}  {m}" for m, k in messages.most_common()]
    errors = {n: dict(s["errors"]) for n, s in summary.items() if s["errors"]}
    if errors:
        lines += ["", f"failed fits: {errors}"]
    return "\n".join(lines)


# --------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------


def _git(*args):
    """The output of ``git args`` in the repository, or None."""
    try:
        done = subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def provenance(command=""):
    """The header line of the stored files: commit, date and ``command``.

    The commit is ``git rev-parse --short HEAD`` ("unknown" outside a git
    checkout), marked "with uncommitted changes" when ``skmba/`` or
    ``validation/`` (its ``results/`` aside) differ from it; the date is
    today's, local.
    """
    commit = _git("rev-parse", "--short", "HEAD") or "unknown"
    changed = _git(
        "status", "--porcelain", "--", "skmba", "validation", ":!validation/results"
    )
    if commit != "unknown" and changed:
        commit += " with uncommitted changes"
    line = (
        f"# skmba validity suite, commit {commit}, {datetime.date.today().isoformat()}"
    )
    return f"{line}: {command}" if command else line


_CSV_FIELDS = [
    "case", "seed", "parameter", "theta_true", "theta_mean", "theta_sd",
    "prior_sd", "lo", "hi", "covered", "z", "rank", "cover_reality", "cover_obs",
    "cover_obs_draw", "noise_ratio", "identifiability", "fit_seconds",
    "warnings", "error",
]  # fmt: skip


def _csv_rows(record, names):
    """The rows of one replicate in ``replicates.csv``, one per parameter."""
    r = record
    for j, p in enumerate(names):
        row = {"case": r["case"], "seed": r["seed"], "parameter": p}
        row["warnings"] = ";".join(sorted(set(r["warning_categories"])))
        row["error"] = r["error"]
        if r["ok"]:
            per_parameter = [*_CSV_FIELDS[3:12], "identifiability"]
            for k in per_parameter:
                row[k] = r[k][j]
            row["noise_ratio"] = _join(r["noise_ratio"], ".4g")
            for k in ("cover_reality", "cover_obs", "cover_obs_draw"):
                row[k] = r[k]
            row["fit_seconds"] = r["fit_seconds"]
        yield row


def save_records(records, out, header=None):
    """``replicates.csv`` (replicate x parameter) and ``replicates.npz``.

    The CSV starts with the line ``header`` (:func:`provenance` by default),
    a comment starting with ``#``: read it with
    ``pandas.read_csv(path, comment="#")`` or skip the first line.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    specs = registry()
    with open(out / "replicates.csv", "w", newline="") as fh:
        fh.write((provenance() if header is None else header) + "\n")
        writer = csv.DictWriter(fh, fieldnames=_CSV_FIELDS)
        writer.writeheader()
        for r in records:
            writer.writerows(_csv_rows(r, specs[r["case"]].parameter_names))
    arrays = {}
    for name in dict.fromkeys(r["case"] for r in records):
        ok = [r for r in records if r["case"] == name and r["ok"]]
        arrays[f"{name}__seed"] = np.array([r["seed"] for r in ok], dtype=int)
        for k in RECORD_ARRAYS:
            arrays[f"{name}__{k}"] = np.array([r[k] for r in ok])
    np.savez(out / "replicates.npz", **arrays)


# --------------------------------------------------------------------------
# rank histograms
# --------------------------------------------------------------------------


def plot_ranks(summary, path, n_rank=N_RANK):
    """Rank histograms, one panel per case and parameter, with the band of
    counts (grey) that a uniform histogram stays inside bin by bin with
    99 % probability (binomial quantiles)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    specs = registry()
    panels = [
        (name, j, p)
        for name, s in summary.items()
        if s["n_ok"]
        for j, p in enumerate(specs[name].parameter_names)
    ]
    ncols = min(4, len(panels))
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(3.2 * ncols, 2.6 * nrows), squeeze=False
    )
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax, (name, j, p) in zip(axes.ravel(), panels, strict=False):
        s = summary[name]
        ranks = s["ranks"][:, j]
        counts, share = rank_histogram(ranks, n_rank)
        n, n_bins = len(ranks), len(counts)
        edges = np.linspace(0, 1, n_bins + 1)
        lo = stats.binom.ppf(0.005, n, share)
        hi = stats.binom.ppf(0.995, n, share)
        ax.stairs(counts, edges, fill=True, color="C0", alpha=0.8)
        ax.fill_between(edges, np.r_[lo, lo[-1]], np.r_[hi, hi[-1]], step="post",
                        color="0.5", alpha=0.25, lw=0, zorder=3)  # fmt: skip
        ax.axhline(n / n_bins, color="0.4", lw=0.8)
        ax.set_title(
            f"{name}: {p}  (n={n})\nchi2 p={s['chi2_p'][j]:.2g}, "
            f"KS p={s['ks_p'][j]:.2g}",
            fontsize=9,
        )
        ax.set_xlabel("normalised rank of theta*", fontsize=8)
        ax.tick_params(labelsize=8)
    axes[0, 0].set_ylabel("replicates", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def combined_ranks(directories, n_rank=N_RANK):
    """What :func:`plot_ranks` needs, from the ``replicates.npz`` of runs.

    Cases of several runs (say, the cheap cases with 50 seeds and the MCMC
    cases with fewer) then share one figure.
    """
    summary = {}
    for directory in directories:
        arrays = np.load(Path(directory) / "replicates.npz")
        for key in arrays.files:
            name, field = key.split("__")
            if field != "rank":
                continue
            ranks = arrays[key]
            tests = [rank_tests(col, n_rank) for col in ranks.T]
            summary[name] = {
                "n_ok": len(ranks),
                "ranks": ranks,
                "chi2_p": [t[0] for t in tests],
                "ks_p": [t[1] for t in tests],
            }
    return summary
