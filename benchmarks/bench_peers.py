"""Benchmark skmba against a peer package, surmise: ESS per second.

Prints, from one run in one process, the bulk effective sample size (ESS)
per second of wall-clock time of the posterior of the two calibration
parameters (E, I) of the thesis' section 4.7.3 set-up (the cantilever of
``make_cantilever(170, 70, parameters=("E", "I"), random_state=0)``: a tip
force F as the design variable, the tip displacement and the deformation
energy as responses, 170 simulations, 70 noise-free observations of the beam
on a rotational spring, a uniform prior) for

1. ``skmba.ModularBayesCalibrator`` with ``discrepancy_uncertainty=
   "plug-in"`` and with the default ``"propagate"``: 4 chains of 1000 draws
   after 500 burn-in steps, ``n_jobs=-1``, ``random_state=0``;
2. surmise (https://github.com/bandframework/surmise): the ``"PCGP"``
   emulator (Higdon et al. 2008: principal components of the outputs, one GP
   over theta per component) and the ``"directbayes"`` calibrator with its
   default sampler, Metropolis-Hastings (one chain; settings below).

For each: the wall time (emulator fit + calibration, the simulations being
given), the bulk ESS and the split R-hat of E and I, the acceptance rate, the
smallest ESS per second, the posterior mean and sd of E, I and E*I against
the truth, and the warnings raised; then the ratio of the smallest ESS per
second, skmba / surmise (the goal: >= 1). Both packages' ESS and R-hat come
from the same functions, ``skmba.mcmc._diagnostics.ess_bulk`` and ``split_rhat``
(skmba's draws as its 4 chains, surmise's as one chain ``draws[None, :]``
after its burn-in; both functions split every chain in halves). The thread
settings are printed first (``skmba._core.threads.describe_threads``).

**Same simulations, same field data, different x layout.** skmba takes the
170 runs of ``make_cantilever`` as they are: run i at its own force F_i and
its own (E_i, I_i), drawn together by a Latin hypercube (170 x 2 outputs).
surmise's PCGP needs every theta run at the same x, so it gets the same 170
``theta_sim``, each run of the same closed-form model (``data.simulator``)
at the 70 field forces ``X_obs`` (170 x 70 x 2 outputs): same theta, but
surmise sees the model exactly at the forces it is calibrated at (no
interpolation in x) and 70 times as many outputs as skmba. The field data
(``X_obs``, ``y_obs``) are the same. The two responses are stacked as the rows
of surmise's x, with a response indicator: x = (F, k), k = 0 for the
displacement, 1 for the energy; ``f`` is 140 x 170 and y has 140 values. Each
response is divided by the sd of its simulations for surmise (its calibrator
refuses an observation variance outside [1e-6, 1e6]; PCGP standardises the
outputs anyway); this does not change the posterior.

**surmise has no model discrepancy**: the likelihood of ``directbayes`` is
y = emulator(x, theta) + N(0, yvar), so the model error of the spring
support is not modelled. For a tip force, both responses of the spring-
supported beam equal those of the fixed-support model at
EI_eff = 1 / (1 / (E* I*) + 3 / (L K*)) (printed): without a discrepancy,
the noise-free data pin E*I to EI_eff, 3 % below the true E* I*.

**Observation variance of surmise.** The data are noise-free
(``data.noise_variance`` is 0) and surmise needs a positive ``yvar``. It is
estimated from the data without the truth, as the variance of noise plus
model error that a model without discrepancy needs: per response, the mean
squared residual of the field data about the simulation run (of the 170, at
the field forces) that fits them best (smallest sum of squared scaled
residuals). The emulator's predictive covariance, which ``directbayes`` adds
to ``yvar``, is printed next to it.

**surmise's sampler settings** (its Metropolis-Hastings is a random walk
with a fixed, diagonal normal proposal): ``stepType="normal"``, ``stepParam``
= 20 % of each parameter's prior range. Tried on this problem (single chains of
10 000 to 30 000 draws, 20 % with two seeds): 0.1 % to 3 % of the range gave
1-18 bulk ESS per 30 000 draws, 5-10 % about 60, 15 % about 115, 20 % 135-170
(acceptance 4.5 %), 29 % (the sd of prior draws: what surmise's
``stepParam=None`` takes) about 100. The
posterior is a thin curved ridge along E*I = const: small steps crawl along
it, large ones are mostly rejected but, when accepted, jump far along it.
``theta0`` = the theta of the best-fitting simulation run (on the ridge: a
short burn-in suffices), ``nBurnSamples`` = 5000 (discarded by surmise),
``nSamples`` = 60 000 (its ESS per step is small; a long chain makes its
ESS estimate less rough). surmise runs with BLAS limited to one thread
(``--surmise-blas-threads``): its Metropolis-Hastings step eigendecomposes a
140 x 140 matrix, which ran 20-50 times slower on two OpenBLAS threads while
another process kept a core busy (skmba's chains hold BLAS to one thread
too). surmise's chain is serial and uses one core; skmba's ``n_jobs=-1`` runs
its 4 chains on all cores: the ratio is one of the packages as they can be
used, not of the samplers per core.

Run from the repository root with ``python -m benchmarks.bench_peers``
(about 1.5 minutes; it imports ``benchmarks.bench_calibration``); add
``--quick`` for a smoke run (44 simulations, 18 observations, short chains;
its numbers mean little). surmise is an optional dependency of this benchmark
only: ``pip install surmise``; without it the script says so and exits.
"""

import argparse
import time
import warnings

import numpy as np
import threadpoolctl

from benchmarks.bench_calibration import fit_cantilever
from skmba.datasets import make_cantilever
from skmba.mcmc._diagnostics import ess_bulk, split_rhat

try:  # run as a script (python benchmarks/bench_x.py) or as a module
    from _machine import machine_report
except ImportError:
    from benchmarks._machine import machine_report

try:
    import surmise
    from surmise.calibration import calibrator as SurmiseCalibrator
    from surmise.emulation import emulator as SurmiseEmulator
except ImportError:  # optional dependency
    surmise = None

#: Step of surmise's random walk, as a fraction of each prior range.
SURMISE_STEP = 0.2
FULL = {
    "data": {"n_simulations": 170, "n_observations": 70},
    "skmba": {"n_samples": 1000, "burn_in": 500},
    "surmise": {"nSamples": 60_000, "nBurnSamples": 5000},
}
QUICK = {
    "data": {"n_simulations": 44, "n_observations": 18},
    "skmba": {"n_samples": 250, "burn_in": 250},
    "surmise": {"nSamples": 3000, "nBurnSamples": 500},
}


def recording_warnings(fn):
    """``(wall seconds, fn(), warnings raised)``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        start = time.perf_counter()
        out = fn()
        elapsed = time.perf_counter() - start
    return elapsed, out, [f"{w.category.__name__}: {w.message}" for w in caught]


def summarise(name, seconds, chains, acceptance, caught, extra=()):
    """The common record of one run; ``chains`` is (n_chains, n_draws, r)."""
    r = chains.shape[2]
    return {
        "name": name,
        "seconds": seconds,
        "chains": chains,
        "ess": np.array([ess_bulk(chains[:, :, j]) for j in range(r)]),
        "rhat": np.array([split_rhat(chains[:, :, j]) for j in range(r)]),
        "acceptance": np.atleast_1d(acceptance),
        "warnings": caught,
        "extra": list(extra),
    }


# ---------------------------------------------------------------- skmba
def run_skmba(data, discrepancy_uncertainty, n_samples, burn_in):
    cal, seconds, caught = fit_cantilever(
        data, n_samples, burn_in, discrepancy_uncertainty, n_jobs=-1
    )
    name = f'skmba, discrepancy_uncertainty="{discrepancy_uncertainty}"'
    return summarise(
        name,
        seconds,
        np.asarray(cal.theta_chains_),
        cal.acceptance_rate_,
        caught,
        extra=[
            f"4 chains x {n_samples} draws (burn-in {burn_in}), n_jobs=-1; "
            f"{len(data.theta_sim)} simulations at (F_i, E_i, I_i)"
        ],
    )


# ---------------------------------------------------------------- surmise
class UniformBoxPrior:
    """The product prior of ``data.prior`` in surmise's interface."""

    def __init__(self, marginals, seed):
        self.marginals = list(marginals)
        self.rng = np.random.default_rng(seed)

    def lpdf(self, theta):
        theta = np.atleast_2d(theta)
        logpdf = sum(p.logpdf(theta[:, j]) for j, p in enumerate(self.marginals))
        return np.reshape(logpdf, (-1, 1))

    def rnd(self, n):
        return np.column_stack(
            [p.rvs(size=n, random_state=self.rng) for p in self.marginals]
        )


def surmise_layout(data):
    """surmise's x (F, response index), simulations ``f`` and field ``y``.

    The same ``theta_sim`` as skmba's, each run at every field force. Each
    response is divided by the sd of its simulations.
    """
    n, q = data.y_obs.shape
    x = np.column_stack([np.tile(data.X_obs[:, 0], q), np.repeat(np.arange(q), n)])
    f = np.column_stack(
        [data.simulator(data.X_obs, theta).T.ravel() for theta in data.theta_sim]
    )  # (q n, N): responses stacked as x is
    scale = np.repeat(f.reshape(q, -1).std(axis=1), n)
    return x, f / scale[:, None], data.y_obs.T.ravel() / scale, scale


def best_run_noise(f, y, q):
    """Index of the best-fitting run, and the per-row observation variance.

    Per response, the mean squared residual of ``y`` about the run whose
    outputs have the smallest sum of squared residuals.
    """
    resid = f - y[:, None]
    best = int(np.argmin(np.sum(resid**2, axis=0)))
    per_response = np.mean(resid[:, best].reshape(q, -1) ** 2, axis=1)
    return best, np.repeat(per_response, len(y) // q)


def run_surmise(data, nSamples, nBurnSamples, blas_threads=1):
    q = data.y_obs.shape[1]
    bounds = np.asarray(data.theta_bounds, dtype=float)
    x, f, y, scale = surmise_layout(data)
    prior = UniformBoxPrior(data.prior, seed=1)
    surmise.set_RNG(np.random.default_rng(0))

    def fit():
        best, yvar = best_run_noise(f, y, q)
        emu = SurmiseEmulator(x=x, theta=data.theta_sim, f=f, method="PCGP")
        t_emu = time.perf_counter()
        args = {
            "sampler": "metropolis_hastings",
            "nSamples": nSamples,
            "nBurnSamples": nBurnSamples,
            "theta0": data.theta_sim[best][None, :],
            "stepType": "normal",
            "stepParam": SURMISE_STEP * (bounds[:, 1] - bounds[:, 0]),
            "verbose": False,
        }
        cal = SurmiseCalibrator(
            emu=emu,
            y=y,
            x=x,
            thetaprior=prior,
            method="directbayes",
            yvar=yvar,
            args=args,
        )
        return emu, cal, best, yvar, t_emu

    with threadpoolctl.threadpool_limits(blas_threads, user_api="blas"):
        start = time.perf_counter()
        seconds, (emu, cal, best, yvar, t_emu), caught = recording_warnings(fit)
        emu_seconds = t_emu - start
    draws = np.asarray(cal.info["thetarnd"])  # (nSamples, r), burn-in removed
    moved = np.any(np.diff(draws, axis=0) != 0, axis=1).mean()
    pred = emu.predict(x, data.theta_sim[best][None, :])
    emu_var = np.asarray(pred.var())[:, 0]
    n = len(y) // q
    names = data.response_names
    sd_yvar = ", ".join(
        f"{name} {np.sqrt(yvar[k * n]) * scale[k * n]:.3g}"
        for k, name in enumerate(names)
    )
    ratio = ", ".join(
        f"{name} {emu_var[k * n : (k + 1) * n].mean() / yvar[k * n]:.3g}"
        for k, name in enumerate(names)
    )
    extra = [
        f"1 chain x {nSamples} draws (burn-in {nBurnSamples}), BLAS threads "
        f"{blas_threads}; {len(data.theta_sim)} simulations, each at the "
        f"{n} field forces; PCGP kept {len(emu._info['emulist'])} principal "
        "component(s)",
        f"emulator fit {emu_seconds:.2f} s, calibration "
        f"{seconds - emu_seconds:.2f} s "
        f"({1e3 * (seconds - emu_seconds) / (nSamples + nBurnSamples):.2f} ms "
        "per Metropolis-Hastings step)",
        f"observation sd (estimated, no discrepancy model): {sd_yvar}",
        f"emulator variance / yvar at theta0, mean over x: {ratio}",
        f"theta0 (best-fitting run): E {data.theta_sim[best, 0]:.5g}, "
        f"I {data.theta_sim[best, 1]:.5g}; stepParam "
        f"{SURMISE_STEP:g} x prior range",
    ]
    return summarise(
        "surmise, PCGP + directbayes (no discrepancy)",
        seconds,
        draws[None],
        moved,
        caught,
        extra=extra,
    )


# ---------------------------------------------------------------- output
def rate(result):
    return np.min(result["ess"]) / result["seconds"]


def print_result(result, data):
    print(result["name"])
    for line in result["extra"]:
        print(f"  {line}")
    print(f"  wall time (emulator fit + calibration): {result['seconds']:8.2f} s")
    for j, name in enumerate(data.parameter_names):
        print(
            f"  {name:>3s}: bulk ESS {result['ess'][j]:8.1f}   split R-hat "
            f"{result['rhat'][j]:.4f}"
        )
    print(
        "  acceptance rate per chain: "
        + ", ".join(f"{a:.3f}" for a in result["acceptance"])
    )
    print(f"  smallest ESS per second: {rate(result):.3g}")
    draws = result["chains"].reshape(-1, result["chains"].shape[2])
    columns = np.column_stack([draws, np.prod(draws, axis=1)])
    truth = np.append(data.theta_true, np.prod(data.theta_true))
    for name, col, true in zip(("E", "I", "E*I"), columns.T, truth, strict=True):
        print(
            f"  posterior {name:>3s}: mean {col.mean():11.5g}  sd {col.std():10.4g}"
            f"   truth {true:11.5g}  ({(col.mean() - true) / col.std():+6.2f} sd)"
        )
    print(f"  posterior correlation(E, I): {np.corrcoef(draws.T)[0, 1]:+.4f}")
    unique = sorted(set(result["warnings"]))
    print(f"  warnings: {len(result['warnings'])}" + (":" if unique else ""))
    for message in unique:
        print(f"    {message[:300]}")
    print()


def effective_stiffness(data):
    """E*I of the fixed-support model that matches the spring-supported beam."""
    reality = data.reality
    return 1.0 / (
        1.0 / (reality.E * reality.I)
        + 3.0 / (reality.length * reality.spring_stiffness)
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small smoke run")
    parser.add_argument(
        "--surmise-blas-threads",
        type=int,
        default=1,
        help="BLAS threads for surmise's fit and sampling (default: 1)",
    )
    args = parser.parse_args()
    if surmise is None:
        print(
            "surmise is not installed; this benchmark compares skmba with it.\n"
            "Install it with `pip install surmise` and run again."
        )
        return
    print(machine_report(), flush=True)
    print(f"surmise {getattr(surmise, '__version__', '?')}")
    sizes = QUICK if args.quick else FULL
    data = make_cantilever(**sizes["data"], parameters=("E", "I"), random_state=0)
    n_sim, n_obs = sizes["data"]["n_simulations"], sizes["data"]["n_observations"]
    print(
        f"Cantilever, section 4.7.3: {n_sim} simulations, {n_obs} noise-free "
        f"observations of {', '.join(data.response_names)}; parameters E, I "
        f"(uniform prior); truth E* = {data.theta_true[0]:g}, I* = "
        f"{data.theta_true[1]:g}, E*I* = {np.prod(data.theta_true):.5g}; "
        f"without discrepancy the data match E*I = {effective_stiffness(data):.5g}"
    )
    print()
    start = time.perf_counter()
    results = [
        run_skmba(data, "plug-in", **sizes["skmba"]),
        run_skmba(data, "propagate", **sizes["skmba"]),
    ]
    for result in results:
        print_result(result, data)
    theirs = run_surmise(
        data, **sizes["surmise"], blas_threads=args.surmise_blas_threads
    )
    print_result(theirs, data)
    print("Summary" + (" (--quick: smoke run, numbers not meaningful)" * args.quick))
    print(f"  surmise: {rate(theirs):.3g} ESS/s (smallest over E, I)")
    for result in results:
        ratio = rate(result) / rate(theirs)
        print(
            f"  {result['name']}: {rate(result):.3g} ESS/s; ratio skmba / surmise "
            f"= {ratio:.3g} (goal >= 1: {'met' if ratio >= 1 else 'NOT met'})"
        )
    print(f"  total benchmark wall time: {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
