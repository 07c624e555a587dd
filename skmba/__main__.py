"""Command line of skmba: ``python -m skmba demo``.

The demo runs what the package offers so far on the thesis' cantilever beam
(section 4.7.1): 70 Latin-hypercube runs of the fixed-support beam model
``y_m = f(F, E)`` (tip displacement and deformation energy) are emulated by a
:class:`~skmba.MultiResponseGP`, the module-1 emulator of the modular
Bayesian approach. It prints the fitted hyperparameters, the held-out R^2
and the coverage of the 95 % prediction intervals, and, when matplotlib is
installed, writes a figure of the emulator against the beam formulas.

Examples
--------
>>> from skmba.__main__ import build_parser
>>> build_parser().parse_args(["demo", "--out", "somewhere"]).out
'somewhere'
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np


def build_parser():
    """The argument parser of ``python -m skmba``.

    Examples
    --------
    >>> build_parser().parse_args(["demo"]).n_simulations
    70
    """
    parser = argparse.ArgumentParser(
        prog="python -m skmba",
        description="skmba: modular Bayesian model calibration (command line).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser(
        "demo",
        help="emulate the thesis' cantilever beam model with MultiResponseGP",
        description=(
            "Fit a multi-response Gaussian process emulator to simulations of "
            "the thesis' cantilever beam (section 4.7.1), report its accuracy "
            "and write a figure."
        ),
    )
    demo.add_argument(
        "--out",
        default="skmba-demo",
        help="folder for the figures (default: ./skmba-demo)",
    )
    demo.add_argument(
        "--n-simulations",
        type=int,
        default=70,
        help="number of beam-model runs in the Latin hypercube (default: 70)",
    )
    demo.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    return parser


def _say(message):
    print(message, flush=True)


def run_demo(out, n_simulations=70, seed=0):
    """Run the cantilever emulator demo; return a dict of the figures it found.

    Parameters
    ----------
    out : str or Path
        Folder for the figure (created if needed).
    n_simulations : int, default=70
    seed : int, default=0

    Returns
    -------
    report : dict
        ``r2`` (per response), ``coverage`` (per response, fraction of
        held-out points inside the 95 % interval) and ``figure`` (path or
        None when matplotlib is missing).
    """
    from skmba import MultiResponseGP
    from skmba.datasets import make_cantilever
    from skmba.kernels import Gauss

    start = time.perf_counter()
    _say(f"[1/3] Simulating the cantilever beam model ({n_simulations} runs)")
    data = make_cantilever(n_simulations=n_simulations, random_state=seed)
    X = np.hstack([data.X_sim, data.theta_sim])
    names = list(data.design_variable_names) + list(data.parameter_names)
    scale = X.std(axis=0)

    _say("[2/3] Fitting the multi-response Gaussian process emulator")
    gp = MultiResponseGP(
        Gauss(roughness=np.ones(X.shape[1])),
        regression="linear",
        n_restarts_optimizer=2,
        random_state=seed,
    )
    gp.fit(X / scale, data.y_sim)

    rng = np.random.default_rng(seed + 1)
    lo, hi = np.vstack([data.X_bounds, data.theta_bounds]).T
    X_test = lo + (hi - lo) * rng.uniform(size=(500, X.shape[1]))
    y_test = data.simulator(X_test[:, :1], X_test[:, 1:])
    mean, std = gp.predict(X_test / scale, return_std=True)
    r2 = 1 - ((y_test - mean) ** 2).sum(0) / ((y_test - y_test.mean(0)) ** 2).sum(0)
    coverage = (np.abs(y_test - mean) <= 1.96 * std).mean(axis=0)

    _say("[3/3] Report")
    roughness = np.atleast_1d(gp.kernel_.roughness) / scale**2
    for name, w in zip(names, roughness, strict=True):
        _say(f"  roughness of {name}: {w:.3g} per squared unit of {name}")
    for k, response in enumerate(data.response_names):
        unit = data.response_units[k]
        _say(
            f"  {response}: sd {np.sqrt(gp.sigma2_[k, k]):.3g} {unit}, "
            f"held-out R^2 {r2[k]:.6f}, 95% interval coverage {coverage[k]:.0%}"
        )
    corr = gp.sigma2_[0, 1] / np.sqrt(gp.sigma2_[0, 0] * gp.sigma2_[1, 1])
    _say(f"  correlation between the responses in Sigma2: {corr:.3f}")

    figure = None
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        _say("  matplotlib is not installed: no figure (pip install 'skmba[plot]')")
    else:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        E = np.linspace(lo[1], hi[1], 200)
        F = np.full_like(E, 0.5 * (lo[0] + hi[0]))
        grid = np.column_stack([F, E])
        m, s = gp.predict(grid / scale, return_std=True)
        truth = data.simulator(grid[:, :1], grid[:, 1:])
        fig, axes = plt.subplots(
            2, 2, figsize=(10, 6.5), sharex=True, layout="constrained"
        )
        for k in range(2):
            label = f"{data.response_names[k]} ({data.response_units[k]})"
            top, bottom = axes[0, k], axes[1, k]
            top.plot(E / 1e3, truth[:, k], "k--", lw=2, label="beam theory")
            top.plot(E / 1e3, m[:, k], label="emulator mean")
            top.set_ylabel(label)
            top.set_title(f"F = {F[0]:.0f} N")
            top.legend()
            # The bands are too narrow to see on the response scale: show the
            # emulator's error against the 95 % interval instead.
            bottom.fill_between(
                E / 1e3,
                -1.96 * s[:, k],
                1.96 * s[:, k],
                alpha=0.3,
                label="95% interval",
            )
            bottom.plot(E / 1e3, m[:, k] - truth[:, k], label="emulator - theory")
            bottom.axhline(0.0, color="k", lw=0.8)
            bottom.set_xlabel("Young's modulus E (GPa)")
            bottom.set_ylabel(f"error ({data.response_units[k]})")
            bottom.legend()
        figure = out / "cantilever_emulator.png"
        fig.savefig(figure, dpi=120)
        plt.close(fig)
        _say(f"  figure written to {figure}")
    _say(f"Done in {time.perf_counter() - start:.1f} s.")
    return {"r2": r2, "coverage": coverage, "figure": figure}


def main(argv=None):
    """Entry point of ``python -m skmba``."""
    args = build_parser().parse_args(argv)
    if args.command == "demo":
        if args.n_simulations < 10:
            raise SystemExit("--n-simulations must be at least 10.")
        run_demo(args.out, args.n_simulations, args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
