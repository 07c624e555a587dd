"""Each field response against its simulations, on both sides.

:func:`check_responses` warns (:class:`~skmba.exceptions.FieldDataWarning`),
naming the response and the likely cause, of logger slips that pass every
check of the field data alone: single readings far outside the simulated
range or a logger's "no reading" code, a stuck sensor, a reversed sign,
other units, and readings that vary far less than the design variables
move the simulations (the ``x`` part of a least-squares plane of the runs
in ``[x, theta]``, :func:`_input_spread`). docs/monitoring_data.rst states
what each check measured on the package's reference problems.
"""

import numpy as np

from skmba._core.warn import warn
from skmba.exceptions import FieldDataWarning

#: Field data whose typical magnitude differs from their simulations' (over
#: the same inputs) by more than this factor, either way, are in other units.
MAGNITUDE_FACTOR = 5.0
#: A field response whose spread (interquartile range) is below this share
#: of what the design variables move its simulations by over the same
#: inputs varies far less than it can.
SPREAD_SHARE = 0.05
#: A reading this many widths of the simulated range beyond it is a single
#: slip or a logger's "no reading" code.
OUTLIER_WIDTHS = 3.0
#: Values that data loggers write for "no reading".
LOGGER_CODES = (-99999.0, -9999.0, -999.0, -32768.0, 32767.0, 9999.0, 99999.0)
#: Simulations within the field inputs' box needed to compare spreads there.
MIN_NEAR_RUNS = 10


def check_responses(X, Y, X_sim, theta_sim, y_sim, names=None, rows=None):
    """Each field response against its simulations, on both sides.

    Warns (:class:`~skmba.exceptions.FieldDataWarning`), naming the response
    and the likely cause, when its finite readings

    * hold single readings more than :data:`OUTLIER_WIDTHS` simulated widths
      beyond the simulated range, or a logger code (:data:`LOGGER_CODES`)
      outside it (named by row: mark them missing with NaN), and, without
      those,
    * are constant (a stuck sensor),
    * have the opposite sign of simulations that have one sign, at their size
      (a sign convention),
    * differ in typical magnitude (median of ``log |y|``) from one-signed
      simulations over the same inputs by more than :data:`MAGNITUDE_FACTOR`
      either way, or, for simulations of both signs, lie farther beyond
      their range than its width (units),
    * spread less than :data:`SPREAD_SHARE` of what the design variables
      move the simulations by over the field inputs (a stuck or slipping
      sensor, or units): the ``x`` part of a least-squares plane of the
      runs in ``[x, theta]``, so that the spread of the simulations over the
      prior of ``theta`` does not count (the readings come from one theta).

    "The same inputs" are the runs whose design variables lie in the box of
    the field inputs (when there are :data:`MIN_NEAR_RUNS` of them; else
    all runs, and no spread test). ``names`` name the responses and ``rows``
    the rows of ``Y`` (default: their positions).

    Examples
    --------
    >>> import warnings
    >>> X_sim = np.linspace(0.0, 1.0, 20)[:, None]
    >>> theta_sim = np.tile([2.0, 3.0], 10)[:, None]
    >>> y_sim = 1.0 + X_sim
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_responses(X_sim[::2], y_sim[::2] / 1000, X_sim, theta_sim, y_sim)
    >>> "units" in str(caught[0].message)
    True
    """
    near = _runs_near(X, X_sim)
    rows = np.arange(len(Y)) if rows is None else np.asarray(rows)
    for j in range(Y.shape[1]):
        finite = np.isfinite(Y[:, j])
        sims = y_sim[:, j][np.isfinite(y_sim[:, j])]
        if not finite.any() or sims.size < 2 or np.ptp(sims) <= 0:
            continue
        label = _response_label(names, j, Y.shape[1])
        far = finite & _far_outside(Y[:, j], sims)
        if 0 < far.sum() <= finite.sum() // 2:
            _warn_single_readings(label, rows[far], Y[far, j], sims)
            finite &= ~far
        obs = Y[finite, j]
        if obs.size >= 3 and np.ptp(obs) == 0:
            warn(
                f"The observations of {label} are all {obs[0]:.6g}: a sensor "
                "stuck at one value? Its readings carry no information; mark "
                "them missing (NaN) or leave the response out.",
                FieldDataWarning,
            )
            continue
        runs = near & np.isfinite(y_sim[:, j])
        local = y_sim[runs, j] if near.sum() >= MIN_NEAR_RUNS else sims
        cause = _scale_or_sign(obs, local, sims)
        if cause is None and near.sum() >= MIN_NEAR_RUNS:
            moved = _input_spread(X[finite], X_sim[runs], theta_sim[runs], local)
            cause = _spread(obs, moved)
        if cause is not None:
            warn(f"The observations of {label} {cause}", FieldDataWarning)


def _runs_near(X, X_sim):
    """The simulation runs whose design variables lie in the box of ``X``."""
    lo, hi = X.min(axis=0), X.max(axis=0)
    if np.any(hi <= lo):  # field inputs that do not vary: no box
        return np.zeros(len(X_sim), dtype=bool)
    return np.all((X_sim >= lo) & (X_sim <= hi), axis=1)


def _far_outside(y, sims):
    """Readings more than :data:`OUTLIER_WIDTHS` simulated widths beyond the
    simulated range, or a logger code anywhere outside it."""
    lo, hi = sims.min(), sims.max()
    width = hi - lo
    with np.errstate(invalid="ignore"):
        far = (y < lo - OUTLIER_WIDTHS * width) | (y > hi + OUTLIER_WIDTHS * width)
        code = np.isin(y, LOGGER_CODES) & ((y < lo) | (y > hi))
    return far | code


def _response_label(names, j, q):
    if names is not None:
        return f"response {names[j]!r} (column {j} of y)"
    return "the response" if q == 1 else f"response {j} (column {j} of y)"


def _warn_single_readings(label, rows, values, sims):
    codes = [v for v in values if v in LOGGER_CODES]
    what = (
        f"a logger's 'no reading' code ({codes[0]:.6g})"
        if codes
        else "slips in single readings"
    )
    shown = ", ".join(
        f"{r}: {v:.6g}" for r, v in zip(rows[:8], values[:8], strict=True)
    )
    warn(
        f"{len(rows)} reading(s) of {label} lie far outside its simulated "
        f"range [{sims.min():.4g}, {sims.max():.4g}] (row: value {shown}"
        f"{' ...' if len(rows) > 8 else ''}): {what}? Mark them missing "
        "(NaN): the noise estimate and every band would otherwise take them "
        "in.",
        FieldDataWarning,
    )


def _scale_or_sign(obs, local, sims):
    """The message of a sign or unit slip of ``obs`` against the simulations
    (``local``: over the same inputs), or None."""
    positive, negative = np.mean(local > 0), np.mean(local < 0)
    if max(positive, negative) >= 0.95:  # simulations of one sign
        sign = 1.0 if positive >= negative else -1.0
        # A reversed sign: most readings of the other sign, and of the size
        # of the simulations (a discrepancy rarely mirrors the model).
        mirrored = abs(np.log(abs(np.median(obs)) / np.median(np.abs(local))))
        if np.mean(sign * obs < 0) >= 0.75 and mirrored < np.log(3.0):
            return (
                f"have the opposite sign of its simulations (median "
                f"{np.median(obs):.4g} against {np.median(local):.4g}): a sign "
                "convention, or a model that predicts the wrong sign here? Check "
                "the sign of y against y_sim or the simulator."
            )
        size = np.abs(obs[obs != 0])
        if size.size == 0:
            return None
        ratio = np.exp(np.median(np.log(size)) - np.median(np.log(np.abs(local))))
        if ratio > MAGNITUDE_FACTOR or ratio < 1.0 / MAGNITUDE_FACTOR:
            return (
                f"are typically {ratio:.3g} times the size of its simulations "
                f"over the same inputs (median {np.median(obs):.4g} against "
                f"{np.median(local):.4g}): other units (m against mm, strain "
                "against microstrain, kN against N)? Check the units of y "
                "against y_sim or the simulator."
            )
        return None
    lo, hi = sims.min(), sims.max()
    median = float(np.median(obs))
    if max(lo - median, median - hi) > hi - lo:
        return (
            f"lie far outside the range of its simulations [{lo:.4g}, "
            f"{hi:.4g}] (median {median:.4g}): other units (mm against m, kN "
            "against N)? Check the units of y against y_sim or the simulator."
        )
    return None


def _input_spread(X, X_runs, theta_runs, y_runs):
    """The interquartile range over the field inputs ``X`` of what the design
    variables move the simulations ``y_runs`` by: the ``x`` part of their
    least-squares plane in ``[x, theta]`` (standardised columns), at ``X``.

    With theta in the plane, the runs' spread over the prior of theta is not
    counted: the readings of one structure come from one theta (measured on
    the bridge year: docs/monitoring_data.rst). None with fewer than two
    runs per coefficient of the plane, whose slopes would be noise.
    """
    Z = np.column_stack([X_runs, theta_runs])
    if len(Z) < 2 * (1 + Z.shape[1]):
        return None
    mean, sd = Z.mean(axis=0), Z.std(axis=0)
    sd[sd == 0] = 1.0
    A = np.column_stack([np.ones(len(Z)), (Z - mean) / sd])
    slopes = np.linalg.lstsq(A, y_runs, rcond=None)[0][1:] / sd
    return _iqr(X @ slopes[: X.shape[1]])


def _iqr(a):
    return np.subtract(*np.percentile(a, [75, 25]))


def _spread(obs, moved):
    """The message of a response that varies far less than the design
    variables move its simulations (``moved``, :func:`_input_spread`; None:
    not known), or None."""
    if moved is None or moved <= 0:
        return None
    q_obs = _iqr(obs)
    if obs.size < 5 or q_obs >= SPREAD_SHARE * moved:
        return None
    return (
        f"spread {q_obs / moved:.2g} times as much as the design variables move "
        "its simulations over the same inputs (interquartile ranges): a sensor "
        "stuck or slipping, or other units? Check the readings and their units "
        "against y_sim."
    )
