"""Summaries of fitted estimators: tables, a line for logs, ArviZ export.

The functions here read a fitted estimator's public attributes only, so
that the estimators' ``summary`` and ``to_inference_data`` methods stay
thin:

* :func:`calibration_table` and :func:`calibration_text`: the posterior of
  each calibration parameter of a :class:`~skmba.ModularBayesCalibrator`
  (mean, sd, 95 % interval, prior mean and sd, R-hat, bulk ESS) as a table
  or a one-line text;
* :func:`inference_data`: the calibrator's chains, prior draws and field
  data as an ArviZ ``InferenceData`` (ArviZ 0.x) or ``DataTree`` (ArviZ
  1.x), built with ``arviz.from_dict``;
* :func:`design_table` and :func:`jackknife_mcse`: the ranking of the
  sensor subsets of a :class:`~skmba.PreposteriorDesigner` with the Monte
  Carlo standard error of each score.

Tables are pandas ``DataFrame`` objects when pandas is installed and numpy
structured arrays otherwise (the same columns; the row labels become a
first field).

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._summary import jackknife_mcse
>>> covs = np.array([[[[1.0]], [[3.0]]]])  # 1 subset, 2 replicates, r = 1
>>> jackknife_mcse(covs, lambda stack: np.trace(stack, axis1=1, axis2=2))
array([1.])
"""

import math
import warnings

import numpy as np

#: What to install for :func:`inference_data`.
ARVIZ_EXTRA = 'pip install "skmba[arviz]"'

#: The columns of :func:`calibration_table`, in order.
CALIBRATION_COLUMNS = (
    "mean",
    "sd",
    "2.5%",
    "97.5%",
    "prior_mean",
    "prior_sd",
    "sd_ratio",
    "r_hat",
    "ess_bulk",
    "identifiability",
    "robust_2.5%",
    "robust_97.5%",
)


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


def _table(index_name, index, columns):
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


# ------------------------------------------------------------- calibrator
def _posterior_columns(cal):
    """The columns of :func:`calibration_table` as a dict of (r,) arrays."""
    samples = cal.theta_samples_
    r = samples.shape[1]
    sd = np.sqrt(np.diag(cal.theta_cov_))
    prior_sd = np.sqrt(np.diag(cal.prior_.cov()))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = sd / prior_sd
    nan = np.full(r, np.nan)
    columns = {
        "mean": np.asarray(cal.theta_mean_, dtype=float),
        "sd": sd,
        "2.5%": np.quantile(samples, 0.025, axis=0),
        "97.5%": np.quantile(samples, 0.975, axis=0),
        "prior_mean": cal.prior_.mean(),
        "prior_sd": prior_sd,
        "sd_ratio": ratio,
        "r_hat": np.asarray(getattr(cal, "rhat_", nan), dtype=float),
        "ess_bulk": np.asarray(getattr(cal, "ess_", nan), dtype=float),
        "identifiability": np.asarray(cal.identifiability_, dtype=float),
        "robust_2.5%": cal.theta_robust_interval_[:, 0],
        "robust_97.5%": cal.theta_robust_interval_[:, 1],
    }
    return columns


def calibration_table(cal):
    """The posterior of each calibration parameter, one row per parameter.

    See :meth:`skmba.ModularBayesCalibrator.summary`.

    Parameters
    ----------
    cal : fitted ModularBayesCalibrator

    Returns
    -------
    table : pandas.DataFrame or numpy structured array
    """
    return _table("parameter", cal.parameter_names_, _posterior_columns(cal))


def calibration_text(cal):
    """One line for logs: each parameter's mean, sd, interval and diagnostics.

    See :meth:`skmba.ModularBayesCalibrator.summary`.
    """
    columns = _posterior_columns(cal)
    parts = []
    for j, name in enumerate(cal.parameter_names_):
        text = (
            f"{name} = {columns['mean'][j]:.5g} ± {columns['sd'][j]:.3g} "
            f"[95% {columns['2.5%'][j]:.5g}, {columns['97.5%'][j]:.5g}], "
            f"sd/prior sd {columns['sd_ratio'][j]:.3g}"
        )
        if not math.isnan(columns["r_hat"][j]):
            text += (
                f", R-hat {columns['r_hat'][j]:.3f}, ESS {columns['ess_bulk'][j]:.0f}"
            )
        text += (
            f", identifiability {columns['identifiability'][j]:.3g}, robust 95% "
            f"[{columns['robust_2.5%'][j]:.5g}, {columns['robust_97.5%'][j]:.5g}]"
        )
        parts.append(text)
    method = "MCMC" if hasattr(cal, "theta_chains_") else "quadrature"
    return f"ModularBayesCalibrator ({method}): " + "; ".join(parts)


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


def _data_names(cal, attribute, prefix, n):
    """Names of the field responses or inputs: recorded ones, else y0, y1..."""
    names = getattr(cal, attribute, None)
    if names is None or len(names) != n:
        return [f"{prefix}{k}" for k in range(n)]
    return [str(name) for name in names]


#: The note on the posterior group of a quadrature fit.
QUADRATURE_NOTE = (
    "One-parameter posterior computed by adaptive Gauss-Legendre quadrature; "
    "the draws are theta_samples_ (stratified inverse-CDF draws from it) in "
    "a random order, stored as one pseudo-chain. They are not a Markov "
    "chain: R-hat and ESS do not apply."
)


def inference_data(cal, n_prior_draws=None, random_state=0):
    """A fitted calibrator as an ArviZ object, through ``arviz.from_dict``.

    See :meth:`skmba.ModularBayesCalibrator.to_inference_data`.
    """
    arviz = _import_arviz()
    rng = np.random.default_rng(random_state)
    names = list(cal.parameter_names_)
    if hasattr(cal, "theta_chains_"):
        chains = np.asarray(cal.theta_chains_, dtype=float)
        stats = {
            "lp": np.asarray(cal.theta_log_posterior_, dtype=float),
            "acceptance_rate": np.broadcast_to(
                np.asarray(cal.acceptance_rate_, dtype=float)[:, None],
                chains.shape[:2],
            ).copy(),
        }
        attrs = {"sampler": "Metropolis-Hastings (skmba)"}
    else:
        order = rng.permutation(len(cal.theta_samples_))
        chains = np.asarray(cal.theta_samples_, dtype=float)[order][np.newaxis]
        stats = None
        attrs = {"sampler": "quadrature (skmba)", "note": QUADRATURE_NOTE}
    n_draws = chains.shape[0] * chains.shape[1]
    prior_draws = cal.prior_.rvs(
        n_draws if n_prior_draws is None else int(n_prior_draws), random_state=rng
    )
    y = np.asarray(cal.y_obs_, dtype=float).reshape(len(cal.X_obs_), -1)
    X = np.asarray(cal.X_obs_, dtype=float)
    responses = _data_names(cal, "response_names_", "y", y.shape[1])
    inputs = _data_names(cal, "feature_names_in_", "x", X.shape[1])
    groups = {
        "posterior": {name: chains[:, :, j] for j, name in enumerate(names)},
        "sample_stats": stats,
        "prior": {name: prior_draws[np.newaxis, :, j] for j, name in enumerate(names)},
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


# --------------------------------------------------------------- designer
def jackknife_mcse(covs, score):
    """Jackknife Monte Carlo standard error of each subset's score.

    The score of a subset is ``score(mean_i V_i)``, a norm of the mean of its
    per-replicate posterior covariances ``V_i``. With ``s_(i)`` the score of
    the mean without replicate ``i`` and ``s_(.)`` their mean, the jackknife
    standard error is ``sqrt((n - 1) / n * sum_i (s_(i) - s_(.))**2)``; for
    the (linear) trace criterion it equals the standard error of the mean of
    the per-replicate criteria, ``std(ddof=1) / sqrt(n)``.

    Parameters
    ----------
    covs : ndarray of shape (n_subsets, n_mc, r, r)
        Per-replicate posterior covariances.
    score : callable
        ``score(covs) -> ndarray (m,)`` for a stack of ``m`` covariances
        ``(m, r, r)``, e.g. :func:`~skmba.sensor_design._replicates.criterion_value`
        with the prior's covariance and a criterion bound.

    Returns
    -------
    mcse : ndarray of shape (n_subsets,)
        NaN when there is a single replicate.
    """
    covs = np.asarray(covs, dtype=float)
    n = covs.shape[1]
    if n < 2:
        return np.full(covs.shape[0], np.nan)
    left_out = (covs.sum(axis=1, keepdims=True) - covs) / (n - 1)
    scores = score(left_out.reshape(-1, *covs.shape[2:])).reshape(covs.shape[:2])
    spread = ((scores - scores.mean(axis=1, keepdims=True)) ** 2).sum(axis=1)
    return np.sqrt((n - 1) / n * spread)


def design_table(designer, response_names=None):
    """The scored sensor subsets, best first.

    See :meth:`skmba.PreposteriorDesigner.summary`.
    """
    q = designer.n_responses_
    if response_names is None:
        names = _data_names(designer, "response_names_", "y", q)
    else:
        names = [str(name) for name in response_names]
        if len(names) != q:
            raise ValueError(
                f"response_names has {len(names)} names but the designer scored "
                f"{q} responses; give one name per response."
            )
    order = np.argsort(designer.scores_, kind="stable")
    subsets = [designer.subsets_[i] for i in order]
    columns = {
        "subset": np.array([", ".join(names[k] for k in s) for s in subsets]),
        "n_responses": np.array([len(s) for s in subsets]),
        "score": np.asarray(designer.scores_, dtype=float)[order],
        "mcse": np.asarray(designer.scores_mcse_, dtype=float)[order],
    }
    return _table("rank", np.arange(1, len(order) + 1), columns)
