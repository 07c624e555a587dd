"""Field readings repeated at the same inputs, kept as their means and counts.

Monitoring systems log the same temperature many times a year. For a GP with
independent noise, the ``a`` readings ``y_1 .. y_a`` of response ``k`` at one
input have the likelihood of their mean ``ybar`` with noise variance
``lambda_k / a``, times a factor of the noise alone (Binois, Gramacy &
Ludkovski 2018)::

    prod_j N(y_j | f, lambda) = N(ybar | f, lambda / a)
        * (2 pi lambda)^-(a - 1)/2  a^-1/2  exp(-s / (2 lambda))

with ``s`` the sum of squared deviations from the mean; the factor does not
involve ``f``, so it survives the integral over the GP. Modules 2-4 then
factor matrices of the distinct inputs, not of the readings.

- :class:`FieldReadings`: the distinct inputs (or bins), the means, counts and
  sums of squares of the readings, built from the readings in the order of
  first appearance (no repeated input: the readings themselves, bit for bit);
- :class:`ReplicateTerms`: the same in the standardised units of modules 2-4,
  with the noise diagonal of the means and the factor above, the one home of
  that formula (``GlobalModel`` and ``DiscrepancyFit`` call it);
- :func:`noise_covariance`: the noise covariance of the field rows, readings
  or means; :func:`check_bin_width`, the calibrator's ``bin_width``;
- :func:`appended_readings`: a batch of ``partial_fit`` appended to the
  readings so far.

Examples
--------
>>> import numpy as np
>>> X = np.array([[1.0], [2.0], [1.0]])
>>> Y = np.array([[10.0], [20.0], [12.0]])
>>> r = FieldReadings.from_readings(X, Y)
>>> r.X.ravel().tolist(), r.Y.ravel().tolist(), r.counts.ravel().tolist()
([1.0, 2.0], [11.0, 20.0], [2.0, 1.0])
"""

from dataclasses import dataclass

import numpy as np

from skmba._core.linalg import LOG_2PI
from skmba.calibration._field_data import pandas_index


@dataclass(frozen=True)
class ReplicateTerms:
    """Means of repeated readings in module 2-4 units: their noise and factor.

    Parameters
    ----------
    counts : ndarray of shape (n, q)
        Readings behind each mean (0: none, the entry is a gap).
    sum_squares : ndarray of shape (n, q)
        Sum of squared deviations of those readings from their mean (in a
        bin, from their trend), in the units of the means.
    degrees : ndarray of shape (n, q)
        Its degrees of freedom: ``counts - 1`` (in a bin whose trend was
        removed, ``counts - 1 - d``).

    Examples
    --------
    >>> import numpy as np
    >>> counts = np.array([[2.0], [1.0]])
    >>> terms = ReplicateTerms(counts, np.array([[2.0], [0.0]]), counts - 1)
    >>> terms.noise_diagonal(np.array([4.0])).tolist()
    [2.0, 4.0]
    """

    counts: np.ndarray
    sum_squares: np.ndarray
    degrees: np.ndarray

    def noise_diagonal(self, noise):
        """The noise variances of the means, ``vec`` response-slowest (n q,);
        a gap's entry holds the noise of one reading (it is never used)."""
        per_mean = np.asarray(noise, dtype=float)[None, :] / np.maximum(self.counts, 1)
        return per_mean.T.ravel()

    def smallest_noise(self, noise):
        """The smallest noise variance of a measured mean."""
        counts = np.where(self.counts > 0, self.counts, np.nan)
        return float(np.nanmin(np.asarray(noise, dtype=float) / counts))

    def log_factor(self, noise, eval_gradient=False):
        """``sum`` of the log factors of the module docstring at the noise
        variances ``noise`` (q,), and its gradient in ``log noise``."""
        noise = np.asarray(noise, dtype=float)
        extra = np.sum(self.degrees, axis=0)
        ss = np.sum(self.sum_squares, axis=0)
        log_counts = np.sum(np.log(np.maximum(self.counts, 1.0)))
        value = float(
            -0.5 * np.sum(extra * (LOG_2PI + np.log(noise)) + ss / noise)
            - 0.5 * log_counts
        )
        if not eval_gradient:
            return value
        return value, -0.5 * extra + 0.5 * ss / noise


def check_bin_width(bin_width, d):
    """``bin_width`` as an array of shape (d,), or None.

    Raises
    ------
    ValueError, TypeError
        Not None, a positive finite number or one per design variable.
    """
    if bin_width is None:
        return None
    try:
        width = np.asarray(bin_width, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"bin_width must be None, a number or one number per design variable "
            f"(d={d}), got {bin_width!r}."
        ) from None
    if width.ndim > 1 or width.size not in (1, d):
        raise ValueError(
            f"bin_width must be one number or {d} (one per design variable), got "
            f"shape {width.shape}."
        )
    if not np.all(np.isfinite(width) & (width > 0)):
        raise ValueError(
            f"bin_width must be positive and finite (in the units of X, e.g. 0.5 "
            f"degC), got {bin_width!r}; None keeps every distinct input."
        )
    return np.broadcast_to(width, (d,)).copy()


def noise_diagonal(noise, n, replicates=None):
    """The diagonal (n q,) of :func:`noise_covariance`."""
    if replicates is None:
        return np.repeat(np.asarray(noise, dtype=float), n)
    return replicates.noise_diagonal(noise)


def noise_covariance(noise, n, replicates=None):
    """The field data's noise covariance (n q, n q), ``vec`` response-slowest:
    ``noise`` (q,) per reading, divided by the counts of ``replicates`` (a
    :class:`ReplicateTerms`, or None: one reading per row)."""
    return np.diag(noise_diagonal(noise, n, replicates))


@dataclass(frozen=True)
class FieldReadings:
    """The field readings as means at their distinct inputs (or bins).

    Parameters
    ----------
    X : ndarray of shape (n, d)
        The distinct inputs in the order they first appear; with bins, the
        mean input of each bin's readings.
    Y : ndarray of shape (n, q)
        The mean of the measured readings of each response there (NaN: none).
    counts : ndarray of shape (n, q)
        How many readings each mean holds.
    sum_squares : ndarray of shape (n, q)
        Their sum of squared deviations from the mean (in a bin with room
        for it, from their linear trend in the inputs).
    degrees : ndarray of shape (n, q)
        The degrees of freedom of those sums.
    n_readings : int
        The readings (rows) behind the means.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.array([[0.12], [0.31], [0.08]])
    >>> r = FieldReadings.from_readings(X, np.ones((3, 1)), bin_width=0.25)
    >>> r.X.ravel().round(2).tolist(), r.counts.ravel().tolist()
    ([0.1, 0.31], [2.0, 1.0])
    """

    X: np.ndarray
    Y: np.ndarray
    counts: np.ndarray
    sum_squares: np.ndarray
    degrees: np.ndarray
    n_readings: int

    @classmethod
    def from_readings(cls, X, Y, bin_width=None):
        """Group the readings ``Y`` (n, q) by their inputs ``X`` (n, d).

        ``bin_width`` (None, a float or one per input, in the units of
        ``X``): readings whose inputs fall in the same bin ``floor(x / w)``
        are averaged at their mean input, an approximation; None groups
        equal inputs only, the exact identity. In a bin, the readings'
        linear trend in the inputs (the response's slope across the bin) is
        taken out of the sum of squares, which would otherwise count it as
        noise, when the bin has room for it (``d + 2`` readings whose inputs
        span every direction).
        """
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        keys = X if bin_width is None else np.floor(X / bin_width)
        _, first, inverse = np.unique(
            keys, axis=0, return_index=True, return_inverse=True
        )
        # Groups in the order of their first reading, not numpy's sorted one.
        order = np.argsort(first, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        group = rank[inverse.ravel()]
        n_groups = len(first)
        if bin_width is None:
            centres = X[first[order]]
        else:
            sizes = np.bincount(group, minlength=n_groups)
            centres = np.column_stack(
                [np.bincount(group, x, minlength=n_groups) / sizes for x in X.T]
            )
        trend = bin_width is not None
        columns = [_group_moments(X, y, group, centres, trend) for y in Y.T]
        means, counts, ss, degrees = (
            np.column_stack(c) for c in zip(*columns, strict=True)
        )
        return cls(centres, means, counts, ss, degrees, len(X))

    @property
    def repeated(self):
        """Whether some mean holds more than one reading."""
        return bool(np.any(self.counts > 1))

    def terms(self, y_scale):
        """The :class:`ReplicateTerms` in units of ``y / y_scale``, or None
        when no input is repeated (the readings are the means)."""
        if not self.repeated:
            return None
        ss = self.sum_squares / np.asarray(y_scale) ** 2
        return ReplicateTerms(self.counts, ss, self.degrees)


def _group_moments(X, y, group, centres, trend):
    """Per group of ``centres``: the mean of the measured readings of one
    response ``y`` (NaN: not measured), their count, their sum of squares and
    its degrees of freedom; with ``trend`` (bins), the linear trend in the
    inputs ``X`` taken out of the sum and the mean moved to the group's
    centre."""
    measured = np.isfinite(y)
    X, y, group = X[measured], y[measured], group[measured]
    n_groups, d = centres.shape
    counts = np.bincount(group, minlength=n_groups).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.bincount(group, y, minlength=n_groups) / counts
    dy = y - means[group]
    ss = np.bincount(group, dy**2, minlength=n_groups)
    degrees = np.maximum(counts - 1.0, 0.0)
    if not trend:
        return means, counts, ss, degrees
    with np.errstate(invalid="ignore", divide="ignore"):
        x_means = np.column_stack(
            [np.bincount(group, x, minlength=n_groups) / counts for x in X.T]
        )
    dx = X - x_means[group]
    Sxx = np.zeros((n_groups, d, d))
    np.add.at(Sxx, group, dx[:, :, None] * dx[:, None, :])
    Sxy = np.zeros((n_groups, d))
    np.add.at(Sxy, group, dx * dy[:, None])
    # Room for a trend: d + 2 readings whose inputs span every direction.
    scale = np.trace(Sxx, axis1=1, axis2=2)
    spans = np.linalg.eigvalsh(Sxx)[:, 0] > 1e-10 * np.maximum(scale, 1e-300)
    fit = spans & (counts >= d + 2)
    if np.any(fit):
        slope = np.linalg.solve(Sxx[fit], Sxy[fit][:, :, None])[:, :, 0]
        ss[fit] -= np.einsum("gi,gi->g", slope, Sxy[fit])
        ss[fit] = np.maximum(ss[fit], 0.0)
        degrees[fit] -= d
        means[fit] += np.einsum("gi,gi->g", slope, centres[fit] - x_means[fit])
    return means, counts, ss, degrees


def appended_readings(log, X, y):
    """The field readings so far, ``log = (X, y)`` as they were given, with
    a batch of readings ``X``, ``y`` appended (``partial_fit``).

    Tables (pandas) are appended to tables by column name (a batch's columns
    may come in another order), keeping their row labels; arrays to arrays
    by position.

    Raises
    ------
    ValueError
        A batch whose columns differ from the first batch's.

    Examples
    --------
    >>> import numpy as np
    >>> X, y = appended_readings((np.zeros((2, 1)), np.zeros(2)), [[1.0]], [1.0])
    >>> X.shape, y.shape
    ((3, 1), (3,))
    """
    return tuple(
        _appended(name, old, new)
        for name, old, new in (("X", log[0], X), ("y", log[1], y))
    )


def _appended(name, old, new):
    """:func:`appended_readings` of one of ``X`` and ``y``."""
    if pandas_index(old) is not None:
        import pandas  # the readings so far are a pandas object

        if pandas_index(new) is None:
            raise ValueError(
                f"The batch's {name} is not a table but the first batch's was: "
                f"pass a pandas {type(old).__name__} with the same columns."
            )
        if hasattr(old, "columns"):
            new = new if hasattr(new, "columns") else new.to_frame()
            names = [str(c) for c in new.columns]
            wanted = [str(c) for c in old.columns]
            if sorted(names) != sorted(wanted):
                raise ValueError(
                    f"The batch's {name} has columns {names}; the first batch's "
                    f"were {wanted}: pass the same columns in every batch."
                )
            new = new.set_axis(names, axis=1)[wanted].set_axis(old.columns, axis=1)
        return pandas.concat([old, new])
    old, new = np.asarray(old, dtype=float), np.asarray(new, dtype=float)
    if new.ndim != old.ndim or new.shape[1:] != old.shape[1:]:
        raise ValueError(
            f"The batch's {name} has shape {new.shape}; the readings so far have "
            f"shape {old.shape}: pass the same columns in every batch."
        )
    return np.concatenate([old, new])
