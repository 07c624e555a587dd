"""Building blocks shared by the dataset generators.

One home for the steps that :func:`~skmba.datasets.make_cantilever` and
:func:`~skmba.datasets.make_truss_bridge` have in common: the random
generator, the Latin hypercube and its scaling to the variables' ranges,
the checks of physical constants and of per-response arguments, the
measurement noise at a given signal-to-noise ratio and the returned
:class:`~sklearn.utils.Bunch`.

Examples
--------
>>> from skmba.datasets._design import (
...     as_generator, latin_hypercube, scale_to_bounds)
>>> latin_hypercube(4, 2, as_generator(0)).shape
(4, 2)
>>> scale_to_bounds([[0.0, 0.5], [1.0, 0.25]], [(0.0, 10.0), (20.0, 30.0)])
array([[ 0. , 25. ],
       [10. , 22.5]])
"""

import math

import numpy as np
from scipy.stats import qmc
from sklearn.utils import Bunch, check_random_state


def as_generator(random_state):
    """A numpy Generator from an int, RandomState, Generator or None.

    Examples
    --------
    >>> import numpy as np
    >>> isinstance(as_generator(3), np.random.Generator)
    True
    """
    if isinstance(random_state, np.random.Generator):
        return random_state
    try:
        rs = check_random_state(random_state)
    except ValueError:
        raise ValueError(
            "random_state must be None, an int, a numpy RandomState or a numpy "
            f"Generator; got {random_state!r}."
        ) from None
    return np.random.default_rng(rs.randint(np.iinfo(np.int32).max))


def latin_hypercube(n, d, generator):
    """``n`` Latin-hypercube points in ``[0, 1)^d`` drawn with ``generator``.

    Examples
    --------
    >>> u = latin_hypercube(5, 1, as_generator(1))
    >>> sorted((u[:, 0] * 5).astype(int).tolist())
    [0, 1, 2, 3, 4]
    """
    try:
        sampler = qmc.LatinHypercube(d=d, rng=generator)
    except TypeError:  # SciPy < 1.15
        sampler = qmc.LatinHypercube(d=d, seed=generator)
    return sampler.random(n)


def scale_to_bounds(unit, bounds):
    """Map points of the unit cube to the box ``bounds``, column by column.

    Parameters
    ----------
    unit : array-like of shape (n, d)
        Points in ``[0, 1]^d``.
    bounds : array-like of shape (d, 2)
        ``(low, high)`` of each column.

    Returns
    -------
    ndarray of shape (n, d)
        ``low + unit * (high - low)``.

    Examples
    --------
    >>> scale_to_bounds([[0.5]], [(20.0, 40.0)])
    array([[30.]])
    """
    bounds = np.asarray(bounds, dtype=float)
    return bounds[:, 0] + unit * (bounds[:, 1] - bounds[:, 0])


def to_float(value):
    """``float(value)``, or nan when ``value`` is not a number.

    Examples
    --------
    >>> to_float("2.5"), to_float("steep"), to_float(None)
    (2.5, nan, nan)
    """
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def check_positive(value, name, *, allow_inf=False):
    """``value`` as a positive float, or a ValueError naming ``name``.

    Parameters
    ----------
    value : object
        The number to check.
    name : str
        The argument's name, for the message.
    allow_inf : bool, default=False
        Whether ``inf`` is valid (e.g. an infinitely stiff spring).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        ``value`` is not a number, not positive, or infinite while
        ``allow_inf`` is False.

    Examples
    --------
    >>> check_positive(3, "length")
    3.0
    >>> check_positive(float("inf"), "spring_stiffness", allow_inf=True)
    inf
    >>> check_positive(0.0, "length")
    Traceback (most recent call last):
    ...
    ValueError: length must be a finite positive number, got 0.0.
    """
    number = to_float(value)
    if not number > 0 or (math.isinf(number) and not allow_inf):
        kind = (
            "positive number (inf allowed)" if allow_inf else "finite positive number"
        )
        shown = value if math.isnan(number) else number
        raise ValueError(f"{name} must be a {kind}, got {shown!r}.")
    return number


def per_response(value, name, q, *, nonnegative=False):
    """A scalar or one value per response, as a finite (q,) array.

    Examples
    --------
    >>> per_response(18.0, "snr_db", 2)
    array([18., 18.])
    """
    try:
        value = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        value = np.array(np.nan)
    if value.ndim == 0:
        value = np.full(q, float(value))
    if value.shape != (q,) or not np.all(np.isfinite(value)):
        raise ValueError(
            f"{name} must be a finite scalar or one value per response ({q}); "
            f"got {value!r}."
        )
    if nonnegative and np.any(value < 0.0):
        raise ValueError(f"{name} must be >= 0; got {value!r}.")
    return value


def noise_variance(y_true, *, snr_db=None, noise_std=None):
    """Variance of the measurement noise of each response.

    Parameters
    ----------
    y_true : ndarray of shape (n, q)
        Noise-free observations.
    snr_db : ndarray of shape (q,) or None, default=None
        Signal-to-noise ratio in dB, thesis Eq. (3.34):
        ``SNR = 10 log10(var_signal / var_noise)``, ``var_signal`` being the
        (population) variance of the column of ``y_true``.
    noise_std : ndarray of shape (q,) or None, default=None
        Standard deviation of the noise; used when ``snr_db`` is None.

    Returns
    -------
    ndarray of shape (q,)
        Zeros when both ``snr_db`` and ``noise_std`` are None.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.array([[0.0], [2.0]])  # signal variance 1
    >>> noise_variance(y, snr_db=np.array([10.0]))
    array([0.1])
    >>> noise_variance(y, noise_std=np.array([0.5])), noise_variance(y)
    (array([0.25]), array([0.]))
    """
    if snr_db is not None:
        return np.var(y_true, axis=0) / 10.0 ** (snr_db / 10.0)
    if noise_std is not None:
        return noise_std**2
    return np.zeros(np.shape(y_true)[1])


def add_noise(y_true, variance, generator):
    """``y_true`` plus independent Gaussian noise of the given column variances.

    A standard normal draw of the shape of ``y_true`` is always taken from
    ``generator``, also for zero variance, so that the draws which follow do
    not depend on the noise level.

    Examples
    --------
    >>> import numpy as np
    >>> add_noise(np.ones((2, 1)), np.zeros(1), as_generator(0))
    array([[1.],
           [1.]])
    """
    return y_true + generator.standard_normal(np.shape(y_true)) * np.sqrt(variance)


def calibration_bunch(X_sim, theta_sim, y_sim, X_obs, y_obs, y_obs_true, **fields):
    """The :class:`~sklearn.utils.Bunch` a dataset generator returns.

    The simulations and the observations come first, then ``fields`` in the
    order given (truth, prior, callables, names, ..., ``DESCR``).

    Examples
    --------
    >>> data = calibration_bunch(1, 2, 3, 4, 5, 6, DESCR="toy")
    >>> list(data)
    ['X_sim', 'theta_sim', 'y_sim', 'X_obs', 'y_obs', 'y_obs_true', 'DESCR']
    """
    return Bunch(
        X_sim=X_sim,
        theta_sim=theta_sim,
        y_sim=y_sim,
        X_obs=X_obs,
        y_obs=y_obs,
        y_obs_true=y_obs_true,
        **fields,
    )
