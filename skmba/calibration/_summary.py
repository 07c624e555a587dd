"""Summaries of fitted estimators: tables, a line for logs, ArviZ export.

* :class:`CalibrationSummaryMixin`: the calibrator's ``summary`` (the
  posterior of each calibration parameter: mean, sd, 95 % interval, prior
  mean and sd, R-hat, bulk ESS, identifiability) as a table or one line of
  text, and ``to_inference_data`` (chains, prior draws and field data as an
  ArviZ ``InferenceData`` with ArviZ 0.x or ``DataTree`` with 1.x, through
  ``arviz.from_dict``), from its public fitted attributes;
* :func:`table`: a pandas ``DataFrame`` when pandas is installed, a numpy
  structured array otherwise (the same columns; the row labels become a
  first field);
* :func:`history_row`, :func:`history_table`: the calibrator's
  ``theta_history_``, the posterior after each ``partial_fit``.

Examples
--------
>>> from skmba.calibration._summary import table
>>> table("k", [1, 2], {"score": [0.5, 0.25]}).shape
(2, 1)
"""

import math
import warnings

import numpy as np
from scipy import stats
from sklearn.utils.validation import check_is_fitted

from skmba.kernels import Gauss
from skmba.priors._hyperprior import Hyperprior
from skmba.priors._table_6_2 import check_discrepancy_ranges

#: What to install for ``to_inference_data``.
ARVIZ_EXTRA = 'pip install "skmba[arviz]"'

#: The columns of the calibrator's ``summary()``, in order.
CALIBRATION_COLUMNS = (
    "mean",
    "sd",
    "2.5%",
    "97.5%",
    "mcse_mean",
    "mcse_sd",
    "mcse_2.5%",
    "mcse_97.5%",
    "prior_mean",
    "prior_sd",
    "sd_ratio",
    "r_hat",
    "ess_bulk",
    "identifiability",
)


#: The columns of the calibrator's ``discrepancy_prior_summary()``.
PRIOR_COLUMNS = ("prior_2.5%", "prior_97.5%", "fitted", "field_spread", "prior_unit")


def _log_uniform_quantiles(bounds, p=(0.025, 0.975)):
    """Quantiles ``p`` of a log-uniform law on ``bounds`` (NaN for None)."""
    if bounds is None:
        return np.full(len(p), np.nan)
    lo, hi = np.log(np.asarray(bounds, dtype=float).reshape(2, -1)[:, 0])
    return np.exp(lo + np.asarray(p) * (hi - lo))


def parameter_names(prior):
    """The names of a prior's parameters: its ``names``, else theta0, theta1...

    Examples
    --------
    >>> from scipy import stats
    >>> from skmba.priors._theta import check_prior
    >>> parameter_names(check_prior([stats.norm(0, 1), stats.norm(0, 1)]))
    ['theta0', 'theta1']
    >>> parameter_names(check_prior({"E": stats.norm(0, 1)}))
    ['E']
    """
    names = getattr(prior, "names", None)
    if names is None:
        return [f"theta{j}" for j in range(prior.dim)]
    return [str(name) for name in names]


def _pandas():
    """The pandas module, or None when it cannot be imported."""
    try:
        import pandas
    except ImportError:
        return None
    return pandas


def table(index_name, index, columns):
    """A DataFrame (pandas) or a structured array of named columns."""
    pandas = _pandas()
    if pandas is not None:
        frame = pandas.DataFrame(columns, index=pandas.Index(index, name=index_name))
        return frame
    fields = [(index_name, np.asarray(index).dtype)]
    for name, values in columns.items():
        fields.append((name, np.asarray(values).dtype))
    table = np.empty(len(index), dtype=fields)
    table[index_name] = index
    for name, values in columns.items():
        table[name] = values
    return table


#: The statistics of each parameter in ``theta_history_``, column suffixes.
HISTORY_STATISTICS = ("mean", "sd", "2.5%", "97.5%")


def history_row(label, readings, posterior):
    """One update of ``theta_history_``: the label of its last reading, the
    readings behind it (a :class:`~skmba.calibration._field_replicates.
    FieldReadings`) and the posterior of theta after it (``samples``,
    ``mean``, ``cov``, user units)."""
    samples = posterior.samples
    return {
        "label": label,
        "n_readings": readings.n_readings,
        "n_means": len(readings.X),
        "statistics": np.vstack(
            [
                posterior.mean,
                np.sqrt(np.diag(posterior.cov)),
                np.quantile(samples, 0.025, axis=0),
                np.quantile(samples, 0.975, axis=0),
            ]
        ),
    }


def history_table(rows, names):
    """``theta_history_``: one row per update (:func:`history_row`), indexed
    by its last reading's label (``until``): the readings and distinct
    inputs (``n_means``) so far, and ``<name>_<statistic>`` per parameter."""
    columns = {
        "n_readings": np.array([row["n_readings"] for row in rows]),
        "n_means": np.array([row["n_means"] for row in rows]),
    }
    stats_ = np.stack([row["statistics"] for row in rows])  # (updates, 4, r)
    for j, name in enumerate(names):
        for i, statistic in enumerate(HISTORY_STATISTICS):
            columns[f"{name}_{statistic}"] = stats_[:, i, j]
    return table("until", [row["label"] for row in rows], columns)


# ------------------------------------------------------------- calibrator
def _import_arviz():
    """The arviz module, or an ImportError that names the extra."""
    try:
        with warnings.catch_warnings():
            # ArviZ 0.x announces its refactor with a FutureWarning on import.
            warnings.simplefilter("ignore", FutureWarning)
            import arviz
    except ImportError as error:
        raise ImportError(
            "to_inference_data needs ArviZ, an optional dependency of skmba: "
            f"{ARVIZ_EXTRA} (or pip install arviz)."
        ) from error
    return arviz


#: The note on the posterior group of a quadrature fit.
QUADRATURE_NOTE = (
    "One-parameter posterior computed by adaptive Gauss-Legendre quadrature; "
    "the draws are theta_samples_ (stratified inverse-CDF draws from it) in "
    "a random order, stored as one pseudo-chain. They are not a Markov "
    "chain: R-hat and ESS do not apply."
)
#: The same with several parameters (``discrepancy_tol``): weighted nodes.
NODES_NOTE = (
    "Posterior of several parameters computed by importance sampling at "
    "weighted nodes (theta_nodes_, theta_weights_; discrepancy_tol); the "
    "draws are theta_samples_ (systematically resampled from the nodes, so "
    "some repeat) in a random order, stored as one pseudo-chain. They are "
    "not a Markov chain: R-hat and ESS do not apply."
)
#: The same for an update that reweighted the last run's draws.
REWEIGHTED_NOTE = (
    "Posterior of an update (partial_fit) computed by reweighting the last "
    "MCMC run's thinned draws (theta_nodes_, theta_weights_) to it; the "
    "draws are theta_samples_ (systematically resampled from them, so some "
    "repeat) in a random order, stored as one pseudo-chain. They are not a "
    "Markov chain: R-hat does not apply; ess_ is the run's ESS times the "
    "weights' Kish share."
)
#: The same for the best-fit estimand's draws.
BEST_FIT_NOTE = (
    "The best fit: independent joint draws of reality at the field inputs, "
    "each projected on the model by least squares (estimand='best_fit'), in "
    "a random order, stored as one pseudo-chain; module 3's posterior of the "
    "physical parameter is the calibrator's theta_chains_ or theta_nodes_. "
    "Not a Markov chain: R-hat and ESS do not apply."
)


class CalibrationSummaryMixin:
    """``summary`` and ``to_inference_data`` of
    :class:`~skmba.ModularBayesCalibrator`, from its public fitted attributes."""

    def to_inference_data(self, *, n_prior_draws=None, random_state=0):
        """The posterior, prior and field data as an ArviZ object.

        Built with ``arviz.from_dict`` (an ``InferenceData`` with ArviZ 0.x,
        a ``DataTree`` with 1.x) with the groups ``posterior`` (one variable
        per name of ``parameter_names_``, dims (chain, draw); with
        quadrature one pseudo-chain of independent draws, said in its
        ``note`` attribute; with ``discrepancy_tol``, the Monte Carlo
        errors ``mcse_mean_<name>``, ``mcse_sd_<name>``,
        ``mcse_2.5%_<name>``, ``mcse_97.5%_<name>`` and
        ``discrepancy_draws`` as attributes), ``sample_stats`` (MCMC: ``lp``,
        ``acceptance_rate``), ``prior``, ``observed_data`` and
        ``constant_data``. Read more in :ref:`user-guide-diagnostics`.

        Parameters
        ----------
        n_prior_draws : int, default=None
            Prior draws; None means as many as posterior draws.
        random_state : int, Generator or None, default=0
            Seeds the prior draws (and the order of quadrature draws).

        Returns
        -------
        arviz.InferenceData or xarray.DataTree

        Raises
        ------
        ImportError
            Without ArviZ: install the extra, ``pip install "skmba[arviz]"``.
        """
        check_is_fitted(self, "theta_mean_")
        return self._inference_data(n_prior_draws, random_state)

    def summary(self, kind="table"):
        """The posterior of each calibration parameter.

        Parameters
        ----------
        kind : {"table", "text"}, default="table"
            ``"table"``: one row per parameter with ``mean``, ``sd``,
            ``2.5%``, ``97.5%``, their Monte Carlo standard errors from the
            integral over the discrepancy hyperparameters (``mcse_mean``,
            ``mcse_sd``, ``mcse_2.5%``, ``mcse_97.5%``: ``theta_mcse_``, NaN
            for the plug-in), ``prior_mean``, ``prior_sd``,
            ``sd_ratio`` (posterior over prior sd), ``r_hat``, ``ess_bulk`` (NaN with
            quadrature and for the best fit, whose draws are independent) and
            ``identifiability`` (of the physical parameter, module 3's).
            ``"text"``: the same on one line, for logs.

        Returns
        -------
        pandas.DataFrame, numpy structured array or str
            A DataFrame indexed by parameter name when pandas is installed,
            else a structured array with a first field ``parameter``.
        """
        check_is_fitted(self, "theta_mean_")
        if kind == "text":
            return self._summary_text()
        if kind != "table":
            raise ValueError(f'kind must be "table" or "text"; got {kind!r}.')
        return table("parameter", self.parameter_names_, self._posterior_columns())

    def _posterior_columns(self):
        """The columns of :meth:`summary` as a dict of (r,) arrays."""
        samples = self.theta_samples_
        r = samples.shape[1]
        sd = np.sqrt(np.diag(self.theta_cov_))
        prior_sd = np.sqrt(np.diag(self.prior_.cov()))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = sd / prior_sd
        nan = np.full(r, np.nan)
        chains = getattr(self, "estimand_", "physical") == "physical"
        columns = {
            "mean": np.asarray(self.theta_mean_, dtype=float),
            "sd": sd,
            "2.5%": np.quantile(samples, 0.025, axis=0),
            "97.5%": np.quantile(samples, 0.975, axis=0),
            **dict(zip(CALIBRATION_COLUMNS[4:8], self._mcse(r), strict=True)),
            "prior_mean": self.prior_.mean(),
            "prior_sd": prior_sd,
            "sd_ratio": ratio,
            "r_hat": np.asarray(getattr(self, "rhat_", nan) if chains else nan, float),
            "ess_bulk": np.asarray(
                getattr(self, "ess_", nan) if chains else nan, float
            ),
            "identifiability": np.asarray(self.identifiability_, dtype=float),
        }
        return columns

    def discrepancy_prior_summary(self):
        """The discrepancy and noise prior in the user's units, with the fit.

        The prior of module 2 (``discrepancy_prior``) is stated in the
        field data's terms; this table says what it means in the user's
        units. Rows: ``length_scale[<input>]`` per design variable (the
        distance over which the discrepancy's correlation falls to
        ``exp(-1/2)``, ``1 / sqrt(2 roughness)`` of the Gauss kernel in the
        input's units; NaN for another kernel),
        ``sd[<response>]`` (the discrepancy's sd) and ``noise_sd[<response>]``
        per response. Columns: ``prior_2.5%`` and ``prior_97.5%`` (with
        ``discrepancy_uncertainty="plug-in"``: the ends of its range),
        ``fitted`` (module 2's mode, as ``discrepancy_kernel_``,
        ``discrepancy_sigma2_`` and ``noise_``) and, for scale,
        ``field_spread``: the range of the field inputs, the sd of the
        field responses; ``prior_unit``: the unit the prior is stated in
        (the sd of the distinct field inputs; the spread of the model's
        response over them and the prior of theta). Read more in the User
        Guide ("What the discrepancy prior means in your units").

        Returns
        -------
        pandas.DataFrame or numpy structured array
            Indexed by ``quantity``.
        """
        check_is_fitted(self, "theta_mean_")
        X = np.asarray(self.X_obs_, dtype=float)
        Y = np.asarray(self.y_obs_, dtype=float).reshape(len(X), -1)
        d, q = X.shape[1], Y.shape[1]
        units = self.discrepancy_prior_units_
        lengths, sds, noise = self._prior_quantiles(d, q, units)
        kernel = self.discrepancy_kernel_
        fitted_length = (
            self.X_scale_ / np.sqrt(2.0 * np.asarray(kernel.roughness, float))
            if isinstance(kernel, Gauss)
            else np.full(d, np.nan)
        )
        inputs = self._data_names("feature_names_in_", "x", d)
        responses = self._data_names("response_names_", "y", q)
        rows = [f"length_scale[{n}]" for n in inputs]
        rows += [f"sd[{n}]" for n in responses] + [f"noise_sd[{n}]" for n in responses]
        spread_y = np.nanstd(Y, axis=0)
        unit_x = self.X_scale_ / np.asarray(units.input_ratio)
        unit_y = self.y_scale_ * np.asarray(units.response_ratio)
        columns = np.vstack(
            [
                np.column_stack(
                    [lengths, np.broadcast_to(fitted_length, d), np.ptp(X, 0), unit_x]
                ),
                np.column_stack(
                    [sds, np.sqrt(np.diag(self.discrepancy_sigma2_)), spread_y, unit_y]
                ),
                np.column_stack([noise, np.sqrt(self.noise_), spread_y, unit_y]),
            ]
        )
        return table("quantity", rows, dict(zip(PRIOR_COLUMNS, columns.T, strict=True)))

    def _prior_quantiles(self, d, q, units):
        """The prior's 2.5 % and 97.5 % points (plug-in: its range) in user
        units: length scales (d, 2), discrepancy sds (q, 2), noise sds (q, 2)."""
        if self.discrepancy_uncertainty == "propagate":
            prior = Hyperprior.from_spec(self.discrepancy_prior).in_units(units)
            bounds = prior.roughness_bounds(d)
            roughness = (
                np.full((d, 2), np.nan)
                if bounds is None
                else np.column_stack(
                    [_log_uniform_quantiles(b)[::-1] for b in np.transpose(bounds)]
                ).T
            )
            sd = stats.halfnorm.ppf([[0.025, 0.975]]) * prior.scales(q)[:, None]
            noise = np.sqrt(
                np.vstack([_log_uniform_quantiles(b) for b in prior.noise_bounds(q)])
            )
        else:
            ranges = check_discrepancy_ranges(self.discrepancy_prior, d, q)
            rough = ranges["roughness"]
            roughness = (
                np.full((d, 2), np.nan)
                if rough is None
                else np.column_stack(
                    np.broadcast_arrays(*(units.roughness(b, 2) for b in rough[::-1]))
                )
            )
            var = ranges["variance"]
            sd = (
                np.full((q, 2), np.nan)
                if var is None
                else np.sqrt(
                    np.column_stack(
                        np.broadcast_arrays(*(units.response(v, 2) for v in var))
                    )
                )
            )
            noise = np.full((q, 2), np.nan)
        lengths = self.X_scale_[:, None] / np.sqrt(2.0 * np.atleast_2d(roughness))
        return (
            np.broadcast_to(lengths, (d, 2)),
            sd * self.y_scale_[:, None],
            noise * self.y_scale_[:, None],
        )

    def _mcse(self, r):
        """The rows of ``theta_mcse_`` (NaN for a fit from before it)."""
        mcse = getattr(self, "theta_mcse_", None)
        return np.full((4, r), np.nan) if mcse is None else np.asarray(mcse, float)

    def _summary_text(self):
        """One line for logs: each parameter's mean, sd, interval and
        diagnostics (``summary(kind="text")``)."""
        columns = self._posterior_columns()
        parts = []
        for j, name in enumerate(self.parameter_names_):
            text = (
                f"{name} = {columns['mean'][j]:.5g} ± {columns['sd'][j]:.3g} "
                f"[95% {columns['2.5%'][j]:.5g}, {columns['97.5%'][j]:.5g}], "
                f"sd/prior sd {columns['sd_ratio'][j]:.3g}"
            )
            if not math.isnan(columns["mcse_sd"][j]):
                text += (
                    f", Monte Carlo error of mean/sd {columns['mcse_mean'][j]:.2g}"
                    f"/{columns['mcse_sd'][j]:.2g}"
                )
            r_hat, ess = columns["r_hat"][j], columns["ess_bulk"][j]
            if not math.isnan(r_hat):
                text += f", R-hat {r_hat:.3f}, ESS {ess:.0f}"
            elif not math.isnan(ess):  # reweighted draws: no chains
                text += f", ESS {ess:.0f}"
            text += f", identifiability {columns['identifiability'][j]:.3g}"
            parts.append(text)
        method = "MCMC" if hasattr(self, "theta_chains_") else self._rule_name()
        if getattr(self, "estimand_", "physical") == "best_fit":
            method = f"best fit, reality's posterior by {method}"
        return f"ModularBayesCalibrator ({method}): " + "; ".join(parts)

    def _rule_name(self):
        """How a fit without chains integrated theta: on a grid (one
        parameter), at weighted importance nodes (several), or by
        reweighting the last run's draws (an update)."""
        if hasattr(self, "ess_"):  # an update's, with an ESS but no chains
            return "the last MCMC draws reweighted"
        nodes = getattr(self, "theta_nodes_", None)
        several = nodes is not None and np.ndim(nodes) == 2 and nodes.shape[1] > 1
        return "importance nodes" if several else "quadrature"

    def _data_names(self, attribute, prefix, n):
        """Names of the field responses or inputs: recorded ones, else y0, y1..."""
        names = getattr(self, attribute, None)
        if names is None or len(names) != n:
            return [f"{prefix}{k}" for k in range(n)]
        return [str(name) for name in names]

    def _inference_data(self, n_prior_draws=None, random_state=0):
        """The fitted calibrator as an ArviZ object (``to_inference_data``)."""
        arviz = _import_arviz()
        rng = np.random.default_rng(random_state)
        names = list(self.parameter_names_)
        best_fit = getattr(self, "estimand_", "physical") == "best_fit"
        if hasattr(self, "theta_chains_") and not best_fit:
            chains = np.asarray(self.theta_chains_, dtype=float)
            stats = {
                "lp": np.asarray(self.theta_log_posterior_, dtype=float),
                "acceptance_rate": np.broadcast_to(
                    np.asarray(self.acceptance_rate_, dtype=float)[:, None],
                    chains.shape[:2],
                ).copy(),
            }
            attrs = {"sampler": "Metropolis-Hastings (skmba)"}
        else:
            order = rng.permutation(len(self.theta_samples_))
            chains = np.asarray(self.theta_samples_, dtype=float)[order][np.newaxis]
            stats = None
            attrs = {"sampler": "quadrature (skmba)", "note": QUADRATURE_NOTE}
            if self._rule_name() == "importance nodes":
                attrs = {"sampler": "importance nodes (skmba)", "note": NODES_NOTE}
            elif self._rule_name() != "quadrature":
                attrs = {"sampler": "reweighted draws (skmba)", "note": REWEIGHTED_NOTE}
            if best_fit:
                attrs = {"sampler": "best fit (skmba)", "note": BEST_FIT_NOTE}
        mcse = self._mcse(len(names))
        if not np.all(np.isnan(mcse)):
            # ArviZ's attrs hold scalars: one per parameter and summary.
            for row, label in zip(mcse, CALIBRATION_COLUMNS[4:8], strict=True):
                for name, value in zip(names, row, strict=True):
                    attrs[f"{label}_{name}"] = float(value)
            attrs["discrepancy_draws"] = int(self.discrepancy_draws_)
        n_draws = chains.shape[0] * chains.shape[1]
        prior_draws = self.prior_.rvs(
            n_draws if n_prior_draws is None else int(n_prior_draws), random_state=rng
        )
        y = np.asarray(self.y_obs_, dtype=float).reshape(len(self.X_obs_), -1)
        X = np.asarray(self.X_obs_, dtype=float)
        responses = self._data_names("response_names_", "y", y.shape[1])
        inputs = self._data_names("feature_names_in_", "x", X.shape[1])
        groups = {
            "posterior": {name: chains[:, :, j] for j, name in enumerate(names)},
            "sample_stats": stats,
            "prior": {
                name: prior_draws[np.newaxis, :, j] for j, name in enumerate(names)
            },
            "observed_data": {name: y[:, k] for k, name in enumerate(responses)},
            "constant_data": {name: X[:, k] for k, name in enumerate(inputs)},
        }
        # A data variable named like a parameter keeps ArviZ's default dimension.
        dims = {
            name: ["observation"] for name in [*responses, *inputs] if name not in names
        }
        coords = {"observation": np.arange(len(X))}
        groups = {group: data for group, data in groups.items() if data is not None}
        if int(arviz.__version__.split(".")[0]) >= 1:
            result = arviz.from_dict(groups, dims=dims, coords=coords)  # a DataTree
        else:
            result = arviz.from_dict(**groups, dims=dims, coords=coords)
        result["posterior"].attrs.update(inference_library="skmba", **attrs)
        return result
