"""
=======================================================
A finite element engine as the simulator: OpenSeesPy
=======================================================

The monitored bridge of :func:`~skmba.datasets.make_bridge_monitoring` is a
30 m concrete deck on two bearings whose natural frequencies a monitoring
system logs every hour. Here its simulator is a real finite element
program, OpenSees, through :class:`~skmba.datasets.OpenSeesBridgeModel`:
the same deck as the numpy :class:`~skmba.datasets.BridgeModel`, built from
``elasticBeamColumn`` elements and solved by ``ops.eigen``, each analysis
in a worker process of its own. We check it against the numpy model, time
it, and calibrate the deck's Young's modulus ``E`` and the bearings'
stiffness ``k_bearing`` on readings spread over a year, with one run in
twenty made to fail.

It needs ``pip install "skmba[opensees]"`` (and on Linux the system BLAS
and LAPACK, Debian's ``libblas3`` and ``liblapack3``). Read more in the
User Guide, :ref:`user-guide-monitoring-data`.
"""

# %%
# The same deck in two programs
# -----------------------------
# Four modes at three temperatures, a pinned deck among them.

import time
import warnings

import matplotlib.pyplot as plt
import numpy as np

from skmba import ModularBayesCalibrator
from skmba.datasets import (
    BridgeModel,
    OpenSeesBridgeModel,
    make_bridge_monitoring,
    youngs_modulus_at,
)

X = np.array([[20.0], [-5.0], [10.0]])
theta = np.array([[35e9, 3e9], [30e9, 1e9], [40e9, np.inf]])
opensees = OpenSeesBridgeModel(n_jobs=2)
f_opensees, f_numpy = opensees(X, theta), BridgeModel()(X, theta)
print(np.round(f_opensees, 4))
print(f"largest relative difference: {np.max(np.abs(f_opensees / f_numpy - 1)):.1e}")

# %%
# The time of an analysis
# -----------------------
# ``timed_states`` gives the seconds of each analysis (rigidity ``EI`` and
# bearing stiffness per row); the first call also starts the workers.

rng = np.random.default_rng(0)
states = np.column_stack([rng.uniform(5e10, 9e10, 60), rng.uniform(5e8, 1e10, 60)])
started = time.perf_counter()
_, seconds = opensees.timed_states(states)
wall = time.perf_counter() - started
print(
    f"60 analyses: median {1e3 * np.median(seconds):.1f} ms each, "
    f"{wall:.2f} s of wall time on 2 workers"
)

# %%
# Calibrating with OpenSees runs, one in twenty failing
# -----------------------------------------------------
# Readings every 146 hours over a year (60 readings of the first two
# modes, gaps left out), 60 OpenSees runs on a Latin hypercube. Every
# twentieth run (20, 40 and 60) gets a negative modulus: OpenSees finds negative
# eigenvalues, the run returns NaN and the calibrator sets it aside.


class EveryTwentiethFails:
    """The OpenSees simulator with runs 20, 40, ... made to fail."""

    def __init__(self, model):
        self.model = model

    def __call__(self, X, theta):
        E = youngs_modulus_at(theta[:, 0], X[:, 0])
        sign = np.where(np.arange(1, len(X) + 1) % 20 == 0, -1.0, 1.0)
        rigidity = sign * E * self.model.second_moment
        return self.model.timed_states(np.column_stack([rigidity, theta[:, 1]]))[0]


data = make_bridge_monitoring(n_modes=2, random_state=0)
rows = np.arange(0, len(data.X_obs), 146)
X_field, y_field = data.X_obs[rows], data.y_obs[rows]
measured = np.isfinite(y_field).all(axis=1)
cal = ModularBayesCalibrator(
    simulator=EveryTwentiethFails(OpenSeesBridgeModel(n_modes=2, n_jobs=2)),
    prior=data.prior,
    n_simulations=60,
    n_samples=2000,
    burn_in=2000,
    random_state=0,
)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    cal.fit(X_field[measured], y_field[measured])
print(f"failed runs: {len(cal.simulation_failures_)}, kept: {len(cal.X_sim_)}")
print(cal.summary(kind="text"))
for w in caught:
    print(f"{w.category.__name__}: {str(w.message)[:160]}...")

# %%
# The failed runs are listed with their inputs; the rest were used. The
# posterior of ``E`` stays close to its prior, and the calibrator says why:
# with the temperature as the only design variable, a discrepancy of
# plausible size can mimic a change of ``E`` (``identifiability_``).

# %%
# What the model lacks
# --------------------
# Below freezing the bridge stiffens and the model does not: the fitted
# discrepancy carries the knee of the first frequency. The band is the
# calibrated prediction of the bridge (95 %).

T = np.linspace(-15.0, 30.0, 91)[:, None]
mean, sd = cal.predict_reality(T, return_std=True)
model_mean = cal.predict_model(T)
fig, ax = plt.subplots(figsize=(6.0, 3.6))
ax.plot(X_field, y_field[:, 0], ".", color="0.4", label="readings")
ax.plot(T[:, 0], model_mean[:, 0], "--", label="calibrated model")
ax.plot(T[:, 0], mean[:, 0], label="model + discrepancy")
ax.fill_between(T[:, 0], mean[:, 0] - 1.96 * sd[:, 0], mean[:, 0] + 1.96 * sd[:, 0],
                alpha=0.3)  # fmt: skip
ax.set(xlabel="air temperature [°C]", ylabel="f1 [Hz]")
ax.legend()
fig.tight_layout()
plt.show()
