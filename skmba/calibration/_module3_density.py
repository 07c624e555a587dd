"""The calibrator's ``log_posterior`` method: module 3's log posterior of
theta in user units, from the
:class:`~skmba.calibration._module3_posterior.LogPosterior` that ``fit``
stored (:class:`PosteriorDensityMixin`, a base of
:class:`~skmba.ModularBayesCalibrator`)."""

import numpy as np
from sklearn.utils.validation import check_is_fitted

from skmba._core.columns import match_columns


class PosteriorDensityMixin:
    """Module 3's log posterior as a method of
    :class:`~skmba.ModularBayesCalibrator`, from the
    :class:`~skmba.calibration._module3_posterior.LogPosterior` its ``fit``
    stored."""

    def log_posterior(self, theta):
        """Module-3 log posterior of ``theta`` (user units), up to a constant.

        ``log p(theta) + log p(Y | theta, D, phi)`` with the regression
        coefficients integrated out (Eq. 4.30); ``-inf`` outside the prior's
        support or where the global covariance cannot be factored.

        Parameters
        ----------
        theta : array-like of shape (r,) or (m, r)
            A DataFrame's columns are matched to ``parameter_names_`` when
            the prior named them (a dict prior), else taken in order.

        Returns
        -------
        float or ndarray of shape (m,)
        """
        check_is_fitted(self, "theta_mean_")
        # A table is matched by name when the prior named the parameters.
        named = getattr(self.prior_, "names", None)
        theta = match_columns(theta, named, "theta", "the parameter names")
        theta = np.asarray(theta, dtype=float)
        single = theta.ndim == 1
        theta = np.atleast_2d(theta)
        if theta.shape[1] != self.prior_.dim:
            raise ValueError(
                f"theta has {theta.shape[1]} values per row; the prior has "
                f"{self.prior_.dim} parameters."
            )
        out = np.array([self._log_posterior(t) for t in theta])
        return float(out[0]) if single else out
