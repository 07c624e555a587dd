"""Checks of what the user gives as the prior of the calibration parameters.

:func:`skmba.priors._theta.check_prior` accepts frozen ``scipy.stats``
distributions and objects with ``logpdf`` and ``rvs`` methods; the checks
here recognise those forms, validate a univariate distribution and describe
it in messages, and validate the arguments of the prior methods
(``random_state``, ``coverage``), so that a bad prior fails early with a
message saying what to give instead.

Examples
--------
>>> from scipy.stats import norm, poisson
>>> from skmba.priors._checks import check_univariate, describe_univariate
>>> describe_univariate(norm(50e3, 1e4))
'norm(loc=50000, scale=10000)'
>>> check_univariate(poisson(3), "prior[0]")
Traceback (most recent call last):
...
TypeError: prior[0] is the discrete distribution poisson(mu=3); ...
"""

import numbers
import warnings

import numpy as np
from scipy import stats
from sklearn.utils import check_random_state

#: The forms of prior :func:`skmba.priors._theta.check_prior` accepts, for messages.
PRIOR_FORMS = (
    "a list of frozen continuous scipy.stats distributions, one per "
    "parameter (e.g. [uniform(20e3, 80e3), norm(50e3, 1e4)]), a dict of them "
    "naming the parameters (e.g. {'E': uniform(20e3, 80e3), 'I': norm(2, 0.1)}), "
    "a frozen "
    "scipy.stats.multivariate_normal(mean, cov), or an object with logpdf "
    "and rvs methods"
)

_ENTRY_FORM = (
    "a frozen continuous scipy.stats distribution such as uniform(20e3, 80e3) "
    "or norm(50e3, 1e4)"
)


def is_frozen_univariate(obj):
    """Whether ``obj`` is a frozen ``scipy.stats`` univariate distribution."""
    return isinstance(
        getattr(obj, "dist", None), (stats.rv_continuous, stats.rv_discrete)
    )


def is_multivariate_generator(obj):
    """Whether ``obj`` is an unfrozen multivariate ``scipy.stats`` object.

    The class is private in scipy, so it is recognised by name.
    """
    return any(c.__name__ == "multi_rv_generic" for c in type(obj).__mro__)


def describe_univariate(dist):
    """``norm(loc=0, scale=1)``-style text for a frozen distribution."""
    names = []
    shapes = dist.dist.shapes
    if shapes:
        names = [s.strip() for s in shapes.split(",")]
    names = [*names, "loc", "scale"]
    parts = [f"{name}={value:g}" for name, value in zip(names, dist.args, strict=False)]
    parts += [f"{name}={value:g}" for name, value in dist.kwds.items()]
    return f"{dist.dist.name}({', '.join(parts)})"


def _safe_describe(dist):
    """:func:`describe_univariate`, or ``repr`` when the parameters are odd."""
    try:
        return describe_univariate(dist)
    except (TypeError, ValueError):
        return repr(dist)


def check_univariate(dist, where):
    """Validate one frozen continuous univariate distribution.

    ``where`` names it in messages, e.g. ``"prior"`` or ``"prior[1]"``.
    Returns ``dist``; raises TypeError if it is not a frozen continuous
    ``scipy.stats`` distribution and ValueError if its parameters are not
    finite scalars or give it zero width.
    """
    if dist is None:
        raise TypeError(f"{where} is None; each entry must be {_ENTRY_FORM}.")
    if isinstance(dist, type):
        raise TypeError(
            f"{where} is the class {dist.__name__}, not a distribution; "
            f"each entry must be {_ENTRY_FORM}."
        )
    if isinstance(dist, (stats.rv_continuous, stats.rv_discrete)):
        name = getattr(dist, "name", type(dist).__name__)
        raise TypeError(
            f"{where} is the unfrozen distribution scipy.stats.{name}; freeze "
            f"it with its parameters, e.g. {name}(loc=..., scale=...) (or "
            f"{name}() for the default ones)."
        )
    if is_frozen_univariate(dist) and isinstance(dist.dist, stats.rv_discrete):
        raise TypeError(
            f"{where} is the discrete distribution {_safe_describe(dist)}; "
            "calibration parameters are continuous: use a continuous "
            "distribution such as uniform or norm."
        )
    if not is_frozen_univariate(dist):
        if not callable(getattr(dist, "logpdf", None)):
            raise TypeError(
                f"{where} of type {type(dist).__name__} has no logpdf method; "
                f"each entry must be {_ENTRY_FORM}."
            )
        raise TypeError(
            f"{where} of type {type(dist).__name__} is not a frozen "
            f"scipy.stats univariate distribution; each entry must be "
            f"{_ENTRY_FORM}. For a joint prior of your own, pass a single "
            "object with logpdf and rvs methods instead of a list."
        )
    values = [*dist.args, *dist.kwds.values()]
    for value in values:
        array = as_float_array(
            value, f"{where} has a non-numeric parameter {value!r}; give numbers."
        )
        if array.size != 1:
            raise ValueError(
                f"{where} has a parameter with {array.size} values; it must "
                "describe one parameter: use a list with one distribution per "
                "parameter instead of vector-valued arguments."
            )
        if not np.isfinite(array).all():
            raise ValueError(
                f"{where}, {describe_univariate(dist)}, has non-finite "
                "parameters; give finite loc, scale and shape parameters."
            )
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        q25, q75 = np.asarray(dist.ppf([0.25, 0.75]), dtype=float)
    if not (np.isfinite(q25) and np.isfinite(q75) and q75 > q25):
        raise ValueError(
            f"{where}, {describe_univariate(dist)}, has zero width or invalid "
            "parameters (the scale must be > 0 and shape parameters within "
            "their domain). A parameter known exactly is not calibrated: fix "
            "it as an input instead, or give its prior a positive width."
        )
    return dist


def check_parameter_names(names, n_parameters):
    """Parameter names as a tuple of distinct non-empty strings, or None.

    Examples
    --------
    >>> check_parameter_names(["E", "I"], 2)
    ('E', 'I')
    >>> check_parameter_names(["E", "E"], 2)
    Traceback (most recent call last):
    ...
    ValueError: prior names the parameter 'E' twice; ...
    """
    if names is None:
        return None
    names = tuple(names)
    if len(names) != n_parameters:
        raise ValueError(
            f"prior has {len(names)} name(s) for {n_parameters} distribution(s); "
            "give one name per parameter."
        )
    for name in names:
        if not isinstance(name, str) or not name:
            raise TypeError(
                f"prior's parameter names must be non-empty strings (the keys "
                f"of a dict prior, e.g. {{'E': uniform(20e3, 80e3)}}); got "
                f"{name!r}."
            )
    for name in names:
        if names.count(name) > 1:
            raise ValueError(
                f"prior names the parameter {name!r} twice; give each "
                "parameter its own name."
            )
    return names


def as_float_array(value, message):
    """``value`` as a float ndarray, or a ValueError saying ``message``.

    Examples
    --------
    >>> as_float_array([1, 2], "x must be numbers.")
    array([1., 2.])
    >>> as_float_array("a", "x must be numbers.")
    Traceback (most recent call last):
    ...
    ValueError: x must be numbers.
    """
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(message) from None


def check_rng(random_state):
    """A RandomState or Generator from an int, None, RandomState or Generator."""
    if isinstance(random_state, np.random.Generator):
        return random_state
    if isinstance(random_state, bool):
        raise ValueError(
            "random_state must be an int, None, a numpy RandomState or a "
            f"numpy Generator; got {random_state!r}."
        )
    return check_random_state(random_state)


def check_coverage(coverage):
    """``coverage`` as a float strictly between 0 and 1, or a ValueError."""
    if not (isinstance(coverage, numbers.Real) and 0.0 < coverage < 1.0):
        raise ValueError(
            f"coverage must be a probability strictly between 0 and 1; got "
            f"{coverage!r}."
        )
    return float(coverage)
