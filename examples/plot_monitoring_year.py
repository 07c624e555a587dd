"""
=====================================================
A year of monitoring, updated as the readings arrive
=====================================================

A monitoring system logs the air temperature and the first four natural
frequencies of a concrete bridge every hour
(:func:`~skmba.datasets.make_bridge_monitoring`: 8,760 readings, 5 % of
them lost to outages). The finite element model knows how the concrete
softens with temperature, but not that the asphalt and the bearings stiffen
below freezing. Here the calibrator is updated at the end of every month
with :meth:`~skmba.ModularBayesCalibrator.partial_fit`: module 1 (the
emulator of the 60 simulations) is built once, modules 2-3 start where the
last update ended, and the readings at one temperature enter as their mean
and count. ``theta_history_`` records the posterior after each month.

Read more in the User Guide, :ref:`user-guide-monitoring`.
"""

# %%
# The readings and the simulations
# --------------------------------
# A table on an hourly time index: the temperature is the design variable,
# the frequencies the responses. Temperatures are binned by 2 °C
# (``bin_width``): the year's 434 distinct temperatures become 25 means
# per frequency, each with its count, and the frequencies' slope across a
# bin is kept out of the noise estimate. The sampler keeps its defaults:
# an update that adds a month either reweights the last chains' draws (one
# likelihood per effective draw) or, when those no longer stand for the
# posterior, runs new chains.

import time
import warnings

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from skmba import ModularBayesCalibrator
from skmba.datasets import make_bridge_monitoring
from skmba.plotting import plot_theta_history

data = make_bridge_monitoring(random_state=0)
log = data.frame
print(log.head(3))
X, Y = log[["temperature"]], log[list(data.response_names)]
sims = dict(X_sim=data.X_sim, theta_sim=data.theta_sim, y_sim=data.y_sim)

cal = ModularBayesCalibrator(prior=data.prior, bin_width=2.0, random_state=0)

# %%
# Twelve monthly updates
# ----------------------
# The first call carries the simulations; the others add a month each,
# and say how module 3 ran (chains with their R-hat, or the last chains'
# draws reweighted, with their ESS). The first call's warnings are
# printed: the temperature alone cannot tell the deck's modulus E from the
# bearings and the discrepancy (each shifts every frequency). Each update
# reports its own hours without any reading, and checks all the readings so
# far against the simulations again, which repeats the identifiability
# warning and the spread check's (the higher frequencies' readings look
# narrow next to simulations that span the whole prior, a false alarm
# here); they are not printed.

months = log.index.month
for month in range(1, 13):
    rows = months == month
    started = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.partial_fit(X[rows], Y[rows], **(sims if month == 1 else {}))
    seconds = time.perf_counter() - started
    if hasattr(cal, "theta_chains_"):
        how = f"chains, R-hat {np.round(cal.rhat_, 3)}"
    else:
        how = f"reweighted, ESS {np.round(cal.ess_)}"
    print(f"month {month:2d}: {seconds:5.1f} s, {how}")
    if month == 1:
        for w in caught:
            print(f"  {w.category.__name__}: {str(w.message)[:110]}...")

history = cal.theta_history_
print(history[["n_readings", "n_means", "E_mean", "E_sd", "k_bearing_mean"]])

# %%
# The parameters over the year
# ----------------------------
# The bands are the 95 % intervals after each month, against the true
# values of the simulation. E's stays near its prior: the frequencies
# scale with the square root of E I / m and with the bearings together.

fig = plot_theta_history(cal, true_value=data.theta_true, units=data.parameter_units)
fig.suptitle("Posterior after each monthly update")

# %%
# What the discrepancy learned: frost
# -----------------------------------
# The fitted discrepancy of each frequency against the temperature, with
# its 95 % band, and the readings minus the model at the posterior mean.
# Above freezing reality is the model and the discrepancy is flat; below,
# it rises in every frequency: the bridge stiffens with every degree of
# frost, at -15 °C by about 12 % of the first frequency and 24 % of the
# fourth. The band is wide because the discrepancy's level trades with E
# and the bearings; its shape in temperature is what the data fix.

grid = pd.DataFrame({"temperature": np.linspace(-15.0, 33.0, 120)})
delta, delta_std = cal.predict_discrepancy(grid, return_std=True)
model_at_mean = cal.predict_model(X)
fig, axes = plt.subplots(2, 2, figsize=(9, 6), sharex=True, layout="constrained")
for k, ax in enumerate(axes.ravel()):
    name = data.response_names[k]
    residual = Y[name].to_numpy() - model_at_mean[:, k]
    ax.plot(
        X["temperature"], residual, ".", ms=1, color="0.6", label="readings - model"
    )
    ax.fill_between(
        grid["temperature"],
        delta[:, k] - 1.96 * delta_std[:, k],
        delta[:, k] + 1.96 * delta_std[:, k],
        alpha=0.3,
        label="discrepancy, 95 %",
    )
    ax.plot(grid["temperature"], delta[:, k])
    ax.axvline(0.0, color="k", lw=0.8, ls=":")
    ax.set_title(name)
    ax.set_ylabel("Hz")
axes[0, 0].legend(fontsize="small")
for ax in axes[1]:
    ax.set_xlabel("temperature [°C]")
plt.show()
