"""Command line of skmba: ``python -m skmba demo``.

The demo runs the cantilever study of the thesis end to end (sections 4.7.1
and 6.3). The beam model has a fixed support; the "real" beam sits on a
rotational spring, which the model does not know about.

1. Field data: noisy measurements of the real beam's tip displacement and
   deformation energy under tip forces between 1 and 10 kN.
2. Calibration of Young's modulus E with model discrepancy
   (:class:`~skmba.ModularBayesCalibrator`): it runs the beam model on a
   Latin hypercube (the simulations), emulates it, learns the discrepancy
   and the noise with their uncertainty (``discrepancy_prior``), and samples
   the posterior of E with Metropolis-Hastings chains, whose diagnostics are
   reported. The report explains the confounding of the spring with E, what
   ``identifiability_`` and the calibrator's warning say about it, and what
   sets the width of the posterior.
3. Calibrated predictions of the beam, checked against the true process.
4. A small sensor ranking (:class:`~skmba.PreposteriorDesigner`): which of
   the five responses of Table 6.1 identify E best, before measuring.

It prints a short report and writes its figures (PNG) into an output
folder when matplotlib is installed.

Examples
--------
>>> from skmba.__main__ import build_parser
>>> build_parser().parse_args(["demo", "--out", "somewhere"]).out
'somewhere'
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

#: Settings of the full demo and of the quick one (``--quick``, for tests).
SETTINGS = {
    "full": {
        "n_observations": 25,
        "n_chains": 4,
        "n_samples": 2000,
        "burn_in": 500,
        "design_simulations": 54,
        "design_responses": "all",
        "n_design": 25,
        "n_mc": 30,
    },
    "quick": {
        "n_observations": 15,
        "n_chains": 2,
        "n_samples": 300,
        "burn_in": 200,
        "design_simulations": 30,
        "design_responses": ("tip_displacement", "energy", "tip_rotation"),
        "n_design": 8,
        "n_mc": 4,
    },
}
#: The letters of the cantilever's responses in thesis Table 6.1.
TABLE_6_1 = {
    "tip_displacement": "A",
    "energy": "B",
    "tip_rotation": "C",
    "mid_displacement": "D",
    "quarter_displacement": "E",
}
#: Signal-to-noise ratio of the demo's measurements (thesis Eq. 3.34).
SNR_DB = 30.0
#: The informative discrepancy prior of thesis section 6.3: the largest
#: discrepancy variance of the tip rotation lowered from 20 to 0.1.
ROTATION_PRIOR = 0.1


def build_parser():
    """The argument parser of ``python -m skmba``.

    Examples
    --------
    >>> args = build_parser().parse_args(["demo"])
    >>> args.n_simulations, args.seed, args.quick
    (70, 0, False)
    """
    parser = argparse.ArgumentParser(
        prog="python -m skmba",
        description="skmba: modular Bayesian model calibration and sensor design.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser(
        "demo",
        help="run the cantilever study end to end (calibration and sensor ranking)",
        description=(
            "Run the thesis' cantilever study end to end: simulate the beam "
            "model, calibrate Young's modulus E with model discrepancy from "
            "noisy measurements of a beam on a spring support, predict the "
            "beam with 95 % bands and rank the five candidate sensors by the "
            "fast preposterior analysis. Prints a report (posterior mean and "
            "95 % interval against the truth, diagnostics, best sensors) and "
            "writes the figures as PNG files. Well under a minute on two cores."
        ),
    )
    demo.add_argument(
        "--out",
        default="skmba-demo",
        help="folder for the figures, created if needed (default: ./skmba-demo)",
    )
    demo.add_argument(
        "--seed",
        type=int,
        default=0,
        help="random seed of the data, the simulations and the samplers (default: 0)",
    )
    demo.add_argument(
        "--n-jobs",
        type=int,
        default=-1,
        help=(
            "parallel joblib workers, -1 for all cores (default: -1); the results "
            "do not depend on it"
        ),
    )
    demo.add_argument(
        "--n-simulations",
        type=int,
        default=70,
        help="runs of the beam model for the calibration (default: 70, as in thesis)",
    )
    demo.add_argument(
        "--n-mc",
        type=int,
        default=None,
        help=(
            "Monte Carlo replicates of the sensor ranking (default: 30, or 4 "
            "with --quick; the thesis uses 100)"
        ),
    )
    demo.add_argument(
        "--monitoring",
        action="store_true",
        help=(
            "run the monitoring case instead: a bridge's hourly frequencies, a "
            "reference year, then a year judged week by week by ChangeDetector "
            "(a 5 %% stiffness loss of one element on 1 September)"
        ),
    )
    demo.add_argument(
        "--quick",
        action="store_true",
        help="a few seconds' smoke run with small settings (for tests)",
    )
    return parser


def _say(message):
    print(message, flush=True)


class _Steps:
    """Numbered progress lines with the elapsed time."""

    def __init__(self, total):
        self.total, self.done = total, 0
        self.started = time.perf_counter()

    def elapsed(self):
        return time.perf_counter() - self.started

    def __call__(self, message):
        self.done += 1
        _say(f"[{self.done}/{self.total}] {message} ({self.elapsed():.0f} s)")


def _emulator_accuracy(cal, data, seed, n_test=200):
    """R^2 of the fitted emulator on fresh runs of the beam model."""
    rng = np.random.default_rng(seed + 1)
    lo, hi = np.vstack([data.X_bounds, data.theta_bounds]).T
    Z = lo + (hi - lo) * rng.uniform(size=(n_test, len(lo)))
    d = data.X_bounds.shape[0]
    X, theta = Z[:, :d], Z[:, d:]
    y = data.simulator(X, theta)
    Zs = np.hstack(
        [
            (X - cal.X_mean_) / cal.X_scale_,
            (theta - cal.theta_offset_) / cal.theta_scale_,
        ]
    )
    pred = cal.model_gp_.predict(Zs) * cal.y_scale_ + cal.y_mean_
    return 1 - ((y - pred) ** 2).sum(0) / ((y - y.mean(0)) ** 2).sum(0)


def _figures(out, cal, data, designer, design_names):
    """Write the PNG figures; returns their paths (empty without matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        _say("  matplotlib is not installed: no figures (pip install 'skmba[plot]')")
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for fig, name, title in _calibration_figures(cal, data):
        fig.suptitle(title)
        written.append(_save(plt, fig, out / name))
    ax = _sensor_figure(designer, design_names)
    written.append(_save(plt, ax.figure, out / "sensor_criterion_by_size.png"))
    return written


def _save(plt, fig, path):
    """Write ``fig`` to ``path`` and close it; returns ``path``."""
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _calibration_figures(cal, data):
    """The calibration's figures with their file names and titles, one at a
    time (each is saved and closed before the next is drawn)."""
    from skmba.plotting import plot_calibrated_components, plot_posterior, plot_traces

    force = np.linspace(*data.X_bounds[0], 60)
    fig = plot_calibrated_components(
        cal,
        force,
        X_obs=data.X_obs,
        y_obs=data.y_obs,
        y_true=data.reality,
        names=["tip displacement", "energy"],
        units=data.response_units,
        input_name="tip force F [N]",
    )
    yield (
        fig,
        "calibrated_predictions.png",
        "Calibrated cantilever: model, discrepancy and observations (95 % bands)",
    )
    fig = plot_posterior(
        cal, true_value=data.theta_true, names=["E"], units=["MPa"], limits="posterior"
    )
    fig.set_size_inches(6.4, 4.2)
    yield fig, "posterior_E.png", "Posterior of Young's modulus"
    fig = plot_traces(cal, names=["E"], units=["MPa"], true_value=data.theta_true)
    # The legend goes below the panel, off the chains and the true value.
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.axes[0].get_legend().remove()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels))
    fig.set_size_inches(8.0, 3.6)
    yield fig, "traces_E.png", "Metropolis-Hastings chains of E"


def _sensor_figure(designer, design_names):
    """The sensor ranking's axes: best and worst subset of each size."""
    from skmba.plotting import plot_criterion_by_size

    letters = [name.split()[0] for name in design_names]
    ax = plot_criterion_by_size(designer, names=letters)
    ax.set_yscale("log")
    ax.set_title("Sensor ranking: best and worst subset of each size")
    ax.text(
        0.02,
        0.02,
        "\n".join(design_names),
        transform=ax.transAxes,
        fontsize="small",
        va="bottom",
        bbox={"facecolor": "white", "edgecolor": "0.8"},
    )
    return ax


def _simulate(settings, n_simulations, seed, steps):
    """Step 1: the cantilever problem and its noisy field data."""
    from skmba.datasets import make_cantilever

    data = make_cantilever(
        n_simulations=n_simulations,
        n_observations=settings["n_observations"],
        snr_db=SNR_DB,
        random_state=seed,
    )
    steps(
        f"Field data: {len(data.X_obs)} measurements of the tip displacement "
        f"and the energy at SNR {SNR_DB:g} dB, true E = "
        f"{data.theta_true[0] / 1e3:g} GPa"
    )
    return data


def _calibrate(data, settings, n_simulations, seed, n_jobs, steps):
    """Step 2: calibrate E; returns the calibrator and its fit's warnings."""
    from skmba import ModularBayesCalibrator

    cal = ModularBayesCalibrator(
        data.simulator,
        data.prior,
        n_simulations=n_simulations,
        sampler="mcmc",
        n_chains=settings["n_chains"],
        n_samples=settings["n_samples"],
        burn_in=settings["burn_in"],
        n_jobs=n_jobs,
        random_state=seed,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.fit(data.X_obs, data.y_obs)
    fit_warnings = sorted({str(w.message).split("\n")[0] for w in caught})
    steps(
        f"Calibrated E: {n_simulations} runs of the beam model, emulator, "
        f"discrepancy, {settings['n_chains']} chains of "
        f"{settings['burn_in']} + {settings['n_samples']} draws"
    )
    return cal, fit_warnings


def _predict(cal, data, seed, steps):
    """Step 3: emulator R^2 and the coverage of the true beam, per response."""
    r2 = _emulator_accuracy(cal, data, seed)
    force = np.linspace(*data.X_bounds[0], 60)[:, None]
    mean, std = cal.predict_reality(force, return_std=True)
    coverage = (np.abs(data.reality(force) - mean) <= 1.96 * std).mean(axis=0)
    steps("Predictions of the true beam (60 forces) and of fresh model runs")
    return r2, coverage


def _design_sensors(settings, n_mc, seed, n_jobs, steps):
    """Step 4: rank the sensors; returns the designer and the sensors' names."""
    from skmba import ModularBayesCalibrator, PreposteriorDesigner
    from skmba.datasets import make_cantilever

    design_data = make_cantilever(
        n_simulations=settings["design_simulations"],
        responses=settings["design_responses"],
        random_state=seed,
    )
    q = len(design_data.response_names)
    design_names = [f"{TABLE_6_1[n]} {n}" for n in design_data.response_names]
    variance_high = np.full(q, 20.0)
    variance_high[design_data.response_names.index("tip_rotation")] = ROTATION_PRIOR
    designer = PreposteriorDesigner(
        design_data.prior,
        calibrator=ModularBayesCalibrator(n_restarts_optimizer=0),
        discrepancy_prior={"variance": (0.01, variance_high)},
        n_design=settings["n_design"],
        n_mc=n_mc,
        n_jobs=n_jobs,
        random_state=seed,
    )
    with warnings.catch_warnings():
        # Module-2 fits of synthetic data that stop short of full convergence
        # are used as they are; the designer's warning says so.
        warnings.simplefilter("ignore")
        designer.fit(
            np.hstack([design_data.X_sim, design_data.theta_sim]), design_data.y_sim
        )
    steps(
        f"Sensor ranking: fast preposterior analysis of the {len(designer.subsets_)} "
        f"subsets of {q} responses ({n_mc} Monte Carlo replicates, "
        f"{settings['design_simulations']} simulations)"
    )
    return designer, design_names


def _report_posterior(cal, data):
    """Report E against the truth and explain the width of its posterior.

    Returns the 95 % credible interval of E.
    """
    samples = cal.theta_samples_[:, 0]
    interval = np.quantile(samples, [0.025, 0.975])
    E_true, E_mean = data.theta_true[0], cal.theta_mean_[0]
    inside = interval[0] <= E_true <= interval[1]
    _say("")
    _say("Report")
    _say("------")
    _say(
        f"E: posterior mean {E_mean / 1e3:.2f} GPa, 95 % interval "
        f"[{interval[0] / 1e3:.2f}, {interval[1] / 1e3:.2f}] GPa; truth "
        f"{E_true / 1e3:.2f} GPa (error {E_mean / E_true - 1:+.1%}, truth "
        f"{'inside' if inside else 'outside'} the interval)"
    )
    E_effective = _report_confounding(cal, data)
    _report_identifiability(cal)
    if not inside:
        z = abs(E_mean - E_true) / samples.std()
        shift = E_mean - E_effective
        _say(
            f"   The truth is outside the interval: the posterior mean is "
            f"{abs(shift) / 1e3:.2f} GPa {'below' if shift < 0 else 'above'} the "
            f"effective modulus, where the confounding alone would put it, and "
            f"{z:.1f} posterior sd from E*."
        )
    return interval


def _report_confounding(cal, data):
    """Explain why the spring and E are confounded, and the size of the
    discrepancy; returns the effective modulus."""
    # The spring changes both responses by the same fraction as a softer
    # beam: the fixed-support model at this modulus reproduces the real one.
    beam = data.reality
    E_effective = beam.E / (
        1 + 3 * beam.E * beam.I / (beam.spring_stiffness * beam.length)
    )
    _say(
        "   The spring at the support changes both responses by the same "
        "fraction as a softer E: the fixed-support model at the effective "
        f"modulus E*/(1 + 3E*I/(K*L)) = {E_effective / 1e3:.2f} GPa reproduces "
        "the real beam, so the data alone cannot tell the spring from E."
    )
    sd = np.sqrt(np.diag(cal.discrepancy_sigma2_)) / cal.y_scale_
    _say(
        "   Discrepancy sd at its posterior mode, as a share of each "
        "response's simulated sd: "
        + ", ".join(
            f"{name} {v:.3g}" for name, v in zip(data.response_names, sd, strict=True)
        )
        + " (default prior: half-normal with scale 0.5)."
    )
    return E_effective


def _report_identifiability(cal):
    """What ``identifiability_`` of E says about the width of its interval."""
    from skmba.calibration._module3_identifiability import IDENTIFIABILITY_THRESHOLD

    ident = cal.identifiability_[0]
    if ident < IDENTIFIABILITY_THRESHOLD:
        _say(
            f"   identifiability_ of E is {ident:.2g} (below "
            f"{IDENTIFIABILITY_THRESHOLD:.2f}; the calibrator warned): the data "
            f"account for {ident:.0%} of E's posterior sd. A discrepancy shaped "
            "like a change of E on both responses mimics it, so the width of "
            "the interval comes from the prior on the discrepancy, not from the "
            "data, and the interval misses E* when the model error has that "
            "shape, as the spring's has, whatever its size. Other responses "
            "(the sensor ranking below) "
            "or prior information on E are what identify it. "
            "cal.prior_sensitivity() refits under a stated class of "
            "discrepancy priors: how far the interval moves with them, and "
            "E's range across the class (its union rows)."
        )
    else:
        _say(
            f"   identifiability_ of E is {ident:.2g}: the data account for "
            "most of E's posterior sd, whatever the discrepancy."
        )


def _report_diagnostics(cal, data, r2, coverage, fit_warnings):
    """Report the MCMC diagnostics, the emulator, the noise and the bands."""
    acceptance = cal.acceptance_rate_
    _say(
        f"MCMC: split R-hat {cal.rhat_[0]:.3f} (want < 1.01), bulk ESS "
        f"{cal.ess_[0]:.0f} of {cal.theta_samples_.shape[0]} draws, acceptance "
        f"{acceptance.min():.2f}-{acceptance.max():.2f}"
    )
    for k, name in enumerate(data.response_names):
        unit = data.response_units[k]
        _say(
            f"{name}: emulator R^2 {r2[k]:.5f} on 200 fresh model runs; noise sd "
            f"{np.sqrt(cal.noise_[k]):.3g} {unit} estimated, "
            f"{np.sqrt(data.noise_variance[k]):.3g} {unit} true; 95 % bands "
            f"cover {coverage[k]:.0%} of the true beam"
        )
    for message in fit_warnings:
        _say(f"warning during the calibration: {message}")


def _report_sensors(designer, design_names):
    """Report the sensors' ranking; returns the best subset of each size."""
    order = np.argsort(designer.ranking_, kind="stable")
    _say(
        "Sensors alone, best first (informative discrepancy prior of section "
        "6.3): "
        + ", ".join(
            f"{designer.ranking_[k]}. {design_names[k]} "
            f"({designer.scores_[designer.subsets_.index((k,))]:.3f})"
            for k in order
        )
    )
    sizes = sorted({len(s) for s in designer.subsets_})
    best_subsets = {}
    for size in sizes:
        members = [i for i, s in enumerate(designer.subsets_) if len(s) == size]
        best = min(members, key=lambda i: designer.scores_[i])
        best_subsets[size] = [design_names[k] for k in designer.subsets_[best]]
        _say(
            f"Best {size} sensor{'s' if size > 1 else ' '}: "
            f"{' + '.join(n.split()[0] for n in best_subsets[size])} "
            f"(posterior/prior variance {designer.scores_[best]:.3f})"
        )
    return best_subsets


def run_demo(out, *, n_simulations=70, n_mc=None, seed=0, n_jobs=-1, quick=False):
    """Run the cantilever study end to end; print a report, write figures.

    Parameters
    ----------
    out : str or Path
        Folder for the figures (created if needed).
    n_simulations : int, default=70
        Runs of the beam model for the calibration.
    n_mc : int, default=None
        Monte Carlo replicates of the sensor ranking (None: 30, 4 if quick).
    seed : int, default=0
    n_jobs : int, default=-1
        joblib workers of the calibrator and the designer.
    quick : bool, default=False
        Small settings for a smoke run of a few seconds.

    Returns
    -------
    report : dict
        ``theta_mean``, ``interval`` (2,) and ``theta_true`` of E (MPa);
        ``rhat``, ``ess``, ``acceptance`` (MCMC diagnostics); ``r2``
        (emulator, per response); ``coverage`` (share of the true process
        inside the 95 % bands of the calibrated prediction, per response);
        ``ranking`` (dict name -> rank of each response alone) and
        ``best_subsets`` (best subset of each size, as names); ``figures``
        (paths) and ``seconds``.
    """
    settings = SETTINGS["quick" if quick else "full"]
    n_mc = settings["n_mc"] if n_mc is None else n_mc
    steps = _Steps(5)
    _say(
        "skmba demo: the cantilever beam of thesis sections 4.7.1 and 6.3 "
        "(model: fixed support; reality: rotational spring K* = 1.5e12 N mm/rad)"
    )
    data = _simulate(settings, n_simulations, seed, steps)
    cal, fit_warnings = _calibrate(data, settings, n_simulations, seed, n_jobs, steps)
    r2, coverage = _predict(cal, data, seed, steps)
    designer, design_names = _design_sensors(settings, n_mc, seed, n_jobs, steps)
    figures = _figures(out, cal, data, designer, design_names)
    steps(f"Figures written to {out}" if figures else "No figures")

    interval = _report_posterior(cal, data)
    _report_diagnostics(cal, data, r2, coverage, fit_warnings)
    best_subsets = _report_sensors(designer, design_names)
    for path in figures:
        _say(f"figure: {path}")
    seconds = steps.elapsed()
    _say(f"Done in {seconds:.0f} s.")
    return {
        "theta_mean": cal.theta_mean_[0],
        "interval": interval,
        "theta_true": data.theta_true[0],
        "rhat": cal.rhat_,
        "ess": cal.ess_,
        "acceptance": cal.acceptance_rate_,
        "r2": r2,
        "coverage": coverage,
        "ranking": dict(zip(design_names, designer.ranking_.tolist(), strict=True)),
        "best_subsets": best_subsets,
        "figures": figures,
        "seconds": seconds,
    }


def main(argv=None):
    """Entry point of ``python -m skmba``."""
    args = build_parser().parse_args(argv)
    if args.command == "demo" and args.monitoring:
        from skmba._demo_monitoring import run_monitoring_demo

        run_monitoring_demo(args.out, seed=args.seed, quick=args.quick, say=_say)
    elif args.command == "demo":
        if args.n_simulations < 10:
            raise SystemExit("--n-simulations must be at least 10.")
        if args.n_mc is not None and args.n_mc < 1:
            raise SystemExit("--n-mc must be at least 1.")
        if args.n_jobs == 0:
            raise SystemExit("--n-jobs must be a positive number or -1 (all cores).")
        run_demo(
            args.out,
            n_simulations=args.n_simulations,
            n_mc=args.n_mc,
            seed=args.seed,
            n_jobs=args.n_jobs,
            quick=args.quick,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
