"""Random generators and Latin hypercubes shared by the dataset generators.

Examples
--------
>>> from skmba.datasets._design import as_generator, latin_hypercube
>>> latin_hypercube(4, 2, as_generator(0)).shape
(4, 2)
"""

import numpy as np
from scipy.stats import qmc
from sklearn.utils import check_random_state


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
