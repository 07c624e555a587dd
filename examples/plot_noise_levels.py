"""
===================================================
Noisy measurements: calibration across noise levels
===================================================

Thesis section 4.7.4 and Table 4.6. Real sensors are noisy. Here the
measurements of the cantilever beam (tip displacement and deformation
energy, 35 of them) are polluted with Gaussian noise at three
signal-to-noise ratios, 30, 18 and 10 dB (Eq. 3.34: at 10 dB the noise
variance is a tenth of the variance of the signal), and the Young's
modulus E is calibrated from each data set against 100 model runs.

:class:`~skmba.ModularBayesCalibrator` estimates one noise variance per
response (``noise_``, module 2) together with the discrepancy, and
carries it into the posterior of E. We compare, in one figure, the
posteriors of E and the estimated noise variances with the true ones.
"""

# %%
# Three data sets, three calibrations
# -----------------------------------
# The same seed gives the same design, observation sites and (scaled)
# noise realisation at every level, so that only the noise level changes.

import matplotlib.pyplot as plt
import numpy as np

from skmba import ModularBayesCalibrator
from skmba.datasets import make_cantilever
from skmba.plotting import plot_posterior

snr_levels = [30, 18, 10]  # dB
results = []
for snr in snr_levels:
    data = make_cantilever(100, 35, snr_db=snr, random_state=1)
    cal = ModularBayesCalibrator(prior=data.prior, random_state=0)
    cal.fit(
        data.X_obs,
        data.y_obs,
        X_sim=data.X_sim,
        theta_sim=data.theta_sim,
        y_sim=data.y_sim,
    )
    results.append((data, cal))
print(
    "identifiability_ of E:",
    ", ".join(f"{cal.identifiability_[0]:.3f}" for _, cal in results),
)

E_true = data.theta_true[0]
print(
    f"{'SNR':>4} {'E mean':>8} {'95 % interval':>18} {'sd':>6} {'error':>7}   "
    "noise variance"
)
print(f"{'dB':>4} {'MPa':>8} {'MPa':>18} {'MPa':>6} {'':>7}   estimated / true")
for snr, (data, cal) in zip(snr_levels, results, strict=True):
    low, high = np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975])
    ratio = cal.noise_ / data.noise_variance
    print(
        f"{snr:4d} {cal.theta_mean_[0]:8.0f} [{low:7.0f}, {high:7.0f}] "
        f"{np.sqrt(cal.theta_cov_[0, 0]):6.0f} "
        f"{cal.theta_mean_[0] / E_true - 1:+7.1%}   "
        + ", ".join(
            f"{name} {r:.2f}"
            for name, r in zip(data.response_names, ratio, strict=True)
        )
    )

# %%
# One figure
# ----------
# Top: the posterior of E at each noise level, on a common axis, with the
# truth; the uniform prior over 20-100 GPa is the flat line at the bottom.
# Bottom left and centre: the estimated noise variance of each response
# against the true one (log scale). Bottom right: posterior mean and 95 %
# interval of E against the noise level, with the truth and the effective
# modulus of the spring-supported beam (see the single-parameter example).

L, I, K = 3000.0, 6.75e8, 1.5e12
E_effective = E_true / (1 + 3 * E_true * I / (K * L))

fig, axes = plt.subplots(2, 3, figsize=(12, 7.5), layout="constrained")
lows, highs = [], []
for ax, snr, (data, cal) in zip(axes[0], snr_levels, results, strict=True):
    plot_posterior(
        cal,
        true_value=data.theta_true,
        names=["E"],
        units=["MPa"],
        limits="posterior",
        ax=ax,
    )
    ax.set_title(f"SNR {snr} dB\n" + ax.get_title(), fontsize="small")
    lows.append(ax.get_xlim()[0])
    highs.append(ax.get_xlim()[1])
for ax in axes[0]:  # a common axis, so that the widths compare
    ax.set_xlim(min(lows), max(highs))
for ax in axes[0, 1:]:
    ax.get_legend().remove()

x = np.arange(len(snr_levels))
for k, ax in enumerate(axes[1, :2]):
    true = [data.noise_variance[k] for data, _ in results]
    estimated = [cal.noise_[k] for _, cal in results]
    ax.bar(x - 0.2, true, width=0.4, color="0.6", label="true")
    ax.bar(x + 0.2, estimated, width=0.4, color="C0", label="estimated (noise_)")
    ax.set_yscale("log")
    ax.set_xticks(x, [f"{snr} dB" for snr in snr_levels])
    ax.set_xlabel("signal-to-noise ratio")
    name, unit = results[0][0].response_names[k], results[0][0].response_units[k]
    ax.set_ylabel(f"noise variance of {name} [{unit}²]")
    ax.legend(fontsize="small")

ax = axes[1, 2]
means = np.array([cal.theta_mean_[0] for _, cal in results])
intervals = np.array(
    [np.quantile(cal.theta_samples_[:, 0], [0.025, 0.975]) for _, cal in results]
)
ax.errorbar(
    x,
    means,
    yerr=[means - intervals[:, 0], intervals[:, 1] - means],
    fmt="o",
    capsize=5,
    label="posterior mean, 95 % interval",
)
ax.axhline(E_true, color="k", linestyle="--", label="true E*")
ax.axhline(E_effective, color="C2", label="effective modulus")
ax.set_xticks(x, [f"{snr} dB" for snr in snr_levels])
ax.set_xlabel("signal-to-noise ratio")
ax.set_ylabel("E [MPa]")
ax.legend(fontsize="small")
plt.show()

# %%
# The noise variances are recovered within about 30 % (estimated over true
# between 0.72 and 0.85) over two orders of magnitude of noise; a variance
# estimated from 35 readings is itself uncertain by about
# ``sqrt(2 / 35)``, some 24 %, and all six estimates are low here, as in
# the validation runs of the cantilever (:ref:`validity`: median 0.87-0.92),
# where the new observations are covered at 0.93 instead of 0.95.
#
# At 30 dB the posterior mean (67925 MPa) sits near the effective modulus of
# the spring-supported beam, about 3 % below E*, with a standard deviation
# of 0.87 GPa, and its 95 % interval stops short of E*: the spring is
# confounded with E (see the single-parameter example), and at every noise
# level ``fit`` raised a :class:`~skmba.exceptions.NonIdentifiabilityWarning`
# (``identifiability_`` 0.13 to 0.21: the data account for a fifth or less
# of the posterior's width). With more noise the data say less
# and the posterior of E widens, from a standard deviation of 0.87 GPa at
# 30 dB to 2.7 GPa at 18 dB and 5.6 GPa at 10 dB, as in the thesis (Table
# 4.6: it increases as the SNR decreases); at 18 and 10 dB the intervals
# are wide enough to contain E*. The interval at 30 dB is not wrong by
# accident: two responses whose model values both scale as 1/E cannot tell
# the spring from a softer beam, and the warning says so. The 30 dB fit
# also warns that the integral over the discrepancy's hyperparameters
# stopped at 4096 draws short of its tolerance: its Monte Carlo errors
# (``summary()``'s mcse columns) are 0.08 posterior sds on the sd and
# 0.13-0.15 on the interval's ends, against 0.05 and 0.1.
