"""
======================================================================
Two design variables: slices of the calibrated prediction, named plots
======================================================================

The cantilever of thesis section 4.7.2 carries a tip force F (1 to 10 kN)
*and* a tip moment M (1 to 30 kN·m): two design variables. We calibrate
Young's modulus E and the second moment of area I and look at the result
with the figures of :mod:`skmba.plotting`:

* :func:`~skmba.plotting.plot_calibrated_components` and
  :func:`~skmba.plotting.plot_gp_prediction` draw a prediction over several
  design variables along one of them with the others held fixed (a
  *slice*), or one block of panels per design variable, or, for two
  design variables, contours over the plane;
* :func:`~skmba.plotting.plot_traces` and
  :func:`~skmba.plotting.plot_posterior` label the parameters with the
  calibrator's ``parameter_names_`` (the keys of a dict prior), and also
  read the ArviZ object of
  :meth:`~skmba.ModularBayesCalibrator.to_inference_data`.
"""

# %%
# Data and calibration
# --------------------
# 60 simulations over (F, M, E, I) and 20 measurements of the real beam,
# whose rotational spring at the support the model does not know. A dict
# prior names the parameters. Units are N, mm and MPa; the moment is in
# N·mm.

import matplotlib.pyplot as plt
import numpy as np

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever
from skmba.plotting import (
    plot_calibrated_components,
    plot_gp_prediction,
    plot_posterior,
    plot_traces,
)

data = make_cantilever(
    60,
    20,
    design_variables=("force", "moment"),
    parameters=("E", "I"),
    random_state=0,
)
prior = dict(zip(data.parameter_names, data.prior, strict=True))
cal = ModularBayesCalibrator(
    prior=prior, n_samples=2000, burn_in=1000, n_jobs=2, random_state=0
)
cal.fit(
    data.X_obs,
    data.y_obs,
    X_sim=data.X_sim,
    theta_sim=data.theta_sim,
    y_sim=data.y_sim,
)
print("parameters:", cal.parameter_names_)
print("split R-hat:", np.round(cal.rhat_, 3))

inputs = ["force [N]", "moment [N·mm]"]
responses = dict(names=data.response_names, units=data.response_units)

# %%
# One block of panels per design variable
# ---------------------------------------
# Without ``X``, the calibrator's components are drawn over the range of
# its field data: along the force with the moment held at the middle of
# its range (top block), then along the moment with the force held at the
# middle of its range (bottom block). The held value is written under each
# abscissa. The measurements were taken at other values of the held
# design variable: they are drawn *projected* on the varied one, so they
# scatter around the bands instead of following them.

fig = plot_calibrated_components(
    cal, X_obs=data.X_obs, y_obs=data.y_obs, input_names=inputs, **responses
)
plt.show()

# %%
# One design variable, the others fixed where we choose
# -----------------------------------------------------
# ``vary`` picks the design variable along the abscissa and ``fixed`` holds
# the others (by index or by name). Here the force varies at a moment of
# 2.5e7 N·mm, with the true process (``data.reality``, a function of the
# design variables) on the observation panels.

fig = plot_calibrated_components(
    cal,
    vary="force [N]",
    fixed={"moment [N·mm]": 2.5e7},
    y_true=data.reality,
    input_names=inputs,
    **responses,
)
plt.show()

# %%
# The calibrated prediction over the plane
# ----------------------------------------
# :func:`~skmba.plotting.plot_gp_prediction` takes any regressor with
# ``predict(X, return_std=True)``, the calibrator included. Given points
# spanning both design variables, it draws contours of the mean and of the
# 95 % half-width of a new measurement over a grid; given points along one
# of them at a fixed value of the other (a line in the plane), it draws
# bands along it.

force = np.linspace(1e3, 1e4, 15)
moment = np.linspace(1e6, 3e7, 15)
plane = np.column_stack([g.ravel() for g in np.meshgrid(force, moment)])
fig = plot_gp_prediction(
    cal, plane, X_train=data.X_obs, input_names=inputs, **responses
)
plt.show()

# %%
line = np.column_stack([force, np.full_like(force, 1e7)])
fig = plot_gp_prediction(cal, line, input_names=inputs, **responses)
plt.show()

# %%
# Traces and posterior, named by the prior
# ----------------------------------------
# The titles and axes carry the names of the dict prior's keys, read from
# ``cal.parameter_names_``; only the units are ours to give. As in the
# one-design-variable example, the tip displacement and the energy depend
# on E and I through their product: the posterior is a ridge along ``E I =
# const``, which a moment at the tip does not break either.

units = ["MPa", "mm⁴"]
fig = plot_traces(cal, units=units, true_value=data.theta_true)
plt.show()

# %%
fig = plot_posterior(cal, units=units, true_value=data.theta_true)
plt.show()

# %%
# From ArviZ
# ----------
# Both figures also read an ArviZ object (``pip install "skmba[arviz]"``):
# the calibrator's own export, or the output of any other sampler. The
# variables of its ``posterior`` group, of dimensions ``(chain, draw)``, are
# the parameters; its ``prior`` group, draws of the prior, is drawn as
# histograms.

try:
    idata = cal.to_inference_data(random_state=0)
except ImportError:
    print("ArviZ is not installed: pip install 'skmba[arviz]'")
else:
    fig = plot_posterior(idata, units=units, true_value=data.theta_true)
    plt.show()
