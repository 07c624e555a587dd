"""Figures for Gaussian processes, calibration and sensor design.

The functions of this module draw what the numbers of :mod:`skmba` mean:
prediction bands of a :class:`~skmba.MultiResponseGP`, the model,
discrepancy and observation components of a calibrated
:class:`~skmba.ModularBayesCalibrator` (thesis Figs. 4.14, 5.9), posteriors
of the calibration parameters against their prior and the truth (Figs.
4.13, 4.22, 4.33), MCMC traces (Fig. 4.21), the posterior over the updates
of a monitored structure and its changes against a reference state, and the
criteria of a preposterior sensor design (Figs. 6.3, 6.5, 6.7).

matplotlib is an optional dependency (``pip install skmba[plot]``); it is
imported when a function is called, not when :mod:`skmba` is imported.

Conventions:

* 95 % bands are ``mean ± 1.96 std``.
* Predictions over several design variables are drawn along one of them
  with the others held fixed (``vary``, ``fixed``; by default at the
  middle of their range), one block of panels per design variable, or,
  for two of them, as contours over a grid of the plane.
* Posterior figures take a fitted calibrator, an ArviZ ``InferenceData``
  (or ``DataTree``) such as the calibrator's ``to_inference_data()``, or
  an array; the parameters are named by the calibrator's
  ``parameter_names_`` or the ArviZ variables unless ``names`` is given.
* ``names`` label the responses (or the parameters); by default they are
  the names the fitted estimator recorded (``parameter_names_``,
  ``response_names_``, ``feature_names_in_``) when it has them, else ``y0,
  y1, ...`` (responses), ``θ0, θ1, ...`` (parameters) and ``x0, x1, ...``
  (inputs), 0-based like the columns they label. ``units`` add
  ``" [unit]"`` to the axis labels.
* ``ax`` is where to draw: an Axes, or an array of Axes for multi-panel
  figures, or None to create a new figure. A function that draws one panel
  returns its Axes; one that draws several returns the Figure.

Examples
--------
>>> import matplotlib
>>> matplotlib.use("Agg")
>>> import numpy as np
>>> from skmba.plotting import plot_posterior
>>> draws = np.random.default_rng(0).normal([1.0, 5.0], [0.1, 0.5], (500, 2))
>>> fig = plot_posterior(draws, true_value=[1.0, 5.0], names=["a", "b"])
>>> fig.axes[2].get_xlabel(), fig.axes[3].get_xlabel()
('a', 'b')
"""

from skmba.plotting._bands import plot_gp_prediction
from skmba.plotting._change import plot_change_history
from skmba.plotting._components import plot_calibrated_components
from skmba.plotting._history import plot_theta_history
from skmba.plotting._posterior import plot_posterior
from skmba.plotting._sensor_design import (
    plot_convergence,
    plot_criterion_by_size,
    plot_criterion_vs_bias,
    plot_warning_rate,
)
from skmba.plotting._traces import plot_traces

__all__ = [
    "plot_calibrated_components",
    "plot_change_history",
    "plot_convergence",
    "plot_criterion_by_size",
    "plot_criterion_vs_bias",
    "plot_gp_prediction",
    "plot_posterior",
    "plot_theta_history",
    "plot_traces",
    "plot_warning_rate",
]
