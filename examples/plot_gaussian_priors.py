"""
=====================================================
Gaussian priors: what the engineer knew beforehand
=====================================================

Thesis section 4.7.7. The previous examples used uniform priors, which say
only "E is somewhere between 20 and 100 GPa". Often the engineer knows
more: a nominal value and a tolerance. Here the cantilever beam is
calibrated with Gaussian priors, deliberately centred *off* the truth as in
the thesis (Eq. 4.54), to see how the data correct a wrong prior:

* one parameter, ``E ~ N(50, 10²)`` GPa (truth 70 GPa), a frozen
  ``scipy.stats.norm``;
* two parameters, E and I jointly, a frozen
  ``scipy.stats.multivariate_normal`` with means (53 GPa, 4.72e8 mm⁴) and
  standard deviations (10 GPa, 6.7e7 mm⁴), uncorrelated (truth 70 GPa,
  6.75e8 mm⁴).

Any prior with a ``logpdf`` and ``rvs`` works the same way;
:func:`~skmba.plotting.plot_posterior` draws the prior's marginal
densities next to the posterior.
"""

# %%
# One parameter: a univariate Gaussian prior
# ------------------------------------------

import matplotlib.pyplot as plt
import numpy as np

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever
from skmba.plotting import plot_posterior

data = make_cantilever(70, 25, prior="gaussian", random_state=1)
prior = data.prior[0]
print(f"prior: E ~ {prior.dist.name}({prior.mean():.4g}, {prior.std():.4g}²) MPa")
cal = ModularBayesCalibrator(prior=data.prior, random_state=0)
cal.fit(
    data.X_obs,
    data.y_obs,
    X_sim=data.X_sim,
    theta_sim=data.theta_sim,
    y_sim=data.y_sim,
)
low, high = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
print(
    f"posterior: E = {cal.theta_mean_[0]:.0f} MPa, 95 % [{low:.0f}, {high:.0f}] "
    f"(truth {data.theta_true[0]:.0f} MPa)"
)

# %%
# The data override the prior: the prior put the truth two standard
# deviations away, and the posterior mean is 67840 MPa, the effective
# modulus (67862 MPa) of the single-parameter example. The spring at the
# support is confounded with E there and here (``fit`` raises a
# :class:`~skmba.exceptions.NonIdentifiabilityWarning`), so the data fix the
# effective modulus and E* lies outside the 95 % interval: with these two
# responses only a prior that already knew E could place it. The posterior
# standard deviation, about 83 MPa, is some 120 times smaller than the
# prior's 10 GPa, so we draw the posterior twice: over the prior's range,
# where its peak is cut off to keep the prior visible, and zoomed.

fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
for ax, limits, title in zip(
    axes,
    ("prior", "posterior"),
    ("the prior's range (posterior's peak cut off)", "zoom on the posterior"),
    strict=True,
):
    plot_posterior(
        cal,
        true_value=data.theta_true,
        names=["E"],
        units=["MPa"],
        limits=limits,
        ax=ax,
    )
    ax.set_title(f"{title}\n{ax.get_title()}", fontsize="small")
axes[0].set_ylim(0, 1.5 * data.prior[0].pdf(data.prior[0].mean()))
axes[0].legend(fontsize="small", loc="upper left")
plt.show()

# %%
# Two parameters: a bivariate Gaussian prior
# ------------------------------------------
# E and I, sampled by Metropolis-Hastings (four chains, run in parallel
# with ``n_jobs=2``). The thesis uses 170 simulations and 70 measurements;
# 120 and 40 keep the example fast.

data2 = make_cantilever(
    120, 40, parameters=("E", "I"), prior="gaussian", random_state=0
)
mean, sd = data2.prior.mean, np.sqrt(np.diag(data2.prior.cov))
print(
    f"prior: E ~ N({mean[0]:.4g}, {sd[0]:.3g}²) MPa, "
    f"I ~ N({mean[1]:.4g}, {sd[1]:.3g}²) mm⁴"
)
cal2 = ModularBayesCalibrator(
    prior=data2.prior, n_samples=2000, burn_in=1000, n_jobs=2, random_state=0
)
cal2.fit(
    data2.X_obs,
    data2.y_obs,
    X_sim=data2.X_sim,
    theta_sim=data2.theta_sim,
    y_sim=data2.y_sim,
)
E, I = cal2.theta_samples_.T
print("split R-hat:", np.round(cal2.rhat_, 4))
for name, draws, truth in (
    ("E", E, data2.theta_true[0]),
    ("I", I, data2.theta_true[1]),
    ("EI", E * I, np.prod(data2.theta_true)),
):
    low, high = np.quantile(draws, [0.025, 0.975])
    print(
        f"{name:>2}: mean {draws.mean():.4g}, 95 % [{low:.4g}, {high:.4g}], "
        f"truth {truth:.4g}"
    )
print("posterior correlation of E and I:", np.corrcoef(E, I)[0, 1].round(3))
print("posterior covariance:\n", np.array2string(cal2.theta_cov_, precision=3))

# %%
# As in the thesis (Eq. 4.55), E and I come out negatively correlated: the
# data constrain the bending stiffness EI, so a stiffer material goes with
# a smaller section. How EI splits into E and I, the data cannot say; the
# prior decides. The posterior settles where the ridge ``E I ≈ const``
# passes through high prior density. Both prior means are too low, and E
# has the larger relative prior spread (19 % against 14 % for I), so E
# moves further from its prior mean than I does (by 40 % against 31 %): E
# ends 6 % above its truth and I 8.6 % below, both truths inside their 95 %
# intervals.
#
# EI itself is where the uniform priors of the two-parameter example put
# it: at the effective stiffness of the spring-supported beam (mean
# 4.572e13 N·mm², 3.2 % below E* I*, which lies outside its 95 % interval),
# with a posterior CV of about 1.3 %. The prior, whose means give an EI of
# 2.5e13 N·mm², about half the truth, has no pull left on it: the data fix
# the effective stiffness, and ``fit`` warns that the spring cannot be told
# from a softer beam. The correlation of E and I, -0.969, is nearly as
# strong as under uniform priors (-0.985), while the Gaussian priors shorten
# the ridge (posterior CVs of E and I of 5.7 % and 5.6 %, against 21 % and
# 18 %).

fig = plot_posterior(
    cal2,
    true_value=data2.theta_true,
    names=["E", "I"],
    units=["MPa", "mm⁴"],
    limits="prior",
)
scatter = fig.axes[2]
E_grid = np.linspace(*scatter.get_xlim(), 200)
EI_true = np.prod(data2.theta_true)
scatter.plot(E_grid, EI_true / E_grid, color="C3", label="E I = E* I*")
scatter.plot(*data2.prior.mean, "s", color="C1", label="prior mean")
scatter.legend(fontsize="small")
plt.show()

# %%
# The prior densities (orange) sit away from the truth (dashed) and the
# posterior histograms far from the priors, E's above its truth and I's
# below it; the cloud of draws lies just below the curve of the true
# stiffness, along the effective one. A measurement that separates E from I
# and the spring from both, or a better prior, would move the posterior
# onto the truth; more displacement and energy data would only sharpen the
# ridge around the effective stiffness.
