"""What sets theta's interval: refits under a stated class of discrepancy priors.

:class:`PriorSensitivityMixin` gives the calibrator
:meth:`~PriorSensitivityMixin.prior_sensitivity`: the same readings and
simulations refitted with the discrepancy prior's roughness range and size
scaled down and up (:func:`prior_variants`), and theta's posterior under
each, beside the fit's own. An interval the data set barely moves; one the
prior sets moves with it. The refits are fits like any other (same
settings and ``random_state``), so their differences include module 2's
Monte Carlo error (``discrepancy_tol`` bounds it for one parameter).

Examples
--------
>>> prior_variants({"roughness": (0.1, 9.0)}, "propagate", 10.0, 4.0)[1]
('roughness/10', {'roughness': (0.01, 0.9)})
"""

import warnings
from numbers import Real

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from skmba.calibration._summary import table
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._table_6_2 import TABLE_6_2_RANGES

#: The columns of :meth:`PriorSensitivityMixin.prior_sensitivity`.
SENSITIVITY_COLUMNS = (
    "mean",
    "sd",
    "2.5%",
    "97.5%",
    "sd_ratio",
    "shift",
    "r_hat",
    "prior_share",
)


def prior_variants(spec, treatment, roughness_factor, size_factor):
    """The class of discrepancy priors: ``[(name, discrepancy_prior), ...]``.

    The user's ``spec`` (None: the defaults) first, then its roughness range
    divided and multiplied by ``roughness_factor`` (smoother and rougher
    discrepancies: correlation lengths times and divided by its square root
    with the Gauss kernel), then its size divided and multiplied by
    ``size_factor`` (``sd_scale`` under "propagate", the variance range by
    its square under "plug-in"). A roughness of None (the kernel's own
    bounds) has no variants.
    """
    spec = dict(spec or {})
    if treatment == "propagate":
        full = {**vars(Hyperprior.from_spec(spec))}
        full.pop("units")
        size_key, size_power = "sd_scale", 1
    else:
        full = {**TABLE_6_2_RANGES, **spec}
        size_key, size_power = "variance", 2
    out = [("default", spec)]
    for key, factor, power in (
        ("roughness", roughness_factor, 1),
        (size_key, size_factor, size_power),
    ):
        value = full.get(key)
        if value is None:
            continue
        for word, scale in (("/", 1.0 / factor), ("*", factor)):
            moved = _scaled(value, scale**power)
            out.append((f"{key}{word}{factor:g}", {**spec, key: moved}))
    return out


def _scaled(value, scale):
    """A number, array or ``(low, high)`` range times ``scale``."""
    if isinstance(value, tuple):
        return tuple(_scaled(v, scale) for v in value)
    scaled = np.asarray(value, dtype=float) * scale
    return float(scaled) if scaled.ndim == 0 else scaled


def _refit(estimator, spec, data):
    """``estimator`` refitted with ``discrepancy_prior=spec`` on ``data``:
    its posterior samples and the largest R-hat (NaN for quadrature)."""
    X, y, X_sim, theta_sim, y_sim = data
    refit = clone(estimator).set_params(discrepancy_prior=spec, simulator=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refit.fit(X, y, X_sim=X_sim, theta_sim=theta_sim, y_sim=y_sim)
    rhat = getattr(refit, "rhat_", None)
    return refit.theta_samples_, np.nan if rhat is None else float(np.max(rhat))


class PriorSensitivityMixin:
    """:meth:`prior_sensitivity` for :class:`~skmba.ModularBayesCalibrator`."""

    def prior_sensitivity(self, *, roughness_factor=10.0, size_factor=4.0, n_jobs=None):
        """Theta's posterior under a stated class of discrepancy priors.

        The fit's readings and simulations (``X_obs_``, ``y_obs_``,
        ``X_sim_``, ``theta_sim_``, ``y_sim_``; the simulator is not run
        again) are refitted with the discrepancy prior's roughness range
        divided and multiplied by ``roughness_factor`` and its size by
        ``size_factor`` (``sd_scale``; with the plug-in, the variance range
        by its square), each with the fit's own settings and
        ``random_state``. Four refits, each as costly as ``fit``; their
        warnings are not repeated. Read more in the User Guide ("What sets
        the interval's width").

        Parameters
        ----------
        roughness_factor : float > 1, default=10.0
            10: correlation lengths 3.2 times longer and shorter (Gauss).
        size_factor : float > 1, default=4.0
        n_jobs : int, default=None
            Refits in parallel through joblib.

        Returns
        -------
        pandas.DataFrame or numpy structured array
            Indexed by ``variant[parameter]``, ``default`` first (the fit
            itself). Columns: the posterior ``mean``, ``sd``, ``2.5%`` and
            ``97.5%``; ``sd_ratio``, the sd over the fit's; ``shift``, the
            mean's change in the fit's sds; ``r_hat``, the largest R-hat
            of a refit's chains (NaN for quadrature); ``prior_share``, the
            interval's width over that of the prior's central 95 %. Last,
            a ``union[parameter]`` row per parameter: the union of the
            rows' intervals, theta's 95 % range over the stated class of
            discrepancy priors (robust Bayes, Berger 1994), with its
            ``prior_share`` and largest ``r_hat`` (the other columns NaN).
            It is as wide as the class is: a discrepancy shaped like
            theta's effect can lie outside every prior of the class (User
            Guide, "What sets the interval's width").
        """
        check_is_fitted(self, "theta_mean_")
        for name, value in (("roughness_factor", roughness_factor),
                            ("size_factor", size_factor)):  # fmt: skip
            if not (isinstance(value, Real) and np.isfinite(value) and value > 1):
                raise ValueError(f"{name} must be a number > 1, got {value!r}.")
        variants = prior_variants(
            self.discrepancy_prior,
            self.discrepancy_uncertainty,
            roughness_factor,
            size_factor,
        )
        data = (self.X_obs_, self.y_obs_, self.X_sim_, self.theta_sim_, self.y_sim_)
        refits = Parallel(n_jobs=n_jobs)(
            delayed(_refit)(self, spec, data) for _, spec in variants[1:]
        )
        rhat = getattr(self, "rhat_", None)
        own = (self.theta_samples_, np.nan if rhat is None else float(np.max(rhat)))
        prior_width = np.diff(self.prior_.bounds(0.95), axis=1)[:, 0]
        return _sensitivity_table(
            [name for name, _ in variants],
            [own, *refits],
            self.parameter_names_,
            prior_width,
        )


def _sensitivity_table(names, fits, parameters, prior_width):
    """The table of :meth:`PriorSensitivityMixin.prior_sensitivity`; the
    prior's central 95 % widths ``prior_width`` (r,)."""
    rows, values = [], []
    base_mean = np.mean(fits[0][0], axis=0)
    base_sd = np.std(fits[0][0], axis=0, ddof=1)
    for name, (samples, rhat) in zip(names, fits, strict=True):
        mean, sd = np.mean(samples, axis=0), np.std(samples, axis=0, ddof=1)
        ends = np.quantile(samples, [0.025, 0.975], axis=0)
        for j, parameter in enumerate(parameters):
            rows.append(f"{name}[{parameter}]")
            values.append(
                [
                    mean[j],
                    sd[j],
                    ends[0, j],
                    ends[1, j],
                    sd[j] / base_sd[j],
                    (mean[j] - base_mean[j]) / base_sd[j],
                    rhat,
                    (ends[1, j] - ends[0, j]) / prior_width[j],
                ]
            )
    r, col = len(parameters), SENSITIVITY_COLUMNS.index
    for j, parameter in enumerate(parameters):
        each = np.array(values[j::r])  # parameter j's row of every fit
        lo, hi = each[:, col("2.5%")].min(), each[:, col("97.5%")].max()
        rhats = each[:, col("r_hat")]
        rhat = np.nan if np.all(np.isnan(rhats)) else np.nanmax(rhats)
        rows.append(f"union[{parameter}]")
        nan = np.nan
        values.append([nan, nan, lo, hi, nan, nan, rhat, (hi - lo) / prior_width[j]])
    columns = np.array(values, dtype=float).T
    return table("variant", rows, dict(zip(SENSITIVITY_COLUMNS, columns, strict=True)))
