"""How honest are the intervals? Seeded replicate studies of the calibrator.

Fits ``ModularBayesCalibrator`` with its current defaults on seeded
replicates of the cases of issue 13 and prints, per case, how often the
95 % intervals contain the truth (with a Wilson interval), rms z, SBC rank
tests, the predictive coverage of reality and of new observations, and the
warnings; what each column means is in ``docs/validity.rst``.

Usage::

    python -m validation --n-seeds 20 --n-jobs 2 --out /tmp/validity
    python -m validation --cases a2,freq --n-seeds 4
    python -m validation --n-seeds 20 --case-seeds a2=10,sbc_a2=10
    python -m validation --combine /tmp/run1,/tmp/run2 --out /tmp/all

``--out DIR`` writes ``replicates.csv`` (one row per replicate and
parameter, after a ``#`` line with the git commit, the date and the
command), ``replicates.npz`` (per case arrays), ``table.txt`` (the same
header line, then the printed tables) and the rank histograms
``validity_ranks.png`` (one panel per case and parameter). Replicates run
in parallel through joblib (``--n-jobs``), each with the calibrator's
``n_jobs=1`` and BLAS held to one thread.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

from validation.report import (
    combined_ranks,
    format_tables,
    plot_ranks,
    provenance,
    save_records,
)
from validation.statistics import summarise
from validation.suite import registry, run


def parse_case_seeds(text):
    """``"a2=10,sbc_a2=8"`` -> ``{"a2": 10, "sbc_a2": 8}``."""
    out = {}
    for item in filter(None, (t.strip() for t in (text or "").split(","))):
        name, _, value = item.partition("=")
        out[name.strip()] = int(value)
    return out


def _parser(specs):
    parser = argparse.ArgumentParser(
        prog="python -m validation",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--n-seeds", type=int, default=20, help="seeds per case")
    parser.add_argument(
        "--case-seeds",
        default="",
        help="per-case overrides of --n-seeds, e.g. 'a2=10,sbc_a2=10'",
    )
    parser.add_argument("--n-jobs", type=int, default=1, help="parallel replicates")
    parser.add_argument(
        "--cases", default=",".join(specs), help=f"comma list of {', '.join(specs)}"
    )
    parser.add_argument("--out", default=None, help="directory for the results")
    parser.add_argument(
        "--discrepancy-tol",
        type=discrepancy_tol_argument,
        default="auto",
        help="the calibrator's discrepancy_tol: a number, 'none' (16 draws) "
        "or 'auto' (its default)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.add_argument(
        "--combine",
        default="",
        help="comma list of earlier --out directories: draw their rank "
        "histograms in one figure, --out/validity_ranks.png, and stop",
    )
    return parser


def discrepancy_tol_argument(text):
    """``--discrepancy-tol``: ``"auto"``, None for ``"none"``, or a number."""
    if text.lower() in ("auto", "none"):
        return None if text.lower() == "none" else "auto"
    return float(text)


def _save(out, records, summary, table, footer, command):
    """The files of ``--out``; prints where they are."""
    out = Path(out)
    header = provenance(command)
    save_records(records, out, header=header)
    (out / "table.txt").write_text(header + "\n\n" + table + "\n\n" + footer + "\n")
    plot_ranks(summary, out / "validity_ranks.png")
    print(f"results in {out}/ (replicates.csv, replicates.npz, table.txt, "
          "validity_ranks.png)")  # fmt: skip


def main(argv=None):
    """The command line; returns the summary (None with ``--combine``)."""
    specs = registry()
    parser = _parser(specs)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    if args.combine:
        if not args.out:
            parser.error("--combine needs --out")
        Path(args.out).mkdir(parents=True, exist_ok=True)
        directories = [d for d in args.combine.split(",") if d]
        plot_ranks(combined_ranks(directories), Path(args.out) / "validity_ranks.png")
        return None
    names = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in names if c not in specs]
    if unknown:
        parser.error(f"unknown case(s) {unknown}; choose from {list(specs)}")
    seeds = dict.fromkeys(names, args.n_seeds)
    seeds.update({k: v for k, v in parse_case_seeds(args.case_seeds).items()
                  if k in seeds})  # fmt: skip

    options = {}
    if args.discrepancy_tol != "auto":
        options["discrepancy_tol"] = args.discrepancy_tol
    print(
        "skmba validity suite: ModularBayesCalibrator with its current defaults"
        + "".join(f", {k}={v}" for k, v in options.items())
    )
    for name in names:
        print(f"  {name:<7} {seeds[name]:>3} seeds  {specs[name].description}")
    print(f"  n_jobs={args.n_jobs}; 95 % intervals; 30 dB noise\n", flush=True)
    started = time.perf_counter()
    records = run(
        names, seeds, n_jobs=args.n_jobs, progress=not args.quiet, options=options
    )
    wall = time.perf_counter() - started
    summary = summarise(records)
    table = format_tables(summary)
    fits = sum(r["seconds"] for r in records)
    footer = (
        f"wall time {wall:.0f} s ({wall / 60:.1f} min) for {len(records)} "
        f"replicates, {fits:.0f} s of fits in total, n_jobs={args.n_jobs}"
    )
    print(table)
    print()
    print(footer)
    if args.out:
        command = shlex.join(["python", "-m", "validation", *argv])
        _save(args.out, records, summary, table, footer, command)
    return summary


if __name__ == "__main__":
    main()
