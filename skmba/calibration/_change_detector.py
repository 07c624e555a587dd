"""ChangeDetector: did the structure change, which parameter, by how much?

Monitoring 2/2 (thesis 7.2.3): a :class:`~skmba.ModularBayesCalibrator`
fitted to the reference state, then each batch of current readings compared
with its prediction of reality (:mod:`skmba.calibration._change_evidence` for
the statistics). The batch's readings are grouped at their distinct inputs
(or bins) by :class:`~skmba.calibration._field_replicates.FieldReadings`; the
reference supplies the joint covariance of reality there (module 4), the
noise and the emulator (module 1), on which a relative change of the
parameters moves the prediction.

Examples
--------
>>> from skmba import ChangeDetector, ModularBayesCalibrator
>>> ChangeDetector(ModularBayesCalibrator(), alpha=0.01).alpha
0.01
"""

from typing import ClassVar

import numpy as np
from scipy import stats
from sklearn.base import BaseEstimator, clone
from sklearn.utils.validation import check_is_fitted, validate_data

from skmba._core.columns import match_columns
from skmba._core.regression import regression_basis
from skmba._core.validation import (
    Callable,
    Options,
    Real,
    check_count,
    validate_parameter_table,
)
from skmba.calibration._change_evidence import change_evidence
from skmba.calibration._field_data import (
    check_same_index,
    checked_field_y,
    pandas_index,
    row_labels,
)
from skmba.calibration._field_replicates import FieldReadings, check_bin_width
from skmba.calibration._summary import table

#: How the discrepancy of the reference enters a batch of the current state.
DISCREPANCY_CHANGES = ("carry", "refit")


class ChangeDetector(BaseEstimator):
    """Detect, locate and size a change of a structure from batches of readings.

    Read more in the :ref:`User Guide <user-guide-change>`.

    ``fit`` calibrates the reference state with ``calibrator`` (modules
    1-4). A batch of current readings is then compared with the reference's
    prediction of reality at the batch's inputs, whose joint covariance
    carries the emulator's, the discrepancy's and theta's uncertainty: under
    "no change" the batch's means are Gaussian around it, and a relative
    change ``Delta`` of the parameters (``theta = theta_0 (1 + Delta)``,
    ``theta_0`` the reference posterior median) moves them along the
    emulator. :meth:`predict` raises an alarm when the score test of
    ``Delta = 0`` rejects at level ``alpha``; :meth:`report` gives the
    posterior of each relative change and the evidence for it.

    Parameters
    ----------
    calibrator : ModularBayesCalibrator
        Its parameters (prior, kernels, module 2 and 3 settings) calibrate
        the reference. If it is fitted, ``fit`` reuses its simulations
        (the simulator is not run again) unless others are passed.
    alpha : float in (0, 1), default=0.05
        The false-alarm rate of :meth:`predict`: the probability of an
        alarm at a batch of the unchanged structure.
    threshold : float, default=0.01
        The relative change that matters to the user (0.01: 1 %);
        :meth:`report` gives the probability that each parameter's change
        exceeds it in size.
    change_scale : float, default=0.1
        Prior sd of each relative change under "changed", in the posterior
        and the Bayes factors (not in the test).
    bin_width : None, float or array-like of shape (d,), default=None
        Group a batch's readings whose inputs fall in one bin, as the
        calibrator's ``bin_width``; None groups equal inputs only (exact).
        A coarser grouping makes a batch's decision cheaper.
    simulator : callable, default=None
        ``simulator(X, theta) -> Y`` as the calibrator's, used to move the
        prediction by a change of the parameters; None uses the
        calibrator's ``simulator`` if it has one, else the reference's
        emulator, whose sensitivities can be off by the emulator's error
        (on the bridge, 60 simulations over the prior: sensitivities 20 %
        too large, the sizes of changes with them; User Guide). Called
        with a few rows per distinct input of a batch and per step.
    discrepancy : {"carry", "refit"}, default="carry"
        ``"carry"``: the reference's discrepancy, as its data determined
        it, holds in the current state (a damage changes the parameters,
        not the model's missing physics). ``"refit"``: the current state
        has a discrepancy of its own, a new draw from the reference's
        discrepancy model (its mean, variance and correlation), which the
        batch alone must tell from a change.

    Only ``calibrator`` acts on ``fit``; the other parameters act on the
    batches, so that ``set_params`` after ``fit`` (another ``alpha``, the
    ``"refit"`` discrepancy) needs no new reference calibration.

    Attributes
    ----------
    calibrator_ : ModularBayesCalibrator
        The reference calibration.
    theta_reference_ : ndarray of shape (r,)
        ``theta_0``, the reference posterior median (per parameter), to
        which the relative changes refer: unlike the mean, it does not
        follow the Monte Carlo draws of a weakly identified parameter's
        heavy tail.
    parameter_names_ : list of str
        The parameters, from the reference.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (d,)
        Only when ``X`` had column names.

    See Also
    --------
    ModularBayesCalibrator : the calibration of the reference state.
    sklearn.covariance.EllipticEnvelope : a data-driven novelty detector.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba import ChangeDetector, ModularBayesCalibrator
    >>> from skmba.datasets import make_bridge_monitoring
    >>> import warnings
    >>> data = make_bridge_monitoring(n_hours=24 * 28, random_state=0)
    >>> calibrator = ModularBayesCalibrator(
    ...     prior=data.prior, discrepancy_uncertainty="plug-in", bin_width=1.0,
    ...     n_samples=500, burn_in=200, random_state=0)
    >>> detector = ChangeDetector(calibrator, bin_width=0.5, simulator=data.simulator)
    >>> with warnings.catch_warnings():  # E is confounded with the discrepancy
    ...     warnings.simplefilter("ignore")
    ...     detector = detector.fit(data.X_obs, data.y_obs, X_sim=data.X_sim,
    ...                             theta_sim=data.theta_sim, y_sim=data.y_sim)
    >>> week = make_bridge_monitoring(n_hours=168, damage_size=0.1,
    ...                               damage_start=0, random_state=1)
    >>> detector.predict(week.X_obs, week.y_obs)  # a 10 % loss of one element
    -1
    >>> detector.report(week.X_obs, week.y_obs)["log10_bf"].idxmax()
    'E'
    """

    _parameter_table: ClassVar[dict] = {
        "calibrator": "no_validation",  # checked in fit
        "alpha": [Real(minimum=0.0, hint="the false-alarm rate, e.g. 0.05")],
        "threshold": [Real(minimum=0.0, hint="a relative change, e.g. 0.01")],
        "change_scale": [Real(minimum=1e-6, hint="a relative change, e.g. 0.1")],
        "bin_width": "no_validation",  # check_bin_width, in fit
        "simulator": [
            Callable(what="a callable simulator(X, theta) -> Y", allow_none=True)
        ],
        "discrepancy": [Options(DISCREPANCY_CHANGES)],
    }

    def __init__(
        self,
        calibrator,
        *,
        alpha=0.05,
        threshold=0.01,
        change_scale=0.1,
        bin_width=None,
        simulator=None,
        discrepancy="carry",
    ):
        self.calibrator = calibrator
        self.alpha = alpha
        self.threshold = threshold
        self.change_scale = change_scale
        self.bin_width = bin_width
        self.simulator = simulator
        self.discrepancy = discrepancy

    def fit(self, X, y, X_sim=None, theta_sim=None, y_sim=None):
        """Calibrate the reference state on its readings ``X``, ``y``.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n, d)
        y : array-like or DataFrame of shape (n,) or (n, q)
            The reference readings (NaN: not taken).
        X_sim, theta_sim, y_sim : array-like, optional
            Simulations, as in :meth:`ModularBayesCalibrator.fit`.

        Returns
        -------
        self
        """
        self._check_params()
        if not (
            hasattr(self.calibrator, "fit")
            and hasattr(self.calibrator, "predict_reality")
        ):
            raise TypeError(
                "calibrator must be a ModularBayesCalibrator, got "
                f"{type(self.calibrator).__name__}."
            )
        reference = clone(self.calibrator)
        sims = (X_sim, theta_sim, y_sim)
        if all(a is None for a in sims) and hasattr(self.calibrator, "theta_mean_"):
            fitted = self.calibrator
            sims = (fitted.X_sim_, fitted.theta_sim_, fitted.y_sim_)
            reference.set_params(simulator=None)
        reference.fit(X, y, X_sim=sims[0], theta_sim=sims[1], y_sim=sims[2])
        # The median: the mean of a parameter the data barely identify
        # (the bridge's k_bearing, sd above its mean) moved with the chains'
        # draws of its tail, and the reading of E's change with it (-0.72 to
        # -1.39 % over random_state 0-5, against -0.84 to -0.90 %).
        theta = np.median(np.asarray(reference.theta_samples_, dtype=float), axis=0)
        if np.any(theta == 0.0):
            raise ValueError(
                "A parameter's reference posterior median is 0, so its relative "
                "change is undefined; shift the parameter (e.g. a stiffness, "
                "not its deviation from a nominal value)."
            )
        self.calibrator_ = reference
        self.theta_reference_ = theta
        self.parameter_names_ = list(reference.parameter_names_)
        self.n_features_in_ = reference.n_features_in_
        if hasattr(reference, "feature_names_in_"):
            self.feature_names_in_ = reference.feature_names_in_
        return self

    def _check_params(self):
        """The parameter table, and ``alpha`` inside (0, 1)."""
        validate_parameter_table(
            self._parameter_table, self.get_params(deep=False), type(self).__name__
        )
        if not 0.0 < self.alpha < 1.0:
            raise ValueError(f"alpha must be in (0, 1), e.g. 0.05; got {self.alpha!r}.")

    def evidence(self, X, y):
        """What the batch ``X``, ``y`` says about a change.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n, d)
            The batch's inputs, with the reference's columns.
        y : array-like or DataFrame of shape (n,) or (n, q)
            Its readings (NaN: not taken), with the reference's responses.

        Returns
        -------
        BatchEvidence
            The score test, the Bayes factors and the posterior of the
            relative changes.

        Raises
        ------
        ValueError
            Other columns than the reference's; no finite reading.
        """
        check_is_fitted(self, "calibrator_")
        self._check_params()
        ref = self.calibrator_
        check_same_index(X, y)
        X = validate_data(ref, X, reset=False).astype(float)
        y = checked_field_y(match_columns(y, ref.response_names_, "y", "the reference"))
        q = len(ref.y_scale_)
        if y.reshape(len(y), -1).shape[1] != q:
            raise ValueError(
                f"y has {y.reshape(len(y), -1).shape[1]} responses, the reference {q}."
            )
        width = check_bin_width(self.bin_width, X.shape[1])
        readings = FieldReadings.from_readings(X, y.reshape(len(y), q), width)
        measured = (readings.counts > 0).ravel()
        if not measured.any():
            raise ValueError(
                "The batch has no finite reading: pass readings of at least one "
                "response (NaN marks a reading not taken)."
            )
        mean, cov = self._reference_moments(readings.X)
        noise = np.asarray(ref.global_model_.predictive_noise) * ref.y_scale_**2
        per_mean = noise[None, :] / np.maximum(readings.counts, 1.0)
        Sigma = cov[np.ix_(measured, measured)] + np.diag(per_mean.ravel()[measured])
        r = (readings.Y - mean).ravel()[measured]
        model = self._shift_model()
        at_zero = model(readings.X, self.theta_reference_).ravel()[measured]

        def eta(delta):
            theta = self.theta_reference_ * (1.0 + delta)
            return model(readings.X, theta).ravel()[measured] - at_zero

        return change_evidence(
            r, Sigma, eta, len(self.theta_reference_), self.change_scale
        )

    def decision_function(self, X, y):
        """``log(p / alpha)`` of the batch: negative where it changed.

        ``p`` is the score test's p-value (:meth:`evidence`); an alarm,
        ``predict == -1``, is a negative value.
        """
        return self.evidence(X, y).log_p_value - np.log(self.alpha)

    def predict(self, X, y):
        """``+1`` if the batch shows no change at level ``alpha``, ``-1`` if it does."""
        return 1 if self.decision_function(X, y) >= 0.0 else -1

    def report(self, X, y):
        """Per parameter, the batch's relative change and the evidence for it.

        Returns
        -------
        pandas.DataFrame or numpy structured array
            Indexed by parameter: ``mean``, ``sd``, ``2.5%``, ``97.5%`` of
            the relative change (posterior, Gaussian), ``p_exceeds`` the
            probability that its size exceeds ``threshold``, and
            ``log10_bf``, the Bayes factor of "this parameter changed"
            against "nothing changed".
        """
        ev = self.evidence(X, y)
        mu, sd, t = ev.change_mean, ev.change_sd, self.threshold
        z = stats.norm.ppf(0.975)
        exceeds = stats.norm.cdf((-t - mu) / sd) + stats.norm.sf((t - mu) / sd)
        columns = {
            "mean": mu,
            "sd": sd,
            "2.5%": mu - z * sd,
            "97.5%": mu + z * sd,
            "p_exceeds": exceeds,
            "log10_bf": ev.single_log10_bayes_factors,
        }
        return table("parameter", np.array(self.parameter_names_), columns)

    def scan(self, X, y, batch_size=168):
        """The detector over consecutive batches of ``batch_size`` rows.

        For a record of readings in time order (e.g. a year of hourly
        readings in weeks, ``batch_size=168``), one row per batch: a control
        chart of the structure. A batch without a finite reading (the logger
        down) has no row.

        Parameters
        ----------
        X, y : array-like or DataFrame
            As in :meth:`evidence`, rows in time order.
        batch_size : int, default=168
            Rows per batch; the last batch may be shorter.

        Returns
        -------
        pandas.DataFrame or numpy structured array
            Indexed by each batch's first row label (``from``; its position
            without pandas): ``n_readings``, ``p_value``, ``changed``
            (``p_value < alpha``), ``log10_bf``, ``residual_p_value``,
            ``misfit_p_value`` (:class:`BatchEvidence`), and per parameter
            ``<name>_mean``, ``<name>_sd``, ``<name>_2.5%`` and
            ``<name>_97.5%`` of its relative change, the columns of
            ``theta_history_``, so that
            :func:`~skmba.plotting.plot_theta_history` draws them.
        """
        check_is_fitted(self, "calibrator_")
        check_count(batch_size, "batch_size")
        check_same_index(X, y)
        labels = row_labels(pandas_index(y), len(y))
        rows, starts = [], []
        for start in range(0, len(labels), batch_size):
            part = slice(start, start + batch_size)
            Yb = checked_field_y(_rows(y, part))
            if not np.isfinite(Yb).any():
                continue
            ev = self.evidence(_rows(X, part), _rows(y, part))
            starts.append(labels[start])
            rows.append((int(np.isfinite(Yb).any(axis=-1).sum()), ev))
        return table("from", np.array(starts), self._scan_columns(rows))

    def _scan_columns(self, rows):
        z = stats.norm.ppf(0.975)
        evs = [ev for _, ev in rows]
        columns = {
            "n_readings": np.array([n for n, _ in rows], dtype=int),
            "p_value": np.array([ev.p_value for ev in evs]),
            "changed": np.array([ev.p_value < self.alpha for ev in evs]),
            "log10_bf": np.array([ev.log10_bayes_factor for ev in evs]),
            "residual_p_value": np.array([ev.residual_p_value for ev in evs]),
            "misfit_p_value": np.array([ev.misfit_p_value for ev in evs]),
        }
        mean = np.array([ev.change_mean for ev in evs]).reshape(len(evs), -1)
        sd = np.array([ev.change_sd for ev in evs]).reshape(len(evs), -1)
        for j, name in enumerate(self.parameter_names_):
            columns[f"{name}_mean"] = mean[:, j]
            columns[f"{name}_sd"] = sd[:, j]
            columns[f"{name}_2.5%"] = mean[:, j] - z * sd[:, j]
            columns[f"{name}_97.5%"] = mean[:, j] + z * sd[:, j]
        return columns

    def _shift_model(self):
        """The model a change moves: the simulator, else the emulator."""
        simulator = self.simulator
        if simulator is None:
            simulator = getattr(self.calibrator_, "simulator", None)
        if simulator is None:
            return self._emulated

        def simulated(X, theta):
            rows = np.repeat(np.asarray(theta, dtype=float)[None, :], len(X), axis=0)
            return np.asarray(simulator(X, rows), dtype=float).reshape(len(X), -1)

        return simulated

    def _emulated(self, X, theta):
        """The emulator's mean ``y_m(X, theta)`` (s, q) in user units."""
        ref = self.calibrator_
        Zx = (X - ref.X_mean_) / ref.X_scale_
        Zt = (np.asarray(theta) - ref.theta_offset_) / ref.theta_scale_
        Z = np.hstack([Zx, np.repeat(Zt[None, :], len(X), axis=0)])
        out = np.asarray(ref.model_gp_.predict(Z)).reshape(len(X), -1)
        return out * ref.y_scale_ + ref.y_mean_

    def _reference_moments(self, X):
        """Reality's mean (s, q) and covariance (s q, s q) at ``X`` under the
        reference (``"refit"``: the model's, plus a new discrepancy)."""
        ref, s = self.calibrator_, len(X)
        q = len(ref.y_scale_)
        names = getattr(ref, "feature_names_in_", None)
        if names is not None:  # the reference was fitted on a table
            X = _named(X, names)
        if self.discrepancy == "carry":
            mean, cov = ref.predict_reality(X, return_cov=True)
            return mean.reshape(s, q), cov.reshape(s * q, s * q)
        mean, cov = ref.predict_model(X, return_cov=True)
        Zx = (np.asarray(X, dtype=float) - ref.X_mean_) / ref.X_scale_
        basis = regression_basis(Zx, ref.discrepancy_regression)
        mean = mean.reshape(s, q) + basis @ ref.discrepancy_beta_
        K = ref.discrepancy_kernel_(Zx)
        disc = np.einsum("ab,kl->akbl", K, ref.discrepancy_sigma2_)
        return mean, cov.reshape(s * q, s * q) + disc.reshape(s * q, s * q)


def _named(X, names):
    """``X`` as a DataFrame with the reference's column names (pandas is
    there: the reference was fitted on a table)."""
    import pandas

    return pandas.DataFrame(X, columns=list(names))


def _rows(A, part):
    """Rows ``part`` (a slice) of an array or a pandas object."""
    return A.iloc[part] if hasattr(A, "iloc") else np.asarray(A)[part]
